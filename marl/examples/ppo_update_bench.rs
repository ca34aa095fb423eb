//! Times the pieces of one PPO gradient step (forward, backward, optimiser) on a random
//! rollout of 3m_vlm's sizes (or the scenario named by `SCENARIO`), for profiling the update:
//! `cargo run --release -p avacraft-marl --example ppo_update_bench -- [ALGO] [key=value ...]`
//! (with the environment `avacraft train` sets for itself: see the `ppo` module's docs).

use avacraft_engine::Scenario;
use avacraft_marl::ppo::{CriticInput, FlatBatch, MASKED, PpoLearner, Rollout};
use avacraft_marl::{Config, train::shape_of};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (algo, overrides) = match args.split_first() {
        Some((a, rest)) => (a.as_str(), rest.to_vec()),
        None => ("mappo", Vec::new()),
    };
    let cfg = Config::for_algo(algo, &overrides)?;
    let shape = shape_of(&cfg, &Arc::new(Scenario::load(&std::env::var("SCENARIO").unwrap_or_else(|_| "3m_vlm".into()))?))?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (t, rows, h) = (cfg.rollout_len, cfg.envs * shape.n_agents, cfg.rnn_hidden_dim);
    let wa = shape.input(cfg.obs_agent_id, cfg.obs_last_action);
    let mut r = Rollout { t, rows, n_agents: shape.n_agents, ..Rollout::default() };
    let n = t * rows;
    let mut rand = |k: usize| -> Vec<f32> { (0..k).map(|_| rng.random_range(-1f32..1.0)).collect() };
    r.actor_in = rand(n * wa);
    let critic = CriticInput::of(&cfg);
    for _ in 0..t {
        let (obs, state) = (rand(rows * shape.obs), rand(cfg.envs * shape.state));
        r.critic.extend(&critic.rows(&shape, &obs, &state, cfg.envs));
    }
    r.h_actor = rand(n / cfg.data_chunk_length * h);
    r.h_critic = rand(n / cfg.data_chunk_length * h);
    r.values = rand(n + rows);
    r.mask = (0..n * shape.n_actions).map(|i| if i % 3 == 0 { MASKED } else { 0.0 }).collect();
    r.actions = (0..n).map(|i| (1 + i % 2) as u32).collect();
    r.logp = vec![-1.5; n];
    r.active = vec![1.0; n];
    r.keep = (0..n).map(|i| if i % 23 == 0 { 0.0 } else { 1.0 }).collect();
    let adv = rand(n);
    let targets = rand(n);
    let flat = FlatBatch::new(&r, &adv, &targets, cfg.data_chunk_length)?;
    let mb = cfg.num_mini_batch.max(1);
    let idx: Vec<u32> = (0..(flat.len() / mb) as u32).collect();
    let part = flat.select(&idx);
    let batch = part.tensors(h)?;
    let mut l = PpoLearner::new(&cfg, shape, 1)?;
    let reps = 10;
    let time = |f: &mut dyn FnMut() -> Result<(), Box<dyn std::error::Error>>| -> Result<f64, Box<dyn std::error::Error>> {
        let clock = Instant::now();
        for _ in 0..reps {
            f()?;
        }
        Ok(clock.elapsed().as_secs_f64() / f64::from(reps) * 1e3)
    };
    if std::env::var_os("FUSED_ONLY").is_some() {
        let fused = time(&mut || Ok(l.gradients(&part).map(|_| ())?))?;
        println!("{algo}: fused forward+backward {fused:.1} ms");
        return Ok(());
    }
    let candle_fwd = time(&mut || Ok(l.loss(&batch)?.total.to_scalar::<f32>().map(|_| ())?))?;
    let candle_all = time(&mut || Ok(l.loss(&batch)?.total.backward().map(|_| ())?))?;
    let fused = time(&mut || Ok(l.gradients(&part).map(|_| ())?))?;
    let step = time(&mut || Ok(l.step(&part).map(|_| ())?))?;
    println!(
        "{algo}: mini-batch of {} sequences x {} steps: candle forward {candle_fwd:.1} ms, forward+backward {candle_all:.1} ms; fused forward+backward {fused:.1} ms ({:.1}x), step with Adam {step:.1} ms",
        part.len(),
        cfg.data_chunk_length,
        candle_all / fused,
    );
    Ok(())
}
