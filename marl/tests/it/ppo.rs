//! IPPO and MAPPO: the update on a fixed batch, masking and sampling, GAE, value
//! normalisation, checkpoints, reproducibility and short end-to-end runs on 3m_vlm.

use crate::common;

use avacraft_engine::{Env, Scenario, Team};
use avacraft_marl::kernels::Input;
use avacraft_marl::ppo::{CriticInput, FlatBatch, MASKED, PpoLearner, Rollout, ValueNorm, gae, masked_log_softmax, sample_actions};
use avacraft_marl::{Config, FramesActor, MarlAgent, Policy, RunOptions, Shape, Trained, select_actions, train};
use candle_core::{Device, Tensor};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

const SMALL: Shape = Shape { n_agents: 3, obs: 6, state: 7, n_actions: 4, n_enemies: 3 };

/// A rollout of random data over `SMALL` (`envs` environments, `t` steps, chunks of `l`):
/// random masks with at least one action available, actions among the available ones,
/// resets here and there.
fn random_rollout(cfg: &Config, envs: usize, t: usize, rng: &mut ChaCha8Rng) -> Rollout {
    let sh = SMALL;
    let rows = envs * sh.n_agents;
    let wa = sh.input(cfg.obs_agent_id, cfg.obs_last_action);
    let critic = CriticInput::of(cfg);
    let mut r = Rollout { t, rows, n_agents: sh.n_agents, ..Rollout::default() };
    let h = cfg.rnn_hidden_dim;
    for ti in 0..t {
        if ti % cfg.data_chunk_length == 0 {
            r.h_actor.extend((0..rows * h).map(|_| rng.random_range(-0.5f32..0.5)));
            r.h_critic.extend((0..rows * h).map(|_| rng.random_range(-0.5f32..0.5)));
        }
        r.actor_in.extend((0..rows * wa).map(|_| rng.random_range(-1f32..1.0)));
        let obs: Vec<f32> = (0..rows * sh.obs).map(|_| rng.random_range(-1f32..1.0)).collect();
        let state: Vec<f32> = (0..envs * sh.state).map(|_| rng.random_range(-1f32..1.0)).collect();
        r.critic.extend(&critic.rows(&sh, &obs, &state, envs));
        for _ in 0..rows {
            let mut avail: Vec<u8> = (0..sh.n_actions).map(|_| rng.random_range(0..2u8)).collect();
            avail[1] = 1;
            let choices: Vec<usize> = (0..sh.n_actions).filter(|&i| avail[i] == 1).collect();
            r.actions.push(choices[rng.random_range(0..choices.len())] as u32);
            r.logp.push(-(choices.len() as f32).ln());
            r.active.push(if choices.len() > 1 { 1.0 } else { 0.0 });
            r.mask.extend(avail.iter().map(|&m| if m == 1 { 0.0 } else { MASKED }));
            r.keep.push(if rng.random_range(0..5) == 0 { 0.0 } else { 1.0 });
            r.values.push(rng.random_range(-1f32..1.0));
        }
        r.reward.extend((0..envs).map(|_| rng.random_range(0f32..1.0)));
        r.done.extend((0..envs).map(|_| if rng.random_range(0..6) == 0 { 1.0 } else { 0.0 }));
    }
    r.values.extend((0..rows).map(|_| rng.random_range(-1f32..1.0)));
    r
}

fn ppo_cfg(algo: &str, extra: &[&str]) -> Result<Config, avacraft_marl::Error> {
    let mut o: Vec<String> = vec!["rollout_len=8".into(), "data_chunk_length=4".into(), "envs=2".into()];
    o.extend(extra.iter().map(|s| s.to_string()));
    Config::for_algo(algo, &o)
}

#[test]
fn an_update_on_a_fixed_batch_lowers_the_surrogate_and_value_loss() -> R {
    for algo in ["ippo", "mappo"] {
        let c = ppo_cfg(algo, &[])?;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let r = random_rollout(&c, 2, 8, &mut rng);
        let adv: Vec<f32> = (0..r.t * r.rows).map(|_| rng.random_range(-1f32..1.0)).collect();
        let targets: Vec<f32> = (0..r.t * r.rows).map(|_| rng.random_range(-2f32..2.0)).collect();
        let flat = FlatBatch::new(&r, &adv, &targets, c.data_chunk_length)?;
        let batch = flat.tensors(c.rnn_hidden_dim)?;
        let mut l = PpoLearner::new(&c, SMALL, 1)?;
        let before = l.loss(&batch)?;
        let b_sv = before.policy.to_scalar::<f32>()? + before.value.to_scalar::<f32>()?;
        for _ in 0..10 {
            l.step(&flat)?;
        }
        l.store_weights()?;
        let after = l.loss(&batch)?;
        let a_sv = after.policy.to_scalar::<f32>()? + after.value.to_scalar::<f32>()?;
        assert!(a_sv < b_sv - 1e-3, "{algo}: surrogate + value loss {b_sv} -> {a_sv}");
        assert!(after.value.to_scalar::<f32>()? < before.value.to_scalar::<f32>()?, "{algo}: value loss did not fall");
        assert!(after.policy.to_scalar::<f32>()? < before.policy.to_scalar::<f32>()?, "{algo}: surrogate did not fall");
    }
    Ok(())
}

