//! PPO's loop: all environments step together with one batched forward pass of actor and
//! critic for every environment and agent, actions drawn from the masked policy, and an
//! update after every `rollout_len` steps (`envs x rollout_len` environment steps). Tests,
//! the CSV log and checkpoints are the Q-learners' (see [`crate::monitor`]); the CSV's
//! `epsilon` is 0 (PPO explores by sampling), `loss` is the PPO loss (mean over the update's
//! epochs), `grad_norm` the actor's gradient norm before clipping, `q_taken` the rollout's
//! mean value estimate, and `updates` counts rollouts.
//!
//! In an image mode the actor also sees each environment's rendered frames (stored with the
//! rollout, encoded again at every epoch so the encoder learns); the critic keeps its SMAC
//! input.
//!
//! A run that ends inside a rollout drops the unfinished rollout (its steps count, but no
//! update learns from them). A run resumed from a test round inside a rollout goes on with it
//! (features mode, [`crate::carry`]); in the image modes it starts a fresh one.

use super::learner::{PpoLearner, additive_mask, sample_actions};
use super::rollout::{CriticRows, Rollout, Sizes};
use crate::buffer::{Shape, act_inputs};
use crate::carry::Carry;
use crate::monitor::{Monitor, Progress, RunOptions, Summary};
use crate::resume::{self, RunState};
use crate::{Config, Error, Stack, UpdateStats, checkpoint};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};

