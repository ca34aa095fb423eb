//! What both training loops share (the Q-learners' in [`crate::train`], PPO's in
//! [`crate::ppo`]): a run's options, its progress and summary, and the [`Monitor`] that
//! seeds the environments, runs the greedy tests, writes the CSV log and the curves and
//! checkpoints. Apart from [`crate::train`], which hands PPO runs to PPO's loop, so that
//! PPO's loop need not import it.

use crate::config::Opponent;
use crate::evaluation::{TestResult, test, vec_env_with};
use crate::nets::Nets;
use crate::plot::CurvePoint;
use crate::resume::RunState;
use crate::selfplay::Pool;
use crate::tensorboard::EventWriter;
use crate::{Config, Error};
use avacraft_engine::{Scenario, VecEnv};
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// What a run needs besides its config.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub scenario: Arc<Scenario>,
    pub seed: u64,
    /// Threads stepping the environments (the results do not depend on it).
    pub threads: usize,
    /// Where the log and checkpoints go (`None`: nowhere).
    pub out: Option<PathBuf>,
}

/// Where a run is, for progress displays.
#[derive(Clone, Debug)]
pub struct Progress {
    pub t_env: u64,
    pub t_max: u64,
    pub episodes: u64,
    pub updates: u64,
    pub epsilon: f64,
    pub loss: f64,
    pub last_test: Option<TestResult>,
}

/// How a run went.
#[derive(Clone, Debug)]
pub struct Summary {
    pub t_env: u64,
    pub episodes: u64,
    pub updates: u64,
    pub last_loss: f64,
    pub tests: Vec<TestResult>,
    /// Wall-clock seconds per phase of the loop (PPO's: act, env, record, update, test),
    /// for profiles; empty where not measured.
    pub phases: Vec<(String, f64)>,
}

const CSV_HEADER: &str = "t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s";

/// What both training loops share: the environments' seeds, counts of won training
/// episodes, greedy tests every `test_interval` steps and at the end, the CSV log, and the
/// checkpoints (the latest, and in `best/` the one with the highest greedy win rate so far).
pub(crate) struct Monitor<'a> {
    cfg: &'a Config,
    opts: &'a RunOptions,
    started: std::time::Instant,
    base: u64,
    csv: Option<(std::fs::File, PathBuf)>,
    /// TensorBoard's event file, beside the CSV log.
    tb: Option<EventWriter>,
    /// The previous test round's step and elapsed seconds (the log's steps per second).
    last_rate: (u64, f64),
    pub tests: Vec<TestResult>,
    pub curve: Vec<CurvePoint>,
    pub test_round: u64,
    last_test_t: u64,
    wins_since: u64,
    eps_since: u64,
    return_since: f64,
    /// Seconds run before a resume.
    elapsed_before: f64,
    /// Episodes already played before a resume: the environments start past them.
    seed_offset: u64,
    /// The offset the resumed run's environments had, which played its kept episodes.
    kept_offset: u64,
    /// Self-play: the learner's snapshots team 2 plays.
    pool: Option<Arc<Pool>>,
    /// Fixed opponents each test round also plays ([`Config::fixed_test_opponents`]).
    fixed: Vec<String>,
    /// Self-play: the pool's oldest snapshot at the previous test round; written snapshots
    /// older than it are no longer needed to resume.
    prune_below: Option<u64>,
}

