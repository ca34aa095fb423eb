//! Property tests: the scenario parser never panics on any input, and any valid random
//! scenario simulates without panics or non-finite state.

use crate::helpers::*;
use avacraft_engine::{Controllers, Env, EnvConfig, Scenario, UnitKind};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn parser_never_panics_on_arbitrary_text(text in ".{0,400}") {
        let _ = Scenario::from_toml("fuzz.toml", &text);
    }

    #[test]
    fn parser_never_panics_on_mutated_files(cut in 0usize..400, insert in "[ -~]{0,12}") {
        let base = arena("pve", &[("Marine", 1, 10.0, 16.0), ("Zealot", 2, 14.0, 16.0)]);
        let at = cut.min(base.len());
        let at = (0..=at).rev().find(|&i| base.is_char_boundary(i)).unwrap_or(0);
        let text = format!("{}{}{}", &base[..at], insert, &base[at..]);
        if let Err(e) = Scenario::from_toml("fuzz.toml", &text) {
            prop_assert!(e.to_string().contains("fuzz.toml"));
        }
    }

    #[test]
    fn random_armies_simulate_cleanly(
        units in prop::collection::vec((0usize..UnitKind::ALL.len(), 1u8..=2, 1.0f32..31.0, 1.0f32..31.0), 2..24),
        seed in 0u64..1000,
    ) {
        let mut list: Vec<(&str, u8, f32, f32)> = units.iter().map(|&(k, t, x, y)| (UnitKind::ALL[k].name(), t, x, y)).collect();
        list.push(("Marine", 1, 2.0, 2.0));
        list.push(("Marine", 2, 30.0, 30.0));
        let s = load(&arena("pvp", &list));
        let mut env = Env::new(s.clone(), EnvConfig::default(), seed);
        let mut c = Controllers::named(&s, "random", Some("focus")).expect("policy");
        c.reset(&env);
        for _ in 0..60 {
            if env.done() { break; }
            c.act(&mut env);
            env.step();
        }
        for u in env.world().units() {
            prop_assert!(u.pos.is_finite() && u.hp.is_finite() && u.shield.is_finite());
            prop_assert!(u.hp <= u.max_hp + 1e-3 && u.shield <= u.max_shield + 1e-3);
            prop_assert!(env.world().terrain().playable().contains(u.pos));
        }
    }
}
