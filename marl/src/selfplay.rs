//! Self-play (`opponent = "self"`): team 2 plays snapshots of the learner. Every
//! `self_play_every` updates a copy of the agent network joins a pool of the last
//! `self_play_pool` snapshots, and each episode team 2 plays one drawn uniformly from the
//! pool. The draw is seeded by the episode (team 2's agent seed), and the pool changes only
//! between vector steps, in the training loop's thread: a run stays a function of its config
//! and seed, whatever the thread count.
//!
//! With `self_play_scripts` the pool is a small league: in a `self_play_script_share` of the
//! episodes (all of them before the first snapshot) team 2 plays one of those scripted agents
//! instead, so the learner keeps meeting opponents unlike itself: drawn uniformly, or with
//! `self_play_script_draw = "pfsp"` (prioritised fictitious self-play, as AlphaStar's league
//! weights its opponents) weighted towards the scripts the learner's last greedy test round
//! lost to. The weights change only at test rounds, in the training loop's thread, and a
//! resumed run takes them from its last test round: a run stays a function of its config
//! and seed.
//!
//! Snapshots are written to `<run>/selfplay/u<updates>/` as they are taken, so a resumed run
//! finds the pool it had (those taken up to its last checkpoint); at each test round those
//! no checkpoint can need any more are deleted, but the first (the run's start).

use crate::buffer::Shape;
use crate::checkpoint::{MarlAgent, Policy};
use crate::config::ScriptDraw;
use crate::nets::Nets;
use crate::{Config, Error};
use avacraft_engine::{Action, Agent, AgentCtx, GroupObs, Reads};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

/// Snapshots by the update count they were taken at, oldest first.
type Snapshots = Vec<(u64, Arc<Policy>)>;

/// The learner's snapshots team 2 draws from.
#[derive(Debug)]
pub struct Pool {
    snapshots: RwLock<Snapshots>,
    max: usize,
    every: u64,
    cfg: Config,
    shape: Shape,
    scenario: String,
    dir: Option<PathBuf>,
    /// Each of `self_play_scripts`' weight in the draw (all 1 under `uniform`).
    weights: RwLock<Vec<f64>>,
}

/// PFSP's weight of a script the learner won `win_rate` of its test games against: the
/// square of the loss rate, so a script beaten half the time comes up a quarter as often as
/// one never beaten, with a floor that keeps a beaten script in the league.
pub fn pfsp_weight(win_rate: f64) -> f64 {
    let lost = (1.0 - win_rate).clamp(0.0, 1.0);
    lost * lost + 0.05
}

impl Pool {
    pub fn new(cfg: &Config, shape: Shape, scenario: &str, dir: Option<&Path>) -> Pool {
        Pool {
            snapshots: RwLock::new(Vec::new()),
            max: cfg.self_play_pool.max(1),
            every: cfg.self_play_every.max(1),
            cfg: cfg.clone(),
            shape,
            scenario: scenario.to_owned(),
            dir: dir.map(|d| d.join("selfplay")),
            weights: RwLock::new(vec![1.0; cfg.self_play_scripts.len()]),
        }
    }

    /// Under `pfsp`, reweights the league's scripts from a test round's greedy win rates
    /// against the fixed test opponents `tested` (`win_rates` in the same order); a script
    /// not among them keeps weight 1. Nothing to do under `uniform`.
    pub fn reweight(&self, tested: &[String], win_rates: &[f64]) -> Result<(), Error> {
        if self.cfg.self_play_script_draw != ScriptDraw::Pfsp {
            return Ok(());
        }
        let new: Vec<f64> = self
            .cfg
            .self_play_scripts
            .iter()
            .map(|s| tested.iter().position(|t| t.trim() == s.trim()).and_then(|i| win_rates.get(i)).map_or(1.0, |&w| pfsp_weight(w)))
            .collect();
        *self.weights.write().map_err(|_| Error::Checkpoint { message: "the self-play pool's lock was poisoned".into() })? = new;
        Ok(())
    }