/// Trains IPPO or MAPPO, going on from `start` when given (see [`crate::resume`]: the
/// checkpoint and state in `opts.out`); returns the learner and how the run went. Reached
/// through [`crate::train_from`], which holds the run folder's lock.
pub(crate) fn train_from(
    cfg: &Config,
    opts: &RunOptions,
    start: Option<RunState>,
    on_progress: &mut dyn FnMut(&Progress),
) -> Result<(PpoLearner, Summary), Error> {
    let e = cfg.envs;
    let mut monitor = Monitor::resuming(cfg, opts, start.as_ref())?;
    // Features mode keeps the rollout under way and the environments (see `crate::carry`);
    // the image modes' frames are not kept, and they resume with a fresh rollout; nor does
    // self-play (an episode's opponent was drawn from the pool as it was then).
    let exact = opts.out.as_ref().filter(|_| !cfg.obs.images() && !cfg.self_play());
    // Under another game (`--set` changed a rule, the data or the opponent) the rollout kept
    // would be replayed into other games: the run goes on with a fresh one.
    let kept = match (exact, &start) {
        (Some(dir), Some(st)) if st.played_config(dir)?.same_game(cfg) => Carry::load(&st.files(dir), st.t_env)?,
        _ => None,
    };
    if kept.is_some() {
        monitor.keep_episodes();
    }
    let mut env = monitor.env()?;
    let (a, _, _, na) = env.shape();
    let shape = Shape::of(&env);
    // The networks' sizes: `stacked_frames` steps of observation and state side by side.
    let net = shape.stacked(cfg.stacked_frames);
    let mut learner = PpoLearner::new(cfg, shape, opts.seed)?;
    let mut act_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed_0001);
    let mut update_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed_0002);
    let mut source = crate::ObsSource::new(cfg)?;
    let (mut t_env, mut episodes) = match &start {
        Some(st) => resumed(opts, st, &mut learner, (&mut act_rng, &mut update_rng))?,
        None => (0, 0),
    };
    monitor.start_self_play(&learner.actor, learner.updates, start.is_some(), &mut env)?;
    let (rows, hidden) = (e * a, cfg.rnn_hidden_dim);
    let (id, la) = (cfg.obs_agent_id, cfg.obs_last_action);
    let agents: Vec<usize> = (0..rows).map(|r| r % a.max(1)).collect();
    let shared = learner.shared();
    let stacks = || (Stack::new(cfg.stacked_frames, shape.obs, rows), Stack::new(cfg.stacked_frames, shape.state, e));
    let mut lanes = Lanes::new(rows, hidden, shared, e, stacks());
    let mut roll = Rollout { rows, n_agents: a, ..Rollout::default() };
    let mut last_stats = UpdateStats::default();
    if let Some(c) = &kept {
        let want = kept_sizes(cfg, &learner, &net, e);
        (lanes, roll, last_stats) = (Lanes::kept(c, &mut env, &want, stacks())?, Rollout::kept(c, &want)?, c.get_stats("last_stats")?);
    }
    // Wall-clock per phase, for the summary only: nothing learned depends on it.
    let mut time = [Duration::ZERO; 5];
    while t_env < cfg.t_max {
        let clock = Instant::now();
        let b = &env.buffers;
        let (obs, state) = (lanes.obs_stack.push(&b.obs), lanes.state_stack.push(&b.state));
        let x_actor = act_inputs(&obs, &agents, &lanes.last, &net, id, la);
        // A shared trunk's critic reads the actor's rows: no rows or states of its own.
        let x_critic = if shared { CriticRows::default() } else { learner.critic_input.rows(&net, &obs, &state, e) };
        if roll.t.is_multiple_of(cfg.data_chunk_length) {
            roll.h_actor.extend_from_slice(&lanes.h_actor);
            roll.h_critic.extend_from_slice(&lanes.h_critic);
        }
        let frames = source.as_mut().map(|s| s.observe(env.envs())).transpose()?;
        let out = learner.act_with(&x_actor, &lanes.h_actor, x_critic.input(), &lanes.h_critic, frames.as_ref())?;
        roll.frames.extend(frames);
        let (acts, logp) = sample_actions(&out.logits, &b.avail, na, &mut act_rng);
        roll.actor_in.extend(x_actor);
        roll.critic.extend(&x_critic);
        roll.mask.extend(additive_mask(&b.avail));
        roll.actions.extend_from_slice(&acts);
        roll.logp.extend(logp);
        roll.values.extend(out.values);
        roll.active.extend(b.avail.chunks_exact(na.max(1)).map(|m| if m.iter().filter(|&&x| x != 0).count() > 1 { 1.0 } else { 0.0 }));
        roll.keep.extend_from_slice(&lanes.keep);
        let t_act = clock.elapsed();
        env.step(&acts.iter().map(|&x| i64::from(x)).collect::<Vec<_>>())?;
        let t_env_step = clock.elapsed();
        t_env += e as u64;
        let b = &env.buffers;
        let done: Vec<bool> = b.terminated.iter().zip(&b.truncated).map(|(t, u)| *t || *u).collect();
        roll.reward.extend_from_slice(&b.reward);
        roll.done.extend(done.iter().map(|&d| if d { 1.0 } else { 0.0 }));
        roll.t += 1;
        episodes += lanes.end_step(b, &done, &acts, exact.is_some(), &mut monitor);
        lanes.advance(&done, &acts, (out.h_actor, out.h_critic), a, hidden);
        let t_record = clock.elapsed();
        if roll.t == cfg.rollout_len {
            let rows = Inputs { obs: &b.obs, state: &b.state, agents: &agents, shape: &net, envs: e };
            last_stats = update(cfg, &mut learner, &mut roll, &lanes, &rows, &mut update_rng)?;
        }
        let t_update = clock.elapsed();
        let mut save = |dir: &std::path::Path| -> Result<(), Error> {
            checkpoint::save(dir, &learner.actor, cfg, &shape, &opts.scenario.name)?;
            learner.save_critic(dir)
        };
        let tested = monitor.after_step(t_env, (episodes, learner.updates), 0.0, &last_stats, &learner.actor, &mut save)?;
        if tested && let Some(dir) = &opts.out {
            let rngs = (act_rng.get_word_pos(), update_rng.get_word_pos());
            let carry = exact.is_some().then_some((&env, &roll, &lanes));
            checkpoint(dir, opts.seed, (t_env, episodes), rngs, &learner, &monitor, carry, &last_stats)?;
        }
        let t_test = clock.elapsed();
        for (acc, d) in time.iter_mut().zip([t_act, t_env_step - t_act, t_record - t_env_step, t_update - t_record, t_test - t_update]) {
            *acc += d;
        }
        on_progress(&Progress {
            t_env,
            t_max: cfg.t_max,
            episodes,
            updates: learner.updates,
            epsilon: 0.0,
            loss: last_stats.loss,
            last_test: monitor.tests.last().copied(),
        });
    }
    let phases = ["act", "env", "record", "update", "test"].iter().zip(time).map(|(n, d)| (n.to_string(), d.as_secs_f64())).collect();
    let summary = Summary { t_env, episodes, updates: learner.updates, last_loss: last_stats.loss, tests: monitor.tests, phases };
    Ok((learner, summary))
}

