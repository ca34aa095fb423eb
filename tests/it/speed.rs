//! Movement speed: every mobile unit type and mode covers open ground at its StarCraft II
//! speed under every kind of move order, and stops at the goal.

use crate::helpers::*;
use avacraft_engine::DataSet;
use avacraft_engine::{Action, Command, Direction, LOOPS_PER_SECOND, MOVE_AMOUNT, Order, Team, UnitKind, Vec2, World, grid_cell_center};

/// Speed in cells per Faster second, as Liquipedia and `shared/reference/units.md` quote it
/// (python-sc2's Normal-speed value x1.4, rounded to what those pages print). Kept apart
/// from the unit table so that a conversion slip in the table shows up here too.
const FASTER_SPEED: &[(UnitKind, f32)] = &[
    (UnitKind::Marine, 3.15),
    (UnitKind::Marauder, 3.15),
    (UnitKind::Medivac, 3.5),
    (UnitKind::SiegeTank, 3.15),
    (UnitKind::Reaper, 5.25),
    (UnitKind::Hellbat, 3.15),
    (UnitKind::VikingAssault, 3.15),
    (UnitKind::VikingFighter, 3.85),
    (UnitKind::Ghost, 3.94),
    (UnitKind::Banshee, 3.85),
    (UnitKind::Zealot, 3.15),
    (UnitKind::Stalker, 4.13),
    (UnitKind::Sentry, 3.5),
    (UnitKind::HighTemplar, 2.82),
    (UnitKind::Archon, 3.94),
    (UnitKind::Immortal, 3.15),
    (UnitKind::Colossus, 3.15),
    (UnitKind::Phoenix, 5.95),
    (UnitKind::WarpPrism, 4.13),
    (UnitKind::Zergling, 4.13),
    (UnitKind::Baneling, 3.5),
    (UnitKind::Ultralisk, 4.13),
    (UnitKind::Queen, 1.31),
    (UnitKind::Hydralisk, 3.15),
];

/// Rows of the unit table that cannot move at all, and why; every other row must be in
/// [`FASTER_SPEED`].
const IMMOBILE: &[(UnitKind, &str)] = &[
    (UnitKind::SiegeTankSieged, "sieged: must unsiege (a morph) before it can move"),
    (UnitKind::WarpPrismPhasing, "phasing mode: a stationary power field until Transport Mode"),
    (UnitKind::PhotonCannon, "a structure"),
    (UnitKind::SpineCrawler, "rooted; uprooting is not modelled"),
];

/// Loops of margin past the ideal arrival loop (the last step is a partial one).
const ARRIVAL_SLACK: u32 = 3;
/// Loops the unit must then stay put.
const STAY_LOOPS: u32 = 40;
/// How far from the goal counts as there (the engine's own arrival distance is 0.05).
const AT_GOAL: f32 = 0.06;

#[derive(Clone, Copy, Debug)]
enum MoveOrder {
    MoveTo,
    MoveGrid,
    MoveDir,
    AttackMove,
}

