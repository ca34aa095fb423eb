//! PyMARL's episode replay buffer: whole episodes kept (the GRU needs the sequence), the
//! oldest dropped past `buffer_size`, batches of episodes padded to the longest one with a
//! `filled` mask. Inputs are built here once per batch (observation, agent id one-hot, last
//! action one-hot), shared by the online and target networks.

use crate::frames::{Frames, StepFrames, sizes};
use crate::{Config, Error};
use candle_core::{Device, Tensor};
use rand::seq::index::sample;
use rand_chacha::ChaCha8Rng;

/// Sizes of one team: agents, observation, state and action counts, and enemies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shape {
    pub n_agents: usize,
    pub obs: usize,
    pub state: usize,
    pub n_actions: usize,
    /// The other team's units in the scenario (the vision-text slots; 0 in checkpoints
    /// older than the field).
    #[serde(default)]
    pub n_enemies: usize,
}

impl Shape {
    /// Team 1's sizes in `env`.
    pub fn of(env: &avacraft_engine::VecEnv) -> Shape {
        let (n_agents, obs, state, n_actions) = env.shape();
        let n_enemies = env.envs().first().map_or(0, |e| e.scenario().count(avacraft_engine::Team::Two));
        Shape { n_agents, obs, state, n_actions, n_enemies }
    }

    /// The sizes the networks read when they stack `k` steps' observations and states
    /// ([`crate::Stack`]).
    pub fn stacked(&self, k: usize) -> Shape {
        Shape { obs: self.obs * k.max(1), state: self.state * k.max(1), ..*self }
    }

    /// The agent network's input width.
    pub fn input(&self, agent_id: bool, last_action: bool) -> usize {
        self.obs + if agent_id { self.n_agents } else { 0 } + if last_action { self.n_actions } else { 0 }
    }
}

/// One finished episode of `len` steps; observations, states and masks have `len + 1` rows
/// (the last one after the final step, a placeholder: see [`Episode::close`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Episode {
    pub len: usize,
    pub obs: Vec<f32>,
    pub state: Vec<f32>,
    pub avail: Vec<u8>,
    pub actions: Vec<u32>,
    pub reward: Vec<f32>,
    pub terminated: Vec<f32>,
    /// Image modes: the step's frames (empty in `features` mode).
    pub frames: Frames,
}

impl Episode {
    /// Records the step's observation, state, masks and chosen actions.
    pub fn push_step(&mut self, obs: &[f32], state: &[f32], avail: &[u8], actions: &[u32]) {
        self.obs.extend_from_slice(obs);
        self.state.extend_from_slice(state);
        self.avail.extend_from_slice(avail);
        self.actions.extend_from_slice(actions);
        self.len += 1;
    }
    /// Records the step's outcome.
    pub fn push_outcome(&mut self, reward: f32, terminated: bool) {
        self.reward.push(reward);
        self.terminated.push(if terminated { 1.0 } else { 0.0 });
    }
    /// Adds the row after the last step: what the episode ended on (`last`: observations,
    /// state and masks, from the vector environment's `final_*` buffers) when it timed out,
    /// so the learner bootstraps there as PyMARL does (a time-out is not a terminal state of
    /// the game: the value of going on is not zero). A terminal step needs no row (its
    /// target does not look past it), so it gets zeros with only the no-op available.
    pub fn close(&mut self, shape: &Shape, last: Option<(&[f32], &[f32], &[u8])>) {
        match last {
            Some((obs, state, avail)) => {
                self.obs.extend_from_slice(obs);
                self.state.extend_from_slice(state);
                self.avail.extend_from_slice(avail);
            }
            None => {
                self.obs.extend(std::iter::repeat_n(0.0, shape.n_agents * shape.obs));
                self.state.extend(std::iter::repeat_n(0.0, shape.state));
                for _ in 0..shape.n_agents {
                    self.avail.push(1);
                    self.avail.extend(std::iter::repeat_n(0, shape.n_actions.saturating_sub(1)));
                }
                if let Some(t) = self.terminated.last_mut() {
                    *t = 1.0;
                }
            }
        }
        // A finished episode lives in the replay buffer for thousands of episodes: without
        // the slack its arrays grew by, a large map's buffer takes its data's size, not up to
        // twice it.
        self.obs.shrink_to_fit();
        self.state.shrink_to_fit();
        self.avail.shrink_to_fit();
        self.actions.shrink_to_fit();
        self.reward.shrink_to_fit();
        self.terminated.shrink_to_fit();
    }
}

