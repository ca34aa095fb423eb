//! The ability slots' table: which abilities each agent's slots hold. A leaf, because the
//! SMAC layout holds one while the extension's methods are on the layout.

use crate::ability::Ability;
use crate::action::Direction;
use crate::scenario::Scenario;
use crate::units::UnitKind;

/// What index `j` of a direction slot aims at: SMAC's moves, in their order.
pub(super) const DIRS: [Direction; 4] = [Direction::Up, Direction::Down, Direction::Right, Direction::Left];

/// Ability slots of one team's agents.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct AbilitySlots {
    /// Abilities per agent, slot order.
    pub per_agent: Vec<Vec<Ability>>,
    /// Slots per agent (the most any agent has).
    pub slots: usize,
    /// Actions per slot.
    pub width: usize,
}

/// The SMAC slot abilities of a unit type: every mode's abilities except Heal, which
/// SMAC's attack slots already cover for healers.
pub fn slot_abilities(kind: UnitKind) -> Vec<Ability> {
    kind.abilities().filter(|a| *a != Ability::Heal).collect()
}

impl AbilitySlots {
    /// `floor`: the fewest slots per agent (a procedural scenario's most, whatever it drew).
    pub(crate) fn new(scenario: &Scenario, agents: &[crate::ids::UnitId], n_enemies: usize, floor: usize) -> Self {
        let per_agent: Vec<Vec<Ability>> = agents.iter().map(|id| slot_abilities(scenario.units[id.index()].kind)).collect();
        let slots = per_agent.iter().map(Vec::len).max().unwrap_or(0).max(floor);
        let width = if slots == 0 { 0 } else { n_enemies.max(agents.len()).max(DIRS.len()) };
        Self { per_agent, slots, width }
    }
    pub fn n_actions(&self) -> usize {
        self.slots * self.width
    }
}
