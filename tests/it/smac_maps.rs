//! SMAC's 23 maps as scenario files (engine/scenarios/smac/, tools/gen_smac.py): every map's
//! armies, episode limit, unit data and fog as SMAC's map files and registry have them, armies
//! created at one point spread over free ground, and SMAC's interface sizes where SMAC's
//! layout documents them.

use avacraft_engine::{DataSet, Env, EnvConfig, Scenario, Team};
use std::path::PathBuf;
use std::sync::Arc;

/// SMAC's registry (smac_maps.py): agents, enemies, episode limit in steps.
const REGISTRY: [(&str, usize, usize, u32); 23] = [
    ("3m", 3, 3, 60),
    ("8m", 8, 8, 120),
    ("25m", 25, 25, 150),
    ("5m_vs_6m", 5, 6, 70),
    ("8m_vs_9m", 8, 9, 120),
    ("10m_vs_11m", 10, 11, 150),
    ("27m_vs_30m", 27, 30, 180),
    ("MMM", 10, 10, 150),
    ("MMM2", 10, 12, 180),
    ("2s3z", 5, 5, 120),
    ("3s5z", 8, 8, 150),
    ("3s5z_vs_3s6z", 8, 9, 170),
    ("3s_vs_3z", 3, 3, 150),
    ("3s_vs_4z", 3, 4, 200),
    ("3s_vs_5z", 3, 5, 250),
    ("1c3s5z", 9, 9, 180),
    ("2m_vs_1z", 2, 1, 150),
    ("corridor", 6, 24, 400),
    ("6h_vs_8z", 6, 8, 150),
    ("2s_vs_1sc", 2, 1, 300),
    ("bane_vs_bane", 24, 24, 200),
    ("so_many_baneling", 7, 32, 100),
    ("2c_vs_64zg", 2, 64, 400),
];

fn map(name: &str) -> Arc<Scenario> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../engine/scenarios/smac").join(format!("{name}.toml"));
    Arc::new(Scenario::load(&path.to_string_lossy()).unwrap_or_else(|e| panic!("{name}: {e}")))
}

#[test]
fn every_map_has_smacs_armies_limit_data_and_no_fog() {
    for (name, agents, enemies, limit) in REGISTRY {
        let s = map(name);
        assert_eq!((s.count(Team::One), s.count(Team::Two)), (agents, enemies), "{name}");
        assert_eq!(s.time_limit_loops, limit * 8, "{name}: SMAC's {limit} steps");
        assert_eq!((s.data, s.fog_of_war), (DataSet::Liberty, false), "{name}");
        // Armies made at one point stand on free ground, none inside another.
        for (i, a) in s.units.iter().enumerate() {
            let sa = s.data.spec(a.kind);
            assert!(sa.flying || s.terrain.walkable(a.pos), "{name}: unit {i} off the ground at {:?}", a.pos);
            for b in &s.units[..i] {
                let sb = s.data.spec(b.kind);
                if sa.flying == sb.flying {
                    assert!(a.pos.dist(b.pos) + 1e-4 >= sa.radius + sb.radius, "{name}: units overlap at {:?} and {:?}", a.pos, b.pos);
                }
            }
        }
        let env = Env::new(Arc::clone(&s), EnvConfig::smac(), 1);
        let info = env.env_info(Team::One);
        assert_eq!((info.n_agents, info.episode_limit), (agents, limit as usize), "{name}");
    }
}

#[test]
fn smacs_interface_sizes_where_its_layout_gives_them() {
    // shared/reference/smac_layout.md: n_actions, obs and state sizes.
    for (name, n_actions, obs, state) in [
        ("3m", 9, 30, 48),
        ("2m_vs_1z", 7, 16, 26),
        ("2s_vs_1sc", 7, 17, 27),
        ("3s_vs_3z", 9, 36, 54),
        ("2s3z", 11, 80, 120),
        ("MMM", 16, 160, 290),
    ] {
        let env = Env::new(map(name), EnvConfig::smac(), 1);
        let info = env.env_info(Team::One);
        assert_eq!((info.n_actions, info.obs_shape, info.state_shape), (n_actions, obs, state), "{name}");
    }
}

#[test]
fn no_fog_shows_every_unit_from_the_start() {
    // 2s_vs_1sc's Spine Crawler stands beyond the Stalkers' sight: with the map's fog off they
    // see it (and may attack it) at once.
    let env = Env::new(map("2s_vs_1sc"), EnvConfig::smac(), 1);
    let w = env.world();
    let spine = w.units().iter().find(|u| u.team == Team::Two).map(|u| u.id).expect("the Crawler");
    assert!(w.visible_to(Team::One, spine));
}
