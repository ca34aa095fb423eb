//! One test per ability with StarCraft II's numbers worked by hand (patch 5.0.13 game data,
//! Faster seconds x 22.4 = loops), then every refusal reason.

use crate::helpers::{arena_units, exact_loop, load, run_loops, uid};
use avacraft_engine::DataSet;
use avacraft_engine::{Ability, AbilityTarget, Action, ActionError, Command, Env, LOOPS_PER_SECOND, Refusal, Team, UnitId, UnitKind, Vec2};

const STIM: &str = "upgrades = [{ team = 1, name = \"Stimpack\" }]";

fn unit(env: &Env, i: u16) -> &avacraft_engine::Unit {
    env.world().unit(uid(i)).expect("unit")
}

fn cast(env: &mut Env, team: Team, i: u16, ability: Ability, target: AbilityTarget) -> Result<(), ActionError> {
    env.submit(team, &[Action::new(uid(i), Command::Ability { ability, target })]).remove(0)
}

fn order(env: &mut Env, team: Team, i: u16, command: Command) -> Result<(), ActionError> {
    env.submit(team, &[Action::new(uid(i), command)]).remove(0)
}

fn refusal(r: Result<(), ActionError>) -> Refusal {
    match r {
        Err(ActionError::AbilityRefused { refusal, .. }) => refusal,
        other => panic!("expected a refused cast, got {other:?}"),
    }
}

fn on(u: UnitId) -> AbilityTarget {
    AbilityTarget::Unit { unit: u }
}

fn at(x: f32, y: f32) -> AbilityTarget {
    AbilityTarget::Point { to: Vec2::new(x, y) }
}

fn env_of(units: &[(&str, u8, f32, f32, &str)], extra: &str) -> Env {
    Env::new(load(&arena_units("pvp", units, extra)), exact_loop(), 1)
}

#[test]
fn stimpack_costs_life_and_speeds_up_attacks_and_movement() {
    let mut env = env_of(&[("Marine", 1, 10.0, 16.0, ""), ("Zealot", 2, 15.0, 16.0, "")], STIM);
    let base_speed = unit(&env, 0).speed;
    cast(&mut env, Team::One, 0, Ability::Stimpack, AbilityTarget::None).expect("stim");
    order(&mut env, Team::One, 0, Command::Attack { target: uid(1) }).expect("attack");
    env.step();
    let m = unit(&env, 0);
    assert_eq!(m.hp, 35.0);
    assert_eq!(m.status.stim_until, 240, "10.71 s");
    assert!((m.speed - base_speed * 1.5).abs() < 1e-6);
    // 13.77 loops between shots become 9.18; one loop has passed.
    let cd = UnitKind::Marine.spec_in(DataSet::Legacy).weapons[0].cooldown;
    assert!((m.cooldown - (cd / 1.5 - 1.0)).abs() < 1e-4, "{}", m.cooldown);
    run_loops(&mut env, 239);
    assert!(!unit(&env, 0).status.stimmed(env.world().tick()));
    env.step();
    assert_eq!(unit(&env, 0).speed, base_speed, "speed back after 240 loops");
}

#[test]
fn stimpack_needs_more_life_than_it_costs_and_the_upgrade() {
    let mut env = env_of(&[("Marine", 1, 10.0, 16.0, ""), ("Marauder", 1, 12.0, 16.0, ""), ("Zealot", 2, 25.0, 16.0, "")], STIM);
    for hp in [35.0, 25.0, 15.0, 5.0] {
        cast(&mut env, Team::One, 0, Ability::Stimpack, AbilityTarget::None).expect("stim");
        env.step();
        assert_eq!(unit(&env, 0).hp, hp);
    }
    assert_eq!(
        refusal(cast(&mut env, Team::One, 0, Ability::Stimpack, AbilityTarget::None)),
        Refusal::NotEnoughLife { have: 5.0, cost: 10.0 }
    );
    cast(&mut env, Team::One, 1, Ability::Stimpack, AbilityTarget::None).expect("marauder stim");
    env.step();
    assert_eq!(unit(&env, 1).hp, 105.0, "a Marauder pays 20");
    let mut plain = env_of(&[("Marine", 1, 10.0, 16.0, ""), ("Zealot", 2, 25.0, 16.0, "")], "");
    assert!(matches!(refusal(cast(&mut plain, Team::One, 0, Ability::Stimpack, AbilityTarget::None)), Refusal::NeedsUpgrade { .. }));
}

