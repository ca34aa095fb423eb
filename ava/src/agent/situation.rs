//! The situation in words, in the screenshot's terms: every position is a cell of the grid
//! the image draws over the same camera view (the paper's code described positions on a 3x3
//! grid while its image showed 10x10), and units off screen say which way they are.

use crate::decision::Order;
use avacraft_engine::agent::{GroupObs, Stance, view};
use avacraft_engine::{Command, Direction, UnitId, UnitInfo, loops_to_seconds};
use avacraft_render::Camera;
use std::fmt::Write as _;

/// Where a unit is, in the view's terms.
pub fn place(camera: &Camera, u: &UnitInfo) -> String {
    let p = view::pos(u);
    match camera.cell_of(p) {
        Some((c, r)) => format!("cell [{c}, {r}]"),
        None => {
            let r = camera.rect();
            let ns = if p.y > r.top {
                "north"
            } else if p.y < r.bottom {
                "south"
            } else {
                ""
            };
            let ew = if p.x > r.right {
                "east"
            } else if p.x < r.left {
                "west"
            } else {
                ""
            };
            format!("off screen to the {ns}{ew}")
        }
    }
}

fn vitals(u: &UnitInfo) -> String {
    let mut s = format!("HP {:.0}/{:.0}", u.hp, u.max_hp);
    if u.max_shield > 0.0 {
        let _ = write!(s, ", shield {:.0}/{:.0}", u.shield, u.max_shield);
    }
    if u.max_energy > 0.0 {
        let _ = write!(s, ", energy {:.0}/{:.0}", u.energy, u.max_energy);
    }
    s
}

/// The unit block of a prompt: own units with weapons and abilities, then the enemies seen.
pub fn describe(obs: &GroupObs, camera: &Camera, controlled: &[UnitId]) -> String {
    let mut s = format!("Step {}, game time {:.1} s.\nYour units:\n", obs.step, loops_to_seconds(obs.game_loop));
    for u in obs.units.iter().filter(|u| u.own && controlled.contains(&u.tag)) {
        let _ = write!(s, "- {} {} at {}: {}", u.tag.tag(), u.kind.name(), place(camera, u), vitals(u));
        if !u.spec().weapons.is_empty() {
            if u.weapon_cooldown_s > 0.0 {
                let _ = write!(s, ", weapon ready in {:.1} s", u.weapon_cooldown_s);
            } else {
                s.push_str(", weapon ready");
            }
        }
        if !u.abilities.is_empty() {
            let list: Vec<String> = u
                .abilities
                .iter()
                .map(|a| {
                    if a.available {
                        format!("{} (ready)", a.ability.name())
                    } else {
                        format!("{} ({})", a.ability.name(), a.why_not.map_or("not ready", |c| c.text()))
                    }
                })
                .collect();
            let _ = write!(s, "; abilities: {}", list.join(", "));
        }
        s.push('\n');
    }
    let others: Vec<&UnitInfo> = obs.units.iter().filter(|u| u.own && !controlled.contains(&u.tag)).collect();
    if !others.is_empty() {
        s.push_str("Other friendly units (not yours to command):\n");
        for u in others {
            let _ = writeln!(s, "- {} {} at {}: {}", u.tag.tag(), u.kind.name(), place(camera, u), vitals(u));
        }
    }
    let enemies: Vec<&UnitInfo> = obs.units.iter().filter(|u| !u.own).collect();
    if enemies.is_empty() {
        s.push_str("No enemy in sight.\n");
    } else {
        s.push_str("Enemies in sight:\n");
        for u in enemies {
            let _ = writeln!(s, "- {} {} at {}: {}", u.tag.tag(), u.kind.name(), place(camera, u), vitals(u));
        }
    }
    s
}

/// Sums that outcomes are measured by: living units and their HP plus shields, per side.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    pub own_units: usize,
    pub own_life: f32,
    pub enemy_units: usize,
    pub enemy_life: f32,
}

