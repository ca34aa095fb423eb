//! Conversions of flag values shared by several commands.

use avacraft_engine::Team;

/// A `--team` flag's side (clap has checked it is 1 or 2).
pub(crate) fn team_of(n: u8) -> Team {
    Team::from_player(i64::from(n)).unwrap_or(Team::One)
}
