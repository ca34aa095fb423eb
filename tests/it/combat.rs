//! Damage, cooldowns, range and duels, with StarCraft II numbers worked by hand.

use crate::helpers::*;
use avacraft_engine::DataSet;
use avacraft_engine::{Env, Outcome, Team, UnitKind};

/// Loops at which a unit firing continuously shoots, from its cooldown in loops, with the
/// engine's rule: fire when the cooldown is at most 0; after firing it is the weapon's
/// cooldown plus the (negative) leftover, clamped to -1; one is taken off every loop.
fn shot_loops(cooldown: f32, n: usize) -> Vec<u32> {
    let (mut cd, mut out) = (0.0f32, Vec::new());
    let mut t = 0;
    while out.len() < n {
        if cd <= 0.0 {
            out.push(t);
            cd = cooldown + cd.clamp(-1.0, 0.0);
        }
        cd = (cd - 1.0).max(-1.0);
        t += 1;
    }
    out
}

#[test]
fn marine_cooldown_is_13_77_loops() {
    // 0.8608 Normal seconds * 16 = 13.77 loops: shots at 0, 14, 28, 42, 56, 69, 83, 97.
    assert_eq!(shot_loops(13.7734, 8), [0, 14, 28, 42, 56, 69, 83, 97]);
    // And the engine fires on exactly those loops: a Marine on a Spine Crawler in range.
    let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("SpineCrawler", 2, 15.0, 16.0)]));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Attack { target: uid(1) })]);
    let mut shots = Vec::new();
    for _ in 0..100 {
        let t = env.world().tick();
        env.step();
        if env.world().shots().iter().any(|s| s.from == uid(0)) {
            shots.push(t);
        }
    }
    assert_eq!(shots, [0, 14, 28, 42, 56, 69, 83, 97]);
}

#[test]
fn marine_mirror_duel_is_a_draw_at_loop_98() {
    // 45 HP / 6 per shot = 8 shots; both fire on loops 0..97 (above) and die on the 8th.
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 15.0, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 1);
    while !env.done() {
        env.step();
    }
    assert_eq!(env.outcome(), Some(Outcome::Draw));
    assert_eq!(env.world().tick(), 98);
}

#[test]
fn zealot_beats_marine_at_loop_40() {
    // Zealot: 8x2 per attack, cooldown 1.2 Normal s = 19.2 loops: attacks at 0, 20, 39.
    // Marine 45 HP, armour 0: 16 per attack, dead after the third (loop 39).
    // Marine: 6 per shot into 50 shields; three shots (0, 14, 28) leave the Zealot at 32 shields.
    assert_eq!(shot_loops(19.2, 3), [0, 20, 39]);
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Zealot", 2, 10.9, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 1);
    while !env.done() {
        env.step();
    }
    assert_eq!(env.outcome(), Some(Outcome::Loss));
    assert_eq!(env.world().tick(), 40);
    let z = env.world().unit(uid(1)).expect("zealot");
    assert_eq!((z.shield, z.hp), (50.0 - 18.0, 100.0));
}

#[test]
fn marine_on_zealot_shield_then_hull_in_game() {
    let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Zealot", 2, 14.0, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 1);
    env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Attack { target: uid(1) })]);
    env.step();
    let z = env.world().unit(uid(1)).expect("zealot");
    assert_eq!((z.shield, z.hp), (44.0, 100.0), "a Marine shot takes 6 off the shields");
}

#[test]
fn edge_to_edge_range() {
    // Marine range 5, radii 0.375 + 0.5: fires at centre distance 5.87, not at 5.93.
    for (dx, fires) in [(5.87, true), (5.93, false)] {
        let s = load(&arena("pve", &[("Marine", 1, 10.0, 16.0), ("Zealot", 2, 10.0 + dx, 16.0)]));
        let mut env = Env::new(s, one_loop(exact()), 1);
        env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Hold)]);
        env.step();
        let shot = env.world().shots().iter().any(|s| s.from == uid(0));
        assert_eq!(shot, fires, "centre distance {dx}");
    }
}

#[test]
fn bonus_damage_and_armour_per_hit() {
    // Marauder on Stalker: 10 + 10 armoured = 20 into 80 shields.
    // Zealot on Ultralisk: 2 hits of 8 - 2 armour = 12 to the hull.
    let s = load(&arena("pvp", &[("Marauder", 1, 10.0, 16.0), ("Stalker", 2, 15.0, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 1);
    env.submit(Team::Two, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Hold)]);
    env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Attack { target: uid(1) })]);
    env.step();
    assert_eq!(env.world().unit(uid(1)).map(|u| u.shield), Some(60.0));
    let s = load(&arena("pvp", &[("Zealot", 1, 10.0, 16.0), ("Ultralisk", 2, 11.45, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 1);
    env.step();
    // Zerg regeneration adds its per-loop share at the end of the loop.
    let hp = env.world().unit(uid(1)).map_or(0.0, |u| u.hp);
    assert!((hp - (500.0 - 12.0 + UnitKind::Ultralisk.spec_in(DataSet::Legacy).regen.life)).abs() < 1e-4, "{hp}");
}

#[test]
fn cooldowns_in_loops_match_the_data() {
    // python-sc2 Normal-speed cooldowns times 16.
    for (k, loops) in
        [(UnitKind::Marine, 13.773), (UnitKind::Stalker, 29.92), (UnitKind::Zergling, 11.136), (UnitKind::SiegeTankSieged, 48.0)]
    {
        let cd = k.spec_in(DataSet::Legacy).weapons[0].cooldown;
        assert!((cd - loops).abs() < 0.01, "{k}: {cd}");
    }
}

#[test]
fn regeneration_rates() {
    // The legacy table's rates (arenas without `data` play it); game_data.rs checks the sets'.
    let legacy = |k: UnitKind| k.spec_in(DataSet::Legacy).regen;
    let (shield_regen, shield_delay) = (legacy(UnitKind::Zealot).shield, legacy(UnitKind::Zealot).shield_delay as u32);
    let (zerg_regen, energy_regen) = (legacy(UnitKind::Zergling).life, legacy(UnitKind::HighTemplar).energy);
    // Shields: nothing for 160 loops after the last damage, then 2 per Normal second.
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Zealot", 2, 15.5, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 1);
    env.submit(Team::Two, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Hold)]);
    env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Attack { target: uid(1) })]);
    env.step();
    env.submit(
        Team::One,
        &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::MoveTo { to: avacraft_engine::Vec2::new(2.0, 30.0) })],
    );
    assert_eq!(env.world().unit(uid(1)).map(|u| u.shield), Some(44.0));
    // Damaged on loop 0: loops 1..=159 regenerate nothing, loop 160 is the first that does.
    for _ in 1..shield_delay {
        env.step();
    }
    let sh = env.world().unit(uid(1)).map(|u| u.shield).unwrap_or_default();
    assert!((sh - 44.0).abs() < 1e-4, "no regeneration during the delay: {sh}");
    for _ in 0..16 {
        env.step();
    }
    let sh = env.world().unit(uid(1)).map(|u| u.shield).unwrap_or_default();
    assert!((sh - (44.0 + 16.0 * shield_regen)).abs() < 1e-3, "2 shields per Normal second: {sh}");
    assert!((shield_regen * 16.0 - 2.0).abs() < 1e-6);
    assert!((zerg_regen * 22.4 - 0.38).abs() < 1e-6);
    assert!((energy_regen * 22.4 - 0.7875).abs() < 1e-6);
}
