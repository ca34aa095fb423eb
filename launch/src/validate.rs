//! A launch file checked field by field into a [`Plan`]: every refusal names the file, the
//! field and the value. The checks run in the file's order (the scenario first: the agent
//! entries are checked against its units and teams), one function per section.

use crate::command;
use crate::deploy;
use crate::error::{Cx, LaunchError};
use crate::plan::{AgentPlan, ClockMode, CommanderPlan, EncoderPlan, FramePlan, Plan, RawAgent, RawFrames, RawLaunch};
use avacraft_engine::agent::FrameNeed;
use avacraft_engine::{Env, EnvConfig, EnvOptions, Mode, OpponentKind, RewardMode, Scenario, Team, UnitId, WeaponPeriod};
use avacraft_nodes::{AgentId, FrameKind, TeamNo, UnitTag};
use avacraft_policy::{AVA_POLICY, CommanderPolicy, DDS_POLICY, PolicyError, PolicySpec, Resolve, Weights};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

/// The `env` section over a deployment's defaults (PvP-ready: no passive allies, sparse
/// reward), refusing the rules a session description cannot carry: its recording could not
/// be replayed with them.
fn env_section(cx: &Cx<'_>, over: Option<&serde_json::Value>, opponent: Option<OpponentKind>) -> Result<EnvConfig, LaunchError> {
    let mut options = EnvOptions { opponent, passive_allies: false, reward: RewardMode::Sparse, ..EnvOptions::default() };
    if let Some(over) = over {
        options = options.overlay(over, &["opponent", "data"]).map_err(|why| cx.err("env", over, why))?;
    }
    let env = options.config().map_err(|b| cx.err(format!("env.{}", b.option), b.value, b.supported))?;
    if env.rules.weapon_period != WeaponPeriod::Attack {
        let why = "only `attack` in a deployment: the session description (SessionInfo) does not carry another reading, so its recording could not be replayed";
        return Err(cx.err("env.weapon_period", env.rules.weapon_period, why));
    }
    if env.rules.melee_surround {
        let why = "only `false` in a deployment: the session description (SessionInfo) does not carry the surround experiment, so its recording could not be replayed";
        return Err(cx.err("env.melee_surround", true, why));
    }
    if env.state_agent {
        let why = "only `false` in a deployment: the session description (SessionInfo) does not carry the agent-specific state, a training option (the critic's input)";
        return Err(cx.err("env.state_agent", true, why));
    }
    if let Some((option, value)) = env.dense_reward.first_change() {
        let why = "SMAC's default only in a deployment: the session description (SessionInfo) does not carry other reward settings, so its recording could not be replayed";
        return Err(cx.err(format!("env.{option}"), value, why));
    }
    Ok(env)
}

