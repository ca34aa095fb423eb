//! PyMARL's `QLearner` for IQL, VDN and QMIX (and its `QTranLearner`, in [`crate::qtran`]):
//! the agent network unrolled over a batch of episodes, chosen-action Q-values mixed (or
//! not), double-Q targets from the target networks (one-step, or PyMARL2's TD(lambda)),
//! masked squared TD error, RMSprop or Adam with global-norm clipping, and target copies
//! every `target_update_interval` episodes.

use crate::buffer::{Batch, Shape};
use crate::kernels::EncoderForward;
use crate::nets::{AgentNet, Mixer, Params, QmixMixer};
use crate::optim::{Optimizer, OptimizerKind};
use crate::qtran::QtranMixer;
use crate::{Config, Error, MixerKind};
use candle_core::backprop::GradStore;
use candle_core::{D, Device, Tensor, Var};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Mutex;

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

    fn copy_from(&self, other: &Nets) -> Result<(), Error> {
        self.agent_params.copy_from(&other.agent_params)?;
        self.mixer_params.copy_from(&other.mixer_params)
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

#[derive(Debug)]
pub struct Learner {
    pub cfg: Config,
    pub shape: Shape,
    pub nets: Nets,
    pub(crate) target: Nets,
    opt: Optimizer,
    pub(crate) last_target_update: u64,
    pub updates: u64,
    /// The fused encoder's buffers, kept across updates (see [`crate::kernels::conv`]).
    encoder_pass: Mutex<EncoderForward>,
}

impl Learner {
    pub fn new(cfg: &Config, shape: Shape, seed: u64) -> Result<Learner, Error> {
        let nets = Nets::new(cfg, &shape, seed)?;
        let target = Nets::new(cfg, &shape, seed)?;
        target.copy_from(&nets)?;
        let vars = nets.agent_params.vars().chain(nets.mixer_params.vars()).cloned().collect();
        let opt = match cfg.optimizer {
            OptimizerKind::Rmsprop => Optimizer::rmsprop(vars, cfg.lr, cfg.optim_alpha, cfg.optim_eps, cfg.grad_norm_clip)?,
            OptimizerKind::Adam => Optimizer::adam(vars, cfg.lr, cfg.optim_eps, cfg.grad_norm_clip)?,
        };
        Ok(Learner {
            cfg: cfg.clone(),
            shape,
            nets,
            target,
            opt,
            last_target_update: 0,
            updates: 0,
            encoder_pass: Mutex::new(EncoderForward::default()),
        })
    }

    /// The TD loss of a batch under the current networks (and its parts), by candle's
    /// autograd all through: the reference for the fused path [`Learner::train`] takes.
    pub fn loss(&self, batch: &Batch) -> Result<(Tensor, Tensor, Tensor), Error> {
        if self.nets.qtran.is_some() {
            return crate::qtran::loss(self, batch);
        }
        self.loss_of(batch, &self.nets.unroll(batch)?, &self.target.unroll(batch)?)
    }

    /// The TD loss from the agent network's Q-values `q` and the target network's
    /// `target_q`, both `(T+1, B*A, n_actions)`.
    fn loss_of(&self, batch: &Batch, q: &Tensor, target_q: &Tensor) -> Result<(Tensor, Tensor, Tensor), Error> {
        let (t, b, a) = (batch.t, batch.b, self.shape.n_agents);
        let chosen = q.narrow(0, 0, t)?.gather(&batch.actions, D::Minus1)?.reshape((t * b, a))?;
        let target_q = target_q.narrow(0, 1, t)?.detach();
        let avail_next = batch.avail.narrow(0, 1, t)?;
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
        let filled = batch.filled.reshape((t * b, 1))?;
        let (chosen_tot, target_tot) = match (&self.nets.mixer, &self.target.mixer) {
            (Some(m), Some(tm)) => {
                let s = batch.state.dim(2)?;
                let st = batch.state.narrow(0, 0, t)?.reshape((t * b, s))?;
                let st1 = batch.state.narrow(0, 1, t)?.reshape((t * b, s))?;
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

    /// The loss of `batch`, its parts and its gradients: with `fused`, the agent networks run
    /// in the fused kernels (QTRAN's, which its mixer reads the hidden states of, always in
    /// candle) and the mixer and the loss in candle; without, all in candle (the reference).
    pub fn gradients(&self, batch: &Batch, fused: bool) -> Result<(GradStore, Tensor, Tensor, Tensor), Error> {
        let poisoned = || Error::Observation { message: "a thread panicked while it held the encoder's buffers".into() };
        let mut fused = if fused && self.nets.qtran.is_none() {
            let scratch = std::mem::take(&mut *self.encoder_pass.lock().map_err(|_| poisoned())?);
            Some(FusedUnroll::run(&self.nets, batch, true, scratch)?)
        } else {
            None
        };
        let (loss, td, chosen) = match &fused {
            None => self.loss(batch)?,
            Some(f) => {
                let target = FusedUnroll::run(&self.target, batch, false, EncoderForward::default())?;
                self.loss_of(batch, f.q.as_tensor(), target.q.as_tensor())?
            }
        };
        let mut grads = loss.backward()?;
        if let Some(f) = &mut fused {
            f.backward(&self.nets, batch, &mut grads)?;
            if let Some((_, pass, _)) = f.encoded.take() {
                *self.encoder_pass.lock().map_err(|_| poisoned())? = pass;
            }
        }
        Ok((grads, loss, td, chosen))
    }

    /// One gradient step on `batch`; `episodes` (finished so far) decides the target copies.
    pub fn train(&mut self, batch: &Batch, episodes: u64) -> Result<UpdateStats, Error> {
        let (mut grads, loss, td, chosen) = self.gradients(batch, true)?;
        let loss_v = f64::from(loss.to_scalar::<f32>()?);
        if !loss_v.is_finite() || loss_v > 1e8 {
            return Err(Error::Diverged { update: self.updates, loss: loss_v });
        }
        let grad_norm = self.opt.step(&mut grads)?;
        self.updates += 1;
        if episodes.saturating_sub(self.last_target_update) >= self.cfg.target_update_interval {
            self.update_targets()?;
            self.last_target_update = episodes;
        }
        let n = batch.filled.sum_all()?.to_scalar::<f32>()?.max(1.0) as f64;
        let td_abs = f64::from(td.abs()?.sum_all()?.to_scalar::<f32>()?) / n;
        let q_taken = f64::from((chosen.broadcast_mul(&batch.filled.reshape(((), 1))?)?).sum_all()?.to_scalar::<f32>()?)
            / (n * self.shape.n_agents as f64);
        Ok(UpdateStats { loss: loss_v, grad_norm, td_abs, q_taken })
    }

    /// Copies the networks into the targets.
    pub fn update_targets(&mut self) -> Result<(), Error> {
        self.target.copy_from(&self.nets)
    }
}

/// The agent network unrolled over a batch by the fused kernels ([`crate::kernels`]): Q
/// `(T+1, B*A, n_actions)` as a leaf variable of candle's graph, so the mixer and the loss
/// stay in candle and their gradient with respect to Q comes back through
/// [`FusedUnroll::backward`] (in image modes, on into the fused CNN encoder, or the Swin
/// encoder's candle graph).
struct FusedUnroll {
    theta: Vec<f32>,
    fwd: crate::kernels::Forward,
    /// The input rows as a candle tensor with the Swin encoder's graph.
    x_graph: Option<Tensor>,
    /// The fused CNN encoder's weights, pass (with a tape) and each input row's frame.
    encoded: Option<(Vec<f32>, EncoderForward, Vec<u32>)>,
    q: Var,
}

impl FusedUnroll {
    /// `scratch`: buffers for the fused encoder's pass (see [`EncoderForward`]).
    fn run(nets: &Nets, batch: &Batch, tape: bool, mut scratch: EncoderForward) -> Result<FusedUnroll, Error> {
        let layout = nets.agent.layout();
        let (t1, rows, _) = batch.inputs.dims3()?;
        let (xv, x_graph, encoded) = match (&nets.encoder, nets.encoder.as_ref().and_then(|e| e.kernel()), &batch.frames) {
            (Some(e), Some(k), Some(fb)) => {
                let theta = nets.encoder_weights()?;
                k.forward_into(&theta, &fb.frames.pixels(), tape, &mut scratch)?;
                let row_frame = nets.unroll_frames(batch)?;
                let x = e.fuse_flat(&scratch.out, &row_frame, &batch.inputs.flatten_all()?.to_vec1()?);
                (x, None, tape.then_some((theta, scratch, row_frame)))
            }
            _ => {
                let x = nets.unroll_inputs(batch)?;
                let x_graph = (nets.encoder.is_some() && tape).then(|| x.clone());
                (x.flatten_all()?.to_vec1()?, x_graph, None)
            }
        };
        let theta = nets.agent_params.flat(nets.agent.var_count())?;
        let h0 = vec![0f32; rows * layout.hidden];
        // Rows past an episode's closing row are padding: skipped when the batch is sorted
        // longest first (`Batch::new` sorts it).
        let lens = batch.row_lens();
        let sorted = lens.windows(2).all(|w| w[0] >= w[1]);
        let fwd = layout.forward(&theta, &xv, &h0, None, sorted.then_some(&lens[..]), t1, rows, tape);
        let q = Var::from_slice(&fwd.out, (t1, rows, layout.out), &Device::Cpu)?;
        Ok(FusedUnroll { theta, fwd, x_graph, encoded, q })
    }

    /// Replaces the gradient with respect to Q in `grads` by the agent network's parameters'
    /// (and the encoder's).
    fn backward(&mut self, nets: &Nets, batch: &Batch, grads: &mut GradStore) -> Result<(), Error> {
        let layout = nets.agent.layout();
        let Some(dq) = grads.remove(self.q.as_tensor()) else { return Ok(()) };
        let dq: Vec<f32> = dq.flatten_all()?.to_vec1()?;
        let mut g = vec![0f32; layout.len()];
        let want_dx = self.x_graph.is_some() || self.encoded.is_some();
        let dx = layout.backward(&self.theta, &self.fwd, &dq, None, &mut g, want_dx);
        let mut at = 0;
        for v in nets.agent_params.vars().take(nets.agent.var_count()) {
            let n = v.elem_count();
            grads.insert(v, Tensor::from_slice(&g[at..at + n], v.shape(), &Device::Cpu)?);
            at += n;
        }
        if let (Some((theta, pass, row_frame)), Some(e), Some(k), Some(fb), Some(dx)) =
            (self.encoded.as_mut(), &nets.encoder, nets.encoder.as_ref().and_then(|e| e.kernel()), &batch.frames, dx.as_deref())
        {
            let d_feats = e.feature_grads(dx, row_frame, pass.n);
            let mut ge = vec![0f32; k.len()];
            k.backward(theta, pass, &fb.frames.pixels(), &d_feats, &mut ge);
            let mut at = 0;
            for v in nets.agent_params.vars_after(nets.agent.var_count()) {
                let n = v.elem_count();
                grads.insert(v, Tensor::from_slice(&ge[at..at + n], v.shape(), &Device::Cpu)?);
                at += n;
            }
        } else if let (Some(x), Some(dx)) = (&self.x_graph, dx) {
            let d = Tensor::from_vec(dx, x.dims(), &Device::Cpu)?;
            let enc = (x * d)?.sum_all()?.backward()?;
            for v in nets.agent_params.vars_after(nets.agent.var_count()) {
                if let Some(g) = enc.get(v) {
                    grads.insert(v, g.clone());
                }
            }
        }
        Ok(())
    }
}

/// The targets `(T*B, C)` (time-major rows) of a batch from the target networks' values of
/// the next steps `next` `(T*B, C)`: `G_t = r_t + gamma (1 - d_t) ((1 - lambda) V_{t+1} +
/// lambda G_{t+1})`, with `G` of an episode's last step bootstrapped from `V` alone (its
/// time-out row, or nothing after a terminal step). `lambda = 0` gives one-step targets.
/// Computed on the CPU in plain loops: the recursion runs backwards in time, which tensors
/// would do one small op per step.
pub fn td_targets(batch: &Batch, next: &Tensor, gamma: f64, lambda: f64) -> Result<Tensor, Error> {
    let (t, b) = (batch.t, batch.b);
    let c = next.dim(1)?;
    let v: Vec<f32> = next.detach().flatten_all()?.to_vec1()?;
    let r: Vec<f32> = batch.reward.flatten_all()?.to_vec1()?;
    let d: Vec<f32> = batch.terminated.flatten_all()?.to_vec1()?;
    let f: Vec<f32> = batch.filled.flatten_all()?.to_vec1()?;
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
                let boot = if next_real { (1.0 - l32) * v[row * c + k] + l32 * out[(row + b) * c + k] } else { v[row * c + k] };
                out[row * c + k] = r[row] + g32 * (1.0 - d[row]) * boot;
            }
        }
    }
    Ok(Tensor::from_vec(out, (t * b, c), next.device())?)
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
