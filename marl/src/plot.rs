//! Learning curves as a PNG next to the CSV log (`curves.png`): greedy test and training win
//! rates, the test return and the loss against environment steps, redrawn after every test
//! round so a run can be watched while it goes. Text is drawn with DejaVu Sans from the
//! `dejavu` crate, so no system font is needed.

use crate::Error;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// One logged point of a run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CurvePoint {
    pub t_env: u64,
    pub test_win_rate: f64,
    /// `None` when no training episode ended since the previous point.
    pub train_win_rate: Option<f64>,
    pub test_return: f64,
    pub loss: f64,
    /// Greedy win rates against the run's fixed test opponents, in their order.
    #[serde(default)]
    pub vs: Vec<f64>,
}

pub(crate) fn font() -> Result<(), Error> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok { Ok(()) } else { Err(Error::Plot { message: "the embedded DejaVu Sans font did not load".into() }) }
}

pub(crate) fn err(e: impl std::fmt::Display) -> Error {
    Error::Plot { message: e.to_string() }
}

/// An RGB canvas that plotters draws on, saved as PNG by the workspace's `image` crate:
/// plotters' own file back end would build a second, older `image` (and its JPEG decoder)
/// into every build for nothing else.
#[derive(Debug)]
pub struct Png {
    size: (u32, u32),
    rgb: Vec<u8>,
}

impl Png {
    pub fn new(size: (u32, u32)) -> Png {
        Png { size, rgb: vec![255; size.0 as usize * size.1 as usize * 3] }
    }

    /// The whole canvas as plotters' drawing area; drop it (and what was drawn from it)
    /// before [`Png::save`].
    pub fn area(&mut self) -> DrawingArea<BitMapBackend<'_>, plotters::coord::Shift> {
        BitMapBackend::with_buffer(&mut self.rgb, self.size).into_drawing_area()
    }

    pub fn save(self, path: &Path) -> Result<(), String> {
        image::save_buffer_with_format(path, &self.rgb, self.size.0, self.size.1, image::ExtendedColorType::Rgb8, image::ImageFormat::Png)
            .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// A thick curve as separate two-point strokes: plotters joins a polyline's segments with
/// mitres, and at a sharp turn (a win rate falling from 0.9 to 0 and back) the mitre runs far
/// out of the chart, over the title and the next panel. Strokes side by side have no joins.
pub fn strokes<X: Clone + 'static, Y: Clone + 'static>(
    points: Vec<(X, Y)>,
    style: ShapeStyle,
) -> impl Iterator<Item = PathElement<(X, Y)>> {
    let single = (points.len() == 1).then(|| PathElement::new(points.clone(), style));
    let pairs: Vec<PathElement<(X, Y)>> = points.windows(2).map(|w| PathElement::new(w.to_vec(), style)).collect();
    single.into_iter().chain(pairs)
}

/// An environment-step axis label, short enough not to run off a panel's edge: `750k`,
/// `2.5M`, `10M`.
pub fn steps_label(v: f64) -> String {
    if v >= 1e6 {
        let m = format!("{:.1}", v / 1e6);
        format!("{}M", m.strip_suffix(".0").unwrap_or(&m))
    } else if v >= 1e3 {
        format!("{:.0}k", v / 1e3)
    } else {
        format!("{v:.0}")
    }
}

/// Where on a chart a legend of `entries` lines would hide the least of `curves` (each a
/// series of points as fractions of the chart's width and height, 0 at the lower left; the
/// stretch between two points counts too, so a curve's jump from 0 to 1 is not missed): a
/// corner, the lower right first, then the middle of a side.
pub fn quiet_corner(curves: &[Vec<(f64, f64)>], entries: usize) -> SeriesLabelPosition {
    use SeriesLabelPosition as P;
    // About the box a legend covers on the project's panels: its lines are some 8% of a
    // panel's height each.
    const W: f64 = 0.4;
    let h = (0.1 + 0.08 * entries as f64).min(0.9);
    let (lo, hi) = (0.5 - h / 2.0, 0.5 + h / 2.0);
    let (left, right) = (0.5 - W / 2.0, 0.5 + W / 2.0);
    let boxes: [(P, [f64; 4]); 8] = [
        (P::LowerRight, [1.0 - W, 1.0, 0.0, h]),
        (P::UpperRight, [1.0 - W, 1.0, 1.0 - h, 1.0]),
        (P::UpperLeft, [0.0, W, 1.0 - h, 1.0]),
        (P::LowerLeft, [0.0, W, 0.0, h]),
        (P::MiddleRight, [1.0 - W, 1.0, lo, hi]),
        (P::MiddleLeft, [0.0, W, lo, hi]),
        (P::LowerMiddle, [left, right, 0.0, h]),
        (P::UpperMiddle, [left, right, 1.0 - h, 1.0]),
    ];
    let mut hidden = [0usize; 8];
    let mut count = |(x, y): (f64, f64)| {
        for (k, (_, [x0, x1, y0, y1])) in boxes.iter().enumerate() {
            hidden[k] += usize::from((*x0..=*x1).contains(&x) && (*y0..=*y1).contains(&y));
        }
    };
    for c in curves {
        c.first().copied().into_iter().for_each(&mut count);
        for w in c.windows(2) {
            let ((xa, ya), (xb, yb)) = (w[0], w[1]);
            for i in 1..=8 {
                let f = f64::from(i) / 8.0;
                count((xa + (xb - xa) * f, ya + (yb - ya) * f));
            }
        }
    }
    // The first with the fewest: a tie keeps the earlier.
    let best = (0..boxes.len()).fold(0, |b, k| if hidden[k] < hidden[b] { k } else { b });
    boxes[best].0.clone()
}

/// The series' legend in a corner of a chart, in one style for every plot of the project.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    corner: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(corner)
        .draw()
        .map_err(|e| e.to_string())
}

