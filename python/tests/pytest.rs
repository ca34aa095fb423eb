//! Runs the Python test suite (`python/tests/test_*.py`) under `cargo test`, against the
//! extension built from the current source by the same `cargo test`: the library is a
//! `cdylib` and an `rlib`, so Cargo builds it (fresh, with this build's profile and features)
//! before this test, next to the test binary in `deps/`. The library is staged as
//! `avacraft/_avacraft.abi3.so` next to copies of the pure-Python sources in a temporary
//! directory, and that directory first on `PYTHONPATH`, so neither a stale build nor a
//! `pip install`ed copy is what gets tested.
#![allow(clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

const PIP: &str = "python3 -m pip install numpy pettingzoo gymnasium pytest";

fn python() -> String {
    std::env::var("PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The extension Cargo built for this test (in the test binary's own `deps/` folder: a
/// library that is also a `cdylib` gets no hash in its file name) and the name Python
/// imports it under.
fn built_library() -> (PathBuf, &'static str) {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().unwrap().to_owned();
    if cfg!(target_os = "windows") {
        (dir.join("_avacraft.dll"), "_avacraft.pyd")
    } else if cfg!(target_os = "macos") {
        (dir.join("lib_avacraft.dylib"), "_avacraft.abi3.so")
    } else {
        (dir.join("lib_avacraft.so"), "_avacraft.abi3.so")
    }
}

#[test]
fn pytest_suite() {
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let py = python();

    let missing = Command::new(&py).args(["-c", "import numpy, pettingzoo, gymnasium, pytest"]).output().unwrap_or_else(|e| {
        panic!("cannot run {py} ({e}): the Python tests need Python 3 with numpy, pettingzoo, gymnasium and pytest: {PIP}")
    });
    assert!(
        missing.status.success(),
        "the Python tests need numpy, pettingzoo, gymnasium and pytest: {PIP}\n{}",
        String::from_utf8_lossy(&missing.stderr)
    );

    let start = Instant::now();
    let stage = std::env::temp_dir().join(format!("avacraft-pytest-{}", std::process::id()));
    let pkg = stage.join("avacraft");
    let _ = std::fs::remove_dir_all(&stage);
    std::fs::create_dir_all(&pkg).unwrap();
    for entry in std::fs::read_dir(crate_dir.join("avacraft")).unwrap() {
        let path = entry.unwrap().path();
        let keep = path.extension().is_some_and(|e| e == "py" || e == "pyi") || path.file_name().is_some_and(|n| n == "py.typed");
        if keep {
            std::fs::copy(&path, pkg.join(path.file_name().unwrap())).unwrap();
        }
    }
    let (lib, name) = built_library();
    std::fs::copy(&lib, pkg.join(name)).unwrap_or_else(|e| {
        panic!("{}: {e} (Cargo builds it before this test: is python/Cargo.toml's crate-type still cdylib and rlib?)", lib.display())
    });

    // From the staging directory: `python -m` puts the working directory first on the path,
    // and python/ holds the sources without the extension.
    let out = Command::new(&py)
        .current_dir(&stage)
        .env("PYTHONPATH", &stage)
        .env("AVACRAFT_STAGED", &pkg)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .args(["-m", "pytest"])
        .arg(crate_dir.join("tests"))
        .args(["-q", "--rootdir"])
        .arg(&crate_dir)
        .args(["-p", "no:cacheprovider", "-W", "error::pytest.PytestUnraisableExceptionWarning"])
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&stage);
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    println!("pytest ran in {:.1?}", start.elapsed());
    assert!(out.status.success(), "the Python test suite failed (see above)");
}
