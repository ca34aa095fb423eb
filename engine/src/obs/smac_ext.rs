//! The opt-in ability extension of SMAC's discrete actions, so MARL algorithms can learn
//! to use abilities. After SMAC's own actions come `slots` blocks of `width` actions each.
//! Slot `k` of an agent is the `k`-th ability of its unit type (all modes, table order, so
//! a tank's slots stay put when it sieges); index `j` in the block picks the target by the
//! ability's rule: self-cast (`j = 0`), enemy `j`, enemy `j`'s position, ally `j` (agent
//! order), or direction `j` (up, down, right, left, as SMAC's moves). Observations gain the
//! agent's energy fraction and one "some target available" flag per slot.

use super::slots::DIRS;
use super::smac::Known;
use super::smac::SmacLayout;
use crate::ability::{Ability, AbilityTarget, SlotRule};
use crate::action::Command;
use crate::geom::Vec2;
use crate::rules::Facts;
use crate::world::{Unit, World};

impl SmacLayout {
    /// First index of the ability block (SMAC's own action count).
    pub fn ability_base(&self) -> usize {
        self.n_actions - self.abilities.n_actions()
    }

    /// The command for ability-block offset `off` of `agent`; `None` when the target is a
    /// unit `known` does not hold (an observation's unseen enemy or the agent's own dead unit).
    pub(crate) fn ability_command(&self, known: &impl Known, agent: usize, off: usize) -> Option<Command> {
        let w = self.abilities.width;
        let (k, j) = (off / w.max(1), off % w.max(1));
        let ability = *self.abilities.per_agent.get(agent)?.get(k)?;
        let me = known.body(*self.agents.get(agent)?)?;
        let target = match ability.spec().slot {
            SlotRule::NoTarget if j == 0 => AbilityTarget::None,
            SlotRule::NoTarget => return None,
            SlotRule::EnemyUnit => AbilityTarget::Unit { unit: *self.enemies.get(j)? },
            SlotRule::EnemyPoint => AbilityTarget::Point { to: known.body(*self.enemies.get(j)?)?.pos() },
            SlotRule::AllyUnit => AbilityTarget::Unit { unit: *self.agents.get(j)? },
            SlotRule::Direction => {
                let d = DIRS.get(j)?.vector();
                let r = me.radius();
                let reach = ability.spec().range + r - 0.01;
                AbilityTarget::Point { to: self.playable().clamp(me.pos() + d * reach, r) }
            }
        };
        Some(Command::Ability { ability, target })
    }

    /// Whether ability-block offset `off` is available to living agent `u`.
    pub(crate) fn ability_available(&self, world: &World, agent: usize, u: &Unit, off: usize) -> bool {
        if u.status.morph.is_some() {
            return false;
        }
        let Some(Command::Ability { ability, target }) = self.ability_command(world, agent, off) else { return false };
        // An area spell aimed at an enemy needs that enemy in sight (its position is not known otherwise).
        if ability.spec().slot == SlotRule::EnemyPoint && !world.visible_to(self.team, self.enemies[off % self.abilities.width]) {
            return false;
        }
        world.check_cast(self.team, u, ability, target).is_ok()
    }

    /// Fills the ability block of an availability mask.
    pub(crate) fn ability_mask(&self, world: &World, agent: usize, u: &Unit, out: &mut [u8]) {
        let base = self.ability_base();
        let w = self.abilities.width;
        let Some(list) = self.abilities.per_agent.get(agent) else { return };
        for (k, &a) in list.iter().enumerate() {
            // One cheap check first: most of the time the ability is not castable at all.
            if u.status.morph.is_some() || world.can_cast(u, a).is_err() {
                continue;
            }
            for j in 0..w {
                out[base + k * w + j] = self.ability_available(world, agent, u, k * w + j) as u8;
            }
        }
    }

    /// The extra observation features: energy fraction, then per slot whether some target
    /// is available now.
    pub(crate) fn ability_obs(&self, world: &World, agent: usize, u: &Unit, out: &mut [f32]) {
        let emax = u.spec().energy_max;
        out[0] = if emax > 0.0 { u.energy / emax } else { 0.0 };
        let Some(list) = self.abilities.per_agent.get(agent) else { return };
        let w = self.abilities.width;
        for (k, &a) in list.iter().enumerate() {
            if world.can_cast(u, a).is_err() {
                continue;
            }
            out[1 + k] = (0..w).any(|j| self.ability_available(world, agent, u, k * w + j)) as u8 as f32;
        }
    }

    /// Ability-block index of a typed ability command, where it has one.
    pub(crate) fn ability_index(&self, world: &World, agent: usize, ability: Ability, target: &AbilityTarget) -> Option<usize> {
        let k = self.abilities.per_agent.get(agent)?.iter().position(|&a| a == ability)?;
        let j = match (ability.spec().slot, target) {
            (SlotRule::NoTarget, AbilityTarget::None) => 0,
            (SlotRule::EnemyUnit, AbilityTarget::Unit { unit }) => self.enemies.iter().position(|e| e == unit)?,
            (SlotRule::AllyUnit, AbilityTarget::Unit { unit }) => self.agents.iter().position(|e| e == unit)?,
            (SlotRule::EnemyPoint, AbilityTarget::Point { to }) => {
                self.enemies.iter().position(|&e| world.unit(e).is_some_and(|eu| eu.pos.dist_sq(*to) < 1e-6))?
            }
            (SlotRule::Direction, AbilityTarget::Point { to }) => {
                let u = world.unit(self.agents[agent])?;
                let d: Vec2 = (*to - u.pos).normalized();
                DIRS.iter().position(|dir| dir.vector().dot(d) > 0.99)?
            }
            _ => return None,
        };
        Some(self.ability_base() + k * self.abilities.width + j)
    }
}
