//! The integration test binary of avacraft-msgs: one module per area.
#![forbid(unsafe_code)]

mod cdr;
mod common;
mod hashes;
mod parser;
mod schema;
mod struct_matches_msg;
