//! What abilities leave behind: per-unit buffs and timers, and area effects on the ground.
//! Everything is a loop number ("until"), so nothing needs counting down and a state is
//! exactly reproducible from the loop it was saved at. Casts accepted for the next loop are
//! kept here too: the world holds them, and its file must not depend on casting's.

use super::{Ability, AbilityTarget, SLOW_FACTOR, STIM_FACTOR};
use crate::flags::Buffs;
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::units::UnitKind;
use serde::Serialize;

/// A channelled ability in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Channel {
    /// Steady Targeting: the shot lands at `done` unless interrupted.
    Snipe { target: UnitId, done: u32 },
    /// Graviton Beam: the Phoenix holds `target` in the air.
    Graviton { target: UnitId },
}

/// Buffs, debuffs, timers and modes of one unit.
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    pub stim_until: u32,
    pub slow_until: u32,
    pub boost_until: u32,
    /// The Sentry's own Guardian Shield is up until then.
    pub guardian_until: u32,
    pub barrier_until: u32,
    pub barrier_hp: f32,
    pub cloaked: bool,
    /// Lifted by a Graviton Beam until then.
    pub lifted_until: u32,
    /// Transfusion's heal over time: HP per loop until then.
    pub hot_until: u32,
    pub hot_per_loop: f32,
    /// Morphing into a mode, done at that loop.
    pub morph: Option<(UnitKind, u32)>,
    pub channel: Option<Channel>,
    /// Next loop a Psionic Storm may damage it (storms do not stack).
    pub storm_next: u32,
    /// The loop from which the unit's ability with a cooldown may be cast again (no unit
    /// type has more than one such ability; a unit test holds the table to that).
    pub cooldown_until: u32,
    /// Under a friendly Guardian Shield this loop.
    pub guarded: bool,
    /// Cloaked and seen by an enemy detector this loop.
    pub detected: bool,
    /// Revealed (EMP) until then even if cloaked.
    pub revealed_until: u32,
    /// No timer of this unit runs past this loop: the per-loop update skips it after.
    pub(crate) quiet_after: u32,
}

impl Default for Status {
    fn default() -> Self {
        Self {
            stim_until: 0,
            slow_until: 0,
            boost_until: 0,
            guardian_until: 0,
            barrier_until: 0,
            barrier_hp: 0.0,
            cloaked: false,
            lifted_until: 0,
            hot_until: 0,
            hot_per_loop: 0.0,
            morph: None,
            channel: None,
            storm_next: 0,
            cooldown_until: 0,
            guarded: false,
            detected: false,
            revealed_until: 0,
            quiet_after: 0,
        }
    }
}

impl Status {
    /// Notes a timer running until `until`, so the per-loop update visits the unit.
    pub(crate) fn hold(&mut self, until: u32) {
        self.quiet_after = self.quiet_after.max(until);
    }
    /// Whether the per-loop update has nothing to do for this unit.
    pub(crate) fn quiet(&self, tick: u32) -> bool {
        tick > self.quiet_after && !self.cloaked && self.morph.is_none() && self.channel.is_none()
    }

    /// The loop from which `ability` may be cast again.
    pub fn ready_at(&self, ability: Ability) -> u32 {
        if ability.spec().cooldown > 0 { self.cooldown_until } else { 0 }
    }
    pub fn stimmed(&self, tick: u32) -> bool {
        tick < self.stim_until
    }
    pub fn slowed(&self, tick: u32) -> bool {
        tick < self.slow_until
    }
    pub fn boosted(&self, tick: u32) -> bool {
        tick < self.boost_until
    }
    pub fn lifted(&self, tick: u32) -> bool {
        tick < self.lifted_until
    }
    pub fn barrier_up(&self, tick: u32) -> bool {
        tick < self.barrier_until && self.barrier_hp > 0.0
    }
    pub fn guardian_up(&self, tick: u32) -> bool {
        tick < self.guardian_until
    }
    /// Cannot take orders of its own this loop (morphing, lifted, channelling).
    pub fn busy(&self, tick: u32) -> bool {
        self.morph.is_some() || self.lifted(tick) || self.channel.is_some()
    }
    /// Multiplier of the weapon's attack rate.
    pub fn attack_rate(&self, tick: u32) -> f32 {
        if self.stimmed(tick) { STIM_FACTOR } else { 1.0 }
    }
    /// Movement speed given the unit's base speed and its boosted speed (Afterburners).
    pub fn speed(&self, tick: u32, base: f32) -> f32 {
        if self.morph.is_some() || self.lifted(tick) || self.channel.is_some() {
            return 0.0;
        }
        let mut v = if self.boosted(tick) { base * super::AFTERBURNER_FACTOR } else { base };
        if self.stimmed(tick) {
            v *= STIM_FACTOR;
        }
        if self.slowed(tick) {
            v *= SLOW_FACTOR;
        }
        v
    }

    /// The active states, for observations (stimmed, cloaked, ...).
    pub fn buffs(&self, tick: u32) -> Buffs {
        let checks = [
            (self.stimmed(tick), Buffs::STIMMED),
            (self.slowed(tick), Buffs::SLOWED),
            (self.boosted(tick), Buffs::AFTERBURNERS),
            (self.guardian_up(tick), Buffs::GUARDIAN_SHIELD),
            (self.guarded, Buffs::GUARDIAN_SHIELDED),
            (self.barrier_up(tick), Buffs::BARRIER),
            (self.cloaked, Buffs::CLOAKED),
            (self.lifted(tick), Buffs::LIFTED),
            (tick < self.hot_until, Buffs::TRANSFUSING),
            (self.morph.is_some(), Buffs::MORPHING),
            (self.channel.is_some(), Buffs::CHANNELLING),
        ];
        let mut b = Buffs::empty();
        for (on, f) in checks {
            if on {
                b.insert(f);
            }
        }
        b
    }
}

/// Kinds of effect on the ground.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    PsionicStorm,
    ForceField,
    /// A Sentry's shield, centred on it.
    GuardianShield,
    /// A KD8 Charge about to detonate.
    Kd8Charge,
}

impl EffectKind {
    pub const ALL: [EffectKind; 4] = [EffectKind::PsionicStorm, EffectKind::ForceField, EffectKind::GuardianShield, EffectKind::Kd8Charge];
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::PsionicStorm => "psionic_storm",
            EffectKind::ForceField => "force_field",
            EffectKind::GuardianShield => "guardian_shield",
            EffectKind::Kd8Charge => "kd8_charge",
        }
    }
}

/// An area effect: where, whose, how big, and until which loop.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AreaEffect {
    pub kind: EffectKind,
    pub team: Team,
    pub owner: UnitId,
    pub pos: Vec2,
    pub radius: f32,
    pub start: u32,
    pub until: u32,
}

impl AreaEffect {
    pub fn active(&self, tick: u32) -> bool {
        tick < self.until
    }
    /// Whether a unit at `p` with radius `r` touches it.
    pub fn touches(&self, p: Vec2, r: f32) -> bool {
        p.dist_sq(self.pos) < (self.radius + r) * (self.radius + r)
    }
}

/// A cast accepted at submission, carried out at the start of the next loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PendingCast {
    pub team: Team,
    pub unit: UnitId,
    pub ability: Ability,
    pub target: AbilityTarget,
}
