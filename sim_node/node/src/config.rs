//! What the simulator node is told to run, from a launch file or the command line. A leaf
//! of its own: the node loop, the commanders' side and the session description all read it.

use avacraft_engine::agent::{GroupRole, Reads};
use avacraft_engine::{EnvConfig, Scenario};
use avacraft_nodes::{AgentId, FrameKind, TeamNo, UnitTag};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

/// How the simulation advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    /// A step waits for every owned live unit's action, up to `deadline`.
    Lockstep { deadline: Duration },
    /// 22.4 game loops per second of wall time; actions apply when they arrive.
    RealTime,
}

/// Everything the simulator node needs (from a launch file or the command line).
#[derive(Clone, Debug)]
pub struct SimConfig {
    pub scenario: Arc<Scenario>,
    pub env: EnvConfig,
    pub clock: Clock,
    /// Seeds of the episodes, played back to back.
    pub seeds: Vec<u64>,
    /// Which agent node owns each unit (units of agent teams not listed stay idle).
    pub owners: BTreeMap<UnitTag, AgentId>,
    /// How long to wait at start for every agent node to appear.
    pub startup_timeout: Duration,
    /// Rendered frames to publish (`sensor_msgs/Image`), if any.
    pub frames: Option<FrameSpec>,
    /// Wait at start for the recorder's subscription too (so the recording starts at step 0).
    pub wait_for_recorder: bool,
    /// Agents driven from DDS: the bridge node publishes their actions (it announces each
    /// once the DDS agent is there), and subscribes to the observations for them.
    pub dds_agents: BTreeSet<AgentId>,
    /// The launch file it came from (carried in the session description, for people).
    pub launch_file: String,
    /// Teams under a commander: ownership of their units follows the commander's orders.
    pub commands: Vec<TeamCommand>,
    /// What each agent node's policy reads of its observations. A team's messages carry what
    /// any of its nodes reads (SMAC's features and masks, the text), as an in-process run
    /// builds for the same policies; a team with a node not listed here, or a commander,
    /// gets everything.
    pub reads: BTreeMap<AgentId, Reads>,
}

impl SimConfig {
    /// What the messages of `team`'s units carry: what any of its agent nodes reads.
    pub fn team_reads(&self, team: TeamNo) -> Reads {
        if self.commands.iter().any(|c| c.team == team) {
            return Reads::ALL;
        }
        let mut agents: BTreeSet<&AgentId> = self.owners.values().collect();
        agents.retain(|a| self.team_of(a) == Some(team));
        agents.into_iter().fold(Reads::UNITS, |acc, a| {
            let r = self.reads.get(a).copied().unwrap_or(Reads::ALL);
            Reads { smac: acc.smac || r.smac, text: acc.text || r.text }
        })
    }

    /// The team an agent node plays for (from the units it owns at the start), or a
    /// commander's team.
    pub fn team_of(&self, agent: &AgentId) -> Option<TeamNo> {
        let by_unit = self
            .owners
            .iter()
            .find(|(_, a)| *a == agent)
            .and_then(|(t, _)| self.scenario.units.get(t.get() as usize - 1))
            .map(|u| TeamNo::from(u.team));
        by_unit.or_else(|| self.commands.iter().find(|c| &c.commander == agent).map(|c| c.team))
    }
}

/// Which frames the simulator renders and publishes per agent team.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameSpec {
    pub kinds: Vec<FrameKind>,
    /// Sizes (width, height) of the screen, minimap and VLM screenshot.
    pub screen: (u32, u32),
    pub minimap: (u32, u32),
    pub vlm: (u32, u32),
    /// Publish every this many steps.
    pub every: u32,
    /// Agent nodes read them (an image-mode network): sent reliably, as the observations
    /// are, not best effort.
    pub for_agents: bool,
}

/// A team under a commander.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TeamCommand {
    pub team: TeamNo,
    /// The commander node's id (its node is `agent_<id>`).
    pub commander: AgentId,
    /// The role groups' agent nodes, in order, with their roles.
    pub groups: Vec<(AgentId, GroupRole)>,
}
