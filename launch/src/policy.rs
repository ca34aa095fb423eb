//! Policies by name: the one parser behind every place that names one, so `episode --agent`,
//! a launch file's `policy:` (hence `launch` and `episode --launch`) and `agent-node --policy`
//! accept the same values and build the same agents. A policy is a scripted engine agent
//! (`focus-fire`, ...), a trained MARL checkpoint (`marl:DIR`, written by `avacraft train`),
//! a shipped baseline (`baseline:qmix`: the scenario's policy under `baselines/`), or `dds`
//! (an agent outside, driven over the bridge).
//!
//! Parsing `marl:DIR` loads the checkpoint, so a missing or corrupt one is refused where it
//! is named instead of surfacing as a silent no-op agent once episodes run (an engine agent
//! cannot fail at reset); [`PolicySpec::check`] then refuses one trained for another
//! scenario or team size. The loaded network is shared (`Arc`) by every agent made from it:
//! the per-unit agents of one launch entry load the file once.

use avacraft_ava::{AvaAgent, AvaRun, AvaSetup, AvaSpec, CallObserver};
use avacraft_engine::agent::{AGENTS, Agent, factory};
use avacraft_engine::{Scenario, SmacLayout, Team};
use avacraft_marl::baselines::{self, BASELINE_PREFIX, BaselineError};
use avacraft_marl::{MarlAgent, Policy};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// The prefix of a trained policy's checkpoint directory.
pub const MARL_PREFIX: &str = "marl:";
/// The policy name of agents driven from DDS through the bridge.
pub const DDS_POLICY: &str = "dds";
/// The policy name of the AVA agent (its settings come with it, see [`PolicySpec::ava`]).
pub const AVA_POLICY: &str = "ava";

/// What makes a fresh agent of a policy (one per agent group, per episode).
pub type AgentFactory = Box<dyn Fn() -> Box<dyn Agent> + Send>;

/// A validated policy name.
#[derive(Clone)]
pub enum PolicySpec {
    /// A scripted engine agent, by its name in [`AGENTS`].
    Scripted(&'static str),
    /// A trained MARL policy.
    Marl(MarlCheckpoint),
    /// A shipped baseline by run name: each scenario's own checkpoint ([`PolicySpec::on`]).
    Baseline(BaselineSet),
    /// The AVA agent with its settings.
    Ava(Arc<AvaSpec>),
    /// An agent outside, over DDS through the bridge: no agent node of ours runs it.
    Dds,
}

/// A loaded checkpoint directory.
#[derive(Clone)]
pub struct MarlCheckpoint {
    /// As resolved (absolute), so another process started from elsewhere finds it.
    dir: PathBuf,
    policy: Arc<Policy>,
}

/// `baseline:NAME`: the shipped checkpoints of one run name, loaded per scenario on first use.
#[derive(Clone)]
pub struct BaselineSet {
    name: String,
    root: PathBuf,
    loaded: Arc<Mutex<BTreeMap<String, MarlCheckpoint>>>,
}

impl std::fmt::Debug for BaselineSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BaselineSet").field("name", &self.name).field("root", &self.root).finish_non_exhaustive()
    }
}

impl BaselineSet {
    /// The run name (`qmix` of `baseline:qmix`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The checkpoint shipped for `scenario`, loaded once.
    pub fn for_scenario(&self, scenario: &str) -> Result<MarlCheckpoint, PolicyError> {
        let mut loaded = self.loaded.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(m) = loaded.get(scenario) {
            return Ok(m.clone());
        }
        let dir = baselines::dir(&self.root, scenario, &self.name).map_err(PolicyError::Baseline)?;
        let m = MarlCheckpoint::load(&dir)?;
        loaded.insert(scenario.to_owned(), m.clone());
        Ok(m)
    }
}

