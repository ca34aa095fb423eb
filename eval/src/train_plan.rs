//! Training plans (`avacraft train --plan FILE`): scenarios x algorithms x seeds x
//! observation mode x budget, expanded into jobs in a fixed order so a plan resumes after a
//! kill (each run goes on from its last test round) and splits into shards (`--shard i/n`,
//! as evaluations do) for a cluster's array jobs. Each job is one ordinary training run in
//! its own folder, `<out>/<scenario>/<run>-s<seed>`.
//!
//! ```toml
//! name = "baselines"
//! out = "../../runs/baselines"   # relative to this file
//! steps = 1000000                # each run's budget (the config's t_max)
//! seeds = [1]
//!
//! [[runs]]
//! name = "qmix"                  # the run's folder prefix
//! algo = "qmix"
//! scenarios = ["all"]            # names, or "all", "pve", "pvp" (the paper's), "smac" (SMAC's 23)
//! set = ["use_rnn=false"]        # config overrides, as `train --set`
//! opponent = "focus-fire"        # who plays team 2 of the PvP scenarios
//! ```
//!
//! A run with `from = "<name>"` goes on from an earlier run's last state (a curriculum: the
//! same network, trained further with other settings): once that run has reached its budget,
//! its folder is copied into this run's and training resumes there with the earlier run's
//! settings, this run's `set` on top, to this run's (larger) budget. Its log, test history and
//! `best/` pick therefore cover both stages.
//!
//! Jobs run in the order of the `[[runs]]` tables, then scenarios, then seeds; with
//! `order = "scenarios"` at the top, scenario by scenario instead (every run of the first
//! scenario, then of the next), so a plan cut short leaves complete scenarios.

use crate::plan::Shard;
use avacraft_engine::{Mode, Scenario, builtin_names, smac_names};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Why a training plan was refused.
#[derive(Debug, thiserror::Error)]
pub enum TrainPlanError {
    #[error("{file}: cannot read")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: field `{field}` = {value}: {reason}")]
    Invalid { file: String, field: String, value: String, reason: String },
    #[error("{file}: field `{field}`")]
    Config {
        file: String,
        field: String,
        #[source]
        source: Box<avacraft_marl::Error>,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlan {
    name: Option<String>,
    out: String,
    steps: Option<u64>,
    #[serde(default)]
    seeds: Vec<u64>,
    order: Option<String>,
    #[serde(default)]
    runs: Vec<RawRun>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRun {
    name: String,
    algo: String,
    obs: Option<String>,
    scenarios: Vec<String>,
    seeds: Option<Vec<u64>>,
    steps: Option<u64>,
    #[serde(default)]
    set: Vec<String>,
    opponent: Option<String>,
    from: Option<String>,
}

/// The run a plan's run goes on from (its `from`).
#[derive(Clone, Debug, PartialEq)]
pub struct Source {
    /// The earlier job's id (`<scenario>/<run>-s<seed>`).
    pub id: String,
    pub dir: PathBuf,
    /// Its budget: it must have reached it before this run starts.
    pub steps: u64,
}

/// One training run of a plan.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainJob {
    /// `<scenario>/<run>-s<seed>`: unique in the plan, and the folder under `out`.
    pub id: String,
    pub run: String,
    pub scenario: String,
    pub algo: String,
    pub seed: u64,
    /// The config overrides, budget (`t_max`), observation mode and opponent included.
    pub overrides: Vec<String>,
    /// The run's budget of environment steps (its config's `t_max`).
    pub steps: u64,
    pub dir: PathBuf,
    /// The earlier run this one goes on from (`from`).
    pub from: Option<Source>,
}

/// A validated training plan.
#[derive(Clone, Debug)]
pub struct TrainPlan {
    pub file: String,
    pub name: String,
    pub out: PathBuf,
    pub jobs: Vec<TrainJob>,
}

impl TrainPlan {
    /// The jobs `shard` takes (all without one), in the plan's order. A run that goes on from
    /// another is in that run's shard, so it starts in the same process once that one ends.
    pub fn shard(&self, shard: Option<Shard>) -> Vec<&TrainJob> {
        let root = |mut i: usize| {
            while let Some(k) = self.jobs[i].from.as_ref().and_then(|s| self.jobs.iter().position(|j| j.id == s.id)) {
                i = k;
            }
            i
        };
        self.jobs.iter().enumerate().filter(|(i, _)| shard.is_none_or(|s| s.takes(root(*i)))).map(|(_, j)| j).collect()
    }
}

/// Reads and validates a training plan; `out` is resolved against the plan's folder.
pub fn load_train_plan(path: &Path) -> Result<TrainPlan, TrainPlanError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| TrainPlanError::Io { file: file.clone(), source })?;
    parse_train_plan(&file, &text, path.parent())
}

