//! What an agent is given: one unit's observation ([`AgentObs`], what the deployment's
//! `UnitObservation` message carries, field for field) and the fold of a group's unit
//! observations ([`GroupObs`]) that policies act on. In-process runs build the same values
//! the simulator node publishes, so a policy cannot tell where it runs.

use crate::ability::EffectKind;
use crate::ids::{Team, UnitId, serde_as};
use crate::obs::UnitInfo;
use serde::Serialize;
use std::sync::Arc;

/// A lasting area effect a team knows of (its own, and others' where it sees the spot).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EffectInfo {
    pub kind: EffectKind,
    /// The caster's team (1 or 2 in JSON).
    #[serde(serialize_with = "serde_as::player::serialize")]
    pub team: Team,
    pub x: f32,
    pub y: f32,
    pub radius: f32,
    pub remaining_s: f32,
}

/// One unit's observation at one step.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgentObs {
    pub episode: u64,
    /// The episode's seed, from which agents seed their own random choices.
    pub seed: u64,
    pub step: u32,
    pub game_loop: u32,
    /// The observed unit (its tag in JSON).
    #[serde(serialize_with = "serde_as::tag::serialize")]
    pub unit: UnitId,
    /// Its team (1 or 2 in JSON).
    #[serde(serialize_with = "serde_as::player::serialize")]
    pub team: Team,
    pub alive: bool,
    /// The unit itself with its abilities (`None` once dead).
    pub own: Option<UnitInfo>,
    /// The other living units of its team (without their abilities).
    pub allies: Vec<UnitInfo>,
    /// Enemy units its team sees.
    pub enemies: Vec<UnitInfo>,
    pub effects: Vec<EffectInfo>,
    /// SMAC's mask, one byte per action index (1: available).
    pub avail_actions: Vec<u8>,
    /// SMAC's feature vector.
    pub features: Vec<f32>,
    /// The team's text description (shared by its units).
    pub text: Arc<str>,
}

/// What a group of units (one agent node's) knows at one step: the fold of its units'
/// observations. Every unit of a team sees the same battlefield, so the fold is its team's
/// view, with abilities for the units the group controls.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupObs {
    pub episode: u64,
    /// The episode's seed (the environment's, which a deployment's messages carry).
    pub seed: u64,
    pub step: u32,
    pub game_loop: u32,
    pub team: Team,
    /// Own units first, then seen enemies, each in tag order.
    pub units: Vec<UnitInfo>,
    pub effects: Vec<EffectInfo>,
    /// The group's units, dead ones included (their masks allow only the no-op).
    pub controlled: Vec<Controlled>,
    pub text: Arc<str>,
}

/// What only a unit's own observation holds: its SMAC mask and features.
#[derive(Clone, Debug, PartialEq)]
pub struct Controlled {
    pub unit: UnitId,
    pub alive: bool,
    /// Index of the unit among its team's SMAC agents.
    pub agent: usize,
    pub avail_actions: Vec<u8>,
    pub features: Vec<f32>,
}

impl GroupObs {
    /// Folds the observations of one group's units at one step (all the same step, same team).
    /// `None` when given none.
    pub fn fold(obs: &[AgentObs], agent_index: impl Fn(UnitId) -> usize) -> Option<GroupObs> {
        let first = obs.first()?;
        let team = first.team;
        let mut units: Vec<UnitInfo> = Vec::new();
        // Own units: the controlled ones carry their abilities; allies come without.
        for o in obs {
            units.extend(o.own.iter().cloned());
        }
        for o in obs {
            for a in &o.allies {
                if !units.iter().any(|u| u.tag == a.tag) {
                    units.push(a.clone());
                }
            }
        }
        units.sort_by_key(|u| u.tag);
        let mut enemies = first.enemies.clone();
        enemies.sort_by_key(|u| u.tag);
        units.extend(enemies);
        Some(GroupObs {
            episode: first.episode,
            seed: first.seed,
            step: first.step,
            game_loop: first.game_loop,
            team,
            units,
            effects: first.effects.clone(),
            controlled: obs
                .iter()
                .map(|o| Controlled {
                    unit: o.unit,
                    alive: o.alive,
                    agent: agent_index(o.unit),
                    avail_actions: o.avail_actions.clone(),
                    features: o.features.clone(),
                })
                .collect(),
            text: Arc::clone(&first.text),
        })
    }

    /// The team's living units.
    pub fn own(&self) -> impl Iterator<Item = &UnitInfo> {
        self.units.iter().filter(|u| u.own)
    }
    /// Enemy units the team sees.
    pub fn enemies(&self) -> impl Iterator<Item = &UnitInfo> {
        self.units.iter().filter(|u| !u.own)
    }
    /// The living units this group controls (with their abilities).
    pub fn mine(&self) -> impl Iterator<Item = &UnitInfo> {
        self.units.iter().filter(|u| u.own && self.controlled.iter().any(|c| c.unit == u.tag))
    }
    /// A unit the team knows of.
    pub fn unit(&self, id: UnitId) -> Option<&UnitInfo> {
        self.units.iter().find(|u| u.tag == id)
    }
    pub fn tick(&self) -> u32 {
        self.game_loop
    }
}

/// Parts of an observation an agent may not need: SMAC's features and masks, and the text.
/// They cost more to build than the rest (the text most), and scripted agents read neither.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reads {
    /// The controlled units' SMAC masks and features.
    pub smac: bool,
    /// The team's text description.
    pub text: bool,
}

impl Reads {
    pub const ALL: Reads = Reads { smac: true, text: true };
    /// The units and effects only.
    pub const UNITS: Reads = Reads { smac: false, text: false };
}
