//! The engine's structures to messages and back. Every action off the wire passes
//! `action_from_msg`, which names what is wrong instead of guessing.

use avacraft_engine::{AbilityTarget, Action, Command, Env, UnitId, World};
use avacraft_msgs::{Header, Time, UnitAction};
use avacraft_nodes::wire;

/// Header stamped with game time (the simulation's clock, as `/clock` would give it).
pub fn header(world: &World, frame: &str) -> Header {
    let loops = world.tick() as u64;
    let nanos = loops * 1_000_000_000 * 10 / 224;
    Header { stamp: Time { sec: (nanos / 1_000_000_000) as i32, nanosec: (nanos % 1_000_000_000) as u32 }, frame_id: frame.to_owned() }
}

pub use avacraft_nodes::wire::unit_state;

/// Why an action message was refused before reaching the engine.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BadAction {
    #[error("unit tag {0} does not exist")]
    UnknownUnit(u32),
    #[error("target tag {0} does not exist")]
    UnknownTarget(u32),
    #[error(transparent)]
    Wire(#[from] wire::WireError),
}

/// A message to an engine action (the engine then checks it against the game's rules).
pub fn action_from_msg(w: &World, a: &UnitAction) -> Result<Action, BadAction> {
    let action = wire::action(a)?;
    if w.unit(action.unit).is_none() {
        return Err(BadAction::UnknownUnit(a.unit_tag));
    }
    let target = match action.command {
        Command::Attack { target } | Command::Ability { target: AbilityTarget::Unit { unit: target }, .. } => Some(target),
        _ => None,
    };
    if target.is_some_and(|t| w.unit(t).is_none()) {
        return Err(BadAction::UnknownTarget(a.target_tag));
    }
    Ok(action)
}

/// The unit with wire tag `tag`, if it exists.
pub(crate) fn unit_of(env: &Env, tag: u32) -> Option<&avacraft_engine::Unit> {
    let i = u16::try_from(tag.checked_sub(1)?).ok()?;
    env.world().unit(UnitId::new(i))
}
