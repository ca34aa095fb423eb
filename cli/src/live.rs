//! `--foxglove`: the live view flags shared by `episode`, `replay` and the simulator node
//! (which `launch` hands them to), and the pacing of a watched run.

use anyhow::{Context, Result, bail};
use avacraft_ava::llm::Stage;
use avacraft_engine::Env;
use avacraft_live::{Level, LiveServer, LiveView, ViewSize};
use clap::Args;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

/// The address `--foxglove` without a value listens on: loopback, Foxglove's usual port.
pub const DEFAULT_ADDR: &str = "127.0.0.1:8765";

#[derive(Args, Debug, Clone, Default)]
pub struct LiveArgs {
    /// Serve a live view of the battle to Foxglove or Lichtblick (Open connection, Foxglove
    /// WebSocket, ws://ADDR:PORT): team 1's screen and minimap, the units in 3D, unit
    /// annotations, agents' orders and AVA's calls as logs, the episode's status. Loopback
    /// (127.0.0.1:8765) unless an address is given, e.g. 0.0.0.0:8765 to serve other
    /// machines; port 0 takes a free port (printed).
    #[arg(long, value_name = "ADDR:PORT", num_args = 0..=1, default_missing_value = DEFAULT_ADDR)]
    pub foxglove: Option<SocketAddr>,
    /// With --foxglove: wait up to this many seconds for a viewer to subscribe before playing.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, requires = "foxglove")]
    pub foxglove_wait: f64,
    /// With --foxglove: game speed of the view, 1 for real time (22.4 game loops a second,
    /// StarCraft II's "faster"), 4 for four times that, 0 for as fast as the machine goes.
    #[arg(long, value_name = "X", default_value_t = 1.0, requires = "foxglove")]
    pub foxglove_speed: f64,
}

/// A model call as a line of the live view's log, for in-process and agent-node calls
/// alike: its level, its name (`ava/<who>/<Stage>`) and its text (the reply, else the error).
/// `None` for a call with neither.
pub fn call_line(who: &str, stage: Stage, step: u32, reply: Option<&str>, error: Option<&str>) -> Option<(Level, String, String)> {
    let name = format!("ava/{who}/{stage:?}");
    match (reply.filter(|r| !r.is_empty()), error.filter(|e| !e.is_empty())) {
        (Some(r), _) => Some((Level::Info, name, format!("step {step}: {r}"))),
        (None, Some(e)) => Some((Level::Error, name, format!("step {step}: {e}"))),
        (None, None) => None,
    }
}

/// An AVA agent node's model call (off its `model_calls` topic, live or recorded) as a line of
/// the live view's log ([`call_line`]); `None` also for a stage this build does not know.
pub fn model_call_line(agent: &str, c: &avacraft_msgs::ModelCall) -> Option<(Level, String, String)> {
    use avacraft_msgs::ModelCall as M;
    let stage = match c.stage {
        M::STAGE_PLANNER => Stage::Planner,
        M::STAGE_PRIORITY => Stage::Priority,
        M::STAGE_ROLES => Stage::Roles,
        M::STAGE_DECISION => Stage::Decision,
        _ => return None,
    };
    call_line(agent, stage, c.step, Some(&c.response), Some(&c.error))
}

/// A running live view and its pacing.
pub struct Live {
    view: LiveView,
    speed: f64,
    /// Wall clock and session game time at the last pacing point.
    anchor: Option<(Instant, u64, u32)>,
}

impl LiveArgs {
    /// These flags as arguments again, for the node that serves the view.
    pub fn args(&self) -> Vec<String> {
        match self.foxglove {
            Some(addr) => vec![
                format!("--foxglove={addr}"),
                format!("--foxglove-wait={}", self.foxglove_wait),
                format!("--foxglove-speed={}", self.foxglove_speed),
            ],
            None => Vec::new(),
        }
    }

    /// Starts the server when `--foxglove` was given.
    pub fn start(&self, what: &str) -> Result<Option<Live>> {
        let Some(addr) = self.foxglove else { return Ok(None) };
        if !(self.foxglove_speed.is_finite() && self.foxglove_speed >= 0.0) {
            bail!("--foxglove-speed {}: give a speed of 0 (unpaced) or more", self.foxglove_speed);
        }
        if !(self.foxglove_wait.is_finite() && self.foxglove_wait >= 0.0) {
            bail!("--foxglove-wait {}: give a number of seconds, 0 or more", self.foxglove_wait);
        }
        let server = LiveServer::start(addr, &format!("avacraft {what}"), avacraft_live::DEFAULT_BACKLOG)
            .with_context(|| format!("--foxglove {addr}"))?;
        // On stderr, so that `--json` output stays clean; tests read the port from here.
        eprintln!("foxglove: live view on ws://{} (Foxglove or Lichtblick: Open connection, Foxglove WebSocket)", server.addr());
        if self.foxglove_wait > 0.0 && !server.wait_for(avacraft_live::LiveChannel::Status, Duration::from_secs_f64(self.foxglove_wait)) {
            eprintln!("foxglove: no viewer after {} s; playing anyway", self.foxglove_wait);
        }
        Ok(Some(Live { view: LiveView::new(server, ViewSize::default()), speed: self.foxglove_speed, anchor: None }))
    }
}

impl Live {
    /// Publishes the environment's step, then sleeps as long as the game speed asks (the
    /// run's results do not depend on it: only when it is shown).
    pub fn step(&mut self, env: &Env) {
        self.view.step(env);
        if self.speed <= 0.0 {
            return;
        }
        let (seed, tick) = (env.seed(), env.world().tick());
        match self.anchor {
            Some((at, s, t0)) if s == seed && tick >= t0 => {
                let game = Duration::from_secs_f64(f64::from(tick - t0) / f64::from(avacraft_engine::LOOPS_PER_SECOND) / self.speed);
                if let Some(wait) = game.checked_sub(at.elapsed()) {
                    std::thread::sleep(wait);
                }
            }
            _ => self.anchor = Some((Instant::now(), seed, tick)),
        }
    }

    pub fn logger(&self) -> avacraft_live::LiveLog {
        self.view.logger()
    }

    /// A line saying what the server did, for the end of a run.
    pub fn summary(&self) -> String {
        let s = self.view.server().stats();
        format!(
            "foxglove: {} viewer(s), {} messages sent, {} dropped for slow viewers, {} disconnected for sending garbage",
            s.clients, s.sent, s.dropped, s.refused
        )
    }
}
