//! The fused network against candle's autograd on the crate's reference network
//! ([`crate::nets::AgentNet`]), and the same bits whatever the number of threads.

use super::{NetLayout, Want};
use crate::Error;
use crate::nets::AgentNet;
use crate::params::Params;
use candle_core::{Device, Tensor, Var};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random(n: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-1f32..1.0)).collect()
}

struct Case {
    layout: NetLayout,
    l: usize,
    n: usize,
    x: Vec<f32>,
    h0: Vec<f32>,
    keep: Vec<f32>,
    /// Weights of the test loss `sum(out * w_out) + sum(hidden * w_hid)`.
    w_out: Vec<f32>,
    w_hid: Vec<f32>,
}

/// The networks checked: (recurrent, the MAPPO repository's layer-normalised form).
const KINDS: [(bool, bool); 4] = [(true, false), (false, false), (true, true), (false, true)];

fn case((recurrent, norm): (bool, bool), rng: &mut ChaCha8Rng) -> (Case, AgentNet, Params) {
    let (input, hidden, out, l, n) = (7, 5, 4, 6, 50);
    let mut p = Params::default();
    let net = match (recurrent, norm) {
        // A gain of 1 on the output layer: the policy's 0.01 would leave its gradients tiny.
        (_, true) => AgentNet::normed(&mut p, input, hidden, out, recurrent, 1.0, rng),
        (true, false) => AgentNet::new(&mut p, input, hidden, out, rng),
        (false, false) => AgentNet::feed_forward(&mut p, input, hidden, out, rng),
    }
    .unwrap_or_else(|e| panic!("{e}"));
    if norm {
        // Random weights in place of the zero biases and unit scales it starts with: with
        // those, a row whose ReLUs are all off feeds exact zeros to the next layer, where
        // candle's ReLU has slope 1 (PyTorch's and the kernel's: 0).
        let theta = random(net.layout().len(), rng);
        p.set_flat(net.var_count(), &theta).unwrap_or_else(|e| panic!("{e}"));
    }
    let keep = (0..l * n).map(|_| if rng.random_bool(0.2) { 0.0 } else { 1.0 }).collect();
    let c = Case {
        layout: net.layout(),
        l,
        n,
        x: random(l * n * input, rng),
        h0: random(n * hidden, rng),
        keep,
        w_out: random(l * n * out, rng),
        w_hid: random(l * n * hidden, rng),
    };
    (c, net, p)
}

/// Row `row`'s values of a `(rows, width)` array set to 0 where `unread(row)`.
fn zero_rows(w: &[f32], width: usize, unread: &dyn Fn(usize) -> bool) -> Vec<f32> {
    let mut w = w.to_vec();
    for (row, values) in w.chunks_exact_mut(width).enumerate() {
        if unread(row) {
            values.fill(0.0);
        }
    }
    w
}

impl Case {
    /// The same case whose test loss reads no row `unread` picks (its weights there 0).
    fn reading(&self, unread: &dyn Fn(usize) -> bool) -> Case {
        Case {
            layout: self.layout,
            l: self.l,
            n: self.n,
            x: self.x.clone(),
            h0: self.h0.clone(),
            keep: self.keep.clone(),
            w_out: zero_rows(&self.w_out, self.layout.out, unread),
            w_hid: zero_rows(&self.w_hid, self.layout.hidden, unread),
        }
    }
}

/// Candle's pass: the learners' unroll (hidden state times `keep` before each step after the
/// first), the test loss, its gradients.
/// Outputs, parameter gradients and input gradients.
type Passes = (Vec<f32>, Vec<f32>, Vec<f32>);

fn reference(c: &Case, net: &AgentNet, p: &Params) -> Result<Passes, Error> {
    let dev = Device::Cpu;
    let (l, n, h) = (c.l, c.n, c.layout.hidden);
    let x = Var::from_slice(&c.x, (l * n, c.layout.input), &dev)?;
    let gi = net.project(x.as_tensor())?.reshape((l, n, ()))?;
    let keep = Tensor::from_slice(&c.keep, (l, n, 1), &dev)?;
    let mut hcur = Tensor::from_slice(&c.h0, (n, h), &dev)?;
    let mut hs = Vec::new();
    for t in 0..l {
        if t > 0 && net.is_recurrent() {
            hcur = hcur.broadcast_mul(&keep.get(t)?)?;
        }
        hcur = net.recur(&gi.get(t)?, &hcur)?;
        hs.push(hcur.clone());
    }
    let hs = Tensor::stack(&hs, 0)?.reshape((l * n, h))?;
    let out = net.head(&hs)?;
    let loss = ((&out * Tensor::from_slice(&c.w_out, out.dims(), &dev)?)?.sum_all()?
        + (&hs * Tensor::from_slice(&c.w_hid, hs.dims(), &dev)?)?.sum_all()?)?;
    let grads = loss.backward()?;
    let mut g = Vec::new();
    for v in p.vars() {
        let gv = grads.get(v).map(|t| t.flatten_all().and_then(|t| t.to_vec1::<f32>())).transpose()?;
        g.extend(gv.unwrap_or_else(|| vec![0.0; v.elem_count()]));
    }
    let dx = grads.get(&x).map(|t| t.flatten_all().and_then(|t| t.to_vec1::<f32>())).transpose()?.unwrap_or_default();
    Ok((out.flatten_all()?.to_vec1()?, g, dx))
}