impl Tally {
    pub fn of(obs: &GroupObs) -> Tally {
        let mut t = Tally::default();
        for u in &obs.units {
            if u.own {
                t.own_units += 1;
                t.own_life += u.hp + u.shield;
            } else {
                t.enemy_units += 1;
                t.enemy_life += u.hp + u.shield;
            }
        }
        t
    }

    /// What happened between two tallies, in words. Enemies leaving sight count as lost
    /// from view, which is all a player can tell.
    pub fn outcome(&self, now: &Tally) -> String {
        format!(
            "you lost {} unit(s) and {:.0} HP+shields; enemies in sight went from {} to {} and lost {:.0} HP+shields",
            self.own_units.saturating_sub(now.own_units),
            (self.own_life - now.own_life).max(0.0),
            self.enemy_units,
            now.enemy_units,
            (self.enemy_life - now.enemy_life).max(0.0)
        )
    }
}

/// The fallback's commands: idle units attack the nearest enemy they can hit.
pub fn attack_nearest(obs: &GroupObs, units: &[UnitId]) -> Vec<(UnitId, Command)> {
    let mut out = Vec::new();
    // Not a unit that is morphing or channelling: the engine would refuse it.
    for u in obs.units.iter().filter(|u| u.own && units.contains(&u.tag) && view::is_idle(u) && !view::busy(u)) {
        let nearest = obs
            .units
            .iter()
            .filter(|t| !t.own && view::can_attack(u, t))
            .min_by(|a, b| view::edge(u, a).total_cmp(&view::edge(u, b)).then(a.tag.cmp(&b.tag)));
        if let Some(t) = nearest {
            out.push((u.tag, Command::Attack { target: view::id(t) }));
        }
    }
    out
}

/// An order in words for the history. `grid` is the camera of the paper's prompt: its
/// history keeps the wording its recorded calls were made with (moves as "move to [c, r]",
/// directions as "move right"), so they still replay; the rich prompt (`grid` none) writes
/// the schema's own words, with points for moves.
pub fn order_text(unit: UnitId, o: &Order, grid: Option<&Camera>) -> String {
    let tag = unit.tag();
    match o {
        Order::Do(c) => command_text(tag, c, grid),
        Order::Keep(Stance::Focus { target: Some(target) } | Stance::Kite { target: Some(target) }) => {
            format!("{tag} stance {} {}", if matches!(o, Order::Keep(Stance::Focus { .. })) { "focus" } else { "kite" }, target.tag())
        }
        Order::Keep(st) => format!("{tag} stance {}", st.name()),
    }
}

fn command_text(tag: u32, c: &Command, grid: Option<&Camera>) -> String {
    match (c, grid) {
        (Command::Attack { target }, _) => format!("{tag} attack {}", target.tag()),
        (Command::MoveTo { to }, Some(camera)) => match camera.cell_of(*to) {
            Some((col, row)) => format!("{tag} move to [{col}, {row}]"),
            None => format!("{tag} move"),
        },
        (Command::MoveTo { to }, None) => format!("{tag} move ({:.1},{:.1})", to.x, to.y),
        (Command::MoveDir { dir }, Some(_)) => format!("{tag} move {dir:?}").to_lowercase(),
        (Command::MoveDir { dir }, None) => format!("{tag} move_dir {}", compass(*dir)),
        (Command::AttackMoveTo { to }, _) => format!("{tag} attack_move ({:.1},{:.1})", to.x, to.y),
        (Command::Ability { ability, .. }, _) => format!("{tag} {}", ability.name()),
        (Command::Hold, _) => format!("{tag} hold"),
        (Command::Stop, _) => format!("{tag} stop"),
        (other, _) => format!("{tag} {other:?}"),
    }
}

/// A `move_dir` direction as the schema names it.
pub fn compass(d: Direction) -> &'static str {
    match d {
        Direction::Up => "north",
        Direction::Down => "south",
        Direction::Right => "east",
        Direction::Left => "west",
    }
}
