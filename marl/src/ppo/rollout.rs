//! On-policy rollouts: `rollout_len` steps of all `envs` environments, stored time-major
//! (`T x R` rows, `R = envs x agents`), the advantages computed on them with GAE, and the
//! rollout cut into the chunks the recurrent networks learn on.
//!
//! The MAPPO repository's recurrent training: each row's `T` steps are cut into chunks of
//! `data_chunk_length` (`L`) steps, and each chunk is unrolled from the hidden state recorded
//! while acting at its first step. A chunk is thus a fixed-length sequence whatever the
//! episodes' lengths, so one update unrolls `L` GRU steps (not `T`) over `T/L x R` sequences
//! at once: few large tensor operations instead of many small ones. Episodes that start
//! inside a chunk zero the hidden state there, as acting did.
//!
//! The vector environment resets on its own, so the observation after a time-out is gone:
//! a truncated episode's last step is treated as terminal (no bootstrap from its final
//! value), which biases the values of states near the time limit low. Once the environment
//! reports final observations, GAE can bootstrap truncations from them.

use crate::Error;
use crate::frames::{FrameTensors, StepFrames, concat_steps};
use crate::kernels::Input;
use candle_core::{Device, Tensor};
use std::sync::Arc;

/// The additive logit mask of an unavailable action: finite, so masked rows stay finite,
/// and so large that its probability underflows to exactly 0 in f32.
pub const MASKED: f32 = -1e10;

/// One rollout of `t` steps over `rows` rows (`envs x agents`, environment-major).
#[derive(Clone, Debug, Default)]
pub struct Rollout {
    pub t: usize,
    pub rows: usize,
    pub n_agents: usize,
    /// `T x R x` actor input width.
    pub actor_in: Vec<f32>,
    /// `T x R` critic input rows (factored: one state per environment step in MAPPO).
    pub critic: CriticRows,
    /// `T x R x n_actions`: 0 where available, [`MASKED`] where not.
    pub mask: Vec<f32>,
    pub actions: Vec<u32>,
    /// `T x R`: the log-probability of the action taken, under the acting policy.
    pub logp: Vec<f32>,
    /// `(T + 1) x R`: the critic's outputs (normalised scale); the last row is the bootstrap
    /// value of the state after the rollout.
    pub values: Vec<f32>,
    /// `T x R`: 1 where the agent had a choice (more than one available action). Dead agents
    /// (only the no-op) are left out of the losses, as MAPPO's active masks do.
    pub active: Vec<f32>,
    /// `T x R`: 0 where an episode starts at this step (the hidden state was reset before it).
    pub keep: Vec<f32>,
    /// `T x envs`: the team's reward and whether the step ended the episode.
    pub reward: Vec<f32>,
    pub done: Vec<f32>,
    /// `T/L x R x hidden`: hidden states at the chunks' first steps.
    pub h_actor: Vec<f32>,
    pub h_critic: Vec<f32>,
    /// Image modes: each step's observations of the `envs` environments (the agents of an
    /// environment share them); empty in `features` mode.
    pub frames: Vec<StepFrames>,
}

impl Rollout {
    /// Empties the rollout, keeping its allocations.
    pub fn clear(&mut self) {
        self.t = 0;
        self.critic.clear();
        for v in [
            &mut self.actor_in,
            &mut self.mask,
            &mut self.logp,
            &mut self.values,
            &mut self.active,
            &mut self.keep,
            &mut self.reward,
            &mut self.done,
            &mut self.h_actor,
            &mut self.h_critic,
        ] {
            v.clear();
        }
        self.actions.clear();
        self.frames.clear();
    }
}

impl Rollout {
    /// Keeps a rollout under way (features mode: no frames) in `carry`, to go on with.
    pub(crate) fn keep(&self, c: &mut crate::carry::Carry) -> Result<(), Error> {
        c.u64s("roll.dims", &[self.t as u64, self.rows as u64, self.n_agents as u64])?;
        for (name, v) in [
            ("roll.actor_in", &self.actor_in),
            ("roll.mask", &self.mask),
            ("roll.logp", &self.logp),
            ("roll.values", &self.values),
            ("roll.active", &self.active),
            ("roll.keep", &self.keep),
            ("roll.reward", &self.reward),
            ("roll.done", &self.done),
            ("roll.h_actor", &self.h_actor),
            ("roll.h_critic", &self.h_critic),
            ("roll.critic.table", self.critic.table.as_ref()),
        ] {
            c.f32s(name, v)?;
        }
        c.u32s("roll.actions", &self.actions)?;
        c.u64s("roll.critic.dims", &[self.critic.width as u64, self.critic.n_ids as u64])?;
        c.u32s("roll.critic.idx", &self.critic.idx)?;
        c.u32s("roll.critic.ids", &self.critic.ids)
    }

