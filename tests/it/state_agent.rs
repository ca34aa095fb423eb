//! The MAPPO repository's agent-specific state (`state_agent`): its width, each agent's row
//! read against the agent's own observation and SMAC's global state, a dead agent's row,
//! and that the option changes what the state reads, never what happens.

use avacraft_engine::{Env, EnvConfig, SmacLayout, Team, builtin};
use std::sync::Arc;

fn env(map: &str, on: bool, seed: u64) -> Env {
    let s = Arc::new(builtin(map).unwrap_or_else(|e| panic!("{map}: {e}")));
    Env::new(s, EnvConfig { state_agent: on, ..EnvConfig::smac() }, seed)
}

fn state(env: &Env) -> Vec<f32> {
    let mut s = vec![0.0; env.env_info(Team::One).state_shape];
    env.state(Team::One, &mut s);
    s
}

fn obs(env: &Env, agent: usize) -> Vec<f32> {
    let mut o = vec![0.0; env.env_info(Team::One).obs_shape];
    env.obs_agent(Team::One, agent, &mut o);
    o
}

/// Steps with every agent attacking the first enemy it may attack, else moving east.
fn advance(env: &mut Env, steps: usize) -> Vec<i64> {
    let (n, na) = (env.env_info(Team::One).n_agents, env.env_info(Team::One).n_actions);
    let mut acts = vec![0i64; n];
    for _ in 0..steps {
        if env.done() {
            break;
        }
        for (a, act) in acts.iter_mut().enumerate() {
            let mut m = vec![0u8; na];
            env.avail_agent(Team::One, a, &mut m);
            *act = (6..na).find(|&i| m[i] == 1).or_else(|| [4, 1, 0].into_iter().find(|&i| m[i] == 1)).unwrap_or(0) as i64;
        }
        env.step_indices(&acts, None).expect("available actions");
    }
    acts
}

/// The repository's sizes (`get_state_size` under `use_state_agent`) on three of SMAC's maps:
/// one kind a side, shields and mixed types (the Zealot/Stalker one-hot), and a healer.
#[test]
fn the_width_is_the_repositorys() {
    // (map, agents, enemies, actions, ally shield bit, enemy shield bit, type bits)
    for (map, n, e, na, sa, se, tb) in
        [("6h_vs_8z", 6, 8, 14, 0, 1, 0), ("2s3z", 5, 5, 11, 1, 1, 2), ("MMM", 10, 10, 16, 0, 0, 3), ("3m", 3, 3, 9, 0, 0, 0)]
    {
        let env = env(map, true, 1);
        let l = env.smac_layout(Team::One);
        assert_eq!((l.n_agents, l.n_enemies, l.n_actions), (n, e, na), "{map}");
        let ally = 5 + 1 + sa + 2 + tb + na;
        let enemy = 5 + 1 + se + tb + 2;
        let own = 4 + 1 + sa + 2 + tb + na;
        let row = (n - 1) * ally + e * enemy + 4 + own + n;
        assert_eq!(l.agent_state_size(), row, "{map}");
        assert_eq!(env.env_info(Team::One).state_shape, n * row, "{map}");
        // SMAC's own state is left as it was without the option.
        let plain = self::env(map, false, 1);
        assert_eq!(plain.env_info(Team::One).state_shape, SmacLayout::new(plain.scenario(), Team::One).state_size, "{map}");
    }
}

