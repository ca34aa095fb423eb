//! Playing a plan: every job not already in the results file, on a pool of threads (one per
//! core unless told otherwise), each result appended the moment its episode ends. A job that
//! fails (an endpoint down, a replay that diverged, an agent that panicked) is written as a
//! failed result with the reason and played again on the next run; the others go on.

use crate::plan::{AgentDef, Cell, Job, Plan, Shard};
use crate::results::{Appender, EpisodeResult, ModelUse, ResultsError};
use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, EnvOptions, LOOPS_PER_SECOND, Outcome, Team};
use avacraft_policy::Calls;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// How to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// The evaluation's folder: `results.jsonl`, AVA's recordings under `ava/`.
    pub out: PathBuf,
    pub shard: Option<Shard>,
    /// Worker threads (0: one per core).
    pub threads: usize,
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RunStats {
    /// Jobs of this shard.
    pub planned: usize,
    /// Already in the results file.
    pub skipped: usize,
    pub played: usize,
    pub failed: usize,
}

/// Progress, as each job ends (for a progress bar).
pub trait Progress: Sync {
    fn start(&self, total: usize, skipped: usize);
    fn done(&self, result: &EpisodeResult);
}

/// Plays the plan's jobs of this shard that the results file lacks.
pub fn run(plan: &Plan, opts: &RunOptions, progress: &dyn Progress) -> Result<RunStats, ResultsError> {
    let path = opts.out.join(crate::RESULTS_FILE);
    let loaded = crate::results::read(&path)?;
    for why in &loaded.unreadable {
        tracing::warn!("skipping an unreadable result line: {why}");
    }
    let jobs = plan.jobs_in(opts.shard);
    let mut todo: Vec<Job> =
        jobs.iter().copied().filter(|j| !loaded.done.contains_key(&(plan.cells[j.cell].key.clone(), j.seed))).collect();
    models_last(plan, &mut todo);
    let mut stats = RunStats { planned: jobs.len(), skipped: jobs.len() - todo.len(), ..RunStats::default() };
    progress.start(jobs.len(), stats.skipped);
    let mut appender = Appender::open(&path)?;
    let threads = if opts.threads == 0 { std::thread::available_parallelism().map_or(1, |n| n.get()) } else { opts.threads };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| ResultsError::Io {
        path: path.clone(),
        what: "cannot start the worker threads",
        source: std::io::Error::other(e),
    })?;
    let (tx, rx) = std::sync::mpsc::channel::<EpisodeResult>();
    let mut write_error = None;
    // The workers take the jobs in `todo`'s order (rayon's parallel iterators would split it
    // in halves), each result sent the moment its episode ends.
    let next = AtomicUsize::new(0);
    std::thread::scope(|s| {
        s.spawn(|| {
            pool.scope(|ps| {
                for _ in 0..threads {
                    let (tx, next, todo) = (tx.clone(), &next, &todo);
                    ps.spawn(move |_| {
                        while let Some(job) = todo.get(next.fetch_add(1, Ordering::Relaxed)) {
                            drop(tx.send(play_job(plan, *job, &opts.out)));
                        }
                    });
                }
            });
            drop(tx);
        });
        for r in rx {
            if r.ok() {
                stats.played += 1;
            } else {
                stats.failed += 1;
            }
            if write_error.is_none()
                && let Err(e) = appender.append(&r)
            {
                write_error = Some(e);
            }
            progress.done(&r);
        }
    });
    match write_error {
        Some(e) => Err(e),
        None => Ok(stats),
    }
}

/// Puts the jobs that call a model (an AVA side with a local model or an endpoint) after the
/// others, each group in plan order. Why: a model's
/// episodes take minutes and a local model runs one answer at a time, so with them first the
/// thousands of scripted and MARL episodes waited behind them (35 minutes with nothing
/// written, on the paper's plan).
pub(crate) fn models_last(plan: &Plan, todo: &mut [Job]) {
    let calls_model = |a: usize| plan.agents[a].policy.ava_spec().is_some_and(|s| s.model.calls_model());
    todo.sort_by_key(|j| {
        let cell = &plan.cells[j.cell];
        calls_model(cell.agent) || cell.agent2.is_some_and(calls_model)
    });
}

