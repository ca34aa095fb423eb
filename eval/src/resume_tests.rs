//! `write_meta`: which plans may resume a folder. The same plan, or the same plan grown by
//! cells; never one whose results would differ from those recorded.

use crate::{AgentKind, CellKey, EvalError, Meta, Shard, read_meta, write_meta};

fn cell(scenario: &str, agent: &str) -> CellKey {
    CellKey { scenario: scenario.into(), agent: agent.into(), against: "opponent:default".into() }
}

fn plan(agents: &[(&str, &str)], fingerprints: &[(&str, &str, &str)]) -> Meta {
    Meta {
        name: "paper".into(),
        agents: agents.iter().map(|(n, p)| ((*n).to_owned(), AgentKind::Marl, (*p).to_owned())).collect(),
        seeds: (1001..=1100).collect(),
        curves: Vec::new(),
        cells: agents.iter().flat_map(|(n, _)| [cell("3m_vlm", n), cell("2s3z_vlm", n)]).collect(),
        shard: None,
        unshipped: Vec::new(),
        off_rules: Vec::new(),
        document: None,
        protocol: String::new(),
        fingerprints: fingerprints.iter().map(|(a, s, f)| ((*a).to_owned(), (*s).to_owned(), (*f).to_owned())).collect(),
        seed_of: Vec::new(),
        games: Vec::new(),
        names: crate::meta::NAMES,
        env: crate::plan::eval_env(),
    }
}

#[test]
fn a_folder_played_before_smacs_names_is_refused_naming_the_new_name() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path();
    // Written before SMAC's maps took SMAC's names: its `3m` was the paper's scenario.
    let mut old = plan(&[("qmix", "baseline:qmix")], &[]);
    old.cells = vec![cell("3m", "qmix")];
    old.games = Vec::new();
    let mut json = serde_json::to_value(&old).expect("json");
    json.as_object_mut().map(|o| o.remove("names"));
    std::fs::write(dir.join("plan.json"), json.to_string()).expect("write");
    let read = read_meta(dir).expect("an old plan.json reads");
    assert_eq!(read.names, 1);
    // The same plan now means SMAC's 3m: refused, naming 3m_vlm.
    let mut now = old.clone();
    now.names = crate::meta::NAMES;
    let why = refused(dir, &now);
    assert!(why.contains("3m_vlm") && why.contains("SMAC"), "{why}");
    // A folder of the new names resumes as before.
    let fresh = tempfile::tempdir().expect("temp dir");
    write_meta(fresh.path(), &now).expect("new folder");
    write_meta(fresh.path(), &now).expect("resumed");
}

fn refused(dir: &std::path::Path, m: &Meta) -> String {
    match write_meta(dir, m) {
        Err(e @ EvalError::Folder { .. }) => e.to_string(),
        other => panic!("expected the folder to be refused, got {other:?}"),
    }
}

#[test]
fn a_folder_resumes_with_its_plan_grown_but_not_with_other_results() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path();
    let fp = [("qmix", "3m_vlm", "xxh3:1"), ("qmix", "2s3z_vlm", "xxh3:2")];
    let base = plan(&[("qmix", "baseline:qmix")], &fp);
    write_meta(dir, &base).expect("a new folder");
    write_meta(dir, &base).expect("the same plan again");

    // An agent added: its cells are new, the old ones stay; plan.json is the grown plan.
    let grown = plan(&[("qmix", "baseline:qmix"), ("ava", "ava")], &[fp[0], fp[1], ("ava", "3m_vlm", "xxh3:9")]);
    write_meta(dir, &grown).expect("the plan grown by an agent");
    assert_eq!(read_meta(dir).expect("written").cells.len(), 4);

    // Cells recorded there that the plan no longer has.
    let fewer = refused(dir, &base);
    assert!(fewer.contains("cell `3m_vlm / ava vs opponent:default` is not in this plan"), "{fewer}");
    assert!(fewer.contains("pick another --out (nothing is overwritten)"), "{fewer}");

    // Another policy under the same agent name.
    let other = refused(dir, &plan(&[("qmix", "marl:runs/q"), ("ava", "ava")], &[]));
    assert!(other.contains("agent `qmix` played `baseline:qmix` (marl) there and is `marl:runs/q` (marl) here"), "{other}");

    // The same name and policy, but a network trained or shipped again.
    let again = refused(dir, &plan(&[("qmix", "baseline:qmix"), ("ava", "ava")], &[("qmix", "2s3z_vlm", "xxh3:3")]));
    assert!(again.contains("agent `qmix` on 2s3z_vlm") && again.contains("xxh3:2") && again.contains("xxh3:3"), "{again}");

    // Other seeds, another shard.
    let mut seeds = grown.clone();
    seeds.seeds = vec![1, 2, 3];
    let s = refused(dir, &seeds);
    assert!(s.contains("seeds 100 seeds, 1001 to 1100, this plan's are 1, 2, 3"), "{s}");
    let mut shard = grown.clone();
    shard.shard = Some(Shard { index: 1, count: 2 });
    let s = refused(dir, &shard);
    assert!(s.contains("the whole plan's, not shard 1/2's"), "{s}");

    // Nothing refused was written.
    assert_eq!(read_meta(dir).expect("still there"), grown);
}

