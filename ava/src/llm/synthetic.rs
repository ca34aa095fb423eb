//! A stand-in model that answers every stage in its schema, instantly and deterministically,
//! from the prompt's unit block: every unit of ours attacks the enemy with the lowest tag in
//! sight (or walks east when none is). It plays like a crude focus-fire script; it exists to
//! measure the pipeline without a model (`avacraft bench --ava`) and to drive tests and the
//! fake OpenAI server.

use super::{ChatModel, ChatReply, ChatRequest, LlmError, Part, Role, Stage, Usage};
use serde_json::{Value, json};

/// Tags listed under a heading of the unit block (`- <tag> <Type> at ...`), up to the next
/// heading.
pub fn tags_under(text: &str, heading: &str) -> Vec<u32> {
    let mut out = Vec::new();
    let mut on = false;
    for line in text.lines() {
        if line.starts_with(heading) {
            on = true;
            continue;
        }
        if on {
            match line.strip_prefix("- ").and_then(|r| r.split_whitespace().next()).and_then(|t| t.parse().ok()) {
                Some(t) => out.push(t),
                None => break,
            }
        }
    }
    out
}

/// The answer for `stage` to a request whose first user message reads `prompt`.
pub fn synthetic_answer(stage: Stage, prompt: &str) -> String {
    // Headings as both prompts write them ("Your units:", "Your units (tag type ...):").
    let mine = tags_under(prompt, "Your units");
    let enemies = tags_under(prompt, "Enemies in sight");
    match stage {
        Stage::Planner => json!({
            "primary_skill": {"name": "focus fire", "description": "all shoot one target", "steps": ["pick the weakest enemy", "all attack it"]},
            "secondary_skills": [{"name": "kiting", "description": "step back while reloading", "when_to_use": "when outranging the enemy"}]
        })
        .to_string(),
        Stage::Priority => json!({"priorities": enemies.iter().take(2).map(|t| json!({"unit": t, "reason": "lowest tag"})).collect::<Vec<_>>()}).to_string(),
        // The first half of the units attack, the rest defend: as units fall the split moves,
        // so a commander's units change groups during an episode.
        Stage::Roles => {
            let half = mine.len().div_ceil(2);
            let roles: Vec<Value> = mine
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    let (role, task) = if i < half { ("attacker", "focus fire") } else { ("defender", "cover the attackers") };
                    json!({"unit": t, "role": role, "task": task})
                })
                .collect();
            json!({ "roles": roles }).to_string()
        }
        Stage::Decision => {
            let actions: Vec<Value> = match enemies.first() {
                Some(e) => mine.iter().map(|t| json!({"unit": t, "action": "attack", "target": e})).collect(),
                None => mine.iter().map(|t| json!({"unit": t, "action": "move_dir", "direction": "east"})).collect(),
            };
            json!({"reasoning": "focus the lowest tag", "actions": actions}).to_string()
        }
    }
}

/// The text of a request's first user message.
pub fn first_user_text(req: &ChatRequest) -> String {
    req.messages
        .iter()
        .find(|m| m.role == Role::User)
        .map(|m| {
            m.parts
                .iter()
                .filter_map(|p| match p {
                    Part::Text(t) => Some(t.as_str()),
                    Part::Image(_) => None,
                })
                .collect::<Vec<_>>()
                .join("\n")
        })
        .unwrap_or_default()
}

/// The stand-in model. Token counts are a rough four characters per token, so accounting
/// has numbers to show.
#[derive(Clone, Copy, Debug, Default)]
pub struct Synthetic;

impl ChatModel for Synthetic {
    fn model(&self) -> &str {
        "synthetic"
    }
    fn complete(&mut self, req: &ChatRequest) -> Result<ChatReply, LlmError> {
        let prompt = first_user_text(req);
        let text = synthetic_answer(req.stage, &prompt);
        let chars: usize = req.messages.iter().flat_map(|m| &m.parts).map(|p| if let Part::Text(t) = p { t.len() } else { 0 }).sum();
        let usage = Usage { prompt_tokens: (chars / 4) as u64, completion_tokens: (text.len() / 4) as u64 };
        Ok(ChatReply { text, usage: Some(usage), latency_ms: 0.0, model: "synthetic".into(), finish: Some("stop".into()) })
    }
    fn waits(&self) -> bool {
        false
    }
}
