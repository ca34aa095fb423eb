//! The PPO learner: the actor (PyMARL's GRU agent network read as logits), a recurrent
//! critic of the same architecture with one output, Adam on each, and the update: clipped
//! surrogate, entropy bonus and Huber value loss (optionally clipped) over chunked
//! sequences, with MAPPO's value normalisation and active masks.

use super::critic_input::CriticInput;
use super::rollout::{FlatBatch, MASKED, PpoBatch, Rollout, gae};
use crate::buffer::Shape;
use crate::frames::StepFrames;
use crate::kernels::ppo_loss::{LossGrads, LossRows, LossSettings, ppo_loss};
use crate::kernels::{Adam, EncoderForward, EncoderLayout, Input, Moments, NetLayout, Pixels, Want, clip_global_norm};
use crate::nets::{AgentNet, Nets};
use crate::params::{Linear, Params};
use crate::value_norm::ValueNorm;
use crate::{Config, Error};
use candle_core::backprop::GradStore;
use candle_core::{D, Device, Tensor, Var};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Mutex;

/// The critic: a recurrent network of its own (the MAPPO repository's design), or a value
/// head on the actor's trunk (`shared_trunk`: JaxMARL's IPPO, whose one GRU feeds both heads).
#[derive(Debug, Clone)]
pub enum Critic {
    Own(AgentNet),
    /// One linear layer `hidden -> 1` on the actor's GRU output. In the flat vector it is the
    /// last row of the actor's output layer (the fused network's `out` is `n_actions + 1`).
    Head(Linear),
}

/// Statistics of one update (means over its epochs and mini-batches).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PpoStats {
    pub loss: f64,
    pub policy_loss: f64,
    pub value_loss: f64,
    pub entropy: f64,
    /// Gradient norms before clipping.
    pub actor_grad_norm: f64,
    pub critic_grad_norm: f64,
    /// The rollout's mean value estimate (denormalised) over active rows.
    pub value_mean: f64,
}

/// The loss of a batch and its parts.
#[derive(Debug)]
pub struct Losses {
    pub total: Tensor,
    pub policy: Tensor,
    pub value: Tensor,
    pub entropy: Tensor,
}

/// Log-probabilities of every action with unavailable ones masked out: `logits` and the
/// additive `mask` (0 or [`MASKED`]) `(N, n_actions)`. The row maximum is a constant shift,
/// so it is taken outside the graph (fewer backward operations).
pub fn masked_log_softmax(logits: &Tensor, mask: &Tensor) -> Result<Tensor, Error> {
    let z = (logits + mask)?;
    let z = z.broadcast_sub(&z.max_keepdim(D::Minus1)?.detach())?;
    let lse = z.exp()?.sum_keepdim(D::Minus1)?.log()?;
    Ok(z.broadcast_sub(&lse)?)
}

/// One action per row drawn from the softmax of `logits` over the available actions
/// (`avail` 0/1), and its log-probability. An unavailable action has probability exactly 0
/// and is never drawn; a row with none available gets the no-op (0), log-probability 0.
pub fn sample_actions(logits: &[f32], avail: &[u8], n_actions: usize, rng: &mut ChaCha8Rng) -> (Vec<u32>, Vec<f32>) {
    let na = n_actions.max(1);
    logits
        .chunks_exact(na)
        .zip(avail.chunks_exact(na))
        .map(|(lr, ar)| {
            let avail_logits = || lr.iter().zip(ar).enumerate().filter(|(_, (_, m))| **m != 0).map(|(i, (&l, _))| (i, f64::from(l)));
            let Some(max) = avail_logits().map(|(_, l)| l).reduce(f64::max) else { return (0, 0.0) };
            let total: f64 = avail_logits().map(|(_, l)| (l - max).exp()).sum();
            let u = rng.random::<f64>() * total;
            let mut acc = 0.0;
            let mut pick = (0, max);
            for (i, l) in avail_logits() {
                pick = (i, l);
                acc += (l - max).exp();
                if u < acc {
                    break;
                }
            }
            (pick.0 as u32, (pick.1 - max - total.ln()) as f32)
        })
        .unzip()
}

/// Huber loss with threshold `delta` (`0`: half the squared error), elementwise.
fn huber(err: &Tensor, delta: f64) -> Result<Tensor, Error> {
    if delta <= 0.0 {
        return Ok((err.sqr()? * 0.5)?);
    }
    let a = err.abs()?;
    let q = a.minimum(delta)?;
    Ok(((q.sqr()? * 0.5)? + ((a - &q)? * delta)?)?)
}

