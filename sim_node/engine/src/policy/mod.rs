//! Policies: anything that turns a team's view into actions. Scripted agents, the scripted
//! opponent styles, and (later) VLM and MARL agents all implement [`Policy`].

mod scripted;
mod view;

pub use scripted::{AttackMove, Defensive, FocusFire, NoOp, RandomActions, Style};
pub use view::TeamView;

use crate::action::Action;
use crate::ids::Team;
use crate::scenario::{OpponentKind, Scenario};
use rand_chacha::ChaCha8Rng;

pub trait Policy: Send {
    fn name(&self) -> &str;
    /// Called at the start of every episode.
    fn reset(&mut self, _scenario: &Scenario, _team: Team) {}
    /// Actions for this step; units without an action keep their orders.
    fn act(&mut self, view: &TeamView<'_>, rng: &mut ChaCha8Rng) -> Vec<Action>;
}

/// Names accepted by [`by_name`], with a line each for `--help` and error messages.
pub const POLICIES: &[(&str, &str)] = &[
    ("focus-fire", "every unit attacks the visible enemy with the lowest HP + shields it can hit"),
    ("kite", "focus fire; ranged units step back from slower melee units while reloading"),
    ("attack-move", "attack-move to the enemy start and let the engine pick targets"),
    ("builtin", "the built-in AI's behaviour: attack-move towards the enemy"),
    ("aggressive", "scripted style: attack-move, everyone on the enemy closest to the army"),
    ("defensive", "scripted style: hold ground or high ground, pull back badly hurt units"),
    ("focus", "scripted style: lowest effective HP in range, ranged units kite slower melee"),
    ("random", "uniformly random available SMAC action per unit"),
    ("noop", "never gives an order"),
];

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown policy `{0}` (known: focus-fire, kite, attack-move, builtin, aggressive, defensive, focus, random, noop)")]
pub struct UnknownPolicy(pub String);

/// A policy by its CLI name.
pub fn by_name(name: &str) -> Result<Box<dyn Policy>, UnknownPolicy> {
    Ok(match name {
        "focus-fire" => Box::new(FocusFire::team_focus()),
        "kite" => Box::new(FocusFire::kiting()),
        "attack-move" | "builtin" => Box::new(AttackMove),
        "aggressive" => Box::new(Style::aggressive()),
        "defensive" => Box::new(Defensive::default()),
        "focus" => Box::new(Style::focus()),
        "random" => Box::new(RandomActions),
        "noop" => Box::new(NoOp),
        other => return Err(UnknownPolicy(other.to_owned())),
    })
}

/// The scripted opponent for a style (not `builtin`, which is the engine's own AI).
pub(crate) fn opponent(kind: OpponentKind) -> Box<dyn Policy> {
    match kind {
        OpponentKind::Aggressive => Box::new(Style::aggressive()),
        OpponentKind::Defensive => Box::new(Defensive::default()),
        OpponentKind::Focus | OpponentKind::Builtin | OpponentKind::Random => Box::new(Style::focus()),
    }
}
