//! The ceiling back end: a stand-in for a perfect model that reads only the prompt's text and
//! answers as a chosen scripted agent would. What it wins measures how much of a scenario AVA's
//! prompt and action set allow, whatever the model: an order it cannot work out from the
//! prompt, a real model could not either. It never reads the game state.
//!
//! It reads both prompts: the rich one's exact positions, ranges, orders and unit-type lines,
//! and the paper's grid cells (where it can only aim by cell). Planner, roles and priorities
//! are answered as the synthetic model does; the decision as the script:
//!
//! - `focus-fire`: every unit on the enemy with the lowest HP + shields it can hit;
//! - `kite`: the same, and ranged units step back from slower melee enemies while reloading;
//! - `nearest`: every unit on the enemy nearest the army's centre (the `aggressive` script);
//! - `attack-move`: attack-move onto the enemies (the map's centre when none is seen);
//! - `hold`: every unit holds its ground and fires at what comes in range (the `hold` script).
//!
//! With the micro action set the answer uses stances (`focus`, `kite`) so the script's rule
//! keeps acting between decisions; with the paper's, one order per decision.

use super::synthetic::{first_user_text, synthetic_answer};
use super::{ChatModel, ChatReply, ChatRequest, LlmError, Part, Stage, Usage};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

/// The script a ceiling model answers as.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum CeilingScript {
    FocusFire,
    Kite,
    Nearest,
    AttackMove,
    Hold,
}

impl CeilingScript {
    pub const ALL: [CeilingScript; 5] =
        [CeilingScript::FocusFire, CeilingScript::Kite, CeilingScript::Nearest, CeilingScript::AttackMove, CeilingScript::Hold];

    pub fn name(self) -> &'static str {
        match self {
            CeilingScript::FocusFire => "focus-fire",
            CeilingScript::Kite => "kite",
            CeilingScript::Nearest => "nearest",
            CeilingScript::AttackMove => "attack-move",
            CeilingScript::Hold => "hold",
        }
    }
}

/// A unit as a prompt line gives it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Seen {
    pub tag: u32,
    pub kind: String,
    /// Exact (rich prompt) or a grid cell's [column, row] as a point (paper prompt; y grows
    /// downwards there, which only flips directions the same way for everyone).
    pub at: (f32, f32),
    /// HP plus shields.
    pub life: f32,
    /// Weapon ready now (own units; enemies: unknown, `true`).
    pub ready: bool,
    /// Weapon range when the prompt says it.
    pub range: Option<f32>,
    /// Rich prompt: HP at its maximum.
    pub full: bool,
    /// Rich prompt: no order (idle).
    pub idle: bool,
    /// Rich prompt: attack-moving.
    pub advancing: bool,
    /// Rich prompt: morphing or channelling, taking no order.
    pub busy: bool,
    /// Rich prompt: the enemies within the weapon's range.
    pub in_range: Vec<u32>,
    /// Rich prompt: the nearest enemy's edge-to-edge distance, and its tag.
    pub nearest: Option<f32>,
    pub nearest_tag: Option<u32>,
    pub stimmed: bool,
    /// Rich prompt: abilities it can cast now.
    pub can: Vec<String>,
    /// Rich prompt: HP, its maximum, and shields.
    pub hp: f32,
    pub hp_max: f32,
    pub shields: f32,
}

/// What the prompt says of the fight.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Read {
    pub mine: Vec<Seen>,
    pub enemies: Vec<Seen>,
    /// Positions are exact world units (the rich prompt).
    pub exact: bool,
    /// The map's centre, when the prompt gives its extent.
    pub centre: Option<(f32, f32)>,
    /// Where the enemy started, when the prompt says.
    pub enemy_start: Option<(f32, f32)>,
    /// Unit types the prompt calls flying, and what each type's weapons hit.
    pub flying: Vec<String>,
    pub hits: Vec<(String, bool, bool)>,
    /// Each type's speed and weapon range.
    pub speed: Vec<(String, f32)>,
    pub ranges: Vec<(String, f32)>,
    /// Types with no weapon (healers, casters): the scripts keep them with the army.
    pub unarmed: Vec<String>,
    /// Each type's maximum shields.
    pub max_shields: Vec<(String, f32)>,
    /// The micro action set is offered.
    pub micro: bool,
    /// Steps to the next decision, when the prompt says (1 when it does not).
    pub next_in: u32,
}

