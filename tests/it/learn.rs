//! The learning API: batched accessors, terminated versus truncated, SMAC's info, checked
//! indices, and the vector environment's independence from its thread count.

use avacraft_engine::{Env, EnvConfig, LearnError, OpponentFactory, Team, VecEnv, VecEnvError, agent_by_name, builtin};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::num::NonZeroU32;
use std::sync::Arc;

fn env(name: &str, cfg: EnvConfig, seed: u64) -> Env {
    Env::new(Arc::new(builtin(name).expect("scenario")), cfg, seed)
}

/// A uniformly random available action per agent, from flat masks.
fn random_actions(avail: &[u8], n_actions: usize, rng: &mut ChaCha8Rng) -> Vec<i64> {
    avail
        .chunks(n_actions)
        .map(|m| {
            let ok: Vec<usize> = m.iter().enumerate().filter(|(_, a)| **a == 1).map(|(i, _)| i).collect();
            ok[rng.random_range(0..ok.len())] as i64
        })
        .collect()
}

#[test]
fn batched_accessors_match_the_per_agent_ones() {
    let e = env("2s3z_vlm", EnvConfig::default(), 3);
    let i = e.env_info(Team::One);
    let mut all = vec![0.0; i.n_agents * i.obs_shape];
    e.obs_all(Team::One, &mut all).expect("sizes");
    let mut one = vec![0.0; i.obs_shape];
    for agent in 0..i.n_agents {
        e.obs_agent(Team::One, agent, &mut one);
        assert_eq!(&all[agent * i.obs_shape..(agent + 1) * i.obs_shape], &one[..]);
    }
    let mut masks = vec![0u8; i.n_agents * i.n_actions];
    e.avail_all(Team::One, &mut masks).expect("sizes");
    assert!(masks.chunks(i.n_actions).all(|m| m[0] == 0 && m[1] == 1), "alive units: no-op unavailable, stop available");
    let mut short = vec![0.0; 3];
    assert_eq!(e.obs_all(Team::One, &mut short), Err(LearnError::Buffer { name: "obs", len: 3, needed: i.n_agents * i.obs_shape }));
}

#[test]
fn a_time_out_is_truncated_and_a_wipe_is_terminated() {
    let short = EnvConfig { time_limit_loops: NonZeroU32::new(16), ..EnvConfig::default() };
    let mut e = env("3m_vlm", short, 1);
    let stop = vec![1i64; 3];
    let first = e.step_indices(&stop, None).expect("valid");
    assert!(!first.done && !first.terminated && !first.truncated);
    let last = e.step_indices(&stop, None).expect("valid");
    assert!(last.done && last.truncated && !last.terminated, "{last:?}");
    let info = e.info(Team::One);
    assert!(info.episode_limit && !info.battle_won, "{info:?}");

    // Random actions against the built-in AI's attack-move: the episode ends in the game, one
    // side wiped out, long before its time limit.
    let mut e = env("3m_vlm", EnvConfig::default(), 2);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let n = e.env_info(Team::One).n_actions;
    let mut masks = vec![0u8; 3 * n];
    let r = loop {
        e.avail_all(Team::One, &mut masks).expect("sizes");
        let r = e.step_indices(&random_actions(&masks, n, &mut rng), None).expect("valid");
        if r.done {
            break r;
        }
    };
    let info = e.info(Team::One);
    assert!(r.terminated && !r.truncated && !info.episode_limit, "a wipe, not a time-out: {r:?} {info:?}");
    assert!(info.dead_allies == 3 || info.dead_enemies == 3, "{info:?}");
    assert_eq!(info.battle_won, info.dead_enemies == 3 && info.dead_allies < 3, "{info:?}");
}

#[test]
fn bad_indices_name_the_agent_and_apply_nothing() {
    let mut e = env("3m_vlm", EnvConfig::default(), 1);
    let before = e.state_hash();
    assert_eq!(e.step_indices(&[1, 1], None).err(), Some(LearnError::Count { given: 2, agents: 3 }));
    assert_eq!(e.step_indices(&[1, 99, 1], None).err(), Some(LearnError::OutOfRange { agent: 1, index: 99, n_actions: 9 }));
    assert_eq!(e.step_indices(&[1, 1, -1], None).err(), Some(LearnError::OutOfRange { agent: 2, index: -1, n_actions: 9 }));
    match e.step_indices(&[0, 1, 1], None) {
        Err(LearnError::Unavailable { agent: 0, index: 0, available }) => assert!(available.contains(&1) && !available.contains(&0)),
        other => panic!("expected unavailable, got {other:?}"),
    }
    assert_eq!(e.state_hash(), before, "nothing was applied");
    assert_eq!(e.steps(), 0);
}

