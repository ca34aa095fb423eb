//! Empty: it exists so that the compile-time dependencies in Cargo.toml are resolved (with
//! the proc macros' and build scripts' features) for this crate.
fn main() {}