fn num(s: &str) -> Option<f32> {
    s.trim().trim_end_matches(['s', ',', ')', ';']).parse().ok()
}

fn point(s: &str) -> Option<(f32, f32)> {
    let inner = s.trim().strip_prefix('(')?.strip_suffix(')')?;
    let (x, y) = inner.split_once(',')?;
    Some((num(x)?, num(y)?))
}

/// A rich unit line: `- 1 Marine (12.3,8.1) 45/45 | range 5 ready | idle | in range 31 | nearest
/// 31 at 4.2 | stimmed | can cast stimpack`.
fn rich_line(line: &str) -> Option<Seen> {
    let rest = line.strip_prefix("- ")?;
    let mut fields = rest.split(" | ");
    let head = fields.next()?;
    let mut words = head.split_whitespace();
    let tag = words.next()?.parse().ok()?;
    let kind = words.next()?.to_owned();
    let at = point(words.next()?)?;
    // "80/80+80sh": HP over its maximum, then shields.
    let vitals = words.next().unwrap_or("");
    let (health, shield_text) = vitals.split_once('+').unwrap_or((vitals, ""));
    let (now, max) = health.split_once('/').unwrap_or((health, health));
    let (hp, hp_max, shields) = (num(now).unwrap_or(0.0), num(max).unwrap_or(0.0), num(shield_text.trim_end_matches("sh")).unwrap_or(0.0));
    let mut seen = Seen { tag, kind, at, life: hp + shields, ready: true, full: hp >= hp_max, hp, hp_max, shields, ..Seen::default() };
    for f in fields {
        if let Some(r) = f.strip_prefix("range ") {
            let mut w = r.split_whitespace();
            seen.range = w.next().and_then(num);
            seen.ready = w.next() == Some("ready") && w.next().is_none();
        } else if f == "no weapon" {
            seen.ready = false;
        } else if f == "idle" {
            seen.idle = true;
        } else if f.starts_with("attack-moving") {
            seen.advancing = true;
        } else if f.starts_with("morphing") || f == "channelling" {
            seen.busy = true;
        } else if let Some(tags) = f.strip_prefix("in range ") {
            seen.in_range = tags.split_whitespace().filter_map(|t| t.parse().ok()).collect();
        } else if let Some(n) = f.strip_prefix("nearest ") {
            let mut parts = n.split(" at ");
            seen.nearest_tag = parts.next().and_then(|t| t.trim().parse().ok());
            seen.nearest = parts.next().and_then(num);
        } else if f == "stimmed" {
            seen.stimmed = true;
        } else if let Some(c) = f.strip_prefix("can cast ") {
            seen.can = c.split_whitespace().map(str::to_owned).collect();
        }
    }
    Some(seen)
}

/// A paper unit line: `- 1 Stalker at cell [6, 8]: HP 80/80, shield 80/80, weapon ready; ...`.
fn paper_line(line: &str) -> Option<Seen> {
    let rest = line.strip_prefix("- ")?;
    let (head, vitals) = rest.split_once(": ")?;
    let mut words = head.split_whitespace();
    let tag = words.next()?.parse().ok()?;
    let kind = words.next()?.to_owned();
    let cell = head.split_once('[').and_then(|(_, c)| c.split_once(']')).map(|(c, _)| c)?;
    let (c, r) = cell.split_once(',')?;
    let at = (num(c)?, num(r)?);
    let part = |name: &str| vitals.split(", ").find_map(|p| p.strip_prefix(name)).and_then(|v| v.split('/').next()).and_then(num);
    let life = part("HP ").unwrap_or(0.0) + part("shield ").unwrap_or(0.0);
    let ready = vitals.contains("weapon ready") && !vitals.contains("weapon ready in");
    let hp = part("HP ").unwrap_or(0.0);
    let shields = part("shield ").unwrap_or(0.0);
    let seen = Seen { tag, kind, at, life, ready, hp, shields, ..Seen::default() };
    Some(seen)
}

