//! A training run without the CLI (which pulls in the deployment stack):
//! `cargo run --release -p avacraft-marl --example quick_train -- ALGO SCENARIO OUT [key=value ...]`
//! (the seed from the environment variable `SEED`, default 1). Same run as `avacraft train`.

use avacraft_engine::Scenario;
use avacraft_marl::{Config, RunOptions, train};
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [algo, scenario, out, overrides @ ..] = args.as_slice() else {
        return Err("usage: quick_train ALGO SCENARIO OUT [key=value ...]".into());
    };
    let cfg = Config::for_algo(algo, overrides)?;
    let scenario = Arc::new(Scenario::load(scenario)?);
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let seed = std::env::var("SEED").ok().map(|s| s.parse::<u64>()).transpose()?.unwrap_or(1);
    let opts = RunOptions { scenario, seed, threads, out: Some(out.into()) };
    let started = std::time::Instant::now();
    let mut last_tests = 0;
    let (_, summary) = train(&cfg, &opts, &mut |p| {
        if let Some(t) = p.last_test
            && t.t_env != last_tests
        {
            last_tests = t.t_env;
            let secs = started.elapsed().as_secs_f64();
            eprintln!(
                "t_env {:>8} ({:.0} steps/s) episodes {} updates {} eps {:.3} loss {:.4} test win {:.1}%",
                p.t_env,
                p.t_env as f64 / secs,
                p.episodes,
                p.updates,
                p.epsilon,
                p.loss,
                100.0 * t.win_rate
            );
        }
    })?;
    println!(
        "{} steps, {} episodes, {} updates in {:.1} s ({:.0} steps/s); phases (s): {:?}",
        summary.t_env,
        summary.episodes,
        summary.updates,
        started.elapsed().as_secs_f64(),
        summary.t_env as f64 / started.elapsed().as_secs_f64(),
        summary.phases.iter().map(|(n, s)| format!("{n} {s:.1}")).collect::<Vec<_>>()
    );
    Ok(())
}
