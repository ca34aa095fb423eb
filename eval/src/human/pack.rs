//! `pack`: from an evaluation folder, pick finished PvE episodes of each agent kind, re-play
//! them (deterministically: AVA answers from its recordings) and draw every step's annotated
//! VLM view as team 1 sees it, under anonymous ids in a random order. Raters see only the
//! frames; the key that un-blinds them is a separate file.
//!
//! PvP episodes are left out: the view is one team's, and a rating would mix two agents.

use super::{HumanError, KEY_FILE, Key, KeyEntry, MANIFEST_FILE, Manifest, REPLAYS_DIR, STUDY_FILE, Study, io, write_json};
use crate::{AgentKind, EpisodeResult, Job, Meta, Plan};
use avacraft_engine::{Env, LOOPS_PER_SECOND, Team};
use avacraft_render::{CpuBackend, FrameBuilder, VlmOptions};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// What to pack.
#[derive(Clone, Debug)]
pub struct PackOptions {
    /// The evaluation folder (`plan.json`, `results.jsonl`, AVA's recordings).
    pub eval: PathBuf,
    /// The new study folder (must not exist, or be empty).
    pub out: PathBuf,
    /// Episodes per agent kind.
    pub per_kind: usize,
    /// Seeds the choice of episodes, their order and the anonymous ids.
    pub seed: u64,
    /// Frame size in pixels.
    pub width: u32,
    pub height: u32,
}

/// What `pack` made.
#[derive(Clone, Debug, PartialEq)]
pub struct PackSummary {
    /// Replays per kind.
    pub per_kind: BTreeMap<AgentKind, usize>,
    pub replays: usize,
    pub frames: u64,
    pub bytes: u64,
}

