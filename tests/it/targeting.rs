//! Target acquisition as StarCraft II does it.

use crate::helpers::*;
use avacraft_engine::{Env, Team};

#[test]
fn threats_before_harmless_units_then_distance() {
    // An idle Marine with a Medivac (harmless) closer than a Zergling: it shoots the Zergling.
    let s = load(&arena(
        "pvp",
        &[("Marine", 1, 10.0, 16.0), ("Medivac", 2, 12.0, 16.0), ("Zergling", 2, 14.0, 16.0), ("Zergling", 2, 14.5, 17.0)],
    ));
    let mut env = Env::new(s, one_loop(exact()), 0);
    env.submit(
        Team::Two,
        &[
            avacraft_engine::Action::new(uid(2), avacraft_engine::Command::Hold),
            avacraft_engine::Action::new(uid(3), avacraft_engine::Command::Hold),
        ],
    );
    env.step();
    assert_eq!(env.world().unit(uid(0)).and_then(|u| u.target), Some(uid(2)));
}

#[test]
fn a_unit_keeps_its_target_while_it_is_valid() {
    // A Marine engaged with a Zergling keeps it even when another one comes closer.
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Zergling", 2, 14.0, 16.0), ("Zergling", 2, 13.0, 20.0)]));
    let mut env = Env::new(s, one_loop(exact()), 0);
    env.submit(Team::Two, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Hold)]);
    env.submit(
        Team::Two,
        &[avacraft_engine::Action::new(uid(2), avacraft_engine::Command::MoveTo { to: avacraft_engine::Vec2::new(11.0, 16.8) })],
    );
    let mut first = None;
    for _ in 0..30 {
        env.step();
        let t = env.world().unit(uid(0)).and_then(|u| u.target);
        first = first.or(t);
        assert_eq!(t, first, "switched targets");
    }
    assert_eq!(first, Some(uid(1)));
}

#[test]
fn passive_units_do_not_acquire_but_hold_fires() {
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Marine", 1, 10.0, 14.0), ("Zergling", 2, 13.0, 15.0)]));
    let mut env = Env::new(s, one_loop(passive()), 0);
    env.submit(Team::One, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Hold)]);
    env.step();
    let shooters: Vec<_> = env.world().shots().iter().map(|s| s.from).collect();
    assert_eq!(shooters, [uid(1)]);
}

#[test]
fn idle_units_answer_an_attacker_beyond_their_acquisition_range() {
    // A Stalker (range 6) shoots an idle Zealot from 7 away (5.9 edge to edge): beyond the Zealot's scan
    // range of 5, but it turns on its attacker.
    let s = load(&arena("pvp", &[("Zealot", 1, 10.0, 16.0), ("Stalker", 2, 17.0, 16.0)]));
    let mut env = Env::new(s, one_loop(exact()), 0);
    env.submit(Team::Two, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Attack { target: uid(0) })]);
    env.step();
    env.submit(Team::Two, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Hold)]);
    for _ in 0..20 {
        env.step();
    }
    let z = env.world().unit(uid(0)).expect("zealot");
    assert_eq!(z.target, Some(uid(1)));
    assert!(z.pos.x > 11.0, "it closes in: {:?}", z.pos);
}

#[test]
fn photon_cannons_need_the_warp_prism_field() {
    // A phasing Warp Prism powers Cannons within 3.75; without it they do nothing.
    for (with_prism, fires) in [(true, true), (false, false)] {
        let mut units = vec![("PhotonCannon", 2, 16.0, 16.0), ("Marine", 1, 16.0, 10.5)];
        if with_prism {
            units.push(("WarpPrismPhasing", 2, 18.0, 17.0));
        }
        let s = load(&arena("pvp", &units));
        let mut env = Env::new(s, one_loop(exact()), 0);
        env.submit(Team::One, &[avacraft_engine::Action::new(uid(1), avacraft_engine::Command::Hold)]);
        for _ in 0..5 {
            env.step();
        }
        let hp = env.world().unit(uid(1)).map_or(0.0, |u| u.hp);
        assert_eq!(hp < 45.0, fires, "prism {with_prism}: marine at {hp}");
    }
}

#[test]
fn passive_medivacs_do_not_autocast() {
    let s =
        load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Medivac", 1, 11.0, 16.0), ("Zealot", 2, 10.9, 16.0), ("Marine", 2, 30.0, 30.0)]));
    let mut env = Env::new(s, one_loop(passive()), 0);
    env.submit(Team::Two, &[avacraft_engine::Action::new(uid(2), avacraft_engine::Command::Attack { target: uid(0) })]);
    env.step();
    env.submit(
        Team::Two,
        &[avacraft_engine::Action::new(uid(2), avacraft_engine::Command::MoveTo { to: avacraft_engine::Vec2::new(25.0, 25.0) })],
    );
    for _ in 0..30 {
        env.step();
    }
    assert_eq!(env.world().unit(uid(0)).map(|u| u.hp), Some(45.0 - 16.0));
}
