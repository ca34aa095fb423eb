//! A run's `log.csv` read back, and runs compared: learning curves of groups of runs (say,
//! the same config over seeds, old code against new) in one figure against environment steps
//! and against wall-clock seconds, and when each run first reached given win rates.
//!
//! The reader is strict about the columns it needs (a missing column or a number that does
//! not parse names the file, the line and the column) and ignores columns it does not know,
//! so logs of older builds with the same core columns still read.

use crate::Error;
use crate::plot::Png;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One row of a run's log: a test round.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogRow {
    pub t_env: u64,
    pub episodes: u64,
    pub updates: u64,
    /// Training episodes' win rate since the previous row (`NaN` when none ended).
    pub train_win_rate: f64,
    pub test_win_rate: f64,
    pub test_return: f64,
    /// Wall-clock seconds of training so far.
    pub elapsed_s: f64,
}

/// The columns the reader needs.
const NEEDED: [&str; 7] = ["t_env", "episodes", "updates", "train_win_rate", "test_win_rate", "test_return", "elapsed_s"];

fn bad(path: &Path, message: String) -> Error {
    Error::Observation { message: format!("{}: {message}", path.display()) }
}

/// Parses the text of a `log.csv` (`path` names it in errors).
pub fn parse_log(path: &Path, text: &str) -> Result<Vec<LogRow>, Error> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else { return Err(bad(path, "empty: no header line".into())) };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut at = [0usize; NEEDED.len()];
    for (slot, name) in at.iter_mut().zip(NEEDED) {
        *slot = cols.iter().position(|c| *c == name).ok_or_else(|| bad(path, format!("the header has no `{name}` column")))?;
    }
    let mut rows = Vec::new();
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(bad(path, format!("line {}: {} fields, the header has {}", i + 1, fields.len(), cols.len())));
        }
        let num = |k: usize| -> Result<f64, Error> {
            let text = fields[at[k]];
            text.parse::<f64>().map_err(|_| bad(path, format!("line {}: `{}` = `{text}` is not a number", i + 1, NEEDED[k])))
        };
        let count = |k: usize| -> Result<u64, Error> {
            let text = fields[at[k]];
            text.parse::<u64>().map_err(|_| bad(path, format!("line {}: `{}` = `{text}` is not a count", i + 1, NEEDED[k])))
        };
        rows.push(LogRow {
            t_env: count(0)?,
            episodes: count(1)?,
            updates: count(2)?,
            train_win_rate: num(3)?,
            test_win_rate: num(4)?,
            test_return: num(5)?,
            elapsed_s: num(6)?,
        });
    }
    Ok(rows)
}

/// Reads `dir/log.csv` (or a CSV file given directly).
pub fn read_log(path: &Path) -> Result<Vec<LogRow>, Error> {
    let file = if path.is_dir() { path.join("log.csv") } else { path.to_path_buf() };
    let text = std::fs::read_to_string(&file).map_err(|source| Error::Io { path: file.clone(), source })?;
    parse_log(&file, &text)
}

/// A run's `log.csv` as the points of its figure ([`crate::plot::curves`]) and the names of
/// its fixed test opponents (the `test_win_rate_vs_NAME` columns, in order): a shipped run's
/// figure is drawn again from its log. A log without the `loss` column draws no loss.
pub fn curve_points(path: &Path) -> Result<(Vec<crate::plot::CurvePoint>, Vec<String>), Error> {
    let file = if path.is_dir() { path.join("log.csv") } else { path.to_path_buf() };
    let text = std::fs::read_to_string(&file).map_err(|source| Error::Io { path: file.clone(), source })?;
    let rows = parse_log(&file, &text)?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let cols: Vec<&str> = lines.next().map(|h| h.split(',').map(str::trim).collect()).unwrap_or_default();
    let loss_at = cols.iter().position(|c| *c == "loss");
    let vs: Vec<(String, usize)> =
        cols.iter().enumerate().filter_map(|(i, c)| c.strip_prefix("test_win_rate_vs_").map(|n| (n.to_owned(), i))).collect();
    // `read_log` checked every line's field count; a field here that does not parse is a gap.
    let num = |fields: &[&str], i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(f64::NAN);
    let points = lines
        .zip(&rows)
        .map(|(line, r)| {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            crate::plot::CurvePoint {
                t_env: r.t_env,
                test_win_rate: r.test_win_rate,
                train_win_rate: r.train_win_rate.is_finite().then_some(r.train_win_rate),
                test_return: r.test_return,
                loss: loss_at.map_or(f64::NAN, |i| num(&fields, i)),
                vs: vs.iter().map(|(_, i)| num(&fields, *i)).collect(),
            }
        })
        .collect();
    Ok((points, vs.into_iter().map(|(n, _)| n).collect()))
}

