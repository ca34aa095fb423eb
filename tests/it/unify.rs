//! The Python extension and the `avacraft` program are built by separate commands on a
//! newcomer's machine (`pip install ./python`, then the README's main job), and Cargo enables
//! a dependency's features from what each command builds. Where the two see a shared crate
//! with different features, the second build compiles it again, and everything above it
//! (unify/Cargo.toml has the numbers). This checks that they agree, so the second build
//! reuses the first, and that CI's wheel check (the extension alone, after the tests, in the
//! test build's target folder) finds its dependencies compiled by the test build.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// The standard output of `cargo ARGS --locked --offline` in the workspace, which must succeed.
fn cargo(args: &[&str], env: &[(&str, &str)]) -> Vec<u8> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .envs(env.iter().copied())
        .args(args)
        .args(["--locked", "--offline"])
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cargo}: {e}"));
    assert!(out.status.success(), "cargo {args:?} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    out.stdout
}

/// Every crate (name and version) in a package's build graph, compile-time side included,
/// with the features Cargo enables for it when that package alone is built.
fn features_of(package: &str) -> BTreeMap<String, BTreeSet<String>> {
    let out = cargo(&["tree", "-p", package, "-e", "normal,build", "--prefix", "none", "--no-dedupe", "-f", "{p}|{f}"], &[]);
    let mut crates: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&out).lines() {
        let Some((id, features)) = line.split_once('|') else { continue };
        // "name v1.2.3 (path)" or "name v1.2.3 (*)": name and version identify the crate.
        let id: Vec<&str> = id.split_whitespace().take(2).collect();
        let entry = crates.entry(id.join(" ")).or_default();
        entry.extend(features.split(',').filter(|f| !f.is_empty()).map(str::to_owned));
    }
    assert!(crates.len() > 100, "only {} crates read from cargo tree -p {package}: has its output changed?", crates.len());
    crates
}

#[test]
fn the_python_extension_and_the_program_share_their_dependencies_builds() {
    let python = features_of("avacraft-python");
    let program = features_of("avacraft-cli");
    let mut differ = Vec::new();
    let mut shared = 0;
    for (id, py) in &python {
        let Some(cli) = program.get(id) else { continue };
        shared += 1;
        if py != cli {
            let only_cli: Vec<&String> = cli.difference(py).collect();
            let only_py: Vec<&String> = py.difference(cli).collect();
            differ.push(format!("{id}: only the program's build enables {only_cli:?}, only the extension's {only_py:?}"));
        }
    }
    assert!(shared > 100, "only {shared} crates shared: the comparison is not reading what it should");
    assert!(
        differ.is_empty(),
        "the extension and the program enable different features of {} shared crates, so building one recompiles \
         them for the other; add the union to unify/Cargo.toml:\n{}",
        differ.len(),
        differ.join("\n")
    );
}

/// One build unit's identity as far as its compiled artefact goes: crate, target, mode,
/// features and optimisation level.
type UnitKey = (String, String, String, Vec<String>, String);

/// The build units `args` asks Cargo for, from its unit graph (`--unit-graph`, unstable:
/// `RUSTC_BOOTSTRAP=1` lets this one Cargo process use it; nothing is compiled).
fn units(args: &[&str]) -> BTreeSet<UnitKey> {
    let args = [args, &["--unit-graph", "-Z", "unstable-options"]].concat();
    let out = cargo(&args, &[("RUSTC_BOOTSTRAP", "1")]);
    let graph: serde_json::Value = serde_json::from_slice(&out).expect("the unit graph is JSON");
    let list = graph["units"].as_array().expect("a `units` list");
    let text = |v: &serde_json::Value| v.as_str().map(str::to_owned).unwrap_or_else(|| v.to_string());
    list.iter()
        .map(|u| {
            let mut features: Vec<String> = u["features"].as_array().into_iter().flatten().map(text).collect();
            features.sort();
            (text(&u["pkg_id"]), text(&u["target"]["name"]), text(&u["mode"]), features, text(&u["profile"]["opt_level"]))
        })
        .collect()
}

/// Crates whose own build for the extension alone may differ from the test build's, and why:
/// what differs compiles again, with the crates above it (here the llama.cpp bindings, not
/// llama.cpp, and AVA).
const MAY_DIFFER: &[(&str, &str)] = &[("enumflags2", "a deployment crate enables its `serde` feature in the test build")];

/// CI checks the README's `pip install ./python` after the tests, with the test build's
/// profile, target folder and the features `.ci/run` names, so that Cargo finds the
/// extension's dependencies compiled. That holds while the extension alone enables the
/// features the whole workspace's test build does: this names every crate that drifts.
#[test]
fn the_ci_wheel_check_finds_its_dependencies_in_the_test_build() {
    let ci_run = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.ci/run")).expect(".ci/run");
    let features = ci_run
        .split("MATURIN_PEP517_ARGS=\"--profile dev --features ")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .expect(".ci/run sets MATURIN_PEP517_ARGS=\"--profile dev --features ...\" for its wheel check");
    let wheel = units(&["build", "-p", "avacraft-python", "--lib", "--features", features]);
    let tests = units(&["test", "--workspace", "--no-run"]);
    assert!(wheel.len() > 200, "only {} units in the extension's build: is the unit graph read right?", wheel.len());
    let crate_of = |pkg_id: &str| {
        // "registry+...#name@1.2.3", "path+file:///.../python#avacraft-python@0.1.0" or "...#0.1.0".
        let tail = pkg_id.rsplit('#').next().unwrap_or(pkg_id);
        tail.split('@').next().unwrap_or(tail).to_owned()
    };
    let drift: Vec<String> = wheel
        .difference(&tests)
        .map(|u| format!("{} ({}, {}, features {:?}, opt-level {})", crate_of(&u.0), u.1, u.2, u.3, u.4))
        .filter(|d| !MAY_DIFFER.iter().any(|(name, _)| d.starts_with(name)))
        .collect();
    assert!(
        drift.is_empty(),
        "the wheel check would compile these crates again, which the test build has with other features \
         (add the test build's features to unify/Cargo.toml):\n{}",
        drift.join("\n")
    );
}