/// Why an episode could not be played (recorded in its result, with its sources, as text).
#[derive(Debug, thiserror::Error)]
pub enum EpisodeError {
    #[error("{agent}: no recording of this episode under {}", dir.display())]
    NoRecording { agent: String, dir: PathBuf },
    #[error("{agent}: AVA ran without `record`, so its episodes cannot be replayed")]
    NotRecorded { agent: String },
    #[error("{agent}: 99 tries of this episode are recorded already")]
    TooManyTries { agent: String },
    #[error("{agent}")]
    Policy {
        agent: String,
        #[source]
        source: Box<avacraft_policy::PolicyError>,
    },
    #[error("AVA stopped: {0}")]
    Ava(String),
    #[error("{agent}: playing from rendered frames")]
    Frames {
        agent: String,
        #[source]
        source: avacraft_marl::Error,
    },
    #[error("the plan has no cell {0}")]
    NoCell(usize),
    #[error("the environment's options")]
    Options(#[from] avacraft_engine::BadOption),
}

/// Plays one job; never panics (a panicking agent becomes a failed result).
pub fn play_job(plan: &Plan, job: Job, out: &Path) -> EpisodeResult {
    let cell = &plan.cells[job.cell];
    let failed = |why: String| EpisodeResult { error: Some(why), ..EpisodeResult::blank(cell.key.clone(), job.seed) };
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| play(plan, cell, job.seed, out, None))) {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => failed(chain(&e)),
        Err(p) => {
            let msg = p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_owned())).unwrap_or_default();
            failed(format!("an agent panicked: {msg}"))
        }
    }
}

/// The folders an AVA side of an episode records in: the first try's, then `-try2`, ...
fn ava_dirs(out: &Path, agent: &str, cell: &Cell, seed: u64, team: Team) -> impl Iterator<Item = PathBuf> {
    let base =
        out.join("ava").join(agent).join(format!("{}-{}-seed{seed}-team{}", cell.key.scenario, slug(&cell.key.against), team.player()));
    (1..100).map(move |k| if k == 1 { base.clone() } else { PathBuf::from(format!("{}-try{k}", base.display())) })
}

/// One side's agents, and AVA's run when the side is AVA. Replaying, AVA answers from the
/// episode's recording (the last try's: the one that finished).
fn side(
    agent: &AgentDef,
    cell: &Cell,
    team: Team,
    seed: u64,
    out: &Path,
    replay: bool,
) -> Result<(AgentTeam, Option<Arc<avacraft_ava::AvaRun>>), EpisodeError> {
    let calls = match agent.policy.ava_spec() {
        // Replaying, AVA answers from the recording of the try that finished.
        Some(spec) if replay && spec.record.is_some() => {
            let Some(dir) = ava_dirs(out, &agent.name, cell, seed, team).take_while(|p| p.exists()).last() else {
                return Err(EpisodeError::NoRecording { agent: agent.name.clone(), dir: out.join("ava") });
            };
            Calls::Replay(dir)
        }
        Some(spec) if replay && spec.model.calls_model() => {
            return Err(EpisodeError::NotRecorded { agent: agent.name.clone() });
        }
        // Each episode records in its own folder (a failed one's is kept: a retry takes the
        // next free name).
        Some(spec) if !replay && spec.record.is_some() => match ava_dirs(out, &agent.name, cell, seed, team).find(|p| !p.exists()) {
            Some(dir) => Calls::In(dir),
            None => return Err(EpisodeError::TooManyTries { agent: agent.name.clone() }),
        },
        _ => Calls::Own,
    };
    let made = agent
        .policy
        .on(&cell.scenario)
        .and_then(|p| p.make(&calls, None))
        .map_err(|e| EpisodeError::Policy { agent: agent.name.clone(), source: Box::new(e) })?;
    let make = made.factory;
    Ok((AgentTeam::new(team, Grouping::Team, move || make()), made.run))
}

/// An error and its sources on one line (what `anyhow` prints with `{:#}`), for the
/// episode's record.
pub(crate) fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut src = e.source();
    while let Some(x) = src {
        s.push_str(": ");
        s.push_str(&x.to_string());
        src = x.source();
    }
    s
}

fn slug(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}

fn model_use(run: &avacraft_ava::AvaRun) -> ModelUse {
    let mut m = ModelUse::default();
    for e in run.episodes() {
        m.decisions += e.decisions;
        m.calls += e.total.calls;
        m.prompt_tokens += e.total.prompt_tokens;
        m.completion_tokens += e.total.completion_tokens;
        m.cost_usd += e.total.cost_usd;
        m.unpriced_calls += e.total.unpriced_calls;
        m.model_ms += e.total.latency_ms;
        m.failed_calls += e.total.failed_calls;
        m.fallbacks += e.fallbacks;
    }
    m
}

/// Plays a finished episode again, calling `on_step` with the environment before each step
/// and once after the last (to draw it); AVA answers from the episode's recording, so no
/// model is asked. The result's trajectory hash is the recorded one when all went well.
pub fn replay_job(plan: &Plan, job: Job, out: &Path, on_step: &mut dyn FnMut(&Env)) -> Result<EpisodeResult, EpisodeError> {
    let cell = plan.cells.get(job.cell).ok_or(EpisodeError::NoCell(job.cell))?;
    play(plan, cell, job.seed, out, Some(on_step))
}