fn close(what: &str, got: &[f32], want: &[f32], tol: f32) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    let scale = want.iter().fold(0f32, |m, v| m.max(v.abs())).max(1e-3);
    for (i, (a, b)) in got.iter().zip(want).enumerate() {
        assert!((a - b).abs() <= tol * scale, "{what}[{i}]: fused {a}, candle {b} (scale {scale})");
    }
}

#[test]
fn fused_passes_match_candles_autograd() -> Result<(), Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for kind in KINDS {
        let (c, net, p) = case(kind, &mut rng);
        let theta = p.flat(net.var_count())?;
        assert_eq!(theta.len(), c.layout.len());
        let f = c.layout.forward(&theta, &c.x, &c.h0, Some(&c.keep), Want::All, c.l, c.n, true);
        let (out, g_ref, dx_ref) = reference(&c, &net, &p)?;
        close("outputs", &f.out, &out, 1e-5);
        let mut g = vec![0f32; c.layout.len()];
        let dx = c.layout.backward(&theta, &f, &c.w_out, Some(&c.w_hid), &mut g, true).unwrap_or_default();
        close(&format!("parameter gradients ({kind:?})"), &g, &g_ref, 2e-5);
        close("input gradients", &dx, &dx_ref, 2e-5);
        // Padding skipped (in any order of lengths), the padded rows' loss weights 0.
        let lens: Vec<usize> = (0..c.n).map(|_| rng.random_range(1..=c.l)).collect();
        let padding = |row: usize| row / c.n >= lens[row % c.n];
        let cp = c.reading(&padding);
        let fp = cp.layout.forward(&theta, &cp.x, &cp.h0, Some(&cp.keep), Want::Lens(&lens), cp.l, cp.n, true);
        let (out_all, g_ref, _) = reference(&cp, &net, &p)?;
        close("outputs of real steps", &fp.out, &zero_rows(&out_all, cp.layout.out, &padding), 1e-5);
        let mut g = vec![0f32; cp.layout.len()];
        cp.layout.backward(&theta, &fp, &cp.w_out, Some(&cp.w_hid), &mut g, false);
        close(&format!("parameter gradients without padding ({kind:?})"), &g, &g_ref, 2e-5);
        // A single step without a tape gives the same outputs as the first step with one.
        let one = c.layout.forward(&theta, &c.x[..c.n * c.layout.input], &c.h0, None, Want::All, 1, c.n, false);
        close("one step", &one.out, &f.out[..c.n * c.layout.out], 1e-6);
    }
    Ok(())
}

/// Rows left out by a mask (PPO's dead agents) are skipped where nothing read depends on
/// them, and the rows read get candle's full pass: outputs, every parameter's gradient and
/// the input gradients, the same bits on 1 and 3 threads.
#[test]
fn masked_rows_are_skipped_and_the_rest_match_candle() -> Result<(), Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for kind in KINDS {
        let (c, net, p) = case(kind, &mut rng);
        let theta = p.flat(net.var_count())?;
        // Each sequence dies at a random step and stays dead until an episode starts (keep 0);
        // a few rows in between are left out too, while later rows still read them.
        let mut mask = vec![1f32; c.l * c.n];
        for i in 0..c.n {
            let mut dead = false;
            let death = rng.random_range(0..c.l + 2);
            for t in 0..c.l {
                if t > 0 && c.keep[t * c.n + i] == 0.0 {
                    dead = false;
                }
                dead |= t == death;
                if dead || rng.random_bool(0.1) {
                    mask[t * c.n + i] = 0.0;
                }
            }
        }
        let unread = |row: usize| mask[row] == 0.0;
        let cm = c.reading(&unread);
        let (out_ref, g_ref, dx_ref) = reference(&cm, &net, &p)?;
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap_or_else(|e| panic!("{e}"));
            pool.install(|| {
                let f = cm.layout.forward(&theta, &cm.x, &cm.h0, Some(&cm.keep), Want::Mask(&mask), cm.l, cm.n, true);
                let mut g = vec![0f32; cm.layout.len()];
                let dx = cm.layout.backward(&theta, &f, &cm.w_out, Some(&cm.w_hid), &mut g, true).unwrap_or_default();
                (f.out, g, dx)
            })
        };
        let (out, g, dx) = run(1);
        let what = format!("{kind:?}");
        let o = cm.layout.out;
        close(&format!("outputs read ({what})"), &zero_rows(&out, o, &unread), &zero_rows(&out_ref, o, &unread), 1e-5);
        close(&format!("parameter gradients ({what})"), &g, &g_ref, 2e-5);
        close(&format!("input gradients ({what})"), &dx, &dx_ref, 2e-5);
        // Rows were skipped: rows not read with no output at all (candle's are never all 0).
        let skipped = (0..c.l * c.n).filter(|&r| mask[r] == 0.0 && out[r * o..(r + 1) * o].iter().all(|&v| v == 0.0)).count();
        let unread = mask.iter().filter(|&&m| m == 0.0).count();
        assert!(skipped > unread / 3 && skipped <= unread, "{skipped} rows skipped of {unread} not read ({what})");
        assert!(run(3) == (out, g, dx), "3 threads changed the masked passes ({what})");
    }
    Ok(())
}