/// A named group of runs (e.g. one code version over seeds).
#[derive(Clone, Debug)]
pub struct Group {
    pub name: String,
    pub runs: Vec<(PathBuf, Vec<LogRow>)>,
}

/// The first row at which a run's greedy test win rate is at least `test` and its training
/// win rate at least `train` (both on the same row).
pub fn first_reaching(rows: &[LogRow], test: f64, train: f64) -> Option<LogRow> {
    rows.iter().copied().find(|r| r.test_win_rate >= test && r.train_win_rate >= train)
}

const COLORS: [RGBColor; 20] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(127, 127, 127),
    RGBColor(0, 0, 128),
    RGBColor(0, 100, 0),
    RGBColor(128, 0, 0),
    RGBColor(230, 180, 0),
    RGBColor(40, 40, 40),
    // Picked to stand apart from the fifteen above (the generated hues past the palette
    // came back near its blue, red and green on SMAC's 23-map figure).
    RGBColor(200, 0, 200),
    RGBColor(75, 0, 130),
    RGBColor(110, 220, 0),
    RGBColor(0, 150, 130),
    RGBColor(250, 60, 150),
];

/// Series `i`'s colour: the palette's, then hues a golden angle apart (a figure with more
/// series than the palette no longer draws two of them alike, as it did when the index wrapped).
fn series_color(i: usize) -> RGBColor {
    if let Some(c) = COLORS.get(i) {
        return *c;
    }
    let k = (i - COLORS.len()) as f64;
    let RGBAColor(r, g, b, _) = HSLColor((k * 0.618_033_988_75 + 0.13).fract(), 0.75, 0.4 + 0.15 * (k % 2.0)).to_rgba();
    RGBColor(r, g, b)
}

/// Draws the groups' greedy test and training win rates against environment steps and
/// against wall-clock seconds (four panels; each run a thin line, each group's mean over its
/// runs a thick one) into `path` (PNG).
pub fn compare(path: &Path, title: &str, groups: &[Group]) -> Result<(), Error> {
    crate::plot::font()?;
    let err = crate::plot::err;
    let mut canvas = Png::new((1400, 900));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
        let panels = root.split_evenly((2, 2));
        let all = || groups.iter().flat_map(|g| g.runs.iter().flat_map(|(_, r)| r.iter()));
        let max_steps = all().map(|r| r.t_env).max().unwrap_or(1).max(1) as f64;
        let max_secs = all().map(|r| r.elapsed_s).fold(1.0, f64::max);
        type Pick = fn(&LogRow) -> f64;
        let specs: [(&str, Pick, &str, Pick, f64); 4] = [
            ("greedy test win rate", |r| r.test_win_rate, "environment steps", |r| r.t_env as f64, max_steps),
            ("training win rate", |r| r.train_win_rate, "environment steps", |r| r.t_env as f64, max_steps),
            ("greedy test win rate", |r| r.test_win_rate, "wall-clock seconds", |r| r.elapsed_s, max_secs),
            ("training win rate", |r| r.train_win_rate, "wall-clock seconds", |r| r.elapsed_s, max_secs),
        ];
        for (area, (y_label, y, x_label, x, x_max)) in panels.iter().zip(specs) {
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(56)
                .build_cartesian_2d(0.0..x_max, 0.0..1.02)
                .map_err(err)?;
            let steps = x_label.starts_with("env");
            let fmt_x = move |v: &f64| if steps { crate::plot::steps_label(*v) } else { format!("{v:.0}") };
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .x_label_formatter(&fmt_x)
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(err)?;
            for (gi, g) in groups.iter().enumerate() {
                let color = series_color(gi);
                for (_, rows) in &g.runs {
                    let pts: Vec<(f64, f64)> = rows.iter().map(|r| (x(r), y(r))).filter(|(_, v)| v.is_finite()).collect();
                    chart.draw_series(LineSeries::new(pts, color.mix(0.35).stroke_width(1))).map_err(err)?;
                }
                let mean = mean_curve(&g.runs, x, y);
                chart
                    .draw_series(crate::plot::strokes(mean, color.stroke_width(3)))
                    .map_err(err)?
                    .label(format!("{} ({} runs, mean)", g.name, g.runs.len()))
                    .legend(move |(px, py)| PathElement::new(vec![(px, py), (px + 18, py)], color.stroke_width(3)));
            }
            let drawn: Vec<Vec<(f64, f64)>> = groups
                .iter()
                .flat_map(|g| {
                    g.runs.iter().map(|(_, r)| r.iter().map(|r| (x(r) / x_max, y(r) / 1.02)).filter(|(_, v)| v.is_finite()).collect())
                })
                .collect();
            let corner = crate::plot::quiet_corner(&drawn, groups.len());
            crate::plot::legend(&mut chart, corner).map_err(crate::plot::err)?;
        }
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(crate::plot::err)
}