fn play(plan: &Plan, cell: &Cell, seed: u64, out: &Path, mut on_step: Option<&mut dyn FnMut(&Env)>) -> Result<EpisodeResult, EpisodeError> {
    let replay = on_step.is_some();
    let options =
        EnvOptions { opponent: cell.opponent, ability_actions: plan.env.ability_actions || cell.ability_actions, ..plan.env.clone() };
    let cfg = options.config()?;
    let mut env = Env::new(Arc::clone(&cell.scenario), cfg, seed);
    let team1 = &plan.agents[cell.agent];
    let policy_err = |source| EpisodeError::Policy { agent: team1.name.clone(), source: Box::new(source) };
    let (mut run1, mut run2) = (None, None);
    // An image-mode checkpoint (PvE only: the plan refuses it elsewhere) acts on frames
    // rendered from the environment, which an engine agent is not handed.
    match team1.policy.frames_policy(&cell.scenario).map_err(policy_err)?.filter(|_| cell.agent2.is_none()) {
        Some(policy) => {
            let mut seen = |e: &Env| {
                if let Some(f) = on_step.as_mut() {
                    f(e);
                }
            };
            policy.play_out(&mut env, &mut seen).map_err(|source| EpisodeError::Frames { agent: team1.name.clone(), source })?;
        }
        None => {
            let (one, r1) = side(team1, cell, Team::One, seed, out, replay)?;
            let mut teams = vec![one];
            run1 = r1;
            if let Some(b) = cell.agent2 {
                let (two, r) = side(&plan.agents[b], cell, Team::Two, seed, out, replay)?;
                teams.push(two);
                run2 = r;
            }
            let mut controllers = Controllers::new(&cell.scenario, teams);
            controllers.reset(&env);
            while !env.done() {
                if let Some(f) = on_step.as_mut() {
                    f(&env);
                }
                controllers.act(&mut env);
                env.step();
            }
            if let Some(f) = on_step.as_mut() {
                f(&env);
            }
        }
    }
    for r in [&run1, &run2].into_iter().flatten() {
        if let Some(why) = r.fatal() {
            return Err(EpisodeError::Ava(why));
        }
    }
    let w = env.world();
    let per = |f: &dyn Fn(Team) -> f64| [f(Team::One), f(Team::Two)];
    let result = env.outcome().unwrap_or(Outcome::Draw);
    let damage = per(&|t| f64::from(w.stats(t).damage_dealt));
    let kills = per(&|t| f64::from(w.stats(t).kills));
    let left = per(&|t| w.alive(t).count() as f64);
    Ok(EpisodeResult {
        cell: cell.key.clone(),
        seed,
        result: Some(result),
        error: None,
        steps: env.steps(),
        game_seconds: f64::from(w.tick()) / f64::from(LOOPS_PER_SECOND),
        damage_dealt: damage,
        kills: kills.map(|k| k as u32),
        units_left: left.map(|k| k as u32),
        refused_actions: env.refused(),
        trajectory_hash: format!("{:016x}", env.trajectory_hash()),
        model: run1.as_deref().map(model_use),
        model2: run2.as_deref().map(model_use),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Episodes that call a model go after the rest, whichever team the model plays; the
    /// others keep the plan's order, and a synthetic AVA (no model) is not moved.
    #[test]
    fn jobs_that_call_a_model_go_last() {
        let text = r#"
name = "order"
scenarios = ["3m_vlm", "2s3z_vlm"]
seeds = [1, 2]
[[agents]]
name = "vlm"
policy = "ava"
kind = "vlm"
ava = { model = { kind = "openai", url = "http://127.0.0.1:9/v1", model = "m" } }
[[agents]]
name = "fake"
policy = "ava"
kind = "vlm"
ava = { model = { kind = "synthetic" } }
[[agents]]
name = "focus-fire"
policy = "focus-fire"
[[headtohead]]
scenarios = ["MMM_vs_MMM"]
agents = ["focus-fire"]
against = ["vlm"]
"#;
        let plan = crate::parse("order.toml", text, None).unwrap_or_else(|e| panic!("{e}"));
        let mut todo = plan.jobs();
        let before = todo.clone();
        models_last(&plan, &mut todo);
        let calls = |j: &Job| {
            let k = &plan.cells[j.cell].key;
            k.agent == "vlm" || k.against == "vlm"
        };
        let first_model = todo.iter().position(calls).unwrap_or_else(|| panic!("the plan has model jobs"));
        assert!(first_model > 0 && todo[first_model..].iter().all(calls), "{todo:?}");
        // Headtohead: the model on team 2 counts too.
        assert!(todo[first_model..].iter().any(|j| plan.cells[j.cell].key.against == "vlm"));
        let rest: Vec<Job> = before.iter().copied().filter(|j| !calls(j)).collect();
        assert_eq!(todo[..first_model], rest[..], "the others in plan order");
        assert!(rest.iter().any(|j| plan.cells[j.cell].key.agent == "fake"));
    }
}
