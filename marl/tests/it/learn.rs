//! The learners on small hand-made data, the checkpoint format, action masking, and a short
//! end-to-end run on 3m_vlm.

use crate::common;

use avacraft_engine::Scenario;
use avacraft_marl::{Batch, Config, Episode, Learner, MarlAgent, Nets, Policy, RunOptions, Shape, select_actions, train};
use candle_core::{Device, Tensor};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

fn cfg(algo: &str, extra: &[&str]) -> Result<Config, avacraft_marl::Error> {
    let mut o: Vec<String> = vec!["target_update_interval=1000000".into()];
    o.extend(extra.iter().map(|s| s.to_string()));
    Config::for_algo(algo, &o)
}

/// Random episodes of random lengths over `shape` (every action available).
fn random_episodes(shape: &Shape, n: usize, rng: &mut ChaCha8Rng) -> Vec<Episode> {
    (0..n)
        .map(|_| {
            let mut ep = Episode::default();
            let len = rng.random_range(1..6);
            for t in 0..len {
                let obs: Vec<f32> = (0..shape.n_agents * shape.obs).map(|_| rng.random_range(-1.0..1.0)).collect();
                let state: Vec<f32> = (0..shape.state).map(|_| rng.random_range(-1.0..1.0)).collect();
                let avail = vec![1u8; shape.n_agents * shape.n_actions];
                let acts: Vec<u32> = (0..shape.n_agents).map(|_| rng.random_range(0..shape.n_actions as u32)).collect();
                ep.push_step(&obs, &state, &avail, &acts);
                ep.push_outcome(rng.random_range(0.0..2.0), t + 1 == len);
            }
            ep.close(shape, None);
            ep
        })
        .collect()
}

const SMALL: Shape = Shape { n_agents: 3, obs: 6, state: 7, n_actions: 4, n_enemies: 3 };

/// A batch refilled in the memory of a larger one holds what a new batch of the same
/// episodes holds: no value of the earlier batch is left in its padding.
#[test]
fn a_refilled_batch_is_a_new_batch() -> R {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let eps = random_episodes(&SMALL, 12, &mut rng);
    let (big, small): (Vec<&Episode>, Vec<&Episode>) = (eps.iter().collect(), eps[..3].iter().collect());
    let mut batch = Batch::new(&big, &SMALL, true, true)?;
    batch.refill(&small, &SMALL, true, true)?;
    let fresh = Batch::new(&small, &SMALL, true, true)?;
    assert_eq!(format!("{batch:?}"), format!("{fresh:?}"));
    assert!(batch.b == 3 && batch.inputs.len() < Batch::new(&big, &SMALL, true, true)?.inputs.len());
    // Refilled over memory holding anything at all (a refill writes its arrays whole rather
    // than zeroing them first): every value is written.
    for first in [&big[..], &small[..], &big[6..]] {
        for second in [&small[..], &big[..], &big[3..9]] {
            let mut batch = Batch::new(first, &SMALL, true, true)?;
            for v in [&mut batch.inputs, &mut batch.avail, &mut batch.state, &mut batch.reward, &mut batch.terminated, &mut batch.filled] {
                v.fill(7.0);
            }
            batch.actions.fill(7);
            batch.refill(second, &SMALL, true, true)?;
            assert_eq!(format!("{batch:?}"), format!("{:?}", Batch::new(second, &SMALL, true, true)?));
        }
    }
    Ok(())
}

