//! The ceiling back end and the rich prompt: the prompt carries what the ceiling reads (every
//! unit's tag, exact position, HP and readiness, as the observation has them), the paper's
//! prompt is still read, a ceiling over HTTP plays as the in-process one, and the micro
//! action set lets a prompt-only player kite where the paper's did not.

use crate::common::{FakeServer, play, setup, state};
use avacraft_ava::llm::{Ceiling, CeilingScript, ceiling_decision, read_prompt};
use avacraft_ava::{ActionSet, AvaConfig, PromptStyle, describe};
use avacraft_engine::agent::{GroupObs, Reads};
use avacraft_engine::{Env, Outcome, Team, UnitId};
use avacraft_render::{Camera, vlm_obs_layout};

fn ceiling_cfg(prompt: PromptStyle, actions: ActionSet, decide_every: u32) -> AvaConfig {
    AvaConfig { prompt, actions, decide_every, image: false, ..AvaConfig::default() }
}

/// What the rich prompt says of each unit is what the observation holds: the ceiling reads
/// every own and enemy tag, its position to 0.05 and its HP plus shields, on scenarios with
/// shields, energy, air units and many units, at several moments.
#[test]
fn the_rich_prompt_carries_every_unit_as_observed() {
    for (scenario, steps) in [("3m_vlm", 8), ("2s3z_vlm", 20), ("pvz_ht", 30), ("mixed_units", 25), ("8m3mr1mv1st_vs_5s2c", 12)] {
        let env = state(scenario, 3, steps);
        let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
        let mine: Vec<UnitId> = obs.units.iter().filter(|u| u.own).map(|u| u.tag).collect();
        let text = avacraft_ava::describe_rich(&obs, &env.scenario().terrain, &mine, None);
        let read = read_prompt(&text);
        assert!(read.exact, "{scenario}: exact positions");
        assert_eq!(read.mine.len(), mine.len(), "{scenario}: own units\n{text}");
        let enemies: Vec<_> = obs.units.iter().filter(|u| !u.own).collect();
        assert_eq!(read.enemies.len(), enemies.len(), "{scenario}: enemies\n{text}");
        for s in read.mine.iter().chain(&read.enemies) {
            let u = obs.units.iter().find(|u| u.tag.tag() == s.tag).expect("a unit the observation has");
            assert_eq!(s.kind, u.kind.name(), "{scenario} {}", s.tag);
            assert!(
                (s.at.0 - u.x).abs() <= 0.051 && (s.at.1 - u.y).abs() <= 0.051,
                "{scenario} {}: {:?} vs ({}, {})",
                s.tag,
                s.at,
                u.x,
                u.y
            );
            assert!((s.life - (u.hp + u.shield)).abs() <= 1.0, "{scenario} {}: {} vs {}", s.tag, s.life, u.hp + u.shield);
            if u.own && !u.spec().weapons.is_empty() {
                assert_eq!(s.ready, u.weapon_cooldown_s <= 0.0, "{scenario} {}: readiness", s.tag);
            }
        }
        // Every type on the field has its data line, with what its weapons hit.
        for u in &obs.units {
            assert!(read.hits.iter().any(|(k, _, _)| k == u.kind.name()), "{scenario}: a line for {}", u.kind.name());
        }
    }
}

/// The paper's prompt is read too: tags and HP from its lines, positions as grid cells.
#[test]
fn the_paper_prompt_is_read_by_cells() {
    let env = state("2s3z_vlm", 2, 20);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let mine: Vec<UnitId> = obs.units.iter().filter(|u| u.own).map(|u| u.tag).collect();
    let own = obs.units.iter().filter(|u| u.own).map(|u| avacraft_engine::Vec2::new(u.x, u.y));
    let cam: Camera = vlm_obs_layout(1024, 576).camera(own, Camera::DEFAULT_WIDTH, env.world().terrain().playable());
    let read = read_prompt(&describe(&obs, &cam, &mine));
    assert!(!read.exact);
    assert_eq!(read.mine.iter().map(|s| s.tag).collect::<Vec<_>>(), mine.iter().map(|id| id.tag()).collect::<Vec<_>>());
    for s in &read.mine {
        let u = obs.units.iter().find(|u| u.tag.tag() == s.tag).expect("unit");
        let cell = cam.cell_of(avacraft_engine::Vec2::new(u.x, u.y)).expect("own units are on screen");
        assert_eq!((s.at.0 as u8, s.at.1 as u8), cell, "{}", s.tag);
        assert!((s.life - (u.hp + u.shield)).abs() <= 1.0);
    }
}