/// One run: a lone unit of `kind` crosses a flat 32x32 arena under one kind of order, with a
/// single idle enemy far from its path (at least 14 cells: beyond every acquisition range,
/// so an attack-move meets no enemy). Returns what went wrong, if anything.
///
/// It drives the `World` loop by loop rather than an `Env`: an `Env` ends the episode as
/// soon as a side has no unit that can deal damage (SMAC's "only Medivacs left" rule), so
/// a lone Medivac or Warp Prism would be frozen after its first loop with its order still
/// `Move`, and an armed escort would make a healer on attack-move follow it instead.
fn run(kind: UnitKind, order: MoveOrder, per_loop: f32) -> Result<(), String> {
    // Grid row 5 of the 32x32 arena is at y = 17.6; directional and point moves use it too.
    let (start, goal_x) = match order {
        MoveOrder::MoveGrid => (1.6, 27.2),
        MoveOrder::MoveDir => (4.0, 4.0 + MOVE_AMOUNT),
        MoveOrder::MoveTo | MoveOrder::AttackMove => (4.0, 28.0),
    };
    let scenario = load(&arena("pvp", &[(kind.name(), 1, start, 17.6), ("Zergling", 2, 16.0, 1.0)]));
    let mut w = World::new(&scenario, passive().rules, 1);
    let id = uid(0);
    let goal = Vec2::new(goal_x, 17.6);
    let command = match order {
        MoveOrder::MoveTo => Command::MoveTo { to: goal },
        MoveOrder::MoveGrid => Command::MoveGrid { x: 9, y: 5 },
        MoveOrder::MoveDir => Command::MoveDir { dir: Direction::Right },
        MoveOrder::AttackMove => Command::AttackMoveTo { to: goal },
    };
    if let Command::MoveGrid { x, y } = command {
        let centre = grid_cell_center(w.terrain().playable(), x, y);
        assert!(centre.dist(goal) < 1e-4, "grid cell ({x}, {y}) is at {centre:?}, not {goal:?}");
    }
    w.apply(Team::One, &Action::new(id, command)).map_err(|e| format!("order refused: {e}"))?;
    let p0 = w.unit(id).expect("unit").pos;
    let dist = p0.dist(goal);
    // Mid-way the unit must still be at full speed: the engine does not model acceleration,
    // so the distance covered is speed x loops up to rounding.
    let mid = ((0.75 * dist / per_loop).floor() as u32).max(1);
    for _ in 0..mid {
        w.step_loop();
    }
    let u = w.unit(id).expect("unit");
    let covered = u.pos.x - p0.x;
    let want = per_loop * mid as f32;
    if (covered - want).abs() > 0.02 * want {
        return Err(format!(
            "covered {covered:.3} cells in {mid} loops, want {want:.3} ({per_loop:.4}/loop); at {:?}, vel {:?}, order {:?}",
            u.pos, u.vel, u.order
        ));
    }
    if (u.pos.y - p0.y).abs() > 0.01 {
        return Err(format!("left the straight line: at {:?}", u.pos));
    }
    let arrive = (dist / per_loop).ceil() as u32 + ARRIVAL_SLACK;
    for _ in mid..arrive {
        w.step_loop();
    }
    let u = w.unit(id).expect("unit");
    let off = u.pos.dist(goal);
    if off > AT_GOAL || u.order != Order::Idle {
        return Err(format!("after {arrive} loops: {off:.3} from the goal at {:?}, vel {:?}, order {:?}", u.pos, u.vel, u.order));
    }
    for _ in 0..STAY_LOOPS {
        w.step_loop();
    }
    let u = w.unit(id).expect("unit");
    let off = u.pos.dist(goal);
    if off > AT_GOAL || u.vel.len() > 1e-6 {
        return Err(format!("did not stay at the goal: {off:.3} from it {STAY_LOOPS} loops later, vel {:?}", u.vel));
    }
    Ok(())
}

#[test]
fn every_mobile_unit_moves_at_its_speed_and_stops_at_the_goal() {
    // Every row of the table is either listed as immobile (with zero speed) or tested.
    for k in UnitKind::ALL {
        let immobile = IMMOBILE.iter().any(|(i, _)| *i == k);
        let listed = FASTER_SPEED.iter().any(|(m, _)| *m == k);
        assert!(immobile != listed, "{k}: list it in exactly one of FASTER_SPEED and IMMOBILE");
        assert_eq!(
            immobile,
            k.spec_in(DataSet::Legacy).speed == 0.0,
            "{k}: table speed {} disagrees with IMMOBILE",
            k.spec_in(DataSet::Legacy).speed
        );
    }
    let mut failures = Vec::new();
    for &(kind, faster) in FASTER_SPEED {
        // Faster seconds to game loops (22.4 a second); the table rounds to 1 % at most.
        let per_loop = faster / LOOPS_PER_SECOND;
        let table = kind.spec_in(DataSet::Legacy).speed;
        if (table - per_loop).abs() > 0.01 * per_loop {
            failures.push(format!("{kind}: table speed {table:.4}/loop, StarCraft II's {per_loop:.4}/loop"));
        }
        for order in [MoveOrder::MoveTo, MoveOrder::MoveGrid, MoveOrder::MoveDir, MoveOrder::AttackMove] {
            if let Err(e) = run(kind, order, table) {
                failures.push(format!("{kind} {order:?}: {e}"));
            }
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}
