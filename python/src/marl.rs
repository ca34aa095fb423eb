//! A trained MARL policy for Python loops: `avacraft.MarlPolicy(dir)` loads a checkpoint of
//! `avacraft train` and acts for every agent of a team from the SMAC observations and masks
//! Python holds (`StarCraft2Env.get_obs()`, `get_avail_actions()`, or `parallel_env`'s
//! dicts through the Python wrapper). It computes what `avacraft_marl::MarlAgent` computes
//! for one agent driving the whole team (`avacraft episode --agent marl:DIR`): all agents'
//! rows through the network at once, in agent order, dead agents included, each with its
//! own GRU state and last action, then the greedy available action. So a Python loop plays
//! the Rust agent's episodes, action for action; [`PyMarlPolicy::play`] runs that Rust
//! agent, to check it. Playing team 2, the network sees and acts in the mirror image, as
//! `MarlAgent` does (it was trained as team 1).

use crate::env::PyEnv;
use crate::error::{AvacraftError, PolicyError};
use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Mode, Outcome, Scenario, SmacLayout, Team};
use avacraft_marl::{FramesActor, MarlAgent, ObsKind, Policy, select_actions};
use avacraft_policy::MarlCheckpoint;
use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;
use std::sync::Arc;

/// A trained policy acting greedily for a team's agents, with their GRU states.
#[pyclass(module = "avacraft._avacraft", name = "MarlPolicy", subclass)]
#[derive(Debug)]
pub struct PyMarlPolicy {
    policy: Arc<Policy>,
    checkpoint: MarlCheckpoint,
    /// n_agents x the policy's memory (its hidden state and, stacking, its last observations:
    /// `Policy::memory_width`), and each agent's last action (none before the first step).
    hidden: Vec<f32>,
    last: Vec<Option<u32>>,
    /// Team 2's layout on the trained scenario, loaded when team 2 first acts (to mirror).
    mirror: Option<SmacLayout>,
    /// `act_env`'s actor (frames rendered from the game, its own hidden states), made on
    /// first use.
    frames: Option<FramesActor>,
}

impl PyMarlPolicy {
    fn check(&self, env: &avacraft_engine::Env, team: Team) -> Result<(), PolicyError> {
        Ok(self.checkpoint.check(env.scenario(), team)?)
    }

    /// The policy of a checkpoint the registry opened.
    pub(crate) fn from_checkpoint(checkpoint: MarlCheckpoint) -> Result<Self, PolicyError> {
        let policy = Arc::clone(checkpoint.policy()?);
        let n = policy.shape.n_agents;
        let width = policy.memory_width();
        Ok(Self { policy, checkpoint, hidden: vec![0.0; n * width], last: vec![None; n], mirror: None, frames: None })
    }

    fn dir(&self) -> String {
        self.checkpoint.dir().display().to_string()
    }

    /// Refuses an image checkpoint where only SMAC features are handed over.
    fn features_only(&self, method: &'static str) -> Result<(), PolicyError> {
        match self.policy.cfg.obs {
            ObsKind::Features => Ok(()),
            obs => Err(PolicyError::NeedsFrames { dir: self.dir(), obs: obs.name(), method }),
        }
    }

    /// Checks that team 1 of `env` fits and that the scenario is PvE for an image checkpoint
    /// (its frames are team 1's, and no mirror image of them is drawn).
    fn check_frames(&self, env: &avacraft_engine::Env) -> Result<(), PolicyError> {
        if self.policy.cfg.obs != ObsKind::Features && env.scenario().mode == Mode::Pvp {
            return Err(PolicyError::FramesPvp { dir: self.dir(), obs: self.policy.cfg.obs.name(), scenario: env.scenario().name.clone() });
        }
        match self.checkpoint.frames_policy(env.scenario())? {
            Some(_) => Ok(()),
            None => self.check(env, Team::One),
        }
    }

    /// Team 2's layout, for the mirror image.
    fn mirror_layout(&mut self) -> PyResult<&SmacLayout> {
        if self.mirror.is_none() {
            let name = &self.policy.scenario;
            let s = Scenario::load(name).map_err(|e| {
                AvacraftError::new_err(format!(
                    "team=2 mirrors the observations on the trained scenario {name:?}, which does not load: {e}"
                ))
            })?;
            self.mirror = Some(self.policy.layout(&s, Team::Two));
        }
        Ok(self.mirror.get_or_insert_with(|| unreachable!("set above")))
    }
}