impl Episode {
    /// The episode a lane played, from its replay ([`avacraft_engine::Replayer::replay`]) and
    /// the actions replayed (`A` a step): its rows and outcomes as the training loop recorded
    /// them, and, `closed` (it ended with its last step), closed as the loop closed it. An
    /// episode that ended where it should not have, or not where it should, is refused.
    pub(crate) fn replayed(r: avacraft_engine::Replayed, actions: Vec<u32>, shape: &Shape, closed: bool) -> Result<Episode, String> {
        match (&r.last, closed) {
            (None, true) => return Err(format!("the episode goes on after its {} steps", r.steps)),
            (Some(_), false) => return Err(format!("the episode ended at its step {}, under way when kept", r.steps)),
            _ => {}
        }
        let (ended_in_game, timed_out) = (r.terminated.last().copied(), r.truncated.last().copied());
        let mut ep = Episode {
            len: r.steps,
            obs: r.obs,
            state: r.state,
            avail: r.avail,
            actions,
            reward: r.reward,
            terminated: r.terminated.iter().map(|&t| if t { 1.0 } else { 0.0 }).collect(),
            frames: Frames::default(),
        };
        if let Some((obs, state, avail)) = r.last {
            let last = (timed_out == Some(true) && ended_in_game != Some(true)).then_some((&obs[..], &state[..], &avail[..]));
            ep.close(shape, last);
        }
        Ok(ep)
    }

    /// Whether the arrays hold what `len` steps of a team of `shape` hold (with the closing
    /// row when `closed`, and at most one step's outcome missing when not), every action one
    /// of the team's: an episode read back from a resume's files is checked before a batch
    /// indexes with it. The error says what does not fit.
    pub(crate) fn check(&self, shape: &Shape, closed: bool) -> Result<(), String> {
        let (a, o, s, na) = (shape.n_agents, shape.obs, shape.state, shape.n_actions);
        let rows = self.len + usize::from(closed);
        let want = [
            ("observations", self.obs.len(), rows * a * o),
            ("states", self.state.len(), rows * s),
            ("masks", self.avail.len(), rows * a * na),
            ("actions", self.actions.len(), self.len * a),
        ];
        for (what, got, wanted) in want {
            if got != wanted {
                return Err(format!("an episode of {} steps has {got} values of {what}, not {wanted}", self.len));
            }
        }
        let outcomes = if closed { self.len..=self.len } else { self.len.saturating_sub(1)..=self.len };
        if self.reward.len() != self.terminated.len() || !outcomes.contains(&self.reward.len()) {
            return Err(format!("an episode of {} steps has {} rewards and {} ends", self.len, self.reward.len(), self.terminated.len()));
        }
        if let Some(x) = self.actions.iter().find(|&&x| x as usize >= na) {
            return Err(format!("an episode holds action {x}; the team has {na}"));
        }
        Ok(())
    }
}

/// A ring of finished episodes.
#[derive(Debug, PartialEq)]
pub struct ReplayBuffer {
    episodes: Vec<Episode>,
    capacity: usize,
    next: usize,
}

