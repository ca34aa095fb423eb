//! The evaluation's episodes in marl-eval's raw-data JSON (InstaDeep's aggregation and
//! plotting tools for cooperative MARL, used by Mava and BenchMARL users):
//! `{environment: {task: {algorithm: {run_k: {step_1: {step_count, metric: [per episode]},
//! absolute_metrics: {metric: [per episode]}}}}}}`.
//!
//! marl-eval aggregates an environment's algorithms over its tasks, so it needs every
//! algorithm in every task of an environment (its `DiagnoseData` check; without that its
//! pipeline stops with a KeyError). Not every agent plays every scenario (the trained
//! baselines cover some), so tasks are grouped into environments by their set of
//! algorithms: `avacraft-pve`, `avacraft-pve-2`, ... and `avacraft-pvp`, ..., the group with
//! the most tasks first. A task is a scenario; an algorithm is a cell's agent (PvE, against
//! the scenario's opponent) or `agent vs opponent` (PvP); an evaluation is one run of one
//! step: the policy evaluated as it is (`step_count` 0), each metric listed per episode in
//! seed order. Failed episodes are left out.

use crate::results::Loaded;
use serde_json::{Map, Value, json};
use std::collections::BTreeMap;

/// The metrics, per episode: the win (1 or 0, so marl-eval's mean is the win rate),
/// team 1's damage dealt, kills and units left.
pub const MARL_EVAL_METRICS: [&str; 4] = ["win_rate", "damage_dealt", "kills", "units_left"];

/// What a PvE cell's opponent is called (the scenario's own).
const DEFAULT_OPPONENT: &str = "opponent:default";

type Metrics = BTreeMap<&'static str, Vec<f64>>;

