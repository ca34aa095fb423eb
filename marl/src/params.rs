//! Trainable parameters and the linear layer every network here builds on (the agent
//! network, the mixers, the image and text encoders, PPO's critic). Parameters live in a
//! [`Params`] list kept in creation order, initialised from a seeded ChaCha stream as
//! PyTorch does (uniform in +-1/sqrt(fan_in)), so a seed fixes every weight: candle's own
//! initialisers draw from an unseeded thread RNG on the CPU, and its `VarMap` is a `HashMap`.
//!
//! A module of its own, below [`crate::nets`] and [`crate::encoders`]: the networks a learner
//! holds ([`crate::Nets`]) include an encoder, and the encoders are built of these.

use crate::Error;
use candle_core::{DType, Device, Tensor, Var};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;

/// Named trainable variables in creation order.
#[derive(Debug, Default)]
pub struct Params {
    vars: Vec<(String, Var)>,
}

impl Params {
    /// A new variable of `shape`, uniform in `+-1/sqrt(fan_in)`.
    pub(crate) fn uniform(&mut self, name: String, shape: &[usize], fan_in: usize, rng: &mut ChaCha8Rng) -> Result<Tensor, Error> {
        let bound = 1.0 / (fan_in.max(1) as f32).sqrt();
        let n: usize = shape.iter().product();
        let data: Vec<f32> = (0..n).map(|_| rng.random_range(-bound..=bound)).collect();
        let var = Var::from_vec(data, shape, &Device::Cpu)?;
        let t = var.as_tensor().clone();
        self.vars.push((name, var));
        Ok(t)
    }

