//! The structured unit list (the paper's U_t): one record per unit a team knows of.

use crate::ability::AbilityInfo;
use crate::action::grid_cell_of;
use crate::flags::{Buffs, UnitFlags};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId, serde_as};
use crate::rules::Facts;
use crate::time::LOOPS_PER_SECOND;
use crate::units::{Attrs, DataSet, UnitKind, UnitSpec};
use crate::world::{Activity, Order, Unit, World};
use serde::Serialize;

/// A unit's current order, with targets named by tag.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum OrderInfo {
    Idle,
    Hold,
    Move {
        x: f32,
        y: f32,
    },
    AttackMove {
        x: f32,
        y: f32,
    },
    Attack {
        #[serde(serialize_with = "serde_as::tag::serialize")]
        target: UnitId,
    },
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnitInfo {
    /// Permanent numeric tag (also drawn on screenshots).
    #[serde(serialize_with = "serde_as::tag::serialize")]
    pub tag: UnitId,
    /// `Marine_1`: base type and number within its team, kept for the whole episode.
    pub name: String,
    #[serde(rename = "type")]
    pub kind: UnitKind,
    /// The game's unit data, which gives the kind's stats (a player knows them). A fact of the
    /// game, not of the unit: left out of the JSON that prompts, unit lists and recordings carry.
    #[serde(skip_serializing)]
    pub data: DataSet,
    #[serde(serialize_with = "serde_as::player::serialize")]
    pub team: Team,
    pub own: bool,
    pub x: f32,
    pub y: f32,
    /// Cell (x, y) of the 10x10 movement grid, (1, 1) top left.
    pub grid: [u8; 2],
    pub hp: f32,
    pub max_hp: f32,
    pub shield: f32,
    pub max_shield: f32,
    pub energy: f32,
    pub max_energy: f32,
    /// Current top speed in game units per game second ("Faster"): stim, slows, Afterburners
    /// and upgrades included; 0 while immobile, morphing, lifted or channelling.
    pub speed: f32,
    /// Seconds of game time until the weapon is ready (0 when ready).
    pub weapon_cooldown_s: f32,
    pub order: OrderInfo,
    pub activity: Activity,
    #[serde(serialize_with = "serde_as::tag_opt::serialize")]
    pub target: Option<UnitId>,
    pub flags: UnitFlags,
    /// Active buffs and states: stimmed, slowed, cloaked, guardian-shielded, lifted,
    /// morphing, ...
    pub buffs: Buffs,
    /// The unit's abilities with cooldowns and availability (own units only: a player does
    /// not see enemy cooldowns).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub abilities: Vec<AbilityInfo>,
}