pub fn marl_eval_json(loaded: &Loaded) -> Value {
    // task -> algorithm -> metric -> values, episodes in seed order (`done` is keyed so).
    let mut tasks: BTreeMap<String, BTreeMap<String, Metrics>> = BTreeMap::new();
    let mut pvp: BTreeMap<String, bool> = BTreeMap::new();
    for ((cell, _), r) in &loaded.done {
        let Some(result) = r.result.filter(|_| r.ok()) else { continue };
        let vs = cell.against != DEFAULT_OPPONENT;
        *pvp.entry(cell.scenario.clone()).or_default() |= vs;
        // marl-eval refuses commas in algorithm names (it splits on them).
        let algo = if vs { format!("{} vs {}", cell.agent, cell.against) } else { cell.agent.clone() }.replace(',', ";");
        let m = tasks.entry(cell.scenario.clone()).or_default().entry(algo).or_default();
        let won = if result == avacraft_engine::Outcome::Win { 1.0 } else { 0.0 };
        for (name, v) in MARL_EVAL_METRICS.iter().zip([won, r.damage_dealt[0], f64::from(r.kills[0]), f64::from(r.units_left[0])]) {
            m.entry(name).or_default().push(v);
        }
    }
    // (PvP?, algorithm set) -> its tasks.
    let mut groups: BTreeMap<(bool, Vec<String>), Vec<String>> = BTreeMap::new();
    for (task, algos) in &tasks {
        groups.entry((pvp[task], algos.keys().cloned().collect())).or_default().push(task.clone());
    }
    let mut ordered: Vec<_> = groups.into_iter().collect();
    ordered.sort_by(|((pa, _), ta), ((pb, _), tb)| pa.cmp(pb).then(tb.len().cmp(&ta.len())).then(ta.cmp(tb)));
    let mut out = Map::new();
    let mut count = [0usize; 2];
    for ((vs, _), names) in ordered {
        let k = &mut count[usize::from(vs)];
        *k += 1;
        let mode = if vs { "pvp" } else { "pve" };
        let env_name = if *k == 1 { format!("avacraft-{mode}") } else { format!("avacraft-{mode}-{k}") };
        let mut env = Map::new();
        for task in names {
            let mut t = Map::new();
            for (algo, metrics) in tasks.remove(&task).unwrap_or_default() {
                let values: Map<String, Value> = metrics.into_iter().map(|(k, v)| (k.to_owned(), json!(v))).collect();
                let mut step = values.clone();
                step.insert("step_count".into(), json!(0));
                t.insert(algo, json!({ "run_1": { "step_1": step, "absolute_metrics": values } }));
            }
            env.insert(task, Value::Object(t));
        }
        out.insert(env_name, Value::Object(env));
    }
    Value::Object(out)
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
            ep("3m_vlm", "kite", 2, Some(Outcome::Loss)),
            ep("3m_vlm", "kite", 1, Some(Outcome::Win)),
            ep("3m_vlm", "kite", 3, None),
            ep("2s3z_vlm", "kite", 1, Some(Outcome::Draw)),
        ] {
            loaded.done.insert((r.cell.clone(), r.seed), r);
        }
        let v = marl_eval_json(&loaded);
        let run = &v["avacraft-pve"]["3m_vlm"]["kite"]["run_1"];
        assert_eq!(run["step_1"]["step_count"], 0);
        assert_eq!(run["step_1"]["win_rate"], json!([1.0, 0.0]), "seed 1 then 2, the failed one left out");
        assert_eq!(run["absolute_metrics"]["damage_dealt"], json!([1.0, 2.0]));
        for m in MARL_EVAL_METRICS {
            assert_eq!(run["step_1"][m].as_array().map(Vec::len), Some(2), "{m}");
        }
        assert_eq!(v["avacraft-pve"]["2s3z_vlm"]["kite"]["run_1"]["absolute_metrics"]["win_rate"], json!([0.0]));
        assert_eq!(v["avacraft-pve"].as_object().map(|o| o.len()), Some(2));
    }

    /// marl-eval's `DiagnoseData` rule: within an environment, every task has the same
    /// algorithms (and every algorithm one run of one step with the same metrics).
    #[test]
    fn every_environment_has_the_same_algorithms_in_every_task() {
        let mut loaded = Loaded::default();
        let mut add = |scenario: &str, agent: &str, against: &str| {
            let mut r = ep(scenario, agent, 1, Some(Outcome::Win));
            r.cell.against = against.into();
            loaded.done.insert((r.cell.clone(), 1), r);
        };
        for s in ["3m_vlm", "2s3z_vlm", "pvz_ht", "MMM_vs_MMM"] {
            let against = if s == "MMM_vs_MMM" { "focus-fire" } else { DEFAULT_OPPONENT };
            add(s, "kite", against);
            add(s, "focus,fire", against);
        }
        // The trained baselines cover two of the PvE scenarios.
        add("3m_vlm", "qmix", DEFAULT_OPPONENT);
        add("2s3z_vlm", "qmix", DEFAULT_OPPONENT);
        let v = marl_eval_json(&loaded);
        let envs = v.as_object().expect("environments");
        let names: Vec<&str> = envs.keys().map(String::as_str).collect();
        assert_eq!(names, ["avacraft-pve", "avacraft-pve-2", "avacraft-pvp"]);
        let tasks = |e: &str| envs[e].as_object().map(|o| o.keys().cloned().collect::<Vec<_>>()).unwrap_or_default();
        assert_eq!(tasks("avacraft-pve"), ["2s3z_vlm", "3m_vlm"], "the largest group first");
        assert_eq!(tasks("avacraft-pve-2"), ["pvz_ht"]);
        assert!(envs["avacraft-pvp"]["MMM_vs_MMM"]["kite vs focus-fire"].is_object());
        for (name, env) in envs {
            let sets: Vec<Vec<&String>> =
                env.as_object().expect("tasks").values().map(|t| t.as_object().expect("algos").keys().collect()).collect();
            assert!(sets.windows(2).all(|w| w[0] == w[1]), "{name}: {sets:?}");
            assert!(sets.iter().flatten().all(|a| !a.contains(',')), "{name}: a comma in {sets:?}");
        }
    }
}
