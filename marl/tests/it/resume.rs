//! A run killed and resumed writes the log the uninterrupted run writes, row for row (elapsed
//! time aside), for QMIX and MAPPO. A kill loses what came after the last test round (the
//! state a resume starts from, and the log rows past it, which the resume drops), so stopping
//! a run right after a test round and going on from its state is what a kill anywhere between
//! that round and the next amounts to.

use avacraft_engine::Scenario;
use avacraft_marl::{Config, RunOptions, train, train_from};
use std::path::{Path, PathBuf};
use std::sync::Arc;

type R = Result<(), Box<dyn std::error::Error>>;

/// The log's rows without the elapsed-seconds column.
fn rows(dir: &Path) -> Result<Vec<String>, std::io::Error> {
    let text = std::fs::read_to_string(dir.join("log.csv"))?;
    Ok(text.lines().map(|l| l.rsplit_once(',').map_or(l, |(head, _)| head).to_owned()).collect())
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("avacraft-resume-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn killed_and_resumed_runs_write_the_uninterrupted_log(name: &str, algo: &str, scenario: &str, extra: &[&str], kills: &[usize]) -> R {
    let mut o: Vec<String> = vec!["test_nepisode=4".into(), "test_interval=200".into()];
    o.extend(extra.iter().map(|s| s.to_string()));
    let full = Config::for_algo(algo, &o)?;
    let scenario = Arc::new(Scenario::load(scenario)?);
    let dir = scratch(&format!("{name}-full"));
    let opts = RunOptions { scenario: Arc::clone(&scenario), seed: 3, threads: 2, out: Some(dir.clone()) };
    let (_, whole) = train(&full, &opts, &mut |_| {})?;
    let want = rows(&dir)?;
    assert!(!dir.join("resume/buffer").exists(), "a finished run keeps no replay journal");
    assert_eq!(want.len(), 1 + whole.tests.len());
    // The steps of the full run's test rounds picked by `kills` (indices of its rounds).
    let steps: Vec<u64> = want[1..].iter().filter_map(|r| r.split(',').next()?.parse().ok()).collect();
    let kill_steps: Vec<u64> = kills.iter().filter_map(|&i| steps.get(i).copied()).collect();
    assert_eq!(kill_steps.len(), kills.len(), "{algo}: every kill falls on one of the {} test rounds", steps.len());
    for k in kill_steps {
        let kdir = scratch(&format!("{name}-{k}"));
        let opts = RunOptions { out: Some(kdir.clone()), ..opts.clone() };
        // Killed right after the test round of step k (the progress callback comes after the
        // round's checkpoint; a panic stops the run there, as a kill would)...
        let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            train(&full, &opts, &mut |p| assert!(p.t_env < k || p.last_test.is_none(), "killed at {k}"))
        }));
        assert!(killed.is_err(), "{algo}: the run was to be killed at {k}");
        let (_, state) = avacraft_marl::resume::load(&kdir)?;
        // ... and gone on from its state, with one threads count less: nothing depends on it.
        let opts = RunOptions { threads: 1, ..opts };
        let (_, resumed) = train_from(&full, &opts, Some(state), &mut |_| {})?;
        assert_eq!(rows(&kdir)?, want, "{algo} stopped at {k}: the resumed log differs");
        assert_eq!(
            (resumed.episodes, resumed.updates, resumed.last_loss),
            (whole.episodes, whole.updates, whole.last_loss),
            "{algo} at {k}"
        );
        // Resumed once its run is over (killed after the last test round): nothing more.
        let (_, state) = avacraft_marl::resume::load(&kdir)?;
        train_from(&full, &opts, Some(state), &mut |_| {})?;
        assert_eq!(rows(&kdir)?, want, "{algo} resumed after its end");
        let _ = std::fs::remove_dir_all(&kdir);
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn a_killed_and_resumed_mappo_run_writes_the_uninterrupted_log() -> R {
    // Rollouts of 8 x 30 steps and a test round every 100: the kills fall inside rollouts,
    // and some test rounds come before the resumed run's first update.
    let extra = ["t_max=1200", "envs=8", "rollout_len=30", "episode_limit=25", "test_interval=100"];
    killed_and_resumed_runs_write_the_uninterrupted_log("mappo", "mappo", "2s3z", &extra, &[1, 4, 9])
}

