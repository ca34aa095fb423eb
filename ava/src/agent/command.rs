//! The AVA commander of dynamic role groups: the planner, roles and priority stages for the
//! whole team, and no decision. The roles become ownership (each unit goes to the group with
//! its role; a role no group has leaves the unit where it is) and the plan and priorities
//! become the groups' briefing. Its calls are recorded and costed like an agent's.

use super::decide::{self, Mode};
use super::state::{AvaSetup, Episode};
use crate::cost::EpisodeCost;
use avacraft_engine::UnitId;
use avacraft_engine::agent::{AgentCtx, Assignment, Briefing, Commander, GroupObs, GroupRole, Orders};
use avacraft_render::{CpuBackend, FrameBuilder};

/// The commander.
#[derive(Debug)]
pub struct AvaCommander {
    name: String,
    setup: AvaSetup,
    frames: FrameBuilder,
    cpu: CpuBackend,
    groups: Vec<GroupRole>,
    ep: Option<Episode>,
    briefing: Briefing,
}

impl AvaCommander {
    pub fn new(setup: AvaSetup) -> AvaCommander {
        let name = format!("ava-commander:{}", setup.run.model());
        AvaCommander {
            name,
            setup,
            frames: FrameBuilder::new(),
            cpu: CpuBackend::new(),
            groups: Vec::new(),
            ep: None,
            briefing: Briefing::default(),
        }
    }
}

impl Commander for AvaCommander {
    fn name(&self) -> &str {
        &self.name
    }

    fn reset(&mut self, ctx: &AgentCtx, groups: &[GroupRole]) {
        let cost = EpisodeCost { seed: ctx.seed, team: ctx.team.player(), ..EpisodeCost::default() };
        let cost_idx = self.setup.run.open_episode(cost.clone());
        self.ep = Some(Episode::new(ctx, cost_idx, cost));
        self.groups = groups.to_vec();
        self.briefing = Briefing::default();
    }

    fn command(&mut self, obs: &GroupObs, current: &Assignment) -> Orders {
        let keep = Orders { owners: current.pairs(), briefing: self.briefing.clone() };
        let Some(ep) = self.ep.as_mut() else { return keep };
        let mut alive: Vec<UnitId> = obs.controlled.iter().filter(|c| c.alive).map(|c| c.unit).collect();
        alive.sort_unstable();
        let first = *ep.first_step.get_or_insert(obs.step);
        if alive.is_empty() || !(obs.step - first).is_multiple_of(self.setup.config.decide_every) {
            return keep;
        }
        decide::decide(&self.setup, &mut self.frames, &mut self.cpu, ep, obs, &alive, Mode::Command);
        let owners = current
            .pairs()
            .into_iter()
            .map(|(unit, group)| {
                let role = ep.roles.iter().find(|r| r.unit == unit).and_then(|r| GroupRole::from_name(&r.role));
                let to = role.and_then(|r| self.groups.iter().position(|g| *g == r));
                (unit, to.unwrap_or(group))
            })
            .collect();
        self.briefing = Briefing {
            role: GroupRole::None,
            plan: ep.plan.as_ref().filter(|_| self.setup.config.planner).map(super::Plan::summary).unwrap_or_default(),
            priorities: ep.priorities.iter().map(|p| p.unit).collect(),
        };
        Orders { owners, briefing: self.briefing.clone() }
    }
}