pub(crate) fn validate(file: &str, raw: RawLaunch, how: Resolve<'_>) -> Result<Plan, LaunchError> {
    let cx = Cx(file);
    let scenario_arg = match how.base.map(|b| b.join(&raw.scenario)) {
        Some(p) if p.exists() => p.display().to_string(),
        _ => raw.scenario.clone(),
    };
    let scenario = Scenario::load(&scenario_arg).map_err(|e| cx.err("scenario", format!("{:?}", raw.scenario), e.to_string()))?;
    let scenario = match &raw.data {
        None => scenario,
        Some(d) => {
            let set: avacraft_engine::DataSet =
                d.parse().map_err(|e: avacraft_engine::UnknownDataSet| cx.err("data", format!("{d:?}"), e.to_string()))?;
            scenario.with_data(set).map_err(|e| cx.err("data", format!("{d:?}"), e.to_string()))?
        }
    };
    let clock = match raw.clock.as_str() {
        "lockstep" => ClockMode::Lockstep,
        "realtime" => ClockMode::RealTime,
        other => return Err(cx.err("clock", format!("{other:?}"), "must be `lockstep` or `realtime`")),
    };
    if !(1..=600_000).contains(&raw.deadline_ms) {
        return Err(cx.err("deadline_ms", raw.deadline_ms, "must be 1 to 600000 milliseconds"));
    }
    if !(1..=1_000_000).contains(&raw.episodes) {
        return Err(cx.err("episodes", raw.episodes, "must be 1 to 1000000"));
    }
    if raw.seed.checked_add(raw.episodes).is_none() {
        return Err(cx.err("seed", raw.seed, format!("seed + episodes ({}) overflows", raw.episodes)));
    }
    let opponent = match &raw.opponent {
        None => None,
        Some(o) if scenario.mode == Mode::Pvp => {
            return Err(cx.err("opponent", format!("{o:?}"), "a PvP scenario has agent nodes on both teams"));
        }
        Some(o) => Some(o.parse::<OpponentKind>().map_err(|e| cx.err("opponent", format!("{o:?}"), e))?),
    };
    let hosts = hosts(&cx, &raw.hosts)?;
    let security = raw.security.as_ref().map(|s| deploy::security(s, how.base));
    if hosts.len() > 1 && security.is_none() {
        return Err(cx.err("hosts", format!("{hosts:?}"), "a deployment across hosts needs `security:` (TLS and access control)"));
    }
    router(&cx, &raw.router, security.is_some(), hosts.len() > 1)?;
    let frames = raw.frames.as_ref().map(|f| frames(&cx, f)).transpose()?;
    let scenario = Arc::new(scenario);
    if raw.agents.is_empty() {
        return Err(cx.err("agents", "[]", "at least one agent node is needed"));
    }
    let mut nodes = Nodes::new(&cx, &scenario, how, &hosts);
    for (i, a) in raw.agents.iter().enumerate() {
        nodes.entry(i, a, raw.ava.as_ref())?;
    }
    let frames = agent_frames(&cx, frames, &nodes.needs)?;
    let Nodes { mut agents, fields, mut commanders, .. } = nodes;
    let encoders = if raw.share_encoder { encoders(&mut agents, &commanders, &scenario) } else { Vec::new() };
    command::link(&cx, &mut commanders, &agents, &fields)?;
    let bridge = match &raw.bridge {
        None => {
            if let Some(a) = agents.iter().position(|a| a.is_dds()) {
                return Err(cx.err(format!("agents[{a}].policy"), DDS_POLICY, "agents driven from DDS need a `bridge:` section"));
            }
            None
        }
        Some(b) => {
            let plan = deploy::bridge_plan(&cx, b, &hosts, &agents)?;
            if let Some(a) = agents.iter().find(|a| a.is_dds() && a.host != plan.host) {
                return Err(cx.err(
                    "bridge.host",
                    format!("{:?}", plan.host),
                    format!("agent `{}` (policy dds) is on host `{}`; DDS agents live on the bridge's host", a.id, a.host),
                ));
            }
            Some(plan)
        }
    };
    let env = env_section(&cx, raw.env.as_ref(), opponent)?;
    // A network trained with the ability slots reads an observation only a game with them
    // gives: without, its node would give no orders at all.
    if !env.ability_actions {
        for (i, a) in agents.iter().enumerate() {
            if a.policy.ability_actions(&scenario).map_err(|e| cx.policy_err(format!("agents[{i}].policy"), &a.policy.to_string(), e))? {
                return Err(cx.err(
                    format!("agents[{i}].policy"),
                    a.policy.to_string(),
                    "this network was trained with the ability slots: the launch needs `env: {ability_actions: true}`",
                ));
            }
        }
    }
    Ok(Plan {
        file: file.to_owned(),
        scenario_arg,
        scenario,
        clock,
        deadline: Duration::from_millis(raw.deadline_ms),
        seeds: (0..raw.episodes).map(|k| raw.seed + k).collect(),
        opponent,
        env,
        router: raw.router,
        record: raw.record,
        record_by: raw.record_by,
        frames,
        agents,
        commanders,
        encoders,
        hosts,
        security,
        bridge,
    })
}

