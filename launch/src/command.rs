//! Commanders in launch files: an agent entry with `commander: true` and a `team` makes that
//! team's units change role groups during the episode. Every other entry of the team is then a
//! role group with a distinct `role` and the units it starts with.

use crate::{AgentPlan, Cx, LaunchError, PolicyError};
use avacraft_ava::{AvaCommander, AvaRun, AvaSpec, CallObserver};
use avacraft_engine::agent::{GroupRole, MakeCommander, Rotate};
use avacraft_nodes::{AgentId, TeamNo};
use std::sync::Arc;

/// The scripted commander's name, and how often it moves units (steps).
pub const ROTATE_POLICY: &str = Rotate::NAME;
pub const ROTATE_EVERY: u32 = 4;

/// What commands a team.
#[derive(Clone, Debug, PartialEq)]
pub enum CommanderPolicy {
    /// AVA's planner, roles and priorities.
    Ava(Arc<AvaSpec>),
    /// Hands every unit to the next group every [`ROTATE_EVERY`] steps (tests, demonstrations).
    Rotate,
}

impl CommanderPolicy {
    /// What makes fresh commanders; AVA records the node's calls under `record/<agent>`.
    pub fn factory_for(&self, agent: &str) -> Result<MakeCommander, PolicyError> {
        self.factory_observed(agent, None)
    }

    /// [`CommanderPolicy::factory_for`], with AVA's calls also handed to `observer`.
    pub fn factory_observed(&self, agent: &str, observer: Option<CallObserver>) -> Result<MakeCommander, PolicyError> {
        self.factory_run(agent, observer).map(|(f, _)| f)
    }

    /// [`CommanderPolicy::factory_observed`], and for AVA its run (the node's accounting).
    pub fn factory_run(&self, agent: &str, observer: Option<CallObserver>) -> Result<(MakeCommander, Option<Arc<AvaRun>>), PolicyError> {
        match self {
            CommanderPolicy::Rotate => Ok((Box::new(|| Box::new(Rotate::new(ROTATE_EVERY))), None)),
            CommanderPolicy::Ava(spec) => {
                let setup = crate::policy::ava_setup(spec, agent, observer)?;
                let run = setup.run.clone();
                Ok((Box::new(move || Box::new(AvaCommander::new(setup.clone()))), Some(run)))
            }
        }
    }
}

impl std::fmt::Display for CommanderPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CommanderPolicy::Ava(_) => crate::AVA_POLICY,
            CommanderPolicy::Rotate => ROTATE_POLICY,
        })
    }
}

/// A team's commander node.
#[derive(Clone, Debug, PartialEq)]
pub struct CommanderPlan {
    pub id: AgentId,
    pub team: TeamNo,
    pub policy: CommanderPolicy,
    pub host: String,
    /// The team's role groups (agent nodes), in order, with their roles.
    pub groups: Vec<(AgentId, GroupRole)>,
}

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
            return Err(cx.err(format!("{field}.policy"), crate::DDS_POLICY, "a role group under a commander runs here, not over DDS"));
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

#[cfg(test)]
mod tests {
    use crate::{LaunchError, parse};
    use avacraft_engine::agent::GroupRole;

    const GROUPS: &str =
        "  - {id: front, units: [1, 2], policy: focus-fire, role: attacker}\n  - {id: back, units: [3], policy: hold, role: defender}\n";

    #[test]
    fn a_commander_links_its_teams_role_groups() {
        let p =
            parse("c.yaml", &format!("scenario: 3m\nagents:\n  - {{id: cmd, team: 1, commander: true, policy: rotate}}\n{GROUPS}"), None)
                .expect("plan");
        assert_eq!(p.commanders.len(), 1);
        let c = &p.commanders[0];
        assert_eq!((c.id.as_str(), c.team.get(), c.policy.to_string().as_str()), ("cmd", 1, "rotate"));
        let groups: Vec<(&str, GroupRole)> = c.groups.iter().map(|(id, r)| (id.as_str(), *r)).collect();
        assert_eq!(groups, vec![("front", GroupRole::Attacker), ("back", GroupRole::Defender)]);
        assert_eq!(p.agents.len(), 2, "the commander is no unit's owner");
        assert_eq!(p.controllers().expect("controllers").commanded().len(), 1);
    }

    #[test]
    fn commander_mistakes_name_the_field() {
        let cmd = "  - {id: cmd, team: 1, commander: true, policy: rotate}\n";
        let cases = [
            (format!("scenario: 3m\nagents:\n{GROUPS}"), "agents[0].role", "has no commander"),
            (
                format!("scenario: 3m\nagents:\n{cmd}  - {{id: front, units: [1, 2, 3], policy: hold}}\n"),
                "agents[1].role",
                "each of its agent nodes",
            ),
            (format!("scenario: 3m\nagents:\n{cmd}{}", GROUPS.replace("defender", "attacker")), "agents[2].role", "has this role already"),
            (format!("scenario: 3m\nagents:\n{cmd}{}", GROUPS.replace("defender", "medic")), "agents[2].role", "must be one of"),
            (format!("scenario: 3m\nagents:\n{cmd}{cmd}{GROUPS}"), "agents[1].team", "has a commander already"),
            (
                format!("scenario: 3m\nagents:\n  - {{id: cmd, team: 1, commander: true, policy: hold}}\n{GROUPS}"),
                "agents[0].policy",
                "ava or rotate",
            ),
            (
                format!("scenario: 3m\nagents:\n  - {{id: cmd, team: 1, units: [1], commander: true, policy: rotate}}\n{GROUPS}"),
                "agents[0].commander",
                "not `units`",
            ),
            (
                format!("scenario: 3m\nagents:\n  - {{id: cmd, team: 2, commander: true, policy: rotate}}\n{GROUPS}"),
                "agents[0].team",
                "opponent",
            ),
            (
                format!("scenario: 3m\nagents:\n  - {{id: front, team: 1, commander: true, policy: rotate}}\n{GROUPS}"),
                "agents[1].id",
                "share this id",
            ),
            ("scenario: 3m\nagents:\n  - {id: cmd, team: 1, commander: true, policy: rotate}\n".to_owned(), "agents", "has no role groups"),
        ];
        for (text, field, why) in cases {
            let e = parse("bad.yaml", &text, None).expect_err(&text);
            let msg = e.to_string();
            match &e {
                LaunchError::Invalid { field: f, .. } => assert_eq!(f, field, "{msg}"),
                other => panic!("{other:?}"),
            }
            assert!(msg.contains(why), "{text}: {msg}");
        }
    }
}