/// Puts a resumed run's learner and random streams back; returns its steps and episodes.
fn resumed(
    opts: &RunOptions,
    st: &RunState,
    learner: &mut PpoLearner,
    (act, update): (&mut ChaCha8Rng, &mut ChaCha8Rng),
) -> Result<(u64, u64), Error> {
    let Some(dir) = &opts.out else {
        return Err(Error::Checkpoint { message: "resuming needs the run's directory".into() });
    };
    restore(dir, learner, st)?;
    let (ap, up) = st.rng_positions()?;
    act.set_word_pos(ap);
    update.set_word_pos(up);
    Ok((st.t_env, st.episodes))
}

/// What a resume's kept rollout and lanes must measure in this run.
fn kept_sizes(cfg: &Config, learner: &PpoLearner, shape: &Shape, envs: usize) -> Sizes {
    let a = shape.n_agents;
    let critic = (!learner.shared()).then(|| (learner.critic_input.width(shape) - a, a));
    Sizes {
        rows: envs * a,
        n_agents: a,
        envs,
        n_actions: shape.n_actions,
        rollout_len: cfg.rollout_len,
        chunk: cfg.data_chunk_length,
        hidden: cfg.rnn_hidden_dim,
        actor_width: shape.input(cfg.obs_agent_id, cfg.obs_last_action),
        critic,
    }
}

/// Each row's recurrent state and each environment's episode so far, as a resume keeps them.
struct Lanes {
    h_actor: Vec<f32>,
    /// Empty with a shared trunk: its critic reads the actor's rows.
    h_critic: Vec<f32>,
    /// Each row's previous action (none at an episode's start).
    last: Vec<Option<u32>>,
    /// 0 where a row's episode starts this step: the run starts an episode everywhere.
    keep: Vec<f32>,
    /// Each environment's return so far this episode (the log's training return).
    returns: Vec<f32>,
    /// Team 1's actions since each environment's episode began (what a resume replays).
    since: Vec<Vec<u32>>,
    /// Each row's last observations and each environment's last states (`stacked_frames`).
    obs_stack: Stack,
    state_stack: Stack,
}

impl Lanes {
    fn new(rows: usize, hidden: usize, shared: bool, envs: usize, (obs_stack, state_stack): (Stack, Stack)) -> Lanes {
        Lanes {
            obs_stack,
            state_stack,
            h_actor: vec![0f32; rows * hidden],
            h_critic: vec![0f32; if shared { 0 } else { rows * hidden }],
            last: vec![None; rows],
            keep: vec![0f32; rows],
            returns: vec![0f32; envs],
            since: vec![Vec::new(); envs],
        }
    }

