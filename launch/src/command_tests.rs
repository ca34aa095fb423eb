//! Commanders in launch files: the role groups they link, and the mistakes refused.

use crate::{LaunchError, parse};
use avacraft_engine::agent::GroupRole;

const GROUPS: &str =
    "  - {id: front, units: [1, 2], policy: focus-fire, role: attacker}\n  - {id: back, units: [3], policy: hold, role: defender}\n";

#[test]
fn a_commander_links_its_teams_role_groups() {
    let p =
        parse("c.yaml", &format!("scenario: 3m_vlm\nagents:\n  - {{id: cmd, team: 1, commander: true, policy: rotate}}\n{GROUPS}"), None)
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
        (format!("scenario: 3m_vlm\nagents:\n{GROUPS}"), "agents[0].role", "has no commander"),
        (
            format!("scenario: 3m_vlm\nagents:\n{cmd}  - {{id: front, units: [1, 2, 3], policy: hold}}\n"),
            "agents[1].role",
            "each of its agent nodes",
        ),
        (format!("scenario: 3m_vlm\nagents:\n{cmd}{}", GROUPS.replace("defender", "attacker")), "agents[2].role", "has this role already"),
        (format!("scenario: 3m_vlm\nagents:\n{cmd}{}", GROUPS.replace("defender", "medic")), "agents[2].role", "must be one of"),
        (format!("scenario: 3m_vlm\nagents:\n{cmd}{cmd}{GROUPS}"), "agents[1].team", "has a commander already"),
        (
            format!("scenario: 3m_vlm\nagents:\n  - {{id: cmd, team: 1, commander: true, policy: hold}}\n{GROUPS}"),
            "agents[0].policy",
            "is `ava` or `rotate`",
        ),
        (
            format!("scenario: 3m_vlm\nagents:\n  - {{id: cmd, team: 1, units: [1], commander: true, policy: rotate}}\n{GROUPS}"),
            "agents[0].commander",
            "not `units`",
        ),
        (
            format!("scenario: 3m_vlm\nagents:\n  - {{id: cmd, team: 2, commander: true, policy: rotate}}\n{GROUPS}"),
            "agents[0].team",
            "opponent",
        ),
        (
            format!("scenario: 3m_vlm\nagents:\n  - {{id: front, team: 1, commander: true, policy: rotate}}\n{GROUPS}"),
            "agents[1].id",
            "share this id",
        ),
        ("scenario: 3m_vlm\nagents:\n  - {id: cmd, team: 1, commander: true, policy: rotate}\n".to_owned(), "agents", "has no role groups"),
    ];
    for (text, field, why) in cases {
        let e = parse("bad.yaml", &text, None).expect_err(&text);
        let msg = crate::chain(&e);
        match &e {
            LaunchError::Invalid { field: f, .. } | LaunchError::Policy { field: f, .. } => assert_eq!(f, field, "{msg}"),
            other => panic!("{other:?}"),
        }
        assert!(msg.contains(why), "{text}: {msg}");
    }
}
