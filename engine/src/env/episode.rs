//! An episode's state and everything read or changed without stepping it: configuration,
//! reset, actions, hashes and the SMAC interface. Below the observations (which read an
//! `Env`) and the step (which builds them for the opponent).

use super::epo::Epo;
use super::reward::DenseReward;
use crate::action::{Action, ActionError, Command};
use crate::builtin_ai::BuiltinAi;
use crate::hash::Fnv;
use crate::ids::{Team, UnitId};
use crate::obs::{EnvInfo, IndexError, SmacLayout};
use crate::policy::{self, AgentCtx, agent_seed};
use crate::scenario::{Mode, OpponentKind, Scenario};
use crate::time::DEFAULT_STEP_MUL;
use crate::world::{Rules, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::num::NonZeroU32;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RewardMode {
    /// +1 win, -1 loss, 0 otherwise (the paper).
    Sparse,
    /// SMAC's shaped reward: damage and kills dealt, +200 on win, scaled to 20 at most.
    Dense,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EnvConfig {
    /// Game loops per environment step.
    pub step_mul: NonZeroU32,
    pub rules: Rules,
    pub reward: RewardMode,
    /// Opponent for PvE; `None` uses the scenario's default.
    pub opponent: Option<OpponentKind>,
    /// Overrides the scenario's time limit (loops).
    pub time_limit_loops: Option<NonZeroU32>,
    /// Appends the ability slots to SMAC's discrete actions (and their features to the
    /// observations); off by default for drop-in SMAC compatibility.
    #[serde(default)]
    pub ability_actions: bool,
    /// SMACv2's extended partial observability (EPO): when an agent first sees an enemy,
    /// each of its teammates keeps that enemy in its observation only with this
    /// probability, until the enemy or the spotter dies. 1 (the default) is off; SMACv2's
    /// EPO configs use 0. Drawn from its own seeded stream; entry points refuse values
    /// outside [0, 1].
    #[serde(default = "one")]
    pub prob_obs_enemy: f32,
    /// SMAC's range mask on attack actions (the default). Off (SMACv2's `action_mask:
    /// False`, used with EPO): any living enemy the team sees may be attacked from any
    /// distance, so the mask stops telling an agent which enemies are near.
    #[serde(default = "yes")]
    pub action_mask: bool,
    /// SMACv2's conic fields of view (`conic_fov` with `num_fov_actions`): 0 (the default)
    /// is off; N adds N look actions after the moves, and each agent's SMAC features see
    /// and attack only within a cone of 2π/N around where it looks (`Command::Look`).
    /// Entry points accept even N from 2 to 64 ([`check_fov_actions`]).
    #[serde(default)]
    pub fov_actions: u8,
    /// SMAC's shaped-reward settings, read under [`RewardMode::Dense`] (SMAC's defaults by
    /// default).
    #[serde(default)]
    pub dense_reward: DenseReward,
    /// The MAPPO repository's agent-specific state (`use_state_agent`) in place of SMAC's
    /// global state: each agent's row of every unit as seen from it, the rows one after
    /// another (off by default). It changes what the state reads, never what happens.
    #[serde(default)]
    pub state_agent: bool,
}

/// The largest number of look actions an entry point accepts.
pub const MAX_FOV_ACTIONS: u8 = 64;

/// Whether `n` look actions (SMACv2's `num_fov_actions`) are accepted: 0 (off) or an even
/// number from 2 to [`MAX_FOV_ACTIONS`]. Even, so that a policy trained as team 1 plays team
/// 2 in the mirror image with every look direction's mirror among its actions.
pub fn check_fov_actions(n: i64) -> Result<u8, BadFovActions> {
    match u8::try_from(n) {
        Ok(v) if v == 0 || (v % 2 == 0 && v <= MAX_FOV_ACTIONS) => Ok(v),
        _ => Err(BadFovActions { n }),
    }
}

/// A refused number of look actions ([`check_fov_actions`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{n} look actions: must be an even number from 2 to {MAX_FOV_ACTIONS} (or 0 for off)")]
pub struct BadFovActions {
    pub n: i64,
}

fn one() -> f32 {
    1.0
}

fn yes() -> bool {
    true
}

impl EnvConfig {
    /// SMAC's setting: allied units are passive (they neither acquire targets nor autocast
    /// heal on their own), so every engagement is the agents' decision.
    pub fn smac() -> Self {
        Self { rules: Rules { auto_acquire: [false, true], ..Rules::default() }, ..Self::default() }
    }

    /// Whether extended partial observability is on (a probability below 1).
    pub fn epo(&self) -> bool {
        self.prob_obs_enemy < 1.0
    }
}

impl Default for EnvConfig {
    fn default() -> Self {
        Self {
            step_mul: DEFAULT_STEP_MUL,
            rules: Rules::default(),
            reward: RewardMode::Sparse,
            opponent: None,
            time_limit_loops: None,
            ability_actions: false,
            prob_obs_enemy: 1.0,
            action_mask: true,
            fov_actions: 0,
            dense_reward: DenseReward::default(),
            state_agent: false,
        }
    }
}

/// How an episode ended, from team 1's side.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    Win,
    Loss,
    Draw,
}

impl Outcome {
    /// Its name in results files, reports and Python (`win`, `loss`, `draw`: serde's too).
    pub const fn name(self) -> &'static str {
        match self {
            Outcome::Win => "win",
            Outcome::Loss => "loss",
            Outcome::Draw => "draw",
        }
    }

    /// The same end seen from `team`.
    pub fn for_team(self, team: Team) -> Outcome {
        match (self, team) {
            (o, Team::One) | (o @ Outcome::Draw, _) => o,
            (Outcome::Win, Team::Two) => Outcome::Loss,
            (Outcome::Loss, Team::Two) => Outcome::Win,
        }
    }
    pub fn sparse_reward(self) -> f32 {
        match self {
            Outcome::Win => 1.0,
            Outcome::Loss => -1.0,
            Outcome::Draw => 0.0,
        }
    }
}

