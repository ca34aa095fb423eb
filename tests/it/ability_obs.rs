//! Abilities as agents see and use them: observations, the SMAC ability slots, the
//! ability scenarios played by scripted sides, and determinism with abilities in play.

use crate::helpers::{arena_units, exact_loop, load, play, run_loops, uid};
use avacraft_engine::{Ability, AbilityTarget, Action, Command, Env, EnvConfig, Rules, Scenario, Team, builtin, describe, unit_list};
use std::sync::Arc;

#[test]
fn observations_show_abilities_buffs_and_area_effects() {
    let units = [("HighTemplar", 1, 8.0, 16.0, "energy = 200"), ("Marine", 1, 8.0, 18.0, ""), ("Zealot", 2, 15.0, 16.0, "")];
    let toml = arena_units("pvp", &units, "upgrades = [{ team = 1, name = \"PsiStormTech\" }, { team = 1, name = \"Stimpack\" }]");
    let mut env = Env::new(load(&toml), exact_loop(), 1);
    let storm =
        Command::Ability { ability: Ability::PsionicStorm, target: AbilityTarget::Point { to: avacraft_engine::Vec2::new(15.0, 16.0) } };
    let stim = Command::Ability { ability: Ability::Stimpack, target: AbilityTarget::None };
    env.submit(Team::One, &[Action::new(uid(0), storm), Action::new(uid(1), stim)]);
    env.step();
    let list = unit_list(env.world(), Team::One);
    let ht = list.iter().find(|u| u.tag == uid(0)).expect("templar");
    let storm_info = ht.abilities.iter().find(|a| a.ability == Ability::PsionicStorm).expect("storm listed");
    assert!(!storm_info.available && storm_info.cooldown_s > 1.3, "{storm_info:?}");
    assert!(ht.abilities.iter().any(|a| a.ability == Ability::Feedback));
    let marine = list.iter().find(|u| u.tag == uid(1)).expect("marine");
    assert!(marine.buffs.contains(avacraft_engine::Buffs::STIMMED));
    let enemy = list.iter().find(|u| !u.own).expect("zealot");
    assert!(enemy.abilities.is_empty(), "enemy cooldowns are not shown");
    let text = describe(&env, Team::One);
    assert!(text.contains("status: stimmed"), "{text}");
    assert!(text.contains("own psionic storm at grid"), "{text}");
    assert!(text.contains("psionic storm in 1.4 s") || text.contains("psionic storm in 1.3 s"), "{text}");
    let json = serde_json::to_value(&list).expect("json");
    assert!(json[0]["abilities"][0]["ability"].is_string());
}

#[test]
fn smac_ability_slots_extend_actions_masks_and_observations() {
    let s = Arc::new(builtin("8m3mr1mv1st_mirror").expect("scenario"));
    let plain = Env::new(Arc::clone(&s), EnvConfig::default(), 1);
    let cfg = EnvConfig { ability_actions: true, rules: Rules { cooldown_jitter: false, ..Rules::default() }, ..EnvConfig::default() };
    let mut env = Env::new(Arc::clone(&s), cfg, 1);
    let (a, b) = (plain.env_info(Team::One), env.env_info(Team::One));
    let l = env.smac_layout(Team::One).clone();
    // Tanks have two slots (siege, unsiege); every block holds max(enemies, agents, 4) = 13.
    assert_eq!((l.abilities.slots, l.abilities.width), (2, 13));
    assert_eq!(b.n_actions, a.n_actions + 26);
    assert_eq!(b.obs_shape, a.obs_shape + 3);
    assert_eq!(b.state_shape, a.state_shape + 13 * 26);
    // A Marine's stim slot is available (self-cast, index 0 of slot 0); the rest of its
    // block is not; and submitting it casts.
    let marine =
        l.agents.iter().position(|&u| env.world().unit(u).is_some_and(|u| u.kind == avacraft_engine::UnitKind::Marine)).expect("marine");
    let mut avail = vec![0u8; b.n_actions];
    env.avail_agent(Team::One, marine, &mut avail);
    let base = l.ability_base();
    assert_eq!(avail[base], 1);
    assert!(avail[base + 1..].iter().all(|&x| x == 0));
    let mut obs = vec![0f32; b.obs_shape];
    env.obs_agent(Team::One, marine, &mut obs);
    assert_eq!(obs[b.obs_shape - 2..], [1.0, 0.0], "stim ready, no second slot");
    let mut actions = vec![0usize; b.n_agents];
    for (agent, slot) in actions.iter_mut().enumerate() {
        env.avail_agent(Team::One, agent, &mut avail);
        *slot = if agent == marine { base } else { 1 };
    }
    let r = env.submit_indices(Team::One, &actions);
    assert!(r.iter().all(|r| r.is_ok()), "{r:?}");
    env.step();
    let id = l.agents[marine];
    assert!(env.world().unit(id).is_some_and(|u| u.status.stimmed(env.world().tick())));
    // The index maps back from the typed command.
    let cmd = Command::Ability { ability: Ability::Stimpack, target: AbilityTarget::None };
    assert_eq!(l.index_for(env.world(), marine, &cmd), Some(base));
    // Every available index converts to a command the engine accepts.
    for agent in 0..b.n_agents {
        env.avail_agent(Team::One, agent, &mut avail);
        for (idx, _) in avail.iter().enumerate().filter(|(_, a)| **a == 1) {
            let c = l.command_for(env.world(), agent, idx).expect("command");
            assert!(env.world().validate(Team::One, &Action::new(l.agents[agent], c)).is_ok(), "agent {agent} index {idx} {c:?}");
        }
    }
}

