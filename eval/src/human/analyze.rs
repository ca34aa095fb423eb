//! `analyze`: un-blind the ratings with the key, then per metric and agent kind: count, mean,
//! median; and for every pair of kinds a two-sided Mann-Whitney U test and its effect size.
//!
//! The test is SciPy's `mannwhitneyu(x, y, method="asymptotic")`: U of the first sample from
//! mid-ranks, the normal approximation with SciPy's tie correction of the variance and its
//! continuity correction, p from statrs' normal distribution. The exact method is not used:
//! 1-to-5 ratings are full of ties, for which it does not hold. The effect size is the
//! rank-biserial correlation `2 U / (n1 n2) - 1`: +1 when every rating of the first kind is
//! above every rating of the second, 0 when neither tends higher. Each rating counts as one
//! observation (several raters rate each replay), as in the paper's analysis.

use super::{DB_FILE, Db, HumanError, Key, METRICS, Rating, read_key};
use crate::AgentKind;
use avacraft_marl::plot::Png;
use plotters::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A Mann-Whitney U test of two samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MannWhitney {
    /// U of the first sample (SciPy's `statistic`).
    pub u: f64,
    pub z: f64,
    /// Two-sided, normal approximation with tie and continuity corrections.
    pub p: f64,
    /// `2 U / (n1 n2) - 1`, in -1..=1.
    pub rank_biserial: f64,
}

/// The test of `x` against `y`; `None` when either is empty.
pub fn mann_whitney(x: &[f64], y: &[f64]) -> Option<MannWhitney> {
    let (n1, n2) = (x.len(), y.len());
    if n1 == 0 || n2 == 0 {
        return None;
    }
    let mut all: Vec<(f64, bool)> = x.iter().map(|&v| (v, true)).chain(y.iter().map(|&v| (v, false))).collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = all.len();
    let (mut r1, mut ties) = (0.0, 0.0);
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && all[j + 1].0 == all[i].0 {
            j += 1;
        }
        // Ranks i+1 ..= j+1 share their mean.
        let rank = (i + j + 2) as f64 / 2.0;
        let t = (j - i + 1) as f64;
        ties += t * t * t - t;
        r1 += rank * all[i..=j].iter().filter(|(_, first)| *first).count() as f64;
        i = j + 1;
    }
    let (f1, f2, nf) = (n1 as f64, n2 as f64, n as f64);
    let u1 = r1 - f1 * (f1 + 1.0) / 2.0;
    let u2 = f1 * f2 - u1;
    let mu = f1 * f2 / 2.0;
    let sd = (f1 * f2 / 12.0 * ((nf + 1.0) - ties / (nf * (nf - 1.0)))).sqrt();
    let (z, p) = if sd > 0.0 && sd.is_finite() {
        let z = (u1.max(u2) - mu - 0.5) / sd;
        let normal = Normal::new(0.0, 1.0).ok()?;
        (z, (2.0 * normal.sf(z)).clamp(0.0, 1.0))
    } else {
        // Every value tied (or a single observation): no evidence either way.
        (0.0, 1.0)
    };
    Some(MannWhitney { u: u1, z, p, rank_biserial: 2.0 * u1 / (f1 * f2) - 1.0 })
}

/// One metric's ratings of one kind.
#[derive(Clone, Debug, PartialEq)]
pub struct KindSummary {
    pub metric: &'static str,
    pub kind: AgentKind,
    pub ratings: usize,
    /// Distinct replays rated.
    pub replays: usize,
    pub mean: f64,
    pub median: f64,
    /// Standard error of the mean (the plot's whiskers).
    pub sem: f64,
}

/// Two kinds compared on one metric.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    pub metric: &'static str,
    pub a: AgentKind,
    pub b: AgentKind,
    pub test: MannWhitney,
}

/// The whole analysis.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    pub raters: usize,
    pub ratings: usize,
    /// Replays of the study none has rated yet.
    pub unrated: usize,
    pub summaries: Vec<KindSummary>,
    pub comparisons: Vec<Comparison>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

