//! Each splash shape, with StarCraft II numbers worked by hand.

use crate::helpers::*;
use avacraft_engine::{Action, Command, Env, Team};

fn hp(env: &Env, i: u16) -> f32 {
    env.world().unit(uid(i)).map(|u| u.hp).unwrap_or(f32::NAN)
}

#[test]
fn sieged_tank_three_radii_and_friendly_fire() {
    // Tank (team 1) fires at the Marine at (20, 16): 40 (+30 armoured) = 40 to a light Marine.
    // Others by edge distance to the impact: 0.3 -> 100%, 0.7 -> 50%, 1.1 -> 25%, 1.6 -> none.
    // The Marine at 0.7 is the tank's own: friendly fire.
    let r = 0.375;
    let units = [
        ("SiegeTankSieged", 1, 8.0, 16.0),
        ("Marine", 2, 20.0, 16.0),
        ("Marine", 2, 20.0, 16.0 + 0.3 + r),
        ("Marine", 1, 20.0, 16.0 - 0.7 - r),
        ("Marine", 2, 20.0 + 1.1 + r, 16.0),
        ("Marine", 2, 20.0 - 1.6 - r, 16.0),
    ];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::Attack { target: uid(1) })]);
    env.step();
    assert_eq!([hp(&env, 1), hp(&env, 2), hp(&env, 3), hp(&env, 4), hp(&env, 5)], [5.0, 5.0, 25.0, 35.0, 45.0]);
}

#[test]
fn baneling_explosion_hits_enemies_not_friends() {
    // 16 (+19 light) = 35 to every enemy whose edge is within 2.2 of the Baneling; none to
    // its own Zerglings; the Baneling dies.
    let units = [
        ("Baneling", 2, 10.0, 16.0),
        ("Marine", 1, 10.9, 16.0),
        ("Marine", 1, 10.0, 16.0 + 2.0 + 0.375),
        ("Marine", 1, 10.0, 16.0 - 2.5 - 0.375),
        ("Zergling", 2, 9.0, 16.0),
        ("Marauder", 1, 8.0, 17.8),
    ];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::Two, &[Action::new(uid(0), Command::Attack { target: uid(1) })]);
    env.step();
    let w = env.world();
    assert!(!w.unit(uid(0)).is_some_and(|u| u.alive), "the Baneling is spent");
    assert_eq!([hp(&env, 1), hp(&env, 2), hp(&env, 3)], [10.0, 10.0, 45.0]);
    assert_eq!(hp(&env, 4), 35.0, "no friendly fire");
    // Marauder: armoured, 16 - 1 armour = 15; its edge is 2.7 - 0.5625 = 2.14 from the Baneling.
    assert_eq!(hp(&env, 5), 125.0 - 15.0);
}

#[test]
fn colossus_lance_hits_a_line_across_the_shot() {
    // Colossus at (10, 16) fires east at a Zergling at (16, 16); the lance runs north-south
    // through the impact point, 1.4 each way: Zerglings at (16, 17.2) and (16, 14.9) are on
    // it, one at (17.5, 16) behind the target is not. 10 (+5 light) x2 = 30 each.
    let units = [
        ("Colossus", 1, 10.0, 16.0),
        ("Zergling", 2, 16.0, 16.0),
        ("Zergling", 2, 16.0, 17.2),
        ("Zergling", 2, 16.0, 14.9),
        ("Zergling", 2, 17.5, 16.0),
    ];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::Attack { target: uid(1) })]);
    env.step();
    // Zerglings regenerate their per-loop share after the hit.
    let z = avacraft_engine::UnitKind::Zergling.spec_in(avacraft_engine::DataSet::Legacy).regen.life;
    assert_eq!([hp(&env, 1), hp(&env, 2), hp(&env, 3), hp(&env, 4)], [5.0 + z, 5.0 + z, 5.0 + z, 35.0]);
}

#[test]
fn archon_splash_zones() {
    // Archon: 25 (+10 biological) = 35 to the Zergling it hits; splash 100% / 50% / 25% to
    // enemies whose edge is within 0.25 / 0.5 / 1.0 of the impact.
    let units = [
        ("Archon", 1, 10.0, 16.0),
        ("Zergling", 2, 13.5, 16.0),
        ("Zergling", 2, 13.5, 16.55),
        ("Zergling", 2, 13.5, 15.2),
        ("Zergling", 2, 14.8, 16.0),
        ("Zergling", 2, 13.5, 18.0),
    ];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::Attack { target: uid(1) })]);
    env.step();
    // (Zerg regeneration adds 0.017 in the loop.)
    let got = [1, 2, 3, 4, 5].map(|i| hp(&env, i));
    let want = [0.0, 0.0, 35.0 - 17.5, 35.0 - 8.75, 35.0];
    assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 0.05), "{got:?} vs {want:?}");
}

#[test]
fn hellbat_cone_and_ultralisk_cleave() {
    // Hellbat: 18 to the target and to enemies in its 45-degree cone; nothing behind it.
    let units = [("Hellbat", 1, 10.0, 16.0), ("Zealot", 2, 11.9, 16.0), ("Zealot", 2, 11.9, 16.6), ("Zealot", 2, 8.5, 16.0)];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::Attack { target: uid(1) })]);
    env.step();
    let sh = |i: u16| env.world().unit(uid(i)).map(|u| u.shield).unwrap_or(f32::NAN);
    assert_eq!([sh(1), sh(2), sh(3)], [32.0, 32.0, 50.0]);
    // Ultralisk: 35 - 0 armour to a Marine, a third of it (11.55) to enemies in its arc.
    let units = [("Ultralisk", 1, 10.0, 16.0), ("Marine", 2, 11.3, 16.0), ("Marine", 2, 11.1, 17.0), ("Marine", 2, 8.6, 16.0)];
    let s = load(&arena("pvp", &units));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::Attack { target: uid(1) })]);
    env.step();
    assert_eq!(hp(&env, 1), 10.0);
    assert!((hp(&env, 2) - (45.0 - 35.0 * 0.33)).abs() < 1e-4);
    assert_eq!(hp(&env, 3), 45.0);
}
