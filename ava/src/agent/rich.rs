//! The rich prompt's unit block: what a player reads off the game and the paper's prompt
//! left out. Exact positions in world units with the map's extent, so distances can be worked
//! out; each own unit's weapon range and readiness, current order, the enemies already in its
//! range and the nearest one's distance; each enemy's current target; and one line of data per
//! unit type on the field (the scenario's own data set), so ranges and speeds need no
//! retrieval. Lines are terse on purpose: a 23-unit army must not double the prompt.

use avacraft_engine::agent::{GroupObs, view};
use avacraft_engine::{Buffs, OrderInfo, Terrain, UnitId, UnitInfo, UnitKind, Vec2, loops_to_seconds};
use std::fmt::Write as _;

fn hp(u: &UnitInfo) -> String {
    let mut s = format!("{:.0}/{:.0}", u.hp, u.max_hp);
    if u.max_shield > 0.0 {
        let _ = write!(s, "+{:.0}sh", u.shield);
    }
    if u.max_energy > 0.0 {
        let _ = write!(s, " {:.0}en", u.energy);
    }
    s
}

fn order(u: &UnitInfo) -> String {
    // A unit that takes no order now says so: a model would otherwise order it and be refused.
    if u.buffs.contains(Buffs::MORPHING) {
        return "morphing, takes no order until done".into();
    }
    if u.buffs.contains(Buffs::CHANNELLING) {
        return "channelling".into();
    }
    match u.order {
        OrderInfo::Idle => "idle".into(),
        OrderInfo::Hold => "holding".into(),
        OrderInfo::Move { x, y } => format!("moving to ({x:.1},{y:.1})"),
        OrderInfo::AttackMove { x, y } => format!("attack-moving to ({x:.1},{y:.1})"),
        OrderInfo::Attack { target } => format!("attacking {}", target.tag()),
    }
}

/// The unit block: own units, other friendly units, enemies, unit types. `enemy_start` is
/// where the enemy army began (a player knows the map, as the scripted agents do).
pub fn describe_rich(obs: &GroupObs, terrain: &Terrain, controlled: &[UnitId], enemy_start: Option<Vec2>) -> String {
    let r = terrain.playable();
    let mut s = format!(
        "Step {}, game time {:.1} s. Positions (x,y) in world units: x {:.0}-{:.0} west to east, y {:.0}-{:.0} south to north. Distances are edge to edge, as weapon ranges are.",
        obs.step,
        loops_to_seconds(obs.game_loop),
        r.left,
        r.right,
        r.bottom,
        r.top
    );
    if let Some(p) = enemy_start {
        let _ = write!(s, " The enemy started near ({:.1},{:.1}).", p.x, p.y);
    }
    s.push('\n');
    let enemies: Vec<&UnitInfo> = obs.units.iter().filter(|u| !u.own).collect();
    s.push_str("Your units (tag type (x,y) hp[+shields] | weapon | order | enemies in range | nearest enemy):\n");
    for u in obs.units.iter().filter(|u| u.own && controlled.contains(&u.tag)) {
        let _ = write!(s, "- {} {} ({:.1},{:.1}) {} | ", u.tag.tag(), u.kind.name(), u.x, u.y, hp(u));
        if u.spec().weapons.is_empty() {
            s.push_str("no weapon");
        } else if u.weapon_cooldown_s > 0.0 {
            let _ = write!(s, "range {} ready in {:.1}s", view::max_range(u), u.weapon_cooldown_s);
        } else {
            let _ = write!(s, "range {} ready", view::max_range(u));
        }
        let _ = write!(s, " | {} | ", order(u));
        let in_range: Vec<String> =
            enemies.iter().filter(|e| view::range_gap(u, e).is_some_and(|g| g <= 0.0)).map(|e| e.tag.tag().to_string()).collect();
        if in_range.is_empty() {
            s.push_str("none in range");
        } else {
            let _ = write!(s, "in range {}", in_range.join(" "));
        }
        let nearest = enemies.iter().min_by(|a, b| view::edge(u, a).total_cmp(&view::edge(u, b)).then(a.tag.cmp(&b.tag)));
        if let Some(e) = nearest {
            let _ = write!(s, " | nearest {} at {:.1}", e.tag.tag(), view::edge(u, e));
        }
        if u.buffs.contains(Buffs::STIMMED) {
            s.push_str(" | stimmed");
        }
        let ready: Vec<&str> = u.abilities.iter().filter(|a| a.available).map(|a| a.ability.name()).collect();
        if !ready.is_empty() {
            let _ = write!(s, " | can cast {}", ready.join(" "));
        }
        s.push('\n');
    }
    let others: Vec<&UnitInfo> = obs.units.iter().filter(|u| u.own && !controlled.contains(&u.tag)).collect();
    if !others.is_empty() {
        s.push_str("Other friendly units (not yours to command):\n");
        for u in others {
            let _ = writeln!(s, "- {} {} ({:.1},{:.1}) {} | {}", u.tag.tag(), u.kind.name(), u.x, u.y, hp(u), order(u));
        }
    }
    if enemies.is_empty() {
        s.push_str("No enemy in sight.\n");
    } else {
        s.push_str("Enemies in sight (tag type (x,y) hp[+shields] | target):\n");
        for u in &enemies {
            let _ = write!(s, "- {} {} ({:.1},{:.1}) {}", u.tag.tag(), u.kind.name(), u.x, u.y, hp(u));
            if let Some(t) = u.target {
                let _ = write!(s, " | attacking {}", t.tag());
            }
            s.push('\n');
        }
    }
    s.push_str("Unit types here:\n");
    let mut kinds: Vec<(UnitKind, &UnitInfo)> = Vec::new();
    for u in &obs.units {
        if !kinds.iter().any(|(k, _)| *k == u.kind) {
            kinds.push((u.kind, u));
        }
    }
    kinds.sort_by_key(|(k, _)| k.name());
    for (k, u) in kinds {
        let _ = writeln!(s, "- {}: {}", k.name(), crate::kb::stats_line(u.spec()));
    }
    s
}
