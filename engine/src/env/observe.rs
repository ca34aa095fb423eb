//! Observations built from an environment. Apart from their types (`crate::obs`): `Env` holds
//! its opponent as an agent and the agent contract names those types, so they cannot depend on
//! `Env`, while building them must.

use super::Env;
use super::text::describe;
use crate::ids::{Team, UnitId};
use crate::obs::{AgentObs, Controlled, EffectInfo, GroupObs, Reads, UnitInfo, unit_list};
use crate::time::LOOPS_PER_SECOND;
use std::sync::Arc;

/// Area effects `team` knows of now.
pub fn effects(env: &Env, team: Team) -> Vec<EffectInfo> {
    let w = env.world();
    let tick = w.tick();
    w.area_effects()
        .iter()
        .filter(|e| e.active(tick) && (e.team == team || w.team_sees_point(team, e.pos)))
        .map(|e| EffectInfo {
            kind: e.kind,
            team: e.team,
            x: e.pos.x,
            y: e.pos.y,
            radius: e.radius,
            remaining_s: e.until.saturating_sub(tick) as f32 / LOOPS_PER_SECOND,
        })
        .collect()
}

impl GroupObs {
    /// The whole of `team` as one group, straight from the world: what folding every agent's
    /// [`AgentObs`] gives, without building them (the engine's opponents act on this).
    /// `reads` says whether to fill the controlled units' masks and features, and the text.
    pub fn team(env: &Env, team: Team, episode: u64, reads: Reads) -> GroupObs {
        let l = env.smac_layout(team);
        let units = unit_list(env.world(), team);
        let controlled = env
            .agents(team)
            .iter()
            .enumerate()
            .map(|(agent, id)| {
                let (mut avail_actions, mut features) = (Vec::new(), Vec::new());
                if reads.smac {
                    avail_actions = vec![0u8; l.n_actions];
                    env.avail_agent(team, agent, &mut avail_actions);
                    features = vec![0f32; l.obs_size];
                    env.obs_agent(team, agent, &mut features);
                }
                Controlled { unit: *id, alive: units.iter().any(|u| u.tag == *id), agent, avail_actions, features }
            })
            .collect();
        GroupObs {
            episode,
            seed: env.seed(),
            step: env.steps(),
            game_loop: env.world().tick(),
            team,
            units,
            effects: effects(env, team),
            controlled,
            text: if reads.text { describe(env, team).into() } else { Arc::from("") },
        }
    }
}

impl Env {
    /// Every agent's observation of `team` this step, in agent order (the text is built once).
    pub fn agent_observations(&self, team: Team, episode: u64) -> Vec<AgentObs> {
        let text: Arc<str> = describe(self, team).into();
        let list = unit_list(self.world(), team);
        let fx = effects(self, team);
        (0..self.agents(team).len()).map(|agent| self.agent_obs_with(team, agent, episode, &list, &fx, &text, true)).collect()
    }

    /// The observations of the agents of `team` whose units are in `units`, in agent order,
    /// built with only what `reads` asks for (empty masks, features or text otherwise).
    pub fn agent_observations_of(&self, team: Team, episode: u64, units: &[UnitId], reads: Reads) -> Vec<AgentObs> {
        let text: Arc<str> = if reads.text { describe(self, team).into() } else { Arc::from("") };
        let list = unit_list(self.world(), team);
        let fx = effects(self, team);
        (0..self.agents(team).len())
            .filter(|&agent| units.contains(&self.agents(team)[agent]))
            .map(|agent| self.agent_obs_with(team, agent, episode, &list, &fx, &text, reads.smac))
            .collect()
    }

    /// One agent's observation (see [`Env::agent_observations`] for all of a team's). Panics
    /// unless `agent` indexes the team's agents.
    pub fn agent_obs(&self, team: Team, agent: usize, episode: u64) -> AgentObs {
        let text: Arc<str> = describe(self, team).into();
        self.agent_obs_with(team, agent, episode, &unit_list(self.world(), team), &effects(self, team), &text, true)
    }

    #[allow(clippy::too_many_arguments)]
    fn agent_obs_with(
        &self,
        team: Team,
        agent: usize,
        episode: u64,
        list: &[UnitInfo],
        fx: &[EffectInfo],
        text: &Arc<str>,
        smac: bool,
    ) -> AgentObs {
        let tag = self.agents(team)[agent];
        let l = self.smac_layout(team);
        let (mut avail_actions, mut features) = (Vec::new(), Vec::new());
        if smac {
            avail_actions = vec![0u8; l.n_actions];
            self.avail_agent(team, agent, &mut avail_actions);
            features = vec![0f32; l.obs_size];
            self.obs_agent(team, agent, &mut features);
        }
        let own = list.iter().find(|u| u.tag == tag).cloned();
        let strip = |u: &UnitInfo| UnitInfo { abilities: Vec::new(), ..u.clone() };
        AgentObs {
            episode,
            seed: self.seed(),
            step: self.steps(),
            game_loop: self.world().tick(),
            unit: tag,
            team,
            alive: own.is_some(),
            own,
            allies: list.iter().filter(|u| u.own && u.tag != tag).map(strip).collect(),
            enemies: list.iter().filter(|u| !u.own).cloned().collect(),
            effects: fx.to_vec(),
            avail_actions,
            features,
            text: Arc::clone(text),
        }
    }
}
