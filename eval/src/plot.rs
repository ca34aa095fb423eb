//! The report's plots (PNG, plotters, DejaVu Sans from the `dejavu` crate so no system font
//! is needed): a heat map of every agent's win rate on every scenario, a head-to-head
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
    if !cells.is_empty() {
        let p = dir.join(WIN_RATES);
        win_rates(meta, cells, &p)?;
        files.push(p);
    }
    let mut pvp: Vec<&str> = cells.iter().filter(|c| !c.key.against.starts_with("opponent:")).map(|c| c.key.scenario.as_str()).collect();
    let mut seen: Vec<&str> = Vec::new();
    pvp.retain(|sc| {
        if seen.contains(sc) {
            false
        } else {
            seen.push(sc);
            true
        }
    });
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

/// The file name of the win-rate heat map that opens the report.
pub(crate) const WIN_RATES: &str = "winrate.png";

/// Blues, from near white at 0 to dark blue at 1: the darker, the more won.
fn blues(v: f64) -> RGBColor {
    let v = v.clamp(0.0, 1.0);
    let mix = |lo: f64, hi: f64| (lo + (hi - lo) * v).round() as u8;
    RGBColor(mix(240.0, 8.0), mix(246.0, 48.0), mix(252.0, 107.0))
}

/// One row per scenario (PvE, then PvP), one column per agent in plan order, each
/// cell the win rate written in it: every agent on every scenario in one picture.
fn win_rates(meta: &Meta, cells: &[CellStats], path: &Path) -> Result<(), EvalError> {
    let mut scenarios: Vec<(&str, bool)> = Vec::new();
    for pvp in [false, true] {
        for c in cells {
            let sc = c.key.scenario.as_str();
            if c.key.against.starts_with("opponent:") != pvp && !scenarios.iter().any(|(s, _)| *s == sc) {
                scenarios.push((sc, pvp));
            }
        }
    }
    let agents: Vec<&str> = meta
        .agents
        .iter()
        .map(|(n, _, _)| n.as_str())
        .filter(|a| scenarios.iter().any(|(sc, _)| meta.versus_scripted(cells, sc, a).is_some()))
        .collect();
    let (cw, ch) = (66i32, 26i32);
    let left = 16 + 9 * scenarios.iter().map(|(s, p)| s.chars().count() as i32 + if *p { 6 } else { 0 }).max().unwrap_or(8);
    let top = 44 + 8 * agents.iter().map(|a| a.chars().count() as i32).max().unwrap_or(6);
    let (w, h) = (left + cw * agents.len() as i32 + 16, top + ch * scenarios.len() as i32 + 60);
    // The note below takes two lines of about 60 characters: a narrow table still shows it whole.
    let mut canvas = Png::new((w.max(480) as u32, h as u32));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let title = ("sans-serif", 20).into_font().color(&BLACK);
        root.draw(&Text::new(format!("Win rate per scenario and agent: {}", meta.name), (12, 10), title)).map_err(err)?;
        let label = ("sans-serif", 15).into_font().color(&BLACK).pos(Pos::new(HPos::Right, VPos::Center));
        let head = ("sans-serif", 15).into_font().color(&BLACK).transform(FontTransform::Rotate270).pos(Pos::new(HPos::Left, VPos::Center));
        for (i, a) in agents.iter().enumerate() {
            let x = left + cw * i as i32 + cw / 2;
            root.draw(&Text::new((*a).to_owned(), (x, top - 6), head.clone())).map_err(err)?;
        }
        for (r, (sc, pvp)) in scenarios.iter().enumerate() {
            let y = top + ch * r as i32;
            let name = if *pvp { format!("{sc} (PvP)") } else { (*sc).to_owned() };
            root.draw(&Text::new(name, (left - 8, y + ch / 2), label.clone())).map_err(err)?;
            for (i, a) in agents.iter().enumerate() {
                let x = left + cw * i as i32;
                let cell = [(x, y), (x + cw - 2, y + ch - 2)];
                let v = meta.versus_scripted(cells, sc, a);
                let fill = v.map_or(RGBColor(225, 225, 225), blues);
                root.draw(&Rectangle::new(cell, fill.filled())).map_err(err)?;
                let ink = if v.is_some_and(|v| v > 0.55) { WHITE } else { BLACK };
                let text = v.map_or("–".to_owned(), |v| format!("{v:.2}"));
                let font = ("sans-serif", 14).into_font().color(&ink).pos(Pos::new(HPos::Center, VPos::Center));
                root.draw(&Text::new(text, (x + cw / 2 - 1, y + ch / 2 - 1), font)).map_err(err)?;
            }
            // A rule between the PvE and the PvP rows.
            if *pvp && r > 0 && !scenarios[r - 1].1 {
                root.draw(&PathElement::new(vec![(8, y - 1), (w - 8, y - 1)], BLACK.stroke_width(2))).map_err(err)?;
            }
        }
        // Rules between kinds of agent (learners, scripts, AVA).
        for i in 1..agents.len() {
            if meta.kind(agents[i]) != meta.kind(agents[i - 1]) {
                let x = left + cw * i as i32 - 1;
                root.draw(&PathElement::new(vec![(x, top - 4), (x, top + ch * scenarios.len() as i32)], BLACK.stroke_width(2)))
                    .map_err(err)?;
            }
        }
        let note = ("sans-serif", 14).into_font().color(&RGBColor(60, 60, 60));
        let y = top + ch * scenarios.len() as i32 + 12;
        root.draw(&Text::new("PvE: against the scenario's own opponent.", (12, y), note.clone())).map_err(err)?;
        root.draw(&Text::new("PvP: mean over the scripted agents on team 2. Grey: not played.", (12, y + 18), note)).map_err(err)?;
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(err)
}

