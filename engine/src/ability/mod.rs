//! Unit abilities: the table of every ability the scenarios' units have, the refusal
//! reasons, and the per-unit and per-world state they leave behind (buffs, area effects).
//!
//! Values are StarCraft II's (patch 5.0.x), converted to game loops once. Where the
//! reference marks a value unconfirmed, the row says so and the README lists which value
//! was used. Casting is split in two: [`World::validate`](crate::World::validate) checks a
//! cast when it is submitted (typed refusal), and the cast resolves at the start of the next
//! game loop together with every other cast of both teams, in unit order, so neither side
//! reacts to a cast before the loop in which it happens.

mod status;

pub(crate) use status::PendingCast;
pub use status::{AreaEffect, Channel, EffectKind, Status};

use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::scenario::Upgrade;
use crate::time::LOOPS_PER_SECOND;
use crate::units::UnitKind;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// HP a Stimpack costs this unit type.
pub(crate) fn stim_cost(kind: UnitKind) -> f32 {
    if kind == UnitKind::Marauder { STIM_HP_MARAUDER } else { STIM_HP_MARINE }
}

/// Every castable ability. Passive ones (Combat Shield, Concussive Shells, cloak drain,
/// detection, cliff walking) are not here: they have no command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ability {
    Stimpack,
    Heal,
    Afterburners,
    SiegeMode,
    Unsiege,
    Kd8Charge,
    SteadyTargeting,
    Emp,
    Cloak,
    Decloak,
    FighterMode,
    AssaultMode,
    Blink,
    GuardianShield,
    ForceField,
    PsionicStorm,
    Feedback,
    Barrier,
    GravitonBeam,
    PhasingMode,
    TransportMode,
    Explode,
    Transfusion,
}

/// What an ability is cast on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TargetKind {
    None,
    Point,
    Unit,
    PointOrUnit,
}

/// The target given with a cast.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum AbilityTarget {
    None,
    Point { to: Vec2 },
    Unit { unit: UnitId },
}

/// Which units a unit-targeted ability accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetRule {
    /// No unit target.
    NoUnit,
    /// An enemy unit.
    Enemy,
    /// A friendly unit other than the caster.
    Ally,
}

/// How the opt-in SMAC ability slots choose a target for a discrete action.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SlotRule {
    /// Self-cast: one action.
    NoTarget,
    /// On enemy `j` (unit-targeted spells).
    EnemyUnit,
    /// At enemy `j`'s position (area spells).
    EnemyPoint,
    /// On ally `j` (agent order).
    AllyUnit,
    /// `range` in one of the four directions (Blink).
    Direction,
}

/// One row of the ability table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AbilitySpec {
    pub ability: Ability,
    pub target: TargetKind,
    pub rule: TargetRule,
    pub slot: SlotRule,
    pub energy: f32,
    /// Loops before the same unit may cast it again.
    pub cooldown: u32,
    /// Cast range: centre to point for point targets, edge to edge for unit targets.
    pub range: f32,
    pub upgrade: Option<Upgrade>,
    /// Whether this is StarCraft II's autocast default (Medivac heal, Immortal Barrier).
    pub autocast: bool,
}

/// Faster seconds to loops, at compile time.
const fn s(seconds: f32) -> u32 {
    (seconds * LOOPS_PER_SECOND + 0.5) as u32
}

const fn row(ability: Ability, target: TargetKind, rule: TargetRule, slot: SlotRule) -> AbilitySpec {
    AbilitySpec { ability, target, rule, slot, energy: 0.0, cooldown: 0, range: 0.0, upgrade: None, autocast: false }
}
const fn energy(r: AbilitySpec, energy: f32) -> AbilitySpec {
    AbilitySpec { energy, ..r }
}
const fn ranged(r: AbilitySpec, range: f32) -> AbilitySpec {
    AbilitySpec { range, ..r }
}
const fn cooldown(r: AbilitySpec, loops: u32) -> AbilitySpec {
    AbilitySpec { cooldown: loops, ..r }
}
const fn needs(r: AbilitySpec, up: Upgrade) -> AbilitySpec {
    AbilitySpec { upgrade: Some(up), ..r }
}

