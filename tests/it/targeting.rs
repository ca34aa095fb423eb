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
