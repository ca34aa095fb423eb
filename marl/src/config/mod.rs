//! One config per algorithm (`configs/{iql,vdn,qmix}.toml`, PyMARL's defaults;
//! `configs/{ippo,mappo}.toml`, the MAPPO repository's), built into the crate so
//! `train --algo qmix` needs no file, with `key=value` overrides checked against the keys the
//! file has: a typo names the key instead of being silently ignored.
//!
//! The Q-learning and PPO families share one [`Config`]; the keys only one family reads
//! default when absent (`#[serde(default)]`), so each file lists only what its algorithm
//! uses, and an override of a key the file lacks is refused like a typo.

use crate::Error;
mod env;
mod league;
mod obs;
mod ppo;

pub use crate::opponent::Opponent;
use avacraft_engine::{DataSet, RewardMode, Scenario, WeaponPeriod};
pub use league::ScriptDraw;
pub use obs::{Backbone, ObsKind, SwinSizes};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The algorithms with a built-in config.
pub const ALGOS: &[&str] = &["iql", "vdn", "qmix", "qtran", "ippo", "mappo"];

const IQL: &str = include_str!("../../configs/iql.toml");
const VDN: &str = include_str!("../../configs/vdn.toml");
const QMIX: &str = include_str!("../../configs/qmix.toml");
const QTRAN: &str = include_str!("../../configs/qtran.toml");
const IPPO: &str = include_str!("../../configs/ippo.toml");
const MAPPO: &str = include_str!("../../configs/mappo.toml");

/// How the agents' Q-values combine into the team's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MixerKind {
    /// Independent learners: each agent's own TD error on the team reward (IQL).
    #[default]
    None,
    /// The sum of the agents' Q-values (VDN).
    Vdn,
    /// A monotonic mixing network whose weights a hypernetwork makes from the state (QMIX).
    Qmix,
    /// A joint action-value network and a state value that the agents' summed Q-values are
    /// held to (QTRAN-base).
    Qtran,
}