    /// The scripts' weights in the draw now, in `self_play_scripts`' order.
    pub fn script_weights(&self) -> Vec<f64> {
        self.weights.read().map(|w| w.clone()).unwrap_or_default()
    }

    fn write(&self) -> Result<std::sync::RwLockWriteGuard<'_, Snapshots>, Error> {
        self.snapshots.write().map_err(|_| Error::Checkpoint { message: "the self-play pool's lock was poisoned".into() })
    }

    fn read(&self) -> Option<std::sync::RwLockReadGuard<'_, Snapshots>> {
        self.snapshots.read().ok()
    }

    /// Snapshots held now, by the update they were taken at.
    pub fn updates(&self) -> Vec<u64> {
        self.read().map(|s| s.iter().map(|(u, _)| *u).collect()).unwrap_or_default()
    }

    /// Takes a snapshot of `nets` at `updates` when one is due (the first, or `every`
    /// updates after the last); the oldest leaves a full pool. Returns whether it did.
    pub fn maybe_snapshot(&self, nets: &Nets, updates: u64) -> Result<bool, Error> {
        let last = self.read().and_then(|s| s.last().map(|(u, _)| *u));
        if last.is_some_and(|l| updates < l + self.every) {
            return Ok(false);
        }
        let policy = Policy::of(nets, &self.cfg, self.shape, &self.scenario)?;
        if let Some(dir) = &self.dir {
            crate::checkpoint::save(&dir.join(format!("u{updates:010}")), &policy.nets, &self.cfg, &self.shape, &self.scenario)?;
        }
        let mut s = self.write()?;
        s.push((updates, Arc::new(policy)));
        let excess = s.len().saturating_sub(self.max);
        s.drain(..excess);
        Ok(true)
    }

    /// The snapshots written to the run's folder, by update count, oldest first (none
    /// without a folder).
    fn written(&self) -> Vec<(u64, PathBuf)> {
        let Some(entries) = self.dir.as_ref().and_then(|d| std::fs::read_dir(d).ok()) else { return Vec::new() };
        let mut found: Vec<(u64, PathBuf)> = entries
            .filter_map(Result::ok)
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                name.strip_prefix('u').and_then(|n| n.parse::<u64>().ok()).map(|u| (u, e.path()))
            })
            .collect();
        found.sort_by_key(|(u, _)| *u);
        found
    }

    /// Deletes the written snapshots a resume can no longer need: those older than
    /// `oldest`, the oldest of the pool at a checkpoint already superseded, but the first
    /// (the run's start, kept to compare against).
    pub fn prune_files(&self, oldest: u64) -> Result<(), Error> {
        for (_, path) in self.written().into_iter().skip(1).filter(|(u, _)| *u < oldest) {
            std::fs::remove_dir_all(&path).map_err(|source| Error::Io { path, source })?;
        }
        Ok(())
    }

    /// A resumed run's pool: the snapshots written up to `updates`, the newest `max`.
    pub fn restore(&self, updates: u64) -> Result<(), Error> {
        let mut found: Vec<(u64, PathBuf)> = self.written().into_iter().filter(|(u, _)| *u <= updates).collect();
        let keep = found.split_off(found.len().saturating_sub(self.max));
        let mut s = self.write()?;
        s.clear();
        for (u, path) in keep {
            s.push((u, Arc::new(Policy::load(&path)?)));
        }
        Ok(())
    }

    /// The snapshot an episode whose team-2 agent seed is `seed` plays: uniform over the pool.
    pub fn draw(&self, seed: u64) -> Option<Arc<Policy>> {
        let s = self.read()?;
        if s.is_empty() {
            return None;
        }
        let i = ChaCha8Rng::seed_from_u64(seed ^ 0x5e1f_0000_0000_0001).random_range(0..s.len());
        Some(Arc::clone(&s[i].1))
    }

    /// Who team 2 is in the episode whose team-2 agent seed is `seed`: one of the league's
    /// scripted agents (by name) in `self_play_script_share` of the episodes and whenever no
    /// snapshot exists yet, else a snapshot ([`Pool::draw`]). `None`: nobody (no snapshot and
    /// no scripts).
    pub fn pick(&self, seed: u64) -> Option<Pick> {
        let scripts = &self.cfg.self_play_scripts;
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x1ea6_0000_0000_0002);
        let empty = self.read().is_none_or(|s| s.is_empty());
        if !scripts.is_empty() && (empty || rng.random_bool(self.cfg.self_play_script_share)) {
            let i = match self.cfg.self_play_script_draw {
                ScriptDraw::Uniform => rng.random_range(0..scripts.len()),
                ScriptDraw::Pfsp => weighted(&self.script_weights(), rng.random::<f64>()),
            };
            return Some(Pick::Script(scripts[i].clone()));
        }
        self.draw(seed).map(Pick::Snapshot)
    }

    /// Team 2's agent factory: each episode's agent plays a snapshot drawn from the pool.
    pub fn factory(self: &Arc<Self>) -> avacraft_engine::OpponentFactory {
        let pool = Arc::clone(self);
        Arc::new(move || Box::new(PoolAgent { pool: Arc::clone(&pool), inner: None }))
    }
}

