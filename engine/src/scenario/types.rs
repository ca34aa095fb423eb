//! The validated scenario and its parts. A leaf: validation builds these, the built-in
//! scenarios load through them, and the rest of the engine reads them.

use crate::geom::Vec2;
use crate::ids::Team;
use crate::terrain::Terrain;
use crate::units::{DataSet, UnitKind};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

/// Who drives team 2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    Pve,
    Pvp,
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Mode::Pve => "PvE",
            Mode::Pvp => "PvP",
        })
    }
}

/// Upgrades a scenario can grant at the start. Names of the source maps are aliases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Upgrade {
    Stimpack,
    CombatShield,
    ConcussiveShells,
    Blink,
    PsionicStorm,
    MetabolicBoost,
    /// Ghost cloak.
    PersonalCloaking,
    /// Banshee cloak.
    CloakingField,
}

impl FromStr for Upgrade {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "Stimpack" => Upgrade::Stimpack,
            "CombatShield" | "ShieldWall" => Upgrade::CombatShield,
            "ConcussiveShells" | "PunisherGrenades" => Upgrade::ConcussiveShells,
            "Blink" | "BlinkTech" => Upgrade::Blink,
            "PsionicStorm" | "PsiStormTech" => Upgrade::PsionicStorm,
            "MetabolicBoost" | "zerglingmovementspeed" => Upgrade::MetabolicBoost,
            "PersonalCloaking" => Upgrade::PersonalCloaking,
            "CloakingField" | "BansheeCloak" => Upgrade::CloakingField,
            _ => {
                return Err("unknown upgrade (known: Stimpack, CombatShield, ConcussiveShells, Blink, PsionicStorm, MetabolicBoost, PersonalCloaking, CloakingField)".into());
            }
        })
    }
}

/// The built-in AI's opening order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StartOrder {
    None,
    AttackMove { to: Vec2, delay_loops: u32 },
    AttackMoveRandom { from: Vec2, to: Vec2, delay_loops: u32 },
}

/// Opponent policies for team 2 in PvE.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OpponentKind {
    Builtin,
    Aggressive,
    Defensive,
    Focus,
    Random,
}

impl OpponentKind {
    pub const ALL: [OpponentKind; 5] =
        [OpponentKind::Builtin, OpponentKind::Aggressive, OpponentKind::Defensive, OpponentKind::Focus, OpponentKind::Random];
    pub fn name(self) -> &'static str {
        match self {
            OpponentKind::Builtin => "builtin",
            OpponentKind::Aggressive => "aggressive",
            OpponentKind::Defensive => "defensive",
            OpponentKind::Focus => "focus",
            OpponentKind::Random => "random",
        }
    }
}

impl FromStr for OpponentKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        OpponentKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| "unknown opponent (known: builtin, aggressive, defensive, focus, random)".to_owned())
    }
}

impl fmt::Display for OpponentKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenarioUnit {
    pub kind: UnitKind,
    pub team: Team,
    pub pos: Vec2,
    pub facing: f32,
    /// Energy at the start (the type's default unless the file sets it).
    pub energy: f32,
}

/// A validated scenario.
#[derive(Clone, Debug)]
pub struct Scenario {
    pub name: String,
    pub mode: Mode,
    pub description: String,
    pub objective: String,
    pub source: String,
    /// The unit data the game runs (the map's dependency).
    pub data: DataSet,
    /// Whether fog of war hides units (SMAC's maps turn it off).
    pub fog_of_war: bool,
    pub terrain: Arc<Terrain>,
    pub units: Vec<ScenarioUnit>,
    pub upgrades: [Vec<Upgrade>; 2],
    pub opponent: OpponentKind,
    pub start: StartOrder,
    pub time_limit_loops: u32,
    /// The TOML text it was parsed from, verbatim: a recording carries it, so a replay needs
    /// neither the file nor the same built-in scenarios.
    pub text: Arc<str>,
    /// Procedural scenarios: the distribution every episode's units are drawn from. `units`
    /// then holds one draw (seed 0) so that team sizes and agent order can be read as for any
    /// scenario; [`Scenario::episode`] gives the draw of an episode.
    pub generator: Option<Arc<super::Generator>>,
}

