//! The image and text encoders of the rgb, hybrid and vision-text modes: shapes, adaptive
//! pooling, gradients, seeding, and short end-to-end runs on 3m_vlm (the text features
//! themselves: `tests/it/text.rs`).

use avacraft_engine::Scenario;
use avacraft_marl::encoders::layers::adaptive_avg_pool2d;
use avacraft_marl::encoders::text::{MiniLm, PIP_INSTALL};
use avacraft_marl::encoders::{FrameTensors, ObsEncoder, SwinSizes, text_width};
use avacraft_marl::nets::Params;
use avacraft_marl::{Config, MarlAgent, Nets, Policy, RunOptions, Shape, train};
use candle_core::{DType, Device, Tensor};
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

const SHAPE: Shape = Shape { n_agents: 3, obs: 30, state: 48, n_actions: 9, n_enemies: 3 };

fn cfg(extra: &[&str]) -> Result<Config, avacraft_marl::Error> {
    Config::for_algo("qmix", &extra.iter().map(|s| s.to_string()).collect::<Vec<_>>())
}

/// `n` frames of the given sizes with a seeded pattern (and text embeddings when `text`).
fn frames(n: usize, (sw, sh): (usize, usize), (mw, mh): (usize, usize), text: bool) -> Result<FrameTensors, candle_core::Error> {
    let pattern = |len: usize, k: usize| (0..len).map(|i| ((i * 37 + k * 11) % 255) as f32 / 255.0).collect::<Vec<f32>>();
    Ok(FrameTensors {
        screen: Tensor::from_vec(pattern(n * 3 * sh * sw, 1), (n, 3, sh, sw), &Device::Cpu)?,
        minimap: Tensor::from_vec(pattern(n * 3 * mh * mw, 2), (n, 3, mh, mw), &Device::Cpu)?,
        text: if text { Some(Tensor::from_vec(pattern(n * text_width(&SHAPE), 3), (n, text_width(&SHAPE)), &Device::Cpu)?) } else { None },
    })
}

#[test]
fn encoders_give_their_widths_for_every_backbone_and_frame_size() -> R {
    for (extra, text) in [
        (vec!["obs=rgb"], false),
        (vec!["obs=hybrid", "encoder=swin"], false),
        (vec!["obs=\"vision-text\"", "encoder=swin", "swin_window=4"], true),
        (vec!["obs=\"vision-text\"", "cnn_channels=[8]", "cnn_pool=2", "encoder_dim=16", "text_dim=8"], true),
    ] {
        let c = cfg(&extra)?;
        let nets = Nets::new(&c, &SHAPE, 1)?;
        let enc = nets.encoder.as_ref().ok_or("no encoder")?;
        assert_eq!(enc.out, c.encoder_dim + if text { c.text_dim } else { 0 });
        // The default 80x60 and the paper's 160x120 screen give the same width.
        for (screen, minimap) in [((80, 60), (32, 32)), ((160, 120), (32, 32)), ((37, 23), (9, 13))] {
            let y = enc.forward(&frames(2, screen, minimap, text)?)?;
            assert_eq!(y.dims(), &[2, enc.out], "{extra:?} {screen:?}");
            let v: Vec<f32> = y.flatten_all()?.to_vec1()?;
            assert!(v.iter().all(|x| x.is_finite()));
        }
        // The agent network reads the encoder's features (and the SMAC features in hybrid).
        let x = Tensor::zeros((2 * SHAPE.n_agents, SHAPE.input(true, true)), DType::F32, &Device::Cpu)?;
        let inputs = nets.step_inputs(x, Some(&frames(2, (80, 60), (32, 32), text)?))?;
        let base = SHAPE.n_agents + SHAPE.n_actions + if c.obs.features() { SHAPE.obs } else { 0 };
        assert_eq!(inputs.dims(), &[2 * SHAPE.n_agents, enc.out + base]);
        let (q, _) = nets.agent.step(&inputs, &nets.agent.zero_hidden(2 * SHAPE.n_agents)?)?;
        assert_eq!(q.dims(), &[2 * SHAPE.n_agents, SHAPE.n_actions]);
    }
    Ok(())
}

#[test]
fn swin_tiny_has_swin_tinys_size() -> R {
    // Swin-Tiny: 28.3M weights with its 1000-class head, 27.5M without (one stream here).
    let mut p = Params::default();
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(0);
    let s = avacraft_marl::encoders::swin::SwinStream::new(&mut p, "s", &SwinSizes::tiny(), &mut rng)?;
    assert_eq!(s.out, 768);
    let n = p.count() as f64 / 1e6;
    assert!((27.4..27.7).contains(&n), "{n}M weights");
    Ok(())
}