/// Why a policy was refused.
#[derive(Debug, thiserror::Error)]
pub enum PolicyError {
    #[error("unknown policy `{name}` (known: {known}, {MARL_PREFIX}DIR, {BASELINE_PREFIX}NAME, {DDS_POLICY})")]
    Unknown { name: String, known: String },
    #[error("`{MARL_PREFIX}` needs the directory of a checkpoint written by `avacraft train`, e.g. {MARL_PREFIX}runs/qmix-3m")]
    NoDir,
    #[error("checkpoint directory {} does not exist", dir.display())]
    MissingDir {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("checkpoint directory {} cannot be opened", dir.display())]
    Unreadable {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("checkpoint {} is not a directory", dir.display())]
    NotADir { dir: PathBuf },
    #[error("cannot load the checkpoint in {}", dir.display())]
    Checkpoint {
        dir: PathBuf,
        #[source]
        source: avacraft_marl::Error,
    },
    #[error("checkpoint {} was trained on scenario `{trained}`, not `{scenario}`", dir.display())]
    OtherScenario { dir: PathBuf, trained: String, scenario: String },
    #[error(
        "checkpoint {} was trained for {} agents, {} features and {} actions; {team} of {scenario} has {} agents, {} features and {} actions",
        dir.display(), trained.0, trained.1, trained.2, here.0, here.1, here.2
    )]
    OtherShape { dir: PathBuf, trained: (usize, usize, usize), team: Team, scenario: String, here: (usize, usize, usize) },
    #[error("shipped baseline")]
    Baseline(#[source] BaselineError),
    #[error("policy `{BASELINE_PREFIX}{name}` names each scenario's shipped policy: it is resolved for a scenario first")]
    BaselineUnresolved { name: String },
    #[error("policy `{DDS_POLICY}` is an agent outside, driven over DDS through the bridge: it cannot run here")]
    Dds,
    #[error("policy `{AVA_POLICY}` needs its settings: an `ava:` block (with at least `model:`) in the launch file or on the agent entry")]
    AvaWithoutSpec,
    #[error("policy `{AVA_POLICY}`")]
    Ava(#[source] Arc<avacraft_ava::SpecError>),
}

impl MarlCheckpoint {
    /// Loads the checkpoint in `dir` (resolved to an absolute path first).
    pub fn load(dir: &Path) -> Result<MarlCheckpoint, PolicyError> {
        let abs = std::fs::canonicalize(dir).map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound => PolicyError::MissingDir { dir: dir.to_path_buf(), source },
            _ => PolicyError::Unreadable { dir: dir.to_path_buf(), source },
        })?;
        if !abs.is_dir() {
            return Err(PolicyError::NotADir { dir: abs });
        }
        let policy = Policy::load(&abs).map_err(|source| PolicyError::Checkpoint { dir: abs.clone(), source })?;
        Ok(MarlCheckpoint { dir: abs, policy: Arc::new(policy) })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn policy(&self) -> &Arc<Policy> {
        &self.policy
    }

    /// Refuses a checkpoint trained on another scenario, or whose network does not fit
    /// `team`'s agents there (team size, feature and action counts): it would read other
    /// features, and [`MarlAgent`] gives no orders at all then.
    pub fn check(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        if self.policy.scenario != scenario.name {
            return Err(PolicyError::OtherScenario {
                dir: self.dir.clone(),
                trained: self.policy.scenario.clone(),
                scenario: scenario.name.clone(),
            });
        }
        // The sizes MarlAgent checks at reset (`Policy::check_scenario`), named.
        let l = SmacLayout::new(scenario, team);
        let s = self.policy.shape;
        let (trained, here) = ((s.n_agents, s.obs, s.n_actions), (l.n_agents, l.obs_size, l.n_actions));
        if trained != here || self.policy.check_scenario(scenario, team).is_err() {
            return Err(PolicyError::OtherShape { dir: self.dir.clone(), trained, team, scenario: scenario.name.clone(), here });
        }
        Ok(())
    }

    /// The agent's name: `marl:DIR`.
    pub fn name(&self) -> String {
        format!("{MARL_PREFIX}{}", self.dir.display())
    }
}

impl std::fmt::Debug for MarlCheckpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Not the weights.
        f.debug_struct("MarlCheckpoint")
            .field("dir", &self.dir)
            .field("scenario", &self.policy.scenario)
            .field("algo", &self.policy.cfg.algo)
            .field("shape", &self.policy.shape)
            .finish()
    }
}

