//! Every topic name in the deployment comes from here: a validated ROS 2 name type and one
//! builder per topic, so no raw topic string exists anywhere else.

use avacraft_engine::{Team, UnitId};
use std::fmt;

/// Why a name was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    #[error("topic `{0}`: must start with '/' and have segments of letters, digits and '_' that do not start with a digit")]
    Topic(String),
    #[error("agent id `{0}`: must be 1 to 64 lowercase letters, digits or '_', starting with a letter")]
    Agent(String),
    #[error("unit tag {0}: tags run from 1 to 65536")]
    Unit(u32),
    #[error("team {0}: must be 1 or 2")]
    Team(u8),
}

/// A fully qualified ROS 2 topic name (`/avacraft/unit_3/obs`).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Topic(String);

impl Topic {
    pub fn parse(name: &str) -> Result<Topic, NameError> {
        let ok = name.starts_with('/')
            && name.len() > 1
            && name[1..].split('/').all(|seg| {
                !seg.is_empty()
                    && seg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                    && !seg.starts_with(|c: char| c.is_ascii_digit())
            });
        if ok { Ok(Topic(name.to_owned())) } else { Err(NameError::Topic(name.to_owned())) }
    }
    pub fn as_str(&self) -> &str {
        &self.0
    }
    /// The ROS namespace and base name (`/avacraft/team_1`, `obs`), as DDS APIs take them.
    pub fn namespace_and_base(&self) -> (&str, &str) {
        match self.0.rsplit_once('/') {
            Some(("", base)) => ("/", base),
            Some((ns, base)) => (ns, base),
            None => ("/", &self.0),
        }
    }
}

impl fmt::Display for Topic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// An agent node's id, as launch files name it (`marine_1`, `ranged`).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct AgentId(String);

impl AgentId {
    pub fn parse(s: &str) -> Result<AgentId, NameError> {
        let ok = (1..=64).contains(&s.len())
            && s.starts_with(|c: char| c.is_ascii_lowercase())
            && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
        if ok { Ok(AgentId(s.to_owned())) } else { Err(NameError::Agent(s.to_owned())) }
    }
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for AgentId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// A unit's tag on the wire (1-based, the engine's `UnitId::tag`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct UnitTag(u32);

impl UnitTag {
    /// A tag read from outside: refused unless it names a unit id ([`UnitId`]'s rule).
    pub fn new(tag: u32) -> Result<UnitTag, NameError> {
        UnitId::try_from(tag).map(UnitTag::from).map_err(|_| NameError::Unit(tag))
    }
    pub fn get(self) -> u32 {
        self.0
    }
}

/// Every unit id has a tag.
impl From<UnitId> for UnitTag {
    fn from(id: UnitId) -> UnitTag {
        UnitTag(id.tag())
    }
}

/// Every tag names a unit id ([`UnitTag::new`] checked it).
impl From<UnitTag> for UnitId {
    fn from(tag: UnitTag) -> UnitId {
        UnitId::new((tag.0 - 1) as u16)
    }
}

/// Every side has a number.
impl From<Team> for TeamNo {
    fn from(team: Team) -> TeamNo {
        TeamNo(team.player())
    }
}

impl From<TeamNo> for Team {
    fn from(no: TeamNo) -> Team {
        no.team()
    }
}

/// A team number on the wire (1 or 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TeamNo(u8);

impl TeamNo {
    pub fn new(n: u8) -> Result<TeamNo, NameError> {
        if n == 1 || n == 2 { Ok(TeamNo(n)) } else { Err(NameError::Team(n)) }
    }
    pub fn get(self) -> u8 {
        self.0
    }
    /// The engine's side of this number.
    pub fn team(self) -> Team {
        if self.0 == 1 { Team::One } else { Team::Two }
    }
}

/// Image streams of a team.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameKind {
    Screen,
    Minimap,
    Vlm,
}

