//! The unit knowledge base against the engine's tables, and retrieval from it.

use avacraft_ava::{Bm25, KbError, KnowledgeBase, Retriever, Topic};
use avacraft_engine::{Ability, UnitKind};
use proptest::prelude::*;
use std::sync::OnceLock;

fn kb() -> &'static KnowledgeBase {
    static KB: OnceLock<KnowledgeBase> = OnceLock::new();
    KB.get_or_init(|| KnowledgeBase::builtin().unwrap_or_else(|e| panic!("the shipped knowledge base: {e}")))
}

fn bm25() -> &'static Bm25 {
    static R: OnceLock<Bm25> = OnceLock::new();
    R.get_or_init(|| Bm25::new(kb()))
}

#[test]
fn every_unit_type_and_every_ability_is_described() {
    for kind in UnitKind::ALL {
        let doc = kb().doc(kind).unwrap_or_else(|| panic!("{kind} has no entry"));
        for a in kind.mode_abilities() {
            assert!(doc.abilities.iter().any(|(x, _)| *x == a), "{kind}: ability {} is not described", a.name());
        }
        let topics: Vec<Topic> = kb().passages().iter().filter(|p| p.kind == kind).map(|p| p.topic).collect();
        assert!(topics.contains(&Topic::Profile) && topics.contains(&Topic::Tactics), "{kind}: {topics:?}");
        assert!(!doc.weak_against.contains(&kind) || !doc.strong_against.contains(&kind), "{kind} both strong and weak against itself");
    }
    assert_eq!(kb().docs().len(), UnitKind::ALL.len());
}

#[test]
fn profiles_carry_the_engines_numbers() {
    for kind in UnitKind::ALL {
        let spec = kind.spec_in(avacraft_engine::DataSet::Liberty);
        let p = kb().passages().iter().find(|p| p.kind == kind && p.topic == Topic::Profile).expect("a profile");
        assert!(p.text.contains(&format!("{} health", spec.hp)), "{kind}: {}", p.text);
        assert!(p.text.contains(&format!("{} armor", spec.armor)), "{kind}: {}", p.text);
        for w in spec.weapons {
            assert!(p.text.contains(&format!("range {}", w.range)), "{kind}: {}", p.text);
        }
        if spec.shield > 0.0 {
            assert!(p.text.contains(&format!("{} shields", spec.shield)), "{kind}: {}", p.text);
        }
    }
    let storm = kb().passages().iter().find(|p| p.topic == Topic::Ability(Ability::PsionicStorm)).expect("storm");
    assert!(storm.text.contains(&format!("costs {} energy", Ability::PsionicStorm.spec().energy)), "{}", storm.text);
}

#[test]
fn a_unit_name_retrieves_that_unit_first() {
    for kind in UnitKind::ALL {
        let hits = bm25().search(kind.name(), 3);
        assert_eq!(
            hits.first().map(|h| h.passage.kind),
            Some(kind),
            "query `{kind}`: {:?}",
            hits.iter().map(|h| &h.passage.title).collect::<Vec<_>>()
        );
    }
}

#[test]
fn situation_queries_find_the_right_passages() {
    let cases: [(&str, UnitKind, Option<Ability>); 6] = [
        ("Stalker blink away when shields are low", UnitKind::Stalker, Some(Ability::Blink)),
        ("psionic storm on clumped units", UnitKind::HighTemplar, Some(Ability::PsionicStorm)),
        ("heal injured biological units", UnitKind::Medivac, Some(Ability::Heal)),
        ("tank siege mode long range artillery", UnitKind::SiegeTank, Some(Ability::SiegeMode)),
        ("Queen transfusion", UnitKind::Queen, Some(Ability::Transfusion)),
        ("Sentry force field", UnitKind::Sentry, Some(Ability::ForceField)),
    ];
    for (query, kind, ability) in cases {
        let hits = bm25().search(query, 3);
        let titles: Vec<&str> = hits.iter().map(|h| h.passage.title.as_str()).collect();
        assert!(
            hits.iter().any(|h| h.passage.kind == kind && ability.is_none_or(|a| h.passage.topic == Topic::Ability(a))),
            "query `{query}`: {titles:?}"
        );
    }
}

