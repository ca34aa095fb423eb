//! The acting side shared by training, test rounds and trained agents: epsilon-greedy choice
//! over the masks, and the rows' recurrent state between steps.

use crate::buffer::{Shape, act_inputs};
use crate::frames::StepFrames;
use crate::kernels::Want;
use crate::nets::Nets;
use crate::{Config, Error, Stack};
use avacraft_engine::VecBuffers;
use candle_core::{Device, Tensor};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Epsilon-greedy over the available actions of each row of `q` (`rows x n_actions`): with
/// probability `epsilon` a uniformly random available action, else the best available one
/// (the first on ties). An unavailable action is never chosen; a row with no available
/// action gets 0 (SMAC's no-op).
pub fn select_actions(q: &[f32], avail: &[u8], n_actions: usize, epsilon: f64, rng: &mut ChaCha8Rng) -> Vec<u32> {
    q.chunks_exact(n_actions.max(1))
        .zip(avail.chunks_exact(n_actions.max(1)))
        .map(|(qr, ar)| {
            let n_avail = ar.iter().filter(|&&m| m != 0).count();
            if n_avail == 0 {
                return 0;
            }
            if epsilon > 0.0 && rng.random::<f64>() < epsilon {
                let k = rng.random_range(0..n_avail);
                return ar.iter().enumerate().filter(|(_, m)| **m != 0).nth(k).map_or(0, |(i, _)| i as u32);
            }
            let mut best: Option<(usize, f32)> = None;
            for (i, (&v, &m)) in qr.iter().zip(ar).enumerate() {
                if m != 0 && best.is_none_or(|(_, bv)| v > bv) {
                    best = Some((i, v));
                }
            }
            best.map_or(0, |(i, _)| i as u32)
        })
        .collect()
}

/// The acting side of a set of rows (environments x agents): GRU hidden states, last
/// actions and (`stacked_frames`) the last observations, reset per environment when its
/// episode restarts. It acts through the fused
/// network ([`crate::kernels::NetLayout`]) on the flat weights it is handed.
pub(crate) struct Actor {
    h: Vec<f32>,
    last: Vec<Option<u32>>,
    agents: Vec<usize>,
    hidden: usize,
    /// Made at the first step, when the config says how many observations it stacks.
    stack: Option<Stack>,
}

impl Actor {
    pub(crate) fn new(nets: &Nets, envs: usize, n_agents: usize) -> Actor {
        let rows = envs * n_agents;
        let hidden = nets.agent.hidden;
        Actor {
            h: vec![0.0; rows * hidden],
            last: vec![None; rows],
            agents: (0..rows).map(|r| r % n_agents.max(1)).collect(),
            hidden,
            stack: None,
        }
    }

    /// Actions for every row, epsilon-greedy over the masks (`frames`: the image modes'),
    /// with the agent network's flat weights `theta`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn act(
        &mut self,
        theta: &[f32],
        nets: &Nets,
        cfg: &Config,
        shape: &Shape,
        b: &VecBuffers,
        frames: Option<&StepFrames>,
        eps: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Vec<u32>, Error> {
        let rows = self.agents.len();
        let stack = self.stack.get_or_insert_with(|| Stack::new(cfg.stacked_frames, shape.obs, rows));
        let obs = stack.push(&b.obs[..rows * shape.obs]);
        let net = shape.stacked(cfg.stacked_frames);
        let mut x = act_inputs(&obs, &self.agents, &self.last, &net, cfg.obs_agent_id, cfg.obs_last_action);
        if nets.encoder.is_some() {
            let width = net.input(cfg.obs_agent_id, cfg.obs_last_action);
            let t = Tensor::from_vec(x, (rows, width), &Device::Cpu)?;
            x = nets.step_inputs_pixels(t, frames)?.flatten_all()?.to_vec1()?;
        }
        let f = nets.agent.layout().forward(theta, &x, &self.h, None, Want::All, 1, rows, false);
        if nets.agent.is_recurrent() {
            self.h = f.hidden;
        }
        let acts = select_actions(&f.out, &b.avail, shape.n_actions, eps, rng);
        for (l, &a) in self.last.iter_mut().zip(&acts) {
            *l = Some(a);
        }
        Ok(acts)
    }

    /// The hidden states and last actions of every row (what a resumed run restores).
    pub(crate) fn state(&self) -> (&[f32], &[Option<u32>]) {
        (&self.h, &self.last)
    }

    /// Puts back what [`Actor::state`] gave; sizes must match.
    pub(crate) fn set_state(&mut self, h: Vec<f32>, last: Vec<Option<u32>>) -> Result<(), Error> {
        if h.len() != self.h.len() || last.len() != self.last.len() {
            return Err(Error::Checkpoint {
                message: format!(
                    "resume: {} hidden values and {} last actions kept, {} and {} wanted",
                    h.len(),
                    last.len(),
                    self.h.len(),
                    self.last.len()
                ),
            });
        }
        (self.h, self.last) = (h, last);
        Ok(())
    }

    /// Clears the rows of the environments whose episode just ended.
    pub(crate) fn reset_envs(&mut self, done: &[bool], n_agents: usize) {
        for (e, &d) in done.iter().enumerate() {
            if d {
                let rows = e * n_agents..(e + 1) * n_agents;
                self.h[rows.start * self.hidden..rows.end * self.hidden].fill(0.0);
                self.last[rows].iter_mut().for_each(|l| *l = None);
            }
        }
        if let Some(s) = &mut self.stack {
            s.clear(done, n_agents);
        }
    }
}
