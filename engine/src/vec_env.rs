//! Many environments stepped together across threads, for learners' throughput. Results land
//! in contiguous arrays (environment-major), finished episodes restart on their own, and
//! the outcome depends on the seed list only, never on the number of threads: each
//! environment is stepped by exactly one thread and draws from its own seeded streams.

use crate::agent::{Agent, AgentTeam, Grouping};
use crate::env::{Env, EnvConfig};
use crate::ids::Team;
use crate::learn::{LearnError, StepInfo, check_against_masks};
use crate::scenario::{Mode, Scenario};
use std::sync::Arc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

mod replay;
pub use replay::{Replayed, Replayer};

/// Why a vector environment refused a call.
#[derive(Debug, thiserror::Error)]
pub enum VecEnvError {
    #[error("a vector environment needs at least one seed")]
    NoSeeds,
    #[error("{threads} threads: must be at least 1")]
    Threads { threads: usize },
    #[error("cannot start the thread pool: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
    #[error("{given} actions given: {envs} environments x {agents} agents = {needed} needed")]
    Count { given: usize, envs: usize, agents: usize, needed: usize },
    #[error("scenario `{scenario}` is PvE: its own opponent policy plays team 2, which takes no agent")]
    OpponentInPve { scenario: String },
    #[error("environment {env}: no environment {env} among {envs}")]
    NoEnv { env: usize, envs: usize },
    #[error("environment {env}: episode {episode} ended after {steps} of the {given} steps replayed: these actions are not that episode's")]
    Replay { env: usize, episode: u64, steps: usize, given: usize },
    #[error("environment {env}: {source}")]
    Action {
        env: usize,
        #[source]
        source: LearnError,
    },
}

/// The arrays a step fills (`E` environments, `A` agents of team 1).
#[derive(Clone, Debug, Default)]
pub struct VecBuffers {
    /// `E x A x obs_shape`: after an automatic reset, the new episode's first observation.
    pub obs: Vec<f32>,
    /// `E x state_shape`.
    pub state: Vec<f32>,
    /// `E x A x n_actions`.
    pub avail: Vec<u8>,
    /// `E`: team 1's reward of the step.
    pub reward: Vec<f32>,
    /// `E`: the step ended its episode in the game.
    pub terminated: Vec<bool>,
    /// `E`: the step ended its episode at the time limit.
    pub truncated: Vec<bool>,
    /// `E`: SMAC's info of the step (of the episode that just ended, where one did).
    pub info: Vec<StepInfo>,
    /// `E`: the seed of the episode each environment is now in.
    pub seed: Vec<u64>,
    /// `E x A x obs_shape`, `E x state_shape`, `E x A x n_actions`: where a step ended an
    /// episode, what it ended on (the automatic reset overwrote `obs`, `state` and `avail`).
    /// A learner bootstraps a time-out's last step from these. Stale elsewhere.
    pub final_obs: Vec<f32>,
    pub final_state: Vec<f32>,
    pub final_avail: Vec<u8>,
}

/// What makes a fresh team-2 agent (one per environment, per episode).
pub type OpponentFactory = Arc<dyn Fn() -> Box<dyn Agent> + Send + Sync>;

pub struct VecEnv {
    envs: Vec<Env>,
    /// What the environments were made from, for [`VecEnv::replayer`].
    scenario: Arc<Scenario>,
    cfg: EnvConfig,
    /// PvP: the agent playing team 2 in each environment (empty when team 2 gets no orders).
    opponents: Vec<AgentTeam>,
    opponent_make: Option<OpponentFactory>,
    opponent_name: Option<String>,
    /// Episodes started per environment; environment `i`'s episode `k` (from 1) uses seed
    /// `seeds[i] + (k - 1) * E`, so distinct base seeds give distinct episodes.
    started: Vec<u64>,
    seeds: Vec<u64>,
    /// Helpers of the calling thread (`threads - 1` of them), which steps lanes too.
    pool: Option<rayon::ThreadPool>,
    threads: usize,
    pub buffers: VecBuffers,
    n_agents: usize,
    obs_size: usize,
    state_size: usize,
    n_actions: usize,
}

impl std::fmt::Debug for VecEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VecEnv").field("envs", &self.envs.len()).field("threads", &self.threads).finish()
    }
}