    /// A new `(rows, cols)` variable with orthonormal rows or columns (whichever are fewer),
    /// times `gain`: PyTorch's `orthogonal_`, by Gram-Schmidt on a seeded normal draw.
    pub(crate) fn orthogonal(&mut self, name: String, rows: usize, cols: usize, gain: f32, rng: &mut ChaCha8Rng) -> Result<Tensor, Error> {
        // `k` orthonormal vectors of length `len`, one per row of `q`.
        let (k, len) = (rows.min(cols), rows.max(cols));
        let mut normal = || {
            // Box-Muller; `1 - u` keeps the logarithm's argument in (0, 1].
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            ((-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()) as f32
        };
        let mut q: Vec<f32> = (0..k * len).map(|_| normal()).collect();
        for a in 0..k {
            let (done, rest) = q.split_at_mut(a * len);
            let row = &mut rest[..len];
            for prev in done.chunks_exact(len) {
                let dot: f32 = row.iter().zip(prev).map(|(x, y)| x * y).sum();
                row.iter_mut().zip(prev).for_each(|(x, y)| *x -= dot * y);
            }
            let norm = row.iter().map(|x| x * x).sum::<f32>().sqrt().max(f32::MIN_POSITIVE);
            row.iter_mut().for_each(|x| *x /= norm);
        }
        q.iter_mut().for_each(|x| *x *= gain);
        // `q` is `(k, len)`: the matrix itself when it has fewer rows, else its transpose.
        let data = if rows <= cols {
            q
        } else {
            let mut t = vec![0f32; rows * cols];
            for (c, row) in q.chunks_exact(len).enumerate() {
                for (r, &v) in row.iter().enumerate() {
                    t[r * cols + c] = v;
                }
            }
            t
        };
        let var = Var::from_vec(data, &[rows, cols], &Device::Cpu)?;
        let t = var.as_tensor().clone();
        self.vars.push((name, var));
        Ok(t)
    }

    /// A new variable of `shape` filled with `value` (layer norms' scales and shifts).
    pub(crate) fn constant(&mut self, name: String, shape: &[usize], value: f32) -> Result<Tensor, Error> {
        let n: usize = shape.iter().product();
        let var = Var::from_vec(vec![value; n], shape, &Device::Cpu)?;
        let t = var.as_tensor().clone();
        self.vars.push((name, var));
        Ok(t)
    }

    /// The number of trainable scalars.
    pub fn count(&self) -> usize {
        self.vars.iter().map(|(_, v)| v.elem_count()).sum()
    }

    pub fn vars(&self) -> impl Iterator<Item = &Var> {
        self.vars.iter().map(|(_, v)| v)
    }

    /// Copies `other`'s values (a network of the same shape) into these variables.
    pub fn copy_from(&self, other: &Params) -> Result<(), Error> {
        for ((n, v), (m, w)) in self.vars.iter().zip(&other.vars) {
            if n != m {
                return Err(Error::Checkpoint { message: format!("parameter `{n}` copied from `{m}`") });
            }
            v.set(&w.as_tensor().detach().copy()?)?;
        }
        Ok(())
    }

    /// Multiplies the variables whose name starts with `prefix` by `factor` (PPO starts its
    /// policy's output layer small, so the first policy is near uniform).
    pub fn scale(&self, prefix: &str, factor: f64) -> Result<(), Error> {
        for (_, v) in self.vars.iter().filter(|(n, _)| n.starts_with(prefix)) {
            v.set(&(v.as_tensor().detach() * factor)?)?;
        }
        Ok(())
    }

    /// The first `k` variables' values, flattened and concatenated (the fused networks'
    /// parameter vector, [`crate::kernels::NetLayout`]).
    pub fn flat(&self, k: usize) -> Result<Vec<f32>, Error> {
        let mut out = Vec::new();
        for (_, v) in self.vars.iter().take(k) {
            out.extend(v.as_tensor().flatten_all()?.to_vec1::<f32>()?);
        }
        Ok(out)
    }

    /// Sets the first `k` variables from a flat vector ([`Params::flat`]'s layout).
    pub fn set_flat(&self, k: usize, flat: &[f32]) -> Result<(), Error> {
        let mut at = 0;
        for (n, v) in self.vars.iter().take(k) {
            let len = v.elem_count();
            let Some(part) = flat.get(at..at + len) else {
                return Err(Error::Checkpoint { message: format!("a flat vector of {} values ends inside `{n}`", flat.len()) });
            };
            v.set(&Tensor::from_slice(part, v.shape(), &Device::Cpu)?)?;
            at += len;
        }
        Ok(())
    }

    /// The values of the variables after the first `k` (an agent network's encoder),
    /// flattened and concatenated.
    pub fn flat_after(&self, k: usize) -> Result<Vec<f32>, Error> {
        let mut out = Vec::new();
        for (_, v) in self.vars.iter().skip(k) {
            out.extend(v.as_tensor().flatten_all()?.to_vec1::<f32>()?);
        }
        Ok(out)
    }

    /// The number of variables.
    pub fn len(&self) -> usize {
        self.vars.len()
    }

    pub fn is_empty(&self) -> bool {
        self.vars.is_empty()
    }

    /// The variables after the first `k` (an agent network's encoder).
    pub fn vars_after(&self, k: usize) -> impl Iterator<Item = &Var> {
        self.vars.iter().skip(k).map(|(_, v)| v)
    }

    /// The values by name (what a safetensors file holds).
    pub fn to_map(&self) -> HashMap<String, Tensor> {
        self.vars.iter().map(|(n, v)| (n.clone(), v.as_tensor().detach())).collect()
    }

    /// Sets every variable from `map`, which must hold each name with the same shape.
    pub fn load_map(&self, map: &HashMap<String, Tensor>, what: &str) -> Result<(), Error> {
        for (n, v) in &self.vars {
            let Some(t) = map.get(n) else {
                return Err(Error::Checkpoint { message: format!("{what}: no tensor `{n}`") });
            };
            if t.dims() != v.dims() {
                return Err(Error::Checkpoint {
                    message: format!("{what}: `{n}` has shape {:?}, the network needs {:?}", t.dims(), v.dims()),
                });
            }
            v.set(&t.to_dtype(DType::F32)?)?;
        }
        Ok(())
    }
}

/// `y = x W^T + b`.
#[derive(Debug, Clone)]
pub struct Linear {
    w: Tensor,
    b: Tensor,
}

impl Linear {
    pub(crate) fn new(p: &mut Params, name: &str, inp: usize, out: usize, rng: &mut ChaCha8Rng) -> Result<Linear, Error> {
        Ok(Linear {
            w: p.uniform(format!("{name}.weight"), &[out, inp], inp, rng)?,
            b: p.uniform(format!("{name}.bias"), &[out], inp, rng)?,
        })
    }
    /// Orthogonal weights times `gain` and zero biases (the MAPPO repository's layers).
    pub(crate) fn orthogonal(p: &mut Params, name: &str, inp: usize, out: usize, gain: f32, rng: &mut ChaCha8Rng) -> Result<Linear, Error> {
        Ok(Linear { w: p.orthogonal(format!("{name}.weight"), out, inp, gain, rng)?, b: p.constant(format!("{name}.bias"), &[out], 0.0)? })
    }
    pub(crate) fn weight(&self) -> &Tensor {
        &self.w
    }
    /// `x` of shape `(N, inp)`.
    pub(crate) fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        Ok(x.matmul(&self.w.t()?)?.broadcast_add(&self.b)?)
    }
}
