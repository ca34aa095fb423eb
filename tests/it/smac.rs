//! SMAC-compatible layouts, values and action indices.

use crate::helpers::*;
use avacraft_engine::{Env, EnvConfig, EnvInfo, SmacLayout, Team, builtin};
use std::sync::Arc;

fn info(name: &str) -> EnvInfo {
    Env::new(Arc::new(builtin(name).expect("scenario")), EnvConfig::default(), 0).env_info(Team::One)
}

#[test]
fn sizes_match_smac_for_the_same_unit_mix() {
    // (n_agents, n_actions, obs, state) from SMAC's formulas; the SMAC-derived maps.
    for (name, want) in [
        ("3m_vlm", (3, 9, 30, 48)),
        ("2m_vs_1z_vlm", (2, 7, 16, 26)),
        ("2s_vs_1sc_vlm", (2, 7, 17, 27)),
        ("3s_vs_3z_vlm", (3, 9, 36, 54)),
        ("2s3z_vlm", (5, 11, 80, 120)),
        ("2c_vs_64zg_vlm", (2, 70, 332, 342)),
        // 12 per side, 3 types: 4 + 12*8 + 11*8 + 4 = 192; 12*7 + 12*6 + 12*18 = 372.
        ("MMM_vs_MMM", (12, 18, 192, 372)),
    ] {
        let i = info(name);
        assert_eq!((i.n_agents, i.n_actions, i.obs_shape, i.state_shape), want, "{name}");
        assert_eq!(i.episode_limit, 840, "300 s / 8 loops per step");
    }
}

#[test]
fn observation_values_are_smac_normalised() {
    // Agent at (10, 16), enemy 4 cells east: attackable (<= 6), dist/9, dx/9, dy/9, health.
    let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Marine", 1, 10.0, 19.0), ("Marine", 2, 14.0, 16.0)]));
    let env = Env::new(s, passive(), 0);
    let l = env.smac_layout(Team::One);
    assert_eq!(l.obs_size, 4 + 5 + 5 + 1);
    let mut o = vec![0f32; l.obs_size];
    env.obs_agent(Team::One, 0, &mut o);
    let close = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(close(&o[..4], &[1.0, 1.0, 1.0, 1.0]), "move N S E W: {o:?}");
    assert!(close(&o[4..9], &[1.0, 4.0 / 9.0, 4.0 / 9.0, 0.0, 1.0]), "enemy: {o:?}");
    assert!(close(&o[9..14], &[1.0, 3.0 / 9.0, 0.0, 3.0 / 9.0, 1.0]), "ally: {o:?}");
    assert!(close(&o[14..], &[1.0]), "own: {o:?}");
    // State: health, cooldown/15, (x - 16)/32, (y - 16)/32 per ally; health, rel x, rel y per enemy.
    let mut st = vec![0f32; l.state_size];
    env.state(Team::One, &mut st);
    assert!(close(&st[..4], &[1.0, 0.0, (10.0 - 16.0) / 32.0, 0.0]), "{st:?}");
    assert!(close(&st[8..11], &[1.0, (14.0 - 16.0) / 32.0, 0.0]), "{st:?}");
}

#[test]
fn available_actions_and_dead_agents() {
    let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 14.0, 16.0), ("Marine", 2, 20.0, 16.0)]));
    let mut env = Env::new(s, passive(), 0);
    let mut av = vec![0u8; env.smac_layout(Team::One).n_actions];
    env.avail_agent(Team::One, 0, &mut av);
    // no-op only when dead; stop; four moves; enemy 0 within 6, enemy 1 at 10 is not.
    assert_eq!(av, [0, 1, 1, 1, 1, 1, 1, 0]);
    // An unavailable index is refused and counted; an available one is taken.
    let r = env.submit_indices(Team::One, &[7]);
    assert!(r[0].is_err());
    assert_eq!(env.refused()[0], 1);
    let r = env.submit_indices(Team::One, &[6]);
    assert!(r[0].is_ok(), "{r:?}");
    assert_eq!(env.world().unit(uid(0)).map(|u| u.order), Some(avacraft_engine::Order::Attack { target: uid(1) }));
    // The step's action lands in the state's last-action one-hot, and only for that step.
    let l = env.smac_layout(Team::One).clone();
    let mut st = vec![0f32; l.state_size];
    env.step();
    env.state(Team::One, &mut st);
    assert_eq!(st[st.len() - l.n_actions + 6], 1.0);
    env.step();
    env.state(Team::One, &mut st);
    assert!(st[st.len() - l.n_actions..].iter().all(|&x| x == 0.0), "no action given this step");
    // A dead agent: only no-op, and an all-zero observation.
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Marine", 1, 30.0, 30.0), ("Zealot", 2, 10.9, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 0);
    while env.world().unit(uid(0)).is_some_and(|u| u.alive) {
        env.step();
    }
    env.avail_agent(Team::One, 0, &mut av[..8]);
    assert_eq!(&av[..7], &[1, 0, 0, 0, 0, 0, 0]);
    assert!(env.submit_indices(Team::One, &[0, 1])[0].is_ok(), "no-op is the dead agent's action");
    assert_eq!(env.refused()[0], 0);
    let mut o = vec![1f32; env.smac_layout(Team::One).obs_size];
    env.obs_agent(Team::One, 0, &mut o);
    assert!(o.iter().all(|&x| x == 0.0));
}