/// Result of one environment step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepResult {
    /// Reward per team (index by [`Team::index`]).
    pub reward: [f32; 2],
    /// `terminated || truncated`.
    pub done: bool,
    /// The episode ended in the game: a side can no longer fight (a mutual wipe included).
    pub terminated: bool,
    /// The episode hit its time limit with both sides still able to fight (a draw).
    pub truncated: bool,
    pub outcome: Option<Outcome>,
}

/// Per-team SMAC reward bookkeeping.
#[derive(Clone, Debug, Default)]
pub(super) struct DenseTracker {
    pub(super) prev: Vec<f32>,
    pub(super) dead: Vec<bool>,
}

pub struct Env {
    /// The scenario as loaded; for a procedural one, what every episode is drawn from.
    pub(super) template: Arc<Scenario>,
    /// This episode's scenario (the template itself unless it is procedural).
    pub(super) scenario: Arc<Scenario>,
    pub(super) cfg: EnvConfig,
    pub(super) world: World,
    pub(super) seed: u64,
    pub(super) agents: [Vec<UnitId>; 2],
    pub(super) opponent: Option<Box<dyn policy::ForkAgent>>,
    pub(super) opponent_kind: Option<OpponentKind>,
    pub(super) policy_rng: ChaCha8Rng,
    pub(super) builtin: Option<BuiltinAi>,
    pub(super) outcome: Option<Outcome>,
    pub(super) steps: u32,
    pub(super) refused: [u32; 2],
    /// SMAC index of each agent's action in the last step (None: no action given).
    pub(super) last_actions: [Vec<Option<usize>>; 2],
    /// Actions given for the step being prepared; they become `last_actions` at `step`.
    pub(super) pending_actions: [Vec<Option<usize>>; 2],
    pub(super) dense: DenseTracker,
    /// SMAC's max_reward per team (`Env::max_reward_of`).
    pub(super) max_reward: [f32; 2],
    pub(super) trajectory: Fnv,
    pub(super) layouts: [SmacLayout; 2],
    /// Extended partial observability, per team (empty while it is off).
    pub(super) epo: [Epo; 2],
}

impl std::fmt::Debug for Env {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Env").field("scenario", &self.scenario.name).field("seed", &self.seed).field("tick", &self.world.tick()).finish()
    }
}