/// The hosts (`local` when none are named).
fn hosts(cx: &Cx<'_>, raw: &[String]) -> Result<Vec<String>, LaunchError> {
    let hosts = if raw.is_empty() { vec!["local".to_owned()] } else { raw.to_vec() };
    for (i, h) in hosts.iter().enumerate() {
        if !deploy::valid_host(h) {
            return Err(cx.err(
                format!("hosts[{i}]"),
                format!("{h:?}"),
                "must be 1 to 32 lowercase letters, digits or '_', starting with a letter",
            ));
        }
        if hosts[..i].contains(h) {
            return Err(cx.err(format!("hosts[{i}]"), format!("{h:?}"), "named twice"));
        }
    }
    Ok(hosts)
}

/// The router's endpoint: TLS exactly when the file has `security:`, and an address other
/// hosts can reach when there are several.
fn router(cx: &Cx<'_>, router: &str, secure: bool, across_hosts: bool) -> Result<(), LaunchError> {
    let bad = |why: &str| Err(cx.err("router", format!("{router:?}"), why));
    match (router.split_once('/').map(|(p, _)| p), secure) {
        (Some("tcp"), false) | (Some("tls"), true) => {}
        (Some("tcp"), true) => return bad("with `security:` the router must be a tls/ endpoint"),
        (Some("tls"), false) => return bad("a tls/ router needs a `security:` section with the certificates"),
        _ => return bad("must be a Zenoh endpoint such as tcp/127.0.0.1:7447 or tls/10.0.0.1:7447"),
    }
    let (addr, port) = router
        .split_once('/')
        .and_then(|(_, rest)| rest.rsplit_once(':'))
        .map(|(a, p)| (a.trim_start_matches('[').trim_end_matches(']'), p.split('#').next().unwrap_or(p)))
        .unwrap_or(("", ""));
    if addr.is_empty() || port.parse::<u16>().is_err() {
        return bad("must be <protocol>/<address>:<port>");
    }
    let ip = addr.parse::<std::net::IpAddr>().ok();
    if across_hosts && (addr == "localhost" || ip.is_some_and(|ip| ip.is_loopback() || ip.is_unspecified())) {
        return bad("other hosts connect here: it must be the first host's address on their network");
    }
    Ok(())
}

fn frames(cx: &Cx<'_>, f: &RawFrames) -> Result<FramePlan, LaunchError> {
    let mut kinds = Vec::new();
    for (i, k) in f.kinds.iter().enumerate() {
        kinds.push(match k.as_str() {
            "screen" => FrameKind::Screen,
            "minimap" => FrameKind::Minimap,
            "vlm" => FrameKind::Vlm,
            other => return Err(cx.err(format!("frames.kinds[{i}]"), format!("{other:?}"), "must be screen, minimap or vlm")),
        });
    }
    for (name, [w, h]) in [("screen", f.screen), ("minimap", f.minimap), ("vlm", f.vlm)] {
        if !(1..=4096).contains(&w) || !(1..=4096).contains(&h) {
            return Err(cx.err(format!("frames.{name}"), format!("[{w}, {h}]"), "width and height must be 1 to 4096"));
        }
    }
    if f.every == 0 {
        return Err(cx.err("frames.every", 0, "must be at least 1"));
    }
    let p = |s: [u32; 2]| (s[0], s[1]);
    Ok(FramePlan { kinds, screen: p(f.screen), minimap: p(f.minimap), vlm: p(f.vlm), every: f.every, for_agents: false })
}

