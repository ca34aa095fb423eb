//! Helpers shared by the MARL test files.
// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, Outcome, Scenario, Team};
use avacraft_marl::{Config, MarlAgent, Policy};
use std::sync::Arc;

/// What one episode of a policy played as an engine agent gave.
#[derive(Debug)]
pub struct Played {
    /// Team 1's return.
    pub ret: f32,
    /// Team 1's orders the engine refused.
    pub refused: u32,
    pub outcome: Option<Outcome>,
}

/// Plays one episode of `scenario` (seed `seed`, `cfg`'s environment settings) with
/// `policy` as team 1's engine agent, through the same `Controllers` path as `episode`.
pub fn play(policy: &Arc<Policy>, scenario: &Arc<Scenario>, cfg: &Config, seed: u64) -> Played {
    let policy = Arc::clone(policy);
    let mut controllers = Controllers::new(
        scenario,
        vec![AgentTeam::new(Team::One, Grouping::Team, move || Box::new(MarlAgent::new(Arc::clone(&policy), "marl")))],
    );
    let mut env = Env::new(Arc::clone(scenario), cfg.env_config(), seed);
    controllers.reset(&env);
    let mut ret = 0.0;
    while !env.done() {
        controllers.act(&mut env);
        ret += env.step().reward[0];
    }
    Played { ret, refused: env.refused()[0], outcome: env.outcome() }
}
