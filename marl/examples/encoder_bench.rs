//! Times the image encoder's forward and backward passes on a batch of frames, candle's
//! autograd against the fused kernels (CNN backbone):
//! `cargo run --release -p avacraft-marl --example encoder_bench -- N [key=value ...]`
//! (config keys as for `avacraft train --set`, e.g. `encoder=swin screen_size=[160,120]`;
//! `N` defaults to 3200, a MAPPO rollout's frames). `CANDLE=0` skips candle.

use avacraft_marl::encoders::ObsEncoder;
use avacraft_marl::nets::Params;
use avacraft_marl::observe::StepFrames;
use avacraft_marl::{Config, Shape};
use candle_core::Tensor;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().map_or(Ok(3200), |s| s.parse())?;
    let mut o: Vec<String> = vec!["obs=rgb".into()];
    o.extend(args.iter().skip(1).cloned());
    let cfg = Config::for_algo("qmix", &o)?;
    let shape = Shape { n_agents: 3, obs: 30, state: 48, n_actions: 9, n_enemies: 3 };
    let mut p = Params::default();
    let enc = ObsEncoder::for_config(&cfg, &shape, &mut p, 1)?.ok_or("features mode has no encoder")?;
    let [sw, sh] = cfg.screen_size.map(|v| v as usize);
    let [mw, mh] = cfg.minimap_size.map(|v| v as usize);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut bytes = |len: usize| (0..len).map(|_| rng.random_range(0..=255u8)).collect::<Vec<u8>>();
    let mut frames = StepFrames::from_pixels(n, ((sw, sh), (mw, mh)), bytes(n * sw * sh * 3), bytes(n * mw * mh * 3));
    if cfg.obs.text() {
        frames.text = (0..n * avacraft_marl::encoders::text_width(&shape)).map(|i| ((i % 97) as f32 / 97.0) - 0.5).collect();
    }
    frames.check()?;
    println!("{} weights, {n} frames {sw}x{sh} + {mw}x{mh}, {} threads", p.count(), rayon::current_num_threads());
    if std::env::var("CANDLE").map_or(true, |v| v != "0") {
        let f = frames.tensors()?;
        for _ in 0..2 {
            let t = Instant::now();
            let y = enc.forward(&f)?;
            let fwd = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let _g = y.sqr()?.mean_all()?.backward()?;
            println!("candle: forward {:.1} ms, backward {:.1} ms", fwd * 1e3, t.elapsed().as_secs_f64() * 1e3);
        }
    }
    let Some(k) = enc.kernel() else {
        println!("no fused kernels for this backbone");
        return Ok(());
    };
    let theta = p.flat(p.len())?;
    let mut pass = avacraft_marl::kernels::EncoderForward::default();
    let mut grad = vec![0f32; k.len()];
    let mut d = Vec::new();
    for _ in 0..5 {
        let (t, cpu) = (Instant::now(), cpu_seconds());
        k.forward_into(&theta, &frames.pixels(), true, &mut pass)?;
        let (fwd, fwd_cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu);
        // The gradient of mean(y^2).
        let scale = 2.0 / pass.out.len().max(1) as f32;
        d.clear();
        d.extend(pass.out.iter().map(|&y| y * scale));
        let (t, cpu) = (Instant::now(), cpu_seconds());
        grad.fill(0.0);
        k.backward(&theta, &mut pass, &frames.pixels(), &d, &mut grad);
        let (bwd, bwd_cpu) = (t.elapsed().as_secs_f64(), cpu_seconds() - cpu);
        println!(
            "fused: forward {:.1} ms (CPU {:.0} ms), backward {:.1} ms (CPU {:.0} ms)",
            fwd * 1e3,
            fwd_cpu * 1e3,
            bwd * 1e3,
            bwd_cpu * 1e3
        );
    }
    let y = Tensor::from_slice(&pass.out, (n, k.out()), &candle_core::Device::Cpu)?;
    println!("features' mean {:.5}", y.mean_all()?.to_scalar::<f32>()?);
    Ok(())
}

/// This process's CPU time (all threads; Linux, 10 ms ticks), 0 elsewhere: on a shared
/// machine the wall clock also measures the other processes.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the command name (which may hold spaces): utime and stime are 14 and 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = rest.split_whitespace().skip(11).take(2).filter_map(|v| v.parse().ok()).collect();
    f.iter().sum::<f64>() / 100.0
}
