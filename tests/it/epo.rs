//! SMACv2's extended partial observability (`prob_obs_enemy`) and `action_mask: False`:
//! who observes which enemy, the draws' rate, that nothing else of the episode changes, and
//! attacks beyond the range mask.

use crate::helpers::{arena, load};
use avacraft_engine::{Controllers, Env, EnvConfig, Team, builtin};
use std::sync::Arc;

fn cfg(prob: f32) -> EnvConfig {
    EnvConfig { prob_obs_enemy: prob, ..EnvConfig::default() }
}

/// Every step of an episode of focus-fire against the scenario's opponent (scripted agents
/// read units, not feature vectors, so the actions do not depend on EPO): `f(env)` after
/// the reset and after each step.
fn episode(name: &str, cfg: EnvConfig, seed: u64, mut f: impl FnMut(&Env)) -> Env {
    let s = Arc::new(builtin(name).expect("scenario"));
    let mut env = Env::new(Arc::clone(&s), cfg, seed);
    let mut c = Controllers::named(&s, "focus-fire", None).expect("policy");
    c.reset(&env);
    f(&env);
    while !env.done() {
        c.act(&mut env);
        env.step();
        f(&env);
    }
    env
}

fn observations(env: &Env, team: Team) -> Vec<Vec<f32>> {
    let info = env.env_info(team);
    (0..info.n_agents)
        .map(|a| {
            let mut o = vec![0.0; info.obs_shape];
            env.obs_agent(team, a, &mut o);
            o
        })
        .collect()
}

/// For each enemy, how many agents have its row in their observation.
fn observers(env: &Env) -> Vec<usize> {
    let l = env.smac_layout(Team::One);
    let obs = observations(env, Team::One);
    (0..l.n_enemies).map(|e| obs.iter().filter(|o| o[l.enemy_row(e)].iter().any(|&v| v != 0.0)).count()).collect()
}

/// With every draw a success, EPO hides nothing SMAC's sight rule shows: the observations
/// are those without it, step for step. And the world never depends on it.
#[test]
fn epo_with_sure_draws_observes_what_sight_does() {
    let almost = 1.0 - f32::EPSILON / 2.0;
    for seed in [1, 2, 3] {
        let (mut off, mut on) = (Vec::new(), Vec::new());
        let a = episode("protoss_5_vs_5", EnvConfig::default(), seed, |e| off.push((observations(e, Team::One), e.world().state_hash())));
        let b = episode("protoss_5_vs_5", cfg(almost), seed, |e| on.push((observations(e, Team::One), e.world().state_hash())));
        assert_eq!(off, on, "seed {seed}");
        assert_eq!(a.outcome(), b.outcome());
        // The environment's own hash covers EPO's state once it is on.
        assert_ne!(a.trajectory_hash(), b.trajectory_hash());
    }
}

/// SMACv2's EPO config (`prob_obs_enemy: 0`): an enemy is in one agent's observation at
/// most, the one that spotted it, while without EPO several agents see the same enemy.
#[test]
fn at_zero_only_the_spotter_observes_an_enemy() {
    let (mut shared_without, mut seen_with) = (0, 0);
    for seed in 1..6 {
        episode("protoss_5_vs_5", EnvConfig::default(), seed, |e| shared_without += observers(e).iter().filter(|&&n| n > 1).count());
        episode("protoss_5_vs_5", cfg(0.0), seed, |e| {
            let n = observers(e);
            assert!(n.iter().all(|&k| k <= 1), "seed {seed} step {}: observers per enemy {n:?}", e.steps());
            seen_with += n.iter().sum::<usize>();
            // The masks agree with what the environment says it allows.
            let l = e.smac_layout(Team::One);
            for (a, o) in observations(e, Team::One).iter().enumerate() {
                for j in 0..l.n_enemies {
                    if o[l.enemy_row(j)].iter().any(|&v| v != 0.0) {
                        assert!(e.epo_allows(Team::One, a, j) && l.sees_enemy(e.world(), a, j));
                    }
                }
            }
        });
    }
    assert!(shared_without > 100, "without EPO, enemies seen by several agents at once: {shared_without}");
    assert!(seen_with > 100, "with EPO, enemies still observed by their spotters: {seen_with}");
}