use Ability as Ab;
use SlotRule as Sl;
use TargetKind as Tk;
use TargetRule as Tr;

/// The table, in [`Ability`] order.
static SPECS: [AbilitySpec; 23] = [
    needs(row(Ab::Stimpack, Tk::None, Tr::NoUnit, Sl::NoTarget), Upgrade::Stimpack),
    AbilitySpec { autocast: true, ..ranged(row(Ab::Heal, Tk::Unit, Tr::Ally, Sl::AllyUnit), 4.0) },
    cooldown(row(Ab::Afterburners, Tk::None, Tr::NoUnit, Sl::NoTarget), s(AFTERBURNER_COOLDOWN_S)),
    row(Ab::SiegeMode, Tk::None, Tr::NoUnit, Sl::NoTarget),
    row(Ab::Unsiege, Tk::None, Tr::NoUnit, Sl::NoTarget),
    cooldown(ranged(row(Ab::Kd8Charge, Tk::PointOrUnit, Tr::Enemy, Sl::EnemyPoint), 5.0), s(KD8_COOLDOWN_S)),
    energy(ranged(row(Ab::SteadyTargeting, Tk::Unit, Tr::Enemy, Sl::EnemyUnit), 10.0), 50.0),
    energy(ranged(row(Ab::Emp, Tk::Point, Tr::NoUnit, Sl::EnemyPoint), 10.0), 75.0),
    energy(row(Ab::Cloak, Tk::None, Tr::NoUnit, Sl::NoTarget), CLOAK_ENERGY),
    row(Ab::Decloak, Tk::None, Tr::NoUnit, Sl::NoTarget),
    row(Ab::FighterMode, Tk::None, Tr::NoUnit, Sl::NoTarget),
    row(Ab::AssaultMode, Tk::None, Tr::NoUnit, Sl::NoTarget),
    needs(cooldown(ranged(row(Ab::Blink, Tk::Point, Tr::NoUnit, Sl::Direction), 8.0), s(BLINK_COOLDOWN_S)), Upgrade::Blink),
    cooldown(energy(row(Ab::GuardianShield, Tk::None, Tr::NoUnit, Sl::NoTarget), 75.0), GUARDIAN_LOOPS),
    energy(ranged(row(Ab::ForceField, Tk::Point, Tr::NoUnit, Sl::EnemyPoint), 9.0), 50.0),
    needs(
        cooldown(energy(ranged(row(Ab::PsionicStorm, Tk::Point, Tr::NoUnit, Sl::EnemyPoint), 9.0), 75.0), s(STORM_COOLDOWN_S)),
        Upgrade::PsionicStorm,
    ),
    energy(ranged(row(Ab::Feedback, Tk::Unit, Tr::Enemy, Sl::EnemyUnit), 10.0), 50.0),
    AbilitySpec { autocast: true, ..cooldown(row(Ab::Barrier, Tk::None, Tr::NoUnit, Sl::NoTarget), s(BARRIER_COOLDOWN_S)) },
    energy(ranged(row(Ab::GravitonBeam, Tk::Unit, Tr::Enemy, Sl::EnemyUnit), 4.0), 50.0),
    row(Ab::PhasingMode, Tk::None, Tr::NoUnit, Sl::NoTarget),
    row(Ab::TransportMode, Tk::None, Tr::NoUnit, Sl::NoTarget),
    row(Ab::Explode, Tk::None, Tr::NoUnit, Sl::NoTarget),
    cooldown(energy(ranged(row(Ab::Transfusion, Tk::Unit, Tr::Ally, Sl::AllyUnit), 7.0), 50.0), s(TRANSFUSE_COOLDOWN_S)),
];

