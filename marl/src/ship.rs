//! Shipping a trained run: its best checkpoint's agent network (and its last one's), config,
//! log and curves, into `baselines/` under a size budget, read back before it replaces what was
//! there.

use crate::Error;
use crate::checkpoint::Policy;
use candle_core::Tensor;
use std::path::Path;

/// What [`ship`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shipped {
    /// Bytes of everything but the curves (the checkpoint, its config and the log).
    pub bytes: u64,
    /// Whether the weights that play (`best/`'s, else the last's) were stored as 16-bit floats
    /// to fit the budget.
    pub half: bool,
    /// Whether the last checkpoint's, in `last/`, were.
    pub last_half: bool,
}

/// The shipped curves' width and height: the training run's 900x900 PNG took about 450 kB, so
/// 42 runs' curves alone would have come near the 25 MB all baselines may take.
const SHIPPED_CURVES_SIZE: u32 = 600;

/// `from` scaled to at most `size` pixels a side and written with the PNG encoder's best
/// compression.
fn small_png(from: &Path, to: &Path, size: u32) -> Result<(), Error> {
    let bad = |e: image::ImageError| Error::Plot { message: format!("{}: {e}", from.display()) };
    let img = image::open(from).map_err(bad)?.into_rgb8();
    let (w, h) = img.dimensions();
    let scale = (size as f32 / w.max(h) as f32).min(1.0);
    let (nw, nh) = (((w as f32 * scale).round() as u32).max(1), ((h as f32 * scale).round() as u32).max(1));
    let img = image::imageops::resize(&img, nw, nh, image::imageops::FilterType::Triangle);
    let file = std::fs::File::create(to).map_err(|source| Error::Io { path: to.to_path_buf(), source })?;
    let enc = image::codecs::png::PngEncoder::new_with_quality(
        std::io::BufWriter::new(file),
        image::codecs::png::CompressionType::Best,
        image::codecs::png::FilterType::Adaptive,
    );
    img.write_with_encoder(enc).map_err(bad)
}

/// A plan's run folder is `<run>-s<seed>`.
fn seed_of(run: &Path) -> Option<u64> {
    let name = run.file_name()?.to_str()?;
    name.rsplit_once("-s").and_then(|(_, s)| s.parse().ok())
}

/// The run folder a plan trained the shipped copy `shipped` in (`<run>-s<seed>`): the copy's
/// folder drops the seed when it is 1.
fn run_folder(shipped: &Path, seed: u64) -> std::path::PathBuf {
    let name = shipped.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let run = name.strip_suffix(&format!("-s{seed}")).unwrap_or(name);
    shipped.with_file_name(format!("{run}-s{seed}"))
}

/// `dir/log.csv` drawn as the training run's figure into `to`, at the shipped size.
fn draw_from_log(dir: &Path, title: &str, to: &Path) -> Result<(), Error> {
    let (points, vs) = crate::runlog::curve_points(dir)?;
    let full = to.with_extension("full.png");
    crate::plot::curves(&full, title, &points, &vs)?;
    let small = small_png(&full, to, SHIPPED_CURVES_SIZE);
    let _ = std::fs::remove_file(&full);
    small
}

/// A shipped run's figure drawn again from its shipped log (the run's own folder gone):
/// `seed` is the plan's, which a seed-1 copy's folder does not name. Written beside the old
/// figure and renamed over it, so a failure leaves the old one. False where the copy has no
/// log.
pub fn redraw(shipped: &Path, seed: u64) -> Result<bool, Error> {
    if !shipped.join("log.csv").is_file() {
        return Ok(false);
    }
    let (algo, scenario) = Policy::algo_scenario_in(shipped)?;
    let title = crate::monitor::figure_title(&run_folder(shipped, seed), &algo, &scenario, Some(seed));
    let new = shipped.join("curves.new.png");
    draw_from_log(shipped, &title, &new)?;
    std::fs::rename(&new, shipped.join("curves.png")).map_err(|source| Error::Io { path: shipped.join("curves.png"), source })?;
    Ok(true)
}

/// Copies what plays a trained run in `run` (its `best/` checkpoint if it has one, else the
/// last) into `to`: the agent network's weights (the mixer and critic are not needed to act),
/// `config.json`, and the run's `log.csv` and `curves.png`; with a `best/` checkpoint, the last
/// one's weights and config too, in `last/`. Past `max_bytes` (curves aside) the last
/// checkpoint's weights are stored as 16-bit floats, then the best one's too (rounding can
/// change a greedy policy's games, so the one that plays keeps full precision as long as
/// it can); still past it, nothing is left half-written and the error names the run.
pub fn ship(run: &Path, to: &Path, max_bytes: u64) -> Result<Shipped, Error> {
    ship_under(run, to, max_bytes, None)
}

/// All shipped runs' size budget: the folder that holds them and the bytes it may take.
#[derive(Clone, Copy, Debug)]
pub struct Total<'a> {
    pub root: &'a Path,
    pub max_bytes: u64,
}