/// The frames the simulator publishes: the file's, or, when agent nodes read frames (an
/// image-mode network), their sizes at every step, delivered reliably. The file's must
/// then draw the screen and minimap at those sizes every step; all such agents read one size.
fn agent_frames(cx: &Cx<'_>, file: Option<FramePlan>, needs: &[(String, String, FrameNeed)]) -> Result<Option<FramePlan>, LaunchError> {
    let Some((field, policy, need)) = needs.first() else { return Ok(file) };
    let size = |(w, h): (u32, u32)| format!("[{w}, {h}]");
    if let Some((f2, p2, n2)) = needs.iter().find(|(_, _, n)| n != need) {
        return Err(cx.err(
            f2,
            p2,
            format!(
                "reads {} screens and {} minimaps, but {field} ({policy}) reads {} and {}: the simulator draws one size",
                size(n2.screen),
                size(n2.minimap),
                size(need.screen),
                size(need.minimap)
            ),
        ));
    }
    let why = |what: &str| format!("{field} ({policy}) reads {what}");
    let Some(mut f) = file else {
        return Ok(Some(FramePlan {
            kinds: vec![FrameKind::Screen, FrameKind::Minimap],
            screen: need.screen,
            minimap: need.minimap,
            vlm: {
                let [w, h] = crate::plan::vlm_size();
                (w, h)
            },
            every: 1,
            for_agents: true,
        }));
    };
    for (kind, name, got, want) in
        [(FrameKind::Screen, "screen", f.screen, need.screen), (FrameKind::Minimap, "minimap", f.minimap, need.minimap)]
    {
        if !f.kinds.contains(&kind) {
            return Err(cx.err(
                "frames.kinds",
                format!("{:?}", f.kinds.iter().map(|k| k.name()).collect::<Vec<_>>()),
                why(&format!("{name} frames")),
            ));
        }
        if got != want {
            return Err(cx.err(format!("frames.{name}"), size(got), why(&format!("{name} frames of {}", size(want)))));
        }
    }
    if f.every != 1 {
        return Err(cx.err("frames.every", f.every, why("frames at every step")));
    }
    f.for_agents = true;
    Ok(Some(f))
}

/// The agent nodes and commanders of the entries checked so far, and who owns each unit.
struct Nodes<'a> {
    cx: &'a Cx<'a>,
    scenario: &'a Arc<Scenario>,
    /// A fresh episode, for the scenario's units and which teams agents drive.
    env: Env,
    how: Resolve<'a>,
    hosts: &'a [String],
    agents: Vec<AgentPlan>,
    /// Each agent node's entry (`agents[i]`), for the commanders' checks.
    fields: Vec<String>,
    commanders: Vec<CommanderPlan>,
    owner: BTreeMap<u32, String>,
    /// Entries whose network reads frames: (field, policy, sizes).
    needs: Vec<(String, String, FrameNeed)>,
}

impl<'a> Nodes<'a> {
    fn new(cx: &'a Cx<'a>, scenario: &'a Arc<Scenario>, how: Resolve<'a>, hosts: &'a [String]) -> Self {
        let env = Env::new(Arc::clone(scenario), EnvConfig::default(), 0);
        Nodes {
            cx,
            scenario,
            env,
            how,
            hosts,
            agents: Vec::new(),
            fields: Vec::new(),
            commanders: Vec::new(),
            owner: BTreeMap::new(),
            needs: Vec::new(),
        }
    }