#[test]
fn concussive_shells_slow_for_24_loops_but_not_massive_units() {
    let extra = "upgrades = [{ team = 1, name = \"PunisherGrenades\" }]";
    let mut env = env_of(&[("Marauder", 1, 10.0, 16.0, ""), ("Zealot", 2, 15.0, 16.0, ""), ("Ultralisk", 2, 15.0, 20.0, "")], extra);
    order(&mut env, Team::One, 0, Command::Attack { target: uid(1) }).expect("attack");
    env.step();
    assert_eq!(unit(&env, 1).status.slow_until, 24, "1.07 s");
    env.step();
    let z = unit(&env, 1);
    assert!((z.speed - UnitKind::Zealot.spec_in(DataSet::Legacy).speed * 0.5).abs() < 1e-6, "{}", z.speed);
    let mut env = env_of(&[("Marauder", 1, 10.0, 20.0, ""), ("Ultralisk", 2, 15.5, 20.0, "")], extra);
    order(&mut env, Team::One, 0, Command::Attack { target: uid(1) }).expect("attack");
    env.step();
    assert!(unit(&env, 1).hp < 500.0, "hit");
    assert_eq!(unit(&env, 1).status.slow_until, 0, "massive units are not slowed");
}

#[test]
fn medivac_heal_cast_and_afterburners() {
    let mut env = env_of(&[("Medivac", 1, 10.0, 16.0, ""), ("Marine", 1, 11.0, 16.0, ""), ("Zealot", 2, 25.0, 16.0, "")], "");
    // A Marine at full health cannot be healed; a Zealot is not ours.
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::Heal, on(uid(1)))), Refusal::InvalidTarget { .. }));
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::Heal, on(uid(2)))), Refusal::InvalidTarget { .. }));
    cast(&mut env, Team::One, 0, Ability::Afterburners, AbilityTarget::None).expect("boost");
    env.step();
    let m = unit(&env, 0);
    assert!((m.speed - UnitKind::Medivac.spec_in(DataSet::Legacy).speed * 1.7).abs() < 1e-6, "5.95 instead of 3.5");
    assert_eq!(m.status.boost_until, 128, "5.71 s");
    let r = refusal(cast(&mut env, Team::One, 0, Ability::Afterburners, AbilityTarget::None));
    assert_eq!(r, Refusal::OnCooldown { seconds: 319.0 / LOOPS_PER_SECOND }, "14.29 s from the cast");
    run_loops(&mut env, 128);
    match refusal(cast(&mut env, Team::One, 0, Ability::Afterburners, AbilityTarget::None)) {
        Refusal::OnCooldown { seconds } => assert!((seconds - (320 - 129) as f32 / LOOPS_PER_SECOND).abs() < 1e-3, "{seconds}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn siege_and_unsiege_take_65_and_57_loops() {
    let mut env = env_of(&[("SiegeTank", 1, 8.0, 16.0, ""), ("Zealot", 2, 20.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::SiegeMode, AbilityTarget::None).expect("siege");
    env.step();
    assert!(unit(&env, 0).status.morph.is_some());
    let r = order(&mut env, Team::One, 0, Command::MoveTo { to: Vec2::new(8.0, 20.0) });
    assert!(matches!(r, Err(ActionError::Unavailable { .. })), "{r:?}");
    run_loops(&mut env, 64);
    assert_eq!(unit(&env, 0).kind, UnitKind::SiegeTank, "still morphing in loop 64");
    env.step();
    assert_eq!(unit(&env, 0).kind, UnitKind::SiegeTankSieged);
    // Sieged: 13 range reaches the Zealot 11 away (edge 10.6).
    order(&mut env, Team::One, 0, Command::Attack { target: uid(1) }).expect("attack");
    env.step();
    assert!(unit(&env, 1).shield < 50.0);
    cast(&mut env, Team::One, 0, Ability::Unsiege, AbilityTarget::None).expect("unsiege");
    run_loops(&mut env, 57);
    assert_eq!(unit(&env, 0).kind, UnitKind::SiegeTankSieged);
    env.step();
    assert_eq!(unit(&env, 0).kind, UnitKind::SiegeTank);
}

#[test]
fn kd8_charge_detonates_after_32_loops_damages_and_knocks_back() {
    let mut env = env_of(&[("Reaper", 1, 10.0, 16.0, ""), ("Zealot", 2, 13.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::Kd8Charge, on(uid(1))).expect("kd8");
    run_loops(&mut env, 32);
    assert_eq!(unit(&env, 1).shield, 50.0, "not yet");
    env.step();
    let z = unit(&env, 1);
    assert_eq!(z.shield, 45.0, "5 spell damage");
    assert!((z.pos.x - 16.0).abs() < 0.05, "knocked 3 away from the blast: {:?}", z.pos);
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::Kd8Charge, on(uid(1)))), Refusal::OnCooldown { .. }));
}

#[test]
fn steady_targeting_channels_then_hits_and_is_interrupted_by_damage() {
    let units = [("Ghost", 1, 10.0, 16.0, ""), ("Ultralisk", 2, 18.0, 16.0, ""), ("HighTemplar", 2, 18.0, 20.0, "")];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::One, 0, Ability::SteadyTargeting, on(uid(1))).expect("snipe");
    run_loops(&mut env, 32);
    assert_eq!(unit(&env, 1).hp, 500.0);
    assert_eq!(unit(&env, 0).energy.floor(), 26.0, "75 - 50 + regen");
    env.step();
    assert!((unit(&env, 1).hp - 370.0).abs() < 0.2, "130, armour ignored: {}", unit(&env, 1).hp);
    // +40 against psionic units: a High Templar (40 + 40) dies.
    let mut env = env_of(&[("Ghost", 1, 10.0, 16.0, "energy = 100"), ("HighTemplar", 2, 18.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::SteadyTargeting, on(uid(1))).expect("snipe");
    run_loops(&mut env, 33);
    assert!(!unit(&env, 1).alive);
    // Damage to the Ghost interrupts it and refunds the energy.
    let units = [("Ghost", 1, 10.0, 16.0, ""), ("Ultralisk", 2, 18.0, 16.0, ""), ("Marine", 2, 12.0, 16.0, "")];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::One, 0, Ability::SteadyTargeting, on(uid(1))).expect("snipe");
    env.step();
    order(&mut env, Team::Two, 2, Command::Attack { target: uid(0) }).expect("marine attacks");
    run_loops(&mut env, 40);
    assert_eq!(unit(&env, 1).hp, 500.0, "the shot never landed");
    assert!(unit(&env, 0).energy > 75.0, "refunded: {}", unit(&env, 0).energy);
    assert!(unit(&env, 0).status.channel.is_none());
}

#[test]
fn emp_takes_100_shields_and_100_energy_in_radius_one_and_a_half() {
    let units =
        [("Ghost", 1, 10.0, 16.0, ""), ("Stalker", 2, 18.0, 16.0, ""), ("HighTemplar", 2, 18.0, 17.0, ""), ("Sentry", 2, 18.0, 19.5, "")];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::One, 0, Ability::Emp, at(18.0, 16.5)).expect("emp");
    env.step();
    assert_eq!((unit(&env, 1).shield, unit(&env, 2).shield, unit(&env, 2).energy.floor()), (0.0, 0.0, 0.0));
    assert_eq!((unit(&env, 3).shield, unit(&env, 3).energy.floor()), (40.0, 50.0), "the Sentry is 3 away");
    assert!(unit(&env, 0).energy < 1.0, "75 spent");
}

