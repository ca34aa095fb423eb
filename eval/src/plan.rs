//! Evaluation plans (TOML): which agents play which scenarios against which opponents, with
//! which seeds, and which pairs meet head to head in PvP. Parsed with unknown fields refused,
//! then expanded into [`Cell`]s and [`Job`]s (one episode each) in a fixed order, so a shard
//! of a plan is the same set of episodes on every machine.

use avacraft_ava::AvaSpec;
use avacraft_engine::{EnvOptions, OpponentKind, Scenario};
use avacraft_policy::{PolicyError, PolicySpec};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPlan {
    #[serde(default)]
    pub(crate) name: Option<String>,
    /// PvE scenarios by name (or files), or `all`.
    #[serde(default)]
    pub(crate) scenarios: Vec<String>,
    /// Opponent policies of the PvE scenarios (default: each scenario's own).
    #[serde(default)]
    pub(crate) opponents: Vec<String>,
    /// Episode seeds: one episode per seed and cell.
    pub(crate) seeds: Vec<u64>,
    /// The unit data every scenario of the plan plays on (`liberty`, `void`, `ladder`,
    /// `legacy`); default: each scenario's own (its map's).
    #[serde(default)]
    pub(crate) data: Option<String>,
    #[serde(default)]
    pub(crate) agents: Vec<RawAgent>,
    #[serde(default)]
    pub(crate) headtohead: Vec<RawHeadToHead>,
    /// MARL training runs whose learning curves go into the report.
    #[serde(default)]
    pub(crate) curves: Vec<RawCurve>,
    /// A Markdown file (relative to the plan's folder) that also gets the report, its plots
    /// in a `<stem>/` folder beside it: e.g. `../../docs/results.md`.
    #[serde(default)]
    pub(crate) document: Option<String>,
    /// Environment options besides the opponent and the unit data (`step_mul`,
    /// `full_vision`, ...: the Python keyword names) over the evaluation's defaults (sparse
    /// reward, no passive side).
    #[serde(default)]
    pub(crate) env: Option<serde_json::Value>,
    /// Markdown put at the head of the report: the protocol (budget, seeds, opponents).
    #[serde(default)]
    pub(crate) protocol: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawAgent {
    pub(crate) name: String,
    /// A scripted agent, `marl:DIR` or `ava`.
    pub(crate) policy: String,
    /// With `policy = "ava"`: the settings (model, config, record, prices, prompts).
    #[serde(default)]
    pub(crate) ava: Option<AvaSpec>,
    /// Only these of the plan's scenarios (a checkpoint plays its own).
    #[serde(default)]
    pub(crate) scenarios: Option<Vec<String>>,
    /// What the agent is in the tables: scripted, marl or vlm (default: from the policy).
    #[serde(default)]
    pub(crate) kind: Option<AgentKind>,
    /// Only the first `seeds` of the plan's seeds (an expensive agent, e.g. a local model).
    #[serde(default)]
    pub(crate) seeds: Option<usize>,
    /// Another training seed of the agent named here (same algorithm, config and budget).
    #[serde(default)]
    pub(crate) seed_of: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawHeadToHead {
    pub(crate) scenarios: Vec<String>,
    /// Every ordered pair of these agents plays (the first named on team 1), itself included.
    pub(crate) agents: Vec<String>,
    /// Instead of the pairs among `agents`: each of `agents` on team 1 against each of these
    /// on team 2 (e.g. trained policies against the scripted opponent they trained on).
    #[serde(default)]
    pub(crate) against: Option<Vec<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCurve {
    pub(crate) name: String,
    /// A training run's output folder (its `log.csv`).
    pub(crate) dir: PathBuf,
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
    /// The agent it is another training seed of: its rows are shown, the table of training
    /// seeds gathers it with that agent, and the best-of comparisons leave it out (the best
    /// of several training runs of one learner would flatter the learner).
    pub seed_of: Option<String>,
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
    /// The game has the ability slots (`EnvOptions::ability_actions`) because a network of
    /// the cell reads them; the other side plays with or without them alike.
    pub ability_actions: bool,
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
    /// `(agent, scenario, what differs)`: networks played under other rules than they learned
    /// (weapon periods, the surround experiment), which the plan's `env` sets for every cell.
    pub off_rules: Vec<(String, String, String)>,
    /// Where the report is also written (resolved against the plan's folder).
    pub document: Option<PathBuf>,
    pub protocol: String,
    /// The environment every cell plays in (its own opponent aside).
    pub env: EnvOptions,
}

/// The options an evaluation plays with unless its plan says otherwise: whole games (sparse
/// reward), both sides acquiring targets by themselves.
pub fn eval_env() -> EnvOptions {
    EnvOptions { passive_allies: false, reward: avacraft_engine::RewardMode::Sparse, ..EnvOptions::default() }
}

/// A shipped baseline with nothing for this scenario: its cell is left out and reported.
pub(crate) fn unshipped(e: &PolicyError) -> bool {
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
    #[error("{file}: not a valid plan")]
    Syntax {
        file: String,
        #[source]
        source: Box<toml::de::Error>,
    },
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

    /// The jobs `shard` plays (all of them without one), in plan order.
    pub fn jobs_in(&self, shard: Option<Shard>) -> Vec<Job> {
        self.jobs().into_iter().enumerate().filter(|(i, _)| shard.is_none_or(|s| s.takes(*i))).map(|(_, j)| j).collect()
    }

    /// The seeds a cell plays: the plan's, or the first ones its team-1 agent is limited to.
    pub fn seeds_of(&self, cell: &Cell) -> &[u64] {
        let n = self.agents[cell.agent].seeds.unwrap_or(self.seeds.len());
        &self.seeds[..n.min(self.seeds.len())]
    }
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
