//! The Python extension and the `avacraft` program are built by separate commands on a
//! newcomer's machine (`pip install ./python`, then the README's main job), and Cargo enables
//! a dependency's features from what each command builds. Where the two see a shared crate
//! with different features, the second build compiles it again, and everything above it
//! (unify/Cargo.toml has the numbers). This checks that they agree, so the second build
//! reuses the first.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// Every crate (name and version) in a package's build graph, compile-time side included,
/// with the features Cargo enables for it when that package alone is built.
fn features_of(package: &str) -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new(&cargo)
        .current_dir(&root)
        .args(["tree", "--locked", "--offline", "-p", package, "-e", "normal,build", "--prefix", "none", "--no-dedupe"])
        .args(["-f", "{p}|{f}"])
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cargo}: {e}"));
    assert!(out.status.success(), "cargo tree -p {package} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    let mut crates: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
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
