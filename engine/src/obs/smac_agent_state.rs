//! The MAPPO repository's agent-specific global state (marlbenchmark/on-policy,
//! `StarCraft2_Env.get_state_agent` under its SMAC defaults: `use_state_agent`,
//! `use_mustalive`, `add_center_xy`, `state_last_action`, `state_agent_id`). Each agent gets
//! its own row: every living unit of both teams as seen from that agent (no sight limit and
//! no fog: a critic's input for centralised training), its own features and its one-hot id.
//! Under [`SmacLayout::with_state_agent`] the state is the agents' rows one after another,
//! so one state per environment still holds all of them.
//!
//! A row, in the repository's order and normalisation:
//! - allies (the other agents, in agent order): visible (within sight), distance, relative
//!   x and y (over the agent's sight), weapon cooldown (a healer's energy) over SMAC's
//!   maximum, health, shield, position from the map's centre (over the playable size), type
//!   one-hot, last action one-hot;
//! - enemies: attack available, distance, relative x and y, visible, health, shield, type
//!   one-hot, position from the map's centre (the repository puts the type before the
//!   position here and after it for allies);
//! - the four move bits;
//! - own: 1, 0, 0, 0, health, shield, position from the map's centre, type one-hot, last
//!   action one-hot;
//! - the agent's one-hot id.
//!
//! A dead agent's row is zeros but for its id (`use_mustalive`).

use super::smac::{SmacLayout, cooldown_feature};
use crate::world::{Unit, World};

impl SmacLayout {
    /// The layout with the agent-specific state on or off (see the module's documentation).
    pub fn with_state_agent(mut self, on: bool) -> Self {
        self.state_agent = on;
        self.state_size = self.state_width();
        self
    }

    /// Whether the state is the agents' agent-specific rows ([`SmacLayout::with_state_agent`]).
    pub fn state_agent(&self) -> bool {
        self.state_agent
    }

    /// The width of one agent's row of the agent-specific state.
    pub fn agent_state_size(&self) -> usize {
        let tb = self.ally_types.len();
        let ally = 8 + self.shield_ally + tb + self.n_actions;
        let enemy = 8 + self.shield_enemy + tb;
        let own = 7 + self.shield_ally + tb + self.n_actions;
        (self.n_agents - 1) * ally + self.n_enemies * enemy + MOVE_FEATS + own + self.n_agents
    }

    /// Writes agent `agent`'s row of the agent-specific state into `out` (its width).
    pub(super) fn agent_state(&self, world: &World, agent: usize, last: &[Option<usize>], out: &mut [f32]) {
        out.fill(0.0);
        out[out.len() - self.n_agents + agent] = 1.0;
        let Some(u) = self.agents.get(agent).and_then(|&id| world.unit(id)).filter(|u| u.alive) else { return };
        let tb = self.ally_types.len();
        let sight = self.sight(u);
        let one_hot_action = |a: usize, out: &mut [f32]| {
            if let Some(i) = last.get(a).copied().flatten().filter(|&i| i < self.n_actions) {
                out[i] = 1.0;
            }
        };
        let mut off = 0;
        let wa = 8 + self.shield_ally + tb + self.n_actions;
        for (k, (a, &id)) in self.agents.iter().enumerate().filter(|&(a, _)| a != agent).enumerate() {
            let f = &mut out[off + k * wa..off + (k + 1) * wa];
            let Some(au) = world.unit(id).filter(|au| au.alive) else { continue };
            let d = au.pos - u.pos;
            let dist = d.len();
            f[0] = (dist < sight) as u8 as f32;
            f[1] = dist / sight;
            f[2] = d.x / sight;
            f[3] = d.y / sight;
            f[4] = cooldown_feature(au);
            let t = 5 + health_shield(au, self.shield_ally > 0, &mut f[5..]);
            f[t..t + 2].copy_from_slice(&self.centred(au.pos));
            Self::one_hot(&self.ally_types, au.kind, &mut f[t + 2..t + 2 + tb]);
            one_hot_action(a, &mut f[t + 2 + tb..]);
        }
        off += (self.n_agents - 1) * wa;
        let we = 8 + self.shield_enemy + tb;
        for (j, &e) in self.enemies.iter().enumerate() {
            let f = &mut out[off + j * we..off + (j + 1) * we];
            let Some(eu) = world.unit(e).filter(|eu| eu.alive) else { continue };
            let d = eu.pos - u.pos;
            let dist = d.len();
            f[0] = self.is_available(world, agent, self.attack_base() + j) as u8 as f32;
            f[1] = dist / sight;
            f[2] = d.x / sight;
            f[3] = d.y / sight;
            f[4] = (dist < sight) as u8 as f32;
            let t = 5 + health_shield(eu, self.shield_enemy > 0, &mut f[5..]);
            Self::one_hot(&self.enemy_types, eu.kind, &mut f[t..t + tb]);
            f[t + tb..t + tb + 2].copy_from_slice(&self.centred(eu.pos));
        }
        off += self.n_enemies * we;
        for k in 0..MOVE_FEATS {
            out[off + k] = self.is_available(world, agent, 2 + k) as u8 as f32;
        }
        off += MOVE_FEATS;
        let f = &mut out[off..off + 7 + self.shield_ally + tb + self.n_actions];
        f[0] = 1.0;
        let t = 4 + health_shield(u, self.shield_ally > 0, &mut f[4..]);
        f[t..t + 2].copy_from_slice(&self.centred(u.pos));
        Self::one_hot(&self.ally_types, u.kind, &mut f[t + 2..t + 2 + tb]);
        one_hot_action(agent, &mut f[t + 2 + tb..]);
    }

    /// Every agent's row, one after another ([`SmacLayout::state`] under the option).
    pub(super) fn agent_states(&self, world: &World, last: &[Option<usize>], out: &mut [f32]) {
        let w = self.agent_state_size();
        for (agent, row) in out.chunks_mut(w).take(self.n_agents).enumerate() {
            self.agent_state(world, agent, last, row);
        }
    }
}

const MOVE_FEATS: usize = 4;

/// Writes the unit's health fraction and, where the layout has the feature, its shield
/// fraction; returns how many features that was.
fn health_shield(u: &Unit, shield: bool, f: &mut [f32]) -> usize {
    f[0] = u.hp / u.max_hp;
    if !shield {
        return 1;
    }
    f[1] = if u.max_shield > 0.0 { u.shield / u.max_shield } else { 0.0 };
    2
}