/// [`load_train_plan`] on text (`base`: the folder `out` is relative to).
pub fn parse_train_plan(file: &str, text: &str, base: Option<&Path>) -> Result<TrainPlan, TrainPlanError> {
    let raw: RawPlan = toml::from_str(text).map_err(|e| TrainPlanError::Syntax { file: file.to_owned(), message: e.to_string() })?;
    let err = |field: String, value: String, reason: &str| TrainPlanError::Invalid {
        file: file.to_owned(),
        field,
        value,
        reason: reason.to_owned(),
    };
    if raw.out.trim().is_empty() {
        return Err(err("out".into(), "\"\"".into(), "the folder the runs go in"));
    }
    let out = match base {
        Some(b) if Path::new(&raw.out).is_relative() => b.join(&raw.out),
        _ => PathBuf::from(&raw.out),
    };
    if raw.runs.is_empty() {
        return Err(err("runs".into(), "[]".into(), "at least one [[runs]] table is needed"));
    }
    check_seeds("seeds", &raw.seeds, &err)?;
    let mut jobs: Vec<TrainJob> = Vec::new();
    for (i, r) in raw.runs.iter().enumerate() {
        let f = |name: &str| format!("runs[{i}].{name}");
        if r.name.is_empty() || !r.name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)) {
            return Err(err(f("name"), format!("{:?}", r.name), "1 or more letters, digits or -_."));
        }
        let steps = r.steps.or(raw.steps).ok_or_else(|| err(f("steps"), "none".into(), "a budget is needed here or at the top"))?;
        if steps == 0 {
            return Err(err(f("steps"), "0".into(), "must be at least 1"));
        }
        let seeds = r.seeds.clone().unwrap_or_else(|| raw.seeds.clone());
        if seeds.is_empty() {
            return Err(err(f("seeds"), "[]".into(), "at least one seed is needed, here or at the top"));
        }
        check_seeds(&f("seeds"), &seeds, &err)?;
        let scenarios = expand_scenarios(&r.scenarios, &f("scenarios"), &err)?;
        let mut base: Vec<String> = r.set.clone();
        base.push(format!("t_max={steps}"));
        if let Some(obs) = &r.obs {
            base.push(format!("obs=\"{obs}\""));
        }
        // The config with every override, checked now so a typo stops the plan at once.
        let check = |overrides: &[String]| {
            avacraft_marl::Config::for_algo(&r.algo, overrides).map_err(|e| TrainPlanError::Config {
                file: file.to_owned(),
                field: f("set"),
                source: Box::new(e),
            })
        };
        check(&base)?;
        if let Some(src) = &r.from
            && !raw.runs[..i].iter().any(|e| e.name == *src)
        {
            return Err(err(f("from"), format!("{src:?}"), "names no [[runs]] table above this one"));
        }
        for sc in &scenarios {
            let mut own = base.clone();
            if sc.mode == Mode::Pvp {
                match (&r.opponent, &r.from) {
                    (Some(o), _) => own.push(format!("opponent={o:?}")),
                    // A continuation keeps its source's opponent unless it names one.
                    (None, Some(_)) => {}
                    (None, None) => {
                        return Err(err(f("opponent"), "none".into(), &format!("PvP scenario `{}` needs who plays team 2", sc.name)));
                    }
                }
            }
            for &seed in &seeds {
                let id = format!("{}/{}-s{seed}", sc.name, r.name);
                if jobs.iter().any(|j| j.id == id) {
                    return Err(err(f("name"), format!("{:?}", r.name), &format!("run `{id}` is planned twice")));
                }
                let (overrides, from) = match &r.from {
                    None => (own.clone(), None),
                    Some(src) => continuation(&jobs, r, src, &own, (&sc.name, seed), steps, (&err, &f, &check))?,
                };
                check(&overrides)?;
                jobs.push(TrainJob {
                    dir: out.join(&id),
                    id,
                    run: r.name.clone(),
                    scenario: sc.name.clone(),
                    algo: r.algo.clone(),
                    seed,
                    overrides,
                    steps,
                    from,
                });
            }
        }
    }
    match raw.order.as_deref() {
        None | Some("runs") => {}
        Some("scenarios") => {
            let mut firsts: Vec<String> = Vec::new();
            for j in &jobs {
                if !firsts.contains(&j.scenario) {
                    firsts.push(j.scenario.clone());
                }
            }
            // Stable: within a scenario, the runs' order stays.
            jobs.sort_by_key(|j| firsts.iter().position(|s| *s == j.scenario));
        }
        Some(other) => return Err(err("order".into(), format!("{other:?}"), "\"runs\" or \"scenarios\"")),
    }
    let name = raw.name.unwrap_or_else(|| Path::new(file).file_stem().map_or_else(|| "plan".into(), |s| s.to_string_lossy().into()));
    Ok(TrainPlan { file: file.to_owned(), name, out, jobs })
}

