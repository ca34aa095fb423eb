//! Decisions checked against real observations: the reasons given, and the property that
//! matters most: whatever a model writes, an accepted command is never refused by the engine.

use crate::common::state;
use avacraft_ava::decision::{Item, Order, Situation, Verb, check, extract_json, parse_items, schema, targets};
use avacraft_engine::agent::{GroupObs, Reads};
use avacraft_engine::{Ability, Action, Command, Env, Team, UnitId};
use avacraft_render::{Camera, vlm_obs_layout};
use proptest::prelude::*;
use serde_json::{Value, json};

fn camera(env: &Env, obs: &GroupObs) -> Camera {
    let own = obs.units.iter().filter(|u| u.own).map(|u| avacraft_engine::Vec2::new(u.x, u.y));
    vlm_obs_layout(1024, 576).camera(own, Camera::DEFAULT_WIDTH, env.world().terrain().playable())
}

fn id(tag: u32) -> UnitId {
    UnitId::try_from(tag).expect("a tag")
}

fn ids(tags: &[u32]) -> Vec<UnitId> {
    tags.iter().map(|&t| id(t)).collect()
}

fn item(unit: u32, action: Verb) -> Item {
    Item { unit, action, target: None, cell: None, direction: None, ability: None, point: None, stance: None }
}

#[test]
fn refusals_say_what_is_wrong() {
    let env = state("3m_vlm", 1, 6);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let cam = camera(&env, &obs);
    let sit = Situation { obs: &obs, camera: &cam, terrain: env.world().terrain(), micro: false };
    let own: Vec<u32> = obs.units.iter().filter(|u| u.own).map(|u| u.tag.tag()).collect();
    let enemy_id = obs.units.iter().find(|u| !u.own).map(|u| u.tag).expect("an enemy in sight after 6 steps");
    let enemy = enemy_id.tag();
    let items = vec![
        (0, Item { target: Some(enemy), ..item(own[0], Verb::Attack) }),
        (1, Item { target: Some(enemy), ..item(own[0], Verb::Attack) }),
        (2, item(99, Verb::Hold)),
        (3, Item { target: Some(own[2]), ..item(own[1], Verb::Attack) }),
        (4, Item { cell: Some([11, 3]), ..item(own[1], Verb::MoveGrid) }),
        (5, Item { direction: Some("up-left".into()), ..item(own[1], Verb::MoveDir) }),
        (6, Item { ability: Some("psionic_storm".into()), cell: Some([5, 5]), ..item(own[1], Verb::Ability) }),
        (7, item(own[2], Verb::Attack)),
        (8, Item { cell: Some([5, 5]), ..item(own[1], Verb::MoveGrid) }),
    ];
    let c = check(&sit, &items, Vec::new());
    let reasons: Vec<(usize, &str)> = c.refused.iter().map(|r| (r.item, r.reason.as_str())).collect();
    let want = [
        (1, "already has an action"),
        (2, "not one of yours"),
        (3, "your own unit"),
        (4, "not on the 10x10 grid"),
        (5, "unknown direction"),
        (6, "has no ability `psionic_storm`"),
        (7, "needs `target`"),
    ];
    assert_eq!(reasons.len(), want.len(), "{reasons:?}");
    for ((i, r), (wi, w)) in reasons.iter().zip(want) {
        assert_eq!(*i, wi);
        assert!(r.contains(w), "item {i}: `{r}` should say `{w}`");
    }
    assert_eq!(c.commands.len(), 2);
    assert_eq!(c.commands[0], (id(own[0]), Order::Do(Command::Attack { target: enemy_id })));
    // The grid move goes to the camera's cell, the one drawn on the screenshot.
    let Order::Do(Command::MoveTo { to }) = c.commands[1].1 else { panic!("{:?}", c.commands[1]) };
    assert_eq!(cam.cell_of(to), Some((5, 5)));
}

