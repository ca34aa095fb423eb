//! One environment: the engine's `Env` for Python, with SMAC features, typed actions,
//! frames and an episode recording.

use crate::convert::{image, indices, matrix, to_py};
use crate::error::{AvacraftError, Error};
use crate::options;
use avacraft_engine::EnvOptions;
use avacraft_engine::agent::{Agent, GroupObs, Reads, SmacHeuristic};
use avacraft_engine::{Action, Env, LearnError, Mode, Team, UnitId, describe, unit_list};
use avacraft_render::{ObsMode, Observer, RenderConfig, RgbImage, VideoWriter, VlmOptions};
use numpy::PyArray1;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;
use std::path::PathBuf;
use std::sync::Mutex;

/// Frames of the episode being played (when recording) and of the one before it.
#[derive(Debug, Default)]
struct Recording {
    size: Option<(u32, u32)>,
    current: Vec<RgbImage>,
    last: Vec<RgbImage>,
}

/// The engine's environment. Python's `avacraft.StarCraft2Env` and `avacraft.parallel_env`
/// wrap it; the arguments mirror `avacraft_engine::EnvConfig`.
#[pyclass(module = "avacraft._avacraft", name = "Env")]
#[derive(Debug)]
pub struct PyEnv {
    // pyo3 shares a class between threads, so it must be `Sync`; the opponent and render back
    // end are `Send` only. Every method takes `&mut self` (pyo3's borrow flag makes access
    // exclusive), so the mutex is reached through `get_mut` and never locked.
    inner: Mutex<Inner>,
}

#[derive(Debug)]
struct Inner {
    env: Env,
    observer: Observer,
    recording: Recording,
    /// SMAC's heuristic agent while `step_heuristic` plays the episode (its targets last
    /// until the episode ends).
    heuristic: Option<SmacHeuristic>,
}

pub(crate) fn team(t: u8) -> PyResult<Team> {
    let team = match t {
        1 => Team::One,
        2 => Team::Two,
        _ => return Err(PyValueError::new_err(format!("team {t}: teams are 1 and 2"))),
    };
    Ok(team)
}

fn agent_team(t: u8, env: &Env) -> PyResult<Team> {
    let team = team(t)?;
    if !env.is_agent_team(team) {
        return Err(PyValueError::new_err(format!(
            "team 2 is not played by agents in {} (a PvE scenario: the opponent controls it)",
            env.scenario().name
        )));
    }
    Ok(team)
}

/// A unit tag (1-based, as screenshots, texts and unit lists show it) as the engine's index.
fn tag_to_index(v: &mut Value, what: &str) -> Result<(), String> {
    match v.as_u64() {
        Some(t) if (1..=u16::MAX as u64 + 1).contains(&t) => {
            *v = Value::from(t - 1);
            Ok(())
        }
        _ => Err(format!("`{what}` = {v}: a unit tag (1 or more, as the unit list shows it) is needed")),
    }
}

/// A typed action as Python gives it (`{"unit": tag, "command": {"kind": ..., ...}}`, tags
/// 1-based; a command may be given as its kind alone, e.g. `"stop"`) as the engine's `Action`.
fn parse_action(mut v: Value) -> Result<Action, String> {
    let Some(obj) = v.as_object_mut() else {
        return Err(format!("{v} is not a dict like {{\"unit\": 1, \"command\": {{\"kind\": \"stop\"}}}}"));
    };
    for k in obj.keys() {
        if k != "unit" && k != "command" {
            return Err(format!("unknown key `{k}` (an action has `unit` and `command`)"));
        }
    }
    tag_to_index(obj.get_mut("unit").ok_or("missing key `unit` (the tag of the unit to command)")?, "unit")?;
    let cmd = obj.get_mut("command").ok_or("missing key `command`")?;
    if let Value::String(kind) = cmd {
        *cmd = serde_json::json!({ "kind": kind.clone() });
    }
    if let Some(c) = cmd.as_object_mut() {
        match c.get_mut("target") {
            Some(t @ Value::Number(_)) => tag_to_index(t, "command.target")?,
            Some(Value::Object(t)) => {
                if let Some(u) = t.get_mut("unit") {
                    tag_to_index(u, "command.target.unit")?;
                }
            }
            _ => {}
        }
    }
    serde_json::from_value::<Action>(v).map_err(|e| e.to_string())
}

