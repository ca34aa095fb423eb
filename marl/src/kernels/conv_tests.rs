//! The fused CNN encoder against candle's autograd on the reference encoder
//! ([`crate::ObsEncoder`] with the CNN backbone), and the same bits whatever the number of
//! threads.

use super::{EncoderLayout, Pixels};
use crate::encoders::ObsEncoder;
use crate::frames::StepFrames;
use crate::params::Params;
use crate::{Config, Error, Shape};
use candle_core::Tensor;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SHAPE: Shape = Shape { n_agents: 3, obs: 30, state: 48, n_actions: 9, n_enemies: 3 };

/// An encoder of `cfg` overrides, its layout and weights, and `n` random frames (with text
/// embeddings in `vision-text`).
type Case = (ObsEncoder, Params, EncoderLayout, Vec<f32>, StepFrames);

fn case(extra: &[&str], n: usize, rng: &mut ChaCha8Rng) -> Result<Case, Error> {
    let cfg = Config::for_algo("qmix", &extra.iter().map(|s| s.to_string()).collect::<Vec<_>>())?;
    let mut p = Params::default();
    let enc = ObsEncoder::for_config(&cfg, &SHAPE, &mut p, 5)?.ok_or_else(|| Error::Observation { message: "no encoder".into() })?;
    let layout = enc.kernel().cloned().ok_or_else(|| Error::Observation { message: "no fused kernels".into() })?;
    let theta = p.flat(p.len())?;
    assert_eq!(theta.len(), layout.len(), "{extra:?}: parameter count");
    let [sw, sh] = cfg.screen_size.map(|v| v as usize);
    let [mw, mh] = cfg.minimap_size.map(|v| v as usize);
    let bytes = |len: usize, rng: &mut ChaCha8Rng| (0..len).map(|_| rng.random_range(0..=255u8)).collect::<Vec<u8>>();
    let mut frames = StepFrames::from_pixels(n, ((sw, sh), (mw, mh)), bytes(n * sw * sh * 3, rng), bytes(n * mw * mh * 3, rng));
    if cfg.obs.text() {
        frames.text = (0..n * crate::encoders::text_width(&SHAPE)).map(|_| rng.random_range(-0.2f32..0.2)).collect();
    }
    Ok((enc, p, layout, theta, frames))
}

/// Candle's features of the frames and the gradients of `sum(features * w)` for every
/// encoder variable, flat in their order.
fn reference(enc: &ObsEncoder, p: &Params, frames: &StepFrames, w: &[f32]) -> Result<(Vec<f32>, Vec<f32>), Error> {
    let y = enc.forward(&frames.tensors()?)?;
    let loss = (&y * Tensor::from_slice(w, y.dims(), y.device())?)?.sum_all()?;
    let grads = loss.backward()?;
    let mut g = Vec::new();
    for v in p.vars() {
        let gv = grads.get(v).map(|t| t.flatten_all().and_then(|t| t.to_vec1::<f32>())).transpose()?;
        g.extend(gv.unwrap_or_else(|| vec![0.0; v.elem_count()]));
    }
    Ok((y.flatten_all()?.to_vec1()?, g))
}

/// Each variable's slice of the flat vector compared at its own scale (a small kernel's
/// gradient must not hide behind the head's larger one).
fn close(what: &str, got: &[f32], want: &[f32], tol: f32) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    let scale = want.iter().fold(0f32, |m, v| m.max(v.abs())).max(1e-4);
    for (i, (a, b)) in got.iter().zip(want).enumerate() {
        assert!((a - b).abs() <= tol * scale, "{what}[{i}]: fused {a}, candle {b} (scale {scale})");
    }
}

const CASES: [&[&str]; 5] = [
    &["obs=rgb"],
    &["obs=rgb", "screen_size=[37, 23]", "minimap_size=[9, 13]"],
    &["obs=\"vision-text\""],
    &["obs=\"vision-text\"", "screen_size=[37, 23]", "minimap_size=[9, 13]", "text_dim=7"],
    &["obs=hybrid", "cnn_channels=[5, 6, 4]", "cnn_pool=3", "encoder_dim=10", "screen_size=[41, 29]", "minimap_size=[16, 11]"],
];

#[test]
fn fused_encoder_matches_candles_autograd() -> Result<(), Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for extra in CASES {
        let n = 21;
        let (enc, p, layout, theta, frames) = case(extra, n, &mut rng)?;
        let w: Vec<f32> = (0..n * enc.out).map(|_| rng.random_range(-1f32..1.0)).collect();
        let (y_ref, g_ref) = reference(&enc, &p, &frames, &w)?;
        let mut f = layout.forward(&theta, &frames.pixels(), true)?;
        close(&format!("{extra:?}: features"), &f.out, &y_ref, 1e-6);
        let mut g = vec![0f32; layout.len()];
        layout.backward(&theta, &mut f, &frames.pixels(), &w, &mut g);
        let mut at = 0;
        for v in p.vars() {
            let len = v.elem_count();
            close(&format!("{extra:?}: gradient at {at} ({:?})", v.dims()), &g[at..at + len], &g_ref[at..at + len], 1e-5);
            at += len;
        }
        // Without a tape, and on picked frames (repeats allowed), the same features (up to
        // the products' rounding, which may depend on their row count).
        let pick = [3u32, 0, 3, 20];
        let picked = layout.forward(&theta, &Pixels { pick: Some(&pick), ..frames.pixels() }, false)?;
        let o = enc.out;
        for (r, &i) in pick.iter().enumerate() {
            let i = i as usize;
            close(&format!("{extra:?}: picked frame {i}"), &picked.out[r * o..(r + 1) * o], &f.out[i * o..(i + 1) * o], 1e-6);
        }
    }
    Ok(())
}

#[test]
fn encoder_results_do_not_depend_on_the_thread_count() -> Result<(), Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let n = 70;
    let (enc, _p, layout, theta, frames) = case(CASES[3], n, &mut rng)?;
    assert!(EncoderLayout::chunk_count(n) > 1, "the case must cut its frames into several chunks");
    let w: Vec<f32> = (0..n * enc.out).map(|_| rng.random_range(-1f32..1.0)).collect();
    let run = |threads: usize| -> Result<(Vec<f32>, Vec<f32>), Error> {
        let pool =
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| Error::Observation { message: e.to_string() })?;
        pool.install(|| {
            let mut f = layout.forward(&theta, &frames.pixels(), true)?;
            let mut g = vec![0f32; layout.len()];
            layout.backward(&theta, &mut f, &frames.pixels(), &w, &mut g);
            // A second pass reusing the first's buffers gives the same bits.
            let mut g2 = vec![0f32; layout.len()];
            layout.forward_into(&theta, &frames.pixels(), true, &mut f)?;
            layout.backward(&theta, &mut f, &frames.pixels(), &w, &mut g2);
            assert!(g == g2, "{threads} threads: reused buffers changed the gradients");
            Ok((f.out, g))
        })
    };
    let one = run(1)?;
    for threads in [2, 3] {
        assert!(run(threads)? == one, "{threads} threads changed the results");
    }
    Ok(())
}

#[test]
fn frames_of_the_wrong_size_are_refused() -> Result<(), Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (_, _p, layout, theta, frames) = case(CASES[0], 2, &mut rng)?;
    let short = Pixels { screen: &frames.screen[1..], ..frames.pixels() };
    assert!(layout.forward(&theta, &short, false).is_err());
    let pick = [2u32];
    assert!(layout.forward(&theta, &Pixels { pick: Some(&pick), ..frames.pixels() }, false).is_err());
    Ok(())
}
