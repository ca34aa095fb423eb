//! The one factory: a resolved policy made into fresh agents (or commanders). Only AVA has
//! state that depends on where it is used — where its model calls are recorded, whether they
//! are answered from a recording — and [`Calls`] names that, so the launch file's nodes, an
//! eval's episodes and `episode --agent ava` differ only in that argument.

use crate::PolicyError;
use crate::spec::{CommanderPolicy, PolicySpec};
use avacraft_ava::{AvaAgent, AvaCommander, AvaRun, AvaSetup, AvaSpec, CallObserver, ModelSpec};
use avacraft_engine::agent::{Agent, Commander, MakeCommander, Rotate, factory};
use avacraft_marl::MarlAgent;
use std::path::PathBuf;
use std::sync::Arc;

/// How often the scripted commander moves units (steps).
pub const ROTATE_EVERY: u32 = 4;

/// What makes a fresh agent of a policy (one per agent group, per episode). Shared, so one
/// AVA setup (one model, one accounting) can play both teams of a PvP episode.
pub type AgentFactory = Arc<dyn Fn() -> Box<dyn Agent> + Send + Sync>;

/// Where an AVA policy's model calls go for one use of it; other policies make no calls.
#[derive(Clone, Debug, Default)]
pub enum Calls {
    /// Recorded under the settings' own `record` folder in a sub-folder of this name (one
    /// per agent node of a launch file).
    Under(String),
    /// Recorded in this folder (an eval episode's, `episode`'s own).
    In(PathBuf),
    /// Where the settings say: their own `record` folder, if they name one.
    #[default]
    Own,
    /// Answered from this recording, recording nothing (an eval's replay).
    Replay(PathBuf),
}

/// A policy made for one use: its factory, and AVA's run (calls, tokens, dollars) when the
/// policy is AVA.
pub struct Made<F> {
    pub factory: F,
    pub run: Option<Arc<AvaRun>>,
}

impl<F> std::fmt::Debug for Made<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Made").field("ava", &self.run.is_some()).finish_non_exhaustive()
    }
}

/// AVA's setup for one use.
fn ava_setup(spec: &AvaSpec, calls: &Calls, observer: Option<CallObserver>) -> Result<AvaSetup, PolicyError> {
    let setup = match calls {
        Calls::Under(name) => spec.setup(spec.record.as_ref().map(|r| r.join(name)).as_deref()),
        Calls::In(dir) => spec.setup(Some(dir)),
        Calls::Own => spec.setup(None),
        Calls::Replay(dir) => {
            let mut spec = spec.clone();
            spec.model = ModelSpec::Replay { dir: dir.clone() };
            spec.record = None;
            spec.setup(None)
        }
    }
    .map_err(|e| PolicyError::Ava(Arc::new(e)))?;
    if let Some(o) = observer {
        setup.run.observe(o);
    }
    Ok(setup)
}

impl PolicySpec {
    /// Makes the policy's agents for one use (a shipped baseline must be resolved for its
    /// scenario first, with [`PolicySpec::on`]); AVA's calls go where `calls` says, and to
    /// `observer` too (an agent node publishes them).
    pub fn make(&self, calls: &Calls, observer: Option<CallObserver>) -> Result<Made<AgentFactory>, PolicyError> {
        let factory: AgentFactory = match self {
            PolicySpec::Scripted(name) => {
                // Every name in AGENTS has a factory (the engine's test checks it).
                let make = factory(name).map_err(|e| PolicyError::Unknown { name: e.0, known: String::new() })?;
                Arc::new(make)
            }
            PolicySpec::Marl(m) => {
                let (policy, name) = (Arc::clone(m.policy()?), m.name());
                Arc::new(move || Box::new(MarlAgent::new(Arc::clone(&policy), name.clone())))
            }
            PolicySpec::Ava(spec) => {
                let setup = ava_setup(spec, calls, observer)?;
                let run = Arc::clone(&setup.run);
                return Ok(Made { factory: Arc::new(move || Box::new(AvaAgent::new(setup.clone()))), run: Some(run) });
            }
            PolicySpec::Baseline(b) => return Err(PolicyError::BaselineUnresolved { name: b.name().to_owned() }),
            PolicySpec::Dds => return Err(PolicyError::Dds),
        };
        Ok(Made { factory, run: None })
    }

    /// What makes fresh agents of this policy (AVA records where its settings say).
    pub fn factory(&self) -> Result<AgentFactory, PolicyError> {
        self.make(&Calls::Own, None).map(|m| m.factory)
    }

    /// One fresh agent of this policy.
    pub fn agent(&self) -> Result<Box<dyn Agent>, PolicyError> {
        Ok(self.factory()?())
    }
}

impl CommanderPolicy {
    /// Makes the team's commanders for one use (see [`PolicySpec::make`]).
    pub fn make(&self, calls: &Calls, observer: Option<CallObserver>) -> Result<Made<MakeCommander>, PolicyError> {
        match self {
            CommanderPolicy::Rotate => {
                Ok(Made { factory: Box::new(|| Box::new(Rotate::new(ROTATE_EVERY)) as Box<dyn Commander>), run: None })
            }
            CommanderPolicy::Ava(spec) => {
                let setup = ava_setup(spec, calls, observer)?;
                let run = Arc::clone(&setup.run);
                Ok(Made { factory: Box::new(move || Box::new(AvaCommander::new(setup.clone()))), run: Some(run) })
            }
        }
    }
}