    /// The lanes a checkpoint kept, its environments replayed into `env`.
    fn kept(
        c: &Carry,
        env: &mut avacraft_engine::VecEnv,
        want: &Sizes,
        (mut obs_stack, mut state_stack): (Stack, Stack),
    ) -> Result<Lanes, Error> {
        let (rows, hidden, envs, n_actions) = (want.rows, want.hidden, want.envs, want.n_actions);
        if obs_stack.on() {
            obs_stack.set_history(c.get_f32s("obs_stack")?).map_err(|why| c.bad(why))?;
            state_stack.set_history(c.get_f32s("state_stack")?).map_err(|why| c.bad(why))?;
        }
        let lanes = Lanes {
            obs_stack,
            state_stack,
            since: c.restore_lanes(env)?,
            h_actor: c.get_f32s("h_actor")?,
            h_critic: c.get_f32s("h_critic")?,
            last: c.get_actions("last", n_actions)?,
            keep: c.get_f32s("keep")?,
            returns: c.get_f32s("returns")?,
        };
        let h_critic = if want.critic.is_some() { rows * hidden } else { 0 };
        let sizes = (lanes.h_actor.len(), lanes.h_critic.len(), lanes.last.len(), lanes.keep.len(), lanes.returns.len());
        if sizes != (rows * hidden, h_critic, rows, rows, envs) {
            return Err(c.bad("its sizes are not this run's".into()));
        }
        Ok(lanes)
    }

    fn keep_in(&self, c: &mut Carry, env: &avacraft_engine::VecEnv) -> Result<(), Error> {
        c.lanes(env, &self.since)?;
        c.f32s("h_actor", &self.h_actor)?;
        c.f32s("h_critic", &self.h_critic)?;
        c.actions("last", &self.last)?;
        c.f32s("keep", &self.keep)?;
        if self.obs_stack.on() {
            c.f32s("obs_stack", self.obs_stack.history())?;
            c.f32s("state_stack", self.state_stack.history())?;
        }
        c.f32s("returns", &self.returns)
    }

    /// The step's rewards into each environment's return; an episode that ended goes to the
    /// monitor, one going on keeps its actions (when a resume is to replay them). Returns the
    /// episodes that ended.
    fn end_step(&mut self, b: &avacraft_engine::VecBuffers, done: &[bool], acts: &[u32], replay: bool, monitor: &mut Monitor) -> u64 {
        for (r, x) in self.returns.iter_mut().zip(&b.reward) {
            *r += x;
        }
        let a = acts.len() / done.len().max(1);
        let mut ended = 0;
        for (i, &d) in done.iter().enumerate() {
            if d {
                ended += 1;
                monitor.episode_end(b.info[i].battle_won, f64::from(std::mem::take(&mut self.returns[i])));
                self.since[i].clear();
            } else if replay {
                self.since[i].extend_from_slice(&acts[i * a..(i + 1) * a]);
            }
        }
        ended
    }

    /// After a step: rows whose episode ended start the next one with zero state and no
    /// previous action.
    fn advance(&mut self, done: &[bool], acts: &[u32], (h_actor, h_critic): (Vec<f32>, Vec<f32>), a: usize, hidden: usize) {
        for (r, k) in self.keep.iter_mut().enumerate() {
            *k = if done[r / a.max(1)] { 0.0 } else { 1.0 };
        }
        (self.h_actor, self.h_critic) = (h_actor, h_critic);
        for h in [&mut self.h_actor, &mut self.h_critic] {
            for (row, &k) in h.chunks_exact_mut(hidden.max(1)).zip(&self.keep) {
                if k == 0.0 {
                    row.fill(0.0);
                }
            }
        }
        for ((l, &act), &k) in self.last.iter_mut().zip(acts).zip(&self.keep) {
            *l = if k > 0.0 { Some(act) } else { None };
        }
        // The next episode's first step reads no steps of the last one.
        self.obs_stack.clear(done, a);
        self.state_stack.clear(done, 1);
    }
}

/// What the actor's and the critic's input rows are built from this step.
struct Inputs<'a> {
    obs: &'a [f32],
    state: &'a [f32],
    agents: &'a [usize],
    /// The networks' sizes (stacked).
    shape: &'a Shape,
    envs: usize,
}

