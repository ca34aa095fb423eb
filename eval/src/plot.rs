//! The report's plots (PNG, plotters, DejaVu Sans from the `dejavu` crate so no system font
//! is needed): win rates per scenario and agent with their 95% intervals, a head-to-head
//! heatmap per PvP scenario, and the MARL learning curves of the plan's training runs.

use crate::EvalError;
use crate::meta::Meta;
use crate::stats::CellStats;
use avacraft_marl::plot::Png;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Registers DejaVu Sans as plotters' `sans-serif` once per process; false if it failed.
pub(crate) fn font_registered() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular()).is_ok())
}

fn font() -> Result<(), EvalError> {
    if font_registered() { Ok(()) } else { Err(EvalError::Plot { message: "the embedded DejaVu Sans font did not load".into() }) }
}

fn err(e: impl std::fmt::Display) -> EvalError {
    EvalError::Plot { message: e.to_string() }
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Every plot the report of `cells` has; returns the files written.
pub fn all(meta: &Meta, cells: &[CellStats], dir: &Path) -> Result<Vec<PathBuf>, EvalError> {
    font()?;
    let mut files = Vec::new();
    let pve: Vec<_> = cells.iter().filter(|c| c.key.against.starts_with("opponent:")).collect();
    if !pve.is_empty() {
        let p = dir.join("winrate.png");
        win_rates(meta, cells, &p)?;
        files.push(p);
    }
    let mut pvp: Vec<&str> = cells.iter().filter(|c| !c.key.against.starts_with("opponent:")).map(|c| c.key.scenario.as_str()).collect();
    pvp.dedup();
    for sc in pvp {
        let p = dir.join(format!("headtohead-{sc}.png"));
        heatmap(meta, cells, sc, &p)?;
        files.push(p);
    }
    if !meta.curves.is_empty() {
        let p = dir.join("curves.png");
        curves(meta, &p)?;
        files.push(p);
    }
    Ok(files)
}

/// Grouped bars: one group per (scenario, opponent), one bar per agent, whiskers at the 95%
/// interval.
fn win_rates(meta: &Meta, cells: &[CellStats], path: &Path) -> Result<(), EvalError> {
    let cells: Vec<_> = cells.iter().filter(|c| c.key.against.starts_with("opponent:")).collect();
    let mut groups: Vec<(String, String)> = Vec::new();
    for c in &cells {
        let g = (c.key.scenario.clone(), c.key.against.clone());
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    let agents: Vec<&str> = meta.agents.iter().map(|(n, _, _)| n.as_str()).filter(|a| cells.iter().any(|c| c.key.agent == *a)).collect();
    let width = (160 + groups.len() * (agents.len() * 18 + 24)).clamp(700, 4000) as u32;
    let mut canvas = Png::new((width, 560));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let opponents: Vec<&str> = {
            let mut v: Vec<&str> = groups.iter().map(|(_, o)| o.as_str()).collect();
            v.dedup();
            v
        };
        let label = |i: usize| {
            groups.get(i).map_or(String::new(), |(s, o)| {
                if opponents.len() > 1 { format!("{s} ({})", o.trim_start_matches("opponent:")) } else { s.clone() }
            })
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Win rate per scenario: {}", meta.name), ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(210)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..groups.len().max(1) as f64, 0.0..1.05)
            .map_err(err)?;
        // The mesh's own x labels go at "nice" numbers of the float axis, so with many groups
        // some are skipped and the rest sit off the groups' centres: each group's name is drawn
        // under its centre instead.
        chart.configure_mesh().disable_x_mesh().x_labels(0).x_label_formatter(&|_| String::new()).y_desc("win rate").draw().map_err(err)?;
        let style = ("sans-serif", 13).into_text_style(&root).transform(FontTransform::Rotate90);
        for gi in 0..groups.len() {
            let (px, py) = chart.backend_coord(&(gi as f64 + 0.5, 0.0));
            root.draw(&Text::new(label(gi), (px + 6, py + 6), style.clone())).map_err(err)?;
        }
        let n = agents.len().max(1) as f64;
        for (ai, a) in agents.iter().enumerate() {
            let color = PALETTE[ai % PALETTE.len()];
            let bars: Vec<(f64, f64, (f64, f64))> = groups
                .iter()
                .enumerate()
                .filter_map(|(gi, (s, o))| {
                    cells.iter().find(|c| &c.key.scenario == s && &c.key.against == o && c.key.agent == *a).map(|c| {
                        let x = gi as f64 + 0.1 + 0.8 * ai as f64 / n;
                        (x, c.win_rate.mean, c.win_ci95)
                    })
                })
                .collect();
            let w = 0.8 / n;
            chart
                .draw_series(bars.iter().map(|(x, y, _)| Rectangle::new([(*x, 0.0), (*x + w * 0.9, *y)], color.filled())))
                .map_err(err)?
                .label(*a)
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
            chart
                .draw_series(
                    bars.iter()
                        .map(|(x, _, (lo, hi))| PathElement::new(vec![(*x + w * 0.45, *lo), (*x + w * 0.45, *hi)], BLACK.stroke_width(1))),
                )
                .map_err(err)?;
        }
        avacraft_marl::plot::legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(err)?;
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(err)
}

/// Row agent's win rate as team 1 against the column agent.
fn heatmap(meta: &Meta, cells: &[CellStats], scenario: &str, path: &Path) -> Result<(), EvalError> {
    let cells: Vec<_> = cells.iter().filter(|c| c.key.scenario == scenario && !c.key.against.starts_with("opponent:")).collect();
    let names: Vec<&str> =
        meta.agents.iter().map(|(n, _, _)| n.as_str()).filter(|a| cells.iter().any(|c| c.key.agent == *a || c.key.against == *a)).collect();
    let k = names.len().max(1);
    let side = (200 + k * 90).min(2000) as u32;
    let mut canvas = Png::new((side + 60, side));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Head to head on {scenario}: team 1's win rate"), ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(90)
            .y_label_area_size(120)
            // Segmented axes: a label names the cell it sits under, not the edge between two
            // (a segmented a..b has a segment for each of a to b, both included).
            .build_cartesian_2d((0..k - 1).into_segmented(), (0..k - 1).into_segmented())
            .map_err(err)?;
        let name = |i: usize| names.get(i).map_or(String::new(), |s| (*s).to_owned());
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(k)
            .y_labels(k)
            .x_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => name(*i),
                _ => String::new(),
            })
            .y_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => (k - 1).checked_sub(*i).map_or(String::new(), name),
                _ => String::new(),
            })
            .x_desc("team 2")
            .y_desc("team 1")
            .draw()
            .map_err(err)?;
        let font = ("sans-serif", 16).into_font().color(&BLACK).pos(Pos::new(HPos::Center, VPos::Center));
        for (ri, a) in names.iter().enumerate() {
            for (ci, b) in names.iter().enumerate() {
                let Some(c) = cells.iter().find(|c| c.key.agent == *a && c.key.against == *b) else { continue };
                let v = c.win_rate.mean.clamp(0.0, 1.0);
                let color = RGBColor((255.0 * (1.0 - v)) as u8, (90.0 + 120.0 * v) as u8, (255.0 * v) as u8);
                let y = k - 1 - ri;
                let cell = [(SegmentValue::Exact(ci), SegmentValue::Exact(y)), (SegmentValue::Exact(ci + 1), SegmentValue::Exact(y + 1))];
                chart.draw_series(std::iter::once(Rectangle::new(cell, color.filled()))).map_err(err)?;
                let centre = (SegmentValue::CenterOf(ci), SegmentValue::CenterOf(y));
                chart.draw_series(std::iter::once(Text::new(format!("{v:.2}"), centre, font.clone()))).map_err(err)?;
            }
        }
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(err)
}

