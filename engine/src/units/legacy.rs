//! The engine's unit table before it read the game's data files: python-sc2's dump of the
//! ladder's data at patch 5.0.9 (Normal-speed units, converted to game loops with
//! [`normal_s`] and [`per_normal_s`]) and `shared/reference/units.md`, with no weapon timing
//! (attacks land the loop they start). Kept unchanged as the `legacy` data set, so that
//! policies trained, recordings made and results rated on it before still play the same game.
//! Values marked [U] in the reference were not confirmed against a primary source.

use super::short::{A, B, L, M, MS, P, S};
use super::{Attrs, Heal, Race, Reach, Regen, Splash, Timing, UnitKind, UnitSpec, Weapon};
use crate::time::{LOOPS_PER_SECOND, normal_s, per_normal_s};

const fn weapon(reach: Reach, damage: f32, hits: u8, cooldown_normal_s: f32, range: f32) -> Weapon {
    Weapon {
        reach,
        damage,
        hits,
        bonus: &[],
        cooldown: normal_s(cooldown_normal_s),
        range,
        min_range: 0.0,
        splash: Splash::None,
        suicide: false,
        timing: LEGACY_TIMING,
    }
}

/// No wind-up, backswing, slop or missile flight; the random delay of -1 to +2 loops the
/// engine always drew (the data's -0.0625 to +0.125 Normal seconds).
const LEGACY_TIMING: Timing = Timing {
    damage_point: 0.0,
    backswing: 0.0,
    range_slop: 0.0,
    scan: 0.0,
    delay: [-1.0, 2.0],
    missile_speed: 0.0,
    turn: 0.0,
    arc_slop: 0.0,
};

const fn with_bonus(w: Weapon, bonus: &'static [(Attrs, f32)]) -> Weapon {
    Weapon { bonus, ..w }
}

const fn with_splash(w: Weapon, splash: Splash) -> Weapon {
    Weapon { splash, ..w }
}

const fn spec(kind: UnitKind, race: Race, hp: f32, shield: f32, armor: f32, attrs: Attrs) -> UnitSpec {
    UnitSpec {
        kind,
        race,
        hp,
        shield,
        armor,
        attrs,
        speed: 0.0,
        sight: 9.0,
        radius: 0.5,
        flying: false,
        energy_max: 0.0,
        energy_start: 0.0,
        weapons: &[],
        scan_range: 5.0,
        heal: None,
        cliff_walk: false,
        detector: false,
        needs_power: false,
        power_radius: 0.0,
        smac_max_cd: 1.0,
        present: true,
        tall: false,
        regen: legacy_regen(race),
    }
}

/// The engine's regeneration before the game's data: Zerg life 0.38 per Faster second with
/// no delay, shields 2 per Normal second after 10 s, energy 0.5625 per Normal second.
const fn legacy_regen(race: Race) -> Regen {
    let energy = per_normal_s(0.5625);
    match race {
        Race::Zerg => Regen { life: 0.38 / LOOPS_PER_SECOND, life_delay: 0.0, shield: 0.0, shield_delay: 0.0, energy },
        Race::Protoss => Regen { life: 0.0, life_delay: 0.0, shield: per_normal_s(2.0), shield_delay: normal_s(10.0), energy },
        Race::Terran => Regen { life: 0.0, life_delay: 0.0, shield: 0.0, shield_delay: 0.0, energy },
    }
}

/// Movement stats: Normal-speed speed, sight, radius.
const fn body(s: UnitSpec, speed_normal: f32, sight: f32, radius: f32) -> UnitSpec {
    UnitSpec { speed: per_normal_s(speed_normal), sight, radius, ..s }
}

const fn armed(s: UnitSpec, weapons: &'static [Weapon], smac_max_cd: f32) -> UnitSpec {
    UnitSpec { weapons, smac_max_cd, ..s }
}

const fn energy(s: UnitSpec, max: f32, start: f32) -> UnitSpec {
    UnitSpec { energy_max: max, energy_start: start, ..s }
}

const fn air(s: UnitSpec) -> UnitSpec {
    UnitSpec { flying: true, ..s }
}

use Race::{Protoss as Pr, Terran as Te, Zerg as Zg};
use Reach::{Air as RA, Any as RX, Ground as RG};
use UnitKind as K;

const TANK_SPLASH: Splash = Splash::Radial { zones: &[(0.4687, 1.0), (0.7812, 0.5), (1.25, 0.25)], friendly_fire: true };

