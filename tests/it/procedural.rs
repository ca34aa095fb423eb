//! Procedural scenarios (SMACv2's manner): the draws follow the file's distribution, are a
//! function of the seed, keep SMACv2's sizes, and bad distribution files are refused by field.

use crate::helpers::{load, play};
use avacraft_engine::DataSet;
use avacraft_engine::{Env, EnvConfig, PROCEDURAL, Scenario, ScenarioError, Team, UnitKind, Vec2, builtin, procedural_names};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::sync::Arc;

/// A procedural scenario file: the 32x32 flat map with a `[generate]` table.
fn file(generate: &str) -> String {
    format!("name = \"gen\"\nmode = \"pve\"\nmap_size = [32, 32]\nunits = []\n\n[generate]\n{generate}\n")
}

/// The chi-square test's p-value of `counts` against `probs`.
fn chi_square_p(counts: &[u64], probs: &[f64]) -> f64 {
    let n: u64 = counts.iter().sum();
    let stat: f64 = counts.iter().zip(probs).map(|(&c, &p)| (c as f64 - n as f64 * p).powi(2) / (n as f64 * p)).sum();
    let dist = ChiSquared::new((counts.len() - 1) as f64).expect("degrees of freedom");
    1.0 - dist.cdf(stat)
}

fn team(s: &Scenario, t: Team) -> Vec<UnitKind> {
    s.team_units(t).map(|(_, u)| u.kind).collect()
}

/// SMACv2's sizes (`get_env_info` of its 10gen maps with the sc2_gen configs), computed from
/// its formulas: obs = 4 + (ne + na - 1)(8 + P) + 6 + P, state = na(7 + P) + ne(6 + P) + na·n_actions.
#[test]
fn procedural_scenarios_have_smacv2_sizes() {
    assert_eq!(PROCEDURAL.len(), 15);
    for name in procedural_names() {
        let s = Arc::new(builtin(name).expect("procedural scenario"));
        let g = s.generator.clone().expect("drawn units");
        let (na, ne) = (g.n[0], g.n[1]);
        let p = usize::from(name.starts_with("protoss"));
        // Terran teams may hold a Medivac, whose attack slots reach every ally.
        let n_actions = 6 + if name.starts_with("terran") { ne.max(na) } else { ne };
        let info = Env::new(Arc::clone(&s), EnvConfig::default(), 1).env_info(Team::One);
        assert_eq!((info.n_agents, info.n_actions), (na, n_actions), "{name}");
        assert_eq!(info.obs_shape, 4 + (ne + na - 1) * (8 + p) + 6 + p, "{name}");
        assert_eq!(info.state_shape, na * (7 + p) + ne * (6 + p) + na * n_actions, "{name}");
        assert_eq!(info.episode_limit, 200, "{name}");
        // The sizes hold whatever an episode draws.
        for seed in 2..6 {
            assert_eq!(Env::new(Arc::clone(&s), EnvConfig::default(), seed).env_info(Team::One), info, "{name} seed {seed}");
        }
    }
}

/// 10,000 draws: unit types follow the weights (chi-square), the layouts follow `p`, and
/// team 2 copies team 1 before its extra block.
#[test]
fn draws_follow_the_distribution() {
    let s = Arc::new(builtin("protoss_10_vs_11").expect("scenario"));
    let kinds = [UnitKind::Stalker, UnitKind::Zealot, UnitKind::Colossus];
    let mut counts = [0u64; 3];
    let mut surrounded = 0u64;
    let centre = Vec2::new(16.0, 16.0);
    for seed in 0..10_000u64 {
        let d = s.episode(seed);
        let (a, mut e) = (team(&d, Team::One), team(&d, Team::Two));
        assert_eq!((a.len(), e.len()), (10, 11), "seed {seed}");
        for k in &a {
            counts[kinds.iter().position(|x| x == k).expect("a protoss type")] += 1;
        }
        // Team 2 is team 1's units plus one: as multisets, removing team 1 leaves one unit.
        for k in &a {
            let i = e.iter().position(|x| x == k).expect("team 2 holds team 1's types");
            e.remove(i);
        }
        assert_eq!(e.len(), 1);
        // Surrounded: team 1 starts packed around the centre; reflected: over the left half.
        if d.team_units(Team::One).all(|(_, u)| u.pos.dist(centre) < 6.0) {
            surrounded += 1;
        }
    }
    let p = chi_square_p(&counts, &[0.45, 0.45, 0.1]);
    assert!(p > 1e-3, "types {counts:?} against 0.45/0.45/0.1: p = {p}");
    // Half the draws are surrounded (p = 0.5): a binomial within 4 standard deviations.
    let z = (surrounded as f64 - 5_000.0) / 50.0;
    assert!(z.abs() < 4.0, "{surrounded} of 10,000 surrounded");
}

/// A team made of exception types alone is redrawn: with two units of which Medivacs are
/// 80%, no team is all Medivacs, and compositions follow the weights given that.
#[test]
fn teams_of_exceptions_alone_are_redrawn() {
    let s = load(&file(
        "n_units = 2\nn_enemies = 2\nunit_types = [\"Marine\", \"Medivac\"]\nweights = [0.2, 0.8]\nexception_unit_types = [\"Medivac\"]\nstart_positions = \"reflect\"",
    ));
    let mut counts = [0u64; 2];
    for seed in 0..10_000u64 {
        let marines = team(&s.episode(seed), Team::One).iter().filter(|k| **k == UnitKind::Marine).count();
        assert!(marines > 0, "seed {seed}: a team of Medivacs alone");
        counts[marines - 1] += 1;
    }
    // Given at least one Marine: both Marines 0.04 / 0.36, one of each 0.32 / 0.36.
    let p = chi_square_p(&[counts[1], counts[0]], &[0.04 / 0.36, 0.32 / 0.36]);
    assert!(p > 1e-3, "compositions {counts:?}: p = {p}");
}