impl FrameKind {
    pub const ALL: [FrameKind; 3] = [FrameKind::Screen, FrameKind::Minimap, FrameKind::Vlm];
    pub fn name(self) -> &'static str {
        match self {
            FrameKind::Screen => "screen",
            FrameKind::Minimap => "minimap",
            FrameKind::Vlm => "vlm",
        }
    }
}

/// A node's ROS 2 name: what `ros2 node list` shows, what the simulator waits for and what
/// access control grants. Built here only, so the launcher, the simulator and the ACL agree.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeName(String);

impl NodeName {
    pub fn sim() -> NodeName {
        NodeName("sim".into())
    }
    pub fn recorder() -> NodeName {
        NodeName("recorder".into())
    }
    pub fn bridge() -> NodeName {
        NodeName("bridge".into())
    }
    /// The launcher's own node (it hosts the router).
    pub fn launch() -> NodeName {
        NodeName("launch".into())
    }
    /// The launcher of one host of a deployment across hosts.
    pub fn launch_on(host: &str) -> NodeName {
        NodeName(format!("launch_{host}"))
    }
    /// An agent node or commander.
    pub fn agent(id: &AgentId) -> NodeName {
        NodeName(format!("agent_{id}"))
    }
    /// A probe, named after its mark.
    pub fn probe(mark: &AgentId) -> NodeName {
        NodeName(format!("probe_{mark}"))
    }
    /// A tool's node (benchmarks): a name in the agent id alphabet.
    pub fn tool(name: &str) -> Result<NodeName, NameError> {
        AgentId::parse(name).map(|a| NodeName(a.0))
    }
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for NodeName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The deployment's topic names under one namespace (default `/avacraft`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topics {
    ns: String,
}

/// The namespace every topic is under unless a deployment names another.
pub const DEFAULT_NAMESPACE: &str = "/avacraft";

impl Default for Topics {
    fn default() -> Self {
        Self { ns: DEFAULT_NAMESPACE.to_owned() }
    }
}

