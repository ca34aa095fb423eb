//! `avacraft`: list scenarios, inspect their SMAC layout, run episodes, benchmark the engine.

mod bench;
mod episode;
mod info;

use clap::{Parser, Subcommand};
use stats_alloc::{INSTRUMENTED_SYSTEM, StatsAlloc};
use std::alloc::System;

/// Counts allocations so `bench` can report bytes per environment.
#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

#[derive(Parser, Debug)]
#[command(name = "avacraft", version, about = "AVACraft: StarCraft II micro-combat benchmark for MARL and VLM agents")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// List the built-in scenarios with unit counts and mode.
    Scenarios(info::ScenariosArgs),
    /// Print SMAC's get_env_info() for a scenario.
    EnvInfo(info::EnvInfoArgs),
    /// Run episodes in-process and report win/draw/loss rates.
    Episode(episode::EpisodeArgs),
    /// Measure environment steps per second and memory per environment.
    Bench(bench::BenchArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Cmd::Scenarios(a) => info::scenarios(&a),
        Cmd::EnvInfo(a) => info::env_info(&a),
        Cmd::Episode(a) => episode::run(&a),
        Cmd::Bench(a) => bench::run(&a, GLOBAL),
    }
}
