//! Evaluation plans (TOML): which agents play which scenarios against which opponents, with
//! which seeds, and which pairs meet head to head in PvP. Parsed with unknown fields refused,
//! then expanded into [`Cell`]s and [`Job`]s (one episode each) in a fixed order, so a shard
//! of a plan is the same set of episodes on every machine.

use avacraft_ava::AvaSpec;
use avacraft_engine::{Mode, OpponentKind, Scenario, Team, builtin_names};
use avacraft_policy::{PolicyError, PolicySpec, Resolve};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlan {
    #[serde(default)]
    name: Option<String>,
    /// PvE scenarios by name (or files), or `all`.
    #[serde(default)]
    scenarios: Vec<String>,
    /// Opponent policies of the PvE scenarios (default: each scenario's own).
    #[serde(default)]
    opponents: Vec<String>,
    /// Episode seeds: one episode per seed and cell.
    seeds: Vec<u64>,
    #[serde(default)]
    agents: Vec<RawAgent>,
    #[serde(default)]
    headtohead: Vec<RawHeadToHead>,
    /// MARL training runs whose learning curves go into the report.
    #[serde(default)]
    curves: Vec<RawCurve>,
    /// A Markdown file (relative to the plan's folder) that also gets the report, its plots
    /// in a `<stem>/` folder beside it: e.g. `../../docs/results.md`.
    #[serde(default)]
    document: Option<String>,
    /// Markdown put at the head of the report: the protocol (budget, seeds, opponents).
    #[serde(default)]
    protocol: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAgent {
    name: String,
    /// A scripted agent, `marl:DIR` or `ava`.
    policy: String,
    /// With `policy = "ava"`: the settings (model, config, record, prices, prompts).
    #[serde(default)]
    ava: Option<AvaSpec>,
    /// Only these of the plan's scenarios (a checkpoint plays its own).
    #[serde(default)]
    scenarios: Option<Vec<String>>,
    /// What the agent is in the tables: scripted, marl or vlm (default: from the policy).
    #[serde(default)]
    kind: Option<AgentKind>,
    /// Only the first `seeds` of the plan's seeds (an expensive agent, e.g. a local model).
    #[serde(default)]
    seeds: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHeadToHead {
    scenarios: Vec<String>,
    /// Every ordered pair of these agents plays (the first named on team 1), itself included.
    agents: Vec<String>,
    /// Instead of the pairs among `agents`: each of `agents` on team 1 against each of these
    /// on team 2 (e.g. trained policies against the scripted opponent they trained on).
    #[serde(default)]
    against: Option<Vec<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCurve {
    name: String,
    /// A training run's output folder (its `log.csv`).
    dir: PathBuf,
}

/// What an agent is, for the tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AgentKind {
    Scripted,
    Marl,
    Vlm,
}

impl AgentKind {
    pub fn name(self) -> &'static str {
        match self {
            AgentKind::Scripted => "scripted",
            AgentKind::Marl => "marl",
            AgentKind::Vlm => "vlm",
        }
    }
}

/// A validated agent.
#[derive(Clone, Debug)]
pub struct AgentDef {
    pub name: String,
    pub policy: PolicySpec,
    pub kind: AgentKind,
    /// The plan's scenarios it plays (`None`: all).
    pub scenarios: Option<Vec<String>>,
    /// How many of the plan's seeds (the first ones) its cells play (`None`: all).
    pub seeds: Option<usize>,
}

/// A training run's learning curve.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CurveDef {
    pub name: String,
    pub dir: PathBuf,
}

/// What one table cell aggregates: an agent on a scenario against an opponent (PvE) or
/// another agent (PvP).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct CellKey {
    pub scenario: String,
    pub agent: String,
    /// `opponent:<kind>` (PvE, `opponent:default` for the scenario's own) or the name of the
    /// agent on team 2 (PvP).
    pub against: String,
}

impl std::fmt::Display for CellKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} / {} vs {}", self.scenario, self.agent, self.against)
    }
}

/// One cell to play.
#[derive(Clone, Debug)]
pub struct Cell {
    pub key: CellKey,
    pub scenario: Arc<Scenario>,
    /// Index into [`Plan::agents`] of team 1's agent.
    pub agent: usize,
    pub opponent: Option<OpponentKind>,
    /// PvP: team 2's agent.
    pub agent2: Option<usize>,
}

/// One episode to play: a cell and a seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Job {
    pub cell: usize,
    pub seed: u64,
}

