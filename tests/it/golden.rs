//! Golden trajectories: a few whole episodes (scenario, seed, policies) played in-process,
//! their result, length and trajectory hash (the seed and the full state after every step,
//! chained) compared with the values pinned in `tests/golden/trajectories.toml`. Any change
//! to what the simulator does, however small, changes a hash, so behaviour changes across
//! commits are seen and made on purpose.
//!
//! After an intended change, re-bless (rewrite the file) and commit it with the change:
//!
//! ```sh
//! AVACRAFT_BLESS=1 cargo test -p avacraft-tests --test it golden::
//! ```

use avacraft_engine::{Controllers, DataSet, Env, EnvConfig, Mode, OpponentKind, Outcome, Team, builtin};
use std::fmt::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// One pinned episode: team 1's policy (team 2's too in PvP), the PvE opponent and the unit
/// data (`None`: the scenario's own, its map's).
struct Case {
    scenario: &'static str,
    seed: u64,
    policy: &'static str,
    opponent: Option<OpponentKind>,
    data: Option<DataSet>,
}

/// The engine's game before it read StarCraft II's data files: these cases' hashes were pinned
/// then, and still hold.
const LEGACY: Option<DataSet> = Some(DataSet::Legacy);

const CASES: &[Case] = &[
    Case { scenario: "3m_vlm", seed: 1, policy: "focus-fire", opponent: Some(OpponentKind::Builtin), data: LEGACY },
    Case { scenario: "2s3z_vlm", seed: 7, policy: "kite", opponent: None, data: LEGACY },
    Case { scenario: "MMM_vs_MMM", seed: 3, policy: "focus-fire", opponent: None, data: LEGACY },
    // Abilities: storms, feedback and the opponent's casts.
    Case { scenario: "pvz_ht", seed: 2, policy: "focus-fire", opponent: None, data: LEGACY },
    // A Medivac (air movement, heal autocast) and sieging tanks.
    Case { scenario: "8m1mv_vs_2st", seed: 5, policy: "focus-fire", opponent: None, data: LEGACY },
    // Procedural: the units drawn from the seed (python/tests/test_smacv2.py plays this
    // case's draw from Python and checks the same pinned hash under the same actions).
    Case { scenario: "protoss_5_vs_5", seed: 4, policy: "focus-fire", opponent: None, data: LEGACY },
    Case { scenario: "zerg_10_vs_11", seed: 2, policy: "kite", opponent: None, data: LEGACY },
    // SMAC indices only: each agent takes its highest available action. Python plays it too.
    Case { scenario: "protoss_5_vs_5", seed: 4, policy: HIGHEST, opponent: None, data: LEGACY },
    // The maps' own data with the game's weapon timing: Liberty (missiles, wind-ups, Zerg
    // regeneration) and Void (splash, abilities, a Medivac and tanks).
    Case { scenario: "3s_vs_3z_vlm", seed: 1, policy: "kite", opponent: None, data: None },
    Case { scenario: "2s3z_vlm", seed: 7, policy: "kite", opponent: None, data: None },
    Case { scenario: "zerg_10_vs_11", seed: 2, policy: "kite", opponent: None, data: None },
    Case { scenario: "pvz_ht", seed: 2, policy: "focus-fire", opponent: None, data: None },
    Case { scenario: "8m1mv_vs_2st", seed: 5, policy: "focus-fire", opponent: None, data: None },
    Case { scenario: "MMM_vs_MMM", seed: 3, policy: "focus-fire", opponent: None, data: Some(DataSet::Ladder) },
];

/// The SMAC-index rule any binding can play: each agent's highest available action.
const HIGHEST: &str = "highest-index";

/// What an episode came to.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Pinned {
    result: String,
    steps: u32,
    game_loops: u32,
    trajectory_hash: String,
}

impl Case {
    fn key(&self) -> String {
        let opp = self.opponent.map_or("default", |o| o.name());
        let key = format!("{} seed {} {} vs {opp}", self.scenario, self.seed, self.policy);
        // Legacy cases keep the keys they were pinned under.
        match self.data {
            Some(DataSet::Legacy) => key,
            Some(d) => format!("{key} on {d}"),
            None => format!("{key} on {}", builtin(self.scenario).expect("built-in scenario").data),
        }
    }

