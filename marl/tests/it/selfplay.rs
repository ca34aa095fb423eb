//! Self-play: team 2 plays snapshots of the learner, drawn from a pool. A run stays a
//! function of its config and seed, the pool survives a resume, snapshots are copies, and
//! fixed opponents' win rates are logged.

use avacraft_engine::Scenario;
use avacraft_marl::selfplay::Pool;
use avacraft_marl::{Config, Nets, Policy, RunOptions, Shape, train};
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

/// Three Marines a side, agents on both: small enough to train in a test.
fn arena() -> Result<Arc<Scenario>, Box<dyn std::error::Error>> {
    let units: Vec<String> = (0..3)
        .flat_map(|i| {
            let y = 14.0 + i as f32;
            [
                format!("{{ type = \"Marine\", team = 1, x = 10.0, y = {y} }}"),
                format!("{{ type = \"Marine\", team = 2, x = 20.0, y = {y} }}"),
            ]
        })
        .collect();
    let text = format!("name = \"marines_pvp\"\nmode = \"pvp\"\nmap_size = [32, 32]\nunits = [{}]\n", units.join(", "));
    Ok(Arc::new(Scenario::from_toml("marines_pvp.toml", &text)?))
}

fn config(extra: &[&str]) -> Result<Config, avacraft_marl::Error> {
    let mut o: Vec<String> = [
        "t_max=1600",
        "envs=8",
        "test_interval=800",
        "test_nepisode=4",
        "episode_limit=30",
        "batch_size=8",
        "use_rnn=false",
        "opponent=\"self\"",
        "self_play_every=2",
        "self_play_pool=3",
    ]
    .map(String::from)
    .to_vec();
    o.extend(extra.iter().map(|s| s.to_string()));
    Config::for_algo("qmix", &o)
}

