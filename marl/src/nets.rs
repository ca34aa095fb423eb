//! The networks: PyMARL's RNN agent (fc -> GRU cell -> fc, one network shared by all agents)
//! and the mixers (VDN's sum, QMIX's monotonic hypernetwork mixer). Parameters live in a
//! [`Params`] list kept in creation order, initialised from a seeded ChaCha stream as
//! PyTorch does (uniform in +-1/sqrt(fan_in)), so a seed fixes every weight: candle's own
//! initialisers draw from an unseeded thread RNG on the CPU, and its `VarMap` is a `HashMap`.

use crate::Error;
use candle_core::{D, DType, Device, Tensor, Var};
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
    /// `x` of shape `(N, inp)`.
    pub(crate) fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        Ok(x.matmul(&self.w.t()?)?.broadcast_add(&self.b)?)
    }
}

/// PyMARL's `RNNAgent`: `fc1 -> ReLU -> GRUCell -> fc2`, one step at a time so the hidden
/// state can be carried across environment steps while acting; or EPyMARL's `use_rnn: False`
/// form, `fc1 -> ReLU -> Linear -> ReLU -> fc2`, whose "hidden state" is only the last
/// layer's output: it unrolls over a whole batch of episodes in one product per layer,
/// tens of times faster to learn on a CPU, where every small tensor op has a fixed cost.
#[derive(Debug, Clone)]
pub struct AgentNet {
    fc1: Linear,
    core: Core,
    fc2: Linear,
    pub hidden: usize,
}

#[derive(Debug, Clone)]
enum Core {
    Gru { w_ih: Tensor, w_hh: Tensor, b_ih: Tensor, b_hh: Tensor },
    Linear(Linear),
}

impl AgentNet {
    /// The recurrent agent (PyMARL).
    pub fn new(p: &mut Params, input: usize, hidden: usize, n_actions: usize, rng: &mut ChaCha8Rng) -> Result<AgentNet, Error> {
        let fc1 = Linear::new(p, "fc1", input, hidden, rng)?;
        let core = Core::Gru {
            w_ih: p.uniform("rnn.weight_ih".into(), &[3 * hidden, hidden], hidden, rng)?,
            w_hh: p.uniform("rnn.weight_hh".into(), &[3 * hidden, hidden], hidden, rng)?,
            b_ih: p.uniform("rnn.bias_ih".into(), &[3 * hidden], hidden, rng)?,
            b_hh: p.uniform("rnn.bias_hh".into(), &[3 * hidden], hidden, rng)?,
        };
        let fc2 = Linear::new(p, "fc2", hidden, n_actions, rng)?;
        Ok(AgentNet { fc1, core, fc2, hidden })
    }

    /// The feed-forward agent (EPyMARL's `use_rnn: False`).
    pub fn feed_forward(p: &mut Params, input: usize, hidden: usize, n_actions: usize, rng: &mut ChaCha8Rng) -> Result<AgentNet, Error> {
        let fc1 = Linear::new(p, "fc1", input, hidden, rng)?;
        let core = Core::Linear(Linear::new(p, "rnn", hidden, hidden, rng)?);
        let fc2 = Linear::new(p, "fc2", hidden, n_actions, rng)?;
        Ok(AgentNet { fc1, core, fc2, hidden })
    }

    /// The fused kernels' view of this network.
    pub fn layout(&self) -> crate::kernels::NetLayout {
        let (out, _) = self.fc2.w.dims2().unwrap_or((0, 0));
        let (_, input) = self.fc1.w.dims2().unwrap_or((0, 0));
        crate::kernels::NetLayout { input, hidden: self.hidden, out, recurrent: self.is_recurrent() }
    }

    /// How many of its parameter list's variables are this network's (they come first).
    pub fn var_count(&self) -> usize {
        if self.is_recurrent() { 8 } else { 6 }
    }

    /// Whether the output depends on earlier steps.
    pub fn is_recurrent(&self) -> bool {
        matches!(self.core, Core::Gru { .. })
    }

    /// One step for `N` rows: inputs `(N, input)`, hidden `(N, hidden)` -> Q `(N, n_actions)`
    /// and the next hidden state (PyTorch's `GRUCell` equations).
    pub fn step(&self, x: &Tensor, h: &Tensor) -> Result<(Tensor, Tensor), Error> {
        let h2 = self.recur(&self.project(x)?, h)?;
        Ok((self.fc2.forward(&h2)?, h2))
    }

    /// The part of a step that does not depend on the hidden state: done for a whole batch
    /// of episodes in one product when learning. GRU: `(N, input)` -> `(N, 3 * hidden)`;
    /// feed-forward: `(N, input)` -> `(N, hidden)`, the whole core.
    pub fn project(&self, x: &Tensor) -> Result<Tensor, Error> {
        let x = self.fc1.forward(x)?.relu()?;
        match &self.core {
            Core::Gru { w_ih, b_ih, .. } => Ok(x.matmul(&w_ih.t()?)?.broadcast_add(b_ih)?),
            Core::Linear(l) => Ok(l.forward(&x)?.relu()?),
        }
    }

