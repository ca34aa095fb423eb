//! The AVACraft node SDK. Every process of a deployment (simulator node, agent nodes,
//! recorder) opens a [`Node`]: one Zenoh session that speaks rmw_zenoh's conventions (data
//! keys with type name and hash, liveliness tokens, sample attachments), so ROS 2 Jazzy
//! tools attached to the same router see, echo and record every topic. Topic names come
//! only from [`Topics`]. Image frames between local processes go zero-copy through
//! iceoryx2 shared memory ([`frames`]).
#![forbid(unsafe_code)]

mod cli;
pub mod frames;
mod node;
pub mod ros;
mod topics;
pub mod wire;

pub use cli::{NodeArgs, SessionMode, Shutdown, init_logging};
pub use node::{Node, NodeError, Publisher, Received, Subscriber, Tap, Tapped, now_ns, zenoh_config};
pub use ros::Qos;
pub use topics::{
    AgentId, DEFAULT_NAMESPACE, FrameKind, LiveTopic, NameError, NodeName, TeamNo, Topic, TopicKind, TopicPattern, Topics, UnitTag,
};
