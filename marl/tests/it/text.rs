//! The vision-text text features: real 3m_vlm and 2s3z_vlm descriptions cut into clauses and slots,
//! MiniLM's embeddings one at a time, in parallel and padded, features that do not depend
//! on the cache, the thread count or the on-disk file.

use avacraft_engine::{Scenario, Team, VecEnv, describe};
use avacraft_marl::Config;
use avacraft_marl::encoders::clause_cache::TextEmbedder;
use avacraft_marl::encoders::clause_store;
use avacraft_marl::encoders::clauses::{HEADER, SlotLayout, clauses, item_pieces, round_points, sentences};
use avacraft_marl::encoders::text::{MiniLm, PIP_INSTALL, TEXT_DIM};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::{Arc, OnceLock};

type R = Result<(), Box<dyn std::error::Error>>;
/// Descriptions per step, per environment.
type Steps = Vec<Vec<String>>;

/// The model, loaded once; a missing model fails (does not skip) with the pip command.
fn model() -> Result<Arc<MiniLm>, String> {
    static MODEL: OnceLock<Result<Arc<MiniLm>, String>> = OnceLock::new();
    MODEL.get_or_init(|| MiniLm::load().map(Arc::new).map_err(|e| format!("{e} (the test needs it: `{PIP_INSTALL}`)"))).clone()
}

/// Team 1's descriptions of `envs` environments of `scenario` over `steps` steps of random
/// available actions (step-major), and the team's slot layout.
fn play(scenario: &str, envs: u64, steps: usize, seed: u64) -> Result<(Steps, SlotLayout), Box<dyn std::error::Error>> {
    let scenario = Arc::new(Scenario::load(scenario)?);
    let cfg = Config::for_algo("mappo", &[])?;
    let seeds: Vec<u64> = (0..envs).map(|i| seed + i).collect();
    let mut v = VecEnv::new(scenario, cfg.env_config()?, &seeds, 1)?;
    let layout = SlotLayout::of(&v.envs()[0], Team::One);
    let n_actions = v.shape().3.max(1);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    for _ in 0..steps {
        out.push(v.envs().iter().map(|e| describe(e, Team::One)).collect());
        let actions: Vec<i64> = v
            .buffers
            .avail
            .chunks(n_actions)
            .map(|m| {
                let a: Vec<usize> = m.iter().enumerate().filter(|(_, x)| **x == 1).map(|(i, _)| i).collect();
                a.get(rng.random_range(0..a.len().max(1))).map_or(0, |&i| i as i64)
            })
            .collect();
        v.step(&actions)?;
    }
    Ok((out, layout))
}

/// What may lie between the pieces of a line: separators only.
fn only_separators(gap: &str) -> bool {
    let mut g = gap.to_owned();
    for sep in ["abilities: ", "- ", "; ", ", ", ": ", ".", " "] {
        g = g.replace(sep, "");
    }
    g.is_empty()
}

/// The tag a unit line's identity clause names.
fn tag_of(identity: &str) -> Option<u32> {
    let rest = &identity[identity.find("(tag ")? + 5..];
    rest[..rest.find(|c: char| !c.is_ascii_digit())?].parse().ok()
}