impl<'a> Monitor<'a> {
    /// A monitor that goes on from `start`: the log is appended to, the test history kept.
    pub fn resuming(cfg: &'a Config, opts: &'a RunOptions, start: Option<&RunState>) -> Result<Monitor<'a>, Error> {
        let csv = match &opts.out {
            Some(dir) => {
                std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
                let path = dir.join("log.csv");
                let f = if let Some(st) = start {
                    // A test round writes its row and picks `best/` before the state it saves:
                    // a run killed in between left a row the resumed run writes again, and a
                    // `best/` from a round the state does not have.
                    truncate_log(&path, st.t_env)?;
                    crate::resume::restore_best(dir, st)?;
                    std::fs::OpenOptions::new().append(true).open(&path).map_err(|source| Error::Io { path: path.clone(), source })?
                } else {
                    let mut f = std::fs::File::create(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
                    let vs: String =
                        cfg.fixed_test_opponents().iter().map(|o| format!(",test_win_rate_vs_{0},test_return_vs_{0}", o.trim())).collect();
                    writeln!(f, "{CSV_HEADER}{vs}").map_err(|source| Error::Io { path: path.clone(), source })?;
                    f
                };
                Some((f, path))
            }
            None => None,
        };
        let tb = match &opts.out {
            Some(dir) => Some(EventWriter::create(dir)?),
            None => None,
        };
        let started = std::time::Instant::now();
        let base = opts.seed.wrapping_mul(1 << 20);
        let pool = match cfg.opponent {
            Opponent::SelfPlay => {
                let shape = crate::evaluation::team_shape(cfg, &opts.scenario)?;
                Some(Arc::new(Pool::new(cfg, shape, &opts.scenario.name, opts.out.as_deref())))
            }
            _ => None,
        };
        let mut m = Monitor {
            cfg,
            opts,
            started,
            base,
            csv,
            tb,
            last_rate: (0, 0.0),
            tests: Vec::new(),
            curve: Vec::new(),
            test_round: 0,
            last_test_t: 0,
            wins_since: 0,
            eps_since: 0,
            return_since: 0.0,
            elapsed_before: 0.0,
            seed_offset: 0,
            kept_offset: 0,
            pool,
            fixed: cfg.fixed_test_opponents(),
            prune_below: None,
        };
        if let Some(st) = start {
            m.tests.clone_from(&st.tests);
            m.curve.clone_from(&st.curve);
            (m.test_round, m.last_test_t, m.elapsed_before) = (st.test_round, st.t_env, st.elapsed_s);
            m.last_rate = (st.t_env, st.elapsed_s);
            m.seed_offset = st.episodes + cfg.envs as u64;
            m.kept_offset = st.seed_offset;
        }
        Ok(m)
    }

    /// A resume that puts the environments back where they were ([`crate::carry`]): they
    /// are seeded as the saved run's were, not past the episodes played.
    pub fn keep_episodes(&mut self) {
        self.seed_offset = self.kept_offset;
    }

    /// How far past the run's base seeds its environments are seeded (kept in its state).
    pub fn seed_offset(&self) -> u64 {
        self.seed_offset
    }

    /// Seconds of training so far (across resumes).
    pub fn elapsed(&self) -> f64 {
        self.elapsed_before + self.started.elapsed().as_secs_f64()
    }

    /// The training environments as [`Monitor::keep_episodes`] seeds them: those that played
    /// a resumed run's kept episodes, to play them again (one thread: they are not stepped).
    pub fn kept_env(&self) -> Result<VecEnv, Error> {
        let seeds: Vec<u64> = (0..self.cfg.envs as u64).map(|i| self.base.wrapping_add(self.kept_offset).wrapping_add(i)).collect();
        vec_env_with(self.cfg, &self.opts.scenario, &seeds, 1, self.pool.as_ref().map(Pool::factory))
    }

    /// The training environments, seeded from the run's seed.
    pub fn env(&self) -> Result<VecEnv, Error> {
        let seeds: Vec<u64> = (0..self.cfg.envs as u64).map(|i| self.base.wrapping_add(self.seed_offset).wrapping_add(i)).collect();
        vec_env_with(self.cfg, &self.opts.scenario, &seeds, self.opts.threads, self.pool.as_ref().map(Pool::factory))
    }

    /// Self-play: fills team 2's pool with the learner as it starts (a resumed run: the
    /// snapshots it had taken up to `updates`) and restarts the environments, whose team 2
    /// drew from the empty pool when they were made. Nothing to do otherwise.
    pub fn start_self_play(&mut self, nets: &Nets, updates: u64, resumed: bool, env: &mut VecEnv) -> Result<(), Error> {
        let Some(pool) = &self.pool else { return Ok(()) };
        if resumed {
            pool.restore(updates)?;
            // The draw's weights as the last test round left them (PFSP).
            if let Some(last) = self.curve.last() {
                pool.reweight(&self.fixed, &last.vs)?;
            }
        }
        if pool.updates().is_empty() {
            pool.maybe_snapshot(nets, updates)?;
        }
        env.reset();
        Ok(())
    }

