//! `bench --vec`: the learners' side of speed. A vector environment of many episodes on all
//! cores against one environment on one core (how well stepping scales across threads), and
//! the engine's steps per second per core against the goal. Both rates come from the
//! same run, so the ratio does not depend on the machine's speed.

use anyhow::{Context, Result};
use avacraft_engine::{EnvConfig, Scenario, VecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

/// The goal for the scaling ratio on two cores.
const GOAL_RATIO: f64 = 1.8;
/// The goal for 2s3z_vlm engine steps per second per core.
const GOAL_PER_CORE: f64 = 150_000.0;

#[derive(Serialize, Debug, Clone)]
pub struct VecRow {
    pub scenario: String,
    pub envs: usize,
    pub threads: usize,
    /// Environment steps per second of one environment stepped through the vector API on
    /// one thread (the baseline).
    pub single_steps_per_sec: f64,
    /// Environment steps per second of all `envs` on `threads` threads.
    pub vec_steps_per_sec: f64,
    /// vec / single (goal: at least 1.8 on 2 cores).
    pub ratio: f64,
    /// All `envs` on one thread: what the threads add, apart from the cost of keeping many
    /// environments in the caches.
    pub vec_one_thread_steps_per_sec: f64,
    /// vec / vec on one thread.
    pub thread_scaling: f64,
    /// The vector environment's rate per thread.
    pub per_core_steps_per_sec: f64,
    /// The engine's rate on one core (the single environment's) / 150,000.
    pub ratio_to_per_core_goal: f64,
}

/// Environment steps per second with uniformly random available actions chosen on the
/// calling thread, as a learner's policy would.
fn rate(scenario: &Arc<Scenario>, envs: usize, threads: usize, seconds: f64) -> Result<f64> {
    let seeds: Vec<u64> = (1..=envs as u64).collect();
    let mut v = VecEnv::new(Arc::clone(scenario), EnvConfig::default(), &seeds, threads)?;
    let (_, _, _, n_actions) = v.shape();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut actions = vec![0i64; v.buffers.avail.len() / n_actions.max(1)];
    let mut steps = 0u64;
    let start = Instant::now();
    loop {
        for (slot, mask) in actions.iter_mut().zip(v.buffers.avail.chunks(n_actions)) {
            let n = mask.iter().filter(|&&m| m == 1).count();
            let k = rng.random_range(0..n.max(1));
            *slot = mask.iter().enumerate().filter(|(_, m)| **m == 1).nth(k).map_or(0, |(i, _)| i as i64);
        }
        v.step(&actions).context("stepping the vector environment")?;
        steps += envs as u64;
        if steps.is_multiple_of(64 * envs as u64) && start.elapsed().as_secs_f64() >= seconds {
            break;
        }
    }
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

pub fn run(names: &[String], envs: usize, seconds: f64, json: bool, out: &mut dyn Write) -> Result<()> {
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let mut rows = Vec::new();
    for name in names {
        let scenario = Arc::new(Scenario::load(name)?);
        let single = rate(&scenario, 1, 1, seconds)?;
        let many = rate(&scenario, envs, threads, seconds)?;
        let many_one = rate(&scenario, envs, 1, seconds)?;
        rows.push(VecRow {
            scenario: scenario.name.clone(),
            envs,
            threads,
            single_steps_per_sec: single,
            vec_steps_per_sec: many,
            ratio: many / single,
            vec_one_thread_steps_per_sec: many_one,
            thread_scaling: many / many_one,
            per_core_steps_per_sec: many / threads as f64,
            ratio_to_per_core_goal: single / GOAL_PER_CORE,
        });
    }
    if json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "scenario",
        "1 env, 1 core: steps/s",
        "ratio to 150k per core",
        "envs x threads",
        "vector: steps/s",
        "vector per thread",
        format!("vector / 1 env (goal {GOAL_RATIO})").as_str(),
        "vector on 1 thread",
        "thread scaling",
    ]);
    for r in &rows {
        t.add_row([
            r.scenario.clone(),
            format!("{:.0}", r.single_steps_per_sec),
            format!("{:.2}", r.ratio_to_per_core_goal),
            format!("{} x {}", r.envs, r.threads),
            format!("{:.0}", r.vec_steps_per_sec),
            format!("{:.0}", r.per_core_steps_per_sec),
            format!("{:.2}", r.ratio),
            format!("{:.0}", r.vec_one_thread_steps_per_sec),
            format!("{:.2}", r.thread_scaling),
        ]);
    }
    writeln!(out, "{t}")?;
    writeln!(
        out,
        "one step = 8 game loops + every agent's observation, mask and the state written into the vector buffers; random available actions picked on the calling thread"
    )?;
    Ok(())
}
