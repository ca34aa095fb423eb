//! Helpers shared by the MARL test files.
// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, Outcome, Scenario, Team};
use avacraft_marl::{Config, MarlAgent, Policy};
use std::sync::Arc;

/// What one episode of a policy played as an engine agent gave.
#[derive(Debug)]
pub struct Played {
    /// Team 1's return.
    pub ret: f32,
    /// Team 1's orders the engine refused.
    pub refused: u32,
    pub outcome: Option<Outcome>,
}

/// Plays one episode of `scenario` (seed `seed`, `cfg`'s environment settings) with
/// `policy` as team 1's engine agent, through the same `Controllers` path as `episode`.
pub fn play(policy: &Arc<Policy>, scenario: &Arc<Scenario>, cfg: &Config, seed: u64) -> Played {
    let policy = Arc::clone(policy);
    let mut controllers = Controllers::new(
        scenario,
        vec![AgentTeam::new(Team::One, Grouping::Team, move || Box::new(MarlAgent::new(Arc::clone(&policy), "marl")))],
    );
    let mut env = Env::new(Arc::clone(scenario), cfg.env_config().expect("a validated config"), seed);
    controllers.reset(&env);
    let mut ret = 0.0;
    while !env.done() {
        controllers.act(&mut env);
        ret += env.step().reward[0];
    }
    Played { ret, refused: env.refused()[0], outcome: env.outcome() }
}

/// Reads a finished run's TensorBoard event files twice, with this crate's reader and with
/// the `tensorboard` package's (TensorBoard's own loader, run by `python3`), and checks both
/// against the run's `log.csv`: one event per test round, at its step, with the round's
/// greedy win rate and return, and the tags `expect` names.
pub fn check_tensorboard(dir: &std::path::Path, expect: &[&str]) {
    use avacraft_marl::tensorboard::read_events;
    let log = std::fs::read_to_string(dir.join("log.csv")).expect("log.csv");
    let rows: Vec<Vec<f64>> = log.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect()).collect();
    let mut ours: Vec<(i64, String, f32)> = Vec::new();
    let mut files = 0;
    for entry in std::fs::read_dir(dir).expect("run folder") {
        let path = entry.expect("entry").path();
        if !path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("events.out.tfevents.")) {
            continue;
        }
        files += 1;
        let events = read_events(&std::fs::read(&path).expect("event file")).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(events[0].file_version.as_deref(), Some(avacraft_marl::tensorboard::FILE_VERSION));
        for e in &events[1..] {
            for v in &e.summary.as_ref().expect("a summary").value {
                ours.push((e.step, v.tag.clone(), v.simple_value.expect("a scalar")));
            }
        }
    }
    assert_eq!(files, 1, "one event file in {}", dir.display());
    for tag in expect {
        let n = ours.iter().filter(|(_, t, _)| t == tag).count();
        assert_eq!(n, rows.len(), "tag {tag}: {n} events for {} test rounds", rows.len());
    }
    for row in &rows {
        let at = |tag: &str| ours.iter().find(|(s, t, _)| *s == row[0] as i64 && t == tag).map(|x| f64::from(x.2));
        // log.csv: t_env,..., test_win_rate (8), test_return (9), to 4 decimals.
        let (w, r) = (at("test/win_rate").expect("test/win_rate"), at("test/return").expect("test/return"));
        assert!((w - row[8]).abs() < 1e-4 && (r - row[9]).abs() < 1e-3, "step {}: events {w} {r}, log {} {}", row[0], row[8], row[9]);
    }
    let py = r#"
import json, sys
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
acc = EventAccumulator(sys.argv[1], size_guidance={"scalars": 0})
acc.Reload()
print(json.dumps({t: [[e.step, e.value] for e in acc.Scalars(t)] for t in acc.Tags()["scalars"]}))
"#;
    let out = std::process::Command::new("python3").args(["-c", py]).arg(dir).output().expect("python3 runs");
    assert!(
        out.status.success(),
        "TensorBoard's reader failed (CI installs it: pip install tensorboard): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let theirs: std::collections::BTreeMap<String, Vec<(i64, f64)>> = serde_json::from_slice(&out.stdout).expect("the reader's JSON");
    assert_eq!(theirs.len(), ours.iter().map(|x| &x.1).collect::<std::collections::BTreeSet<_>>().len(), "the same tags");
    for (step, tag, v) in &ours {
        let found = theirs.get(tag).and_then(|s| s.iter().find(|(st, _)| st == step));
        assert!(
            found.is_some_and(|(_, x)| (x - f64::from(*v)).abs() <= 1e-6 * x.abs().max(1.0)),
            "{tag} at {step}: ours {v}, TensorBoard's {found:?}"
        );
    }
}

/// Checks that the saved `agent` plays each of `seeds`' episodes as an engine agent with the
/// return the trainer's greedy test of `nets` gave it: the checkpoint plays as it was tested.
pub fn plays_as_tested(
    nets: &avacraft_marl::Nets,
    agent: &MarlAgent,
    scenario: &Arc<Scenario>,
    cfg: &Config,
    seeds: std::ops::RangeInclusive<u64>,
    what: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    for seed in seeds {
        let r = avacraft_marl::train::test(nets, cfg, scenario, &[seed], 1)?;
        let p = play(agent.policy(), scenario, cfg, seed);
        assert!((f64::from(p.ret) - r.mean_return).abs() < 1e-4, "{what} seed {seed}: agent {}, trainer {}", p.ret, r.mean_return);
    }
    Ok(())
}
