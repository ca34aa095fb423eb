//! An evaluation folder's `plan.json`: what the report needs of the plan, and the checks that
//! keep one folder to one plan and a merge to the shards of one split. Kept out of the report:
//! the plots read it, and the report draws the plots.

use crate::EvalError;
use crate::plan::{AgentKind, CellKey, Plan, Shard};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What the report needs of the plan, written next to the results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    pub name: String,
    /// Name, kind and policy of each agent, in plan order.
    pub agents: Vec<(String, AgentKind, String)>,
    pub seeds: Vec<u64>,
    /// Learning curves: name and training folder.
    pub curves: Vec<(String, PathBuf)>,
    /// Every cell the plan has, in plan order.
    pub cells: Vec<CellKey>,
    /// The shard of the plan this folder played (`None`: all of it, or a merge of all).
    #[serde(default)]
    pub shard: Option<Shard>,
    /// `(agent, scenario)`: shipped baselines missing, so left out.
    #[serde(default)]
    pub unshipped: Vec<(String, String)>,
    /// `(agent, scenario, what differs)`: networks played under other rules than they learned
    /// ([`Plan::off_rules`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub off_rules: Vec<(String, String, String)>,
    /// Also written to this Markdown file, with its plots beside it.
    #[serde(default)]
    pub document: Option<PathBuf>,
    #[serde(default)]
    pub protocol: String,
    /// `(agent, scenario, fingerprint)` of the trained networks and AVA settings played
    /// ([`fingerprints`]); folders written before it have none, and are not checked for them.
    #[serde(default)]
    pub fingerprints: Vec<(String, String, String)>,
    /// `(agent, agent it is another training seed of)` ([`crate::AgentDef::seed_of`]).
    #[serde(default)]
    pub seed_of: Vec<(String, String)>,
    /// `(cell, unit data set)`: the game each cell plays. Folders written before data sets
    /// existed have none: their cells played `legacy`.
    #[serde(default)]
    pub games: Vec<(CellKey, String)>,
    /// The scenario names the cells are written in ([`NAMES`]); folders without it were
    /// played before SMAC's maps took SMAC's names.
    #[serde(default = "old_names")]
    pub names: u32,
    /// The environment options the cells played with (their opponents aside); folders
    /// written before plans could set them played the evaluation's defaults.
    #[serde(default = "crate::plan::eval_env")]
    pub env: avacraft_engine::EnvOptions,
}

pub const META_FILE: &str = "plan.json";

/// 2 since SMAC's names mean SMAC's maps ([`avacraft_engine::RENAMED`]): before, `3m` was the
/// paper's scenario now named `3m_vlm`.
pub const NAMES: u32 = 2;

fn old_names() -> u32 {
    1
}

impl Meta {
    pub fn of(plan: &Plan) -> Meta {
        Meta {
            name: plan.name.clone(),
            agents: plan.agents.iter().map(|a| (a.name.clone(), a.kind, a.policy.to_string())).collect(),
            seeds: plan.seeds.clone(),
            curves: plan.curves.iter().map(|c| (c.name.clone(), c.dir.clone())).collect(),
            cells: plan.cells.iter().map(|c| c.key.clone()).collect(),
            shard: None,
            unshipped: plan.unshipped.clone(),
            off_rules: plan.off_rules.clone(),
            document: plan.document.clone(),
            protocol: plan.protocol.clone(),
            fingerprints: Vec::new(),
            seed_of: plan.agents.iter().filter_map(|a| a.seed_of.clone().map(|b| (a.name.clone(), b))).collect(),
            games: plan.cells.iter().map(|c| (c.key.clone(), c.scenario.data.name().to_owned())).collect(),
            names: NAMES,
            env: plan.env.clone(),
        }
    }

    /// The unit data set `cell` played (`legacy` in a folder written before data sets).
    pub fn game(&self, cell: &CellKey) -> &str {
        self.games.iter().find(|(c, _)| c == cell).map_or("legacy", |(_, d)| d.as_str())
    }

    /// Whether `agent` is another agent's training seed.
    pub(crate) fn is_seed(&self, agent: &str) -> bool {
        self.seed_of.iter().any(|(a, _)| a == agent)
    }

    /// The agent whose last checkpoint `agent` plays (`baseline:qmix@last` is qmix's, where
    /// the plan has an agent playing `baseline:qmix`).
    pub(crate) fn last_of(&self, agent: &str) -> Option<&str> {
        let (_, _, spec) = self.agents.iter().find(|(n, _, _)| n == agent)?;
        let run = spec.strip_suffix(avacraft_marl::baselines::LAST_SUFFIX)?;
        self.agents.iter().find(|(_, _, s)| s == run).map(|(n, _, _)| n.as_str())
    }

