//! The `avacraft` command line as a library, so tests drive it in-process with the exact
//! argument parsing and output of the binary.
#![forbid(unsafe_code)]

mod agent_node;
mod ava;
mod bench;
mod bench_ava;
mod bench_bridge;
mod bench_deploy;
mod bench_train;
mod bench_vec;
mod bridge;
mod certs;
mod curves;
mod env_info;
mod episode;
mod eval;
mod flags;
mod human;
mod launch;
mod live;
mod live_mcap;
mod probe;
mod record;
mod render;
mod replay;
mod scenarios;
mod sim_node;
mod smac_report;
mod train;

pub use bench::{BenchRow, RenderRow, ScalingRow};
pub use episode::{EpisodeRecord, Report, Summary};
pub use live_mcap::{Added, RECORDED_VIEW, add_live_channels};
pub use probe::ProbeReport;
pub use replay::{
    FrameSink, Mismatch, RecordedEpisode, Recording, ReplayError, ReplayResult, read_recording, replay_episode, replay_recording,
};

use clap::{Parser, Subcommand};
use stats_alloc::StatsAlloc;
use std::alloc::System;
use std::io::Write;

#[derive(Parser, Debug)]
#[command(name = "avacraft", version, about = "AVACraft: StarCraft II micro-combat benchmark for MARL and VLM agents")]
pub struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// List the built-in scenarios with unit counts and mode.
    Scenarios(scenarios::ScenariosArgs),
    /// Print SMAC's get_env_info() for a scenario.
    EnvInfo(env_info::EnvInfoArgs),
    /// Run episodes in-process (scripted agents or a trained policy, `--agent marl:DIR`) and
    /// report win/draw/loss rates.
    Episode(episode::EpisodeArgs),
    /// Measure environment steps per second and memory per environment.
    Bench(bench::BenchArgs),
    /// Play up to a game loop and save what a team sees (VLM screenshot, screen or minimap) as PNG.
    Render(render::RenderArgs),
    /// Start every node of a launch file as its own process, on an embedded Zenoh router
    /// (agent policies: scripted agents, `marl:DIR` checkpoints, or `dds`).
    Launch(launch::LaunchArgs),
    /// Make a secured launch file's certificates: an authority and one key pair per host.
    Certs(certs::CertsArgs),
    /// Join a deployment as this host and report which topics get through, and whether
    /// marked action batches sent as an agent node arrive (an access-control check).
    Probe(probe::ProbeArgs),
    /// Run the simulator node (publishes observations, takes actions) of a launch file.
    SimNode(sim_node::SimNodeArgs),
    /// Run one agent node: a policy for one unit or a role group.
    AgentNode(agent_node::AgentNodeArgs),
    /// Republish the deployment's topics onto ROS 2 DDS and carry DDS agents' actions back.
    Bridge(bridge::BridgeArgs),
    /// Record every topic to MCAP (ros2 profile).
    Record(record::RecordArgs),
    /// Re-simulate a recording's episodes from their seeds and applied actions and check
    /// the trajectory matches.
    Replay(replay::ReplayArgs),
    /// Train a MARL baseline (IQL, VDN, QMIX, QTRAN, IPPO, MAPPO) on features, rgb, hybrid or
    /// vision-text observations and save a checkpoint (`features` ones play as `--agent
    /// marl:DIR` and as launch files' `policy: marl:DIR`).
    Train(train::TrainArgs),
    /// Compare training runs: groups of runs' learning curves in one figure (against
    /// environment steps and wall-clock seconds) and when each run reached given win rates.
    Curves(curves::CurvesArgs),
    /// SMAC's 23 maps: the learners' training runs (eval/plans/smac.toml) beside the real
    /// game's published win rates, as a Markdown table and one figure of learning curves.
    SmacReport(smac_report::SmacReportArgs),
    /// Evaluate agents from a plan file (scenarios, agents, opponents, seeds, head-to-head
    /// pairings): parallel, resumable, shardable; writes the paper's tables and plots.
    Eval(eval::EvalArgs),
    /// Human evaluation: pack blinded replays of an evaluation, serve the local rating page,
    /// analyze the ratings (Mann-Whitney U per metric and agent kind).
    HumanEval(human::HumanArgs),
}

impl Cli {
    /// Whether the command trains a MARL baseline (the binary then runs it with candle's
    /// elementwise thread pool off and glibc's malloc tuned: see `main.rs`).
    pub fn trains(&self) -> bool {
        matches!(&self.command, Cmd::Train(_)) || matches!(&self.command, Cmd::Bench(b) if b.trains())
    }
}

/// Runs one command, writing its report to `out`. `alloc` is the process's counting
/// allocator, when it has one (the binary does), for `bench`'s bytes per environment.
pub fn run(cli: Cli, out: &mut dyn Write, alloc: Option<&'static StatsAlloc<System>>) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Scenarios(a) => scenarios::scenarios(&a, out),
        Cmd::EnvInfo(a) => env_info::env_info(&a, out),
        Cmd::Episode(a) => episode::run(&a, out),
        Cmd::Bench(a) => bench::run(&a, out, alloc),
        Cmd::Render(a) => render::run(&a, out),
        Cmd::Launch(a) => launch::launch(&a, out),
        Cmd::Certs(a) => certs::certs(&a, out),
        Cmd::Probe(a) => probe::run(&a, out),
        Cmd::SimNode(a) => sim_node::sim_node(&a, out),
        Cmd::AgentNode(a) => agent_node::agent_node(&a),
        Cmd::Record(a) => record::command(&a),
        Cmd::Bridge(a) => bridge::run(&a),
        Cmd::Replay(a) => replay::run(&a, out),
        Cmd::Train(a) => train::run(&a, out),
        Cmd::Curves(a) => curves::run(&a, out),
        Cmd::SmacReport(a) => smac_report::run(&a, out),
        Cmd::Eval(a) => eval::run(&a, out),
        Cmd::HumanEval(a) => human::run(&a, out),
    }
}

/// Parses `args` (program name first) and runs the command.
pub fn run_args<I, T>(args: I, out: &mut dyn Write) -> anyhow::Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = Cli::try_parse_from(args)?;
    run(cli, out, None)
}

#[cfg(test)]
mod tests {
    /// clap checks its own definitions (flag names that `requires` and `conflicts_with`
    /// refer to, ...) only when a command is parsed in a debug build: check every verb here,
    /// not in a child process of a deployment test.
    #[test]
    fn every_command_line_definition_is_consistent() {
        <super::Cli as clap::CommandFactory>::command().debug_assert();
    }
}