/// Rows given as a shared table plus one-hot ids give the passes of the same rows written
/// out: outputs, every parameter's gradient (the table's columns of `W1` and the ids') and
/// the input gradients, with resets and padding, on any number of threads.
#[test]
fn shared_table_rows_match_the_rows_written_out() -> Result<(), Error> {
    use super::Input;
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for kind in KINDS {
        let (c, net, p) = case(kind, &mut rng);
        let theta = p.flat(net.var_count())?;
        let (i, ids_n) = (c.layout.input, 3);
        let width = i - ids_n;
        // 20 table rows, read by the 300 rows unevenly (some rows never, some many times).
        let table = random(20 * width, &mut rng);
        let idx: Vec<u32> = (0..c.l * c.n).map(|_| rng.random_range(0..20u32).min(rng.random_range(0..20u32))).collect();
        let ids: Vec<u32> = (0..c.l * c.n).map(|_| rng.random_range(0..ids_n as u32)).collect();
        let mut x = vec![0f32; c.l * c.n * i];
        for (r, row) in x.chunks_exact_mut(i).enumerate() {
            row[..width].copy_from_slice(&table[idx[r] as usize * width..][..width]);
            row[width + ids[r] as usize] = 1.0;
        }
        let shared = Input::Shared { table: &table, width, idx: &idx, ids: &ids };
        let mut lens: Vec<usize> = (0..c.n).map(|_| rng.random_range(1..=c.l)).collect();
        lens.sort_by(|a, b| b.cmp(a));
        for want in [Want::All, Want::Lens(&lens)] {
            let dense = c.layout.forward(&theta, &x, &c.h0, Some(&c.keep), want, c.l, c.n, true);
            let mut g_dense = vec![0f32; c.layout.len()];
            let dx_dense = c.layout.backward(&theta, &dense, &c.w_out, Some(&c.w_hid), &mut g_dense, true).unwrap_or_default();
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap_or_else(|e| panic!("{e}"));
                pool.install(|| {
                    let f = c.layout.forward_input(&theta, shared, &c.h0, Some(&c.keep), want, c.l, c.n, true);
                    let mut g = vec![0f32; c.layout.len()];
                    let dx = c.layout.backward(&theta, &f, &c.w_out, Some(&c.w_hid), &mut g, true).unwrap_or_default();
                    let hidden = f.hidden_states();
                    (f.out, hidden, g, dx)
                })
            };
            let (out, hidden, g, dx) = run(1);
            let what = format!("{kind:?}, padding {}", matches!(want, Want::Lens(_)));
            close(&format!("outputs ({what})"), &out, &dense.out, 1e-5);
            close(&format!("hidden states ({what})"), &hidden, &dense.hidden_states(), 1e-5);
            close(&format!("parameter gradients ({what})"), &g, &g_dense, 1e-5);
            close(&format!("input gradients ({what})"), &dx, &dx_dense, 1e-5);
            assert!(run(3) == (out, hidden, g, dx), "3 threads changed the shared-table passes ({what})");
        }
    }
    Ok(())
}

#[test]
fn results_do_not_depend_on_the_thread_count() -> Result<(), Error> {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let (c, net, p) = case((true, true), &mut rng);
    let theta = p.flat(net.var_count())?;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap_or_else(|e| panic!("{e}"));
        pool.install(|| {
            let f = c.layout.forward(&theta, &c.x, &c.h0, Some(&c.keep), Want::All, c.l, c.n, true);
            let mut g = vec![0f32; c.layout.len()];
            let dx = c.layout.backward(&theta, &f, &c.w_out, Some(&c.w_hid), &mut g, true);
            (f.out, g, dx)
        })
    };
    let one = run(1);
    assert!(NetLayout::chunk_count(c.n) > 1, "the case must cut its sequences into several chunks");
    for threads in [2, 3] {
        assert!(run(threads) == one, "{threads} threads changed the results");
    }
    Ok(())
}

