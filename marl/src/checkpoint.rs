//! Checkpoints and trained policies as engine agents. A checkpoint directory holds
//! `agent.safetensors` (the shared agent network), `mixer.safetensors` (VDN has no weights,
//! so only QMIX writes one), for PPO `critic.safetensors` (written by the PPO learner, not
//! needed to act), and `config.json` (the run's config, the team's sizes and the
//! scenario). [`MarlAgent`] acts greedily with the agent network on each controlled unit's
//! SMAC features and mask, carrying each unit's GRU state and last action across steps, as
//! in training: decentralised execution, the mixer and critic are not needed. A PPO actor's
//! outputs are logits: the greedy action is the most probable available one.
//!
//! Image-mode checkpoints (`rgb`, `hybrid`, `vision-text`) hold the encoder's weights in
//! `agent.safetensors` too. An engine [`Agent`] is handed units, effects and text, not the
//! world the renderer draws from, so [`MarlAgent`] refuses them; `Policy::evaluate` and
//! `Policy::play_out` (`crate::evaluation`) play them greedily from rendered frames, exactly
//! as training's test episodes do.

use crate::acting::select_actions;
use crate::buffer::{Shape, act_inputs};
use crate::frames::StepFrames;
use crate::kernels::Want;
use crate::nets::Nets;
use crate::{Config, Error};
use avacraft_engine::agent::{FrameNeed, TeamFrames};
use avacraft_engine::{Action, Agent, AgentCtx, GroupObs, Reads, Scenario, SmacLayout, Team};
use candle_core::{Device, Tensor};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

const FORMAT: u32 = 1;
/// The scenario names a checkpoint's `scenario` is written in: 2 since SMAC's maps took SMAC's
/// names ([`avacraft_engine::RENAMED`]). In a checkpoint without it, `3m` meant the paper's
/// scenario, now `3m_vlm`.
const NAMES: u32 = 2;

fn old_names() -> u32 {
    1
}

#[derive(Serialize, Deserialize)]
struct Meta {
    format: u32,
    #[serde(default = "old_names")]
    names: u32,
    scenario: String,
    shape: Shape,
    config: Config,
}

/// Writes a checkpoint of `nets` into `dir` (created if needed).
pub fn save(dir: &Path, nets: &Nets, cfg: &Config, shape: &Shape, scenario: &str) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    crate::aside::tensors(&nets.agent_params.to_map(), &dir.join("agent.safetensors"))?;
    let mixer = nets.mixer_params.to_map();
    if !mixer.is_empty() {
        crate::aside::tensors(&mixer, &dir.join("mixer.safetensors"))?;
    }
    let meta = Meta { format: FORMAT, names: NAMES, scenario: scenario.to_owned(), shape: *shape, config: cfg.clone() };
    let path = dir.join("config.json");
    let text = serde_json::to_string_pretty(&meta).map_err(|source| Error::Json { path: path.clone(), source })?;
    crate::aside::write(&path, text)
}