/// The ceiling's decision names only the prompt's own units, one item each, and targets only
/// enemies the prompt lists; with the micro set it keeps intent with stances.
#[test]
fn the_ceiling_answers_from_the_prompt_in_the_schema() {
    let env = state("3s_vs_3z_vlm", 4, 14);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let mine: Vec<UnitId> = obs.units.iter().filter(|u| u.own).map(|u| u.tag).collect();
    let mut read = read_prompt(&avacraft_ava::describe_rich(&obs, &env.scenario().terrain, &mine, None));
    assert!(!read.enemies.is_empty(), "Zealots in sight after 14 steps");
    read.micro = true;
    for script in CeilingScript::ALL {
        let d = ceiling_decision(script, &read);
        let items = d["actions"].as_array().expect("actions");
        let units: Vec<u64> = items.iter().filter_map(|i| i["unit"].as_u64()).collect();
        let all: Vec<u64> = mine.iter().map(|id| u64::from(id.tag())).collect();
        if script == CeilingScript::AttackMove {
            // Only idle units get the order, as the script gives it.
            assert!(units.iter().all(|u| all.contains(u)), "{script:?}: {units:?}");
            let idle = read.mine.iter().filter(|m| m.idle).count();
            assert_eq!(units.len(), idle, "{script:?}");
        } else {
            assert_eq!(units, all, "{script:?}");
        }
        for i in items {
            if let Some(t) = i["target"].as_u64() {
                assert!(read.enemies.iter().any(|e| e.tag as u64 == t), "{script:?}: target {t}");
            }
            let want = if script == CeilingScript::AttackMove { "attack_move" } else { "stance" };
            assert!(i["action"] == want || i["action"] == "ability", "{script:?}: {i}");
        }
    }
}

fn outcome(env: &Env) -> Option<Outcome> {
    env.outcome()
}

/// What the action set allows a perfect player: on 3s_vs_3z_vlm, where only kiting wins (the
/// `kite` script wins it), the ceiling answering as `kite` through the paper's prompt and
/// actions wins none of three seeds at a decision every 2 steps, and through the rich prompt
/// and micro actions wins all three. The same ceiling over HTTP (the fake server's ceiling
/// mode) plays the same games as the in-process back end.
#[test]
fn the_micro_action_set_lets_a_perfect_player_kite() {
    let won = |cfg: AvaConfig, seed: u64| {
        let s = setup(Box::new(Ceiling::new(CeilingScript::Kite)), cfg, None);
        outcome(&play("3s_vs_3z_vlm", seed, &s, 2000)) == Some(Outcome::Win)
    };
    for seed in [9000, 9001, 9002] {
        assert!(!won(ceiling_cfg(PromptStyle::Paper, ActionSet::Paper, 2), seed), "seed {seed}: the paper's set does not kite");
        assert!(won(ceiling_cfg(PromptStyle::Rich, ActionSet::Micro, 2), seed), "seed {seed}: stances kite");
    }
    let server = FakeServer::start_ceiling(CeilingScript::Kite);
    let cfg = ceiling_cfg(PromptStyle::Rich, ActionSet::Micro, 2);
    let http = play("3s_vs_3z_vlm", 9000, &setup(Box::new(server.client(10.0)), cfg.clone(), None), 2000);
    let local = play("3s_vs_3z_vlm", 9000, &setup(Box::new(Ceiling::new(CeilingScript::Kite)), cfg, None), 2000);
    assert_eq!(http.trajectory_hash(), local.trajectory_hash(), "the fake server's ceiling mode plays as the back end");
    assert!(!server.seen().is_empty());
}