#[test]
fn index_and_typed_action_round_trip() {
    let s = Arc::new(builtin("MMM_vs_MMM").expect("scenario"));
    let env = Env::new(s, EnvConfig::default(), 0);
    let l = env.smac_layout(Team::One);
    for agent in 0..l.n_agents {
        for idx in 0..l.n_actions {
            let c = l.command_for(env.world(), agent, idx).expect("command");
            assert_eq!(l.index_for(env.world(), agent, &c), Some(idx), "agent {agent} index {idx}: {c:?}");
        }
    }
    // The Medivac's attack indices name allies (heal), as in SMAC's MMM.
    let medivac = l.agents.iter().position(|&u| env.world().unit(u).is_some_and(|u| u.spec().heal.is_some())).expect("medivac");
    let c = l.command_for(env.world(), medivac, 6).expect("command");
    assert_eq!(c, avacraft_engine::Command::Attack { target: l.agents[0] });
}

#[test]
fn stalkers_and_zealots_keep_smacs_reversed_enemy_one_hot() {
    let s = Arc::new(builtin("2s3z_vlm").expect("scenario"));
    let env = Env::new(s, EnvConfig::default(), 0);
    let l = env.smac_layout(Team::One);
    use avacraft_engine::UnitKind::{Stalker, Zealot};
    assert_eq!(l.ally_types, [Stalker, Zealot]);
    assert_eq!(l.enemy_types, [Zealot, Stalker]);
}

#[test]
fn dense_reward_follows_smac() {
    // One Marine shot (6) on a 3-Marine enemy team: 6 / ((3 * (45 + 10) + 200) / 20).
    let s =
        load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 14.0, 16.0), ("Marine", 2, 30.0, 30.0), ("Marine", 2, 30.0, 28.0)]));
    let cfg = EnvConfig { reward: avacraft_engine::RewardMode::Dense, ..passive() };
    let mut env = Env::new(s, one_loop(cfg), 0);
    env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Attack { target: uid(1) })]);
    let r = env.step();
    assert!((r.reward[0] - 6.0 / (365.0 / 20.0)).abs() < 1e-5, "{r:?}");
}

/// Steps `env` with both teams idle (auto-acquire does the fighting) until it ends; each
/// step's rewards.
fn rewards_to_the_end(mut env: Env) -> Vec<[f32; 2]> {
    let mut out = Vec::new();
    loop {
        let r = env.step();
        out.push(r.reward);
        if r.done {
            return out;
        }
    }
}

#[test]
fn signed_reward_takes_the_teams_own_losses_off() {
    // A passive Marine shot by an enemy Marine (6 damage, no armour): SMAC's only-positive
    // reward pays nothing for it, the signed one takes off reward_negative_scale of it.
    let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 14.0, 16.0)]));
    let mut cfg = EnvConfig { reward: avacraft_engine::RewardMode::Dense, ..passive() };
    cfg.rules.auto_acquire = [false, true];
    let signed = avacraft_engine::DenseReward { negative_scale: Some(0.5), ..Default::default() };
    let (mut pos, mut neg) =
        (Env::new(s.clone(), one_loop(cfg.clone()), 0), Env::new(s, one_loop(EnvConfig { dense_reward: signed, ..cfg }), 0));
    for _ in 0..200 {
        let (a, b) = (pos.step(), neg.step());
        assert_eq!(a.reward[0], 0.0, "nothing dealt, nothing paid");
        if b.reward[0] != 0.0 {
            // One Marine of 45 life against one: max_reward 45 + 10 + 200.
            assert!((b.reward[0] - -0.5 * 6.0 / (255.0 / 20.0)).abs() < 1e-5, "{b:?}");
            return;
        }
    }
    panic!("the enemy Marine never hit");
}

