//! Agent nodes under a commander (dynamic role groups). Both kinds subscribe to every unit of
//! their team and to `team_<n>/roles`, the groups in force each step with the commander's
//! briefing, published by the simulator:
//! - a **role-group node** acts, each step, for the units the roles give it (none: it sends
//!   nothing), on the fold of their observations, briefed first;
//! - the **commander node** folds the whole team's observations, asks its [`Commander`] and
//!   publishes the orders for the next step on `team_<n>/orders`.
//!
//! That is the in-process schedule of [`avacraft_engine::agent::CommandedTeam`], message for
//! message, so a deployment and `episode --launch` play the same game.

use crate::{AgentStats, GATHER};
use avacraft_engine::agent::{Agent, AgentCtx, AgentObs, Assignment, Briefing, Commander, GroupObs, GroupRole, agent_seed, commander_seed};
use avacraft_engine::{Scenario, Team, UnitId};
use avacraft_msgs::{ActionBatch, RoleAssignment, RoleGroup, UnitObservation};
use avacraft_nodes::{AgentId, Node, NodeError, Qos, Shutdown, Subscriber, TeamNo, TopicKind, Topics, UnitTag, wire};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A node of a commanded team.
#[derive(Debug)]
pub struct CommandedConfig {
    pub id: AgentId,
    pub team: TeamNo,
    /// A role group's units at the start of each episode (its first unit seeds it); empty
    /// for the commander.
    pub initial: Vec<UnitTag>,
    /// The roles of the team's groups, in order (the commander's view of them).
    pub groups: Vec<GroupRole>,
    pub scenario: Arc<Scenario>,
}

/// A `RoleAssignment` off the wire, its tags checked once.
struct Roles {
    groups: Vec<GroupIn>,
    plan: String,
    priorities: Vec<UnitId>,
}

struct GroupIn {
    role: u8,
    agent_id: String,
    units: Vec<UnitId>,
}

impl Roles {
    fn from_wire(m: RoleAssignment) -> Result<Roles, wire::WireError> {
        let tags = |field, v: &[u32]| v.iter().map(|&t| wire::tag_in("RoleAssignment", field, t)).collect::<Result<Vec<_>, _>>();
        let groups = m
            .groups
            .into_iter()
            .map(|g| Ok(GroupIn { units: tags("groups.unit_tags", &g.unit_tags)?, role: g.role, agent_id: g.agent_id }))
            .collect::<Result<_, wire::WireError>>()?;
        Ok(Roles { groups, priorities: tags("priority_tags", &m.priority_tags)?, plan: m.plan })
    }
}

/// One step being gathered: the roles in force and the observations so far.
struct Step {
    since: Instant,
    roles: Option<Roles>,
    obs: BTreeMap<UnitId, AgentObs>,
}

struct Inputs {
    subs: Vec<Subscriber<UnitObservation>>,
    roles: Subscriber<RoleAssignment>,
    steps: BTreeMap<(u64, u32), Step>,
    last_done: Option<(u64, u32)>,
    /// Every unit of the team, in agent order.
    order: Vec<UnitId>,
}

impl Inputs {
    fn open(node: &Node, topics: &Topics, cfg: &CommandedConfig) -> Result<Inputs, NodeError> {
        let reliable = Qos::Reliable { depth: 10 };
        let order = cfg.scenario.agent_order(cfg.team.team());
        let mut subs = Vec::new();
        for &id in &order {
            subs.push(node.subscriber::<UnitObservation>(&topics.unit_obs(cfg.team, UnitTag::from(id)), reliable)?);
        }
        let roles = node.subscriber::<RoleAssignment>(&topics.team_roles(cfg.team), reliable)?;
        Ok(Inputs { subs, roles, steps: BTreeMap::new(), last_done: None, order })
    }

    fn fresh(&mut self, key: (u64, u32)) -> Option<&mut Step> {
        // A restarted simulator counts episodes from 0 again.
        if self.last_done.is_some_and(|d| key.0 < d.0) {
            self.last_done = None;
        }
        if self.last_done.is_some_and(|d| key <= d) {
            return None;
        }
        Some(self.steps.entry(key).or_insert_with(|| Step { since: Instant::now(), roles: None, obs: BTreeMap::new() }))
    }