/// The paper's prompt and action set stay what they were: a recording made by the code
/// before the rich prompt, the micro action set and the ceiling existed (3s_vs_3z_vlm, seed
/// 5, a decision every 4 steps, text only, a fake model that attacks, moves by direction and
/// by cell, so the history holds each wording) replays call for call with today's defaults.
#[test]
fn recordings_of_the_paper_prompt_still_replay() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/paper_v1_3s_vs_3z");
    let replay = avacraft_ava::llm::Replay::open(&dir).expect("the fixture");
    let calls = replay.remaining();
    assert!(calls >= 30, "{calls} calls");
    let cfg = AvaConfig { decide_every: 4, image: false, ..AvaConfig::default() };
    let s = setup(Box::new(replay), cfg, None);
    let env = play("3s_vs_3z_vlm", 5, &s, 5000);
    assert!(env.done());
    assert_eq!(s.run.fatal(), None, "every request is the recorded one");
    let asked: u64 = s.run.episodes().iter().map(|e| e.total.calls).sum();
    assert_eq!(asked as usize, calls, "every recorded call was asked");
}

/// A rich prompt as AVA writes it, for the ceiling to read: the header (with where the enemy
/// started, when given), the unit lines, the enemies in sight, the unit types, and the
/// answer's shape the ceiling looks for.
fn rich(enemy_start: Option<(f32, f32)>, mine: &[&str], enemies: &[&str], types: &[&str]) -> String {
    let mut s = String::from(
        "Step 9, game time 3.0 s. Positions (x,y) in world units: x 0-32 west to east, y 0-32 south to north. Distances are edge to edge, as weapon ranges are.",
    );
    if let Some((x, y)) = enemy_start {
        s.push_str(&format!(" The enemy started near ({x:.1},{y:.1})."));
    }
    s.push_str("\nYour units (tag type (x,y) hp[+shields] | weapon | order | enemies in range | nearest enemy):\n");
    mine.iter().for_each(|l| s.push_str(&format!("- {l}\n")));
    if enemies.is_empty() {
        s.push_str("No enemy in sight.\n");
    } else {
        s.push_str("Enemies in sight (tag type (x,y) hp[+shields] | target):\n");
        enemies.iter().for_each(|l| s.push_str(&format!("- {l}\n")));
    }
    if !types.is_empty() {
        s.push_str("Unit types here:\n");
        types.iter().for_each(|l| s.push_str(&format!("- {l}\n")));
    }
    s.push_str("- {\"unit\": U, \"action\": \"stance\"}");
    s
}

/// `prompt` as it reads when the next decision is two steps away.
fn deciding_every_2(prompt: &str) -> String {
    format!("{prompt}\nGive one action per unit of yours (1); the next decision comes in 2 steps (0.71 s of game time).")
}

const MARINE: &str = "Marine: Terran, Light, Biological, 45 health, 0 armor, speed 3.15, sight 9. Weapon: 6 damage, range 5, every 0.61 s, hits ground and air.";
const ZEALOT: &str = "Zealot: Protoss, Light, Biological, 100 health, 50 shields, 1 armor, speed 3.15, sight 9. Weapon: 8 damage x2 hits, range 0.1, every 0.86 s, hits ground only.";

/// Self-cast abilities, read off the rich prompt's lines: a Marine at full health with an
/// enemy within its range plus 2 and Stimpack ready stims; once stimmed, or hurt, it does not.
#[test]
fn the_ceiling_stims_as_the_scripts_do() {
    let line =
        |extra: &str| rich(Some((23.0, 16.0)), &[&format!("1 Marine (9.0,16.0) {extra}")], &["4 Marine (15.0,16.0) 45/45"], &[MARINE]);
    let act = |extra: &str| {
        let read = read_prompt(&line(extra));
        assert_eq!(read.enemy_start, Some((23.0, 16.0)));
        ceiling_decision(CeilingScript::FocusFire, &read)["actions"][0].clone()
    };
    let stim = act("45/45 | range 5 ready | idle | none in range | nearest 4 at 6.2 | can cast stimpack");
    assert_eq!((stim["action"].as_str(), stim["ability"].as_str()), (Some("ability"), Some("stimpack")), "{stim}");
    for no in [
        "45/45 | range 5 ready | idle | none in range | nearest 4 at 6.2 | stimmed",
        "35/45 | range 5 ready | idle | none in range | nearest 4 at 6.2 | can cast stimpack",
        "45/45 | range 5 ready | idle | none in range | nearest 4 at 9.0 | can cast stimpack",
    ] {
        let a = act(no);
        assert_eq!(a["action"], "stance", "{no}: {a}");
        // Focus fire's rule is the stance's own: no target named, the weakest in sight each step.
        assert!(a["target"].is_null(), "{no}: {a}");
    }
    // An enemy 9.0 away is past the script's line (range 5 + 2), but with the next decision two
    // steps off the armies close about 2.3 a step before then: stim now, not a step late.
    let far = "45/45 | range 5 ready | idle | none in range | nearest 4 at 9.0 | can cast stimpack";
    let a = ceiling_decision(CeilingScript::FocusFire, &read_prompt(&deciding_every_2(&line(far))))["actions"][0].clone();
    assert_eq!(a["ability"], "stimpack", "decides every 2 steps: {a}");
    let farther = deciding_every_2(&line(&far.replace("9.0", "9.6")));
    let a = ceiling_decision(CeilingScript::FocusFire, &read_prompt(&farther))["actions"][0].clone();
    assert_eq!(a["action"], "stance", "beyond the look-ahead: {a}");
}

