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
    let unset: Vec<(&str, &str)> = TRAIN_ENV.iter().copied().filter(|(k, _)| std::env::var_os(k).is_none()).collect();
    if cli.trains() && !unset.is_empty() {
        return rerun_with(&unset);
    }
    run(cli, &mut std::io::stdout().lock(), Some(GLOBAL))
}

/// The environment `train` runs in, where not set already: the libraries read it once, at
/// their first use, and safe code cannot set its own process's environment, so `train`
/// runs again with it: on Unix in place of this process (`exec`: the same process id, so a
/// signal to it, or its training folder's lock, is the training's own), elsewhere as a
/// child. Measured on a 2-core machine shared with other work
/// (others' load about 4-5):
/// - candle runs elementwise operations on tensors of 64k elements or more on its own pool
///   of threads, which spin at a barrier after each operation; a descheduled helper leaves
///   the caller spinning. PPO's updates ran 3x faster without the pool, QMIX's 2x. Set
///   CANDLE_NUM_THREADS (e.g. to the core count) to keep it.
/// - glibc's malloc serves blocks above its (adaptive) mmap threshold with fresh mappings
///   and trims the heap eagerly, so the update's tensors of 0.2 to 2 MB cost page faults
///   on every operation (40% of the time in the kernel). A 32 MiB threshold and a 512 MiB
///   trim threshold made MAPPO's training 1.6x faster at the same peak memory.
const TRAIN_ENV: [(&str, &str); 2] =
    [("CANDLE_NUM_THREADS", "1"), ("GLIBC_TUNABLES", "glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=536870912")];

fn rerun_with(vars: &[(&str, &str)]) -> anyhow::Result<()> {
    use anyhow::Context;
    let exe = std::env::current_exe().context("train: this program's path")?;
    let mut again = std::process::Command::new(exe);
    again.args(std::env::args_os().skip(1)).envs(vars.iter().copied());
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        // Returns only if the program could not be started.
        let e = again.exec();
        Err(e).context("train: starting it in its tuned environment")
    }
    #[cfg(not(unix))]
    {
        let status = again.status().context("train: starting it in its tuned environment")?;
        std::process::exit(status.code().unwrap_or(1))
    }
}