#[test]
fn unavailable_actions_get_probability_zero_and_are_never_sampled() -> R {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (rows, na) = (64, 7);
    let logits: Vec<f32> = (0..rows * na).map(|_| rng.random_range(-30f32..30.0)).collect();
    let mut avail: Vec<u8> = (0..rows * na).map(|_| rng.random_range(0..2u8)).collect();
    for row in avail.chunks_exact_mut(na) {
        if row.iter().all(|&m| m == 0) {
            row[3] = 1;
        }
    }
    let mask: Vec<f32> = avail.iter().map(|&m| if m == 1 { 0.0 } else { MASKED }).collect();
    let lp = masked_log_softmax(
        &Tensor::from_vec(logits.clone(), (rows, na), &Device::Cpu)?,
        &Tensor::from_vec(mask, (rows, na), &Device::Cpu)?,
    )?;
    let probs: Vec<f32> = lp.exp()?.flatten_all()?.to_vec1()?;
    let lp: Vec<f32> = lp.flatten_all()?.to_vec1()?;
    for (i, (&p, &m)) in probs.iter().zip(&avail).enumerate() {
        if m == 0 {
            assert_eq!(p, 0.0, "row {} action {}: probability {p}", i / na, i % na);
        }
    }
    for row in probs.chunks_exact(na) {
        assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }
    for _ in 0..200 {
        let (acts, logp) = sample_actions(&logits, &avail, na, &mut rng);
        for (r, (&a, &l)) in acts.iter().zip(&logp).enumerate() {
            assert_eq!(avail[r * na + a as usize], 1, "row {r} sampled unavailable action {a}");
            assert!((l - lp[r * na + a as usize]).abs() < 1e-3, "row {r}: log-prob {l} vs {}", lp[r * na + a as usize]);
        }
    }
    // The draws follow the probabilities: two equal available logits, one unavailable larger.
    let (mut first, n) = (0, 4000);
    for _ in 0..n {
        first += usize::from(sample_actions(&[0.0, 0.0, 50.0], &[1, 1, 0], 3, &mut rng).0[0] == 0);
    }
    assert!((first as f64 / n as f64 - 0.5).abs() < 0.03, "{first} of {n}");
    Ok(())
}

#[test]
fn gae_matches_a_hand_computed_example_with_a_reset() {
    // Two rows, time-major. Row 0 ends an episode at step 1; row 1 runs on.
    let rewards = [1.0, 1.0, 2.0, 1.0, 3.0, 1.0];
    let values = [0.5, 0.0, 1.0, 0.0, 1.5, 0.0, 2.0, 0.0];
    let dones = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    let adv = gae(&rewards, &values, &dones, 2, 0.9, 0.8);
    // Row 0: A2 = 3 + 0.9 * 2 - 1.5 = 3.3; A1 = 2 - 1 = 1 (no bootstrap, nothing carried
    // back across the reset); A0 = 1 + 0.9 * 1 - 0.5 + 0.72 * 1 = 2.12.
    // Row 1: A2 = 1; A1 = 1 + 0.72 = 1.72; A0 = 1 + 0.72 * 1.72 = 2.2384.
    let want = [2.12, 2.2384, 1.0, 1.72, 3.3, 1.0];
    for (i, (a, w)) in adv.iter().zip(want).enumerate() {
        assert!((f64::from(*a) - w).abs() < 1e-5, "index {i}: {a} vs {w}");
    }
}

#[test]
fn value_normalisation_round_trips() {
    let mut vn = ValueNorm::default();
    assert_eq!(vn.denormalize(vn.normalize(3.0)), 3.0);
    let batch: Vec<f32> = (0..100).map(|i| 5.0 + (i as f32 - 49.5) * 0.1).collect();
    vn.update(&batch);
    let (m, s) = vn.stats();
    let sd = (batch.iter().map(|&x| (f64::from(x) - 5.0).powi(2)).sum::<f64>() / 100.0).sqrt();
    assert!((m - 5.0).abs() < 1e-4 && (s - sd).abs() < 1e-3, "mean {m} sd {s} (want 5, {sd})");
    vn.update(&[20.0; 10]);
    for x in [-7.5f32, 0.0, 5.0, 19.0] {
        assert!((vn.denormalize(vn.normalize(x)) - x).abs() < 1e-4);
        assert!((vn.normalize(vn.denormalize(x)) - x).abs() < 1e-4);
    }
    assert!(vn.normalize(5.0).abs() > 0.1, "the second batch moved the mean");
}

#[test]
fn ppo_configs_take_only_their_keys() {
    let err = |algo: &str, o: &str| Config::for_algo(algo, &[o.to_owned()]).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err("ippo", "epsilon_start=0.5").contains("epsilon_start"));
    assert!(err("mappo", "clip_parm=0.1").contains("clip_parm"));
    assert!(err("mappo", "rollout_len=15").contains("rollout_len"));
    assert!(err("qmix", "clip_param=0.1").contains("clip_param"));
    assert!(Config::for_algo("mappo", &["clip_param=0.1".into()]).is_ok_and(|c| c.clip_param == 0.1 && c.is_ppo()));
    // MAPPO's critic may read each agent's observation beside the state; IPPO's reads nothing
    // else. Off, the key stays out of a saved config, as in runs from before it.
    assert!(err("ippo", "critic_agent_obs=true").contains("critic_agent_obs"));
    // MAPPO's config has no shared trunk at all: the key is refused by name.
    let trunk = err("mappo", "shared_trunk=true");
    assert!(trunk.contains("unknown config key `shared_trunk`"), "{trunk}");
    let plain = Config::for_algo("mappo", &[]).map(|c| serde_json::to_string(&c).unwrap_or_default()).unwrap_or_default();
    assert!(plain.contains("\"algo\"") && !plain.contains("critic_agent_obs"), "{plain}");
    assert!(!plain.contains("state_agent"), "{plain}");
    // The agent-specific state already holds what the agent sees: not both.
    let both = Config::for_algo("mappo", &["critic_agent_obs=true".into(), "state_agent=true".into()]).err().map(|e| e.to_string());
    assert!(both.as_deref().is_some_and(|e| e.contains("critic_agent_obs") && e.contains("state_agent")), "{both:?}");
}

