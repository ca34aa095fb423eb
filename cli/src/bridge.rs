//! `avacraft bridge`: the launch file's `bridge:` section as a node (see `avacraft-bridge`).

use anyhow::{Context, Result, bail};
use avacraft_bridge::BridgeConfig;
use avacraft_engine::{Env, EnvConfig};
use avacraft_launch::BridgeTopic;
use avacraft_nodes::{Node, NodeArgs, Shutdown, TeamNo, Topics, UnitTag};
use clap::Args;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

#[derive(Args, Debug, Clone)]
pub struct BridgeArgs {
    #[command(flatten)]
    pub node: NodeArgs,
    /// The launch file with the `bridge:` section.
    #[arg(long)]
    pub launch: PathBuf,
    /// Seconds to wait for the DDS agents (their writers and readers) to appear.
    #[arg(long, default_value_t = 60.0)]
    pub dds_timeout: f64,
}

pub fn run(a: &BridgeArgs) -> Result<()> {
    avacraft_nodes::init_logging();
    let shutdown = Shutdown::install();
    // The bridge never acts: it names the policies without reading their weights.
    let plan = avacraft_launch::load_with(&a.launch, avacraft_policy::Weights::Later)?;
    let Some(b) = &plan.bridge else { bail!("{}: no `bridge:` section", plan.file) };
    if !(a.dds_timeout.is_finite() && a.dds_timeout > 0.0) {
        bail!("--dds-timeout {}: must be a positive number of seconds", a.dds_timeout);
    }
    let env = Env::new(Arc::clone(&plan.scenario), EnvConfig::default(), 0);
    let team_of = |t: TeamNo| t.team();
    let has = |t: BridgeTopic| b.topics.contains(&t);
    let mut cfg = BridgeConfig {
        dds_domain: b.dds_domain,
        dds_networks: b.dds_networks.clone(),
        status: has(BridgeTopic::Status),
        roles: has(BridgeTopic::Roles),
        frame_size: b.frame_size,
        frame_every: b.frame_every,
        dds_agents: plan.agents.iter().filter(|a| a.is_dds()).map(|a| (a.id.clone(), a.team)).collect(),
        wait_for_dds: Duration::from_secs_f64(a.dds_timeout),
        ..BridgeConfig::default()
    };
    for &team in &b.teams {
        if has(BridgeTopic::TeamObs) {
            cfg.team_obs.push(team);
        }
        if has(BridgeTopic::UnitObs) {
            for id in env.agents(team_of(team)) {
                cfg.unit_obs.push((team, UnitTag::from(*id)));
            }
        }
        if has(BridgeTopic::Frames)
            && let Some(f) = &plan.frames
        {
            cfg.frames.extend(f.kinds.iter().map(|&k| (team, k)));
        }
    }
    let topics = Topics::new(&a.node.namespace)?;
    let node = Node::open(&a.node, &a.node.namespace, &avacraft_nodes::NodeName::bridge()).context("bridge: opening the Zenoh session")?;
    let stats = avacraft_bridge::run(&node, &topics, &cfg, &shutdown)?;
    tracing::info!(to_dds = ?stats.to_dds, thinned = stats.frames_thinned, actions = stats.actions_to_zenoh, malformed = stats.malformed, refused_by_dds = stats.dds_refused, "bridge stops");
    Ok(())
}
