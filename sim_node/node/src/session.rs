//! The session description a recording carries (`SessionInfo`): built here from the
//! simulator's configuration, and read back into a scenario and an `EnvConfig` by replays,
//! so a recording replays with no file and no flag besides itself.

use crate::config::{Clock, SimConfig};
use avacraft_engine::{EnvConfig, OpponentKind, RewardMode, Rules, Scenario, ScenarioError, WeaponPeriod};
use avacraft_msgs::{Header, SessionInfo};
use std::num::NonZeroU32;

/// Why a `SessionInfo` cannot be turned back into what it describes.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("session field `{field}` = {value}: {why}")]
    Field { field: &'static str, value: String, why: &'static str },
    #[error("the recorded scenario `{name}` does not load")]
    Scenario {
        name: String,
        #[source]
        source: ScenarioError,
    },
}

fn opponent_code(o: Option<OpponentKind>) -> u8 {
    match o {
        None => SessionInfo::OPPONENT_SCENARIO,
        Some(OpponentKind::Builtin) => SessionInfo::OPPONENT_BUILTIN,
        Some(OpponentKind::Aggressive) => SessionInfo::OPPONENT_AGGRESSIVE,
        Some(OpponentKind::Defensive) => SessionInfo::OPPONENT_DEFENSIVE,
        Some(OpponentKind::Focus) => SessionInfo::OPPONENT_FOCUS,
        Some(OpponentKind::Random) => SessionInfo::OPPONENT_RANDOM,
    }
}

fn opponent_of(code: u8) -> Result<Option<OpponentKind>, SessionError> {
    Ok(match code {
        SessionInfo::OPPONENT_SCENARIO => None,
        SessionInfo::OPPONENT_BUILTIN => Some(OpponentKind::Builtin),
        SessionInfo::OPPONENT_AGGRESSIVE => Some(OpponentKind::Aggressive),
        SessionInfo::OPPONENT_DEFENSIVE => Some(OpponentKind::Defensive),
        SessionInfo::OPPONENT_FOCUS => Some(OpponentKind::Focus),
        SessionInfo::OPPONENT_RANDOM => Some(OpponentKind::Random),
        c => return Err(SessionError::Field { field: "opponent", value: c.to_string(), why: "not one of the OPPONENT_* constants" }),
    })
}

/// The session of `cfg`, announcing `episode` (stamped with `header`).
pub fn session_info(cfg: &SimConfig, episode: u64, header: Header) -> SessionInfo {
    // Destructured in full, so a new configuration field does not compile until it is
    // carried here (a replay without it would silently use the default).
    let EnvConfig {
        step_mul,
        rules,
        reward,
        opponent,
        time_limit_loops,
        ability_actions,
        prob_obs_enemy,
        action_mask,
        fov_actions,
        dense_reward,
        state_agent,
    } = &cfg.env;
    let Rules { full_vision, cooldown_jitter, auto_acquire, abilities, weapon_period, melee_surround } = *rules;
    // Not on the wire: a launch is refused any reading but the engine's (launch's validate),
    // so a replay's default is the session's.
    debug_assert_eq!(weapon_period, WeaponPeriod::Attack, "launch validation lets only `attack` through");
    debug_assert_eq!(melee_surround, Rules::default().melee_surround, "launch validation lets only the engine's movement through");
    debug_assert!(dense_reward.is_smac_default(), "launch validation lets only SMAC's reward settings through");
    debug_assert!(!state_agent, "launch validation lets only SMAC's state through");
    let (clock, deadline_ms) = match cfg.clock {
        Clock::Lockstep { deadline } => (SessionInfo::CLOCK_LOCKSTEP, u32::try_from(deadline.as_millis()).unwrap_or(u32::MAX)),
        Clock::RealTime => (SessionInfo::CLOCK_REALTIME, 0),
    };
    SessionInfo {
        header,
        scenario_name: cfg.scenario.name.clone(),
        scenario_toml: cfg.scenario.text.to_string(),
        step_mul: step_mul.get(),
        reward: match reward {
            RewardMode::Sparse => SessionInfo::REWARD_SPARSE,
            RewardMode::Dense => SessionInfo::REWARD_DENSE,
        },
        opponent: opponent_code(*opponent),
        time_limit_loops: time_limit_loops.map_or(0, NonZeroU32::get),
        ability_actions: *ability_actions,
        full_vision,
        cooldown_jitter,
        auto_acquire,
        abilities,
        prob_obs_enemy: *prob_obs_enemy,
        action_mask: *action_mask,
        fov_actions: *fov_actions,
        clock,
        deadline_ms,
        launch_file: cfg.launch_file.clone(),
        episode,
        seeds: cfg.seeds.clone(),
    }
}