/// With stacked frames (`stacked_frames`) a resume inside a rollout also puts back each row's
/// last observations and each environment's last states.
#[test]
fn a_killed_and_resumed_frame_stacking_mappo_run_writes_the_uninterrupted_log() -> R {
    let extra = ["t_max=1200", "envs=8", "rollout_len=30", "episode_limit=25", "test_interval=100", "stacked_frames=3", "use_rnn=false"];
    killed_and_resumed_runs_write_the_uninterrupted_log("mappo-stacked", "mappo", "2s3z", &extra, &[1, 4])
}

#[test]
fn a_killed_and_resumed_qmix_run_writes_the_uninterrupted_log() -> R {
    // A buffer smaller than the episodes played, so it has wrapped when resumed.
    let extra = ["t_max=1400", "envs=4", "batch_size=8", "buffer_size=40", "epsilon_anneal_time=600", "episode_limit=25"];
    killed_and_resumed_runs_write_the_uninterrupted_log("qmix", "qmix", "3m", &extra, &[0, 3, 5])
}

/// A run given other settings (a plan's run going on from another) resumes under them;
/// settings its networks or game sizes do not fit are refused, the checkpoint left as it was.
#[test]
fn a_checkpoint_takes_other_settings_its_weights_fit() -> R {
    let small = ["t_max=200", "envs=2", "batch_size=4", "test_interval=200", "test_nepisode=2", "episode_limit=25"];
    let cfg = Config::for_algo("vdn", &small.map(String::from))?;
    let scenario = Arc::new(Scenario::load("3m")?);
    let dir = scratch("restate");
    let opts = RunOptions { scenario, seed: 3, threads: 1, out: Some(dir.clone()) };
    train(&cfg, &opts, &mut |_| {})?;
    let before = std::fs::read_to_string(dir.join("config.json"))?;
    let scenario = Arc::clone(&opts.scenario);
    // Another network, another game size (the ability slots): refused, the checkpoint kept.
    for other in ["rnn_hidden_dim=32", "ability_actions=true"] {
        let c = cfg.overridden(&[other.into()])?;
        let err = avacraft_marl::continuation::continue_as(&dir, &c, &scenario).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(!err.is_empty(), "{other} was taken");
        assert_eq!(std::fs::read_to_string(dir.join("config.json"))?, before, "{other}: a refused config leaves the checkpoint");
    }
    let slower = cfg.overridden(&["lr=0.0001".into(), "t_max=400".into(), "optimizer=\"adam\"".into()])?;
    avacraft_marl::continuation::continue_as(&dir, &slower, &scenario)?;
    let (saved, state) = avacraft_marl::resume::load(&dir)?;
    assert!(!state.files(&dir).join("optim.safetensors").exists(), "another optimiser starts afresh");
    assert_eq!(saved, slower);
    let (_, summary) = train_from(&slower, &opts, Some(state), &mut |_| {})?;
    assert_eq!(summary.t_env, 400);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// A run killed right after its test round at step 200 (the second), with its config and
/// options: what the test below changes.
fn killed_run(algo: &str, extra: &[&str], name: &str) -> Result<(Config, RunOptions, PathBuf), Box<dyn std::error::Error>> {
    let mut o: Vec<String> = vec!["test_nepisode=2".into(), "test_interval=100".into(), "episode_limit=25".into()];
    o.extend(extra.iter().map(|s| s.to_string()));
    let cfg = Config::for_algo(algo, &o)?;
    let dir = scratch(name);
    let opts = RunOptions { scenario: Arc::new(Scenario::load("3m")?), seed: 5, threads: 1, out: Some(dir.clone()) };
    let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| train(&cfg, &opts, &mut |p| assert!(p.t_env < 200, "killed"))));
    assert!(killed.is_err(), "{algo}: the run was to be killed");
    Ok((cfg, opts, dir))
}