/// Every setting of a run (see the TOML files for what each means).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub algo: String,
    #[serde(default)]
    pub mixer: MixerKind,
    pub gamma: f64,
    pub lr: f64,
    #[serde(default)]
    pub optim_alpha: f64,
    pub optim_eps: f64,
    pub grad_norm_clip: f64,
    #[serde(default)]
    pub optimizer: crate::optim::OptimizerKind,
    /// TD(lambda) targets (PyMARL2); 0: one-step targets (PyMARL).
    #[serde(default)]
    pub td_lambda: f64,
    #[serde(default)]
    pub batch_size: usize,
    #[serde(default)]
    pub buffer_size: usize,
    #[serde(default)]
    pub target_update_interval: u64,
    #[serde(default)]
    pub double_q: bool,
    #[serde(default)]
    pub epsilon_start: f64,
    #[serde(default)]
    pub epsilon_finish: f64,
    #[serde(default)]
    pub epsilon_anneal_time: u64,
    pub rnn_hidden_dim: usize,
    /// A GRU agent (PyMARL); false: a feed-forward one (EPyMARL's `use_rnn: False`).
    #[serde(default = "yes")]
    pub use_rnn: bool,
    pub obs_agent_id: bool,
    pub obs_last_action: bool,
    #[serde(default)]
    pub mixing_embed_dim: usize,
    #[serde(default)]
    pub hypernet_layers: usize,
    #[serde(default)]
    pub hypernet_embed: usize,
    pub t_max: u64,
    pub envs: usize,
    #[serde(default)]
    pub episodes_per_update: u64,
    pub test_interval: u64,
    pub test_nepisode: usize,
    pub reward: RewardMode,
    pub passive_agents: bool,
    /// The unit data the run plays: `map` (the scenario's own, its map's) or a data set
    /// (`liberty`, `void`, `ladder`, `legacy`). Training writes the set it resolved to, so a
    /// checkpoint names the game it learned; one without the key was trained on `legacy`,
    /// the only game there was before.
    #[serde(default = "legacy_data")]
    pub data: String,
    /// Where weapons' periods are counted from: `attack` (the engine's reading) or `shot` (an
    /// experiment on the one mechanic the game's data leaves open: docs/smac.md).
    #[serde(default, skip_serializing_if = "WeaponPeriod::is_attack")]
    pub weapon_period: WeaponPeriod,
    /// The surround experiment (`Rules::melee_surround`, off): melee units walk round those
    /// already at their target to a free place beside it (docs/smac.md).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub melee_surround: bool,
    /// SMAC's `reward_only_positive` (the default) and `reward_negative_scale`: false takes
    /// the team's own losses off the dense reward at that scale (SMAC's signed reward).
    /// Left out of saved configs at SMAC's defaults.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub reward_only_positive: bool,
    #[serde(default = "half", skip_serializing_if = "is_half")]
    pub reward_negative_scale: f64,
    /// PvP: team 2's agent while team 1 learns (see the config files); empty: none.
    #[serde(default)]
    pub opponent: Opponent,
    /// Self-play (`opponent = "self"`): updates between snapshots of the learner joining
    /// team 2's pool.
    #[serde(default = "league::default_self_play_every")]
    pub self_play_every: u64,
    /// Self-play: snapshots kept in the pool (team 2 draws one per episode).
    #[serde(default = "league::default_self_play_pool")]
    pub self_play_pool: usize,
    /// Self-play as a small league: scripted agents that join the snapshots in team 2's pool
    /// (e.g. `["focus-fire", "kite", "attack-move", "random"]`); empty: snapshots only.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub self_play_scripts: Vec<String>,
    /// The share of episodes in which team 2 plays one of `self_play_scripts` (drawn
    /// uniformly) instead of a snapshot; every episode before the first snapshot does.
    #[serde(default = "league::default_script_share", skip_serializing_if = "league::is_default_script_share")]
    pub self_play_script_share: f64,
    /// How team 2 draws among `self_play_scripts`: `uniform`, or `pfsp` (prioritised
    /// fictitious self-play: each script weighted by how often the learner's last greedy test
    /// round lost to it, so the scripts it cannot beat come up most).
    #[serde(default, skip_serializing_if = "ScriptDraw::is_uniform")]
    pub self_play_script_draw: ScriptDraw,
    /// PvP: fixed opponents every test round also plays (greedy), logged as
    /// `test_win_rate_vs_<name>` and drawn in the curves; under self-play, empty means
    /// attack-move and focus-fire.
    #[serde(default)]
    pub test_opponents: Vec<String>,
    /// QTRAN's weights of its optimal-action and non-optimal-action losses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub opt_loss: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nopt_min_loss: Option<f64>,
    /// Steps before a time-out; 0: the scenario's time limit.
    #[serde(default)]
    pub episode_limit: u32,
    /// SMACv2's extended partial observability (`EnvConfig::prob_obs_enemy`); 1: off.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub prob_obs_enemy: f64,
    /// SMAC's range mask on attack actions; false: SMACv2's `action_mask: False`.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub action_mask: bool,
    /// SMACv2's conic fields of view (`EnvConfig::fov_actions`), with `num_fov_actions` look
    /// actions (SMACv2's default 12).
    #[serde(default, skip_serializing_if = "is_false")]
    pub conic_fov: bool,
    #[serde(default = "twelve", skip_serializing_if = "is_twelve")]
    pub num_fov_actions: i64,
    /// The ability slots after SMAC's actions (`EnvConfig::ability_actions`): Blink, Stim,
    /// Siege and the rest of the units' abilities as actions of their own, and their
    /// readiness in the observation. Off: SMAC's actions only.
    #[serde(default, skip_serializing_if = "is_false")]
    pub ability_actions: bool,
    // PPO (ippo, mappo) only; see configs/mappo.toml.
    #[serde(default)]
    pub critic_lr: f64,
    #[serde(default)]
    pub rollout_len: usize,
    #[serde(default)]
    pub data_chunk_length: usize,
    #[serde(default)]
    pub ppo_epochs: usize,
    #[serde(default)]
    pub num_mini_batch: usize,
    #[serde(default)]
    pub clip_param: f64,
    #[serde(default)]
    pub entropy_coef: f64,
    #[serde(default)]
    pub value_loss_coef: f64,
    #[serde(default)]
    pub gae_lambda: f64,
    #[serde(default)]
    pub huber_delta: f64,
    #[serde(default)]
    pub value_norm: bool,
    #[serde(default)]
    pub clip_value_loss: bool,
    #[serde(default)]
    pub actor_out_gain: f64,
    /// IPPO: the critic is a value head on the actor's trunk (JaxMARL's `ActorCriticRNN`)
    /// rather than a network of its own.
    #[serde(default)]
    pub shared_trunk: bool,
    /// MAPPO: the critic reads the agent's own observation beside the global state, a stand-in
    /// for the MAPPO repository's agent-specific state (`use_state_agent`). Left out of saved
    /// configs when false, so that runs from before it read as they were.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub critic_agent_obs: bool,
    /// The MAPPO repository's agent-specific state (`use_state_agent`) in place of SMAC's
    /// global state: the environment's state is every agent's row of every unit as seen from
    /// it, and MAPPO's critic reads each agent's own row. Left out of saved configs when false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub state_agent: bool,
    /// PPO: the MAPPO repository's network for actor and critic (layer norms on the inputs
    /// and after every hidden layer, a second hidden layer before the GRU, orthogonal
    /// initialisation: [`crate::nets::AgentNet::normed`]). Left out of saved configs when
    /// false, so that runs from before it read as they were.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub layer_norm: bool,
    /// PPO: the networks read each agent's last `stacked_frames` observations (the critic its
    /// last states), the MAPPO repository's `stacked_frames` ([`crate::Stack`]); 1: this
    /// step's alone. Left out of saved configs when 1, so that runs from before it read as
    /// they were.
    #[serde(default = "one_frame", skip_serializing_if = "is_one_frame")]
    pub stacked_frames: usize,
    // The observation mode and its encoder (`configs/obs.toml`, merged into every config;
    // the defaults let checkpoints older than these keys load as `features` runs).
    #[serde(default)]
    pub obs: ObsKind,
    #[serde(default)]
    pub encoder: Backbone,
    #[serde(default = "obs::screen_size")]
    pub screen_size: [u32; 2],
    #[serde(default = "obs::minimap_size")]
    pub minimap_size: [u32; 2],
    #[serde(default = "obs::encoder_dim")]
    pub encoder_dim: usize,
    #[serde(default = "obs::cnn_channels")]
    pub cnn_channels: Vec<usize>,
    #[serde(default = "obs::cnn_pool")]
    pub cnn_pool: usize,
    #[serde(default = "obs::swin_patch")]
    pub swin_patch: usize,
    #[serde(default = "obs::swin_embed_dim")]
    pub swin_embed_dim: usize,
    #[serde(default = "obs::swin_depths")]
    pub swin_depths: Vec<usize>,
    #[serde(default = "obs::swin_heads")]
    pub swin_heads: Vec<usize>,
    #[serde(default = "obs::swin_window")]
    pub swin_window: usize,
    #[serde(default = "obs::text_dim")]
    pub text_dim: usize,
    #[serde(default = "obs::text_cache")]
    pub text_cache: usize,
    #[serde(default = "obs::text_max_tokens")]
    pub text_max_tokens: usize,
    #[serde(default = "yes")]
    pub text_disk_cache: bool,
}

