//! Dynamic role groups. A commander sees the whole team and, every step, says which role
//! group owns each living unit from the next step on, with a briefing (a plan, the enemies
//! that matter) for the groups. The groups are ordinary [`Agent`]s: each acts for the units it
//! owns at that step, on the fold of their observations, exactly as a deployed agent node of
//! the group does. Orders take effect at a step boundary: what a commander decides on step
//! `s` applies from step `s + 1`, so the commander and the groups of one step can think at
//! the same time (deployed, they are separate processes) and the game still replays.
//!
//! `crate::agent` runs a commanded team in-process (`CommandedTeam`).
//!
//! [`validate`] is the one check of orders, used in-process and by the simulator node: every
//! living unit exactly once, known groups only. Refused orders leave ownership as it was.

use super::contract::{Agent, AgentCtx, agent_seed};
use super::role::{Briefing, GroupRole};
use crate::ids::{Team, UnitId};
use crate::obs::GroupObs;

/// A commander's answer for one step: each living unit's group (an index into the team's
/// groups) from the next step on, and the briefing.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Orders {
    pub owners: Vec<(UnitId, usize)>,
    pub briefing: Briefing,
}

/// A commander: sees every unit of its team, controls none itself.
pub trait Commander: Send {
    fn name(&self) -> &str;
    /// Called at the start of every episode with the roles of the team's groups, in order.
    fn reset(&mut self, ctx: &AgentCtx, groups: &[GroupRole]);
    /// Orders from this step's observation of the whole team and the ownership in force.
    fn command(&mut self, obs: &GroupObs, current: &Assignment) -> Orders;
}

/// Which group owns each unit: per group, its units in ascending order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Assignment {
    groups: Vec<Vec<UnitId>>,
}

impl Assignment {
    pub fn new(mut groups: Vec<Vec<UnitId>>) -> Assignment {
        for g in &mut groups {
            g.sort_unstable();
            g.dedup();
        }
        Assignment { groups }
    }
    pub fn groups(&self) -> &[Vec<UnitId>] {
        &self.groups
    }
    pub fn owner(&self, unit: UnitId) -> Option<usize> {
        self.groups.iter().position(|g| g.contains(&unit))
    }
    /// The same ownership with the units that are not `living` dropped.
    pub fn living(&self, living: &[UnitId]) -> Assignment {
        Assignment { groups: self.groups.iter().map(|g| g.iter().copied().filter(|t| living.contains(t)).collect()).collect() }
    }
    /// As `(unit, group)` pairs in unit order (what [`Orders::owners`] holds).
    pub fn pairs(&self) -> Vec<(UnitId, usize)> {
        let mut v: Vec<(UnitId, usize)> = self.groups.iter().enumerate().flat_map(|(i, g)| g.iter().map(move |&t| (t, i))).collect();
        v.sort_unstable();
        v
    }
}

/// Why orders were refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum OrdersError {
    #[error("unit {} is given to group {group}, but the team has {groups} groups", unit.tag())]
    NoSuchGroup { unit: UnitId, group: usize, groups: usize },
    #[error("unit {} is not a living unit of the team", unit.tag())]
    NotLiving { unit: UnitId },
    #[error("unit {} is given twice", unit.tag())]
    Twice { unit: UnitId },
    #[error("living unit {} is given to no group", unit.tag())]
    Unassigned { unit: UnitId },
}

/// Checks orders against the team's living units and its number of groups.
pub fn validate(owners: &[(UnitId, usize)], living: &[UnitId], groups: usize) -> Result<Assignment, OrdersError> {
    let mut out = vec![Vec::new(); groups];
    let mut seen = Vec::with_capacity(owners.len());
    for &(unit, group) in owners {
        if group >= groups {
            return Err(OrdersError::NoSuchGroup { unit, group, groups });
        }
        if !living.contains(&unit) {
            return Err(OrdersError::NotLiving { unit });
        }
        if seen.contains(&unit) {
            return Err(OrdersError::Twice { unit });
        }
        seen.push(unit);
        out[group].push(unit);
    }
    if let Some(&unit) = living.iter().find(|t| !seen.contains(t)) {
        return Err(OrdersError::Unassigned { unit });
    }
    Ok(Assignment::new(out))
}

/// What makes a fresh agent or commander (one per episode).
pub type MakeAgent = Box<dyn Fn() -> Box<dyn Agent> + Send>;
pub type MakeCommander = Box<dyn Fn() -> Box<dyn Commander> + Send>;