fn adam(vars: Vec<Var>, lr: f64, eps: f64) -> Result<AdamW, Error> {
    Ok(AdamW::new(vars, ParamsAdamW { lr, beta1: 0.9, beta2: 0.999, eps, weight_decay: 0.0 })?)
}

/// The PPO learner. Its networks train as flat parameter vectors through the fused kernels
/// ([`crate::kernels`]); the candle networks (`actor`, `critic`) hold the same weights after
/// every update, for checkpoints, tests and the reference loss ([`PpoLearner::loss`]).
///
/// With the CNN encoder (image modes), the actor's flat vector is the agent network's
/// weights followed by the encoder's (the order of their variables in `agent_params`), so
/// one gradient, one global-norm clip and one Adam cover both, as they did when the encoder
/// trained in candle (Adam is elementwise: one over the concatenation is the two). The Swin
/// encoder still trains in candle, with its own `AdamW`.
#[derive(Debug)]
pub struct PpoLearner {
    pub cfg: Config,
    pub shape: Shape,
    /// The policy: the agent network (no mixer), saved as a Q-learner's checkpoint is.
    pub actor: Nets,
    pub critic: Critic,
    pub critic_params: Params,
    pub critic_input: CriticInput,
    pub value_norm: ValueNorm,
    /// With a shared trunk, one output more than the policy has actions: the value.
    actor_layout: NetLayout,
    /// `None` with a shared trunk.
    critic_layout: Option<NetLayout>,
    /// The agent network's weights (with a shared trunk's value row), then the fused
    /// encoder's (if any).
    actor_theta: Vec<f32>,
    /// The fused encoder and the buffers of its passes (kept across updates: they are an
    /// update's largest allocation).
    encoder_kernel: Option<EncoderLayout>,
    encoder_pass: Mutex<EncoderForward>,
    critic_theta: Vec<f32>,
    actor_adam: Adam,
    critic_adam: Adam,
    /// The Swin encoder's variables and their Adam (candle's, on candle gradients).
    encoder_vars: Vec<Var>,
    encoder_opt: Option<AdamW>,
    /// Updates done (one per rollout).
    pub updates: u64,
}

/// A batch's loss and gradients ([`PpoLearner::gradients`]).
#[derive(Debug)]
pub struct Gradients {
    /// The loss, its parts and its gradients with respect to the logits and values.
    pub loss: LossGrads,
    /// The agent network's flat parameter gradient ([`crate::kernels::NetLayout`]'s order),
    /// then the fused encoder's (CNN image modes).
    pub actor: Vec<f32>,
    pub critic: Vec<f32>,
    /// The Swin encoder's gradients (candle's).
    pub encoder: Option<GradStore>,
}

/// What one gradient step reports.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepReport {
    pub total: f64,
    pub policy: f64,
    pub value: f64,
    pub entropy: f64,
    pub actor_grad_norm: f64,
    pub critic_grad_norm: f64,
}

