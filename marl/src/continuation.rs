//! A run going on under other settings (a training plan's `from`): kept apart from
//! [`crate::resume`], which the trainers' loops use, because it builds both kinds of learner.

use crate::learner::Learner;
use crate::{Config, Error, resume};
use std::path::Path;

/// Prepares the run in `dir`, a copy of a finished run, to go on under other settings `cfg` (a
/// training plan's `from`; `cfg` resolved for `scenario`). What was kept for the old settings
/// goes: the episodes under way and the replay buffer (the continuation starts fresh episodes
/// on seeds past the ones played, and a Q-learner fills a new buffer), and the optimiser's
/// moments when the optimiser changes. The checkpoint then takes `cfg`, and the networks,
/// target networks, critic and moments are loaded as a resume loads them. Refused, the
/// checkpoint's config left as it was, where they do not fit: another game size (observation,
/// actions, agents) or another network (meant for a copy: what went stays gone).
pub fn continue_as(dir: &Path, cfg: &Config, scenario: &std::sync::Arc<avacraft_engine::Scenario>) -> Result<(), Error> {
    // Not while another process trains there: what follows deletes its buffer and carry.
    let _lock = crate::lock::RunLock::acquire(dir)?;
    let (saved, state) = resume::load(dir)?;
    let old = crate::Policy::load(dir)?.shape;
    // The game's sizes do not depend on who plays team 2; a snapshot pool does not exist yet.
    let sizes = Config { opponent: crate::Opponent::Idle, ..cfg.clone() };
    let shape = crate::evaluation::shape_of(&sizes, scenario)?;
    if shape != old {
        return Err(Error::Checkpoint {
            message: format!("{}: trained on a game of {old:?}; these settings play one of {shape:?}", dir.display()),
        });
    }
    let d = state.files(dir);
    let gone = |path: std::path::PathBuf| -> Result<(), Error> {
        let r = if path.is_dir() { std::fs::remove_dir_all(&path) } else { std::fs::remove_file(&path) };
        match r {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::Io { path, source: e }),
            _ => Ok(()),
        }
    };
    gone(d.join(crate::carry::FILE))?;
    gone(dir.join("resume").join("buffer"))?;
    if saved.optimizer != cfg.optimizer {
        gone(d.join(resume::OPTIM_FILE))?;
    }
    crate::checkpoint::restate(dir, cfg)?;
    let fits = if cfg.is_ppo() {
        crate::ppo::PpoLearner::new(cfg, shape, state.seed).and_then(|mut l| crate::ppo::restore(dir, &mut l, &state))
    } else {
        Learner::new(cfg, shape, state.seed).and_then(|mut l| resume::restore(dir, &mut l, &state))
    };
    if let Err(e) = fits {
        crate::checkpoint::restate(dir, &saved)?;
        return Err(e);
    }
    Ok(())
}