    /// Entry `i`: a commander, one node per unit of a team, or one node for the units it names.
    fn entry(&mut self, i: usize, a: &RawAgent, file_ava: Option<&avacraft_ava::AvaSpec>) -> Result<(), LaunchError> {
        let cx = self.cx;
        let f = |name: &str| format!("agents[{i}].{name}");
        // The entry's AVA settings, else the file's for `policy: ava`; a refusal names the
        // block its settings came from.
        let ava = a.ava.clone().or_else(|| if a.policy == AVA_POLICY { file_ava.cloned() } else { None });
        let refused = |e: PolicyError| {
            let field = match e {
                PolicyError::Ava(_) | PolicyError::SpecWithoutAva { .. } if a.ava.is_none() => "ava".to_owned(),
                PolicyError::Ava(_) | PolicyError::SpecWithoutAva { .. } => f("ava"),
                _ => f("policy"),
            };
            cx.policy_err(field, &a.policy, e)
        };
        let host = a.host.clone().unwrap_or_else(|| self.hosts[0].clone());
        if !self.hosts.contains(&host) {
            return Err(cx.err(f("host"), format!("{host:?}"), format!("not one of the hosts {:?}", self.hosts)));
        }
        if a.commander {
            let policy = CommanderPolicy::resolve(&a.policy, ava, self.how).map_err(refused)?;
            return self.commander(i, a, policy, host);
        }
        // A shipped baseline becomes this scenario's checkpoint here, so every node is handed
        // the checkpoint itself (read once for all the entry's nodes).
        let policy = PolicySpec::resolve(&a.policy, ava, self.how).and_then(|p| p.on(self.scenario)).map_err(refused)?;
        let role = a.role.as_deref().map(|r| command::role(cx, f("role"), r)).transpose()?;
        if role.is_some() && a.per_unit {
            return Err(cx.err(
                f("role"),
                a.role.as_deref().unwrap_or_default(),
                "a role group names its `id` and `units`, not `per_unit`",
            ));
        }
        let first_new = self.agents.len();
        if a.per_unit {
            if a.id.is_some() || !a.units.is_empty() {
                return Err(cx.err(f("per_unit"), "true", "takes a `team`, not an `id` or `units`"));
            }
            let team = team(cx, i, a.team)?;
            let tags: Vec<u32> = self.env.agents(team).iter().map(|id| id.tag()).collect();
            for tag in tags {
                self.add(i, format!("unit_{tag}"), &[tag], f("team"), &policy, &host)?;
            }
        } else {
            let Some(id) = a.id.clone() else { return Err(cx.err(f("id"), "none", "an agent node needs an `id` (or `per_unit: true`)")) };
            if let Some(t) = a.team {
                return Err(cx.err(f("team"), t, "a role group names its `units`; `team` goes with `per_unit: true`"));
            }
            if a.units.is_empty() {
                return Err(cx.err(f("units"), "[]", "an agent node needs at least one unit"));
            }
            self.add(i, id, &a.units, f("id"), &policy, &host)?;
        }
        // An image-mode network reads its team's frames, which the simulator then draws at its
        // sizes (read from the checkpoint's settings even where its weights stay unread).
        let need = policy.frames_need(self.scenario).map_err(|e| cx.policy_err(f("policy"), &a.policy, e))?;
        if let Some(need) = need {
            if role.is_some() {
                return Err(cx.err(
                    f("role"),
                    a.role.as_deref().unwrap_or_default(),
                    "a role group's policy reads no frames; this checkpoint does",
                ));
            }
            self.needs.push((f("policy"), a.policy.clone(), need));
        }
        for ag in &mut self.agents[first_new..] {
            // A process that does not act reads no weights, so it cannot check them either:
            // the agent node checks its own when it starts.
            if self.how.weights == Weights::Load {
                policy.check_seeing(self.scenario, ag.team.team()).map_err(|e| cx.policy_err(f("policy"), &a.policy, e))?;
            }
            ag.role = role;
            self.fields.push(format!("agents[{i}]"));
        }
        Ok(())
    }

    fn commander(&mut self, i: usize, a: &RawAgent, policy: CommanderPolicy, host: String) -> Result<(), LaunchError> {
        let cx = self.cx;
        let f = |name: &str| format!("agents[{i}].{name}");
        if a.per_unit || !a.units.is_empty() || a.role.is_some() {
            return Err(cx.err(f("commander"), "true", "a commander takes an `id` and a `team`, not `units`, `per_unit` or `role`"));
        }
        let Some(id) = a.id.clone() else { return Err(cx.err(f("id"), "none", "a commander needs an `id`")) };
        let id = AgentId::parse(&id).map_err(|e| cx.err(f("id"), format!("{id:?}"), e.to_string()))?;
        let team = team(cx, i, a.team)?;
        if !self.env.is_agent_team(team) {
            return Err(cx.err(f("team"), team.player(), "the opponent policy drives this team"));
        }
        let team = TeamNo::from(team);
        if self.commanders.iter().any(|c| c.team == team) {
            return Err(cx.err(f("team"), team.get(), "the team has a commander already"));
        }
        if self.commanders.iter().any(|c| c.id == id) || self.agents.iter().any(|x| x.id == id) {
            return Err(cx.err(f("id"), &id, "two agent nodes share this id"));
        }
        self.commanders.push(CommanderPlan { id, team, policy, host, groups: Vec::new() });
        Ok(())
    }