#[test]
fn self_play_runs_are_a_function_of_config_and_seed() -> R {
    let scenario = arena()?;
    let cfg = config(&[])?;
    let run = |threads: usize| -> Result<_, Box<dyn std::error::Error>> {
        let dir = std::env::temp_dir().join(format!("avacraft-selfplay-{}-{threads}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 5, threads, out: Some(dir.clone()) };
        let (trained, summary) = train(&cfg, &opts, &mut |_| {})?;
        Ok((trained.nets().flat()?, summary, dir))
    };
    let (w1, s1, dir1) = run(1)?;
    let (w2, s2, dir2) = run(2)?;
    assert!(s1.updates >= 4, "{s1:?}");
    assert!(w1 == w2, "2 threads changed the weights");
    assert_eq!((s1.episodes, s1.updates, &s1.tests), (s2.episodes, s2.updates, &s2.tests));
    // Snapshots were taken as the learner went (the first at update 0), and written.
    // Written snapshots a resume no longer needs are deleted (the first is kept).
    let mut snaps: Vec<String> = std::fs::read_dir(dir1.join("selfplay"))?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<Result<_, _>>()?;
    snaps.sort();
    assert!(snaps.len() >= 3 && snaps[0] == "u0000000000", "{snaps:?}");
    // The log carries the fixed opponents' win rates, the default pair under self-play.
    let log = std::fs::read_to_string(dir1.join("log.csv"))?;
    let header: Vec<&str> = log.lines().next().unwrap_or_default().split(',').collect();
    assert_eq!(
        header[header.len() - 4..],
        ["test_win_rate_vs_attack-move", "test_return_vs_attack-move", "test_win_rate_vs_focus-fire", "test_return_vs_focus-fire"]
    );
    for row in log.lines().skip(1) {
        let cols: Vec<f64> = row.split(',').map(|c| c.parse().unwrap_or(f64::NAN)).collect();
        assert_eq!(cols.len(), header.len(), "{row}");
        let n = cols.len();
        assert!([cols[n - 4], cols[n - 2]].iter().all(|w| (0.0..=1.0).contains(w)), "{row}");
        assert!([cols[n - 3], cols[n - 1]].iter().all(|r| r.is_finite() && *r >= 0.0), "{row}");
    }
    for d in [dir1, dir2] {
        let _ = std::fs::remove_dir_all(d);
    }
    Ok(())
}

#[test]
fn the_pool_keeps_copies_draws_uniformly_and_restores() -> R {
    let scenario = arena()?;
    let cfg = config(&[])?;
    let probe = avacraft_engine::VecEnv::new(Arc::clone(&scenario), cfg.env_config()?, &[0], 1)?;
    let shape = Shape::of(&probe);
    let dir = std::env::temp_dir().join(format!("avacraft-pool-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let pool = Pool::new(&cfg, shape, &scenario.name, Some(&dir));
    let nets: Vec<Nets> = (0..4u64).map(|s| Nets::new(&cfg, &shape, s)).collect::<Result<_, _>>()?;
    // Due every 2 updates: 0 is taken, 1 is not, 2 is; the pool keeps the last 3.
    for (u, n) in [(0, &nets[0]), (1, &nets[1]), (2, &nets[1]), (4, &nets[2]), (6, &nets[3])] {
        pool.maybe_snapshot(n, u)?;
    }
    assert_eq!(pool.updates(), [2, 4, 6]);
    // A snapshot is a copy: the network it came from changing later does not reach it.
    // (The agent network's weights: a policy carries no mixer of its source's.)
    let agent = |n: &Nets| n.agent_params.flat(n.agent_params.vars().count());
    let before = agent(&nets[1])?;
    let snap = Policy::of(&nets[1], &cfg, shape, "x")?;
    nets[1].agent_params.load_map(&nets[3].agent_params.to_map(), "test")?;
    assert_ne!(agent(&nets[1])?, before, "the source network changed");
    assert_eq!(agent(&snap.nets)?, before, "the snapshot kept the weights it was taken with");
    // Draws are uniform over the pool and a function of the seed.
    let mut seen: Vec<(Vec<f32>, u32)> = Vec::new();
    for seed in 0..300u64 {
        let w = pool.draw(seed).ok_or("empty pool")?.nets.flat()?;
        match seen.iter_mut().find(|(x, _)| *x == w) {
            Some(e) => e.1 += 1,
            None => seen.push((w, 1)),
        }
    }
    let counts: Vec<u32> = seen.iter().map(|(_, c)| *c).collect();
    assert_eq!(counts.len(), 3, "every snapshot is drawn");
    assert!(counts.iter().all(|c| (60..=140).contains(c)), "300 draws over 3 snapshots: {counts:?}");
    assert_eq!(pool.draw(17).ok_or("empty")?.nets.flat()?, pool.draw(17).ok_or("empty")?.nets.flat()?);
    // A resumed run's pool: what was written up to its update count, the newest 3.
    let again = Pool::new(&cfg, shape, &scenario.name, Some(&dir));
    again.restore(5)?;
    assert_eq!(again.updates(), [0, 2, 4]);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn bad_opponents_are_refused_by_field() {
    for (set, field) in [
        ("opponent=\"nobody\"", "opponent"),
        ("opponent=\"scripted:nobody\"", "opponent"),
        ("test_opponents=[\"self\"]", "test_opponents[0]"),
        ("test_opponents=[\"focus-fire\", \"ghost\"]", "test_opponents[1]"),
        ("self_play_pool=0", "self_play_pool"),
    ] {
        let err = config(&[set]).expect_err(set).to_string();
        assert!(err.contains(field), "{set}: {err}");
    }
    assert!(config(&["opponent=\"scripted:focus-fire\"", "test_opponents=[\"kite\"]"]).is_ok());
}

/// A league: scripted agents join the snapshots. Team 2 plays a script in every episode
/// before the first snapshot and in about `self_play_script_share` of them after, drawn by the
/// episode's seed; names the engine does not know are refused with the config.
#[test]
fn a_league_mixes_scripted_agents_with_snapshots() -> R {
    use avacraft_marl::selfplay::Pick;
    let scenario = arena()?;
    let cfg = config(&["self_play_scripts=[\"kite\", \"attack-move\"]", "self_play_script_share=0.25"])?;
    let probe = avacraft_engine::VecEnv::new(Arc::clone(&scenario), cfg.env_config()?, &[0], 1)?;
    let shape = Shape::of(&probe);
    let pool = Pool::new(&cfg, shape, &scenario.name, None);
    let scripts = |pool: &Pool| (0..400u64).filter(|s| matches!(pool.pick(*s), Some(Pick::Script(_)))).count();
    assert_eq!(scripts(&pool), 400, "no snapshot yet: every episode plays a script");
    pool.maybe_snapshot(&Nets::new(&cfg, &shape, 1)?, 2)?;
    let n = scripts(&pool);
    assert!((60..=140).contains(&n), "{n} of 400 episodes drew a script at a share of 0.25");
    let names: std::collections::BTreeSet<String> = (0..400u64)
        .filter_map(|s| match pool.pick(s) {
            Some(Pick::Script(n)) => Some(n),
            _ => None,
        })
        .collect();
    assert_eq!(names.into_iter().collect::<Vec<_>>(), ["attack-move", "kite"]);
    let again: Vec<bool> = (0..50u64).map(|s| matches!(pool.pick(s), Some(Pick::Script(_)))).collect();
    assert_eq!(
        again,
        (0..50u64).map(|s| matches!(pool.pick(s), Some(Pick::Script(_)))).collect::<Vec<_>>(),
        "a pick is a function of the seed"
    );
    let e = config(&["self_play_scripts=[\"kyte\"]"]).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("self_play_scripts[0]") && e.contains("kyte"), "{e}");
    Ok(())
}

/// A self-play run goes on under other settings (a plan's `from`): the game's sizes are
/// checked without a snapshot pool, and the continuation trains on from the copy.
#[test]
fn a_self_play_run_goes_on_under_other_settings() -> R {
    let scenario = arena()?;
    let cfg = config(&["t_max=800"])?;
    let dir = std::env::temp_dir().join(format!("avacraft-selfplay-more-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 5, threads: 1, out: Some(dir.clone()) };
    train(&cfg, &opts, &mut |_| {})?;
    let more = cfg.overridden(&["lr=0.0001".into(), "t_max=1600".into()])?;
    avacraft_marl::continuation::continue_as(&dir, &more, &scenario)?;
    let (saved, state) = avacraft_marl::resume::load(&dir)?;
    assert_eq!(saved, more);
    let (_, summary) = avacraft_marl::train_from(&more, &opts, Some(state), &mut |_| {})?;
    assert_eq!(summary.t_env, 1600);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