/// The scripts measure their stim and siege lines to the nearest enemy the unit can hit: a
/// Marauder (ground only) with an enemy Medivac nearest does not stim for it, and does when a
/// ground unit comes within its range plus 2.
#[test]
fn the_ceiling_measures_to_what_a_unit_can_hit() {
    let prompt = |marine_at: f32| {
        rich(
            Some((23.0, 16.0)),
            &[
                "1 Marauder (9.0,16.0) 125/125 | range 6 ready | attack-moving to (23.0,16.0) | none in range | nearest 5 at 3.0 | can cast stimpack",
            ],
            &[&format!("4 Marine ({marine_at:.1},16.0) 45/45"), "5 Medivac (12.5,16.0) 150/150"],
            &[
                "Marauder: Terran, Armored, Biological, 125 health, 1 armor, speed 3.15, sight 10. Weapon: 10 damage (+10 vs Armored), range 6, every 1.07 s, hits ground only.",
                MARINE,
                "Medivac: Terran, Armored, Mechanical, 150 health, 1 armor, speed 3.85, sight 11, flying (only anti-air weapons hit it). No weapon.",
            ],
        )
    };
    let act = |marine_at: f32| ceiling_decision(CeilingScript::AttackMove, &read_prompt(&prompt(marine_at)))["actions"][0].clone();
    // The Marine 11 away (about 10 edge to edge): beyond 6 + 2, whatever the Medivac does.
    let a = act(20.0);
    assert_ne!(a["ability"], "stimpack", "the Medivac is not what it fights: {a}");
    // The Marine 8 away (about 7): within the line.
    let a = act(17.0);
    assert_eq!(a["ability"], "stimpack", "{a}");
}

/// Before contact, a unit already advancing gets a stance with no target, so it engages at the
/// first step an enemy is seen rather than at the next decision; one standing still is sent
/// towards where the enemy started.
#[test]
fn the_ceiling_holds_its_stance_ready_before_contact() {
    let text = |order: &str| {
        rich(Some((23.0, 16.0)), &[&format!("1 Marine (9.0,16.0) 45/45 | range 5 ready | {order} | none in range")], &[], &[])
    };
    for script in [CeilingScript::FocusFire, CeilingScript::Kite] {
        let a = ceiling_decision(script, &read_prompt(&text("attack-moving to (23.0,16.0)")))["actions"][0].clone();
        assert_eq!(a["action"], "stance", "{script:?}: {a}");
        assert!(a["target"].is_null(), "{script:?}: {a}");
        let a = ceiling_decision(script, &read_prompt(&text("idle")))["actions"][0].clone();
        assert_eq!(a["action"], "attack_move", "{script:?}: {a}");
        assert_eq!(a["point"], serde_json::json!([23.0, 16.0]), "{script:?}: {a}");
    }
}