#[test]
fn a_cloaked_banshee_is_untargetable_until_detected() {
    let units = [
        ("Banshee", 1, 10.0, 16.0, "energy = 200"),
        ("Marine", 2, 13.0, 16.0, ""),
        ("PhotonCannon", 2, 24.0, 16.0, ""),
        ("WarpPrismPhasing", 2, 25.0, 18.0, ""),
    ];
    let mut env = env_of(&units, "upgrades = [{ team = 1, name = \"BansheeCloak\" }]");
    cast(&mut env, Team::One, 0, Ability::Cloak, AbilityTarget::None).expect("cloak");
    env.step();
    assert!(unit(&env, 0).status.cloaked);
    assert_eq!(
        order(&mut env, Team::Two, 1, Command::Attack { target: uid(0) }),
        Err(ActionError::TargetNotVisible { target: uid(0), team: Team::Two })
    );
    // 10 s later: 200 - 25 - 1.28 x 10 + 0.7875 x 10 = 170.1 energy.
    run_loops(&mut env, 223);
    assert!((unit(&env, 0).energy - 170.075).abs() < 0.1, "{}", unit(&env, 0).energy);
    // Fly into the powered cannon's detection: detected and shot.
    order(&mut env, Team::One, 0, Command::MoveTo { to: Vec2::new(17.0, 16.0) }).expect("move");
    run_loops(&mut env, 60);
    assert!(unit(&env, 0).status.detected);
    order(&mut env, Team::Two, 2, Command::Attack { target: uid(0) }).expect("the cannon may target it now");
    run_loops(&mut env, 2);
    assert!(unit(&env, 0).hp < 140.0);
    // The prism leaves phasing mode: the cannon loses power and with it detection.
    cast(&mut env, Team::Two, 3, Ability::TransportMode, AbilityTarget::None).expect("transport");
    run_loops(&mut env, 26);
    assert!(!env.world().visible_to(Team::Two, uid(0)));
}