/// A full rollout's update: the values of the states it ended in, then PPO's epochs; the
/// rollout is emptied for the next one.
fn update(
    cfg: &Config,
    learner: &mut PpoLearner,
    roll: &mut Rollout,
    lanes: &Lanes,
    x: &Inputs<'_>,
    rng: &mut ChaCha8Rng,
) -> Result<UpdateStats, Error> {
    let shared = learner.shared();
    // The states the rollout ended in, after each row's history (which the next step moves on).
    let (obs, state) = (lanes.obs_stack.peek(x.obs), lanes.state_stack.peek(x.state));
    let x_critic = if shared { CriticRows::default() } else { learner.critic_input.rows(x.shape, &obs, &state, x.envs) };
    let x_actor = if shared { act_inputs(&obs, x.agents, &lanes.last, x.shape, cfg.obs_agent_id, cfg.obs_last_action) } else { Vec::new() };
    roll.values.extend(learner.values(&x_actor, &lanes.h_actor, x_critic.input(), &lanes.h_critic));
    let st = learner.update(roll, rng)?;
    roll.clear();
    Ok(UpdateStats {
        loss: st.loss,
        grad_norm: st.actor_grad_norm,
        td_abs: st.value_loss,
        q_taken: st.value_mean,
        entropy: Some(st.entropy),
        policy_loss: Some(st.policy_loss),
        critic_grad_norm: Some(st.critic_grad_norm),
    })
}

/// A test round's checkpoint, into the round's resume folder: the online weights, the
/// optimisers' state, then (features mode) the environments, the rollout under way and the
/// lanes, then `state.json` naming the folder, what a resume starts from.
#[allow(clippy::too_many_arguments)]
fn checkpoint(
    dir: &std::path::Path,
    seed: u64,
    (t_env, episodes): (u64, u64),
    rngs: (u128, u128),
    learner: &PpoLearner,
    monitor: &Monitor,
    carry: Option<(&avacraft_engine::VecEnv, &Rollout, &Lanes)>,
    last_stats: &UpdateStats,
) -> Result<(), Error> {
    let mut state = RunState::new(
        seed,
        t_env,
        episodes,
        monitor.test_round,
        (learner.updates, 0),
        rngs,
        monitor.elapsed(),
        &monitor.tests,
        &monitor.curve,
    );
    state.value_norm = Some(learner.value_norm.clone());
    state.seed_offset = monitor.seed_offset();
    let files = resume::begin_round(dir, monitor.test_round)?;
    resume::save_moments(&files, &learner.moments())?;
    if let Some((env, roll, lanes)) = carry {
        let mut c = Carry::new(t_env)?;
        lanes.keep_in(&mut c, env)?;
        roll.keep(&mut c)?;
        c.stats("last_stats", last_stats)?;
        c.save(&files)?;
    }
    state.save(dir, None, &files)
}

/// Loads the state's actor, critic and value statistics into `learner`.
pub(crate) fn restore(dir: &std::path::Path, learner: &mut PpoLearner, state: &RunState) -> Result<(), Error> {
    let weights = state.weights(dir);
    let policy = crate::Policy::load_from(dir, &weights)?;
    learner.actor.agent_params.copy_from(&policy.nets.agent_params)?;
    learner.critic_params.load_map(&resume::load_tensors(&weights.join("critic.safetensors"))?, "critic.safetensors")?;
    learner.value_norm = state
        .value_norm
        .clone()
        .ok_or_else(|| Error::Checkpoint { message: format!("{}: no value statistics to resume from", dir.display()) })?;
    learner.updates = state.updates;
    learner.load_weights()?;
    let like = learner.moments();
    let files = state.files(dir);
    if let Some(saved) = resume::load_moments(&files, &like)? {
        for ((name, _), m) in like.iter().zip(saved) {
            learner.set_moments(name, m).map_err(|e| resume::optim_mismatch(&files, name, &e))?;
        }
    }
    Ok(())
}
