//! SMAC's heuristic agent (`smac-heuristic`, SMAC's `heuristic_ai`), played on SMAC's maps:
//! each unit takes the nearest living enemy and keeps it until it dies, healers the nearest
//! hurt ally until it is whole, and with `heuristic_rest` a unit steps towards a target SMAC
//! would not let it attack yet.

use avacraft_engine::agent::{Agent, AgentCtx, GroupObs, Reads, SmacHeuristic, agent_seed};
use avacraft_engine::{Command, Env, EnvConfig, SHOOT_RANGE, Scenario, Team, UnitId};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

fn map(name: &str) -> Arc<Scenario> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../engine/scenarios/smac").join(format!("{name}.toml"));
    Arc::new(Scenario::load(&path.to_string_lossy()).unwrap_or_else(|e| panic!("{name}: {e}")))
}

/// Plays one episode, calling `check` with each step's observation and the agent's actions.
fn play(name: &str, rest: bool, seed: u64, mut check: impl FnMut(&GroupObs, &[avacraft_engine::Action])) {
    let s = map(name);
    let mut env = Env::new(Arc::clone(&s), EnvConfig::smac(), seed);
    env.reset(seed);
    let units = env.agents(Team::One).to_vec();
    let mut agent = SmacHeuristic::new(rest);
    agent.reset(&AgentCtx {
        scenario: Arc::clone(&s),
        team: Team::One,
        units: units.clone(),
        seed: agent_seed(seed, Team::One, units[0].tag()),
    });
    while !env.done() {
        let obs = GroupObs::team(&env, Team::One, 0, Reads::UNITS);
        let actions = agent.act(&obs);
        check(&obs, &actions);
        for (a, r) in actions.iter().zip(env.submit(Team::One, &actions)) {
            assert!(r.is_ok(), "{name}: the engine refused {a:?}: {r:?}");
        }
        env.step();
    }
}

#[test]
fn each_unit_keeps_the_nearest_enemy_until_it_dies() {
    let (mut picks, mut kept) = (0, 0);
    for name in ["3s5z", "5m_vs_6m", "MMM"] {
        let mut held: BTreeMap<UnitId, UnitId> = BTreeMap::new();
        play(name, false, 9000, |obs, actions| {
            for a in actions {
                let Command::Attack { target } = a.command else { panic!("{name}: not an attack or heal: {a:?}") };
                let u = obs.units.iter().find(|u| u.tag == a.unit).expect("own unit");
                if u.spec().heal.is_some() {
                    let t = obs.own().find(|o| o.tag == target).expect("a healer's target is its ally");
                    assert!(t.hp < t.max_hp && t.tag != u.tag, "{name}: {} heals a whole ally or itself", u.name);
                    continue;
                }
                let here = (u.x, u.y);
                let d = |e: &avacraft_engine::UnitInfo| (e.x - here.0).hypot(e.y - here.1);
                match held.get(&a.unit) {
                    Some(t) if obs.enemies().any(|e| e.tag == *t) => {
                        assert_eq!(target, *t, "{name}: {} changed target while its first lived", u.name);
                        kept += 1;
                    }
                    _ => {
                        let t = obs.enemies().find(|e| e.tag == target).expect("an attack's target is a living enemy");
                        let nearest =
                            obs.enemies().filter(|e| avacraft_engine::agent::view::can_attack(u, e)).map(d).fold(f32::MAX, f32::min);
                        assert!(d(t) <= nearest + 1e-4, "{name}: {} picked an enemy {} away, the nearest is {nearest}", u.name, d(t));
                        picks += 1;
                    }
                }
                held.insert(a.unit, target);
            }
        });
    }
    assert!(picks > 20 && kept > 2 * picks, "too little checked: {picks} picks, {kept} kept");
}

#[test]
fn with_rest_a_unit_steps_towards_a_target_beyond_smacs_shoot_range() {
    let (mut steps, mut attacks) = (0, 0);
    play("3s5z_vs_3s6z", true, 9001, |obs, actions| {
        for a in actions {
            let u = obs.units.iter().find(|u| u.tag == a.unit).expect("own unit");
            match a.command {
                Command::Attack { target } => {
                    let t = obs.enemies().find(|e| e.tag == target).expect("living enemy");
                    assert!((t.x - u.x).hypot(t.y - u.y) <= SHOOT_RANGE, "{} attacks beyond SMAC's range", u.name);
                    attacks += 1;
                }
                Command::MoveDir { .. } => steps += 1,
                other => panic!("{} was given {other:?}", u.name),
            }
        }
    });
    assert!(steps > 0 && attacks > 0, "{steps} steps, {attacks} attacks");
}
