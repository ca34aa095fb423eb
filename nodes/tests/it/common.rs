//! Helpers shared by the tests.

use std::process::Command;

/// Set in a copy of this test binary started by [`child_process`].
const CHILD_ARG: &str = "AVACRAFT_TEST_CHILD";

/// A cross-process test plays the other process by running this same test binary again,
/// filtered to that test alone (`test`: its full name, `module::function`), with `arg` for
/// [`child_arg`]. There is no separate entry point, so nothing counts as a test of its own
/// in a normal run; a wrong name runs no test in the copy, which the parent then sees as a
/// child that never does its part.
pub fn child_process(test: &str, arg: &str) -> std::io::Result<Command> {
    let mut c = Command::new(std::env::current_exe()?);
    c.args(["--exact", test, "--nocapture", "--test-threads=1", "--quiet"]).env(CHILD_ARG, arg);
    Ok(c)
}

/// In a copy started by [`child_process`], the argument it was given; `None` in a normal run.
pub fn child_arg() -> Option<String> {
    std::env::var(CHILD_ARG).ok()
}
