//! The agent contract and the agents running in an environment: every agent kind (scripted,
//! MARL, VLM, remote) implements [`Agent`] over the observations a deployment carries, so one
//! policy runs in-process, from Python and as an agent node with the same results. An agent
//! controls a group of units (one unit, a role group, or a whole team) and sees what its
//! units' observations say, nothing more.
//!
//! This module runs agents in an [`Env`](crate::Env) (teams, commanded teams, controllers)
//! and is the public face of the contract; the contract and the scripted agents themselves
//! live below the environment (`crate::policy`), which plays its scenario's scripted opponent.

mod commanded;
mod controllers;
mod runner;

pub use crate::env::effects;
pub use crate::obs::{AgentObs, Controlled, EffectInfo, GroupObs, Reads};
pub use crate::policy::view;
pub use crate::policy::{
    AGENTS, Agent, AgentCtx, Assignment, AttackMove, Briefing, Commander, Defensive, FocusFire, ForkAgent, FrameNeed, FrameSource,
    GroupRole, Hold, MakeAgent, MakeCommander, NoOp, Orders, OrdersError, RandomActions, RoleGroupSpec, Rotate, SmacHeuristic, Stance,
    TeamFrames, UnknownAgent, agent_seed, by_name, check_action, commander_seed, complete, factory, validate_orders,
};
pub use commanded::CommandedTeam;
pub use controllers::Controllers;
pub use runner::{AgentTeam, Grouping};