impl PpoLearner {
    /// Fresh networks, every weight drawn from `seed`.
    pub fn new(cfg: &Config, shape: Shape, seed: u64) -> Result<PpoLearner, Error> {
        let actor = Nets::new(cfg, &shape, seed)?;
        actor.agent_params.scale("fc2.", cfg.actor_out_gain)?;
        let critic_input = CriticInput::of(cfg);
        let mut critic_params = Params::default();
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xc817_1c00);
        let (critic, critic_layout) = if cfg.shared_trunk {
            (Critic::Head(Linear::new(&mut critic_params, "value", cfg.rnn_hidden_dim, 1, &mut rng)?), None)
        } else {
            let (input, hidden) = (critic_input.width(&shape.stacked(cfg.stacked_frames)), cfg.rnn_hidden_dim);
            // The critic is built as the actor is: recurrent (the MAPPO repository's `rmappo`)
            // or feed-forward (its `mappo`, which its scripts run on some maps).
            let net = if cfg.layer_norm {
                AgentNet::normed(&mut critic_params, input, hidden, 1, cfg.use_rnn, 1.0, &mut rng)?
            } else if cfg.use_rnn {
                AgentNet::new(&mut critic_params, input, hidden, 1, &mut rng)?
            } else {
                AgentNet::feed_forward(&mut critic_params, input, hidden, 1, &mut rng)?
            };
            let layout = net.layout();
            (Critic::Own(net), Some(layout))
        };
        let mut actor_layout = actor.agent.layout();
        if cfg.shared_trunk {
            actor_layout.out += 1;
        }
        let encoder_kernel = actor.encoder.as_ref().and_then(|e| e.kernel()).cloned();
        let encoder_vars: Vec<Var> =
            if encoder_kernel.is_some() { Vec::new() } else { actor.agent_params.vars_after(actor.agent.var_count()).cloned().collect() };
        let encoder_opt = if encoder_vars.is_empty() { None } else { Some(adam(encoder_vars.clone(), cfg.lr, cfg.optim_eps)?) };
        let actor_len = actor_layout.len() + encoder_kernel.as_ref().map_or(0, EncoderLayout::len);
        let mut l = PpoLearner {
            cfg: cfg.clone(),
            shape,
            actor,
            critic,
            critic_params,
            critic_input,
            value_norm: ValueNorm::default(),
            actor_adam: Adam::new(actor_len, cfg.lr, cfg.optim_eps),
            critic_adam: Adam::new(critic_layout.map_or(0, |l| l.len()), cfg.critic_lr, cfg.optim_eps),
            actor_layout,
            critic_layout,
            actor_theta: Vec::new(),
            encoder_kernel,
            encoder_pass: Mutex::new(EncoderForward::default()),
            critic_theta: Vec::new(),
            encoder_vars,
            encoder_opt,
            updates: 0,
        };
        l.load_weights()?;
        Ok(l)
    }

    /// How many of `agent_params`' variables the actor's flat vector holds.
    fn actor_vars(&self) -> usize {
        if self.encoder_kernel.is_some() { self.actor.agent_params.len() } else { self.actor.agent.var_count() }
    }

    /// Reads the candle networks' weights into the flat vectors (after a restore).
    pub fn load_weights(&mut self) -> Result<(), Error> {
        let actor = self.actor.agent_params.flat(self.actor_vars())?;
        match &self.critic {
            Critic::Own(net) => {
                self.actor_theta = actor;
                self.critic_theta = self.critic_params.flat(net.var_count())?;
            }
            // Features only (the config refuses an encoder with a shared trunk): the output
            // layer ends the vector.
            Critic::Head(_) => {
                let head = self.critic_params.flat(2)?;
                self.actor_theta = with_value_row(&actor, &head, self.actor_layout.out - 1);
                self.critic_theta = Vec::new();
            }
        }
        Ok(())
    }

    /// Writes the flat vectors into the candle networks (done after every update).
    pub fn store_weights(&self) -> Result<(), Error> {
        match &self.critic {
            Critic::Own(net) => {
                self.actor.agent_params.set_flat(self.actor_vars(), &self.actor_theta)?;
                self.critic_params.set_flat(net.var_count(), &self.critic_theta)
            }
            Critic::Head(_) => {
                let (actor, head) = without_value_row(&self.actor_theta, self.actor_layout.out - 1, self.actor_layout.hidden);
                self.actor.agent_params.set_flat(self.actor.agent.var_count(), &actor)?;
                self.critic_params.set_flat(2, &head)
            }
        }
    }

    /// Candle's gradients of the reference loss ([`PpoLearner::loss`]) in the fused
    /// vectors' layouts (actor, critic), for comparing the two.
    pub fn flat_gradients(&self, grads: &GradStore) -> Result<(Vec<f32>, Vec<f32>), Error> {
        let flat = |vars: &mut dyn Iterator<Item = &Var>| -> Result<Vec<f32>, Error> {
            let mut out = Vec::new();
            for v in vars {
                match grads.get(v) {
                    Some(g) => out.extend(g.flatten_all()?.to_vec1::<f32>()?),
                    None => out.extend(std::iter::repeat_n(0.0, v.elem_count())),
                }
            }
            Ok(out)
        };
        let actor = flat(&mut self.actor.agent_params.vars().take(self.actor_vars()))?;
        let critic = flat(&mut self.critic_params.vars())?;
        Ok(match self.critic {
            Critic::Own(_) => (actor, critic),
            Critic::Head(_) => (with_value_row(&actor, &critic, self.shape.n_actions), Vec::new()),
        })
    }

    /// The critic network's sizes (`None`: a value head on the actor's trunk).
    pub fn critic_layout(&self) -> Option<NetLayout> {
        self.critic_layout
    }

    /// Whether the critic is a head on the actor's trunk.
    pub fn shared(&self) -> bool {
        self.critic_layout.is_none()
    }

    /// The agent network's part of the actor's flat vector, and the encoder's.
    fn actor_parts(&self) -> (&[f32], &[f32]) {
        self.actor_theta.split_at(self.actor_layout.len())
    }

    /// The network of `net` unrolled over a batch's chunks from their first hidden states
    /// `h0`, zeroing the state where an episode starts: `(L * N, out)`.
    fn unroll(net: &AgentNet, x: &Tensor, h0: &Tensor, keep: &Tensor) -> Result<Tensor, Error> {
        net.head(&Self::unroll_hidden(net, x, h0, keep)?)
    }

    /// [`PpoLearner::unroll`]'s hidden states `(L * N, hidden)`, before the output layer.
    fn unroll_hidden(net: &AgentNet, x: &Tensor, h0: &Tensor, keep: &Tensor) -> Result<Tensor, Error> {
        let (l, n, w) = x.dims3()?;
        let gi = net.project(&x.reshape((l * n, w))?)?.reshape((l, n, ()))?;
        let mut h = h0.clone();
        let mut hs = Vec::with_capacity(l);
        for li in 0..l {
            if li > 0 {
                h = h.broadcast_mul(&keep.get(li)?)?;
            }
            h = net.recur(&gi.get(li)?, &h)?;
            hs.push(h.clone());
        }
        Ok(Tensor::stack(&hs, 0)?.reshape((l * n, net.hidden))?)
    }

    /// The actor's inputs `(L, N, input)`: the batch's rows as they are in `features` mode,
    /// else fused with the encoder's features of the frame each row saw (the encoder runs on
    /// the whole rollout's frames, with gradients).
    fn actor_inputs(&self, b: &PpoBatch) -> Result<Tensor, Error> {
        let Some(e) = &self.actor.encoder else { return Ok(b.actor_in.clone()) };
        let Some((frames, idx)) = &b.frames else {
            return Err(Error::Observation { message: "an image encoder was given a batch without frames".into() });
        };
        let (l, n, w) = b.actor_in.dims3()?;
        let rows = e.forward(frames)?.index_select(&idx.flatten_all()?, 0)?;
        Ok(e.fuse_rows(rows, &b.actor_in.reshape((l * n, w))?)?.reshape((l, n, ()))?)
    }

    /// The PPO loss of a batch (MAPPO's, with its means over active rows only).
    pub fn loss(&self, b: &PpoBatch) -> Result<Losses, Error> {
        let cfg = &self.cfg;
        let flat = |x: &Tensor| -> Result<Tensor, Error> {
            let (l, n, w) = x.dims3()?;
            Ok(x.reshape((l * n, w))?)
        };
        let active = flat(&b.active)?;
        let n_active = f64::from(active.sum_all()?.to_scalar::<f32>()?).max(1.0);
        let mean = |x: &Tensor| -> Result<Tensor, Error> { Ok(((x * &active)?.sum_all()? / n_active)?) };

        let (logits, values) = match &self.critic {
            Critic::Own(critic) => (
                Self::unroll(&self.actor.agent, &self.actor_inputs(b)?, &b.h_actor, &b.keep)?,
                Self::unroll(critic, &b.critic_in, &b.h_critic, &b.keep)?,
            ),
            Critic::Head(head) => {
                let hs = Self::unroll_hidden(&self.actor.agent, &self.actor_inputs(b)?, &b.h_actor, &b.keep)?;
                (self.actor.agent.head(&hs)?, head.forward(&hs)?)
            }
        };
        let logp_all = masked_log_softmax(&logits, &flat(&b.mask)?)?;
        let entropy = (logp_all.exp()? * &logp_all)?.sum_keepdim(D::Minus1)?.neg()?;
        let logp = logp_all.gather(&flat(&b.actions)?, D::Minus1)?;
        let ratio = (logp - flat(&b.old_logp)?)?.exp()?;
        let adv = flat(&b.adv)?;
        let s1 = (&ratio * &adv)?;
        let s2 = (ratio.clamp(1.0 - cfg.clip_param, 1.0 + cfg.clip_param)? * &adv)?;
        let policy = mean(&s1.minimum(&s2)?)?.neg()?;
        let entropy = mean(&entropy)?;

        let targets = flat(&b.targets)?;
        let mut vloss = huber(&(&targets - &values)?, cfg.huber_delta)?;
        if cfg.clip_value_loss {
            let old = flat(&b.old_values)?;
            let clipped = (&old + (&values - &old)?.clamp(-cfg.clip_param, cfg.clip_param)?)?;
            vloss = vloss.maximum(&huber(&(&targets - clipped)?, cfg.huber_delta)?)?;
        }
        let value = mean(&vloss)?;
        let total = ((&policy - (&entropy * cfg.entropy_coef)?)? + (&value * cfg.value_loss_coef)?)?;
        Ok(Losses { total, policy, value, entropy })
    }

    /// The actor's input rows `(L * N, input)` of a batch: as they are in `features` mode,
    /// else fused with the candle encoder's features (a candle tensor with its graph,
    /// returned too: the encoder learns through it).
    fn actor_rows(&self, b: &FlatBatch) -> Result<(Vec<f32>, Option<Tensor>), Error> {
        let Some(e) = &self.actor.encoder else { return Ok((b.actor_in.clone(), None)) };
        let Some((frames, idx)) = &b.frames else {
            return Err(Error::Observation { message: "an image encoder was given a batch without frames".into() });
        };
        let rows = b.l * b.n;
        let idx = Tensor::from_slice(idx, idx.len(), &Device::Cpu)?;
        let feats = e.forward(&frames.tensors()?)?.index_select(&idx, 0)?;
        let base = Tensor::from_slice(&b.actor_in, (rows, b.actor_in.len() / rows.max(1)), &Device::Cpu)?;
        let x = e.fuse_rows(feats, &base)?;
        Ok((x.flatten_all()?.to_vec1()?, Some(x)))
    }

    /// The loss of a batch and its gradients, by the fused kernels, without changing
    /// anything.
    pub fn gradients(&self, b: &FlatBatch) -> Result<Gradients, Error> {
        let cfg = &self.cfg;
        let (l, n) = (b.l, b.n);
        let (theta, theta_enc) = self.actor_parts();
        // The fused encoder's pass over the frames the batch's rows see (each once), and
        // each row's frame among them.
        let mut encoded = None;
        let (x, x_graph) = match (&self.actor.encoder, &self.encoder_kernel) {
            (Some(e), Some(k)) => {
                let Some((frames, idx)) = &b.frames else {
                    return Err(Error::Observation { message: "an image encoder was given a batch without frames".into() });
                };
                let (pick, row_frame) = frames_seen(idx, frames.n);
                let px = Pixels { pick: pick.as_deref(), ..frames.pixels() };
                let mut f = std::mem::take(&mut *self.encoder_pass.lock().map_err(|_| poisoned())?);
                k.forward_into(theta_enc, &px, true, &mut f)?;
                let x = e.fuse_flat(&f.out, &row_frame, &b.actor_in);
                encoded = Some((f, pick, row_frame));
                (x, None)
            }
            _ => self.actor_rows(b)?,
        };
        let fa = self.actor_layout.forward(theta, &x, &b.h_actor, Some(&b.keep), Want::Mask(&b.active), l, n, true);
        let fc = self.critic_layout.map(|cl| {
            cl.forward_input(&self.critic_theta, b.critic.input(), &b.h_critic, Some(&b.keep), Want::Mask(&b.active), l, n, true)
        });
        let na = self.shape.n_actions;
        // A shared trunk's outputs are the logits and then the value, per row.
        let split = fc.is_none().then(|| split_value(&fa.out, na));
        let (logits, values) = match (&split, &fc) {
            (Some((lg, v)), _) => (&lg[..], &v[..]),
            (None, Some(fc)) => (&fa.out[..], &fc.out[..]),
            (None, None) => unreachable!("a critic of its own, or the actor's value head"),
        };
        let settings = LossSettings {
            clip: cfg.clip_param as f32,
            entropy_coef: cfg.entropy_coef as f32,
            value_coef: cfg.value_loss_coef as f32,
            huber_delta: cfg.huber_delta as f32,
            clip_value_loss: cfg.clip_value_loss,
        };
        let rows = LossRows {
            n_actions: na,
            logits,
            mask: &b.mask,
            actions: &b.actions,
            old_logp: &b.old_logp,
            adv: &b.adv,
            active: &b.active,
            values,
            old_values: &b.old_values,
            targets: &b.targets,
        };
        let lg = ppo_loss(&rows, &settings);
        if !lg.total.is_finite() || lg.total.abs() > 1e8 {
            return Err(Error::Diverged { update: self.updates, loss: lg.total });
        }
        let mut ga = vec![0f32; self.actor_theta.len()];
        let (ga_net, ga_enc) = ga.split_at_mut(self.actor_layout.len());
        let want_dx = x_graph.is_some() || encoded.is_some();
        let mut gc = vec![0f32; self.critic_theta.len()];
        let dx = match (&fc, self.critic_layout) {
            (Some(fc), Some(cl)) => {
                cl.backward(&self.critic_theta, fc, &lg.d_values, None, &mut gc, false);
                self.actor_layout.backward(theta, &fa, &lg.d_logits, None, ga_net, want_dx)
            }
            _ => {
                let d_out: Vec<f32> = lg
                    .d_logits
                    .chunks_exact(na)
                    .zip(&lg.d_values)
                    .flat_map(|(d, &v)| d.iter().copied().chain(std::iter::once(v)))
                    .collect();
                self.actor_layout.backward(theta, &fa, &d_out, None, ga_net, want_dx)
            }
        };
        if let (Some((mut f, pick, row_frame)), Some(e), Some(k), Some((frames, _)), Some(dx)) =
            (encoded, &self.actor.encoder, &self.encoder_kernel, &b.frames, dx.as_deref())
        {
            let d_feats = e.feature_grads(dx, &row_frame, f.n);
            let px = Pixels { pick: pick.as_deref(), ..frames.pixels() };
            k.backward(theta_enc, &mut f, &px, &d_feats, ga_enc);
            *self.encoder_pass.lock().map_err(|_| poisoned())? = f;
        }
        let enc = match (x_graph, dx) {
            (Some(xg), Some(dx)) => {
                let d = Tensor::from_vec(dx, xg.dims(), &Device::Cpu)?;
                Some((xg * d)?.sum_all()?.backward()?)
            }
            _ => None,
        };
        Ok(Gradients { loss: lg, actor: ga, critic: gc, encoder: enc })
    }

    /// One gradient step of actor and critic on `b` (each clipped to `grad_norm_clip`).
    pub fn step(&mut self, b: &FlatBatch) -> Result<StepReport, Error> {
        let Gradients { loss: lg, actor: mut ga, critic: mut gc, encoder: enc } = self.gradients(b)?;
        let clip = self.cfg.grad_norm_clip;
        let an = match enc {
            None => clip_global_norm(&mut ga, clip),
            Some(mut grads) => {
                // One norm over the agent network and its encoder, as one network.
                let mut sq: f64 = ga.iter().map(|&g| f64::from(g) * f64::from(g)).sum();
                for v in &self.encoder_vars {
                    if let Some(g) = grads.get(v) {
                        sq += f64::from(g.sqr()?.sum_all()?.to_scalar::<f32>()?);
                    }
                }
                let norm = sq.sqrt();
                if norm > clip {
                    let s = clip / (norm + 1e-6);
                    ga.iter_mut().for_each(|g| *g *= s as f32);
                    for v in &self.encoder_vars {
                        if let Some(g) = grads.remove(v) {
                            grads.insert(v, (g * s)?);
                        }
                    }
                }
                if let Some(opt) = &mut self.encoder_opt {
                    opt.step(&grads)?;
                }
                norm
            }
        };
        let cn = clip_global_norm(&mut gc, clip);
        self.actor_adam.step(&mut self.actor_theta, &ga);
        self.critic_adam.step(&mut self.critic_theta, &gc);
        Ok(StepReport {
            total: lg.total,
            policy: lg.policy,
            value: lg.value,
            entropy: lg.entropy,
            actor_grad_norm: an,
            critic_grad_norm: cn,
        })
    }

    /// Advantages and value targets of a finished rollout, then `ppo_epochs` passes of
    /// `num_mini_batch` steps over its chunks (shuffled by `rng` when more than one).
    pub fn update(&mut self, r: &Rollout, rng: &mut ChaCha8Rng) -> Result<PpoStats, Error> {
        let cfg = self.cfg.clone();
        let (t, rows) = (r.t, r.rows);
        let values: Vec<f32> = r.values.iter().map(|&v| if cfg.value_norm { self.value_norm.denormalize(v) } else { v }).collect();
        let a = self.shape.n_agents.max(1);
        let envs = rows / a;
        let per_row = |x: &[f32]| -> Vec<f32> { (0..t * rows).map(|i| x[(i / rows) * envs + (i % rows) / a]).collect() };
        let adv = gae(&per_row(&r.reward), &values, &per_row(&r.done), rows, cfg.gamma, cfg.gae_lambda);
        let returns: Vec<f32> = adv.iter().zip(&values).map(|(a, v)| a + v).collect();
        if cfg.value_norm {
            self.value_norm.update(&returns);
        }
        let targets: Vec<f32> = returns.iter().map(|&g| if cfg.value_norm { self.value_norm.normalize(g) } else { g }).collect();
        // Advantages standardised over the active rows (MAPPO).
        let n_act = r.active.iter().sum::<f32>().max(1.0) as f64;
        let m = adv.iter().zip(&r.active).map(|(&x, &w)| f64::from(x * w)).sum::<f64>() / n_act;
        let var = adv.iter().zip(&r.active).map(|(&x, &w)| f64::from(w) * (f64::from(x) - m).powi(2)).sum::<f64>() / n_act;
        let sd = var.sqrt() + 1e-5;
        let adv_n: Vec<f32> = adv.iter().map(|&x| ((f64::from(x) - m) / sd) as f32).collect();
        let value_mean = values[..t * rows].iter().zip(&r.active).map(|(&v, &w)| f64::from(v * w)).sum::<f64>() / n_act;

        let batch = FlatBatch::new(r, &adv_n, &targets, cfg.data_chunk_length)?;
        let n = batch.len();
        let mb = cfg.num_mini_batch.clamp(1, n.max(1));
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut stats = PpoStats { value_mean, ..PpoStats::default() };
        let mut steps = 0f64;
        for _ in 0..cfg.ppo_epochs {
            if mb > 1 {
                order.shuffle(rng);
            }
            for k in 0..mb {
                let part;
                let b = if mb == 1 {
                    &batch
                } else {
                    part = batch.select(&order[k * n / mb..(k + 1) * n / mb]);
                    &part
                };
                let st = self.step(b)?;
                stats.loss += st.total;
                stats.policy_loss += st.policy;
                stats.value_loss += st.value;
                stats.entropy += st.entropy;
                stats.actor_grad_norm += st.actor_grad_norm;
                stats.critic_grad_norm += st.critic_grad_norm;
                steps += 1.0;
            }
        }
        for x in [
            &mut stats.loss,
            &mut stats.policy_loss,
            &mut stats.value_loss,
            &mut stats.entropy,
            &mut stats.actor_grad_norm,
            &mut stats.critic_grad_norm,
        ] {
            *x /= steps.max(1.0);
        }
        self.updates += 1;
        self.store_weights()?;
        Ok(stats)
    }

    /// The acting step for `rows` rows: actor logits and critic values and the next hidden
    /// states (`rows x hidden`).
    pub fn act(&self, x_actor: &[f32], h_actor: &[f32], x_critic: Input<'_>, h_critic: &[f32]) -> Result<ActOut, Error> {
        self.act_with(x_actor, h_actor, x_critic, h_critic, None)
    }

    /// [`PpoLearner::act`] in an image mode: `frames` holds each environment's observation.
    pub fn act_with(
        &self,
        x_actor: &[f32],
        h_actor: &[f32],
        x_critic: Input<'_>,
        h_critic: &[f32],
        frames: Option<&StepFrames>,
    ) -> Result<ActOut, Error> {
        let rows = h_actor.len() / self.actor_layout.hidden.max(1);
        let (theta, theta_enc) = self.actor_parts();
        let xa = match (&self.actor.encoder, &self.encoder_kernel, frames) {
            (None, ..) => x_actor.to_vec(),
            (Some(e), Some(k), Some(f)) => {
                let feats = k.forward(theta_enc, &f.pixels(), false)?.out;
                let a = self.shape.n_agents.max(1);
                let row_frame: Vec<u32> = (0..rows).map(|r| (r / a) as u32).collect();
                e.fuse_flat(&feats, &row_frame, x_actor)
            }
            (Some(_), ..) => {
                let xa = Tensor::from_slice(x_actor, (rows, x_actor.len() / rows.max(1)), &Device::Cpu)?;
                let tensors = frames.map(StepFrames::tensors).transpose()?;
                self.actor.step_inputs(xa, tensors.as_ref())?.flatten_all()?.to_vec1()?
            }
        };
        let fa = self.actor_layout.forward(theta, &xa, h_actor, None, Want::All, 1, rows, false);
        match self.critic_layout {
            Some(cl) => {
                let fc = cl.forward_input(&self.critic_theta, x_critic, h_critic, None, Want::All, 1, rows, false);
                Ok(ActOut { logits: fa.out, values: fc.out, h_actor: fa.hidden, h_critic: fc.hidden })
            }
            None => {
                let (logits, values) = split_value(&fa.out, self.shape.n_actions);
                Ok(ActOut { logits, values, h_actor: fa.hidden, h_critic: Vec::new() })
            }
        }
    }

    /// The critic's values of `rows` rows (a rollout's bootstrap): from the critic's inputs
    /// and hidden states, or with a shared trunk from the actor's.
    pub fn values(&self, x_actor: &[f32], h_actor: &[f32], x_critic: Input<'_>, h_critic: &[f32]) -> Vec<f32> {
        match self.critic_layout {
            Some(cl) => {
                let rows = h_critic.len() / cl.hidden.max(1);
                cl.forward_input(&self.critic_theta, x_critic, h_critic, None, Want::All, 1, rows, false).out
            }
            None => {
                let rows = h_actor.len() / self.actor_layout.hidden.max(1);
                let fa = self.actor_layout.forward(self.actor_parts().0, x_actor, h_actor, None, Want::All, 1, rows, false);
                split_value(&fa.out, self.shape.n_actions).1
            }
        }
    }

    /// Writes the critic's weights (`critic.safetensors`) into `dir`.
    /// The actor's and the critic's Adam states, kept across a resume (the Swin encoder's
    /// candle Adam starts afresh).
    pub(crate) fn moments(&self) -> [(&'static str, Moments); 2] {
        [("actor", self.actor_adam.moments()), ("critic", self.critic_adam.moments())]
    }

    /// Takes up saved Adam states (see [`PpoLearner::moments`]), by name.
    pub(crate) fn set_moments(&mut self, name: &str, m: Moments) -> Result<(), String> {
        match name {
            "actor" => self.actor_adam.set_moments(m),
            "critic" => self.critic_adam.set_moments(m),
            other => Err(format!("no optimiser named `{other}`")),
        }
    }

    pub fn save_critic(&self, dir: &std::path::Path) -> Result<(), Error> {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
        crate::aside::tensors(&self.critic_params.to_map(), &dir.join("critic.safetensors"))
    }
}