impl ReplayBuffer {
    pub fn new(capacity: usize) -> ReplayBuffer {
        ReplayBuffer { episodes: Vec::new(), capacity: capacity.max(1), next: 0 }
    }
    /// The buffer that started empty at the run's episode `origin` after the run's `inserted`
    /// insertions, from the last of them (`(the run's insertion index, episode)`, in order):
    /// each in the slot the ring put it in.
    pub(crate) fn restored(capacity: usize, kept: Vec<(u64, Episode)>, (origin, inserted): (u64, u64)) -> ReplayBuffer {
        let capacity = capacity.max(1);
        let slot = |idx: u64| (idx.saturating_sub(origin) % capacity as u64) as usize;
        let mut slots: Vec<Option<Episode>> = vec![None; kept.len().min(capacity)];
        for (idx, ep) in kept {
            if let Some(s) = slots.get_mut(slot(idx)) {
                *s = Some(ep);
            }
        }
        ReplayBuffer { episodes: slots.into_iter().flatten().collect(), capacity, next: slot(inserted) }
    }
    /// [`Episode::check`] on every (closed) episode; the error names the first that fails.
    pub(crate) fn check(&self, shape: &Shape) -> Result<(), String> {
        self.episodes
            .iter()
            .enumerate()
            .try_for_each(|(i, ep)| ep.check(shape, true).map_err(|e| format!("episode {i} of the buffer: {e}")))
    }
    pub fn len(&self) -> usize {
        self.episodes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.episodes.is_empty()
    }
    pub fn insert(&mut self, ep: Episode) {
        if self.episodes.len() < self.capacity {
            self.episodes.push(ep);
        } else {
            self.episodes[self.next] = ep;
        }
        self.next = (self.next + 1) % self.capacity;
    }
    /// `n` distinct episodes drawn uniformly (fewer if the buffer holds fewer), longest
    /// first (ties in drawing order). The fused networks skip padding in any order; sorted,
    /// each step's running episodes are one contiguous run of rows to pack.
    pub fn sample(&self, n: usize, rng: &mut ChaCha8Rng) -> Vec<&Episode> {
        let n = n.min(self.episodes.len());
        let mut out: Vec<&Episode> = sample(rng, self.episodes.len(), n).into_iter().map(|i| &self.episodes[i]).collect();
        out.sort_by_key(|e| std::cmp::Reverse(e.len));
        out
    }
}

/// A training batch of `B` episodes padded to `T` steps, as flat time-major arrays (what the
/// fused update reads; [`Batch::tensors`] gives the same as candle tensors).
#[derive(Debug, Default)]
pub struct Batch {
    pub b: usize,
    pub t: usize,
    /// Each episode's length (steps).
    pub lens: Vec<usize>,
    pub n_agents: usize,
    /// The agent network's input width.
    pub width: usize,
    pub n_actions: usize,
    pub state_dim: usize,
    /// `(T+1, B*A, input)`.
    pub inputs: Vec<f32>,
    /// `(T+1, B*A, n_actions)`, 1.0 where available.
    pub avail: Vec<f32>,
    /// `(T, B*A)` chosen action indices.
    pub actions: Vec<u32>,
    /// `(T+1, B, state)`.
    pub state: Vec<f32>,
    /// `(T, B)`.
    pub reward: Vec<f32>,
    pub terminated: Vec<f32>,
    /// `(T, B)`: 1.0 on real steps, 0.0 on padding.
    pub filled: Vec<f32>,
    /// Image modes: the episodes' frames (set by the caller; `None` from [`Batch::new`]).
    pub frames: Option<FrameBatch>,
}

/// The frames of a batch of episodes: every real step's, episode after episode. Beside the
/// episodes it is built from, so that [`crate::frames`] needs nothing of the buffer.
#[derive(Debug, Clone)]
pub struct FrameBatch {
    pub frames: StepFrames,
    /// Steps with frames per episode.
    pub lens: Vec<usize>,
}

impl FrameBatch {
    pub fn new(episodes: &[&Episode], cfg: &Config) -> Result<FrameBatch, Error> {
        for e in episodes {
            if e.frames.len != e.len {
                return Err(Error::Observation { message: format!("an episode of {} steps holds {} frames", e.len, e.frames.len) });
            }
        }
        let stored: Vec<&Frames> = episodes.iter().map(|e| &e.frames).collect();
        let frames = StepFrames::concat_stored(&stored, sizes(cfg));
        frames.check()?;
        Ok(FrameBatch { frames, lens: episodes.iter().map(|e| e.frames.len).collect() })
    }
}

