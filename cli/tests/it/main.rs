//! Multi-process tests of the distributed deployment: real `avacraft` processes on a real
//! Zenoh router (one per test, on a free port).
#![forbid(unsafe_code)]

mod bridge;
mod common;
mod deploy;
mod docs;
mod eval;
mod foxglove;
mod hosts;
mod human;
mod replay;
mod train;