/// What [`PpoLearner::act`] returns.
#[derive(Debug)]
pub struct ActOut {
    pub logits: Vec<f32>,
    pub values: Vec<f32>,
    pub h_actor: Vec<f32>,
    pub h_critic: Vec<f32>,
}

/// A shared trunk's outputs `(rows, n_actions + 1)` as logits `(rows, n_actions)` and values.
fn split_value(out: &[f32], na: usize) -> (Vec<f32>, Vec<f32>) {
    let logits = out.chunks_exact(na + 1).flat_map(|r| r[..na].iter().copied()).collect();
    let values = out.chunks_exact(na + 1).map(|r| r[na]).collect();
    (logits, values)
}

/// The agent network's flat weights `actor` (output layer `n_actions x hidden` and its bias
/// last) with a value head's `[w (hidden), b]` appended as one more output row.
fn with_value_row(actor: &[f32], head: &[f32], na: usize) -> Vec<f32> {
    let h = head.len() - 1;
    let base = actor.len() - na * h - na;
    let mut out = Vec::with_capacity(actor.len() + head.len());
    out.extend_from_slice(&actor[..base + na * h]);
    out.extend_from_slice(&head[..h]);
    out.extend_from_slice(&actor[base + na * h..]);
    out.push(head[h]);
    out
}

