//! The learners' integration tests in one binary: each test binary links the whole stack
//! (the engine, the renderer, candle), so one link instead of four.

mod abilities;
mod common;
mod encoders;
mod learn;
mod play_out;
mod ppo;
mod resume;
mod selfplay;
mod text;