impl PyEnv {
    fn inner(&mut self) -> &mut Inner {
        self.inner.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The engine environment itself (a trained policy's Rust episode plays on it).
    pub(crate) fn engine(&mut self) -> &mut Env {
        &mut self.inner().env
    }
}

impl Inner {
    fn result<'py>(&self, py: Python<'py>, r: avacraft_engine::StepResult) -> PyResult<Bound<'py, PyAny>> {
        let outcome = r.outcome.map(|o| format!("{o:?}").to_lowercase());
        Ok((r.reward[0], r.reward[1], r.terminated, r.truncated, outcome).into_pyobject(py)?.into_any())
    }

    fn after_step(&mut self) {
        if let Some((w, h)) = self.recording.size {
            let frame = self.observer.screen_sized(&self.env, Team::One, w, h);
            self.recording.current.push(frame);
        }
    }
}

trait Sized2 {
    fn screen_sized(&mut self, env: &Env, team: Team, w: u32, h: u32) -> RgbImage;
}

impl Sized2 for Observer {
    fn screen_sized(&mut self, env: &Env, team: Team, w: u32, h: u32) -> RgbImage {
        self.config = self.config.with_screen(w, h);
        self.screen(env, team)
    }
}

#[pymethods]
impl PyEnv {
    #[new]
    #[pyo3(signature = (scenario, seed=0, step_mul=8, reward="dense", opponent=None, full_vision=false, passive_allies=true,
        cooldown_jitter=true, abilities=true, ability_actions=false, time_limit_loops=None, prob_obs_enemy=1.0, action_mask=true, fov_actions=0, data=None, weapon_period="attack", melee_surround=false,
        reward_only_positive=true, reward_negative_scale=0.5, reward_death_value=10.0, reward_win=200.0, reward_defeat=0.0,
        reward_scale=true, reward_scale_rate=20.0, state_agent=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        scenario: &str,
        seed: u64,
        step_mul: u32,
        reward: &str,
        opponent: Option<String>,
        full_vision: bool,
        passive_allies: bool,
        cooldown_jitter: bool,
        abilities: bool,
        ability_actions: bool,
        time_limit_loops: Option<u32>,
        prob_obs_enemy: f64,
        action_mask: bool,
        fov_actions: i64,
        data: Option<String>,
        weapon_period: &str,
        melee_surround: bool,
        reward_only_positive: bool,
        reward_negative_scale: f64,
        reward_death_value: f64,
        reward_win: f64,
        reward_defeat: f64,
        reward_scale: bool,
        reward_scale_rate: f64,
        state_agent: bool,
    ) -> PyResult<Self> {
        // Both constructors take EnvOptions' fields, in its order (a Python test holds them to it).
        let (reward, opponent, data, weapon_period) = options::named(reward, opponent.as_deref(), data.as_deref(), weapon_period)?;
        let opts = EnvOptions {
            step_mul,
            reward,
            opponent,
            full_vision,
            passive_allies,
            cooldown_jitter,
            abilities,
            ability_actions,
            time_limit_loops,
            prob_obs_enemy,
            action_mask,
            fov_actions,
            data,
            weapon_period,
            melee_surround,
            reward_only_positive,
            reward_negative_scale,
            reward_death_value,
            reward_win,
            reward_defeat,
            reward_scale,
            reward_scale_rate,
            state_agent,
        };
        let (scenario, cfg) = options::build(scenario, &opts)?;
        let env = Env::new(scenario, cfg, seed);
        let observer = Observer::new(ObsMode::Features, RenderConfig::default());
        Ok(Self { inner: Mutex::new(Inner { env, observer, recording: Recording::default(), heuristic: None }) })
    }

    /// Starts a new episode from `seed`.
    fn reset(&mut self, seed: u64) {
        let s = self.inner();
        s.env.reset(seed);
        s.heuristic = None;
        if !s.recording.current.is_empty() {
            s.recording.last = std::mem::take(&mut s.recording.current);
        }
        s.after_step();
    }

    #[getter]
    fn scenario(&mut self) -> String {
        let s = self.inner();
        s.env.scenario().name.clone()
    }
    #[getter]
    fn pvp(&mut self) -> bool {
        let s = self.inner();
        s.env.scenario().mode == Mode::Pvp
    }
    #[getter]
    fn seed(&mut self) -> u64 {
        let s = self.inner();
        s.env.seed()
    }
    #[getter]
    fn steps(&mut self) -> u32 {
        let s = self.inner();
        s.env.steps()
    }
    #[getter]
    fn done(&mut self) -> bool {
        let s = self.inner();
        s.env.done()
    }
    #[getter]
    fn trajectory_hash(&mut self) -> u64 {
        let s = self.inner();
        s.env.trajectory_hash()
    }
    /// The opponent policy drawn for this episode (PvE), e.g. "builtin".
    #[getter]
    fn opponent(&mut self) -> Option<&'static str> {
        let s = self.inner();
        s.env.opponent().map(|o| o.name())
    }

    /// SMAC's `get_env_info()` of a team: n_agents, n_actions, obs_shape, state_shape, episode_limit.
    #[pyo3(signature = (team=1))]
    fn env_info<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        to_py(py, &s.env.env_info(self::team(team)?))
    }

    /// The most this episode's dense reward can pay a team before scaling (SMAC's
    /// `max_reward`: the enemies' life and shields, `reward_death_value` each, `reward_win`).
    #[pyo3(signature = (team=1))]
    fn max_reward(&mut self, team: u8) -> PyResult<f32> {
        let s = self.inner();
        Ok(s.env.max_reward(self::team(team)?))
    }

    /// Tags (1-based) of a team's agents, in agent order.
    #[pyo3(signature = (team=1))]
    fn agent_tags(&mut self, team: u8) -> PyResult<Vec<u32>> {
        let s = self.inner();
        Ok(s.env.agents(self::team(team)?).iter().map(|u| u.tag()).collect())
    }

    /// Whether each agent of a team is alive.
    #[pyo3(signature = (team=1))]
    fn alive(&mut self, team: u8) -> PyResult<Vec<bool>> {
        let s = self.inner();
        let w = s.env.world();
        Ok(s.env.agents(self::team(team)?).iter().map(|id| w.unit(*id).is_some_and(|u| u.alive)).collect())
    }

    /// Every agent's observation: `n_agents x obs_shape` float32.
    #[pyo3(signature = (team=1))]
    fn obs<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        let t = self::team(team)?;
        let l = s.env.smac_layout(t);
        let mut v = vec![0.0f32; l.n_agents * l.obs_size];
        s.env.obs_all(t, &mut v).map_err(Error::from)?;
        matrix(py, v, l.n_agents, l.obs_size)
    }

    /// Every agent's observation as a list of `obs_shape` float32 arrays (SMAC's `get_obs()`
    /// type, built here: cheaper than splitting a matrix in Python).
    #[pyo3(signature = (team=1))]
    fn obs_list<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Vec<Bound<'py, PyArray1<f32>>>> {
        let s = self.inner();
        let t = self::team(team)?;
        let l = s.env.smac_layout(t);
        let mut out = Vec::with_capacity(l.n_agents);
        for a in 0..l.n_agents {
            let mut v = vec![0.0f32; l.obs_size];
            s.env.obs_agent(t, a, &mut v);
            out.push(PyArray1::from_vec(py, v));
        }
        Ok(out)
    }

    /// One agent's observation: `obs_shape` float32.
    #[pyo3(signature = (agent, team=1))]
    fn obs_agent<'py>(&mut self, py: Python<'py>, agent: i64, team: u8) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let s = self.inner();
        let t = self::team(team)?;
        let a = s.agent_index(agent, t)?;
        let mut v = vec![0.0f32; s.env.smac_layout(t).obs_size];
        s.env.obs_agent(t, a, &mut v);
        Ok(PyArray1::from_vec(py, v))
    }

    /// SMAC's global state of a team: `state_shape` float32.
    #[pyo3(signature = (team=1))]
    fn state<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let s = self.inner();
        let t = self::team(team)?;
        let mut v = vec![0.0f32; s.env.smac_layout(t).state_size];
        s.env.state_into(t, &mut v).map_err(Error::from)?;
        Ok(PyArray1::from_vec(py, v))
    }

    /// Every agent's action mask: `n_agents x n_actions` uint8 (1 = available).
    #[pyo3(signature = (team=1))]
    fn avail<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        let t = self::team(team)?;
        let l = s.env.smac_layout(t);
        let mut v = vec![0u8; l.n_agents * l.n_actions];
        s.env.avail_all(t, &mut v).map_err(Error::from)?;
        matrix(py, v, l.n_agents, l.n_actions)
    }

    /// One agent's action mask: `n_actions` uint8.
    #[pyo3(signature = (agent, team=1))]
    fn avail_agent<'py>(&mut self, py: Python<'py>, agent: i64, team: u8) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let s = self.inner();
        let t = self::team(team)?;
        let a = s.agent_index(agent, t)?;
        let mut v = vec![0u8; s.env.smac_layout(t).n_actions];
        s.env.avail_agent(t, a, &mut v);
        Ok(PyArray1::from_vec(py, v))
    }

    /// One SMAC step: an action index per agent of team 1 (and of team 2 in PvP). Every index
    /// is checked before anything is applied. Returns (reward team 1, reward team 2,
    /// terminated, truncated, outcome or None).
    #[pyo3(signature = (actions, actions2=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
        actions2: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        if s.env.done() {
            return Err(AvacraftError::new_err("the episode is over: call reset() first"));
        }
        let n1 = s.env.smac_layout(Team::One).n_agents;
        let a1 = indices(actions, "actions", &[n1])?;
        let a2 = match actions2 {
            None if (s.env.scenario().mode == Mode::Pvp) => {
                return Err(PyValueError::new_err(format!("{} is PvP: team 2's actions are needed too", s.env.scenario().name)));
            }
            None => None,
            Some(_) if !(s.env.scenario().mode == Mode::Pvp) => {
                return Err(PyValueError::new_err(format!(
                    "{} is PvE: team 2 is the opponent's, no actions for it",
                    s.env.scenario().name
                )));
            }
            Some(a) => Some(indices(a, "actions2", &[s.env.smac_layout(Team::Two).n_agents])?),
        };
        let r = s.env.step_indices(&a1, a2.as_deref()).map_err(|e| match (&e, a2.is_some()) {
            (LearnError::Count { .. } | LearnError::OutOfRange { .. } | LearnError::Unavailable { .. }, true) => {
                // Name the team where both give actions.
                let team = if s.env.check_indices(Team::One, &a1).is_err() { 1 } else { 2 };
                AvacraftError::new_err(format!("team {team}: {e}"))
            }
            _ => Error::from(e).into(),
        })?;
        s.after_step();
        s.result(py, r)
    }

    /// SMAC's step for team 1 of a PvE scenario in one call: (reward, terminated, truncated,
    /// info with battle_won, dead_allies, dead_enemies). The facade's hot path.
    fn step_smac<'py>(&mut self, py: Python<'py>, actions: &Bound<'py, PyAny>) -> PyResult<(f32, bool, bool, Bound<'py, PyDict>)> {
        let s = self.inner();
        if s.env.done() {
            return Err(AvacraftError::new_err("the episode is over: call reset() first"));
        }
        if s.env.scenario().mode == Mode::Pvp {
            return Err(PyValueError::new_err(format!("{} is PvP: use step(actions, actions2)", s.env.scenario().name)));
        }
        let a1 = indices(actions, "actions", &[s.env.smac_layout(Team::One).n_agents])?;
        let r = s.env.step_indices(&a1, None).map_err(Error::from)?;
        s.after_step();
        let i = s.env.info(Team::One);
        let d = PyDict::new(py);
        d.set_item("battle_won", i.battle_won)?;
        d.set_item("dead_allies", i.dead_allies)?;
        d.set_item("dead_enemies", i.dead_enemies)?;
        Ok((r.reward[0], r.terminated, r.truncated, d))
    }

    /// SMAC's step under `heuristic_ai`: team 1's units are played by SMAC's heuristic
    /// (`rest`: `heuristic_rest`) instead of actions; returns what `step_smac` does.
    fn step_heuristic<'py>(&mut self, py: Python<'py>, rest: bool) -> PyResult<(f32, bool, bool, Bound<'py, PyDict>)> {
        let s = self.inner();
        if s.env.done() {
            return Err(AvacraftError::new_err("the episode is over: call reset() first"));
        }
        if s.env.scenario().mode == Mode::Pvp {
            return Err(PyValueError::new_err(format!("{} is PvP: heuristic_ai plays PvE scenarios", s.env.scenario().name)));
        }
        let agent = s.heuristic.get_or_insert_with(|| SmacHeuristic::new(rest));
        let actions = agent.act(&GroupObs::team(&s.env, Team::One, 0, Reads::UNITS));
        // As SMAC sends them: an order the game refuses is dropped, the unit keeps its own.
        let _ = s.env.submit(Team::One, &actions);
        let r = s.env.step();
        s.after_step();
        let i = s.env.info(Team::One);
        let d = PyDict::new(py);
        d.set_item("battle_won", i.battle_won)?;
        d.set_item("dead_allies", i.dead_allies)?;
        d.set_item("dead_enemies", i.dead_enemies)?;
        Ok((r.reward[0], r.terminated, r.truncated, d))
    }

    /// Gives typed actions to a team's units (see `avacraft.Action` in the stubs) without
    /// stepping. A malformed action raises (nothing applied); an action the game refuses
    /// (a dead target, a unit that cannot move) is reported per action, as the engine does,
    /// and the unit keeps its order. Returns one error message or None per action.
    #[pyo3(signature = (actions_json, team=1))]
    fn submit_typed(&mut self, actions_json: &str, team: u8) -> PyResult<Vec<Option<String>>> {
        let s = self.inner();
        let t = agent_team(team, &s.env)?;
        let vals: Vec<Value> = serde_json::from_str(actions_json)
            .map_err(|e| PyTypeError::new_err(format!("actions: a list of action dicts is needed ({e})")))?;
        let mut actions = Vec::with_capacity(vals.len());
        for (i, v) in vals.into_iter().enumerate() {
            actions.push(parse_action(v).map_err(|e| AvacraftError::new_err(format!("action {i}: {e}")))?);
        }
        Ok(s.env.submit(t, &actions).into_iter().map(|r| r.err().map(|e| e.to_string())).collect())
    }

    /// Advances one step with what was submitted (`submit_typed`); units without a new
    /// action keep their orders.
    fn advance<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        if s.env.done() {
            return Err(AvacraftError::new_err("the episode is over: call reset() first"));
        }
        let r = s.env.step();
        s.after_step();
        s.result(py, r)
    }

    /// SMAC's info of a team now: battle_won, dead_allies, dead_enemies, episode_limit.
    #[pyo3(signature = (team=1))]
    fn info<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Bound<'py, PyDict>> {
        let s = self.inner();
        let i = s.env.info(self::team(team)?);
        let d = PyDict::new(py);
        d.set_item("battle_won", i.battle_won)?;
        d.set_item("dead_allies", i.dead_allies)?;
        d.set_item("dead_enemies", i.dead_enemies)?;
        d.set_item("episode_limit", i.episode_limit)?;
        Ok(d)
    }

    /// The MARL screen (whole playable area) as a team sees it: `height x width x 3` uint8.
    #[pyo3(signature = (width=160, height=120, team=1))]
    fn screen<'py>(&mut self, py: Python<'py>, width: u32, height: u32, team: u8) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        let t = self::team(team)?;
        check_size(width, height)?;
        image(py, s.observer.screen_sized(&s.env, t, width, height))
    }

    /// The minimap: `height x width x 3` uint8.
    #[pyo3(signature = (width=32, height=32, team=1))]
    fn minimap<'py>(&mut self, py: Python<'py>, width: u32, height: u32, team: u8) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        let t = self::team(team)?;
        check_size(width, height)?;
        s.observer.config = s.observer.config.with_minimap(width, height);
        image(py, s.observer.minimap(&s.env, t))
    }

    /// The annotated VLM screenshot (grid, tags, legend): `height x width x 3` uint8.
    /// `highlights`: tags of units to ring.
    #[pyo3(signature = (width=1920, height=1080, team=1, highlights=Vec::new()))]
    fn screenshot<'py>(&mut self, py: Python<'py>, width: u32, height: u32, team: u8, highlights: Vec<u32>) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        let t = self::team(team)?;
        check_size(width, height)?;
        let mut opts = VlmOptions::default();
        for tag in highlights {
            let idx = tag.checked_sub(1).and_then(|i| u16::try_from(i).ok());
            let Some(i) = idx else { return Err(PyValueError::new_err(format!("highlights: {tag} is not a unit tag (tags start at 1)"))) };
            opts.highlights.push(UnitId::new(i));
        }
        s.observer.config = s.observer.config.with_vlm(width, height);
        image(py, s.observer.screenshot(&s.env, t, &opts))
    }

    /// The natural-language battlefield description a team's VLM agent reads.
    #[pyo3(signature = (team=1))]
    fn text(&mut self, team: u8) -> PyResult<String> {
        let s = self.inner();
        Ok(describe(&s.env, self::team(team)?))
    }

    /// The structured unit list (every living unit the team knows of) as dicts.
    #[pyo3(signature = (team=1))]
    fn units<'py>(&mut self, py: Python<'py>, team: u8) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner();
        to_py(py, &unit_list(s.env.world(), self::team(team)?))
    }

    /// Records a `width x height` screen frame of team 1 after every reset and step (off:
    /// `record(None)`); the frames of the current (or else the last) episode go to
    /// `save_video`.
    #[pyo3(signature = (size))]
    fn record(&mut self, size: Option<(u32, u32)>) -> PyResult<()> {
        let s = self.inner();
        if let Some((w, h)) = size {
            check_size(w, h)?;
        }
        s.recording.size = size;
        Ok(())
    }

    /// Writes the recorded episode as an animated GIF; returns the number of frames.
    #[pyo3(signature = (path, delay_ms=100))]
    fn save_video(&mut self, path: PathBuf, delay_ms: u32) -> PyResult<u32> {
        let s = self.inner();
        let r = &s.recording;
        let frames = if r.current.is_empty() { &r.last } else { &r.current };
        if frames.is_empty() {
            return Err(AvacraftError::new_err("no frames recorded: recording is off or no episode was played"));
        }
        let mut v = VideoWriter::create(&path, delay_ms).map_err(Error::from)?;
        for f in frames {
            v.push(f).map_err(Error::from)?;
        }
        Ok(v.finish().map_err(Error::from)?)
    }

    /// An independent copy of this episode (world, RNG streams, opponent memory) that
    /// `restore` returns to: cheap look-ahead and forked evaluations.
    fn snapshot(&mut self) -> PySnapshot {
        let s = self.inner();
        PySnapshot { env: Mutex::new(s.env.clone()) }
    }

    /// Puts the episode back to `snap`.
    fn restore(&mut self, snap: &PySnapshot) {
        let s = self.inner();
        s.env.restore(&snap.env());
    }
}