/// Plays `steps` steps of a vector environment with actions drawn from its masks.
fn play(threads: usize, steps: usize) -> (Vec<u64>, Vec<(usize, u64)>) {
    let seeds: Vec<u64> = (10..18).collect();
    let mut v = VecEnv::new(Arc::new(builtin("3m_vlm").expect("scenario")), EnvConfig::default(), &seeds, threads).expect("vec env");
    let (_, _, _, n_actions) = v.shape();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut digest = Vec::new();
    let mut episodes_seen = Vec::new();
    for _ in 0..steps {
        let actions = random_actions(&v.buffers.avail, n_actions, &mut rng);
        v.step(&actions).expect("valid actions");
        let b = &v.buffers;
        let mut h = avacraft_engine::Fnv::default();
        b.obs.iter().for_each(|x| h.f32(*x));
        b.state.iter().for_each(|x| h.f32(*x));
        b.reward.iter().for_each(|x| h.f32(*x));
        h.bytes(&b.avail);
        b.terminated.iter().chain(&b.truncated).for_each(|x| h.u32(*x as u32));
        digest.push(h.finish());
        for (i, done) in b.terminated.iter().zip(&b.truncated).map(|(t, u)| t | u).enumerate() {
            if done {
                episodes_seen.push((i, b.seed[i]));
            }
        }
    }
    (digest, episodes_seen)
}

#[test]
fn vector_env_results_do_not_depend_on_threads_and_episodes_restart() {
    let (one, restarts) = play(1, 150);
    let (two, restarts2) = play(2, 150);
    assert_eq!(one, two, "same seeds, same actions: same arrays whatever the thread count");
    assert_eq!(restarts, restarts2);
    assert!(!restarts.is_empty(), "some episodes ended and restarted within 150 steps");
    // Environment i's episode k uses seeds[i] + k * 8.
    assert!(restarts.iter().all(|&(i, s)| s >= 18 && (s - 10 - i as u64).is_multiple_of(8)), "{restarts:?}");
}

#[test]
fn vector_env_matches_a_single_env_and_refuses_bad_actions() {
    let seeds = [5u64, 6];
    let mut v = VecEnv::new(Arc::new(builtin("2s3z_vlm").expect("scenario")), EnvConfig::default(), &seeds, 2).expect("vec env");
    let mut solo = env("2s3z_vlm", EnvConfig::default(), 5);
    let (agents, obs, _, n_actions) = v.shape();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..40 {
        let actions = random_actions(&v.buffers.avail, n_actions, &mut rng);
        v.step(&actions).expect("valid");
        let r = solo.step_indices(&actions[..agents], None).expect("valid");
        if r.done {
            break;
        }
        let mut o = vec![0.0; agents * obs];
        solo.obs_all(Team::One, &mut o).expect("sizes");
        assert_eq!(&v.buffers.obs[..agents * obs], &o[..]);
        assert_eq!(v.envs()[0].trajectory_hash(), solo.trajectory_hash());
    }
    let before: Vec<u64> = v.envs().iter().map(|e| e.state_hash()).collect();
    assert!(matches!(v.step(&[1]), Err(VecEnvError::Count { given: 1, needed, .. }) if needed == 2 * agents));
    let mut bad = random_actions(&v.buffers.avail, n_actions, &mut rng);
    bad[agents] = 999;
    match v.step(&bad) {
        Err(VecEnvError::Action { env: 1, source: LearnError::OutOfRange { agent: 0, index: 999, .. } }) => {}
        other => panic!("expected environment 1 agent 0 refused, got {other:?}"),
    }
    assert_eq!(v.envs().iter().map(|e| e.state_hash()).collect::<Vec<_>>(), before, "nothing applied");
}