/// Reads the fight out of a decision prompt's text.
pub fn read_prompt(text: &str) -> Read {
    let mut read = Read { micro: text.contains("\"action\": \"stance\""), ..Read::default() };
    #[derive(PartialEq)]
    enum Block {
        None,
        Mine,
        Enemies,
        Types,
    }
    let mut block = Block::None;
    read.next_in = text
        .split_once("the next decision comes in ")
        .and_then(|(_, rest)| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(1);
    for line in text.lines() {
        if let Some(ext) = line.split_once("Positions (x,y) in world units: x ") {
            read.exact = true;
            // "x 0-32 west to east, y 0-32 south to north."
            let nums: Vec<f32> =
                ext.1.split(|c: char| !(c.is_ascii_digit() || c == '.')).filter(|s| !s.is_empty()).filter_map(|s| s.parse().ok()).collect();
            if let [l, r, b, t, ..] = nums[..] {
                read.centre = Some(((l + r) / 2.0, (b + t) / 2.0));
            }
            read.enemy_start = line.split_once("The enemy started near ").and_then(|(_, p)| point(p.trim_end_matches('.')));
            continue;
        }
        if line.starts_with("Your units") {
            block = Block::Mine;
            continue;
        }
        if line.starts_with("Enemies in sight") {
            block = Block::Enemies;
            continue;
        }
        if line.starts_with("Unit types here") {
            block = Block::Types;
            continue;
        }
        if !line.starts_with("- ") {
            block = Block::None;
            continue;
        }
        match block {
            Block::Mine | Block::Enemies => {
                let seen = if read.exact { rich_line(line) } else { paper_line(line) };
                if let Some(s) = seen {
                    if block == Block::Mine { read.mine.push(s) } else { read.enemies.push(s) }
                }
            }
            Block::Types => {
                if let Some((kind, data)) = line[2..].split_once(": ") {
                    if let Some(sh) =
                        data.split(" shields").next().filter(|h| h.len() < data.len()).and_then(|h| h.rsplit(", ").next()).and_then(num)
                    {
                        read.max_shields.push((kind.to_owned(), sh));
                    }
                    if data.contains("No weapon") {
                        read.unarmed.push(kind.to_owned());
                    }
                    if data.contains("flying") {
                        read.flying.push(kind.to_owned());
                    }
                    let ground = data.contains("hits ground");
                    let air = data.contains("hits ground and air") || data.contains("hits air");
                    read.hits.push((kind.to_owned(), ground, air));
                    if let Some(sp) = data.split("speed ").nth(1).and_then(|s| s.split(',').next()).and_then(num) {
                        read.speed.push((kind.to_owned(), sp));
                    }
                    let weapon = data.split_once("Weapon: ").map(|(_, w)| w);
                    if let Some(r) = weapon.and_then(|w| w.split(", range ").nth(1)).and_then(|r| r.split(',').next()).and_then(num) {
                        read.ranges.push((kind.to_owned(), r));
                    }
                }
            }
            Block::None => {}
        }
    }
    read
}

impl Read {
    /// Whether `u` can hit `t`, by the type lines (unknown types: yes).
    fn can_hit(&self, u: &Seen, t: &Seen) -> bool {
        let flying = self.flying.contains(&t.kind);
        match self.hits.iter().find(|(k, _, _)| *k == u.kind) {
            Some((_, ground, air)) => {
                if flying {
                    *air
                } else {
                    *ground
                }
            }
            None => true,
        }
    }

    fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
        ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
    }

    fn centroid(units: &[Seen]) -> Option<(f32, f32)> {
        let n = units.len() as f32;
        (n > 0.0).then(|| (units.iter().map(|u| u.at.0).sum::<f32>() / n, units.iter().map(|u| u.at.1).sum::<f32>() / n))
    }

    /// The team's target: lowest HP + shields, or nearest the army's centre.
    fn team_target(&self, nearest: bool) -> Option<&Seen> {
        let c = Self::centroid(&self.mine)?;
        let d = |e: &Seen| Self::dist(e.at, c);
        if nearest {
            self.enemies.iter().min_by(|a, b| d(a).total_cmp(&d(b)).then(a.tag.cmp(&b.tag)))
        } else {
            self.enemies.iter().min_by(|a, b| a.life.total_cmp(&b.life).then(d(a).total_cmp(&d(b))))
        }
    }

    /// `u`'s target: the team's when it can hit it, else the weakest it can hit.
    fn target_for<'a>(&'a self, u: &Seen, team: Option<&'a Seen>) -> Option<&'a Seen> {
        team.filter(|t| self.can_hit(u, t))
            .or_else(|| self.enemies.iter().filter(|e| self.can_hit(u, e)).min_by(|a, b| a.life.total_cmp(&b.life).then(a.tag.cmp(&b.tag))))
    }

    /// The edge distance to the nearest enemy `u` can hit, as the scripts measure theirs: the
    /// prompt's nearest when `u` can hit it, else the nearest it can hit by centre distance
    /// less about a unit's width (the prompt's scale: a Marine is about 0.75 wide).
    fn nearest_hittable(&self, u: &Seen) -> Option<f32> {
        let listed = u.nearest_tag.and_then(|t| self.enemies.iter().find(|e| e.tag == t));
        match listed {
            Some(e) if !self.can_hit(u, e) => {
                self.enemies.iter().filter(|e| self.can_hit(u, e)).map(|e| (Self::dist(e.at, u.at) - 1.0).max(0.0)).min_by(f32::total_cmp)
            }
            _ => u.nearest,
        }
    }

    /// A melee type: its weapon's range (the prompt's line for its type, else the unit's own
    /// line) is under 1.5.
    fn is_melee(&self, e: &Seen) -> bool {
        let range = self.ranges.iter().find(|(k, _)| *k == e.kind).map(|(_, r)| *r).or(e.range);
        range.is_some_and(|r| r < 1.5)
    }

    fn speed_of(&self, kind: &str) -> f32 {
        self.speed.iter().find(|(k, _)| k == kind).map_or(0.0, |(_, s)| *s)
    }
}