/// `state_agent`: the environment's state is every agent's row one after another; each
/// agent's critic row is its own row (in each stacked step), then its id.
#[test]
fn a_critic_on_the_agent_specific_state_reads_its_own_row() -> R {
    for frames in [1usize, 2] {
        let stacked = format!("stacked_frames={frames}");
        let c = ppo_cfg("mappo", &["state_agent=true", "use_rnn=false", &stacked])?;
        assert!(c.env_config()?.state_agent);
        let input = CriticInput::of(&c);
        assert_eq!(input, CriticInput::AgentState { frames });
        // Three agents' rows of 4 each, `frames` steps side by side.
        let (a, row) = (3, 4);
        let shape = Shape { n_agents: a, obs: 5, state: a * row * frames, n_actions: 4, n_enemies: 2 };
        let envs = 2;
        let obs = vec![0.0; envs * a * shape.obs];
        let state: Vec<f32> = (0..envs * shape.state).map(|i| i as f32).collect();
        let rows = input.rows(&shape, &obs, &state, envs).dense();
        let w = row * frames + a;
        assert_eq!((input.width(&shape), rows.len()), (w, envs * a * w));
        for (r, got) in rows.chunks_exact(w).enumerate() {
            let (env, agent) = (r / a, r % a);
            let want: Vec<f32> = (0..frames)
                .flat_map(|f| {
                    let from = env * shape.state + f * a * row + agent * row;
                    state[from..from + row].to_vec()
                })
                .chain((0..a).map(|k| if k == agent { 1.0 } else { 0.0 }))
                .collect();
            assert_eq!(got, &want[..], "frames {frames}, row {r}");
        }
    }
    Ok(())
}

/// `critic_agent_obs`: each agent's critic row is its environment's state, then its own
/// observation, then (as always) its id.
#[test]
fn a_critic_with_the_agents_observation_reads_state_then_observation() -> R {
    let c = ppo_cfg("mappo", &["critic_agent_obs=true"])?;
    let input = CriticInput::of(&c);
    assert_eq!(input, CriticInput::StateObs);
    let envs = 2;
    let obs: Vec<f32> = (0..envs * SMALL.n_agents * SMALL.obs).map(|i| i as f32).collect();
    let state: Vec<f32> = (0..envs * SMALL.state).map(|i| -1.0 - i as f32).collect();
    let rows = input.rows(&SMALL, &obs, &state, envs).dense();
    let w = SMALL.state + SMALL.obs + SMALL.n_agents;
    assert_eq!((input.width(&SMALL), rows.len()), (w, envs * SMALL.n_agents * w));
    for (r, row) in rows.chunks_exact(w).enumerate() {
        let (env, agent) = (r / SMALL.n_agents, r % SMALL.n_agents);
        assert_eq!(row[..SMALL.state], state[env * SMALL.state..(env + 1) * SMALL.state], "row {r}: state");
        assert_eq!(row[SMALL.state..SMALL.state + SMALL.obs], obs[r * SMALL.obs..(r + 1) * SMALL.obs], "row {r}: observation");
        let id: Vec<f32> = (0..SMALL.n_agents).map(|k| if k == agent { 1.0 } else { 0.0 }).collect();
        assert_eq!(row[SMALL.state + SMALL.obs..], id[..], "row {r}: id");
    }
    Ok(())
}

