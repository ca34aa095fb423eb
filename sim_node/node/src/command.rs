//! Dynamic role groups on the simulator's side. A team's commander publishes orders on
//! `team_<n>/orders` for each step; the simulator waits for them like for actions (lockstep),
//! checks them with the engine's one check ([`validate_orders`]: every living unit exactly
//! once, known groups only) and, after the step, hands the units over: from the next step
//! the sender check and the awaited actions follow the new owners, so no unit is ever driven
//! by two nodes or by none. Each step it publishes the groups in force with the commander's
//! briefing on `team_<n>/roles`, which the team's role-group nodes act on.

use crate::config::{SimConfig, TeamCommand};
use crate::convert::{header, unit_of};
use avacraft_engine::agent::{Assignment, validate_orders};
use avacraft_engine::{Env, UnitId};
use avacraft_msgs::{RoleAssignment, RoleGroup};
use avacraft_nodes::wire::tag_in;
use avacraft_nodes::{AgentId, Node, NodeError, Publisher, Qos, Subscriber, TopicKind, Topics, UnitTag};
use std::collections::BTreeMap;

/// Counters of one episode, per team.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct OrderCounts {
    pub refused: [u32; 2],
    pub missing: [u32; 2],
    pub changes: [u32; 2],
}

struct Team {
    spec: TeamCommand,
    roles: Publisher<RoleAssignment>,
    orders: Subscriber<RoleAssignment>,
    /// The briefing in force (plan, priorities).
    plan: String,
    priorities: Vec<u32>,
    /// Orders for the step being played, once received and checked.
    next: Option<(Assignment, String, Vec<u32>)>,
    awaited: bool,
}

pub(crate) struct Command {
    teams: Vec<Team>,
    topics: Topics,
    /// (episode, step) whose orders are awaited.
    at: (u64, u32),
}

impl Command {
    pub(crate) fn new(node: &Node, topics: &Topics, cfg: &SimConfig) -> Result<Command, NodeError> {
        let reliable = Qos::Reliable { depth: 10 };
        let mut teams = Vec::new();
        for c in &cfg.commands {
            teams.push(Team {
                spec: c.clone(),
                roles: node.publisher(&topics.team_roles(c.team), reliable)?,
                orders: node.subscriber(&topics.orders(c.team), reliable)?,
                plan: String::new(),
                priorities: Vec::new(),
                next: None,
                awaited: false,
            });
        }
        Ok(Command { teams, topics: topics.clone(), at: (0, 0) })
    }

    /// A new episode: no briefing yet.
    pub(crate) fn reset(&mut self) {
        for t in &mut self.teams {
            t.plan.clear();
            t.priorities.clear();
            t.next = None;
        }
    }

    /// Publishes each commanded team's groups in force (living units only) and briefing.
    pub(crate) fn publish(&mut self, env: &Env, owners: &BTreeMap<UnitTag, AgentId>, episode: u64) -> Result<(), NodeError> {
        for t in &mut self.teams {
            let alive = |tag: &UnitTag| unit_of(env, tag.get()).is_some_and(|u| u.alive);
            let groups = t
                .spec
                .groups
                .iter()
                .map(|(id, role)| RoleGroup {
                    role: role.code(),
                    agent_id: id.to_string(),
                    unit_tags: owners.iter().filter(|(tag, a)| *a == id && alive(tag)).map(|(tag, _)| tag.get()).collect(),
                })
                .collect();
            t.roles.put(&RoleAssignment {
                header: header(env.world(), "map"),
                episode,
                step: env.steps(),
                team: t.spec.team.get(),
                groups,
                plan: t.plan.clone(),
                priority_tags: t.priorities.clone(),
            })?;
        }
        Ok(())
    }

    /// Starts waiting for this step's orders.
    pub(crate) fn expect(&mut self, episode: u64, step: u32) {
        self.at = (episode, step);
        for t in &mut self.teams {
            t.awaited = true;
            t.next = None;
        }
    }

    pub(crate) fn waiting(&self) -> bool {
        self.teams.iter().any(|t| t.awaited)
    }

