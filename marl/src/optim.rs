//! PyMARL's optimiser, which candle lacks: RMSprop (PyTorch's form, no momentum, not
//! centred) after clipping the global norm of all gradients together, as
//! `torch.nn.utils.clip_grad_norm_` does (per-tensor clipping would change the direction).

use crate::Error;
use candle_core::backprop::GradStore;
use candle_core::{Tensor, Var};

#[derive(Debug)]
pub struct RmsProp {
    vars: Vec<Var>,
    square_avg: Vec<Tensor>,
    lr: f64,
    alpha: f64,
    eps: f64,
    clip: f64,
}

impl RmsProp {
    pub fn new(vars: Vec<Var>, lr: f64, alpha: f64, eps: f64, clip: f64) -> Result<RmsProp, Error> {
        let square_avg = vars.iter().map(|v| v.as_tensor().zeros_like()).collect::<Result<Vec<_>, _>>()?;
        Ok(RmsProp { vars, square_avg, lr, alpha, eps, clip })
    }

    /// Backpropagates `loss`, clips and applies one step; returns the gradients' global norm
    /// before clipping.
    pub fn backward_step(&mut self, loss: &Tensor) -> Result<f64, Error> {
        let grads = loss.backward()?;
        self.step(&grads)
    }

    /// One step from computed gradients (variables without one are left alone).
    pub fn step(&mut self, grads: &GradStore) -> Result<f64, Error> {
        let mut total = 0f64;
        for v in &self.vars {
            if let Some(g) = grads.get(v) {
                total += f64::from(g.sqr()?.sum_all()?.to_scalar::<f32>()?);
            }
        }
        let norm = total.sqrt();
        let scale = if norm > self.clip { self.clip / (norm + 1e-6) } else { 1.0 };
        for (v, sq) in self.vars.iter().zip(self.square_avg.iter_mut()) {
            let Some(g) = grads.get(v) else { continue };
            let g = (g.detach() * scale)?;
            *sq = ((&*sq * self.alpha)? + (g.sqr()? * (1.0 - self.alpha))?)?;
            let update = (g / (sq.sqrt()? + self.eps)?)?;
            v.set(&(v.as_tensor().detach() - (update * self.lr)?)?)?;
        }
        Ok(norm)
    }
}
