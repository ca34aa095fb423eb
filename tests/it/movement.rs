//! Movement, terrain, collisions and the playable area.

use crate::helpers::*;
use avacraft_engine::{Action, Command, Env, Team, UnitKind, Vec2, builtin};
use std::sync::Arc;

/// Every pair of living ground units, and how much they overlap (negative: apart).
fn worst_overlap(env: &Env) -> f32 {
    let us: Vec<_> = env.world().units().iter().filter(|u| u.alive && !u.flying()).collect();
    let mut worst = f32::MIN;
    for (i, a) in us.iter().enumerate() {
        for b in us[i + 1..].iter().filter(|b| a.collides_with(b)) {
            worst = worst.max(a.spec().radius + b.spec().radius - a.pos.dist(b.pos));
        }
    }
    worst
}

#[test]
fn ground_units_do_not_overlap_in_battle() {
    for name in ["2s3z_vlm", "3s_vs_3z_vlm", "8m2st_vs_35zg4b", "2c_vs_64zg_vlm"] {
        let s = Arc::new(builtin(name).expect("scenario"));
        let mut env = Env::new(s, exact(), 3);
        let mut worst = f32::MIN;
        let mut steps = 0;
        while !env.done() && steps < 200 {
            env.step();
            worst = worst.max(worst_overlap(&env));
            steps += 1;
        }
        // Local avoidance plus the separation pass keep bodies apart up to a sliver.
        assert!(worst < 0.1, "{name}: ground units overlapped by {worst}");
    }
}

#[test]
fn units_flow_around_a_blocker() {
    // A Marine walks east through a Zealot standing in its way and arrives on the far side.
    let s = load(&arena("pvp", &[("Marine", 1, 6.0, 16.0), ("Zealot", 1, 10.0, 16.0), ("Zergling", 2, 30.0, 2.0)]));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::MoveTo { to: Vec2::new(14.0, 16.0) })]);
    let mut min_gap = f32::MAX;
    for _ in 0..150 {
        env.step();
        let w = env.world();
        let (m, z) = (w.unit(uid(0)).expect("m"), w.unit(uid(1)).expect("z"));
        min_gap = min_gap.min(m.pos.dist(z.pos) - 0.875);
    }
    let m = env.world().unit(uid(0)).expect("marine");
    assert!(m.pos.dist(Vec2::new(14.0, 16.0)) < 0.6, "marine ended at {:?}", m.pos);
    assert!(min_gap > -0.1, "passed through the zealot: {min_gap}");
}

/// Height of every cell a unit stands on over an episode, and whether it ever stepped over
/// a cliff (a change of half a level or more between two loops).
fn path_heights(env: &mut Env, id: u16, loops: u32) -> (Vec<f32>, bool) {
    let mut hs = Vec::new();
    let mut cliff = false;
    let mut last = env.world().terrain().height_at(env.world().unit(uid(id)).expect("unit").pos);
    for _ in 0..loops {
        env.step();
        let h = env.world().terrain().height_at(env.world().unit(uid(id)).expect("unit").pos);
        cliff |= (h - last).abs() >= 0.5;
        last = h;
        hs.push(h);
    }
    (hs, cliff)
}

#[test]
fn ground_units_take_the_ramp_and_colossi_walk_cliffs() {
    // 2c_vs_64zg_vlm: the Colossi stand on a level-2 plateau; low ground is level 1; ramps at
    // x = 4..7 and 25..28. A Zergling ordered onto the plateau must use a ramp; a Colossus
    // ordered down walks straight over the cliff.
    let s = Arc::new(builtin("2c_vs_64zg_vlm").expect("scenario"));
    let zid = s.units.iter().position(|u| u.kind == UnitKind::Zergling).expect("zergling") as u16;
    let mut env = Env::new(Arc::clone(&s), one_loop(passive()), 1);
    let top = Vec2::new(16.0, 17.0);
    assert_eq!(env.world().terrain().height_at(top), 2.0);
    env.submit(Team::Two, &[]);
    // PvE: team 2 takes no agent actions; drive the world through a PvP copy instead.
    let mut raw = s.as_ref().clone();
    raw.mode = avacraft_engine::Mode::Pvp;
    let mut env = Env::new(Arc::new(raw), one_loop(passive()), 1);
    let r = env.submit(Team::Two, &[Action::new(uid(zid), Command::MoveTo { to: top })]);
    assert!(r[0].is_ok(), "{r:?}");
    let (hs, cliff) = path_heights(&mut env, zid, 500);
    assert!(!cliff, "the zergling crossed a cliff");
    assert!(hs.iter().any(|h| h.fract() != 0.0), "it never used a ramp");
    assert_eq!(hs.last().copied(), Some(2.0), "it did not reach the plateau");
    let r = env.submit(Team::One, &[Action::new(uid(0), Command::MoveTo { to: Vec2::new(13.9, 11.0) })]);
    assert!(r[0].is_ok());
    let (hs, cliff) = path_heights(&mut env, 0, 150);
    assert!(cliff, "the colossus should step straight down the cliff");
    assert_eq!(hs.last().copied(), Some(1.0));
    let _ = env.world().unit(uid(0)).expect("colossus");
}

