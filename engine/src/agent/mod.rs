//! The agent contract: every agent kind (scripted, MARL, VLM, remote) implements [`Agent`]
//! over the observations a deployment carries, so one policy runs in-process, from Python and
//! as an agent node with the same results. An agent controls a group of units (one unit, a
//! role group, or a whole team) and sees what its units' observations say, nothing more.

mod check;
mod command;
mod contract;
mod controllers;
pub(crate) mod micro;
mod obs;
mod observe;
mod role;
mod runner;
mod scripted;
mod stance;
pub mod view;

pub use check::check_action;
pub use command::{
    Assignment, CommandedTeam, Commander, MakeAgent, MakeCommander, Orders, OrdersError, RoleGroupSpec, Rotate, commander_seed,
    validate as validate_orders,
};
pub use contract::{Agent, AgentCtx, ForkAgent, FrameNeed, FrameSource, Reads, TeamFrames, agent_seed, complete};
pub use controllers::Controllers;
pub use obs::{AgentObs, Controlled, EffectInfo, GroupObs};
pub use observe::effects;
pub use role::{Briefing, GroupRole};
pub use runner::{AgentTeam, Grouping};
pub(crate) use scripted::opponent;
pub use scripted::{AGENTS, AttackMove, Defensive, FocusFire, Hold, NoOp, RandomActions, UnknownAgent, by_name, factory};
pub use stance::Stance;
