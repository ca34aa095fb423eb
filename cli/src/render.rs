//! `render`: play a scenario up to a game loop and save what a team sees as a PNG.

use crate::flags::team_of;
use anyhow::{Context, Result, bail};
use avacraft_engine::{Controllers, Env, EnvConfig, Mode, OpponentKind, Scenario, UnitId};
use avacraft_render::{CpuBackend, FrameBuilder, VlmOptions};
use clap::{Args, ValueEnum};
use std::io::Write;
use std::num::NonZeroU32;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FrameKind {
    /// The annotated VLM screenshot (default 1920x1080).
    Vlm,
    /// The MARL screen (default 160x120).
    Screen,
    /// The minimap (default 32x32).
    Minimap,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BackendKind {
    Cpu,
    Wgpu,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Built-in scenario name or path to a scenario file.
    #[arg(long)]
    scenario: String,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Game loop to render (the episode is played with the policies up to it).
    #[arg(long = "loop", default_value_t = 0)]
    at_loop: u32,
    #[arg(long, value_enum, default_value_t = FrameKind::Vlm)]
    mode: FrameKind,
    /// Whose view (fog of war, colours).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    team: u8,
    /// Image size WIDTHxHEIGHT (default: the mode's).
    #[arg(long)]
    size: Option<String>,
    /// Unit tags to mark as priority (comma-separated), as a VLM agent would.
    #[arg(long, value_delimiter = ',')]
    highlight: Vec<u32>,
    #[arg(long, default_value = "kite")]
    agent: String,
    #[arg(long)]
    agent2: Option<String>,
    #[arg(long)]
    opponent: Option<String>,
    #[arg(long)]
    full_vision: bool,
    /// Back end: cpu (every machine) or wgpu (needs a Vulkan adapter; lavapipe is enough).
    #[arg(long, value_enum, default_value_t = BackendKind::Cpu)]
    backend: BackendKind,
    /// Output PNG file.
    #[arg(long)]
    out: PathBuf,
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s.split_once('x').with_context(|| format!("--size {s:?}: expected WIDTHxHEIGHT, e.g. 640x360"))?;
    let (w, h): (u32, u32) =
        (w.parse().with_context(|| format!("--size {s:?}: bad width"))?, h.parse().with_context(|| format!("--size {s:?}: bad height"))?);
    if !(8..=8192).contains(&w) || !(8..=8192).contains(&h) {
        bail!("--size {s:?}: width and height must be between 8 and 8192");
    }
    Ok((w, h))
}

pub fn run(a: &RenderArgs, out: &mut dyn Write) -> Result<()> {
    let scenario = Arc::new(Scenario::load(&a.scenario)?);
    let opponent = a.opponent.as_deref().map(str::parse::<OpponentKind>).transpose().map_err(anyhow::Error::msg).context("--opponent")?;
    let size = match (&a.size, a.mode) {
        (Some(s), _) => parse_size(s)?,
        (None, FrameKind::Vlm) => (1920, 1080),
        (None, FrameKind::Screen) => (160, 120),
        (None, FrameKind::Minimap) => (32, 32),
    };
    let mut cfg = EnvConfig { opponent, step_mul: NonZeroU32::MIN, ..EnvConfig::default() };
    cfg.rules.full_vision = a.full_vision;
    let mut env = Env::new(Arc::clone(&scenario), cfg, a.seed);
    avacraft_engine::agent_by_name(&a.agent).context("--agent")?;
    let second = (scenario.mode == Mode::Pvp).then(|| a.agent2.as_deref().unwrap_or(&a.agent));
    let mut controllers = Controllers::named(&scenario, &a.agent, second).context("--agent2")?;
    controllers.reset(&env);
    // The env steps one loop at a time so any loop can be shown; policies act every 8.
    while env.world().tick() < a.at_loop && !env.done() {
        if env.world().tick().is_multiple_of(8) {
            controllers.act(&mut env);
        }
        env.step();
    }
    let team = team_of(a.team);
    let n = env.world().units().len() as u32;
    let highlights: Vec<UnitId> = a
        .highlight
        .iter()
        .map(|&t| match UnitId::try_from(t) {
            Ok(id) if t <= n => Ok(id),
            _ => Err(anyhow::anyhow!("--highlight {t}: no unit has that tag (1..={n})")),
        })
        .collect::<Result<_>>()?;
    let mut frames = FrameBuilder::new();
    let scene = match a.mode {
        FrameKind::Vlm => frames.vlm(env.world(), team, size.0, size.1, &VlmOptions { highlights }),
        FrameKind::Screen => frames.screen(env.world(), team, size.0, size.1),
        FrameKind::Minimap => frames.minimap(env.world(), team, size.0, size.1),
    };
    let img = match a.backend {
        BackendKind::Cpu => CpuBackend::new().render(&scene),
        // An error naming the `gpu` feature where the program was built without it.
        BackendKind::Wgpu => avacraft_render::BackendChoice::Wgpu.open()?.render(&scene)?,
    };
    img.save(&a.out).with_context(|| format!("{}: cannot write the PNG", a.out.display()))?;
    writeln!(
        out,
        "{}: {}x{} {:?} of {} at loop {} for {}",
        a.out.display(),
        size.0,
        size.1,
        a.mode,
        scenario.name,
        env.world().tick(),
        team
    )?;
    Ok(())
}
