//! The shipped baselines by name: `baseline:qmix` on 3m_vlm is the policy under
//! `baselines/3m_vlm/qmix/`, written by `avacraft train --plan ... --ship baselines`.
//!
//! `baseline:qmix@last` is the same run's last checkpoint (`baselines/3m_vlm/qmix/last/`),
//! shipped beside the best-of-N one a plain name plays, so a table can show both.
//!
//! The folder is `$AVACRAFT_BASELINES` when set (an installed binary or wheel pointed at a
//! checkout or a copy), else the repository's own `baselines/` this crate was built from.

use std::path::{Path, PathBuf};

/// The environment variable naming the baselines folder.
pub const BASELINES_ENV: &str = "AVACRAFT_BASELINES";
/// The policy-name prefix of a shipped baseline: `baseline:qmix`.
pub const BASELINE_PREFIX: &str = "baseline:";

/// The suffix naming a shipped run's last checkpoint instead of its best one.
pub const LAST_SUFFIX: &str = "@last";
/// The folder, inside a shipped run, that holds its last checkpoint.
pub const LAST_DIR: &str = "last";

/// Why a shipped baseline cannot be found.
#[derive(Debug, thiserror::Error)]
pub enum BaselineError {
    #[error("`{BASELINE_PREFIX}` needs a run name, e.g. {BASELINE_PREFIX}qmix or {BASELINE_PREFIX}mappo")]
    NoName,
    #[error("baseline name `{name}`: only letters, digits, `-` and `_` (e.g. qmix, mappo-rgb), optionally followed by `{LAST_SUFFIX}`")]
    BadName { name: String },
    #[error("no shipped `{name}` baseline for scenario `{scenario}`: {} is missing (shipped there: {shipped}; the folder is ${BASELINES_ENV} or the repository's baselines/)", dir.display())]
    Missing { name: String, scenario: String, dir: PathBuf, shipped: String },
}

/// The baselines folder: `$AVACRAFT_BASELINES`, else the repository's `baselines/`.
pub fn root() -> PathBuf {
    match std::env::var_os(BASELINES_ENV) {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("baselines"),
    }
}

/// Checks a baseline's run name (the part after `baseline:`): a run, or a run's last
/// checkpoint (`qmix@last`).
pub fn check_name(name: &str) -> Result<(), BaselineError> {
    let (run, _) = split_last(name);
    if run.is_empty() {
        return Err(BaselineError::NoName);
    }
    if !run.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(BaselineError::BadName { name: name.to_owned() });
    }
    Ok(())
}

/// A baseline name's run and whether it names the run's last checkpoint.
pub fn split_last(name: &str) -> (&str, bool) {
    match name.strip_suffix(LAST_SUFFIX) {
        Some(run) => (run, true),
        None => (name, false),
    }
}

/// The shipped runs of `scenario` under `root`, sorted (names of folders holding a config),
/// each followed by its `@last` name where its last checkpoint was shipped too.
pub fn shipped(root: &Path, scenario: &str) -> Vec<String> {
    let mut runs: Vec<(String, bool)> = std::fs::read_dir(root.join(scenario))
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().join("config.json").is_file())
        .filter_map(|e| {
            let last = e.path().join(LAST_DIR).join("config.json").is_file();
            e.file_name().to_str().map(|n| (n.to_owned(), last))
        })
        .collect();
    runs.sort();
    runs.into_iter().flat_map(|(n, last)| std::iter::once(n.clone()).chain(last.then(|| format!("{n}{LAST_SUFFIX}")))).collect()
}

/// The folder of the shipped `name` baseline of `scenario` under `root`.
pub fn dir(root: &Path, scenario: &str, name: &str) -> Result<PathBuf, BaselineError> {
    check_name(name)?;
    let (run, last) = split_last(name);
    let d = if last { root.join(scenario).join(run).join(LAST_DIR) } else { root.join(scenario).join(run) };
    if d.join("config.json").is_file() {
        return Ok(d);
    }
    let shipped = shipped(root, scenario);
    Err(BaselineError::Missing {
        name: name.to_owned(),
        scenario: scenario.to_owned(),
        dir: d,
        shipped: if shipped.is_empty() { "none".to_owned() } else { shipped.join(", ") },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_checked_and_a_missing_baseline_names_what_is_shipped() {
        assert!(matches!(check_name(""), Err(BaselineError::NoName)));
        assert!(matches!(check_name("../x"), Err(BaselineError::BadName { .. })));
        assert!(check_name("mappo-rgb").is_ok());
        let root = std::env::temp_dir().join(format!("avacraft-baselines-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("3m_vlm/qmix")).expect("dir");
        std::fs::write(root.join("3m_vlm/qmix/config.json"), "{}").expect("write");
        assert_eq!(dir(&root, "3m_vlm", "qmix").expect("shipped"), root.join("3m_vlm/qmix"));
        let e = dir(&root, "3m_vlm", "mappo").expect_err("not shipped").to_string();
        assert!(e.contains("`mappo`") && e.contains("shipped there: qmix"), "{e}");
        let e = dir(&root, "2s3z_vlm", "qmix").expect_err("no scenario").to_string();
        assert!(e.contains("shipped there: none"), "{e}");
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_runs_last_checkpoint_is_named_with_at_last() {
        assert!(check_name("qmix@last").is_ok());
        assert!(matches!(check_name("@last"), Err(BaselineError::NoName)));
        assert!(matches!(check_name("qmix@best"), Err(BaselineError::BadName { .. })));
        let root = std::env::temp_dir().join(format!("avacraft-baselines-last-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("3m/qmix/last")).expect("dir");
        std::fs::create_dir_all(root.join("3m/mappo")).expect("dir");
        for f in ["3m/qmix/config.json", "3m/qmix/last/config.json", "3m/mappo/config.json"] {
            std::fs::write(root.join(f), "{}").expect("write");
        }
        assert_eq!(dir(&root, "3m", "qmix@last").expect("shipped"), root.join("3m/qmix/last"));
        assert_eq!(shipped(&root, "3m"), ["mappo", "qmix", "qmix@last"]);
        let e = dir(&root, "3m", "mappo@last").expect_err("no last").to_string();
        assert!(e.contains("`mappo@last`") && e.contains("qmix@last"), "{e}");
        let _ = std::fs::remove_dir_all(&root);
    }
}
