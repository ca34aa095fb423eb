//! Greedy test rounds and their environments: what training's test rounds, an evaluation and
//! a policy's own `evaluate` play. Their team 2 may itself be a checkpoint (`marl:DIR`) or,
//! under self-play, the policy under test, so this sits above the checkpoints
//! (`crate::checkpoint`), which know nothing of it.

use crate::acting::Actor;
use crate::buffer::Shape;
use crate::checkpoint::{MarlAgent, Policy};
use crate::config::Opponent;
use crate::nets::Nets;
use crate::observe::ObsSource;
use crate::{Config, Error};
use avacraft_engine::{Env, Scenario, Team, VecBuffers, VecEnv};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// One round of greedy test episodes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TestResult {
    pub t_env: u64,
    pub episodes: usize,
    pub win_rate: f64,
    pub mean_return: f64,
}

impl Policy {
    /// Greedy episodes (one per seed) on `scenario`, in any observation mode: frames are
    /// rendered from the environments as in training's test episodes.
    pub fn evaluate(&self, scenario: &Arc<Scenario>, seeds: &[u64], threads: usize) -> Result<TestResult, Error> {
        self.check_scenario(scenario, Team::One)?;
        test(&self.nets, &self.cfg, scenario, seeds, threads)
    }

    /// Plays team 1 of `env` greedily to the episode's end, in any observation mode (see
    /// [`FramesActor`]): how an evaluation plays an image checkpoint, which an engine agent
    /// cannot. Team 2 is `env`'s own opponent. `on_step` sees the environment before each
    /// step and at the end.
    pub fn play_out(self: &Arc<Self>, env: &mut Env, on_step: &mut dyn FnMut(&Env)) -> Result<(), Error> {
        let mut actor = FramesActor::new(Arc::clone(self), env.scenario())?;
        while !env.done() {
            on_step(env);
            actor.act(env)?;
            env.step();
        }
        on_step(env);
        Ok(())
    }
}

/// Team 1's greedy actions, step by step, from what the network reads in any observation
/// mode: before each step the frames (and text) of an image mode are rendered from the
/// environment, as in training's test episodes, and its SMAC features and masks are read.
/// An engine agent is handed units, not the world the renderer draws, so image checkpoints
/// play through this instead (an evaluation's PvE cells, `episode`).
pub struct FramesActor {
    policy: Arc<Policy>,
    source: Option<ObsSource>,
    actor: Actor,
    buffers: VecBuffers,
    rng: ChaCha8Rng,
}

impl std::fmt::Debug for FramesActor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FramesActor")
            .field("scenario", &self.policy.scenario)
            .field("obs", &self.policy.cfg.obs.name())
            .finish_non_exhaustive()
    }
}

impl FramesActor {
    /// Refuses a scenario whose team 1 does not have the sizes the network was trained on.
    pub fn new(policy: Arc<Policy>, scenario: &Scenario) -> Result<FramesActor, Error> {
        policy.check_scenario(scenario, Team::One)?;
        let (n, sh) = (policy.shape.n_agents, policy.shape);
        Ok(FramesActor {
            source: ObsSource::new(&policy.cfg)?,
            actor: Actor::new(&policy.nets, 1, n),
            buffers: VecBuffers { obs: vec![0.0; n * sh.obs], avail: vec![0; n * sh.n_actions], ..VecBuffers::default() },
            rng: ChaCha8Rng::seed_from_u64(0),
            policy,
        })
    }

    /// Forgets the episode's hidden states and last actions (call at each episode's start).
    pub fn reset(&mut self) {
        self.actor.reset_envs(&[true], self.policy.shape.n_agents);
    }

    /// Submits team 1's actions for `env`'s next step.
    pub fn act(&mut self, env: &mut Env) -> Result<(), Error> {
        let acts = self.choose(env)?;
        // Greedy choices are among the available actions, so none is refused.
        let _ = env.submit_indices(Team::One, &acts);
        Ok(())
    }