/// The run's carry: where its state says.
fn carry(dir: &Path) -> Result<PathBuf, Box<dyn std::error::Error>> {
    Ok(avacraft_marl::resume::load(dir)?.1.files(dir).join("carry.safetensors"))
}

/// Replaces the array `name` of the run's carry with `f` of it.
fn change_carry(dir: &Path, name: &str, f: impl Fn(Vec<u32>) -> Vec<u32>) -> R {
    let path = carry(dir)?;
    let mut map = candle_core::safetensors::load(&path, &candle_core::Device::Cpu)?;
    let old: Vec<u32> = map.get(name).ok_or(format!("no {name} in the carry"))?.to_vec1()?;
    let new = f(old);
    let n = new.len();
    map.insert(name.into(), candle_core::Tensor::from_vec(new, n, &candle_core::Device::Cpu)?);
    candle_core::safetensors::save(&map, &path)?;
    Ok(())
}

fn resume_error(cfg: &Config, opts: &RunOptions, dir: &Path) -> Result<String, Box<dyn std::error::Error>> {
    let (_, state) = avacraft_marl::resume::load(dir)?;
    Ok(train_from(cfg, opts, Some(state), &mut |_| {}).err().map(|e| e.to_string()).unwrap_or_default())
}

/// A resume's files changed after the kill (a cut, an edit, a flipped word) are refused with
/// an error naming what does not fit, where they used to panic deep in a batch or a kernel.
#[test]
fn a_resume_whose_files_were_changed_is_refused_with_what_does_not_fit() -> R {
    let extra = ["t_max=600", "envs=4", "rollout_len=40"];
    let (cfg, opts, dir) = killed_run("mappo", &extra, "bad-mappo")?;
    // The state's round folder is named by the state: a name out of `resume/` is refused.
    let path = dir.join("resume/state.json");
    let kept = std::fs::read_to_string(&path)?;
    for bad in ["../../elsewhere", "round-", "round-12x", ""] {
        let mut json: serde_json::Value = serde_json::from_str(&kept)?;
        json["files"] = serde_json::Value::from(bad);
        std::fs::write(&path, serde_json::to_string(&json)?)?;
        let err = avacraft_marl::resume::load(&dir).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(err.contains("`files`") && err.contains("state.json"), "{bad:?}: {err:?}");
    }
    std::fs::write(&path, kept)?;
    change_carry(&dir, "roll.actions", |mut v| {
        v[0] = 999;
        v
    })?;
    let err = resume_error(&cfg, &opts, &dir)?;
    assert!(err.contains("roll.actions") && err.contains("999"), "mappo, an action out of range: {err:?}");
    change_carry(&dir, "roll.actions", |mut v| {
        v.truncate(v.len() - 1);
        v
    })?;
    let err = resume_error(&cfg, &opts, &dir)?;
    assert!(err.contains("roll.actions"), "mappo, a short rollout: {err:?}");
    // Killed 10 steps into a rollout (4 envs, step 200, rollouts of 160): a resume with
    // rollouts of 10 steps would never end the one under way. Refused.
    let shorter = cfg.overridden(&["rollout_len=10".into()])?;
    let err = resume_error(&shorter, &opts, &dir)?;
    assert!(err.contains("rollout_len"), "mappo, rollout_len cut: {err:?}");
    let _ = std::fs::remove_dir_all(&dir);

    let extra = ["t_max=600", "envs=4", "batch_size=4", "buffer_size=40", "epsilon_anneal_time=300"];
    let (cfg, opts, dir) = killed_run("qmix", &extra, "bad-qmix")?;
    // The journal keeps each episode as its actions, a byte each, then an 8-byte digest: the
    // segment's last episode's last action is 9 bytes from its end.
    let seg = std::fs::read_dir(dir.join("resume/buffer"))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("seg-")))
        .min()
        .ok_or("no journal segment")?;
    let kept = std::fs::read(&seg)?;
    let mut bytes = kept.clone();
    let end = bytes.len();
    bytes[end - 9] = 200;
    std::fs::write(&seg, &bytes)?;
    let err = resume_error(&cfg, &opts, &dir)?;
    assert!(err.contains("200") && err.contains("episode"), "qmix, a journal's action out of range: {err:?}");
    // Its digest changed: the episode replays, but not to what was kept.
    let mut bytes = kept;
    bytes[end - 1] ^= 0x40;
    std::fs::write(&seg, &bytes)?;
    let err = resume_error(&cfg, &opts, &dir)?;
    assert!(err.contains("plays otherwise") && err.contains("resume/buffer"), "qmix, a journal's digest changed: {err:?}");
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// A resume under another game (`--set` changed a rule) does not replay the kept episodes into
/// it: it goes on exactly as a resume whose carry and journal are gone (fresh episodes, a new
/// buffer), for QMIX and MAPPO.
#[test]
fn a_resume_under_another_game_goes_on_from_fresh_episodes() -> R {
    for (algo, extra) in [
        ("qmix", &["t_max=400", "envs=4", "batch_size=4", "buffer_size=40"][..]),
        ("mappo", &["t_max=400", "envs=4", "rollout_len=40"][..]),
    ] {
        let (cfg, opts, dir) = killed_run(algo, extra, &format!("game-{algo}"))?;
        let other = cfg.overridden(&["melee_surround=true".into()])?;
        assert!(!cfg.same_game(&other) && cfg.same_game(&cfg.overridden(&["lr=0.001".into()])?), "{algo}");
        assert!(carry(&dir)?.is_file(), "{algo}: the killed run kept its episodes");
        let fresh = scratch(&format!("game-{algo}-fresh"));
        copy(&dir, &fresh)?;
        std::fs::remove_file(carry(&fresh)?)?;
        let _ = std::fs::remove_dir_all(fresh.join("resume/buffer"));
        let mut logs = Vec::new();
        for d in [&dir, &fresh] {
            let (_, state) = avacraft_marl::resume::load(d)?;
            let o = RunOptions { out: Some(d.clone()), ..opts.clone() };
            train_from(&other, &o, Some(state), &mut |_| {})?;
            logs.push(rows(d)?);
        }
        assert_eq!(logs[0], logs[1], "{algo}: the resume under another game kept its episodes");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&fresh);
    }
    Ok(())
}