    /// Whether `agent` is another agent's training seed or last checkpoint: a variant of
    /// it, left out where one agent stands for each learner.
    pub(crate) fn is_variant(&self, agent: &str) -> bool {
        self.is_seed(agent) || self.last_of(agent).is_some()
    }

    /// An agent's win rate on a scenario for comparing kinds: PvE against the scenario's
    /// own opponent, PvP averaged over the scripted agents it met on team 2.
    pub(crate) fn versus_scripted(&self, cells: &[crate::CellStats], scenario: &str, agent: &str) -> Option<f64> {
        let rates: Vec<f64> = cells
            .iter()
            .filter(|c| c.key.scenario == scenario && c.key.agent == agent)
            .filter(|c| c.key.against == "opponent:default" || self.kind(&c.key.against) == Some(AgentKind::Scripted))
            .map(|c| c.win_rate.mean)
            .collect();
        (!rates.is_empty()).then(|| rates.iter().sum::<f64>() / rates.len() as f64)
    }

    pub(crate) fn kind(&self, agent: &str) -> Option<AgentKind> {
        self.agents.iter().find(|(n, _, _)| n == agent).map(|(_, k, _)| *k)
    }
}

/// Checks the shards' folders of a merge (each with its `plan.json`): one plan, each shard
/// once, all of the same split. Returns the plan's metadata for the merged folder and the
/// shards that are missing (a merge of part of a plan is allowed, and said).
pub fn check_shards(shards: &[(PathBuf, Meta)]) -> Result<(Meta, Vec<Shard>), EvalError> {
    let Some((first_dir, first)) = shards.first() else {
        return Err(EvalError::Shards { dir: PathBuf::from("."), what: "no shard: name the shards' folders".into() });
    };
    let mut seen: Vec<(Shard, &PathBuf)> = Vec::new();
    let mut whole = false;
    for (dir, m) in shards {
        if m.cells != first.cells || m.seeds != first.seeds || m.name != first.name {
            return Err(EvalError::Shards {
                dir: dir.clone(),
                what: format!("the results of another plan (`{}`) than {} (`{}`)", m.name, first_dir.display(), first.name),
            });
        }
        if !m.fingerprints.is_empty() && !first.fingerprints.is_empty() && m.fingerprints != first.fingerprints {
            return Err(EvalError::Shards {
                dir: dir.clone(),
                what: format!("results of other networks or AVA settings than {} (their fingerprints differ)", first_dir.display()),
            });
        }
        match m.shard {
            None => {
                whole = true;
            }
            Some(s) => {
                if let Some((_, other)) = seen.iter().find(|(t, _)| *t == s) {
                    let how = if *other == dir { "is named twice".to_owned() } else { format!("as {} does", other.display()) };
                    return Err(EvalError::Shards { dir: dir.clone(), what: format!("shard {s}, {how}: each shard is merged once") });
                }
                if let Some((t, other)) = seen.iter().find(|(t, _)| t.count != s.count) {
                    return Err(EvalError::Shards {
                        dir: dir.clone(),
                        what: format!("shard {s}, but {} holds shard {t}: shards of one split have the same n", other.display()),
                    });
                }
                seen.push((s, dir));
            }
        }
    }
    if whole && shards.len() > 1 {
        let (dir, _) = shards.iter().find(|(_, m)| m.shard.is_none()).unwrap_or(&shards[0]);
        return Err(EvalError::Shards { dir: dir.clone(), what: "the whole plan's results: there is nothing to merge it with".into() });
    }
    let missing = match seen.first() {
        Some((s, _)) => (1..=s.count).map(|index| Shard { index, count: s.count }).filter(|s| !seen.iter().any(|(t, _)| t == s)).collect(),
        None => Vec::new(),
    };
    let mut meta = first.clone();
    meta.shard = None;
    Ok((meta, missing))
}

/// Reads an evaluation folder's `plan.json`.
pub fn read_meta(dir: &Path) -> Result<Meta, EvalError> {
    let path = dir.join(META_FILE);
    let text = std::fs::read_to_string(&path).map_err(|source| EvalError::Io { path: path.clone(), source })?;
    serde_json::from_str(&text).map_err(|source| EvalError::Meta { path, source })
}

