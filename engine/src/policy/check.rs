//! Checking an action from a group's observation alone, by the simulator's own rules
//! (`crate::rules`): what an agent outside the engine can know of whether an action will be
//! taken. Where the observation lacks a fact the world has (an enemy out of sight, vision of
//! high ground), this check refuses and the world's might not; never the reverse.

use crate::ability::{Ability, AbilityInfo, Refusal, RefusalCode};
use crate::action::{Action, ActionError};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::obs::GroupObs;
use crate::obs::{Buffs, UnitInfo};
use crate::rules::{self, Sight};
use crate::terrain::Terrain;

/// Checks `a`, an action of `obs.team`, against the observation and the map (which a player
/// knows). `Ok` means the simulator takes it, unless something happened that the
/// observation could not show.
pub fn check_action(obs: &GroupObs, terrain: &Terrain, a: &Action) -> Result<(), ActionError> {
    rules::check(&Observed { obs, terrain }, obs.team, a).map(|_| ())
}

struct Observed<'a> {
    obs: &'a GroupObs,
    terrain: &'a Terrain,
}

impl Sight for Observed<'_> {
    type U = UnitInfo;
    fn terrain(&self) -> &Terrain {
        self.terrain
    }
    fn actor(&self, team: Team, unit: UnitId) -> Result<Option<&UnitInfo>, ActionError> {
        match self.obs.unit(unit) {
            Some(u) if u.own => Ok(Some(u)),
            Some(_) => Err(ActionError::NotYourUnit { unit, owner: team.other(), team }),
            // Observations list living units; the group's dead ones are in `controlled`.
            None if self.obs.controlled.iter().any(|c| c.unit == unit) => Ok(None),
            None => Err(ActionError::UnknownUnit { unit }),
        }
    }
    fn seen(&self, team: Team, target: UnitId) -> Result<(&UnitInfo, bool), ActionError> {
        self.obs.unit(target).map(|t| (t, t.own)).ok_or(ActionError::TargetNotVisible { target, team })
    }
    fn sees(&self, _team: Team, p: Vec2) -> bool {
        super::view::sees_point(self.terrain, self.obs.units.iter().filter(|u| u.own), p)
    }
    fn castable(&self, u: &UnitInfo, ability: Ability) -> Result<(), Refusal> {
        let info = super::view::ability(u, ability).ok_or(Refusal::NotItsAbility { kind: u.kind })?;
        match (info.available, info.why_not) {
            (true, _) => Ok(()),
            (false, code) => Err(refusal(u, info, code.unwrap_or(RefusalCode::Busy))),
        }
    }
}

/// The refusal the simulator gave when it built the observation, with its numbers taken
/// from the observation (observations carry the code only).
fn refusal(u: &UnitInfo, info: &AbilityInfo, code: RefusalCode) -> Refusal {
    let a = info.ability;
    match code {
        RefusalCode::Disabled => Refusal::Disabled,
        RefusalCode::NotItsAbility => Refusal::NotItsAbility { kind: u.kind },
        RefusalCode::NeedsUpgrade => match a.upgrade_for(u.kind) {
            Some(upgrade) => Refusal::NeedsUpgrade { upgrade },
            None => Refusal::NotItsAbility { kind: u.kind },
        },
        RefusalCode::NotEnoughEnergy => {
            let need = match a {
                Ability::Heal => u.spec().heal.map_or(0.0, |h| h.min_energy_to_start),
                _ => info.energy_cost,
            };
            Refusal::NotEnoughEnergy { have: u.energy, need }
        }
        RefusalCode::OnCooldown => Refusal::OnCooldown { seconds: info.cooldown_s },
        RefusalCode::NotEnoughLife => Refusal::NotEnoughLife { have: u.hp, cost: crate::ability::stim_cost(u.kind) },
        RefusalCode::WrongTargetKind => Refusal::WrongTargetKind { expected: info.target },
        RefusalCode::OutOfRange => Refusal::OutOfRange { distance: f32::INFINITY, range: info.range },
        RefusalCode::InvalidTarget => Refusal::InvalidTarget { why: "not castable where the unit stands".into() },
        RefusalCode::Busy => {
            Refusal::Busy { what: if u.buffs.contains(Buffs::LIFTED) { "held by a Graviton Beam".into() } else { "changing mode".into() } }
        }
        RefusalCode::AlreadyActive => Refusal::AlreadyActive,
        RefusalCode::NotActive => Refusal::NotActive,
    }
}
