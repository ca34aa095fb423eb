//! The structured unit list and the text description.

use avacraft_engine::{Env, EnvConfig, GroupObs, Team, builtin, describe, unit_list};
use std::sync::Arc;

#[test]
fn unit_list_has_stable_names_and_grid_cells() {
    let s = Arc::new(builtin("MMM_vs_MMM").expect("scenario"));
    let mut env = Env::new(s, EnvConfig::default(), 0);
    let first = unit_list(env.world(), Team::One);
    let names: Vec<&str> = first.iter().filter(|u| u.own).map(|u| u.name.as_str()).collect();
    assert!(names.contains(&"Marine_1") && names.contains(&"Marine_8") && names.contains(&"Medivac_1"), "{names:?}");
    for _ in 0..60 {
        env.step();
    }
    let later = unit_list(env.world(), Team::One);
    for u in later.iter().filter(|u| u.own) {
        let before = first.iter().find(|b| b.tag == u.tag).expect("same tag");
        assert_eq!(before.name, u.name, "names are permanent");
        assert!((1..=10).contains(&u.grid[0]) && (1..=10).contains(&u.grid[1]));
        assert!(u.hp <= u.max_hp);
    }
    let json = serde_json::to_value(&later).expect("json");
    let m = &json[0];
    for key in
        ["tag", "name", "type", "team", "x", "y", "grid", "hp", "shield", "energy", "weapon_cooldown_s", "order", "activity", "flags"]
    {
        assert!(m.get(key).is_some(), "missing {key}: {m}");
    }
}

#[test]
fn text_names_units_numbers_and_objective() {
    let s = Arc::new(builtin("3m_vlm").expect("scenario"));
    let mut env = Env::new(s, EnvConfig::default(), 0);
    for _ in 0..12 {
        env.step();
    }
    let t = describe(&env, Team::One);
    assert!(t.contains("Objective: Destroy every enemy unit"), "{t}");
    assert!(t.contains("Marine_1 (tag 1, Marine): HP"), "{t}");
    assert!(t.contains("at grid ("), "{t}");
    assert!(t.contains("of 300 s"), "{t}");
    let seen = GroupObs::team(&env, Team::One, 0, avacraft_engine::Reads::UNITS).enemies().count();
    assert_eq!(t.matches("tag 4").count() + t.matches("tag 5").count() + t.matches("tag 6").count() > 0, seen > 0, "{t}");
}
