//! The model's decision: actions as JSON against a schema, checked item by item against what
//! the team observes before anything is executed.
//!
//! The paper's released code threw the model's decision away and had a text-only model
//! rewrite the actions; here the executed actions are the model's own, or nothing: an item
//! that names a unit the agent does not control, a target it cannot see or hit, an ability
//! its unit lacks or cannot cast now (energy, cooldown, range), is refused with a reason in
//! words, and the reasons go back to the model in a repair round. The checks are the
//! engine's rules read from the observation, so an accepted order is not refused later.

mod check;
mod item;
mod parse;

pub use check::{Checked, Order, Refused, Situation, check, targets};
pub use item::{DIRECTIONS, Item, Verb, schema, schema_for};
pub use parse::{ParseError, ParsedItems, extract_json, parse_items};
