//! The rules are written once: an action checked from a group's observation
//! (`agent::check_action`, what AVA and the agent nodes use) gets the simulator's answer, and
//! the SMAC layout turns an index into the same command from the world or from an observation.

use avacraft_engine::agent::{GroupObs, Reads, check_action};
use avacraft_engine::{
    Ability, AbilityTarget, Action, ActionError, Command, Direction, Env, EnvConfig, Refusal, Scenario, Team, UnitId, Vec2,
};
use proptest::prelude::*;
use std::sync::Arc;

const SCENARIOS: [&str; 6] = ["3m_vlm", "MMM_vs_MMM", "pvz_ht", "8m3mr1mv1st_vs_5s2c", "2c_vs_64zg_vlm", "7s_vs_11m1mv1st"];

/// `scenario` after `steps` steps of attack-move for both sides.
fn state(scenario: &str, seed: u64, steps: u32) -> Env {
    let sc = Arc::new(Scenario::load(scenario).expect("scenario"));
    crate::helpers::play_steps(&sc, EnvConfig::default(), seed, "attack-move", "attack-move", steps)
}

/// One random command for `unit` (abilities drawn from its own type's, to reach the cast rules).
fn command(env: &Env, unit: UnitId, p: &(u8, u16, u8, u8, u8, f32, f32)) -> Command {
    let n = env.world().units().len() as u16;
    let target = UnitId::new(p.1 % (n + 2));
    let to = Vec2::new(p.5, p.6);
    match p.0 % 9 {
        0 => Command::NoOp,
        1 => Command::Stop,
        2 => Command::Hold,
        3 => Command::Attack { target },
        4 => Command::MoveGrid { x: p.2 % 12, y: p.3 % 12 },
        5 => Command::MoveDir { dir: Direction::ALL[p.4 as usize % 4] },
        6 => Command::MoveTo { to },
        7 => Command::AttackMoveTo { to },
        _ => {
            let kind = env.world().unit(unit).map(|u| u.kind);
            let own: Vec<Ability> = Ability::ALL.into_iter().filter(|a| kind.is_some_and(|k| a.casters().contains(&k))).collect();
            let ability = own.get(p.4 as usize % own.len().max(1)).copied().unwrap_or(Ability::ALL[p.4 as usize % Ability::ALL.len()]);
            let target = match p.2 % 3 {
                0 => AbilityTarget::None,
                1 => AbilityTarget::Unit { unit: target },
                _ => AbilityTarget::Point { to },
            };
            Command::Ability { ability, target }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Whatever the observation's check accepts, the simulator takes; and whatever the
    /// simulator takes, the observation's check accepts, but a Blink up a cliff, whose vision
    /// of the high ground an observation knows only in part.
    #[test]
    fn an_observation_checks_actions_as_the_simulator_does(
        which in 0usize..SCENARIOS.len(),
        steps in 0u32..40,
        picks in prop::collection::vec((any::<u16>(), (any::<u8>(), any::<u16>(), any::<u8>(), any::<u8>(), any::<u8>(), -4.0f32..90.0, -4.0f32..90.0)), 1..24),
    ) {
        let env = state(SCENARIOS[which], 7, steps);
        let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
        let world = env.world();
        let n = world.units().len() as u16;
        for (u, p) in &picks {
            let unit = UnitId::new(u % (n + 1));
            let a = Action::new(unit, command(&env, unit, p));
            let by_world = world.validate(Team::One, &a);
            let by_obs = check_action(&obs, world.terrain(), &a);
            if let Ok(()) = by_obs {
                prop_assert!(by_world.is_ok(), "{a:?}: the observation accepts it, the simulator refuses: {by_world:?}");
            }
            let blink = matches!(a.command, Command::Ability { ability: Ability::Blink, target: AbilityTarget::Point { .. } });
            if by_world.is_ok() && !blink {
                prop_assert!(by_obs.is_ok(), "{a:?}: the simulator takes it, the observation refuses: {by_obs:?}");
            }
            // A refused cast is refused for the same reason; energy and cooldown, which the
            // observation carries, with the same numbers.
            if let (Err(ActionError::AbilityRefused { refusal: w, .. }), Err(ActionError::AbilityRefused { refusal: o, .. })) = (&by_world, &by_obs)
                && !blink
            {
                prop_assert_eq!(w.code(), o.code(), "{:?}", a);
                if matches!(w, Refusal::OnCooldown { .. } | Refusal::NotEnoughEnergy { .. }) {
                    prop_assert_eq!(w, o, "{:?}", a);
                }
            }
        }
    }
}

/// A command the observation refuses is refused for the simulator's reason (the same typed
/// error), where the observation has the facts.
#[test]
fn refusals_carry_the_simulators_typed_reason() {
    use avacraft_engine::{Inability, TargetProblem};
    let env = state("MMM_vs_MMM", 2, 4);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let w = env.world();
    let find = |name: &str, own: bool| obs.units.iter().find(|u| u.own == own && u.kind.base().name() == name).expect(name);
    let (medivac, marine) = (find("Medivac", true), find("Marine", true));
    let next = UnitId::try_from(marine.tag.tag() + 1).expect("a tag");
    let cases = [
        (Action::new(marine.tag, Command::Attack { target: next }), "friendly"),
        (Action::new(medivac.tag, Command::MoveTo { to: Vec2::new(-3.0, 5.0) }), "off map"),
    ];
    for (a, what) in cases {
        let (o, s) = (check_action(&obs, w.terrain(), &a), w.validate(Team::One, &a).map(|_| ()));
        assert_eq!(o, s, "{what}");
    }
    let heal_enemy = obs.units.iter().find(|u| !u.own).map(|e| Action::new(medivac.tag, Command::Attack { target: e.tag }));
    if let Some(a) = heal_enemy {
        let e = check_action(&obs, w.terrain(), &a).expect_err("a Medivac cannot heal an enemy");
        assert!(matches!(e, ActionError::InvalidTarget { why: TargetProblem::HealerNeedsFriend, .. }), "{e:?}");
    }
    // A Marine is mobile: an immobile unit's move names its kind.
    assert!(!matches!(
        check_action(&obs, w.terrain(), &Action::new(marine.tag, Command::MoveDir { dir: Direction::Up })),
        Err(ActionError::Unavailable { why: Inability::Immobile { .. }, .. })
    ));
}

/// Every SMAC index gives the same command from the world as from the group's observation,
/// for a living agent, wherever the observation holds the unit the command names.
#[test]
fn smac_indices_mean_the_same_from_world_and_observation() {
    for name in ["3m_vlm", "MMM_vs_MMM", "pvz_ht", "8m3mr1mv1st_vs_5s2c"] {
        for steps in [0, 10, 25] {
            let env = state(name, 3, steps);
            if env.done() {
                continue;
            }
            let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
            let layout = avacraft_engine::SmacLayout::with_abilities(env.scenario(), Team::One, true);
            let mut compared = 0;
            for c in obs.controlled.iter().filter(|c| c.alive) {
                for idx in 0..layout.n_actions + 2 {
                    let from_obs = layout.command_for_obs(&obs, c.agent, idx);
                    let from_world = layout.command_for(env.world(), c.agent, idx);
                    match from_obs {
                        Some(cmd) => {
                            assert_eq!(Some(cmd), from_world, "{name} step {steps} agent {} index {idx}", c.agent);
                            compared += 1;
                        }
                        // An index that names nothing names nothing from the world either; the
                        // observation lacks only positions of enemies it does not see (spells).
                        None => assert!(from_world.is_none() || idx >= layout.ability_base(), "{name} step {steps}: index {idx}"),
                    }
                }
            }
            assert!(compared > 0, "{name} step {steps}: nothing compared");
        }
    }
}
