//! PyMARL's `QLearner` for IQL, VDN and QMIX (and its `QTranLearner`, in [`crate::qtran`]):
//! the agent network unrolled over a batch of episodes, chosen-action Q-values mixed (or
//! not), double-Q targets from the target networks (one-step, or PyMARL2's TD(lambda)),
//! masked squared TD error, RMSprop or Adam with global-norm clipping, and target copies
//! every `target_update_interval` episodes.
//!
//! IQL, VDN and QMIX train on flat parameter vectors through the fused kernels (agent
//! network, mixer, loss and optimiser by hand: [`crate::kernels`], and [`fused`] here); the
//! candle networks in [`Nets`] hold the same weights after every update and are the
//! reference the gradient tests hold the kernels to ([`Learner::gradients`] computes both).
//! QTRAN, whose mixer reads the GRU's hidden states, trains through candle.

mod fused;

use crate::buffer::{Batch, BatchTensors, Shape};
use crate::nets::{AgentNet, Mixer, Params, QmixMixer};
use crate::optim::{Optimizer, OptimizerKind};
use crate::qtran::QtranMixer;
use crate::{Config, Error, MixerKind};
use candle_core::{D, Tensor};
use fused::FlatState;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Masked-out Q-values (PyMARL's -9999999): finite, so padded rows stay finite too.
pub(crate) const MASKED: f64 = -1e7;

/// An agent network and, for VDN and QMIX, a mixer, with their parameters.
#[derive(Debug)]
pub struct Nets {
    pub agent: AgentNet,
    pub agent_params: Params,
    pub mixer: Option<Mixer>,
    pub mixer_params: Params,
    /// QTRAN's joint action-value and state-value networks (in `mixer_params`).
    pub qtran: Option<QtranMixer>,
    /// Image modes: the observation encoder (its weights are in `agent_params`).
    pub encoder: Option<crate::ObsEncoder>,
}

impl Nets {
    /// Fresh networks for `cfg` and `shape`, every weight drawn from `seed`.
    pub fn new(cfg: &Config, shape: &Shape, seed: u64) -> Result<Nets, Error> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut agent_params = Params::default();
        let input = crate::encoders::agent_input_width(cfg, shape);
        let agent = if cfg.use_rnn {
            AgentNet::new(&mut agent_params, input, cfg.rnn_hidden_dim, shape.n_actions, &mut rng)?
        } else {
            AgentNet::feed_forward(&mut agent_params, input, cfg.rnn_hidden_dim, shape.n_actions, &mut rng)?
        };
        let mut mixer_params = Params::default();
        let (mut mixer, mut qtran) = (None, None);
        match cfg.mixer {
            MixerKind::None => {}
            MixerKind::Vdn => mixer = Some(Mixer::Vdn),
            MixerKind::Qmix => mixer = Some(Mixer::Qmix(QmixMixer::new(&mut mixer_params, shape.n_agents, shape.state, cfg, &mut rng)?)),
            MixerKind::Qtran => qtran = Some(QtranMixer::new(&mut mixer_params, shape, cfg, &mut rng)?),
        }
        let encoder = crate::ObsEncoder::for_config(cfg, shape, &mut agent_params, seed)?;
        Ok(Nets { agent, agent_params, mixer, mixer_params, qtran, encoder })
    }

    pub(crate) fn copy_from(&self, other: &Nets) -> Result<(), Error> {
        self.agent_params.copy_from(&other.agent_params)?;
        self.mixer_params.copy_from(&other.mixer_params)
    }

    /// Every weight as one flat vector: the agent network's, its encoder's, the mixer's.
    pub fn flat(&self) -> Result<Vec<f32>, Error> {
        let mut v = self.agent_params.flat(self.agent_params.vars().count())?;
        v.extend(self.mixer_params.flat(self.mixer_params.vars().count())?);
        Ok(v)
    }

    /// Sets every weight from a vector in [`Nets::flat`]'s layout.
    pub fn set_flat(&self, flat: &[f32]) -> Result<(), Error> {
        let n = self.agent_params.count();
        let (agent, mixer) = flat.split_at(n.min(flat.len()));
        self.agent_params.set_flat(self.agent_params.vars().count(), agent)?;
        self.mixer_params.set_flat(self.mixer_params.vars().count(), mixer)
    }

    /// Q-values `(T+1, B*A, n_actions)` of the agent network unrolled over a batch: the
    /// input layers and the output layer run on all steps at once, only the GRU step by step.
    pub fn unroll(&self, batch: &Batch) -> Result<Tensor, Error> {
        Ok(self.unroll_hidden(batch)?.0)
    }

    /// [`Nets::unroll`] and the GRU's hidden states `(T+1, B*A, hidden)` (QTRAN reads them).
    pub fn unroll_hidden(&self, batch: &Batch) -> Result<(Tensor, Tensor), Error> {
        let inputs = self.unroll_inputs(batch)?;
        let (t1, rows, width) = inputs.dims3()?;
        let gi = self.agent.project(&inputs.reshape((t1 * rows, width))?)?;
        if !self.agent.is_recurrent() {
            let q = self.agent.head(&gi)?.reshape((t1, rows, ()))?;
            return Ok((q, gi.reshape((t1, rows, ()))?));
        }
        let gi = gi.reshape((t1, rows, ()))?;
        let mut h = self.agent.zero_hidden(rows)?;
        let mut hs = Vec::with_capacity(t1);
        for ti in 0..t1 {
            h = self.agent.recur(&gi.get(ti)?, &h)?;
            hs.push(h.clone());
        }
        let hs = Tensor::stack(&hs, 0)?;
        let q = self.agent.head(&hs.reshape((t1 * rows, self.agent.hidden))?)?.reshape((t1, rows, ()))?;
        Ok((q, hs))
    }
}