/// When an enemy is first spotted, each other agent is allowed it with probability
/// `prob_obs_enemy`: the share over many spottings is within four standard errors.
#[test]
fn allowances_follow_the_probability() {
    let p = 0.3;
    let (mut allowed, mut trials) = (0usize, 0usize);
    for seed in 0..40 {
        let mut before: Option<Vec<Vec<bool>>> = None;
        episode("protoss_10_vs_10", cfg(p), seed, |e| {
            let l = e.smac_layout(Team::One);
            let now: Vec<Vec<bool>> = (0..l.n_enemies).map(|j| (0..l.n_agents).map(|a| e.epo_allows(Team::One, a, j)).collect()).collect();
            for (j, row) in now.iter().enumerate() {
                let was_empty = before.as_ref().is_none_or(|b| b[j].iter().all(|&x| !x));
                let k = row.iter().filter(|&&x| x).count();
                if was_empty && k > 0 {
                    allowed += k - 1;
                    trials += l.n_agents - 1;
                }
            }
            before = Some(now);
        });
    }
    assert!(trials > 1000, "{trials} draws");
    let share = allowed as f64 / trials as f64;
    let se = (p as f64 * (1.0 - p as f64) / trials as f64).sqrt();
    assert!((share - p as f64).abs() < 4.0 * se, "share {share:.4} over {trials} draws, expected {p}");
}

/// EPO's draws are the episode's: the same seed gives the same observations and hashes; the
/// snapshot carries EPO's state.
#[test]
fn epo_is_a_function_of_the_seed() {
    let run = |seed| {
        let mut seen = Vec::new();
        let env = episode("terran_5_vs_5", cfg(0.5), seed, |e| seen.push(observations(e, Team::One)));
        (seen, env.trajectory_hash())
    };
    let (a, b, c) = (run(7), run(7), run(8));
    assert_eq!(a, b);
    assert_ne!(a.1, c.1);
    // A snapshot taken mid-episode goes on as the original does.
    let s = Arc::new(builtin("zerg_5_vs_5").expect("scenario"));
    let mut env = Env::new(Arc::clone(&s), cfg(0.5), 3);
    let mut ctl = Controllers::named(&s, "focus-fire", None).expect("policy");
    ctl.reset(&env);
    for _ in 0..5 {
        ctl.act(&mut env);
        env.step();
    }
    let mut fork = env.snapshot();
    assert_eq!(fork.state_hash(), env.state_hash());
    for _ in 0..10 {
        env.step();
        fork.step();
        assert_eq!(observations(&fork, Team::One), observations(&env, Team::One));
        assert_eq!(fork.state_hash(), env.state_hash());
    }
}

/// `action_mask: False`: an enemy the team sees beyond shoot range may be attacked, and the
/// order is carried out; the observation's "can attack" bit keeps the range.
#[test]
fn without_the_range_mask_a_seen_enemy_beyond_range_is_attackable() {
    // A Marine (sight 9, SMAC's shoot range 6) and a Zergling 8 away.
    let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Zergling", 2, 18.0, 16.0)]));
    let attack = 6;
    let avail = |env: &Env| {
        let mut m = vec![0u8; env.env_info(Team::One).n_actions];
        env.avail_agent(Team::One, 0, &mut m);
        m
    };
    let masked = Env::new(Arc::clone(&s), EnvConfig::default(), 1);
    assert_eq!(avail(&masked)[attack], 0);
    let mut open = Env::new(Arc::clone(&s), EnvConfig { action_mask: false, ..EnvConfig::default() }, 1);
    assert_eq!(avail(&open)[attack], 1);
    for env in [&masked, &open] {
        let mut o = vec![0.0; env.env_info(Team::One).obs_shape];
        env.obs_agent(Team::One, 0, &mut o);
        let row = env.smac_layout(Team::One).enemy_row(0);
        assert_eq!(o[row.start], 0.0, "the can-attack bit");
        assert!(o[row.start + 1] > 0.0, "the Zergling is in sight");
    }
    let hp = |env: &Env| env.world().units()[1].hp;
    let full = hp(&open);
    assert!(open.submit_indices(Team::One, &[attack]).iter().all(Result::is_ok));
    for _ in 0..20 {
        open.step();
    }
    assert!(hp(&open) < full, "the Marine walked up and shot");
}