impl PolicySpec {
    /// Parses a policy name; a relative `marl:DIR` is resolved against `base` (a launch
    /// file's directory), or the working directory without one.
    pub fn parse(text: &str, base: Option<&Path>) -> Result<PolicySpec, PolicyError> {
        if text == DDS_POLICY {
            return Ok(PolicySpec::Dds);
        }
        if text == AVA_POLICY {
            return Err(PolicyError::AvaWithoutSpec);
        }
        if let Some(name) = text.strip_prefix(BASELINE_PREFIX) {
            baselines::check_name(name).map_err(PolicyError::Baseline)?;
            return Ok(PolicySpec::Baseline(BaselineSet {
                name: name.to_owned(),
                root: baselines::root(),
                loaded: Arc::new(Mutex::new(BTreeMap::new())),
            }));
        }
        if let Some(dir) = text.strip_prefix(MARL_PREFIX) {
            if dir.trim().is_empty() {
                return Err(PolicyError::NoDir);
            }
            let dir = Path::new(dir);
            let dir = match base {
                Some(b) if dir.is_relative() => b.join(dir),
                _ => dir.to_path_buf(),
            };
            return MarlCheckpoint::load(&dir).map(PolicySpec::Marl);
        }
        match AGENTS.iter().find(|(n, _)| *n == text) {
            Some((name, _)) => Ok(PolicySpec::Scripted(name)),
            None => {
                Err(PolicyError::Unknown { name: text.to_owned(), known: AGENTS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ") })
            }
        }
    }

    /// The policy as it plays `scenario`: a shipped baseline becomes that scenario's
    /// checkpoint (refused if none is shipped); any other policy is itself.
    pub fn on(&self, scenario: &Scenario) -> Result<PolicySpec, PolicyError> {
        match self {
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name).map(PolicySpec::Marl),
            other => Ok(other.clone()),
        }
    }

    pub fn is_dds(&self) -> bool {
        matches!(self, PolicySpec::Dds)
    }

    /// The AVA agent with `spec` (checked here, so a bad setting is refused where it is named).
    pub fn ava(spec: AvaSpec) -> Result<PolicySpec, PolicyError> {
        spec.validate().map_err(|e| PolicyError::Ava(Arc::new(e)))?;
        Ok(PolicySpec::Ava(Arc::new(spec)))
    }

    /// [`PolicySpec::factory`] for the agent node `agent`: AVA records each node's calls in
    /// its own folder under the spec's (`record/<agent>`).
    pub fn factory_for(&self, agent: &str) -> Result<AgentFactory, PolicyError> {
        self.factory_observed(agent, None)
    }

    /// [`PolicySpec::factory_for`], with AVA's calls also handed to `observer` (an agent
    /// node publishes them); other policies make no calls.
    pub fn factory_observed(&self, agent: &str, observer: Option<CallObserver>) -> Result<AgentFactory, PolicyError> {
        self.factory_run(agent, observer).map(|(f, _)| f)
    }

    /// [`PolicySpec::factory_observed`], and for AVA its run (the node's accounting), so that
    /// a caller playing the launch file in-process can report each node's costs.
    pub fn factory_run(&self, agent: &str, observer: Option<CallObserver>) -> Result<(AgentFactory, Option<Arc<AvaRun>>), PolicyError> {
        match self {
            PolicySpec::Ava(spec) => {
                let setup = ava_setup(spec, agent, observer)?;
                let run = setup.run.clone();
                Ok((Box::new(move || Box::new(AvaAgent::new(setup.clone()))), Some(run)))
            }
            other => Ok((other.factory()?, None)),
        }
    }

    /// Refuses a policy that cannot play `team` in `scenario` (a checkpoint of another
    /// scenario or size); scripted agents and DDS agents play anything.
    pub fn check(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.check(scenario, team),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.check(scenario, team),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(()),
        }
    }

    /// What makes fresh agents of this policy; a trained one shares its loaded network.
    pub fn factory(&self) -> Result<AgentFactory, PolicyError> {
        match self {
            PolicySpec::Scripted(name) => {
                // Every name in AGENTS has a factory (the engine's test checks it).
                let make = factory(name).map_err(|e| PolicyError::Unknown { name: e.0, known: String::new() })?;
                Ok(Box::new(make))
            }
            PolicySpec::Marl(m) => {
                let (policy, name) = (Arc::clone(&m.policy), m.name());
                Ok(Box::new(move || Box::new(MarlAgent::new(Arc::clone(&policy), name.clone()))))
            }
            PolicySpec::Ava(spec) => {
                let setup = spec.setup(None).map_err(|e| PolicyError::Ava(Arc::new(e)))?;
                Ok(Box::new(move || Box::new(AvaAgent::new(setup.clone()))))
            }
            PolicySpec::Baseline(b) => Err(PolicyError::BaselineUnresolved { name: b.name.clone() }),
            PolicySpec::Dds => Err(PolicyError::Dds),
        }
    }

    /// One fresh agent of this policy.
    pub fn agent(&self) -> Result<Box<dyn Agent>, PolicyError> {
        Ok(self.factory()?())
    }
}