#[test]
fn a_saved_ppo_checkpoint_loads_and_acts_identically() -> R {
    let dir = std::env::temp_dir().join(format!("avacraft-ppo-ckpt-{}", std::process::id()));
    let c = ppo_cfg("mappo", &[])?;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let r = random_rollout(&c, 2, 8, &mut rng);
    let mut l = PpoLearner::new(&c, SMALL, 2)?;
    l.update(&r, &mut rng)?;
    avacraft_marl::checkpoint::save(&dir, &l.actor, &c, &SMALL, "small")?;
    l.save_critic(&dir)?;
    assert!(dir.join("critic.safetensors").is_file() && !dir.join("mixer.safetensors").exists());
    let p = Policy::load(&dir)?;
    assert_eq!(p.cfg, c);
    assert!(p.nets.mixer.is_none());
    let features: Vec<f32> = (0..3 * SMALL.obs).map(|i| (i as f32 * 0.37).sin()).collect();
    let (agents, last) = (vec![0, 1, 2], vec![None, Some(2), Some(0)]);
    let hidden = vec![0.1f32; 3 * c.rnn_hidden_dim];
    let (q, h) = p.q_values(&features, &agents, &last, &hidden)?;
    let x = avacraft_marl::buffer::act_inputs(&features, &agents, &last, &SMALL, true, true);
    let x = Tensor::from_vec(x, (3, SMALL.input(true, true)), &Device::Cpu)?;
    let (q2, h2) = l.actor.agent.step(&x, &Tensor::from_vec(hidden, (3, c.rnn_hidden_dim), &Device::Cpu)?)?;
    // The same weights, bit for bit; the loaded policy acts through the fused network, the
    // learner's mirror here through candle's, which round differently in the last bits.
    for (k, t) in l.actor.agent_params.to_map() {
        let back = p.nets.agent_params.to_map().remove(&k).ok_or(format!("no {k} after loading"))?;
        assert_eq!(t.flatten_all()?.to_vec1::<f32>()?, back.flatten_all()?.to_vec1::<f32>()?, "{k}");
    }
    for (a, b) in q.iter().zip(q2.flatten_all()?.to_vec1::<f32>()?).chain(h.iter().zip(h2.flatten_all()?.to_vec1::<f32>()?)) {
        assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "loaded {a}, learner {b}");
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// The fused kernels' loss and gradients (what training runs) equal candle's autograd on the
/// reference loss built from tensor operations, in every loss variant.
#[test]
fn fused_gradients_match_the_candle_reference() -> R {
    for (algo, extra) in [
        ("ippo", vec![]),
        ("mappo", vec![]),
        ("mappo", vec!["clip_value_loss=false", "huber_delta=0.0"]),
        ("ippo", vec!["huber_delta=0.3", "entropy_coef=0.2"]),
        ("ippo", vec!["shared_trunk=true"]),
        ("ippo", vec!["shared_trunk=true", "value_loss_coef=0.5", "clip_value_loss=false"]),
        ("mappo", vec!["use_rnn=false"]),
        ("mappo", vec!["critic_agent_obs=true"]),
        ("mappo", vec!["critic_agent_obs=true", "use_rnn=false"]),
        ("ippo", vec!["use_rnn=false", "shared_trunk=true"]),
        ("mappo", vec!["layer_norm=true"]),
        ("mappo", vec!["layer_norm=true", "use_rnn=false", "critic_agent_obs=true"]),
        ("ippo", vec!["layer_norm=true"]),
    ] {
        let c = ppo_cfg(algo, &extra)?;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let r = random_rollout(&c, 3, 8, &mut rng);
        let adv: Vec<f32> = (0..r.t * r.rows).map(|_| rng.random_range(-1f32..1.0)).collect();
        let targets: Vec<f32> = (0..r.t * r.rows).map(|_| rng.random_range(-2f32..2.0)).collect();
        let flat = FlatBatch::new(&r, &adv, &targets, c.data_chunk_length)?;
        let mut l = PpoLearner::new(&c, SMALL, 3)?;
        // One step first, so ratios leave 1 and some clip.
        l.step(&flat)?;
        l.store_weights()?;
        let reference = l.loss(&flat.tensors(c.rnn_hidden_dim)?)?;
        let (want_a, want_c) = l.flat_gradients(&reference.total.backward()?)?;
        let g = l.gradients(&flat)?;
        let want = f64::from(reference.total.to_scalar::<f32>()?);
        assert!((g.loss.total - want).abs() < 1e-4 * want.abs().max(1.0), "{algo} {extra:?}: loss {} vs {want}", g.loss.total);
        assert_eq!(want_c.is_empty(), l.shared(), "{algo} {extra:?}");
        for (what, got, want) in [("actor", &g.actor, &want_a), ("critic", &g.critic, &want_c)] {
            assert_eq!(got.len(), want.len(), "{algo} {extra:?}: {what}");
            let scale = want.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-4);
            for (i, (a, b)) in got.iter().zip(want).enumerate() {
                assert!((a - b).abs() <= 2e-4 * scale, "{algo} {extra:?}: {what} gradient [{i}]: fused {a}, candle {b}");
            }
        }
    }
    Ok(())
}

/// In `rgb` mode the fused path (the CNN encoder's kernels feeding the agent network's)
/// gives candle's loss and gradients for every actor weight, the encoder's included; one
/// update (one global-norm clip over agent network and encoder, Adam) lands on the weights
/// candle's clip and `AdamW` give; and acting gives the reference network's logits.
#[test]
fn a_fused_rgb_update_matches_the_candle_reference() -> R {
    use avacraft_marl::observe::StepFrames;
    use candle_nn::Optimizer as _;
    let (screen, minimap) = ((20, 12), (9, 8));
    // A small clip, so that the clipped update is the one compared.
    let c = ppo_cfg("mappo", &["obs=rgb", "screen_size=[20, 12]", "minimap_size=[9, 8]", "grad_norm_clip=0.05"])?;
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let envs = 2;
    let mut r = random_rollout(&c, envs, 8, &mut rng);
    let mut bytes = |len: usize| (0..len).map(|_| rng.random_range(0..=255u8)).collect::<Vec<u8>>();
    for _ in 0..r.t {
        let (s, m) = (bytes(envs * screen.0 * screen.1 * 3), bytes(envs * minimap.0 * minimap.1 * 3));
        r.frames.push(StepFrames::from_pixels(envs, (screen, minimap), s, m));
    }
    let adv: Vec<f32> = (0..r.t * r.rows).map(|_| rng.random_range(-1f32..1.0)).collect();
    let targets: Vec<f32> = (0..r.t * r.rows).map(|_| rng.random_range(-2f32..2.0)).collect();
    let flat = FlatBatch::new(&r, &adv, &targets, c.data_chunk_length)?;
    let batch = flat.tensors(c.rnn_hidden_dim)?;

    // Loss and gradients.
    let l = PpoLearner::new(&c, SMALL, 3)?;
    let reference = l.loss(&batch)?;
    let grads = reference.total.backward()?;
    let g = l.gradients(&flat)?;
    let want = f64::from(reference.total.to_scalar::<f32>()?);
    assert!((g.loss.total - want).abs() < 1e-4 * want.abs().max(1.0), "loss {} vs {want}", g.loss.total);
    let vars: Vec<_> = l.actor.agent_params.vars().cloned().collect();
    assert!(vars.len() > 8, "the encoder's weights follow the agent network's");
    let mut at = 0;
    let mut sq = 0f64;
    for v in &vars {
        let want = grads.get(v).map_or(Ok(vec![0.0; v.elem_count()]), |t| t.flatten_all()?.to_vec1::<f32>())?;
        sq += want.iter().map(|&x| f64::from(x) * f64::from(x)).sum::<f64>();
        let got = &g.actor[at..at + want.len()];
        let scale = want.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-6);
        for (i, (a, b)) in got.iter().zip(&want).enumerate() {
            assert!((a - b).abs() <= 2e-4 * scale, "actor gradient of {:?} [{i}]: fused {a}, candle {b}", v.dims());
        }
        at += want.len();
    }
    assert_eq!(at, g.actor.len());
    assert!(sq.sqrt() > c.grad_norm_clip, "the case must clip");

    // One update: candle's clip over all actor weights and AdamW, against the fused step.
    let mut fused = PpoLearner::new(&c, SMALL, 3)?;
    fused.step(&flat)?;
    fused.store_weights()?;
    let mut grads = grads;
    let s = c.grad_norm_clip / (sq.sqrt() + 1e-6);
    for v in &vars {
        if let Some(t) = grads.remove(v) {
            grads.insert(v, (t * s)?);
        }
    }
    let params = candle_nn::ParamsAdamW { lr: c.lr, eps: c.optim_eps, weight_decay: 0.0, ..candle_nn::ParamsAdamW::default() };
    candle_nn::AdamW::new(vars.clone(), params)?.step(&grads)?;
    for (v, w) in vars.iter().zip(fused.actor.agent_params.vars()) {
        let (a, b) = (w.as_tensor().flatten_all()?.to_vec1::<f32>()?, v.as_tensor().flatten_all()?.to_vec1::<f32>()?);
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!((x - y).abs() <= 1e-2 * c.lr as f32, "weight of {:?} [{i}] after one update: fused {x}, candle {y}", v.dims());
        }
    }

    // Acting on one step's frames.
    let rows = envs * SMALL.n_agents;
    let h: Vec<f32> = (0..rows * c.rnn_hidden_dim).map(|i| (i as f32 * 0.1).sin() * 0.5).collect();
    let xa: Vec<f32> = (0..rows * SMALL.input(true, true)).map(|i| (i as f32 * 0.3).cos()).collect();
    let xc = vec![0.5f32; rows * CriticInput::of(&c).width(&SMALL)];
    let out = fused.act_with(&xa, &h, Input::Rows(&xc), &h, Some(&r.frames[3]))?;
    let x = Tensor::from_vec(xa, (rows, SMALL.input(true, true)), &Device::Cpu)?;
    let x = fused.actor.step_inputs(x, Some(&r.frames[3].tensors()?))?;
    let (q, _) = fused.actor.agent.step(&x, &Tensor::from_vec(h, (rows, c.rnn_hidden_dim), &Device::Cpu)?)?;
    for (a, b) in out.logits.iter().zip(q.flatten_all()?.to_vec1::<f32>()?) {
        assert!((a - b).abs() < 1e-5, "acting: fused {a}, reference {b}");
    }
    Ok(())
}

