//! Same seed and actions, same trajectory, to the bit; record-then-replay equality.

use crate::helpers::*;
use avacraft_engine::agent::{AgentTeam, Grouping, factory};
use avacraft_engine::{Action, Env, EnvConfig, Team, builtin};
use std::sync::Arc;

fn hashes(name: &str, seed: u64, policy_name: &str) -> Vec<u64> {
    let s = Arc::new(builtin(name).expect("scenario"));
    let mut env = Env::new(Arc::clone(&s), EnvConfig::default(), seed);
    let mut p = AgentTeam::new(Team::One, Grouping::Team, factory(policy_name).expect("policy"));
    p.reset(&env);
    let mut out = Vec::new();
    while !env.done() {
        p.step(&mut env, 0);
        env.step();
        out.push(env.world().state_hash());
    }
    out.push(env.trajectory_hash());
    out
}

#[test]
fn same_seed_same_trajectory() {
    for (name, pol) in [("3m_vlm", "kite"), ("2s3z_vlm", "random"), ("2c_vs_64zg_vlm", "focus-fire"), ("2m_vs_1z_vlm", "attack-move")] {
        assert_eq!(hashes(name, 11, pol), hashes(name, 11, pol), "{name}");
    }
}

#[test]
fn different_seeds_differ() {
    // Random attack delays and the random opening point make seeds matter.
    assert_ne!(hashes("2m_vs_1z_vlm", 1, "kite").last(), hashes("2m_vs_1z_vlm", 2, "kite").last());
    assert_ne!(hashes("3m_vlm", 1, "kite").last(), hashes("3m_vlm", 2, "kite").last());
}

#[test]
fn record_then_replay_reproduces_every_step() {
    // Record the actions a policy took, then replay them blind into a fresh env.
    let s = Arc::new(builtin("8m3mr1mv1st_vs_5s2c").expect("scenario"));
    let cfg = EnvConfig { opponent: Some(avacraft_engine::OpponentKind::Random), ..EnvConfig::default() };
    let mut env = Env::new(Arc::clone(&s), cfg.clone(), 99);
    let mut p = AgentTeam::new(Team::One, Grouping::Team, factory("kite").expect("policy"));
    p.reset(&env);
    let mut log: Vec<(Vec<Action>, u64)> = Vec::new();
    while !env.done() {
        let a = p.act(&env, 0);
        env.submit(Team::One, &a);
        env.step();
        log.push((a, env.world().state_hash()));
    }
    let recorded = env.trajectory_hash();
    let mut replay = Env::new(s, cfg, 99);
    for (i, (a, h)) in log.iter().enumerate() {
        replay.submit(Team::One, a);
        replay.step();
        assert_eq!(replay.world().state_hash(), *h, "diverged at step {i}");
    }
    assert!(replay.done());
    assert_eq!(replay.trajectory_hash(), recorded);
    assert_eq!(replay.outcome(), env.outcome());
}

#[test]
fn reset_restarts_identically() {
    let s = Arc::new(builtin("2s3z_vlm").expect("scenario"));
    let mut env = Env::new(s, exact(), 4);
    let first = env.world().state_hash();
    for _ in 0..30 {
        env.step();
    }
    env.reset(4);
    assert_eq!(env.world().state_hash(), first);
    assert_eq!(env.world().tick(), 0);
    assert!(!env.done());
}
