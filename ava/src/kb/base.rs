//! The base itself: the authored file checked against the engine's tables and cut into
//! passages. A leaf, so the retrievers can read passages without depending on each other.

use avacraft_engine::{Ability, Reach, Splash, UnitKind, UnitSpec, Weapon};
use serde::Deserialize;
use std::fmt::Write as _;

/// The knowledge base shipped with the crate.
const BUILTIN: &str = include_str!("../../kb/units.toml");
const BUILTIN_FILE: &str = "ava/kb/units.toml";

/// Why a knowledge-base file was refused. Every variant names the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KbError {
    #[error("{file}: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: unit `{kind}`: {source}")]
    UnknownUnit {
        file: String,
        kind: String,
        #[source]
        source: avacraft_engine::UnknownUnitKind,
    },
    #[error("{file}: unit `{kind}` is described twice")]
    Duplicate { file: String, kind: UnitKind },
    #[error("{file}: unit `{kind}`: ability `{name}`: {reason}")]
    Ability { file: String, kind: UnitKind, name: String, reason: String },
    #[error("{file}: unit `{kind}`: `{field}` names `{name}`, which is not a unit type")]
    Matchup { file: String, kind: UnitKind, field: &'static str, name: String },
    #[error("{file}: unit `{kind}`: `{field}` is empty")]
    Empty { file: String, kind: UnitKind, field: &'static str },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    unit: Vec<RawUnit>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawUnit {
    kind: String,
    summary: String,
    strengths: String,
    weaknesses: String,
    #[serde(default)]
    strong_against: Vec<String>,
    #[serde(default)]
    weak_against: Vec<String>,
    #[serde(default)]
    tactics: Vec<String>,
    #[serde(default)]
    abilities: Vec<RawAbility>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAbility {
    name: String,
    text: String,
}

/// One unit type's authored description, checked against the engine.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitDoc {
    pub kind: UnitKind,
    pub summary: String,
    pub strengths: String,
    pub weaknesses: String,
    pub strong_against: Vec<UnitKind>,
    pub weak_against: Vec<UnitKind>,
    pub tactics: Vec<String>,
    pub abilities: Vec<(Ability, String)>,
}

/// What a passage is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    /// Stats, weapons, attributes, strengths, weaknesses and matchups.
    Profile,
    Ability(Ability),
    Tactics,
}

/// A unit of retrieval.
#[derive(Clone, Debug, PartialEq)]
pub struct Passage {
    pub kind: UnitKind,
    pub topic: Topic,
    pub title: String,
    pub text: String,
}

/// Unit descriptions and the passages cut from them.
#[derive(Clone, Debug)]
pub struct KnowledgeBase {
    docs: Vec<UnitDoc>,
    passages: Vec<Passage>,
}

impl KnowledgeBase {
    /// The base shipped with the crate (every unit type of the engine).
    pub fn builtin() -> Result<KnowledgeBase, KbError> {
        KnowledgeBase::from_toml(BUILTIN_FILE, BUILTIN)
    }

    /// Parses and checks a knowledge-base file (`file` names it in errors): unit, ability and
    /// matchup names must be the engine's, an ability must be one the unit has.
    pub fn from_toml(file: &str, text: &str) -> Result<KnowledgeBase, KbError> {
        let raw: RawFile =
            toml::from_str(text).map_err(|e| KbError::Syntax { file: file.to_owned(), message: e.to_string().trim_end().to_owned() })?;
        let mut docs: Vec<UnitDoc> = Vec::with_capacity(raw.unit.len());
        for u in raw.unit {
            let doc = check(file, u)?;
            if docs.iter().any(|d| d.kind == doc.kind) {
                return Err(KbError::Duplicate { file: file.to_owned(), kind: doc.kind });
            }
            docs.push(doc);
        }
        // Table order, whatever the file's: passage ids do not depend on how it is written.
        docs.sort_by_key(|d| UnitKind::ALL.iter().position(|k| *k == d.kind));
        let passages = docs.iter().flat_map(passages_of).collect();
        Ok(KnowledgeBase { docs, passages })
    }

    pub fn docs(&self) -> &[UnitDoc] {
        &self.docs
    }
    pub fn doc(&self, kind: UnitKind) -> Option<&UnitDoc> {
        self.docs.iter().find(|d| d.kind == kind)
    }
    pub fn passages(&self) -> &[Passage] {
        &self.passages
    }
}

fn check(file: &str, u: RawUnit) -> Result<UnitDoc, KbError> {
    let kind: UnitKind = u.kind.parse().map_err(|source| KbError::UnknownUnit { file: file.to_owned(), kind: u.kind.clone(), source })?;
    for (field, value) in [("summary", &u.summary), ("strengths", &u.strengths), ("weaknesses", &u.weaknesses)] {
        if value.trim().is_empty() {
            return Err(KbError::Empty { file: file.to_owned(), kind, field });
        }
    }
    let kinds = |field: &'static str, names: &[String]| -> Result<Vec<UnitKind>, KbError> {
        names.iter().map(|n| n.parse().map_err(|_| KbError::Matchup { file: file.to_owned(), kind, field, name: n.clone() })).collect()
    };
    let mut abilities = Vec::with_capacity(u.abilities.len());
    for a in u.abilities {
        let bad = |reason: String| KbError::Ability { file: file.to_owned(), kind, name: a.name.clone(), reason };
        let ability: Ability = a.name.parse().map_err(|e: avacraft_engine::UnknownAbility| bad(e.to_string()))?;
        if !kind.mode_abilities().any(|x| x == ability) {
            let has: Vec<&str> = kind.mode_abilities().map(Ability::name).collect();
            return Err(bad(format!(
                "not an ability of this unit (it has: {})",
                if has.is_empty() { "none".into() } else { has.join(", ") }
            )));
        }
        if a.text.trim().is_empty() {
            return Err(bad("no text".into()));
        }
        abilities.push((ability, a.text));
    }
    Ok(UnitDoc {
        kind,
        strong_against: kinds("strong_against", &u.strong_against)?,
        weak_against: kinds("weak_against", &u.weak_against)?,
        summary: u.summary,
        strengths: u.strengths,
        weaknesses: u.weaknesses,
        tactics: u.tactics,
        abilities,
    })
}