impl VecEnv {
    /// One environment per seed, stepped on `threads` threads (all cores: `num_cpus`).
    pub fn new(scenario: Arc<Scenario>, cfg: EnvConfig, seeds: &[u64], threads: usize) -> Result<VecEnv, VecEnvError> {
        if seeds.is_empty() {
            return Err(VecEnvError::NoSeeds);
        }
        if threads == 0 {
            return Err(VecEnvError::Threads { threads });
        }
        let pool = if threads > 1 { Some(rayon::ThreadPoolBuilder::new().num_threads(threads - 1).build()?) } else { None };
        let envs: Vec<Env> = seeds.iter().map(|&s| Env::new(Arc::clone(&scenario), cfg.clone(), s)).collect();
        let (template, cfg) = (scenario, cfg);
        let l = envs[0].smac_layout(Team::One);
        let (n_agents, obs_size, state_size, n_actions) = (l.n_agents, l.obs_size, l.state_size, l.n_actions);
        let e = envs.len();
        let buffers = VecBuffers {
            obs: vec![0.0; e * n_agents * obs_size],
            state: vec![0.0; e * state_size],
            avail: vec![0; e * n_agents * n_actions],
            reward: vec![0.0; e],
            terminated: vec![false; e],
            truncated: vec![false; e],
            info: vec![StepInfo::default(); e],
            seed: seeds.to_vec(),
            final_obs: vec![0.0; e * n_agents * obs_size],
            final_state: vec![0.0; e * state_size],
            final_avail: vec![0; e * n_agents * n_actions],
        };
        let mut v = VecEnv {
            envs,
            scenario: template,
            cfg,
            opponents: Vec::new(),
            opponent_make: None,
            opponent_name: None,
            started: vec![1; e],
            seeds: seeds.to_vec(),
            pool,
            threads,
            buffers,
            n_agents,
            obs_size,
            state_size,
            n_actions,
        };
        v.fill_all();
        Ok(v)
    }

    pub fn len(&self) -> usize {
        self.envs.len()
    }
    pub fn is_empty(&self) -> bool {
        self.envs.is_empty()
    }
    pub fn threads(&self) -> usize {
        self.threads
    }
    /// (agents, obs_shape, state_shape, n_actions) of team 1.
    pub fn shape(&self) -> (usize, usize, usize, usize) {
        (self.n_agents, self.obs_size, self.state_size, self.n_actions)
    }
    pub fn envs(&self) -> &[Env] {
        &self.envs
    }

    /// In a PvP scenario, `make`'s agents play team 2 (one per environment, fresh each
    /// episode, seeded from the episode's seed as every in-process agent is), acting on the
    /// same observation team 1's actions were chosen on. Without one, team 2 gets no orders.
    pub fn with_opponent(mut self, make: OpponentFactory) -> Result<VecEnv, VecEnvError> {
        let scenario = self.envs[0].scenario();
        if scenario.mode != Mode::Pvp {
            return Err(VecEnvError::OpponentInPve { scenario: scenario.name.clone() });
        }
        self.opponents = self
            .envs
            .iter()
            .map(|env| {
                let make = Arc::clone(&make);
                let mut t = AgentTeam::new(Team::Two, Grouping::Team, move || make());
                t.reset(env);
                t
            })
            .collect();
        self.opponent_name = self.opponents.first().map(AgentTeam::name);
        self.opponent_make = Some(make);
        Ok(self)
    }

    /// The name of team 2's agent, if one plays it ([`VecEnv::with_opponent`]).
    pub fn opponent(&self) -> Option<&str> {
        self.opponent_name.as_deref()
    }

    /// Restarts every environment from its base seed (episode counts start again).
    pub fn reset(&mut self) {
        let seeds = self.seeds.clone();
        for (i, (env, &s)) in self.envs.iter_mut().zip(&seeds).enumerate() {
            env.reset(s);
            if let Some(o) = self.opponents.get_mut(i) {
                o.reset(env);
            }
        }
        self.started.iter_mut().for_each(|k| *k = 1);
        self.buffers.seed.clone_from(&seeds);
        self.fill_all();
    }

    /// The number (1 for the first) of the episode each environment is now in: with the
    /// actions taken since it started, what [`VecEnv::restore`] puts an environment back from.
    pub fn episode_numbers(&self) -> &[u64] {
        &self.started
    }