/// A snapshot: an independent copy of the episode at this step (world, RNG positions, the
/// opponent's memory, reward bookkeeping, trajectory hash), for look-ahead and for forking
/// evaluations. The copy and the original, given the same actions, go on identically; the
/// scenario is shared, being immutable.
impl Clone for Env {
    fn clone(&self) -> Self {
        Env {
            template: Arc::clone(&self.template),
            scenario: Arc::clone(&self.scenario),
            cfg: self.cfg.clone(),
            world: self.world.clone(),
            seed: self.seed,
            agents: self.agents.clone(),
            opponent: self.opponent.as_ref().map(|o| o.fork()),
            opponent_kind: self.opponent_kind,
            policy_rng: self.policy_rng.clone(),
            builtin: self.builtin.clone(),
            outcome: self.outcome,
            steps: self.steps,
            refused: self.refused,
            last_actions: self.last_actions.clone(),
            pending_actions: self.pending_actions.clone(),
            dense: self.dense.clone(),
            max_reward: self.max_reward,
            trajectory: self.trajectory,
            layouts: self.layouts.clone(),
            epo: self.epo.clone(),
        }
    }
}

impl Env {
    /// A copy to explore from; `restore` goes back to it. Same as `clone`, named for readers
    /// of look-ahead code.
    pub fn snapshot(&self) -> Env {
        self.clone()
    }
    /// Puts this environment back to `snap`'s state (a snapshot of an environment of the same
    /// scenario, or of any other: the snapshot carries everything).
    pub fn restore(&mut self, snap: &Env) {
        *self = snap.clone();
    }
}

impl Env {
    pub fn new(scenario: Arc<Scenario>, cfg: EnvConfig, seed: u64) -> Env {
        let world = World::new(&scenario, cfg.rules, seed);
        let layouts = layouts(&scenario, &cfg);
        let mut env = Env {
            template: Arc::clone(&scenario),
            agents: [Vec::new(), Vec::new()],
            world,
            scenario,
            cfg,
            seed,
            opponent: None,
            opponent_kind: None,
            policy_rng: ChaCha8Rng::seed_from_u64(seed),
            builtin: None,
            outcome: None,
            steps: 0,
            refused: [0, 0],
            last_actions: [Vec::new(), Vec::new()],
            pending_actions: [Vec::new(), Vec::new()],
            dense: DenseTracker::default(),
            max_reward: [0.0, 0.0],
            trajectory: Fnv::default(),
            layouts,
            epo: [Epo::new(0, 0, 0, 0), Epo::new(0, 1, 0, 0)],
        };
        env.reset(seed);
        env
    }

    /// Starts a new episode; everything random in it follows from `seed`.
    pub fn reset(&mut self, seed: u64) {
        self.seed = seed;
        if self.template.is_procedural() {
            self.scenario = self.template.episode(seed);
            self.layouts = layouts(&self.scenario, &self.cfg);
        }
        self.world = World::new(&self.scenario, self.cfg.rules, seed);
        // Policies draw from their own stream so adding a draw there never shifts the world's.
        self.policy_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
        for team in Team::BOTH {
            self.agents[team.index()] = self.scenario.agent_order(team);
            self.last_actions[team.index()] = vec![None; self.agents[team.index()].len()];
            self.pending_actions[team.index()] = vec![None; self.agents[team.index()].len()];
        }
        self.outcome = None;
        self.steps = 0;
        self.refused = [0, 0];
        self.trajectory = Fnv::default();
        self.trajectory.u64(seed);
        self.dense = DenseTracker {
            prev: self.world.units().iter().map(|u| u.hp + u.shield).collect(),
            dead: vec![false; self.world.units().len()],
        };
        for team in Team::BOTH {
            self.max_reward[team.index()] = self.max_reward_of(team);
        }
        self.opponent = None;
        self.opponent_kind = None;
        if self.scenario.mode == Mode::Pve {
            let mut kind = self.cfg.opponent.unwrap_or(self.scenario.opponent);
            if kind == OpponentKind::Random {
                let pool = [OpponentKind::Builtin, OpponentKind::Aggressive, OpponentKind::Defensive, OpponentKind::Focus];
                kind = pool[self.policy_rng.random_range(0..pool.len())];
            }
            self.opponent_kind = Some(kind);
            if kind != OpponentKind::Builtin {
                let mut p = policy::opponent(kind);
                // One agent for the whole team, seeded as an agent team of it would be.
                let units = self.agents[Team::Two.index()].clone();
                let seed = agent_seed(seed, Team::Two, units.first().map_or(0, |id| id.tag()));
                p.reset(&AgentCtx { scenario: Arc::clone(&self.scenario), team: Team::Two, units, seed });
                self.opponent = Some(p);
            }
        }
        self.builtin = (self.opponent_kind == Some(OpponentKind::Builtin)).then(|| BuiltinAi::new(&self.scenario, &mut self.world));
        if let Some(ai) = self.builtin.as_mut() {
            ai.before_loop(&mut self.world, &self.agents[Team::Two.index()]);
        }
        if self.cfg.epo() {
            self.epo = Team::BOTH.map(|t| {
                let l = &self.layouts[t.index()];
                Epo::new(seed, t.index(), l.n_enemies, l.n_agents)
            });
            self.update_epo();
        }
    }

