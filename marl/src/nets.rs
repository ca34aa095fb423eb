//! The networks: PyMARL's RNN agent (fc -> GRU cell -> fc, one network shared by all agents),
//! the mixers (VDN's sum, QMIX's monotonic hypernetwork mixer, QTRAN-base's joint networks),
//! and [`Nets`], the set a learner trains, an actor acts with and a checkpoint holds. Their
//! weights are [`Params`] ([`crate::params`]).
//!
//! [`Nets`] includes an image mode's encoder, so this module sits above [`crate::encoders`]
//! (whose layers come from [`crate::params`], not from here); the Q-learners, PPO, the
//! checkpoints and the test episodes all build on it.

use crate::buffer::{Batch, Shape};
use crate::encoders::layers::LayerNorm;
use crate::encoders::{NO_FRAME, ObsEncoder, agent_input_width};
use crate::frames::{FrameTensors, StepFrames};
use crate::{Config, Error, MixerKind};
use candle_core::{D, DType, Device, Tensor};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

// `Params` and `Linear` were defined here; their old paths stay valid.
pub use crate::params::{Linear, Params};

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
    /// The MAPPO repository's form ([`AgentNet::normed`]).
    norms: Option<Norms>,
}

/// The MAPPO repository's layer norms (its `MLPBase` with `use_feature_normalization`, and
/// its `RNNLayer`'s norm) and, in the recurrent form, its second hidden layer.
#[derive(Debug, Clone)]
struct Norms {
    input: LayerNorm,
    fc1: LayerNorm,
    mid: Option<(Linear, LayerNorm)>,
    /// After the core: the GRU's hidden state (read by the output layer only), or the
    /// feed-forward core's output.
    core: LayerNorm,
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
        Ok(AgentNet { fc1, core, fc2, hidden, norms: None })
    }

    /// The feed-forward agent (EPyMARL's `use_rnn: False`).
    pub fn feed_forward(p: &mut Params, input: usize, hidden: usize, n_actions: usize, rng: &mut ChaCha8Rng) -> Result<AgentNet, Error> {
        let fc1 = Linear::new(p, "fc1", input, hidden, rng)?;
        let core = Core::Linear(Linear::new(p, "rnn", hidden, hidden, rng)?);
        let fc2 = Linear::new(p, "fc2", hidden, n_actions, rng)?;
        Ok(AgentNet { fc1, core, fc2, hidden, norms: None })
    }

    /// The MAPPO repository's network (`r_actor_critic.py` on `MLPBase` and `RNNLayer`):
    /// `LN -> fc1 -> ReLU -> LN -> fc -> ReLU -> LN -> GRU -> LN -> fc2`, or feed-forward
    /// `LN -> fc1 -> ReLU -> LN -> Linear -> ReLU -> LN -> fc2`; orthogonal weights (gain
    /// sqrt 2 before a ReLU, 1 in the GRU, `out_gain` on the output layer: the repository's
    /// 0.01 for the policy, 1 for the value) and zero biases.
    pub fn normed(
        p: &mut Params,
        input: usize,
        hidden: usize,
        n_actions: usize,
        recurrent: bool,
        out_gain: f32,
        rng: &mut ChaCha8Rng,
    ) -> Result<AgentNet, Error> {
        let relu = std::f32::consts::SQRT_2;
        let input_norm = p.layer_norm("feature_norm", input)?;
        let fc1 = Linear::orthogonal(p, "fc1", input, hidden, relu, rng)?;
        let fc1_norm = p.layer_norm("fc1_norm", hidden)?;
        let mid = if recurrent {
            Some((Linear::orthogonal(p, "fc_h", hidden, hidden, relu, rng)?, p.layer_norm("fc_h_norm", hidden)?))
        } else {
            None
        };
        let core = if recurrent {
            Core::Gru {
                w_ih: p.orthogonal("rnn.weight_ih".into(), 3 * hidden, hidden, 1.0, rng)?,
                w_hh: p.orthogonal("rnn.weight_hh".into(), 3 * hidden, hidden, 1.0, rng)?,
                b_ih: p.constant("rnn.bias_ih".into(), &[3 * hidden], 0.0)?,
                b_hh: p.constant("rnn.bias_hh".into(), &[3 * hidden], 0.0)?,
            }
        } else {
            Core::Linear(Linear::orthogonal(p, "rnn", hidden, hidden, relu, rng)?)
        };
        let core_norm = p.layer_norm("rnn_norm", hidden)?;
        let fc2 = Linear::orthogonal(p, "fc2", hidden, n_actions, out_gain, rng)?;
        let norms = Norms { input: input_norm, fc1: fc1_norm, mid, core: core_norm };
        Ok(AgentNet { fc1, core, fc2, hidden, norms: Some(norms) })
    }

    /// The fused kernels' view of this network.
    pub fn layout(&self) -> crate::kernels::NetLayout {
        let (out, _) = self.fc2.weight().dims2().unwrap_or((0, 0));
        let (_, input) = self.fc1.weight().dims2().unwrap_or((0, 0));
        crate::kernels::NetLayout { input, hidden: self.hidden, out, recurrent: self.is_recurrent(), norm: self.norms.is_some() }
    }

    /// How many of its parameter list's variables are this network's (they come first).
    pub fn var_count(&self) -> usize {
        let base = if self.is_recurrent() { 8 } else { 6 };
        // Three norms of two variables each, and the recurrent form's second layer and norm.
        base + self.norms.as_ref().map_or(0, |n| 6 + if n.mid.is_some() { 4 } else { 0 })
    }

    /// Whether the output depends on earlier steps.
    pub fn is_recurrent(&self) -> bool {
        matches!(self.core, Core::Gru { .. })
    }

    /// One step for `N` rows: inputs `(N, input)`, hidden `(N, hidden)` -> Q `(N, n_actions)`
    /// and the next hidden state (PyTorch's `GRUCell` equations).
    pub fn step(&self, x: &Tensor, h: &Tensor) -> Result<(Tensor, Tensor), Error> {
        let h2 = self.recur(&self.project(x)?, h)?;
        Ok((self.head(&h2)?, h2))
    }

    /// The part of a step that does not depend on the hidden state: done for a whole batch
    /// of episodes in one product when learning. GRU: `(N, input)` -> `(N, 3 * hidden)`;
    /// feed-forward: `(N, input)` -> `(N, hidden)`, the whole core.
    pub fn project(&self, x: &Tensor) -> Result<Tensor, Error> {
        let mut x = match &self.norms {
            Some(n) => n.fc1.forward(&self.fc1.forward(&n.input.forward(x)?)?.relu()?)?,
            None => self.fc1.forward(x)?.relu()?,
        };
        if let Some((l, norm)) = self.norms.as_ref().and_then(|n| n.mid.as_ref()) {
            x = norm.forward(&l.forward(&x)?.relu()?)?;
        }
        match (&self.core, &self.norms) {
            (Core::Gru { w_ih, b_ih, .. }, _) => Ok(x.matmul(&w_ih.t()?)?.broadcast_add(b_ih)?),
            (Core::Linear(l), Some(n)) => n.core.forward(&l.forward(&x)?.relu()?),
            (Core::Linear(l), None) => Ok(l.forward(&x)?.relu()?),
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
        match &self.norms {
            Some(n) if self.is_recurrent() => self.fc2.forward(&n.core.forward(h)?),
            _ => self.fc2.forward(h),
        }
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
    pub fn new(p: &mut Params, n_agents: usize, state: usize, cfg: &Config, rng: &mut ChaCha8Rng) -> Result<QmixMixer, Error> {
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

/// QTRAN-base's joint networks (how they train: [`crate::qtran`]).
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
    pub(crate) fn one_hot(&self, idx: &Tensor) -> Result<Tensor, Error> {
        let m = idx.dim(0)?;
        let zeros = Tensor::zeros((m, self.n_actions), DType::F32, idx.device())?;
        let ones = Tensor::ones((m, 1), DType::F32, idx.device())?;
        Ok(zeros.scatter_add(&idx.contiguous()?, &ones, 1)?)
    }
}

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
    pub encoder: Option<ObsEncoder>,
}

impl Nets {
    /// Fresh networks for `cfg` and `shape`, every weight drawn from `seed`.
    pub fn new(cfg: &Config, shape: &Shape, seed: u64) -> Result<Nets, Error> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut agent_params = Params::default();
        // What the networks read: `stacked_frames` steps of the observation (PPO's option).
        let shape = &shape.stacked(cfg.stacked_frames);
        let input = agent_input_width(cfg, shape);
        let agent = if cfg.layer_norm {
            AgentNet::normed(&mut agent_params, input, cfg.rnn_hidden_dim, shape.n_actions, cfg.use_rnn, 1.0, &mut rng)?
        } else if cfg.use_rnn {
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
        let encoder = ObsEncoder::for_config(cfg, shape, &mut agent_params, seed)?;
        Ok(Nets { agent, agent_params, mixer, mixer_params, qtran, encoder })
    }

    pub(crate) fn copy_from(&self, other: &Nets) -> Result<(), Error> {
        self.agent_params.copy_from(&other.agent_params)?;
        self.mixer_params.copy_from(&other.mixer_params)
    }

    /// Every weight as one flat vector: the agent network's, its encoder's, the mixer's.
    pub fn flat(&self) -> Result<Vec<f32>, Error> {
        let mut v = self.agent_params.flat(self.agent_params.vars().count())?;
        v.extend(self.mixer_params.flat(self.mixer_params.vars().count())?);
        Ok(v)
    }

    /// Sets every weight from a vector in [`Nets::flat`]'s layout.
    pub fn set_flat(&self, flat: &[f32]) -> Result<(), Error> {
        let n = self.agent_params.count();
        let (agent, mixer) = flat.split_at(n.min(flat.len()));
        self.agent_params.set_flat(self.agent_params.vars().count(), agent)?;
        self.mixer_params.set_flat(self.mixer_params.vars().count(), mixer)
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

    /// The agent network's input rows for one step: `x` (SMAC's rows, `E * A`) as is in
    /// `features` mode, else fused with the encoder's features of the `E` frames.
    pub fn step_inputs(&self, x: Tensor, frames: Option<&FrameTensors>) -> Result<Tensor, Error> {
        match (&self.encoder, frames) {
            (None, _) => Ok(x),
            (Some(e), Some(f)) => e.fuse(&e.forward(f)?, &x),
            (Some(_), None) => Err(Error::Observation { message: "an image encoder was given no frames".into() }),
        }
    }

    /// [`Nets::step_inputs`] from the renderer's pixels, through the fused encoder when
    /// the backbone has one (what acting runs).
    pub fn step_inputs_pixels(&self, x: Tensor, frames: Option<&StepFrames>) -> Result<Tensor, Error> {
        match (&self.encoder, frames) {
            (None, _) => Ok(x),
            (Some(e), Some(f)) if e.kernel().is_some() => {
                let theta = self.encoder_weights()?;
                let feats = e.encode_pixels(Some(&theta), f)?;
                let feats = Tensor::from_vec(feats, (f.n, e.out), x.device())?;
                e.fuse(&feats, &x)
            }
            (Some(_), Some(f)) => self.step_inputs(x, Some(&f.tensors()?)),
            (Some(_), None) => Err(Error::Observation { message: "an image encoder was given no frames".into() }),
        }
    }

    /// The encoder's weights as one flat vector (its variables follow the agent network's).
    pub fn encoder_weights(&self) -> Result<Vec<f32>, Error> {
        self.agent_params.flat_after(self.agent.var_count())
    }

    /// Each row of a batch's agent-network input `(T+1, B*A)`: the index of the frame it
    /// sees among the batch's frames (episode after episode), or [`NO_FRAME`] on the rows
    /// after an episode's last step.
    pub fn unroll_frames(&self, batch: &Batch) -> Result<Vec<u32>, Error> {
        let Some(fb) = &batch.frames else {
            return Err(Error::Observation { message: "an image encoder was given a batch without frames".into() });
        };
        let (t1, a) = (batch.t + 1, batch.n_agents);
        let mut starts = Vec::with_capacity(fb.lens.len());
        let mut off = 0u32;
        for &len in &fb.lens {
            starts.push((off, len));
            off += len as u32;
        }
        let mut idx = Vec::with_capacity(t1 * starts.len() * a);
        for ti in 0..t1 {
            for &(start, len) in &starts {
                let i = if ti < len.min(t1) { start + ti as u32 } else { NO_FRAME };
                idx.extend(std::iter::repeat_n(i, a));
            }
        }
        Ok(idx)
    }

    /// The agent network's inputs `(T+1, B*A, input)` for a batch: the encoder runs on the
    /// batch's real frames only; padded steps get zero features (they are masked out).
    pub fn unroll_inputs(&self, batch: &Batch) -> Result<Tensor, Error> {
        let inputs = Tensor::from_slice(&batch.inputs, (batch.t + 1, batch.b * batch.n_agents, batch.width), &Device::Cpu)?;
        let Some(e) = &self.encoder else { return Ok(inputs) };
        let Some(fb) = &batch.frames else {
            return Err(Error::Observation { message: "an image encoder was given a batch without frames".into() });
        };
        let (t1, rows, width) = inputs.dims3()?;
        let feats = e.forward(&fb.frames.tensors()?)?;
        let f = feats.dim(1)?;
        let mut per_episode = Vec::with_capacity(fb.lens.len());
        let mut off = 0;
        for &len in &fb.lens {
            let len = len.min(t1);
            let ep = if len == 0 {
                Tensor::zeros((t1, f), feats.dtype(), feats.device())?
            } else {
                feats.narrow(0, off, len)?.pad_with_zeros(0, 0, t1 - len)?
            };
            off += len;
            per_episode.push(ep);
        }
        let b = per_episode.len();
        let feats = Tensor::stack(&per_episode, 1)?.reshape((t1 * b, f))?; // (t, b) row order
        let fused = e.fuse(&feats, &inputs.reshape((t1 * rows, width))?)?;
        Ok(fused.reshape((t1, rows, ()))?)
    }
}