/// AVA's setup for the agent node `agent`: calls recorded under `record/<agent>`.
pub(crate) fn ava_setup(spec: &AvaSpec, agent: &str, observer: Option<CallObserver>) -> Result<AvaSetup, PolicyError> {
    let record = spec.record.as_ref().map(|r| r.join(agent));
    let setup = spec.setup(record.as_deref()).map_err(|e| PolicyError::Ava(Arc::new(e)))?;
    if let Some(o) = observer {
        setup.run.observe(o);
    }
    Ok(setup)
}

/// The text [`PolicySpec::parse`] reads back to the same policy (a checkpoint by its
/// absolute path): what `launch` hands the agent-node processes.
impl std::fmt::Display for PolicySpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PolicySpec::Scripted(name) => f.write_str(name),
            PolicySpec::Marl(m) => f.write_str(&m.name()),
            PolicySpec::Baseline(b) => write!(f, "{BASELINE_PREFIX}{}", b.name),
            PolicySpec::Ava(_) => f.write_str(AVA_POLICY),
            PolicySpec::Dds => f.write_str(DDS_POLICY),
        }
    }
}

impl std::fmt::Debug for PolicySpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PolicySpec::Scripted(name) => f.debug_tuple("Scripted").field(name).finish(),
            PolicySpec::Marl(m) => f.debug_tuple("Marl").field(m).finish(),
            PolicySpec::Baseline(b) => f.debug_tuple("Baseline").field(&b.name).finish(),
            PolicySpec::Ava(s) => f.debug_tuple("Ava").field(&s.model.label()).finish(),
            PolicySpec::Dds => f.write_str("Dds"),
        }
    }
}

/// Equal when they name the same policy (checkpoints: the same directory).
impl PartialEq for PolicySpec {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (PolicySpec::Scripted(a), PolicySpec::Scripted(b)) => a == b,
            (PolicySpec::Marl(a), PolicySpec::Marl(b)) => a.dir == b.dir,
            (PolicySpec::Baseline(a), PolicySpec::Baseline(b)) => a.name == b.name && a.root == b.root,
            (PolicySpec::Dds, PolicySpec::Dds) => true,
            (PolicySpec::Ava(a), PolicySpec::Ava(b)) => a == b,
            _ => false,
        }
    }
}

