//! A live view of battles for Foxglove (and its open-source fork Lichtblick): a Foxglove
//! WebSocket server and the battle as Foxglove's own message types, so the panels people
//! already use for robots (Image with annotations, 3D, Log, Raw Messages) show a battle
//! without a plugin.
//!
//! - [`LiveServer`]: the WebSocket server (`foxglove.sdk.v1`); loopback unless told
//!   otherwise by its caller, never blocking the simulation (a slow client's messages are
//!   dropped and counted), disconnecting clients that do not speak the protocol.
//! - [`Framer`]: one step of an [`avacraft_engine::Env`] as messages on the
//!   [`LiveChannel`]s, as Foxglove's protobuf messages for the server or as ROS 2 messages
//!   ([`Wire::Ros2`]) for recordings, which ROS 2 readers open; Foxglove shows both with the
//!   same panels, so one layout (`docs/foxglove-layout.json`) opens a live run and an MCAP file.

mod channels;
mod ros2;
mod server;
mod view;

pub use channels::LiveChannel;
pub use foxglove::schemas::log::Level;
pub use ros2::ros2_type;
pub use server::{DEFAULT_BACKLOG, LEGACY_SUBPROTOCOL, LiveError, LiveServer, LiveStats, SUBPROTOCOL};
pub use view::{Frame, Framer, LiveLog, LiveView, ViewSize, Wire, log, log_bytes, status};