/// The engine's loops per second of game time (Faster speed).
const LOOPS_PER_S: f32 = avacraft_engine::LOOPS_PER_SECOND;

fn join_kinds(kinds: &[UnitKind]) -> String {
    kinds.iter().map(|k| k.name()).collect::<Vec<_>>().join(", ")
}

fn weapon_line(w: &Weapon) -> String {
    let mut s = format!("{} damage", w.damage);
    if w.hits > 1 {
        let _ = write!(s, " x{} hits", w.hits);
    }
    for (attrs, bonus) in w.bonus {
        let _ = write!(s, " (+{bonus} vs {})", attrs.names().collect::<Vec<_>>().join("/"));
    }
    let reach = match w.reach {
        Reach::Ground => "ground only",
        Reach::Air => "air only",
        Reach::Any => "ground and air",
    };
    let _ = write!(s, ", range {}, every {:.2} s, hits {reach}", w.range, w.cooldown / LOOPS_PER_S);
    if w.min_range > 0.0 {
        let _ = write!(s, ", minimum range {}", w.min_range);
    }
    match w.splash {
        Splash::None => {}
        Splash::Radial { friendly_fire, .. } => {
            s.push_str(", splash damage around the target");
            if friendly_fire {
                s.push_str(" (also to friendly units)");
            }
        }
        Splash::Line { .. } => s.push_str(", splash along a line across the target"),
        Splash::Cone { .. } => s.push_str(", splash in a cone towards the target"),
    }
    if w.suicide {
        s.push_str(", the unit dies when it attacks");
    }
    s
}

/// A unit type's data in one line: race, attributes, health, shields, armor, speed, sight,
/// energy, weapons.
pub fn stats_line(spec: &UnitSpec) -> String {
    let attrs: Vec<&str> = spec.attrs.names().collect();
    let mut s =
        format!("{:?}, {}, {} health", spec.race, if attrs.is_empty() { "no attributes".into() } else { attrs.join(", ") }, spec.hp);
    if spec.shield > 0.0 {
        let _ = write!(s, ", {} shields", spec.shield);
    }
    let _ = write!(s, ", {} armor", spec.armor);
    if spec.speed > 0.0 {
        let _ = write!(s, ", speed {:.2}", spec.speed * LOOPS_PER_S);
    } else {
        s.push_str(", cannot move");
    }
    let _ = write!(s, ", sight {}", spec.sight);
    if spec.flying {
        s.push_str(", flying (only anti-air weapons hit it)");
    }
    if spec.energy_max > 0.0 {
        let _ = write!(s, ", energy {} of at most {}", spec.energy_start, spec.energy_max);
    }
    if spec.detector {
        s.push_str(", detector (reveals cloaked units)");
    }
    if spec.weapons.is_empty() {
        s.push_str(". No weapon");
    }
    for w in spec.weapons {
        let _ = write!(s, ". Weapon: {}", weapon_line(w));
    }
    s.push('.');
    s
}

fn ability_facts(a: Ability) -> String {
    let spec = a.spec();
    let mut facts = Vec::new();
    if spec.energy > 0.0 {
        facts.push(format!("costs {} energy", spec.energy));
    }
    if spec.cooldown > 0 {
        facts.push(format!("cooldown {:.1} s", spec.cooldown as f32 / LOOPS_PER_S));
    }
    if spec.range > 0.0 {
        facts.push(format!("cast range {}", spec.range));
    }
    if facts.is_empty() { String::new() } else { format!(" ({}; action name `{}`)", facts.join(", "), a.name()) }
}

/// The unit data the passages' numbers come from: Liberty, which SMAC's, SMACv2's and most of
/// the paper's maps run (the Void maps' numbers differ for a few units; docs/ava.md).
const KB_DATA: avacraft_engine::DataSet = avacraft_engine::DataSet::Liberty;

fn passages_of(d: &UnitDoc) -> Vec<Passage> {
    let name = d.kind.name();
    let mut profile = format!("{name}: {} Stats: {}", d.summary.trim(), stats_line(d.kind.spec_in(KB_DATA)));
    let _ = write!(profile, " Strengths: {} Weaknesses: {}", d.strengths.trim(), d.weaknesses.trim());
    if !d.strong_against.is_empty() {
        let _ = write!(profile, " Strong against: {}.", join_kinds(&d.strong_against));
    }
    if !d.weak_against.is_empty() {
        let _ = write!(profile, " Weak against: {}.", join_kinds(&d.weak_against));
    }
    let mut out = vec![Passage { kind: d.kind, topic: Topic::Profile, title: format!("{name} profile"), text: profile }];
    for (a, text) in &d.abilities {
        out.push(Passage {
            kind: d.kind,
            topic: Topic::Ability(*a),
            title: format!("{name} ability {}", a.name()),
            text: format!("{name} ability {}{}: {}", a.name(), ability_facts(*a), text.trim()),
        });
    }
    if !d.tactics.is_empty() {
        let tips: Vec<&str> = d.tactics.iter().map(|t| t.trim()).collect();
        out.push(Passage {
            kind: d.kind,
            topic: Topic::Tactics,
            title: format!("{name} tactics"),
            text: format!("{name} tactics: {}", tips.join(" ")),
        });
    }
    out
}