/// The flat Adam takes candle's `AdamW` steps (no weight decay), and clipping scales the
/// norm down to its bound.
#[test]
fn flat_adam_matches_candles_and_clipping_bounds_the_norm() -> Result<(), Error> {
    use candle_nn::Optimizer as _;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let start = random(40, &mut rng);
    let var = Var::from_slice(&start, 40, &Device::Cpu)?;
    let params = candle_nn::ParamsAdamW { lr: 0.01, eps: 1e-5, weight_decay: 0.0, ..candle_nn::ParamsAdamW::default() };
    let mut reference = candle_nn::AdamW::new(vec![var.clone()], params)?;
    let mut flat = start.clone();
    let mut adam = super::Adam::new(40, 0.01, 1e-5);
    for _ in 0..5 {
        let g = random(40, &mut rng);
        let loss = (var.as_tensor() * Tensor::from_slice(&g, 40, &Device::Cpu)?)?.sum_all()?;
        reference.step(&loss.backward()?)?;
        adam.step(&mut flat, &g);
    }
    close("Adam", &flat, &var.as_tensor().to_vec1::<f32>()?, 1e-6);
    let mut g = vec![3.0f32, 4.0];
    assert_eq!(super::clip_global_norm(&mut g, 10.0), 5.0);
    assert_eq!(g, [3.0, 4.0]);
    assert!((super::clip_global_norm(&mut g, 1.0) - 5.0).abs() < 1e-12);
    assert!((g[0].hypot(g[1]) - 1.0).abs() < 1e-5);
    Ok(())
}

/// The fused QMIX mixer against candle's (`nets::QmixMixer`): `Q_tot`, every parameter's
/// gradient and the agents' Q-values' gradient, for one- and two-layer hypernetworks.
#[test]
fn fused_mixer_matches_candles_autograd() -> Result<(), Error> {
    use super::MixerLayout;
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for layers in [1usize, 2] {
        let (a, s, n) = (3, 11, 300);
        let mut cfg = crate::Config::for_algo("qmix", &[])?;
        (cfg.mixing_embed_dim, cfg.hypernet_layers, cfg.hypernet_embed) = (8, layers, 12);
        let mut p = Params::default();
        let mixer = crate::nets::QmixMixer::new(&mut p, a, s, &cfg, &mut rng)?;
        let layout = MixerLayout { n_agents: a, state: s, embed: 8, hyper_embed: 12, two_layer: layers == 2 };
        let theta = p.flat(p.vars().count())?;
        assert_eq!(theta.len(), layout.len());
        let (q, st, w) = (random(n * a, &mut rng), random(n * s, &mut rng), random(n, &mut rng));
        let dev = Device::Cpu;
        let qv = Var::from_slice(&q, (n, a), &dev)?;
        let out = mixer.forward(qv.as_tensor(), &Tensor::from_slice(&st, (n, s), &dev)?)?;
        let loss = (&out * Tensor::from_slice(&w, (n, 1), &dev)?)?.sum_all()?;
        let grads = loss.backward()?;
        let mut g_ref = Vec::new();
        for v in p.vars() {
            let gv = grads.get(v).map(|t| t.flatten_all().and_then(|t| t.to_vec1::<f32>())).transpose()?;
            g_ref.extend(gv.unwrap_or_else(|| vec![0.0; v.elem_count()]));
        }
        let dq_ref = grads.get(&qv).map(|t| t.flatten_all().and_then(|t| t.to_vec1::<f32>())).transpose()?.unwrap_or_default();
        let f = layout.forward(&theta, &q, &st, n, true);
        close(&format!("Q_tot ({layers} layers)"), &f.out, &out.flatten_all()?.to_vec1()?, 1e-5);
        let mut g = vec![0f32; layout.len()];
        let dq = layout.backward(&theta, &f, &w, &mut g);
        close(&format!("mixer gradients ({layers} layers)"), &g, &g_ref, 2e-5);
        close(&format!("Q gradients ({layers} layers)"), &dq, &dq_ref, 2e-5);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap_or_else(|e| panic!("{e}"));
        let g3 = pool.install(|| {
            let f = layout.forward(&theta, &q, &st, n, true);
            let mut g = vec![0f32; layout.len()];
            layout.backward(&theta, &f, &w, &mut g);
            g
        });
        assert!(g3 == g, "3 threads changed the mixer's gradients");
    }
    Ok(())
}