// Durations and amounts in Faster seconds. Source: Blizzard's game data for patch 5.0.13
// (SC2Mapster/SC2GameData, `voidmulti` layer, unchanged in 5.0.14), whose Normal-speed
// seconds are divided by 1.4 here. [U] marks the few values the data did not settle.
pub(crate) const STIM_LOOPS: u32 = s(10.71);
pub(crate) const STIM_HP_MARINE: f32 = 10.0;
pub(crate) const STIM_HP_MARAUDER: f32 = 20.0;
/// Stim: +50% movement speed, attack cooldown divided by 1.5; no cooldown. [U] a unit
/// needs more life than the cost.
pub(crate) const STIM_FACTOR: f32 = 1.5;
/// Concussive Shells: 50% slower for 1.07 s; not Massive units or structures.
pub(crate) const SLOW_LOOPS: u32 = s(1.07);
pub(crate) const SLOW_FACTOR: f32 = 0.5;
/// Afterburners: Medivac speed x1.7 (3.5 to 5.95) for 5.71 s, cooldown 14.29 s.
pub(crate) const AFTERBURNER_FACTOR: f32 = 1.7;
pub(crate) const AFTERBURNER_LOOPS: u32 = s(5.71);
const AFTERBURNER_COOLDOWN_S: f32 = 14.29;
/// Siege 2.89 s, unsiege 2.53 s (the game adds up to 0.36 s at random; not modelled).
pub(crate) const SIEGE_LOOPS: u32 = s(2.89);
pub(crate) const UNSIEGE_LOOPS: u32 = s(2.53);
/// Viking landing and lift-off, 1.67 s each way.
pub(crate) const VIKING_MORPH_LOOPS: u32 = s(1.67);
/// Warp Prism phasing and transport mode, 1.07 s.
pub(crate) const PRISM_MORPH_LOOPS: u32 = s(1.07);
/// KD8 Charge: detonates 1.43 s after the throw for 5 spell damage in radius 2 to every
/// ground unit (the Reaper's own side too) and knocks non-massive ones back. [U] the
/// knockback distance (about 3).
pub(crate) const KD8_DAMAGE: f32 = 5.0;
pub(crate) const KD8_DELAY_LOOPS: u32 = s(1.43);
pub(crate) const KD8_RADIUS: f32 = 2.0;
pub(crate) const KD8_KNOCKBACK: f32 = 3.0;
const KD8_COOLDOWN_S: f32 = 14.29;
/// Steady Targeting: 130 (+40 against psionic) spell damage to a biological target after
/// a 1.43 s channel; interrupted (energy refunded) when the Ghost takes damage or the
/// target gets more than 14 away.
pub(crate) const SNIPE_DAMAGE: f32 = 130.0;
pub(crate) const SNIPE_PSIONIC_BONUS: f32 = 40.0;
pub(crate) const SNIPE_LOOPS: u32 = s(1.43);
pub(crate) const SNIPE_LEASH: f32 = 14.0;
/// EMP: 100 shields and 100 energy in radius 1.5; reveals cloaked units. [U] how long the
/// reveal lasts; the missile's 0.24 s flight is not modelled.
pub(crate) const EMP_RADIUS: f32 = 1.5;
pub(crate) const EMP_DRAIN: f32 = 100.0;
pub(crate) const EMP_REVEAL_LOOPS: u32 = s(1.43);
/// Cloak: 25 energy, then 1.28 energy per second.
pub(crate) const CLOAK_ENERGY: f32 = 25.0;
pub(crate) const CLOAK_DRAIN: f32 = 1.28 / LOOPS_PER_SECOND;
const BLINK_COOLDOWN_S: f32 = 7.14;
/// Guardian Shield: 2 less damage per ranged hit (not melee, splash or spells) within 4.5
/// plus the unit's radius, for 12.86 s; cooldown the same.
pub(crate) const GUARDIAN_RADIUS: f32 = 4.5;
pub(crate) const GUARDIAN_LOOPS: u32 = s(12.86);
pub(crate) const GUARDIAN_REDUCTION: f32 = 2.0;
/// Attacks with at least this range are ranged for Guardian Shield.
pub(crate) const RANGED_MIN: f32 = 1.5;
/// Force Field: radius 1.5 for 10.71 s; Massive ground units break it.
pub(crate) const FORCE_FIELD_RADIUS: f32 = 1.5;
pub(crate) const FORCE_FIELD_LOOPS: u32 = s(10.71);
/// Psionic Storm: 10 spell damage on entering and every 0.41 s inside (80 over its 2.86 s
/// for a unit that stays), radius 1.5, friendly fire, no stacking; cooldown 1.43 s.
pub(crate) const STORM_RADIUS: f32 = 1.5;
pub(crate) const STORM_LOOPS: u32 = s(2.86);
pub(crate) const STORM_TICK_LOOPS: u32 = 9;
pub(crate) const STORM_TICK_DAMAGE: f32 = 10.0;
const STORM_COOLDOWN_S: f32 = 1.43;
/// Feedback: 0.5 damage per energy drained.
pub(crate) const FEEDBACK_PER_ENERGY: f32 = 0.5;
/// Barrier: absorbs 100 damage for 2.14 s, raised by the first hit; cooldown 32.14 s.
pub(crate) const BARRIER_HP: f32 = 100.0;
pub(crate) const BARRIER_LOOPS: u32 = s(2.14);
const BARRIER_COOLDOWN_S: f32 = 32.14;
/// Graviton Beam: lifts a non-massive ground unit for up to 7.14 s.
pub(crate) const GRAVITON_LOOPS: u32 = s(7.14);
/// Transfusion: +75 HP now and +50 over 7.14 s; cooldown 0.71 s.
pub(crate) const TRANSFUSE_NOW: f32 = 75.0;
pub(crate) const TRANSFUSE_LATER: f32 = 50.0;
pub(crate) const TRANSFUSE_LOOPS: u32 = s(7.14);
const TRANSFUSE_COOLDOWN_S: f32 = 0.71;
/// Photon Cannon detection radius.
pub(crate) const DETECTION_RADIUS: f32 = 11.0;