/// The greedy test win rate of each training run against environment steps.
fn curves(meta: &Meta, path: &Path) -> Result<(), EvalError> {
    let mut runs = Vec::new();
    for (name, dir) in &meta.curves {
        runs.push((name.as_str(), read_log(&dir.join("log.csv"))?));
    }
    let x_max = runs.iter().flat_map(|(_, p)| p.iter().map(|(t, _)| *t)).fold(1.0f64, f64::max);
    let mut canvas = Png::new((900, 500));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption("MARL learning curves (greedy test win rate)", ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..x_max, 0.0..1.05)
            .map_err(err)?;
        chart.configure_mesh().x_desc("environment steps").y_desc("win rate").draw().map_err(err)?;
        for (i, (name, points)) in runs.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(points.iter().copied(), color.stroke_width(2)))
                .map_err(err)?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], color.stroke_width(2)));
        }
        avacraft_marl::plot::legend(&mut chart, SeriesLabelPosition::LowerRight).map_err(err)?;
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(err)
}

/// `(t_env, test_win_rate)` of a training log (`avacraft train`'s log.csv).
pub fn read_log(path: &Path) -> Result<Vec<(f64, f64)>, EvalError> {
    let text = std::fs::read_to_string(path).map_err(|source| EvalError::Io { path: path.to_path_buf(), source })?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (Some(t), Some(w)) = (col("t_env"), col("test_win_rate")) else {
        return Err(EvalError::Log { path: path.to_path_buf(), line: 1, why: "no t_env and test_win_rate columns".into() });
    };
    let mut out = Vec::new();
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let num = |k: usize| f.get(k).and_then(|v| v.trim().parse::<f64>().ok());
        match (num(t), num(w)) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => out.push((x, y)),
            // Rows without a test round leave the win rate empty.
            (Some(_), None) => {}
            _ => return Err(EvalError::Log { path: path.to_path_buf(), line: i + 2, why: format!("cannot read `{line}`") }),
        }
    }
    Ok(out)
}
