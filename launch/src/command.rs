//! Commanders in launch files: an agent entry with `commander: true` and a `team` makes that
//! team's units change role groups during the episode. Every other entry of the team is then a
//! role group with a distinct `role` and the units it starts with.

use crate::error::{Cx, LaunchError};
use crate::plan::{AgentPlan, CommanderPlan};
use avacraft_engine::agent::GroupRole;

/// Checks the role groups against the commanders, and fills in each commander's groups.
pub(crate) fn link(cx: &Cx<'_>, commanders: &mut [CommanderPlan], agents: &[AgentPlan], fields: &[String]) -> Result<(), LaunchError> {
    for (a, field) in agents.iter().zip(fields) {
        let commanded = commanders.iter().any(|c| c.team == a.team);
        match (a.role, commanded) {
            (Some(r), false) => {
                return Err(cx.err(
                    format!("{field}.role"),
                    r,
                    format!("team {} has no commander (an entry with `commander: true`)", a.team.get()),
                ));
            }
            (None, true) => {
                return Err(cx.err(
                    format!("{field}.role"),
                    "none",
                    format!("team {} has a commander: each of its agent nodes is a role group with a `role`", a.team.get()),
                ));
            }
            _ => {}
        }
        if commanded && a.is_dds() {
            return Err(cx.err(
                format!("{field}.policy"),
                avacraft_policy::DDS_POLICY,
                "a role group under a commander runs here, not over DDS",
            ));
        }
    }
    for c in commanders.iter_mut() {
        for (a, field) in agents.iter().zip(fields).filter(|(a, _)| a.team == c.team) {
            let role = a.role.unwrap_or_default();
            if let Some((other, _)) = c.groups.iter().find(|(_, r)| *r == role) {
                return Err(cx.err(format!("{field}.role"), role, format!("role group `{other}` of the team has this role already")));
            }
            if a.id == c.id {
                return Err(cx.err(format!("{field}.id"), &a.id, "the commander's id"));
            }
            c.groups.push((a.id.clone(), role));
        }
        if c.groups.is_empty() {
            return Err(cx.err("agents", &c.id, format!("commander `{}` has no role groups on team {}", c.id, c.team.get())));
        }
    }
    Ok(())
}

/// A role name of a launch file.
pub(crate) fn role(cx: &Cx<'_>, field: String, name: &str) -> Result<GroupRole, LaunchError> {
    GroupRole::from_name(name).filter(|r| GroupRole::ASSIGNABLE.contains(r)).ok_or_else(|| {
        let known: Vec<&str> = GroupRole::ASSIGNABLE.iter().map(|r| r.name()).collect();
        cx.err(field, format!("{name:?}"), format!("must be one of {}", known.join(", ")))
    })
}