/// A resume under another game killed inside its first checkpoint (the checkpoint's config
/// then the new game's, the state still the round before's) resumes under the new game again
/// from fresh episodes, not from the round's episodes of the old game: the same log as the
/// resume under the new game that was not killed.
#[test]
fn a_resume_under_another_game_killed_inside_its_checkpoint_still_starts_fresh() -> R {
    for (algo, extra) in SMALL {
        let (cfg, opts, dir) = killed_run(algo, extra, &format!("game-mid-{algo}"))?;
        let other = cfg.overridden(&["melee_surround=true".into()])?;
        let straight = uninterrupted(&other, &opts, &dir, &format!("game-mid-{algo}-straight"))?;

        let o = RunOptions { out: Some(dir.clone()), ..opts.clone() };
        killed_inside_checkpoint(&other, &o)?;
        let (saved, state) = avacraft_marl::resume::load(&dir)?;
        assert!(saved.melee_surround, "{algo}: the checkpoint took the new game's config");
        train_from(&other, &o, Some(state), &mut |_| {})?;
        assert_eq!(rows(&dir)?, rows(&straight)?, "{algo}: the round's episodes of the old game were replayed");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&straight);
    }
    Ok(())
}

/// Resumes the run in `o.out` under `cfg` with a folder in the way of its state's write: the
/// next test round's checkpoint writes everything but `state.json`, as a kill there would
/// leave it.
fn killed_inside_checkpoint(cfg: &Config, o: &RunOptions) -> R {
    let dir = o.out.clone().ok_or("a run folder")?;
    let blocker = dir.join("resume/state.json.tmp");
    std::fs::create_dir_all(blocker.join("x"))?;
    let (_, state) = avacraft_marl::resume::load(&dir)?;
    let err = train_from(cfg, o, Some(state), &mut |_| {}).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err.contains("state.json"), "{}: the checkpoint was to fail at its state: {err:?}", cfg.algo);
    std::fs::remove_dir_all(&blocker)?;
    Ok(())
}

