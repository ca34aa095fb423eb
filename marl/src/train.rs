//! The training loops: `envs` environments stepped together by the engine's [`VecEnv`] (in
//! parallel, restarting on their own), one batched forward pass of the agent network for
//! all environments and agents per step, greedy test episodes every `test_interval` steps,
//! a CSV log, learning curves (`curves.png`) and checkpoints in the output directory (the latest, and in `best/` the one
//! with the highest greedy win rate so far). The Q-learners' loop is here (finished episodes
//! into the replay buffer, one update per `episodes_per_update` finished episodes); PPO's
//! is in [`crate::ppo`]. In the image modes an [`ObsSource`] draws every environment's
//! frames (and embeds its text) each step, before acting; they go with the episode into the
//! replay buffer and through the encoder again in each batch.
//!
//! Everything that decides the run draws from streams seeded by the run's seed (the vector
//! environment's results depend on its seeds only, not on its threads); the clock is read
//! for the log's `elapsed_s` column only.

use crate::buffer::{Batch, Episode, ReplayBuffer, Shape, act_inputs};
use crate::learner::{Learner, Nets, select_actions};
use crate::observe::{FrameBatch, ObsSource, StepFrames};
use crate::plot::CurvePoint;
use crate::ppo::PpoLearner;
use crate::resume::RunState;
use crate::{Config, Error, policy};
use avacraft_engine::{Scenario, VecBuffers, VecEnv};
use candle_core::{Device, Tensor};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
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

/// One round of greedy test episodes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TestResult {
    pub t_env: u64,
    pub episodes: usize,
    pub win_rate: f64,
    pub mean_return: f64,
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

/// The acting side of a set of rows (environments x agents): GRU hidden states and last
/// actions, reset per environment when its episode restarts. It acts through the fused
/// network ([`crate::kernels::NetLayout`]) on the flat weights it is handed.
struct Actor {
    h: Vec<f32>,
    last: Vec<Option<u32>>,
    agents: Vec<usize>,
    hidden: usize,
}

impl Actor {
    fn new(nets: &Nets, envs: usize, n_agents: usize) -> Actor {
        let rows = envs * n_agents;
        let hidden = nets.agent.hidden;
        Actor { h: vec![0.0; rows * hidden], last: vec![None; rows], agents: (0..rows).map(|r| r % n_agents.max(1)).collect(), hidden }
    }

