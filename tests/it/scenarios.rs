//! The 21 built-in scenarios: they load, match the paper, and run to the end against every
//! opponent; user scenario files get errors that name file, field and value.

use crate::helpers::*;
use avacraft_engine::{BUILTIN, Env, EnvConfig, Mode, OpponentKind, Scenario, ScenarioError, Team, UnitKind, builtin, builtin_names};
use std::collections::BTreeMap;
use std::sync::Arc;

fn count(s: &Scenario, team: Team) -> BTreeMap<UnitKind, usize> {
    let mut m = BTreeMap::new();
    for (_, u) in s.team_units(team) {
        *m.entry(u.kind.base()).or_default() += 1;
    }
    m
}

#[test]
fn the_paper_has_21_scenarios_with_its_armies() {
    assert_eq!(BUILTIN.len(), 21);
    use UnitKind::*;
    type Army = &'static [(UnitKind, usize)];
    let want: &[(&str, Mode, Army, Army)] = &[
        ("2c_vs_64zg_vlm", Mode::Pve, &[(Colossus, 2)], &[(Zergling, 64)]),
        ("6r_vs_8z", Mode::Pve, &[(Reaper, 6)], &[(Zealot, 8)]),
        ("8m_vs_2pc1wp", Mode::Pve, &[(Marine, 8)], &[(WarpPrism, 1), (PhotonCannon, 2)]),
        (
            "pvz_ht",
            Mode::Pve,
            &[(Stalker, 12), (Archon, 1), (Sentry, 4), (HighTemplar, 6)],
            &[(Zergling, 64), (Baneling, 32), (Ultralisk, 3), (Queen, 3)],
        ),
        ("MMM_vs_MMM", Mode::Pvp, &[(Marine, 8), (Marauder, 3), (Medivac, 1)], &[(Marine, 8), (Marauder, 3), (Medivac, 1)]),
        ("7s_vs_11m1mv1st", Mode::Pvp, &[(Stalker, 7)], &[(Marine, 11), (Medivac, 1), (SiegeTank, 1)]),
    ];
    for (name, mode, a, b) in want {
        let s = builtin(name).expect("scenario");
        assert_eq!(s.mode, *mode, "{name}");
        assert_eq!(count(&s, Team::One), a.iter().copied().collect(), "{name} team 1");
        assert_eq!(count(&s, Team::Two), b.iter().copied().collect(), "{name} team 2");
        assert_eq!(s.time_limit_loops, 6720, "{name}: 300 s");
    }
    let pvp: Vec<&str> = builtin_names().filter(|n| builtin(n).is_ok_and(|s| s.mode == Mode::Pvp)).collect();
    assert_eq!(pvp.len(), 6, "{pvp:?}");
    // Modes from the source maps.
    let s = builtin("8m2st_vs_35zg4b").expect("scenario");
    assert!(s.units.iter().any(|u| u.kind == SiegeTankSieged));
    let s = builtin("8m_vs_2pc1wp").expect("scenario");
    assert!(s.units.iter().any(|u| u.kind == WarpPrismPhasing));
}

#[test]
fn every_scenario_runs_to_the_end_against_every_opponent() {
    for name in builtin_names() {
        let s = Arc::new(builtin(name).expect("scenario"));
        let opponents: Vec<Option<OpponentKind>> =
            if s.mode == Mode::Pve { OpponentKind::ALL.into_iter().map(Some).collect() } else { vec![None] };
        for (k, opp) in opponents.into_iter().enumerate() {
            let cfg = EnvConfig { opponent: opp, ..EnvConfig::default() };
            let env = play(&s, cfg, k as u64, "kite", "focus");
            assert!(env.done(), "{name} {opp:?}");
            assert!(env.world().tick() <= 6720, "{name}: ran past the limit");
            let o = env.outcome().expect("outcome");
            // Reaching the limit is a draw; otherwise one side can no longer fight.
            if env.world().tick() < 6720 {
                let fight = [env.world().can_fight(Team::One), env.world().can_fight(Team::Two)];
                assert!(!(fight[0] && fight[1]), "{name}: ended early with both sides able to fight ({o:?})");
            }
            assert!(env.world().units().iter().all(|u| u.pos.is_finite() && u.hp.is_finite()), "{name}: non-finite state");
        }
    }
}

#[test]
fn random_opponent_draws_each_style_from_the_seed() {
    let s = Arc::new(builtin("3m_vlm").expect("scenario"));
    let cfg = EnvConfig { opponent: Some(OpponentKind::Random), ..EnvConfig::default() };
    let mut seen = std::collections::BTreeSet::new();
    for seed in 0..40 {
        let env = Env::new(Arc::clone(&s), cfg.clone(), seed);
        let o = env.opponent().expect("drawn");
        assert_ne!(o, OpponentKind::Random);
        seen.insert(o.name());
        assert_eq!(Env::new(Arc::clone(&s), cfg.clone(), seed).opponent(), Some(o), "same seed, same draw");
    }
    assert_eq!(seen.len(), 4, "{seen:?}");
}

