//! A team under a commander, in-process (`crate::policy::Commander` says what commanders
//! are): every step, each role group acts on the fold of its units' observations, then the
//! commander's orders for the next step are validated and take effect.

use crate::action::Action;
use crate::env::Env;
use crate::ids::{Team, UnitId};
use crate::obs::{GroupObs, Reads};
use crate::policy::{
    Agent, AgentCtx, Assignment, Briefing, Commander, GroupRole, MakeCommander, OrdersError, RoleGroupSpec, agent_seed, commander_seed,
    complete, validate_orders,
};

/// A team under a commander, in-process: the same schedule a deployment runs.
pub struct CommandedTeam {
    team: Team,
    make_commander: MakeCommander,
    specs: Vec<RoleGroupSpec>,
    commander: Option<Box<dyn Commander>>,
    agents: Vec<Box<dyn Agent>>,
    assignment: Assignment,
    briefing: Briefing,
    refused: Vec<OrdersError>,
}

impl std::fmt::Debug for CommandedTeam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CommandedTeam")
            .field("team", &self.team)
            .field("groups", &self.specs.len())
            .field("assignment", &self.assignment)
            .finish()
    }
}

impl CommandedTeam {
    pub fn new(team: Team, make_commander: MakeCommander, groups: Vec<RoleGroupSpec>) -> CommandedTeam {
        CommandedTeam {
            team,
            make_commander,
            specs: groups,
            commander: None,
            agents: Vec::new(),
            assignment: Assignment::default(),
            briefing: Briefing::default(),
            refused: Vec::new(),
        }
    }
    pub fn team(&self) -> Team {
        self.team
    }
    pub fn name(&self) -> String {
        self.commander.as_ref().map_or_else(|| (self.make_commander)().name().to_owned(), |c| c.name().to_owned())
    }
    /// The ownership in force.
    pub fn assignment(&self) -> &Assignment {
        &self.assignment
    }
    /// Orders refused this episode, in order.
    pub fn refused(&self) -> &[OrdersError] {
        &self.refused
    }

    pub fn reset(&mut self, env: &Env) {
        let ids = env.agents(self.team);
        let scenario = std::sync::Arc::clone(env.scenario());
        let roles: Vec<GroupRole> = self.specs.iter().map(|s| s.role).collect();
        self.agents = self
            .specs
            .iter()
            .map(|s| {
                let mut a = (s.make)();
                let first = s.initial.first().map_or(0, |id| id.tag());
                a.reset(&AgentCtx {
                    scenario: scenario.clone(),
                    team: self.team,
                    units: s.initial.iter().copied().filter(|id| ids.contains(id)).collect(),
                    seed: agent_seed(env.seed(), self.team, first),
                });
                a
            })
            .collect();
        let mut c = (self.make_commander)();
        c.reset(
            &AgentCtx { scenario, team: self.team, units: env.agents(self.team).to_vec(), seed: commander_seed(env.seed(), self.team) },
            &roles,
        );
        self.commander = Some(c);
        self.assignment =
            Assignment::new(self.specs.iter().map(|s| s.initial.iter().copied().filter(|id| ids.contains(id)).collect()).collect());
        self.briefing = Briefing::default();
        self.refused.clear();
    }

    /// This step's actions of every group, then the commander's orders for the next step.
    pub fn act(&mut self, env: &Env, episode: u64) -> Vec<Action> {
        let order = env.agents(self.team);
        let index = |id: UnitId| order.iter().position(|&o| o == id).unwrap_or(0);
        let living: Vec<UnitId> = env.world().alive(self.team).map(|u| u.id).filter(|id| order.contains(id)).collect();
        self.assignment = self.assignment.living(&living);
        let mut out = Vec::new();
        for ((agent, units), spec) in self.agents.iter_mut().zip(self.assignment.groups()).zip(&self.specs) {
            if units.is_empty() {
                continue;
            }
            agent.brief(&Briefing { role: spec.role, ..self.briefing.clone() });
            let mine = env.agent_observations_of(self.team, episode, units, agent.reads());
            if let Some(g) = GroupObs::fold(&mine, index) {
                out.extend(complete(agent.act(&g), &g));
            }
        }
        if let Some(c) = self.commander.as_mut() {
            let g = GroupObs::team(env, self.team, episode, Reads::ALL);
            let orders = c.command(&g, &self.assignment);
            match validate_orders(&orders.owners, &living, self.specs.len()) {
                Ok(a) => {
                    self.assignment = a;
                    self.briefing = orders.briefing;
                }
                Err(e) => self.refused.push(e),
            }
        }
        out
    }
}