    /// Actions for every row, epsilon-greedy over the masks (`frames`: the image modes'),
    /// with the agent network's flat weights `theta`.
    #[allow(clippy::too_many_arguments)]
    fn act(
        &mut self,
        theta: &[f32],
        nets: &Nets,
        cfg: &Config,
        shape: &Shape,
        b: &VecBuffers,
        frames: Option<&StepFrames>,
        eps: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Vec<u32>, Error> {
        let rows = self.agents.len();
        let mut x = act_inputs(&b.obs, &self.agents, &self.last, shape, cfg.obs_agent_id, cfg.obs_last_action);
        if nets.encoder.is_some() {
            let width = shape.input(cfg.obs_agent_id, cfg.obs_last_action);
            let t = Tensor::from_vec(x, (rows, width), &Device::Cpu)?;
            x = nets.step_inputs_pixels(t, frames)?.flatten_all()?.to_vec1()?;
        }
        let f = nets.agent.layout().forward(theta, &x, &self.h, None, None, 1, rows, false);
        if nets.agent.is_recurrent() {
            self.h = f.hidden;
        }
        let acts = select_actions(&f.out, &b.avail, shape.n_actions, eps, rng);
        for (l, &a) in self.last.iter_mut().zip(&acts) {
            *l = Some(a);
        }
        Ok(acts)
    }

    /// Clears the rows of the environments whose episode just ended.
    fn reset_envs(&mut self, done: &[bool], n_agents: usize) {
        for (e, &d) in done.iter().enumerate() {
            if d {
                let rows = e * n_agents..(e + 1) * n_agents;
                self.h[rows.start * self.hidden..rows.end * self.hidden].fill(0.0);
                self.last[rows].iter_mut().for_each(|l| *l = None);
            }
        }
    }
}

fn vec_env(cfg: &Config, scenario: &Arc<Scenario>, seeds: &[u64], threads: usize) -> Result<VecEnv, Error> {
    let env = VecEnv::new(Arc::clone(scenario), cfg.env_config(), seeds, threads.clamp(1, seeds.len()))?;
    match opponent_factory(cfg)? {
        Some(make) => {
            env.with_opponent(make).map_err(|e| crate::config::bad("opponent", format!("{:?}", cfg.opponent), &e.to_string(), "\"\""))
        }
        None => Ok(env),
    }
}

/// What makes team 2's agents under `cfg.opponent`: a scripted agent by name, or a trained
/// policy (`marl:DIR`, loaded once and shared); `None` for "".
pub fn opponent_factory(cfg: &Config) -> Result<Option<avacraft_engine::OpponentFactory>, Error> {
    let name = cfg.opponent.trim();
    if name.is_empty() {
        return Ok(None);
    }
    if let Some(dir) = name.strip_prefix("marl:") {
        let policy = Arc::new(crate::Policy::load(std::path::Path::new(dir))?);
        let label = name.to_owned();
        return Ok(Some(Arc::new(move || Box::new(crate::MarlAgent::new(Arc::clone(&policy), label.clone())))));
    }
    match avacraft_engine::agent::factory(name) {
        Ok(make) => Ok(Some(Arc::new(make))),
        Err(_) => Err(crate::config::bad(
            "opponent",
            format!("{name:?}"),
            &format!(
                "a scripted agent ({}) or marl:DIR",
                avacraft_engine::agent::AGENTS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
            ),
            "\"focus-fire\"",
        )),
    }
}

/// The team's sizes in `scenario` under `cfg`.
pub fn shape_of(cfg: &Config, scenario: &Arc<Scenario>) -> Result<Shape, Error> {
    Ok(Shape::of(&vec_env(cfg, scenario, &[0], 1)?))
}

/// Greedy episodes, one per seed, all run together.
pub fn test(nets: &Nets, cfg: &Config, scenario: &Arc<Scenario>, seeds: &[u64], threads: usize) -> Result<TestResult, Error> {
    test_with(nets, cfg, scenario, seeds, threads, ObsSource::new(cfg)?.as_mut())
}

/// [`test`] with the image modes' observation source (`None` in `features` mode).
pub fn test_with(
    nets: &Nets,
    cfg: &Config,
    scenario: &Arc<Scenario>,
    seeds: &[u64],
    threads: usize,
    mut source: Option<&mut ObsSource>,
) -> Result<TestResult, Error> {
    let mut env = vec_env(cfg, scenario, seeds, threads)?;
    let (a, ..) = env.shape();
    let shape = Shape::of(&env);
    let mut actor = Actor::new(nets, seeds.len(), a);
    let theta = nets.agent_params.flat(nets.agent.var_count())?;
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let (mut finished, mut won, mut returns) = (vec![false; seeds.len()], 0usize, vec![0f64; seeds.len()]);
    while finished.iter().any(|f| !f) {
        let frames = source.as_mut().map(|s| s.observe(env.envs())).transpose()?;
        let acts = actor.act(&theta, nets, cfg, &shape, &env.buffers, frames.as_ref(), 0.0, &mut rng)?;
        env.step(&acts.iter().map(|&x| i64::from(x)).collect::<Vec<_>>())?;
        let b = &env.buffers;
        let done: Vec<bool> = b.terminated.iter().zip(&b.truncated).map(|(t, u)| *t || *u).collect();
        for e in 0..seeds.len() {
            if !finished[e] {
                returns[e] += f64::from(b.reward[e]);
                if done[e] {
                    finished[e] = true;
                    won += usize::from(b.info[e].battle_won);
                }
            }
        }
        actor.reset_envs(&done, a);
    }
    let n = seeds.len().max(1) as f64;
    Ok(TestResult { t_env: 0, episodes: seeds.len(), win_rate: won as f64 / n, mean_return: returns.iter().sum::<f64>() / n })
}

const CSV_HEADER: &str = "t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s";

/// What a run trained.
#[derive(Debug)]
pub enum Trained {
    /// IQL, VDN or QMIX.
    Q(Box<Learner>),
    /// IPPO or MAPPO.
    Ppo(Box<PpoLearner>),
}

impl Trained {
    /// The networks that act (what the checkpoint's `agent.safetensors` holds).
    pub fn nets(&self) -> &Nets {
        match self {
            Trained::Q(l) => &l.nets,
            Trained::Ppo(l) => &l.actor,
        }
    }
    pub fn shape(&self) -> Shape {
        match self {
            Trained::Q(l) => l.shape,
            Trained::Ppo(l) => l.shape,
        }
    }
}

/// Trains `cfg.algo` on `opts.scenario` for `cfg.t_max` environment steps; returns what it
/// trained and how the run went. `on_progress` is called after every vector step.
pub fn train(cfg: &Config, opts: &RunOptions, on_progress: &mut dyn FnMut(&Progress)) -> Result<(Trained, Summary), Error> {
    train_from(cfg, opts, None, on_progress)
}

/// [`train`], going on from `start` (see [`crate::resume`]) when given: the checkpoint and
/// state in `opts.out`.
pub fn train_from(
    cfg: &Config,
    opts: &RunOptions,
    start: Option<RunState>,
    on_progress: &mut dyn FnMut(&Progress),
) -> Result<(Trained, Summary), Error> {
    if let Some(st) = &start
        && st.seed != opts.seed
    {
        return Err(Error::Checkpoint { message: format!("resuming a run of seed {} with seed {}", st.seed, opts.seed) });
    }
    if cfg.is_ppo() {
        let (l, s) = crate::ppo::train_from(cfg, opts, start, on_progress)?;
        return Ok((Trained::Ppo(Box::new(l)), s));
    }
    let (l, s) = train_q(cfg, opts, start, on_progress)?;
    Ok((Trained::Q(Box::new(l)), s))
}

/// What both training loops share: the environments' seeds, counts of won training
/// episodes, greedy tests every `test_interval` steps and at the end, the CSV log, and the
/// checkpoints (the latest, and in `best/` the one with the highest greedy win rate so far).
pub(crate) struct Monitor<'a> {
    cfg: &'a Config,
    opts: &'a RunOptions,
    started: std::time::Instant,
    base: u64,
    csv: Option<(std::fs::File, PathBuf)>,
    pub tests: Vec<TestResult>,
    pub curve: Vec<CurvePoint>,
    pub test_round: u64,
    last_test_t: u64,
    wins_since: u64,
    eps_since: u64,
    /// Seconds run before a resume.
    elapsed_before: f64,
    /// Episodes already played before a resume: the environments start past them.
    seed_offset: u64,
}