#[test]
fn real_3m_and_2s3z_descriptions_cut_into_clauses_and_slots() -> R {
    for (name, agents, enemies) in [("3m_vlm", 3, 3), ("2s3z_vlm", 5, 5)] {
        let (steps, layout) = play(name, 4, 120, 11)?;
        let (own_tags, enemy_tags) = roster(name)?;
        assert_eq!(layout.slots(), 1 + agents + enemies + 1, "{name}");
        let (mut enemy_lines, mut own_lines) = (0, 0);
        for text in steps.iter().flatten() {
            // Every line is tiled by its pieces: nothing but separators is left out.
            for line in text.lines() {
                let ranges: Vec<_> =
                    if line.starts_with("- ") { item_pieces(line).1.into_iter().map(|p| p.range).collect() } else { sentences(line) };
                let mut at = 0;
                for r in &ranges {
                    assert!(r.start >= at && !r.is_empty(), "{line}: {ranges:?}");
                    assert!(only_separators(&line[at..r.start]), "{line}: lost {:?}", &line[at..r.start]);
                    at = r.end;
                }
                assert!(only_separators(&line[at..]), "{line}: lost the end {:?}", &line[at..]);
            }
            let cs = clauses(text, &layout);
            // Unit lines go to their unit's slot: agents in agent order, enemies by tag.
            let mut slots_seen = Vec::new();
            for c in &cs {
                assert!(c.slot < layout.extra(), "{name}: nothing is left for the extra slot here: {c:?}");
                assert_eq!(round_points(&c.text), c.text, "points are whole");
                if c.slot != HEADER && !slots_seen.contains(&c.slot) {
                    // A slot's first clause is its unit's identity.
                    slots_seen.push(c.slot);
                    let tag = tag_of(&c.text).ok_or_else(|| format!("no tag in {c:?}"))?;
                    if c.slot <= agents {
                        own_lines += 1;
                        assert_eq!(tag, own_tags[c.slot - 1], "{c:?}");
                    } else {
                        enemy_lines += 1;
                        assert_eq!(tag, enemy_tags[c.slot - 1 - agents], "{c:?}");
                    }
                }
            }
            assert!(cs.iter().any(|c| c.slot == HEADER && c.text.starts_with("Game time")));
            let units = text.lines().filter(|l| l.starts_with("- ")).count();
            assert_eq!(slots_seen.len(), units, "one slot per unit line:\n{text}");
        }
        assert!(own_lines > 0 && enemy_lines > 0, "{name}: enemies came into sight");
    }
    Ok(())
}

#[test]
fn the_first_3m_and_2s3z_descriptions_give_these_slots_and_clauses() -> R {
    let (steps, layout) = play("3m_vlm", 1, 1, 1)?;
    let got: Vec<(usize, String)> = clauses(&steps[0][0], &layout).into_iter().map(|c| (c.slot, c.text.into_owned())).collect();
    let marine = |slot: usize, n: u32, cell: &str| {
        let id = format!("Marine_{n} (tag {n}, Marine)");
        [&*id, "HP 45/45", "weapon ready", cell, "idle", "abilities: stimpack unavailable (needs upgrade)"].map(|t| (slot, t.to_owned()))
    };
    let mut want: Vec<(usize, String)> = [
        (0, "Scenario 3m_vlm (PvE), you are team 1."),
        (0, "Game time 0.0 s of 300 s (loop 0 of 6720)."),
        (0, "Objective: Destroy every enemy unit within 300 seconds of game time."),
        (0, "The map is divided into a 10x10 grid; (1, 1) is the top-left cell and (10, 10) the bottom-right."),
        (0, "Your units (3 alive, 0 lost):"),
    ]
    .map(|(k, t)| (k, t.to_owned()))
    .to_vec();
    // SMAC's agent order (type, then x, then y) puts Marine_2 first.
    want.extend(marine(2, 1, "at grid (3, 5)"));
    want.extend(marine(1, 2, "at grid (3, 5)"));
    want.extend(marine(3, 3, "at grid (3, 6)"));
    want.push((0, "No enemy units in sight (0 destroyed so far); the rest are hidden by fog of war.".to_owned()));
    assert_eq!(got, want);

    let (steps, layout) = play("2s3z_vlm", 1, 1, 1)?;
    let cs = clauses(&steps[0][0], &layout);
    let zealot: Vec<&str> = cs.iter().filter(|c| c.slot == 5).map(|c| &*c.text).collect();
    assert_eq!(zealot, ["Zealot_1 (tag 2, Zealot)", "HP 100/100", "shields 50/50", "weapon ready", "at grid (4, 6)", "idle"]);
    let stalker: Vec<&str> = cs.iter().filter(|c| c.slot == 1).map(|c| &*c.text).collect();
    assert_eq!(
        stalker,
        [
            "Stalker_1 (tag 1, Stalker)",
            "HP 80/80",
            "shields 80/80",
            "weapon ready",
            "at grid (3, 6)",
            "idle",
            "abilities: blink unavailable (needs upgrade)"
        ]
    );
    // Agents fill slots 1-5; no enemy is in sight yet (slots 6-10), nothing is extra (11).
    let mut used: Vec<usize> = cs.iter().map(|c| c.slot).collect();
    used.dedup();
    used.sort_unstable();
    used.dedup();
    assert_eq!(used, [0, 1, 2, 3, 4, 5]);
    assert_eq!(layout.slots(), 12);
    Ok(())
}

