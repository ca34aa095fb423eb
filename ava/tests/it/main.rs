//! AVA's integration tests in one binary: each test binary links the whole stack (the
//! engine, the renderer, candle, llama.cpp), so one link instead of four.

mod ceiling;
mod common;
mod decision;
mod kb;
mod llm;
#[cfg(feature = "local")]
mod local;