/// A validated plan.
#[derive(Debug)]
pub struct Plan {
    pub file: String,
    pub name: String,
    pub agents: Vec<AgentDef>,
    pub cells: Vec<Cell>,
    pub seeds: Vec<u64>,
    pub curves: Vec<CurveDef>,
    /// `(agent, scenario)` pairs a `baseline:NAME` agent skips: no policy is shipped there.
    pub unshipped: Vec<(String, String)>,
    /// Where the report is also written (resolved against the plan's folder).
    pub document: Option<PathBuf>,
    pub protocol: String,
}

/// A shipped baseline with nothing for this scenario: its cell is left out and reported.
fn unshipped(e: &PolicyError) -> bool {
    matches!(e, PolicyError::Baseline(avacraft_marl::baselines::BaselineError::Missing { .. }))
}

/// Why a plan was refused; every error names the file, the field and the value.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
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
    #[error("{file}: field `{field}` = {value}")]
    Policy {
        file: String,
        field: String,
        value: String,
        #[source]
        source: Box<PolicyError>,
    },
}

impl Plan {
    pub fn jobs(&self) -> Vec<Job> {
        self.cells.iter().enumerate().flat_map(|(cell, c)| self.seeds_of(c).iter().map(move |&seed| Job { cell, seed })).collect()
    }

    /// The seeds a cell plays: the plan's, or the first ones its team-1 agent is limited to.
    pub fn seeds_of(&self, cell: &Cell) -> &[u64] {
        let n = self.agents[cell.agent].seeds.unwrap_or(self.seeds.len());
        &self.seeds[..n.min(self.seeds.len())]
    }
}

/// Reads and validates a plan; relative paths (`marl:DIR`, scenario files, curve folders)
/// are resolved against its folder.
pub fn load(path: &Path) -> Result<Plan, PlanError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| PlanError::Io { file: file.clone(), source })?;
    parse(&file, &text, path.parent())
}

/// Parses plan text (`file` names it in errors).
pub fn parse(file: &str, text: &str, base: Option<&Path>) -> Result<Plan, PlanError> {
    let raw: RawPlan = toml::from_str(text).map_err(|e| PlanError::Syntax { file: file.to_owned(), message: e.to_string() })?;
    validate(file, raw, base)
}

