//! Shared helpers: small hand-made scenarios and episode drivers.

use avacraft_engine::{Controllers, Env, EnvConfig, Rules, Scenario, UnitId};
use std::fmt::Write;
use std::sync::Arc;

/// A flat 32x32 arena with the given units `(type, team, x, y)`.
pub fn arena(mode: &str, units: &[(&str, u8, f32, f32)]) -> String {
    arena_with(mode, units, "")
}

/// Like [`arena`], with extra top-level TOML lines (upgrades, time limit...).
pub fn arena_with(mode: &str, units: &[(&str, u8, f32, f32)], extra: &str) -> String {
    let mut s = format!("name = \"test\"\nmode = \"{mode}\"\nmap_size = [32, 32]\n{extra}\nunits = [\n");
    for (k, t, x, y) in units {
        let _ = writeln!(s, "  {{ type = \"{k}\", team = {t}, x = {x}, y = {y} }},");
    }
    s.push_str("]\n[opponent]\nstart = { kind = \"none\" }\n");
    s
}

/// Like [`arena_with`], each unit with extra inline fields (e.g. `energy = 200`).
pub fn arena_units(mode: &str, units: &[(&str, u8, f32, f32, &str)], extra: &str) -> String {
    let mut s = format!("name = \"test\"\nmode = \"{mode}\"\nmap_size = [32, 32]\n{extra}\nunits = [\n");
    for (k, t, x, y, more) in units {
        let more = if more.is_empty() { String::new() } else { format!(", {more}") };
        let _ = writeln!(s, "  {{ type = \"{k}\", team = {t}, x = {x}, y = {y}{more} }},");
    }
    s.push_str("]\n[opponent]\nstart = { kind = \"none\" }\n");
    s
}

/// One loop per step, full vision, no jitter, nobody acts unless ordered.
pub fn exact_loop() -> EnvConfig {
    one_loop(passive())
}

/// Runs `n` steps. Stepping a finished episode does nothing: in an arena where a side has no
/// unit that can deal damage (a lone Medivac or Warp Prism), the episode ends after the first
/// loop and every unit freezes with its last order and velocity.
pub fn run_loops(env: &mut Env, n: u32) {
    for _ in 0..n {
        env.step();
    }
}

pub fn load(toml: &str) -> Arc<Scenario> {
    Arc::new(Scenario::from_toml("test.toml", toml).unwrap_or_else(|e| panic!("test scenario: {e}")))
}

/// Exact rules: fog on, no random attack delay.
pub fn exact() -> EnvConfig {
    EnvConfig { rules: Rules { cooldown_jitter: false, ..Rules::default() }, ..EnvConfig::default() }
}

/// Full vision, no random delay, and nobody attacks unless ordered: for exact damage tests.
pub fn passive() -> EnvConfig {
    EnvConfig {
        rules: Rules { cooldown_jitter: false, full_vision: true, auto_acquire: [false, false], ..Rules::default() },
        ..EnvConfig::default()
    }
}

pub fn one_loop(mut cfg: EnvConfig) -> EnvConfig {
    cfg.step_mul = std::num::NonZeroU32::MIN;
    cfg
}

pub fn uid(i: u16) -> UnitId {
    UnitId::new(i)
}

/// Runs an episode with named policies for the agent teams; returns the env at its end.
pub fn play(scenario: &Arc<Scenario>, cfg: EnvConfig, seed: u64, p1: &str, p2: &str) -> Env {
    play_steps(scenario, cfg, seed, p1, p2, u32::MAX)
}

/// [`play`] for at most `steps` steps: the env at that moment of the episode.
pub fn play_steps(scenario: &Arc<Scenario>, cfg: EnvConfig, seed: u64, p1: &str, p2: &str, steps: u32) -> Env {
    let mut env = Env::new(Arc::clone(scenario), cfg, seed);
    let mut c = Controllers::named(scenario, p1, Some(p2)).expect("policy");
    c.reset(&env);
    while env.steps() < steps && !env.done() {
        c.act(&mut env);
        env.step();
    }
    env
}