/// A [`Batch`] as candle tensors (the reference loss's and QTRAN's input).
#[derive(Debug)]
pub struct BatchTensors {
    /// `(T+1, B*A, input)`.
    pub inputs: Tensor,
    /// `(T+1, B*A, n_actions)`.
    pub avail: Tensor,
    /// `(T, B*A, 1)`.
    pub actions: Tensor,
    /// `(T+1, B, state)`.
    pub state: Tensor,
    /// `(T, B, 1)` each.
    pub reward: Tensor,
    pub terminated: Tensor,
    pub filled: Tensor,
}

/// `v` as `n` zeros, in the memory it has (a batch's arrays are refilled every update: fresh
/// ones of hundreds of MB on large scenarios were fresh mappings, each page a fault).
fn zeroed<T: Copy + Default>(v: &mut Vec<T>, n: usize) -> &mut [T] {
    v.clear();
    v.resize(n, T::default());
    v
}

/// `v` at length `n`, in the memory it has, its values left as they were: for the arrays
/// [`Batch::refill`] writes whole, row by row (zeroing them first was a pass of its own over
/// hundreds of MB on large scenarios, every update).
fn sized<T: Copy + Default>(v: &mut Vec<T>, n: usize) -> &mut [T] {
    v.resize(n, T::default());
    v
}

impl Batch {
    /// Pads and stacks `episodes`.
    pub fn new(episodes: &[&Episode], shape: &Shape, agent_id: bool, last_action: bool) -> Result<Batch, Error> {
        let mut batch = Batch::default();
        batch.refill(episodes, shape, agent_id, last_action)?;
        Ok(batch)
    }

    /// [`Batch::new`] in this batch's memory (its frames cleared).
    pub fn refill(&mut self, episodes: &[&Episode], shape: &Shape, agent_id: bool, last_action: bool) -> Result<(), Error> {
        let b = episodes.len();
        let t = episodes.iter().map(|e| e.len).max().unwrap_or(0);
        let (a, o, s, na) = (shape.n_agents, shape.obs, shape.state, shape.n_actions);
        let width = shape.input(agent_id, last_action);
        self.frames = None;
        // Every row of these three is written below, padding included.
        let inputs = sized(&mut self.inputs, (t + 1) * b * a * width);
        let avail = sized(&mut self.avail, (t + 1) * b * a * na);
        let actions = zeroed(&mut self.actions, t * b * a);
        let state = sized(&mut self.state, (t + 1) * b * s);
        let reward = zeroed(&mut self.reward, t * b);
        let terminated = zeroed(&mut self.terminated, t * b);
        let filled = zeroed(&mut self.filled, t * b);
        for (bi, ep) in episodes.iter().enumerate() {
            if ep.obs.len() < (ep.len + 1) * a * o || ep.avail.len() < (ep.len + 1) * a * na || ep.state.len() < (ep.len + 1) * s {
                return Err(Error::Observation { message: format!("an episode of {} steps is not closed (see Episode::close)", ep.len) });
            }
            for ti in 0..=t {
                let real = ti <= ep.len;
                for ag in 0..a {
                    let row = (ti * b + bi) * a + ag;
                    let inp = &mut inputs[row * width..(row + 1) * width];
                    let av = &mut avail[row * na..(row + 1) * na];
                    if real {
                        inp[..o].copy_from_slice(&ep.obs[(ti * a + ag) * o..(ti * a + ag + 1) * o]);
                        inp[o..].fill(0.0);
                        for (d, &m) in av.iter_mut().zip(&ep.avail[(ti * a + ag) * na..(ti * a + ag + 1) * na]) {
                            *d = f32::from(m);
                        }
                    } else {
                        inp.fill(0.0);
                        av.fill(0.0);
                        av[0] = 1.0;
                    }
                    let mut off = o;
                    if agent_id {
                        inp[off + ag] = 1.0;
                        off += a;
                    }
                    if last_action && ti > 0 && ti - 1 < ep.len {
                        inp[off + ep.actions[(ti - 1) * a + ag] as usize] = 1.0;
                    }
                    if ti < t && ti < ep.len {
                        actions[row] = ep.actions[ti * a + ag];
                    }
                }
                let st = &mut state[(ti * b + bi) * s..(ti * b + bi + 1) * s];
                if real {
                    st.copy_from_slice(&ep.state[ti * s..(ti + 1) * s]);
                } else {
                    st.fill(0.0);
                }
                if ti < ep.len {
                    reward[ti * b + bi] = ep.reward[ti];
                    terminated[ti * b + bi] = ep.terminated[ti];
                    filled[ti * b + bi] = 1.0;
                }
            }
        }
        (self.b, self.t, self.n_agents, self.width, self.n_actions, self.state_dim) = (b, t, a, width, na, s);
        self.lens = episodes.iter().map(|e| e.len).collect();
        Ok(())
    }

