//! What a policy is and the scripted ones: the agent contract every agent kind implements
//! ([`Agent`], over the observations in `crate::obs`), commanders and their orders, the
//! scripted agents and opponent styles, ability micro, stances and the action check. Below
//! `crate::env`, because an environment plays its scenario's scripted opponent; what runs
//! agents in an environment is `crate::agent`, above it.

mod check;
mod command;
mod contract;
mod heuristic;
pub(crate) mod micro;
mod role;
mod scripted;
mod stance;
pub mod view;

pub use check::check_action;
pub use command::{
    Assignment, Commander, MakeAgent, MakeCommander, Orders, OrdersError, RoleGroupSpec, Rotate, commander_seed,
    validate as validate_orders,
};
pub use contract::{Agent, AgentCtx, ForkAgent, FrameNeed, FrameSource, TeamFrames, agent_seed, complete};
pub use heuristic::SmacHeuristic;
pub use role::{Briefing, GroupRole};
pub(crate) use scripted::opponent;
pub use scripted::{AGENTS, AttackMove, Defensive, FocusFire, Hold, NoOp, RandomActions, UnknownAgent, by_name, factory};
pub use stance::Stance;