    /// Extended partial observability after a reset or a step (see `epo`).
    pub(super) fn update_epo(&mut self) {
        if !self.cfg.epo() {
            return;
        }
        for t in Team::BOTH {
            self.epo[t.index()].update(&self.layouts[t.index()], &self.world, self.cfg.prob_obs_enemy);
        }
    }

    /// Whether extended partial observability lets `team`'s agent observe enemy `enemy`
    /// (the index in its observation's enemy rows) now; always true while EPO is off.
    pub fn epo_allows(&self, team: Team, agent: usize, enemy: usize) -> bool {
        !self.cfg.epo() || self.epo[team.index()].allowed(agent, enemy)
    }

    /// This episode's scenario: for a procedural scenario, the units drawn from its seed.
    pub fn scenario(&self) -> &Arc<Scenario> {
        &self.scenario
    }
    /// The scenario as loaded (for a procedural one, the distribution's).
    pub fn template(&self) -> &Arc<Scenario> {
        &self.template
    }
    pub fn config(&self) -> &EnvConfig {
        &self.cfg
    }
    pub fn world(&self) -> &World {
        &self.world
    }
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// The opponent policy drawn for this episode (PvE).
    pub fn opponent(&self) -> Option<OpponentKind> {
        self.opponent_kind
    }
    /// Units a team's agents control, in agent order.
    pub fn agents(&self, team: Team) -> &[UnitId] {
        &self.agents[team.index()]
    }
    /// Whether a team's units take actions from agents (team 1 always; team 2 in PvP).
    pub fn is_agent_team(&self, team: Team) -> bool {
        team == Team::One || self.scenario.mode == Mode::Pvp
    }
    pub fn outcome(&self) -> Option<Outcome> {
        self.outcome
    }
    pub fn done(&self) -> bool {
        self.outcome.is_some()
    }
    /// Whether the episode ended at its time limit rather than in the game (SMAC's
    /// `episode_limit`: a learner bootstraps there instead of treating it as terminal).
    pub fn truncated(&self) -> bool {
        self.outcome.is_some() && self.terminal().is_none()
    }
    pub fn steps(&self) -> u32 {
        self.steps
    }
    pub fn time_limit_loops(&self) -> u32 {
        self.cfg.time_limit_loops.map_or(self.scenario.time_limit_loops, NonZeroU32::get)
    }
    /// Actions refused so far this episode, per team.
    pub fn refused(&self) -> [u32; 2] {
        self.refused
    }
    /// Running hash of the trajectory: the seed, then every step's [`Env::state_hash`], chained.
    pub fn trajectory_hash(&self) -> u64 {
        self.trajectory.finish()
    }

