//! What the model writes: the items of a decision and the JSON schema they are held to. A
//! leaf, so parsing and checking both read items without depending on each other.

use avacraft_engine::UnitId;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

/// What an item asks a unit to do. The names are the schema's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verb {
    /// Attack an enemy unit (a healer: heal a friendly one).
    Attack,
    /// Move to the centre of a cell of the screenshot's 10x10 grid.
    MoveGrid,
    /// Move a few units north, south, east or west.
    MoveDir,
    /// Cast an ability, with a unit or cell target where it needs one.
    Ability,
    Hold,
    Stop,
    /// Micro action set: walk to a cell or an exact point, fighting what comes in range.
    AttackMove,
    /// Micro action set: walk to an exact point (world units).
    Move,
    /// Micro action set: a standing order carried out every step until the unit's next
    /// order (`focus` a target, `kite`, `hold`).
    Stance,
}

impl Verb {
    /// The paper's action set.
    pub const ALL: [Verb; 6] = [Verb::Attack, Verb::MoveGrid, Verb::MoveDir, Verb::Ability, Verb::Hold, Verb::Stop];
    /// The micro action set: the paper's and three more.
    pub const MICRO: [Verb; 9] =
        [Verb::Attack, Verb::MoveGrid, Verb::MoveDir, Verb::Ability, Verb::Hold, Verb::Stop, Verb::AttackMove, Verb::Move, Verb::Stance];
    pub fn name(self) -> &'static str {
        match self {
            Verb::Attack => "attack",
            Verb::MoveGrid => "move_grid",
            Verb::MoveDir => "move_dir",
            Verb::Ability => "ability",
            Verb::Hold => "hold",
            Verb::Stop => "stop",
            Verb::AttackMove => "attack_move",
            Verb::Move => "move",
            Verb::Stance => "stance",
        }
    }
}

/// The compass directions of `move_dir` (north is up on the screenshot).
pub const DIRECTIONS: [&str; 4] = ["north", "south", "east", "west"];

/// One requested action as the model wrote it, before checking.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Item {
    /// The unit's tag, as drawn on the screenshot.
    pub unit: u32,
    pub action: Verb,
    /// A unit tag: the attack's or the ability's target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<u32>,
    /// A grid cell [column, row], each 1..=10, [1, 1] top left.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cell: Option<[u8; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ability: Option<String>,
    /// Micro action set: an exact point [x, y] in world units (`move`, `attack_move`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point: Option<[f32; 2]>,
    /// Micro action set: `focus` (with `target`), `kite` or `hold`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stance: Option<String>,
}

/// The JSON schema of a decision, for the team's alive controllable `units`, the unit tags an
/// action may target (`targets`, see [`targets`](super::targets)) and the ability names the
/// team may cast.
///
/// Flat items: every field is present and those an action does not use are `null`, as
/// OpenAI's strict `json_schema` mode requires (every property required, none extra);
/// llama.cpp's grammar and the other servers take the same schema. What an action needs is
/// checked afterwards, with a reason the model can act on.
///
/// The schema is as tight as the situation allows, because constrained decoding makes a
/// small model follow it to the letter: unit and target tags are `enum`s of the tags there
/// are, so no decoding is spent on tags that would be refused, and the list holds at most
/// one item per unit, so it ends: with an unbounded list SmolLM2-135M went on listing actions
/// until `max_tokens` cut the JSON off. Verbs that cannot succeed are left out (`attack`
/// with nothing to target, `ability` for a team without abilities).
pub fn schema(units: &[UnitId], targets: &[UnitId], abilities: &[&str]) -> Value {
    schema_for(units, targets, abilities, false)
}

/// [`schema`], with the micro action set's verbs and fields (`point`, `stance`) when `micro`.
/// The paper's schema is unchanged, so its recorded calls still replay.
pub fn schema_for(units: &[UnitId], targets: &[UnitId], abilities: &[&str], micro: bool) -> Value {
    let tags = |ids: &[UnitId]| ids.iter().map(|id| id.tag()).collect::<Vec<u32>>();
    let (units, targets) = (&tags(units)[..], &tags(targets)[..]);
    let all: &[Verb] = if micro { &Verb::MICRO } else { &Verb::ALL };
    let verbs: Vec<&str> = all
        .iter()
        .filter(|v| match v {
            Verb::Attack => !targets.is_empty(),
            Verb::Ability => !abilities.is_empty(),
            _ => true,
        })
        .map(|v| v.name())
        .collect();
    // `enum` must not be empty: with no tag to name, a field can only be null.
    let nullable = |s: Value| json!({"anyOf": [s, {"type": "null"}]});
    let unit = if units.is_empty() { json!({"type": "integer", "minimum": 1}) } else { json!({"type": "integer", "enum": units}) };
    let target = if targets.is_empty() { json!({"type": "null"}) } else { nullable(json!({"type": "integer", "enum": targets})) };
    let ability = if abilities.is_empty() { json!({"type": "null"}) } else { nullable(json!({"type": "string", "enum": abilities})) };
    let mut item = json!({
        "type": "object",
        "properties": {
            "unit": unit,
            "action": {"type": "string", "enum": verbs},
            "target": target,
            "cell": nullable(json!({"type": "array", "items": {"type": "integer", "minimum": 1, "maximum": 10}, "minItems": 2, "maxItems": 2})),
            "direction": nullable(json!({"type": "string", "enum": DIRECTIONS})),
            "ability": ability
        },
        "required": ["unit", "action", "target", "cell", "direction", "ability"],
        "additionalProperties": false
    });
    if micro {
        item["properties"]["point"] = nullable(json!({"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}));
        item["properties"]["stance"] = nullable(json!({"type": "string", "enum": avacraft_engine::agent::Stance::NAMES}));
        item["required"] = json!(["unit", "action", "target", "cell", "point", "direction", "ability", "stance"]);
    }
    json!({
        "type": "object",
        "properties": {
            "reasoning": {"type": "string", "maxLength": 600},
            "actions": {
                "type": "array",
                "maxItems": units.len(),
                "items": item
            }
        },
        "required": ["reasoning", "actions"],
        "additionalProperties": false
    })
}
