//! `avacraft probe`: what can this host see and send? It joins the deployment like a node
//! (same flags, same TLS identity), listens to the topics asked for, optionally publishes
//! marked action batches on one agent's action topic, and prints what got through as JSON.
//! The security tests run it as an intruder; operators run it to check a host's access.

use anyhow::{Context, Result, bail};
use avacraft_msgs::{ActionBatch, RosMessage};
use avacraft_nodes::{AgentId, Node, NodeArgs, Qos, TeamNo, Topics};
use clap::Args;
use std::collections::BTreeMap;
use std::io::Write;
use std::time::{Duration, Instant};
use zenoh::Wait;

#[derive(Args, Debug, Clone)]
pub struct ProbeArgs {
    #[command(flatten)]
    pub node: NodeArgs,
    /// What to listen to (repeatable): `team:<n>` (everything of a team), `status`,
    /// `actions` (every agent node's actions, counted by the sender id in each batch).
    #[arg(long = "watch")]
    pub watch: Vec<String>,
    /// Publish action batches on this agent node's action topic, marked with `--mark` as
    /// sender id, an empty action list and a step no episode reaches.
    #[arg(long)]
    pub send_as: Option<String>,
    /// The sender id written into those batches (so a listener can tell probes apart).
    #[arg(long, default_value = "probe")]
    pub mark: String,
    /// Stop early once the simulator, having been seen, is gone (needs the ROS graph).
    #[arg(long)]
    pub until_sim_exits: bool,
    /// How long to listen and send at most, seconds.
    #[arg(long, default_value_t = 3.0)]
    pub seconds: f64,
}

/// What the probe saw.
#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct ProbeReport {
    /// Samples received per listened item.
    pub received: BTreeMap<String, u64>,
    /// Action batches received per sender id (with `--watch actions`).
    pub action_senders: BTreeMap<String, u64>,
    pub sent: u64,
    /// ROS node names seen in the graph (with `--until-sim-exits`).
    pub nodes_seen: std::collections::BTreeSet<String>,
}

pub fn run(a: &ProbeArgs, out: &mut dyn Write) -> Result<()> {
    avacraft_nodes::init_logging();
    if !(a.seconds.is_finite() && a.seconds > 0.0 && a.seconds <= 3600.0) {
        bail!("--seconds {}: must be more than 0 and at most 3600", a.seconds);
    }
    let topics = Topics::new(&a.node.namespace)?;
    let d = a.node.domain;
    let mut keys = Vec::new();
    for item in &a.watch {
        let key = match item.split_once(':') {
            Some(("team", n)) => {
                let team = n.parse::<u8>().ok().and_then(|n| TeamNo::new(n).ok());
                let Some(team) = team else { bail!("--watch {item}: the team must be 1 or 2") };
                avacraft_nodes::ros::key_space(d, &topics.team_prefix(team))
            }
            None if item == "status" => avacraft_nodes::ros::key_space(d, &topics.status()),
            None if item == "actions" => {
                avacraft_nodes::ros::pattern_key(d, &topics.any_actions(), ActionBatch::dds_type_name(), ActionBatch::type_hash())
            }
            _ => bail!("--watch {item}: must be team:<n>, status or actions"),
        };
        keys.push((item.clone(), key));
    }
    let target = a.send_as.as_deref().map(AgentId::parse).transpose()?;
    // Named after its mark, so a listener can tell which probe's node it sees.
    let mark =
        AgentId::parse(&a.mark).map_err(|_| anyhow::anyhow!("--mark {}: must be like an agent id (lowercase, digits, '_')", a.mark))?;
    let name = avacraft_nodes::NodeName::probe(&mark);
    let node = Node::open(&a.node, &a.node.namespace, &name).context("probe: opening the Zenoh session")?;
    let subs = keys
        .iter()
        .map(|(item, key)| {
            node.session()
                .declare_subscriber(key.clone())
                .with(zenoh::handlers::FifoChannel::new(100_000))
                .wait()
                .map(|s| (item.clone(), s))
                .map_err(|e| anyhow::anyhow!("probe: subscribing to {key}: {e}"))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut publisher = match &target {
        Some(agent) => Some(node.publisher::<ActionBatch>(&topics.actions(agent), Qos::Reliable { depth: 10 })?),
        None => None,
    };
    let mut report = ProbeReport::default();
    for (item, _) in &subs {
        report.received.insert(item.clone(), 0);
    }
    let start = Instant::now();
    let mut next_send = start;
    let (mut sim_seen, mut misses, mut next_look) = (false, 0, start);
    while start.elapsed().as_secs_f64() < a.seconds {
        if a.until_sim_exits && Instant::now() >= next_look {
            let nodes = node.alive_nodes(Duration::from_millis(300))?;
            let up = nodes.contains("sim");
            report.nodes_seen.extend(nodes);
            sim_seen |= up;
            misses = if up { 0 } else { misses + 1 };
            if sim_seen && misses >= 3 {
                break;
            }
            next_look = Instant::now() + Duration::from_millis(300);
        }
        if let Some(p) = &mut publisher
            && Instant::now() >= next_send
        {
            p.put(&ActionBatch { agent_id: a.mark.clone(), step: u32::MAX, ..ActionBatch::default() })?;
            report.sent += 1;
            next_send += Duration::from_millis(50);
        }
        for (item, s) in &subs {
            while let Ok(Some(sample)) = s.try_recv() {
                *report.received.entry(item.clone()).or_default() += 1;
                if item == "actions"
                    && let Ok(b) = avacraft_msgs::decode::<ActionBatch>(&sample.payload().to_bytes())
                {
                    *report.action_senders.entry(b.agent_id).or_default() += 1;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    writeln!(out, "{}", serde_json::to_string(&report)?)?;
    Ok(())
}