/// Writes an evaluation folder's `plan.json`. A folder played by another plan is refused, so
/// results of two plans never mix, with one exception: the same plan grown by cells (an agent
/// added, a baseline shipped since) takes the folder over, and only the new cells are played.
pub fn write_meta(dir: &Path, meta: &Meta) -> Result<(), EvalError> {
    std::fs::create_dir_all(dir).map_err(|source| EvalError::Io { path: dir.to_path_buf(), source })?;
    let path = dir.join(META_FILE);
    if path.exists() {
        let old = read_meta(dir)?;
        if let Some(why) = cannot_extend(&old, meta) {
            return Err(EvalError::Folder { path, why });
        }
    }
    let text = serde_json::to_string_pretty(meta).map_err(|e| EvalError::Io { path: path.clone(), source: std::io::Error::other(e) })?;
    // Written aside and renamed: a torn plan.json would keep the folder's results from every
    // later run.
    avacraft_marl::aside::write_file(&path, text).map_err(|source| EvalError::Io { path, source })
}

/// Why the plan `new` cannot resume a folder that `old` played (`None`: it can). Every result
/// there must stay what `new` would have played: the same seeds and shard, each old cell
/// still in the plan, each agent's policy the same, and each trained network or AVA setting
/// the same (their fingerprints, so a checkpoint trained again is not mixed with the old one).
pub fn cannot_extend(old: &Meta, new: &Meta) -> Option<String> {
    if old.names < NAMES
        && let Some((c, now)) = old.cells.iter().find_map(|c| avacraft_engine::renamed(&c.scenario).map(|n| (c, n)))
    {
        return Some(format!(
            "its cell `{c}` played the paper's `{}`, named `{now}` since `{}` means SMAC's map: play this plan into a new folder (or name `{now}` in it)",
            c.scenario, c.scenario
        ));
    }
    if old.shard != new.shard {
        let name = |s: Option<Shard>| s.map_or_else(|| "the whole plan".to_owned(), |s| format!("shard {s}"));
        return Some(format!("its results are {}'s, not {}'s", name(old.shard), name(new.shard)));
    }
    if old.env != new.env {
        let json = |o: &avacraft_engine::EnvOptions| serde_json::to_string(o).unwrap_or_default();
        return Some(format!(
            "its results were played with the environment options {}, this plan's are {}",
            json(&old.env),
            json(&new.env)
        ));
    }
    if old.seeds != new.seeds {
        return Some(format!("its results were played on seeds {}, this plan's are {}", seed_list(&old.seeds), seed_list(&new.seeds)));
    }
    if let Some(c) = old.cells.iter().find(|c| !new.cells.contains(c)) {
        return Some(format!("its cell `{c}` is not in this plan, whose report would leave its results out"));
    }
    for (name, kind, policy) in &old.agents {
        if let Some((_, k, p)) = new.agents.iter().find(|(n, _, _)| n == name)
            && (k, p) != (kind, policy)
        {
            return Some(format!("agent `{name}` played `{policy}` ({}) there and is `{p}` ({}) here", kind.name(), k.name()));
        }
    }
    if let Some(c) = old.cells.iter().find(|c| new.cells.contains(c) && old.game(c) != new.game(c)) {
        return Some(format!("its cell `{c}` was played on the {} unit data and is {} here", old.game(c), new.game(c)));
    }
    for (agent, scenario, was) in &old.fingerprints {
        if let Some((_, _, now)) = new.fingerprints.iter().find(|(a, s, _)| a == agent && s == scenario)
            && now != was
        {
            return Some(format!(
                "agent `{agent}` on {scenario} played a policy whose fingerprint was {was} and is {now} now \
                 (a checkpoint trained or shipped again, or AVA's settings changed)"
            ));
        }
    }
    None
}

/// Seeds for a message: short lists whole, long ones by their ends.
fn seed_list(seeds: &[u64]) -> String {
    match seeds {
        [] => "none".to_owned(),
        [a, .., b] if seeds.len() > 6 => format!("{} seeds, {a} to {b}", seeds.len()),
        _ => seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", "),
    }
}

/// The fingerprint of every trained network and AVA configuration the plan plays, per agent
/// and scenario ([`avacraft_policy::PolicySpec::fingerprint`]), sorted.
pub fn fingerprints(plan: &Plan) -> Result<Vec<(String, String, String)>, EvalError> {
    let mut out = std::collections::BTreeSet::new();
    // Each (agent, scenario) once: a policy plays many cells of a scenario (opponents, pairings).
    let mut seen = std::collections::BTreeSet::new();
    for cell in &plan.cells {
        for k in std::iter::once(cell.agent).chain(cell.agent2) {
            let a = &plan.agents[k];
            let scenario = &cell.scenario.name;
            if !seen.insert((k, scenario)) {
                continue;
            }
            let fp = a.policy.fingerprint(scenario).map_err(|source| EvalError::Policy {
                agent: a.name.clone(),
                scenario: scenario.clone(),
                source: Box::new(source),
            })?;
            if let Some(fp) = fp {
                out.insert((a.name.clone(), scenario.clone(), fp));
            }
        }
    }
    Ok(out.into_iter().collect())
}
