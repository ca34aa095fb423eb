//! Where a Q-learner's update spends its time, on a fixed batch of 32 random 3m_vlm-sized
//! episodes (20 to 60 steps): building the batch, the unroll, the loss, the backward pass
//! and a whole `train` step, printed per repetition. Config overrides as arguments:
//! `cargo run --release -p avacraft-marl --example update_bench -- use_rnn=false`.
//! It showed that the GRU unroll (tens of small candle ops per time step) dominates, which is
//! why `use_rnn = false` trains several times faster per wall-clock second.

use avacraft_marl::{Batch, Config, Episode, Learner, Shape};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let cfg = Config::for_algo("qmix", &args)?;
    let shape = Shape { n_agents: 3, obs: 30, state: 48, n_actions: 9, n_enemies: 3 };
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let eps: Vec<Episode> = (0..cfg.batch_size)
        .map(|_| {
            let mut e = Episode::default();
            let len = rng.random_range(20..60);
            for _ in 0..len {
                let obs: Vec<f32> = (0..90).map(|_| rng.random()).collect();
                let st: Vec<f32> = (0..48).map(|_| rng.random()).collect();
                e.push_step(&obs, &st, &[1u8; 27], &[1, 2, 3]);
                e.push_outcome(rng.random(), false);
            }
            e.close(&shape, None);
            e
        })
        .collect();
    let refs: Vec<&Episode> = eps.iter().collect();
    let mut l = Learner::new(&cfg, shape, 1)?;
    for i in 0..12 {
        let t0 = std::time::Instant::now();
        let b = Batch::new(&refs, &shape, true, true)?;
        let batch = t0.elapsed();
        let t1 = std::time::Instant::now();
        let _ = l.gradients(&b, false)?;
        let candle = t1.elapsed();
        let t2 = std::time::Instant::now();
        let _ = l.train(&b, i)?;
        let fused = t2.elapsed();
        eprintln!("batch {batch:?}, candle loss and gradients {candle:?}, fused update {fused:?}");
    }
    Ok(())
}