    /// One agent node `id` of entry `i`, owning the units `tags` (all of one agent team,
    /// owned by no other node).
    fn add(&mut self, i: usize, id: String, tags: &[u32], field: String, policy: &PolicySpec, host: &str) -> Result<(), LaunchError> {
        let cx = self.cx;
        let units_field = format!("agents[{i}].units");
        let agent = AgentId::parse(&id).map_err(|e| cx.err(field.clone(), format!("{id:?}"), e.to_string()))?;
        let mut units = Vec::new();
        let mut team: Option<Team> = None;
        for &t in tags {
            let Some(u) = UnitId::try_from(t).ok().and_then(|uid| self.env.world().unit(uid)) else {
                return Err(cx.err(
                    &units_field,
                    t,
                    format!("no unit has this tag ({} has tags 1 to {})", self.scenario.name, self.scenario.units.len()),
                ));
            };
            if !self.env.is_agent_team(u.team) {
                return Err(cx.err(&units_field, t, format!("{} belongs to {}, which the opponent policy drives", u.name(), u.team)));
            }
            if team.is_some_and(|x| x != u.team) {
                return Err(cx.err(&units_field, t, format!("{} belongs to {}; one agent node plays for one team", u.name(), u.team)));
            }
            team = Some(u.team);
            if let Some(prev) = self.owner.insert(t, id.clone()) {
                return Err(cx.err(&units_field, t, format!("already owned by agent node `{prev}`")));
            }
            units.push(UnitTag::from(u.id));
        }
        if self.agents.iter().any(|x| x.id == agent) || self.commanders.iter().any(|c| c.id == agent) {
            return Err(cx.err(field, format!("{id:?}"), "two agent nodes share this id"));
        }
        let team = team.map(TeamNo::from).ok_or_else(|| cx.err(&units_field, "[]", "an agent node needs at least one unit"))?;
        self.agents.push(AgentPlan { id: agent, team, units, policy: policy.clone(), host: host.to_owned(), role: None, encoded: false });
        Ok(())
    }
}

/// One encoder node per team, image network and host with two or more agent nodes of that
/// network (their encoder would run that many times a step); those nodes are `encoded`.
fn encoders(agents: &mut [AgentPlan], commanders: &[CommanderPlan], scenario: &Scenario) -> Vec<EncoderPlan> {
    let mut groups: BTreeMap<(TeamNo, String, String), Vec<usize>> = BTreeMap::new();
    for (i, a) in agents.iter().enumerate() {
        if a.role.is_none() && !a.is_dds() && a.policy.frames_need(scenario).ok().flatten().is_some() {
            groups.entry((a.team, a.policy.to_string(), a.host.clone())).or_default().push(i);
        }
    }
    let ids: Vec<AgentId> = agents.iter().map(|a| a.id.clone()).chain(commanders.iter().map(|c| c.id.clone())).collect();
    let taken = |id: &AgentId, made: &[EncoderPlan]| ids.contains(id) || made.iter().any(|e| e.id == *id);
    let mut out: Vec<EncoderPlan> = Vec::new();
    for ((team, _, host), members) in groups.into_iter().filter(|(_, m)| m.len() >= 2) {
        let Some(id) = (0..)
            .map(|k| if k == 0 { format!("encoder_{}", team.get()) } else { format!("encoder_{}_{k}", team.get()) })
            .filter_map(|s| AgentId::parse(&s).ok())
            .find(|id| !taken(id, &out))
        else {
            continue;
        };
        for &i in &members {
            agents[i].encoded = true;
        }
        out.push(EncoderPlan { id, team, policy: agents[members[0]].policy.clone(), host });
    }
    out
}

/// An entry's `team`: 1 or 2.
fn team(cx: &Cx<'_>, i: usize, team: Option<u8>) -> Result<Team, LaunchError> {
    match team {
        Some(1) => Ok(Team::One),
        Some(2) => Ok(Team::Two),
        other => Err(cx.err(format!("agents[{i}].team"), format!("{other:?}"), "must be 1 or 2")),
    }
}
