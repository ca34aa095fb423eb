//! Typed actions: each refusal reason, counting, and orders kept on refusal.

use crate::helpers::*;
use avacraft_engine::{Action, ActionError, Command, Env, Order, Team, Vec2};

fn setup() -> Env {
    let s = load(&arena(
        "pve",
        &[
            ("Marine", 1, 10.0, 16.0),
            ("Medivac", 1, 9.0, 16.0),
            ("SiegeTankSieged", 1, 8.0, 14.0),
            ("Marine", 2, 14.0, 16.0),
            ("Medivac", 2, 15.0, 18.0),
        ],
    ));
    Env::new(s, passive(), 0)
}

#[test]
fn every_refusal_reason_is_typed_and_counted() {
    let mut env = setup();
    env.submit(Team::One, &[Action::new(uid(0), Command::MoveTo { to: Vec2::new(5.0, 5.0) })]);
    let before = env.world().unit(uid(0)).map(|u| u.order);
    type Check = fn(&ActionError) -> bool;
    let cases: Vec<(Action, Check)> = vec![
        (Action::new(uid(99), Command::Stop), |e| matches!(e, ActionError::UnknownUnit { .. })),
        (Action::new(uid(3), Command::Stop), |e| matches!(e, ActionError::NotYourUnit { .. })),
        (Action::new(uid(0), Command::Attack { target: uid(77) }), |e| matches!(e, ActionError::UnknownTarget { .. })),
        (Action::new(uid(0), Command::Attack { target: uid(1) }), |e| matches!(e, ActionError::InvalidTarget { .. })),
        (Action::new(uid(0), Command::MoveGrid { x: 0, y: 3 }), |e| matches!(e, ActionError::OffGrid { x: 0, y: 3 })),
        (Action::new(uid(0), Command::MoveGrid { x: 4, y: 11 }), |e| matches!(e, ActionError::OffGrid { .. })),
        (Action::new(uid(0), Command::MoveTo { to: Vec2::new(-1.0, 3.0) }), |e| matches!(e, ActionError::OffMap { .. })),
        (Action::new(uid(0), Command::MoveTo { to: Vec2::new(f32::NAN, 3.0) }), |e| matches!(e, ActionError::OffMap { .. })),
        (Action::new(uid(2), Command::MoveDir { dir: avacraft_engine::Direction::Up }), |e| matches!(e, ActionError::Unavailable { .. })),
        (Action::new(uid(1), Command::Attack { target: uid(3) }), |e| matches!(e, ActionError::InvalidTarget { .. })),
        (Action::new(uid(1), Command::Attack { target: uid(2) }), |e| matches!(e, ActionError::InvalidTarget { .. })),
        // A Marauder-less test: the sieged tank cannot hit air.
        (Action::new(uid(2), Command::Attack { target: uid(4) }), |e| matches!(e, ActionError::InvalidTarget { .. })),
    ];
    let n = cases.len() as u32;
    for (a, check) in cases {
        let r = env.submit(Team::One, &[a]);
        let e = r[0].as_ref().expect_err("refused");
        assert!(check(e), "{a:?}: {e}");
        assert!(!e.to_string().is_empty());
    }
    assert_eq!(env.refused(), [n, 0]);
    assert_eq!(env.world().unit(uid(0)).map(|u| u.order), before, "the unit keeps its order");
    // The episode goes on.
    assert!(!env.step().done);
}

#[test]
fn pve_opponent_units_take_no_agent_orders_and_dead_units_none() {
    let mut env = setup();
    let r = env.submit(Team::Two, &[Action::new(uid(3), Command::Stop)]);
    assert!(matches!(r[0], Err(ActionError::Unavailable { .. })), "{r:?}");
    // Kill the enemy Marine, then order it.
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Zealot", 2, 10.9, 16.0), ("Zealot", 2, 30.0, 30.0)]));
    let mut env = Env::new(s, one_loop(exact()), 0);
    while env.world().unit(uid(0)).is_some_and(|u| u.alive) {
        env.step();
    }
    let r = env.submit(Team::One, &[Action::new(uid(0), Command::Stop)]);
    assert!(matches!(r[0], Err(ActionError::DeadUnit { .. })));
    let r = env.submit(Team::Two, &[Action::new(uid(1), Command::Attack { target: uid(0) })]);
    assert!(matches!(r[0], Err(ActionError::TargetDead { .. })));
}

#[test]
fn valid_orders_take_effect() {
    let mut env = setup();
    let r = env.submit(
        Team::One,
        &[
            Action::new(uid(0), Command::Hold),
            Action::new(uid(1), Command::AttackMoveTo { to: Vec2::new(20.0, 20.0) }),
            Action::new(uid(2), Command::Attack { target: uid(3) }),
        ],
    );
    assert!(r.iter().all(Result::is_ok), "{r:?}");
    let o = |i| env.world().unit(uid(i)).map(|u| u.order);
    assert_eq!(o(0), Some(Order::Hold));
    assert_eq!(o(1), Some(Order::AttackMove { to: Vec2::new(20.0, 20.0) }));
    assert_eq!(o(2), Some(Order::Attack { target: uid(3) }));
    let r = env.submit(Team::One, &[Action::new(uid(0), Command::Stop)]);
    assert!(r[0].is_ok());
    assert_eq!(env.world().unit(uid(0)).map(|u| u.order), Some(Order::Idle));
}

#[test]
fn medivac_heals_biological_allies() {
    // A wounded Marine next to a Medivac: 9 HP per Normal second (0.5625 per loop), 1 energy per 3 HP.
    let s =
        load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Medivac", 1, 11.0, 16.0), ("Zealot", 2, 10.9, 16.0), ("Marine", 2, 30.0, 30.0)]));
    let mut env = Env::new(s, one_loop(passive()), 0);
    env.submit(Team::Two, &[Action::new(uid(2), Command::Attack { target: uid(0) })]);
    env.step();
    env.submit(Team::Two, &[Action::new(uid(2), Command::MoveTo { to: Vec2::new(25.0, 25.0) })]);
    let hurt = env.world().unit(uid(0)).map_or(0.0, |u| u.hp);
    assert_eq!(hurt, 45.0 - 16.0);
    let energy = env.world().unit(uid(1)).map_or(0.0, |u| u.energy);
    env.submit(Team::One, &[Action::new(uid(1), Command::Attack { target: uid(0) })]);
    for _ in 0..16 {
        env.step();
    }
    let hp = env.world().unit(uid(0)).map_or(0.0, |u| u.hp);
    assert!((hp - (hurt + 9.0)).abs() < 1e-3, "{hp}");
    let spent = energy + 16.0 * avacraft_engine::UnitKind::Medivac.spec_in(avacraft_engine::DataSet::Legacy).regen.energy
        - env.world().unit(uid(1)).map_or(0.0, |u| u.energy);
    assert!((spent - 3.0).abs() < 1e-3, "{spent}");
}