    /// The rollout [`Rollout::keep`] kept, checked against the run's sizes
    /// ([`Rollout::check`]).
    pub(crate) fn kept(c: &crate::carry::Carry, want: &Sizes) -> Result<Rollout, Error> {
        let roll = Rollout::read(c)?;
        roll.check(want).map_err(|m| c.bad(m))?;
        Ok(roll)
    }

    fn read(c: &crate::carry::Carry) -> Result<Rollout, Error> {
        let dims = c.get_u64s("roll.dims")?;
        let cd = c.get_u64s("roll.critic.dims")?;
        let (&[t, rows, n_agents], &[width, n_ids]) = (&dims[..], &cd[..]) else {
            return Err(c.bad("the rollout's sizes are missing".into()));
        };
        Ok(Rollout {
            t: t as usize,
            rows: rows as usize,
            n_agents: n_agents as usize,
            actor_in: c.get_f32s("roll.actor_in")?,
            critic: CriticRows {
                table: Arc::new(c.get_f32s("roll.critic.table")?),
                width: width as usize,
                n_ids: n_ids as usize,
                idx: c.get_u32s("roll.critic.idx")?,
                ids: c.get_u32s("roll.critic.ids")?,
            },
            mask: c.get_f32s("roll.mask")?,
            actions: c.get_u32s("roll.actions")?,
            logp: c.get_f32s("roll.logp")?,
            values: c.get_f32s("roll.values")?,
            active: c.get_f32s("roll.active")?,
            keep: c.get_f32s("roll.keep")?,
            reward: c.get_f32s("roll.reward")?,
            done: c.get_f32s("roll.done")?,
            h_actor: c.get_f32s("roll.h_actor")?,
            h_critic: c.get_f32s("roll.h_critic")?,
            frames: Vec::new(),
        })
    }
}

/// What a rollout kept for a resume must measure, from the run's own settings.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sizes {
    pub rows: usize,
    pub n_agents: usize,
    pub envs: usize,
    pub n_actions: usize,
    pub rollout_len: usize,
    pub chunk: usize,
    pub hidden: usize,
    pub actor_width: usize,
    /// The critic's table width and id count; `None` with a shared trunk (no rows of its own).
    pub critic: Option<(usize, usize)>,
}