/// At most this many lines a legend inside a panel holds; more go in a key beside the panels.
const KEY_INSIDE_MAX: usize = 4;
/// The key's width in pixels.
const KEY_WIDTH: u32 = 200;

/// Draws `points` of the run `title` into `path` (PNG, 900x900).
pub fn curves(path: &Path, title: &str, points: &[CurvePoint], vs: &[String]) -> Result<(), Error> {
    font()?;
    let mut canvas = Png::new((900, 900));
    {
        let root = canvas.area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
        let panels = root.split_evenly((3, 1));
        let x_max = points.iter().map(|p| p.t_env).max().unwrap_or(1).max(1);
        let finite = |f: fn(&CurvePoint) -> f64| points.iter().map(f).filter(|v| v.is_finite());
        let range = |f: fn(&CurvePoint) -> f64| {
            let (lo, hi) = finite(f).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
            if lo.is_finite() && hi > lo {
                lo..hi + (hi - lo) * 0.05
            } else if lo.is_finite() {
                lo - 1.0..lo + 1.0
            } else {
                0.0..1.0
            }
        };
        let line = |f: &dyn Fn(&CurvePoint) -> f64| -> Vec<(u64, f64)> {
            points.iter().map(|p| (p.t_env, f(p))).filter(|(_, v)| v.is_finite()).collect()
        };
        type Series = (String, Vec<(u64, f64)>, RGBColor);
        let mut wins: Vec<Series> = vec![
            ("greedy test".into(), line(&|p| p.test_win_rate), BLUE),
            ("training (exploring)".into(), line(&|p| p.train_win_rate.unwrap_or(f64::NAN)), RGBColor(230, 120, 0)),
        ];
        // Fixed opponents (a self-play run's progress): greens and purples after the two above.
        let palette = [RGBColor(0, 150, 70), RGBColor(140, 60, 170), RGBColor(120, 120, 120), RGBColor(200, 40, 120)];
        for (i, name) in vs.iter().enumerate() {
            wins.push((format!("greedy vs {name}"), line(&|p| p.vs.get(i).copied().unwrap_or(f64::NAN)), palette[i % palette.len()]));
        }
        // More lines than a legend inside a panel can hold clear of the curves (a league's
        // fixed opponents): the key goes beside the panels, which all give it the room so that
        // their step axes stay aligned.
        let key_width = if wins.len() > KEY_INSIDE_MAX { KEY_WIDTH } else { 0 };
        let specs: [(&str, std::ops::Range<f64>, Vec<Series>); 3] = [
            ("win rate", 0.0..1.02, wins),
            ("test return", range(|p| p.test_return), vec![("greedy test return".into(), line(&|p| p.test_return), RGBColor(0, 140, 60))]),
            ("loss", range(|p| p.loss), vec![("last update's loss".into(), line(&|p| p.loss), RED)]),
        ];
        for (area, (label, y, series)) in panels.iter().zip(specs) {
            let (y_lo, y_span) = (y.start, y.end - y.start);
            let (area, key) = area.split_horizontally(area.dim_in_pixel().0.saturating_sub(key_width));
            let mut chart = ChartBuilder::on(&area)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(60)
                .build_cartesian_2d(0u64..x_max, y)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("environment steps")
                .y_desc(label)
                .x_label_formatter(&|v: &u64| steps_label(*v as f64))
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(err)?;
            let drawn: Vec<Vec<(f64, f64)>> = series
                .iter()
                .map(|(_, pts, _)| pts.iter().map(|(x, v)| (*x as f64 / x_max as f64, (v - y_lo) / y_span)).collect())
                .collect();
            let corner = quiet_corner(&drawn, series.len());
            let outside = series.len() > KEY_INSIDE_MAX;
            for (i, (name, pts, color)) in series.into_iter().enumerate() {
                if outside {
                    let y = 24 + 22 * i as i32;
                    key.draw(&PathElement::new(vec![(6, y), (26, y)], color.stroke_width(3))).map_err(err)?;
                    key.draw(&Text::new(name.clone(), (32, y - 8), ("sans-serif", 14))).map_err(err)?;
                }
                let drawn = chart.draw_series(strokes(pts, color.stroke_width(2))).map_err(err)?;
                if !outside {
                    drawn.label(name).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
                }
            }
            if !outside {
                legend(&mut chart, corner).map_err(err)?;
            }
        }
        root.present().map_err(err)?;
    }
    canvas.save(path).map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_goes_where_no_curve_runs() {
        use SeriesLabelPosition as P;
        let along = |f: fn(f64) -> f64| (0..=50).map(|i| (i as f64 / 50.0, f(i as f64 / 50.0))).collect::<Vec<_>>();
        let at = |curves: &[Vec<(f64, f64)>], entries| quiet_corner(curves, entries);
        assert!(matches!(at(&[along(|x| x)], 2), P::LowerRight), "a rising win rate");
        assert!(matches!(at(&[along(|_| 0.05)], 2), P::UpperRight), "a win rate that stays low");
        assert!(matches!(at(&[along(|x| 1.0 - x)], 2), P::UpperRight), "a falling loss");
        // Curves along the top and the bottom leave the middle of a side.
        let both = [along(|_| 0.05), along(|_| 0.95)];
        assert!(matches!(at(&both, 2), P::MiddleRight), "top and bottom taken: the middle right");
        // A curve drawn from two points, its jump from 0 to 1 at the right edge.
        let jump = [vec![(0.0, 0.95), (0.7, 0.95), (0.8, 0.05), (1.0, 0.05)], vec![(0.0, 0.02), (0.7, 0.02), (0.7, 0.98), (1.0, 0.98)]];
        assert!(matches!(at(&jump, 2), P::MiddleLeft), "the jumps are seen between their points");
        // A taller legend (six lines) does not fit between curves at a third and two thirds.
        let thirds = [along(|_| 0.33), along(|_| 0.67)];
        assert!(matches!(at(&thirds, 2), P::LowerRight));
        assert!(!matches!(at(&thirds, 6), P::MiddleRight | P::MiddleLeft));
        assert!(matches!(at(&[], 2), P::LowerRight));
    }

    /// A win rate jumping between 0 and 0.95 draws no stroke out of its panel (over the title).
    #[test]
    fn sharp_turns_stay_inside_their_panel() {
        let path = std::env::temp_dir().join(format!("avacraft-zigzag-{}.png", std::process::id()));
        let points: Vec<CurvePoint> = (0..1000)
            .map(|i| CurvePoint {
                t_env: i * 10_000,
                test_win_rate: if i % 7 == 3 { 0.0 } else { 0.95 },
                train_win_rate: Some(0.5),
                test_return: 10.0,
                loss: 0.1,
                vs: Vec::new(),
            })
            .collect();
        curves(&path, "zigzag", &points, &[]).expect("drawn");
        let img = image::open(&path).expect("a PNG image reads back").to_rgb8();
        std::fs::remove_file(&path).ok();
        assert!(img.pixels().any(|p| p.0 == [0, 0, 255]), "the curve is drawn");
        // The title band, above the top panel: nothing of the curve.
        let over_title = (0..img.width()).flat_map(|x| (0..28).map(move |y| (x, y))).filter(|&(x, y)| img.get_pixel(x, y).0 == [0, 0, 255]);
        assert_eq!(over_title.count(), 0, "a stroke runs out over the title");
    }

    #[test]
    fn step_labels_are_short() {
        let got: Vec<String> = [0.0, 500.0, 40_000.0, 1e6, 2.5e6, 1e7].into_iter().map(steps_label).collect();
        assert_eq!(got, ["0", "500", "40k", "1M", "2.5M", "10M"]);
    }

    #[test]
    fn curves_are_drawn_into_a_png_of_their_size() {
        let dir = std::env::temp_dir().join(format!("avacraft-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("curves.png");
        let points: Vec<CurvePoint> = (0..20)
            .map(|i| CurvePoint {
                t_env: i * 1000,
                test_win_rate: i as f64 / 20.0,
                train_win_rate: Some(i as f64 / 25.0),
                test_return: i as f64,
                loss: 1.0 / (1.0 + i as f64),
                vs: Vec::new(),
            })
            .collect();
        curves(&path, "a run", &points, &[]).expect("drawn");
        let img = image::open(&path).expect("a PNG image reads back").to_rgb8();
        assert_eq!(img.dimensions(), (900, 900));
        // The greedy test curve is drawn in plotters' blue.
        assert!(img.pixels().any(|p| p.0 == [0, 0, 255]), "the blue test curve is on the canvas");
        assert!(img.pixels().filter(|p| p.0 == [255, 255, 255]).count() > 900 * 900 / 2, "a white background");
        // A league's five fixed opponents: seven lines, their key beside the panels (right of
        // every panel's plot), where two lines keep theirs inside.
        let key_green =
            |img: &image::RgbImage| (900 - KEY_WIDTH + 4..900).any(|x| (30..300).any(|y| img.get_pixel(x, y).0 == [0, 150, 70]));
        assert!(!key_green(&img), "two lines: no key beside the panels");
        let league: Vec<CurvePoint> = points.iter().map(|p| CurvePoint { vs: vec![0.5, 0.6, 0.7, 0.8, 0.9], ..p.clone() }).collect();
        let names: Vec<String> = ["focus-fire", "kite", "attack-move", "random", "hold"].map(String::from).to_vec();
        curves(&path, "a league run", &league, &names).expect("drawn");
        let img = image::open(&path).expect("a PNG image reads back").to_rgb8();
        assert!(key_green(&img), "the first opponent's line in the key");
        let right_of_plots = (900 - KEY_WIDTH + 4..900).all(|x| (300..900).all(|y| img.get_pixel(x, y).0 == [255, 255, 255]));
        assert!(right_of_plots, "the lower panels leave the key's room empty, their axes aligned with the top one's");
        // An unwritable path is an error naming it, not a panic.
        let bad = dir.join("missing-folder").join("curves.png");
        let e = curves(&bad, "a run", &points, &[]).expect_err("no folder to write into").to_string();
        assert!(e.contains("missing-folder"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
