//! The contract itself: what every agent kind implements and is given. The runners, the
//! scripted agents and `Env` (whose opponent is a [`ForkAgent`]) all build on it, so it
//! depends on none of them, only on the observation types (`crate::obs`).

use super::role::Briefing;
use crate::action::Action;
use crate::ids::{Team, UnitId};
use crate::obs::{GroupObs, Reads};
use crate::scenario::Scenario;
use std::sync::Arc;

/// What an agent knows when an episode starts: the map (a player knows it), its side, the
/// units it controls, and a seed for its own random choices.
#[derive(Clone, Debug)]
pub struct AgentCtx {
    pub scenario: Arc<Scenario>,
    pub team: Team,
    /// The units it controls.
    pub units: Vec<UnitId>,
    pub seed: u64,
}

pub trait Agent: Send {
    fn name(&self) -> &str;
    /// Called at the start of every episode.
    fn reset(&mut self, ctx: &AgentCtx);
    /// Actions for the group's units this step; units without one keep their orders.
    fn act(&mut self, obs: &GroupObs) -> Vec<Action>;
    /// What the agent reads of its observation besides the units and effects. In-process
    /// runs build only that; a deployment's messages carry what any node of the team reads
    /// (everything when a node's policy cannot be asked before it runs: networks, AVA, DDS).
    fn reads(&self) -> Reads {
        Reads::ALL
    }
    /// A commander's briefing for this step (a role group under dynamic roles gets one before
    /// each `act`); agents that take no orders ignore it.
    fn brief(&mut self, _briefing: &Briefing) {}
    /// The rendered frames it reads besides its observation (an image-mode network), if any.
    /// The engine draws nothing: whoever runs the agent renders them (in-process through a
    /// [`FrameSource`], a deployment from the simulator's frame topics) and hands them to
    /// [`Agent::see`] before each `act`.
    fn frames(&self) -> Option<FrameNeed> {
        None
    }
    /// This step's frames, before `act`, for an agent whose [`Agent::frames`] asks for some.
    fn see(&mut self, _frames: &TeamFrames) {}
    /// The name of the team-level encoding of its frames this agent can act on instead of the
    /// frames (an image network's encoder: the same for every unit of the team, so a
    /// deployment computes it once per step, in the team's encoder node, and hands it to the
    /// team's agent nodes of the same network). `None`: the agent reads frames only.
    fn encoder(&self) -> Option<String> {
        None
    }
    /// The team-level encoding of `frames` ([`Agent::encoder`]); what [`Agent::see`] followed
    /// by `act` would compute itself.
    fn encode(&self, _frames: &TeamFrames) -> Option<Vec<f32>> {
        None
    }
    /// This step's encoding, before `act`, instead of [`Agent::see`]: `act` then plays as it
    /// would have on the frames.
    fn see_encoded(&mut self, _features: &[f32]) {}
}

/// The frames an agent reads: its team's screen and minimap at these (width, height).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FrameNeed {
    pub screen: (u32, u32),
    pub minimap: (u32, u32),
}

/// One step's frames of a team, RGB8 rows as the renderer draws them, at a [`FrameNeed`]'s
/// sizes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TeamFrames {
    pub screen: Vec<u8>,
    pub minimap: Vec<u8>,
}

impl TeamFrames {
    /// Whether the pixel counts fit `need` (3 bytes a pixel).
    pub fn fits(&self, need: FrameNeed) -> bool {
        let len = |(w, h): (u32, u32)| w as usize * h as usize * 3;
        self.screen.len() == len(need.screen) && self.minimap.len() == len(need.minimap)
    }
}

/// What draws a team's frames from the world for in-process agents that read them (the
/// renderer implements it; the engine has none).
pub trait FrameSource: Send {
    fn draw(&mut self, world: &crate::World, team: Team, need: FrameNeed) -> TeamFrames;
}

/// An agent whose whole state can be copied mid-episode: what an environment needs of its
/// built-in opponent to fork (look-ahead search, evaluations branching from one state). Every
/// `Clone` agent is one.
pub trait ForkAgent: Agent {
    fn fork(&self) -> Box<dyn ForkAgent>;
}

impl<T: Agent + Clone + 'static> ForkAgent for T {
    fn fork(&self) -> Box<dyn ForkAgent> {
        Box::new(self.clone())
    }
}

/// What a group sends for a step: its policy's actions for the units it controls (others
/// dropped), then a no-op for each of its living units the policy left alone. A deployed
/// node must answer for every unit it owns (the simulator waits for each), and an in-process
/// run submits the same, so both leave the same last actions in the state.
pub fn complete(actions: Vec<Action>, g: &GroupObs) -> Vec<Action> {
    let mut out: Vec<Action> = actions.into_iter().filter(|a| g.controlled.iter().any(|c| c.unit == a.unit)).collect();
    for c in g.controlled.iter().filter(|c| c.alive) {
        if !out.iter().any(|a| a.unit == c.unit) {
            out.push(Action::new(c.unit, crate::action::Command::NoOp));
        }
    }
    out
}

/// The seed of one agent's random choices in an episode: a function of the episode's seed,
/// the side and the group's first unit only, so an agent node and an in-process run of the
/// same grouping draw the same numbers.
pub fn agent_seed(episode_seed: u64, team: Team, first_unit: u32) -> u64 {
    // SplitMix64 over the three, so nearby seeds give unrelated streams.
    let mut z = episode_seed ^ ((team.player() as u64) << 56) ^ ((first_unit as u64) << 24) ^ 0x9e37_79b9_7f4a_7c15;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
