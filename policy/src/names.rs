//! The policy names that are not a scripted agent's, shared by the parser and its errors.

use avacraft_engine::agent::Rotate;

/// The prefix of a trained policy's checkpoint directory.
pub const MARL_PREFIX: &str = "marl:";
/// The policy name of agents driven from DDS through the bridge.
pub const DDS_POLICY: &str = "dds";
/// The policy name of the AVA agent (its settings come with it: an `AvaSpec`).
pub const AVA_POLICY: &str = "ava";
/// The scripted commander's name.
pub const ROTATE_POLICY: &str = Rotate::NAME;
