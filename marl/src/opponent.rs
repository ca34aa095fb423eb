//! Who plays team 2 of a PvP scenario while team 1 learns: the config's `opponent`, parsed
//! once when the config is read (it is written and read as its string form, so config files
//! and checkpoints' `config.json` keep the text users write).

/// Why an opponent's text names none.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("opponent {given:?}: expected scripted:NAME ({known}), marl:DIR, self, or \"\" for none")]
pub struct BadOpponent {
    pub given: String,
    pub known: String,
}

/// Who plays team 2 of a PvP scenario while team 1 learns (the config's `opponent`).
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Opponent {
    /// "": team 2 gets no orders.
    #[default]
    Idle,
    /// `scripted:NAME` or `NAME`: a scripted agent.
    Scripted(String),
    /// `marl:DIR`: a trained checkpoint.
    Marl(std::path::PathBuf),
    /// `self`: the learner's own snapshots ([`crate::selfplay`]).
    SelfPlay,
}

impl Opponent {
    pub fn parse(s: &str) -> Result<Opponent, BadOpponent> {
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
            return Err(BadOpponent { given: s.to_owned(), known: known.join(", ") });
        }
        Ok(Opponent::Scripted(name.to_owned()))
    }
}

impl std::fmt::Display for Opponent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Opponent::Idle => Ok(()),
            Opponent::Scripted(name) => f.write_str(name),
            Opponent::Marl(dir) => write!(f, "marl:{}", dir.display()),
            Opponent::SelfPlay => f.write_str("self"),
        }
    }
}

impl TryFrom<String> for Opponent {
    type Error = BadOpponent;
    fn try_from(s: String) -> Result<Opponent, BadOpponent> {
        Opponent::parse(&s)
    }
}

impl From<Opponent> for String {
    fn from(o: Opponent) -> String {
        o.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every form reads back as itself through its text, and the text a user writes keeps
    /// its meaning (`scripted:NAME` is NAME).
    #[test]
    fn opponents_round_trip_through_their_text() {
        for text in ["", "self", "focus-fire", "marl:runs/x/best"] {
            let o = Opponent::parse(text).expect(text);
            assert_eq!(Opponent::parse(&o.to_string()), Ok(o.clone()), "{text}");
            let json = serde_json::to_string(&o).expect("json");
            assert_eq!(serde_json::from_str::<Opponent>(&json).expect("back"), o);
        }
        assert_eq!(Opponent::parse(" scripted:kite "), Ok(Opponent::Scripted("kite".into())));
        let e = Opponent::parse("dance").expect_err("unknown");
        assert!(e.to_string().contains("focus-fire") && e.to_string().contains("\"dance\""), "{e}");
        assert!(serde_json::from_str::<Opponent>("\"dance\"").is_err());
    }
}
