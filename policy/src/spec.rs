//! Policy names and their settings, resolved once: a scripted engine agent (`focus-fire`,
//! ...), a trained checkpoint (`marl:DIR`), a shipped baseline (`baseline:qmix`, each
//! scenario's own checkpoint), the AVA agent (`ava` with its [`AvaSpec`]) or `dds` (an agent
//! outside, driven over the bridge). Launch files, eval plans, `episode --agent`, agent nodes
//! and Python all go through [`PolicySpec::resolve`], so they accept the same names, refuse
//! the same mistakes with the same words, and build the same agents.

use crate::PolicyError;
use crate::checkpoint::{BaselineSet, MarlCheckpoint, Weights};
use crate::names::{AVA_POLICY, DDS_POLICY, MARL_PREFIX, ROTATE_POLICY};
use avacraft_ava::AvaSpec;
use avacraft_engine::agent::{AGENTS, FrameNeed};
use avacraft_engine::{Scenario, Team};
use avacraft_marl::baselines::BASELINE_PREFIX;
use std::path::Path;
use std::sync::Arc;

/// How names are resolved: a relative `marl:DIR` (and AVA's files) against `base` (a launch
/// file's or plan's folder; the working directory without one), and when weights are read.
#[derive(Clone, Copy, Debug, Default)]
pub struct Resolve<'a> {
    pub base: Option<&'a Path>,
    pub weights: Weights,
}

impl<'a> Resolve<'a> {
    pub fn against(base: Option<&'a Path>) -> Self {
        Resolve { base, weights: Weights::Load }
    }
}

/// A validated policy.
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

/// What commands a team whose units change role groups.
#[derive(Clone, Debug, PartialEq)]
pub enum CommanderPolicy {
    /// AVA's planner, roles and priorities.
    Ava(Arc<AvaSpec>),
    /// Hands every unit to the next group every [`crate::ROTATE_EVERY`] steps (tests, demonstrations).
    Rotate,
}

/// AVA's settings, checked, with their files resolved against `base`.
fn ava_spec(mut spec: AvaSpec, how: Resolve<'_>) -> Result<Arc<AvaSpec>, PolicyError> {
    if let Some(b) = how.base {
        spec.resolve(b);
    }
    spec.validate().map_err(|e| PolicyError::Ava(Arc::new(e)))?;
    Ok(Arc::new(spec))
}

impl PolicySpec {
    /// The one resolution of a policy: its name, and AVA's settings when the name is `ava`
    /// (refused with any other name, and required with that one).
    pub fn resolve(text: &str, ava: Option<AvaSpec>, how: Resolve<'_>) -> Result<PolicySpec, PolicyError> {
        match (text, ava) {
            (AVA_POLICY, Some(spec)) => return ava_spec(spec, how).map(PolicySpec::Ava),
            (AVA_POLICY, None) => return Err(PolicyError::AvaWithoutSpec),
            (_, Some(_)) => return Err(PolicyError::SpecWithoutAva { policy: text.to_owned() }),
            (_, None) => {}
        }
        if text == DDS_POLICY {
            return Ok(PolicySpec::Dds);
        }
        if let Some(name) = text.strip_prefix(BASELINE_PREFIX) {
            return BaselineSet::new(name, how.weights).map(PolicySpec::Baseline);
        }
        if let Some(dir) = text.strip_prefix(MARL_PREFIX) {
            if dir.trim().is_empty() {
                return Err(PolicyError::NoDir);
            }
            let dir = Path::new(dir);
            let dir = match how.base {
                Some(b) if dir.is_relative() => b.join(dir),
                _ => dir.to_path_buf(),
            };
            return MarlCheckpoint::open(&dir, how.weights).map(PolicySpec::Marl);
        }
        match AGENTS.iter().find(|(n, _)| *n == text) {
            Some((name, _)) => Ok(PolicySpec::Scripted(name)),
            None => {
                Err(PolicyError::Unknown { name: text.to_owned(), known: AGENTS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ") })
            }
        }
    }

    /// A policy named without settings (anything but `ava`), weights read now.
    pub fn parse(text: &str, base: Option<&Path>) -> Result<PolicySpec, PolicyError> {
        Self::resolve(text, None, Resolve::against(base))
    }

    /// The settings that go with the name, so that
    /// `resolve(&p.to_string(), p.ava_spec().cloned(), ..)` is `p` again.
    pub fn ava_spec(&self) -> Option<&AvaSpec> {
        match self {
            PolicySpec::Ava(s) => Some(s),
            _ => None,
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

    /// What identifies the policy's play on `scenario` beyond its name: a trained
    /// network's file hash ([`MarlCheckpoint::fingerprint`]; a baseline's for that scenario)
    /// or a hash of AVA's settings (`ava` names every model and configuration alike).
    /// `None` for scripted and DDS agents, whose name says it all.
    pub fn fingerprint(&self, scenario: &str) -> Result<Option<String>, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.fingerprint().map(Some),
            PolicySpec::Baseline(b) => b.for_scenario(scenario)?.fingerprint().map(Some),
            PolicySpec::Ava(spec) => {
                // Settings always serialise (no map with other than string keys); the debug
                // form would do as well.
                let bytes = serde_json::to_vec(spec.as_ref()).unwrap_or_else(|_| format!("{spec:?}").into_bytes());
                Ok(Some(format!("xxh3:{:016x}", xxhash_rust::xxh3::xxh3_64(&bytes))))
            }
            PolicySpec::Scripted(_) | PolicySpec::Dds => Ok(None),
        }
    }

    /// The network when this policy plays `scenario`'s team 1 from rendered frames (an
    /// image-mode checkpoint, which engine agents cannot play; an evaluation plays it with
    /// [`avacraft_marl::Policy::play_out`]). `None` for every other policy.
    pub fn frames_policy(&self, scenario: &Scenario) -> Result<Option<Arc<avacraft_marl::Policy>>, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.frames_policy(scenario),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.frames_policy(scenario),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(None),
        }
    }