// Long: one check per section of the plan in the file's order (scenarios, agents,
// head-to-head, curves), each refusal naming its field.
fn validate(file: &str, raw: RawPlan, base: Option<&Path>) -> Result<Plan, PlanError> {
    let err = |field: String, value: String, reason: String| PlanError::Invalid { file: file.to_owned(), field, value, reason };
    if raw.seeds.is_empty() {
        return Err(err("seeds".into(), "[]".into(), "at least one seed is needed".into()));
    }
    for (i, s) in raw.seeds.iter().enumerate() {
        if raw.seeds[..i].contains(s) {
            return Err(err(format!("seeds[{i}]"), s.to_string(), "named twice".into()));
        }
    }
    let load_scenario = |field: String, name: &str| -> Result<Arc<Scenario>, PlanError> {
        let arg = match base.map(|b| b.join(name)) {
            Some(p) if p.is_file() => p.display().to_string(),
            _ => name.to_owned(),
        };
        Scenario::load(&arg).map(Arc::new).map_err(|e| err(field, format!("{name:?}"), e.to_string()))
    };
    let mut scenarios: Vec<Arc<Scenario>> = Vec::new();
    for (i, s) in raw.scenarios.iter().enumerate() {
        if s == "all" {
            for n in builtin_names() {
                let sc = load_scenario(format!("scenarios[{i}]"), n)?;
                if sc.mode == Mode::Pve && !scenarios.iter().any(|x| x.name == sc.name) {
                    scenarios.push(sc);
                }
            }
            continue;
        }
        let sc = load_scenario(format!("scenarios[{i}]"), s)?;
        if sc.mode == Mode::Pvp {
            return Err(err(format!("scenarios[{i}]"), format!("{s:?}"), "a PvP scenario goes in a [[headtohead]] table".into()));
        }
        if scenarios.iter().any(|x| x.name == sc.name) {
            return Err(err(format!("scenarios[{i}]"), format!("{s:?}"), "named twice".into()));
        }
        scenarios.push(sc);
    }
    let mut opponents: Vec<Option<OpponentKind>> = Vec::new();
    for (i, o) in raw.opponents.iter().enumerate() {
        let k = if o == "default" {
            None
        } else {
            Some(o.parse::<OpponentKind>().map_err(|e| err(format!("opponents[{i}]"), format!("{o:?}"), e))?)
        };
        if opponents.contains(&k) {
            return Err(err(format!("opponents[{i}]"), format!("{o:?}"), "named twice".into()));
        }
        opponents.push(k);
    }
    if opponents.is_empty() {
        opponents.push(None);
    }
    let mut agents: Vec<AgentDef> = Vec::new();
    for (i, a) in raw.agents.iter().enumerate() {
        let f = |name: &str| format!("agents[{i}].{name}");
        if a.name.is_empty() || a.name.len() > 64 || !a.name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.:+".contains(c)) {
            return Err(err(f("name"), format!("{:?}", a.name), "1 to 64 letters, digits or -_.:+".into()));
        }
        if agents.iter().any(|x| x.name == a.name) {
            return Err(err(f("name"), format!("{:?}", a.name), "two agents share this name".into()));
        }
        let policy_err = |field: String, source: PolicyError| PlanError::Policy {
            file: file.to_owned(),
            field,
            value: format!("{:?}", a.policy),
            source: Box::new(source),
        };
        let policy = PolicySpec::resolve(&a.policy, a.ava.clone(), Resolve::against(base)).map_err(|e| {
            let field = if matches!(e, PolicyError::Ava(_) | PolicyError::SpecWithoutAva { .. }) { f("ava") } else { f("policy") };
            policy_err(field, e)
        })?;
        if policy.is_dds() {
            return Err(err(f("policy"), format!("{:?}", a.policy), "an evaluation plays in-process; DDS agents cannot".into()));
        }
        let kind = a.kind.unwrap_or(match &policy {
            PolicySpec::Marl(_) | PolicySpec::Baseline(_) => AgentKind::Marl,
            PolicySpec::Ava(_) => AgentKind::Vlm,
            _ => AgentKind::Scripted,
        });
        if let Some(only) = &a.scenarios {
            for (j, s) in only.iter().enumerate() {
                if !scenarios.iter().any(|x| &x.name == s) {
                    return Err(err(format!("agents[{i}].scenarios[{j}]"), format!("{s:?}"), "not one of the plan's scenarios".into()));
                }
            }
        }
        if let Some(n) = a.seeds
            && (n == 0 || n > raw.seeds.len())
        {
            return Err(err(f("seeds"), n.to_string(), format!("the number of the plan's seeds it plays: 1 to {}", raw.seeds.len())));
        }
        agents.push(AgentDef { name: a.name.clone(), policy, kind, scenarios: a.scenarios.clone(), seeds: a.seeds });
    }
    let mut cells = Vec::new();
    let mut skipped: Vec<(String, String)> = Vec::new();
    for sc in &scenarios {
        for (ai, a) in agents.iter().enumerate() {
            if a.scenarios.as_ref().is_some_and(|only| !only.contains(&sc.name)) {
                continue;
            }
            match a.policy.check(sc, Team::One) {
                Ok(()) => {}
                Err(e) if unshipped(&e) => {
                    skipped.push((a.name.clone(), sc.name.clone()));
                    continue;
                }
                Err(source) => {
                    return Err(PlanError::Policy {
                        file: file.to_owned(),
                        field: format!("agents[{ai}].policy"),
                        value: format!("{} on {}", a.policy, sc.name),
                        source: Box::new(source),
                    });
                }
            }
            for o in &opponents {
                let against = format!("opponent:{}", o.map_or("default", |k| k.name()));
                cells.push(Cell {
                    key: CellKey { scenario: sc.name.clone(), agent: a.name.clone(), against },
                    scenario: Arc::clone(sc),
                    agent: ai,
                    opponent: *o,
                    agent2: None,
                });
            }
        }
    }
    for (h, t) in raw.headtohead.iter().enumerate() {
        let indices = |field: &str, names: &[String]| -> Result<Vec<usize>, PlanError> {
            let mut idx = Vec::new();
            for (j, n) in names.iter().enumerate() {
                let Some(k) = agents.iter().position(|a| &a.name == n) else {
                    return Err(err(format!("headtohead[{h}].{field}[{j}]"), format!("{n:?}"), "not one of the plan's agents".into()));
                };
                if idx.contains(&k) {
                    return Err(err(format!("headtohead[{h}].{field}[{j}]"), format!("{n:?}"), "named twice".into()));
                }
                idx.push(k);
            }
            if idx.is_empty() {
                return Err(err(format!("headtohead[{h}].{field}"), "[]".into(), "at least one agent is needed".into()));
            }
            Ok(idx)
        };
        let idx = indices("agents", &t.agents)?;
        let idx2 = match &t.against {
            Some(names) => indices("against", names)?,
            None => idx.clone(),
        };
        for (j, s) in t.scenarios.iter().enumerate() {
            let sc = load_scenario(format!("headtohead[{h}].scenarios[{j}]"), s)?;
            if sc.mode != Mode::Pvp {
                return Err(err(format!("headtohead[{h}].scenarios[{j}]"), format!("{s:?}"), "a PvE scenario goes in `scenarios`".into()));
            }
            for &a in &idx {
                for &b in &idx2 {
                    let missing = [a, b].into_iter().find(|&k| agents[k].policy.check(&sc, Team::One).is_err_and(|e| unshipped(&e)));
                    if let Some(k) = missing {
                        let pair = (agents[k].name.clone(), sc.name.clone());
                        if !skipped.contains(&pair) {
                            skipped.push(pair);
                        }
                        continue;
                    }
                    for (k, team) in [(a, Team::One), (b, Team::Two)] {
                        agents[k].policy.check(&sc, team).map_err(|source| PlanError::Policy {
                            file: file.to_owned(),
                            field: format!("headtohead[{h}].agents"),
                            value: format!("{} as {team} on {}", agents[k].name, sc.name),
                            source: Box::new(source),
                        })?;
                    }
                    let key = CellKey { scenario: sc.name.clone(), agent: agents[a].name.clone(), against: agents[b].name.clone() };
                    if cells.iter().any(|c: &Cell| c.key == key) {
                        return Err(err(format!("headtohead[{h}]"), key.to_string(), "this pairing is planned twice".into()));
                    }
                    cells.push(Cell { key, scenario: Arc::clone(&sc), agent: a, opponent: None, agent2: Some(b) });
                }
            }
        }
    }
    if cells.is_empty() {
        return Err(err(
            "agents".into(),
            format!("{} agents", agents.len()),
            "the plan has nothing to play (agents and scenarios, or [[headtohead]])".into(),
        ));
    }
    let mut curves = Vec::new();
    for (i, c) in raw.curves.iter().enumerate() {
        let dir = match base {
            Some(b) if c.dir.is_relative() => b.join(&c.dir),
            _ => c.dir.clone(),
        };
        if !dir.join("log.csv").is_file() {
            return Err(err(
                format!("curves[{i}].dir"),
                format!("{:?}", c.dir.display().to_string()),
                "holds no log.csv of `avacraft train`".into(),
            ));
        }
        curves.push(CurveDef { name: c.name.clone(), dir });
    }
    let name =
        raw.name.unwrap_or_else(|| Path::new(file).file_stem().map_or_else(|| "plan".to_owned(), |s| s.to_string_lossy().into_owned()));
    let document = match raw.document {
        Some(d) if d.trim().is_empty() || !d.ends_with(".md") => {
            return Err(err("document".into(), format!("{d:?}"), "a Markdown file (`.md`), e.g. \"../../docs/results.md\"".into()));
        }
        Some(d) => Some(base.map_or_else(|| PathBuf::from(&d), |b| b.join(&d))),
        None => None,
    };
    Ok(Plan {
        file: file.to_owned(),
        name,
        agents,
        cells,
        seeds: raw.seeds,
        curves,
        unshipped: skipped,
        document,
        protocol: raw.protocol.unwrap_or_default(),
    })
}

