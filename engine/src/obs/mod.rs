//! Observations built from the world: SMAC features, the structured unit list and the
//! natural-language battlefield description. All of them obey the team's fog of war.

mod group;
mod slots;
pub(crate) mod smac;
mod smac_agent_state;
mod smac_ext;
mod units;

pub use crate::flags::{Buffs, UnitFlags, UnknownBits};
pub use group::{AgentObs, Controlled, EffectInfo, GroupObs, Reads};
pub use slots::{AbilitySlots, slot_abilities};
pub use smac::{EnvInfo, IndexError, N_ACTIONS_NO_ATTACK, SHOOT_RANGE, SIGHT_RANGE, SmacLayout};
pub use units::{OrderInfo, UnitInfo, ability_infos, unit_list};
