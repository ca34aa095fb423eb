//! `check_shards`: what a merge accepts and how it names what it refuses.

use crate::{CellKey, EvalError, Meta, Shard, check_shards};
use std::path::PathBuf;

fn meta(name: &str, shard: Option<(usize, usize)>) -> Meta {
    Meta {
        name: name.to_owned(),
        agents: Vec::new(),
        seeds: vec![1, 2],
        curves: Vec::new(),
        cells: vec![CellKey { scenario: "3m_vlm".into(), agent: "a".into(), against: "opponent:default".into() }],
        shard: shard.map(|(index, count)| Shard { index, count }),
        unshipped: Vec::new(),
        off_rules: Vec::new(),
        document: None,
        protocol: String::new(),
        fingerprints: Vec::new(),
        names: crate::meta::NAMES,
        seed_of: Vec::new(),
        games: Vec::new(),
        env: crate::plan::eval_env(),
    }
}

fn refused(parts: &[(&str, Meta)]) -> String {
    let parts: Vec<(PathBuf, Meta)> = parts.iter().map(|(d, m)| (PathBuf::from(d), m.clone())).collect();
    match check_shards(&parts) {
        Err(e @ EvalError::Shards { .. }) => e.to_string(),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn a_merge_takes_each_shard_of_one_plan_once() {
    let parts = vec![(PathBuf::from("s1"), meta("p", Some((1, 3)))), (PathBuf::from("s3"), meta("p", Some((3, 3))))];
    let (m, missing) = check_shards(&parts).expect("two shards of one plan");
    assert_eq!(m.shard, None);
    assert_eq!(missing, vec![Shard { index: 2, count: 3 }]);

    let twice = refused(&[("s1", meta("p", Some((1, 2)))), ("s1", meta("p", Some((1, 2))))]);
    assert!(twice.contains("s1") && twice.contains("shard 1/2") && twice.contains("named twice"), "{twice}");
    let copy = refused(&[("a", meta("p", Some((2, 2)))), ("b", meta("p", Some((2, 2))))]);
    assert!(copy.contains("b holds shard 2/2, as a does"), "{copy}");
    let other = refused(&[("a", meta("p", Some((1, 2)))), ("b", meta("q", Some((2, 2))))]);
    assert!(other.contains("b holds the results of another plan (`q`)"), "{other}");
    let split = refused(&[("a", meta("p", Some((1, 2)))), ("b", meta("p", Some((2, 3))))]);
    assert!(split.contains("shard 2/3") && split.contains("shard 1/2"), "{split}");
    let whole = refused(&[("a", meta("p", None)), ("b", meta("p", Some((2, 2))))]);
    assert!(whole.contains("a holds the whole plan"), "{whole}");
}

#[test]
fn a_merge_refuses_shards_that_played_other_networks() {
    let with = |fp: &str| Meta { fingerprints: vec![("q".into(), "3m_vlm".into(), fp.into())], ..meta("p", Some((1, 2))) };
    let mut second = with("xxh3:2");
    second.shard = Some(Shard { index: 2, count: 2 });
    let e = refused(&[("a", with("xxh3:1")), ("b", second.clone())]);
    assert!(e.contains("b holds results of other networks or AVA settings than a"), "{e}");
    second.fingerprints = with("xxh3:1").fingerprints;
    check_shards(&[(PathBuf::from("a"), with("xxh3:1")), (PathBuf::from("b"), second)]).expect("the same networks");
}