#[test]
fn signed_unscaled_reward_with_scale_one_is_zero_sum_in_pvp() {
    // With the team's losses at full weight and no win or defeat terms, what one team is
    // paid the other loses, step by step; scaling divides by each team's max_reward / rate.
    let units = [("Marine", 1, 10.0, 16.0), ("Marauder", 1, 10.0, 18.0), ("Zealot", 2, 16.0, 16.0), ("Stalker", 2, 16.0, 18.0)];
    let s = load(&arena("pvp", &units));
    let mut cfg = EnvConfig { reward: avacraft_engine::RewardMode::Dense, ..exact() };
    cfg.rules.full_vision = true;
    let flat = avacraft_engine::DenseReward { negative_scale: Some(1.0), win: 0.0, defeat: 0.0, scale_rate: None, ..Default::default() };
    let raw = rewards_to_the_end(Env::new(s.clone(), EnvConfig { dense_reward: flat, ..cfg.clone() }, 3));
    assert!(raw.len() > 3 && raw.iter().any(|r| r[0] != 0.0), "a fight: {raw:?}");
    for r in &raw {
        assert!((r[0] + r[1]).abs() < 1e-3, "{r:?}");
    }
    let scaled = rewards_to_the_end(Env::new(
        s,
        EnvConfig { dense_reward: avacraft_engine::DenseReward { scale_rate: Some(20.0), ..flat }, ..cfg },
        3,
    ));
    // Team 1's enemies: a Zealot (100 + 50) and a Stalker (80 + 80), 10 a kill each; team 2's:
    // a Marine (45) and a Marauder (125).
    let max = [150.0 + 160.0 + 20.0, 45.0 + 125.0 + 20.0];
    assert_eq!(scaled.len(), raw.len());
    for (a, b) in raw.iter().zip(&scaled) {
        for t in 0..2 {
            assert!((a[t] * 20.0 / max[t] - b[t]).abs() < 1e-4, "{a:?} {b:?}");
        }
    }
}

#[test]
fn win_and_defeat_are_paid_on_the_last_step_only() {
    let units = [("Marine", 1, 10.0, 16.0), ("Marine", 1, 10.0, 18.0), ("Marine", 2, 15.0, 16.0)];
    let s = load(&arena("pvp", &units));
    let cfg = EnvConfig { reward: avacraft_engine::RewardMode::Dense, ..exact() };
    let play = |win: f32, defeat: f32| {
        let r = avacraft_engine::DenseReward { win, defeat, scale_rate: None, ..Default::default() };
        rewards_to_the_end(Env::new(s.clone(), EnvConfig { dense_reward: r, ..cfg.clone() }, 1))
    };
    let (base, paid) = (play(0.0, 0.0), play(200.0, -7.0));
    assert_eq!(base.len(), paid.len());
    let last = base.len() - 1;
    for (i, (a, b)) in base.iter().zip(&paid).enumerate() {
        // Two Marines beat one: team 1 wins.
        let want = if i == last { [200.0, -7.0] } else { [0.0, 0.0] };
        assert!((b[0] - a[0] - want[0]).abs() < 1e-3 && (b[1] - a[1] - want[1]).abs() < 1e-3, "step {i}: {a:?} {b:?}");
    }
}

#[test]
fn layouts_scale_past_256_actions() {
    // 300 Zerglings: 306 actions per agent; observation, mask and indices all work.
    let mut units = vec![("Marine", 1u8, 4.0f32, 16.0f32)];
    for k in 0..300 {
        units.push(("Zergling", 2, 10.0 + (k % 20) as f32, 2.0 + (k / 20) as f32 * 1.5));
    }
    let s = load(&arena("pve", &units));
    let mut env = Env::new(s, EnvConfig::default(), 0);
    let l = env.smac_layout(Team::One).clone();
    assert_eq!(l.n_actions, 306);
    let mut o = vec![0f32; l.obs_size];
    env.obs_agent(Team::One, 0, &mut o);
    let mut av = vec![0u8; l.n_actions];
    env.avail_agent(Team::One, 0, &mut av);
    assert_eq!(av[1], 1);
    for (idx, a) in av.iter().enumerate() {
        assert_eq!(l.is_available(env.world(), 0, idx), *a == 1, "index {idx}");
    }
    let r = env.submit_indices(Team::One, &[1]);
    assert!(r[0].is_ok(), "{r:?}");
}