/// The table. Order matches [`UnitKind`].
pub(super) const LEGACY: [UnitSpec; 28] = [
    armed(body(spec(K::Marine, Te, 45.0, 0.0, 0.0, L.union(B)), 2.25, 9.0, 0.375), &[weapon(RX, 6.0, 1, 0.8608, 5.0)], 15.0),
    armed(
        body(spec(K::Marauder, Te, 125.0, 0.0, 1.0, A.union(B)), 2.25, 10.0, 0.5625),
        &[with_bonus(weapon(RG, 10.0, 1, 1.5, 6.0), &[(A, 10.0)])],
        25.0,
    ),
    UnitSpec {
        heal: Some(Heal { hp_per_loop: per_normal_s(9.0), energy_per_hp: 1.0 / 3.0, range: 4.0, min_energy_to_start: 5.0 }),
        smac_max_cd: 200.0,
        ..energy(air(body(spec(K::Medivac, Te, 150.0, 0.0, 1.0, A.union(M)), 2.5, 11.0, 0.75)), 200.0, 50.0)
    },
    armed(
        body(spec(K::SiegeTank, Te, 175.0, 0.0, 1.0, A.union(M)), 2.25, 11.0, 0.875),
        &[with_bonus(weapon(RG, 15.0, 1, 1.04, 7.0), &[(A, 10.0)])],
        17.0,
    ),
    armed(
        body(spec(K::SiegeTankSieged, Te, 175.0, 0.0, 1.0, A.union(M)), 0.0, 11.0, 0.875),
        &[Weapon {
            min_range: 2.0, // [U]
            ..with_splash(with_bonus(weapon(RG, 40.0, 1, 3.0, 13.0), &[(A, 30.0)]), TANK_SPLASH)
        }],
        48.0,
    ),
    armed(body(spec(K::Reaper, Te, 60.0, 0.0, 0.0, L.union(B)), 3.75, 9.0, 0.375), &[weapon(RG, 4.0, 2, 1.1, 5.0)], 18.0),
    armed(
        body(spec(K::Hellbat, Te, 135.0, 0.0, 0.0, L.union(B).union(M)), 2.25, 10.0, 0.625),
        // A 45-degree arc of radius 2 in front of the Hellbat (game data 5.0.13).
        &[with_splash(
            weapon(RG, 18.0, 1, 2.0, 2.0),
            Splash::Cone { length: 2.0 + 0.625, half_angle: std::f32::consts::FRAC_PI_8, fraction: 1.0 },
        )],
        32.0,
    ),
    armed(
        body(spec(K::VikingAssault, Te, 135.0, 0.0, 0.0, A.union(M)), 2.25, 10.0, 0.75),
        &[with_bonus(weapon(RG, 12.0, 1, 1.0, 6.0), &[(M, 8.0)])],
        16.0,
    ),
    armed(
        air(body(spec(K::VikingFighter, Te, 135.0, 0.0, 0.0, A.union(M)), 2.75, 10.0, 0.75)),
        &[with_bonus(weapon(RA, 10.0, 2, 2.0, 9.0), &[(A, 4.0)])],
        32.0,
    ),
    energy(
        armed(
            body(spec(K::Ghost, Te, 100.0, 0.0, 0.0, B.union(P)), 2.8125, 11.0, 0.375),
            &[with_bonus(weapon(RX, 10.0, 1, 1.5, 6.0), &[(L, 10.0)])],
            24.0,
        ),
        200.0,
        75.0,
    ),
    energy(
        armed(air(body(spec(K::Banshee, Te, 140.0, 0.0, 0.0, L.union(M)), 2.75, 10.0, 0.75)), &[weapon(RG, 12.0, 2, 1.25, 6.0)], 20.0),
        200.0,
        50.0,
    ),
    armed(body(spec(K::Zealot, Pr, 100.0, 50.0, 1.0, L.union(B)), 2.25, 9.0, 0.5), &[weapon(RG, 8.0, 2, 1.2, 0.1)], 22.0),
    armed(
        body(spec(K::Stalker, Pr, 80.0, 80.0, 1.0, A.union(M)), 2.953125, 10.0, 0.625),
        &[with_bonus(weapon(RX, 13.0, 1, 1.87, 6.0), &[(A, 5.0)])],
        35.0,
    ),
    // Sentry: 6 damage, 0.71 s (Faster), range 5 (game data 5.0.13; its +4 against shields
    // is not modelled).
    energy(
        armed(body(spec(K::Sentry, Pr, 40.0, 40.0, 1.0, L.union(M).union(P)), 2.5, 10.0, 0.5), &[weapon(RX, 6.0, 1, 1.0, 5.0)], 16.0),
        200.0,
        50.0,
    ),
    energy(
        armed(
            body(spec(K::HighTemplar, Pr, 40.0, 40.0, 0.0, L.union(B).union(P)), 2.015625, 10.0, 0.375),
            &[weapon(RG, 4.0, 1, 1.754, 6.0)],
            28.0,
        ),
        200.0,
        50.0,
    ),
    armed(
        body(spec(K::Archon, Pr, 10.0, 350.0, 0.0, P.union(MS)), 2.8125, 9.0, 1.0),
        // Splash 100% / 50% / 25% within 0.25 / 0.5 / 1.0 of the target (game data 5.0.13).
        &[with_splash(
            with_bonus(weapon(RX, 25.0, 1, 1.754, 3.0), &[(B, 10.0)]),
            Splash::Radial { zones: &[(0.25, 1.0), (0.5, 0.5), (1.0, 0.25)], friendly_fire: false },
        )],
        28.0,
    ),
    armed(
        body(spec(K::Immortal, Pr, 200.0, 100.0, 1.0, A.union(M)), 2.25, 9.0, 0.75),
        &[with_bonus(weapon(RG, 20.0, 1, 1.45, 6.0), &[(A, 30.0)])],
        23.0,
    ),
    UnitSpec {
        cliff_walk: true,
        tall: true,
        ..armed(
            body(spec(K::Colossus, Pr, 200.0, 150.0, 1.0, A.union(M).union(MS)), 2.25, 10.0, 1.0),
            // Each lance sweeps a line 2.5 long across the target (game data 5.0.13).
            &[with_splash(with_bonus(weapon(RG, 10.0, 2, 1.5, 7.0), &[(L, 5.0)]), Splash::Line { half_length: 1.25, fraction: 1.0 })],
            24.0,
        )
    },
    energy(
        armed(
            air(body(spec(K::Phoenix, Pr, 120.0, 60.0, 0.0, L.union(M)), 4.25, 10.0, 0.75)),
            &[with_bonus(weapon(RA, 5.0, 2, 1.1, 5.0), &[(L, 5.0)])],
            18.0,
        ),
        200.0,
        50.0,
    ),
    air(body(spec(K::WarpPrism, Pr, 80.0, 100.0, 0.0, A.union(M).union(P)), 2.953125, 10.0, 0.875)),
    // Power field radius 3.75 (game data 5.0.13).
    UnitSpec { power_radius: 3.75, ..air(body(spec(K::WarpPrismPhasing, Pr, 80.0, 100.0, 0.0, A.union(M).union(P)), 0.0, 11.0, 0.875)) },
    UnitSpec {
        detector: true,
        needs_power: true,
        ..armed(body(spec(K::PhotonCannon, Pr, 150.0, 150.0, 1.0, A.union(S)), 0.0, 11.0, 1.125), &[weapon(RX, 20.0, 1, 1.25, 7.0)], 20.0)
    },
    armed(body(spec(K::Zergling, Zg, 35.0, 0.0, 0.0, L.union(B)), 2.953125, 8.0, 0.375), &[weapon(RG, 5.0, 1, 0.696, 0.1)], 11.0),
    armed(
        body(spec(K::Baneling, Zg, 30.0, 0.0, 0.0, B), 2.5, 8.0, 0.375),
        &[Weapon {
            suicide: true,
            ..with_splash(
                with_bonus(weapon(RG, 16.0, 1, 0.0, 0.25), &[(L, 19.0), (S, 80.0)]),
                Splash::Radial { zones: &[(2.2, 1.0)], friendly_fire: false },
            )
        }],
        1.0,
    ),
    armed(
        body(spec(K::Ultralisk, Zg, 500.0, 0.0, 2.0, A.union(B).union(MS)), 2.953125, 9.0, 0.875),
        // Cleave: 33% to enemies within 2 in front (game data 5.0.13 lists a 45 and a 180
        // degree arc; [U] how they combine: the 180-degree front arc is used).
        &[with_splash(
            weapon(RG, 35.0, 1, 0.86, 1.0),
            Splash::Cone { length: 2.0 + 0.875, half_angle: std::f32::consts::FRAC_PI_2, fraction: 0.33 },
        )],
        14.0,
    ),
    energy(
        armed(
            body(spec(K::Queen, Zg, 175.0, 0.0, 1.0, B.union(P)), 0.9375, 9.0, 0.875),
            &[weapon(RG, 4.0, 2, 1.0, 5.0), weapon(RA, 9.0, 1, 1.0, 7.0)],
            16.0,
        ),
        200.0,
        25.0,
    ),
    UnitSpec {
        scan_range: 10.0,
        ..armed(
            body(spec(K::SpineCrawler, Zg, 300.0, 0.0, 2.0, A.union(B).union(S)), 0.0, 11.0, 1.125),
            &[with_bonus(weapon(RG, 25.0, 1, 1.85, 7.0), &[(A, 5.0)])],
            30.0,
        )
    },
    armed(body(spec(K::Hydralisk, Zg, 90.0, 0.0, 0.0, L.union(B)), 2.25, 9.0, 0.625), &[weapon(RX, 12.0, 1, 0.826, 5.0)], 10.0),
];
