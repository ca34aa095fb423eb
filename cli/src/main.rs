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
    let cli = Cli::parse();
    if cli.trains() && std::env::var_os("CANDLE_NUM_THREADS").is_none() {
        return train_without_candle_pool();
    }
    run(cli, &mut std::io::stdout().lock(), Some(GLOBAL))
}

/// candle runs elementwise operations on tensors of 64k elements or more on its own pool of
/// threads, which spin at a barrier after each operation. On a small machine shared with
/// other work, a descheduled helper leaves the caller spinning: PPO's updates ran 3x slower
/// with the pool (2 cores, other processes' load about 5), QMIX's 2x slower. The pool
/// reads CANDLE_NUM_THREADS once and safe code cannot set its own process's environment,
/// so `train` runs as a child with CANDLE_NUM_THREADS=1 unless the variable is set (set it,
/// e.g. to the core count, to keep the pool).
fn train_without_candle_pool() -> anyhow::Result<()> {
    use anyhow::Context;
    let exe = std::env::current_exe().context("train: this program's path")?;
    let status = std::process::Command::new(exe)
        .args(std::env::args_os().skip(1))
        .env("CANDLE_NUM_THREADS", "1")
        .status()
        .context("train: starting it with CANDLE_NUM_THREADS=1")?;
    std::process::exit(status.code().unwrap_or(1))
}