    /// A training episode ended, `won` or not, with this return.
    pub fn episode_end(&mut self, won: bool, ret: f64) {
        self.eps_since += 1;
        self.wins_since += u64::from(won);
        self.return_since += ret;
    }

    /// Called after every vector step: when a test is due (every `test_interval` steps, and
    /// at `t_max`), plays greedy test episodes with `nets`, logs a CSV row and checkpoints
    /// through `save(dir)`; returns whether it did.
    pub fn after_step(
        &mut self,
        t_env: u64,
        counts: (u64, u64),
        eps: f64,
        last: &crate::UpdateStats,
        nets: &Nets,
        save: &mut dyn FnMut(&std::path::Path) -> Result<(), Error>,
    ) -> Result<bool, Error> {
        let (episodes, updates) = counts;
        let cfg = self.cfg;
        if let Some(pool) = &self.pool {
            pool.maybe_snapshot(nets, updates)?;
        }
        if t_env - self.last_test_t < cfg.test_interval && t_env < cfg.t_max {
            return Ok(false);
        }
        self.last_test_t = t_env;
        let n = cfg.test_nepisode.max(1) as u64;
        let test_seeds: Vec<u64> = (0..n).map(|i| self.base.wrapping_add(1 << 19).wrapping_add(self.test_round * n + i)).collect();
        self.test_round += 1;
        let mut r = test(nets, cfg, &self.opts.scenario, &test_seeds, self.opts.threads)?;
        r.t_env = t_env;
        self.tests.push(r);
        let mut vs = Vec::with_capacity(self.fixed.len());
        let mut vs_return = Vec::with_capacity(self.fixed.len());
        for o in &self.fixed {
            let opponent =
                Opponent::parse(o).map_err(|e| crate::config::bad("test_opponents", format!("{o:?}"), &e.to_string(), "\"focus-fire\""))?;
            let fixed = Config { opponent, ..cfg.clone() };
            let t = test(nets, &fixed, &self.opts.scenario, &test_seeds, self.opts.threads)?;
            vs.push(t.win_rate);
            vs_return.push(t.mean_return);
        }
        if let Some(pool) = &self.pool {
            // The previous round's checkpoint is superseded by this one: what only it needed goes.
            if let Some(below) = self.prune_below {
                pool.prune_files(below)?;
            }
            self.prune_below = pool.updates().first().copied();
            pool.reweight(&self.fixed, &vs)?;
        }
        let elapsed = self.elapsed();
        if let Some((f, path)) = self.csv.as_mut() {
            let train_wr = if self.eps_since > 0 { self.wins_since as f64 / self.eps_since as f64 } else { f64::NAN };
            let vs: String = vs.iter().zip(&vs_return).map(|(w, r)| format!(",{w:.4},{r:.4}")).collect();
            writeln!(
                f,
                "{t_env},{episodes},{updates},{eps:.4},{:.6},{:.4},{:.4},{train_wr:.4},{:.4},{:.4},{:.1}{vs}",
                last.loss, last.grad_norm, last.q_taken, r.win_rate, r.mean_return, elapsed
            )
            .and_then(|()| f.flush())
            .map_err(|source| Error::Io { path: path.clone(), source })?;
        }
        let train_win_rate = (self.eps_since > 0).then(|| self.wins_since as f64 / self.eps_since as f64);
        if let Some(tb) = self.tb.as_mut() {
            let train_return = if self.eps_since > 0 { self.return_since / self.eps_since as f64 } else { f64::NAN };
            let (t0, e0) = self.last_rate;
            let rate = if elapsed > e0 { (t_env - t0) as f64 / (elapsed - e0) } else { f64::NAN };
            let row = Row { episodes, updates, eps, train_win_rate, train_return, steps_per_s: rate };
            tb.scalars(t_env, &scalars(cfg, &row, last, &r, &self.fixed, &vs, &vs_return))?;
        }
        self.last_rate = (t_env, elapsed);
        self.curve.push(CurvePoint { t_env, test_win_rate: r.win_rate, train_win_rate, test_return: r.mean_return, loss: last.loss, vs });
        (self.wins_since, self.eps_since, self.return_since) = (0, 0, 0.0);
        if let Some(dir) = &self.opts.out {
            let title = figure_title(dir, &cfg.algo, &self.opts.scenario.name, Some(self.opts.seed));
            crate::plot::curves(&dir.join("curves.png"), &title, &self.curve, &self.fixed)?;
            save(dir)?;
            // Greedy win rates swing while the policy explores: keep the best one's weights too.
            // With fixed test opponents (a league), the best is the one whose worst result
            // against them is highest: a policy that beats every script, not one script best.
            if let Some((now, before)) = self.curve.split_last()
                && before.iter().all(|p| best_score(p) <= best_score(now))
            {
                save(&dir.join("best"))?;
            }
        }
        Ok(true)
    }
}

