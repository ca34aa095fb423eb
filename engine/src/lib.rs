//! AVACraft's simulator core: a deterministic StarCraft II micro-combat engine at game-loop
//! resolution, the paper's scenarios, opponents, and observations. No middleware: MARL
//! training, bindings and the ROS 2 / Zenoh nodes all drive this same library.
//!
//! ```
//! use avacraft_engine::{builtin, Env, EnvConfig, Team};
//! use std::sync::Arc;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mut env = Env::new(Arc::new(builtin("3m_vlm")?), EnvConfig::default(), 1);
//! let info = env.env_info(Team::One);
//! assert_eq!((info.obs_shape, info.state_shape, info.n_actions), (30, 48, 9));
//! let (mut obs, mut avail) = (vec![0.0; info.obs_shape], vec![0u8; info.n_actions]);
//! while !env.done() {
//!     let mut actions = Vec::new();
//!     for agent in 0..info.n_agents {
//!         env.obs_agent(Team::One, agent, &mut obs);
//!         env.avail_agent(Team::One, agent, &mut avail);
//!         actions.push(avail.iter().rposition(|&a| a == 1).unwrap_or(0));
//!     }
//!     env.submit_indices(Team::One, &actions);
//!     let step = env.step();
//!     assert!(step.reward.iter().all(|r| r.is_finite()));
//! }
//! assert!(env.outcome().is_some());
//! # Ok(())
//! # }
//! ```
//!
//! # Layers
//!
//! Each module uses only modules of its own layer or a lower one, and no two modules use each
//! other, directly or around a circle (`tests/it/structure.rs` checks both, from this list):
//!
//! 1. data: `time`, `geom`, `ids`, `flags`, `units`, `damage`, `terrain`, `spatial`, `orca`, `pathing`, `scenario`
//! 2. state: `ability`, `world`, `movement`, `hash`
//! 3. rules: `action`, `rules`, `combat`, `cast`, `sim`, `builtin_ai`
//! 4. observations: `obs`
//! 5. policies: `policy` (the agent contract and the scripted agents; an episode plays its
//!    scenario's scripted opponent, so they sit below it)
//! 6. episodes: `env`, `learn`
//! 7. agents: `agent` (agents running in an environment, and the contract's public face), `vec_env`
#![forbid(unsafe_code)]

mod ability;
mod action;
pub mod agent;
mod builtin_ai;
mod cast;
mod combat;
mod damage;
mod env;
mod flags;
mod geom;
mod hash;
mod ids;
mod learn;
mod movement;
mod obs;
mod orca;
mod pathing;
mod policy;
mod rules;
mod scenario;
mod sim;
mod spatial;
mod terrain;
mod time;
mod units;
mod vec_env;
mod world;

pub use ability::{
    Ability, AbilityInfo, AbilitySpec, AbilityTarget, AreaEffect, Channel, EffectKind, Refusal, RefusalCode, SlotRule, Status, TargetKind,
    TargetRule, UnknownAbility,
};
pub use action::{Action, ActionError, Command, Direction, GRID, Inability, MOVE_AMOUNT, TargetProblem, grid_cell_center, grid_cell_of};
pub use agent::{
    AGENTS as POLICIES, Agent, AgentCtx, Controllers, ForkAgent, GroupObs, Reads, UnknownAgent as UnknownPolicy, by_name as agent_by_name,
};
pub use damage::{Dealt, apply_hits, hit_damage};
pub use env::{
    BadFovActions, BadOption, DenseReward, Env, EnvConfig, EnvOptions, MAX_FOV_ACTIONS, Outcome, RewardMode, StepResult, check_fov_actions,
    describe,
};
pub use geom::Vec2;
pub use hash::Fnv;
pub use ids::{BadTag, Team, Tick, UnitId, serde_as};
pub use learn::{LearnError, StepInfo};
pub use obs::{AbilitySlots, slot_abilities};
pub use obs::{
    Buffs, EnvInfo, IndexError, N_ACTIONS_NO_ATTACK, OrderInfo, SHOOT_RANGE, SIGHT_RANGE, SmacLayout, UnitFlags, UnitInfo, UnknownBits,
    ability_infos, unit_list,
};
pub use scenario::{
    BUILTIN, Generator, Mode, OpponentKind, PROCEDURAL, RENAMED, RawGenerate, RawOpponent, RawScenario, RawStart, RawTerrain, RawUnit,
    RawUpgrade, SMAC, Scenario, ScenarioError, ScenarioUnit, StartDist, StartOrder, Upgrade, all_names, builtin, builtin_names,
    procedural_names, renamed, smac_names,
};
pub use terrain::{MAX_STEP, Rect, Terrain};
pub use time::{DEFAULT_STEP_MUL, DEFAULT_TIME_LIMIT_S, LOOPS_PER_NORMAL_SECOND, LOOPS_PER_SECOND, loops_to_seconds, seconds_to_loops};
pub use units::{Attrs, DataSet, Heal, Race, Reach, Regen, Splash, Timing, UnitKind, UnitSpec, UnknownDataSet, UnknownUnitKind, Weapon};
pub use vec_env::{OpponentFactory, Replayed, Replayer, VecBuffers, VecEnv, VecEnvError};
pub use world::{Activity, Body, Order, Rules, Shot, TeamStats, Unit, UnknownWeaponPeriod, WeaponPeriod, World};