/// The agents' tags in agent order and the enemies' in ascending order.
fn roster(scenario: &str) -> Result<(Vec<u32>, Vec<u32>), Box<dyn std::error::Error>> {
    let s = Scenario::load(scenario)?;
    let own = s.agent_order(Team::One).iter().map(|id| id.tag()).collect();
    let mut enemies: Vec<u32> = s.team_units(Team::Two).map(|(i, _)| i as u32 + 1).collect();
    enemies.sort_unstable();
    Ok((own, enemies))
}

/// Distinct clauses of `steps`, in first-seen order.
fn distinct(steps: &[Vec<String>], layout: &SlotLayout) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for text in steps.iter().flatten() {
        for c in clauses(text, layout) {
            if !out.iter().any(|t| *t == c.text) {
                out.push(c.text.into_owned());
            }
        }
    }
    out
}

#[test]
fn parallel_and_padded_embeddings_equal_one_at_a_time() -> R {
    let model = model()?;
    let (steps, layout) = play("2s3z_vlm", 2, 30, 5)?;
    let mut texts = distinct(&steps, &layout);
    texts.truncate(40);
    texts.push("Objective: a much longer clause, so that the batch pads the short ones by many tokens.".into());
    let refs: Vec<&str> = texts.iter().map(String::as_str).collect();
    let one: Vec<_> = refs.iter().map(|t| model.embedding(t)).collect::<Result<_, _>>()?;
    // In parallel: the same bits (each text is its own forward).
    assert!(model.embed_many(&refs)? == one);
    // Padded into one batch: equal up to float rounding.
    let batched = model.embed_batch(&refs)?;
    for ((b, o), t) in batched.iter().zip(&one).zip(&refs) {
        assert_eq!(b.tokens, o.tokens, "{t}");
        let worst = b.vec.iter().zip(&o.vec).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
        assert!(worst < 1e-5, "{t}: {worst}");
        let norm: f32 = o.vec.iter().map(|x| x * x).sum();
        assert!((norm - 1.0).abs() < 1e-5 && o.vec.len() == TEXT_DIM);
    }
    // Similar clauses embed closer than unrelated ones.
    let e = |t: &str| model.embedding(t).map(|e| e.vec);
    let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f32>();
    let (hp1, hp2, grid) = (e("HP 45/45")?, e("HP 44/45")?, e("attacking enemy Marine_2 (tag 5)")?);
    assert!(dot(&hp1, &hp2) > dot(&hp1, &grid) + 0.1);
    Ok(())
}

/// Features of every step of `steps` with `emb`, step by step.
fn features(emb: &mut TextEmbedder, steps: &[Vec<String>], layout: &SlotLayout) -> Result<Vec<f32>, avacraft_marl::Error> {
    let mut out = Vec::new();
    for texts in steps {
        let docs: Vec<_> = texts.iter().map(|t| clauses(t, layout)).collect();
        emb.features(&docs, layout.slots(), &mut out)?;
    }
    Ok(out)
}