/// [`ship`], refusing (with nothing changed under `total.root`, the run `to` replaces left as
/// it was) a run that would take the folder past its budget: checked on the finished copy,
/// before it replaces anything.
pub fn ship_under(run: &Path, to: &Path, max_bytes: u64, total: Option<Total<'_>>) -> Result<Shipped, Error> {
    let ckpt = if run.join("best").join("config.json").is_file() { run.join("best") } else { run.to_path_buf() };
    // Loads as a check: a checkpoint that does not load is not shipped.
    let policy = Policy::load(&ckpt)?;
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    let tmp = to.with_extension("partial");
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(io(&tmp))?;
    std::fs::copy(ckpt.join("config.json"), tmp.join("config.json")).map_err(io(&ckpt.join("config.json")))?;
    if run.join("log.csv").is_file() {
        std::fs::copy(run.join("log.csv"), tmp.join("log.csv")).map_err(io(&run.join("log.csv")))?;
    }
    // Drawn again from the log, so a figure shows the plotting of the build that ships it
    // (a run that trained over several builds drew its last figure with the last one only).
    if run.join("log.csv").is_file() {
        let title = crate::monitor::figure_title(run, &policy.cfg.algo, &policy.scenario, seed_of(run));
        draw_from_log(run, &title, &tmp.join("curves.png"))?;
    } else if run.join("curves.png").is_file() {
        small_png(&run.join("curves.png"), &tmp.join("curves.png"), SHIPPED_CURVES_SIZE)?;
    }
    let weights = policy.nets.agent_params.to_map();
    let size_without_curves = |dir: &Path| -> u64 {
        ["agent.safetensors", "config.json", "log.csv"].iter().filter_map(|f| std::fs::metadata(dir.join(f)).ok()).map(|m| m.len()).sum()
    };
    // The run's last checkpoint too, where the best one is another (`baseline:NAME@last`):
    // a table can then show what training ended with beside the best of its tests.
    let last = (ckpt != run && run.join("config.json").is_file()).then(|| Policy::load(run)).transpose()?;
    let last_dir = tmp.join(crate::baselines::LAST_DIR);
    if last.is_some() {
        std::fs::create_dir_all(&last_dir).map_err(io(&last_dir))?;
        std::fs::copy(run.join("config.json"), last_dir.join("config.json")).map_err(io(&run.join("config.json")))?;
    }
    let last_weights = last.as_ref().map(|p| p.nets.agent_params.to_map());
    let size = |dir: &Path| size_without_curves(dir) + size_without_curves(&dir.join(crate::baselines::LAST_DIR));
    let write = |half: bool, last_half: bool| -> Result<(), Error> {
        let conv = |w: &std::collections::HashMap<String, Tensor>,
                    half: bool|
         -> Result<std::collections::HashMap<String, Tensor>, candle_core::Error> {
            w.iter().map(|(k, t)| Ok((k.clone(), if half { t.to_dtype(candle_core::DType::F16)? } else { t.clone() }))).collect()
        };
        candle_core::safetensors::save(&conv(&weights, half)?, tmp.join("agent.safetensors"))?;
        if let Some(w) = &last_weights {
            candle_core::safetensors::save(&conv(w, last_half)?, last_dir.join("agent.safetensors"))?;
        }
        Ok(())
    };
    let (mut half, mut last_half) = (false, false);
    write(half, last_half)?;
    for (h, lh) in [(false, true), (true, true)] {
        if size(&tmp) <= max_bytes {
            break;
        }
        (half, last_half) = (h, lh && last_weights.is_some());
        write(half, last_half)?;
    }
    let bytes = size(&tmp);
    if bytes > max_bytes {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(Error::Checkpoint {
            message: format!("{}: {bytes} bytes without the curves even in 16-bit floats, over the {max_bytes} allowed", run.display()),
        });
    }
    // The loaded copy must play: a shipped checkpoint is read back before it replaces one.
    Policy::load(&tmp)?;
    if last.is_some() {
        Policy::load(&last_dir)?;
    }
    if let Some(total) = total {
        // What the root holds once the copy replaces `to`: the copy counted once (it sits
        // beside `to`, so usually under the root already), the run it replaces not at all.
        let within = |p: &Path| p.starts_with(total.root);
        let staged = dir_bytes(&tmp)?;
        let held = dir_bytes(total.root)?;
        let replaced = if within(to) { dir_bytes(to)? } else { 0 };
        let after = held.saturating_sub(replaced).saturating_sub(if within(&tmp) { staged } else { 0 }) + staged;
        if after > total.max_bytes {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(Error::Checkpoint {
                message: format!(
                    "{}: shipping it, {} would hold {after} bytes, over the {} allowed for shipped runs (nothing changed)",
                    run.display(),
                    total.root.display(),
                    total.max_bytes
                ),
            });
        }
    }
    let _ = std::fs::remove_dir_all(to);
    std::fs::rename(&tmp, to).map_err(io(to))?;
    Ok(Shipped { bytes, half, last_half })
}

/// Bytes of the files under `dir` (0 if it does not exist).
pub fn dir_bytes(dir: &Path) -> Result<u64, Error> {
    if !dir.exists() {
        return Ok(0);
    }
    let io = |source| Error::Io { path: dir.to_path_buf(), source };
    let mut total = 0;
    for e in std::fs::read_dir(dir).map_err(io)? {
        let e = e.map_err(io)?;
        let ty = e.file_type().map_err(io)?;
        total += if ty.is_dir() { dir_bytes(&e.path())? } else { e.metadata().map_err(io)?.len() };
    }
    Ok(total)
}
