//! SMACv2's conic fields of view (`conic_fov`, `num_fov_actions`): the look actions, what
//! the cone shows and lets an agent attack, the look direction in the features and the
//! state, the mirror image, and that the option leaves every other run as it was.

use crate::helpers::{arena, load, passive};
use avacraft_engine::{Action, ActionError, Command, Env, EnvConfig, SmacLayout, Team, UnitId, builtin};
use std::sync::Arc;

const N: u8 = 12;

fn fov(n: u8) -> EnvConfig {
    EnvConfig { fov_actions: n, ..passive() }
}

/// One team-1 Marine at (10, 16) (agent 0: agents are ordered by x) with an ally 2 east of
/// it; enemy Marines 4 east, 4 west and 4 north of it (all within SMAC's shoot range 6 and
/// sight 9).
fn cross() -> Arc<avacraft_engine::Scenario> {
    load(&arena(
        "pve",
        &[
            ("Marine", 1, 10.0, 16.0),
            ("Marine", 1, 12.0, 16.0),
            ("Marine", 2, 14.0, 16.0),
            ("Marine", 2, 6.0, 16.0),
            ("Marine", 2, 10.0, 20.0),
        ],
    ))
}

fn obs(env: &Env, agent: usize) -> Vec<f32> {
    let mut o = vec![0.0; env.env_info(Team::One).obs_shape];
    env.obs_agent(Team::One, agent, &mut o);
    o
}

fn avail(env: &Env, agent: usize) -> Vec<u8> {
    let mut a = vec![0; env.env_info(Team::One).n_actions];
    env.avail_agent(Team::One, agent, &mut a);
    a
}

/// Which enemies (east, west, north) agent 0 has in its features and may attack.
fn seen_and_attackable(env: &Env) -> ([bool; 3], [bool; 3]) {
    let l = env.smac_layout(Team::One);
    let (o, a) = (obs(env, 0), avail(env, 0));
    let seen = [0, 1, 2].map(|e| o[l.enemy_row(e)].iter().any(|&v| v != 0.0));
    let attack = [0, 1, 2].map(|e| a[l.attack_base() + e] == 1);
    (seen, attack)
}

/// Agent 0 looks at sector `sector`; agent 1 stops.
fn look(env: &mut Env, sector: usize) {
    let r = env.step_indices(&[6 + sector as i64, 1], None).expect("look and stop are available");
    assert!(!r.done);
}

#[test]
fn the_cone_follows_the_look_actions() {
    let s = cross();
    // Off: a full circle, as SMAC.
    let env = Env::new(Arc::clone(&s), passive(), 1);
    assert_eq!(env.env_info(Team::One).n_actions, 6 + 3);
    assert_eq!(seen_and_attackable(&env), ([true; 3], [true; 3]));

    let mut env = Env::new(Arc::clone(&s), fov(N), 1);
    let l = env.smac_layout(Team::One).clone();
    assert_eq!((l.fov, l.attack_base(), l.n_actions), (12, 18, 6 + 12 + 3));
    // Every look action is available to a living agent.
    assert!(avail(&env, 0)[6..18].iter().all(|&m| m == 1));
    // SMACv2 starts looking east: only the enemy and the ally to the east, not the enemy
    // straight behind (which SMACv2's slope comparison would also admit).
    assert_eq!(seen_and_attackable(&env), ([true, false, false], [true, false, false]));
    let own = |env: &Env| {
        let o = obs(env, 0);
        // Marines only: no type bits, so the look direction ends the observation.
        (o[o.len() - 2], o[o.len() - 1])
    };
    assert_eq!(own(&env), (1.0, 0.0));
    let ally = |env: &Env| obs(env, 0)[4 + 3 * 5] == 1.0;
    assert!(ally(&env));

    look(&mut env, 6);
    assert_eq!(seen_and_attackable(&env), ([false, true, false], [false, true, false]));
    let (x, y) = own(&env);
    assert!((x + 1.0).abs() < 1e-6 && y.abs() < 1e-6, "looking west: ({x}, {y})");
    assert!(!ally(&env), "the ally to the east is behind now");

    look(&mut env, 3);
    assert_eq!(seen_and_attackable(&env), ([false, false, true], [false, false, true]));
    // One sector off north (30 degrees, the cone's half-width is 15) shows nothing.
    look(&mut env, 2);
    assert_eq!(seen_and_attackable(&env), ([false; 3], [false; 3]));

    // The state carries every ally's look direction after its health, cooldown and position.
    let mut st = vec![0.0; env.env_info(Team::One).state_shape];
    env.state_into(Team::One, &mut st).expect("state");
    let (x, y) = (st[4], st[5]);
    let want = Command::look_direction(2, N);
    assert!((x - want.x).abs() < 1e-6 && (y - want.y).abs() < 1e-6, "state look ({x}, {y}), want {want:?}");
    assert_eq!((st[6 + 4], st[6 + 5]), (1.0, 0.0), "agent 1 never looked");
}