    pub fn is_dds(&self) -> bool {
        matches!(self, PolicySpec::Dds)
    }

    /// What the policy reads of its observations ([`avacraft_engine::agent::Agent::reads`]),
    /// known without loading anything: a scripted agent says; trained networks, AVA and DDS
    /// agents (which are not ours to ask) get everything.
    pub fn reads(&self) -> avacraft_engine::agent::Reads {
        match self {
            PolicySpec::Scripted(name) => avacraft_engine::agent::by_name(name).map_or(avacraft_engine::agent::Reads::ALL, |a| a.reads()),
            PolicySpec::Marl(_) | PolicySpec::Baseline(_) | PolicySpec::Ava(_) | PolicySpec::Dds => avacraft_engine::agent::Reads::ALL,
        }
    }

    /// The unit data a trained network learned on (`None` for scripted agents, AVA and DDS,
    /// which play any). A network played on another set still plays, a different game.
    pub fn trained_data(&self, scenario: &Scenario) -> Result<Option<avacraft_engine::DataSet>, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.trained_data().map(Some),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.trained_data().map(Some),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(None),
        }
    }

    /// Where weapons' periods were counted from in the games a network learned (`None`: not a
    /// network).
    pub fn trained_weapon_period(&self, scenario: &Scenario) -> Result<Option<avacraft_engine::WeaponPeriod>, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.trained_weapon_period().map(Some),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.trained_weapon_period().map(Some),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(None),
        }
    }

    /// Whether the policy learned under the surround experiment (`None`: not a network).
    pub fn trained_melee_surround(&self, scenario: &Scenario) -> Result<Option<bool>, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.trained_melee_surround().map(Some),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.trained_melee_surround().map(Some),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(None),
        }
    }

    /// Whether the policy's network reads the ability slots, so that the game it plays in
    /// must have them (`EnvConfig::ability_actions`); every other policy plays with or
    /// without them.
    pub fn ability_actions(&self, scenario: &Scenario) -> Result<bool, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.ability_actions(),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.ability_actions(),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(false),
        }
    }

    /// Refuses a policy that cannot play `team` in `scenario` (a checkpoint of another
    /// scenario or size); scripted agents, AVA and DDS agents play anything.
    pub fn check(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.check(scenario, team),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.check(scenario, team),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(()),
        }
    }

    /// [`PolicySpec::check`] where the agent is shown its team's frames before each step
    /// (an agent node of a launch file, `episode --launch`): an `rgb` or `hybrid`
    /// checkpoint plays team 1 there too.
    pub fn check_seeing(&self, scenario: &Scenario, team: Team) -> Result<(), PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.check_seeing(scenario, team),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.check_seeing(scenario, team),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(()),
        }
    }

    /// The frames the policy reads (an image-mode checkpoint's screen and minimap sizes,
    /// from its `config.json` alone: a process that never acts reads no weights).
    pub fn frames_need(&self, scenario: &Scenario) -> Result<Option<FrameNeed>, PolicyError> {
        match self {
            PolicySpec::Marl(m) => m.frames_need(),
            PolicySpec::Baseline(b) => b.for_scenario(&scenario.name)?.frames_need(),
            PolicySpec::Scripted(_) | PolicySpec::Dds | PolicySpec::Ava(_) => Ok(None),
        }
    }
}

impl CommanderPolicy {
    /// A commander's policy: `rotate`, or `ava` with its settings.
    pub fn resolve(text: &str, ava: Option<AvaSpec>, how: Resolve<'_>) -> Result<CommanderPolicy, PolicyError> {
        match (text, ava) {
            (ROTATE_POLICY, None) => Ok(CommanderPolicy::Rotate),
            (AVA_POLICY, Some(spec)) => ava_spec(spec, how).map(CommanderPolicy::Ava),
            (AVA_POLICY, None) => Err(PolicyError::AvaWithoutSpec),
            (_, Some(_)) => Err(PolicyError::SpecWithoutAva { policy: text.to_owned() }),
            (_, None) => Err(PolicyError::NotACommander { policy: text.to_owned() }),
        }
    }

    /// The settings that go with the name (see [`PolicySpec::ava_spec`]).
    pub fn ava_spec(&self) -> Option<&AvaSpec> {
        match self {
            CommanderPolicy::Ava(s) => Some(s),
            CommanderPolicy::Rotate => None,
        }
    }
}

/// The name [`PolicySpec::resolve`] reads back, with [`PolicySpec::ava_spec`], to the same
/// policy (a checkpoint by its absolute path).
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

impl std::fmt::Display for CommanderPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CommanderPolicy::Ava(_) => AVA_POLICY,
            CommanderPolicy::Rotate => ROTATE_POLICY,
        })
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
            (PolicySpec::Marl(a), PolicySpec::Marl(b)) => a.dir() == b.dir(),
            (PolicySpec::Baseline(a), PolicySpec::Baseline(b)) => a.name == b.name && a.root == b.root,
            (PolicySpec::Dds, PolicySpec::Dds) => true,
            (PolicySpec::Ava(a), PolicySpec::Ava(b)) => a == b,
            _ => false,
        }
    }
}

impl Eq for PolicySpec {}
