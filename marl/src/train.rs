//! The training loops: `envs` environments stepped together by the engine's
//! [`VecEnv`](avacraft_engine::VecEnv) (in parallel, restarting on their own), one batched
//! forward pass of the agent network for all environments and agents per step, greedy test
//! episodes every `test_interval` steps, a CSV log, learning curves (`curves.png`) and
//! checkpoints in the output directory (the latest, and in `best/` the one with the highest
//! greedy win rate so far; both loops share these through [`crate::monitor`]). The
//! Q-learners' loop is here (finished episodes into the replay buffer, one update per
//! `episodes_per_update` finished episodes); PPO's is in [`crate::ppo`]. In the image modes
//! an [`ObsSource`] draws every environment's frames (and embeds its text) each step, before
//! acting; they go with the episode into the replay buffer and through the encoder again in
//! each batch.
//!
//! Everything that decides the run draws from streams seeded by the run's seed (the vector
//! environment's results depend on its seeds only, not on its threads); the clock is read
//! for the log's `elapsed_s` column only.

use crate::acting::Actor;
use crate::buffer::{Batch, Episode, FrameBatch, ReplayBuffer, Shape};
use crate::carry::Carry;
use crate::journal::{self, Journal};
use crate::learner::Learner;
use crate::monitor::Monitor;
use crate::nets::Nets;
use crate::observe::ObsSource;
use crate::ppo::PpoLearner;
use crate::resume::RunState;
use crate::{Config, Error, checkpoint};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

// These were defined here; their old paths stay valid.
pub use crate::evaluation::{TestResult, opponent_factory, shape_of, test, test_with};
pub use crate::monitor::{Progress, RunOptions, Summary};

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
    // Held until training returns: no second process writes into this run meanwhile.
    let _lock = opts.out.as_deref().map(crate::lock::RunLock::acquire).transpose()?;
    // `start` was read before the lock was taken: a process that trained there meanwhile has
    // moved the state on and removed the round folder it names. Going on would mix rounds.
    if let (Some(st), Some(dir)) = (&start, opts.out.as_deref())
        && crate::resume::load_state(dir)? != *st
    {
        return Err(Error::Checkpoint {
            message: format!(
                "{}: its resume state changed after it was read (another process trained there meanwhile): read it again to resume",
                dir.display()
            ),
        });
    }
    // The game the run plays, named in its config (so in every checkpoint it writes).
    let (cfg, scenario) = cfg.resolved(std::sync::Arc::clone(&opts.scenario))?;
    let (cfg, opts) = (&cfg, &RunOptions { scenario, ..opts.clone() });
    if cfg.is_ppo() {
        let (l, s) = crate::ppo::train_from(cfg, opts, start, on_progress)?;
        return Ok((Trained::Ppo(Box::new(l)), s));
    }
    let (l, s) = train_q(cfg, opts, start, on_progress)?;
    Ok((Trained::Q(Box::new(l)), s))
}

/// A Q-learners' run's lanes as a resume needs them: the vector environment, the episodes
/// under way, the actor's state, the episodes not yet trained on and the last update's stats.
struct Lanes<'a> {
    env: &'a avacraft_engine::VecEnv,
    running: &'a [Episode],
    actor: &'a Actor,
    pending: u64,
    last: &'a crate::UpdateStats,
}

/// A test round's checkpoint of the Q-learners' loop, into the round's resume folder: the
/// online weights, the optimiser's state, then (features mode) the journal and the lanes,
/// then `state.json` naming the folder, what a resume starts from.
#[allow(clippy::too_many_arguments)]
fn checkpoint(
    dir: &std::path::Path,
    seed: u64,
    (t_env, episodes): (u64, u64),
    rngs: (u128, u128),
    learner: &Learner,
    monitor: &Monitor,
    journal: Option<&mut Journal>,
    lanes: &Lanes<'_>,
) -> Result<(), Error> {
    let files = crate::resume::begin_round(dir, monitor.test_round)?;
    if let Some(m) = learner.moments() {
        crate::resume::save_moments(&files, &[("q", m)])?;
    }
    if let Some(j) = journal {
        j.sync()?;
        let mut carry = Carry::new(t_env)?;
        let since: Vec<Vec<u32>> = lanes.running.iter().map(|ep| ep.actions.clone()).collect();
        // The episodes under way are not kept: a resume plays them again from these.
        carry.lanes(lanes.env, &since)?;
        let (h, last_acts) = lanes.actor.state();
        carry.f32s("actor.h", h)?;
        carry.actions("actor.last", last_acts)?;
        carry.u64s("pending", &[lanes.pending])?;
        carry.stats("last", lanes.last)?;
        carry.save(&files)?;
    }
    let mut state = RunState::new(
        seed,
        t_env,
        episodes,
        monitor.test_round,
        (learner.updates, learner.last_target_update),
        rngs,
        monitor.elapsed(),
        &monitor.tests,
        &monitor.curve,
    );
    state.seed_offset = monitor.seed_offset();
    state.save(dir, Some(&learner.target), &files)
}