/// Each row agrees with the agent's observation on what the agent sees (the observation
/// is the row's features within sight), with SMAC's global state on positions, health,
/// shields and cooldowns, and carries the last actions and the agent's id.
#[test]
fn rows_agree_with_the_observation_and_the_global_state() {
    for map in ["2s3z", "6h_vs_8z", "MMM"] {
        let (mut on, mut off) = (env(map, true, 3), env(map, false, 3));
        let acts = advance(&mut on, 12);
        advance(&mut off, 12);
        let l = on.smac_layout(Team::One).clone();
        let (n, e, na, tb) = (l.n_agents, l.n_enemies, l.n_actions, l.ally_types.len());
        let (sa, se) = (l.shield_ally, l.shield_enemy);
        let (s, g) = (state(&on), state(&off));
        let w = l.agent_state_size();
        let (ally_w, enemy_w) = (8 + sa + tb + na, 8 + se + tb);
        // SMAC's global state: ally rows (health, cooldown, x, y, shield, types), enemy rows
        // (health, x, y, shield, types).
        let (ga, ge) = (4 + sa + tb, 3 + se + tb);
        let mut seen_any = 0;
        for agent in 0..n {
            let row = &s[agent * w..(agent + 1) * w];
            let o = obs(&on, agent);
            let alive = o.iter().any(|&v| v != 0.0);
            assert_eq!(row[w - n + agent], 1.0, "{map}: agent {agent}'s id");
            assert_eq!(row[w - n..].iter().sum::<f32>(), 1.0, "{map}: one id");
            if !alive {
                assert!(row[..w - n].iter().all(|&v| v == 0.0), "{map}: dead agent {agent}'s row");
                continue;
            }
            // Enemies: available, distance, x, y, visible, health, shield, types, centre x, y.
            let fe = 5 + se + tb;
            for j in 0..e {
                let f = &row[(n - 1) * ally_w + j * enemy_w..(n - 1) * ally_w + (j + 1) * enemy_w];
                let ob = &o[4 + j * fe..4 + (j + 1) * fe];
                let gl = &g[n * ga + j * ge..n * ga + (j + 1) * ge];
                if gl[0] == 0.0 {
                    assert!(f.iter().all(|&v| v == 0.0), "{map}: dead enemy {j} in agent {agent}'s row");
                    continue;
                }
                assert_eq!(f[5], gl[0], "{map}: enemy {j}'s health");
                assert_eq!(&f[6 + se + tb..], &gl[1..3], "{map}: enemy {j}'s position");
                if ob.iter().any(|&v| v != 0.0) {
                    seen_any += 1;
                    assert_eq!(f[4], 1.0, "{map}: enemy {j} in agent {agent}'s sight");
                    assert_eq!(&f[..4], &ob[..4], "{map}: enemy {j}: available, distance, x, y");
                    assert_eq!(&f[5..], &[&ob[4..], &gl[1..3]].concat()[..], "{map}: enemy {j}: health, shield, types");
                }
            }
            // Allies: visible, distance, x, y, cooldown, health, shield, centre x, y, types, last action.
            let fa = 5 + sa + tb;
            let others: Vec<usize> = (0..n).filter(|&a| a != agent).collect();
            for (k, &a) in others.iter().enumerate() {
                let f = &row[k * ally_w..(k + 1) * ally_w];
                let ob = &o[4 + e * fe + k * fa..4 + e * fe + (k + 1) * fa];
                let gl = &g[a * ga..(a + 1) * ga];
                if gl[0] == 0.0 {
                    assert!(f.iter().all(|&v| v == 0.0), "{map}: dead ally {a}");
                    continue;
                }
                if ob[0] == 1.0 {
                    assert_eq!(&f[..4], &ob[..4], "{map}: ally {a} seen by agent {agent}");
                }
                assert_eq!(f[4], gl[1], "{map}: ally {a}'s cooldown");
                assert_eq!(f[5], gl[0], "{map}: ally {a}'s health");
                assert_eq!(&f[6 + sa..8 + sa], &gl[2..4], "{map}: ally {a}'s position");
                let last = &f[8 + sa + tb..];
                assert_eq!(last.iter().sum::<f32>(), 1.0, "{map}: ally {a}'s last action");
                assert_eq!(last[acts[a] as usize], 1.0, "{map}: ally {a}'s last action");
            }
            let own = &row[(n - 1) * ally_w + e * enemy_w + 4..w - n];
            let gl = &g[agent * ga..(agent + 1) * ga];
            assert_eq!(&own[..5], &[1.0, 0.0, 0.0, 0.0, gl[0]], "{map}: agent {agent}'s own health");
            assert_eq!(&own[5 + sa..7 + sa], &gl[2..4], "{map}: agent {agent}'s own position");
            assert_eq!(own[7 + sa + tb + acts[agent] as usize], 1.0, "{map}: agent {agent}'s own last action");
            // The move bits are the observation's.
            let moves = &row[(n - 1) * ally_w + e * enemy_w..(n - 1) * ally_w + e * enemy_w + 4];
            assert_eq!(moves, &o[..4], "{map}: agent {agent}'s move bits");
        }
        assert!(seen_any > 0, "{map}: no agent saw an enemy after 12 steps: the check read nothing");
    }
}

/// The option reads the game; it does not change it: the same actions give the same
/// trajectory with it on and off, to the end of an episode with dead agents in it.
#[test]
fn the_option_leaves_the_game_as_it_was() {
    let (mut on, mut off) = (env("3m", true, 9), env("3m", false, 9));
    for _ in 0..80 {
        let a = advance(&mut on, 1);
        let b = advance(&mut off, 1);
        assert_eq!(a, b);
        assert_eq!(on.state_hash(), off.state_hash());
    }
    assert!(on.done(), "3m did not end in 80 steps");
}