impl<'a> Monitor<'a> {
    /// A monitor that goes on from `start`: the log is appended to, the test history kept.
    pub fn resuming(cfg: &'a Config, opts: &'a RunOptions, start: Option<&RunState>) -> Result<Monitor<'a>, Error> {
        let csv = match &opts.out {
            Some(dir) => {
                std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
                let path = dir.join("log.csv");
                let f = if start.is_some() {
                    std::fs::OpenOptions::new().append(true).open(&path).map_err(|source| Error::Io { path: path.clone(), source })?
                } else {
                    let mut f = std::fs::File::create(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
                    writeln!(f, "{CSV_HEADER}").map_err(|source| Error::Io { path: path.clone(), source })?;
                    f
                };
                Some((f, path))
            }
            None => None,
        };
        let started = std::time::Instant::now();
        let base = opts.seed.wrapping_mul(1 << 20);
        let mut m = Monitor {
            cfg,
            opts,
            started,
            base,
            csv,
            tests: Vec::new(),
            curve: Vec::new(),
            test_round: 0,
            last_test_t: 0,
            wins_since: 0,
            eps_since: 0,
            elapsed_before: 0.0,
            seed_offset: 0,
        };
        if let Some(st) = start {
            m.tests.clone_from(&st.tests);
            m.curve.clone_from(&st.curve);
            (m.test_round, m.last_test_t, m.elapsed_before) = (st.test_round, st.t_env, st.elapsed_s);
            m.seed_offset = st.episodes + cfg.envs as u64;
        }
        Ok(m)
    }