/// Two small runs (the Q-learners' and PPO's loops) the checkpoint tests below kill.
const SMALL: [(&str, &[&str]); 2] =
    [("qmix", &["t_max=400", "envs=4", "batch_size=4", "buffer_size=40"]), ("mappo", &["t_max=400", "envs=4", "rollout_len=20"])];

/// A copy of the killed run in `dir` resumed under `cfg` to its end without a kill: what a
/// resume after any kill is to write.
fn uninterrupted(cfg: &Config, opts: &RunOptions, dir: &Path, name: &str) -> Result<PathBuf, Box<dyn std::error::Error>> {
    let copied = scratch(name);
    copy(dir, &copied)?;
    let (_, state) = avacraft_marl::resume::load(&copied)?;
    train_from(cfg, &RunOptions { out: Some(copied.clone()), ..opts.clone() }, Some(state), &mut |_| {})?;
    Ok(copied)
}

fn copy(from: &Path, to: &Path) -> R {
    std::fs::create_dir_all(to)?;
    for e in std::fs::read_dir(from)? {
        let e = e?;
        if e.file_type()?.is_dir() {
            copy(&e.path(), &to.join(e.file_name()))?;
        } else {
            std::fs::copy(e.path(), to.join(e.file_name()))?;
        }
    }
    Ok(())
}

/// A run that once went on from fresh episodes (its carry and journal gone) seeds its
/// environments past the episodes it had played. Killed again later, it resumes exactly, from
/// the seeds it then had: its log is the one it writes uninterrupted after the fresh start.
/// (The Q-learner's buffer is small enough that the journal holds all of it by the kill, so the
/// kept episodes are played again.)
#[test]
fn a_run_that_went_on_from_fresh_episodes_resumes_exactly_later() -> R {
    for (algo, extra, kill) in [
        // The journal started after the fresh start holds whole segments of episodes (64
        // each): by the kill it holds the buffer.
        ("qmix", &["t_max=3000", "envs=4", "batch_size=4", "buffer_size=20"][..], 2600),
        ("mappo", &["t_max=800", "envs=4", "rollout_len=40"][..], 600),
    ] {
        let (cfg, opts, dir) = killed_run(algo, extra, &format!("fresh-{algo}"))?;
        std::fs::remove_file(carry(&dir)?)?;
        let _ = std::fs::remove_dir_all(dir.join("resume/buffer"));
        let once = scratch(&format!("fresh-{algo}-once"));
        copy(&dir, &once)?;
        let (_, state) = avacraft_marl::resume::load(&once)?;
        train_from(&cfg, &RunOptions { out: Some(once.clone()), ..opts.clone() }, Some(state), &mut |_| {})?;
        let o = RunOptions { out: Some(dir.clone()), ..opts.clone() };
        let (_, state) = avacraft_marl::resume::load(&dir)?;
        let killed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            train_from(&cfg, &o, Some(state), &mut |p| assert!(p.t_env < kill || p.last_test.is_none(), "killed"))
        }));
        assert!(killed.is_err(), "{algo}: the run was to be killed at {kill}");
        let (_, state) = avacraft_marl::resume::load(&dir)?;
        assert!(state.seed_offset > 0 && carry(&dir)?.is_file(), "{algo}: {}", state.seed_offset);
        if algo == "qmix" {
            let segs = std::fs::read_dir(dir.join("resume/buffer"))?.count();
            assert!(segs >= 1 && state.episodes >= 64 + 20, "{algo}: {} episodes, {segs} segments", state.episodes);
        }
        train_from(&cfg, &o, Some(state), &mut |_| {})?;
        assert_eq!(rows(&dir)?, rows(&once)?, "{algo}: the second resume differs from the run after the fresh start");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&once);
    }
    Ok(())
}