impl Rollout {
    /// Whether this rollout (read back from a resume's files) fits a run of `want`: every
    /// array as long as its steps make it, every action and critic row in range. The error
    /// says what does not fit.
    pub(crate) fn check(&self, want: &Sizes) -> Result<(), String> {
        if (self.rows, self.n_agents) != (want.rows, want.n_agents) {
            return Err(format!(
                "the rollout kept has {} rows of {} agents; the run has {} of {}",
                self.rows, self.n_agents, want.rows, want.n_agents
            ));
        }
        if self.t >= want.rollout_len {
            return Err(format!(
                "the rollout kept has {} steps; rollout_len is {} (a resume cannot shorten a rollout under way)",
                self.t, want.rollout_len
            ));
        }
        let n = self.t * want.rows;
        let hidden = self.t.div_ceil(want.chunk.max(1)) * want.rows * want.hidden;
        let critic_rows = if want.critic.is_some() { n } else { 0 };
        let lens = [
            ("roll.actor_in", self.actor_in.len(), n * want.actor_width),
            ("roll.mask", self.mask.len(), n * want.n_actions),
            ("roll.actions", self.actions.len(), n),
            ("roll.logp", self.logp.len(), n),
            ("roll.values", self.values.len(), n),
            ("roll.active", self.active.len(), n),
            ("roll.keep", self.keep.len(), n),
            ("roll.reward", self.reward.len(), self.t * want.envs),
            ("roll.done", self.done.len(), self.t * want.envs),
            ("roll.h_actor", self.h_actor.len(), hidden),
            ("roll.h_critic", self.h_critic.len(), if want.critic.is_some() { hidden } else { 0 }),
            ("roll.critic.idx", self.critic.idx.len(), critic_rows),
            ("roll.critic.ids", self.critic.ids.len(), critic_rows),
        ];
        for (name, got, wanted) in lens {
            if got != wanted {
                return Err(format!("`{name}` holds {got} values; {} steps of this run make {wanted}", self.t));
            }
        }
        if let Some(x) = self.actions.iter().find(|&&x| x as usize >= want.n_actions) {
            return Err(format!("`roll.actions` holds action {x}; the team has {}", want.n_actions));
        }
        if let (Some((width, n_ids)), true) = (want.critic, critic_rows > 0) {
            let c = &self.critic;
            if (c.width, c.n_ids) != (width, n_ids) {
                return Err(format!(
                    "the critic's rows kept are {} wide with {} ids; the run's are {width} with {n_ids}",
                    c.width, c.n_ids
                ));
            }
            let table_rows = c.table.len() / width.max(1);
            if !c.table.len().is_multiple_of(width.max(1))
                || c.idx.iter().any(|&i| i as usize >= table_rows)
                || c.ids.iter().any(|&i| i as usize >= n_ids)
            {
                return Err(format!("the critic's rows kept point past its table of {table_rows} rows or its {n_ids} ids"));
            }
        }
        Ok(())
    }
}

/// Generalised advantage estimation over `T` steps of `rows` independent rows:
/// `rewards` and `dones` `T x rows`, `values` `(T + 1) x rows` (the last row bootstraps the
/// step after the rollout). A done step neither bootstraps nor passes advantages back across
/// the reset that follows it. Returns the advantages; the value targets are `A + V`.
pub fn gae(rewards: &[f32], values: &[f32], dones: &[f32], rows: usize, gamma: f64, lambda: f64) -> Vec<f32> {
    let t = rewards.len() / rows.max(1);
    let mut adv = vec![0f32; t * rows];
    for r in 0..rows {
        let mut next = 0f64;
        for ti in (0..t).rev() {
            let i = ti * rows + r;
            let not_done = 1.0 - f64::from(dones[i]);
            let delta = f64::from(rewards[i]) + gamma * f64::from(values[i + rows]) * not_done - f64::from(values[i]);
            next = delta + gamma * lambda * not_done * next;
            adv[i] = next as f32;
        }
    }
    adv
}

/// The critic's input rows, factored as the kernels' [`Input::Shared`] reads them: row `r` is
/// `table[idx[r]]` (`width` values) followed by the one-hot of `ids[r]` (`n_ids` wide).
///
/// MAPPO's critic sees the global state and the agent's id, so all agents of an environment
/// step share one table row: a rollout keeps one state per environment step instead of one
/// per agent (on pvz_ht, 23 times less), and its batches share the table instead of copying
/// it. IPPO's table holds each agent's observation, one row per row.
#[derive(Clone, Debug, Default)]
pub struct CriticRows {
    /// `(table rows, width)`; shared (not copied) by the batches cut from a rollout.
    pub table: Arc<Vec<f32>>,
    pub width: usize,
    pub n_ids: usize,
    pub idx: Vec<u32>,
    pub ids: Vec<u32>,
}

impl CriticRows {
    /// The number of rows.
    pub fn len(&self) -> usize {
        self.idx.len()
    }
    pub fn is_empty(&self) -> bool {
        self.idx.is_empty()
    }