    /// Team 1's greedy SMAC action indices for `env`'s next step (dead agents' no-op
    /// included), advancing the agents' hidden states: call once per step.
    pub fn choose(&mut self, env: &Env) -> Result<Vec<usize>, Error> {
        let p = &*self.policy;
        let unreadable = |e: avacraft_engine::LearnError| Error::Observation { message: format!("team 1 of {}: {e}", env.scenario().name) };
        env.obs_all(Team::One, &mut self.buffers.obs).map_err(unreadable)?;
        env.avail_all(Team::One, &mut self.buffers.avail).map_err(unreadable)?;
        let frames = self.source.as_mut().map(|s| s.observe(std::slice::from_ref(env))).transpose()?;
        let acts = self.actor.act(&p.theta, &p.nets, &p.cfg, &p.shape, &self.buffers, frames.as_ref(), 0.0, &mut self.rng)?;
        Ok(acts.iter().map(|&a| a as usize).collect())
    }
}

pub(crate) fn vec_env(cfg: &Config, scenario: &Arc<Scenario>, seeds: &[u64], threads: usize) -> Result<VecEnv, Error> {
    vec_env_with(cfg, scenario, seeds, threads, None)
}

/// [`vec_env`], team 2 made by `self_play` under self-play (the learner's snapshot pool's
/// factory, or the policy under test playing itself); otherwise the opponent is the config's.
pub(crate) fn vec_env_with(
    cfg: &Config,
    scenario: &Arc<Scenario>,
    seeds: &[u64],
    threads: usize,
    self_play: Option<avacraft_engine::OpponentFactory>,
) -> Result<VecEnv, Error> {
    let env = VecEnv::new(Arc::clone(scenario), cfg.env_config()?, seeds, threads.clamp(1, seeds.len()))?;
    let bad =
        |e: avacraft_engine::VecEnvError| crate::config::bad("opponent", format!("{:?}", cfg.opponent.to_string()), &e.to_string(), "\"\"");
    match cfg.opponent {
        Opponent::SelfPlay => match self_play {
            Some(make) => env.with_opponent(make).map_err(bad),
            None => Err(Error::Checkpoint { message: "self-play needs the learner's snapshot pool".into() }),
        },
        _ => match opponent_factory(cfg)? {
            Some(make) => env.with_opponent(make).map_err(bad),
            None => Ok(env),
        },
    }
}

/// What makes team 2's agents under `cfg.opponent`: a scripted agent by name, or a trained
/// policy (`marl:DIR`, loaded once and shared); `None` for "" (and for `self`, whose agents
/// come from the training run's pool).
pub fn opponent_factory(cfg: &Config) -> Result<Option<avacraft_engine::OpponentFactory>, Error> {
    match &cfg.opponent {
        Opponent::Idle | Opponent::SelfPlay => Ok(None),
        Opponent::Marl(dir) => {
            let policy = Arc::new(Policy::load(dir)?);
            let label = cfg.opponent.to_string();
            Ok(Some(Arc::new(move || Box::new(MarlAgent::new(Arc::clone(&policy), label.clone())))))
        }
        Opponent::Scripted(name) => {
            let make = avacraft_engine::agent::factory(name)
                .map_err(|e| crate::config::bad("opponent", format!("{name:?}"), &e.to_string(), "\"focus-fire\""))?;
            Ok(Some(Arc::new(make)))
        }
    }
}

/// Team 1's sizes in `scenario` under `cfg`, whoever plays team 2 (self-play's pool is made
/// from them before any environment has an opponent).
pub(crate) fn team_shape(cfg: &Config, scenario: &Arc<Scenario>) -> Result<Shape, Error> {
    Ok(Shape::of(&VecEnv::new(Arc::clone(scenario), cfg.env_config()?, &[0], 1)?))
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
    // Under self-play a test's team 2 is the policy under test itself.
    let itself: Option<avacraft_engine::OpponentFactory> = if cfg.self_play() {
        let policy = Arc::new(Policy::of(nets, cfg, team_shape(cfg, scenario)?, &scenario.name)?);
        Some(Arc::new(move || Box::new(MarlAgent::new(Arc::clone(&policy), "self"))))
    } else {
        None
    };
    let mut env = vec_env_with(cfg, scenario, seeds, threads, itself)?;
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
