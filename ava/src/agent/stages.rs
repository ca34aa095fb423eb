//! The answers of the planner, priority and role stages: schemas, and reading them with the
//! same care as decisions (what names units is checked against the observation; what does
//! not fit is dropped and counted, never guessed).

use avacraft_engine::UnitId;
use avacraft_engine::agent::GroupObs;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Skill {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub steps: Vec<String>,
    #[serde(default)]
    pub when_to_use: String,
}

/// The planner's micro plan.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub primary_skill: Skill,
    #[serde(default)]
    pub secondary_skills: Vec<Skill>,
}

impl Plan {
    pub fn schema() -> Value {
        let skill = |extra: &str| {
            json!({"type": "object", "properties": {
                "name": {"type": "string", "maxLength": 80},
                "description": {"type": "string", "maxLength": 300},
                extra: if extra == "steps" { json!({"type": "array", "items": {"type": "string", "maxLength": 160}, "maxItems": 5}) } else { json!({"type": "string", "maxLength": 200}) }
            }, "required": ["name", "description", extra], "additionalProperties": false})
        };
        json!({"type": "object", "properties": {
            "primary_skill": skill("steps"),
            "secondary_skills": {"type": "array", "items": skill("when_to_use"), "maxItems": 3}
        }, "required": ["primary_skill", "secondary_skills"], "additionalProperties": false})
    }

    /// The plan in one paragraph, for the decision prompt.
    pub fn summary(&self) -> String {
        let mut s = format!("{}: {}", self.primary_skill.name, self.primary_skill.description);
        if !self.primary_skill.steps.is_empty() {
            s.push_str(&format!(" Steps: {}.", self.primary_skill.steps.join("; ")));
        }
        for k in &self.secondary_skills {
            s.push_str(&format!(" Also {} ({}), when {}.", k.name, k.description, k.when_to_use));
        }
        s
    }
}

/// An enemy the model named as important.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Priority {
    /// Written and read as the unit's tag; a number that is no tag does not parse.
    #[serde(with = "avacraft_engine::serde_as::tag")]
    pub unit: UnitId,
    pub reason: String,
}

pub fn priority_schema() -> Value {
    json!({"type": "object", "properties": {"priorities": {"type": "array", "maxItems": 3, "items": {
        "type": "object",
        "properties": {"unit": {"type": "integer", "minimum": 1}, "reason": {"type": "string", "maxLength": 200}},
        "required": ["unit", "reason"], "additionalProperties": false}}},
        "required": ["priorities"], "additionalProperties": false})
}

/// The priorities that name enemies in sight (at most three), and how many were dropped.
pub fn read_priorities(v: &Value, obs: &GroupObs) -> (Vec<Priority>, usize) {
    let list = v.get("priorities").and_then(Value::as_array).cloned().unwrap_or_default();
    let mut out: Vec<Priority> = Vec::new();
    let mut dropped = 0;
    for raw in list {
        match serde_json::from_value::<Priority>(raw) {
            Ok(p) if obs.units.iter().any(|u| !u.own && u.tag == p.unit) && !out.iter().any(|q| q.unit == p.unit) && out.len() < 3 => {
                out.push(p)
            }
            _ => dropped += 1,
        }
    }
    (out, dropped)
}

pub const ROLES: [&str; 4] = ["attacker", "defender", "scout", "support"];

/// A unit's role and task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoleOf {
    #[serde(with = "avacraft_engine::serde_as::tag")]
    pub unit: UnitId,
    pub role: String,
    #[serde(default)]
    pub task: String,
}

pub fn roles_schema() -> Value {
    json!({"type": "object", "properties": {"roles": {"type": "array", "items": {
        "type": "object",
        "properties": {"unit": {"type": "integer", "minimum": 1}, "role": {"type": "string", "enum": ROLES}, "task": {"type": "string", "maxLength": 120}},
        "required": ["unit", "role", "task"], "additionalProperties": false}}},
        "required": ["roles"], "additionalProperties": false})
}

/// Roles for controlled units (one each, known role names), and how many were dropped.
pub fn read_roles(v: &Value, controlled: &[UnitId]) -> (Vec<RoleOf>, usize) {
    let list = v.get("roles").and_then(Value::as_array).cloned().unwrap_or_default();
    let mut out: Vec<RoleOf> = Vec::new();
    let mut dropped = 0;
    for raw in list {
        match serde_json::from_value::<RoleOf>(raw) {
            Ok(mut r) if controlled.contains(&r.unit) && !out.iter().any(|q| q.unit == r.unit) => {
                r.role = r.role.to_ascii_lowercase();
                if ROLES.contains(&r.role.as_str()) {
                    out.push(r);
                } else {
                    dropped += 1;
                }
            }
            _ => dropped += 1,
        }
    }
    out.sort_by_key(|r| r.unit);
    (out, dropped)
}