    /// Puts environment `i` back where it was: in its episode number `episode` (as
    /// [`VecEnv::episode_numbers`] gave it), after team 1's `actions` (SMAC indices, `A` a
    /// step) replayed from the episode's start. The game and its opponent are deterministic
    /// given the episode's seed and team 1's actions, so the environment and its row of the
    /// buffers are as they were when those were recorded (a resumed training run goes on
    /// exactly as the uninterrupted one). Actions that end the episode early, or that its
    /// masks refuse, are not that episode's: an error.
    pub fn restore(&mut self, i: usize, episode: u64, actions: &[i64]) -> Result<(), VecEnvError> {
        let (episode, seed) = episode_seed(&self.seeds, i, episode, (actions.len(), self.n_agents))?;
        let a = self.n_agents.max(1);
        let env = &mut self.envs[i];
        env.reset(seed);
        let mut opponent = self.opponents.get_mut(i);
        if let Some(o) = opponent.as_deref_mut() {
            o.reset(env);
        }
        self.started[i] = episode;
        self.buffers.seed[i] = seed;
        let (na, steps) = (self.n_actions, actions.len() / a);
        let mut masks = vec![0u8; self.n_agents * na];
        for (t, acts) in actions.chunks(a).enumerate() {
            if env.done() {
                return Err(VecEnvError::Replay { env: i, episode, steps: t, given: steps });
            }
            let _ = env.avail_all(Team::One, &mut masks);
            check_against_masks(acts, &masks, self.n_agents, na).map_err(|source| VecEnvError::Action { env: i, source })?;
            step_lane(env, opponent.as_deref_mut(), episode, acts);
        }
        if env.done() {
            return Err(VecEnvError::Replay { env: i, episode, steps, given: steps });
        }
        let (oa, sa, aa) = (self.n_agents * self.obs_size, self.state_size, self.n_agents * na);
        let b = &mut self.buffers;
        fill(env, &mut b.obs[i * oa..(i + 1) * oa], &mut b.state[i * sa..(i + 1) * sa], &mut b.avail[i * aa..(i + 1) * aa]);
        Ok(())
    }

    /// Writes every environment's observation, state and mask into the buffers.
    fn fill_all(&mut self) {
        let (oa, sa, aa) = (self.n_agents * self.obs_size, self.state_size, self.n_agents * self.n_actions);
        let b = &mut self.buffers;
        for (i, env) in self.envs.iter().enumerate() {
            fill(env, &mut b.obs[i * oa..(i + 1) * oa], &mut b.state[i * sa..(i + 1) * sa], &mut b.avail[i * aa..(i + 1) * aa]);
        }
    }

    /// One step of every environment with `actions` (`E x A` SMAC indices, environment-major).
    /// All actions are checked before any environment steps.
    pub fn step(&mut self, actions: &[i64]) -> Result<(), VecEnvError> {
        let (e, a) = (self.envs.len(), self.n_agents);
        if actions.len() != e * a {
            return Err(VecEnvError::Count { given: actions.len(), envs: e, agents: a, needed: e * a });
        }
        let a = a.max(1);
        // Against the masks the caller was handed (the buffers hold each environment's
        // current ones), not recomputed: this loop is the serial part of a step.
        let aa = self.n_agents * self.n_actions;
        for (i, acts) in actions.chunks(a).enumerate() {
            let masks = &self.buffers.avail[i * aa..(i + 1) * aa];
            check_against_masks(acts, masks, self.n_agents, self.n_actions).map_err(|source| VecEnvError::Action { env: i, source })?;
        }
        let (oa, sa, aa) = ((self.n_agents * self.obs_size).max(1), self.state_size.max(1), (self.n_agents * self.n_actions).max(1));
        let b = &mut self.buffers;
        let stride = e as u64;
        let seeds = &self.seeds;
        let mut opponents: Vec<Option<&mut AgentTeam>> = self.opponents.iter_mut().map(Some).collect();
        opponents.resize_with(e, || None);
        // One lane per environment: its own slices of every buffer, so lanes step on any
        // thread without sharing anything.
        let lanes: Vec<Lane<'_>> = self
            .envs
            .iter_mut()
            .zip(self.started.iter_mut())
            .zip(actions.chunks(a))
            .zip(b.obs.chunks_mut(oa))
            .zip(b.state.chunks_mut(sa))
            .zip(b.avail.chunks_mut(aa))
            .zip(b.reward.iter_mut())
            .zip(b.terminated.iter_mut())
            .zip(b.truncated.iter_mut())
            .zip(b.info.iter_mut())
            .zip(b.seed.iter_mut())
            .zip(b.final_obs.chunks_mut(oa).zip(b.final_state.chunks_mut(sa)).zip(b.final_avail.chunks_mut(aa)))
            .zip(opponents)
            .enumerate()
            .map(
                |(
                    i,
                    (
                        (
                            ((((((((((env, started), acts), obs), state), avail), reward), terminated), truncated), info), seed),
                            ((fo, fs), fa),
                        ),
                        opponent,
                    ),
                )| Lane {
                    base_seed: seeds[i],
                    env,
                    opponent,
                    started,
                    acts,
                    obs,
                    state,
                    avail,
                    reward,
                    terminated,
                    truncated,
                    info,
                    seed,
                    final_obs: fo,
                    final_state: fs,
                    final_avail: fa,
                },
            )
            .collect();
        match &self.pool {
            None => lanes.into_iter().for_each(|l| l.step(stride)),
            Some(pool) => {
                // A shared queue of lanes that the calling thread and the helpers drain
                // together: the caller works instead of waiting, and a lane whose episode
                // resets (dearer than a step) does not hold the others up.
                let queue: Vec<Mutex<Option<Lane<'_>>>> = lanes.into_iter().map(|l| Mutex::new(Some(l))).collect();
                let next = AtomicUsize::new(0);
                let drain = || {
                    while let Some(slot) = queue.get(next.fetch_add(1, Ordering::Relaxed)) {
                        // Each slot is taken once; a poisoned lock means a lane panicked,
                        // which the scope re-raises.
                        if let Some(lane) = slot.lock().ok().and_then(|mut l| l.take()) {
                            lane.step(stride);
                        }
                    }
                };
                pool.in_place_scope(|s| {
                    for _ in 0..pool.current_num_threads() {
                        s.spawn(|_| drain());
                    }
                    drain();
                });
            }
        }
        Ok(())
    }
}