#[test]
fn vector_env_keeps_what_an_episode_ended_on() {
    // A short time limit so that both kinds of ending (time-out, battle over) happen.
    let cfg = EnvConfig { time_limit_loops: NonZeroU32::new(12 * 8), ..EnvConfig::default() };
    let mut v = VecEnv::new(Arc::new(builtin("3m_vlm").expect("scenario")), cfg.clone(), &[21], 1).expect("vec env");
    let mut solo = env("3m_vlm", cfg, 21);
    let (agents, obs, state, n_actions) = v.shape();
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut ended = 0;
    for _ in 0..12 {
        let actions = random_actions(&v.buffers.avail, n_actions, &mut rng);
        v.step(&actions).expect("valid");
        let r = solo.step_indices(&actions, None).expect("valid");
        if r.done {
            let (mut o, mut s, mut m) = (vec![0.0; agents * obs], vec![0.0; state], vec![0u8; agents * n_actions]);
            solo.obs_all(Team::One, &mut o).expect("sizes");
            solo.state_into(Team::One, &mut s).expect("sizes");
            solo.avail_all(Team::One, &mut m).expect("sizes");
            assert_eq!(v.buffers.final_obs, o, "the last observation, not the next episode's first");
            assert_eq!(v.buffers.final_state, s);
            assert_eq!(v.buffers.final_avail, m);
            assert_ne!(v.buffers.obs, o, "the buffers moved on to the next episode");
            ended += 1;
            break;
        }
    }
    assert_eq!(ended, 1, "the episode ended within its 12-step limit");
}

/// Plays `e` to the end with random available actions drawn from `rng`; returns the
/// trajectory hash and the rewards of every step.
fn play_out(e: &mut Env, rng: &mut ChaCha8Rng) -> (u64, Vec<f32>) {
    let n = e.env_info(Team::One).n_actions;
    let mut masks = vec![0u8; e.agents(Team::One).len() * n];
    let mut rewards = Vec::new();
    while !e.done() {
        e.avail_all(Team::One, &mut masks).expect("sizes");
        let r = e.step_indices(&random_actions(&masks, n, rng), None).expect("valid");
        rewards.push(r.reward[0]);
    }
    (e.trajectory_hash(), rewards)
}

#[test]
fn a_snapshot_goes_on_exactly_as_the_original() {
    use avacraft_engine::OpponentKind;
    // Every opponent kind: the scripted ones keep memory (focus targets, seeded draws) that
    // the snapshot must carry; the built-in AI keeps its opening.
    for opponent in [OpponentKind::Builtin, OpponentKind::Aggressive, OpponentKind::Defensive, OpponentKind::Focus] {
        for name in ["3m_vlm", "2s3z_vlm"] {
            let cfg = EnvConfig { opponent: Some(opponent), reward: avacraft_engine::RewardMode::Dense, ..EnvConfig::default() };
            let mut e = env(name, cfg, 11);
            let mut rng = ChaCha8Rng::seed_from_u64(5);
            let n = e.env_info(Team::One).n_actions;
            let mut masks = vec![0u8; e.agents(Team::One).len() * n];
            for _ in 0..12 {
                e.avail_all(Team::One, &mut masks).expect("sizes");
                e.step_indices(&random_actions(&masks, n, &mut rng), None).expect("valid");
            }
            let snap = e.snapshot();
            assert_eq!(snap.state_hash(), e.state_hash(), "{name} vs {opponent:?}: a snapshot is the same state");
            let (hash, rewards) = play_out(&mut e, &mut rng.clone());
            // Diverge the snapshot's copy, then restore and replay the same draws.
            let mut fork = snap.snapshot();
            play_out(&mut fork, &mut ChaCha8Rng::seed_from_u64(99));
            fork.restore(&snap);
            let (again, rewards_again) = play_out(&mut fork, &mut rng.clone());
            assert_eq!((hash, &rewards), (again, &rewards_again), "{name} vs {opponent:?}: the restored fork replays identically");
            assert!(snap.steps() == 12 && !snap.done(), "playing the original and the fork left the snapshot alone");
        }
    }
}

/// Plays a PvP vector environment for `steps` steps with random team-1 actions; returns the
/// per-step digests and team 1's deaths.
fn play_pvp(opponent: Option<&str>, threads: usize, steps: usize) -> (Vec<u64>, u32) {
    let scenario = Arc::new(builtin("8m3mr1mv1st_mirror_pvp").expect("scenario"));
    let mut v = VecEnv::new(scenario, EnvConfig::default(), &[3, 4, 5], threads).expect("vec env");
    if let Some(name) = opponent {
        let name = name.to_owned();
        let make: OpponentFactory = Arc::new(move || agent_by_name(&name).expect("a scripted agent"));
        v = v.with_opponent(make).expect("a PvP scenario takes an opponent");
        assert!(v.opponent().is_some());
    }
    let (_, _, _, n_actions) = v.shape();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (mut digest, mut deaths) = (Vec::new(), 0);
    for _ in 0..steps {
        let actions = random_actions(&v.buffers.avail, n_actions, &mut rng);
        v.step(&actions).expect("valid actions");
        digest.push(v.envs().iter().fold(0u64, |h, e| h.rotate_left(7) ^ e.state_hash()));
        for (i, info) in v.buffers.info.iter().enumerate() {
            if v.buffers.terminated[i] || v.buffers.truncated[i] {
                deaths += info.dead_allies;
            }
        }
    }
    (digest, deaths)
}