    /// The rows as the kernels take them.
    pub fn input(&self) -> Input<'_> {
        Input::Shared { table: &self.table, width: self.width, idx: &self.idx, ids: &self.ids }
    }

    /// The rows written out, `(rows, width + n_ids)` (the reference loss's input).
    pub fn dense(&self) -> Vec<f32> {
        let w = self.width + self.n_ids;
        let mut out = vec![0f32; self.len() * w];
        for ((row, &i), &id) in out.chunks_exact_mut(w.max(1)).zip(&self.idx).zip(&self.ids) {
            row[..self.width].copy_from_slice(&self.table[i as usize * self.width..][..self.width]);
            row[self.width + id as usize] = 1.0;
        }
        out
    }

    /// Appends `step`'s rows (and its table rows) after these.
    pub fn extend(&mut self, step: &CriticRows) {
        let base = (self.table.len() / self.width.max(1)) as u32;
        (self.width, self.n_ids) = (step.width, step.n_ids);
        // Unshared once the previous update's batches are gone: no copy.
        Arc::make_mut(&mut self.table).extend_from_slice(&step.table);
        self.idx.extend(step.idx.iter().map(|&i| base + i));
        self.ids.extend_from_slice(&step.ids);
    }

    /// Empties the rows, keeping the allocations.
    pub fn clear(&mut self) {
        Arc::make_mut(&mut self.table).clear();
        self.idx.clear();
        self.ids.clear();
    }

    /// These `T x R` rows as a batch's `(L, T/L * R)` ([`to_chunks`]), sharing the table.
    fn chunked(&self, t: usize, rows: usize, chunk: usize) -> CriticRows {
        CriticRows {
            table: Arc::clone(&self.table),
            width: self.width,
            n_ids: self.n_ids,
            idx: to_chunks(&self.idx, t, rows, chunk),
            ids: to_chunks(&self.ids, t, rows, chunk),
        }
    }
}

/// Rows of `T x R x width` (time-major) rearranged into `L x (T/L * R) x width`: step `l` of
/// every chunk, chunk-major then row, so sequence `c * R + r` is row `r`'s chunk `c`.
pub fn to_chunks<T: Copy>(data: &[T], t: usize, rows: usize, chunk: usize) -> Vec<T> {
    let width = data.len() / (t * rows).max(1);
    let n_chunks = t / chunk.max(1);
    let block = rows * width;
    let mut out = Vec::with_capacity(data.len());
    for l in 0..chunk {
        for c in 0..n_chunks {
            let ti = c * chunk + l;
            out.extend_from_slice(&data[ti * block..(ti + 1) * block]);
        }
    }
    out
}

/// One update's data, flat: `L` steps of `N` chunk sequences, time-major `(L, N, width)`
/// (the fused networks' layout). [`PpoBatch`] is the same as candle tensors.
#[derive(Debug, Clone, Default)]
pub struct FlatBatch {
    pub l: usize,
    pub n: usize,
    pub actor_in: Vec<f32>,
    /// `(L, N)` rows.
    pub critic: CriticRows,
    /// `(L, N, n_actions)` additive mask.
    pub mask: Vec<f32>,
    /// `(L, N)` each.
    pub actions: Vec<u32>,
    pub old_logp: Vec<f32>,
    pub adv: Vec<f32>,
    pub old_values: Vec<f32>,
    pub targets: Vec<f32>,
    pub active: Vec<f32>,
    pub keep: Vec<f32>,
    /// `(N, hidden)`.
    pub h_actor: Vec<f32>,
    pub h_critic: Vec<f32>,
    /// Image modes: the rollout's `T x envs` observations (u8, shared by the mini-batches),
    /// and `(L, N)` the one each chunk step's row sees.
    pub frames: Option<(Arc<StepFrames>, Vec<u32>)>,
}

impl FlatBatch {
    /// Chunks a finished rollout; `adv` (normalised advantages) and `targets` (normalised
    /// value targets) are `T x R`.
    pub fn new(r: &Rollout, adv: &[f32], targets: &[f32], chunk: usize) -> Result<FlatBatch, Error> {
        let (t, rows) = (r.t, r.rows);
        let l = chunk.max(1);
        let n = t / l * rows;
        let seq = |data: &[f32]| to_chunks(data, t, rows, l);
        let frames = if r.frames.is_empty() {
            None
        } else {
            if r.frames.len() != t {
                return Err(Error::Observation { message: format!("a rollout of {t} steps holds {} steps of frames", r.frames.len()) });
            }
            let (envs, a) = (r.frames[0].n, r.n_agents.max(1));
            if envs * a != rows {
                return Err(Error::Observation { message: format!("frames of {envs} environments for {rows} rows of {a} agents") });
            }
            // Sequence `c * R + row`, step `l`: rollout step `c * L + l`, its row's environment.
            let mut idx = Vec::with_capacity(l * n);
            for li in 0..l {
                for c in 0..t / l {
                    idx.extend((0..rows).map(|row| ((c * l + li) * envs + row / a) as u32));
                }
            }
            Some((Arc::new(concat_steps(&r.frames)?), idx))
        };
        let actions: Vec<f32> = r.actions.iter().map(|&a| a as f32).collect();
        Ok(FlatBatch {
            l,
            n,
            actor_in: seq(&r.actor_in),
            critic: r.critic.chunked(t, rows, l),
            mask: seq(&r.mask),
            actions: seq(&actions).into_iter().map(|a| a as u32).collect(),
            old_logp: seq(&r.logp),
            adv: seq(adv),
            old_values: seq(&r.values[..t * rows]),
            targets: seq(targets),
            active: seq(&r.active),
            keep: seq(&r.keep),
            h_actor: r.h_actor.clone(),
            h_critic: r.h_critic.clone(),
            frames,
        })
    }