/// One environment of a vector step and its share of the buffers.
struct Lane<'a> {
    base_seed: u64,
    env: &'a mut Env,
    opponent: Option<&'a mut AgentTeam>,
    started: &'a mut u64,
    acts: &'a [i64],
    obs: &'a mut [f32],
    state: &'a mut [f32],
    avail: &'a mut [u8],
    reward: &'a mut f32,
    terminated: &'a mut bool,
    truncated: &'a mut bool,
    info: &'a mut StepInfo,
    seed: &'a mut u64,
    final_obs: &'a mut [f32],
    final_state: &'a mut [f32],
    final_avail: &'a mut [u8],
}

impl Lane<'_> {
    fn step(mut self, stride: u64) {
        let r = step_lane(self.env, self.opponent.as_deref_mut(), *self.started, self.acts);
        *self.reward = r.reward[0];
        *self.terminated = r.terminated;
        *self.truncated = r.truncated;
        *self.info = self.env.info(Team::One);
        if r.done {
            fill(self.env, self.final_obs, self.final_state, self.final_avail);
            let s = self.base_seed.wrapping_add(self.started.wrapping_mul(stride));
            *self.started += 1;
            self.env.reset(s);
            if let Some(o) = self.opponent.as_deref_mut() {
                o.reset(self.env);
            }
            *self.seed = s;
        }
        fill(self.env, self.obs, self.state, self.avail);
    }
}

/// Environment `i`'s episode number `episode` (from 1) and its seed, for `given` actions of
/// `agents` agents a step: the one place the seed of a lane's episode is worked out.
fn episode_seed(seeds: &[u64], i: usize, episode: u64, (given, agents): (usize, usize)) -> Result<(u64, u64), VecEnvError> {
    let e = seeds.len();
    if i >= e {
        return Err(VecEnvError::NoEnv { env: i, envs: e });
    }
    let a = agents.max(1);
    if !given.is_multiple_of(a) {
        return Err(VecEnvError::Count { given, envs: 1, agents: a, needed: given.div_ceil(a) * a });
    }
    let episode = episode.max(1);
    Ok((episode, seeds[i].wrapping_add((episode - 1).wrapping_mul(e as u64))))
}

/// One step of an environment in its episode number `episode`: team 2's agent (if any)
/// chooses on the observation team 1 chose on, then both are submitted. The one place a
/// vector step, a restore and a replay step through, so that the three play alike.
fn step_lane(env: &mut Env, opponent: Option<&mut AgentTeam>, episode: u64, acts: &[i64]) -> crate::env::StepResult {
    if let Some(o) = opponent {
        let orders = o.act(env, episode - 1);
        env.submit(Team::Two, &orders);
    }
    let idx: Vec<usize> = acts.iter().map(|&x| x as usize).collect();
    env.submit_indices(Team::One, &idx);
    env.step()
}

fn fill(env: &Env, obs: &mut [f32], state: &mut [f32], avail: &mut [u8]) {
    // Sizes come from the environment's own layout, so these cannot fail.
    let _ = env.obs_all(Team::One, obs);
    let _ = env.state_into(Team::One, state);
    let _ = env.avail_all(Team::One, avail);
}