/// Where a Stalker blinks to, by the scripts' rule (engine/src/policy/micro.rs): shields under a
/// tenth of their maximum, HP under 60%, enemies within 6; 7.5 away from them, on the map.
/// Needs the micro action set (an exact point) and the rich prompt's extent.
fn blink_to(read: &Read, u: &Seen) -> Option<(f32, f32)> {
    if !read.micro || !u.can.iter().any(|c| c == "blink") || u.hp_max <= 0.0 {
        return None;
    }
    let max_sh = read.max_shields.iter().find(|(k, _)| *k == u.kind).map_or(0.0, |(_, s)| *s);
    // The scripts' rule is checked every step; a model deciding every few steps blinks
    // earlier, while the Stalker still has the life to survive until the next decision.
    let hp_line = if read.next_in > 1 { 0.8 } else { 0.6 };
    if !(u.shields < 0.1 * max_sh && u.hp < hp_line * u.hp_max) {
        return None;
    }
    // Centre distances: edge distances plus about a unit's width.
    let threats: Vec<&Seen> = read.enemies.iter().filter(|e| !read.unarmed.contains(&e.kind) && Read::dist(e.at, u.at) < 7.0).collect();
    if threats.is_empty() {
        return None;
    }
    let (mut ax, mut ay) = (0.0f32, 0.0f32);
    for e in threats {
        let (dx, dy) = (u.at.0 - e.at.0, u.at.1 - e.at.1);
        let d = (dx * dx + dy * dy).sqrt().max(1e-3);
        ax += dx / d;
        ay += dy / d;
    }
    let n = (ax * ax + ay * ay).sqrt();
    if n < 1e-3 {
        return None;
    }
    let (cx, cy) = read.centre?;
    let (x, y) = (u.at.0 + ax / n * 7.5, u.at.1 + ay / n * 7.5);
    // The map's extent: the centre is its middle, and it starts at 0 on this engine's maps.
    Some((x.clamp(0.7, 2.0 * cx - 0.7), y.clamp(0.7, 2.0 * cy - 0.7)))
}

/// A self-cast ability the scripts would use now, from the prompt's line: Stimpack when an
/// enemy is within the weapon's range plus 2 at full health, Siege Mode when the nearest enemy
/// is 3 to 13 away, Unsiege when none is within reach and none is near, or one hugs it.
fn self_cast(read: &Read, u: &Seen) -> Option<&'static str> {
    let can = |a: &str| u.can.iter().any(|c| c == a);
    let near = read.nearest_hittable(u);
    // The scripts check every step; a model deciding every few steps would stim a step or more
    // after the enemy crossed the script's line, so it looks as far ahead as two armies close
    // (about 2.3 world units a step) before its next decision.
    let ahead = 2.3 * read.next_in.saturating_sub(1) as f32;
    if can("stimpack") && !u.stimmed && u.full && near.zip(u.range).is_some_and(|(d, r)| d <= r + 2.0 + ahead) {
        return Some("stimpack");
    }
    if can("siege_mode") && near.is_some_and(|d| (3.0..=13.0).contains(&d)) {
        return Some("siege_mode");
    }
    // As the script: nothing to shoot between the minimum range and the range, and either
    // nothing within 15 or an enemy hugging under the minimum range. The prompt lists who is in
    // range (the minimum range aside) and the nearest one's distance: a lone enemy in range
    // that is the nearest and closer than 2 is a hugger.
    let in_reach = u.in_range.len() >= 2 || (u.in_range.len() == 1 && near.is_some_and(|d| d >= 2.0));
    if can("unsiege") && !in_reach && near.is_none_or(|d| !(2.0..=15.0).contains(&d)) {
        return Some("unsiege");
    }
    None
}