#[test]
fn a_folder_from_before_fingerprints_still_resumes() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let m = plan(&[("qmix", "baseline:qmix")], &[]);
    let mut json: serde_json::Value = serde_json::to_value(&m).expect("json");
    json.as_object_mut().expect("an object").remove("fingerprints");
    std::fs::write(tmp.path().join(crate::META_FILE), json.to_string()).expect("write");
    write_meta(tmp.path(), &plan(&[("qmix", "baseline:qmix")], &[("qmix", "3m_vlm", "xxh3:1")])).expect("no fingerprints to compare");
    assert_eq!(read_meta(tmp.path()).expect("written").fingerprints.len(), 1);
}

mod properties {
    use super::*;
    use crate::cannot_extend;
    use proptest::prelude::*;

    fn meta_of(cells: &[(u8, u8)], seeds: &[u64]) -> Meta {
        let mut m = plan(&[], &[]);
        m.cells = cells.iter().map(|(s, a)| cell(&format!("s{s}"), &format!("a{a}"))).collect();
        m.seeds = seeds.to_vec();
        m
    }

    proptest! {
        /// Any plan.json text is read or refused with an error, never a panic.
        #[test]
        fn any_plan_json_is_read_or_refused(text in ".{0,400}") {
            let tmp = tempfile::tempdir().expect("temp dir");
            std::fs::write(tmp.path().join(crate::META_FILE), &text).expect("write");
            let _ = read_meta(tmp.path());
        }

        /// A plan grown by cells takes its folder over; one that lost a cell, or plays other
        /// seeds, does not.
        #[test]
        fn growth_resumes_and_loss_does_not(
            cells in proptest::collection::btree_set((0u8..6, 0u8..6), 1..12),
            extra in proptest::collection::btree_set((0u8..6, 0u8..6), 0..6),
            seeds in proptest::collection::vec(0u64..1000, 1..5),
            drop in 0usize..12,
        ) {
            let old: Vec<(u8, u8)> = cells.iter().copied().collect();
            let grown: Vec<(u8, u8)> = cells.union(&extra).copied().collect();
            let base = meta_of(&old, &seeds);
            prop_assert_eq!(cannot_extend(&base, &meta_of(&grown, &seeds)), None);
            let mut lost = old.clone();
            let gone = lost.remove(drop % lost.len());
            let why = cannot_extend(&base, &meta_of(&lost, &seeds));
            prop_assert!(why.as_deref().is_some_and(|w| w.contains(&format!("s{} / a{}", gone.0, gone.1))), "{:?}", why);
            let mut other = seeds.clone();
            other.push(1000);
            prop_assert!(cannot_extend(&base, &meta_of(&grown, &other)).is_some());
        }
    }
}

/// A cell played on one unit data set is not mixed with the same cell on another: a folder
/// written before data sets existed played `legacy`.
#[test]
fn a_folder_of_another_game_is_not_resumed() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path();
    let old = plan(&[("qmix", "baseline:qmix")], &[]);
    write_meta(dir, &old).expect("a folder of before data sets");
    let same = Meta { games: old.cells.iter().map(|c| (c.clone(), "legacy".to_owned())).collect(), ..old.clone() };
    write_meta(dir, &same).expect("the same cells on legacy");
    let liberty = Meta { games: old.cells.iter().map(|c| (c.clone(), "liberty".to_owned())).collect(), ..old };
    let why = refused(dir, &liberty);
    assert!(why.contains("was played on the legacy unit data and is liberty here"), "{why}");
}

#[test]
fn a_folder_played_with_other_environment_options_is_refused_and_old_folders_read_the_defaults() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let dir = tmp.path();
    let old = plan(&[("qmix", "baseline:qmix")], &[]);
    // Written before plans could set environment options: no `env` field.
    let mut json = serde_json::to_value(&old).expect("json");
    json.as_object_mut().map(|o| o.remove("env"));
    std::fs::write(dir.join("plan.json"), json.to_string()).expect("write");
    assert_eq!(read_meta(dir).expect("an old plan.json reads").env, crate::plan::eval_env());
    write_meta(dir, &old).expect("the same plan resumes");
    let mut fast = old.clone();
    fast.env.step_mul = 4;
    let why = refused(dir, &fast);
    assert!(why.contains("environment options") && why.contains("\"step_mul\":4"), "{why}");
}