    /// The GRU cell on projected inputs `gi` `(N, 3 * hidden)` (feed-forward: `gi` itself).
    pub fn recur(&self, gi: &Tensor, h: &Tensor) -> Result<Tensor, Error> {
        let Core::Gru { w_hh, b_hh, .. } = &self.core else {
            return Ok(gi.clone());
        };
        let gh = h.matmul(&w_hh.t()?)?.broadcast_add(b_hh)?;
        let k = self.hidden;
        let rz = candle_nn::ops::sigmoid(&(gi.narrow(1, 0, 2 * k)? + gh.narrow(1, 0, 2 * k)?)?)?;
        let (r, z) = (rz.narrow(1, 0, k)?, rz.narrow(1, k, k)?);
        let n = (gi.narrow(1, 2 * k, k)? + (r * gh.narrow(1, 2 * k, k)?)?)?.tanh()?;
        // h' = (1 - z) * n + z * h = n + z * (h - n)
        Ok((&n + (z * (h - &n)?)?)?)
    }

    /// Q-values of hidden states, `(N, hidden)` -> `(N, n_actions)`.
    pub fn head(&self, h: &Tensor) -> Result<Tensor, Error> {
        self.fc2.forward(h)
    }

    /// A zero hidden state for `n` rows.
    pub fn zero_hidden(&self, n: usize) -> Result<Tensor, Error> {
        Ok(Tensor::zeros((n, self.hidden), DType::F32, &Device::Cpu)?)
    }
}

/// A small feed-forward network of a hypernetwork: one layer, or two with a ReLU between.
#[derive(Debug, Clone)]
enum Hyper {
    One(Linear),
    Two(Linear, Linear),
}

impl Hyper {
    fn new(p: &mut Params, name: &str, layers: usize, inp: usize, hidden: usize, out: usize, rng: &mut ChaCha8Rng) -> Result<Hyper, Error> {
        Ok(if layers == 1 {
            Hyper::One(Linear::new(p, &format!("{name}.0"), inp, out, rng)?)
        } else {
            Hyper::Two(Linear::new(p, &format!("{name}.0"), inp, hidden, rng)?, Linear::new(p, &format!("{name}.2"), hidden, out, rng)?)
        })
    }
    fn forward(&self, x: &Tensor) -> Result<Tensor, Error> {
        match self {
            Hyper::One(l) => l.forward(x),
            Hyper::Two(a, b) => b.forward(&a.forward(x)?.relu()?),
        }
    }
}

/// QMIX's mixer: `Q_tot = elu(q . |W1(s)| + b1(s)) . |Wf(s)| + V(s)`. The absolute values
/// keep every mixing weight non-negative, so `Q_tot` is monotonic in each agent's Q and the
/// agents' greedy actions are the team's.
#[derive(Debug, Clone)]
pub struct QmixMixer {
    w1: Hyper,
    wf: Hyper,
    b1: Linear,
    v0: Linear,
    v1: Linear,
    n_agents: usize,
    embed: usize,
}

impl QmixMixer {
    pub fn new(p: &mut Params, n_agents: usize, state: usize, cfg: &crate::Config, rng: &mut ChaCha8Rng) -> Result<QmixMixer, Error> {
        let (e, l, h) = (cfg.mixing_embed_dim, cfg.hypernet_layers, cfg.hypernet_embed);
        Ok(QmixMixer {
            w1: Hyper::new(p, "hyper_w_1", l, state, h, e * n_agents, rng)?,
            wf: Hyper::new(p, "hyper_w_final", l, state, h, e, rng)?,
            b1: Linear::new(p, "hyper_b_1", state, e, rng)?,
            v0: Linear::new(p, "V.0", state, e, rng)?,
            v1: Linear::new(p, "V.2", e, 1, rng)?,
            n_agents,
            embed: e,
        })
    }

    /// Agents' Q `(N, A)` and states `(N, S)` -> `Q_tot` `(N, 1)`.
    pub fn forward(&self, qs: &Tensor, states: &Tensor) -> Result<Tensor, Error> {
        let n = qs.dim(0)?;
        let (a, e) = (self.n_agents, self.embed);
        let w1 = self.w1.forward(states)?.abs()?.reshape((n, a, e))?;
        let b1 = self.b1.forward(states)?.reshape((n, 1, e))?;
        let hidden = (qs.reshape((n, 1, a))?.matmul(&w1)? + b1)?.elu(1.0)?;
        let wf = self.wf.forward(states)?.abs()?.reshape((n, e, 1))?;
        let v = self.v1.forward(&self.v0.forward(states)?.relu()?)?.reshape((n, 1, 1))?;
        Ok((hidden.matmul(&wf)? + v)?.reshape((n, 1))?)
    }
}

/// The value mixer of a learner.
#[derive(Debug, Clone)]
pub enum Mixer {
    Vdn,
    Qmix(QmixMixer),
}

impl Mixer {
    /// `(N, A)` agents' Q and `(N, S)` states -> `(N, 1)`.
    pub fn forward(&self, qs: &Tensor, states: &Tensor) -> Result<Tensor, Error> {
        match self {
            Mixer::Vdn => Ok(qs.sum_keepdim(D::Minus1)?),
            Mixer::Qmix(m) => m.forward(qs, states),
        }
    }
}
