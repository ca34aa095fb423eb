//! The agents driving an environment's agent teams (team 1; team 2 too in PvP) as one
//! value, so every tool (episodes, rendering, tests) plays episodes the same way.

use super::{AgentTeam, CommandedTeam, Grouping};
use crate::env::Env;
use crate::ids::Team;
use crate::policy::{FrameNeed, FrameSource, TeamFrames, UnknownAgent, factory};
use crate::scenario::{Mode, Scenario};

pub struct Controllers {
    teams: Vec<AgentTeam>,
    /// Teams under a commander (dynamic role groups).
    commanded: Vec<CommandedTeam>,
    /// Episodes started so far, less one (the episode number the agents are told).
    episode: Option<u64>,
    /// What draws the frames of agents that read them (image-mode networks).
    frames: Option<Box<dyn FrameSource>>,
}

impl std::fmt::Debug for Controllers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.teams.iter().map(|t| (t.team(), t.name())))
            .entries(self.commanded.iter().map(|t| (t.team(), t.name())))
            .finish()
    }
}

impl Controllers {
    /// The given agent teams; one for team 2 is dropped in PvE, where the opponent plays it.
    pub fn new(scenario: &Scenario, teams: Vec<AgentTeam>) -> Self {
        let teams = teams.into_iter().filter(|t| t.team() == Team::One || scenario.mode == Mode::Pvp).collect();
        Self { teams, commanded: Vec::new(), episode: None, frames: None }
    }

    /// Adds teams under a commander (one dropped in PvE for team 2, as in [`Controllers::new`]).
    pub fn with_commanded(mut self, scenario: &Scenario, commanded: Vec<CommandedTeam>) -> Self {
        self.commanded.extend(commanded.into_iter().filter(|t| t.team() == Team::One || scenario.mode == Mode::Pvp));
        self
    }

    /// Draws frames with `source` for the agents that read them (see [`Agent::frames`]);
    /// without one they see none, and an image-mode network gives no orders.
    ///
    /// [`Agent::frames`]: super::Agent::frames
    pub fn with_frames(mut self, source: Box<dyn FrameSource>) -> Self {
        self.frames = Some(source);
        self
    }

    /// The commanded teams (their ownership and refused orders, for reports and tests).
    pub fn commanded(&self) -> &[CommandedTeam] {
        &self.commanded
    }

    /// Scripted policies by name, one agent per team: `second` drives team 2 in PvP
    /// scenarios and is ignored in PvE.
    pub fn named(scenario: &Scenario, first: &str, second: Option<&str>) -> Result<Self, UnknownAgent> {
        Self::grouped(scenario, first, second, Grouping::Team)
    }

    /// Like [`Controllers::named`], every team split among agents by `grouping`.
    pub fn grouped(scenario: &Scenario, first: &str, second: Option<&str>, grouping: Grouping) -> Result<Self, UnknownAgent> {
        let mut teams = vec![AgentTeam::new(Team::One, grouping.clone(), factory(first)?)];
        if let Some(second) = second {
            teams.push(AgentTeam::new(Team::Two, grouping, factory(second)?));
        }
        Ok(Self::new(scenario, teams))
    }

    /// Starts an episode (call it after [`Env::reset`]): fresh agents, seeded from the
    /// environment's seed.
    pub fn reset(&mut self, env: &Env) {
        self.episode = Some(self.episode.map_or(0, |e| e + 1));
        for t in &mut self.teams {
            t.reset(env);
        }
        for t in &mut self.commanded {
            t.reset(env);
        }
    }

    /// Every team's agents act on this step's observations, then all their actions are
    /// submitted: no side sees the other's orders of the same step.
    pub fn act(&mut self, env: &mut Env) {
        let episode = self.episode.unwrap_or(0);
        if let Some(source) = self.frames.as_deref_mut() {
            // Each team's frames of a size are drawn once, however many groups read them.
            let mut drawn: Vec<(Team, FrameNeed, TeamFrames)> = Vec::new();
            for t in &self.teams {
                for need in t.frame_needs() {
                    if !drawn.iter().any(|(team, n, _)| *team == t.team() && *n == need) {
                        drawn.push((t.team(), need, source.draw(env.world(), t.team(), need)));
                    }
                }
            }
            for t in &mut self.teams {
                t.show(&drawn);
            }
        }
        let mut actions: Vec<_> = self.teams.iter_mut().map(|t| (t.team(), t.act(env, episode))).collect();
        actions.extend(self.commanded.iter_mut().map(|t| (t.team(), t.act(env, episode))));
        for (team, a) in actions {
            env.submit(team, &a);
        }
    }

    /// Names of the policies, team 1 first.
    pub fn names(&self) -> Vec<String> {
        let mut names: Vec<(Team, String)> = self.teams.iter().map(|t| (t.team(), t.name())).collect();
        names.extend(self.commanded.iter().map(|t| (t.team(), t.name())));
        names.sort_by_key(|(t, _)| t.index());
        names.into_iter().map(|(_, n)| n).collect()
    }
}