    /// Hash of the full state of the episode: the world's ([`World::state_hash`]) plus what
    /// the environment keeps between steps (the policies' RNG, the opponent, the built-in
    /// AI's opening, the step, the outcome, last actions, dense-reward bookkeeping) and the
    /// configuration. Equal hashes at a step mean equal futures under equal actions.
    pub fn state_hash(&self) -> u64 {
        let Env {
            // The drawn scenario is a function of the template and the seed, both hashed (the
            // template through the world's units).
            template: _,
            scenario: _,
            cfg,
            world,
            seed,
            opponent: _,
            opponent_kind,
            policy_rng,
            builtin,
            outcome,
            steps,
            // Refused actions change nothing, and a replay re-applies only accepted ones.
            refused: _,
            last_actions,
            pending_actions,
            dense,
            // Fixed by the scenario (as are the agents' order, the opponent policy's setup
            // and the SMAC layouts); the trajectory is what this hash feeds.
            agents: _,
            max_reward: _,
            layouts: _,
            trajectory: _,
            epo,
        } = self;
        let mut h = Fnv::default();
        h.u64(world.state_hash());
        h.u64(*seed);
        // The rules are hashed with the world, which holds a copy.
        // The reward's settings change what is paid, never what happens.
        let EnvConfig {
            step_mul,
            rules: _,
            reward,
            opponent,
            time_limit_loops,
            ability_actions,
            prob_obs_enemy,
            action_mask,
            fov_actions,
            dense_reward: _,
            // What the state reads, not what happens.
            state_agent: _,
        } = cfg;
        h.u32(step_mul.get());
        h.u32(*reward as u32 | (*ability_actions as u32) << 4);
        h.u32(opponent.map_or(0, |o| o as u32 + 1));
        h.u32(time_limit_loops.map_or(0, NonZeroU32::get));
        // Hashed only when on, so that every trajectory hash recorded before they existed
        // still holds.
        if cfg.epo() {
            h.f32(*prob_obs_enemy);
            epo.iter().for_each(|e| e.hash(&mut h));
        }
        if !action_mask {
            h.u32(0x00a1_1a77);
        }
        if *fov_actions > 0 {
            h.u32(0x0f0f_0000 | u32::from(*fov_actions));
        }
        h.u32(opponent_kind.map_or(0, |o| o as u32 + 1));
        h.rng(policy_rng);
        match builtin {
            None => h.u32(0),
            Some(ai) => {
                h.u32(1);
                ai.hash(&mut h);
            }
        }
        h.u32(outcome.map_or(0, |o| o as u32 + 1));
        h.u32(*steps);
        for a in last_actions.iter().chain(pending_actions.iter()) {
            h.u32(a.len() as u32);
            a.iter().for_each(|x| h.u64(x.map_or(u64::MAX, |i| i as u64)));
        }
        h.u32(dense.prev.len() as u32);
        dense.prev.iter().for_each(|&v| h.f32(v));
        h.bools(dense.dead.iter().copied());
        h.finish()
    }
    pub(crate) fn layouts(&self) -> &[SmacLayout; 2] {
        &self.layouts
    }
    pub(crate) fn count_refused(&mut self, team: Team, n: u32) {
        self.refused[team.index()] += n;
    }
    pub(crate) fn last_actions(&self, team: Team) -> &[Option<usize>] {
        &self.last_actions[team.index()]
    }
    pub(crate) fn set_last_action(&mut self, team: Team, agent: usize, idx: Option<usize>) {
        if let Some(slot) = self.pending_actions[team.index()].get_mut(agent) {
            *slot = idx;
        }
    }
    /// Gives orders to `team`'s units. Each action is checked on its own; a refused one is
    /// counted and leaves that unit's order unchanged.
    pub fn submit(&mut self, team: Team, actions: &[Action]) -> Vec<Result<(), ActionError>> {
        actions.iter().map(|a| self.submit_one(team, a, None)).collect()
    }

    /// Applies one action; `known_index` is its SMAC index when the caller has it already.
    pub(crate) fn submit_one(&mut self, team: Team, a: &Action, known_index: Option<usize>) -> Result<(), ActionError> {
        let r = if self.is_agent_team(team) || self.world.unit(a.unit).is_none() {
            self.world.apply(team, a)
        } else {
            Err(ActionError::Unavailable { unit: a.unit, why: crate::action::Inability::OpponentDriven { team } })
        };
        match r {
            Err(_) => self.refused[team.index()] += 1,
            Ok(()) => {
                if let Some(agent) = self.agents[team.index()].iter().position(|&u| u == a.unit) {
                    let idx = known_index.or_else(|| command_index(self, team, agent, &a.command));
                    self.set_last_action(team, agent, idx);
                }
            }
        }
        r
    }

