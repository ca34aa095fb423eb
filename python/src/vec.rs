//! The threaded vector environment, and the Rust loop the Python benchmark compares against.

use crate::convert::indices;
use crate::error::Error;
use crate::options::{self, load_scenario};
use avacraft_engine::EnvOptions;
use avacraft_engine::{Env, EnvConfig, RewardMode, Team, VecEnv};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Mutex;
use std::time::Instant;

/// `E` environments of one scenario stepped together on a thread pool (auto-reset), results
/// in numpy arrays. Deterministic for a seed list whatever the number of threads.
#[pyclass(module = "avacraft._avacraft", name = "VecEnv")]
#[derive(Debug)]
pub struct PyVecEnv {
    // `Sync` for pyo3 (see `PyEnv`); reached through `get_mut` or a short lock.
    inner: Mutex<VecEnv>,
}

impl PyVecEnv {
    fn inner(&mut self) -> &mut VecEnv {
        self.inner.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

#[pymethods]
impl PyVecEnv {
    #[new]
    #[pyo3(signature = (scenario, seeds, threads=None, step_mul=8, reward="dense", opponent=None, full_vision=false,
        passive_allies=true, cooldown_jitter=true, abilities=true, ability_actions=false, time_limit_loops=None, prob_obs_enemy=1.0, action_mask=true, fov_actions=0, data=None, weapon_period="attack", melee_surround=false,
        reward_only_positive=true, reward_negative_scale=0.5, reward_death_value=10.0, reward_win=200.0, reward_defeat=0.0,
        reward_scale=true, reward_scale_rate=20.0, state_agent=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        scenario: &str,
        seeds: Vec<u64>,
        threads: Option<usize>,
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
        let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
        let inner = VecEnv::new(scenario, cfg, &seeds, threads).map_err(Error::from)?;
        Ok(Self { inner: Mutex::new(inner) })
    }

    #[getter]
    fn num_envs(&mut self) -> usize {
        self.inner().len()
    }
    #[getter]
    fn threads(&mut self) -> usize {
        self.inner().threads()
    }
    /// SMAC's get_env_info() of team 1.
    fn env_info<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::to_py(py, &self.inner().envs()[0].env_info(Team::One))
    }

    /// Restarts every environment from its base seed.
    fn reset(&mut self) {
        self.inner().reset();
    }

    /// Steps every environment with `actions` (`E x A` integer indices); the GIL is released
    /// while the environments step.
    fn step(&mut self, py: Python<'_>, actions: &Bound<'_, PyAny>) -> PyResult<()> {
        let inner = self.inner();
        let (a, ..) = inner.shape();
        let acts = indices(actions, "actions", &[inner.len(), a])?;
        py.detach(|| inner.step(&acts)).map_err(Error::from)?;
        Ok(())
    }

    /// The arrays of the last step (copies): obs `E x A x obs`, state `E x S`, avail
    /// `E x A x n_actions`, reward, terminated, truncated, seed `E`, and SMAC's info as arrays
    /// battle_won, dead_allies, dead_enemies, episode_limit `E`.
    fn buffers<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.inner();
        let (a, o, s, n) = inner.shape();
        let e = inner.len();
        let b = &inner.buffers;
        let d = PyDict::new(py);
        d.set_item("obs", PyArray1::from_slice(py, &b.obs).reshape([e, a, o])?)?;
        d.set_item("state", PyArray1::from_slice(py, &b.state).reshape([e, s])?)?;
        d.set_item("avail", PyArray1::from_slice(py, &b.avail).reshape([e, a, n])?)?;
        d.set_item("reward", PyArray1::from_slice(py, &b.reward))?;
        d.set_item("terminated", PyArray1::from_slice(py, &b.terminated))?;
        d.set_item("truncated", PyArray1::from_slice(py, &b.truncated))?;
        d.set_item("seed", PyArray1::from_slice(py, &b.seed))?;
        // What each finished episode ended on (the automatic reset overwrote obs, state and
        // avail); copied only on a step that ended one, as Gymnasium's same-step autoreset.
        if b.terminated.iter().zip(&b.truncated).any(|(t, u)| *t || *u) {
            d.set_item("final_obs", PyArray1::from_slice(py, &b.final_obs).reshape([e, a, o])?)?;
            d.set_item("final_state", PyArray1::from_slice(py, &b.final_state).reshape([e, s])?)?;
            d.set_item("final_avail", PyArray1::from_slice(py, &b.final_avail).reshape([e, a, n])?)?;
        }
        let info = |f: fn(&avacraft_engine::StepInfo) -> u32| PyArray1::from_iter(py, b.info.iter().map(f));
        d.set_item("battle_won", info(|i| i.battle_won as u32).cast_array::<bool>(false)?)?;
        d.set_item("dead_allies", info(|i| i.dead_allies))?;
        d.set_item("dead_enemies", info(|i| i.dead_enemies))?;
        d.set_item("episode_limit", info(|i| i.episode_limit as u32).cast_array::<bool>(false)?)?;
        Ok(d)
    }
}

/// Steps per second of the Rust loop doing what the Python SMAC loop of the benchmark does
/// each step: every agent's observation, the state and the masks into buffers, a uniformly
/// random available action per agent, a checked step; dense reward and SMAC's passive
/// allies, as `StarCraft2Env`'s defaults. The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (scenario, steps, seed=0))]
pub fn rust_loop_steps_per_s(py: Python<'_>, scenario: &str, steps: u64, seed: u64) -> PyResult<f64> {
    let sc = load_scenario(scenario)?;
    let cfg = EnvConfig { reward: RewardMode::Dense, ..EnvConfig::smac() };
    py.detach(move || -> Result<f64, Error> {
        let mut env = Env::new(sc, cfg, seed);
        let l = env.smac_layout(Team::One).clone();
        let (mut obs, mut state, mut avail) =
            (vec![0.0f32; l.n_agents * l.obs_size], vec![0.0f32; l.state_size], vec![0u8; l.n_agents * l.n_actions]);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut actions = vec![0i64; l.n_agents];
        let mut episode = seed;
        let start = Instant::now();
        for _ in 0..steps {
            env.obs_all(Team::One, &mut obs)?;
            env.state_into(Team::One, &mut state)?;
            env.avail_all(Team::One, &mut avail)?;
            for (a, mask) in actions.iter_mut().zip(avail.chunks_exact(l.n_actions)) {
                let n = mask.iter().filter(|&&m| m == 1).count();
                let k = rng.random_range(0..n.max(1));
                *a = mask.iter().enumerate().filter(|(_, m)| **m == 1).nth(k).map_or(0, |(i, _)| i as i64);
            }
            std::hint::black_box((&obs, &state));
            let r = env.step_indices(&actions, None)?;
            if r.done {
                episode += 1;
                env.reset(episode);
            }
        }
        Ok(steps as f64 / start.elapsed().as_secs_f64().max(1e-9))
    })
    .map_err(PyErr::from)
}