/// Acting (one fused step) gives the reference network's logits and hidden states.
#[test]
fn acting_matches_the_reference_network() -> R {
    let c = ppo_cfg("ippo", &[])?;
    let l = PpoLearner::new(&c, SMALL, 4)?;
    let rows = 6;
    let h: Vec<f32> = (0..rows * c.rnn_hidden_dim).map(|i| (i as f32 * 0.1).sin() * 0.5).collect();
    let xa: Vec<f32> = (0..rows * SMALL.input(true, true)).map(|i| (i as f32 * 0.3).cos()).collect();
    let xc = vec![0.5f32; rows * CriticInput::of(&c).width(&SMALL)];
    let out = l.act(&xa, &h, Input::Rows(&xc), &h)?;
    assert_eq!((out.logits.len(), out.values.len()), (rows * SMALL.n_actions, rows));
    let x = Tensor::from_vec(xa, (rows, SMALL.input(true, true)), &Device::Cpu)?;
    let (q, h2) = l.actor.agent.step(&x, &Tensor::from_vec(h, (rows, c.rnn_hidden_dim), &Device::Cpu)?)?;
    for (a, b) in
        out.logits.iter().zip(q.flatten_all()?.to_vec1::<f32>()?).chain(out.h_actor.iter().zip(h2.flatten_all()?.to_vec1::<f32>()?))
    {
        assert!((a - b).abs() < 1e-5, "fused {a}, reference {b}");
    }
    Ok(())
}

/// A short MAPPO run on the agent-specific state trains (its critic reads one agent's row
/// and the id), saves a critic of that width, and its policy plays as the trainer tested it.
#[test]
fn mappo_on_the_agent_specific_state_trains_and_plays() -> R {
    let scenario = Arc::new(Scenario::load("3m")?);
    let dir = std::env::temp_dir().join(format!("avacraft-ppo-as-{}", std::process::id()));
    let c = Config { use_rnn: false, state_agent: true, ..short("mappo")? };
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 4, threads: 2, out: Some(dir.clone()) };
    let (trained, summary) = train(&c, &opts, &mut |_| {})?;
    assert!(summary.last_loss.is_finite() && summary.updates == 25, "{summary:?}");
    let env = Env::new(Arc::clone(&scenario), c.env_config()?, 0);
    let row = env.smac_layout(Team::One).agent_state_size();
    let critic = candle_core::safetensors::load(dir.join("critic.safetensors"), &Device::Cpu)?;
    let first = critic.get("fc1.weight").ok_or_else(|| format!("no fc1.weight among {:?}", critic.keys().collect::<Vec<_>>()))?;
    assert_eq!(first.dims(), [c.rnn_hidden_dim, row + 3], "the critic reads one agent's row and its id");
    let agent = MarlAgent::load(&dir)?;
    common::plays_as_tested(trained.nets(), &agent, &scenario, &c, 1..=2, "mappo on the agent-specific state")?;
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// A short run: `envs` 4, rollouts of 20 steps, 2000 steps.
fn short(algo: &str) -> Result<Config, avacraft_marl::Error> {
    Config::for_algo(
        algo,
        &["t_max=2000", "envs=4", "rollout_len=20", "test_interval=1000", "test_nepisode=4", "episode_limit=60", "ppo_epochs=4"]
            .map(String::from),
    )
}