    /// The number of sequences.
    pub fn len(&self) -> usize {
        self.n
    }
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The sequences `idx` (a mini-batch), in that order.
    pub fn select(&self, idx: &[u32]) -> FlatBatch {
        let (l, n, m) = (self.l, self.n, idx.len());
        fn pick<T: Copy>(data: &[T], l: usize, n: usize, idx: &[u32]) -> Vec<T> {
            let w = data.len() / (l * n).max(1);
            let mut out = Vec::with_capacity(l * idx.len() * w);
            for t in 0..l {
                for &i in idx {
                    let at = (t * n + i as usize) * w;
                    out.extend_from_slice(&data[at..at + w]);
                }
            }
            out
        }
        FlatBatch {
            l,
            n: m,
            actor_in: pick(&self.actor_in, l, n, idx),
            critic: CriticRows {
                table: Arc::clone(&self.critic.table),
                width: self.critic.width,
                n_ids: self.critic.n_ids,
                idx: pick(&self.critic.idx, l, n, idx),
                ids: pick(&self.critic.ids, l, n, idx),
            },
            mask: pick(&self.mask, l, n, idx),
            actions: pick(&self.actions, l, n, idx),
            old_logp: pick(&self.old_logp, l, n, idx),
            adv: pick(&self.adv, l, n, idx),
            old_values: pick(&self.old_values, l, n, idx),
            targets: pick(&self.targets, l, n, idx),
            active: pick(&self.active, l, n, idx),
            keep: pick(&self.keep, l, n, idx),
            h_actor: pick(&self.h_actor, 1, n, idx),
            h_critic: pick(&self.h_critic, 1, n, idx),
            frames: self.frames.as_ref().map(|(f, i)| (Arc::clone(f), pick(i, l, n, idx))),
        }
    }

    /// As candle tensors (the reference loss's input).
    pub fn tensors(&self, hidden: usize) -> Result<PpoBatch, Error> {
        let (l, n) = (self.l, self.n);
        let dev = Device::Cpu;
        let seq = |data: &[f32]| -> Result<Tensor, Error> {
            let width = data.len() / (l * n).max(1);
            Ok(Tensor::from_slice(data, (l, n, width), &dev)?)
        };
        Ok(PpoBatch {
            actor_in: seq(&self.actor_in)?,
            critic_in: seq(&self.critic.dense())?,
            mask: seq(&self.mask)?,
            actions: Tensor::from_slice(&self.actions, (l, n, 1), &dev)?,
            old_logp: seq(&self.old_logp)?,
            adv: seq(&self.adv)?,
            old_values: seq(&self.old_values)?,
            targets: seq(&self.targets)?,
            active: seq(&self.active)?,
            keep: seq(&self.keep)?,
            h_actor: Tensor::from_slice(&self.h_actor, (n, hidden), &dev)?,
            // Empty when the critic is a head on the actor's trunk.
            h_critic: Tensor::from_slice(&self.h_critic, (n, if self.h_critic.is_empty() { 0 } else { hidden }), &dev)?,
            frames: self.frames.as_ref().map(|(f, i)| Ok::<_, Error>((f.tensors()?, Tensor::from_slice(i, (l, n), &dev)?))).transpose()?,
        })
    }
}

