//! PyMARL's `QLearner` for IQL, VDN and QMIX (and its `QTranLearner`, whose loss is in
//! [`crate::qtran`]): the agent network unrolled over a batch of episodes, chosen-action
//! Q-values mixed (or not), double-Q targets from the target networks (one-step, or
//! PyMARL2's TD(lambda)), masked squared TD error, RMSprop or Adam with global-norm clipping,
//! and target copies every `target_update_interval` episodes.
//!
//! IQL, VDN and QMIX train on flat parameter vectors through the fused kernels (agent
//! network, mixer, loss and optimiser by hand: [`crate::kernels`], and [`fused`] here); the
//! candle networks in [`Nets`] hold the same weights after every update and are the
//! reference the gradient tests hold the kernels to ([`Learner::gradients`] computes both).
//! QTRAN, whose mixer reads the GRU's hidden states, trains through candle.

mod fused;

use crate::buffer::{Batch, BatchTensors, Shape};
use crate::optim::{Optimizer, OptimizerKind};
use crate::td::MASKED;
use crate::{Config, Error};
use candle_core::{D, Tensor};
use fused::FlatState;

// These were defined here; their old paths stay valid.
pub use crate::acting::select_actions;
pub use crate::nets::Nets;
pub use crate::td::{QGrads, td_targets, td_targets_flat};

/// Statistics of one update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UpdateStats {
    pub loss: f64,
    pub grad_norm: f64,
    pub td_abs: f64,
    pub q_taken: f64,
    /// PPO only (the TensorBoard log's): the policy's entropy and surrogate loss, and the
    /// critic's gradient norm before clipping.
    pub entropy: Option<f64>,
    pub policy_loss: Option<f64>,
    pub critic_grad_norm: Option<f64>,
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

    /// The optimiser's running state, kept across a resume (`None` for QTRAN, whose
    /// candle optimiser starts afresh).
    pub(crate) fn moments(&self) -> Option<crate::kernels::Moments> {
        self.flat.as_ref().map(FlatState::moments)
    }

    /// Takes up a saved optimiser state (see [`Learner::moments`]).
    pub(crate) fn set_moments(&mut self, m: crate::kernels::Moments) -> Result<(), String> {
        match &mut self.flat {
            Some(f) => f.set_moments(m),
            None => Err("QTRAN's optimiser keeps no state across a resume".into()),
        }
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
            return crate::qtran::loss(&self.cfg, self.shape.n_agents, (&self.nets, &self.target), batch);
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
            return f.gradients(&self.cfg, &self.shape, (&self.nets, &self.target), batch);
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
                UpdateStats { loss: g.loss, grad_norm, td_abs: g.td_abs, q_taken: g.q_taken, ..UpdateStats::default() }
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
                UpdateStats { loss: loss_v, grad_norm, td_abs, q_taken, ..UpdateStats::default() }
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