impl Topics {
    /// Topics under `namespace` (a valid topic name itself, e.g. `/match_3`).
    pub fn new(namespace: &str) -> Result<Topics, NameError> {
        Topic::parse(namespace).map(|t| Topics { ns: t.0 })
    }
    pub fn namespace(&self) -> &str {
        &self.ns
    }
    fn make(&self, rest: &str) -> Topic {
        // The namespace and every segment built here are valid names by construction.
        Topic(format!("{}/{rest}", self.ns))
    }
    /// One unit's observation (`UnitObservation`), for the agent node that owns it. Under
    /// its team's prefix, so access control can grant a team exactly its own observations.
    pub fn unit_obs(&self, team: TeamNo, unit: UnitTag) -> Topic {
        self.make(&format!("team_{}/unit_{}/obs", team.0, unit.0))
    }
    /// Everything published for one team (its units' and team observations, its frames).
    pub fn team_prefix(&self, team: TeamNo) -> Topic {
        self.make(&format!("team_{}", team.0))
    }
    /// A team's whole view (`TeamObservation`): text and unit list.
    pub fn team_obs(&self, team: TeamNo) -> Topic {
        self.make(&format!("team_{}/obs", team.0))
    }
    /// A team's rendered frames (`sensor_msgs/Image`).
    pub fn frames(&self, team: TeamNo, kind: FrameKind) -> Topic {
        self.make(&format!("team_{}/{}", team.0, kind.name()))
    }
    /// Actions of one agent node (`ActionBatch`): the sender is the topic, so ownership can
    /// be checked against the launch file.
    pub fn actions(&self, agent: &AgentId) -> Topic {
        self.make(&format!("agents/{}/actions", agent.0))
    }
    /// The model calls of an AVA agent node (`ModelCall`), for the session's recording.
    pub fn model_calls(&self, agent: &AgentId) -> Topic {
        self.make(&format!("agents/{}/model_calls", agent.0))
    }
    /// Every topic of the namespace (a pattern): what a recorder takes.
    pub fn all(&self) -> TopicPattern {
        TopicPattern(self.ns.clone())
    }
    /// Every agent node's action topic (a pattern: `*` is one segment).
    pub fn any_actions(&self) -> TopicPattern {
        TopicPattern(format!("{}/agents/*/actions", self.ns))
    }
    /// Every AVA agent node's model calls (a pattern), for the live view's log.
    pub fn any_model_calls(&self) -> TopicPattern {
        TopicPattern(format!("{}/agents/*/model_calls", self.ns))
    }
    /// Episode status (`EpisodeStatus`).
    pub fn status(&self) -> Topic {
        self.make("status")
    }
    /// The actions the simulator applied each step, in order (`ActionBatch`, agent `sim`):
    /// with the seed in the status, enough to re-simulate a recorded episode exactly.
    pub fn applied(&self) -> Topic {
        self.make("applied")
    }
    /// Role assignment (`RoleAssignment`).
    pub fn roles(&self) -> Topic {
        self.make("roles")
    }
    /// A team's effective role groups under its commander, with the commander's briefing
    /// (`RoleAssignment`, every step): what its role-group nodes act on. Under the team's
    /// prefix, since the plan is the team's secret.
    pub fn team_roles(&self, team: TeamNo) -> Topic {
        self.make(&format!("team_{}/roles", team.0))
    }
    /// An image network's encoding of the team's frames (`TeamFeatures`, every step), from the
    /// team's encoder node for its per-unit agent nodes.
    pub fn features(&self, team: TeamNo) -> Topic {
        self.make(&format!("team_{}/features", team.0))
    }
    /// A team commander's orders (`RoleAssignment` for the next step), which the simulator
    /// checks before ownership follows them.
    pub fn orders(&self, team: TeamNo) -> Topic {
        self.make(&format!("team_{}/orders", team.0))
    }
    /// What the session runs (`SessionInfo`: scenario text, environment configuration,
    /// seeds), published at start and at each episode's start, so recordings replay alone.
    pub fn session(&self) -> Topic {
        self.make("session")
    }
    /// A live-view channel (Foxglove's messages), recorded beside the ROS 2 topics.
    pub fn live(&self, channel: LiveTopic) -> Topic {
        self.make(&format!("live/{}", channel.name()))
    }
    /// The iceoryx2 service a frame topic's images also go through (same path, no leading
    /// '/': iceoryx2 names are not ROS names).
    pub fn frame_service(&self, team: TeamNo, kind: FrameKind) -> String {
        self.frames(team, kind).as_str().trim_start_matches('/').to_owned()
    }
    /// A topic of any deployment, with the namespace it is under (the shortest that makes it
    /// one of a deployment's topics), for readers of recordings that do not know it.
    pub fn find(topic: &Topic) -> Option<(Topics, TopicKind)> {
        let name = topic.as_str();
        name.match_indices('/').skip(1).find_map(|(i, _)| {
            let topics = Topics::new(&name[..i]).ok()?;
            let kind = topics.classify(topic)?;
            Some((topics, kind))
        })
    }
    /// What a topic under this namespace is, or `None` for a topic that is not one of the
    /// deployment's (another namespace, a misspelt name). The inverse of the builders above.
    pub fn classify(&self, topic: &Topic) -> Option<TopicKind> {
        let rest = topic.as_str().strip_prefix(&self.ns)?.strip_prefix('/')?;
        let segs: Vec<&str> = rest.split('/').collect();
        let team = |s: &str| s.strip_prefix("team_").and_then(|n| n.parse::<u8>().ok()).and_then(|n| TeamNo::new(n).ok());
        Some(match segs.as_slice() {
            ["status"] => TopicKind::Status,
            ["applied"] => TopicKind::Applied,
            ["roles"] => TopicKind::Roles,
            ["session"] => TopicKind::Session,
            ["live", name] => TopicKind::Live(LiveTopic::ALL.into_iter().find(|c| c.name() == *name)?),
            ["agents", agent, "actions"] => TopicKind::Actions(AgentId::parse(agent).ok()?),
            ["agents", agent, "model_calls"] => TopicKind::ModelCalls(AgentId::parse(agent).ok()?),
            [t, "obs"] => TopicKind::TeamObs(team(t)?),
            [t, "roles"] => TopicKind::TeamRoles(team(t)?),
            [t, "orders"] => TopicKind::Orders(team(t)?),
            [t, "features"] => TopicKind::Features(team(t)?),
            [t, u, "obs"] => {
                let unit = u.strip_prefix("unit_").and_then(|n| n.parse::<u32>().ok()).and_then(|n| UnitTag::new(n).ok())?;
                TopicKind::UnitObs(team(t)?, unit)
            }
            [t, f] => TopicKind::Frames(team(t)?, FrameKind::ALL.into_iter().find(|k| k.name() == *f)?),
            _ => return None,
        })
    }
}

