//! What the simulator's publish leg spends before any message is sent, on one scenario:
//! building a team's observations (the text description among them) and encoding them as
//! the wire's `UnitObservation`s, and what one unit's message is made of.
//!
//! `cargo run --release -p avacraft-sim-node --example obs_cost -- pvz_ht`

use avacraft_engine::{Env, EnvConfig, Scenario, Team};
use avacraft_msgs::{Header, UnitObservation, encode};
use avacraft_nodes::wire::unit_observation;
use std::sync::Arc;
use std::time::Instant;

const ROUNDS: u32 = 200;

/// Mean microseconds of `f` over `ROUNDS` calls.
fn time(mut f: impl FnMut()) -> f64 {
    let t = Instant::now();
    for _ in 0..ROUNDS {
        f();
    }
    t.elapsed().as_secs_f64() * 1e6 / f64::from(ROUNDS)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let name = std::env::args().nth(1).unwrap_or_else(|| "pvz_ht".into());
    let mut env = Env::new(Arc::new(Scenario::load(&name)?), EnvConfig::default(), 1);
    env.reset(1);
    // A few steps in, so the units have met and the lists are full.
    for _ in 0..20 {
        env.step();
    }
    let obs = env.agent_observations(Team::One, 0);
    let build = time(|| drop(std::hint::black_box(env.agent_observations(Team::One, 0))));
    let describe = time(|| drop(std::hint::black_box(avacraft_engine::describe(&env, Team::One))));
    let msgs: Vec<UnitObservation> = obs.iter().map(|o| unit_observation(o, Header::default())).collect();
    let encoding = time(|| msgs.iter().for_each(|m| drop(std::hint::black_box(encode(m)))));
    let bytes: usize = msgs.iter().map(|m| encode(m).len()).sum();
    println!(
        "{name}: {} units; building {build:.0} us (describe {describe:.0} us), encoding {encoding:.0} us, {bytes} bytes a step",
        obs.len()
    );
    // What a team of scripted nodes is sent: the units and effects only.
    let units = env.agents(Team::One).to_vec();
    let lean = env.agent_observations_of(Team::One, 0, &units, avacraft_engine::agent::Reads::UNITS);
    let lean_bytes: usize = lean.iter().map(|o| encode(&unit_observation(o, Header::default())).len()).sum();
    let lean_build =
        time(|| drop(std::hint::black_box(env.agent_observations_of(Team::One, 0, &units, avacraft_engine::agent::Reads::UNITS))));
    println!("units and effects only (what scripted nodes read): building {lean_build:.0} us, {lean_bytes} bytes a step");
    let Some(one) = msgs.first() else { return Ok(()) };
    let size = |m: &UnitObservation| encode(m).len();
    let (mut no_text, mut no_lists) = (one.clone(), one.clone());
    no_text.text.clear();
    no_lists.allies.clear();
    no_lists.enemies.clear();
    println!(
        "one unit's message: {} bytes; its text {} bytes, allies and enemies {} bytes ({} + {} units), {} features",
        size(one),
        size(one) - size(&no_text),
        size(one) - size(&no_lists),
        one.allies.len(),
        one.enemies.len(),
        one.features.len()
    );
    Ok(())
}