/// A `from` run's settings and source: the source job's settings (budget aside), then the
/// run's own (later keys win), checked against the source's algorithm, budget and test
/// opponents.
#[allow(clippy::type_complexity)]
fn continuation(
    jobs: &[TrainJob],
    r: &RawRun,
    src: &str,
    own: &[String],
    (scenario, seed): (&str, u64),
    steps: u64,
    (err, f, check): (
        &dyn Fn(String, String, &str) -> TrainPlanError,
        &dyn Fn(&str) -> String,
        &dyn Fn(&[String]) -> Result<avacraft_marl::Config, TrainPlanError>,
    ),
) -> Result<(Vec<String>, Option<Source>), TrainPlanError> {
    let src_id = format!("{scenario}/{src}-s{seed}");
    let Some(s) = jobs.iter().find(|j| j.id == src_id) else {
        return Err(err(f("from"), format!("{src:?}"), &format!("run `{src_id}` is not planned above")));
    };
    if s.algo != r.algo {
        return Err(err(f("from"), format!("{src:?}"), &format!("a {} run cannot go on from a {} run", r.algo, s.algo)));
    }
    if s.steps >= steps {
        return Err(err(f("steps"), steps.to_string(), &format!("must be above the budget of `{src_id}` it goes on from ({})", s.steps)));
    }
    let mut o: Vec<String> = s.overrides.iter().filter(|k| !k.starts_with("t_max=")).cloned().collect();
    o.extend(own.iter().cloned());
    // The log's columns and the `best/` pick stand on the test opponents: both stages must
    // test the same ones.
    let tests = |o: &[String]| check(o).map(|c| (c.fixed_test_opponents(), c.self_play()));
    let (before, after) = (tests(&s.overrides)?, tests(&o)?);
    if before != after {
        return Err(err(
            f("set"),
            format!("{:?}", r.set),
            &format!("`{src_id}` tested against {:?}; a run that goes on from it must test the same", before.0),
        ));
    }
    Ok((o, Some(Source { id: src_id, dir: s.dir.clone(), steps: s.steps })))
}

fn check_seeds(field: &str, seeds: &[u64], err: &dyn Fn(String, String, &str) -> TrainPlanError) -> Result<(), TrainPlanError> {
    for (i, s) in seeds.iter().enumerate() {
        if seeds[..i].contains(s) {
            return Err(err(format!("{field}[{i}]"), s.to_string(), "named twice"));
        }
    }
    Ok(())
}

