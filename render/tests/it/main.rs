//! The renderer's integration tests in one binary (one link instead of two).

mod camera;
mod obs_frame;