/// One panel of [`grid`]: a title, named runs (one colour per name, [`series_color`]'s)
/// and an optional reference level (e.g. a published win rate) drawn dashed.
#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub runs: Vec<(String, Vec<LogRow>)>,
    pub reference: Option<f64>,
    /// The x axis runs to this many steps at least (the budget), so a run under way shows
    /// how far it has come.
    pub budget: u64,
}

/// At most this many points a run draws in a [`grid`] panel, one per stretch of the panel's x
/// axis: a longer run draws the median of each stretch's test rounds, so a 10M-step run (1,000
/// rounds) reads as well as a 2M-step one instead of filling its panel with noise, and a run
/// stopped at a tenth of its axis is not drawn as a hundred points in a few pixels (whose
/// zigzag the stroke's joins turned into spikes across neighbouring panels).
pub const MAX_PANEL_POINTS: usize = 200;

/// `pts` (in step order) on an axis from 0 to `x_max`, with at most [`MAX_PANEL_POINTS`]: the
/// points of each of that many equal stretches of the axis become their last step and the
/// median of their values.
pub fn thin(pts: Vec<(f64, f64)>, x_max: f64) -> Vec<(f64, f64)> {
    let stretch = |x: f64| {
        let at = if x_max > 0.0 { x / x_max * MAX_PANEL_POINTS as f64 } else { 0.0 };
        (at.max(0.0) as usize).min(MAX_PANEL_POINTS - 1)
    };
    pts.chunk_by(|a, b| stretch(a.0) == stretch(b.0))
        .filter_map(|c| {
            let mut ys: Vec<f64> = c.iter().map(|p| p.1).collect();
            ys.sort_by(f64::total_cmp);
            Some((c.last()?.0, ys[ys.len() / 2]))
        })
        .collect()
}

/// Height of a line of [`grid`]'s legend, in pixels.
const LEGEND_LINE: u32 = 26;

/// Where [`grid`]'s legend puts each label in a header `width` pixels wide: its left edge and
/// its line, filling a line before starting the next (a dozen run names do not fit in one).
fn legend_layout(labels: &[&str], width: i32) -> Vec<(i32, usize)> {
    let (mut x, mut line) = (12, 0);
    labels
        .iter()
        .map(|n| {
            let w = label_width(n);
            if x > 12 && x + w > width {
                (x, line) = (12, line + 1);
            }
            let at = (x, line);
            x += w;
            at
        })
        .collect()
}

/// A legend label's width in pixels: the stroke, a gap and the text at about 10 pixels a
/// character.
fn label_width(label: &str) -> i32 {
    40 + 10 * label.chars().count() as i32
}