/// One update's data as candle tensors, `L` steps of `N` chunk sequences: the input of the
/// reference loss ([`crate::ppo::PpoLearner::loss`]).
#[derive(Debug, Clone)]
pub struct PpoBatch {
    /// `(L, N, width)`.
    pub actor_in: Tensor,
    pub critic_in: Tensor,
    /// `(L, N, n_actions)` additive mask.
    pub mask: Tensor,
    /// `(L, N, 1)` (u32).
    pub actions: Tensor,
    /// `(L, N, 1)` each.
    pub old_logp: Tensor,
    pub adv: Tensor,
    pub old_values: Tensor,
    pub targets: Tensor,
    pub active: Tensor,
    pub keep: Tensor,
    /// `(N, hidden)`.
    pub h_actor: Tensor,
    pub h_critic: Tensor,
    /// Image modes: the rollout's `T x envs` observations, and `(L, N)` (u32) the one each
    /// chunk step's row sees.
    pub frames: Option<(FrameTensors, Tensor)>,
}

impl PpoBatch {
    /// Chunks a finished rollout ([`FlatBatch::new`]) into tensors.
    pub fn new(r: &Rollout, adv: &[f32], targets: &[f32], chunk: usize, hidden: usize) -> Result<PpoBatch, Error> {
        FlatBatch::new(r, adv, targets, chunk)?.tensors(hidden)
    }

    /// The number of sequences.
    pub fn len(&self) -> usize {
        self.h_actor.dim(0).unwrap_or(0)
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every chunk step's row sees the frame of its own rollout step and environment: the
    /// frames' indices follow the chunks' layout.
    #[test]
    fn chunk_rows_see_their_own_step_and_environment() -> Result<(), Error> {
        let (t, envs, agents, l) = (6, 3, 2, 3);
        let rows = envs * agents;
        let code = |ti: usize, x: usize| (ti * 10 + x) as f32;
        let mut r = Rollout { t, rows, n_agents: agents, ..Rollout::default() };
        for ti in 0..t {
            for row in 0..rows {
                r.actor_in.push(code(ti, row));
                r.mask.push(0.0);
                r.actions.push(0);
                r.logp.push(0.0);
                r.values.push(0.0);
                r.active.push(1.0);
                r.keep.push(1.0);
            }
            r.reward.extend(std::iter::repeat_n(0.0, envs));
            r.done.extend(std::iter::repeat_n(0.0, envs));
            let px: Vec<u8> = (0..envs).flat_map(|e| [(ti * 10 + e) as u8; 3]).collect();
            r.frames.push(StepFrames::from_pixels(envs, ((1, 1), (1, 1)), px.clone(), px));
        }
        r.values.extend(std::iter::repeat_n(0.0, rows));
        r.h_actor = vec![0.0; t / l * rows];
        r.h_critic = r.h_actor.clone();
        let zeros = vec![0.0; t * rows];
        let b = PpoBatch::new(&r, &zeros, &zeros, l, 1)?;
        let (frames, idx) = b.frames.as_ref().ok_or_else(|| Error::Observation { message: "no frames".into() })?;
        let pixels: Vec<f32> = frames.screen.flatten_all()?.to_vec1()?; // (T * envs) x 3
        let idx: Vec<Vec<u32>> = idx.to_vec2()?;
        let inputs: Vec<Vec<Vec<f32>>> = b.actor_in.to_vec3()?;
        assert_eq!((idx.len(), idx[0].len()), (l, t / l * rows));
        for (li, row_idx) in idx.iter().enumerate() {
            for (n, &i) in row_idx.iter().enumerate() {
                let input = inputs[li][n][0] as usize;
                let (ti, row) = (input / 10, input % 10);
                let seen = (pixels[i as usize * 3] * 255.0).round() as usize;
                assert_eq!(seen, ti * 10 + row / agents, "step {li} of sequence {n}");
            }
        }
        // A mini-batch keeps each sequence's frames.
        let part = FlatBatch::new(&r, &zeros, &zeros, l)?.select(&[4, 1]);
        let part_idx = part.frames.as_ref().map(|(_, i)| i.clone()).unwrap_or_default();
        for li in 0..l {
            assert_eq!(part_idx[li * 2..li * 2 + 2], [idx[li][4], idx[li][1]]);
        }
        Ok(())
    }
}
