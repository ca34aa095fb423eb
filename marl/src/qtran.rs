//! QTRAN-base (Son et al. 2019) as PyMARL's `QTranLearner` with its `qtran_paper` mixer: a
//! joint action-value network `Q_jt(s, u)` over the state and the sum of per-agent encodings
//! of (GRU hidden state, action), and a state value `V_jt(s)`. The agents' summed Q-values
//! are tied to them by two extra losses instead of a structural constraint: at the greedy
//! joint action `sum_i max q_i - Q_jt + V_jt = 0` (`opt`), and elsewhere it must not fall
//! below zero (`nopt`). `Q_jt` itself learns by TD on the team reward.
//!
//! The networks ([`QtranMixer`]) are in [`crate::nets`] with the other mixers, as a learner's
//! [`Nets`] hold them; this module is their loss.

use crate::buffer::Batch;
use crate::nets::Nets;
use crate::td::{MASKED, td_targets};
use crate::{Config, Error};
use candle_core::{D, Tensor};

// `QtranMixer` was defined here; its old path stays valid.
pub use crate::nets::QtranMixer;

/// PyMARL's QTRAN loss: `td + opt_loss * opt + nopt_min_loss * nopt`; returns the loss, the
/// masked TD error and the chosen agents' Q-values (as [`crate::Learner::loss`]), under a
/// learner's networks and their targets: handed in rather than the learner, which calls
/// this, so that this module need not import the learner.
pub(crate) fn loss(
    cfg: &Config,
    n_agents: usize,
    (nets, target): (&Nets, &Nets),
    batch: &Batch,
) -> Result<(Tensor, Tensor, Tensor), Error> {
    let (Some(mix), Some(tmix)) = (&nets.qtran, &target.qtran) else {
        return Err(Error::Checkpoint { message: "QTRAN loss without QTRAN networks".into() });
    };
    let (t, b, a) = (batch.t, batch.b, n_agents);
    let bt = batch.tensors()?;
    let (q, hs) = nets.unroll_hidden(batch)?;
    let (_, ths) = target.unroll_hidden(batch)?;
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
        let tq = target.unroll(batch)?.narrow(0, 1, t)?;
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