/// KD8 Charge by the scripts' rule: a Reaper throws it at the nearest enemy when that is a
/// mobile melee unit within 3; not at a Marine, and not at a Zealot further away.
#[test]
fn the_ceiling_knocks_back_melee_units_closing_in() {
    let text = |enemy: &str, dist: f32| {
        rich(
            None,
            &[&format!(
                "1 Reaper (16.0,16.0) 50/50 | range 4.5 ready | attacking 4 | in range 4 | nearest 4 at {dist:.1} | can cast kd8_charge"
            )],
            &[&format!("4 {enemy} (18.0,16.0) 45/45 | attacking 1")],
            &[
                "Reaper: Terran, Light, Biological, 50 health, 0 armor, speed 4.13, sight 9. Weapon: 4 damage x2 hits (+5 vs Light), range 4.5, every 0.79 s, hits ground only.",
                ZEALOT,
                MARINE,
            ],
        )
    };
    let a = ceiling_decision(CeilingScript::Kite, &read_prompt(&text("Zealot", 1.2)))["actions"][0].clone();
    assert_eq!((a["action"].as_str(), a["ability"].as_str(), a["target"].as_u64()), (Some("ability"), Some("kd8_charge"), Some(4)), "{a}");
    for (enemy, dist) in [("Marine", 1.2), ("Zealot", 4.0)] {
        let a = ceiling_decision(CeilingScript::Kite, &read_prompt(&text(enemy, dist)))["actions"][0].clone();
        assert_eq!(a["action"], "stance", "{enemy} at {dist}: {a}");
    }
}

/// Blink by the scripts' rule, read off the rich prompt: a Stalker out of shields and under 60%
/// HP with an enemy close blinks 7.5 away from it (an exact point, micro set only); with
/// shields left it does not.
#[test]
fn the_ceiling_blinks_hurt_stalkers_away() {
    let text = |vitals: &str| {
        rich(
            None,
            &[&format!("1 Stalker (16.0,16.0) {vitals} | range 6 ready | attacking 4 | in range 4 | nearest 4 at 2.0 | can cast blink")],
            &["4 Zealot (19.0,16.0) 100/100+50sh | attacking 1"],
            &[
                "Stalker: Protoss, Armored, Mechanical, 80 health, 80 shields, 1 armor, speed 4.13, sight 10. Weapon: 10 damage, range 6, every 1.03 s, hits ground and air.",
                ZEALOT,
            ],
        )
    };
    let read = read_prompt(&text("40/80+0sh"));
    assert_eq!(read.mine[0].shields, 0.0);
    let a = ceiling_decision(CeilingScript::Kite, &read)["actions"][0].clone();
    assert_eq!((a["action"].as_str(), a["ability"].as_str()), (Some("ability"), Some("blink")), "{a}");
    let p = a["point"].as_array().expect("a point");
    let (x, y) = (p[0].as_f64().expect("x"), p[1].as_f64().expect("y"));
    assert!((x - 8.5).abs() < 0.01 && (y - 16.0).abs() < 0.01, "7.5 west, away from the Zealot: ({x}, {y})");
    let a = ceiling_decision(CeilingScript::Kite, &read_prompt(&text("40/80+30sh")))["actions"][0].clone();
    assert_eq!(a["action"], "stance", "shields left: {a}");
    // At 75% HP it waits while it decides every step, and blinks when the next decision is
    // two steps away (the scripts check every step).
    let a = ceiling_decision(CeilingScript::Kite, &read_prompt(&text("60/80+0sh")))["actions"][0].clone();
    assert_eq!(a["action"], "stance", "decides every step: {a}");
    let a = ceiling_decision(CeilingScript::Kite, &read_prompt(&deciding_every_2(&text("60/80+0sh"))))["actions"][0].clone();
    assert_eq!(a["ability"], "blink", "decides every 2 steps: {a}");
}

/// A stance naming no target fights by the focus-fire script's rule every step: each unit
/// attacks the group's weakest enemy in sight; with no enemy in sight it gives no order, so
/// the unit's attack-move goes on.
#[test]
fn a_stance_without_a_target_takes_the_weakest_in_sight() {
    use avacraft_engine::Command;
    use avacraft_engine::agent::Stance;
    let env = state("3m_vlm", 4, 0);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    assert_eq!(obs.units.iter().filter(|u| !u.own).count(), 0, "nothing in sight at the start");
    for u in obs.units.iter().filter(|u| u.own) {
        assert_eq!(Stance::Focus { target: None }.act(&obs, &env.scenario().terrain, u), None);
    }
    let env = state("3m_vlm", 4, 14);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let weakest = obs.units.iter().filter(|u| !u.own).map(|e| e.hp + e.shield).fold(f32::INFINITY, f32::min);
    assert!(weakest.is_finite(), "Marines in sight after 14 steps");
    let mut attacks = 0;
    for u in obs.units.iter().filter(|u| u.own) {
        for stance in [Stance::Focus { target: None }, Stance::Kite { target: None }] {
            if let Some(a) = stance.act(&obs, &env.scenario().terrain, u)
                && let Command::Attack { target } = a.command
            {
                let t = obs.units.iter().find(|e| e.tag == target).expect("a seen target");
                assert!(!t.own && t.hp + t.shield <= weakest + 1e-3, "{stance:?}: {t:?} is not the weakest");
                attacks += 1;
            }
        }
    }
    assert!(attacks > 0, "someone is told to attack");
}