/// A run killed inside a test round's checkpoint (its weights, optimiser, targets, carry and
/// journal written, its state not: here a folder in the way of `state.json`'s write stops it
/// there) resumes from the round before, all of whose files it kept, and writes the
/// uninterrupted log, for QMIX and MAPPO. (Its checkpoint's weights were the newer round's, and
/// the resume used to read them with the older state.)
#[test]
fn a_run_killed_inside_a_checkpoint_resumes_from_the_round_before() -> R {
    for (algo, extra) in SMALL {
        let (cfg, opts, dir) = killed_run(algo, extra, &format!("mid-{algo}"))?;
        let whole = uninterrupted(&cfg, &opts, &dir, &format!("mid-{algo}-whole"))?;

        let (_, before) = avacraft_marl::resume::load(&dir)?;
        let o = RunOptions { out: Some(dir.clone()), ..opts.clone() };
        killed_inside_checkpoint(&cfg, &o)?;
        let (_, state) = avacraft_marl::resume::load(&dir)?;
        assert_eq!(state, before, "{algo}: the state is the round before's");
        assert_ne!(
            std::fs::read(dir.join("agent.safetensors"))?,
            std::fs::read(state.files(&dir).join("agent.safetensors"))?,
            "{algo}: the checkpoint moved on a round"
        );
        train_from(&cfg, &o, Some(state), &mut |_| {})?;
        assert_eq!(rows(&dir)?, rows(&whole)?, "{algo}: the resume after a kill inside a checkpoint differs");
        let rounds =
            std::fs::read_dir(dir.join("resume"))?.flatten().filter(|e| e.file_name().to_string_lossy().starts_with("round-")).count();
        assert_eq!(rounds, 1, "{algo}: the earlier rounds' folders are gone");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&whole);
    }
    Ok(())
}

/// A state written before rounds had folders (its files in `resume/`, the weights in the
/// checkpoint: the layout of runs kept from then) resumes as it did, exactly, and its next
/// round moves to the new layout.
#[test]
fn a_state_written_before_round_folders_resumes_exactly() -> R {
    for (algo, extra) in SMALL {
        let (cfg, opts, dir) = killed_run(algo, extra, &format!("flat-{algo}"))?;
        let whole = uninterrupted(&cfg, &opts, &dir, &format!("flat-{algo}-whole"))?;

        // The old layout: the round's files moved up into resume/, the state naming none.
        let (_, state) = avacraft_marl::resume::load(&dir)?;
        let round = state.files(&dir);
        for e in std::fs::read_dir(&round)?.flatten() {
            let name = e.file_name();
            // The round's `best/` pick came with round folders: the old layout had none.
            if name == "best" {
                std::fs::remove_dir_all(e.path())?;
            } else if !["agent.safetensors", "mixer.safetensors", "critic.safetensors"].contains(&name.to_string_lossy().as_ref()) {
                std::fs::rename(e.path(), dir.join("resume").join(&name))?;
            }
        }
        std::fs::remove_dir_all(&round)?;
        let path = dir.join("resume/state.json");
        let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path)?)?;
        json.as_object_mut().ok_or("state.json is an object")?.remove("files");
        json["format"] = serde_json::Value::from(1);
        std::fs::write(&path, serde_json::to_string(&json)?)?;
        let (_, flat) = avacraft_marl::resume::load(&dir)?;
        assert_eq!((flat.files.as_deref(), flat.files(&dir)), (None, dir.join("resume")), "{algo}");

        train_from(&cfg, &RunOptions { out: Some(dir.clone()), ..opts.clone() }, Some(flat), &mut |_| {})?;
        assert_eq!(rows(&dir)?, rows(&whole)?, "{algo}: the old layout's resume differs");
        let (_, after) = avacraft_marl::resume::load(&dir)?;
        assert!(after.files(&dir).join("agent.safetensors").is_file(), "{algo}: the next round has its folder");
        assert!(!dir.join("resume/carry.safetensors").exists(), "{algo}: the old layout's files are gone");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&whole);
    }
    Ok(())
}