#[test]
fn bad_files_are_refused_naming_what_is_wrong() {
    let unit =
        |kind: &str, extra: &str| format!("[[unit]]\nkind = \"{kind}\"\nsummary = \"s\"\nstrengths = \"s\"\nweaknesses = \"w\"\n{extra}\n");
    let cases: Vec<(String, &str)> = vec![
        (unit("Marinee", ""), "Marinee"),
        (format!("{}{}", unit("Marine", ""), unit("Marine", "")), "twice"),
        (unit("Marine", "[[unit.abilities]]\nname = \"Blink\"\ntext = \"t\""), "not an ability of this unit"),
        (unit("Marine", "[[unit.abilities]]\nname = \"Teleport\"\ntext = \"t\""), "Teleport"),
        (unit("Marine", "weak_against = [\"Dragoon\"]"), "Dragoon"),
        (unit("Marine", "colour = \"red\""), "colour"),
        ("[[unit]]\nkind = \"Marine\"\nsummary = \"\"\nstrengths = \"s\"\nweaknesses = \"w\"\n".to_owned(), "summary"),
        ("[[unit]\n".to_owned(), "my.toml"),
    ];
    for (text, needle) in cases {
        let err = KnowledgeBase::from_toml("my.toml", &text).err().unwrap_or_else(|| panic!("accepted: {text}"));
        let msg = err.to_string();
        assert!(msg.contains("my.toml") && msg.contains(needle), "{msg}");
        if needle == "Marinee" {
            assert!(matches!(err, KbError::UnknownUnit { .. }) && std::error::Error::source(&err).is_some());
        }
    }
    // A partial base is fine: a user's own file may describe some units only.
    let one = KnowledgeBase::from_toml("my.toml", &unit("Marine", "[[unit.abilities]]\nname = \"Stimpack\"\ntext = \"t\""));
    assert_eq!(one.map(|k| k.passages().len()).ok(), Some(2));
}

proptest! {
    /// Any query: at most k hits, best first, positive scores, and the same answer twice.
    #[test]
    fn search_is_bounded_ordered_and_deterministic(query in "\\PC{0,80}", k in 0usize..12) {
        let a = bm25().search(&query, k);
        prop_assert!(a.len() <= k);
        prop_assert!(a.windows(2).all(|w| w[0].score >= w[1].score));
        prop_assert!(a.iter().all(|h| h.score > 0.0 && h.index < kb().passages().len()));
        prop_assert_eq!(a, bm25().search(&query, k));
    }
}

fn dense() -> &'static avacraft_ava::kb::Dense {
    static R: OnceLock<avacraft_ava::kb::Dense> = OnceLock::new();
    R.get_or_init(|| avacraft_ava::kb::Dense::load(kb()).unwrap_or_else(|e| panic!("dense retrieval needs all-MiniLM-L6-v2: {e}")))
}

/// Dense retrieval (all-MiniLM-L6-v2): a unit's name finds that unit among the first three
/// passages, and a question in words finds the unit it describes, which keywords alone can
/// miss.
#[test]
fn dense_retrieval_finds_units_by_name_and_by_meaning() {
    let mut first = 0;
    for kind in UnitKind::ALL {
        let hits = dense().search(kind.name(), 3);
        assert!(
            hits.iter().any(|h| h.passage.kind == kind),
            "query `{kind}`: {:?}",
            hits.iter().map(|h| &h.passage.title).collect::<Vec<_>>()
        );
        first += usize::from(hits.first().is_some_and(|h| h.passage.kind == kind));
        assert!(hits.windows(2).all(|w| w[0].score >= w[1].score), "best first");
    }
    assert!(first * 10 >= UnitKind::ALL.len() * 8, "the unit itself first for most names: {first} of {}", UnitKind::ALL.len());
    for (question, kind) in
        [("which unit heals wounded infantry", UnitKind::Medivac), ("a psionic storm that damages an area", UnitKind::HighTemplar)]
    {
        let hits = dense().search(question, 4);
        assert!(
            hits.iter().any(|h| h.passage.kind == kind),
            "`{question}`: {:?}",
            hits.iter().map(|h| &h.passage.title).collect::<Vec<_>>()
        );
    }
    // The same query ranks the same way (cached or not).
    assert_eq!(dense().search("Stalker blink", 4), dense().search("Stalker blink", 4));
    assert!(dense().search("", 4).is_empty() && dense().search("Marine", 0).is_empty());
}
