//! Measures the vision-text text features on random play: distinct clauses, cache hit
//! rates, and the time per step of the warm-up and after it.
//!
//! `cargo run --release -p avacraft-marl --example text_features -- SCENARIO STEPS
//! [ENVS] [key=value ...]`: STEPS environment steps (summed over the ENVS environments, 8 by
//! default) with uniformly random available actions, every environment's features computed
//! at every step as training does (config keys as for `avacraft train --set`; the on-disk
//! cache is off unless `text_disk_cache=true`). `... -- batch N` instead compares padded
//! batches of N clauses with one-at-a-time embedding (time and largest difference).

use avacraft_engine::{Scenario, Team, VecEnv, describe};
use avacraft_marl::Config;
use avacraft_marl::encoders::clause_cache::TextEmbedder;
use avacraft_marl::encoders::clauses::{SlotLayout, clauses};
use avacraft_marl::encoders::text::{MiniLm, locate};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use std::time::{Duration, Instant};

type R<T> = Result<T, Box<dyn std::error::Error>>;

fn main() -> R<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("batch") {
        return batch(args.get(1).map_or(Ok(64), |s| s.parse())?);
    }
    let scenario = Arc::new(Scenario::load(args.first().map_or("3m_vlm", String::as_str))?);
    let steps: u64 = args.get(1).map_or(Ok(20_000), |s| s.parse())?;
    let envs: usize = args.get(2).map_or(Ok(8), |s| s.parse())?;
    let mut o = vec!["obs=\"vision-text\"".to_owned(), "text_disk_cache=false".to_owned()];
    o.extend(args.iter().skip(3).cloned());
    let cfg = Config::for_algo("mappo", &o)?;
    let t = Instant::now();
    let model = MiniLm::load_from(&locate()?, cfg.text_max_tokens)?;
    println!("model loaded and hashed in {:.2} s", t.elapsed().as_secs_f64());
    let dir = avacraft_marl::observe::disk_cache_dir(&cfg);
    let file = dir.map(|d| avacraft_marl::encoders::clause_store::file_in(&d, model.hash()));
    let mut emb = TextEmbedder::new(Arc::new(model), cfg.text_cache, file);
    let seeds: Vec<u64> = (1..=envs as u64).collect();
    let mut v = VecEnv::new(Arc::clone(&scenario), cfg.env_config()?, &seeds, 1)?;
    let n_actions = v.shape().3.max(1);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut done, mut step) = (0u64, 0u64);
    let (mut text_time, mut describe_time) = (Duration::ZERO, Duration::ZERO);
    // Steps without a miss: what a step costs once every clause is cached.
    let (mut hit_steps, mut hit_time) = (0u64, Duration::ZERO);
    // Per window of steps: (steps, features time, misses).
    let mut windows: Vec<(u64, Duration, u64, u64)> = Vec::new();
    let marks = [10u64, 100, 1_000, 10_000, u64::MAX];
    let mut window = (0u64, Duration::ZERO, 0u64, 0u64);
    let mut tokens_whole = 0usize;
    let mut buf = Vec::new();
    while done < steps {
        let t = Instant::now();
        let texts: Vec<String> = v.envs().iter().map(|e| describe(e, Team::One)).collect();
        let layout = SlotLayout::of(&v.envs()[0], Team::One);
        let docs: Vec<_> = texts.iter().map(|s| clauses(s, &layout)).collect();
        describe_time += t.elapsed();
        if step % 1000 == 0 {
            tokens_whole = tokens_whole.max(texts.iter().map(|s| s.split_whitespace().count()).max().unwrap_or(0));
        }
        let before = emb.stats();
        let t = Instant::now();
        buf.clear();
        emb.features(&docs, layout.slots(), &mut buf)?;
        let dt = t.elapsed();
        text_time += dt;
        let after = emb.stats();
        if after.computed == before.computed {
            hit_steps += 1;
            hit_time += dt;
        }
        window.0 += 1;
        window.1 += dt;
        window.2 += after.computed - before.computed;
        window.3 += after.lookups - before.lookups;
        step += 1;
        if marks.contains(&step) || done + envs as u64 >= steps {
            windows.push(window);
            window = (0, Duration::ZERO, 0, 0);
        }
        let mut actions = vec![0i64; v.buffers.avail.len() / n_actions];
        for (slot, mask) in actions.iter_mut().zip(v.buffers.avail.chunks(n_actions)) {
            let avail: Vec<usize> = mask.iter().enumerate().filter(|(_, m)| **m == 1).map(|(i, _)| i).collect();
            *slot = avail.get(rng.random_range(0..avail.len().max(1))).map_or(0, |&i| i as i64);
        }
        v.step(&actions)?;
        done += envs as u64;
    }
    let s = emb.stats();
    println!(
        "{}: {done} env steps ({step} vector steps of {envs}), {} slots; longest text {tokens_whole} words",
        scenario.name,
        SlotLayout::of(&v.envs()[0], Team::One).slots()
    );
    println!(
        "clauses read {}, distinct (embedded) {}, hits {} ({:.3}%), cached now {}",
        s.lookups,
        s.computed,
        s.hits,
        100.0 * s.hits as f64 / s.lookups.max(1) as f64,
        emb.cache().len()
    );
    println!(
        "describe + split: {:.3} ms per vector step; features (lookups, MiniLM on misses, means): {:.1} s in all",
        1e3 * describe_time.as_secs_f64() / step as f64,
        text_time.as_secs_f64()
    );
    println!(
        "vector steps without a miss: {hit_steps}, {:.3} ms each ({:.1} us per environment)",
        1e3 * hit_time.as_secs_f64() / hit_steps.max(1) as f64,
        1e6 * hit_time.as_secs_f64() / (hit_steps.max(1) * envs as u64) as f64
    );
    let mut from = 0u64;
    for (n, t, misses, lookups) in windows {
        println!(
            "  vector steps {:>6}..{:<6}: {:>9.3} ms per vector step, {misses:>5} misses ({:.3}% of {lookups} clauses)",
            from,
            from + n,
            1e3 * t.as_secs_f64() / n.max(1) as f64,
            100.0 * misses as f64 / lookups.max(1) as f64
        );
        from += n;
    }
    Ok(())
}

