//! SMACv2's extended partial observability (EPO, `prob_obs_enemy`): which agents of a team
//! may observe which enemies.
//!
//! SMACv2 decides this inside `get_obs_agent`, so what an agent sees there depends on
//! which observations were asked for and in which (shuffled) order. Here the same rules run
//! once per environment step, at reset and after each step (when SMACv2's runner calls
//! `get_obs`), from the episode's seed: an observation is a pure read of the episode, and
//! a run replays whatever its caller reads.
//!
//! The rules, SMACv2's (`starcraft2.py`):
//! - each step, the living agents in a shuffled order look at the enemies in id order; an
//!   agent that sees an untagged enemy (within its sight, as the observation's features)
//!   tags it and may observe it, and each other agent may observe it with probability
//!   `prob_obs_enemy`;
//! - an agent observes an enemy's features only while allowed to and within sight;
//! - when an enemy dies, it is untagged and nobody may observe it; when an agent dies, each
//!   enemy it had tagged is untagged, nobody may observe those, and the agent may observe
//!   nothing until it tags again (it never does: it is dead).
//!
//! One change, on purpose: where an agent may not observe enemy `e`, SMACv2 zeroes the
//! whole enemy block of its observation built so far, not row `e` (oxwhirl/smacv2#50 asks
//! whether that was meant). Here only row `e` is zeroed, which is what the paper describes.

use crate::hash::Fnv;
use crate::obs::SmacLayout;
use crate::world::World;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One team's EPO state.
#[derive(Clone, Debug)]
pub(super) struct Epo {
    n_agents: usize,
    /// Per enemy, the agent that spotted it (None: untagged).
    tagger: Vec<Option<usize>>,
    /// `allowed[e * n_agents + a]`: agent `a` may observe enemy `e`.
    allowed: Vec<bool>,
    rng: ChaCha8Rng,
}

impl Epo {
    /// Nothing tagged. The stream is apart from the world's and the policies', so turning
    /// EPO on shifts no other draw of the episode.
    pub(super) fn new(seed: u64, team_index: usize, n_enemies: usize, n_agents: usize) -> Epo {
        let stream = seed ^ 0x5eed_0e90_0000_0000 ^ team_index as u64;
        Epo { n_agents, tagger: vec![None; n_enemies], allowed: vec![false; n_enemies * n_agents], rng: ChaCha8Rng::seed_from_u64(stream) }
    }

    /// After a step: forgets what deaths end, then tags what the living agents now see.
    pub(super) fn update(&mut self, layout: &SmacLayout, world: &World, prob: f32) {
        let alive = |id| world.unit(id).is_some_and(|u| u.alive);
        let n = self.n_agents;
        for (a, &id) in layout.agents.iter().enumerate() {
            if alive(id) {
                continue;
            }
            for e in 0..self.tagger.len() {
                if self.tagger[e] == Some(a) {
                    self.tagger[e] = None;
                    self.allowed[e * n..(e + 1) * n].fill(false);
                    // SMACv2 clears the dead agent's column only here, under a tag it held.
                    for row in self.allowed.chunks_exact_mut(n) {
                        row[a] = false;
                    }
                }
            }
        }
        for (e, &id) in layout.enemies.iter().enumerate() {
            if !alive(id) {
                self.tagger[e] = None;
                self.allowed[e * n..(e + 1) * n].fill(false);
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.shuffle(&mut self.rng);
        for a in order {
            for e in 0..self.tagger.len() {
                if self.tagger[e].is_some() || !layout.sees_enemy(world, a, e) {
                    continue;
                }
                self.tagger[e] = Some(a);
                self.allowed[e * n + a] = true;
                for b in (0..n).filter(|&b| b != a) {
                    self.allowed[e * n + b] = self.rng.random::<f32>() < prob;
                }
            }
        }
    }

    /// Zeroes the rows of the enemies `agent` may not observe.
    pub(super) fn mask(&self, layout: &SmacLayout, agent: usize, obs: &mut [f32]) {
        for e in 0..self.tagger.len() {
            if !self.allowed(agent, e)
                && let Some(row) = obs.get_mut(layout.enemy_row(e))
            {
                row.fill(0.0);
            }
        }
    }

    /// Whether `agent` may observe enemy `e` now.
    pub(super) fn allowed(&self, agent: usize, e: usize) -> bool {
        self.allowed.get(e * self.n_agents + agent).copied().unwrap_or(false)
    }

    pub(super) fn hash(&self, h: &mut Fnv) {
        h.u32(self.tagger.len() as u32);
        self.tagger.iter().for_each(|t| h.u32(t.map_or(u32::MAX, |a| a as u32)));
        h.bools(self.allowed.iter().copied());
        h.rng(&self.rng);
    }
}