/// Small multiples: each panel's greedy test win rates against environment steps, `cols`
/// panels a row, one legend of run names under the title. For many maps at a glance.
pub fn grid(path: &Path, title: &str, names: &[&str], panels: &[Panel], cols: usize) -> Result<(), Error> {
    crate::plot::font()?;
    let err = crate::plot::err;
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let (cell_w, cell_h) = (300u32, 220u32);
    const PUBLISHED: &str = "published (best)";
    let labels: Vec<&str> = names.iter().copied().chain([PUBLISHED]).collect();
    let at = legend_layout(&labels, (cell_w * cols as u32) as i32);
    let head_h = 70 + LEGEND_LINE * at.last().map_or(0, |a| a.1) as u32;
    let mut canvas = Png::new((cell_w * cols as u32, cell_h * rows as u32 + head_h));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let (head, body) = root.split_vertically(head_h);
        head.draw(&Text::new(title.to_owned(), (12, 8), ("sans-serif", 22))).map_err(err)?;
        for (i, (n, &(x, line))) in labels.iter().zip(&at).enumerate() {
            let y = 50 + LEGEND_LINE as i32 * line as i32;
            let stroke = if *n == PUBLISHED { BLACK.stroke_width(1) } else { series_color(i).stroke_width(3) };
            head.draw(&PathElement::new(vec![(x, y), (x + 24, y)], stroke)).map_err(err)?;
            head.draw(&Text::new((*n).to_owned(), (x + 30, y - 9), ("sans-serif", 17))).map_err(err)?;
        }
        for (area, p) in body.split_evenly((rows, cols)).iter().zip(panels) {
            let x_max = p.runs.iter().flat_map(|(_, r)| r.iter().map(|r| r.t_env)).max().unwrap_or(1).max(p.budget).max(1) as f64;
            let mut chart = ChartBuilder::on(area)
                .caption(&p.title, ("sans-serif", 17))
                .margin(6)
                .x_label_area_size(24)
                .y_label_area_size(34)
                .build_cartesian_2d(0.0..x_max, 0.0..1.02)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_labels(4)
                .y_labels(3)
                .x_label_formatter(&|v: &f64| crate::plot::steps_label(*v))
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(err)?;
            if let Some(level) = p.reference {
                let dashes = (0..20).map(|k| {
                    let a = x_max * k as f64 / 20.0;
                    PathElement::new(vec![(a, level), (a + x_max / 40.0, level)], BLACK.stroke_width(1))
                });
                chart.draw_series(dashes).map_err(err)?;
            }
            for (name, rows) in &p.runs {
                let c = series_color(names.iter().position(|n| n == name).unwrap_or(names.len()));
                let pts: Vec<(f64, f64)> = rows.iter().map(|r| (r.t_env as f64, r.test_win_rate)).filter(|(_, v)| v.is_finite()).collect();
                chart.draw_series(crate::plot::strokes(thin(pts, x_max), c.stroke_width(2))).map_err(err)?;
            }
        }
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(crate::plot::err)
}

