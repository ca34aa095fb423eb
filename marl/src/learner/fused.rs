//! The Q-learners' update on flat parameter vectors (IQL, VDN, QMIX): the agent network
//! ([`crate::kernels::NetLayout`]) and the mixer ([`crate::kernels::MixerLayout`]) forward
//! and backward by hand, the chosen and target values, the TD loss and its gradient in
//! closed form, global-norm clipping and RMSprop or Adam, all on one vector laid out as
//! [`Nets::flat`]: agent network, encoder, mixer.
//!
//! The image encoders (candle) stay in candle: the agent network's input gradient goes back
//! through their graph, and their gradients join the flat vector for the one clip and step.
//! Every rule here follows the candle reference ([`crate::Learner::loss`]) exactly, ties
//! included (the first of equal Q-values is the greedy action, as candle's `argmax`), so the
//! two give the same gradients (`tests/it/learn.rs`).

use crate::buffer::{Batch, Shape};
use crate::kernels::{Adam, EncoderForward, MixerLayout, Moments, NetLayout, RmsProp, Want};
use crate::nets::{Mixer, Nets};
use crate::optim::OptimizerKind;
use crate::td::{MASKED, QGrads, td_targets_flat};
use crate::{Config, Error};
use candle_core::{Device, Tensor};
use std::borrow::Cow;
use std::sync::Mutex;

/// How the agents' values combine.
#[derive(Clone, Copy, Debug)]
enum MixKind {
    None,
    Vdn,
    Qmix(MixerLayout),
}

#[derive(Clone, Debug)]
enum FlatOpt {
    Rms(RmsProp),
    Adam(Adam),
}

/// The flat weights that train, their targets and their optimiser.
#[derive(Debug)]
pub(super) struct FlatState {
    /// [`Nets::flat`]'s layout.
    pub(super) theta: Vec<f32>,
    pub(super) target: Vec<f32>,
    agent: NetLayout,
    /// The encoder's weights follow the agent network's; then the mixer's.
    enc_len: usize,
    mixer: MixKind,
    opt: FlatOpt,
    clip: f64,
    /// The fused CNN encoder's buffers, kept across updates (see [`crate::kernels::conv`]).
    scratch: Mutex<EncoderForward>,
}

/// How the agent network's input rows came from an image encoder, for the backward pass.
enum Encoded {
    None,
    /// Through candle (the Swin backbone): the rows with their graph.
    Candle(Tensor),
    /// Through the fused CNN encoder: its pass (with a tape) and each row's frame.
    Fused {
        pass: EncoderForward,
        row_frame: Vec<u32>,
    },
}

impl FlatState {
    pub(super) fn new(cfg: &Config, shape: &Shape, nets: &Nets) -> Result<FlatState, Error> {
        let theta = nets.flat()?;
        let agent = nets.agent.layout();
        let enc_len = nets.agent_params.count().saturating_sub(agent.len());
        let mixer = match &nets.mixer {
            None => MixKind::None,
            Some(Mixer::Vdn) => MixKind::Vdn,
            Some(Mixer::Qmix(_)) => MixKind::Qmix(MixerLayout {
                n_agents: shape.n_agents,
                state: shape.state,
                embed: cfg.mixing_embed_dim,
                hyper_embed: cfg.hypernet_embed,
                two_layer: cfg.hypernet_layers == 2,
            }),
        };
        let mixer_len = match mixer {
            MixKind::Qmix(m) => m.len(),
            _ => 0,
        };
        if theta.len() != agent.len() + enc_len + mixer_len {
            return Err(Error::Checkpoint {
                message: format!(
                    "{} weights for an agent network of {}, an encoder of {enc_len} and a mixer of {mixer_len}",
                    theta.len(),
                    agent.len()
                ),
            });
        }
        let opt = match cfg.optimizer {
            OptimizerKind::Rmsprop => FlatOpt::Rms(RmsProp::new(theta.len(), cfg.lr, cfg.optim_alpha, cfg.optim_eps)),
            OptimizerKind::Adam => FlatOpt::Adam(Adam::new(theta.len(), cfg.lr, cfg.optim_eps)),
        };
        Ok(FlatState {
            target: theta.clone(),
            theta,
            agent,
            enc_len,
            mixer,
            opt,
            clip: cfg.grad_norm_clip,
            scratch: Mutex::new(EncoderForward::default()),
        })
    }

    pub(super) fn moments(&self) -> Moments {
        match &self.opt {
            FlatOpt::Rms(o) => o.moments(),
            FlatOpt::Adam(o) => o.moments(),
        }
    }

    pub(super) fn set_moments(&mut self, m: Moments) -> Result<(), String> {
        match &mut self.opt {
            FlatOpt::Rms(o) => o.set_moments(m),
            FlatOpt::Adam(o) => o.set_moments(m),
        }
    }