/// The inverse of [`with_value_row`]: the agent network's weights and the head's.
fn without_value_row(theta: &[f32], na: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
    let base = theta.len() - (na + 1) * h - (na + 1);
    let mut actor = Vec::with_capacity(theta.len() - h - 1);
    actor.extend_from_slice(&theta[..base + na * h]);
    actor.extend_from_slice(&theta[base + (na + 1) * h..theta.len() - 1]);
    let mut head = theta[base + na * h..base + (na + 1) * h].to_vec();
    head.push(theta[theta.len() - 1]);
    (actor, head)
}

/// The frames a batch's rows see (`idx`, of `stored`): `None` if every stored frame is
/// seen, else the seen ones in order; and each row's frame among those encoded.
fn frames_seen(idx: &[u32], stored: usize) -> (Option<Vec<u32>>, Vec<u32>) {
    let mut at = vec![u32::MAX; stored];
    for &i in idx {
        if let Some(a) = at.get_mut(i as usize) {
            *a = 0;
        }
    }
    if at.iter().all(|&a| a == 0) {
        return (None, idx.to_vec());
    }
    let mut pick = Vec::new();
    for (i, a) in at.iter_mut().enumerate() {
        if *a == 0 {
            *a = pick.len() as u32;
            pick.push(i as u32);
        }
    }
    (Some(pick), idx.iter().map(|&i| at.get(i as usize).copied().unwrap_or(u32::MAX)).collect())
}

fn poisoned() -> Error {
    Error::Observation { message: "a thread panicked while it held the encoder's buffers".into() }
}

/// The additive logit masks (`0` or [`MASKED`]) of 0/1 availability masks.
pub fn additive_mask(avail: &[u8]) -> impl Iterator<Item = f32> + '_ {
    avail.iter().map(|&m| if m != 0 { 0.0 } else { MASKED })
}