/// `i/n` of `--shard`: this machine plays the jobs whose index is `i - 1` modulo `n`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let (i, n) = s.split_once('/').ok_or_else(|| format!("`{s}`: a shard is i/n, e.g. 2/8"))?;
        let (index, count) = (i.trim().parse::<usize>(), n.trim().parse::<usize>());
        match (index, count) {
            (Ok(index), Ok(count)) if count >= 1 && (1..=count).contains(&index) => Ok(Shard { index, count }),
            _ => Err(format!("`{s}`: a shard is i/n with 1 <= i <= n, e.g. 2/8")),
        }
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    pub fn takes(&self, job_index: usize) -> bool {
        job_index % self.count == self.index - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plan the README shows parses, with its checkpoint found from the plan's folder.
    #[test]
    fn the_shipped_plan_is_valid() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("plans/pve_scripted.toml");
        let plan = load(&p).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(plan.agents.iter().map(|a| a.kind).filter(|k| *k == AgentKind::Marl).count(), 1);
        assert_eq!(plan.jobs().len(), plan.cells.len() * 5);
        assert!(plan.cells.iter().any(|c| c.agent2.is_some()), "the head-to-head matrix");
    }

    #[test]
    fn shards_split_every_job_once() {
        let shards: Vec<Shard> = ["1/3", "2/3", "3/3"].iter().map(|s| s.parse().expect("shard")).collect();
        for i in 0..30 {
            assert_eq!(shards.iter().filter(|s| s.takes(i)).count(), 1);
        }
        for bad in ["0/3", "4/3", "1/0", "a/b", "3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