/// Statistics of one update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UpdateStats {
    pub loss: f64,
    pub grad_norm: f64,
    pub td_abs: f64,
    pub q_taken: f64,
}

/// A batch's loss and gradients ([`Learner::gradients`]).
#[derive(Debug, Clone)]
pub struct QGrads {
    pub loss: f64,
    /// Every parameter's gradient in [`Nets::flat`]'s layout.
    pub grad: Vec<f32>,
    /// The mean absolute TD error and the mean chosen Q-value over real steps.
    pub td_abs: f64,
    pub q_taken: f64,
}

#[derive(Debug)]
pub struct Learner {
    pub cfg: Config,
    pub shape: Shape,
    /// The networks (for IQL, VDN and QMIX, a mirror of the flat vectors that train).
    pub nets: Nets,
    pub(crate) target: Nets,
    /// QTRAN's optimiser (candle's); the others train through `flat`.
    opt: Option<Optimizer>,
    flat: Option<FlatState>,
    pub(crate) last_target_update: u64,
    pub updates: u64,
}

impl Learner {
    pub fn new(cfg: &Config, shape: Shape, seed: u64) -> Result<Learner, Error> {
        let nets = Nets::new(cfg, &shape, seed)?;
        let target = Nets::new(cfg, &shape, seed)?;
        target.copy_from(&nets)?;
        let (opt, flat) = if nets.qtran.is_some() {
            let vars = nets.agent_params.vars().chain(nets.mixer_params.vars()).cloned().collect();
            let opt = match cfg.optimizer {
                OptimizerKind::Rmsprop => Optimizer::rmsprop(vars, cfg.lr, cfg.optim_alpha, cfg.optim_eps, cfg.grad_norm_clip)?,
                OptimizerKind::Adam => Optimizer::adam(vars, cfg.lr, cfg.optim_eps, cfg.grad_norm_clip)?,
            };
            (Some(opt), None)
        } else {
            (None, Some(FlatState::new(cfg, &shape, &nets)?))
        };
        Ok(Learner { cfg: cfg.clone(), shape, nets, target, opt, flat, last_target_update: 0, updates: 0 })
    }

    /// Reads the flat vectors back from the candle networks (after a restore).
    pub(crate) fn reload(&mut self) -> Result<(), Error> {
        if let Some(f) = &mut self.flat {
            f.theta = self.nets.flat()?;
            f.target = self.target.flat()?;
        }
        Ok(())
    }

    /// The TD loss of a batch under the current networks (and its parts), by candle's
    /// autograd all through: the reference for the fused update.
    pub fn loss(&self, batch: &Batch) -> Result<(Tensor, Tensor, Tensor), Error> {
        if self.nets.qtran.is_some() {
            return crate::qtran::loss(self, batch);
        }
        let bt = batch.tensors()?;
        self.loss_of(batch, &bt, &self.nets.unroll(batch)?, &self.target.unroll(batch)?)
    }

