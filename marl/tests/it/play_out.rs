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
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../baselines/3m").join(run)
}

#[test]
fn play_out_plays_the_game_the_engine_agent_plays() -> R {
    let policy = Arc::new(Policy::load(&shipped("qmix"))?);
    let scenario = Arc::new(Scenario::load("3m")?);
    for seed in [4001, 4002] {
        let p = Arc::clone(&policy);
        let mut controllers = Controllers::new(
            &scenario,
            vec![AgentTeam::new(Team::One, Grouping::Team, move || Box::new(MarlAgent::new(Arc::clone(&p), "marl")))],
        );
        let mut by_agent = Env::new(Arc::clone(&scenario), policy.cfg.env_config(), seed);
        controllers.reset(&by_agent);
        while !by_agent.done() {
            controllers.act(&mut by_agent);
            by_agent.step();
        }
        let mut played = Env::new(Arc::clone(&scenario), policy.cfg.env_config(), seed);
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
    let scenario = Arc::new(Scenario::load("3m")?);
    let seeds = [4001, 4002];
    let mut won = 0;
    for seed in seeds {
        let mut env = Env::new(Arc::clone(&scenario), policy.cfg.env_config(), seed);
        policy.play_out(&mut env, &mut |_| {})?;
        won += usize::from(env.outcome() == Some(Outcome::Win));
    }
    let tested = policy.evaluate(&scenario, &seeds, 1)?;
    assert_eq!(won as f64 / seeds.len() as f64, tested.win_rate);
    // The shipped policy won every greedy test of its last 950k training steps.
    assert_eq!(won, seeds.len());
    Ok(())
}