/// The index `u` (uniform in [0, 1)) falls on when each index takes its weight's share of
/// the unit interval; the last index when the weights are empty or sum to nothing. One
/// uniform number mapped over the cumulative weights, kept as written (not rand's
/// `WeightedIndex`, which draws its number another way): the shipped PFSP runs' opponents
/// are these draws, and a rerun of their config and seed must meet the same ones.
fn weighted(weights: &[f64], u: f64) -> usize {
    let total: f64 = weights.iter().filter(|w| w.is_finite() && **w > 0.0).sum();
    let mut left = u * total;
    for (i, w) in weights.iter().enumerate() {
        let w = if w.is_finite() && *w > 0.0 { *w } else { 0.0 };
        if left < w {
            return i;
        }
        left -= w;
    }
    weights.len().saturating_sub(1)
}

/// Team 2's opponent in one self-play episode ([`Pool::pick`]).
#[derive(Clone, Debug)]
pub enum Pick {
    /// A scripted agent of the league, by name.
    Script(String),
    /// A snapshot of the learner.
    Snapshot(Arc<Policy>),
}

/// Team 2 under self-play: a [`MarlAgent`] on the snapshot drawn for the episode, or one of
/// the league's scripted agents.
struct PoolAgent {
    pool: Arc<Pool>,
    inner: Option<Box<dyn Agent>>,
}