    /// Takes what has arrived; blocks up to a millisecond when nothing has.
    fn poll(&mut self, cfg: &CommandedConfig, topics: &Topics, stats: &mut AgentStats) -> Result<(), NodeError> {
        let mut got = false;
        while let Some(r) = self.roles.try_recv()? {
            got = true;
            let on_topic = topics.classify(&r.topic) == Some(TopicKind::TeamRoles(cfg.team));
            self.take_roles(cfg, r.msg.ok().filter(|_| on_topic), stats);
        }
        for i in 0..self.subs.len() {
            while let Some(r) = self.subs[i].try_recv()? {
                got = true;
                self.accept(cfg, topics, r, stats);
            }
        }
        if !got && let Some(r) = self.roles.recv_timeout(Duration::from_millis(1))? {
            self.take_roles(cfg, r.msg.ok(), stats);
        }
        Ok(())
    }

    fn take_roles(&mut self, cfg: &CommandedConfig, m: Option<RoleAssignment>, stats: &mut AgentStats) {
        let Some(m) = m.filter(|m| m.team == cfg.team.get()) else {
            stats.malformed += 1;
            return;
        };
        let key = (m.episode, m.step);
        match Roles::from_wire(m) {
            Ok(roles) => {
                if let Some(s) = self.fresh(key) {
                    s.roles = Some(roles);
                }
            }
            Err(e) => {
                stats.malformed += 1;
                tracing::warn!(agent = %cfg.id, error = %e, "roles refused");
            }
        }
    }

    fn accept(&mut self, cfg: &CommandedConfig, topics: &Topics, r: avacraft_nodes::Received<UnitObservation>, stats: &mut AgentStats) {
        let Ok(o) = r.msg else {
            stats.malformed += 1;
            return;
        };
        let on_its_topic = matches!(topics.classify(&r.topic), Some(TopicKind::UnitObs(t, u)) if t == cfg.team && u.get() == o.unit_tag);
        if !on_its_topic {
            stats.malformed += 1;
            return;
        }
        match wire::agent_obs(&o, Team::from(cfg.team)) {
            Ok(obs) => {
                if let Some(s) = self.fresh((o.episode, o.step)) {
                    s.obs.insert(obs.unit, obs);
                }
            }
            Err(e) => {
                stats.malformed += 1;
                tracing::warn!(agent = %cfg.id, error = %e, "observation refused");
            }
        }
    }

    /// The newest step that has its roles and the observations `needed` says it needs (or
    /// has waited long enough), removed with everything older.
    fn ready(&mut self, needed: impl Fn(&Roles) -> Vec<UnitId>) -> Option<((u64, u32), Roles, Vec<AgentObs>)> {
        let key = self
            .steps
            .iter()
            .rev()
            .find(|(_, s)| s.roles.as_ref().is_some_and(|r| needed(r).iter().all(|t| s.obs.contains_key(t)) || s.since.elapsed() >= GATHER))
            .map(|(k, _)| *k)?;
        let s = self.steps.remove(&key)?;
        self.steps.retain(|k, _| *k > key);
        self.last_done = Some(key);
        let roles = s.roles?;
        let want = needed(&roles);
        Some((key, roles, s.obs.into_iter().filter(|(t, _)| want.contains(t)).map(|(_, o)| o).collect()))
    }

    fn index(&self) -> impl Fn(UnitId) -> usize + '_ {
        |id| self.order.iter().position(|&o| o == id).unwrap_or(0)
    }
}

/// The units `roles` gives the group `id`.
fn owned(roles: &Roles, id: &AgentId) -> Vec<UnitId> {
    roles.groups.iter().filter(|g| g.agent_id == id.as_str()).flat_map(|g| g.units.iter().copied()).collect()
}

fn team_of(no: TeamNo) -> Team {
    no.team()
}

