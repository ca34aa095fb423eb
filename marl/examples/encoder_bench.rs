//! Times the image encoder's forward and backward passes on a batch of frames:
//! `cargo run -p avacraft-marl --example encoder_bench -- N [key=value ...]` (config keys as
//! for `avacraft train --set`, e.g. `encoder=swin screen_size=[160,120]`).

use avacraft_marl::encoders::{FrameTensors, ObsEncoder};
use avacraft_marl::nets::Params;
use avacraft_marl::{Config, Shape};
use candle_core::{Device, Tensor};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().map_or(Ok(256), |s| s.parse())?;
    let mut o: Vec<String> = vec!["obs=rgb".into()];
    o.extend(args.iter().skip(1).cloned());
    let cfg = Config::for_algo("qmix", &o)?;
    let shape = Shape { n_agents: 3, obs: 30, state: 48, n_actions: 9, n_enemies: 3 };
    let mut p = Params::default();
    let enc = ObsEncoder::for_config(&cfg, &shape, &mut p, 1)?.ok_or("features mode has no encoder")?;
    let [sw, sh] = cfg.screen_size.map(|v| v as usize);
    let [mw, mh] = cfg.minimap_size.map(|v| v as usize);
    let f = FrameTensors {
        screen: Tensor::rand(0f32, 1f32, (n, 3, sh, sw), &Device::Cpu)?,
        minimap: Tensor::rand(0f32, 1f32, (n, 3, mh, mw), &Device::Cpu)?,
        text: cfg
            .obs
            .text()
            .then(|| Tensor::rand(0f32, 1f32, (n, avacraft_marl::encoders::text_width(&shape)), &Device::Cpu))
            .transpose()?,
    };
    println!("{} weights, {n} frames {sw}x{sh} + {mw}x{mh}", p.count());
    for _ in 0..2 {
        let t = Instant::now();
        let y = enc.forward(&f)?;
        let fwd = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let _g = y.sqr()?.mean_all()?.backward()?;
        println!("forward {fwd:.3} s, backward {:.3} s", t.elapsed().as_secs_f64());
    }
    Ok(())
}