/// Each lane's reward this step; the episodes that ended are closed (a truncated one with its
/// final observation), counted by the monitor, journalled and put in the replay buffer.
/// Returns which lanes ended, and how many.
fn end_episodes(
    b: &avacraft_engine::VecBuffers,
    numbers: &[u64],
    shape: &Shape,
    running: &mut [Episode],
    monitor: &mut Monitor,
    mut journal: Option<&mut Journal>,
    buffer: &mut ReplayBuffer,
) -> Result<(Vec<bool>, u64), Error> {
    let (a, o, s, na) = (shape.n_agents, shape.obs, shape.state, shape.n_actions);
    let done: Vec<bool> = b.terminated.iter().zip(&b.truncated).map(|(t, u)| *t || *u).collect();
    let mut ended = 0;
    for (i, ep) in running.iter_mut().enumerate() {
        ep.push_outcome(b.reward[i], b.terminated[i]);
        if done[i] {
            let mut finished = std::mem::take(ep);
            let last = (b.truncated[i] && !b.terminated[i]).then(|| {
                (&b.final_obs[i * a * o..(i + 1) * a * o], &b.final_state[i * s..(i + 1) * s], &b.final_avail[i * a * na..(i + 1) * a * na])
            });
            finished.close(shape, last);
            monitor.episode_end(b.info[i].battle_won, finished.reward.iter().map(|&r| f64::from(r)).sum());
            if let Some(j) = journal.as_deref_mut() {
                // The lane has started its next episode: this one was the one before.
                j.append(&finished, i, numbers[i].saturating_sub(1))?;
            }
            buffer.insert(finished);
            ended += 1;
        }
    }
    Ok((done, ended))
}

/// One update on a batch sampled from the replay buffer (with its frames in the image modes).
fn learn(
    cfg: &Config,
    shape: &Shape,
    learner: &mut Learner,
    buffer: &ReplayBuffer,
    batch: &mut Batch,
    rng: &mut ChaCha8Rng,
    (frames, episodes): (bool, u64),
) -> Result<crate::UpdateStats, Error> {
    let sample = buffer.sample(cfg.batch_size, rng);
    batch.refill(&sample, shape, cfg.obs_agent_id, cfg.obs_last_action)?;
    if frames {
        batch.frames = Some(FrameBatch::new(&sample, cfg)?);
    }
    learner.train(batch, episodes)
}

/// Lane `lane`'s episode number `episode` played again with `actions` (`A` a step), as the
/// training loop recorded it (`closed`: finished with its last step).
fn replayed(
    replayer: &avacraft_engine::Replayer,
    shape: &Shape,
    lane: usize,
    episode: u64,
    actions: Vec<u32>,
    closed: bool,
) -> Result<Episode, String> {
    let acts: Vec<i64> = actions.iter().map(|&x| i64::from(x)).collect();
    let at = |e: String| format!("environment {lane}, its episode {episode}: {e}");
    let r = replayer.replay(lane, episode, &acts).map_err(|e| at(e.to_string()))?;
    Episode::replayed(r, actions, shape, closed).map_err(at)
}

/// A journal's played episode given back, on the calling thread: the buffer is most of a
/// run's memory, and one rebuilt on two threads left a 27m_vs_30m run growing to 24 GB
/// (killed for memory), where on the training thread it grew half as fast; memory made on a
/// helper thread is not reused by the loop's own allocations.
fn rebuild_episode(replayer: &avacraft_engine::Replayer, shape: &Shape, p: &journal::Played) -> Result<Episode, Error> {
    let bad = |e: String| Error::Checkpoint { message: format!("replaying the kept replay buffer: {e}") };
    if Some(p.actions.len()) != p.len.checked_mul(shape.n_agents) {
        return Err(bad(format!("an episode of {} steps kept with {} actions for {} agents", p.len, p.actions.len(), shape.n_agents)));
    }
    replayed(replayer, shape, p.lane, p.episode, p.actions.clone(), true).map_err(bad)
}

/// What a QMIX-family resume kept beside its journal, put back: the environments, the
/// episodes under way (played again from their actions), the acting state; checked against
/// the run's team (a resume's files may have been cut short or changed), with the buffer the
/// journal gave back.
fn restore_q(
    carry: &Carry,
    buffer: &ReplayBuffer,
    env: &mut avacraft_engine::VecEnv,
    actor: &mut Actor,
    shape: &Shape,
    resume: &std::path::Path,
) -> Result<(Vec<Episode>, u64, crate::UpdateStats), Error> {
    let bad = |e: String| Error::Checkpoint { message: format!("{}: {e}", resume.display()) };
    let since = carry.restore_lanes(env)?;
    // Carries written before episodes were replayed kept them whole.
    let running = match carry.has("running.len") {
        true => carry.get_episodes("running", shape)?,
        false => {
            let replayer = env.replayer();
            let mut eps = Vec::with_capacity(since.len());
            for (i, acts) in since.into_iter().enumerate() {
                eps.push(replayed(&replayer, shape, i, env.episode_numbers()[i], acts, false).map_err(|e| bad(e.to_string()))?);
            }
            eps
        }
    };
    running.iter().try_for_each(|ep| ep.check(shape, false)).map_err(bad)?;
    buffer.check(shape).map_err(bad)?;
    actor.set_state(carry.get_f32s("actor.h")?, carry.get_actions("actor.last", shape.n_actions)?)?;
    let pending = carry.get_u64s("pending")?.first().copied().unwrap_or(0);
    Ok((running, pending, carry.get_stats("last")?))
}

