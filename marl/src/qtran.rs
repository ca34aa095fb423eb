//! QTRAN-base (Son et al. 2019) as PyMARL's `QTranLearner` with its `qtran_paper` mixer: a
//! joint action-value network `Q_jt(s, u)` over the state and the sum of per-agent encodings
//! of (GRU hidden state, action), and a state value `V_jt(s)`. The agents' summed Q-values
//! are tied to them by two extra losses instead of a structural constraint: at the greedy
//! joint action `sum_i max q_i - Q_jt + V_jt = 0` (`opt`), and elsewhere it must not fall
//! below zero (`nopt`). `Q_jt` itself learns by TD on the team reward.

use crate::buffer::{Batch, Shape};
use crate::learner::{Learner, MASKED, td_targets};
use crate::nets::{Linear, Params};
use crate::{Config, Error};
use candle_core::{D, DType, Tensor};
use rand_chacha::ChaCha8Rng;

/// Three layers with ReLUs between (PyMARL's `network_size: small`).
#[derive(Debug, Clone)]
struct Mlp3(Linear, Linear, Linear);

impl Mlp3 {
    fn new(p: &mut Params, name: &str, inp: usize, hidden: usize, rng: &mut ChaCha8Rng) -> Result<Mlp3, Error> {
        Ok(Mlp3(
            Linear::new(p, &format!("{name}.0"), inp, hidden, rng)?,
            Linear::new(p, &format!("{name}.2"), hidden, hidden, rng)?,
            Linear::new(p, &format!("{name}.4"), hidden, 1, rng)?,
        ))
    }
    fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        self.2.forward(&self.1.forward(&self.0.forward(x)?.relu()?)?.relu()?)
    }
}

/// QTRAN-base's joint networks.
#[derive(Debug, Clone)]
pub struct QtranMixer {
    q: Mlp3,
    v: Mlp3,
    enc0: Linear,
    enc1: Linear,
    n_agents: usize,
    n_actions: usize,
}

impl QtranMixer {
    pub fn new(p: &mut Params, shape: &Shape, cfg: &Config, rng: &mut ChaCha8Rng) -> Result<QtranMixer, Error> {
        let ae = cfg.rnn_hidden_dim + shape.n_actions;
        let e = cfg.mixing_embed_dim;
        Ok(QtranMixer {
            q: Mlp3::new(p, "Q", shape.state + ae, e, rng)?,
            v: Mlp3::new(p, "V", shape.state, e, rng)?,
            enc0: Linear::new(p, "action_encoding.0", ae, ae, rng)?,
            enc1: Linear::new(p, "action_encoding.2", ae, ae, rng)?,
            n_agents: shape.n_agents,
            n_actions: shape.n_actions,
        })
    }

    /// `Q_jt` `(N, 1)` of states `(N, S)`, the agents' hidden states `(N*A, H)` and their
    /// actions as one-hot rows `(N*A, n_actions)`.
    pub fn joint_q(&self, states: &Tensor, hidden: &Tensor, actions: &Tensor) -> Result<Tensor, Error> {
        let n = states.dim(0)?;
        let x = Tensor::cat(&[hidden, actions], 1)?;
        let enc = self.enc1.forward(&self.enc0.forward(&x)?.relu()?)?;
        let summed = enc.reshape((n, self.n_agents, ()))?.sum(1)?;
        self.q.forward(&Tensor::cat(&[states, &summed], 1)?)
    }

    /// `V_jt` `(N, 1)` of states `(N, S)`.
    pub fn value(&self, states: &Tensor) -> Result<Tensor, Error> {
        self.v.forward(states)
    }

    /// One-hot rows `(M, n_actions)` of action indices `(M, 1)` (u32).
    fn one_hot(&self, idx: &Tensor) -> Result<Tensor, Error> {
        let m = idx.dim(0)?;
        let zeros = Tensor::zeros((m, self.n_actions), DType::F32, idx.device())?;
        let ones = Tensor::ones((m, 1), DType::F32, idx.device())?;
        Ok(zeros.scatter_add(&idx.contiguous()?, &ones, 1)?)
    }
}

