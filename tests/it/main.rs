//! The integration test binary: one binary, one module per area.
#![forbid(unsafe_code)]

mod abilities;
mod ability_obs;
mod actions;
mod agents;
mod cli;
mod combat;
mod determinism;
mod epo;
mod fov;
mod game_data;
mod golden;
mod helpers;
mod heuristic;
mod learn;
mod movement;
mod observations;
mod procedural;
mod properties;
mod render;
mod rules;
mod scenarios;
mod smac;
mod smac_maps;
mod speed;
mod splash;
mod state_agent;
mod structure;
mod targeting;
mod unify;
mod vision;