#[pymethods]
impl PyMarlPolicy {
    /// Loads the checkpoint in `path` (`agent.safetensors`, `config.json`).
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        Ok(Self::from_checkpoint(MarlCheckpoint::load(&path).map_err(PolicyError::from)?)?)
    }

    /// The scenario it was trained on.
    #[getter]
    fn scenario(&self) -> String {
        self.policy.scenario.clone()
    }
    #[getter]
    fn algo(&self) -> String {
        self.policy.cfg.algo.clone()
    }
    /// The observation mode it was trained on (`features`, `rgb`, `hybrid`, `vision-text`).
    #[getter]
    fn obs(&self) -> &'static str {
        self.policy.cfg.obs.name()
    }
    #[getter]
    fn n_agents(&self) -> usize {
        self.policy.shape.n_agents
    }
    #[getter]
    fn obs_size(&self) -> usize {
        self.policy.shape.obs
    }
    #[getter]
    fn n_actions(&self) -> usize {
        self.policy.shape.n_actions
    }

    /// Forgets the GRU states and last actions: call it when an episode starts.
    fn reset(&mut self) {
        self.hidden.iter_mut().for_each(|h| *h = 0.0);
        self.last.iter_mut().for_each(|l| *l = None);
        if let Some(f) = self.frames.as_mut() {
            f.reset();
        }
    }

    /// Raises `AvacraftError` unless the policy can play `team` of `env`'s scenario (the
    /// scenario it was trained on, with its sizes).
    #[pyo3(signature = (env, team=1))]
    fn check_env(&self, env: &Bound<'_, PyEnv>, team: u8) -> PyResult<()> {
        let team = crate::env::team(team)?;
        let mut e = env.borrow_mut();
        Ok(self.check(e.engine(), team)?)
    }

    /// Greedy actions (int64, one per agent) for one step from every agent's SMAC features
    /// (`n_agents x obs_size` float32) and masks (`n_agents x n_actions` uint8), agents in
    /// SMAC order, dead ones included; advances each agent's GRU state. `team=2` plays team
    /// 2 of a PvP scenario in the mirror image, as `MarlAgent` does.
    #[pyo3(signature = (obs, avail, team=1))]
    fn act<'py>(
        &mut self,
        py: Python<'py>,
        obs: PyReadonlyArray2<'py, f32>,
        avail: PyReadonlyArray2<'py, u8>,
        team: u8,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let team = crate::env::team(team)?;
        self.features_only("act(obs, avail)")?;
        let sh = self.policy.shape;
        let n = sh.n_agents;
        for (what, a, cols, what_size) in [("obs", obs.shape(), sh.obs, "obs_size"), ("avail", avail.shape(), sh.n_actions, "n_actions")] {
            if a != [n, cols] {
                return Err(PolicyError::Shape { what, given: a.to_vec(), needed: [n, cols], what_size }.into());
            }
        }
        let mut features: Vec<f32> = obs.as_array().iter().copied().collect();
        let mut mask: Vec<u8> = avail.as_array().iter().map(|&m| u8::from(m != 0)).collect();
        let mirror = team == Team::Two;
        if mirror {
            let layout = self.mirror_layout()?;
            features.chunks_exact_mut(sh.obs.max(1)).for_each(|f| layout.mirror_obs(f));
            mask.chunks_exact_mut(sh.n_actions.max(1)).for_each(SmacLayout::mirror_avail);
        }
        if let Some(agent) = mask.chunks(sh.n_actions.max(1)).position(|row| row.iter().all(|&m| m == 0)) {
            return Err(PolicyError::NoAction { agent }.into());
        }
        let agents: Vec<usize> = (0..n).collect();
        let (q, h2) = self.policy.q_values(&features, &agents, &self.last, &self.hidden).map_err(|e| PolicyError::Network(Box::new(e)))?;
        // Greedy, as MarlAgent: epsilon 0 never draws from the stream.
        let acts = select_actions(&q, &mask, sh.n_actions, 0.0, &mut ChaCha8Rng::seed_from_u64(0));
        self.hidden = h2;
        for (l, &a) in self.last.iter_mut().zip(&acts) {
            *l = Some(a);
        }
        // The network's own action (in its image) stays its next last-action input.
        // `mirror_layout` above filled `self.mirror` when playing team 2.
        let layout = self.mirror.as_ref().filter(|_| mirror);
        let out = acts.into_iter().map(|a| layout.map_or(i64::from(a), |l| l.mirror_action(a as usize) as i64));
        Ok(PyArray1::from_vec(py, out.collect()))
    }

    /// Greedy actions (int64, one per agent, dead agents' no-op included) for team 1 of
    /// `env`'s next step, from what the network reads in its own observation mode: an image
    /// checkpoint's frames (and text) are rendered from the game as in training's test
    /// episodes, with its SMAC features and masks. Any checkpoint plays this way (a
    /// `features` one reads the same features `act` is handed). Advances the agents' hidden
    /// states, kept apart from `act`'s: call once per step, and `reset()` at an episode's start.
    fn act_env<'py>(&mut self, py: Python<'py>, env: &Bound<'py, PyEnv>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let mut e = env.borrow_mut();
        let env = e.engine();
        self.check_frames(env)?;
        let network = |e| PolicyError::Network(Box::new(e));
        let actor = match self.frames.take() {
            Some(a) => a,
            None => FramesActor::new(Arc::clone(&self.policy), env.scenario()).map_err(network)?,
        };
        let acts = self.frames.insert(actor).choose(env).map_err(network)?;
        Ok(PyArray1::from_vec(py, acts.into_iter().map(|a| a as i64).collect()))
    }

    /// Plays one episode of `env` from `seed` in Rust with `avacraft_marl::MarlAgent` for
    /// team 1 (what `avacraft episode --agent marl:DIR` runs), and in PvP for team 2 too
    /// (`--agent2 marl:DIR`, in the mirror image), leaving `env` at its end: the reference a
    /// Python loop with `act` reproduces. Returns `{"result": "win" | "loss" | "draw" (team
    /// 1's), "steps", "trajectory_hash", "actions"}` and in PvP `"actions2"`, holding per
    /// step the SMAC index of each agent's order (-1: none, a dead unit). Frames are not
    /// recorded. This policy's own GRU states are left alone.
    ///
    /// The trajectory hash is the typed-action path's: it records no last action for dead
    /// units, where a SMAC loop records their no-op, so it differs from a Python loop's hash
    /// once a unit has died although the games are the same; compare actions and units.
    ///
    /// An image checkpoint plays team 1 of a PvE scenario through `FramesActor` (frames
    /// rendered from the game), as `avacraft eval` and `episode` play it; `act_env` in a
    /// Python loop takes the same actions.
    fn play<'py>(&self, py: Python<'py>, env: &Bound<'py, PyEnv>, seed: u64) -> PyResult<Bound<'py, PyDict>> {
        let mut e = env.borrow_mut();
        let env = e.engine();
        if self.policy.cfg.obs != ObsKind::Features {
            return self.play_frames(py, env, seed);
        }
        let teams: &[Team] = if env.scenario().mode == Mode::Pvp { &[Team::One, Team::Two] } else { &[Team::One] };
        for &t in teams {
            self.check(env, t)?;
        }
        // One agent per team, as `Controllers` runs it for `episode --agent`.
        let mut players: Vec<AgentTeam> = teams
            .iter()
            .map(|&t| {
                let policy = Arc::clone(&self.policy);
                let name = format!("marl:{}", self.checkpoint.dir().display());
                AgentTeam::new(t, Grouping::Team, move || Box::new(MarlAgent::new(Arc::clone(&policy), name.clone())))
            })
            .collect();
        env.reset(seed);
        players.iter_mut().for_each(|p| p.reset(env));
        let mut chosen: Vec<Vec<Vec<i64>>> = vec![Vec::new(); teams.len()];
        while !env.done() {
            for (k, (p, &t)) in players.iter_mut().zip(teams).enumerate() {
                let actions = p.act(env, 0);
                let (order, layout) = (env.agents(t), env.smac_layout(t));
                let mut row = vec![-1i64; order.len()];
                for a in &actions {
                    if let Some(i) = order.iter().position(|&u| u == a.unit) {
                        row[i] = layout.index_for(env.world(), i, &a.command).map_or(-1, |x| x as i64);
                    }
                }
                chosen[k].push(row);
                env.submit(t, &actions);
            }
            env.step();
        }
        let d = episode_result(py, env, Team::One)?;
        for (k, rows) in chosen.into_iter().enumerate() {
            d.set_item(if k == 0 { "actions" } else { "actions2" }, rows)?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "MarlPolicy({:?}, scenario={:?}, algo={:?}, n_agents={})",
            self.checkpoint.dir().display().to_string(),
            self.policy.scenario,
            self.policy.cfg.algo,
            self.policy.shape.n_agents
        )
    }
}