    fn play(&self) -> Pinned {
        let s = builtin(self.scenario).expect("built-in scenario");
        let s = Arc::new(match self.data {
            Some(d) => s.with_data(d).expect("every unit is in the set"),
            None => s,
        });
        let mut env = Env::new(Arc::clone(&s), EnvConfig { opponent: self.opponent, ..EnvConfig::default() }, self.seed);
        if self.policy == HIGHEST {
            let info = env.env_info(Team::One);
            let mut avail = vec![0u8; info.n_actions];
            while !env.done() {
                let actions: Vec<usize> = (0..info.n_agents)
                    .map(|a| {
                        env.avail_agent(Team::One, a, &mut avail);
                        avail.iter().rposition(|&x| x == 1).unwrap_or(0)
                    })
                    .collect();
                env.submit_indices(Team::One, &actions);
                env.step();
            }
        } else {
            let second = (s.mode == Mode::Pvp).then_some(self.policy);
            let mut controllers = Controllers::named(&s, self.policy, second).expect("policy");
            controllers.reset(&env);
            while !env.done() {
                controllers.act(&mut env);
                env.step();
            }
        }
        let result = match env.outcome() {
            Some(Outcome::Win) => "win",
            Some(Outcome::Loss) => "loss",
            Some(Outcome::Draw) | None => "draw",
        };
        Pinned {
            result: result.into(),
            steps: env.steps(),
            game_loops: env.world().tick(),
            trajectory_hash: format!("{:016x}", env.trajectory_hash()),
        }
    }
}

fn file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("golden").join("trajectories.toml")
}

/// The pinned values by case key; a missing or malformed file reads as nothing pinned.
fn read_pinned(text: &str) -> Vec<(String, Pinned)> {
    let Ok(table) = text.parse::<toml::Table>() else { return Vec::new() };
    let Some(eps) = table.get("episode").and_then(|v| v.as_array()) else { return Vec::new() };
    eps.iter()
        .filter_map(|e| {
            let s = |k: &str| e.get(k).and_then(|v| v.as_str()).map(str::to_owned);
            let n = |k: &str| e.get(k).and_then(|v| v.as_integer()).and_then(|v| u32::try_from(v).ok());
            Some((
                s("case")?,
                Pinned { result: s("result")?, steps: n("steps")?, game_loops: n("game_loops")?, trajectory_hash: s("trajectory_hash")? },
            ))
        })
        .collect()
}

fn render(played: &[(String, Pinned)]) -> String {
    let mut out = String::from(
        "# Golden trajectories, checked by tests/it/golden.rs: whole episodes played in-process\n\
         # and what they came to. The trajectory hash chains the seed and the simulator's full\n\
         # state after every step. After an intended change of behaviour, re-bless with\n\
         #   AVACRAFT_BLESS=1 cargo test -p avacraft-tests --test it golden::\n\
         # and commit this file with the change.\n",
    );
    for (key, p) in played {
        let _ = write!(
            out,
            "\n[[episode]]\ncase = \"{key}\"\nresult = \"{}\"\nsteps = {}\ngame_loops = {}\ntrajectory_hash = \"{}\"\n",
            p.result, p.steps, p.game_loops, p.trajectory_hash
        );
    }
    out
}

/// Each played case that differs from its pinned values (or is not pinned), old and new.
fn differences(played: &[(String, Pinned)], pinned: &[(String, Pinned)]) -> Vec<String> {
    let mut diffs = Vec::new();
    for (key, now) in played {
        match pinned.iter().find(|(k, _)| k == key) {
            Some((_, old)) if old == now => {}
            Some((_, old)) => diffs.push(format!("{key}:\n    pinned {old:?}\n    now    {now:?}")),
            None => diffs.push(format!("{key}: not pinned; now {now:?}")),
        }
    }
    diffs
}

#[test]
fn trajectories_match_the_pinned_hashes() {
    let played: Vec<(String, Pinned)> = CASES.iter().map(|c| (c.key(), c.play())).collect();
    // Deterministic in-process: a second run of the first case must agree with the first.
    assert_eq!(CASES[0].play(), played[0].1, "the same episode played twice differs");
    if std::env::var_os("AVACRAFT_BLESS").is_some() {
        std::fs::write(file(), render(&played)).expect("write the golden file");
        return;
    }
    let text = std::fs::read_to_string(file()).unwrap_or_default();
    let diffs = differences(&played, &read_pinned(&text));
    assert!(
        diffs.is_empty(),
        "{} of {} golden trajectories changed ({}):\n  {}\nIf the change is intended, re-bless: AVACRAFT_BLESS=1 cargo test -p avacraft-tests --test it golden::",
        diffs.len(),
        played.len(),
        file().display(),
        diffs.join("\n  ")
    );
}

/// The check above must fail on a changed hash and show both, or it proves nothing.
#[test]
fn a_changed_hash_is_reported_with_old_and_new() {
    let p = Pinned { result: "win".into(), steps: 3, game_loops: 24, trajectory_hash: "00000000000000aa".into() };
    let key = "x seed 1 p vs default".to_owned();
    let pinned = read_pinned(&render(&[(key.clone(), p.clone())]));
    assert_eq!(pinned, vec![(key.clone(), p.clone())], "the file format round-trips");
    assert!(differences(&[(key.clone(), p.clone())], &pinned).is_empty());
    let changed = Pinned { trajectory_hash: "00000000000000ab".into(), ..p };
    let d = differences(&[(key.clone(), changed)], &pinned);
    assert_eq!(d.len(), 1);
    assert!(d[0].contains("00000000000000aa") && d[0].contains("00000000000000ab"), "{}", d[0]);
    assert!(differences(&[("other".into(), pinned[0].1.clone())], &pinned)[0].contains("not pinned"));
}