    /// The TD loss from the agent network's Q-values `q` and the target network's
    /// `target_q`, both `(T+1, B*A, n_actions)`.
    fn loss_of(&self, batch: &Batch, bt: &BatchTensors, q: &Tensor, target_q: &Tensor) -> Result<(Tensor, Tensor, Tensor), Error> {
        let (t, b, a) = (batch.t, batch.b, self.shape.n_agents);
        let chosen = q.narrow(0, 0, t)?.gather(&bt.actions, D::Minus1)?.reshape((t * b, a))?;
        let target_q = target_q.narrow(0, 1, t)?.detach();
        let avail_next = bt.avail.narrow(0, 1, t)?;
        let masked = |x: &Tensor| -> Result<Tensor, Error> {
            let fill = Tensor::full(MASKED as f32, x.dims(), x.device())?;
            Ok(avail_next.gt(0.0)?.where_cond(x, &fill)?)
        };
        let target_max = if self.cfg.double_q {
            let best = masked(&q.narrow(0, 1, t)?.detach())?.argmax_keepdim(D::Minus1)?;
            target_q.gather(&best, D::Minus1)?
        } else {
            masked(&target_q)?.max_keepdim(D::Minus1)?
        }
        .reshape((t * b, a))?;
        let filled = bt.filled.reshape((t * b, 1))?;
        let (chosen_tot, target_tot) = match (&self.nets.mixer, &self.target.mixer) {
            (Some(m), Some(tm)) => {
                let s = batch.state_dim;
                let st = bt.state.narrow(0, 0, t)?.reshape((t * b, s))?;
                let st1 = bt.state.narrow(0, 1, t)?.reshape((t * b, s))?;
                (m.forward(&chosen, &st)?, tm.forward(&target_max, &st1)?.detach())
            }
            _ => (chosen.clone(), target_max),
        };
        let targets = td_targets(batch, &target_tot, self.cfg.gamma, self.cfg.td_lambda)?;
        let mask = filled.broadcast_as(chosen_tot.shape())?.contiguous()?;
        let td = ((chosen_tot - targets)? * &mask)?;
        let loss = (td.sqr()?.sum_all()? / mask.sum_all()?.to_scalar::<f32>()?.max(1.0) as f64)?;
        Ok((loss, td, chosen))
    }

    /// The loss of `batch` and every parameter's gradient ([`Nets::flat`]'s layout), without
    /// changing anything: with `fused`, by the fused update (IQL, VDN, QMIX); without, by
    /// candle's autograd through the reference networks.
    pub fn gradients(&self, batch: &Batch, fused: bool) -> Result<QGrads, Error> {
        if fused && let Some(f) = &self.flat {
            return f.gradients(self, batch);
        }
        let (loss, td, chosen) = self.loss(batch)?;
        let grads = loss.backward()?;
        let mut grad = Vec::new();
        for v in self.nets.agent_params.vars().chain(self.nets.mixer_params.vars()) {
            match grads.get(v) {
                Some(g) => grad.extend(g.flatten_all()?.to_vec1::<f32>()?),
                None => grad.extend(std::iter::repeat_n(0.0, v.elem_count())),
            }
        }
        let filled: f64 = batch.filled.iter().map(|&f| f64::from(f)).sum::<f64>().max(1.0);
        let td_abs = f64::from(td.abs()?.sum_all()?.to_scalar::<f32>()?) / filled;
        let fill = Tensor::from_slice(&batch.filled, (batch.t * batch.b, 1), chosen.device())?;
        let q_taken = f64::from(chosen.broadcast_mul(&fill)?.sum_all()?.to_scalar::<f32>()?) / (filled * self.shape.n_agents as f64);
        Ok(QGrads { loss: f64::from(loss.to_scalar::<f32>()?), grad, td_abs, q_taken })
    }

    /// One gradient step on `batch`; `episodes` (finished so far) decides the target copies.
    pub fn train(&mut self, batch: &Batch, episodes: u64) -> Result<UpdateStats, Error> {
        let stats = match (&mut self.opt, self.flat.is_some()) {
            (_, true) => {
                let g = self.gradients(batch, true)?;
                check_loss(g.loss, self.updates)?;
                let Some(f) = &mut self.flat else { unreachable_flat()? };
                let grad_norm = f.step(g.grad)?;
                self.nets.set_flat(&f.theta)?;
                UpdateStats { loss: g.loss, grad_norm, td_abs: g.td_abs, q_taken: g.q_taken }
            }
            (Some(_), false) => {
                let (loss, td, chosen) = self.loss(batch)?;
                let loss_v = f64::from(loss.to_scalar::<f32>()?);
                check_loss(loss_v, self.updates)?;
                let mut grads = loss.backward()?;
                let Some(opt) = &mut self.opt else { unreachable_flat()? };
                let grad_norm = opt.step(&mut grads)?;
                let n = batch.filled.iter().map(|&f| f64::from(f)).sum::<f64>().max(1.0);
                let td_abs = f64::from(td.abs()?.sum_all()?.to_scalar::<f32>()?) / n;
                let fill = Tensor::from_slice(&batch.filled, (batch.t * batch.b, 1), chosen.device())?;
                let q_taken = f64::from(chosen.broadcast_mul(&fill)?.sum_all()?.to_scalar::<f32>()?) / (n * self.shape.n_agents as f64);
                UpdateStats { loss: loss_v, grad_norm, td_abs, q_taken }
            }
            (None, false) => unreachable_flat()?,
        };
        self.updates += 1;
        if episodes.saturating_sub(self.last_target_update) >= self.cfg.target_update_interval {
            self.update_targets()?;
            self.last_target_update = episodes;
        }
        Ok(stats)
    }