#[test]
fn adaptive_pooling_matches_pytorchs_bins_for_any_size() -> R {
    for (h, w) in [(6usize, 8usize), (5, 7), (3, 2)] {
        let data: Vec<f32> = (0..h * w).map(|i| i as f32).collect();
        let x = Tensor::from_vec(data.clone(), (1, 1, h, w), &Device::Cpu)?;
        let y = adaptive_avg_pool2d(&x, 4, 4)?;
        assert_eq!(y.dims(), &[1, 1, 4, 4]);
        let y: Vec<f32> = y.flatten_all()?.to_vec1()?;
        for i in 0..4 {
            for j in 0..4 {
                let (r0, r1) = (i * h / 4, ((i + 1) * h).div_ceil(4));
                let (c0, c1) = (j * w / 4, ((j + 1) * w).div_ceil(4));
                let mut sum = 0.0;
                for r in r0..r1 {
                    for c in c0..c1 {
                        sum += data[r * w + c];
                    }
                }
                let want = sum / ((r1 - r0) * (c1 - c0)) as f32;
                assert!((y[i * 4 + j] - want).abs() < 1e-4, "{h}x{w} bin ({i}, {j}): {} vs {want}", y[i * 4 + j]);
            }
        }
    }
    Ok(())
}

#[test]
fn gradients_reach_the_convolutions_and_an_update_lowers_the_loss() -> R {
    for backbone in ["cnn", "swin"] {
        let c = cfg(&["obs=rgb", &format!("encoder={backbone}"), "swin_window=4"])?;
        let mut p = Params::default();
        let enc = ObsEncoder::for_config(&c, &SHAPE, &mut p, 3)?.ok_or("no encoder")?;
        let f = frames(4, (40, 30), (16, 16), false)?;
        let target = Tensor::from_vec((0..4 * enc.out).map(|i| (i % 7) as f32 / 7.0).collect::<Vec<_>>(), (4, enc.out), &Device::Cpu)?;
        let loss = |e: &ObsEncoder| -> Result<Tensor, Box<dyn std::error::Error>> { Ok((e.forward(&f)? - &target)?.sqr()?.mean_all()?) };
        let l0 = loss(&enc)?;
        let grads = l0.backward()?;
        // The first weight of the screen stream: the first convolution's kernel, or Swin's
        // patch embedding.
        let first = p.vars().next().ok_or("no weights")?;
        let g = grads.get(first).ok_or("no gradient reached the first layer")?;
        assert!(g.abs()?.sum_all()?.to_scalar::<f32>()? > 0.0, "{backbone}");
        // A small step against the gradient (RMSprop's first steps are sign steps of lr
        // size: too coarse for this check).
        let norm: f32 =
            p.vars().filter_map(|v| grads.get(v)).map(|g| g.sqr()?.sum_all()?.to_scalar::<f32>()).sum::<Result<f32, _>>()?.sqrt();
        for v in p.vars() {
            if let Some(g) = grads.get(v) {
                v.set(&(v.as_tensor() - (g * f64::from(1e-2 / norm))?)?)?;
            }
        }
        let (before, after) = (l0.to_scalar::<f32>()?, loss(&enc)?.to_scalar::<f32>()?);
        assert!(after < before, "{backbone}: loss {before} -> {after}");
    }
    Ok(())
}

#[test]
fn a_seed_fixes_every_weight() -> R {
    for extra in [vec!["obs=rgb"], vec!["obs=hybrid", "encoder=swin"], vec!["obs=\"vision-text\""]] {
        let c = cfg(&extra)?;
        let (a, b, other) = (Nets::new(&c, &SHAPE, 7)?, Nets::new(&c, &SHAPE, 7)?, Nets::new(&c, &SHAPE, 8)?);
        let (ma, mb, mo) = (a.agent_params.to_map(), b.agent_params.to_map(), other.agent_params.to_map());
        assert!(ma.keys().any(|k| k.starts_with("encoder.screen")) && ma.keys().any(|k| k.starts_with("encoder.minimap")));
        let mut differs = false;
        for (k, t) in &ma {
            let u = mb.get(k).ok_or("missing weight")?;
            assert!(t.flatten_all()?.to_vec1::<f32>()? == u.flatten_all()?.to_vec1::<f32>()?, "{k}");
            let o = mo.get(k).ok_or("missing weight")?.flatten_all()?.to_vec1::<f32>()?;
            differs |= t.flatten_all()?.to_vec1::<f32>()? != o;
        }
        assert!(differs, "another seed draws other weights");
    }
    // The encoder draws from a stream of its own: the same backbone has the same weights in
    // every image mode, whatever the agent network's input width.
    let w = |extra: &[&str]| -> Result<Vec<f32>, Box<dyn std::error::Error>> {
        let m = Nets::new(&cfg(extra)?, &SHAPE, 7)?.agent_params.to_map();
        Ok(m.get("encoder.screen.conv0.weight").ok_or("no conv0")?.flatten_all()?.to_vec1::<f32>()?)
    };
    assert!(w(&["obs=rgb"])? == w(&["obs=hybrid"])?);
    Ok(())
}

