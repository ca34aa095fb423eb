//! Sight, fog of war, and the cliff rule; every observation obeys it.

use crate::helpers::*;
use avacraft_engine::{Env, EnvConfig, GroupObs, Rules, Team, UnitKind, builtin, unit_list};
use std::sync::Arc;

#[test]
fn low_ground_does_not_see_high_ground() {
    // 2c_vs_64zg_vlm: Zerglings on low ground, Colossi on the plateau, within sight range.
    let s = Arc::new(builtin("2c_vs_64zg_vlm").expect("scenario"));
    let env = Env::new(Arc::clone(&s), exact(), 1);
    let w = env.world();
    let colossus = w.units().iter().find(|u| u.kind == UnitKind::Colossus).expect("colossus");
    let near = w.units().iter().filter(|u| u.kind == UnitKind::Zergling).any(|z| z.pos.dist(colossus.pos) < 8.0);
    assert!(near, "a Zergling is within its sight range of the Colossus");
    assert!(!w.visible_to(Team::Two, colossus.id), "low ground must not see the plateau");
    assert!(w.visible_to(Team::One, colossus.id));
    // High ground sees low ground: some Zergling is visible to the Colossi.
    assert!(w.units().iter().any(|u| u.kind == UnitKind::Zergling && w.visible_to(Team::One, u.id)));
    // Every observation agrees: team 2's unit list, its text and its groups' unit views.
    assert!(unit_list(w, Team::Two).iter().all(|u| u.kind != UnitKind::Colossus));
    let text = avacraft_engine::describe(&env, Team::Two);
    assert!(!text.contains("Colossus") && text.contains("Zergling"), "{text}");
    let seen = GroupObs::team(&env, Team::Two, 0, avacraft_engine::Reads::UNITS);
    assert!(seen.enemies().all(|u| u.kind != UnitKind::Colossus), "team 2's group sees a Colossus");
    // Full vision switches it off.
    let cfg = EnvConfig { rules: Rules { full_vision: true, ..Rules::default() }, ..EnvConfig::default() };
    let env = Env::new(s, cfg, 1);
    assert!(env.world().visible_to(Team::Two, colossus.id));
}

#[test]
fn enemies_beyond_sight_are_hidden_from_every_observation() {
    // A Marine (sight 9) and a Zergling 12 away: not seen; at 8.5 away: seen.
    for (dx, seen) in [(12.0, false), (8.5, true)] {
        let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Zergling", 2, 10.0 + dx, 16.0)]));
        let env = Env::new(s, passive_fog(), 1);
        let w = env.world();
        assert_eq!(w.visible_to(Team::One, uid(1)), seen, "dx {dx}");
        assert_eq!(unit_list(w, Team::One).len(), if seen { 2 } else { 1 });
        let text = avacraft_engine::describe(&env, Team::One);
        assert_eq!(text.contains("Zergling_1"), seen, "{text}");
        assert_eq!(GroupObs::team(&env, Team::One, 0, avacraft_engine::Reads::UNITS).enemies().count(), seen as usize);
        let mut obs = vec![0f32; env.smac_layout(Team::One).obs_size];
        env.obs_agent(Team::One, 0, &mut obs);
        // Enemy block starts after the 4 move features; its 'distance' slot is non-zero when seen.
        assert_eq!(obs[5] > 0.0, seen && dx < 9.0, "dx {dx}: {obs:?}");
    }
}

fn passive_fog() -> EnvConfig {
    EnvConfig {
        rules: Rules { cooldown_jitter: false, full_vision: false, auto_acquire: [false, false], ..Rules::default() },
        ..EnvConfig::default()
    }
}

#[test]
fn a_unit_cannot_be_attacked_unseen() {
    let s = load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Zergling", 2, 22.0, 16.0)]));
    let mut env = Env::new(s, passive_fog(), 1);
    let r = env.submit(Team::One, &[avacraft_engine::Action::new(uid(0), avacraft_engine::Command::Attack { target: uid(1) })]);
    assert!(matches!(r[0], Err(avacraft_engine::ActionError::TargetNotVisible { .. })), "{r:?}");
}