/// The feed-forward MAPPO (`use_rnn = false`, the MAPPO repository's `mappo`): neither
/// network carries anything from one step to the next, its checkpoint says so and plays as
/// the trainer's greedy tests do.
#[test]
fn a_feed_forward_mappo_run_keeps_no_state_and_its_checkpoint_plays_alike() -> R {
    let c = ppo_cfg("mappo", &["use_rnn=false"])?;
    let l = PpoLearner::new(&c, SMALL, 4)?;
    assert!(!l.actor.agent.is_recurrent());
    let rows = 6;
    let xa: Vec<f32> = (0..rows * SMALL.input(true, true)).map(|i| (i as f32 * 0.3).cos()).collect();
    let xc = vec![0.5f32; rows * CriticInput::of(&c).width(&SMALL)];
    let h = |k: f32| vec![k; rows * c.rnn_hidden_dim];
    let (a, b) = (l.act(&xa, &h(0.0), Input::Rows(&xc), &h(0.0))?, l.act(&xa, &h(0.7), Input::Rows(&xc), &h(-0.7))?);
    assert_eq!((a.logits, a.values), (b.logits, b.values), "a feed-forward step read the state it was given");

    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    let dir = std::env::temp_dir().join(format!("avacraft-ppo-ff-{}", std::process::id()));
    let c = Config { use_rnn: false, ..short("mappo")? };
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 3, threads: 2, out: Some(dir.clone()) };
    let (trained, summary) = train(&c, &opts, &mut |_| {})?;
    assert!(summary.last_loss.is_finite() && summary.updates == 25, "{summary:?}");
    let agent = MarlAgent::load(&dir)?;
    assert!(!agent.policy().cfg.use_rnn && !agent.policy().nets.agent.is_recurrent());
    common::plays_as_tested(trained.nets(), &agent, &scenario, &c, 1..=2, "feed-forward mappo")?;
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// `stacked_frames` (the MAPPO repository's frame stacking): refused where it cannot mean
/// what it says, saved only when on; the networks read `k` observations (and the critic `k`
/// states) a row, a short run's checkpoint carries each agent's last observations from step to
/// step and plays as the trainer's greedy tests do, recurrent or not.
#[test]
fn a_frame_stacking_mappo_run_reads_its_last_observations_and_its_checkpoint_plays_alike() -> R {
    let err =
        |algo: &str, o: &[&str]| Config::for_algo(algo, &o.iter().map(|s| s.to_string()).collect::<Vec<_>>()).err().map(|e| e.to_string());
    for (algo, o) in [
        ("qmix", &["stacked_frames=4"][..]),
        ("mappo", &["stacked_frames=0"]),
        ("mappo", &["stacked_frames=17"]),
        ("ippo", &["stacked_frames=2", "obs=\"rgb\""]),
    ] {
        let e = err(algo, o).ok_or(format!("{algo} {o:?} was taken"))?;
        assert!(e.contains("stacked_frames"), "{algo} {o:?}: {e}");
    }
    // A config file (not `--set`, which qmix.toml refuses for want of the key) reaches validate.
    let q = Config { stacked_frames: 4, ..Config::for_algo("qmix", &[])? }.validate().err().map(|e| e.to_string());
    assert!(q.as_deref().is_some_and(|e| e.contains("stacked_frames")), "{q:?}");
    assert!(!serde_json::to_string(&ppo_cfg("mappo", &[])?)?.contains("stacked_frames"));
    let c = ppo_cfg("mappo", &["stacked_frames=4"])?;
    assert!(serde_json::to_string(&c)?.contains("\"stacked_frames\":4"));
    let l = PpoLearner::new(&c, SMALL, 4)?;
    assert_eq!(l.actor.agent.layout().input, 4 * SMALL.obs + SMALL.n_agents + SMALL.n_actions);
    assert_eq!(l.critic_layout().map(|x| x.input), Some(4 * SMALL.state + SMALL.n_agents));

    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    for use_rnn in [false, true] {
        let dir = std::env::temp_dir().join(format!("avacraft-ppo-stack-{use_rnn}-{}", std::process::id()));
        let c = Config { use_rnn, stacked_frames: 3, ..short("mappo")? };
        let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 3, threads: 2, out: Some(dir.clone()) };
        let (trained, summary) = train(&c, &opts, &mut |_| {})?;
        assert!(summary.last_loss.is_finite() && summary.updates == 25, "{summary:?}");
        let agent = MarlAgent::load(&dir)?;
        let p = agent.policy();
        assert_eq!((p.cfg.stacked_frames, p.memory_width()), (3, c.rnn_hidden_dim + 2 * p.shape.obs));
        for seed in 1..=2 {
            let r = train::test(trained.nets(), &c, &scenario, &[seed], 1)?;
            let played = common::play(p, &scenario, &c, seed);
            assert!(
                (f64::from(played.ret) - r.mean_return).abs() < 1e-4,
                "rnn {use_rnn}, seed {seed}: agent {}, trainer {}",
                played.ret,
                r.mean_return
            );
        }
        // The memory a step hands back holds the observation it read, after the ones before.
        let n = p.shape.n_agents;
        let agents: Vec<usize> = (0..n).collect();
        let step = |k: f32| -> Vec<f32> { (0..n * p.shape.obs).map(|i| (i as f32 * 0.11 + k).sin()).collect() };
        let (q0, m1) = p.q_values(&step(0.0), &agents, &vec![None; n], &vec![0.0; n * p.memory_width()])?;
        let (q1, m2) = p.q_values(&step(1.0), &agents, &vec![None; n], &m1)?;
        let (q1_fresh, _) = p.q_values(&step(1.0), &agents, &vec![None; n], &vec![0.0; n * p.memory_width()])?;
        let (h, o) = (c.rnn_hidden_dim, p.shape.obs);
        for a in 0..n {
            let row = &m2[a * p.memory_width() + h..(a + 1) * p.memory_width()];
            assert_eq!(row[..o], step(0.0)[a * o..(a + 1) * o], "agent {a}: the older observation");
            assert_eq!(row[o..], step(1.0)[a * o..(a + 1) * o], "agent {a}: the newer one");
        }
        assert_ne!(q1, q1_fresh, "rnn {use_rnn}: the observations before did not change what it reads");
        assert_eq!(q0.len(), q1.len());
        // Step by step through a game, the trainer's acting side (here through `FramesActor`)
        // and a checkpoint's memory choose alike, where forgetting the history would not (a
        // fresh network at full output scale, whose choices the history moves).
        let sharp = Config { actor_out_gain: 1.0, ..c.clone() };
        let fresh = PpoLearner::new(&sharp, p.shape, 9)?;
        avacraft_marl::checkpoint::save(&dir, &fresh.actor, &sharp, &p.shape, "3m_vlm")?;
        let p = &Arc::new(Policy::load(&dir)?);
        let mut actor = FramesActor::new(Arc::clone(p), &scenario)?;
        let mut env = Env::new(Arc::clone(&scenario), c.env_config()?, 7);
        let (mut memory, mut last) = (vec![0.0; n * p.memory_width()], vec![None; n]);
        let (mut obs, mut avail) = (vec![0.0; n * o], vec![0u8; n * p.shape.n_actions]);
        let (mut steps, mut forgetful) = (0, 0);
        let greedy = |q: &[f32], avail: &[u8]| select_actions(q, avail, p.shape.n_actions, 0.0, &mut ChaCha8Rng::seed_from_u64(0));
        while !env.done() {
            let acts = actor.choose(&env)?;
            env.obs_all(Team::One, &mut obs)?;
            env.avail_all(Team::One, &mut avail)?;
            let (q, m) = p.q_values(&obs, &agents, &last, &memory)?;
            let chosen = greedy(&q, &avail);
            assert_eq!(acts, chosen.iter().map(|&a| a as usize).collect::<Vec<_>>(), "rnn {use_rnn}, step {steps}");
            let (q_fresh, _) = p.q_values(&obs, &agents, &last, &vec![0.0; n * p.memory_width()])?;
            forgetful += usize::from(greedy(&q_fresh, &avail) != chosen);
            (memory, last) = (m, chosen.iter().map(|&a| Some(a)).collect());
            let _ = env.submit_indices(Team::One, &acts);
            env.step();
            steps += 1;
        }
        assert!(forgetful > 0, "rnn {use_rnn}: no step of {steps} chose otherwise without its history");
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(())
}