impl UnitInfo {
    /// The unit type's data in the game's data set.
    pub fn spec(&self) -> &'static UnitSpec {
        self.data.spec(self.kind)
    }

    pub fn from_unit(w: &World, team: Team, u: &Unit) -> Self {
        let s = u.spec();
        let checks = [
            (s.flying, UnitFlags::FLYING),
            (s.attrs.has(Attrs::STRUCTURE), UnitFlags::STRUCTURE),
            (s.detector, UnitFlags::DETECTOR),
            (s.heal.is_some(), UnitFlags::HEALER),
            (s.cliff_walk, UnitFlags::CLIFF_WALKER),
            (u.kind == UnitKind::SiegeTankSieged, UnitFlags::SIEGED),
            (u.kind == UnitKind::WarpPrismPhasing, UnitFlags::PHASING),
            (u.kind == UnitKind::VikingAssault, UnitFlags::ASSAULT_MODE),
            (u.kind == UnitKind::VikingFighter, UnitFlags::FIGHTER_MODE),
            (u.speed <= 0.0, UnitFlags::IMMOBILE),
            (s.attrs.has(Attrs::LIGHT), UnitFlags::LIGHT),
            (s.attrs.has(Attrs::ARMORED), UnitFlags::ARMORED),
            (s.attrs.has(Attrs::BIOLOGICAL), UnitFlags::BIOLOGICAL),
            (s.attrs.has(Attrs::MECHANICAL), UnitFlags::MECHANICAL),
            (s.attrs.has(Attrs::PSIONIC), UnitFlags::PSIONIC),
            (s.attrs.has(Attrs::MASSIVE), UnitFlags::MASSIVE),
        ];
        let mut flags = UnitFlags::empty();
        for (on, f) in checks {
            if on {
                flags.insert(f);
            }
        }
        let (gx, gy) = grid_cell_of(w.terrain().playable(), u.pos);
        UnitInfo {
            tag: u.id,
            name: u.name(),
            kind: u.kind,
            data: w.data(),
            team: u.team,
            own: u.team == team,
            x: u.pos.x,
            y: u.pos.y,
            grid: [gx, gy],
            hp: u.hp,
            max_hp: u.max_hp,
            shield: u.shield,
            max_shield: u.max_shield,
            energy: u.energy,
            max_energy: s.energy_max,
            speed: u.speed * LOOPS_PER_SECOND,
            weapon_cooldown_s: u.cooldown.max(0.0) / LOOPS_PER_SECOND,
            order: match u.order {
                Order::Idle => OrderInfo::Idle,
                Order::Hold => OrderInfo::Hold,
                Order::Move { to } => OrderInfo::Move { x: to.x, y: to.y },
                Order::AttackMove { to } => OrderInfo::AttackMove { x: to.x, y: to.y },
                Order::Attack { target } => OrderInfo::Attack { target },
            },
            activity: u.activity,
            target: u.target,
            flags,
            buffs: {
                let mut b = u.status.buffs(w.tick());
                // An enemy that sees a cloaked unit has detected it; its owner is not told
                // (that would reveal enemy detectors in the fog).
                if u.team != team && u.status.cloaked {
                    b.insert(Buffs::DETECTED);
                }
                if u.swing.is_some_and(|s| !s.fired) {
                    b.insert(Buffs::WINDING_UP);
                }
                b
            },
            abilities: if u.team == team { ability_infos(w, u) } else { Vec::new() },
        }
    }
}

/// Every ability of a unit's current mode, with what stops it now.
pub fn ability_infos(w: &World, u: &Unit) -> Vec<AbilityInfo> {
    u.kind
        .mode_abilities()
        .map(|a| {
            let s = a.spec();
            let check = w.can_cast(u, a);
            let ready = u.status.ready_at(a);
            AbilityInfo {
                ability: a,
                target: s.target,
                energy_cost: s.energy,
                range: s.range,
                cooldown_s: ready.saturating_sub(w.tick()) as f32 / LOOPS_PER_SECOND,
                available: check.is_ok(),
                why_not: check.err().map(|e| e.code()),
            }
        })
        .collect()
}

/// Every living unit `team` knows of: its own, then the enemies it sees, each by tag order.
pub fn unit_list(w: &World, team: Team) -> Vec<UnitInfo> {
    let own = w.alive(team);
    let seen = w.alive(team.other()).filter(|u| w.visible_to(team, u.id));
    own.chain(seen).map(|u| UnitInfo::from_unit(w, team, u)).collect()
}

/// The rules read an observed unit as they read the world's.
impl Facts for UnitInfo {
    fn id(&self) -> UnitId {
        self.tag
    }
    fn kind(&self) -> UnitKind {
        self.kind
    }
    fn spec(&self) -> &'static UnitSpec {
        UnitInfo::spec(self)
    }
    fn pos(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }
    fn radius(&self) -> f32 {
        UnitInfo::spec(self).radius
    }
    fn speed(&self) -> f32 {
        self.speed
    }
    fn on_air(&self) -> bool {
        self.flags.contains(UnitFlags::FLYING) || self.buffs.contains(Buffs::LIFTED)
    }
    fn heals(&self) -> bool {
        self.flags.contains(UnitFlags::HEALER)
    }
    fn morphing(&self) -> bool {
        self.buffs.contains(Buffs::MORPHING)
    }
    fn energy(&self) -> f32 {
        self.energy
    }
    fn hp(&self) -> f32 {
        self.hp
    }
    fn max_hp(&self) -> f32 {
        self.max_hp
    }
}
