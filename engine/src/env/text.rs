//! The natural-language battlefield description (the paper's T_t): what a player would read
//! off the screen, with the exact numbers a screenshot leaves unclear.

use super::Env;
use crate::flags::UnitFlags;
use crate::ids::{Team, UnitId};
use crate::obs::{OrderInfo, UnitInfo, unit_list};
use crate::time::{LOOPS_PER_SECOND, loops_to_seconds};
use std::fmt::Write;

fn line(u: &UnitInfo, names: &dyn Fn(UnitId) -> String) -> String {
    let mut s = format!("- {} (tag {}, {}): HP {:.0}/{:.0}", u.name, u.tag.tag(), u.kind.display_name(), u.hp.ceil(), u.max_hp);
    if u.max_shield > 0.0 {
        let _ = write!(s, ", shields {:.0}/{:.0}", u.shield.ceil(), u.max_shield);
    }
    if u.max_energy > 0.0 {
        let _ = write!(s, ", energy {:.0}/{:.0}", u.energy.floor(), u.max_energy);
    }
    if u.weapon_cooldown_s > 0.0 {
        let _ = write!(s, ", weapon ready in {:.1} s", u.weapon_cooldown_s);
    } else if !u.flags.contains(UnitFlags::HEALER) && u.kind.can_fight() {
        s.push_str(", weapon ready");
    }
    let _ = write!(s, ", at grid ({}, {})", u.grid[0], u.grid[1]);
    let doing = match (&u.order, u.target) {
        (OrderInfo::Attack { target }, _) if u.flags.contains(UnitFlags::HEALER) => format!("healing {}", names(*target)),
        (_, Some(t)) if u.flags.contains(UnitFlags::HEALER) => format!("healing {}", names(t)),
        (OrderInfo::Attack { target }, _) => format!("attacking {}", names(*target)),
        (OrderInfo::Move { x, y }, _) => format!("moving to ({x:.1}, {y:.1})"),
        (OrderInfo::AttackMove { x, y }, Some(t)) => format!("attack-moving to ({x:.1}, {y:.1}), engaging {}", names(t)),
        (OrderInfo::AttackMove { x, y }, None) => format!("attack-moving to ({x:.1}, {y:.1})"),
        (OrderInfo::Hold, Some(t)) => format!("holding position, engaging {}", names(t)),
        (OrderInfo::Hold, None) => "holding position".to_owned(),
        (OrderInfo::Idle, Some(t)) => format!("engaging {}", names(t)),
        (OrderInfo::Idle, None) => "idle".to_owned(),
    };
    let _ = write!(s, ", {doing}");
    if !u.buffs.is_empty() {
        let _ = write!(s, "; status: {}", u.buffs.names().collect::<Vec<_>>().join(", ").replace('_', " "));
    }
    if !u.abilities.is_empty() {
        let list: Vec<String> = u
            .abilities
            .iter()
            .map(|a| {
                let name = a.ability.name().replace('_', " ");
                if a.available {
                    if a.energy_cost > 0.0 { format!("{name} ready ({:.0} energy)", a.energy_cost) } else { format!("{name} ready") }
                } else if a.cooldown_s > 0.0 {
                    format!("{name} in {:.1} s", a.cooldown_s)
                } else {
                    format!("{name} unavailable ({})", a.why_not.map_or("?", |c| c.text()))
                }
            })
            .collect();
        let _ = write!(s, "; abilities: {}", list.join(", "));
    }
    const SHOWN: [UnitFlags; 6] =
        [UnitFlags::FLYING, UnitFlags::SIEGED, UnitFlags::PHASING, UnitFlags::IMMOBILE, UnitFlags::CLIFF_WALKER, UnitFlags::DETECTOR];
    let special: Vec<&str> = UnitFlags::NAMES.iter().filter(|(f, _)| SHOWN.contains(f) && u.flags.contains(*f)).map(|(_, n)| *n).collect();
    if !special.is_empty() {
        let _ = write!(s, " [{}]", special.join(", "));
    }
    s.push('.');
    s
}

/// A description of the battle as `team` sees it.
pub fn describe(env: &Env, team: Team) -> String {
    let w = env.world();
    let units = unit_list(w, team);
    let tags: Vec<(UnitId, String, bool)> = units.iter().map(|u| (u.tag, u.name.clone(), u.own)).collect();
    let names = |id: UnitId| match tags.iter().find(|t| t.0 == id) {
        Some((_, n, true)) => format!("own {n}"),
        Some((_, n, false)) => format!("enemy {n} (tag {})", id.tag()),
        None => format!("unit tag {}", id.tag()),
    };
    let limit = env.time_limit_loops();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Scenario {} ({}), you are {}. Game time {:.1} s of {:.0} s (loop {} of {}).",
        env.scenario().name,
        env.scenario().mode,
        team,
        loops_to_seconds(w.tick()),
        limit as f32 / LOOPS_PER_SECOND,
        w.tick(),
        limit
    );
    let _ = writeln!(s, "Objective: {}", env.scenario().objective);
    let _ = writeln!(s, "The map is divided into a 10x10 grid; (1, 1) is the top-left cell and (10, 10) the bottom-right.");
    let own: Vec<&UnitInfo> = units.iter().filter(|u| u.own).collect();
    let lost = env.agents(team).len().saturating_sub(own.len());
    let _ = writeln!(s, "Your units ({} alive, {} lost):", own.len(), lost);
    for u in &own {
        let _ = writeln!(s, "{}", line(u, &names));
    }
    let enemies: Vec<&UnitInfo> = units.iter().filter(|u| !u.own).collect();
    let killed = w.stats(team).kills;
    if enemies.is_empty() {
        let _ = writeln!(s, "No enemy units in sight ({killed} destroyed so far); the rest are hidden by fog of war.");
    } else {
        let _ = writeln!(s, "Enemy units in sight ({}; {} destroyed so far):", enemies.len(), killed);
        for u in &enemies {
            let _ = writeln!(s, "{}", line(u, &names));
        }
    }
    let effects: Vec<String> = w
        .area_effects()
        .iter()
        .filter(|e| e.active(w.tick()) && (e.team == team || visible_effect(w, team, e)))
        .map(|e| {
            let (gx, gy) = crate::action::grid_cell_of(w.terrain().playable(), e.pos);
            format!(
                "- {} {} at grid ({gx}, {gy}), ({:.1}, {:.1}), radius {:.1}, {:.1} s left",
                if e.team == team { "own" } else { "enemy" },
                e.kind.name().replace('_', " "),
                e.pos.x,
                e.pos.y,
                e.radius,
                e.until.saturating_sub(w.tick()) as f32 / LOOPS_PER_SECOND
            )
        })
        .collect();
    if !effects.is_empty() {
        let _ = writeln!(s, "Area effects:");
        for e in effects {
            let _ = writeln!(s, "{e}");
        }
    }
    s
}

/// Whether `team` sees an enemy area effect: some unit of the team sees its centre.
pub(crate) fn visible_effect(w: &crate::world::World, team: Team, e: &crate::ability::AreaEffect) -> bool {
    w.team_sees_point(team, e.pos)
}