#[test]
fn a_pvp_vector_env_plays_a_named_opponent_whatever_the_thread_count() {
    let (idle, idle_deaths) = play_pvp(None, 1, 120);
    let (one, deaths) = play_pvp(Some("focus-fire"), 1, 120);
    let (two, deaths2) = play_pvp(Some("focus-fire"), 2, 120);
    assert_eq!(one, two, "the opponent's play does not depend on the thread count");
    assert_eq!(deaths, deaths2);
    assert_ne!(one, idle, "team 2 acts when an opponent is installed");
    assert!(deaths > idle_deaths, "a focus-firing team 2 kills more of random team 1 ({deaths}) than an idle one ({idle_deaths})");
    let pve = VecEnv::new(Arc::new(builtin("3m_vlm").expect("scenario")), EnvConfig::default(), &[1], 1).expect("vec env");
    let make: OpponentFactory = Arc::new(|| agent_by_name("focus-fire").expect("a scripted agent"));
    assert!(matches!(pve.with_opponent(make), Err(VecEnvError::OpponentInPve { scenario }) if scenario == "3m_vlm"));
}

/// A vector environment made again from its seeds, each environment restored from its
/// episode number and the actions taken since that episode began, is the environment it was:
/// the same buffers now and the same results from then on.
#[test]
fn a_vector_env_restored_from_episode_numbers_and_actions_goes_on_as_the_original() {
    for (name, opponent) in [("3m_vlm", None), ("8m3mr1mv1st_mirror_pvp", Some("random"))] {
        // A short time limit, so that environments are several episodes in when restored.
        let cfg = EnvConfig { time_limit_loops: NonZeroU32::new(15 * 8), ..EnvConfig::default() };
        let make = |threads: usize| {
            let v = VecEnv::new(Arc::new(builtin(name).expect("scenario")), cfg.clone(), &[31, 32, 33], threads).expect("vec env");
            match opponent {
                Some(o) => v.with_opponent(Arc::new(move || agent_by_name(o).expect("scripted"))).expect("PvP"),
                None => v,
            }
        };
        let mut v = make(2);
        let (a, _, _, n_actions) = v.shape();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut since: Vec<Vec<i64>> = vec![Vec::new(); 3];
        for _ in 0..40 {
            let acts = random_actions(&v.buffers.avail, n_actions, &mut rng);
            v.step(&acts).expect("valid");
            for (i, h) in since.iter_mut().enumerate() {
                if v.buffers.terminated[i] || v.buffers.truncated[i] {
                    h.clear();
                } else {
                    h.extend_from_slice(&acts[i * a..(i + 1) * a]);
                }
            }
        }
        assert!(v.episode_numbers().iter().all(|&k| k > 1), "{name}: every environment restarted at least once");
        let mut back = make(1);
        for (i, h) in since.iter().enumerate() {
            back.restore(i, v.episode_numbers()[i], h).expect("the episode's own actions");
        }
        assert_eq!(back.episode_numbers(), v.episode_numbers());
        assert_eq!((&back.buffers.obs, &back.buffers.state, &back.buffers.avail), (&v.buffers.obs, &v.buffers.state, &v.buffers.avail));
        assert_eq!(back.buffers.seed, v.buffers.seed);
        for _ in 0..40 {
            let acts = random_actions(&v.buffers.avail, n_actions, &mut rng);
            v.step(&acts).expect("valid");
            back.step(&acts).expect("valid");
            let hashes = |x: &VecEnv| x.envs().iter().map(Env::trajectory_hash).collect::<Vec<_>>();
            assert_eq!(hashes(&back), hashes(&v), "{name}");
            assert_eq!((&back.buffers.reward, &back.buffers.terminated), (&v.buffers.reward, &v.buffers.terminated));
        }
        // Actions that are not the episode's are refused, naming the environment.
        let long = vec![1i64; a * 400];
        let e = back.restore(1, back.episode_numbers()[1], &long).expect_err("the episode ends before");
        assert!(matches!(e, VecEnvError::Replay { env: 1, .. } | VecEnvError::Action { env: 1, .. }), "{e}");
        assert!(matches!(back.restore(7, 1, &[]), Err(VecEnvError::NoEnv { env: 7, envs: 3 })));
    }
}
