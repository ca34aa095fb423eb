//! What the Q-learners' updates share: the candle reference ([`crate::learner`]), the fused
//! one on flat vectors and QTRAN's loss ([`crate::qtran`]) compute these TD targets, mask
//! actions with the same value and report a batch's loss and gradient alike. Apart from the
//! learner because the learner calls the other two, which would otherwise import it back.

use crate::Error;
use crate::buffer::Batch;
use candle_core::Tensor;

/// Masked-out Q-values (PyMARL's -9999999): finite, so padded rows stay finite too.
pub(crate) const MASKED: f64 = -1e7;

/// A batch's loss and gradients ([`crate::Learner::gradients`]).
#[derive(Debug, Clone)]
pub struct QGrads {
    pub loss: f64,
    /// Every parameter's gradient in [`crate::Nets::flat`]'s layout.
    pub grad: Vec<f32>,
    /// The mean absolute TD error and the mean chosen Q-value over real steps.
    pub td_abs: f64,
    pub q_taken: f64,
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