fn one() -> f64 {
    1.0
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

fn one_frame() -> usize {
    1
}

fn is_one_frame(v: &usize) -> bool {
    *v == 1
}

fn half() -> f64 {
    0.5
}

fn is_half(v: &f64) -> bool {
    *v == 0.5
}

fn is_false(v: &bool) -> bool {
    !*v
}

fn twelve() -> i64 {
    12
}

fn is_twelve(v: &i64) -> bool {
    *v == 12
}

fn is_true(v: &bool) -> bool {
    *v
}

fn yes() -> bool {
    true
}

/// The built-in config text of `algo`.
pub fn default_text(algo: &str) -> Result<&'static str, Error> {
    match algo {
        "iql" => Ok(IQL),
        "vdn" => Ok(VDN),
        "qmix" => Ok(QMIX),
        "qtran" => Ok(QTRAN),
        "ippo" => Ok(IPPO),
        "mappo" => Ok(MAPPO),
        other => Err(Error::UnknownAlgo { algo: other.to_owned(), known: ALGOS.join(", ") }),
    }
}

/// `data = "map"`: the scenario's own unit data.
pub const MAP_DATA: &str = "map";

fn legacy_data() -> String {
    DataSet::Legacy.name().to_owned()
}

impl Config {
    /// Whether team 2 is the learner's own snapshot pool (`opponent = "self"`).
    pub fn self_play(&self) -> bool {
        self.opponent == Opponent::SelfPlay
    }