fn ability_counts(env: &Env, team: Team) -> u32 {
    env.world().stats(team).abilities.values().sum()
}

#[test]
fn ability_scenarios_end_with_abilities_used_by_both_sides() {
    // (scenario, opponent or PvP policy, seed, whether team 2 has an ability it can use here)
    for (name, both) in [
        ("8m3mr1mv1st_mirror", true),
        ("8m3mr1mv1st_mirror_pvp", true),
        ("8s_vs_8m3mr1mv1st", true),
        ("8s_vs_8m3mr1mv1st_pvp", true),
        ("pvz_ht", true),
        ("MMM_vs_MMM", true),
        ("terran_mirror", true),
        // Team 2 (Stalkers without Blink, Colossi) has no castable ability in this one.
        ("8m3mr1mv1st_vs_5s2c", false),
    ] {
        let s: Arc<Scenario> = Arc::new(builtin(name).expect("scenario"));
        let env = play(&s, EnvConfig::default(), 3, "focus-fire", "focus-fire");
        assert!(env.done(), "{name} did not end");
        assert!(ability_counts(&env, Team::One) > 0, "{name}: team 1 used no ability");
        if both {
            assert!(ability_counts(&env, Team::Two) > 0, "{name}: team 2 used no ability: {:?}", env.world().stats(Team::Two));
        }
    }
}

#[test]
fn episodes_with_abilities_replay_exactly() {
    for name in ["pvz_ht", "8m3mr1mv1st_mirror_pvp", "mixed_units_pvp"] {
        let s = Arc::new(builtin(name).expect("scenario"));
        let a = play(&s, EnvConfig::default(), 11, "kite", "focus");
        let b = play(&s, EnvConfig::default(), 11, "kite", "focus");
        assert_eq!(a.trajectory_hash(), b.trajectory_hash(), "{name}");
        assert_eq!(a.world().stats(Team::One), b.world().stats(Team::One));
    }
}

#[test]
fn scenario_energy_is_validated() {
    let bad = arena_units("pvp", &[("HighTemplar", 1, 8.0, 16.0, "energy = 250"), ("Zealot", 2, 15.0, 16.0, "")], "");
    let e = Scenario::from_toml("bad.toml", &bad).expect_err("over the maximum");
    assert!(e.to_string().contains("units[0].energy") && e.to_string().contains("250"), "{e}");
    let bad = arena_units("pvp", &[("Marine", 1, 8.0, 16.0, "energy = 10"), ("Zealot", 2, 15.0, 16.0, "")], "");
    let e = Scenario::from_toml("bad.toml", &bad).expect_err("a Marine has no energy");
    assert!(e.to_string().contains("has no energy"), "{e}");
    let ok = arena_units("pvp", &[("HighTemplar", 1, 8.0, 16.0, "energy = 200"), ("Zealot", 2, 15.0, 16.0, "")], "");
    let mut env = Env::new(load(&ok), exact_loop(), 1);
    run_loops(&mut env, 1);
    assert!(env.world().unit(uid(0)).is_some_and(|u| u.energy == 200.0));
}
