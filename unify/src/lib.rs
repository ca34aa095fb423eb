//! Build time only: see Cargo.toml. The crate has no code; its dependencies' features are
//! the point.
#![forbid(unsafe_code)]
