//! What a commander tells a role group: its role and the briefing. A leaf, because the agent
//! contract carries briefings (`Agent::brief`) while the commanders' machinery is built on
//! that contract.

use crate::ids::UnitId;

/// A role group's role. The codes are `RoleGroup.msg`'s `ROLE_*` constants.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum GroupRole {
    /// Fixed ownership (no commander).
    #[default]
    None,
    Attacker,
    Defender,
    Scout,
    Support,
}

impl GroupRole {
    pub const ALL: [GroupRole; 5] = [GroupRole::None, GroupRole::Attacker, GroupRole::Defender, GroupRole::Scout, GroupRole::Support];
    /// The roles a commander hands out.
    pub const ASSIGNABLE: [GroupRole; 4] = [GroupRole::Attacker, GroupRole::Defender, GroupRole::Scout, GroupRole::Support];

    pub fn code(self) -> u8 {
        self as u8
    }
    pub fn from_code(code: u8) -> Option<GroupRole> {
        GroupRole::ALL.get(code as usize).copied()
    }
    pub fn name(self) -> &'static str {
        match self {
            GroupRole::None => "none",
            GroupRole::Attacker => "attacker",
            GroupRole::Defender => "defender",
            GroupRole::Scout => "scout",
            GroupRole::Support => "support",
        }
    }
    pub fn from_name(name: &str) -> Option<GroupRole> {
        GroupRole::ALL.into_iter().find(|r| r.name().eq_ignore_ascii_case(name))
    }
}

impl std::fmt::Display for GroupRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a commander tells its groups besides who owns what.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Briefing {
    /// The role of the group being briefed.
    pub role: GroupRole,
    /// The plan in words (empty: none).
    pub plan: String,
    /// Enemy units that matter most, most important first.
    pub priorities: Vec<UnitId>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn role_codes_round_trip() {
        for r in GroupRole::ALL {
            assert_eq!(GroupRole::from_code(r.code()), Some(r));
            assert_eq!(GroupRole::from_name(r.name()), Some(r));
        }
        assert_eq!(GroupRole::from_code(5), None);
    }
}
