//! The evaluation's episodes in marl-eval's raw-data JSON (InstaDeep's aggregation and
//! plotting tools for cooperative MARL, used by Mava and BenchMARL users):
//! `{environment: {task: {algorithm: {run_k: {step_1: {step_count, metric: [per episode]},
//! absolute_metrics: {metric: [per episode]}}}}}}`.
//!
//! Here the environment is `avacraft`, a task is a scenario, an algorithm is a cell's agent
//! with its opponent (`agent vs opponent`, as the report's rows), and an evaluation is one
//! run of one step: the policy evaluated as it is (`step_count` 0), each metric listed per
//! episode in seed order. Failed episodes are left out.

use crate::results::Loaded;
use serde_json::{Map, Value, json};
use std::collections::BTreeMap;

/// The metrics, per episode: the win (1 or 0, so marl-eval's mean is the win rate),
/// team 1's damage dealt, kills and units left.
pub const MARL_EVAL_METRICS: [&str; 4] = ["win_rate", "damage_dealt", "kills", "units_left"];

pub fn marl_eval_json(loaded: &Loaded) -> Value {
    // task -> algorithm -> metric -> values, episodes in seed order (`done` is keyed so).
    let mut tasks: BTreeMap<String, BTreeMap<String, BTreeMap<&str, Vec<f64>>>> = BTreeMap::new();
    for ((cell, _), r) in &loaded.done {
        let Some(result) = r.result.filter(|_| r.ok()) else { continue };
        let algo = format!("{} vs {}", cell.agent, cell.against);
        let m = tasks.entry(cell.scenario.clone()).or_default().entry(algo).or_default();
        let won = if result == avacraft_engine::Outcome::Win { 1.0 } else { 0.0 };
        for (name, v) in MARL_EVAL_METRICS.iter().zip([won, r.damage_dealt[0], f64::from(r.kills[0]), f64::from(r.units_left[0])]) {
            m.entry(name).or_default().push(v);
        }
    }
    let mut env = Map::new();
    for (task, algos) in tasks {
        let mut t = Map::new();
        for (algo, metrics) in algos {
            let values: Map<String, Value> = metrics.into_iter().map(|(k, v)| (k.to_owned(), json!(v))).collect();
            let mut step = values.clone();
            step.insert("step_count".into(), json!(0));
            t.insert(algo, json!({ "run_1": { "step_1": step, "absolute_metrics": values } }));
        }
        env.insert(task, Value::Object(t));
    }
    json!({ "avacraft": env })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CellKey, EpisodeResult};
    use avacraft_engine::Outcome;

    fn ep(scenario: &str, agent: &str, seed: u64, result: Option<Outcome>) -> EpisodeResult {
        EpisodeResult {
            cell: CellKey { scenario: scenario.into(), agent: agent.into(), against: "opponent:default".into() },
            seed,
            result,
            error: result.is_none().then(|| "endpoint down".into()),
            steps: 10,
            game_seconds: 3.0,
            damage_dealt: [seed as f64, 0.0],
            kills: [2, 1],
            units_left: [1, 0],
            refused_actions: [0, 0],
            trajectory_hash: format!("{seed:016x}"),
            model: None,
            model2: None,
        }
    }

    #[test]
    fn episodes_land_per_task_and_algorithm_in_seed_order() {
        let mut loaded = Loaded::default();
        for r in [
            ep("3m", "kite", 2, Some(Outcome::Loss)),
            ep("3m", "kite", 1, Some(Outcome::Win)),
            ep("3m", "kite", 3, None),
            ep("2s3z", "ava", 1, Some(Outcome::Draw)),
        ] {
            loaded.done.insert((r.cell.clone(), r.seed), r);
        }
        let v = marl_eval_json(&loaded);
        let run = &v["avacraft"]["3m"]["kite vs opponent:default"]["run_1"];
        assert_eq!(run["step_1"]["step_count"], 0);
        assert_eq!(run["step_1"]["win_rate"], json!([1.0, 0.0]), "seed 1 then 2, the failed one left out");
        assert_eq!(run["absolute_metrics"]["damage_dealt"], json!([1.0, 2.0]));
        for m in MARL_EVAL_METRICS {
            assert_eq!(run["step_1"][m].as_array().map(Vec::len), Some(2), "{m}");
        }
        assert_eq!(v["avacraft"]["2s3z"]["ava vs opponent:default"]["run_1"]["absolute_metrics"]["win_rate"], json!([0.0]));
        assert_eq!(v["avacraft"].as_object().map(|o| o.len()), Some(2));
    }
}