    /// Copies the networks into the targets.
    pub fn update_targets(&mut self) -> Result<(), Error> {
        if let Some(f) = &mut self.flat {
            f.target.clone_from(&f.theta);
        }
        self.target.copy_from(&self.nets)
    }

    /// The acting network's flat weights (IQL, VDN, QMIX: what trains; QTRAN: read from the
    /// candle network).
    pub(crate) fn agent_theta(&self) -> Result<std::borrow::Cow<'_, [f32]>, Error> {
        match &self.flat {
            Some(f) => Ok(std::borrow::Cow::Borrowed(&f.theta[..self.nets.agent.layout().len()])),
            None => Ok(std::borrow::Cow::Owned(self.nets.agent_params.flat(self.nets.agent.var_count())?)),
        }
    }
}

fn check_loss(loss: f64, update: u64) -> Result<(), Error> {
    if !loss.is_finite() || loss > 1e8 { Err(Error::Diverged { update, loss }) } else { Ok(()) }
}

/// A learner has either a flat state or candle's optimiser (QTRAN); never neither.
fn unreachable_flat<T>() -> Result<T, Error> {
    Err(Error::Checkpoint { message: "a learner without an optimiser".into() })
}

/// The targets (time-major rows `t * B + b`, `C` columns) of a batch from the target
/// networks' values of the next steps `next` `(T*B, C)`: `G_t = r_t + gamma (1 - d_t)
/// ((1 - lambda) V_{t+1} + lambda G_{t+1})`, with `G` of an episode's last step bootstrapped
/// from `V` alone (its time-out row, or nothing after a terminal step). `lambda = 0` gives
/// one-step targets. Plain loops: the recursion runs backwards in time, which tensors would
/// do one small op per step.
pub fn td_targets_flat(batch: &Batch, next: &[f32], c: usize, gamma: f64, lambda: f64) -> Vec<f32> {
    let (t, b) = (batch.t, batch.b);
    let (r, d, f) = (&batch.reward, &batch.terminated, &batch.filled);
    let (g32, l32) = (gamma as f32, lambda as f32);
    let mut out = vec![0f32; t * b * c];
    for bi in 0..b {
        for ti in (0..t).rev() {
            let row = ti * b + bi;
            if f[row] == 0.0 {
                continue;
            }
            let next_real = ti + 1 < t && f[row + b] != 0.0;
            for k in 0..c {
                let boot = if next_real { (1.0 - l32) * next[row * c + k] + l32 * out[(row + b) * c + k] } else { next[row * c + k] };
                out[row * c + k] = r[row] + g32 * (1.0 - d[row]) * boot;
            }
        }
    }
    out
}

/// [`td_targets_flat`] on tensors.
pub fn td_targets(batch: &Batch, next: &Tensor, gamma: f64, lambda: f64) -> Result<Tensor, Error> {
    let c = next.dim(1)?;
    let v: Vec<f32> = next.detach().flatten_all()?.to_vec1()?;
    let out = td_targets_flat(batch, &v, c, gamma, lambda);
    Ok(Tensor::from_vec(out, (batch.t * batch.b, c), next.device())?)
}

/// Epsilon-greedy over the available actions of each row of `q` (`rows x n_actions`): with
/// probability `epsilon` a uniformly random available action, else the best available one
/// (the first on ties). An unavailable action is never chosen; a row with no available
/// action gets 0 (SMAC's no-op).
pub fn select_actions(q: &[f32], avail: &[u8], n_actions: usize, epsilon: f64, rng: &mut ChaCha8Rng) -> Vec<u32> {
    q.chunks_exact(n_actions.max(1))
        .zip(avail.chunks_exact(n_actions.max(1)))
        .map(|(qr, ar)| {
            let n_avail = ar.iter().filter(|&&m| m != 0).count();
            if n_avail == 0 {
                return 0;
            }
            if epsilon > 0.0 && rng.random::<f64>() < epsilon {
                let k = rng.random_range(0..n_avail);
                return ar.iter().enumerate().filter(|(_, m)| **m != 0).nth(k).map_or(0, |(i, _)| i as u32);
            }
            let mut best: Option<(usize, f32)> = None;
            for (i, (&v, &m)) in qr.iter().zip(ar).enumerate() {
                if m != 0 && best.is_none_or(|(_, bv)| v > bv) {
                    best = Some((i, v));
                }
            }
            best.map_or(0, |(i, _)| i as u32)
        })
        .collect()
}