/// PyMARL's QTRAN loss: `td + opt_loss * opt + nopt_min_loss * nopt`; returns the loss, the
/// masked TD error and the chosen agents' Q-values (as [`Learner::loss`]).
pub(crate) fn loss(l: &Learner, batch: &Batch) -> Result<(Tensor, Tensor, Tensor), Error> {
    let (Some(mix), Some(tmix)) = (&l.nets.qtran, &l.target.qtran) else {
        return Err(Error::Checkpoint { message: "QTRAN loss without QTRAN networks".into() });
    };
    let (t, b, a) = (batch.t, batch.b, l.shape.n_agents);
    let cfg = &l.cfg;
    let bt = batch.tensors()?;
    let (q, hs) = l.nets.unroll_hidden(batch)?;
    let (_, ths) = l.target.unroll_hidden(batch)?;
    let hdim = hs.dim(2)?;
    let rows = t * b * a;
    let fill = Tensor::full(MASKED as f32, q.dims(), q.device())?;
    let masked_q = bt.avail.gt(0.0)?.where_cond(&q.detach(), &fill)?;
    // The greedy actions of the online network (double Q: they pick the target's action too).
    let best = masked_q.argmax_keepdim(D::Minus1)?;
    // Not detached: the opt loss trains the agents' greedy Q-values (PyMARL's clone).
    let best_q = bt.avail.gt(0.0)?.where_cond(&q, &fill)?.max_keepdim(D::Minus1)?;
    let chosen = q.narrow(0, 0, t)?.gather(&bt.actions, D::Minus1)?.reshape((t * b, a))?;
    let s = bt.state.dim(2)?;
    let st = bt.state.narrow(0, 0, t)?.reshape((t * b, s))?;
    let st1 = bt.state.narrow(0, 1, t)?.reshape((t * b, s))?;
    let h_now = hs.narrow(0, 0, t)?.reshape((rows, hdim))?;
    let joint = mix.joint_q(&st, &h_now, &mix.one_hot(&bt.actions.reshape((rows, 1))?)?)?;
    let vs = mix.value(&st)?;
    let next_actions = if cfg.double_q {
        best.narrow(0, 1, t)?
    } else {
        let tq = l.target.unroll(batch)?.narrow(0, 1, t)?;
        let tfill = Tensor::full(MASKED as f32, tq.dims(), tq.device())?;
        bt.avail.narrow(0, 1, t)?.gt(0.0)?.where_cond(&tq, &tfill)?.argmax_keepdim(D::Minus1)?
    };
    let target_joint =
        tmix.joint_q(&st1, &ths.narrow(0, 1, t)?.reshape((rows, hdim))?, &tmix.one_hot(&next_actions.reshape((rows, 1))?)?)?.detach();
    let targets = td_targets(batch, &target_joint, cfg.gamma, cfg.td_lambda)?;
    let mask = bt.filled.reshape((t * b, 1))?;
    let n = mask.sum_all()?.to_scalar::<f32>()?.max(1.0) as f64;
    let td = ((&joint - targets)? * &mask)?;
    let td_loss = (td.sqr()?.sum_all()? / n)?;
    // At the greedy joint action the agents' sum must equal Q_jt - V_jt.
    let max_joint = mix.joint_q(&st, &h_now, &mix.one_hot(&best.narrow(0, 0, t)?.reshape((rows, 1))?)?)?.detach();
    let best_sum = best_q.narrow(0, 0, t)?.reshape((t * b, a))?.sum_keepdim(1)?;
    let opt = (((best_sum - max_joint)? + &vs)? * &mask)?;
    let opt_loss = (opt.sqr()?.sum_all()? / n)?;
    // Elsewhere it must not fall below it.
    let nopt = (((chosen.sum_keepdim(1)? - joint.detach())? + &vs)?.clamp(f32::MIN, 0.0)? * &mask)?;
    let nopt_loss = (nopt.sqr()?.sum_all()? / n)?;
    let total = ((td_loss + (opt_loss * cfg.opt_loss.unwrap_or(1.0))?)? + (nopt_loss * cfg.nopt_min_loss.unwrap_or(0.1))?)?;
    Ok((total, td, chosen))
}