/// Padded batches against one text per forward.
fn batch(n: usize) -> R<()> {
    let model = MiniLm::load()?;
    let scenario = Arc::new(Scenario::load("2s3z_vlm")?);
    let cfg = Config::for_algo("mappo", &[])?;
    let mut v = VecEnv::new(Arc::clone(&scenario), cfg.env_config()?, &[1, 2, 3, 4], 1)?;
    let mut texts: Vec<String> = Vec::new();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let n_actions = v.shape().3.max(1);
    while texts.len() < n {
        let layout = SlotLayout::of(&v.envs()[0], Team::One);
        for e in v.envs() {
            for c in clauses(&describe(e, Team::One), &layout) {
                if !texts.iter().any(|t| *t == c.text) {
                    texts.push(c.text.into_owned());
                }
            }
        }
        let actions: Vec<i64> = v
            .buffers
            .avail
            .chunks(n_actions)
            .map(|m| {
                let a: Vec<usize> = m.iter().enumerate().filter(|(_, x)| **x == 1).map(|(i, _)| i).collect();
                a.get(rng.random_range(0..a.len().max(1))).map_or(0, |&i| i as i64)
            })
            .collect();
        v.step(&actions)?;
    }
    texts.truncate(n);
    let refs: Vec<&str> = texts.iter().map(String::as_str).collect();
    for _ in 0..2 {
        let t = Instant::now();
        let one: Vec<_> = refs.iter().map(|s| model.embedding(s)).collect::<Result<_, _>>()?;
        let t_one = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let many = model.embed_many(&refs)?;
        let t_many = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let batched = model.embed_batch(&refs)?;
        let t_batch = t.elapsed().as_secs_f64();
        let diff = |a: &[avacraft_marl::encoders::text::Embedding]| {
            let mut worst = 0f32;
            let mut same = 0;
            for (x, y) in a.iter().zip(&one) {
                same += usize::from(x.vec == y.vec);
                worst = x.vec.iter().zip(&y.vec).map(|(p, q)| (p - q).abs()).fold(worst, f32::max);
            }
            (same, worst)
        };
        let tokens: u32 = one.iter().map(|e| e.tokens).sum();
        println!(
            "{n} clauses, {tokens} tokens: one at a time {t_one:.3} s; parallel {t_many:.3} s {:?}; padded batch {t_batch:.3} s {:?} (bit-equal count, largest difference)",
            diff(&many),
            diff(&batched)
        );
    }
    Ok(())
}
