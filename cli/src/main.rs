//! `avacraft`: list scenarios, inspect their SMAC layout, run episodes, benchmark the engine.
#![forbid(unsafe_code)]

use avacraft_cli::{Cli, run};
use clap::Parser;
use stats_alloc::{INSTRUMENTED_SYSTEM, StatsAlloc};
use std::alloc::System;

/// Counts allocations so `bench` can report bytes per environment.
#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() -> anyhow::Result<()> {
    run(Cli::parse(), &mut std::io::stdout().lock(), Some(GLOBAL))
}