impl Ability {
    pub const ALL: [Ability; 23] = [
        Ab::Stimpack,
        Ab::Heal,
        Ab::Afterburners,
        Ab::SiegeMode,
        Ab::Unsiege,
        Ab::Kd8Charge,
        Ab::SteadyTargeting,
        Ab::Emp,
        Ab::Cloak,
        Ab::Decloak,
        Ab::FighterMode,
        Ab::AssaultMode,
        Ab::Blink,
        Ab::GuardianShield,
        Ab::ForceField,
        Ab::PsionicStorm,
        Ab::Feedback,
        Ab::Barrier,
        Ab::GravitonBeam,
        Ab::PhasingMode,
        Ab::TransportMode,
        Ab::Explode,
        Ab::Transfusion,
    ];
    pub const COUNT: usize = 23;

    pub fn spec(self) -> &'static AbilitySpec {
        &SPECS[self as usize]
    }

    /// The name used in actions, JSON and text (`psionic_storm`).
    pub const fn name(self) -> &'static str {
        match self {
            Ab::Stimpack => "stimpack",
            Ab::Heal => "heal",
            Ab::Afterburners => "afterburners",
            Ab::SiegeMode => "siege_mode",
            Ab::Unsiege => "unsiege",
            Ab::Kd8Charge => "kd8_charge",
            Ab::SteadyTargeting => "steady_targeting",
            Ab::Emp => "emp",
            Ab::Cloak => "cloak",
            Ab::Decloak => "decloak",
            Ab::FighterMode => "fighter_mode",
            Ab::AssaultMode => "assault_mode",
            Ab::Blink => "blink",
            Ab::GuardianShield => "guardian_shield",
            Ab::ForceField => "force_field",
            Ab::PsionicStorm => "psionic_storm",
            Ab::Feedback => "feedback",
            Ab::Barrier => "barrier",
            Ab::GravitonBeam => "graviton_beam",
            Ab::PhasingMode => "phasing_mode",
            Ab::TransportMode => "transport_mode",
            Ab::Explode => "explode",
            Ab::Transfusion => "transfusion",
        }
    }

    /// Which unit types (and modes) have it.
    pub fn casters(self) -> &'static [UnitKind] {
        use UnitKind as K;
        match self {
            Ab::Stimpack => &[K::Marine, K::Marauder],
            Ab::Heal | Ab::Afterburners => &[K::Medivac],
            Ab::SiegeMode => &[K::SiegeTank],
            Ab::Unsiege => &[K::SiegeTankSieged],
            Ab::Kd8Charge => &[K::Reaper],
            Ab::SteadyTargeting | Ab::Emp => &[K::Ghost],
            Ab::Cloak | Ab::Decloak => &[K::Ghost, K::Banshee],
            Ab::FighterMode => &[K::VikingAssault],
            Ab::AssaultMode => &[K::VikingFighter],
            Ab::Blink => &[K::Stalker],
            Ab::GuardianShield | Ab::ForceField => &[K::Sentry],
            Ab::PsionicStorm | Ab::Feedback => &[K::HighTemplar],
            Ab::Barrier => &[K::Immortal],
            Ab::GravitonBeam => &[K::Phoenix],
            Ab::PhasingMode => &[K::WarpPrism],
            Ab::TransportMode => &[K::WarpPrismPhasing],
            Ab::Explode => &[K::Baneling],
            Ab::Transfusion => &[K::Queen],
        }
    }

    /// The upgrade a unit of this kind needs for the ability (cloak differs per caster).
    pub fn upgrade_for(self, kind: UnitKind) -> Option<Upgrade> {
        match (self, kind) {
            (Ab::Cloak, UnitKind::Ghost) => Some(Upgrade::PersonalCloaking),
            (Ab::Cloak, UnitKind::Banshee) => Some(Upgrade::CloakingField),
            _ => self.spec().upgrade,
        }
    }
}