/// Runs a role-group node until `shutdown` (or `max_batches` batches).
pub fn run_role_group(
    node: &Node,
    topics: &Topics,
    cfg: &CommandedConfig,
    agent: &mut dyn Agent,
    shutdown: &Shutdown,
    max_batches: Option<u64>,
) -> Result<AgentStats, NodeError> {
    let mut inputs = Inputs::open(node, topics, cfg)?;
    let mut out = node.publisher::<ActionBatch>(&topics.actions(&cfg.id), Qos::Reliable { depth: 10 })?;
    let team = team_of(cfg.team);
    let initial: Vec<UnitId> = cfg.initial.iter().map(|&u| UnitId::from(u)).collect();
    let mut stats = AgentStats::default();
    let mut episode: Option<(u64, u64)> = None;
    // The episode's scenario (a procedural scenario's draw for its seed).
    let mut scenario = Arc::clone(&cfg.scenario);
    tracing::info!(agent = %cfg.id, units = initial.len(), policy = agent.name(), "role-group node up");
    while !shutdown.requested() && max_batches.is_none_or(|m| stats.batches < m) {
        inputs.poll(cfg, topics, &mut stats)?;
        let Some((key, roles, obs)) = inputs.ready(|r| owned(r, &cfg.id)) else { continue };
        let Some(first) = obs.first() else { continue };
        if episode != Some((first.episode, first.seed)) {
            let seed = agent_seed(first.seed, team, initial.first().map_or(0, |id| id.tag()));
            scenario = cfg.scenario.episode(first.seed);
            agent.reset(&AgentCtx { scenario: Arc::clone(&scenario), team, units: initial.clone(), seed });
            episode = Some((first.episode, first.seed));
        }
        let role =
            roles.groups.iter().find(|g| g.agent_id == cfg.id.as_str()).and_then(|g| GroupRole::from_code(g.role)).unwrap_or_default();
        agent.brief(&Briefing { role, plan: roles.plan.clone(), priorities: roles.priorities.clone() });
        let actions = GroupObs::fold(&obs, inputs.index()).map(|g| super::act(agent, &g, &scenario, &mut stats)).unwrap_or_default();
        let actions = actions.iter().map(wire::unit_action).collect();
        out.put(&ActionBatch { header: Default::default(), episode: key.0, step: key.1, agent_id: cfg.id.to_string(), actions })?;
        stats.batches += 1;
    }
    Ok(stats)
}

/// Runs a commander node until `shutdown` (or `max_batches` orders).
pub fn run_commander(
    node: &Node,
    topics: &Topics,
    cfg: &CommandedConfig,
    commander: &mut dyn Commander,
    shutdown: &Shutdown,
    max_batches: Option<u64>,
) -> Result<AgentStats, NodeError> {
    let mut inputs = Inputs::open(node, topics, cfg)?;
    let mut out = node.publisher::<RoleAssignment>(&topics.orders(cfg.team), Qos::Reliable { depth: 10 })?;
    let team = team_of(cfg.team);
    let all = inputs.order.clone();
    let mut stats = AgentStats::default();
    let mut episode: Option<(u64, u64)> = None;
    tracing::info!(agent = %cfg.id, groups = cfg.groups.len(), policy = commander.name(), "commander node up");
    while !shutdown.requested() && max_batches.is_none_or(|m| stats.batches < m) {
        inputs.poll(cfg, topics, &mut stats)?;
        let Some((key, roles, obs)) = inputs.ready(|_| all.clone()) else { continue };
        let Some(first) = obs.first() else { continue };
        if episode != Some((first.episode, first.seed)) {
            let ctx = AgentCtx {
                scenario: cfg.scenario.episode(first.seed),
                team,
                units: cfg.scenario.agent_order(team),
                seed: commander_seed(first.seed, team),
            };
            commander.reset(&ctx, &cfg.groups);
            episode = Some((first.episode, first.seed));
        }
        // The groups in force, by index.
        let current = Assignment::new(roles.groups.iter().map(|g| g.units.clone()).collect());
        let Some(g) = GroupObs::fold(&obs, inputs.index()) else { continue };
        let orders = commander.command(&g, &current);
        let mut groups: Vec<RoleGroup> =
            roles.groups.iter().map(|r| RoleGroup { role: r.role, agent_id: r.agent_id.clone(), unit_tags: Vec::new() }).collect();
        for (unit, i) in orders.owners {
            match groups.get_mut(i) {
                Some(gr) => gr.unit_tags.push(unit.tag()),
                // An index past the groups: say so on the wire, where the simulator refuses it.
                None => groups.push(RoleGroup { role: 0, agent_id: format!("group_{i}"), unit_tags: vec![unit.tag()] }),
            }
        }
        out.put(&RoleAssignment {
            header: Default::default(),
            episode: key.0,
            step: key.1,
            team: cfg.team.get(),
            groups,
            plan: orders.briefing.plan,
            priority_tags: orders.briefing.priorities.iter().map(|id| id.tag()).collect(),
        })?;
        stats.batches += 1;
    }
    Ok(stats)
}