/// A topic of the deployment, parsed ([`Topics::classify`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TopicKind {
    UnitObs(TeamNo, UnitTag),
    TeamObs(TeamNo),
    Frames(TeamNo, FrameKind),
    Actions(AgentId),
    ModelCalls(AgentId),
    Status,
    Applied,
    Roles,
    TeamRoles(TeamNo),
    Orders(TeamNo),
    Features(TeamNo),
    Session,
    Live(LiveTopic),
}

/// The live view's channels. Their last parts differ from every ROS 2 topic's, so no reader of
/// recordings takes one for the other.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LiveTopic {
    ScreenImage,
    MinimapImage,
    SceneUpdate,
    ScreenAnnotations,
    LogLines,
    EpisodeStatus,
}

impl LiveTopic {
    pub const ALL: [LiveTopic; 6] = [
        LiveTopic::ScreenImage,
        LiveTopic::MinimapImage,
        LiveTopic::SceneUpdate,
        LiveTopic::ScreenAnnotations,
        LiveTopic::LogLines,
        LiveTopic::EpisodeStatus,
    ];

    /// The topic's last part.
    pub fn name(self) -> &'static str {
        match self {
            LiveTopic::ScreenImage => "screen_image",
            LiveTopic::MinimapImage => "minimap_image",
            LiveTopic::SceneUpdate => "scene_update",
            LiveTopic::ScreenAnnotations => "screen_annotations",
            LiveTopic::LogLines => "log_lines",
            LiveTopic::EpisodeStatus => "episode_status",
        }
    }
}

/// A subscription pattern: a topic name in which a `*` segment stands for any one segment.
/// Only [`Topics`] makes them, so every pattern matches topics the builders make.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicPattern(String);

impl TopicPattern {
    pub fn as_str(&self) -> &str {
        &self.0
    }
    /// The pattern as a valid ROS name (each `*` shown as `any`), for liveliness tokens.
    pub fn shown(&self) -> Topic {
        Topic(self.0.replace('*', "any"))
    }
}

impl From<&Topic> for TopicPattern {
    fn from(t: &Topic) -> Self {
        TopicPattern(t.0.clone())
    }
}