    /// Seconds of training so far (across resumes).
    pub fn elapsed(&self) -> f64 {
        self.elapsed_before + self.started.elapsed().as_secs_f64()
    }

    /// The training environments, seeded from the run's seed.
    pub fn env(&self) -> Result<VecEnv, Error> {
        let seeds: Vec<u64> = (0..self.cfg.envs as u64).map(|i| self.base.wrapping_add(self.seed_offset).wrapping_add(i)).collect();
        vec_env(self.cfg, &self.opts.scenario, &seeds, self.opts.threads)
    }

    pub fn episode_end(&mut self, won: bool) {
        self.eps_since += 1;
        self.wins_since += u64::from(won);
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
        let elapsed = self.elapsed();
        if let Some((f, path)) = self.csv.as_mut() {
            let train_wr = if self.eps_since > 0 { self.wins_since as f64 / self.eps_since as f64 } else { f64::NAN };
            writeln!(
                f,
                "{t_env},{episodes},{updates},{eps:.4},{:.6},{:.4},{:.4},{train_wr:.4},{:.4},{:.4},{:.1}",
                last.loss, last.grad_norm, last.q_taken, r.win_rate, r.mean_return, elapsed
            )
            .and_then(|()| f.flush())
            .map_err(|source| Error::Io { path: path.clone(), source })?;
        }
        let train_win_rate = (self.eps_since > 0).then(|| self.wins_since as f64 / self.eps_since as f64);
        self.curve.push(CurvePoint { t_env, test_win_rate: r.win_rate, train_win_rate, test_return: r.mean_return, loss: last.loss });
        (self.wins_since, self.eps_since) = (0, 0);
        if let Some(dir) = &self.opts.out {
            let title = format!("{} on {} (seed {})", cfg.algo, self.opts.scenario.name, self.opts.seed);
            crate::plot::curves(&dir.join("curves.png"), &title, &self.curve)?;
            save(dir)?;
            // Greedy win rates swing while the policy explores: keep the best one's weights too.
            if self.tests.iter().all(|t| t.win_rate <= r.win_rate) {
                save(&dir.join("best"))?;
            }
        }
        Ok(true)
    }
}