/// The mean over runs of `y` at each run's `x` points, each run held at its last value past
/// its end and at its first before its start (step interpolation on the union of points).
fn mean_curve(runs: &[(PathBuf, Vec<LogRow>)], x: fn(&LogRow) -> f64, y: fn(&LogRow) -> f64) -> Vec<(f64, f64)> {
    let mut xs: Vec<f64> = runs.iter().flat_map(|(_, r)| r.iter().map(x)).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs.into_iter()
        .filter_map(|at| {
            let vals: Vec<f64> = runs
                .iter()
                .filter_map(|(_, r)| {
                    let upto: Vec<&LogRow> = r.iter().filter(|p| x(p) <= at && y(p).is_finite()).collect();
                    upto.last().map(|p| y(p)).or_else(|| r.iter().find(|p| y(p).is_finite()).map(y))
                })
                .collect();
            (!vals.is_empty()).then(|| (at, vals.iter().sum::<f64>() / vals.len() as f64))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn series_colours_stay_apart_past_the_palette() {
        let colours: Vec<(u8, u8, u8)> = (0..40).map(series_color).map(|RGBColor(r, g, b)| (r, g, b)).collect();
        assert_eq!(colours[..COLORS.len()], COLORS.map(|RGBColor(r, g, b)| (r, g, b)), "the palette comes first");
        // Within the palette, every two colours differ by at least 40 in some channel.
        for (i, a) in COLORS.iter().enumerate() {
            for (j, b) in COLORS.iter().enumerate().skip(i + 1) {
                let d = [a.0.abs_diff(b.0), a.1.abs_diff(b.1), a.2.abs_diff(b.2)].into_iter().max().unwrap_or(0);
                assert!(d >= 40, "palette colours {i} and {j} look alike: {a:?} {b:?}");
            }
        }
        for (i, a) in colours.iter().enumerate() {
            for (j, b) in colours.iter().enumerate().skip(i + 1) {
                let d = [a.0.abs_diff(b.0), a.1.abs_diff(b.1), a.2.abs_diff(b.2)].into_iter().max().unwrap_or(0);
                assert!(d >= 12, "series {i} and {j} look alike: {a:?} {b:?}");
            }
        }
    }

    #[test]
    fn the_legend_wraps_inside_the_figure_without_overlaps() {
        let names: Vec<String> = (0..12).map(|i| format!("a-long-run-name-{i}")).collect();
        let labels: Vec<&str> = names.iter().map(String::as_str).collect();
        let width = 1500;
        let at = legend_layout(&labels, width);
        // About 210 pixels a label: seven to a 1,500-pixel line, the other five on a second.
        assert_eq!(at.iter().filter(|a| a.1 == 0).count(), 7, "{at:?}");
        assert_eq!(at.last().map(|a| a.1), Some(1), "{at:?}");
        for (k, ((x, line), n)) in at.iter().zip(&labels).enumerate() {
            assert!(*x + label_width(n) <= width, "label {k} runs off the figure");
            if let Some((nx, nline)) = at.get(k + 1)
                && nline == line
            {
                assert!(*nx >= x + label_width(n), "labels {k} and {} overlap", k + 1);
            }
        }
        assert_eq!(legend_layout(&["qmix", "mappo"], width), vec![(12, 0), (92, 0)]);
    }

    #[test]
    fn long_runs_are_thinned_to_medians_and_short_ones_kept() {
        let short: Vec<(f64, f64)> = (0..150).map(|i| (i as f64, (i % 2) as f64)).collect();
        assert_eq!(thin(short.clone(), 149.0), short);
        // 1,000 rounds: stretches of 5, each its last step and its median.
        let long: Vec<(f64, f64)> = (0..1000).map(|i| (i as f64, if i % 5 == 0 { 1.0 } else { 0.0 })).collect();
        let t = thin(long, 999.0);
        assert_eq!(t.len(), 200);
        assert_eq!(t[0], (4.0, 0.0));
        assert_eq!(t[199], (999.0, 0.0));
        let noisy: Vec<(f64, f64)> = (0..1000).map(|i| (i as f64, if i % 5 < 3 { 0.8 } else { 0.2 })).collect();
        assert!(thin(noisy, 999.0).iter().all(|p| p.1 == 0.8));
        // A run stopped at a tenth of its panel's axis: about a tenth of the points (20
        // stretches of 5 rounds, and the last round starts the 21st).
        let stopped: Vec<(f64, f64)> = (1..=100).map(|i| (i as f64 * 1e4, (i % 2) as f64)).collect();
        let t = thin(stopped, 1e7);
        assert_eq!(t.len(), 21);
        assert_eq!((t[0], t[20]), ((4e4, 1.0), (1e6, 0.0)));
    }

    #[test]
    fn a_log_reads_back_as_its_figure_s_points() {
        let dir = std::env::temp_dir().join(format!("avacraft-curve-points-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let head = "t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s";
        let vs = ",test_win_rate_vs_focus-fire,test_return_vs_focus-fire";
        std::fs::write(
            dir.join("log.csv"),
            format!("{head}{vs}\n1000,3,2,0.9,0.5,1,0.1,NaN,0.25,7.5,3.0,0.5,9.0\n2000,7,6,0.8,0.25,1,0.1,0.5,1.0,20.0,6.0,NaN,1.0\n"),
        )
        .expect("write");
        let (points, names) = curve_points(&dir).expect("read");
        assert_eq!(names, ["focus-fire"]);
        assert_eq!(points.len(), 2);
        assert_eq!((points[0].t_env, points[0].train_win_rate, points[0].loss, points[0].vs[0]), (1000, None, 0.5, 0.5));
        assert_eq!((points[1].train_win_rate, points[1].test_return), (Some(0.5), 20.0));
        assert!(points[1].vs[0].is_nan(), "a gap stays a gap");
        // Without a loss column the figure draws no loss; a short line is refused.
        std::fs::write(dir.join("log.csv"), "t_env,episodes,updates,train_win_rate,test_win_rate,test_return,elapsed_s\n10,1,1,0,0,0,1\n")
            .expect("write");
        assert!(curve_points(&dir).expect("read").0[0].loss.is_nan());
        std::fs::write(dir.join("log.csv"), format!("{head}\n10,1\n")).expect("write");
        assert!(curve_points(&dir).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn text(rows: &[LogRow]) -> String {
        let mut s =
            String::from("t_env,episodes,updates,epsilon,loss,grad_norm,q_taken,train_win_rate,test_win_rate,test_return,elapsed_s\n");
        for r in rows {
            s.push_str(&format!(
                "{},{},{},0.05,0.1,0.2,0.3,{},{},{},{}\n",
                r.t_env, r.episodes, r.updates, r.train_win_rate, r.test_win_rate, r.test_return, r.elapsed_s
            ));
        }
        s
    }

    proptest! {
        /// What the trainer writes reads back as it was.
        #[test]
        fn logs_round_trip(rows in prop::collection::vec((0u64..1 << 40, 0u64..1 << 30, 0u64..1 << 30, 0.0f64..1.0, 0.0f64..1.0, -50.0f64..250.0, 0.0f64..1e6), 0..20)) {
            let rows: Vec<LogRow> = rows.into_iter().map(|(t, e, u, tr, te, ret, s)| LogRow {
                t_env: t, episodes: e, updates: u, train_win_rate: tr, test_win_rate: te, test_return: ret, elapsed_s: s,
            }).collect();
            let back = parse_log(Path::new("log.csv"), &text(&rows)).map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(back, rows);
        }

        /// Any text either parses or is refused with the file named; it never panics.
        #[test]
        fn any_text_is_parsed_or_refused(s in ".{0,300}") {
            if let Err(e) = parse_log(Path::new("x/log.csv"), &s) {
                prop_assert!(e.to_string().starts_with("observation: x/log.csv:"), "{}", e);
            }
        }
    }

    #[test]
    fn mistakes_name_the_line_and_column() {
        let e = |t: &str| parse_log(Path::new("log.csv"), t).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e("").contains("no header"));
        assert!(e("t_env,episodes\n1,2\n").contains("no `updates` column"));
        let good = text(&[LogRow {
            t_env: 10,
            episodes: 1,
            updates: 1,
            train_win_rate: 0.5,
            test_win_rate: 1.0,
            test_return: 3.0,
            elapsed_s: 1.0,
        }]);
        assert!(e(&good.replace("10,1,1", "ten,1,1")).contains("line 2: `t_env` = `ten` is not a count"));
        assert!(e(&format!("{good}1,2\n")).contains("line 3: 2 fields"));
        assert!(e(&good.replace(",0.5,", ",half,")).contains("`train_win_rate` = `half`"));
        // NaN (no training episode since the last row) is a number.
        assert!(parse_log(Path::new("log.csv"), &good.replace(",0.5,", ",NaN,")).is_ok());
    }

    #[test]
    fn the_first_row_meeting_both_rates_is_found() {
        let row = |t, tr, te| LogRow {
            t_env: t,
            episodes: 0,
            updates: 0,
            train_win_rate: tr,
            test_win_rate: te,
            test_return: 0.0,
            elapsed_s: t as f64,
        };
        let rows = [row(1, 0.9, 0.5), row(2, 0.5, 1.0), row(3, 0.8, 0.95), row(4, 1.0, 1.0)];
        assert_eq!(first_reaching(&rows, 0.95, 0.8).map(|r| r.t_env), Some(3));
        assert_eq!(first_reaching(&rows[..2], 0.95, 0.8), None);
        assert!(first_reaching(&[row(1, f64::NAN, 1.0)], 0.95, 0.8).is_none());
    }

    #[test]
    fn groups_are_compared_on_one_png() {
        let row = |t: u64, w: f64| LogRow {
            t_env: t,
            episodes: t / 10,
            updates: t / 100,
            train_win_rate: w * 0.9,
            test_win_rate: w,
            test_return: 20.0 * w,
            elapsed_s: t as f64 / 500.0,
        };
        let run = |k: f64| (PathBuf::from("r"), (0..30).map(|i| row(i * 1000, (i as f64 * k / 30.0).min(1.0))).collect());
        let groups = [Group { name: "old".into(), runs: vec![run(1.0), run(0.8)] }, Group { name: "new".into(), runs: vec![run(1.5)] }];
        let dir = std::env::temp_dir().join(format!("avacraft-compare-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("compare.png");
        compare(&path, "old and new", &groups).expect("drawn");
        let img = image::open(&path).expect("a PNG reads back").to_rgb8();
        assert_eq!(img.dimensions(), (1400, 900));
        let colours: std::collections::BTreeSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        assert!(colours.len() > 20, "lines, text and legend are drawn: {} colours", colours.len());
        std::fs::remove_dir_all(&dir).ok();
    }
}