impl Agent for PoolAgent {
    fn name(&self) -> &str {
        "self"
    }
    fn reads(&self) -> Reads {
        Reads { smac: true, text: false }
    }
    fn reset(&mut self, ctx: &AgentCtx) {
        self.inner = match self.pool.pick(ctx.seed) {
            // Names were checked with the config.
            Some(Pick::Script(name)) => avacraft_engine::agent::factory(&name).ok().map(|make| make()),
            Some(Pick::Snapshot(p)) => Some(Box::new(MarlAgent::new(p, "self")) as Box<dyn Agent>),
            None => None,
        };
        if let Some(a) = self.inner.as_mut() {
            a.reset(ctx);
        }
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        self.inner.as_mut().map(|a| a.act(g)).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::{Pick, Pool, pfsp_weight, weighted};
    use crate::Config;
    use crate::buffer::Shape;

    fn league(draw: &str) -> Pool {
        let set = [
            "opponent=\"self\"".to_owned(),
            "self_play_scripts=[\"focus-fire\", \"attack-move\"]".to_owned(),
            "self_play_script_share=1.0".to_owned(),
            format!("self_play_script_draw={draw}"),
        ];
        let cfg = Config::for_algo("mappo", &set).expect("a league config");
        Pool::new(&cfg, Shape { n_agents: 1, obs: 1, state: 1, n_actions: 1, n_enemies: 1 }, "3m", None)
    }

    fn attack_move_share(pool: &Pool) -> f64 {
        let n = 2_000u32;
        let hits = (0..u64::from(n)).filter(|s| matches!(pool.pick(*s), Some(Pick::Script(name)) if name == "attack-move")).count();
        hits as f64 / f64::from(n)
    }

    #[test]
    fn pfsp_draws_the_script_the_learner_lost_to() {
        let tested = ["focus-fire".to_owned(), "attack-move".to_owned(), "kite".to_owned()];
        let pool = league("pfsp");
        // Before any test round: uniform.
        assert!((attack_move_share(&pool) - 0.5).abs() < 0.05);
        // Won every test game against focus-fire, none against attack-move: 1 to 0.05/1.05.
        pool.reweight(&tested, &[1.0, 0.0, 0.5]).expect("reweight");
        assert_eq!(pool.script_weights(), vec![0.05, 1.05]);
        assert!(attack_move_share(&pool) > 0.9, "{}", attack_move_share(&pool));
        // A uniform league ignores test results.
        let uniform = league("uniform");
        let before: Vec<bool> = (0..200).map(|s| matches!(uniform.pick(s), Some(Pick::Script(n)) if n == "attack-move")).collect();
        uniform.reweight(&tested, &[1.0, 0.0, 0.5]).expect("reweight");
        let after: Vec<bool> = (0..200).map(|s| matches!(uniform.pick(s), Some(Pick::Script(n)) if n == "attack-move")).collect();
        assert_eq!(before, after);
    }

    /// A run resumed with `--set` may turn the league's draw to PFSP: the keys a saved config
    /// leaves out at their defaults can still be set.
    #[test]
    fn a_resumed_league_can_turn_to_pfsp() {
        let saved = Config::for_algo("mappo", &[]).expect("mappo");
        let toml = toml::Table::try_from(&saved).expect("serialises");
        assert!(!toml.contains_key("self_play_script_draw") && !toml.contains_key("self_play_script_share"));
        let set = ["self_play_script_draw=\"pfsp\"".to_owned(), "self_play_script_share=0.75".to_owned()];
        let now = saved.overridden(&set).expect("overridden");
        assert_eq!(now.self_play_script_draw, crate::ScriptDraw::Pfsp);
        assert!((now.self_play_script_share - 0.75).abs() < 1e-12);
    }

    #[test]
    fn an_unknown_draw_is_refused_by_name() {
        let err = Config::for_algo("mappo", &["self_play_script_draw=best".to_owned()]).expect_err("refused");
        assert!(err.to_string().contains("best") || err.to_string().contains("self_play_script_draw"), "{err}");
    }

    #[test]
    fn weighted_draws_follow_the_weights() {
        let w = [1.0, 3.0];
        assert_eq!(weighted(&w, 0.0), 0);
        assert_eq!(weighted(&w, 0.24), 0);
        assert_eq!(weighted(&w, 0.26), 1);
        assert_eq!(weighted(&w, 0.99), 1);
        // A zero or broken weight is never drawn.
        assert_eq!(weighted(&[0.0, f64::NAN, 2.0], 0.0), 2);
        assert_eq!(weighted(&[], 0.5), 0);
        let n = 10_000;
        let ones = (0..n).filter(|k| weighted(&w, f64::from(*k) / f64::from(n)) == 1).count();
        assert_eq!(ones, 7_500);
    }

    #[test]
    fn pfsp_favours_the_scripts_the_learner_loses_to() {
        assert!(pfsp_weight(0.0) > pfsp_weight(0.5));
        assert!(pfsp_weight(0.5) > pfsp_weight(1.0));
        assert!(pfsp_weight(1.0) > 0.0, "a beaten script stays in the league");
        assert!((pfsp_weight(0.5) - 0.3).abs() < 1e-12);
    }
}