impl UnitKind {
    /// Abilities of this unit type in every one of its modes, in table order: the SMAC
    /// ability slots of a type, stable across its mode switches.
    pub fn abilities(self) -> impl Iterator<Item = Ability> {
        let base = self.base();
        Ability::ALL.into_iter().filter(move |a| a.casters().iter().any(|k| k.base() == base))
    }
    /// Abilities castable in this mode.
    pub fn mode_abilities(self) -> impl Iterator<Item = Ability> {
        Ability::ALL.into_iter().filter(move |a| a.casters().contains(&self))
    }
}

impl fmt::Display for Ability {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An ability name that is not in the table.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown ability `{0}` (known: {known})", known = Ability::ALL.map(|a| a.name()).join(", "))]
pub struct UnknownAbility(pub String);

impl FromStr for Ability {
    type Err = UnknownAbility;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let norm: String = s.chars().filter(|c| c.is_ascii_alphanumeric()).map(|c| c.to_ascii_lowercase()).collect();
        Ability::ALL.into_iter().find(|a| a.name().replace('_', "") == norm).ok_or_else(|| UnknownAbility(s.to_owned()))
    }
}

/// Why a cast was refused. Each names the rule that failed, with the numbers involved.
#[derive(Clone, Debug, PartialEq, thiserror::Error, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Refusal {
    #[error("abilities are switched off in this environment")]
    Disabled,
    #[error("{kind} has no such ability")]
    NotItsAbility { kind: UnitKind },
    #[error("needs the {upgrade:?} upgrade")]
    NeedsUpgrade { upgrade: Upgrade },
    #[error("not enough energy ({have:.1} of {need:.0})")]
    NotEnoughEnergy { have: f32, need: f32 },
    #[error("on cooldown for {seconds:.2} s")]
    OnCooldown { seconds: f32 },
    #[error("not enough life ({have:.1}, needs more than {cost:.0})")]
    NotEnoughLife { have: f32, cost: f32 },
    #[error("wrong target: expected {expected:?}")]
    WrongTargetKind { expected: TargetKind },
    #[error("target out of range ({distance:.2} > {range:.2})")]
    OutOfRange { distance: f32, range: f32 },
    #[error("invalid target: {why}")]
    InvalidTarget { why: String },
    #[error("busy: {what}")]
    Busy { what: String },
    #[error("already active")]
    AlreadyActive,
    #[error("not active")]
    NotActive,
}