/// A state read before another process trained on in the folder (the CLI reads it before the
/// trainer takes the run's lock) is refused once the lock is held, naming the change, and what
/// the other process wrote stays as it was.
#[test]
fn a_state_that_moved_on_before_the_lock_is_refused() -> R {
    let (algo, extra) = SMALL[0];
    let (cfg, opts, dir) = killed_run(algo, extra, "stale")?;
    let (_, stale) = avacraft_marl::resume::load(&dir)?;
    let (_, fresh) = avacraft_marl::resume::load(&dir)?;
    train_from(&cfg, &opts, Some(fresh), &mut |_| {})?;
    let (want, state) = (rows(&dir)?, avacraft_marl::resume::load(&dir)?.1);
    assert!(state.t_env > stale.t_env, "the other process trained on");
    let err = train_from(&cfg, &opts, Some(stale), &mut |_| {}).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err.contains("changed after it was read"), "{err:?}");
    assert_eq!((rows(&dir)?, avacraft_marl::resume::load(&dir)?.1), (want, state), "the other process's run is untouched");
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// A `best/` rewritten for a round its state does not have (the monitor picks it before the
/// round's state is written: a kill in between) or left half written is put back, as the
/// resume starts, to the pick of the state's round, which the round's folder keeps.
#[test]
fn a_resume_puts_back_the_best_checkpoint_its_round_picked() -> R {
    for (algo, extra) in SMALL {
        let (cfg, opts, dir) = killed_run(algo, extra, &format!("best-{algo}"))?;
        let whole = uninterrupted(&cfg, &opts, &dir, &format!("best-{algo}-whole"))?;
        let (_, state) = avacraft_marl::resume::load(&dir)?;
        let best = dir.join("best");
        let picked: Vec<Vec<u8>> =
            ["agent.safetensors", "config.json"].iter().map(|f| std::fs::read(best.join(f))).collect::<Result<_, _>>()?;
        // Replaced, as checkpoints write (the round's folder links the file being replaced).
        std::fs::remove_file(best.join("agent.safetensors"))?;
        std::fs::write(best.join("agent.safetensors"), b"a later round's weights")?;
        std::fs::remove_file(best.join("config.json"))?;
        // Stopped as soon as the resume has started, before it plays anything.
        let stopped =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| train_from(&cfg, &opts, Some(state), &mut |_| panic!("stopped"))));
        assert!(stopped.is_err(), "{algo}: the resume was to be stopped");
        let now: Vec<Vec<u8>> =
            ["agent.safetensors", "config.json"].iter().map(|f| std::fs::read(best.join(f))).collect::<Result<_, _>>()?;
        assert!(now == picked, "{algo}: best/ is not the round's pick");
        // Files that were the round's already (the mixer, the critic) leave no name aside.
        let left: Vec<String> = std::fs::read_dir(&best)?.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
        assert!(left.iter().all(|n| !n.ends_with(".tmp")), "{algo}: {left:?}");
        let (_, state) = avacraft_marl::resume::load(&dir)?;
        train_from(&cfg, &opts, Some(state), &mut |_| {})?;
        assert_eq!(std::fs::read(best.join("agent.safetensors"))?, std::fs::read(whole.join("best/agent.safetensors"))?, "{algo}");
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&whole);
    }
    Ok(())
}