#[test]
fn time_limit_ends_in_a_draw() {
    // Two Marines that never meet: the episode ends at the scenario's own limit.
    let s = load(&arena_with("pvp", &[("Marine", 1, 2.0, 2.0), ("Marine", 2, 30.0, 30.0)], "time_limit_s = 10.0"));
    let mut env = Env::new(s, EnvConfig::default(), 0);
    let mut n = 0;
    while !env.step().done {
        n += 1;
    }
    assert_eq!(env.outcome(), Some(avacraft_engine::Outcome::Draw));
    assert_eq!(env.world().tick(), 224);
    assert_eq!(n + 1, 28);
}

fn err(text: &str) -> String {
    match Scenario::from_toml("my_map.toml", text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn malformed_files_name_file_field_and_value() {
    let ok = arena("pve", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 14.0, 16.0)]);
    assert!(Scenario::from_toml("ok.toml", &ok).is_ok());
    let cases: &[(&str, &str, &[&str])] = &[
        ("type = \"Marine\", team = 1", "type = \"Marin\", team = 1", &["my_map.toml", "units[0].type", "\"Marin\"", "unknown unit type"]),
        ("team = 2", "team = 3", &["my_map.toml", "units[1].team", "3"]),
        ("x = 14", "x = 40", &["units[1].x/y", "(40, 16)", "outside"]),
        ("mode = \"pve\"", "mode = \"coop\"", &["mode", "\"coop\""]),
        ("map_size = [32, 32]", "map_size = [32, 2]", &["map_size[1]", "2"]),
        ("name = \"test\"", "name = \"test\"\ncolour = 3", &["my_map.toml", "unknown field", "colour"]),
        ("name = \"test\"", "name = \"test\"\ntime_limit_s = -5", &["time_limit_s", "-5"]),
        ("start = { kind = \"none\" }", "start = { kind = \"attack_move\", x = 99, y = 1 }", &["opponent.start", "(99, 1)"]),
        ("start = { kind = \"none\" }", "policy = \"berserk\"", &["opponent.policy", "\"berserk\""]),
        ("name = \"test\"", "name = \"test\"\nupgrades = [{ team = 1, name = \"Warp\" }]", &["upgrades[0].name", "\"Warp\""]),
        ("units = [", "units = [[", &["my_map.toml"]),
    ];
    for (from, to, needles) in cases {
        let text = ok.replacen(from, to, 1);
        assert_ne!(text, ok, "case {to} did not apply");
        let e = err(&text);
        for n in *needles {
            assert!(e.contains(n), "error for `{to}` lacks `{n}`: {e}");
        }
    }
    // One team only.
    let e = err(&arena("pve", &[("Marine", 1, 10.0, 16.0)]));
    assert!(e.contains("team 2 has no units"), "{e}");
}

#[test]
fn terrain_grid_errors() {
    let base = arena("pve", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 14.0, 16.0)]);
    let row = |c: char| format!("  \"{}\",\n", c.to_string().repeat(32));
    let rows = |n: usize, c: char| (0..n).map(|_| row(c)).collect::<String>();
    let good = format!("{base}[terrain]\nlegend = {{ \"1\" = 1.0 }}\nrows = [\n{}]\n", rows(32, '1'));
    assert!(Scenario::from_toml("t.toml", &good).is_ok());
    let short = format!("{base}[terrain]\nlegend = {{ \"1\" = 1.0 }}\nrows = [\n{}]\n", rows(31, '1'));
    assert!(err(&short).contains("terrain.rows"));
    let odd = good.replacen(&"1".repeat(32), &format!("{}x", "1".repeat(31)), 1);
    let e = err(&odd);
    assert!(e.contains("terrain.rows[0][31]") && e.contains("'x'"), "{e}");
    let void = format!("{base}[terrain]\nlegend = {{ \"1\" = 1.0 }}\nrows = [\n{}]\n", rows(32, '.'));
    assert!(err(&void).contains("no ground"), "a ground unit on a void cell is refused");
    let bad_key = good.replace("\"1\" = 1.0", "\"1\" = 1.0, \"ab\" = 2.0");
    assert!(err(&bad_key).contains("single characters"));
}

#[test]
fn load_by_name_or_path() {
    assert!(Scenario::load("3m_vlm").is_ok());
    assert!(matches!(Scenario::load("no_such_map"), Err(ScenarioError::Unknown(_))));
    let e = Scenario::load("/nonexistent/dir/x.toml").expect_err("missing file");
    assert!(e.to_string().contains("/nonexistent/dir/x.toml"), "{e}");
    let dir = std::env::temp_dir().join(format!("avacraft-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let p = dir.join("mine.toml");
    std::fs::write(&p, arena("pvp", &[("Stalker", 1, 10.0, 16.0), ("Zealot", 2, 14.0, 16.0)])).expect("write");
    let s = Scenario::load(p.to_str().expect("utf8")).expect("load");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(s.mode, Mode::Pvp);
}

#[test]
fn built_in_files_are_what_the_generator_writes() {
    // Every built-in file parses, and re-serialising its units reproduces the count per type.
    for (name, text) in BUILTIN {
        let raw: avacraft_engine::RawScenario = toml::from_str(text).expect("raw");
        assert_eq!(raw.name, *name);
        let s = builtin(name).expect("valid");
        assert_eq!(raw.units.len(), s.units.len());
        assert!(s.terrain.census().1 > 0, "{name}: no ground");
    }
}