/// The environment configuration a session ran with.
pub fn env_config(s: &SessionInfo) -> Result<EnvConfig, SessionError> {
    let step_mul =
        NonZeroU32::new(s.step_mul).ok_or(SessionError::Field { field: "step_mul", value: "0".into(), why: "must be at least 1" })?;
    let reward = match s.reward {
        SessionInfo::REWARD_SPARSE => RewardMode::Sparse,
        SessionInfo::REWARD_DENSE => RewardMode::Dense,
        c => return Err(SessionError::Field { field: "reward", value: c.to_string(), why: "not one of the REWARD_* constants" }),
    };
    if !(0.0..=1.0).contains(&s.prob_obs_enemy) {
        return Err(SessionError::Field {
            field: "prob_obs_enemy",
            value: s.prob_obs_enemy.to_string(),
            why: "must be a probability in [0, 1]",
        });
    }
    if avacraft_engine::check_fov_actions(i64::from(s.fov_actions)).is_err() {
        let why = "must be 0 (off) or an even number of look actions from 2 to 64";
        return Err(SessionError::Field { field: "fov_actions", value: s.fov_actions.to_string(), why });
    }
    Ok(EnvConfig {
        step_mul,
        rules: Rules {
            full_vision: s.full_vision,
            cooldown_jitter: s.cooldown_jitter,
            auto_acquire: s.auto_acquire,
            abilities: s.abilities,
            weapon_period: WeaponPeriod::Attack,
            melee_surround: Rules::default().melee_surround,
        },
        reward,
        opponent: opponent_of(s.opponent)?,
        time_limit_loops: NonZeroU32::new(s.time_limit_loops),
        ability_actions: s.ability_actions,
        prob_obs_enemy: s.prob_obs_enemy,
        action_mask: s.action_mask,
        fov_actions: s.fov_actions,
        // Not on the wire: a launch is refused other settings.
        dense_reward: avacraft_engine::DenseReward::default(),
        state_agent: false,
    })
}

