//! Policies: anything that turns a team's view into actions. Scripted agents, the scripted
//! opponent styles, and (later) VLM and MARL agents all implement [`Policy`].

mod micro;
mod scripted;
mod view;

pub use micro::ability_actions;
pub use scripted::{AttackMove, Defensive, FocusFire, NoOp, RandomActions, Style};
pub use view::TeamView;

use crate::action::Action;
use crate::env::Env;
use crate::ids::Team;
use crate::scenario::{Mode, OpponentKind, Scenario};
use rand::SeedableRng;
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

/// The policies driving an environment's agent teams (team 1; team 2 too in PvP), each with
/// its own seeded RNG, so every tool plays episodes the same way.
pub struct Controllers {
    teams: Vec<(Team, Box<dyn Policy>, ChaCha8Rng)>,
}

impl std::fmt::Debug for Controllers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.teams.iter().map(|(t, p, _)| (t, p.name()))).finish()
    }
}

impl Controllers {
    /// `second` drives team 2 in PvP scenarios and is ignored in PvE.
    pub fn new(scenario: &Scenario, first: Box<dyn Policy>, second: Option<Box<dyn Policy>>) -> Self {
        let mut teams = vec![(Team::One, first, ChaCha8Rng::seed_from_u64(0))];
        if scenario.mode == Mode::Pvp
            && let Some(p) = second
        {
            teams.push((Team::Two, p, ChaCha8Rng::seed_from_u64(0)));
        }
        Self { teams }
    }

    /// Starts an episode: resets every policy and reseeds its RNG from `seed`.
    pub fn reset(&mut self, scenario: &Scenario, seed: u64) {
        for (team, p, rng) in &mut self.teams {
            p.reset(scenario, *team);
            *rng = ChaCha8Rng::seed_from_u64(seed ^ (0x5151_u64 << team.index()));
        }
    }

    /// Each policy looks at its team's view and submits its actions.
    pub fn act(&mut self, env: &mut Env) {
        for (team, p, rng) in &mut self.teams {
            let actions = p.act(&env.view(*team), rng);
            env.submit(*team, &actions);
        }
    }

    /// Names of the policies, team 1 first.
    pub fn names(&self) -> Vec<String> {
        self.teams.iter().map(|(_, p, _)| p.name().to_owned()).collect()
    }
}