/// The same seed gives the same draw and the same episode; other seeds other draws. Agent
/// `i` is always unit `i` of its team (teams are listed in SMAC's agent order), and no two
/// ground bodies start overlapping.
#[test]
fn a_draw_is_a_function_of_the_seed() {
    let s = Arc::new(builtin("zerg_10_vs_11").expect("scenario"));
    let units = |seed| s.episode(seed).units.iter().map(|u| (u.kind, u.pos.x.to_bits(), u.pos.y.to_bits())).collect::<Vec<_>>();
    assert_eq!(units(7), units(7));
    assert_ne!(units(7), units(8));
    for seed in 0..50 {
        let d = s.episode(seed);
        for t in Team::BOTH {
            let order: Vec<usize> = d.agent_order(t).iter().map(|id| id.index()).collect();
            let listed: Vec<usize> = d.team_units(t).map(|(i, _)| i).collect();
            assert_eq!(order, listed, "seed {seed}");
        }
        for (i, a) in d.units.iter().enumerate() {
            for b in &d.units[i + 1..] {
                if !a.kind.spec_in(DataSet::Liberty).flying && !b.kind.spec_in(DataSet::Liberty).flying {
                    let gap = a.pos.dist(b.pos) - a.kind.spec_in(DataSet::Liberty).radius - b.kind.spec_in(DataSet::Liberty).radius;
                    assert!(gap > -1e-3, "seed {seed}: {} and {} overlap by {}", a.kind, b.kind, -gap);
                }
            }
        }
    }
    let a = play(&s, EnvConfig::default(), 3, "focus-fire", "focus-fire");
    let b = play(&s, EnvConfig::default(), 3, "focus-fire", "focus-fire");
    assert_eq!(a.trajectory_hash(), b.trajectory_hash());
    let c = play(&s, EnvConfig::default(), 4, "focus-fire", "focus-fire");
    assert_ne!(a.trajectory_hash(), c.trajectory_hash());
    // A reset replays the draw: the environment's scenario is the seed's.
    let mut env = Env::new(Arc::clone(&s), EnvConfig::default(), 9);
    let first: Vec<UnitKind> = env.world().units().iter().map(|u| u.kind).collect();
    env.reset(10);
    env.reset(9);
    assert_eq!(env.world().units().iter().map(|u| u.kind).collect::<Vec<_>>(), first);
    assert_eq!(env.scenario().units, s.episode(9).units);
}

/// Bad distribution files are refused with the file and the field named.
#[test]
fn bad_distribution_files_name_the_field() {
    let base = |over: &[(&str, &str)]| {
        let mut fields = vec![
            ("n_units", "5"),
            ("n_enemies", "5"),
            ("unit_types", "[\"Marine\", \"Marauder\"]"),
            ("weights", "[0.5, 0.5]"),
            ("start_positions", "\"surrounded_and_reflect\""),
        ];
        for (k, v) in over {
            match fields.iter_mut().find(|(f, _)| f == k) {
                Some(f) => f.1 = v,
                None => fields.push((k, v)),
            }
        }
        file(&fields.iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>().join("\n"))
    };
    // (fields changed, the field named, what the reason says)
    type Case<'a> = (&'a [(&'a str, &'a str)], &'a str, &'a str);
    let cases: &[Case] = &[
        (&[("weights", "[0.5, 0.4]")], "generate.weights", "must sum to 1"),
        (&[("weights", "[1.5, -0.5]")], "generate.weights[0]", "probability in [0, 1]"),
        (&[("weights", "[1.0]")], "generate.weights", "one weight per unit type"),
        (&[("unit_types", "[\"Marine\", \"Dragoon\"]")], "generate.unit_types[1]", "Dragoon"),
        (&[("exception_unit_types", "[\"Zealot\"]")], "generate.exception_unit_types[0]", "not one of unit_types"),
        (&[("exception_unit_types", "[\"Marine\", \"Marauder\"]")], "generate.exception_unit_types", "no type"),
        (&[("p", "1.5")], "generate.p", "probability in [0, 1]"),
        (&[("p", "-0.1")], "generate.p", "probability in [0, 1]"),
        (&[("start_positions", "\"corners\"")], "generate.start_positions", "surrounded_and_reflect"),
        (&[("n_units", "400")], "generate.n_units", "more units than the map's start area holds"),
        (&[("n_enemies", "0")], "generate.n_enemies", "between 1 and"),
    ];
    for (over, field, says) in cases {
        match Scenario::from_toml("bad.toml", &base(over)) {
            Err(ScenarioError::Invalid { file, field: f, reason, value }) => {
                assert_eq!((file.as_str(), f.as_str()), ("bad.toml", *field), "{over:?}");
                assert!(reason.contains(says) || value.contains(says), "{over:?}: {reason} ({value})");
            }
            other => panic!("{over:?}: {other:?}"),
        }
    }
    // Units listed beside [generate] are refused too: the draw replaces them.
    let listed = base(&[]).replace("units = []", "units = [{ type = \"Marine\", team = 1, x = 4.0, y = 4.0 }]");
    let err = Scenario::from_toml("both.toml", &listed).expect_err("units and [generate]");
    assert!(err.to_string().contains("both.toml") && err.to_string().contains("units"), "{err}");
}