#[test]
fn viking_switches_modes_in_37_loops() {
    let mut env = env_of(&[("VikingAssault", 1, 10.0, 16.0, ""), ("Phoenix", 2, 20.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::FighterMode, AbilityTarget::None).expect("lift off");
    run_loops(&mut env, 37);
    assert_eq!(unit(&env, 0).kind, UnitKind::VikingAssault);
    env.step();
    assert_eq!(unit(&env, 0).kind, UnitKind::VikingFighter);
    assert!(unit(&env, 0).flying());
    order(&mut env, Team::One, 0, Command::Attack { target: uid(1) }).expect("a fighter hits air");
}

#[test]
fn blink_teleports_within_8_then_waits_160_loops() {
    let extra = "upgrades = [{ team = 1, name = \"BlinkTech\" }]";
    let mut env = env_of(&[("Stalker", 1, 10.0, 16.0, ""), ("Zealot", 2, 28.0, 16.0, "")], extra);
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::Blink, at(19.0, 16.0))), Refusal::OutOfRange { .. }));
    cast(&mut env, Team::One, 0, Ability::Blink, at(18.0, 16.0)).expect("blink");
    env.step();
    assert_eq!(unit(&env, 0).pos, Vec2::new(18.0, 16.0));
    run_loops(&mut env, 158);
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::Blink, at(12.0, 16.0))), Refusal::OnCooldown { .. }));
    env.step();
    cast(&mut env, Team::One, 0, Ability::Blink, at(12.0, 16.0)).expect("ready after 160 loops");
}

#[test]
fn guardian_shield_takes_two_off_ranged_hits_only() {
    let units = [
        ("Sentry", 1, 10.0, 16.0, "energy = 75"),
        ("Zealot", 1, 12.0, 16.0, ""),
        ("Marine", 2, 16.0, 16.0, ""),
        ("Zergling", 2, 12.0, 16.85, ""),
    ];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::One, 0, Ability::GuardianShield, AbilityTarget::None).expect("shield");
    env.step();
    assert_eq!(unit(&env, 0).status.guardian_until, 288, "12.86 s");
    order(&mut env, Team::Two, 2, Command::Attack { target: uid(1) }).expect("marine");
    order(&mut env, Team::Two, 3, Command::Attack { target: uid(1) }).expect("zergling");
    env.step();
    // Marine 6 - 2 = 4, Zergling melee 5 in full.
    assert_eq!(unit(&env, 1).shield, 50.0 - 4.0 - 5.0);
    assert_eq!(
        refusal(cast(&mut env, Team::One, 0, Ability::GuardianShield, AbilityTarget::None)),
        Refusal::OnCooldown { seconds: 286.0 / LOOPS_PER_SECOND }
    );
}