impl PyMarlPolicy {
    /// `play` for an image checkpoint: team 1 of a PvE scenario through
    /// [`FramesActor`], as `avacraft eval` and `episode` play it. The actions are recorded
    /// as the engine agent's are: -1 for a dead agent (whose only action is the no-op).
    fn play_frames<'py>(&self, py: Python<'py>, env: &mut avacraft_engine::Env, seed: u64) -> PyResult<Bound<'py, PyDict>> {
        self.check_frames(env)?;
        let network = |e| PolicyError::Network(Box::new(e));
        let mut actor = FramesActor::new(Arc::clone(&self.policy), env.scenario()).map_err(network)?;
        env.reset(seed);
        let mut chosen: Vec<Vec<i64>> = Vec::new();
        while !env.done() {
            let acts = actor.choose(env).map_err(network)?;
            // Greedy choices are among the available actions, so none is refused.
            let _ = env.submit_indices(Team::One, &acts);
            chosen.push(acts.iter().map(|&a| if a == 0 { -1 } else { a as i64 }).collect());
            env.step();
        }
        let d = episode_result(py, env, Team::One)?;
        d.set_item("actions", chosen)?;
        Ok(d)
    }
}

/// What `play` returns for an episode that ended, from `team`'s side: `{"result": "win" |
/// "loss" | "draw", "steps", "trajectory_hash"}` (shared by `MarlPolicy` and `Ava`).
pub(crate) fn episode_result<'py>(py: Python<'py>, env: &avacraft_engine::Env, team: Team) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let result = env.outcome().map(|o| o.for_team(team)).unwrap_or(Outcome::Draw).name();
    d.set_item("result", result)?;
    d.set_item("steps", env.steps())?;
    d.set_item("trajectory_hash", env.trajectory_hash())?;
    Ok(d)
}