/// The melee enemy a Reaper knocks back by the scripts' rule (engine/src/policy/micro.rs): the
/// nearest enemy, when it is a mobile ground melee unit within 3.
fn knock_back(read: &Read, u: &Seen) -> Option<u32> {
    if !u.can.iter().any(|c| c == "kd8_charge") {
        return None;
    }
    let (tag, d) = u.nearest_tag.zip(u.nearest)?;
    let e = read.enemies.iter().find(|e| e.tag == tag)?;
    let closing = read.is_melee(e) && read.speed_of(&e.kind) > 0.0 && !read.flying.contains(&e.kind);
    (closing && d < 3.0).then_some(tag)
}

/// The scripts' ability use (engine/src/policy/micro.rs), read off the prompt, written into
/// `a`: a Stalker out of shields and hurt blinks away from its threats, a Reaper throws KD8
/// Charge at a melee unit closing in, and the self-cast abilities. `false`: nothing to cast.
fn cast(read: &Read, u: &Seen, a: &mut Value) -> bool {
    if let Some(to) = blink_to(read, u) {
        a["action"] = json!("ability");
        a["ability"] = json!("blink");
        a["point"] = json!([to.0, to.1]);
        return true;
    }
    if let Some(e) = knock_back(read, u) {
        a["action"] = json!("ability");
        a["ability"] = json!("kd8_charge");
        a["target"] = json!(e);
        return true;
    }
    if let Some(ability) = self_cast(read, u) {
        a["action"] = json!("ability");
        a["ability"] = json!(ability);
        return true;
    }
    false
}

