//! MAPPO's `ValueNorm`: the critic learns returns scaled by running statistics, so its
//! targets stay near unit scale while the returns grow from about 0 to SMAC's 20 as the team
//! learns to win, and one learning rate suits the whole run.
//!
//! The statistics are exponential moving averages of the batches' mean and mean square with a
//! debiasing term (as in Adam), kept in f64 outside the autograd graph: they are data, not
//! parameters. With `beta` 0.99999 and one update per rollout the weights of all batches
//! stay nearly equal, so the statistics are close to those of every return seen so far.

/// Running mean and variance of the value targets.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ValueNorm {
    beta: f64,
    mean: f64,
    mean_sq: f64,
    debias: f64,
}

/// The MAPPO repository's smoothing (`utils/valuenorm.py`).
pub const BETA: f64 = 0.99999;
/// Lower bound of the debiasing term and of the variance (the repository's `epsilon`, `1e-2`).
const EPS: f64 = 1e-5;
const MIN_VAR: f64 = 1e-2;

impl Default for ValueNorm {
    fn default() -> Self {
        ValueNorm::new(BETA)
    }
}

impl ValueNorm {
    pub fn new(beta: f64) -> ValueNorm {
        ValueNorm { beta, mean: 0.0, mean_sq: 0.0, debias: 0.0 }
    }

    /// Folds a batch of targets into the statistics (nothing for an empty batch).
    pub fn update(&mut self, xs: &[f32]) {
        if xs.is_empty() {
            return;
        }
        let n = xs.len() as f64;
        let m = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
        let sq = xs.iter().map(|&x| f64::from(x) * f64::from(x)).sum::<f64>() / n;
        let w = self.beta;
        self.mean = self.mean * w + m * (1.0 - w);
        self.mean_sq = self.mean_sq * w + sq * (1.0 - w);
        self.debias = self.debias * w + (1.0 - w);
    }

    /// The debiased mean and standard deviation (0 and 0.1 before any update).
    pub fn stats(&self) -> (f64, f64) {
        let d = self.debias.max(EPS);
        let mean = self.mean / d;
        let var = (self.mean_sq / d - mean * mean).max(MIN_VAR);
        (mean, var.sqrt())
    }

    pub fn normalize(&self, x: f32) -> f32 {
        let (m, s) = self.stats();
        ((f64::from(x) - m) / s) as f32
    }

    pub fn denormalize(&self, x: f32) -> f32 {
        let (m, s) = self.stats();
        (f64::from(x) * s + m) as f32
    }
}