    fn mixer_range(&self) -> std::ops::Range<usize> {
        self.agent.len() + self.enc_len..self.theta.len()
    }

    /// The loss of `batch` and its gradient (see the module docs) under the learner's
    /// networks and their targets: handed in rather than the learner that owns this state,
    /// so that this module imports nothing of its parent.
    pub(super) fn gradients(&self, cfg: &Config, shape: &Shape, (nets, target): (&Nets, &Nets), batch: &Batch) -> Result<QGrads, Error> {
        let (t, b, a, na) = (batch.t, batch.b, shape.n_agents, shape.n_actions);
        let (t1, rows) = (t + 1, b * a);
        let an = self.agent.len();
        let poisoned = || Error::Observation { message: "a thread panicked while it held the encoder's buffers".into() };
        let scratch = std::mem::take(&mut *self.scratch.lock().map_err(|_| poisoned())?);
        let (x, encoded) = self.inputs(nets, &self.theta, batch, true, scratch)?;
        let xt_own;
        let xt = if nets.encoder.is_some() {
            xt_own = self.inputs(target, &self.target, batch, false, EncoderForward::default())?.0;
            &xt_own
        } else {
            &x
        };
        // Rows past an episode's closing row are padding, skipped.
        let lens = batch.row_lens();
        let h0 = vec![0f32; rows * self.agent.hidden];
        let fo = self.agent.forward(&self.theta[..an], &x, &h0, None, Want::Lens(&lens), t1, rows, true);
        let ft = self.agent.forward(&self.target[..an], xt, &h0, None, Want::Lens(&lens), t1, rows, false);
        // The chosen actions' values and the targets' values of the next step, `(T, B*A)`.
        let mut chosen = vec![0f32; t * rows];
        let mut next = vec![0f32; t * rows];
        for i in 0..t * rows {
            chosen[i] = fo.out[i * na + batch.actions[i] as usize];
            let j = i + rows;
            let (av, tq) = (&batch.avail[j * na..(j + 1) * na], &ft.out[j * na..(j + 1) * na]);
            next[i] = if cfg.double_q { tq[masked_argmax(&fo.out[j * na..(j + 1) * na], av)] } else { tq[masked_argmax(tq, av)] };
        }
        // The mixer's rows are `(t, b)` pairs, time-major: `(T*B, A)` is `(T, B*A)`.
        let n = t * b;
        let s = batch.state_dim;
        let (mt, mtt) = (&self.theta[self.mixer_range()], &self.target[self.mixer_range()]);
        let (tot, target_tot, cols, mixed) = match self.mixer {
            MixKind::None => (chosen.clone(), next, a, None),
            MixKind::Vdn => (row_sums(&chosen, a), row_sums(&next, a), 1, None),
            MixKind::Qmix(m) => {
                let f = m.forward(mt, &chosen, &batch.state[..n * s], n, true);
                let tf = m.forward(mtt, &next, &batch.state[b * s..(t + 1) * b * s], n, false);
                (f.out.clone(), tf.out, 1, Some((m, f)))
            }
        };
        let targets = td_targets_flat(batch, &target_tot, cols, cfg.gamma, cfg.td_lambda);
        let filled: f64 = batch.filled.iter().map(|&f| f64::from(f)).sum();
        let n_mask = (filled * cols as f64).max(1.0);
        let mut d_tot = vec![0f32; n * cols];
        let (mut sq, mut abs) = (0f64, 0f64);
        for r in 0..n {
            if batch.filled[r] == 0.0 {
                continue;
            }
            for c in 0..cols {
                let td = tot[r * cols + c] - targets[r * cols + c];
                sq += f64::from(td * td);
                abs += f64::from(td.abs());
                d_tot[r * cols + c] = (2.0 * f64::from(td) / n_mask) as f32;
            }
        }
        let mut grad = vec![0f32; self.theta.len()];
        let d_chosen = match (self.mixer, mixed) {
            (MixKind::Qmix(_), Some((m, f))) => {
                let range = self.mixer_range();
                m.backward(mt, &f, &d_tot, &mut grad[range])
            }
            (MixKind::Vdn, _) => d_tot.iter().flat_map(|&d| std::iter::repeat_n(d, a)).collect(),
            _ => d_tot,
        };
        let mut dq = vec![0f32; t1 * rows * na];
        for (i, &d) in d_chosen.iter().enumerate() {
            dq[i * na + batch.actions[i] as usize] = d;
        }
        let dx = self.agent.backward(&self.theta[..an], &fo, &dq, None, &mut grad[..an], !matches!(encoded, Encoded::None));
        match (encoded, dx) {
            (Encoded::Candle(xg), Some(dx)) => {
                let d = Tensor::from_vec(dx, xg.dims(), &Device::Cpu)?;
                let enc = (xg * d)?.sum_all()?.backward()?;
                let mut at = an;
                for v in nets.agent_params.vars_after(nets.agent.var_count()) {
                    let k = v.elem_count();
                    if let Some(g) = enc.get(v) {
                        grad[at..at + k].copy_from_slice(&g.flatten_all()?.to_vec1::<f32>()?);
                    }
                    at += k;
                }
            }
            (Encoded::Fused { mut pass, row_frame }, Some(dx)) => {
                let (Some(e), Some(fb)) = (&nets.encoder, &batch.frames) else { return Err(no_frames()) };
                let Some(k) = e.kernel() else { return Err(no_frames()) };
                let d_feats = e.feature_grads(&dx, &row_frame, pass.n);
                let enc = an..an + self.enc_len;
                k.backward(&self.theta[enc.clone()], &mut pass, &fb.frames.pixels(), &d_feats, &mut grad[enc]);
                *self.scratch.lock().map_err(|_| poisoned())? = pass;
            }
            _ => {}
        }
        let filled_rows = filled.max(1.0);
        let q_taken = chosen
            .chunks_exact(a.max(1))
            .zip(&batch.filled)
            .map(|(q, &f)| f64::from(f) * q.iter().map(|&v| f64::from(v)).sum::<f64>())
            .sum::<f64>()
            / (filled_rows * a as f64);
        Ok(QGrads { loss: sq / n_mask, grad, td_abs: abs / filled_rows, q_taken })
    }