/// Row agent's win rate as team 1 against the column agent.
fn heatmap(meta: &Meta, cells: &[CellStats], scenario: &str, path: &Path) -> Result<(), EvalError> {
    let cells: Vec<_> = cells.iter().filter(|c| c.key.scenario == scenario && !c.key.against.starts_with("opponent:")).collect();
    // Rows are the agents that played team 1, columns those that played team 2: a plan whose
    // agents meet only the scripts leaves no empty columns.
    let rows: Vec<&str> = meta.agents.iter().map(|(n, _, _)| n.as_str()).filter(|a| cells.iter().any(|c| c.key.agent == *a)).collect();
    let cols: Vec<&str> = meta.agents.iter().map(|(n, _, _)| n.as_str()).filter(|a| cells.iter().any(|c| c.key.against == *a)).collect();
    let (kr, kc) = (rows.len().max(1), cols.len().max(1));
    // Room for the longest names at 14 px (about 8 px a character): a row label must not run
    // off the left edge, nor column labels into each other.
    let chars = |names: &[&str]| names.iter().map(|n| n.chars().count()).max().unwrap_or(0);
    let label_w = (chars(&rows) * 8 + 40).max(120);
    let col_w = (chars(&cols) * 8 + 16).max(110);
    let mut canvas = Png::new(((140 + label_w + kc * col_w).min(2400) as u32, (200 + kr * 60).min(2000) as u32));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Head to head on {scenario}: team 1's win rate"), ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(90)
            .y_label_area_size(label_w as u32)
            // Segmented axes: a label names the cell it sits under, not the edge between two
            // (a segmented a..b has a segment for each of a to b, both included).
            .build_cartesian_2d((0..kc - 1).into_segmented(), (0..kr - 1).into_segmented())
            .map_err(err)?;
        let name = |names: &[&str], i: usize| names.get(i).map_or(String::new(), |s| (*s).to_owned());
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(kc)
            .y_labels(kr)
            .label_style(("sans-serif", 14))
            .x_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => name(&cols, *i),
                _ => String::new(),
            })
            .y_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => (kr - 1).checked_sub(*i).map_or(String::new(), |r| name(&rows, r)),
                _ => String::new(),
            })
            .x_desc("team 2")
            .y_desc("team 1")
            .draw()
            .map_err(err)?;
        for (ri, a) in rows.iter().enumerate() {
            for (ci, b) in cols.iter().enumerate() {
                let Some(c) = cells.iter().find(|c| c.key.agent == *a && c.key.against == *b) else { continue };
                let v = c.win_rate.mean.clamp(0.0, 1.0);
                // The heat map's scale, the value written in the cell in a colour that reads on it.
                let color = blues(v);
                let ink = if v > 0.55 { WHITE } else { BLACK };
                let font = ("sans-serif", 16).into_font().color(&ink).pos(Pos::new(HPos::Center, VPos::Center));
                let y = kr - 1 - ri;
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