    /// Win when the other side can no longer fight, loss when this side cannot, draw when
    /// neither can (SMAC's rule, with "only Medivacs left" generalised to units without weapons).
    pub(super) fn terminal(&self) -> Option<Outcome> {
        match (self.world.can_fight(Team::One), self.world.can_fight(Team::Two)) {
            (true, true) => None,
            (true, false) => Some(Outcome::Win),
            (false, true) => Some(Outcome::Loss),
            (false, false) => Some(Outcome::Draw),
        }
    }
}

impl Env {
    pub fn smac_layout(&self, team: Team) -> &SmacLayout {
        &self.layouts()[team.index()]
    }

    /// SMAC's `get_env_info()` for a team's agents.
    pub fn env_info(&self, team: Team) -> EnvInfo {
        let l = self.smac_layout(team);
        EnvInfo {
            n_agents: l.n_agents,
            n_actions: l.n_actions,
            obs_shape: l.obs_size,
            state_shape: l.state_size,
            episode_limit: self.time_limit_loops().div_ceil(self.config().step_mul.get()) as usize,
        }
    }

    pub fn obs_agent(&self, team: Team, agent: usize, out: &mut [f32]) {
        let l = self.smac_layout(team);
        l.obs(self.world(), agent, out);
        if self.cfg.epo() {
            self.epo[team.index()].mask(l, agent, out);
        }
    }

    pub fn state(&self, team: Team, out: &mut [f32]) {
        self.smac_layout(team).state(self.world(), self.last_actions(team), out)
    }

    pub fn avail_agent(&self, team: Team, agent: usize, out: &mut [u8]) {
        self.smac_layout(team).avail_actions(self.world(), agent, out)
    }

    /// Submits one SMAC action index per agent of `team`; unavailable indices are refused
    /// and counted like any invalid action.
    pub fn submit_indices(&mut self, team: Team, indices: &[usize]) -> Vec<Result<(), IndexError>> {
        let (n_agents, n_actions) = (self.smac_layout(team).n_agents, self.smac_layout(team).n_actions);
        if indices.len() != n_agents {
            self.count_refused(team, 1);
            return vec![Err(IndexError::WrongCount(indices.len(), n_agents))];
        }
        let mut out = Vec::with_capacity(indices.len());
        for (agent, &index) in indices.iter().enumerate() {
            let checked = {
                let l = self.smac_layout(team);
                if index >= n_actions {
                    Err(IndexError::OutOfRange { agent, index, n_actions })
                } else if !l.is_available(self.world(), agent, index) {
                    Err(IndexError::Unavailable { agent, index })
                } else {
                    l.command_for(self.world(), agent, index).map(|c| (l.agents[agent], c)).ok_or(IndexError::OutOfRange {
                        agent,
                        index,
                        n_actions,
                    })
                }
            };
            match checked {
                Err(e) => {
                    self.count_refused(team, 1);
                    out.push(Err(e));
                }
                Ok((_, Command::NoOp)) => {
                    self.set_last_action(team, agent, Some(0));
                    out.push(Ok(()));
                }
                Ok((unit, command)) => {
                    out.push(self.submit_one(team, &Action::new(unit, command), Some(index)).map_err(IndexError::from));
                }
            }
        }
        out
    }
}

/// Both teams' SMAC layouts under `cfg`'s options.
fn layouts(scenario: &Scenario, cfg: &EnvConfig) -> [SmacLayout; 2] {
    Team::BOTH.map(|t| {
        SmacLayout::with_abilities(scenario, t, cfg.ability_actions)
            .with_range_mask(cfg.action_mask)
            .with_fov(cfg.fov_actions)
            .with_state_agent(cfg.state_agent)
    })
}

pub(crate) fn command_index(env: &Env, team: Team, agent: usize, c: &Command) -> Option<usize> {
    env.smac_layout(team).index_for(env.world(), agent, c)
}