/// The decision a ceiling model gives for `read`.
pub fn ceiling_decision(script: CeilingScript, read: &Read) -> Value {
    let mut actions = Vec::new();
    let item = |unit: u32| json!({"unit": unit, "action": "hold", "target": null, "cell": null, "direction": null, "ability": null});
    let team = match script {
        CeilingScript::Nearest => read.team_target(true),
        _ => read.team_target(false),
    };
    // The attack-move script's goal: the enemy nearest the army, else where the enemy started.
    let goal = read.team_target(true).map(|e| e.at).or(read.enemy_start).or(read.centre);
    // A unit that takes no order now gets none, as the scripts leave it be.
    for u in read.mine.iter().filter(|u| !u.busy) {
        let mut a = item(u.tag);
        if read.micro {
            a["point"] = Value::Null;
            a["stance"] = Value::Null;
        }
        if script == CeilingScript::Hold {
            // Every unit stands, casting nothing, as the `hold` script.
            a["action"] = json!(if read.micro { "stance" } else { "hold" });
            if read.micro {
                a["stance"] = json!("hold");
            }
            actions.push(a);
            continue;
        }
        if cast(read, u, &mut a) {
            actions.push(a);
            continue;
        }
        if script == CeilingScript::AttackMove && read.micro {
            // Idle units that can move only, as the script: units in a fight keep their
            // targets, and a sieged tank cannot walk.
            if let (true, true, Some(g)) = (u.idle, read.speed_of(&u.kind) > 0.0, goal) {
                a["action"] = json!("attack_move");
                a["point"] = json!([g.0, g.1]);
                actions.push(a);
            }
            continue;
        }
        let Some(centre) = Read::centroid(&read.enemies).or(read.enemy_start).or(read.centre) else { continue };
        if read.unarmed.contains(&u.kind) {
            // As the scripts do: a unit without a weapon (a Medivac heals on its own) follows
            // the army instead of walking into the enemy.
            let army: Vec<Seen> = read.mine.iter().filter(|m| !read.unarmed.contains(&m.kind)).cloned().collect();
            // Only when idle, as the scripts: a new order would interrupt its healing.
            if let (true, true, Some(c)) = (read.micro, u.idle, Read::centroid(&army)) {
                a["action"] = json!("attack_move");
                a["point"] = json!([c.0, c.1]);
                actions.push(a);
            }
            continue;
        }
        let stance = if script == CeilingScript::Kite && u.range.is_some_and(|r| r >= 3.0) { "kite" } else { "focus" };
        let Some(t) = read.target_for(u, team) else {
            if read.micro && u.advancing && script != CeilingScript::Nearest {
                // Already advancing: a stance with no target keeps the attack-move going and
                // takes the script's target at the first step an enemy is seen, not at the
                // next decision.
                a["action"] = json!("stance");
                a["stance"] = json!(stance);
                actions.push(a);
            } else if read.micro {
                a["action"] = json!("attack_move");
                a["point"] = json!([centre.0, centre.1]);
                actions.push(a);
            }
            continue;
        };
        if read.micro {
            a["action"] = json!("stance");
            a["stance"] = json!(stance);
            // Focus fire's rule is the stance's own with no target named: the weakest enemy
            // in sight, chosen again every step, so the target moves on between decisions as
            // the script's does. The nearest-target rule is not a stance's: name it.
            a["target"] = if script == CeilingScript::Nearest { json!(t.tag) } else { Value::Null };
        } else if script == CeilingScript::Kite && !u.ready && u.range.is_none_or(|r| r >= 3.0) {
            // The paper's actions: step away from a slower melee enemy that is close.
            let threat = read
                .enemies
                .iter()
                .filter(|e| read.is_melee(e) && read.speed_of(&e.kind) < read.speed_of(&u.kind).max(0.01))
                .min_by(|a, b| Read::dist(a.at, u.at).total_cmp(&Read::dist(b.at, u.at)));
            match threat.filter(|e| Read::dist(e.at, u.at) < if read.exact { 3.0 } else { 1.5 }) {
                Some(e) => {
                    let (dx, dy) = (u.at.0 - e.at.0, u.at.1 - e.at.1);
                    // The paper's grid counts rows downwards; the rich prompt's y grows north.
                    let dy = if read.exact { dy } else { -dy };
                    let dir = if dx.abs() >= dy.abs() {
                        if dx >= 0.0 { "east" } else { "west" }
                    } else if dy >= 0.0 {
                        "north"
                    } else {
                        "south"
                    };
                    a["action"] = json!("move_dir");
                    a["direction"] = json!(dir);
                }
                None => {
                    a["action"] = json!("attack");
                    a["target"] = json!(t.tag);
                }
            }
        } else {
            a["action"] = json!("attack");
            a["target"] = json!(t.tag);
        }
        actions.push(a);
    }
    json!({"reasoning": format!("as the {} script", script.name()), "actions": actions})
}

/// The ceiling model.
#[derive(Clone, Copy, Debug)]
pub struct Ceiling {
    script: CeilingScript,
    /// `ceiling:<script>`, the model name its records carry.
    label: &'static str,
}

impl Ceiling {
    pub fn new(script: CeilingScript) -> Ceiling {
        let label = match script {
            CeilingScript::FocusFire => "ceiling:focus-fire",
            CeilingScript::Kite => "ceiling:kite",
            CeilingScript::Nearest => "ceiling:nearest",
            CeilingScript::AttackMove => "ceiling:attack-move",
            CeilingScript::Hold => "ceiling:hold",
        };
        Ceiling { script, label }
    }
}

impl ChatModel for Ceiling {
    fn model(&self) -> &str {
        self.label
    }
    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError> {
        let prompt = first_user_text(req);
        let text = match req.stage {
            Stage::Decision => ceiling_decision(self.script, &read_prompt(&prompt)).to_string(),
            other => synthetic_answer(other, &prompt),
        };
        let chars: usize = req.messages.iter().flat_map(|m| &m.parts).map(|p| if let Part::Text(t) = p { t.len() } else { 0 }).sum();
        let usage = Usage { prompt_tokens: (chars / 4) as u64, completion_tokens: (text.len() / 4) as u64 };
        Ok(ChatReply { text, usage: Some(usage), latency_ms: 0.0, model: self.label.into(), finish: Some("stop".into()) })
    }
    fn waits(&self) -> bool {
        false
    }
}