#[test]
fn agents_are_ordered_like_smac() {
    // SMAC sorts allies by unit type, then x, then y: 2s3z_vlm is S, S, Z, Z, Z.
    let s = Arc::new(builtin("2s3z_vlm").expect("scenario"));
    let env = Env::new(Arc::clone(&s), EnvConfig::default(), 0);
    let kinds: Vec<_> = env.agents(Team::One).iter().map(|&u| env.world().unit(u).map(|u| u.kind)).collect();
    use avacraft_engine::UnitKind::{Stalker, Zealot};
    assert_eq!(kinds, [Some(Stalker), Some(Stalker), Some(Zealot), Some(Zealot), Some(Zealot)]);
    assert_eq!(env.smac_layout(Team::One).agents, env.agents(Team::One));
    let xs: Vec<f32> = env.agents(Team::One)[2..].iter().filter_map(|&u| env.world().unit(u).map(|u| u.pos.x)).collect();
    assert!(xs.windows(2).all(|w| w[0] <= w[1]), "{xs:?}");
}

#[test]
fn a_medivac_can_heal_every_ally_even_with_few_enemies() {
    // 8m1mv_vs_2st: 9 agents, 2 enemies; the attack block widens to 9 so the Medivac
    // reaches every Marine.
    let s = Arc::new(builtin("8m1mv_vs_2st").expect("scenario"));
    let env = Env::new(s, EnvConfig::default(), 0);
    let l = env.smac_layout(Team::One);
    assert_eq!(l.n_actions, 6 + 9);
    let medivac = l.agents.iter().position(|&u| env.world().unit(u).is_some_and(|u| u.spec().heal.is_some())).expect("medivac");
    for j in 0..l.n_agents {
        let c = l.command_for(env.world(), medivac, 6 + j).expect("command");
        assert_eq!(c, avacraft_engine::Command::Attack { target: l.agents[j] });
    }
}

/// A left-right mirrored PvP arena: team 2's observations and masks, reflected, are team 1's,
/// so a policy trained as team 1 plays team 2 in the mirror image (as `MarlAgent` does);
/// reflecting twice changes nothing.
#[test]
fn team_twos_view_reflected_is_team_ones_on_a_mirrored_map() {
    let units: Vec<String> = [(14.0, 1), (15.0, 1), (17.0, 2)]
        .iter()
        .flat_map(|&(y, k)| {
            let kind = if k == 1 { "Marine" } else { "Marauder" };
            [
                format!("{{ type = \"{kind}\", team = 1, x = 12.0, y = {y} }}"),
                format!("{{ type = \"{kind}\", team = 2, x = 20.0, y = {y} }}"),
            ]
        })
        .collect();
    let s = load(&format!("name = \"mirror\"\nmode = \"pvp\"\nmap_size = [32, 32]\nunits = [{}]\n", units.join(", ")));
    let env = Env::new(Arc::clone(&s), EnvConfig::default(), 1);
    let info = env.env_info(Team::One);
    let layout = env.smac_layout(Team::Two);
    let (mut o1, mut o2) = (vec![0.0; info.obs_shape], vec![0.0; info.obs_shape]);
    let (mut a1, mut a2) = (vec![0u8; info.n_actions], vec![0u8; info.n_actions]);
    for agent in 0..info.n_agents {
        env.obs_agent(Team::One, agent, &mut o1);
        env.obs_agent(Team::Two, agent, &mut o2);
        env.avail_agent(Team::One, agent, &mut a1);
        env.avail_agent(Team::Two, agent, &mut a2);
        let before = o2.clone();
        layout.mirror_obs(&mut o2);
        SmacLayout::mirror_avail(&mut a2);
        assert!(o1.iter().zip(&o2).all(|(x, y)| (x - y).abs() < 1e-5), "agent {agent}: {o1:?} vs {o2:?}");
        assert!(before.iter().any(|&v| v < -0.5), "agent {agent}: team 2 sees its enemies to the west: {before:?}");
        assert_eq!(a1, a2, "agent {agent}");
        layout.mirror_obs(&mut o2);
        assert_eq!(o2, before);
    }
    for i in 0..info.n_actions {
        assert_eq!(layout.mirror_action(layout.mirror_action(i)), i);
    }
    assert_eq!(layout.mirror_action(4), 5);
}