#[test]
fn sizes_grow_by_the_look_actions() {
    for name in ["3m_vlm", "protoss_5_vs_5", "MMM_vs_MMM"] {
        let s = Arc::new(builtin(name).expect("scenario"));
        let off = Env::new(Arc::clone(&s), EnvConfig::default(), 1).env_info(Team::One);
        let on = Env::new(Arc::clone(&s), fov(N), 1).env_info(Team::One);
        assert_eq!(on.n_actions, off.n_actions + 12, "{name}");
        assert_eq!(on.obs_shape, off.obs_shape + 2, "{name}");
        let n = off.n_agents;
        assert_eq!(on.state_shape, off.state_shape + 2 * n + 12 * n, "{name}");
        let env = Env::new(Arc::clone(&s), fov(N), 1);
        let mut st = vec![0.0; on.state_shape];
        env.state_into(Team::One, &mut st).expect("state fits its size");
    }
}

#[test]
fn a_bad_look_is_refused_and_a_look_keeps_the_order() {
    let s = cross();
    let mut env = Env::new(Arc::clone(&s), fov(N), 1);
    let me = UnitId::new(0);
    let e = env.submit(Team::One, &[Action::new(me, Command::Look { sector: 12, sectors: 12 })]);
    assert_eq!(e, vec![Err(ActionError::BadLook { sector: 12, sectors: 12 })]);
    assert!(e[0].as_ref().err().is_some_and(|e| e.to_string().contains("sector 12 of 12")));
    let to = avacraft_engine::Vec2::new(10.0, 26.0);
    env.submit(Team::One, &[Action::new(me, Command::MoveTo { to })]);
    let order = env.world().unit(me).map(|u| u.order);
    assert_eq!(env.submit(Team::One, &[Action::new(me, Command::Look { sector: 6, sectors: 12 })]), vec![Ok(())]);
    assert_eq!(env.world().unit(me).map(|u| u.order), order);
}

/// Same seed, same episode with conic fields of view; turning them on changes the
/// environment's hash but not the world's when nobody looks.
#[test]
fn conic_views_replay_and_leave_other_runs_alone() {
    let s = Arc::new(builtin("3m_vlm").expect("3m_vlm"));
    let run = |cfg: EnvConfig, looks: bool| {
        let mut env = Env::new(Arc::clone(&s), cfg, 7);
        let mut k = 0usize;
        while !env.done() {
            let l = env.smac_layout(Team::One).clone();
            let mut idx = Vec::new();
            for a in 0..l.n_agents {
                let m = avail(&env, a);
                // The dead no-op; else attack the first available enemy, else look around
                // (or stop).
                let pick = if m[1] == 0 {
                    0
                } else {
                    (l.attack_base()..l.n_actions)
                        .find(|&i| m[i] == 1)
                        .or_else(|| (looks && l.fov > 0).then(|| 6 + (k + a) % l.fov))
                        .unwrap_or(1)
                };
                idx.push(pick as i64);
            }
            env.step_indices(&idx, None).expect("available actions");
            k += 1;
        }
        (env.trajectory_hash(), env.world().state_hash(), env.outcome())
    };
    let a = run(fov(N), true);
    assert_eq!(a, run(fov(N), true));
    let off = run(passive(), false);
    let on_still = run(fov(N), false);
    // Nobody looks: the cone still hides what is not east of an agent, and the
    // environment's hash names the option either way.
    assert_ne!(off.0, on_still.0);
}

#[test]
fn the_mirror_image_of_a_look_is_a_look() {
    let s = cross();
    let env = Env::new(Arc::clone(&s), fov(N), 1);
    let l: &SmacLayout = env.smac_layout(Team::One);
    for sector in 0..N {
        let i = 6 + usize::from(sector);
        let m = l.mirror_action(i);
        assert!((6..18).contains(&m));
        assert_eq!(l.mirror_action(m), i);
        let (d, md) = (Command::look_direction(sector, N), Command::look_direction((m - 6) as u8, N));
        assert!((md.x + d.x).abs() < 1e-5 && (md.y - d.y).abs() < 1e-5, "sector {sector}: {d:?} mirrors to {md:?}");
    }
    // Observations: the own look direction's x changes sign, twice is once.
    let mut o = obs(&env, 0);
    let before = o.clone();
    l.mirror_obs(&mut o);
    assert_eq!(o[o.len() - 2], -1.0);
    l.mirror_obs(&mut o);
    assert_eq!(o, before);
}

/// A left-right mirrored PvP arena in which team 1 looks east and team 2 west: team 2's
/// observations, reflected, are team 1's.
#[test]
fn team_twos_cone_reflected_is_team_ones() {
    let units = [("Marine", 1, 12.0, 14.0), ("Marine", 1, 12.0, 17.0), ("Marine", 2, 20.0, 14.0), ("Marine", 2, 20.0, 17.0)];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(Arc::clone(&s), fov(N), 1);
    env.step_indices(&[6, 6 + 1], Some(&[6 + 6, 6 + 5])).expect("looks");
    let info = env.env_info(Team::One);
    let layout = env.smac_layout(Team::Two).clone();
    for agent in 0..info.n_agents {
        let (mut o1, mut o2) = (vec![0.0; info.obs_shape], vec![0.0; info.obs_shape]);
        env.obs_agent(Team::One, agent, &mut o1);
        env.obs_agent(Team::Two, agent, &mut o2);
        layout.mirror_obs(&mut o2);
        assert!(o1.iter().zip(&o2).all(|(x, y)| (x - y).abs() < 1e-5), "agent {agent}: {o1:?} vs {o2:?}");
    }
}