impl fmt::Display for TopicPattern {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_validated_and_built_in_one_place() {
        assert!(Topic::parse("/avacraft/unit_3/obs").is_ok());
        for bad in ["", "/", "avacraft", "/a//b", "/a/3b", "/a b", "/a/"] {
            assert!(Topic::parse(bad).is_err(), "{bad:?}");
        }
        assert!(AgentId::parse("marine_1").is_ok());
        for bad in ["", "Marine", "1m", "a-b", &"a".repeat(65)] {
            assert!(AgentId::parse(bad).is_err(), "{bad:?}");
        }
        assert!(UnitTag::new(0).is_err() && TeamNo::new(3).is_err());
        let t = Topics::default();
        let u = UnitTag::new(3).expect("tag");
        let one = TeamNo::new(1).expect("team");
        assert_eq!(t.unit_obs(one, u).as_str(), "/avacraft/team_1/unit_3/obs");
        assert!(t.unit_obs(one, u).as_str().starts_with(&format!("{}/", t.team_prefix(one))));
        let a = AgentId::parse("marine_1").expect("id");
        assert_eq!(t.actions(&a).as_str(), "/avacraft/agents/marine_1/actions");
        assert_eq!(t.frames(TeamNo::new(2).expect("team"), FrameKind::Minimap).as_str(), "/avacraft/team_2/minimap");
        assert_eq!(t.classify(&t.actions(&a)), Some(TopicKind::Actions(a.clone())));
        assert_eq!(t.any_actions().as_str(), "/avacraft/agents/*/actions");
        assert_eq!(t.any_model_calls().as_str(), "/avacraft/agents/*/model_calls");
        for c in LiveTopic::ALL {
            assert_eq!(t.classify(&t.live(c)), Some(TopicKind::Live(c)), "{c:?}");
        }
        assert_eq!(t.live(LiveTopic::ScreenImage).as_str(), "/avacraft/live/screen_image");
        let nested = Topics::new("/lab/match_3").expect("namespace");
        let found = Topics::find(&nested.model_calls(&a)).expect("a deployment's topic");
        assert_eq!((found.0.namespace(), found.1), ("/lab/match_3", TopicKind::ModelCalls(a.clone())));
        assert_eq!(Topics::find(&t.status()).map(|f| f.1), Some(TopicKind::Status));
        assert_eq!(Topics::find(&Topic::parse("/avacraft/elsewhere").expect("topic")), None);
        assert!(Topics::new("/match_3").is_ok() && Topics::new("match").is_err());
        // Every built topic passes the validator.
        for topic in [t.status(), t.roles(), t.team_obs(TeamNo::new(1).expect("team"))] {
            assert_eq!(Topic::parse(topic.as_str()).as_ref(), Ok(&topic));
        }
    }

    #[test]
    fn every_built_topic_classifies_back_and_others_do_not() {
        let t = Topics::new("/match_3").expect("ns");
        let (one, two) = (TeamNo::new(1).expect("team"), TeamNo::new(2).expect("team"));
        let u = UnitTag::new(12).expect("tag");
        let a = AgentId::parse("ranged").expect("id");
        let mut built = vec![
            (t.unit_obs(two, u), TopicKind::UnitObs(two, u)),
            (t.team_obs(one), TopicKind::TeamObs(one)),
            (t.actions(&a), TopicKind::Actions(a.clone())),
            (t.model_calls(&a), TopicKind::ModelCalls(a.clone())),
            (t.status(), TopicKind::Status),
            (t.applied(), TopicKind::Applied),
            (t.roles(), TopicKind::Roles),
            (t.team_roles(two), TopicKind::TeamRoles(two)),
            (t.orders(one), TopicKind::Orders(one)),
            (t.features(two), TopicKind::Features(two)),
            (t.session(), TopicKind::Session),
        ];
        built.extend(FrameKind::ALL.map(|k| (t.frames(one, k), TopicKind::Frames(one, k))));
        for (topic, kind) in built {
            assert_eq!(t.classify(&topic), Some(kind), "{topic}");
            assert_eq!(Topics::default().classify(&topic), None, "{topic} is not under /avacraft");
        }
        for bad in
            ["/match_3/team_3/obs", "/match_3/team_1/unit_0/obs", "/match_3/team_1/depth", "/match_3/agents/a/orders", "/match_3x/status"]
        {
            assert_eq!(t.classify(&Topic::parse(bad).expect("valid name")), None, "{bad}");
        }
        assert_eq!(t.frame_service(one, FrameKind::Screen), "match_3/team_1/screen");
        assert_eq!(t.team_obs(one).namespace_and_base(), ("/match_3/team_1", "obs"));
        assert_eq!(Topic::parse("/status").expect("valid").namespace_and_base(), ("/", "status"));
    }
}