#[test]
fn abilities_are_checked_for_energy_range_and_target_side() {
    // MMM: Medivacs heal (their attack is a heal on a friendly unit); Marauders and Marines stim.
    let env = state("MMM_vs_MMM", 2, 4);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let cam = camera(&env, &obs);
    let sit = Situation { obs: &obs, camera: &cam, terrain: env.world().terrain(), micro: false };
    let medivac = obs.units.iter().find(|u| u.own && u.kind.base().name() == "Medivac").expect("a Medivac");
    let marine = obs.units.iter().find(|u| u.own && u.kind.base().name() == "Marine").expect("a Marine");
    let items = vec![
        (0, Item { target: Some(marine.tag.tag()), ..item(medivac.tag.tag(), Verb::Attack) }),
        (1, Item { ability: Some("stimpack".into()), ..item(marine.tag.tag(), Verb::Ability) }),
    ];
    let c = check(&sit, &items, Vec::new());
    assert!(c.refused.is_empty(), "{:?}", c.refused);
    assert_eq!(c.commands[1].1, Order::Do(Command::Ability { ability: Ability::Stimpack, target: avacraft_engine::AbilityTarget::None }));
    if let Some(enemy) = obs.units.iter().find(|u| !u.own) {
        let c = check(&sit, &[(0, Item { target: Some(enemy.tag.tag()), ..item(medivac.tag.tag(), Verb::Attack) })], Vec::new());
        assert!(c.refused[0].reason.contains("heals"), "{:?}", c.refused);
    }
}

/// Asserts that `s` stays inside OpenAI's strict `json_schema` subset (the strictest server
/// AVA sends it to): every object requires all its properties and allows no others, arrays
/// have `items`, `enum`s are not empty, and only the keywords strict mode supports appear
/// (since May 2025 these include `maxLength`, `minimum`/`maximum` and `minItems`/`maxItems`).
fn assert_strict(s: &Value, at: &str) {
    const KEYWORDS: [&str; 12] = [
        "type",
        "properties",
        "required",
        "additionalProperties",
        "items",
        "enum",
        "anyOf",
        "maxLength",
        "minimum",
        "maximum",
        "minItems",
        "maxItems",
    ];
    let obj = s.as_object().unwrap_or_else(|| panic!("{at}: a schema is an object: {s}"));
    for k in obj.keys() {
        assert!(KEYWORDS.contains(&k.as_str()), "{at}: keyword `{k}` is outside strict mode's subset");
    }
    if let Some(e) = obj.get("enum") {
        assert!(e.as_array().is_some_and(|e| !e.is_empty()), "{at}: an empty enum");
    }
    if let Some(any) = obj.get("anyOf") {
        for (i, a) in any.as_array().expect("anyOf is a list").iter().enumerate() {
            assert_strict(a, &format!("{at}.anyOf[{i}]"));
        }
        return;
    }
    match obj.get("type").and_then(Value::as_str) {
        Some("object") => {
            let props = obj["properties"].as_object().unwrap_or_else(|| panic!("{at}: an object without properties"));
            let mut required: Vec<&str> = obj["required"].as_array().expect("required").iter().filter_map(Value::as_str).collect();
            let mut names: Vec<&str> = props.keys().map(String::as_str).collect();
            required.sort_unstable();
            names.sort_unstable();
            assert_eq!(required, names, "{at}: strict mode requires every property");
            assert_eq!(obj.get("additionalProperties"), Some(&Value::Bool(false)), "{at}");
            for (k, v) in props {
                assert_strict(v, &format!("{at}.{k}"));
            }
        }
        Some("array") => assert_strict(obj.get("items").unwrap_or_else(|| panic!("{at}: an array without items")), &format!("{at}[]")),
        Some("string" | "integer" | "number" | "boolean" | "null") => {}
        other => panic!("{at}: type {other:?}"),
    }
}

fn verbs(s: &Value) -> Vec<&str> {
    let e = s["properties"]["actions"]["items"]["properties"]["action"]["enum"].as_array().expect("enum");
    e.iter().filter_map(Value::as_str).collect()
}