/// Unsiege by the script's rule, from the prompt's in-range list and nearest distance: a lone
/// enemy hugging the tank under its minimum range makes it unsiege, not when another enemy is in
/// range too; and the attack-move answer sends no sieged (immobile) tank walking.
#[test]
fn the_ceiling_unsieges_as_the_script_and_moves_only_what_can_move() {
    let text = |fields: &str| {
        rich(
            None,
            &[&format!("1 SiegeTankSieged (16.0,16.0) 175/175 | range 13 ready | idle | {fields} | can cast unsiege")],
            &["4 Zealot (17.5,16.0) 100/100+50sh | attacking 1", "5 Zealot (22.0,16.0) 100/100+50sh"],
            &[
                "SiegeTankSieged: Terran, Armored, Mechanical, 175 health, 1 armor, sight 11. Weapon: 40 damage (+30 vs Armored), range 13, every 2.14 s, hits ground only.",
                ZEALOT,
            ],
        )
    };
    let act =
        |script, fields: &str| ceiling_decision(script, &read_prompt(&text(fields)))["actions"].as_array().cloned().unwrap_or_default();
    let hugged = act(CeilingScript::FocusFire, "in range 4 | nearest 4 at 0.4");
    assert_eq!(hugged[0]["ability"], "unsiege", "{hugged:?}");
    let two = act(CeilingScript::FocusFire, "in range 4 5 | nearest 4 at 0.4");
    assert_ne!(two[0]["ability"], "unsiege", "{two:?}");
    let far = act(CeilingScript::FocusFire, "none in range | nearest 4 at 16.0");
    assert_eq!(far[0]["ability"], "unsiege", "{far:?}");
    // Idle but unable to walk: the attack-move answer leaves it be.
    let am = act(CeilingScript::AttackMove, "in range 4 5 | nearest 4 at 2.5");
    assert!(am.iter().all(|a| a["action"] != "attack_move"), "{am:?}");
}

/// A unit that takes no order says so in the rich prompt (a tank packing up from siege mode is
/// "morphing"), so a model, and the ceiling, leave it alone instead of being refused.
#[test]
fn the_rich_prompt_says_when_a_unit_takes_no_order() {
    use avacraft_engine::{Ability, AbilityTarget, Action, Command};
    let mut env = state("8m2st_vs_35zg4b", 4, 0);
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let id = obs.units.iter().find(|u| u.own && u.kind.base().name() == "SiegeTank").expect("a tank").tag;
    let tank = id.tag();
    let r = env.submit(Team::One, &[Action::new(id, Command::Ability { ability: Ability::Unsiege, target: AbilityTarget::None })]);
    assert!(r[0].is_ok(), "the scenario's tanks start sieged: {r:?}");
    env.step();
    let obs = GroupObs::team(&env, Team::One, 0, Reads::ALL);
    let mine: Vec<UnitId> = obs.units.iter().filter(|u| u.own).map(|u| u.tag).collect();
    let text = avacraft_ava::describe_rich(&obs, &env.scenario().terrain, &mine, None);
    let line = text.lines().find(|l| l.starts_with(&format!("- {tank} "))).expect("the tank's line");
    assert!(line.contains("morphing, takes no order"), "{line}");
    let read = read_prompt(&format!("{text}\n- {{\"unit\": U, \"action\": \"stance\"}}"));
    for script in CeilingScript::ALL {
        let d = ceiling_decision(script, &read);
        let items = d["actions"].as_array().cloned().unwrap_or_default();
        assert!(items.iter().all(|i| i["unit"] != tank || i["action"] == "ability"), "{script:?}: {items:?}");
    }
}