/// What kind of [`Refusal`] stops a cast, without its numbers: what observations carry (the
/// numbers that matter, energy and cooldown, are fields of their own there).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RefusalCode {
    Disabled,
    NotItsAbility,
    NeedsUpgrade,
    NotEnoughEnergy,
    OnCooldown,
    NotEnoughLife,
    WrongTargetKind,
    OutOfRange,
    InvalidTarget,
    Busy,
    AlreadyActive,
    NotActive,
}

impl RefusalCode {
    pub const ALL: [RefusalCode; 12] = [
        RefusalCode::Disabled,
        RefusalCode::NotItsAbility,
        RefusalCode::NeedsUpgrade,
        RefusalCode::NotEnoughEnergy,
        RefusalCode::OnCooldown,
        RefusalCode::NotEnoughLife,
        RefusalCode::WrongTargetKind,
        RefusalCode::OutOfRange,
        RefusalCode::InvalidTarget,
        RefusalCode::Busy,
        RefusalCode::AlreadyActive,
        RefusalCode::NotActive,
    ];
    /// In a sentence's words (`on cooldown`).
    pub fn text(self) -> &'static str {
        match self {
            RefusalCode::Disabled => "abilities disabled",
            RefusalCode::NotItsAbility => "not its ability",
            RefusalCode::NeedsUpgrade => "needs upgrade",
            RefusalCode::NotEnoughEnergy => "not enough energy",
            RefusalCode::OnCooldown => "on cooldown",
            RefusalCode::NotEnoughLife => "not enough life",
            RefusalCode::WrongTargetKind => "wrong target kind",
            RefusalCode::OutOfRange => "out of range",
            RefusalCode::InvalidTarget => "invalid target",
            RefusalCode::Busy => "busy",
            RefusalCode::AlreadyActive => "already active",
            RefusalCode::NotActive => "not active",
        }
    }
}

impl Refusal {
    pub fn code(&self) -> RefusalCode {
        match self {
            Refusal::Disabled => RefusalCode::Disabled,
            Refusal::NotItsAbility { .. } => RefusalCode::NotItsAbility,
            Refusal::NeedsUpgrade { .. } => RefusalCode::NeedsUpgrade,
            Refusal::NotEnoughEnergy { .. } => RefusalCode::NotEnoughEnergy,
            Refusal::OnCooldown { .. } => RefusalCode::OnCooldown,
            Refusal::NotEnoughLife { .. } => RefusalCode::NotEnoughLife,
            Refusal::WrongTargetKind { .. } => RefusalCode::WrongTargetKind,
            Refusal::OutOfRange { .. } => RefusalCode::OutOfRange,
            Refusal::InvalidTarget { .. } => RefusalCode::InvalidTarget,
            Refusal::Busy { .. } => RefusalCode::Busy,
            Refusal::AlreadyActive => RefusalCode::AlreadyActive,
            Refusal::NotActive => RefusalCode::NotActive,
        }
    }
}

/// An ability with its readiness for one unit, for observations.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AbilityInfo {
    pub ability: Ability,
    pub target: TargetKind,
    pub energy_cost: f32,
    pub range: f32,
    /// Seconds until the cooldown ends (0: ready).
    pub cooldown_s: f32,
    /// Castable now on some target (energy, cooldown, upgrade, mode, state).
    pub available: bool,
    /// Why not, when not available.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub why_not: Option<RefusalCode>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_rows_match_and_one_cooldown_per_type() {
        for a in Ability::ALL {
            assert_eq!(a.spec().ability, a, "row for {a} is out of order");
            assert_eq!(a.name().parse::<Ability>(), Ok(a));
            assert!(!a.casters().is_empty());
        }
        // `Status` keeps one cooldown per unit: no type may have two abilities with one.
        for k in UnitKind::ALL {
            let n = k.abilities().filter(|a| a.spec().cooldown > 0).count();
            assert!(n <= 1, "{k} has {n} abilities with a cooldown");
        }
        assert_eq!("Psionic Storm".parse::<Ability>(), Ok(Ability::PsionicStorm));
        assert!("psi storm".parse::<Ability>().is_err());
    }
}
