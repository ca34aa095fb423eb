//! What a cell's episodes add up to. Each seed is one episode, so the spread over seeds is
//! the sample standard deviation of the per-episode outcome; the win rate's 95% interval is
//! Wilson's score interval (it stays inside [0, 1] and behaves at 0 and 1 wins, where the
//! normal approximation does not), with the normal quantile from statrs.

use crate::plan::CellKey;
use crate::results::EpisodeResult;
use avacraft_engine::Outcome;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, Normal};

/// Mean and sample standard deviation (0 for fewer than two values).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeanStd {
    pub mean: f64,
    pub std: f64,
}

impl MeanStd {
    pub fn of(values: impl IntoIterator<Item = f64>) -> MeanStd {
        let v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return MeanStd::default();
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let std = if v.len() < 2 { 0.0 } else { (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() };
        MeanStd { mean, std }
    }
}

/// Wilson's score interval for `k` successes in `n` trials at 95%.
pub fn wilson95(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    // The standard normal always exists; 1.959963984540054 is its 0.975 quantile.
    let z = Normal::new(0.0, 1.0).map_or(1.959_963_984_540_054, |d| d.inverse_cdf(0.975));
    let (n, p) = (n as f64, k as f64 / n as f64);
    let denom = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / denom;
    let half = z * ((p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt()) / denom;
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// Model use per decision and per episode (AVA cells).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CostStats {
    pub decisions_per_episode: f64,
    pub calls_per_decision: f64,
    pub tokens_per_decision: f64,
    pub dollars_per_episode: f64,
    /// Episodes that used a model missing from the price table.
    pub unpriced_episodes: usize,
    pub model_seconds_per_decision: f64,
    pub failed_calls: u64,
    pub fallbacks: u64,
}

/// A cell's statistics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellStats {
    pub key: CellKey,
    pub episodes: usize,
    pub failed: usize,
    pub wins: usize,
    pub draws: usize,
    pub losses: usize,
    /// Per-episode win (1) or not (0), over seeds.
    pub win_rate: MeanStd,
    pub win_ci95: (f64, f64),
    pub draw_rate: f64,
    pub loss_rate: f64,
    pub game_seconds: MeanStd,
    pub damage_dealt: MeanStd,
    pub damage_taken: MeanStd,
    pub kills: MeanStd,
    pub deaths: MeanStd,
    pub refused_actions: MeanStd,
    pub cost: Option<CostStats>,
}

impl CellStats {
    /// The statistics of `results` (all of one cell); failed ones are counted apart.
    pub fn of(key: CellKey, results: &[&EpisodeResult], failed: usize) -> CellStats {
        let ok: Vec<&&EpisodeResult> = results.iter().filter(|r| r.ok()).collect();
        let is = |r: &EpisodeResult, what: Outcome| r.result == Some(what);
        let wins = ok.iter().filter(|r| is(r, Outcome::Win)).count();
        let draws = ok.iter().filter(|r| is(r, Outcome::Draw)).count();
        let n = ok.len();
        let rate = |k: usize| if n == 0 { 0.0 } else { k as f64 / n as f64 };
        let f = |g: &dyn Fn(&EpisodeResult) -> f64| MeanStd::of(ok.iter().map(|r| g(r)));
        let models: Vec<_> = ok.iter().filter_map(|r| r.model.as_ref()).collect();
        let cost = (!models.is_empty()).then(|| {
            let decisions: u64 = models.iter().map(|m| m.decisions).sum();
            let d = decisions.max(1) as f64;
            CostStats {
                decisions_per_episode: decisions as f64 / models.len() as f64,
                calls_per_decision: models.iter().map(|m| m.calls).sum::<u64>() as f64 / d,
                tokens_per_decision: models.iter().map(|m| m.prompt_tokens + m.completion_tokens).sum::<u64>() as f64 / d,
                dollars_per_episode: models.iter().map(|m| m.cost_usd).sum::<f64>() / models.len() as f64,
                unpriced_episodes: models.iter().filter(|m| m.unpriced_calls > 0).count(),
                model_seconds_per_decision: models.iter().map(|m| m.model_ms).sum::<f64>() / d / 1000.0,
                failed_calls: models.iter().map(|m| m.failed_calls).sum(),
                fallbacks: models.iter().map(|m| m.fallbacks).sum(),
            }
        });
        CellStats {
            key,
            episodes: n,
            failed,
            wins,
            draws,
            losses: n - wins - draws,
            win_rate: MeanStd::of(ok.iter().map(|r| f64::from(u8::from(is(r, Outcome::Win))))),
            win_ci95: wilson95(wins, n),
            draw_rate: rate(draws),
            loss_rate: rate(n - wins - draws),
            game_seconds: f(&|r| r.game_seconds),
            damage_dealt: f(&|r| r.damage_dealt[0]),
            damage_taken: f(&|r| r.damage_dealt[1]),
            kills: f(&|r| f64::from(r.kills[0])),
            deaths: f(&|r| f64::from(r.kills[1])),
            refused_actions: f(&|r| f64::from(r.refused_actions[0])),
            cost,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_published_values() {
        // 8 of 10: Wilson's 95% interval is [0.4902, 0.9433] (Newcombe 1998, method 3).
        let (lo, hi) = wilson95(8, 10);
        assert!((lo - 0.4902).abs() < 5e-4 && (hi - 0.9433).abs() < 5e-4, "{lo} {hi}");
        let (lo, hi) = wilson95(0, 10);
        assert!(lo.abs() < 1e-12 && (hi - 0.2775).abs() < 5e-4, "{lo} {hi}");
        assert_eq!(wilson95(0, 0), (0.0, 1.0));
    }

    #[test]
    fn sample_standard_deviation() {
        let m = MeanStd::of([1.0, 0.0, 1.0, 1.0]);
        assert!((m.mean - 0.75).abs() < 1e-12 && (m.std - 0.5).abs() < 1e-12, "{m:?}");
        assert_eq!(MeanStd::of([3.0]), MeanStd { mean: 3.0, std: 0.0 });
    }
}