/// The Q-learners' loop (IQL, VDN, QMIX).
fn train_q(
    cfg: &Config,
    opts: &RunOptions,
    start: Option<RunState>,
    on_progress: &mut dyn FnMut(&Progress),
) -> Result<(Learner, Summary), Error> {
    let e = cfg.envs;
    let mut monitor = Monitor::resuming(cfg, opts, start.as_ref())?;
    let mut env = monitor.env()?;
    let (a, o, s, na) = env.shape();
    let shape = Shape::of(&env);
    let mut learner = Learner::new(cfg, shape, opts.seed)?;
    let mut act_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed_0001);
    let mut sample_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed_0002);
    let mut buffer = ReplayBuffer::new(cfg.buffer_size);
    let mut actor = Actor::new(&learner.nets, e, a);
    let mut source = ObsSource::new(cfg)?;
    let mut running: Vec<Episode> = vec![Episode::default(); e];
    let (mut t_env, mut episodes, mut pending) = (0u64, 0u64, 0u64);
    let mut last = crate::UpdateStats::default();
    if let Some(st) = &start {
        let Some(dir) = &opts.out else {
            return Err(Error::Checkpoint { message: "resuming needs the run's directory".into() });
        };
        crate::resume::restore(dir, &mut learner, st)?;
        let (ap, sp) = st.rng_positions()?;
        act_rng.set_word_pos(ap);
        sample_rng.set_word_pos(sp);
        (t_env, episodes) = (st.t_env, st.episodes);
    }
    while t_env < cfg.t_max {
        let eps = cfg.epsilon(t_env);
        let frames = source.as_mut().map(|s| s.observe(env.envs())).transpose()?;
        let acts = actor.act(&learner.agent_theta()?, &learner.nets, cfg, &shape, &env.buffers, frames.as_ref(), eps, &mut act_rng)?;
        for (i, ep) in running.iter_mut().enumerate() {
            let b = &env.buffers;
            if let Some(f) = &frames {
                ep.frames.push(f, i);
            }
            ep.push_step(
                &b.obs[i * a * o..(i + 1) * a * o],
                &b.state[i * s..(i + 1) * s],
                &b.avail[i * a * na..(i + 1) * a * na],
                &acts[i * a..(i + 1) * a],
            );
        }
        env.step(&acts.iter().map(|&x| i64::from(x)).collect::<Vec<_>>())?;
        t_env += e as u64;
        let b = &env.buffers;
        let done: Vec<bool> = b.terminated.iter().zip(&b.truncated).map(|(t, u)| *t || *u).collect();
        for (i, ep) in running.iter_mut().enumerate() {
            ep.push_outcome(b.reward[i], b.terminated[i]);
            if done[i] {
                let mut finished = std::mem::take(ep);
                let last = (b.truncated[i] && !b.terminated[i]).then(|| {
                    (
                        &b.final_obs[i * a * o..(i + 1) * a * o],
                        &b.final_state[i * s..(i + 1) * s],
                        &b.final_avail[i * a * na..(i + 1) * a * na],
                    )
                });
                finished.close(&shape, last);
                buffer.insert(finished);
                episodes += 1;
                pending += 1;
                monitor.episode_end(b.info[i].battle_won);
            }
        }
        actor.reset_envs(&done, a);
        while pending >= cfg.episodes_per_update {
            pending -= cfg.episodes_per_update;
            if buffer.len() >= cfg.batch_size {
                let sample = buffer.sample(cfg.batch_size, &mut sample_rng);
                let mut batch = Batch::new(&sample, &shape, cfg.obs_agent_id, cfg.obs_last_action)?;
                if source.is_some() {
                    batch.frames = Some(FrameBatch::new(&sample, cfg)?);
                }
                last = learner.train(&batch, episodes)?;
            }
        }
        let nets = &learner.nets;
        let mut save = |dir: &std::path::Path| policy::save(dir, nets, cfg, &shape, &opts.scenario.name);
        let tested = monitor.after_step(t_env, (episodes, learner.updates), eps, &last, nets, &mut save)?;
        if tested && let Some(dir) = &opts.out {
            let rngs = (act_rng.get_word_pos(), sample_rng.get_word_pos());
            RunState::new(
                opts.seed,
                t_env,
                episodes,
                monitor.test_round,
                (learner.updates, learner.last_target_update),
                rngs,
                monitor.elapsed(),
                &monitor.tests,
                &monitor.curve,
            )
            .save(dir, Some(&learner.target))?;
        }
        on_progress(&Progress {
            t_env,
            t_max: cfg.t_max,
            episodes,
            updates: learner.updates,
            epsilon: eps,
            loss: last.loss,
            last_test: monitor.tests.last().copied(),
        });
    }
    let summary = Summary { t_env, episodes, updates: learner.updates, last_loss: last.loss, tests: monitor.tests, phases: Vec::new() };
    Ok((learner, summary))
}