/// What `best/` keeps the highest of: the greedy test win rate, or with fixed test
/// opponents the lowest win rate against them, then (where the lowest ties, as when one
/// script beats every checkpoint) the mean over them: otherwise every round of such a run
/// ties and `best/` is just the latest.
fn best_score(p: &CurvePoint) -> (f64, f64) {
    if p.vs.is_empty() {
        (p.test_win_rate, p.test_win_rate)
    } else {
        (p.vs.iter().copied().fold(f64::INFINITY, f64::min), p.vs.iter().sum::<f64>() / p.vs.len() as f64)
    }
}

/// Keeps the header and the rows of `log.csv` up to step `t_env` (the state a run resumes
/// from); the file is replaced whole, so a kill during this leaves the old one.
fn truncate_log(path: &std::path::Path, t_env: u64) -> Result<(), Error> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let text = std::fs::read_to_string(path).map_err(io)?;
    let mut lines = text.lines();
    let mut kept = String::with_capacity(text.len());
    if let Some(header) = lines.next() {
        kept.push_str(header);
        kept.push('\n');
    }
    let mut dropped = false;
    for line in lines {
        let step = line.split(',').next().and_then(|v| v.parse::<u64>().ok());
        if step.is_some_and(|s| s <= t_env) && !dropped {
            kept.push_str(line);
            kept.push('\n');
        } else {
            dropped = true;
        }
    }
    if kept.len() == text.len() {
        return Ok(());
    }
    crate::aside::write(path, kept)
}

/// A test round's counters, for [`scalars`].
struct Row {
    episodes: u64,
    updates: u64,
    eps: f64,
    train_win_rate: Option<f64>,
    train_return: f64,
    steps_per_s: f64,
}

/// The TensorBoard scalars of a test round, grouped by tag prefix as TensorBoard shows them
/// (`NaN`: not measured this round, left out).
fn scalars(
    cfg: &Config,
    row: &Row,
    last: &crate::UpdateStats,
    r: &TestResult,
    fixed: &[String],
    vs: &[f64],
    vs_return: &[f64],
) -> Vec<(String, f64)> {
    let ppo = last.entropy.is_some() || matches!(cfg.algo.as_str(), "ippo" | "mappo");
    let mut out: Vec<(String, f64)> = vec![
        ("test/win_rate".into(), r.win_rate),
        ("test/return".into(), r.mean_return),
        ("train/win_rate".into(), row.train_win_rate.unwrap_or(f64::NAN)),
        ("train/return".into(), row.train_return),
        ("train/episodes".into(), row.episodes as f64),
        ("train/updates".into(), row.updates as f64),
        ("loss/total".into(), last.loss),
        ("grad_norm/agent".into(), last.grad_norm),
        ("perf/steps_per_s".into(), row.steps_per_s),
    ];
    if ppo {
        out.extend([
            ("loss/policy".into(), last.policy_loss.unwrap_or(f64::NAN)),
            ("loss/value".into(), last.td_abs),
            ("train/entropy".into(), last.entropy.unwrap_or(f64::NAN)),
            ("train/value_mean".into(), last.q_taken),
            ("grad_norm/critic".into(), last.critic_grad_norm.unwrap_or(f64::NAN)),
        ]);
    } else {
        out.extend([("train/epsilon".into(), row.eps), ("loss/td_abs".into(), last.td_abs), ("train/q_taken".into(), last.q_taken)]);
    }
    for ((o, w), ret) in fixed.iter().zip(vs).zip(vs_return) {
        out.push((format!("test/win_rate_vs_{}", o.trim()), *w));
        out.push((format!("test/return_vs_{}", o.trim()), *ret));
    }
    out
}