#[test]
fn force_field_blocks_ground_units_until_it_expires_and_massive_units_break_it() {
    let units = [("Sentry", 1, 8.0, 16.0, ""), ("Marine", 2, 20.0, 16.0, "")];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::One, 0, Ability::ForceField, at(15.0, 16.0)).expect("force field");
    env.step();
    order(&mut env, Team::Two, 1, Command::MoveTo { to: Vec2::new(15.0, 16.0) }).expect("move");
    let mut closest = f32::MAX;
    for _ in 0..230 {
        env.step();
        closest = closest.min(unit(&env, 1).pos.dist(Vec2::new(15.0, 16.0)));
    }
    assert!(closest >= 1.5 + 0.375 - 0.02, "the Marine got {closest} from the centre");
    run_loops(&mut env, 40);
    assert!(unit(&env, 1).pos.dist(Vec2::new(15.0, 16.0)) < 0.2, "reached after the field expired");
    let mut env = env_of(&[("Sentry", 1, 8.0, 16.0, ""), ("Ultralisk", 2, 20.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::ForceField, at(15.0, 16.0)).expect("force field");
    env.step();
    order(&mut env, Team::Two, 1, Command::MoveTo { to: Vec2::new(15.0, 16.0) }).expect("move");
    run_loops(&mut env, 60);
    assert!(env.world().area_effects().is_empty(), "the Ultralisk broke it");
}

#[test]
fn psionic_storm_deals_80_to_a_unit_that_stays_and_does_not_stack() {
    let extra = "upgrades = [{ team = 1, name = \"PsiStormTech\" }]";
    let units = [
        ("HighTemplar", 1, 8.0, 16.0, "energy = 200"),
        ("HighTemplar", 1, 8.0, 18.0, "energy = 200"),
        ("Zealot", 2, 15.0, 16.0, ""),
        ("Zealot", 2, 15.0, 22.0, ""),
        ("Zealot", 2, 15.0, 24.0, ""),
    ];
    let mut env = env_of(&units, extra);
    // Two storms on zealot 2: it takes damage from one. Zealot 3 walks out at once.
    cast(&mut env, Team::One, 0, Ability::PsionicStorm, at(15.0, 16.0)).expect("storm");
    cast(&mut env, Team::One, 1, Ability::PsionicStorm, at(15.2, 16.0)).expect("second storm");
    order(&mut env, Team::Two, 2, Command::Hold).expect("hold");
    run_loops(&mut env, 70);
    let z = unit(&env, 2);
    assert_eq!(z.shield + z.hp, 150.0 - 80.0, "8 ticks of 10, armour ignored, no stacking");
    let mut env = env_of(&units, extra);
    cast(&mut env, Team::One, 1, Ability::PsionicStorm, at(15.0, 22.5)).expect("storm");
    order(&mut env, Team::Two, 4, Command::MoveTo { to: Vec2::new(15.0, 30.0) }).expect("leave");
    order(&mut env, Team::Two, 3, Command::Hold).expect("hold");
    env.step();
    let r = refusal(cast(&mut env, Team::One, 1, Ability::PsionicStorm, at(15.0, 22.5)));
    assert_eq!(r, Refusal::OnCooldown { seconds: 31.0 / LOOPS_PER_SECOND }, "1.43 s");
    run_loops(&mut env, 70);
    assert_eq!(unit(&env, 3).shield + unit(&env, 3).hp, 70.0);
    let left = unit(&env, 4).shield + unit(&env, 4).hp;
    assert!((120.0..150.0).contains(&left), "the one leaving took one to three ticks: {left}");
}

#[test]
fn feedback_drains_energy_for_half_a_point_each() {
    let units = [("HighTemplar", 1, 8.0, 16.0, ""), ("Ghost", 2, 16.0, 16.0, ""), ("Marine", 2, 16.0, 18.0, "")];
    let mut env = env_of(&units, "");
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::Feedback, on(uid(2)))), Refusal::InvalidTarget { .. }));
    cast(&mut env, Team::One, 0, Ability::Feedback, on(uid(1))).expect("feedback");
    env.step();
    let g = unit(&env, 1);
    assert!(g.energy < 0.1);
    assert_eq!(g.hp, 100.0 - 37.5, "75 energy x 0.5");
}