/// The source draws its environments in parallel parts: the frames are the renderer's
/// `Observer`'s, environment by environment, in order.
#[test]
fn parallel_frames_are_the_observers() -> R {
    use avacraft_engine::{Team, VecEnv};
    use avacraft_render::{ObsMode, Observer, RenderConfig};
    let c = cfg(&["obs=rgb", "screen_size=[40, 30]", "minimap_size=[16, 12]"])?;
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    let mut env = VecEnv::new(scenario, c.env_config()?, &[1, 2, 3, 4, 5], 1)?;
    let mut source = avacraft_marl::ObsSource::with_text(&c, None);
    let mut observer = Observer::new(ObsMode::Rgb, RenderConfig::default().with_screen(40, 30).with_minimap(16, 12));
    for _ in 0..3 {
        let f = source.observe(env.envs())?;
        let (mut screen, mut minimap) = (Vec::new(), Vec::new());
        for e in env.envs() {
            screen.extend_from_slice(observer.screen(e, Team::One).as_raw());
            minimap.extend_from_slice(observer.minimap(e, Team::One).as_raw());
        }
        assert!(f.screen == screen && f.minimap == minimap, "the parallel parts drew other frames");
        let na = env.shape().3.max(1);
        let actions: Vec<i64> = env.buffers.avail.chunks(na).map(|m| m.iter().rposition(|&a| a == 1).map_or(0, |i| i as i64)).collect();
        env.step(&actions)?;
    }
    Ok(())
}

fn short_run(obs: &str, steps: u64, limit: u32, extra: &[&str]) -> R {
    short_run_of("qmix", obs, steps, limit, extra)
}

fn short_run_of(algo: &str, obs: &str, steps: u64, limit: u32, extra: &[&str]) -> R {
    let dir = std::env::temp_dir().join(format!("avacraft-marl-{algo}-{obs}-{}", std::process::id()));
    let small: &[&str] = if algo.ends_with("ppo") {
        &["envs=2", "rollout_len=10", "data_chunk_length=5", "ppo_epochs=2", "test_interval=100000", "test_nepisode=2"]
    } else {
        &["envs=2", "batch_size=2", "buffer_size=16", "test_interval=100000", "test_nepisode=2", "epsilon_anneal_time=200"]
    };
    let mut o: Vec<String> = small.iter().map(|s| s.to_string()).collect();
    o.push(format!("t_max={steps}"));
    o.push(format!("episode_limit={limit}"));
    o.push(format!("obs=\"{obs}\""));
    o.extend(extra.iter().map(|s| s.to_string()));
    let c = Config::for_algo(algo, &o)?;
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 2, threads: 2, out: Some(dir.clone()) };
    let (learner, summary) = train(&c, &opts, &mut |_| {})?;
    assert!(summary.t_env >= steps && summary.updates > 0 && summary.last_loss.is_finite(), "{summary:?}");
    // The checkpoint holds the encoder; it loads with identical weights and plays greedy
    // episodes from frames, and an engine agent refuses it with a reason.
    let policy = Policy::load(&dir)?;
    let enc_weights = learner.nets().agent_params.to_map();
    let loaded = policy.nets.agent_params.to_map();
    assert!(enc_weights.keys().any(|k| k.starts_with("encoder.")));
    // The encoder learned: its weights moved from the ones the run started with.
    let start = Nets::new(&c, &learner.shape(), 2)?.agent_params.to_map();
    let moved = enc_weights.iter().filter(|(k, _)| k.starts_with("encoder.")).try_fold(false, |any, (k, t)| {
        Ok::<_, candle_core::Error>(any || t.flatten_all()?.to_vec1::<f32>()? != start[k].flatten_all()?.to_vec1::<f32>()?)
    })?;
    assert!(moved, "{algo} {obs}: no encoder weight changed");
    for (k, t) in &enc_weights {
        assert_eq!(t.flatten_all()?.to_vec1::<f32>()?, loaded.get(k).ok_or("missing")?.flatten_all()?.to_vec1::<f32>()?, "{k}");
    }
    let r = policy.evaluate(&scenario, &[11], 1)?;
    assert_eq!(r, train::test(learner.nets(), &c, &scenario, &[11], 1)?);
    let e = MarlAgent::load(&dir).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains(obs) && e.contains("features"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn a_short_rgb_qmix_run_on_3m_completes() -> R {
    short_run("rgb", 300, 30, &[])
}

#[test]
fn a_short_rgb_mappo_run_on_3m_completes() -> R {
    // The actor sees the frames through the encoder; the critic keeps the state.
    short_run_of("mappo", "rgb", 100, 30, &[])
}

#[test]
fn a_short_hybrid_ippo_run_on_3m_completes() -> R {
    short_run_of("ippo", "hybrid", 100, 30, &[])
}

#[test]
fn a_short_vision_text_run_on_3m_completes() -> R {
    MiniLm::load().map_err(|e| format!("{e} (the test needs it: `{PIP_INSTALL}`)"))?;
    // The warm-up embeds a few hundred clauses; no file outside the test.
    short_run("vision-text", 100, 20, &["encoder=swin", "swin_depths=[1, 1]", "text_disk_cache=false"])
}