/// A run's figure's title; `seed` where known (a shipped copy's folder may not say it).
pub(crate) fn figure_title(dir: &std::path::Path, algo: &str, scenario: &str, seed: Option<u64>) -> String {
    match seed {
        Some(seed) => format!("{} on {scenario} (seed {seed})", run_label(dir, algo, seed)),
        None => format!("{algo} on {scenario}"),
    }
}

/// A plan names a run's folder `<run>-s<seed>`: where the run's name is not its algorithm's
/// (a variant such as `mappo-ln`), the figure names both, so variants' figures tell apart.
fn run_label(dir: &std::path::Path, algo: &str, seed: u64) -> String {
    let run = dir.file_name().and_then(|n| n.to_str()).and_then(|n| n.strip_suffix(&format!("-s{seed}")));
    match run {
        Some(run) if run != algo && !run.is_empty() => format!("{run} ({algo})"),
        _ => algo.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::{best_score, truncate_log};
    use crate::plot::CurvePoint;

    #[test]
    fn a_league_keeps_the_checkpoint_whose_worst_script_result_is_best() {
        let p = |test: f64, vs: &[f64]| CurvePoint { test_win_rate: test, vs: vs.to_vec(), ..CurvePoint::default() };
        assert_eq!(best_score(&p(0.7, &[])), (0.7, 0.7));
        // Beating three scripts every time and losing to the fourth is worse than winning
        // half the games against each.
        assert!(best_score(&p(1.0, &[1.0, 1.0, 1.0, 0.0])) < best_score(&p(0.5, &[0.5, 0.6, 0.5, 0.5])));
        // Where one script beats them all, the rest decide: a checkpoint that wins some games
        // against two scripts is not replaced by a later one that wins only against random.
        let some = best_score(&p(0.4, &[0.4, 0.4, 0.0, 1.0]));
        assert!(best_score(&p(0.0, &[0.0, 0.0, 0.0, 1.0])) < some);
        assert!(some < best_score(&p(0.5, &[0.5, 0.4, 0.0, 1.0])));
    }

    #[test]
    fn a_resumed_log_keeps_the_rows_up_to_its_state() {
        let dir = std::env::temp_dir().join(format!("avacraft-log-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("log.csv");
        let rows = "t_env,episodes\n1000,10\n2000,21\n3000,33\n";
        for (t, want) in [
            (2000, "t_env,episodes\n1000,10\n2000,21\n"),
            (3000, rows),
            (0, "t_env,episodes\n"),
            (2500, "t_env,episodes\n1000,10\n2000,21\n"),
        ] {
            std::fs::write(&path, rows).expect("write");
            truncate_log(&path, t).expect("truncate");
            assert_eq!(std::fs::read_to_string(&path).expect("read"), want, "resumed at {t}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_variants_figure_names_the_run_and_its_algorithm() {
        use std::path::Path;
        assert_eq!(super::run_label(Path::new("runs/smac/2m_vs_1z/mappo-ln-s1"), "mappo", 1), "mappo-ln (mappo)");
        assert_eq!(super::run_label(Path::new("runs/smac/3m/mappo-s2"), "mappo", 2), "mappo");
        assert_eq!(super::run_label(Path::new("runs/smac/3m/mappo-ln-s1"), "mappo", 2), "mappo");
        assert_eq!(super::run_label(Path::new("/tmp/out"), "qmix", 1), "qmix");
    }
}