#[test]
fn immortal_barrier_absorbs_100_on_the_first_hit_then_waits_720_loops() {
    let mut env = env_of(&[("Immortal", 1, 10.0, 16.0, ""), ("Marauder", 2, 15.0, 16.0, "")], "");
    order(&mut env, Team::Two, 1, Command::Attack { target: uid(0) }).expect("attack");
    env.step();
    let i = unit(&env, 0);
    assert_eq!((i.shield, i.hp, i.status.barrier_hp), (100.0, 200.0, 80.0), "20 absorbed");
    assert_eq!(i.status.barrier_until, 48);
    assert_eq!(env.world().stats(Team::One).abilities.get(&Ability::Barrier), Some(&1));
    run_loops(&mut env, 60);
    assert!(unit(&env, 0).shield < 100.0, "after 2.14 s hits reach the shields");
    assert_eq!(unit(&env, 0).status.cooldown_until, 720);
}

#[test]
fn graviton_beam_lifts_a_ground_unit_out_of_the_fight() {
    let units = [("Phoenix", 1, 10.0, 16.0, ""), ("Marauder", 2, 13.0, 16.0, ""), ("Ultralisk", 2, 12.0, 19.0, "")];
    let mut env = env_of(&units, "");
    assert!(matches!(refusal(cast(&mut env, Team::One, 0, Ability::GravitonBeam, on(uid(2)))), Refusal::InvalidTarget { .. }));
    cast(&mut env, Team::One, 0, Ability::GravitonBeam, on(uid(1))).expect("lift");
    env.step();
    assert!(unit(&env, 1).flying() && unit(&env, 1).status.lifted(env.world().tick()));
    // Lifted, the Marauder is an air unit: the Phoenix's anti-air weapon could hit it, and
    // it cannot act.
    run_loops(&mut env, 158);
    assert!(unit(&env, 1).flying());
    run_loops(&mut env, 2);
    assert!(!unit(&env, 1).flying(), "down after 7.14 s");
}

#[test]
fn warp_prism_leaving_phasing_mode_unpowers_cannons() {
    let units = [("Marine", 1, 10.0, 16.0, ""), ("PhotonCannon", 2, 14.0, 16.0, ""), ("WarpPrismPhasing", 2, 15.0, 18.0, "")];
    let mut env = Env::new(load(&arena_units("pvp", &units, "")), crate::helpers::one_loop(crate::helpers::exact()), 1);
    env.step();
    assert!(unit(&env, 0).hp < 45.0, "a powered cannon fires");
    cast(&mut env, Team::Two, 2, Ability::TransportMode, AbilityTarget::None).expect("transport");
    run_loops(&mut env, 25);
    assert_eq!(unit(&env, 2).kind, UnitKind::WarpPrism);
    let hp = unit(&env, 0).hp;
    run_loops(&mut env, 60);
    assert_eq!(unit(&env, 0).hp, hp, "an unpowered cannon does not fire");
}