/// Gives the checkpoint in `dir` another config (a run going on under other settings). Refused,
/// and the checkpoint left as it was, when its weights do not fit the network `cfg` describes.
pub(crate) fn restate(dir: &Path, cfg: &Config) -> Result<(), Error> {
    let path = dir.join("config.json");
    let old = std::fs::read_to_string(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
    let mut meta: Meta = serde_json::from_str(&old).map_err(|source| Error::Json { path: path.clone(), source })?;
    meta.config = cfg.clone();
    let text = serde_json::to_string_pretty(&meta).map_err(|source| Error::Json { path: path.clone(), source })?;
    crate::aside::write(&path, text)?;
    if let Err(e) = Policy::load(dir) {
        crate::aside::write(&path, old)?;
        return Err(e);
    }
    Ok(())
}

/// A trained policy loaded from a checkpoint directory.
#[derive(Debug)]
pub struct Policy {
    pub cfg: Config,
    pub shape: Shape,
    /// The scenario it was trained on.
    pub scenario: String,
    pub nets: Nets,
    /// The agent network's weights flat, for the fused forward pass every actor runs
    /// ([`crate::kernels::NetLayout`]): training's, tests' and agents' actions come from one
    /// implementation.
    pub(crate) theta: Vec<f32>,
}

impl Policy {
    pub fn load(dir: &Path) -> Result<Policy, Error> {
        Policy::load_from(dir, dir)
    }

    /// The policy of the checkpoint in `dir` with the weights in `weights` (a resume's round
    /// keeps its own copy of them: [`crate::resume`]).
    pub(crate) fn load_from(dir: &Path, weights: &Path) -> Result<Policy, Error> {
        let path = dir.join("config.json");
        let text = std::fs::read_to_string(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
        let meta: Meta = serde_json::from_str(&text).map_err(|source| Error::Json { path: path.clone(), source })?;
        if meta.format != FORMAT {
            return Err(Error::Checkpoint { message: format!("{}: format {} (this build reads {FORMAT})", path.display(), meta.format) });
        }
        if meta.config.obs.text() && meta.shape.n_enemies == 0 {
            // Before the clause features, vision-text read one 384-d embedding of the whole
            // text: the projection's weights have no place in today's network.
            return Err(Error::Checkpoint {
                message: format!("{}: a vision-text checkpoint from before the per-unit text features; train it again", path.display()),
            });
        }
        let nets = Nets::new(&meta.config, &meta.shape, 0)?;
        let load = |name: &str| -> Result<_, Error> {
            let p = weights.join(name);
            if !p.is_file() {
                return Err(Error::Checkpoint { message: format!("{} is missing", p.display()) });
            }
            Ok(candle_core::safetensors::load(&p, &Device::Cpu)?)
        };
        nets.agent_params.load_map(&load("agent.safetensors")?, "agent.safetensors")?;
        // A shipped policy ([`ship`]) has no mixer: acting never reads it (resuming a run
        // reads the run's own folder, which has it).
        if nets.mixer_params.vars().next().is_some() && weights.join("mixer.safetensors").is_file() {
            nets.mixer_params.load_map(&load("mixer.safetensors")?, "mixer.safetensors")?;
        }
        let theta = nets.agent_params.flat(nets.agent.var_count())?;
        let scenario = match avacraft_engine::renamed(&meta.scenario) {
            Some(now) if meta.names < NAMES => now.to_owned(),
            _ => meta.scenario,
        };
        Ok(Policy { cfg: meta.config, shape: meta.shape, scenario, nets, theta })
    }

    /// The frames the checkpoint in `dir` reads ([`Policy::frames_need`]), from its
    /// `config.json` alone.
    pub fn frames_need_in(dir: &Path) -> Result<Option<FrameNeed>, Error> {
        let meta = meta_in(dir)?;
        Ok(need_of(&meta.config))
    }

    /// The unit data the checkpoint in `dir` trained on, from its `config.json` alone (one
    /// written before data sets existed trained on `legacy`).
    pub fn data_in(dir: &Path) -> Result<avacraft_engine::DataSet, Error> {
        let meta = meta_in(dir)?;
        meta.config.data.parse().map_err(|e: avacraft_engine::UnknownDataSet| Error::Checkpoint { message: e.to_string() })
    }

    /// Where the weapons' periods were counted from in the games the network in `dir` learned
    /// (its `config.json` alone; `attack`, the engine's reading, when the key is absent).
    pub fn weapon_period_in(dir: &Path) -> Result<avacraft_engine::WeaponPeriod, Error> {
        Ok(meta_in(dir)?.config.weapon_period)
    }

    /// The config the checkpoint in `dir` was saved with (its `config.json` alone).
    pub fn config_in(dir: &Path) -> Result<Config, Error> {
        Ok(meta_in(dir)?.config)
    }

    /// Whether the network in `dir` learned under the surround experiment
    /// (`Rules::melee_surround`; its `config.json` alone, false when the key is absent).
    pub fn melee_surround_in(dir: &Path) -> Result<bool, Error> {
        Ok(meta_in(dir)?.config.melee_surround)
    }

    /// The algorithm and the scenario (under today's names) of the checkpoint in `dir`, from
    /// its `config.json` alone.
    pub fn algo_scenario_in(dir: &Path) -> Result<(String, String), Error> {
        let meta = meta_in(dir)?;
        let scenario = match avacraft_engine::renamed(&meta.scenario) {
            Some(now) if meta.names < NAMES => now.to_owned(),
            _ => meta.scenario,
        };
        Ok((meta.config.algo, scenario))
    }

    /// Whether the network in `dir` reads the ability slots (its `config.json` alone): a
    /// game it plays must have them (`EnvConfig::ability_actions`).
    pub fn ability_actions_in(dir: &Path) -> Result<bool, Error> {
        Ok(meta_in(dir)?.config.ability_actions)
    }

    /// A copy of `nets`' agent network as a policy (a self-play snapshot): later updates of
    /// `nets` do not reach it.
    pub fn of(nets: &Nets, cfg: &Config, shape: Shape, scenario: &str) -> Result<Policy, Error> {
        let copy = Nets::new(cfg, &shape, 0)?;
        copy.agent_params.load_map(&nets.agent_params.to_map(), "the learner's agent network")?;
        let theta = copy.agent_params.flat(copy.agent.var_count())?;
        Ok(Policy { cfg: cfg.clone(), shape, scenario: scenario.to_owned(), nets: copy, theta })
    }

    /// Checks that `team`'s agents in `scenario` have the sizes the network was trained on.
    pub fn check_scenario(&self, scenario: &Scenario, team: Team) -> Result<(), Error> {
        let l = self.layout(scenario, team);
        let got = (l.n_agents, l.obs_size, l.n_actions);
        let want = (self.shape.n_agents, self.shape.obs, self.shape.n_actions);
        if got != want {
            return Err(Error::Checkpoint {
                message: format!("trained on {} with (agents, obs, actions) = {want:?}; {} gives {got:?}", self.scenario, scenario.name),
            });
        }
        Ok(())
    }

    /// `team`'s SMAC layout on `scenario` under the options this policy was trained with
    /// (SMACv2's look actions among them): the features and actions its network reads.
    pub fn layout(&self, scenario: &Scenario, team: Team) -> SmacLayout {
        let o = self.cfg.env_options();
        SmacLayout::with_abilities(scenario, team, o.ability_actions).with_fov(u8::try_from(o.fov_actions).unwrap_or(0))
    }

    /// Whether this policy's network reads the ability slots (`ability_actions`): a game
    /// without them cannot give it its observation.
    pub fn ability_actions(&self) -> bool {
        self.cfg.ability_actions
    }

    /// Why an engine agent cannot play this policy (`None`: it can).
    pub fn agent_refusal(&self) -> Option<String> {
        (self.cfg.obs != crate::ObsKind::Features).then(|| {
            format!(
                "trained on `{}` observations: it reads rendered frames, which this run does not show its agents, so only \
                 `features` checkpoints play as agents here (agent nodes of a launch file and `episode --launch` show them \
                 the frames; `avacraft eval` and `episode --agent` play image checkpoints in PvE, from rendered frames)",
                self.cfg.obs.name()
            )
        })
    }

    /// Why an agent handed its team's frames ([`Agent::see`]) still cannot play this policy
    /// for `team` (`None`: it can): `vision-text` also reads the embeddings of the team's
    /// text, which an agent is not handed, and frames are drawn for team 1's side of the
    /// map only (a features network plays team 2 in the mirror image; pixels are not mirrored).
    pub fn seeing_refusal(&self, team: Team) -> Option<String> {
        if self.cfg.obs.text() {
            return Some(format!(
                "trained on `{}` observations: an agent is handed frames but not the text embeddings the encoder also reads \
                 (`avacraft eval` and `episode` play it in PvE, from the game)",
                self.cfg.obs.name()
            ));
        }
        (self.cfg.obs.images() && team == Team::Two).then(|| {
            format!("trained on `{}` observations as team 1: its frames are not drawn in the mirror image for team 2", self.cfg.obs.name())
        })
    }

    /// The frames the network reads (its training's screen and minimap sizes), if any.
    pub fn frames_need(&self) -> Option<FrameNeed> {
        need_of(&self.cfg)
    }

    /// What each row carries from one step to the next ([`Policy::q_values`]'s `hidden`): the
    /// network's hidden state, then (`stacked_frames`) its last observations, oldest first.
    pub fn memory_width(&self) -> usize {
        self.nets.agent.hidden + (self.cfg.stacked_frames.max(1) - 1) * self.shape.obs
    }

    /// Q-values `(rows x n_actions)` and next memories for rows of features: `hidden` and
    /// what comes back are [`Policy::memory_width`] a row (zeros at an episode's start).
    pub fn q_values(
        &self,
        features: &[f32],
        agents: &[usize],
        last: &[Option<u32>],
        hidden: &[f32],
    ) -> Result<(Vec<f32>, Vec<f32>), Error> {
        if let Some(why) = self.agent_refusal() {
            return Err(Error::Checkpoint { message: why });
        }
        self.q_values_seeing(features, agents, last, hidden, None)
    }

    /// What the image encoder makes of one team observation's frames: what every row of the
    /// team reads ([`Policy::q_values_seeing`]), so a deployment computes it once per team and
    /// step (the team's encoder node) and hands it to each agent node.
    pub fn encode_team(&self, frames: &StepFrames) -> Result<Vec<f32>, Error> {
        let Some(e) = &self.nets.encoder else {
            return Err(Error::Observation { message: "this network has no image encoder".into() });
        };
        if frames.n != 1 {
            return Err(Error::Observation { message: "an image encoder needs one team observation's frames".into() });
        }
        if self.cfg.obs.text() {
            return Err(Error::Observation { message: self.seeing_refusal(Team::One).unwrap_or_default() });
        }
        let theta = e.kernel().map(|_| self.nets.encoder_weights()).transpose()?;
        e.encode_pixels(theta.as_deref(), frames)
    }

    /// A name for the image encoder's weights: two checkpoints' team encodings are
    /// interchangeable when their names are equal ([`Agent::encoder`]).
    pub fn encoder_name(&self) -> Option<String> {
        let e = self.nets.encoder.as_ref()?;
        let theta = self.nets.encoder_weights().ok()?;
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        theta.iter().for_each(|w| h.update(&w.to_le_bytes()));
        h.update(&(e.out as u64).to_le_bytes());
        Some(format!("{}-{:016x}", self.cfg.obs.name(), h.digest()))
    }

    /// [`Policy::q_values`] in any mode but `vision-text`: an image mode's rows also read
    /// the encoder's features of its team's frames (one team observation, which every row
    /// sees, as each agent of a team sees its team's frames in training), given as the frames
    /// or as their encoding ([`Policy::encode_team`]).
    pub fn q_values_seeing(
        &self,
        features: &[f32],
        agents: &[usize],
        last: &[Option<u32>],
        hidden: &[f32],
        seen: Option<&Seen>,
    ) -> Result<(Vec<f32>, Vec<f32>), Error> {
        let (id, la) = (self.cfg.obs_agent_id, self.cfg.obs_last_action);
        let rows = agents.len();
        let layout = self.nets.agent.layout();
        let (mw, ow) = (self.memory_width(), self.shape.obs);
        if hidden.len() != rows * mw || features.len() != rows * ow {
            return Err(Error::Checkpoint {
                message: format!(
                    "{rows} rows with {} memory values and {} features; the network carries {mw} and reads {ow} a row",
                    hidden.len(),
                    features.len()
                ),
            });
        }
        // Each row's memory: the network's hidden state, then its last observations.
        let kept = mw - layout.hidden;
        let (h, features) = if kept == 0 {
            (std::borrow::Cow::Borrowed(hidden), std::borrow::Cow::Borrowed(features))
        } else {
            let mut h = Vec::with_capacity(rows * layout.hidden);
            let mut stacked = Vec::with_capacity(rows * (kept + ow));
            for (m, f) in hidden.chunks_exact(mw).zip(features.chunks_exact(ow.max(1))) {
                h.extend_from_slice(&m[..layout.hidden]);
                stacked.extend_from_slice(&m[layout.hidden..]);
                stacked.extend_from_slice(f);
            }
            (std::borrow::Cow::Owned(h), std::borrow::Cow::Owned(stacked))
        };
        let net = self.shape.stacked(self.cfg.stacked_frames);
        let mut x = act_inputs(&features, agents, last, &net, id, la);
        if let Some(e) = &self.nets.encoder {
            let encoded = match seen {
                Some(Seen::Frames(f)) => std::borrow::Cow::Owned(self.encode_team(f)?),
                Some(Seen::Encoded(v)) if v.len() == e.out => std::borrow::Cow::Borrowed(v.as_slice()),
                Some(Seen::Encoded(v)) => {
                    return Err(Error::Observation { message: format!("an encoding {} wide; the encoder gives {}", v.len(), e.out) });
                }
                None => return Err(Error::Observation { message: "an image encoder needs one team observation's frames".into() }),
            };
            let feats = Tensor::from_slice(&encoded, (1, e.out), &Device::Cpu)?.broadcast_as((rows, e.out))?.contiguous()?;
            let base = Tensor::from_vec(x, (rows, net.input(id, la)), &Device::Cpu)?;
            x = e.fuse_rows(feats, &base)?.flatten_all()?.to_vec1()?;
        }
        if x.len() != rows * layout.input {
            return Err(Error::Checkpoint { message: format!("{rows} rows with {} inputs for a network of {layout:?}", x.len()) });
        }
        let f = layout.forward(&self.theta, &x, &h, None, Want::All, 1, rows, false);
        // A feed-forward network's "hidden state" is its core layer's output, as candle's step gives it.
        if kept == 0 {
            return Ok((f.out, f.hidden));
        }
        let mut memory = Vec::with_capacity(rows * mw);
        for ((h2, m), x) in f.hidden.chunks_exact(layout.hidden.max(1)).zip(hidden.chunks_exact(mw)).zip(features.chunks_exact(kept + ow)) {
            memory.extend_from_slice(h2);
            memory.extend(crate::Stack::advance_row(&m[layout.hidden..], &x[kept..]));
        }
        Ok((f.out, memory))
    }
}

/// What an image network is shown of its team's frames for one step.
#[derive(Clone, Debug)]
pub enum Seen {
    Frames(StepFrames),
    /// Their encoding ([`Policy::encode_team`]), computed elsewhere.
    Encoded(Vec<f32>),
}

fn need_of(cfg: &Config) -> Option<FrameNeed> {
    let ((sw, sh), (mw, mh)) = crate::frames::sizes(cfg);
    cfg.obs.images().then_some(FrameNeed { screen: (sw as u32, sh as u32), minimap: (mw as u32, mh as u32) })
}

/// The `config.json` of the checkpoint in `dir`, read without its weights.
fn meta_in(dir: &Path) -> Result<Meta, Error> {
    let path = dir.join("config.json");
    let text = std::fs::read_to_string(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
    serde_json::from_str(&text).map_err(|source| Error::Json { path, source })
}

/// A trained policy acting greedily for the units of its group. On team 2 it plays in the
/// mirror image of the map (policies train as team 1: east and west swap, x is reflected),
/// which is the same game on the left-right mirrored PvP scenarios.
#[derive(Debug, Clone)]
pub struct MarlAgent {
    policy: Arc<Policy>,
    name: String,
    /// Per SMAC agent index: GRU state and last action.
    hidden: Vec<Vec<f32>>,
    last: Vec<Option<u32>>,
    layout: Option<SmacLayout>,
    /// For a network trained without the ability slots: the (observation, actions) sizes of
    /// its layout with them, which a game with the slots hands it ([`Agent::act`]).
    slotted: Option<(usize, usize)>,
    fits: bool,
    /// Playing team 2: the network, trained as team 1, sees and acts in the mirror image
    /// (east and west swapped, x reflected), as on a left-right mirrored map team 1 would.
    mirror: bool,
    /// An image mode's frames of this step, or their encoding ([`Agent::see`],
    /// [`Agent::see_encoded`]), used by the next `act` only.
    seen: Option<Seen>,
}

impl MarlAgent {
    pub fn new(policy: Arc<Policy>, name: impl Into<String>) -> MarlAgent {
        MarlAgent {
            policy,
            name: name.into(),
            hidden: Vec::new(),
            last: Vec::new(),
            layout: None,
            slotted: None,
            fits: false,
            mirror: false,
            seen: None,
        }
    }
    /// Loads the checkpoint in `dir`; the agent is named `marl:DIR`. Image-mode
    /// checkpoints are refused ([`Policy::agent_refusal`]).
    pub fn load(dir: &Path) -> Result<MarlAgent, Error> {
        let policy = Policy::load(dir)?;
        if let Some(why) = policy.agent_refusal() {
            return Err(Error::Checkpoint { message: format!("{}: {why}", dir.display()) });
        }
        Ok(MarlAgent::new(Arc::new(policy), format!("marl:{}", dir.display())))
    }
    pub fn policy(&self) -> &Arc<Policy> {
        &self.policy
    }
    /// `frames` as the network reads them, if they are of its sizes.
    fn step_frames(&self, frames: &TeamFrames) -> Option<StepFrames> {
        self.policy.frames_need().filter(|&need| frames.fits(need)).map(|need| {
            let size = |(w, h): (u32, u32)| (w as usize, h as usize);
            StepFrames::from_pixels(1, (size(need.screen), size(need.minimap)), frames.screen.clone(), frames.minimap.clone())
        })
    }
}

impl Agent for MarlAgent {
    fn name(&self) -> &str {
        &self.name
    }
    fn reads(&self) -> Reads {
        Reads { smac: true, text: false }
    }
    fn reset(&mut self, ctx: &AgentCtx) {
        let n = self.policy.shape.n_agents;
        self.hidden = vec![vec![0.0; self.policy.memory_width()]; n];
        self.last = vec![None; n];
        // A network of other sizes would read other features: it then gives no orders (an
        // image mode's too, at the steps whose frames it was not shown).
        let playable = self.policy.agent_refusal().is_none() || self.policy.seeing_refusal(ctx.team).is_none();
        self.fits = self.policy.check_scenario(&ctx.scenario, ctx.team).is_ok() && playable;
        self.seen = None;
        let layout = self.policy.layout(&ctx.scenario, ctx.team);
        self.slotted = (!self.policy.ability_actions()).then(|| {
            let wide = SmacLayout::with_abilities(&ctx.scenario, ctx.team, true).with_fov(u8::try_from(layout.fov).unwrap_or(0));
            (wide.obs_size, wide.n_actions)
        });
        self.layout = Some(layout);
        self.mirror = ctx.team == Team::Two;
    }
    fn frames(&self) -> Option<FrameNeed> {
        // `vision-text` reads the text's embeddings too, which frames alone do not give it.
        self.policy.frames_need().filter(|_| !self.policy.cfg.obs.text())
    }
    fn see(&mut self, frames: &TeamFrames) {
        self.seen = self.step_frames(frames).map(Seen::Frames);
    }
    fn encoder(&self) -> Option<String> {
        self.frames().and(self.policy.encoder_name())
    }
    fn encode(&self, frames: &TeamFrames) -> Option<Vec<f32>> {
        self.policy.encode_team(&self.step_frames(frames)?).ok()
    }
    fn see_encoded(&mut self, features: &[f32]) {
        self.seen = Some(Seen::Encoded(features.to_vec()));
    }
    fn act(&mut self, g: &GroupObs) -> Vec<Action> {
        let seen = self.seen.take();
        let (Some(layout), true) = (&self.layout, self.fits) else { return Vec::new() };
        let sh = self.policy.shape;
        // A game with the ability slots appends them to SMAC's actions and their readiness to
        // the observation: a policy trained without them reads the part before (its own
        // layout exactly), and acts as it does in a game without them.
        let rows: Vec<_> = g
            .controlled
            .iter()
            .filter(|c| {
                let sizes = (c.features.len(), c.avail_actions.len());
                c.agent < sh.n_agents && (sizes == (sh.obs, sh.n_actions) || Some(sizes) == self.slotted)
            })
            .collect();
        if rows.is_empty() {
            return Vec::new();
        }
        let agents: Vec<usize> = rows.iter().map(|c| c.agent).collect();
        let mut features: Vec<f32> = rows.iter().flat_map(|c| c.features[..sh.obs].iter().copied()).collect();
        let mut avail: Vec<u8> = rows.iter().flat_map(|c| c.avail_actions[..sh.n_actions].iter().copied()).collect();
        if self.mirror {
            features.chunks_exact_mut(sh.obs.max(1)).for_each(|f| layout.mirror_obs(f));
            avail.chunks_exact_mut(sh.n_actions.max(1)).for_each(SmacLayout::mirror_avail);
        }
        let last: Vec<Option<u32>> = agents.iter().map(|&a| self.last[a]).collect();
        let hidden: Vec<f32> = agents.iter().flat_map(|&a| self.hidden[a].iter().copied()).collect();
        let Ok((q, h2)) = self.policy.q_values_seeing(&features, &agents, &last, &hidden, seen.as_ref()) else { return Vec::new() };
        // Greedy: epsilon 0 never draws.
        let acts = select_actions(&q, &avail, sh.n_actions, 0.0, &mut ChaCha8Rng::seed_from_u64(0));
        let width = self.policy.memory_width();
        let mut out = Vec::new();
        for (k, (c, &a)) in rows.iter().zip(&acts).enumerate() {
            self.hidden[c.agent].copy_from_slice(&h2[k * width..(k + 1) * width]);
            // The network's own action (in its image) is its next last-action input.
            self.last[c.agent] = Some(a);
            let a = if self.mirror { layout.mirror_action(a as usize) } else { a as usize };
            if c.alive
                && let Some(command) = layout.command_for_obs(g, c.agent, a)
            {
                out.push(Action::new(c.unit, command));
            }
        }
        out
    }
}
