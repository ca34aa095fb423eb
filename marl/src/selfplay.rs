//! Self-play (`opponent = "self"`): team 2 plays snapshots of the learner. Every
//! `self_play_every` updates a copy of the agent network joins a pool of the last
//! `self_play_pool` snapshots, and each episode team 2 plays one drawn uniformly from the
//! pool. The draw is seeded by the episode (team 2's agent seed), and the pool changes only
//! between vector steps, in the training loop's thread: a run stays a function of its config
//! and seed, whatever the thread count.
//!
//! With `self_play_scripts` the pool is a small league: in a `self_play_script_share` of the
//! episodes (all of them before the first snapshot) team 2 plays one of those scripted agents
//! instead, drawn uniformly, so the learner keeps meeting opponents unlike itself.
//!
//! Snapshots are written to `<run>/selfplay/u<updates>/` as they are taken, so a resumed run
//! finds the pool it had (those taken up to its last checkpoint); at each test round those
//! no checkpoint can need any more are deleted, but the first (the run's start).

use crate::buffer::Shape;
use crate::checkpoint::{MarlAgent, Policy};
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
        }
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
            return Some(Pick::Script(scripts[rng.random_range(0..scripts.len())].clone()));
        }
        self.draw(seed).map(Pick::Snapshot)
    }

    /// Team 2's agent factory: each episode's agent plays a snapshot drawn from the pool.
    pub fn factory(self: &Arc<Self>) -> avacraft_engine::OpponentFactory {
        let pool = Arc::clone(self);
        Arc::new(move || Box::new(PoolAgent { pool: Arc::clone(&pool), inner: None }))
    }
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