impl Analysis {
    /// Un-blinds `ratings` with `key` (a rated replay missing from the key is an error: the
    /// key belongs to another study).
    pub fn of(ratings: &[Rating], key: &Key) -> Result<Analysis, HumanError> {
        let mut by_kind: BTreeMap<AgentKind, Vec<&Rating>> = BTreeMap::new();
        for r in ratings {
            let e = key.replays.get(&r.replay).ok_or_else(|| HumanError::NotInKey(r.replay.clone()))?;
            by_kind.entry(e.kind).or_default().push(r);
        }
        let mut summaries = Vec::new();
        let mut comparisons = Vec::new();
        for (mi, m) in METRICS.iter().enumerate() {
            let values: BTreeMap<AgentKind, Vec<f64>> =
                by_kind.iter().map(|(k, rs)| (*k, rs.iter().map(|r| r.scores()[mi] as f64).collect())).collect();
            for (k, v) in &values {
                let n = v.len() as f64;
                let mean = v.iter().sum::<f64>() / n;
                let var = if v.len() > 1 { v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) } else { 0.0 };
                let replays = by_kind[k].iter().map(|r| r.replay.as_str()).collect::<BTreeSet<_>>().len();
                summaries.push(KindSummary {
                    metric: m.key,
                    kind: *k,
                    ratings: v.len(),
                    replays,
                    mean,
                    median: median(&mut v.clone()),
                    sem: (var / n).sqrt(),
                });
            }
            let kinds: Vec<&AgentKind> = values.keys().collect();
            for (i, a) in kinds.iter().enumerate() {
                for b in &kinds[i + 1..] {
                    if let Some(test) = mann_whitney(&values[*a], &values[*b]) {
                        comparisons.push(Comparison { metric: m.key, a: **a, b: **b, test });
                    }
                }
            }
        }
        let rated: BTreeSet<&str> = ratings.iter().map(|r| r.replay.as_str()).collect();
        Ok(Analysis {
            raters: ratings.iter().map(|r| r.rater.as_str()).collect::<BTreeSet<_>>().len(),
            ratings: ratings.len(),
            unrated: key.replays.keys().filter(|id| !rated.contains(id.as_str())).count(),
            summaries,
            comparisons,
        })
    }

    /// The tables as Markdown.
    pub fn markdown(&self) -> String {
        let name = |key: &str| METRICS.iter().find(|m| m.key == key).map_or(key.to_owned(), |m| m.name.to_owned());
        let mut s = String::from("# Human evaluation\n\n");
        let _ = writeln!(
            s,
            "{} ratings by {} raters; {} replays not rated yet. Ratings from 1 to 5; each rating is one observation.\n",
            self.ratings, self.raters, self.unrated
        );
        s.push_str("| metric | kind | ratings | replays | mean | median |\n|---|---|---:|---:|---:|---:|\n");
        for k in &self.summaries {
            let _ =
                writeln!(s, "| {} | {} | {} | {} | {:.2} | {:.1} |", name(k.metric), k.kind.name(), k.ratings, k.replays, k.mean, k.median);
        }
        s.push_str(
            "\nMann-Whitney U (two-sided; normal approximation with tie and continuity corrections). U is the first kind's; \
             r is the rank-biserial correlation (positive: the first kind is rated higher).\n\n",
        );
        s.push_str("| metric | kinds | U | p | r |\n|---|---|---:|---:|---:|\n");
        for c in &self.comparisons {
            let _ = writeln!(
                s,
                "| {} | {} vs {} | {:.1} | {:.4} | {:+.3} |",
                name(c.metric),
                c.a.name(),
                c.b.name(),
                c.test.u,
                c.test.p,
                c.test.rank_biserial
            );
        }
        if self.comparisons.is_empty() {
            s.push_str("| (fewer than two kinds rated) | | | | |\n");
        }
        s
    }

    /// Mean rating per metric and kind, whiskers at one standard error.
    pub fn plot(&self, path: &Path) -> Result<(), HumanError> {
        font()?;
        let err = |e: &dyn std::fmt::Display| HumanError::Plot { message: e.to_string() };
        let kinds: Vec<AgentKind> = self.summaries.iter().map(|k| k.kind).collect::<BTreeSet<_>>().into_iter().collect();
        let mut canvas = Png::new((800, 480));
        {
            let root = canvas.area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let mut chart = ChartBuilder::on(&root)
                .caption("Human evaluation: mean rating (± s.e.)", ("sans-serif", 22))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
                // Metric i's group of bars is centred on x = i, where its label goes.
                .build_cartesian_2d(-0.5..METRICS.len() as f64 - 0.5, 0.0..5.5)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels(METRICS.len())
                .x_label_formatter(&|x| {
                    let i = x.round();
                    let m = if (x - i).abs() < 1e-6 && i >= 0.0 { METRICS.get(i as usize) } else { None };
                    m.map_or(String::new(), |m| m.name.to_owned())
                })
                .y_desc("rating (1 to 5)")
                .draw()
                .map_err(|e| err(&e))?;
            const COLORS: [RGBColor; 3] = [RGBColor(127, 127, 127), RGBColor(31, 119, 180), RGBColor(255, 127, 14)];
            let w = 0.8 / kinds.len().max(1) as f64;
            for (ki, kind) in kinds.iter().enumerate() {
                let color = COLORS[ki % COLORS.len()];
                let bars: Vec<(f64, &KindSummary)> = self
                    .summaries
                    .iter()
                    .filter(|s| s.kind == *kind)
                    .filter_map(|s| METRICS.iter().position(|m| m.key == s.metric).map(|mi| (mi as f64 - 0.4 + w * ki as f64, s)))
                    .collect();
                chart
                    .draw_series(bars.iter().map(|(x, s)| Rectangle::new([(*x, 0.0), (*x + w * 0.9, s.mean)], color.filled())))
                    .map_err(|e| err(&e))?
                    .label(kind.name())
                    .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
                chart
                    .draw_series(bars.iter().map(|(x, s)| {
                        PathElement::new(vec![(*x + w * 0.45, s.mean - s.sem), (*x + w * 0.45, s.mean + s.sem)], BLACK.stroke_width(1))
                    }))
                    .map_err(|e| err(&e))?;
            }
            avacraft_marl::plot::legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        canvas.save(path).map_err(|e| err(&e))
    }
}

/// DejaVu Sans from the `dejavu` crate, so no system font is needed (as the report's plots).
fn font() -> Result<(), HumanError> {
    if crate::plot::font_registered() {
        Ok(())
    } else {
        Err(HumanError::Plot { message: "the embedded DejaVu Sans font did not load".into() })
    }
}

/// Analyzes a study folder's ratings; writes `analysis.md` and `analysis.png` into it and
/// returns the analysis and the files written.
pub fn analyze(study: &Path) -> Result<(Analysis, Vec<PathBuf>), HumanError> {
    let key = read_key(study)?;
    let ratings = Db::open_read_only(&study.join(DB_FILE))?.all()?;
    if ratings.is_empty() {
        return Err(HumanError::NoRatings { path: study.join(DB_FILE) });
    }
    let a = Analysis::of(&ratings, &key)?;
    let md = study.join("analysis.md");
    std::fs::write(&md, a.markdown()).map_err(super::io(&md))?;
    let png = study.join("analysis.png");
    a.plot(&png)?;
    Ok((a, vec![md, png]))
}
