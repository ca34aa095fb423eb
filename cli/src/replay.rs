//! `avacraft replay session.mcap`: re-simulates every recorded episode from its seed and the
//! actions the simulator applied, and checks the trajectory against the recording step by
//! step (every unit's position, HP and shields as the team saw them). Optionally renders
//! the re-simulated episode to a GIF.

use anyhow::{Context, Result, bail};
use avacraft_engine::{Env, EnvConfig, OpponentKind, Scenario, Team, unit_list};
use avacraft_msgs::{ActionBatch, EpisodeStatus, RosMessage, TeamObservation, decode};
use clap::Args;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Args, Debug, Clone)]
pub struct ReplayArgs {
    /// The recording.
    pub file: PathBuf,
    /// Scenario file or name, when the recorded name is not a built-in scenario.
    #[arg(long)]
    pub scenario: Option<String>,
    /// The PvE opponent the launch file set, if it set one.
    #[arg(long)]
    pub opponent: Option<OpponentKind>,
    /// Render the first replayed episode (team 1's annotated view) to this GIF.
    #[arg(long)]
    pub video: Option<PathBuf>,
}

/// What was recorded of one episode.
#[derive(Debug, Default)]
struct Recorded {
    seed: Option<u64>,
    scenario: String,
    applied: BTreeMap<u32, ActionBatch>,
    /// Team 1's view at the start of each step.
    views: BTreeMap<u32, TeamObservation>,
    last: Option<EpisodeStatus>,
}

/// One episode's verdict.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ReplayResult {
    pub episode: u64,
    pub seed: u64,
    pub steps: u32,
    pub compared_views: usize,
    /// The first difference, or `None` when the trajectory matches.
    pub mismatch: Option<String>,
}

fn read(file: &PathBuf) -> Result<BTreeMap<u64, Recorded>> {
    let bytes = std::fs::read(file).with_context(|| format!("replay: reading {}", file.display()))?;
    let mut eps: BTreeMap<u64, Recorded> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).with_context(|| format!("replay: {} is not an MCAP file", file.display()))? {
        let m = m.with_context(|| format!("replay: {}", file.display()))?;
        let ty = m.channel.schema.as_ref().map(|s| s.name.as_str()).unwrap_or_default();
        let topic = m.channel.topic.as_str();
        if ty == EpisodeStatus::TYPE_NAME && topic.ends_with("/status") {
            let s: EpisodeStatus = decode(&m.data).with_context(|| format!("replay: a status message on {topic}"))?;
            let e = eps.entry(s.episode).or_default();
            e.seed = Some(s.seed);
            e.scenario = s.scenario.clone();
            e.last = Some(s);
        } else if ty == ActionBatch::TYPE_NAME && topic.ends_with("/applied") {
            let b: ActionBatch = decode(&m.data).with_context(|| format!("replay: an applied batch on {topic}"))?;
            eps.entry(b.episode).or_default().applied.insert(b.step, b);
        } else if ty == TeamObservation::TYPE_NAME && topic.ends_with("/team_1/obs") {
            let o: TeamObservation = decode(&m.data).with_context(|| format!("replay: a team view on {topic}"))?;
            eps.entry(o.episode).or_default().views.entry(o.step).or_insert(o);
        }
    }
    Ok(eps)
}

/// Differences between a recorded view and the re-simulated world.
fn compare(env: &Env, view: &TeamObservation) -> Option<String> {
    let now = unit_list(env.world(), Team::One);
    if now.len() != view.units.len() {
        return Some(format!("step {}: {} units recorded, {} re-simulated", view.step, view.units.len(), now.len()));
    }
    for (a, b) in now.iter().zip(&view.units) {
        let same = a.tag == b.tag
            && a.x.to_bits() == b.x.to_bits()
            && a.y.to_bits() == b.y.to_bits()
            && a.hp.to_bits() == b.hp.to_bits()
            && a.shield.to_bits() == b.shield.to_bits();
        if !same {
            return Some(format!(
                "step {}: unit {} recorded at ({}, {}) HP {} shields {}, re-simulated {} at ({}, {}) HP {} shields {}",
                view.step, b.tag, b.x, b.y, b.hp, b.shield, a.tag, a.x, a.y, a.hp, a.shield
            ));
        }
    }
    None
}

/// Re-simulates every episode of a recording.
pub fn replay(a: &ReplayArgs) -> Result<Vec<ReplayResult>> {
    let eps = read(&a.file)?;
    if eps.is_empty() {
        bail!("replay: {} holds no episode (no /status messages)", a.file.display());
    }
    let mut out = Vec::new();
    let mut video = match &a.video {
        Some(p) => {
            Some((avacraft_render::VideoWriter::create(p, 100)?, avacraft_render::FrameBuilder::new(), avacraft_render::CpuBackend::new()))
        }
        None => None,
    };
    for (&episode, rec) in &eps {
        let Some(seed) = rec.seed else { continue };
        let name = a.scenario.clone().unwrap_or_else(|| rec.scenario.clone());
        let scenario = Arc::new(Scenario::load(&name).with_context(|| format!("replay: episode {episode}'s scenario"))?);
        let cfg = EnvConfig { opponent: a.opponent, ..EnvConfig::default() };
        let mut env = Env::new(scenario, cfg, seed);
        let mut mismatch = None;
        let mut compared = 0;
        loop {
            let step = env.steps();
            if let Some(view) = rec.views.get(&step) {
                compared += 1;
                if let Some(d) = compare(&env, view) {
                    mismatch = Some(d);
                    break;
                }
            }
            if env.done() {
                break;
            }
            if let Some(batch) = rec.applied.get(&step) {
                for act in &batch.actions {
                    let action =
                        avacraft_sim_node::action_from_msg(env.world(), act).map_err(|e| anyhow::anyhow!("replay: step {step}: {e}"))?;
                    let team = env.world().unit(action.unit).map_or(Team::One, |u| u.team);
                    let _ = env.submit(team, &[action]);
                }
            } else if rec.last.as_ref().is_some_and(|s| step < s.step) {
                mismatch = Some(format!("step {step}: the recording has no applied actions for it"));
                break;
            }
            env.step();
            if let Some((w, fb, cpu)) = video.as_mut().filter(|_| out.is_empty()) {
                w.push(&cpu.render(&fb.vlm(env.world(), Team::One, 640, 480, &avacraft_render::VlmOptions::default())))?;
            }
        }
        if mismatch.is_none()
            && let Some(s) = &rec.last
            && (s.step != env.steps() || s.game_loop != env.world().tick())
        {
            mismatch = Some(format!(
                "the recording ends at step {} loop {}, the re-simulation at step {} loop {}",
                s.step,
                s.game_loop,
                env.steps(),
                env.world().tick()
            ));
        }
        out.push(ReplayResult { episode, seed, steps: env.steps(), compared_views: compared, mismatch });
    }
    if let Some((w, ..)) = video {
        w.finish()?;
    }
    Ok(out)
}

pub fn run(a: &ReplayArgs, out: &mut dyn Write) -> Result<()> {
    let results = replay(a)?;
    let mut bad = 0;
    for r in &results {
        match &r.mismatch {
            None => writeln!(out, "episode {} (seed {}): {} steps, {} recorded views match", r.episode, r.seed, r.steps, r.compared_views)?,
            Some(d) => {
                bad += 1;
                writeln!(out, "episode {} (seed {}): MISMATCH: {d}", r.episode, r.seed)?;
            }
        }
    }
    if bad > 0 {
        bail!("replay: {bad} of {} episodes do not match the recording", results.len());
    }
    Ok(())
}