#[test]
fn features_do_not_depend_on_the_cache_or_the_thread_count() -> R {
    let model = model()?;
    let (steps, layout) = play("3m_vlm", 3, 40, 21)?;
    let width = layout.slots() * TEXT_DIM;
    let mut big = TextEmbedder::new(Arc::clone(&model), 100_000, None);
    let all = features(&mut big, &steps, &layout)?;
    assert_eq!(all.len(), steps.len() * 3 * width);
    let s = big.stats();
    assert_eq!(s.computed as usize, distinct(&steps, &layout).len(), "each distinct clause embedded once");
    assert!(s.hits > s.lookups / 2, "{s:?}");
    // Slots are unit vectors or zeros (a dead or unseen unit).
    for slot in all.chunks(TEXT_DIM) {
        let n: f32 = slot.iter().map(|x| x * x).sum();
        assert!(n == 0.0 || (n - 1.0).abs() < 1e-4, "{n}");
    }
    // A cache too small for one step: almost every clause is embedded again; same bits.
    let mut small = TextEmbedder::new(Arc::clone(&model), 16, None);
    let some = features(&mut small, &steps[..12], &layout)?;
    assert!(small.stats().computed > big.stats().computed.min(200) / 2);
    assert!(some == all[..some.len()], "features changed with the cache");
    // One thread or two: same bits.
    let run = |threads: usize| -> Result<Vec<f32>, Box<dyn std::error::Error + Send + Sync>> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let mut e = TextEmbedder::new(Arc::clone(&model), 100_000, None);
        Ok(pool.install(|| features(&mut e, &steps[..12], &layout))?)
    };
    let (one, two) = (run(1).map_err(|e| e.to_string())?, run(2).map_err(|e| e.to_string())?);
    assert!(one == two && one == all[..one.len()], "features changed with the thread count");
    Ok(())
}

#[test]
fn the_file_is_used_only_when_it_checks_out() -> R {
    let model = model()?;
    let (steps, layout) = play("3m_vlm", 2, 15, 31)?;
    let dir = std::env::temp_dir().join(format!("avacraft-text-file-{}", std::process::id()));
    let path = clause_store::file_in(&dir, model.hash());
    let _ = std::fs::remove_file(&path);
    let mut first = TextEmbedder::new(Arc::clone(&model), 100_000, Some(path.clone()));
    let want = features(&mut first, &steps, &layout)?;
    let n = first.cache().len() as u64;
    drop(first); // writes the file
    // A second run reads every clause from the file and embeds none.
    let mut second = TextEmbedder::new(Arc::clone(&model), 100_000, Some(path.clone()));
    assert_eq!(second.stats().loaded, n);
    assert!(features(&mut second, &steps, &layout)? == want);
    assert_eq!(second.stats().computed, 0);
    drop(second);
    // Damaged, or another model's: ignored (a warning), and the features are the same.
    let good = std::fs::read(&path)?;
    let mut bad = good.clone();
    let mid = bad.len() / 2;
    bad[mid] ^= 1;
    std::fs::write(&path, &bad)?;
    let mut damaged = TextEmbedder::new(Arc::clone(&model), 100_000, Some(path.clone()));
    assert_eq!(damaged.stats().loaded, 0);
    assert!(features(&mut damaged, &steps[..3], &layout)? == want[..3 * 2 * layout.slots() * TEXT_DIM]);
    drop(damaged); // replaces the damaged file with a good one
    assert!(TextEmbedder::new(Arc::clone(&model), 100_000, Some(path.clone())).stats().loaded > 0);
    let other = [("HP 45/45", 5u32, vec![0.0f32; TEXT_DIM])];
    clause_store::save(&path, model.hash() ^ 1, TEXT_DIM, other.iter().map(|(t, k, v)| (*t, *k, v.as_slice())))?;
    let foreign = TextEmbedder::new(Arc::clone(&model), 100_000, Some(path.clone()));
    assert_eq!(foreign.stats().loaded, 0);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