/// The fused agent networks (what training runs) give the gradients candle's autograd gives
/// through the reference networks, for every mixer and both agent networks.
#[test]
fn fused_gradients_match_the_candle_reference() -> R {
    for (algo, extra) in [
        ("iql", &[][..]),
        ("vdn", &[]),
        ("qmix", &[]),
        ("qmix", &["use_rnn=false"]),
        ("qmix", &["td_lambda=0.6"]),
        ("qmix", &["hypernet_layers=1", "double_q=false"]),
        ("iql", &["double_q=false", "use_rnn=false"]),
    ] {
        let c = cfg(algo, extra)?;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let eps = random_episodes(&SMALL, 40, &mut rng);
        let mut refs: Vec<&Episode> = eps.iter().collect();
        // Longest first, as the replay buffer samples them (the fused pass skips the padding).
        refs.sort_by_key(|e| std::cmp::Reverse(e.len));
        assert!(refs.first().map(|e| e.len) > refs.last().map(|e| e.len), "the batch must hold padding");
        let batch = Batch::new(&refs, &SMALL, true, true)?;
        let l = Learner::new(&c, SMALL, 2)?;
        let fused = l.gradients(&batch, true)?;
        let reference = l.gradients(&batch, false)?;
        let (a, b) = (fused.loss, reference.loss);
        assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{algo} {extra:?}: loss {a} vs {b}");
        assert!((fused.td_abs - reference.td_abs).abs() <= 1e-4 * reference.td_abs.max(1.0), "{algo} {extra:?}: |td|");
        assert!((fused.q_taken - reference.q_taken).abs() <= 1e-4 * reference.q_taken.abs().max(1.0), "{algo} {extra:?}: q");
        assert_eq!(fused.grad.len(), reference.grad.len());
        let mut compared = 0;
        let mut at = 0;
        for v in l.nets.agent_params.vars().chain(l.nets.mixer_params.vars()) {
            let k = v.elem_count();
            let (g, w) = (&fused.grad[at..at + k], &reference.grad[at..at + k]);
            at += k;
            let scale = w.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-5);
            assert!(w.iter().any(|&x| x != 0.0), "{algo} {extra:?}: a variable without a gradient");
            for (x, y) in g.iter().zip(w) {
                assert!((x - y).abs() <= 1e-4 * scale, "{algo} {extra:?}: fused {x}, candle {y} (scale {scale})");
            }
            compared += 1;
        }
        assert!(compared >= 6, "{algo}: {compared} variables");
    }
    Ok(())
}

/// In the image modes the fused CNN encoder (what training runs, reading the replay
/// buffer's bytes) gives candle's gradients for every weight, the encoder's included.
#[test]
fn fused_image_gradients_match_the_candle_reference() -> R {
    use avacraft_marl::observe::{FrameBatch, StepFrames};
    let (screen, minimap) = ((19, 13), (8, 9));
    for (algo, obs) in [("qmix", "rgb"), ("vdn", "hybrid"), ("iql", "\"vision-text\"")] {
        let c = cfg(algo, &[&format!("obs={obs}"), "screen_size=[19, 13]", "minimap_size=[8, 9]", "text_dim=5"])?;
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        let mut eps = random_episodes(&SMALL, 12, &mut rng);
        for ep in &mut eps {
            for _ in 0..ep.len {
                let mut bytes = |len: usize| (0..len).map(|_| rng.random_range(0..=255u8)).collect::<Vec<u8>>();
                let (s, m) = (bytes(screen.0 * screen.1 * 3), bytes(minimap.0 * minimap.1 * 3));
                let mut f = StepFrames::from_pixels(1, (screen, minimap), s, m);
                if c.obs.text() {
                    f.text = (0..avacraft_marl::encoders::text_width(&SMALL)).map(|_| rng.random_range(-0.1f32..0.1)).collect();
                }
                ep.frames.push(&f, 0);
            }
        }
        let mut refs: Vec<&Episode> = eps.iter().collect();
        refs.sort_by_key(|e| std::cmp::Reverse(e.len));
        let mut batch = Batch::new(&refs, &SMALL, true, true)?;
        batch.frames = Some(FrameBatch::new(&refs, &c)?);
        let l = Learner::new(&c, SMALL, 2)?;
        let fused = l.gradients(&batch, true)?;
        let reference = l.gradients(&batch, false)?;
        let (a, b) = (fused.loss, reference.loss);
        assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{algo} {obs}: loss {a} vs {b}");
        let mut compared = 0;
        let mut at = 0;
        for v in l.nets.agent_params.vars().chain(l.nets.mixer_params.vars()) {
            let k = v.elem_count();
            let (g, w) = (&fused.grad[at..at + k], &reference.grad[at..at + k]);
            at += k;
            let scale = w.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-6);
            for (x, y) in g.iter().zip(w) {
                assert!((x - y).abs() <= 1e-4 * scale, "{algo} {obs} {:?}: fused {x}, candle {y} (scale {scale})", v.dims());
            }
            compared += 1;
        }
        assert!(compared >= 8 + 8, "{algo} {obs}: {compared} variables");
    }
    Ok(())
}

