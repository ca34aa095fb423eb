//! The training loop: `envs` environments stepped together by the engine's [`VecEnv`] (in
//! parallel, restarting on their own), one batched forward pass of the agent network for
//! all environments and agents per step, finished episodes into the replay buffer, one
//! update per `episodes_per_update` finished episodes, greedy test episodes every
//! `test_interval` steps, a CSV log and checkpoints in the output directory (the latest, and in `best/` the one
//! with the highest greedy win rate so far). In the image modes an [`ObsSource`] draws
//! every environment's frames (and embeds its text) each step, before acting; they go with
//! the episode into the replay buffer and through the encoder again in each batch.
//!
//! Everything that decides the run draws from streams seeded by the run's seed (the vector
//! environment's results depend on its seeds only, not on its threads); the clock is read
//! for the log's `elapsed_s` column only.

use crate::buffer::{Batch, Episode, ReplayBuffer, Shape, act_inputs};
use crate::learner::{Learner, Nets, select_actions};
use crate::observe::{FrameBatch, ObsSource, StepFrames};
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
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
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
}

/// The acting side of a set of rows (environments x agents): GRU hidden states and last
/// actions, reset per environment when its episode restarts.
struct Actor {
    h: Tensor,
    last: Vec<Option<u32>>,
    agents: Vec<usize>,
}

impl Actor {
    fn new(nets: &Nets, envs: usize, n_agents: usize) -> Result<Actor, Error> {
        let rows = envs * n_agents;
        Ok(Actor { h: nets.agent.zero_hidden(rows)?, last: vec![None; rows], agents: (0..rows).map(|r| r % n_agents.max(1)).collect() })
    }