/// A Q-learners' resume's carry, and its journal with the buffer it gave back.
type Kept = (Carry, (Journal, ReplayBuffer));

/// What a Q-learners' resume in `dir` goes on with exactly: its carry, and its journal with
/// the replay buffer played again from it; `None` where either is gone, or under another game
/// (`--set` changed a rule, the data or the opponent), whose episodes would be replayed into
/// other games: the run then goes on with fresh episodes and a new buffer.
fn kept_q(cfg: &Config, dir: &std::path::Path, st: &RunState, monitor: &mut Monitor) -> Result<Option<Kept>, Error> {
    if !st.played_config(dir)?.same_game(cfg) {
        return Ok(None);
    }
    let Some(carry) = Carry::load(&st.files(dir), st.t_env)? else { return Ok(None) };
    // Checked before thousands of episodes are played again on the wrong lanes.
    carry.check_lanes(cfg.envs)?;
    // The run's environments as they were seeded, which played the kept episodes.
    let kept_env = monitor.kept_env()?;
    let (replayer, shape) = (kept_env.replayer(), Shape::of(&kept_env));
    let rebuild = |p: &journal::Played| rebuild_episode(&replayer, &shape, p);
    let Some(journal) = Journal::resume(dir, cfg.buffer_size, st.episodes, &rebuild)? else { return Ok(None) };
    monitor.keep_episodes();
    Ok(Some((carry, journal)))
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
    // Features mode keeps what a resume needs to go on exactly (see `crate::carry`); the
    // image modes' frames are not kept, and they resume with fresh episodes. Neither is
    // self-play's: an episode's opponent was drawn from the pool as it was when the episode
    // began, which a resume no longer has.
    let exact = opts.out.as_ref().filter(|_| !cfg.obs.images() && !cfg.self_play());
    let kept = match (exact, &start) {
        (Some(dir), Some(st)) => kept_q(cfg, dir, st, &mut monitor)?,
        _ => None,
    };
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
    // One batch's memory for every update (see `Batch::refill`).
    let mut batch = Batch::default();
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
    monitor.start_self_play(&learner.nets, learner.updates, start.is_some(), &mut env)?;
    let mut journal = match kept {
        Some((carry, (journal, kept_buffer))) => {
            let resume = exact.zip(start.as_ref()).map(|(d, st)| st.files(d)).unwrap_or_default();
            (running, pending, last) = restore_q(&carry, &kept_buffer, &mut env, &mut actor, &shape, &resume)?;
            buffer = kept_buffer;
            Some(journal)
        }
        None => match exact {
            Some(dir) => Some(if start.is_some() {
                Journal::create_at(dir, cfg.buffer_size, episodes)?
            } else {
                Journal::create(dir, cfg.buffer_size)?
            }),
            None => None,
        },
    };
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
        let (done, ended) =
            end_episodes(&env.buffers, env.episode_numbers(), &shape, &mut running, &mut monitor, journal.as_mut(), &mut buffer)?;
        episodes += ended;
        pending += ended;
        actor.reset_envs(&done, a);
        while pending >= cfg.episodes_per_update {
            pending -= cfg.episodes_per_update;
            if buffer.len() >= cfg.batch_size {
                last = learn(cfg, &shape, &mut learner, &buffer, &mut batch, &mut sample_rng, (source.is_some(), episodes))?;
            }
        }
        let nets = &learner.nets;
        let mut save = |dir: &std::path::Path| checkpoint::save(dir, nets, cfg, &shape, &opts.scenario.name);
        let tested = monitor.after_step(t_env, (episodes, learner.updates), eps, &last, nets, &mut save)?;
        if tested && let Some(dir) = &opts.out {
            let rngs = (act_rng.get_word_pos(), sample_rng.get_word_pos());
            let lanes = Lanes { env: &env, running: &running, actor: &actor, pending, last: &last };
            checkpoint(dir, opts.seed, (t_env, episodes), rngs, &learner, &monitor, journal.as_mut(), &lanes)?;
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
    if let Some(j) = journal {
        j.remove()?;
    }
    let summary = Summary { t_env, episodes, updates: learner.updates, last_loss: last.loss, tests: monitor.tests, phases: Vec::new() };
    Ok((learner, summary))
}