    /// Takes the orders that have arrived; checks those for this step.
    pub(crate) fn receive(&mut self, env: &Env, episode: u64, step: u32, n: &mut OrderCounts) -> Result<(), NodeError> {
        for t in &mut self.teams {
            let ti = t.spec.team.team().index();
            while let Some(r) = t.orders.try_recv()? {
                let on_topic = matches!(self.topics.classify(&r.topic), Some(TopicKind::Orders(no)) if no == t.spec.team);
                let msg = match r.msg {
                    Ok(m) if on_topic => m,
                    Ok(_) => continue,
                    Err(e) => {
                        tracing::warn!(team = t.spec.team.get(), error = %e, "malformed orders refused");
                        n.refused[ti] += 1;
                        continue;
                    }
                };
                if (msg.episode, msg.step) != (episode, step) || !t.awaited {
                    continue;
                }
                t.awaited = false;
                match check(&t.spec, env, &msg) {
                    Ok(a) => t.next = Some((a, msg.plan, msg.priority_tags)),
                    Err(why) => {
                        tracing::warn!(team = t.spec.team.get(), step, "orders refused: {why}");
                        n.refused[ti] += 1;
                    }
                }
            }
        }
        Ok(())
    }

    /// The step's deadline passed: orders still awaited are missing (ownership stays).
    pub(crate) fn deadline(&mut self, n: &mut OrderCounts) {
        for t in &mut self.teams {
            if t.awaited {
                n.missing[t.spec.team.team().index()] += 1;
                t.awaited = false;
            }
        }
    }

    /// Applies the checked orders to `owners`; true when any unit changed hands.
    pub(crate) fn apply(&mut self, owners: &mut BTreeMap<UnitTag, AgentId>, n: &mut OrderCounts) -> bool {
        let mut changed = false;
        for t in &mut self.teams {
            let Some((a, plan, priorities)) = t.next.take() else { continue };
            for (i, units) in a.groups().iter().enumerate() {
                let id = &t.spec.groups[i].0;
                for &u in units {
                    if owners.insert(UnitTag::from(u), id.clone()).as_ref() != Some(id) {
                        n.changes[t.spec.team.team().index()] += 1;
                        changed = true;
                    }
                }
            }
            t.plan = plan;
            t.priorities = priorities;
        }
        changed
    }
}

/// Orders as the engine's check sees them: group ids become indices.
fn check(spec: &TeamCommand, env: &Env, msg: &RoleAssignment) -> Result<Assignment, String> {
    if msg.team != spec.team.get() {
        return Err(format!("orders for team {} on team {}'s topic", msg.team, spec.team.get()));
    }
    let mut pairs = Vec::new();
    for g in &msg.groups {
        let Some(i) = spec.groups.iter().position(|(id, _)| id.as_str() == g.agent_id) else {
            return Err(format!("`{}` is not a role group of team {}", g.agent_id, spec.team.get()));
        };
        for &u in &g.unit_tags {
            pairs.push((tag_in("RoleAssignment", "groups.unit_tags", u).map_err(|e| e.to_string())?, i));
        }
    }
    let team = spec.team.team();
    let living: Vec<UnitId> = env.world().alive(team).filter(|u| env.agents(team).contains(&u.id)).map(|u| u.id).collect();
    validate_orders(&pairs, &living, spec.groups.len()).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use avacraft_engine::agent::GroupRole;
    use avacraft_engine::{EnvConfig, builtin};
    use avacraft_nodes::{AgentId, TeamNo};
    use std::sync::Arc;

    /// Orders off the wire are checked once: a number that is no tag names the message and
    /// field, and good orders become the engine's assignment.
    #[test]
    fn orders_off_the_wire_are_checked_tags_first() {
        let env = Env::new(Arc::new(builtin("3m_vlm").expect("built in")), EnvConfig::default(), 1);
        let id = |s: &str| AgentId::parse(s).expect("an id");
        let spec = TeamCommand {
            team: TeamNo::new(1).expect("team"),
            commander: id("boss"),
            groups: vec![(id("a"), GroupRole::Attacker), (id("b"), GroupRole::Defender)],
        };
        let msg = |a: Vec<u32>, b: Vec<u32>| RoleAssignment {
            team: 1,
            groups: vec![
                RoleGroup { role: 1, agent_id: "a".into(), unit_tags: a },
                RoleGroup { role: 2, agent_id: "b".into(), unit_tags: b },
            ],
            ..RoleAssignment::default()
        };
        let a = check(&spec, &env, &msg(vec![1], vec![2, 3])).expect("good orders");
        let ids = |t: &[u32]| t.iter().map(|&t| UnitId::try_from(t).expect("a tag")).collect::<Vec<_>>();
        assert_eq!(a.groups(), &[ids(&[1]), ids(&[2, 3])]);
        let e = check(&spec, &env, &msg(vec![0, 1], vec![2, 3])).expect_err("tag 0");
        assert!(e.contains("RoleAssignment.groups.unit_tags = 0"), "{e}");
        let e = check(&spec, &env, &msg(vec![1], vec![2])).expect_err("unit 3 left out");
        assert_eq!(e, "living unit 3 is given to no group");
    }
}
