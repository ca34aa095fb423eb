//! `Policy::play_out`, how an evaluation plays image checkpoints: the game a `features`
//! policy plays through it is the one its engine agent plays, and an `rgb` policy wins the
//! episodes its own greedy tests win.

use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, Outcome, Scenario, Team};
use avacraft_marl::{MarlAgent, ObsKind, Policy};
use std::path::PathBuf;
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

fn shipped(run: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../baselines/3m_vlm").join(run)
}

#[test]
fn play_out_plays_the_game_the_engine_agent_plays() -> R {
    let policy = Arc::new(Policy::load(&shipped("qmix"))?);
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    for seed in [4001, 4002] {
        let p = Arc::clone(&policy);
        let mut controllers = Controllers::new(
            &scenario,
            vec![AgentTeam::new(Team::One, Grouping::Team, move || Box::new(MarlAgent::new(Arc::clone(&p), "marl")))],
        );
        let mut by_agent = Env::new(Arc::clone(&scenario), policy.cfg.env_config()?, seed);
        controllers.reset(&by_agent);
        while !by_agent.done() {
            controllers.act(&mut by_agent);
            by_agent.step();
        }
        let mut played = Env::new(Arc::clone(&scenario), policy.cfg.env_config()?, seed);
        let mut seen = 0;
        policy.play_out(&mut played, &mut |_| seen += 1)?;
        assert_eq!(played.trajectory_hash(), by_agent.trajectory_hash(), "seed {seed}");
        assert!(played.done() && seen > 2, "seed {seed}: {seen} calls");
    }
    Ok(())
}

#[test]
fn an_rgb_policy_plays_out_the_episodes_its_tests_play() -> R {
    let policy = Arc::new(Policy::load(&shipped("mappo-rgb"))?);
    assert_eq!(policy.cfg.obs, ObsKind::Rgb);
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    let seeds = [4001, 4002];
    let mut won = 0;
    for seed in seeds {
        let mut env = Env::new(Arc::clone(&scenario), policy.cfg.env_config()?, seed);
        policy.play_out(&mut env, &mut |_| {})?;
        won += usize::from(env.outcome() == Some(Outcome::Win));
    }
    let tested = policy.evaluate(&scenario, &seeds, 1)?;
    assert_eq!(won as f64 / seeds.len() as f64, tested.win_rate);
    // The shipped policy won every greedy test of its last 950k training steps.
    assert_eq!(won, seeds.len());
    Ok(())
}

/// An image checkpoint as an engine agent that is shown its team's frames before each step
/// (what `episode --launch` and agent nodes do) plays the game `play_out` plays, whether the
/// team is one group or one agent per unit: the same world at every step. (Their trajectory
/// hashes differ once a unit dies: `play_out` submits a dead agent's no-op by index, which
/// records it as the agent's last action, and an engine agent sends dead units nothing.)
#[test]
fn an_rgb_agent_shown_frames_plays_the_game_play_out_plays() -> R {
    let policy = Arc::new(Policy::load(&shipped("mappo-rgb"))?);
    let scenario = Arc::new(Scenario::load("3m_vlm")?);
    let agents = |grouping: Grouping| {
        let p = Arc::clone(&policy);
        Controllers::new(&scenario, vec![AgentTeam::new(Team::One, grouping, move || Box::new(MarlAgent::new(Arc::clone(&p), "marl")))])
    };
    let play = |controllers: &mut Controllers, seed: u64| {
        let mut env = Env::new(Arc::clone(&scenario), policy.cfg.env_config().expect("a validated config"), seed);
        controllers.reset(&env);
        let mut worlds = Vec::new();
        while !env.done() {
            worlds.push(env.world().state_hash());
            controllers.act(&mut env);
            env.step();
        }
        worlds.push(env.world().state_hash());
        (worlds, env.outcome())
    };
    let mut deaths = 0;
    for (seed, grouping) in [(4001, Grouping::Team), (4002, Grouping::PerUnit)] {
        let mut seeing = agents(grouping).with_frames(Box::new(avacraft_render::FramePainter::new()));
        let (by_agent, outcome) = play(&mut seeing, seed);
        let mut env = Env::new(Arc::clone(&scenario), policy.cfg.env_config()?, seed);
        let mut played = Vec::new();
        policy.play_out(&mut env, &mut |e| played.push(e.world().state_hash()))?;
        assert_eq!(played, by_agent, "seed {seed}");
        assert_eq!(env.outcome(), outcome);
        deaths += usize::from(env.world().alive(Team::One).count() < 3);
        // Without frames the network gives no orders: another game.
        let (blind, _) = play(&mut agents(Grouping::Team), seed);
        assert_ne!(blind, by_agent, "seed {seed}");
    }
    // The games compared lost units, where the bookkeeping of the two paths differs.
    assert!(deaths > 0);
    Ok(())
}

/// A checkpoint written before SMAC's maps took SMAC's names: its `3m` is the paper's
/// scenario, read as `3m_vlm`; one written since keeps `3m` (SMAC's map).
#[test]
fn a_checkpoint_from_before_smacs_names_reads_the_papers_new_name() -> R {
    let dir = std::env::temp_dir().join(format!("avacraft-old-names-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    for f in ["agent.safetensors", "config.json"] {
        std::fs::copy(shipped("qmix").join(f), dir.join(f))?;
    }
    let path = dir.join("config.json");
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path)?)?;
    let o = json.as_object_mut().ok_or("config.json is an object")?;
    o.insert("scenario".into(), "3m".into());
    o.remove("names");
    std::fs::write(&path, json.to_string())?;
    let before = Policy::load(&dir)?.scenario;
    json.as_object_mut().ok_or("object")?.insert("names".into(), 2.into());
    std::fs::write(&path, json.to_string())?;
    let since = Policy::load(&dir)?.scenario;
    std::fs::remove_dir_all(&dir)?;
    assert_eq!((before.as_str(), since.as_str()), ("3m_vlm", "3m"));
    Ok(())
}