impl Inner {
    fn agent_index(&self, agent: i64, t: Team) -> PyResult<usize> {
        let n = self.env.smac_layout(t).n_agents;
        usize::try_from(agent)
            .ok()
            .filter(|&a| a < n)
            .ok_or_else(|| AvacraftError::new_err(format!("agent {agent} is out of range: team {} has agents 0..{n}", t.player())))
    }
}

fn check_size(w: u32, h: u32) -> PyResult<()> {
    // 8192 per side keeps a frame under 200 MB.
    if !(1..=8192).contains(&w) || !(1..=8192).contains(&h) {
        return Err(PyValueError::new_err(format!("image size {w}x{h}: each side must be 1..=8192 pixels")));
    }
    Ok(())
}

/// A saved episode state (see `Env.snapshot`).
#[pyclass(module = "avacraft._avacraft", name = "Snapshot")]
#[derive(Debug)]
pub struct PySnapshot {
    // `Sync` for pyo3, as `PyEnv`'s.
    env: Mutex<Env>,
}

impl PySnapshot {
    fn env(&self) -> std::sync::MutexGuard<'_, Env> {
        self.env.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

#[pymethods]
impl PySnapshot {
    #[getter]
    fn steps(&self) -> u32 {
        self.env().steps()
    }
    #[getter]
    fn state_hash(&self) -> u64 {
        self.env().state_hash()
    }
}