/// The MAPPO repository's network (`layer_norm`): the key is saved only when on, the
/// networks start as that repository's do (unit-scale norms, zero biases, orthogonal weights
/// scaled by sqrt 2, the policy's output layer by 0.01), and a short run's checkpoint loads
/// into the same network and plays as the trainer's greedy tests do, recurrent or not.
#[test]
fn a_layer_normed_mappo_run_starts_as_the_repositorys_and_its_checkpoint_plays_alike() -> R {
    let plain = serde_json::to_string(&ppo_cfg("mappo", &[])?)?;
    assert!(!plain.contains("layer_norm"), "{plain}");
    let c = ppo_cfg("mappo", &["layer_norm=true"])?;
    assert!(serde_json::to_string(&c)?.contains("\"layer_norm\":true"));
    let l = PpoLearner::new(&c, SMALL, 4)?;
    let vars = l.actor.agent_params.to_map();
    let get = |k: &str| -> Result<Vec<f32>, Box<dyn std::error::Error>> {
        Ok(vars.get(k).ok_or(format!("no {k}"))?.flatten_all()?.to_vec1::<f32>()?)
    };
    assert!(get("feature_norm.weight")?.iter().all(|&v| v == 1.0) && get("fc1_norm.bias")?.iter().all(|&v| v == 0.0));
    assert!(get("fc1.bias")?.iter().chain(&get("rnn.bias_hh")?).all(|&v| v == 0.0));
    // fc1 `(64, input)`, here `input` < 64: orthonormal columns times sqrt 2.
    let w1 = get("fc1.weight")?;
    let input = w1.len() / c.rnn_hidden_dim;
    assert!(input < c.rnn_hidden_dim, "{input}");
    let dot = |a: usize, b: usize| -> f32 { (0..c.rnn_hidden_dim).map(|r| w1[r * input + a] * w1[r * input + b]).sum() };
    assert!((dot(0, 0) - 2.0).abs() < 1e-4 && (dot(5, 5) - 2.0).abs() < 1e-4 && dot(0, 5).abs() < 1e-4, "{} {}", dot(0, 0), dot(0, 5));
    // The policy's output layer: orthonormal rows of norm 0.01 (its 10 rows of 64).
    let w2 = get("fc2.weight")?;
    let row: f32 = w2[..c.rnn_hidden_dim].iter().map(|v| v * v).sum();
    assert!((row.sqrt() - 0.01).abs() < 1e-5, "{}", row.sqrt());

    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    for use_rnn in [true, false] {
        let dir = std::env::temp_dir().join(format!("avacraft-ppo-ln-{use_rnn}-{}", std::process::id()));
        let c = Config { use_rnn, layer_norm: true, ..short("mappo")? };
        let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 3, threads: 2, out: Some(dir.clone()) };
        let (trained, summary) = train(&c, &opts, &mut |_| {})?;
        assert!(summary.last_loss.is_finite() && summary.updates == 25, "{summary:?}");
        let agent = MarlAgent::load(&dir)?;
        assert!(agent.policy().cfg.layer_norm && agent.policy().nets.agent.layout().norm);
        for seed in 1..=2 {
            let r = train::test(trained.nets(), &c, &scenario, &[seed], 1)?;
            let p = common::play(agent.policy(), &scenario, &c, seed);
            assert!(
                (f64::from(p.ret) - r.mean_return).abs() < 1e-4,
                "rnn {use_rnn}, seed {seed}: agent {}, trainer {}",
                p.ret,
                r.mean_return
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(())
}

#[test]
fn short_ippo_and_mappo_runs_on_3m_train_checkpoint_reproduce_and_play() -> R {
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    for algo in ["ippo", "mappo"] {
        let dir = std::env::temp_dir().join(format!("avacraft-ppo-e2e-{algo}-{}", std::process::id()));
        let c = short(algo)?;
        let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 5, threads: 2, out: Some(dir.clone()) };
        let mut calls = 0;
        let (trained, summary) = train(&c, &opts, &mut |_| calls += 1)?;
        assert!(matches!(trained, Trained::Ppo(_)));
        assert_eq!((summary.t_env, summary.updates, calls), (2000, 25, 500), "{algo}: {summary:?}");
        assert!(summary.last_loss.is_finite() && summary.tests.len() == 2 && summary.episodes > 0, "{algo}: {summary:?}");
        let log = std::fs::read_to_string(dir.join("log.csv"))?;
        assert_eq!(log.lines().count(), 3, "{log}");
        let tags = ["test/return", "train/return", "train/entropy", "loss/policy", "loss/value", "grad_norm/agent", "grad_norm/critic"];
        common::check_tensorboard(&dir, &tags);
        for f in ["agent.safetensors", "critic.safetensors", "config.json", "best/agent.safetensors"] {
            assert!(dir.join(f).is_file(), "{algo}: no {f}");
        }
        if algo == "mappo" {
            // The same seed gives the same run, weights included.
            let (again, s2) = train(&c, &RunOptions { out: None, ..opts.clone() }, &mut |_| {})?;
            assert_eq!((s2.episodes, s2.updates, s2.last_loss), (summary.episodes, summary.updates, summary.last_loss));
            assert_eq!(s2.tests, summary.tests);
            let (w1, w2) = (trained.nets().agent_params.to_map(), again.nets().agent_params.to_map());
            for (k, v) in &w1 {
                assert_eq!(v.flatten_all()?.to_vec1::<f32>()?, w2[k].flatten_all()?.to_vec1::<f32>()?, "{k}");
            }
        }
        // The checkpoint plays as an engine agent exactly as the trainer's greedy tests do.
        let agent = MarlAgent::load(&dir)?;
        assert_eq!(agent.policy().shape, trained.shape());
        for seed in 1..=2 {
            let r = train::test(trained.nets(), &c, &scenario, &[seed], 1)?;
            let p = common::play(agent.policy(), &scenario, &c, seed);
            assert_eq!(p.refused, 0);
            assert!((f64::from(p.ret) - r.mean_return).abs() < 1e-4, "{algo} seed {seed}: agent {}, trainer {}", p.ret, r.mean_return);
        }
        if algo == "mappo" {
            // A resumed run starts from the saved actor, critic and value statistics and goes on
            // with the log and the test history.
            let (cfg_back, state) = avacraft_marl::resume::load(&dir)?;
            assert_eq!((state.t_env, state.updates, state.seed), (2000, 25, 5));
            let Trained::Ppo(first) = &trained else { unreachable!() };
            assert_eq!(state.value_norm.as_ref(), Some(&first.value_norm));
            assert!(state.files(&dir).join("optim.safetensors").is_file(), "the optimisers' state is kept");
            let longer = Config { t_max: 3000, ..cfg_back };
            // A run killed after a test round's log row and before its state: the resumed run
            // writes that round again, so the row left behind must go.
            let log = std::fs::read_to_string(dir.join("log.csv"))?;
            let last = log.lines().last().unwrap_or_default().to_owned();
            std::fs::write(dir.join("log.csv"), format!("{log}{}\n", last.replacen("2000,", "2600,", 1)))?;
            let mut seen_first = None;
            let (resumed, s3) = avacraft_marl::train_from(&longer, &opts, Some(state), &mut |p| {
                seen_first.get_or_insert(p.t_env);
            })?;
            assert_eq!(seen_first, Some(2004), "the resumed run starts past the saved steps");
            assert_eq!((s3.t_env, s3.updates), (3000, 25 + 12), "{s3:?}");
            assert_eq!(s3.tests[..2], summary.tests[..], "the history is kept");
            let resumed_log = std::fs::read_to_string(dir.join("log.csv"))?;
            assert_eq!(resumed_log.lines().count(), 1 + s3.tests.len(), "{resumed_log}");
            assert!(resumed_log.starts_with(&log) && !resumed_log.contains("\n2600,"), "{resumed_log}");
            // Resuming with no step left to train returns what it loaded: the critic and the
            // value statistics the resumed run ended with.
            let (same, s4) = avacraft_marl::train_from(
                &Config { t_max: 3000, ..c.clone() },
                &opts,
                Some(avacraft_marl::resume::load(&dir)?.1),
                &mut |_| {},
            )?;
            assert_eq!(s4.updates, s3.updates);
            let Trained::Ppo(same) = same else { unreachable!() };
            let Trained::Ppo(resumed) = resumed else { unreachable!() };
            for (k, v) in resumed.critic_params.to_map() {
                assert_eq!(v.flatten_all()?.to_vec1::<f32>()?, same.critic_params.to_map()[&k].flatten_all()?.to_vec1::<f32>()?, "{k}");
            }
            assert_eq!(same.value_norm, resumed.value_norm);
            // a run of another seed is not resumed as this one
            let other = RunOptions { seed: 6, ..opts.clone() };
            assert!(avacraft_marl::train_from(&c, &other, Some(avacraft_marl::resume::load(&dir)?.1), &mut |_| {}).is_err());
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(())
}
