//! Networks with the ability slots (`ability_actions`): a run trains on them, its checkpoint
//! says so, and a network trained without them plays a game that has them exactly as it plays
//! one without.

use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, EnvOptions, Scenario, SmacLayout, Team};
use avacraft_marl::{Config, MarlAgent, Policy, RunOptions, train};
use std::path::PathBuf;
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

/// The world after every step of one episode with `policy` on team 1 (`None`: nobody gives
/// team 1 orders), in a game with or without the ability slots.
fn worlds(
    policy: Option<&Arc<Policy>>,
    cfg: &Config,
    scenario: &Arc<Scenario>,
    ability_actions: bool,
    seed: u64,
) -> Result<Vec<u64>, Box<dyn std::error::Error>> {
    let teams = policy.map(Arc::clone).map(|p| {
        AgentTeam::new(Team::One, Grouping::Team, move || {
            Box::new(MarlAgent::new(Arc::clone(&p), "marl")) as Box<dyn avacraft_engine::Agent>
        })
    });
    let mut controllers = Controllers::new(scenario, teams.into_iter().collect());
    let options = EnvOptions { ability_actions, ..cfg.env_options() };
    let mut env = Env::new(Arc::clone(scenario), options.config()?, seed);
    controllers.reset(&env);
    let mut out = Vec::new();
    while !env.done() {
        controllers.act(&mut env);
        env.step();
        out.push(env.world().state_hash());
    }
    Ok(out)
}

#[test]
fn a_network_without_ability_slots_plays_a_game_with_them_as_without() -> R {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../baselines/8s_vs_8m3mr1mv1st/mappo");
    let policy = Arc::new(Policy::load(&dir)?);
    assert!(!policy.ability_actions() && !Policy::ability_actions_in(&dir)?);
    let scenario = Arc::new(Scenario::load("8s_vs_8m3mr1mv1st")?);
    // Blink Stalkers: the game with the slots gives longer observations and more actions.
    let (plain, slots) = (SmacLayout::new(&scenario, Team::One), SmacLayout::with_abilities(&scenario, Team::One, true));
    assert!(slots.n_actions > plain.n_actions && slots.obs_size > plain.obs_size);
    for seed in [11, 12] {
        let without = worlds(Some(&policy), &policy.cfg, &scenario, false, seed)?;
        assert_eq!(worlds(Some(&policy), &policy.cfg, &scenario, true, seed)?, without, "seed {seed}");
        // ... and it did play: a team given no orders makes another game.
        assert_ne!(worlds(None, &policy.cfg, &scenario, false, seed)?, without, "seed {seed}");
    }
    Ok(())
}

#[test]
fn a_run_with_ability_slots_trains_on_them_and_its_checkpoint_says_so() -> R {
    let dir = std::env::temp_dir().join(format!("avacraft-marl-abilities-{}", std::process::id()));
    let c = Config::for_algo(
        "mappo",
        &["t_max=200", "envs=2", "rollout_len=50", "test_interval=100", "test_nepisode=2", "episode_limit=20", "ability_actions=true"]
            .map(String::from),
    )?;
    assert!(c.env_config()?.ability_actions);
    let scenario = Arc::new(Scenario::load("8s_vs_8m3mr1mv1st")?);
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 2, threads: 1, out: Some(dir.clone()) };
    let (trained, _) = train(&c, &opts, &mut |_| {})?;
    let slots = SmacLayout::with_abilities(&scenario, Team::One, true);
    assert_eq!((trained.shape().obs, trained.shape().n_actions), (slots.obs_size, slots.n_actions));
    let policy = Policy::load(&dir.join("best"))?;
    assert!(policy.ability_actions() && Policy::ability_actions_in(&dir.join("best"))?);
    policy.check_scenario(&scenario, Team::One)?;
    // Without the slots the game cannot give this network its observation: it gives no
    // orders there (`episode` and `eval` turn the slots on for it), and plays with them.
    let policy = Arc::new(policy);
    let idle = worlds(None, &c, &scenario, false, 3)?;
    assert_eq!(worlds(Some(&policy), &c, &scenario, false, 3)?, idle);
    assert_ne!(worlds(Some(&policy), &c, &scenario, true, 3)?, idle);
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