    /// Actions for every row, epsilon-greedy over the masks (`frames`: the image modes').
    #[allow(clippy::too_many_arguments)]
    fn act(
        &mut self,
        nets: &Nets,
        cfg: &Config,
        shape: &Shape,
        b: &VecBuffers,
        frames: Option<&StepFrames>,
        eps: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Vec<u32>, Error> {
        let width = shape.input(cfg.obs_agent_id, cfg.obs_last_action);
        let rows = self.agents.len();
        let x = Tensor::from_vec(
            act_inputs(&b.obs, &self.agents, &self.last, shape, cfg.obs_agent_id, cfg.obs_last_action),
            (rows, width),
            &Device::Cpu,
        )?;
        let x = nets.step_inputs(x, frames.map(StepFrames::tensors).transpose()?.as_ref())?;
        let (q, h) = nets.agent.step(&x, &self.h)?;
        // Detached: the acting graph must not grow across steps.
        self.h = h.detach();
        let q: Vec<f32> = q.detach().flatten_all()?.to_vec1()?;
        let acts = select_actions(&q, &b.avail, shape.n_actions, eps, rng);
        for (l, &a) in self.last.iter_mut().zip(&acts) {
            *l = Some(a);
        }
        Ok(acts)
    }

    /// Clears the rows of the environments whose episode just ended.
    fn reset_envs(&mut self, done: &[bool], n_agents: usize) -> Result<(), Error> {
        if !done.iter().any(|&d| d) {
            return Ok(());
        }
        let keep: Vec<f32> = done.iter().flat_map(|&d| std::iter::repeat_n(if d { 0.0 } else { 1.0 }, n_agents)).collect();
        let rows = keep.len();
        self.h = self.h.broadcast_mul(&Tensor::from_vec(keep, (rows, 1), &Device::Cpu)?)?;
        for (e, &d) in done.iter().enumerate() {
            if d {
                self.last[e * n_agents..(e + 1) * n_agents].iter_mut().for_each(|l| *l = None);
            }
        }
        Ok(())
    }
}

fn vec_env(cfg: &Config, scenario: &Arc<Scenario>, seeds: &[u64], threads: usize) -> Result<VecEnv, Error> {
    Ok(VecEnv::new(Arc::clone(scenario), cfg.env_config(), seeds, threads.clamp(1, seeds.len()))?)
}

/// The team's sizes in `scenario` under `cfg`.
pub fn shape_of(cfg: &Config, scenario: &Arc<Scenario>) -> Result<Shape, Error> {
    let (n_agents, obs, state, n_actions) = vec_env(cfg, scenario, &[0], 1)?.shape();
    Ok(Shape { n_agents, obs, state, n_actions })
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
    let shape = {
        let (n_agents, obs, state, n_actions) = env.shape();
        Shape { n_agents, obs, state, n_actions }
    };
    let mut actor = Actor::new(nets, seeds.len(), a)?;
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let (mut finished, mut won, mut returns) = (vec![false; seeds.len()], 0usize, vec![0f64; seeds.len()]);
    while finished.iter().any(|f| !f) {
        let frames = source.as_mut().map(|s| s.observe(env.envs())).transpose()?;
        let acts = actor.act(nets, cfg, &shape, &env.buffers, frames.as_ref(), 0.0, &mut rng)?;
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
        actor.reset_envs(&done, a)?;
    }
    let n = seeds.len().max(1) as f64;
    Ok(TestResult { t_env: 0, episodes: seeds.len(), win_rate: won as f64 / n, mean_return: returns.iter().sum::<f64>() / n })
}

const CSV_HEADER: &str = "t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s";

/// Trains `cfg.algo` on `opts.scenario` for `cfg.t_max` environment steps; returns the
/// learner and how the run went. `on_progress` is called after every vector step.
pub fn train(cfg: &Config, opts: &RunOptions, on_progress: &mut dyn FnMut(&Progress)) -> Result<(Learner, Summary), Error> {
    let started = std::time::Instant::now();
    let e = cfg.envs;
    let base = opts.seed.wrapping_mul(1 << 20);
    let seeds: Vec<u64> = (0..e as u64).map(|i| base.wrapping_add(i)).collect();
    let mut env = vec_env(cfg, &opts.scenario, &seeds, opts.threads)?;
    let (a, o, s, na) = env.shape();
    let shape = Shape { n_agents: a, obs: o, state: s, n_actions: na };
    let mut learner = Learner::new(cfg, shape, opts.seed)?;
    let mut act_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed_0001);
    let mut sample_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed_0002);
    let mut buffer = ReplayBuffer::new(cfg.buffer_size);
    let mut actor = Actor::new(&learner.nets, e, a)?;
    let mut source = ObsSource::new(cfg)?;
    let mut running: Vec<Episode> = vec![Episode::default(); e];
    let mut csv = match &opts.out {
        Some(dir) => {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
            let path = dir.join("log.csv");
            let mut f = std::fs::File::create(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
            writeln!(f, "{CSV_HEADER}").map_err(|source| Error::Io { path: path.clone(), source })?;
            Some((f, path))
        }
        None => None,
    };
    let (mut t_env, mut episodes, mut pending, mut last_test_t) = (0u64, 0u64, 0u64, 0u64);
    let (mut wins_since, mut eps_since) = (0u64, 0u64);
    let mut last = crate::UpdateStats::default();
    let mut tests: Vec<TestResult> = Vec::new();
    let mut test_round = 0u64;
    while t_env < cfg.t_max {
        let eps = cfg.epsilon(t_env);
        let frames = source.as_mut().map(|s| s.observe(env.envs())).transpose()?;
        let acts = actor.act(&learner.nets, cfg, &shape, &env.buffers, frames.as_ref(), eps, &mut act_rng)?;
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
                finished.close(&shape);
                buffer.insert(finished);
                episodes += 1;
                pending += 1;
                eps_since += 1;
                wins_since += u64::from(b.info[i].battle_won);
            }
        }
        actor.reset_envs(&done, a)?;
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
        let finished_run = t_env >= cfg.t_max;
        if t_env - last_test_t >= cfg.test_interval || finished_run {
            last_test_t = t_env;
            let n = cfg.test_nepisode.max(1) as u64;
            let test_seeds: Vec<u64> = (0..n).map(|i| base.wrapping_add(1 << 19).wrapping_add(test_round * n + i)).collect();
            test_round += 1;
            let mut r = test_with(&learner.nets, cfg, &opts.scenario, &test_seeds, opts.threads, source.as_mut())?;
            r.t_env = t_env;
            tests.push(r);
            if let Some((f, path)) = csv.as_mut() {
                let train_wr = if eps_since > 0 { wins_since as f64 / eps_since as f64 } else { f64::NAN };
                writeln!(
                    f,
                    "{t_env},{episodes},{},{eps:.4},{:.6},{:.4},{:.4},{train_wr:.4},{:.4},{:.4},{:.1}",
                    learner.updates,
                    last.loss,
                    last.grad_norm,
                    last.q_taken,
                    r.win_rate,
                    r.mean_return,
                    started.elapsed().as_secs_f64()
                )
                .and_then(|()| f.flush())
                .map_err(|source| Error::Io { path: path.clone(), source })?;
            }
            (wins_since, eps_since) = (0, 0);
            if let Some(dir) = &opts.out {
                policy::save(dir, &learner.nets, cfg, &shape, &opts.scenario.name)?;
                // Greedy win rates swing while epsilon is high: keep the best one's weights too.
                if tests.iter().all(|t| t.win_rate <= r.win_rate) {
                    policy::save(&dir.join("best"), &learner.nets, cfg, &shape, &opts.scenario.name)?;
                }
            }
        }
        on_progress(&Progress {
            t_env,
            t_max: cfg.t_max,
            episodes,
            updates: learner.updates,
            epsilon: eps,
            loss: last.loss,
            last_test: tests.last().copied(),
        });
    }
    let summary = Summary { t_env, episodes, updates: learner.updates, last_loss: last.loss, tests };
    Ok((learner, summary))
}
