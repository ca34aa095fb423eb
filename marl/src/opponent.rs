//! Who plays team 2 of a PvP scenario while team 1 learns: the config's `opponent`, parsed.

/// Who plays team 2 of a PvP scenario while team 1 learns (the config's `opponent`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Opponent {
    /// "": team 2 gets no orders.
    Idle,
    /// `scripted:NAME` or `NAME`: a scripted agent.
    Scripted(String),
    /// `marl:DIR`: a trained checkpoint.
    Marl(std::path::PathBuf),
    /// `self`: the learner's own snapshots ([`crate::selfplay`]).
    SelfPlay,
}

impl Opponent {
    pub fn parse(s: &str) -> Result<Opponent, String> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(Opponent::Idle);
        }
        if s == "self" {
            return Ok(Opponent::SelfPlay);
        }
        if let Some(dir) = s.strip_prefix("marl:") {
            return Ok(Opponent::Marl(dir.into()));
        }
        let name = s.strip_prefix("scripted:").unwrap_or(s);
        if avacraft_engine::agent::factory(name).is_err() {
            let known: Vec<&str> = avacraft_engine::agent::AGENTS.iter().map(|(n, _)| *n).collect();
            return Err(format!("scripted:NAME ({}), marl:DIR or self", known.join(", ")));
        }
        Ok(Opponent::Scripted(name.to_owned()))
    }
}