    /// Clips `grad` to the global norm bound and takes one optimiser step; returns the norm
    /// before clipping.
    pub(super) fn step(&mut self, mut grad: Vec<f32>) -> Result<f64, Error> {
        let norm = grad.iter().map(|&g| f64::from(g) * f64::from(g)).sum::<f64>().sqrt();
        if !norm.is_finite() {
            return Err(Error::NonFiniteGradient { norm });
        }
        if norm > self.clip {
            let s = (self.clip / (norm + 1e-6)) as f32;
            grad.iter_mut().for_each(|g| *g *= s);
        }
        match &mut self.opt {
            FlatOpt::Rms(o) => o.step(&mut self.theta, &grad),
            FlatOpt::Adam(o) => o.step(&mut self.theta, &grad),
        }
        Ok(norm)
    }
}

impl FlatState {
    /// The agent network's input rows `(T+1, B*A, input)` of a batch, flat: as stored in
    /// `features` mode, else through the encoder whose weights are in `theta` (a flat vector
    /// of [`Nets::flat`]'s layout): the fused CNN encoder, or candle's (Swin) with its graph.
    fn inputs<'b>(
        &self,
        nets: &Nets,
        theta: &[f32],
        batch: &'b Batch,
        tape: bool,
        mut pass: EncoderForward,
    ) -> Result<(Cow<'b, [f32]>, Encoded), Error> {
        // Without an encoder the network reads the batch's rows as they are: a copy was a
        // fresh mapping of up to hundreds of MB per update on large scenarios, and its page
        // faults half of the kernel's time.
        let Some(e) = &nets.encoder else { return Ok((Cow::Borrowed(&batch.inputs), Encoded::None)) };
        match (e.kernel(), &batch.frames) {
            (Some(k), Some(fb)) => {
                let an = self.agent.len();
                k.forward_into(&theta[an..an + self.enc_len], &fb.frames.pixels(), tape, &mut pass)?;
                let row_frame = nets.unroll_frames(batch)?;
                let x = e.fuse_flat(&pass.out, &row_frame, &batch.inputs);
                Ok((Cow::Owned(x), if tape { Encoded::Fused { pass, row_frame } } else { Encoded::None }))
            }
            (Some(_), None) => Err(no_frames()),
            (None, _) => {
                let x = nets.unroll_inputs(batch)?;
                let flat = x.flatten_all()?.to_vec1::<f32>()?;
                Ok((Cow::Owned(flat), if tape { Encoded::Candle(x) } else { Encoded::None }))
            }
        }
    }
}

fn no_frames() -> Error {
    Error::Observation { message: "an image encoder was given a batch without frames".into() }
}

/// The index of the greatest available value (the first on ties; with none available, the
/// first of all, as candle's `argmax` over the masked values).
fn masked_argmax(q: &[f32], avail: &[f32]) -> usize {
    let masked = MASKED as f32;
    let mut best = (0, if avail.first().is_some_and(|&m| m > 0.0) { q[0] } else { masked });
    for (i, (&v, &m)) in q.iter().zip(avail).enumerate().skip(1) {
        let v = if m > 0.0 { v } else { masked };
        if best.1 < v {
            best = (i, v);
        }
    }
    best.0
}

fn row_sums(x: &[f32], w: usize) -> Vec<f32> {
    x.chunks_exact(w.max(1)).map(|r| r.iter().sum()).collect()
}