/// The scenario a session ran, parsed from the text it carries.
pub fn scenario(s: &SessionInfo) -> Result<Scenario, SessionError> {
    Scenario::from_toml(&format!("<recorded>/{}.toml", s.scenario_name), &s.scenario_toml)
        .map_err(|source| SessionError::Scenario { name: s.scenario_name.clone(), source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Duration;

    fn config(env: EnvConfig) -> SimConfig {
        SimConfig {
            scenario: Arc::new(avacraft_engine::builtin("pvz_ht").expect("built in")),
            env,
            clock: Clock::Lockstep { deadline: Duration::from_millis(250) },
            seeds: vec![3, 4],
            owners: Default::default(),
            startup_timeout: Duration::from_secs(1),
            frames: None,
            wait_for_recorder: false,
            dds_agents: Default::default(),
            launch_file: "launch/pvz.yaml".into(),
            commands: Vec::new(),
            reads: Default::default(),
        }
    }

    /// A team's messages carry what any of its nodes reads; a node the simulator was not told
    /// about, or a commander, gets everything.
    #[test]
    fn a_teams_messages_carry_what_its_nodes_read() {
        use avacraft_engine::agent::Reads;
        use avacraft_nodes::{AgentId, TeamNo, UnitTag};
        let mut cfg = config(EnvConfig::default());
        let id = |s: &str| AgentId::parse(s).expect("an id");
        let (one, two) = (TeamNo::new(1).expect("team"), TeamNo::new(2).expect("team"));
        // pvz_ht: units 1-23 are team 1's.
        cfg.owners = (1..=23).map(|t| (UnitTag::new(t).expect("tag"), id(if t < 12 { "a" } else { "b" }))).collect();
        cfg.reads = [(id("a"), Reads::UNITS), (id("b"), Reads::UNITS)].into();
        assert_eq!(cfg.team_reads(one), Reads::UNITS);
        cfg.reads.insert(id("b"), Reads { smac: true, text: false });
        assert_eq!(cfg.team_reads(one), Reads { smac: true, text: false });
        cfg.reads.remove(&id("b"));
        assert_eq!(cfg.team_reads(one), Reads::ALL, "a node not listed gets everything");
        cfg.reads.insert(id("b"), Reads::UNITS);
        cfg.commands.push(crate::TeamCommand { team: one, commander: id("boss"), groups: Vec::new() });
        assert_eq!(cfg.team_reads(one), Reads::ALL, "a commander's team gets everything");
        assert_eq!(cfg.team_reads(two), Reads::UNITS, "no node on team 2: nothing to build beyond the units");
    }

    #[test]
    fn configurations_survive_the_wire() {
        let odd = EnvConfig {
            step_mul: NonZeroU32::new(3).expect("non-zero"),
            rules: Rules { full_vision: true, cooldown_jitter: false, auto_acquire: [false, true], abilities: false, ..Rules::default() },
            reward: RewardMode::Dense,
            opponent: Some(OpponentKind::Defensive),
            time_limit_loops: NonZeroU32::new(900),
            ability_actions: true,
            prob_obs_enemy: 0.25,
            action_mask: false,
            fov_actions: 12,
            // Not on the wire: a launch takes SMAC's reward settings and state only.
            dense_reward: avacraft_engine::DenseReward::default(),
            state_agent: false,
        };
        for env in [EnvConfig::default(), EnvConfig::smac(), odd] {
            let cfg = config(env.clone());
            let wire: SessionInfo =
                avacraft_msgs::decode(&avacraft_msgs::encode(&session_info(&cfg, 1, Header::default()))).expect("decodes");
            assert_eq!(env_config(&wire).expect("valid"), env);
            let s = scenario(&wire).expect("the recorded text loads");
            assert_eq!((s.name.as_str(), s.units.len()), (cfg.scenario.name.as_str(), cfg.scenario.units.len()));
            assert_eq!((wire.seeds.as_slice(), wire.deadline_ms, wire.clock), (&[3, 4][..], 250, SessionInfo::CLOCK_LOCKSTEP));
        }
    }

    #[test]
    fn bad_codes_and_text_name_the_field() {
        let good = session_info(&config(EnvConfig::default()), 0, Header::default());
        let e = env_config(&SessionInfo { opponent: 9, ..good.clone() }).expect_err("bad opponent");
        assert!(e.to_string().contains("`opponent` = 9"), "{e}");
        let e = env_config(&SessionInfo { prob_obs_enemy: f32::NAN, ..good.clone() }).expect_err("not a probability");
        assert!(e.to_string().contains("prob_obs_enemy"), "{e}");
        let e = env_config(&SessionInfo { fov_actions: 7, ..good.clone() }).expect_err("odd look actions");
        assert!(e.to_string().contains("fov_actions") && e.to_string().contains("even"), "{e}");
        let e = env_config(&SessionInfo { step_mul: 0, ..good.clone() }).expect_err("zero step_mul");
        assert!(e.to_string().contains("step_mul"), "{e}");
        let e = scenario(&SessionInfo { scenario_toml: "name = 1".into(), ..good }).expect_err("bad toml");
        assert!(e.to_string().contains("pvz_ht"), "{e}");
    }
}