/// The scenarios of a list: names, or `all`, `pve`, `pvp` (the built-in ones of that kind),
/// each once, in the order given.
fn expand_scenarios(
    names: &[String],
    field: &str,
    err: &dyn Fn(String, String, &str) -> TrainPlanError,
) -> Result<Vec<Scenario>, TrainPlanError> {
    if names.is_empty() {
        return Err(err(field.to_owned(), "[]".into(), "at least one scenario is needed"));
    }
    let mut out: Vec<Scenario> = Vec::new();
    for (i, n) in names.iter().enumerate() {
        let paper = |mode: Option<Mode>| -> Vec<Scenario> {
            builtin_names().filter_map(|b| Scenario::load(b).ok()).filter(|s| mode.is_none_or(|m| s.mode == m)).collect()
        };
        let group = match n.as_str() {
            "all" => Some(paper(None)),
            "pve" => Some(paper(Some(Mode::Pve))),
            "pvp" => Some(paper(Some(Mode::Pvp))),
            "smac" => Some(smac_names().filter_map(|b| Scenario::load(b).ok()).collect()),
            _ => None,
        };
        let grouped = group.is_some();
        let found: Vec<Scenario> = match group {
            Some(found) => found,
            None => vec![Scenario::load(n).map_err(|e| err(format!("{field}[{i}]"), format!("{n:?}"), &e.to_string()))?],
        };
        for s in found {
            if out.iter().any(|x| x.name == s.name) {
                if !grouped {
                    return Err(err(format!("{field}[{i}]"), format!("{n:?}"), "named twice"));
                }
                continue;
            }
            out.push(s);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PLAN: &str = r#"
name = "t"
out = "runs"
steps = 1000
seeds = [1]

[[runs]]
name = "qmix"
algo = "qmix"
scenarios = ["3m_vlm", "2s3z_vlm"]
seeds = [1, 2]
set = ["use_rnn=false"]

[[runs]]
name = "mappo"
algo = "mappo"
scenarios = ["pvp"]
opponent = "focus-fire"
"#;

    #[test]
    fn plans_expand_in_a_fixed_order_and_shard_every_job_once() {
        let p = parse_train_plan("t.toml", PLAN, Some(Path::new("/plans"))).unwrap_or_else(|e| panic!("{e}"));
        let ids: Vec<&str> = p.jobs.iter().map(|j| j.id.as_str()).collect();
        assert_eq!(&ids[..4], ["3m_vlm/qmix-s1", "3m_vlm/qmix-s2", "2s3z_vlm/qmix-s1", "2s3z_vlm/qmix-s2"]);
        let pvp = builtin_names().filter_map(|b| Scenario::load(b).ok()).filter(|s| s.mode == Mode::Pvp).count();
        assert_eq!(p.jobs.len(), 4 + pvp);
        assert!(p.jobs[4..].iter().all(|j| j.overrides.contains(&"opponent=\"focus-fire\"".to_owned())));
        assert_eq!(p.jobs[0].dir, Path::new("/plans/runs/3m_vlm/qmix-s1"));
        assert!(p.jobs[0].overrides.contains(&"t_max=1000".to_owned()));
        let shards: Vec<Shard> = ["1/3", "2/3", "3/3"].iter().filter_map(|s| s.parse().ok()).collect();
        let mut seen: Vec<&str> = shards.iter().flat_map(|s| p.shard(Some(*s))).map(|j| j.id.as_str()).collect();
        seen.sort_unstable();
        let mut all = ids.clone();
        all.sort_unstable();
        assert_eq!(seen, all);
    }

    /// The shipped baseline plans parse: every scenario has QMIX and MAPPO, the PvP ones an
    /// opponent, and the two parts plan no run twice.
    #[test]
    fn the_shipped_baseline_plans_are_valid() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("plans");
        let one = load_train_plan(&dir.join("baselines.toml")).unwrap_or_else(|e| panic!("{e}"));
        let two = load_train_plan(&dir.join("baselines_seeds_rgb.toml")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(one.out, two.out);
        let n = builtin_names().count();
        assert_eq!(one.jobs.len(), 2 * n);
        for name in builtin_names() {
            for run in ["qmix", "mappo"] {
                assert!(one.jobs.iter().any(|j| j.id == format!("{name}/{run}-s1")), "{name} {run}");
            }
        }
        let ids: Vec<&str> = one.jobs.iter().chain(&two.jobs).map(|j| j.id.as_str()).collect();
        let mut unique = ids.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), ids.len(), "a run planned twice");
        // Scenario by scenario: QMIX then MAPPO of each.
        assert_eq!(one.jobs[0].scenario, one.jobs[1].scenario);
        // SMACv2's scenario: both learners, with units that acquire targets as the scripts' do.
        let v2 = load_train_plan(&dir.join("smacv2.toml")).unwrap_or_else(|e| panic!("{e}"));
        let ids: Vec<&str> = v2.jobs.iter().map(|j| j.id.as_str()).collect();
        assert_eq!(ids, ["protoss_5_vs_5/mappo-s1", "protoss_5_vs_5/mappo-s2", "protoss_5_vs_5/qmix-s1"]);
        assert!(v2.jobs.iter().all(|j| j.overrides.contains(&"passive_agents=false".to_owned())));
        // The PvP league: both learners on the six PvP scenarios, self-play with scripts, and
        // MAPPO's with units that acquire targets by themselves.
        let league = load_train_plan(&dir.join("pvp_league.toml")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(league.jobs.len(), 18 + 3 + 3 + 1 + 1 + 1);
        let active = league.jobs.iter().filter(|j| j.overrides.contains(&"passive_agents=false".to_owned())).count();
        assert_eq!(active, 6 + 3 + 6, "mappo-league-active on each PvP scenario, mappo-league-pfsp on three, the six with abilities");
        // The Stalkers with Blink as an action: both learners, over the scripts alone.
        let abilities: Vec<&str> =
            league.jobs.iter().filter(|j| j.overrides.contains(&"ability_actions=true".to_owned())).map(|j| j.id.as_str()).collect();
        assert_eq!(
            abilities,
            [
                "8s_vs_8m3mr1mv1st_pvp/mappo-league-abilities-s1",
                "8s_vs_8m3mr1mv1st_pvp/qmix-league-abilities-s1",
                "8s_vs_8m3mr1mv1st_pvp/qmix-am-abilities-s1",
                "8s_vs_8m3mr1mv1st_pvp/qmix-am-abilities-more-s1",
                "8s_vs_8m3mr1mv1st_pvp/mappo-am-abilities-s1",
                "8s_vs_8m3mr1mv1st_pvp/mappo-am-abilities-pfsp-s1"
            ]
        );
        let pfsp: Vec<&TrainJob> = league.jobs.iter().filter(|j| j.run == "mappo-league-pfsp").collect();
        assert_eq!(pfsp.len(), 3);
        assert!(pfsp.iter().all(|j| j.overrides.contains(&"self_play_script_draw=\"pfsp\"".to_owned())));
        let budget = |id: &str| pfsp.iter().find(|j| j.id == id).map(|j| (j.steps, j.overrides.contains(&format!("t_max={}", j.steps))));
        assert_eq!(budget("7s_vs_11m1mv1st/mappo-league-pfsp-s1"), Some((3_000_000, true)));
        assert_eq!(budget("8s_vs_8m3mr1mv1st_pvp/mappo-league-pfsp-s1"), Some((3_000_000, true)));
        assert_eq!(budget("8m3mr1mv1st_mirror_pvp/mappo-league-pfsp-s1"), Some((2_000_000, true)));
        let four = |j: &&TrainJob| j.overrides.iter().any(|o| o.starts_with("self_play_scripts=[\"focus-fire\""));
        let specialists: Vec<&str> = league.jobs.iter().filter(|j| !four(j)).map(|j| j.id.as_str()).collect();
        assert_eq!(
            specialists,
            [
                "8s_vs_8m3mr1mv1st_pvp/qmix-am-abilities-s1",
                "8s_vs_8m3mr1mv1st_pvp/qmix-am-abilities-more-s1",
                "8s_vs_8m3mr1mv1st_pvp/mappo-am-abilities-s1"
            ],
            "every other run meets the four scripts"
        );
        // The specialist's second stage goes on from its first, with its settings.
        let more = league.jobs.iter().find(|j| j.run == "qmix-am-abilities-more").map(|j| (j.from.clone(), j.steps));
        assert_eq!(
            more.and_then(|(f, s)| f.map(|f| (f.id, f.steps, s))),
            Some(("8s_vs_8m3mr1mv1st_pvp/qmix-am-abilities-s1".into(), 2_000_000, 3_000_000))
        );
        // MAPPO's specialist goes on against the four scripts, drawn by PFSP, its own set last.
        let pfsp_stage = league.jobs.iter().find(|j| j.run == "mappo-am-abilities-pfsp").expect("planned");
        assert_eq!(pfsp_stage.from.as_ref().map(|f| f.id.as_str()), Some("8s_vs_8m3mr1mv1st_pvp/mappo-am-abilities-s1"));
        let scripts: Vec<&String> = pfsp_stage.overrides.iter().filter(|o| o.starts_with("self_play_scripts=")).collect();
        assert_eq!(scripts.len(), 2);
        assert!(scripts[1].contains("focus-fire") && pfsp_stage.overrides.contains(&"self_play_script_draw=\"pfsp\"".to_owned()));
        let cfg = avacraft_marl::Config::for_algo("mappo", &pfsp_stage.overrides).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cfg.self_play_scripts, ["focus-fire", "kite", "attack-move", "random"], "the stage's own scripts win");
        // SMAC's 23 maps: QMIX and MAPPO on each at SMAC's budgets (10M on the super-hard ones).
        let smac = load_train_plan(&dir.join("smac.toml")).unwrap_or_else(|e| panic!("{e}"));
        // Seeds 2 and 3 of QMIX and MAPPO on five maps and 6h_vs_8z beside them, and on 6h_vs_8z the
        // feed-forward MAPPO, its critic reading the state alone and with each agent's
        // observation, and QMIX with pymarl2's settings for the map; on 2s_vs_1sc QMIX with
        // the Void data set's Spine Crawler and with pymarl2's default settings; MAPPO with the
        // MAPPO repository's network on 2m_vs_1z, 2s_vs_1sc (2M and the MAPPO paper's 10M),
        // 3s_vs_5z (seeds 1-3) and (feed-forward) on 6h_vs_8z; and the weapon period counted
        // from the shot, QMIX on six maps and MAPPO on 2s_vs_1sc; the SMAC paper's own QMIX
        // settings on three maps and EPyMARL's on 5m_vs_6m; the MAPPO repository's 3s_vs_5z
        // script without and with its stacked frames (seeds 1-3 each); and on 5m_vs_6m the MAPPO
        // repository's clip and epochs on the plan's recurrent network (seeds 1-3); on 3s_vs_4z
        // the repository's script for it (seeds 1-3); on 8m_vs_9m its clip (seed 1); its
        // agent-specific state on 6h_vs_8z (seeds 1-3, and seeds 2-3 without it), 2s_vs_1sc
        // (seed 1) and with its 3s_vs_5z script (seeds 1-3).
        assert_eq!(smac.jobs.len(), 2 * 23 + 2 * 2 * 5 + 2 * 2 + 12 + 7 + 3 + 1 + 2 * 3 + 3 + 3 + 1 + 3 + 3 + 1 + 2 + 3);
        // SMAC's signed reward: QMIX on 2s_vs_1sc, MAPPO's seeds 1 and 3 on 3s_vs_5z.
        for (id, algo) in
            [("2s_vs_1sc/qmix-signed-s1", "qmix"), ("3s_vs_5z/mappo-signed-s1", "mappo"), ("3s_vs_5z/mappo-signed-s3", "mappo")]
        {
            let job = smac.jobs.iter().find(|j| j.id == id).unwrap_or_else(|| panic!("{id}"));
            let cfg = avacraft_marl::Config::for_algo(algo, &job.overrides).unwrap_or_else(|e| panic!("{e}"));
            let signed = cfg.env_config().unwrap_or_else(|e| panic!("{e}")).dense_reward.negative_scale == Some(0.5);
            assert!(signed && job.steps == 2_000_000, "{id}: {cfg:?}");
        }
        for map in ["3s5z_vs_3s6z", "5m_vs_6m", "corridor"] {
            let paper = smac.jobs.iter().find(|j| j.id == format!("{map}/qmix-pymarl-s1")).expect("the SMAC paper's QMIX");
            let cfg = avacraft_marl::Config::for_algo("qmix", &paper.overrides).unwrap_or_else(|e| panic!("{e}"));
            let rms = cfg.optimizer == avacraft_marl::OptimizerKind::Rmsprop;
            assert!(rms && cfg.use_rnn && cfg.td_lambda == 0.0 && cfg.lr == 0.0005 && cfg.epsilon_anneal_time == 50_000, "{cfg:?}");
            assert!(cfg.batch_size == 32 && cfg.episodes_per_update == 1 && paper.steps == 2_000_000, "{cfg:?}");
        }
        let epy = smac.jobs.iter().find(|j| j.id == "5m_vs_6m/qmix-epymarl-s1").expect("EPyMARL's QMIX settings");
        let cfg = avacraft_marl::Config::for_algo("qmix", &epy.overrides).unwrap_or_else(|e| panic!("{e}"));
        let adam = cfg.optimizer == avacraft_marl::OptimizerKind::Adam;
        assert!(adam && cfg.use_rnn && cfg.td_lambda == 0.0 && cfg.lr == 0.0005 && epy.steps == 300_000, "{cfg:?}");
        let shot: Vec<&TrainJob> = smac.jobs.iter().filter(|j| j.run.ends_with("-shot")).collect();
        assert_eq!(shot.len(), 7);
        assert!(shot.iter().all(|j| j.overrides.contains(&"weapon_period=\"shot\"".to_owned())));
        for j in &shot {
            let cfg = avacraft_marl::Config::for_algo(&j.algo, &j.overrides).unwrap_or_else(|e| panic!("{}: {e}", j.id));
            assert_eq!(cfg.env_config().map(|c| c.rules.weapon_period).ok(), Some(avacraft_engine::WeaponPeriod::Shot), "{}", j.id);
        }
        for (id, rnn, steps) in [
            ("2m_vs_1z/mappo-ln-s1", true, 2_000_000),
            ("2s_vs_1sc/mappo-ln-s1", true, 2_000_000),
            ("2s_vs_1sc/mappo-ln-10m-s1", true, 10_000_000),
            ("3s_vs_5z/mappo-ln-s3", true, 2_000_000),
            ("6h_vs_8z/mappo-ff-ln-s1", false, 10_000_000),
        ] {
            let job = smac.jobs.iter().find(|j| j.id == id).unwrap_or_else(|| panic!("{id}"));
            let cfg = avacraft_marl::Config::for_algo("mappo", &job.overrides).unwrap_or_else(|e| panic!("{e}"));
            assert!(cfg.layer_norm && cfg.use_rnn == rnn && job.steps == steps, "{id}: {cfg:?}");
        }
        // The MAPPO repository's 3s_vs_5z script, without and with its stacked frames, and its
        // 3s_vs_4z script (the clip at its default).
        for (id, stacked, clip) in
            [("3s_vs_5z/mappo-ff-ln-clip-s2", 1, 0.05), ("3s_vs_5z/mappo-ff-ln-stack-s3", 4, 0.05), ("3s_vs_4z/mappo-stack-s2", 4, 0.2)]
        {
            let job = smac.jobs.iter().find(|j| j.id == id).unwrap_or_else(|| panic!("{id}"));
            let cfg = avacraft_marl::Config::for_algo("mappo", &job.overrides).unwrap_or_else(|e| panic!("{e}"));
            let repo = cfg.layer_norm && !cfg.use_rnn && cfg.clip_param == clip && cfg.ppo_epochs == 15;
            assert!(repo && cfg.stacked_frames == stacked && job.steps == 2_000_000, "{id}: {cfg:?}");
        }
        let clip = ["5m_vs_6m/mappo-clip-s1", "5m_vs_6m/mappo-clip-s2", "5m_vs_6m/mappo-clip-s3", "8m_vs_9m/mappo-clip15-s1"];
        for (id, epochs) in clip.into_iter().zip([10, 10, 10, 15]) {
            let job = smac.jobs.iter().find(|j| j.id == id).unwrap_or_else(|| panic!("{id}"));
            let cfg = avacraft_marl::Config::for_algo("mappo", &job.overrides).unwrap_or_else(|e| panic!("{e}"));
            let repo = cfg.use_rnn && !cfg.layer_norm && cfg.clip_param == 0.05 && cfg.ppo_epochs == epochs;
            assert!(repo && job.steps == 2_000_000, "{id}: {cfg:?}");
        }
        let default = smac.jobs.iter().find(|j| j.id == "2s_vs_1sc/qmix-pymarl2-s1").expect("pymarl2's QMIX on 2s_vs_1sc");
        let cfg = avacraft_marl::Config::for_algo("qmix", &default.overrides).unwrap_or_else(|e| panic!("{e}"));
        assert!(cfg.use_rnn && cfg.td_lambda == 0.6 && cfg.epsilon_anneal_time == 100_000 && cfg.batch_size == 128, "{cfg:?}");
        let void = smac.jobs.iter().find(|j| j.id == "2s_vs_1sc/qmix-void-s1").expect("QMIX on Void data");
        let cfg = avacraft_marl::Config::for_algo("qmix", &void.overrides).unwrap_or_else(|e| panic!("{e}"));
        assert!(cfg.data == "void" && !cfg.use_rnn && void.steps == 2_000_000, "{cfg:?}");
        let tuned = smac.jobs.iter().find(|j| j.id == "6h_vs_8z/qmix-pymarl2-s1").expect("pymarl2's QMIX");
        let cfg = avacraft_marl::Config::for_algo("qmix", &tuned.overrides).unwrap_or_else(|e| panic!("{e}"));
        assert!(cfg.use_rnn && cfg.td_lambda == 0.3 && cfg.epsilon_anneal_time == 500_000 && tuned.steps == 10_000_000);
        assert!(cfg.batch_size == 128 && cfg.episodes_per_update == 4 && cfg.lr == 0.001, "{cfg:?}");
        for (run, agent_obs) in [("mappo-ff", false), ("mappo-ff-obs", true)] {
            let ff = smac.jobs.iter().find(|j| j.id == format!("6h_vs_8z/{run}-s1")).expect("the feed-forward MAPPO");
            let cfg = avacraft_marl::Config::for_algo("mappo", &ff.overrides).unwrap_or_else(|e| panic!("{e}"));
            assert!(!cfg.use_rnn && cfg.ppo_epochs == 5 && ff.steps == 10_000_000 && cfg.critic_agent_obs == agent_obs, "{run}");
        }
        // The repository's agent-specific state, with the rest of its script for each map.
        for (id, rnn, epochs, steps) in [
            ("6h_vs_8z/mappo-ff-ln-as-s1", false, 5, 10_000_000),
            ("6h_vs_8z/mappo-ff-ln-as-s2", false, 5, 10_000_000),
            ("6h_vs_8z/mappo-ff-ln-as-s3", false, 5, 10_000_000),
            ("2s_vs_1sc/mappo-ln-as-s1", true, 15, 2_000_000),
            ("3s_vs_5z/mappo-ff-ln-stack-as-s3", false, 15, 2_000_000),
        ] {
            let job = smac.jobs.iter().find(|j| j.id == id).unwrap_or_else(|| panic!("{id}"));
            let cfg = avacraft_marl::Config::for_algo("mappo", &job.overrides).unwrap_or_else(|e| panic!("{e}"));
            let repo = cfg.state_agent && cfg.layer_norm && !cfg.critic_agent_obs && cfg.use_rnn == rnn && cfg.ppo_epochs == epochs;
            assert!(repo && job.steps == steps, "{id}: {cfg:?}");
        }
        for name in ["3m", "2s3z", "3s_vs_5z", "5m_vs_6m", "MMM", "6h_vs_8z"] {
            for seed in [2, 3] {
                for run in ["qmix", "mappo"] {
                    let id = format!("{name}/{run}-s{seed}");
                    let job = smac.jobs.iter().find(|j| j.id == id).unwrap_or_else(|| panic!("{id}"));
                    let seed1 = smac.jobs.iter().find(|j| j.id == format!("{name}/{run}-s1")).unwrap_or_else(|| panic!("{name} {run}"));
                    assert!(job.steps == seed1.steps && job.overrides == seed1.overrides, "{id}: seed 1's settings");
                }
            }
        }
        for name in smac_names() {
            for run in ["qmix", "mappo"] {
                let job = smac.jobs.iter().find(|j| j.id == format!("{name}/{run}-s1")).unwrap_or_else(|| panic!("{name} {run}"));
                let hard = ["MMM2", "3s5z_vs_3s6z", "27m_vs_30m", "6h_vs_8z", "corridor"].contains(&name);
                let budget = format!("t_max={}", if hard { 10_000_000 } else { 2_000_000 });
                assert!(job.overrides.contains(&budget), "{name} {run}: {:?}", job.overrides);
            }
        }
    }

    /// `from`: the earlier run's settings (its opponent among them), this run's on top, the
    /// earlier job named; a source that is not above, another algorithm or a budget not above
    /// the source's is refused, naming the field.
    #[test]
    fn a_run_goes_on_from_an_earlier_one() {
        let more = "\n[[runs]]\nname = \"mappo-more\"\nalgo = \"mappo\"\nscenarios = [\"pvp\"]\nsteps = 3000\nfrom = \"mappo\"\nset = [\"lr=0.0001\"]\n";
        let p = parse_train_plan("t.toml", &format!("{PLAN}{more}"), Some(Path::new("/plans"))).unwrap_or_else(|e| panic!("{e}"));
        let job = p.jobs.iter().find(|j| j.run == "mappo-more").unwrap_or_else(|| panic!("no mappo-more job"));
        let src = job.from.as_ref().unwrap_or_else(|| panic!("no source"));
        assert_eq!(src.id, format!("{}/mappo-s1", job.scenario));
        assert_eq!(src.dir, Path::new("/plans/runs").join(&src.id));
        assert_eq!((src.steps, job.steps), (1000, 3000));
        let o = &job.overrides;
        assert!(o.contains(&"opponent=\"focus-fire\"".to_owned()) && o.contains(&"lr=0.0001".to_owned()), "{o:?}");
        assert_eq!(o.iter().filter(|k| k.starts_with("t_max=")).collect::<Vec<_>>(), ["t_max=3000"]);
        assert!(p.jobs.iter().filter(|j| j.run != "mappo-more").all(|j| j.from.is_none()));
        let e = |t: &str| parse_train_plan("t.toml", &format!("{PLAN}{t}"), None).err().map(|e| e.to_string()).unwrap_or_default();
        let bad = |from: &str, to: &str| e(&more.replacen(from, to, 1));
        assert!(bad("from = \"mappo\"", "from = \"later\"").contains("runs[2].from"));
        assert!(bad("algo = \"mappo\"", "algo = \"qmix\"").contains("a qmix run cannot go on from a mappo run"));
        assert!(bad("steps = 3000", "steps = 1000").contains("runs[2].steps"));
        assert!(bad("scenarios = [\"pvp\"]", "scenarios = [\"3m_vlm\"]").contains("3m_vlm/mappo-s1"));
        let other_tests = bad("set = [\"lr=0.0001\"]", "set = [\"test_opponents=[\\\"kite\\\"]\"]");
        assert!(other_tests.contains("runs[2].set") && other_tests.contains("must test the same"), "{other_tests}");
        // Each continuation lands in its source's shard.
        let shards: Vec<Shard> = ["1/3", "2/3", "3/3"].iter().filter_map(|s| s.parse().ok()).collect();
        for s in shards {
            let ids: Vec<&str> = p.shard(Some(s)).iter().map(|j| j.id.as_str()).collect();
            for j in p.shard(Some(s)).iter().filter_map(|j| j.from.as_ref()) {
                assert!(ids.contains(&j.id.as_str()), "{} without its source in shard {s:?}", j.id);
            }
        }
    }

    #[test]
    fn mistakes_name_the_field() {
        let e = |t: &str| {
            parse_train_plan("t.toml", t, None)
                .err()
                .map(|e| format!("{e}: {:?}", std::error::Error::source(&e).map(|s| s.to_string())))
                .unwrap_or_default()
        };
        let with = |from: &str, to: &str| e(&PLAN.replacen(from, to, 1));
        assert!(with("scenarios = [\"3m_vlm\", \"2s3z_vlm\"]", "scenarios = [\"3m_vlm\", \"nowhere\"]").contains("runs[0].scenarios[1]"));
        assert!(with("opponent = \"focus-fire\"\n", "").contains("runs[1].opponent"));
        assert!(with("opponent = \"focus-fire\"", "opponent = \"nobody\"").contains("opponent"));
        assert!(with("set = [\"use_rnn=false\"]", "set = [\"lr=-1\"]").contains("runs[0].set"));
        assert!(with("set = [\"use_rnn=false\"]", "set = [\"lr=-1\"]").contains("lr = -1"));
        assert!(with("seeds = [1, 2]", "seeds = [1, 1]").contains("runs[0].seeds[1]"));
        // The same run name on other scenarios is fine; on the same scenario and seed it is not.
        assert!(with("name = \"mappo\"", "name = \"qmix\"").is_empty());
        let twice = format!("{PLAN}\n[[runs]]\nname = \"qmix\"\nalgo = \"vdn\"\nscenarios = [\"2s3z_vlm\"]\n");
        assert!(e(&twice).contains("runs[2].name") && e(&twice).contains("2s3z_vlm/qmix-s1"));
        assert!(with("steps = 1000", "steps = 0").contains("steps"));
        assert!(e("out = \"x\"\n").contains("runs"));
        assert!(with("seeds = [1]\n", "seeds = [1]\norder = \"random\"\n").contains("order"));
        let by_scenario = parse_train_plan("t.toml", &PLAN.replacen("seeds = [1]\n", "seeds = [1]\norder = \"scenarios\"\n", 1), None)
            .unwrap_or_else(|e| panic!("{e}"));
        let first: Vec<&str> = by_scenario.jobs.iter().take(2).map(|j| j.id.as_str()).collect();
        assert_eq!(first, ["3m_vlm/qmix-s1", "3m_vlm/qmix-s2"]);
        assert!(e("out = \"x\"\nbogus = 1\n").contains("bogus"));
    }
}