#[test]
fn an_update_on_a_fixed_batch_lowers_the_loss() -> R {
    for (algo, extra) in [
        ("iql", &[][..]),
        ("vdn", &[]),
        ("qmix", &[]),
        ("qtran", &[]),
        ("qmix", &["use_rnn=false"]),
        ("qmix", &["optimizer=adam", "td_lambda=0.6"]),
        ("qtran", &["optimizer=adam", "td_lambda=0.6", "use_rnn=false"]),
    ] {
        let c = cfg(algo, extra)?;
        let algo = format!("{algo} {extra:?}");
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let eps = random_episodes(&SMALL, 8, &mut rng);
        let refs: Vec<&Episode> = eps.iter().collect();
        let batch = Batch::new(&refs, &SMALL, true, true)?;
        let mut l = Learner::new(&c, SMALL, 1)?;
        let before = l.loss(&batch)?.0.to_scalar::<f32>()?;
        for _ in 0..20 {
            l.train(&batch, 0)?;
        }
        let after = l.loss(&batch)?.0.to_scalar::<f32>()?;
        assert!(after < before, "{algo}: loss {before} -> {after}");
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Raising any one agent's Q never lowers QMIX's Q_tot, whatever the weights and state.
    #[test]
    fn qmix_mixer_is_monotonic(seed in 0u64..1000, qs in prop::collection::vec(-5.0f32..5.0, 3),
                               state in prop::collection::vec(-3.0f32..3.0, 7), agent in 0usize..3, delta in 0.0f32..4.0) {
        let c = cfg("qmix", &[]).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let nets = Nets::new(&c, &SMALL, seed).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let mixer = nets.mixer.as_ref().ok_or_else(|| TestCaseError::fail("no mixer"))?;
        let mut raised = qs.clone();
        raised[agent] += delta;
        let run = |q: Vec<f32>| -> Result<f32, Box<dyn std::error::Error>> {
            let q = Tensor::from_vec(q, (1, 3), &Device::Cpu)?;
            let s = Tensor::from_vec(state.clone(), (1, 7), &Device::Cpu)?;
            Ok(mixer.forward(&q, &s)?.flatten_all()?.to_vec1::<f32>()?[0])
        };
        let (lo, hi) = (run(qs).map_err(|e| TestCaseError::fail(e.to_string()))?, run(raised).map_err(|e| TestCaseError::fail(e.to_string()))?);
        prop_assert!(hi >= lo - 1e-5, "Q_tot {lo} -> {hi} raising agent {agent} by {delta}");
    }

    /// Epsilon-greedy picks only available actions, at any epsilon.
    #[test]
    fn unavailable_actions_are_never_chosen(seed in 0u64..10_000, eps in 0.0f64..=1.0,
                                            rows in prop::collection::vec((prop::collection::vec(-10.0f32..10.0, 6), prop::collection::vec(0u8..2, 6)), 1..12)) {
        let mut q = Vec::new();
        let mut avail = Vec::new();
        for (qr, mut ar) in rows {
            if ar.iter().all(|&m| m == 0) { ar[5] = 1; }
            q.extend(qr);
            avail.extend(ar);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..5 {
            for (r, a) in select_actions(&q, &avail, 6, eps, &mut rng).into_iter().enumerate() {
                prop_assert_eq!(avail[r * 6 + a as usize], 1);
            }
        }
    }
}

#[test]
fn a_saved_checkpoint_loads_with_identical_q_values() -> R {
    let dir = std::env::temp_dir().join(format!("avacraft-marl-ckpt-{}", std::process::id()));
    for (algo, extra) in [("vdn", &[][..]), ("qmix", &[]), ("qtran", &[]), ("qmix", &["use_rnn=false"])] {
        let c = cfg(algo, extra)?;
        let mut l = Learner::new(&c, SMALL, 9)?;
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let eps = random_episodes(&SMALL, 4, &mut rng);
        let refs: Vec<&Episode> = eps.iter().collect();
        let batch = Batch::new(&refs, &SMALL, true, true)?;
        l.train(&batch, 0)?;
        avacraft_marl::checkpoint::save(&dir, &l.nets, &c, &SMALL, "small")?;
        let p = Policy::load(&dir)?;
        assert_eq!(p.cfg, c);
        let q1: Vec<f32> = l.nets.unroll(&batch)?.flatten_all()?.to_vec1()?;
        let q2: Vec<f32> = p.nets.unroll(&batch)?.flatten_all()?.to_vec1()?;
        assert_eq!(q1, q2, "{algo} {extra:?}");
        let (m1, m2) = (l.nets.mixer_params.to_map(), p.nets.mixer_params.to_map());
        assert_eq!(m1.len(), m2.len());
        for (name, t) in &m1 {
            let back = m2.get(name).ok_or_else(|| format!("{algo}: no {name} after loading"))?;
            assert_eq!(t.flatten_all()?.to_vec1::<f32>()?, back.flatten_all()?.to_vec1::<f32>()?, "{algo} {name}");
        }
        if let (Some(m1), Some(m2)) = (&l.nets.mixer, &p.nets.mixer) {
            let q = Tensor::from_vec(vec![0.5f32, -1.0, 2.0], (1, 3), &Device::Cpu)?;
            let s = Tensor::from_vec((0..7).map(|i| i as f32 * 0.1).collect::<Vec<f32>>(), (1, 7), &Device::Cpu)?;
            assert_eq!(m1.forward(&q, &s)?.to_vec2::<f32>()?, m2.forward(&q, &s)?.to_vec2::<f32>()?);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn a_bad_checkpoint_is_a_clear_error() {
    let e = Policy::load(std::path::Path::new("/nonexistent/ckpt")).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("config.json"), "{e}");
}

/// A one-step cooperative matrix game for two agents with three actions: the team is paid
/// `PAYOFF[a1][a2]`. Data from uniformly random play; the greedy joint action must be the
/// optimum (2, 2).
#[test]
fn vdn_and_qmix_learn_the_joint_optimum_of_a_matrix_game() -> R {
    const PAYOFF: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 8.0]];
    let shape = Shape { n_agents: 2, obs: 1, state: 1, n_actions: 3, n_enemies: 1 };
    for algo in ["vdn", "qmix", "qtran"] {
        let c = cfg(algo, &["lr=0.005", "batch_size=64"])?;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let eps: Vec<Episode> = (0..256)
            .map(|_| {
                let mut ep = Episode::default();
                let (a1, a2) = (rng.random_range(0..3u32), rng.random_range(0..3u32));
                ep.push_step(&[1.0, 1.0], &[1.0], &[1; 6], &[a1, a2]);
                ep.push_outcome(PAYOFF[a1 as usize][a2 as usize], true);
                ep.close(&shape, None);
                ep
            })
            .collect();
        let mut l = Learner::new(&c, shape, 2)?;
        for k in 0..300 {
            let refs: Vec<&Episode> = eps.iter().skip((k * 64) % 192).take(64).collect();
            l.train(&Batch::new(&refs, &shape, true, true)?, 0)?;
        }
        let probe = Batch::new(&[&eps[0]], &shape, true, true)?;
        let q = l.nets.unroll(&probe)?.get(0)?.to_vec2::<f32>()?;
        let avail = vec![1u8; 6];
        let greedy = select_actions(&q.concat(), &avail, 3, 0.0, &mut rng);
        assert_eq!(greedy, vec![2, 2], "{algo}: Q = {q:?}");
    }
    Ok(())
}

/// TD(lambda) targets on a hand-computed episode: rewards 1, 2, 3, values of the next
/// states from a constant target network, the last step a time-out (bootstrapped).
#[test]
fn td_lambda_targets_match_a_hand_computation() -> R {
    let shape = Shape { n_agents: 1, obs: 1, state: 1, n_actions: 2, n_enemies: 1 };
    let mut ep = Episode::default();
    for r in [1.0, 2.0, 3.0] {
        ep.push_step(&[0.0], &[0.0], &[1, 1], &[0]);
        ep.push_outcome(r, false);
    }
    ep.close(&shape, Some((&[0.0], &[0.0], &[1, 1])));
    let batch = Batch::new(&[&ep], &shape, false, false)?;
    let v = Tensor::from_vec(vec![10f32, 20.0, 30.0], (3, 1), &Device::Cpu)?;
    let (g, l) = (0.5f32, 0.5f32);
    let got: Vec<f32> = avacraft_marl::learner::td_targets(&batch, &v, f64::from(g), f64::from(l))?.flatten_all()?.to_vec1()?;
    let g2 = 3.0 + g * 30.0;
    let g1 = 2.0 + g * ((1.0 - l) * 20.0 + l * g2);
    let g0 = 1.0 + g * ((1.0 - l) * 10.0 + l * g1);
    assert_eq!(got, vec![g0, g1, g2]);
    // lambda 0: one-step targets; a terminal last step does not bootstrap.
    let one: Vec<f32> = avacraft_marl::learner::td_targets(&batch, &v, 0.5, 0.0)?.flatten_all()?.to_vec1()?;
    assert_eq!(one, vec![1.0 + 5.0, 2.0 + 10.0, 3.0 + 15.0]);
    let mut term = ep.clone();
    term.terminated[2] = 1.0;
    let batch = Batch::new(&[&term], &shape, false, false)?;
    let t: Vec<f32> = avacraft_marl::learner::td_targets(&batch, &v, 0.5, 0.0)?.flatten_all()?.to_vec1()?;
    assert_eq!(t[2], 3.0);
    Ok(())
}

#[test]
fn a_short_qmix_run_on_3m_trains_checkpoints_and_plays() -> R {
    let dir = std::env::temp_dir().join(format!("avacraft-marl-e2e-{}", std::process::id()));
    let c = Config::for_algo(
        "qmix",
        &["t_max=400", "envs=4", "batch_size=4", "test_interval=200", "test_nepisode=4", "epsilon_anneal_time=300", "episode_limit=20"]
            .map(String::from),
    )?;
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 5, threads: 2, out: Some(dir.clone()) };
    let mut calls = 0;
    let (trained, summary) = train(&c, &opts, &mut |_| calls += 1)?;
    assert!(summary.t_env >= 400 && summary.updates > 0 && summary.tests.len() >= 2, "{summary:?}");
    assert!(summary.last_loss.is_finite());
    assert_eq!(calls, 100);
    let log = std::fs::read_to_string(dir.join("log.csv"))?;
    assert_eq!(log.lines().count(), 1 + summary.tests.len(), "{log}");
    let png = std::fs::read(dir.join("curves.png"))?;
    assert!(png.starts_with(b"\x89PNG") && png.len() > 10_000, "a drawn PNG, {} bytes", png.len());
    common::check_tensorboard(
        &dir,
        &["test/win_rate", "train/epsilon", "loss/total", "loss/td_abs", "grad_norm/agent", "perf/steps_per_s"],
    );
    // The same seed gives the same run.
    let (_, again) = train(&c, &RunOptions { out: None, ..opts.clone() }, &mut |_| {})?;
    assert_eq!((again.episodes, again.updates, again.last_loss), (summary.episodes, summary.updates, summary.last_loss));
    assert_eq!(again.tests, summary.tests);
    // The checkpoint plays in-process as an engine agent.
    assert!(Policy::load(&dir.join("best")).is_ok());
    let agent = MarlAgent::load(&dir)?;
    assert_eq!(agent.policy().shape, trained.shape());
    // ... and plays each episode exactly as the trainer's greedy test episodes do.
    for seed in 1..=3 {
        let r = train::test(trained.nets(), &c, &scenario, &[seed], 1)?;
        let p = common::play(agent.policy(), &scenario, &c, seed);
        assert_eq!(p.refused, 0, "the policy's orders were all valid");
        assert!((f64::from(p.ret) - r.mean_return).abs() < 1e-4, "seed {seed}: agent {}, trainer {}", p.ret, r.mean_return);
        assert_eq!(p.outcome == Some(avacraft_engine::Outcome::Win), r.win_rate == 1.0);
    }
    // Shipped, it keeps the best checkpoint and the last one (`baseline:NAME@last`) apart.
    let root = dir.with_extension("baselines");
    let _ = std::fs::remove_dir_all(&root);
    let full = avacraft_marl::ship::ship(&dir, &root.join("3m_vlm/qmix"), 10_000_000)?;
    assert!(!full.half && !full.last_half, "{full:?}");
    let best = avacraft_marl::baselines::dir(&root, "3m_vlm", "qmix")?;
    // Short of room, the last checkpoint is halved first: the one that plays keeps its
    // precision (rounding can change a greedy policy's games) as long as it can.
    let agent_bytes = std::fs::metadata(best.join("agent.safetensors"))?.len();
    let tight = avacraft_marl::ship::ship(&dir, &root.join("3m_vlm/tight"), full.bytes - agent_bytes / 4)?;
    assert!(!tight.half && tight.last_half && tight.bytes <= full.bytes - agent_bytes / 4, "{tight:?}");
    let half = avacraft_marl::ship::ship(&dir, &root.join("3m_vlm/half"), full.bytes - agent_bytes * 3 / 4)?;
    assert!(half.half && half.last_half, "{half:?}");
    assert!(avacraft_marl::ship::ship(&dir, &root.join("3m_vlm/none"), 100).is_err(), "nothing fits 100 bytes");
    assert!(!root.join("3m_vlm/none").exists(), "nothing half-written is left");
    // Under a budget for all shipped runs: the run a ship replaces is not counted twice, and a
    // ship past the budget changes nothing.
    let held = avacraft_marl::ship::dir_bytes(&root)?;
    let total = |max_bytes| Some(avacraft_marl::ship::Total { root: &root, max_bytes });
    avacraft_marl::ship::ship_under(&dir, &root.join("3m_vlm/half"), full.bytes - agent_bytes * 3 / 4, total(held))?;
    assert_eq!(avacraft_marl::ship::dir_bytes(&root)?, held, "the same run shipped again takes the same room");
    let over = avacraft_marl::ship::ship_under(&dir, &root.join("3m_vlm/extra"), 10_000_000, total(held + 10));
    let message = over.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(message.contains("over the") && message.contains("nothing changed"), "{message}");
    assert!(!root.join("3m_vlm/extra").exists() && !root.join("3m_vlm/extra.partial").exists());
    assert_eq!(avacraft_marl::ship::dir_bytes(&root)?, held, "nothing changed under the root");
    // The shipped figure is drawn from the log; a copy whose run folder is gone draws it again
    // from its own, and a copy without a log is left alone.
    let small = image::image_dimensions(best.join("curves.png"))?;
    assert_eq!(small.0.max(small.1), 600, "{small:?}");
    std::fs::remove_file(best.join("curves.png"))?;
    assert!(avacraft_marl::ship::redraw(&best, 1)?);
    assert_eq!(image::image_dimensions(best.join("curves.png"))?, small);
    std::fs::remove_file(root.join("3m_vlm/tight/log.csv"))?;
    assert!(!avacraft_marl::ship::redraw(&root.join("3m_vlm/tight"), 1)?);
    let last = avacraft_marl::baselines::dir(&root, "3m_vlm", "qmix@last")?;
    assert_eq!(std::fs::read(best.join("config.json"))?, std::fs::read(dir.join("best/config.json"))?);
    assert_eq!(std::fs::read(last.join("config.json"))?, std::fs::read(dir.join("config.json"))?);
    let (p_best, p_last) = (Policy::load(&best)?, Policy::load(&last)?);
    assert_eq!(p_last.nets.agent_params.to_map().len(), p_best.nets.agent_params.to_map().len());
    let _ = std::fs::remove_dir_all(&root);
    // A resumed run goes on from the last test round with the log, curves and schedule.
    let (cfg_back, state) = avacraft_marl::resume::load(&dir)?;
    // The run names the unit data it resolved `map` to: 3m_vlm's own, Liberty.
    assert_eq!(cfg_back, Config { data: "liberty".into(), ..c.clone() });
    assert!(state.files(&dir).join("optim.safetensors").is_file(), "the optimiser's state is kept");
    assert_eq!((state.t_env, state.tests.clone()), (summary.t_env, summary.tests.clone()));
    let longer = Config { t_max: 600, ..c.clone() };
    let (_, resumed) = avacraft_marl::train_from(&longer, &opts, Some(state), &mut |_| {})?;
    assert!(resumed.t_env >= 600 && resumed.updates > summary.updates, "{resumed:?}");
    assert_eq!(resumed.tests[..summary.tests.len()], summary.tests[..], "the history is kept");
    assert!(resumed.tests.len() > summary.tests.len());
    let log = std::fs::read_to_string(dir.join("log.csv"))?;
    assert_eq!(log.lines().count(), 1 + resumed.tests.len(), "the log goes on: {log}");
    assert!(avacraft_marl::resume::load(std::path::Path::new("/nonexistent")).is_err());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// IQL, VDN and QTRAN (QMIX and PPO have fuller tests above and in `ppo.rs`) each run a
/// short training on 3m_vlm end to end: updates happen, the losses stay finite, the greedy
/// tests run and the checkpoint plays as an engine agent without an invalid order.
#[test]
fn short_iql_vdn_and_qtran_runs_on_3m_train_and_play() -> R {
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    for algo in ["iql", "vdn", "qtran"] {
        let dir = std::env::temp_dir().join(format!("avacraft-marl-e2e-{algo}-{}", std::process::id()));
        let c = Config::for_algo(
            algo,
            &[
                "t_max=1000",
                "envs=4",
                "batch_size=8",
                "test_interval=500",
                "test_nepisode=4",
                "epsilon_anneal_time=800",
                "episode_limit=30",
            ]
            .map(String::from),
        )?;
        let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 3, threads: 2, out: Some(dir.clone()) };
        let (trained, summary) = train(&c, &opts, &mut |_| {})?;
        assert!(summary.t_env >= 1000 && summary.updates > 10 && summary.tests.len() == 2, "{algo}: {summary:?}");
        assert!(summary.last_loss.is_finite(), "{algo}: {summary:?}");
        assert_eq!(dir.join("mixer.safetensors").is_file(), algo == "qtran", "{algo}: only QTRAN of these has mixing weights");
        let agent = MarlAgent::load(&dir)?;
        assert_eq!(agent.policy().shape, trained.shape());
        assert_eq!(common::play(agent.policy(), &scenario, &c, 9).refused, 0, "{algo}: the policy's orders were all valid");
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(())
}

/// A run is the same bits whatever the number of threads: the fused kernels cut their work
/// into chunks that depend on the sizes only, and the environments' results on their seeds.
#[test]
fn runs_do_not_depend_on_the_thread_count() -> R {
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    for (algo, extra) in [
        ("qmix", &["batch_size=8", "epsilon_anneal_time=300"][..]),
        ("qmix", &["batch_size=8", "use_rnn=false", "optimizer=adam", "td_lambda=0.6"]),
        ("ippo", &["rollout_len=20", "data_chunk_length=10", "num_mini_batch=2", "ppo_epochs=2", "shared_trunk=true"]),
        ("mappo", &["rollout_len=20", "data_chunk_length=10", "num_mini_batch=2", "ppo_epochs=2", "rnn_hidden_dim=32"]),
    ] {
        let mut o: Vec<String> =
            ["t_max=1200", "envs=8", "test_interval=600", "test_nepisode=4", "episode_limit=30"].map(String::from).to_vec();
        o.extend(extra.iter().map(|s| s.to_string()));
        let c = Config::for_algo(algo, &o)?;
        let run = |threads: usize| -> Result<(Vec<f32>, avacraft_marl::Summary), Box<dyn std::error::Error>> {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            let out = pool.install(|| -> Result<_, avacraft_marl::Error> {
                let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 3, threads, out: None };
                let (trained, summary) = train(&c, &opts, &mut |_| {})?;
                Ok((trained.nets().flat()?, summary))
            })?;
            Ok(out)
        };
        let (w1, s1) = run(1)?;
        assert!(s1.updates > 0, "{algo}: no update");
        for threads in [2, 3] {
            let (w, s) = run(threads)?;
            assert!(w == w1, "{algo} {extra:?}: {threads} threads changed the weights");
            assert_eq!((s.episodes, s.updates, &s.tests), (s1.episodes, s1.updates, &s1.tests), "{algo} {extra:?}: {threads} threads");
        }
    }
    Ok(())
}