#[test]
fn baneling_explodes_on_command() {
    let units =
        [("Baneling", 2, 10.0, 16.0, ""), ("Marine", 1, 11.5, 16.0, ""), ("Marine", 1, 13.5, 16.0, ""), ("Zergling", 2, 9.0, 16.0, "")];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::Two, 0, Ability::Explode, AbilityTarget::None).expect("explode");
    env.step();
    assert!(!unit(&env, 0).alive);
    assert_eq!((unit(&env, 1).hp, unit(&env, 2).hp), (10.0, 45.0), "35 within 2.2 (edge); the far one untouched");
    assert!(unit(&env, 3).hp >= 35.0, "no friendly fire");
}

#[test]
fn transfusion_heals_75_now_and_50_over_160_loops() {
    let units = [("Queen", 2, 10.0, 16.0, "energy = 50"), ("Ultralisk", 2, 13.0, 16.0, ""), ("Marauder", 1, 20.0, 16.0, "")];
    let mut env = env_of(&units, "");
    assert!(
        matches!(refusal(cast(&mut env, Team::Two, 0, Ability::Transfusion, on(uid(1)))), Refusal::InvalidTarget { .. }),
        "full health"
    );
    // Let the Marauder hit the Ultralisk until 125 HP fit under its maximum.
    order(&mut env, Team::One, 2, Command::Attack { target: uid(1) }).expect("attack");
    while unit(&env, 1).hp > 360.0 {
        env.step();
    }
    order(&mut env, Team::One, 2, Command::Stop).expect("stop");
    env.step();
    let before = unit(&env, 1).hp;
    cast(&mut env, Team::Two, 0, Ability::Transfusion, on(uid(1))).expect("transfuse");
    env.step();
    let now = unit(&env, 1).hp;
    assert!((now - before - 75.0 - 50.0 / 160.0).abs() < 0.1, "{before} -> {now}");
    run_loops(&mut env, 170);
    let later = unit(&env, 1).hp;
    let regen = 0.38 / 22.4 * 171.0;
    assert!((later - now - (50.0 - 50.0 / 160.0) - regen).abs() < 0.2, "{now} -> {later}");
}

#[test]
fn every_refusal_reason_is_reported() {
    let units = [
        ("Marine", 1, 10.0, 16.0, ""),
        ("HighTemplar", 1, 10.0, 18.0, ""),
        ("SiegeTank", 1, 10.0, 20.0, ""),
        ("Ghost", 1, 10.0, 22.0, "energy = 200"),
        ("Zealot", 2, 26.0, 16.0, ""),
    ];
    let mut env = env_of(&units, "upgrades = [{ team = 1, name = \"PsiStormTech\" }, { team = 1, name = \"PersonalCloaking\" }]");
    let t1 = Team::One;
    assert_eq!(refusal(cast(&mut env, t1, 0, Ability::PsionicStorm, at(12.0, 16.0))), Refusal::NotItsAbility { kind: UnitKind::Marine });
    assert!(matches!(refusal(cast(&mut env, t1, 0, Ability::Stimpack, AbilityTarget::None)), Refusal::NeedsUpgrade { .. }));
    assert_eq!(refusal(cast(&mut env, t1, 1, Ability::PsionicStorm, at(12.0, 18.0))), Refusal::NotEnoughEnergy { have: 50.0, need: 75.0 });
    assert_eq!(
        refusal(cast(&mut env, t1, 1, Ability::Feedback, at(12.0, 18.0))),
        Refusal::WrongTargetKind { expected: avacraft_engine::TargetKind::Unit }
    );
    assert!(matches!(refusal(cast(&mut env, t1, 3, Ability::SteadyTargeting, on(uid(4)))), Refusal::OutOfRange { .. }));
    assert!(matches!(refusal(cast(&mut env, t1, 3, Ability::SteadyTargeting, on(uid(1)))), Refusal::InvalidTarget { .. }), "own unit");
    assert_eq!(refusal(cast(&mut env, t1, 3, Ability::Decloak, AbilityTarget::None)), Refusal::NotActive);
    cast(&mut env, t1, 3, Ability::Cloak, AbilityTarget::None).expect("cloak");
    cast(&mut env, t1, 2, Ability::SiegeMode, AbilityTarget::None).expect("siege");
    env.step();
    assert_eq!(refusal(cast(&mut env, t1, 3, Ability::Cloak, AbilityTarget::None)), Refusal::AlreadyActive);
    assert_eq!(refusal(cast(&mut env, t1, 2, Ability::Unsiege, AbilityTarget::None)), Refusal::NotItsAbility { kind: UnitKind::SiegeTank });
    assert!(matches!(refusal(cast(&mut env, t1, 3, Ability::Emp, at(f32::NAN, 1.0))), Refusal::InvalidTarget { .. }));
    run_loops(&mut env, 65);
    cast(&mut env, t1, 2, Ability::Unsiege, AbilityTarget::None).expect("unsiege");
    env.step();
    assert!(matches!(refusal(cast(&mut env, t1, 2, Ability::Unsiege, AbilityTarget::None)), Refusal::Busy { .. }), "morphing back");
    let refused = env.refused()[0];
    assert_eq!(refused, 11, "every refusal is counted");
    // Switched off, every cast is refused.
    let mut cfg = exact_loop();
    cfg.rules.abilities = false;
    let mut off = Env::new(load(&arena_units("pvp", &units, "")), cfg, 1);
    assert_eq!(refusal(cast(&mut off, t1, 2, Ability::SiegeMode, AbilityTarget::None)), Refusal::Disabled);
}

