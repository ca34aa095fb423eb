//! The optimisers: PyMARL's RMSprop (PyTorch's form, no momentum, not centred), which candle
//! lacks, and candle's Adam (PyMARL2, EPyMARL and the PPO baselines use Adam). Both first
//! clip the global norm of all gradients together, as `torch.nn.utils.clip_grad_norm_` does
//! (per-tensor clipping would change the direction), which candle lacks too.

use crate::Error;
use candle_core::backprop::GradStore;
use candle_core::{Tensor, Var};
use candle_nn::Optimizer as _;
use serde::{Deserialize, Serialize};

/// Which optimiser a config asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum OptimizerKind {
    #[default]
    Rmsprop,
    Adam,
}

/// An optimiser over a fixed list of variables, clipping the global gradient norm first.
#[derive(Debug)]
pub struct Optimizer {
    vars: Vec<Var>,
    clip: f64,
    inner: Inner,
}

#[derive(Debug)]
enum Inner {
    RmsProp { square_avg: Vec<Tensor>, lr: f64, alpha: f64, eps: f64 },
    Adam(candle_nn::AdamW),
}

impl Optimizer {
    /// RMSprop with smoothing `alpha` and `eps` added to the root.
    pub fn rmsprop(vars: Vec<Var>, lr: f64, alpha: f64, eps: f64, clip: f64) -> Result<Optimizer, Error> {
        let square_avg = vars.iter().map(|v| v.as_tensor().zeros_like()).collect::<Result<Vec<_>, _>>()?;
        Ok(Optimizer { vars, clip, inner: Inner::RmsProp { square_avg, lr, alpha, eps } })
    }

    /// Adam (PyTorch's defaults: betas 0.9 and 0.999, no weight decay) with `eps`.
    pub fn adam(vars: Vec<Var>, lr: f64, eps: f64, clip: f64) -> Result<Optimizer, Error> {
        let params = candle_nn::ParamsAdamW { lr, eps, weight_decay: 0.0, ..candle_nn::ParamsAdamW::default() };
        Ok(Optimizer { inner: Inner::Adam(candle_nn::AdamW::new(vars.clone(), params)?), vars, clip })
    }

    /// Backpropagates `loss`, clips and applies one step; returns the gradients' global norm
    /// before clipping.
    pub fn backward_step(&mut self, loss: &Tensor) -> Result<f64, Error> {
        let mut grads = loss.backward()?;
        self.step(&mut grads)
    }

    /// One step from computed gradients (variables without one are left alone); returns the
    /// global norm before clipping.
    pub fn step(&mut self, grads: &mut GradStore) -> Result<f64, Error> {
        let mut total = 0f64;
        for v in &self.vars {
            if let Some(g) = grads.get(v) {
                total += f64::from(g.sqr()?.sum_all()?.to_scalar::<f32>()?);
            }
        }
        let norm = total.sqrt();
        if !norm.is_finite() {
            return Err(Error::NonFiniteGradient { norm });
        }
        let scale = if norm > self.clip { self.clip / (norm + 1e-6) } else { 1.0 };
        match &mut self.inner {
            Inner::RmsProp { square_avg, lr, alpha, eps } => {
                for (v, sq) in self.vars.iter().zip(square_avg.iter_mut()) {
                    let Some(g) = grads.get(v) else { continue };
                    let g = (g.detach() * scale)?;
                    *sq = ((&*sq * *alpha)? + (g.sqr()? * (1.0 - *alpha))?)?;
                    let update = (g / (sq.sqrt()? + *eps)?)?;
                    v.set(&(v.as_tensor().detach() - (update * *lr)?)?)?;
                }
            }
            Inner::Adam(adam) => {
                if scale < 1.0 {
                    for v in &self.vars {
                        if let Some(g) = grads.remove(v) {
                            grads.insert(v, (g * scale)?);
                        }
                    }
                }
                adam.step(grads)?;
            }
        }
        Ok(norm)
    }
}