#[test]
fn units_stay_in_the_playable_area() {
    // 8m1mv_vs_2st plays in [10, 54] x [8, 44] of a 64x64 map.
    let mut s = builtin("8m1mv_vs_2st").expect("scenario");
    s.mode = avacraft_engine::Mode::Pvp;
    let mut env = Env::new(Arc::new(s), one_loop(passive()), 1);
    let r = env.submit(Team::One, &[Action::new(uid(0), Command::MoveTo { to: Vec2::new(2.0, 2.0) })]);
    assert!(r[0].is_err(), "a point outside the playable area is refused");
    for d in [avacraft_engine::Direction::Left, avacraft_engine::Direction::Down] {
        for _ in 0..40 {
            env.submit(Team::One, &[Action::new(uid(8), Command::MoveDir { dir: d })]);
            for _ in 0..8 {
                env.step();
            }
        }
    }
    let p = env.world().unit(uid(8)).expect("medivac").pos;
    let play = env.world().terrain().playable();
    assert!(play.contains(p), "medivac left the playable area: {p:?}");
    assert!(p.x < play.left + 1.5 && p.y < play.bottom + 1.5, "it should reach the corner: {p:?}");
}

#[test]
fn directional_move_goes_two_cells_and_up_is_north() {
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 10.0), ("Marine", 2, 30.0, 30.0)]));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::MoveDir { dir: avacraft_engine::Direction::Up })]);
    for _ in 0..40 {
        env.step();
    }
    let p = env.world().unit(uid(0)).expect("m").pos;
    assert!((p.y - 12.0).abs() < 0.06 && (p.x - 10.0).abs() < 0.01, "SMAC's move amount is 2: {p:?}");
}

#[test]
fn grid_move_targets_the_cell_a_screenshot_labels() {
    // Cell (1, 1) is the top-left tenth of the playable area: x in [0, 3.2), y in (28.8, 32].
    let s = load(&arena("pvp", &[("Marine", 1, 16.0, 16.0), ("Marine", 2, 30.0, 2.0)]));
    let mut env = Env::new(s, one_loop(passive()), 1);
    env.submit(Team::One, &[Action::new(uid(0), Command::MoveGrid { x: 1, y: 1 })]);
    for _ in 0..250 {
        env.step();
    }
    let w = env.world();
    let p = w.unit(uid(0)).expect("m").pos;
    assert_eq!(avacraft_engine::grid_cell_of(w.terrain().playable(), p), (1, 1), "{p:?}");
    assert!(p.x < 3.2 && p.y > 28.8);
}

#[test]
fn a_move_into_the_void_goes_as_close_as_it_can() {
    // 3m_vlm's arena has no ground in its corners: grid cell (1, 1) is void. The Marine walks to
    // the nearest ground instead of freezing.
    let mut s = builtin("3m_vlm").expect("scenario");
    s.mode = avacraft_engine::Mode::Pvp;
    let mut env = Env::new(Arc::new(s), one_loop(passive()), 1);
    let start = env.world().unit(uid(0)).expect("marine").pos;
    let r = env.submit(Team::One, &[Action::new(uid(0), Command::MoveGrid { x: 1, y: 1 })]);
    assert!(r[0].is_ok(), "{r:?}");
    let Some(avacraft_engine::Order::Move { to }) = env.world().unit(uid(0)).map(|u| u.order) else { panic!("no move order") };
    assert!(env.world().terrain().walkable(to), "goal snapped onto ground: {to:?}");
    for _ in 0..300 {
        env.step();
    }
    let p = env.world().unit(uid(0)).expect("marine").pos;
    assert!(p.dist(to) < 0.5 && p.dist(start) > 3.0, "{start:?} -> {p:?}, goal {to:?}");
}

/// The surround experiment (`Rules::melee_surround`, off by default): twelve Zerglings
/// ordered onto the middle Zealot of a line of three. Off, they queue on the side they came
/// from; on, more of them reach it by walking round.
#[test]
fn the_surround_experiment_brings_more_melee_units_to_a_target() {
    let mut units: Vec<(&str, u8, f32, f32, &str)> = (0..3).map(|k| ("Zealot", 1, 10.0, 15.0 + k as f32, "")).collect();
    for i in 0..12 {
        units.push(("Zergling", 2, 18.0 + (i % 3) as f32 * 0.8, 14.0 + (i / 3) as f32 * 0.8, ""));
    }
    let s = load(&arena_units("pvp", &units, ""));
    let at_it = |surround: bool| {
        let mut cfg = passive();
        cfg.rules.melee_surround = surround;
        let mut env = Env::new(Arc::clone(&s), cfg, 1);
        env.reset(1);
        let z = env.world().alive(Team::One).nth(1).expect("middle Zealot").id;
        let orders: Vec<Action> = env.world().alive(Team::Two).map(|l| Action::new(l.id, Command::Attack { target: z })).collect();
        env.submit(Team::Two, &orders).into_iter().for_each(|r| r.expect("attack order"));
        let mut most = 0;
        for _ in 0..16 {
            env.step();
            let w = env.world();
            let zu = w.unit(z).expect("Zealot");
            let n = w.alive(Team::Two).filter(|l| l.pos.dist(zu.pos) - l.radius() - zu.radius() <= 0.15).count();
            most = most.max(n);
        }
        most
    };
    let (off, on) = (at_it(false), at_it(true));
    assert!(on > off, "Zerglings at the Zealot at once: {on} with the surround, {off} without");
}

/// The maps where the surround experiment can change a game: those with a melee unit on either
/// side, drawn ones included (SMACv2's Protoss draws Zealots; its Terran draws none).
#[test]
fn the_maps_with_melee_units_are_named() {
    for (name, melee) in [
        ("3m", false),
        ("2s_vs_1sc", false),
        ("2s3z", true),
        ("corridor", true),
        ("bane_vs_bane", true),
        ("protoss_5_vs_5", true),
        ("terran_5_vs_5", false),
    ] {
        assert_eq!(builtin(name).expect(name).has_melee(), melee, "{name}");
    }
}