    /// The batch as candle tensors.
    pub fn tensors(&self) -> Result<BatchTensors, Error> {
        let dev = Device::Cpu;
        let (t, b, a) = (self.t, self.b, self.n_agents);
        Ok(BatchTensors {
            inputs: Tensor::from_slice(&self.inputs, (t + 1, b * a, self.width), &dev)?,
            avail: Tensor::from_slice(&self.avail, (t + 1, b * a, self.n_actions), &dev)?,
            actions: Tensor::from_slice(&self.actions, (t, b * a, 1), &dev)?,
            state: Tensor::from_slice(&self.state, (t + 1, b, self.state_dim), &dev)?,
            reward: Tensor::from_slice(&self.reward, (t, b, 1), &dev)?,
            terminated: Tensor::from_slice(&self.terminated, (t, b, 1), &dev)?,
            filled: Tensor::from_slice(&self.filled, (t, b, 1), &dev)?,
        })
    }
}

impl Batch {
    /// Each row's (`B*A`, episode-major) real steps: its episode's steps and the row after
    /// the last one (what the targets bootstrap from); the rest is padding.
    pub fn row_lens(&self) -> Vec<usize> {
        self.lens.iter().flat_map(|&len| std::iter::repeat_n((len + 1).min(self.t + 1), self.n_agents)).collect()
    }
}

/// The agent network's input rows for acting: `(rows, input)` from each row's observation,
/// its agent index and last action (`None`: none yet).
pub fn act_inputs(obs: &[f32], agents: &[usize], last: &[Option<u32>], shape: &Shape, agent_id: bool, last_action: bool) -> Vec<f32> {
    let width = shape.input(agent_id, last_action);
    let mut out = vec![0f32; agents.len() * width];
    for (r, row) in out.chunks_exact_mut(width.max(1)).enumerate() {
        row[..shape.obs].copy_from_slice(&obs[r * shape.obs..(r + 1) * shape.obs]);
        let mut off = shape.obs;
        if agent_id {
            row[off + agents[r]] = 1.0;
            off += shape.n_agents;
        }
        if last_action && let Some(a) = last[r] {
            row[off + a as usize] = 1.0;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed episode keeps no slack: the replay buffer holds thousands of them.
    #[test]
    fn a_closed_episode_holds_its_data_and_no_more() {
        let shape = Shape { n_agents: 3, obs: 7, state: 5, n_actions: 4, n_enemies: 2 };
        for timed_out in [false, true] {
            let mut ep = Episode::default();
            for t in 0..13 {
                ep.push_step(&[t as f32; 21], &[0.5; 5], &[1; 12], &[1, 2, 3]);
                ep.push_outcome(0.25, t == 12 && !timed_out);
            }
            let last = ([9.0; 21], [9.0; 5], [1u8; 12]);
            ep.close(&shape, timed_out.then_some((&last.0[..], &last.1[..], &last.2[..])));
            assert_eq!(ep.check(&shape, true), Ok(()));
            let slack = [
                ep.obs.capacity() - ep.obs.len(),
                ep.state.capacity() - ep.state.len(),
                ep.avail.capacity() - ep.avail.len(),
                ep.actions.capacity() - ep.actions.len(),
                ep.reward.capacity() - ep.reward.len(),
                ep.terminated.capacity() - ep.terminated.len(),
            ];
            assert_eq!(slack, [0; 6], "timed out: {timed_out}");
        }
    }
}