    /// The fixed opponents a test round also plays: `test_opponents`, or under self-play
    /// attack-move and focus-fire when it is empty.
    pub fn fixed_test_opponents(&self) -> Vec<String> {
        if self.test_opponents.is_empty() && self.self_play() {
            return vec!["attack-move".into(), "focus-fire".into()];
        }
        self.test_opponents.clone()
    }

    /// The built-in config of `algo` with `overrides` (`key=value`, the value in TOML syntax;
    /// a bare word is taken as a string) applied in order.
    pub fn for_algo(algo: &str, overrides: &[String]) -> Result<Config, Error> {
        Self::from_toml(default_text(algo)?, overrides)
    }

    /// A config from TOML text with overrides, every key checked.
    pub fn from_toml(text: &str, overrides: &[String]) -> Result<Config, Error> {
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        obs::add_defaults(&mut table)?;
        env::add_default_keys(&mut table);
        table.entry("data").or_insert(toml::Value::String(MAP_DATA.to_owned()));
        league::add_default_keys(&mut table);
        Self::apply(table, overrides)
    }

    /// This config with `overrides` applied as [`Config::from_toml`] applies them, checked
    /// (a resumed run's config with `--set`).
    pub fn overridden(&self, overrides: &[String]) -> Result<Config, Error> {
        let mut table = toml::Table::try_from(self).map_err(|e| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        // A saved config leaves the league's and the environment's options out at their
        // defaults; `--set` may name them.
        env::add_default_keys(&mut table);
        league::add_default_keys(&mut table);
        Self::apply(table, overrides)
    }

    /// `overrides` (`key=value`, the value in TOML syntax) applied to `table` in order, every
    /// key checked, then the whole config.
    fn apply(mut table: toml::Table, overrides: &[String]) -> Result<Config, Error> {
        for o in overrides {
            let Some((key, value)) = o.split_once('=') else {
                return Err(Error::Override { text: o.clone(), message: "expected key=value".into() });
            };
            let key = key.trim();
            let Some(old) = table.get(key) else {
                let known: Vec<&str> = table.keys().map(String::as_str).collect();
                return Err(Error::UnknownKey { key: key.to_owned(), known: known.join(", ") });
            };
            let new = parse_value(value.trim(), old).map_err(|message| Error::Override { text: o.clone(), message })?;
            table.insert(key.to_owned(), new);
        }
        let cfg: Config =
            table.try_into().map_err(|e: toml::de::Error| Error::ConfigParse { what: "config".into(), message: e.to_string() })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// PPO (`ippo`, `mappo`) rather than Q-learning.
    pub fn is_ppo(&self) -> bool {
        matches!(self.algo.as_str(), "ippo" | "mappo")
    }

    /// The data set the run plays on `scenario` (`map`: the scenario's own).
    pub fn data_set(&self, scenario: &Scenario) -> Result<DataSet, Error> {
        if self.data == MAP_DATA {
            return Ok(scenario.data);
        }
        self.data.parse::<DataSet>().map_err(|e| Error::ConfigParse { what: "data".into(), message: e.to_string() })
    }

    /// This config and `scenario` as a run plays them: the scenario on the config's data set,
    /// and the config naming that set (not `map`), as its checkpoints record it.
    pub fn resolved(&self, scenario: Arc<Scenario>) -> Result<(Config, Arc<Scenario>), Error> {
        let d = self.data_set(&scenario)?;
        let scenario = if d == scenario.data {
            scenario
        } else {
            Arc::new(scenario.with_data(d).map_err(|e| Error::ConfigParse { what: "data".into(), message: e.to_string() })?)
        };
        Ok((Config { data: d.name().to_owned(), ..self.clone() }, scenario))
    }

    pub fn validate(&self) -> Result<(), Error> {
        if self.data != MAP_DATA {
            self.data.parse::<DataSet>().map_err(|e| Error::ConfigParse { what: "data".into(), message: e.to_string() })?;
        }
        let default = Config::for_algo_unchecked(&self.algo);
        let def = |f: fn(&Config) -> f64, fallback: f64| default.as_ref().map_or(fallback, f);
        unit("gamma", self.gamma)?;
        unit("prob_obs_enemy", self.prob_obs_enemy)?;
        if self.conic_fov && avacraft_engine::check_fov_actions(self.num_fov_actions).is_err() {
            let n = self.num_fov_actions.clamp(2, i64::from(avacraft_engine::MAX_FOV_ACTIONS));
            let rule = format!("must be an even number from 2 to {} (the look actions of conic_fov)", avacraft_engine::MAX_FOV_ACTIONS);
            return Err(bad("num_fov_actions", self.num_fov_actions, &rule, n - n % 2));
        }
        // The rest of the engine's checks (SMAC's reward settings among them).
        if let Err(b) = self.env_options().config() {
            return Err(bad(b.option, b.value, &b.supported, "SMAC's default"));
        }
        positive("lr", self.lr, def(|c| c.lr, 5e-4))?;
        for (i, o) in self.test_opponents.iter().enumerate() {
            if let Err(why) = Opponent::parse(o) {
                return Err(bad(&format!("test_opponents[{i}]"), format!("{o:?}"), &why.to_string(), "\"focus-fire\""));
            }
            if o.trim() == "self" || o.trim().is_empty() {
                return Err(bad(
                    &format!("test_opponents[{i}]"),
                    format!("{o:?}"),
                    "a fixed opponent: scripted:NAME or marl:DIR",
                    "\"focus-fire\"",
                ));
            }
        }
        at_least("self_play_every", self.self_play_every, 1)?;
        at_least("self_play_pool", self.self_play_pool, 1)?;
        for (i, name) in self.self_play_scripts.iter().enumerate() {
            if avacraft_engine::agent::factory(name).is_err() {
                let known: Vec<&str> = avacraft_engine::agent::AGENTS.iter().map(|(n, _)| *n).collect();
                return Err(bad(
                    &format!("self_play_scripts[{i}]"),
                    format!("{name:?}"),
                    &format!("one of {}", known.join(", ")),
                    "\"focus-fire\"",
                ));
            }
        }
        if !(0.0..=1.0).contains(&self.self_play_script_share) {
            return Err(bad("self_play_script_share", self.self_play_script_share.to_string(), "a share between 0 and 1", "0.5"));
        }
        at_least("envs", self.envs, 1)?;
        at_least("rnn_hidden_dim", self.rnn_hidden_dim, 1)?;
        if self.is_ppo() {
            return self.validate_ppo(&def);
        }
        if self.stacked_frames != 1 {
            let why = "stacking is built for IPPO and MAPPO (the Q-learners' replay batch reads one step's observation)";
            return Err(bad("stacked_frames", self.stacked_frames, why, 1));
        }
        at_least("batch_size", self.batch_size, 1)?;
        at_least("buffer_size", self.buffer_size, self.batch_size)
            .map_err(|e| rule(e, "must hold at least batch_size episodes (batch_size is the nearest)"))?;
        at_least("episodes_per_update", self.episodes_per_update, 1)?;
        at_least("mixing_embed_dim", self.mixing_embed_dim, 1)?;
        at_least("hypernet_embed", self.hypernet_embed, 1)?;
        if !(1..=2).contains(&self.hypernet_layers) {
            return Err(bad("hypernet_layers", self.hypernet_layers, "must be 1 or 2", self.hypernet_layers.clamp(1, 2)));
        }
        unit("td_lambda", self.td_lambda)?;
        if (self.mixer == MixerKind::Qtran) != self.opt_loss.is_some() || self.opt_loss.is_some() != self.nopt_min_loss.is_some() {
            let nearest = if self.mixer == MixerKind::Qtran { "opt_loss = 1.0 with nopt_min_loss = 0.1" } else { "no opt_loss" };
            return Err(bad(
                "opt_loss",
                format!("{:?}", self.opt_loss),
                "QTRAN (mixer = \"qtran\") needs opt_loss and nopt_min_loss; other mixers have neither",
                nearest,
            ));
        }
        at_least("target_update_interval", self.target_update_interval, 1)?;
        validate_obs(self)?;
        Ok(())
    }

    /// The built-in config of `algo` as it is (no overrides, no checks).
    fn for_algo_unchecked(algo: &str) -> Option<Config> {
        let mut table: toml::Table = toml::from_str(default_text(algo).ok()?).ok()?;
        obs::add_defaults(&mut table).ok()?;
        table.try_into().ok()
    }

    /// Epsilon after `t_env` environment steps (linear, then flat).
    pub fn epsilon(&self, t_env: u64) -> f64 {
        let frac = if self.epsilon_anneal_time == 0 { 1.0 } else { (t_env as f64 / self.epsilon_anneal_time as f64).min(1.0) };
        self.epsilon_start + (self.epsilon_finish - self.epsilon_start) * frac
    }
}

// Beside the config rather than the type: `encoders::settings` holds the types of the
// config's observation keys, so it cannot read the config itself.
impl SwinSizes {
    /// The sizes `cfg` selects.
    pub fn of(cfg: &Config) -> SwinSizes {
        match cfg.encoder {
            Backbone::SwinTiny => SwinSizes::tiny(),
            _ => SwinSizes {
                patch: cfg.swin_patch,
                embed_dim: cfg.swin_embed_dim,
                depths: cfg.swin_depths.clone(),
                heads: cfg.swin_heads.clone(),
                window: cfg.swin_window,
            },
        }
    }
}

/// Checks the observation keys of `cfg`.
fn validate_obs(cfg: &Config) -> Result<(), Error> {
    let refuse = |key: &str, value: String, why: &str, nearest: String| Err(bad(key, value, why, nearest));
    for (key, size) in [("screen_size", cfg.screen_size), ("minimap_size", cfg.minimap_size)] {
        if size.iter().any(|&s| !(8..=4096).contains(&s)) {
            let near = size.map(|s| s.clamp(8, 4096));
            return refuse(key, format!("{size:?}"), "frame sides must lie in 8..=4096 pixels", format!("{near:?}"));
        }
    }
    if !(2..=512).contains(&cfg.text_max_tokens) {
        return refuse(
            "text_max_tokens",
            cfg.text_max_tokens.to_string(),
            "must lie in 2..=512 (BERT's positions)",
            cfg.text_max_tokens.clamp(2, 512).to_string(),
        );
    }
    for (key, v) in [("encoder_dim", cfg.encoder_dim), ("text_dim", cfg.text_dim), ("cnn_pool", cfg.cnn_pool)] {
        if v == 0 {
            return refuse(key, "0".into(), "must be at least 1", "1".into());
        }
    }
    if cfg.cnn_channels.is_empty() || cfg.cnn_channels.contains(&0) {
        let near: Vec<usize> = if cfg.cnn_channels.is_empty() { vec![16] } else { cfg.cnn_channels.iter().map(|&c| c.max(1)).collect() };
        return refuse(
            "cnn_channels",
            format!("{:?}", cfg.cnn_channels),
            "needs at least one convolution, every width at least 1",
            format!("{near:?}"),
        );
    }
    let s = SwinSizes::of(cfg);
    if s.depths.is_empty() || s.depths.len() != s.heads.len() {
        let near: Vec<usize> = s.depths.iter().map(|_| 2).collect();
        return refuse(
            "swin_heads",
            format!("{:?}", s.heads),
            &format!("one head count per stage ({} stages in swin_depths)", s.depths.len()),
            format!("{near:?}"),
        );
    }
    for (key, v) in [("swin_patch", s.patch), ("swin_window", s.window), ("swin_embed_dim", s.embed_dim)] {
        if v == 0 {
            return refuse(key, "0".into(), "Swin sizes must be at least 1", "1".into());
        }
    }
    if s.depths.contains(&0) {
        return refuse(
            "swin_depths",
            format!("{:?}", s.depths),
            "every stage needs at least 1 block",
            format!("{:?}", s.depths.iter().map(|&d| d.max(1)).collect::<Vec<_>>()),
        );
    }
    for (i, &h) in s.heads.iter().enumerate() {
        let width = s.embed_dim << i;
        if h == 0 || !width.is_multiple_of(h) {
            let near = (1..=width).filter(|d| width.is_multiple_of(*d)).min_by_key(|d| d.abs_diff(h)).unwrap_or(1);
            return refuse(
                "swin_heads",
                format!("{:?}", s.heads),
                &format!("stage {} is {width} wide: its {h} heads must divide it", i + 1),
                format!("{near} heads at stage {}", i + 1),
            );
        }
    }
    Ok(())
}

/// The error of a refused value: the key, the value, the rule, the nearest valid value.
pub(crate) fn bad(key: &str, value: impl std::fmt::Display, rule: &str, nearest: impl std::fmt::Display) -> Error {
    Error::BadValue(Box::new(crate::Refused {
        key: key.to_owned(),
        value: value.to_string(),
        rule: rule.to_owned(),
        nearest: nearest.to_string(),
    }))
}

/// `e` with another rule text.
fn rule(e: Error, text: &str) -> Error {
    match e {
        Error::BadValue(mut r) => {
            r.rule = text.to_owned();
            Error::BadValue(r)
        }
        other => other,
    }
}

/// `value` must lie in `[0, 1]`.
fn unit(key: &str, value: f64) -> Result<(), Error> {
    if (0.0..=1.0).contains(&value) {
        Ok(())
    } else {
        Err(bad(key, value, "must lie in [0, 1]", if value.is_nan() { 0.0 } else { value.clamp(0.0, 1.0) }))
    }
}

/// `value` must be above 0 (an open bound: the nearest is the built-in default).
fn positive(key: &str, value: f64, default: f64) -> Result<(), Error> {
    if value > 0.0 { Ok(()) } else { Err(bad(key, value, "must be above 0", format!("any positive value, e.g. the default {default}"))) }
}

/// `value` must be at least `min`.
fn at_least<T: PartialOrd + std::fmt::Display + Copy>(key: &str, value: T, min: T) -> Result<(), Error> {
    if value >= min { Ok(()) } else { Err(bad(key, value, &format!("must be at least {min}"), min)) }
}

/// A TOML value of the same type as `old`; integers widen to floats, bare words are strings.
fn parse_value(text: &str, old: &toml::Value) -> Result<toml::Value, String> {
    let parsed = toml::from_str::<toml::Table>(&format!("v = {text}")).ok().and_then(|mut t| t.remove("v"));
    let v = match (parsed, old) {
        (Some(toml::Value::Integer(i)), toml::Value::Float(_)) => toml::Value::Float(i as f64),
        (Some(v), _) => v,
        (None, toml::Value::String(_)) => toml::Value::String(text.to_owned()),
        (None, _) => return Err(format!("`{text}` is not a TOML value (expected a {})", old.type_str())),
    };
    if std::mem::discriminant(&v) != std::mem::discriminant(old) {
        return Err(format!("expected a {}, got a {}", old.type_str(), v.type_str()));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_data_set_resolves_from_the_map_and_checkpoints_without_it_are_legacy() -> Result<(), Error> {
        let s =
            Arc::new(avacraft_engine::builtin("3m_vlm").map_err(|e| Error::ConfigParse { what: "3m_vlm".into(), message: e.to_string() })?);
        let c = Config::for_algo("qmix", &[])?;
        assert_eq!(c.data, MAP_DATA);
        let (r, played) = c.resolved(Arc::clone(&s))?;
        assert_eq!((r.data.as_str(), played.data), ("liberty", DataSet::Liberty));
        let (r, played) = Config::for_algo("qmix", &["data=\"ladder\"".into()])?.resolved(s)?;
        assert_eq!((r.data.as_str(), played.data), ("ladder", DataSet::Ladder));
        let e = Config::for_algo("qmix", &["data=\"lotv\"".into()]).expect_err("no such set");
        assert!(e.to_string().contains("data") && format!("{e:?}").contains("liberty, void, ladder, legacy"), "{e:?}");
        // A checkpoint's config written before data sets existed: the legacy game.
        let mut json = serde_json::to_value(&r).map_err(|e| Error::ConfigParse { what: "json".into(), message: e.to_string() })?;
        json.as_object_mut().map(|o| o.remove("data"));
        let old: Config = serde_json::from_value(json).map_err(|e| Error::ConfigParse { what: "json".into(), message: e.to_string() })?;
        assert_eq!(old.data, "legacy");
        Ok(())
    }

    #[test]
    fn defaults_load_and_overrides_apply() -> Result<(), Error> {
        for a in ALGOS {
            let c = Config::for_algo(a, &[])?;
            assert_eq!(&c.algo, a);
        }
        let c = Config::for_algo("qmix", &["lr=0.001".into(), "envs=2".into(), "mixer=vdn".into(), "gamma=1".into()])?;
        assert_eq!((c.lr, c.envs, c.mixer, c.gamma), (0.001, 2, MixerKind::Vdn, 1.0));
        Ok(())
    }

    #[test]
    fn bad_keys_and_values_are_named() {
        let e = Config::for_algo("qmix", &["learning_rate=1".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("learning_rate"), "{e}");
        let e = Config::for_algo("qmix", &["envs=many".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("envs=many") && e.contains("integer"), "{e}");
        let e = Config::for_algo("qmix", &["mixer=sum".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("sum"), "{e}");
        let e = Config::for_algo("qmix", &["conic_fov=true".into(), "num_fov_actions=7".into()])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("num_fov_actions = 7") && e.contains("even") && e.contains("nearest valid value: 6"), "{e}");
        let e = Config::for_algo("qmix", &["weapon_period=\"later\"".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("weapon_period") && e.contains("later"), "{e}");
        let e = Config::for_algo("qmix", &["prob_obs_enemy=1.5".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("prob_obs_enemy = 1.5") && e.contains("[0, 1]"), "{e}");
        let e = Config::for_algo("qmix", &["gamma=2.0".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("gamma = 2") && e.contains("[0, 1]") && e.contains("nearest valid value: 1"), "{e}");
        let e = Config::for_algo("ippo", &["rollout_len=117".into(), "data_chunk_length=10".into()])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.starts_with("`rollout_len = 117`")
                && e.contains("multiple of data_chunk_length (10)")
                && e.contains("nearest valid value: 120"),
            "{e}"
        );
        let e = Config::for_algo("ippo", &["envs=2".into(), "rollout_len=20".into(), "num_mini_batch=9".into()])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("num_mini_batch = 9") && e.contains("nearest valid value: 4"), "{e}");
        let e = Config::for_algo("qmix", &["lr=-1".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("lr = -1") && e.contains("default 0.0005"), "{e}");
        let e = Config::for_algo("qmix", &["buffer_size=3".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("buffer_size = 3") && e.contains("nearest valid value: 32"), "{e}");
        assert!(Config::for_algo("coma", &[]).is_err());
    }

    #[test]
    fn obs_toml_matches_the_serde_defaults() -> Result<(), Error> {
        // A config without the keys (as old checkpoints are) and one with obs.toml merged.
        let with = Config::for_algo("qmix", &[])?;
        let mut json = serde_json::to_value(&with).map_err(|source| Error::Json { path: "config".into(), source })?;
        let keys: toml::Table =
            toml::from_str(obs::OBS_DEFAULTS).map_err(|e| Error::ConfigParse { what: "obs.toml".into(), message: e.to_string() })?;
        if let Some(o) = json.as_object_mut() {
            for k in keys.keys() {
                assert!(o.remove(k).is_some(), "{k} is not a Config field");
            }
        }
        let without: Config = serde_json::from_value(json).map_err(|source| Error::Json { path: "config".into(), source })?;
        assert_eq!(with, without);
        Ok(())
    }

    #[test]
    fn bad_swin_heads_are_named() {
        let e = Config::for_algo("qmix", &["swin_heads=[5, 4]".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("swin_heads"), "{e}");
        assert!(Config::for_algo("qmix", &["obs=\"vision-text\"".into(), "encoder=\"swin-tiny\"".into()]).is_ok());
        assert!(Config::for_algo("qmix", &["obs=pixels".into()]).is_err());
    }
}