#[test]
fn review_regressions_spell_deaths_channels_feedback_and_force_fields() {
    // A Marine killed by a snipe does not fire in the loop it dies.
    let mut env = env_of(&[("Ghost", 1, 10.0, 16.0, ""), ("Marine", 2, 14.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::SteadyTargeting, on(uid(1))).expect("snipe");
    run_loops(&mut env, 32);
    order(&mut env, Team::Two, 1, Command::Attack { target: uid(0) }).expect("attack");
    env.step();
    assert!(!unit(&env, 1).alive);
    assert_eq!(unit(&env, 0).hp, 100.0, "the dead Marine never shot");
    // Feedback on a channelling Ghost: the refund is drained too.
    let units = [("Ghost", 1, 10.0, 16.0, ""), ("Ultralisk", 2, 18.0, 16.0, ""), ("HighTemplar", 2, 12.0, 22.0, "")];
    let mut env = env_of(&units, "");
    cast(&mut env, Team::One, 0, Ability::SteadyTargeting, on(uid(1))).expect("snipe");
    env.step();
    cast(&mut env, Team::Two, 2, Ability::Feedback, on(uid(0))).expect("feedback");
    env.step();
    assert!(unit(&env, 0).energy < 0.1 && unit(&env, 0).status.channel.is_none(), "{}", unit(&env, 0).energy);
    // Force fields do not push structures.
    let mut env = env_of(&[("Sentry", 1, 8.0, 16.0, ""), ("PhotonCannon", 2, 15.0, 16.0, "")], "");
    cast(&mut env, Team::One, 0, Ability::ForceField, at(15.0, 16.5)).expect("force field");
    run_loops(&mut env, 3);
    assert_eq!(unit(&env, 1).pos, Vec2::new(15.0, 16.0));
}

#[test]
fn smac_agents_can_wait_out_a_channel() {
    let s = load(&arena_units("pvp", &[("Ghost", 1, 10.0, 16.0, ""), ("Ultralisk", 2, 18.0, 16.0, "")], ""));
    let mut env = Env::new(s, exact_loop(), 1);
    cast(&mut env, Team::One, 0, Ability::SteadyTargeting, on(uid(1))).expect("snipe");
    env.step();
    let n = env.env_info(Team::One).n_actions;
    let mut avail = vec![0u8; n];
    env.avail_agent(Team::One, 0, &mut avail);
    assert_eq!(avail[0], 1, "no-op available while channelling");
    for _ in 0..40 {
        env.submit_indices(Team::One, &[0]);
        env.step();
    }
    assert!((unit(&env, 1).hp - 370.0).abs() < 0.5, "the snipe landed: {}", unit(&env, 1).hp);
    env.avail_agent(Team::One, 0, &mut avail);
    assert_eq!(avail[0], 0, "and not after");
}