/// One role group of a commanded team.
pub struct RoleGroupSpec {
    pub role: GroupRole,
    /// The units it owns at the start of an episode (not empty: its first unit seeds it).
    pub initial: Vec<UnitId>,
    pub make: MakeAgent,
}

impl std::fmt::Debug for RoleGroupSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RoleGroupSpec").field("role", &self.role).field("initial", &self.initial).finish()
    }
}

/// The seed of a team's commander in an episode (distinct from every group's).
pub fn commander_seed(episode_seed: u64, team: Team) -> u64 {
    agent_seed(episode_seed, team, 0)
}

/// A scripted commander for tests and demonstrations: every `every` steps it hands each living
/// unit to the next group, round robin, so units keep moving between running groups.
#[derive(Clone, Debug)]
pub struct Rotate {
    every: u32,
    groups: usize,
}

impl Rotate {
    pub const NAME: &'static str = "rotate";
    pub fn new(every: u32) -> Rotate {
        Rotate { every: every.max(1), groups: 1 }
    }
}

impl Commander for Rotate {
    fn name(&self) -> &str {
        Rotate::NAME
    }
    fn reset(&mut self, _ctx: &AgentCtx, groups: &[GroupRole]) {
        self.groups = groups.len().max(1);
    }
    fn command(&mut self, obs: &GroupObs, current: &Assignment) -> Orders {
        let turn = (obs.step + 1).is_multiple_of(self.every);
        let owners = current.pairs().into_iter().map(|(t, g)| (t, if turn { (g + 1) % self.groups } else { g })).collect();
        Orders { owners, briefing: Briefing::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(tags: &[u32]) -> Vec<UnitId> {
        tags.iter().map(|&t| UnitId::try_from(t).expect("a tag")).collect()
    }
    fn u(tag: u32) -> UnitId {
        UnitId::try_from(tag).expect("a tag")
    }
    fn pairs(p: &[(u32, usize)]) -> Vec<(UnitId, usize)> {
        p.iter().map(|&(t, g)| (u(t), g)).collect()
    }

    #[test]
    fn validation_names_what_is_wrong() {
        let living = ids(&[1, 2, 3]);
        assert_eq!(validate(&pairs(&[(1, 0), (2, 1), (3, 1)]), &living, 2), Ok(Assignment::new(vec![ids(&[1]), ids(&[2, 3])])));
        assert_eq!(
            validate(&pairs(&[(1, 0), (2, 2), (3, 1)]), &living, 2),
            Err(OrdersError::NoSuchGroup { unit: u(2), group: 2, groups: 2 })
        );
        assert_eq!(validate(&pairs(&[(1, 0), (2, 0), (3, 0), (4, 0)]), &living, 2), Err(OrdersError::NotLiving { unit: u(4) }));
        assert_eq!(validate(&pairs(&[(1, 0), (1, 1), (3, 0)]), &living, 2), Err(OrdersError::Twice { unit: u(1) }));
        assert_eq!(validate(&pairs(&[(1, 0), (3, 0)]), &living, 2), Err(OrdersError::Unassigned { unit: u(2) }));
        assert_eq!(
            OrdersError::NoSuchGroup { unit: u(2), group: 2, groups: 2 }.to_string(),
            "unit 2 is given to group 2, but the team has 2 groups"
        );
    }

    proptest::proptest! {
        /// Whatever a commander (or the wire) says, accepted orders give every living unit
        /// exactly one known group, and refused ones say which unit is wrong.
        #[test]
        fn accepted_orders_cover_the_living_exactly_once(
            owners in proptest::collection::vec((1u32..9, 0usize..4), 0..10),
            living in proptest::collection::btree_set(1u32..8, 0..6),
            groups in 1usize..4,
        ) {
            let living: Vec<UnitId> = living.into_iter().map(u).collect();
            let owners = pairs(&owners);
            match validate(&owners, &living, groups) {
                Ok(a) => {
                    proptest::prop_assert_eq!(a.groups().len(), groups);
                    for t in &living {
                        proptest::prop_assert_eq!(a.groups().iter().filter(|g| g.contains(t)).count(), 1);
                    }
                    proptest::prop_assert_eq!(a.groups().iter().map(Vec::len).sum::<usize>(), living.len());
                }
                Err(e) => {
                    let unit = match e {
                        OrdersError::NoSuchGroup { unit, .. } | OrdersError::NotLiving { unit } | OrdersError::Twice { unit } | OrdersError::Unassigned { unit } => unit,
                    };
                    proptest::prop_assert!(owners.iter().any(|(u, _)| *u == unit) || living.contains(&unit));
                }
            }
        }
    }
}