impl Eq for PolicySpec {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LaunchError, parse};
    use avacraft_engine::{Env, Mode};

    /// The committed 3m checkpoint (launch/policies/3m), whichever run wrote it.
    fn shipped() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("policies/3m")
    }

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("avacraft-launch-policy-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        d
    }

    /// A copy of the shipped checkpoint with `edit` applied to its config.json.
    fn edited(name: &str, edit: impl Fn(&mut serde_json::Value)) -> PathBuf {
        let d = tmp(name);
        for f in ["agent.safetensors", "mixer.safetensors", "config.json"] {
            if shipped().join(f).exists() {
                std::fs::copy(shipped().join(f), d.join(f)).expect("copy");
            }
        }
        let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("config.json")).expect("read")).expect("json");
        edit(&mut v);
        std::fs::write(d.join("config.json"), v.to_string()).expect("write");
        d
    }

    /// The error and its sources, as `anyhow` prints them with `{:#}`.
    fn chain(e: &dyn std::error::Error) -> String {
        let mut s = e.to_string();
        let mut src = e.source();
        while let Some(x) = src {
            s.push_str(": ");
            s.push_str(&x.to_string());
            src = x.source();
        }
        s
    }

    fn launch(scenario: &str, policy: &str) -> String {
        format!("scenario: {scenario}\nagents:\n  - per_unit: true\n    team: 1\n    policy: {policy}\n")
    }

    #[test]
    fn marl_policies_resolve_against_the_launch_file_and_share_one_network() {
        let base = Path::new(env!("CARGO_MANIFEST_DIR"));
        let plan = parse("m.yaml", &launch("3m", "marl:policies/3m"), Some(base)).unwrap_or_else(|e| panic!("{}", chain(&e)));
        assert_eq!(plan.agents.len(), 3);
        let nets: Vec<&Arc<Policy>> = plan
            .agents
            .iter()
            .map(|a| match &a.policy {
                PolicySpec::Marl(m) => m.policy(),
                other => panic!("{other:?}"),
            })
            .collect();
        assert!(nets.iter().all(|p| Arc::ptr_eq(p, nets[0])), "one load for the entry's nodes");
        // What `launch` hands the agent nodes parses back to the same checkpoint, from anywhere.
        let text = plan.agents[0].policy.to_string();
        assert!(text.starts_with("marl:/"), "{text}");
        assert_eq!(PolicySpec::parse(&text, None).expect("reparse"), plan.agents[0].policy);
        // An absolute directory, and a role group of two units, are fine too.
        let abs = format!("marl:{}", shipped().display());
        let groups =
            "scenario: 3m\nagents:\n  - {id: pair, units: [1, 2], policy: POLICY}\n  - {id: solo, units: [3], policy: focus-fire}\n";
        parse("g.yaml", &groups.replace("POLICY", &abs), None).unwrap_or_else(|e| panic!("{}", chain(&e)));
    }

    #[test]
    fn a_marl_plan_plays_in_process_with_one_network_per_unit() {
        let plan = parse("m.yaml", &launch("3m", &format!("marl:{}", shipped().display())), None).expect("plan");
        let noop = parse("n.yaml", &launch("3m", "noop"), None).expect("plan");
        let play = |p: &crate::Plan| {
            let mut c = p.controllers().expect("controllers");
            let mut env = Env::new(Arc::clone(&p.scenario), p.env_config(), 3);
            c.reset(&env);
            while !env.done() {
                c.act(&mut env);
                env.step();
            }
            env.trajectory_hash()
        };
        assert_eq!(plan.scenario.mode, Mode::Pve);
        assert_ne!(play(&plan), play(&noop), "the network gives orders");
    }

    #[test]
    fn bad_marl_policies_name_the_field_and_why() {
        let garbage = tmp("garbage");
        std::fs::write(garbage.join("config.json"), "{ not json").expect("write");
        let no_weights = edited("no_weights", |_| {});
        std::fs::remove_file(no_weights.join("agent.safetensors")).expect("remove");
        let bad_weights = edited("bad_weights", |_| {});
        std::fs::write(bad_weights.join("agent.safetensors"), b"\x08\0\0\0\0\0\0\0{}garbage").expect("write");
        let renamed = edited("renamed", |v| v["scenario"] = "2m_vs_1z".into());
        let file = tmp("file").join("config.json");
        std::fs::write(&file, "{}").expect("write");
        let s = |p: &Path| format!("marl:{}", p.display());
        let cases: Vec<(String, String, &str)> = vec![
            (launch("3m", "\"marl:\""), "marl:".into(), "needs the directory of a checkpoint"),
            (launch("3m", "marl:/nonexistent/ckpt"), "/nonexistent/ckpt".into(), "does not exist"),
            (launch("3m", &s(&file)), "config.json".into(), "is not a directory"),
            (launch("3m", &s(&garbage)), "config.json".into(), "cannot load the checkpoint"),
            (launch("3m", &s(&no_weights)), "agent.safetensors is missing".into(), "cannot load the checkpoint"),
            (launch("3m", &s(&bad_weights)), "bad_weights: tensor operation failed".into(), "cannot load the checkpoint"),
            (launch("2m_vs_1z", &s(&shipped())), "trained on scenario `3m`, not `2m_vs_1z`".into(), "trained on"),
            (launch("2m_vs_1z", &s(&renamed)), "3 agents".into(), "team 1 of 2m_vs_1z has 2 agents"),
            (launch("3m", "marl-ish"), "unknown policy `marl-ish`".into(), "marl:DIR"),
        ];
        for (text, says, why) in cases {
            let e = parse("bad.yaml", &text, None).expect_err(&text);
            assert!(matches!(e, LaunchError::Policy { .. }), "{e:?}");
            let msg = chain(&e);
            assert!(msg.starts_with("bad.yaml: field `agents[0].policy` = \""), "{msg}");
            assert!(msg.contains(&says) && msg.contains(why), "{text}: {msg}");
        }
        for d in [garbage, no_weights, bad_weights, renamed, file.parent().map(Path::to_path_buf).unwrap_or_default()] {
            let _ = std::fs::remove_dir_all(d);
        }
    }

    #[test]
    fn dds_and_scripted_policies_parse_and_dds_cannot_run_here() {
        assert_eq!(PolicySpec::parse("focus-fire", None).expect("scripted").to_string(), "focus-fire");
        let dds = PolicySpec::parse(DDS_POLICY, None).expect("dds");
        assert!(dds.is_dds() && matches!(dds.factory(), Err(PolicyError::Dds)));
    }
}