#[test]
fn the_schema_names_the_tags_there_are_and_bounds_the_list() {
    let s = schema(&ids(&[1, 2, 3]), &ids(&[4, 5, 6]), &["stimpack", "heal"]);
    assert_strict(&s, "decision");
    let actions = &s["properties"]["actions"];
    assert_eq!(actions["maxItems"], 3, "at most one item per unit: the list ends");
    let props = &actions["items"]["properties"];
    assert_eq!(verbs(&s), Verb::ALL.map(Verb::name));
    assert_eq!(props["unit"]["enum"], json!([1, 2, 3]));
    assert_eq!(props["target"]["anyOf"][0]["enum"], json!([4, 5, 6]));
    assert_eq!(props["target"]["anyOf"][1], json!({"type": "null"}));
    assert_eq!(props["ability"]["anyOf"][0]["enum"][1], "heal");
    // Every example item in the decision prompt fits the schema's fields.
    for name in ["unit", "action", "target", "cell", "direction", "ability"] {
        assert!(props.get(name).is_some(), "{name}");
    }
    // Nothing in sight and no abilities: the verbs that would be refused are left out, and
    // their fields can only be null.
    let s = schema(&ids(&[7]), &[], &[]);
    assert_strict(&s, "decision without targets");
    assert_eq!(verbs(&s), ["move_grid", "move_dir", "hold", "stop"]);
    let props = &s["properties"]["actions"]["items"]["properties"];
    assert_eq!(props["target"], json!({"type": "null"}));
    assert_eq!(props["ability"], json!({"type": "null"}));
    // No unit left: an empty list is the only answer (and no enum is empty).
    let s = schema(&[], &ids(&[4]), &[]);
    assert_strict(&s, "decision without units");
    assert_eq!(s["properties"]["actions"]["maxItems"], 0);
    // What the schema makes a model write (unused fields null) parses into items.
    let v = extract_json(r#"{"reasoning": "x", "actions": [{"unit": 1, "action": "attack", "target": 4, "cell": null, "direction": null, "ability": null}]}"#)
        .expect("object");
    let (items, refused) = parse_items(&v, "actions").expect("list");
    assert!(refused.is_empty(), "{refused:?}");
    assert_eq!(items[0].1, Item { target: Some(4), ..item(1, Verb::Attack) });
}

#[test]
fn targets_are_enemies_in_sight_and_own_units_only_for_those_that_heal() {
    let env = state("3m_vlm", 1, 8);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let enemies: Vec<UnitId> = obs.units.iter().filter(|u| !u.own).map(|u| u.tag).collect();
    assert!(!enemies.is_empty(), "3m_vlm's enemies are in sight after 8 steps of attack-move");
    assert_eq!(targets(&obs), enemies, "Marines act on enemies only");
    // MMM: Medivacs heal other units of theirs.
    let env = state("MMM_vs_MMM", 2, 4);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let t = targets(&obs);
    for u in &obs.units {
        assert!(t.contains(&u.tag), "{} {} is a target", if u.own { "own" } else { "enemy" }, u.tag.tag());
    }
}

type RawItem = (
    prop::sample::Index,
    usize,
    Option<prop::sample::Index>,
    Option<(u8, u8)>,
    Option<usize>,
    Option<usize>,
    Option<(f32, f32)>,
    Option<usize>,
);

fn arb_items() -> impl Strategy<Value = Vec<RawItem>> {
    prop::collection::vec(
        (
            any::<prop::sample::Index>(),
            0usize..10,
            prop::option::of(any::<prop::sample::Index>()),
            prop::option::of((0u8..12, 0u8..12)),
            prop::option::of(0usize..5),
            prop::option::of(0usize..=Ability::COUNT),
            prop::option::of((-5.0f32..70.0, -5.0f32..70.0)),
            prop::option::of(0usize..4),
        ),
        1..12,
    )
}

/// A model's item from raw draws: tags of the observation (and 99), verbs, cells,
/// directions and abilities, with junk among each.
fn to_json(raw: &RawItem, tags: &[u32]) -> Value {
    let verbs = ["attack", "move_grid", "move_dir", "ability", "hold", "stop", "charge", "attack_move", "move", "stance"];
    let dirs = ["north", "south", "east", "west", "sideways"];
    let stances = ["focus", "kite", "hold", "dance"];
    let (unit, verb, target, cell, dir, ability, point, stance) = raw;
    let mut v = json!({"unit": tags[unit.index(tags.len())], "action": verbs[*verb]});
    if let Some(t) = target {
        v["target"] = tags[t.index(tags.len())].into();
    }
    if let Some((c, r)) = cell {
        v["cell"] = json!([c, r]);
    }
    if let Some(d) = dir {
        v["direction"] = dirs[*d].into();
    }
    if let Some(a) = ability {
        v["ability"] = Ability::ALL.get(*a).map_or("nuke", |a| a.name()).into();
    }
    if let Some((x, y)) = point {
        v["point"] = json!([x, y]);
    }
    if let Some(st) = stance {
        v["stance"] = stances[*st].into();
    }
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random decisions over several scenarios and moments: whatever is accepted, the engine
    /// takes; nothing panics.
    #[test]
    fn accepted_commands_are_never_refused_by_the_engine(
        which in 0usize..4,
        steps in 0u32..30,
        picks in arb_items(),
        micro in any::<bool>(),
    ) {
        let scenario = ["3m_vlm", "MMM_vs_MMM", "pvz_ht", "8m3mr1mv1st_vs_5s2c"][which];
        let mut env = state(scenario, 5, steps);
        prop_assume!(!env.done());
        let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
        let mut tags: Vec<u32> = obs.units.iter().map(|u| u.tag.tag()).collect();
        tags.push(99);
        let raw: Vec<Value> = picks.iter().map(|p| to_json(p, &tags)).collect();
        let text = json!({"reasoning": "", "actions": raw}).to_string();
        let v = extract_json(&text).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let (items, refused) = parse_items(&v, "actions").map_err(|e| TestCaseError::fail(e.to_string()))?;
        let cam = camera(&env, &obs);
        let terrain = env.scenario().terrain.clone();
        let c = check(&Situation { obs: &obs, camera: &cam, terrain: &terrain, micro }, &items, refused);
        prop_assert_eq!(c.commands.len() + c.refused.len(), picks.len());
        // The paper's action set refuses the micro verbs.
        if !micro {
            let extra = ["attack_move", "move", "stance"];
            prop_assert!(!c.commands.iter().any(|(t, o)| matches!(o, Order::Keep(_)) && tags.contains(&t.tag())));
            let n = picks.iter().filter(|p| extra.contains(&["attack", "move_grid", "move_dir", "ability", "hold", "stop", "charge", "attack_move", "move", "stance"][p.1])).count();
            prop_assert!(c.refused.len() >= n);
        }
        // A stance's action each step is a command the engine takes too.
        let terrain2 = env.scenario().terrain.clone();
        let stance_actions: Vec<Action> = c
            .commands
            .iter()
            .filter_map(|(t, o)| match o {
                Order::Keep(st) => obs.units.iter().find(|u| u.tag == *t).and_then(|u| st.act(&obs, &terrain2, u)),
                Order::Do(_) => None,
            })
            .collect();
        for (a, r) in stance_actions.iter().zip(env.submit(Team::One, &stance_actions)) {
            prop_assert!(r.is_ok(), "stance action {:?} refused by the engine: {:?}", a, r);
        }
        let actions: Vec<Action> = c
            .commands
            .iter()
            .filter_map(|(t, o)| match o {
                Order::Do(cmd) => Some(Action::new(*t, *cmd)),
                Order::Keep(_) => None,
            })
            .collect();
        for (a, r) in actions.iter().zip(env.submit(Team::One, &actions)) {
            prop_assert!(r.is_ok(), "{:?} accepted by AVA but refused by the engine: {:?}", a, r);
        }
    }

    /// Arbitrary text never panics the reader.
    #[test]
    fn any_text_is_read_or_refused(text in ".{0,200}") {
        if let Ok(v) = extract_json(&text) {
            let _ = parse_items(&v, "actions");
        }
    }
}

/// A stance gives a morphing unit no order (the engine would refuse it: the proptest above
/// found a Siege Tank told to hold mid-morph), and none to a channelling one (it would end
/// the channel).
#[test]
fn stances_leave_a_busy_unit_alone() {
    use avacraft_engine::Buffs;
    use avacraft_engine::agent::Stance;
    let mut seen = 0;
    for steps in 0..12 {
        let env = state("8m3mr1mv1st_vs_5s2c", 5, steps);
        let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
        let terrain = env.scenario().terrain.clone();
        for u in obs.units.iter().filter(|u| [Buffs::MORPHING, Buffs::LIFTED, Buffs::CHANNELLING].iter().any(|b| u.buffs.contains(*b))) {
            seen += 1;
            for st in [Stance::Hold, Stance::Focus { target: None }, Stance::Kite { target: None }] {
                assert_eq!(st.act(&obs, &terrain, u), None, "{st:?} gave busy unit {} an order at step {steps}", u.tag.tag());
            }
        }
    }
    assert!(seen > 0, "no unit was busy in the first 12 steps: the test checks nothing");
}
