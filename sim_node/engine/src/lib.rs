//! AVACraft's simulator core: a deterministic StarCraft II micro-combat engine at game-loop
//! resolution, the paper's scenarios, opponents, and observations. No middleware: MARL
//! training, bindings and the ROS 2 / Zenoh nodes all drive this same library.
//!
//! ```
//! use avacraft_engine::{Env, EnvConfig, Team, builtin};
//! use std::sync::Arc;
//! let scenario = Arc::new(builtin("3m").unwrap());
//! let mut env = Env::new(scenario, EnvConfig::default(), 1);
//! while !env.step().done {}
//! assert!(env.outcome().is_some());
//! let info = env.env_info(Team::One);
//! assert_eq!((info.obs_shape, info.state_shape, info.n_actions), (30, 48, 9));
//! ```

mod action;
mod combat;
mod damage;
mod env;
mod geom;
mod hash;
mod ids;
mod movement;
mod obs;
mod orca;
mod pathing;
pub mod policy;
mod scenario;
mod sim;
mod spatial;
mod terrain;
mod time;
mod units;
mod world;

pub use action::{Action, ActionError, Command, Direction, GRID, MOVE_AMOUNT, grid_cell_center, grid_cell_of};
pub use damage::{Dealt, apply_hits, hit_damage};
pub use env::{Env, EnvConfig, Outcome, RewardMode, StepResult};
pub use geom::Vec2;
pub use hash::Fnv;
pub use ids::{Team, Tick, UnitId};
pub use obs::{EnvInfo, IndexError, N_ACTIONS_NO_ATTACK, OrderInfo, SHOOT_RANGE, SIGHT_RANGE, SmacLayout, UnitInfo, describe, unit_list};
pub use policy::{POLICIES, Policy, TeamView, UnknownPolicy};
pub use scenario::{
    BUILTIN, Mode, OpponentKind, RawOpponent, RawScenario, RawStart, RawTerrain, RawUnit, RawUpgrade, Scenario, ScenarioError,
    ScenarioUnit, StartOrder, Upgrade, builtin, builtin_names,
};
pub use sim::{ENERGY_REGEN, SHIELD_REGEN, SHIELD_REGEN_DELAY, ZERG_REGEN};
pub use terrain::{MAX_STEP, Rect, Terrain};
pub use time::{DEFAULT_STEP_MUL, DEFAULT_TIME_LIMIT_S, LOOPS_PER_NORMAL_SECOND, LOOPS_PER_SECOND, loops_to_seconds, seconds_to_loops};
pub use units::{Attrs, Heal, Race, Reach, Splash, UnitKind, UnitSpec, UnknownUnitKind, Weapon};
pub use world::{Activity, Order, Rules, Shot, TeamStats, Unit, World};