impl Scenario {
    /// Whether some unit that may play it fights in melee, so that the surround experiment
    /// (`Rules::melee_surround`) can change its games; on other maps the rule changes nothing.
    pub fn has_melee(&self) -> bool {
        let placed = self.units.iter().map(|u| u.kind);
        let drawn = self.generator.iter().flat_map(|g| g.kinds());
        placed.chain(drawn).any(|k| self.data.spec(k).weapons.iter().any(crate::units::Weapon::is_melee))
    }

    /// The scenario an episode of `seed` plays: this one, or for a procedural scenario its
    /// units drawn from `seed` (the same draw wherever the episode runs).
    pub fn episode(self: &Arc<Self>, seed: u64) -> Arc<Scenario> {
        match &self.generator {
            None => Arc::clone(self),
            Some(g) => Arc::new(self.drawn(g, seed)),
        }
    }

    pub(super) fn drawn(&self, g: &super::Generator, seed: u64) -> Scenario {
        let units = g.draw(seed, &self.terrain, self.data);
        let mut s = Scenario { units, ..self.clone() };
        // The opponent attack-moves to where team 1 starts (SMAC's opening, whatever the draw).
        if self.mode == Mode::Pve {
            s.start = StartOrder::AttackMove { to: s.spawn(Team::One), delay_loops: 0 };
        }
        s
    }

    /// This scenario on another data set: every unit must be in it. The text a recording
    /// carries says the set, so a replay plays the same game.
    pub fn with_data(&self, data: DataSet) -> Result<Scenario, ScenarioError> {
        if data == self.data {
            return Ok(self.clone());
        }
        let mut table: toml::Table = toml::from_str(&self.text)
            .map_err(|e| ScenarioError::Syntax { file: self.name.clone(), message: e.to_string().trim_end().to_owned() })?;
        table.insert("data".to_owned(), toml::Value::String(data.name().to_owned()));
        let text = toml::to_string(&table).map_err(|e| ScenarioError::Syntax { file: self.name.clone(), message: e.to_string() })?;
        Scenario::from_toml(&format!("{} (data = {data})", self.name), &text)
    }

    /// Whether episodes draw their units ([`Scenario::episode`]).
    pub fn is_procedural(&self) -> bool {
        self.generator.is_some()
    }

    pub fn count(&self, team: Team) -> usize {
        self.units.iter().filter(|u| u.team == team).count()
    }

    /// Units of a team, in scenario order.
    pub fn team_units(&self, team: Team) -> impl Iterator<Item = (usize, &ScenarioUnit)> {
        self.units.iter().enumerate().filter(move |(_, u)| u.team == team)
    }

    /// A team's units in agent order: SMAC sorts agents by unit type, then x, then y (its
    /// `init_units`); agent `i` of a team controls the `i`-th of these.
    pub fn agent_order(&self, team: Team) -> Vec<crate::ids::UnitId> {
        let mut v: Vec<(usize, &ScenarioUnit)> = self.team_units(team).collect();
        v.sort_by(|(_, a), (_, b)| {
            a.kind.base().name().cmp(b.kind.base().name()).then(a.pos.x.total_cmp(&b.pos.x)).then(a.pos.y.total_cmp(&b.pos.y))
        });
        v.into_iter().map(|(i, _)| crate::ids::UnitId::new(i as u16)).collect()
    }

    /// Centroid of a team's starting positions (its spawn).
    pub fn spawn(&self, team: Team) -> Vec2 {
        let (mut s, mut n) = (Vec2::ZERO, 0.0);
        for (_, u) in self.team_units(team) {
            s += u.pos;
            n += 1.0;
        }
        if n > 0.0 { s * (1.0 / n) } else { self.terrain.playable().center() }
    }
}

/// Why a scenario could not be loaded. Every variant names the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    #[error("{file}: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: field `{field}` = {value}: {reason}")]
    Invalid { file: String, field: String, value: String, reason: String },
    #[error("unknown scenario `{0}`: not a file, and not a built-in scenario (see `avacraft scenarios`)")]
    Unknown(String),
}
