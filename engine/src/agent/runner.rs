//! Agents driving a team in-process, grouped exactly as a deployment's agent nodes are, so
//! an in-process run and a lockstep deployment of the same grouping play the same game.

use crate::action::Action;
use crate::env::Env;
use crate::ids::{Team, UnitId};
use crate::obs::GroupObs;
use crate::policy::{Agent, AgentCtx, agent_seed};

/// How a team's units are split among agents.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Grouping {
    /// One agent for the whole team.
    Team,
    /// One agent per unit (a launch file's `per_unit: true`).
    PerUnit,
    /// One agent per listed group of units (a launch file's role groups); units in no group
    /// get no agent.
    Groups(Vec<Vec<UnitId>>),
}

/// A team's agents: one per group, each made by the same factory.
pub struct AgentTeam {
    team: Team,
    grouping: Grouping,
    make: Box<dyn Fn() -> Box<dyn Agent> + Send>,
    groups: Vec<(Vec<UnitId>, Box<dyn Agent>)>,
}

impl std::fmt::Debug for AgentTeam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AgentTeam").field("team", &self.team).field("grouping", &self.grouping).field("groups", &self.groups.len()).finish()
    }
}

impl AgentTeam {
    pub fn new(team: Team, grouping: Grouping, make: impl Fn() -> Box<dyn Agent> + Send + 'static) -> Self {
        Self { team, grouping, make: Box::new(make), groups: Vec::new() }
    }
    pub fn team(&self) -> Team {
        self.team
    }
    /// The name of the policy (from a fresh instance when no episode has started).
    pub fn name(&self) -> String {
        self.groups.first().map_or_else(|| (self.make)().name().to_owned(), |(_, a)| a.name().to_owned())
    }

    /// Starts an episode: one fresh agent per group, each seeded by [`agent_seed`].
    pub fn reset(&mut self, env: &Env) {
        let ids = env.agents(self.team);
        let groups: Vec<Vec<UnitId>> = match &self.grouping {
            Grouping::Team => vec![ids.to_vec()],
            Grouping::PerUnit => ids.iter().map(|&id| vec![id]).collect(),
            // A listed unit is one of the team's or is left out.
            Grouping::Groups(g) => g.iter().map(|g| g.iter().copied().filter(|id| ids.contains(id)).collect()).collect(),
        };
        self.groups = groups
            .into_iter()
            .filter(|g: &Vec<UnitId>| !g.is_empty())
            .map(|units| {
                let mut agent = (self.make)();
                let ctx = AgentCtx {
                    scenario: std::sync::Arc::clone(env.scenario()),
                    team: self.team,
                    seed: agent_seed(env.seed(), self.team, units[0].tag()),
                    units: units.clone(),
                };
                agent.reset(&ctx);
                (units, agent)
            })
            .collect();
    }

    /// The frame sizes its groups' agents read (see [`super::Agent::frames`]).
    pub fn frame_needs(&self) -> impl Iterator<Item = super::FrameNeed> + '_ {
        self.groups.iter().filter_map(|(_, a)| a.frames())
    }

    /// Hands each group's agent that reads frames its team's frames of this step, from
    /// `drawn` (frames by team and size, drawn once for every team that reads them).
    pub fn show(&mut self, drawn: &[(Team, super::FrameNeed, super::TeamFrames)]) {
        for (_, agent) in &mut self.groups {
            let Some(need) = agent.frames() else { continue };
            if let Some((_, _, f)) = drawn.iter().find(|(t, n, _)| *t == self.team && *n == need) {
                agent.see(f);
            }
        }
    }

    /// Every group's actions for this step, from its units' observations.
    pub fn act(&mut self, env: &Env, episode: u64) -> Vec<Action> {
        let order = env.agents(self.team);
        let index = |id: UnitId| order.iter().position(|&t| t == id).unwrap_or(0);
        let mut out = Vec::new();
        if let [(_, agent)] = self.groups.as_mut_slice()
            && self.grouping == Grouping::Team
        {
            // The whole team: the fold of every unit's observation, built directly.
            let g = GroupObs::team(env, self.team, episode, agent.reads());
            out.extend(super::complete(agent.act(&g), &g));
            return out;
        }
        for (units, agent) in &mut self.groups {
            let mine = env.agent_observations_of(self.team, episode, units, agent.reads());
            if let Some(g) = GroupObs::fold(&mine, index) {
                out.extend(super::complete(agent.act(&g), &g));
            }
        }
        out
    }

    /// Acts and submits the actions to the environment.
    pub fn step(&mut self, env: &mut Env, episode: u64) {
        let actions = self.act(env, episode);
        env.submit(self.team, &actions);
    }
}
