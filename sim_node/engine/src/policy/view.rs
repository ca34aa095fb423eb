//! What a team may know: its own units in full, enemy units only while seen. Policies get
//! nothing else, so fog of war holds for scripted agents and opponents by construction.

use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::scenario::Scenario;
use crate::terrain::Terrain;
use crate::world::{Unit, World};

#[derive(Clone, Copy, Debug)]
pub struct TeamView<'a> {
    world: &'a World,
    scenario: &'a Scenario,
    team: Team,
}

impl<'a> TeamView<'a> {
    pub(crate) fn new(world: &'a World, scenario: &'a Scenario, team: Team) -> Self {
        Self { world, scenario, team }
    }
    pub(crate) fn world(&self) -> &'a World {
        self.world
    }
    pub fn team(&self) -> Team {
        self.team
    }
    pub fn tick(&self) -> u32 {
        self.world.tick()
    }
    pub fn terrain(&self) -> &'a Terrain {
        self.world.terrain()
    }
    pub fn scenario(&self) -> &'a Scenario {
        self.scenario
    }
    /// This team's living units.
    pub fn own(&self) -> impl Iterator<Item = &'a Unit> + 'a {
        self.world.alive(self.team)
    }
    /// Enemy units this team sees now.
    pub fn enemies(&self) -> impl Iterator<Item = &'a Unit> + 'a {
        let (w, team) = (self.world, self.team);
        w.alive(team.other()).filter(move |u| w.visible_to(team, u.id))
    }
    /// A unit if this team may see it.
    pub fn unit(&self, id: UnitId) -> Option<&'a Unit> {
        self.world.unit(id).filter(|u| u.alive && self.world.visible_to(self.team, id))
    }
    /// Where the enemy started (known from the scenario, as a player knows the map).
    pub fn enemy_spawn(&self) -> Vec2 {
        self.scenario.spawn(self.team.other())
    }
    pub fn own_spawn(&self) -> Vec2 {
        self.scenario.spawn(self.team)
    }
    /// Edge distance from `u` to the range of its weapon against `t` (<= 0: in range).
    pub fn range_gap(&self, u: UnitId, t: UnitId) -> Option<f32> {
        self.unit(t)?;
        self.world.range_gap(u, t)
    }
    pub fn can_attack(&self, u: &Unit, t: &Unit) -> bool {
        crate::combat::weapon_for(u, t).is_some()
    }
}