/// Packs a study; see the module's documentation. Nothing is overwritten: the study folder
/// must be new (or empty).
pub fn pack(plan: &Plan, opts: &PackOptions, progress: &mut dyn FnMut(usize, usize)) -> Result<PackSummary, HumanError> {
    let meta = crate::read_meta(&opts.eval).map_err(Box::new)?;
    if meta.cells != Meta::of(plan).cells || meta.seeds != plan.seeds {
        return Err(HumanError::OtherPlan { eval: opts.eval.clone(), plan: plan.file.clone() });
    }
    if opts.out.exists() && std::fs::read_dir(&opts.out).map_err(io(&opts.out))?.next().is_some() {
        return Err(HumanError::StudyExists { path: opts.out.clone() });
    }
    let loaded = crate::read(&opts.eval.join(crate::RESULTS_FILE))?;
    // Finished PvE episodes by team 1's agent kind, in the results' (sorted) order.
    let mut by_kind: BTreeMap<AgentKind, Vec<(Job, &EpisodeResult)>> = BTreeMap::new();
    for r in loaded.done.values() {
        let Some(ci) = plan.cells.iter().position(|c| c.key == r.cell) else { continue };
        let cell = &plan.cells[ci];
        if cell.agent2.is_some() || !r.ok() {
            continue;
        }
        by_kind.entry(plan.agents[cell.agent].kind).or_default().push((Job { cell: ci, seed: r.seed }, r));
    }
    if by_kind.len() < 2 {
        let found = by_kind.keys().map(|k| k.name()).collect::<Vec<_>>().join(", ");
        return Err(HumanError::OneKind { found: if found.is_empty() { "no kind (no finished PvE episode)".into() } else { found } });
    }
    for (k, v) in &by_kind {
        if v.len() < opts.per_kind {
            return Err(HumanError::TooFew { kind: k.name().into(), have: v.len(), want: opts.per_kind });
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let mut chosen: Vec<(AgentKind, Job, &EpisodeResult)> = Vec::new();
    for (k, v) in &mut by_kind {
        v.shuffle(&mut rng);
        chosen.extend(v.iter().take(opts.per_kind).map(|(j, r)| (*k, *j, *r)));
    }
    chosen.shuffle(&mut rng);
    let mut ids = BTreeSet::new();
    while ids.len() < chosen.len() {
        ids.insert(format!("r{:08x}", rng.random::<u32>()));
    }
    // The ids' sorted order says nothing of the kinds: pair them with the shuffled episodes
    // in a second random order.
    let mut ids: Vec<String> = ids.into_iter().collect();
    ids.shuffle(&mut rng);

    let replays = opts.out.join(REPLAYS_DIR);
    std::fs::create_dir_all(&replays).map_err(io(&replays))?;
    let mut key = Key { version: 1, eval: opts.eval.clone(), replays: BTreeMap::new() };
    let mut summary = PackSummary { per_kind: BTreeMap::new(), replays: 0, frames: 0, bytes: 0 };
    for (i, ((kind, job, result), id)) in chosen.iter().zip(&ids).enumerate() {
        progress(i, chosen.len());
        let dir = replays.join(id);
        let (manifest, bytes) = draw(plan, *job, result, id, &dir, opts)?;
        summary.frames += u64::from(manifest.frames);
        summary.bytes += bytes;
        *summary.per_kind.entry(*kind).or_default() += 1;
        let agent = &plan.agents[plan.cells[job.cell].agent];
        key.replays.insert(
            id.clone(),
            KeyEntry {
                agent: agent.name.clone(),
                kind: *kind,
                scenario: result.cell.scenario.clone(),
                against: result.cell.against.clone(),
                seed: result.seed,
                result: result.result.map(avacraft_engine::Outcome::name).unwrap_or_default().to_owned(),
                trajectory_hash: result.trajectory_hash.clone(),
            },
        );
    }
    progress(chosen.len(), chosen.len());
    summary.replays = chosen.len();
    write_json(&opts.out.join(KEY_FILE), &key)?;
    // Written last: a folder with a study.json is a complete study.
    write_json(&opts.out.join(STUDY_FILE), &Study { version: 1, replays: ids })?;
    Ok(summary)
}

/// Re-plays one episode into `dir` (frames and manifest); refuses a re-play that diverged.
fn draw(plan: &Plan, job: Job, result: &EpisodeResult, id: &str, dir: &Path, opts: &PackOptions) -> Result<(Manifest, u64), HumanError> {
    let episode = format!("{} seed {}", result.cell, result.seed);
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut frames = FrameBuilder::new();
    let mut backend = CpuBackend::new();
    let (mut n, mut bytes, mut step_mul) = (0u32, 0u64, 0u32);
    let mut failure: Option<HumanError> = None;
    let replayed = crate::replay_job(plan, job, &opts.eval, &mut |env: &Env| {
        if failure.is_some() {
            return;
        }
        step_mul = env.config().step_mul.get();
        let scene = frames.vlm(env.world(), Team::One, opts.width, opts.height, &VlmOptions::default());
        let img = backend.render(&scene);
        let path = dir.join(format!("{n:06}.png"));
        match img.save(&path) {
            Ok(()) => {
                bytes += std::fs::metadata(&path).map_or(0, |m| m.len());
                n += 1;
            }
            Err(source) => failure = Some(HumanError::Image { path, source }),
        }
    });
    if let Some(e) = failure {
        return Err(e);
    }
    let replayed = replayed.map_err(|source| HumanError::Replay { episode: episode.clone(), source: Box::new(source) })?;
    if replayed.trajectory_hash != result.trajectory_hash {
        // Remove what was drawn: these frames show another game than the one rated.
        let _ = std::fs::remove_dir_all(dir);
        return Err(HumanError::Diverged { episode, recorded: result.trajectory_hash.clone(), replayed: replayed.trajectory_hash });
    }
    let manifest = Manifest {
        id: id.to_owned(),
        frames: n,
        width: opts.width,
        height: opts.height,
        step_seconds: f64::from(step_mul) / f64::from(LOOPS_PER_SECOND),
    };
    write_json(&dir.join(MANIFEST_FILE), &manifest)?;
    Ok((manifest, bytes))
}
