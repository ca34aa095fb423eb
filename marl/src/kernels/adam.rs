//! Adam (PyTorch's, as candle's `AdamW` with no weight decay: bias-corrected moments,
//! `eps` added to the root), RMSprop (PyTorch's, as [`crate::optim`]'s: no momentum, not
//! centred) and global-norm gradient clipping on flat vectors.

/// An optimiser's running state over one flat vector (Adam's two moments and its step count;
/// RMSprop's squared-gradient average), kept across a resume so a resumed run's first steps
/// are not those of a fresh optimiser (Adam's bias correction makes them full-size).
#[derive(Clone, Debug, PartialEq)]
pub struct Moments {
    pub vectors: Vec<Vec<f32>>,
    pub steps: i32,
}

impl Moments {
    /// Refuses a state whose vectors' lengths are not `lens` (another optimiser or network).
    fn check(&self, lens: &[usize]) -> Result<(), String> {
        let shape: Vec<usize> = self.vectors.iter().map(Vec::len).collect();
        if shape != lens || self.steps < 0 {
            return Err(format!("vectors of lengths {shape:?} and {} steps where {lens:?} are needed", self.steps));
        }
        Ok(())
    }
}

/// Adam's state for one flat parameter vector.
#[derive(Clone, Debug)]
pub struct Adam {
    pub lr: f64,
    pub eps: f64,
    beta1: f64,
    beta2: f64,
    m: Vec<f32>,
    v: Vec<f32>,
    steps: i32,
}

impl Adam {
    pub fn new(len: usize, lr: f64, eps: f64) -> Adam {
        Adam { lr, eps, beta1: 0.9, beta2: 0.999, m: vec![0.0; len], v: vec![0.0; len], steps: 0 }
    }

    pub fn moments(&self) -> Moments {
        Moments { vectors: vec![self.m.clone(), self.v.clone()], steps: self.steps }
    }

    /// Takes up a saved state; refuses one of another shape, naming it.
    pub fn set_moments(&mut self, m: Moments) -> Result<(), String> {
        m.check(&[self.m.len(), self.v.len()])?;
        let mut it = m.vectors.into_iter();
        if let (Some(first), Some(second)) = (it.next(), it.next()) {
            (self.m, self.v, self.steps) = (first, second, m.steps);
        }
        Ok(())
    }

    /// One step of `theta` along `grad`.
    pub fn step(&mut self, theta: &mut [f32], grad: &[f32]) {
        assert_eq!((theta.len(), grad.len()), (self.m.len(), self.m.len()), "Adam over a vector of another size");
        self.steps += 1;
        let (b1, b2) = (self.beta1 as f32, self.beta2 as f32);
        let scale_m = (1.0 / (1.0 - self.beta1.powi(self.steps))) as f32;
        let scale_v = (1.0 / (1.0 - self.beta2.powi(self.steps))) as f32;
        let (lr, eps) = (self.lr as f32, self.eps as f32);
        for (((p, &g), m), v) in theta.iter_mut().zip(grad).zip(&mut self.m).zip(&mut self.v) {
            *m = *m * b1 + g * (1.0 - b1);
            *v = *v * b2 + g * g * (1.0 - b2);
            *p -= lr * (*m * scale_m) / ((*v * scale_v).sqrt() + eps);
        }
    }
}

/// RMSprop's state for one flat parameter vector.
#[derive(Clone, Debug)]
pub struct RmsProp {
    pub lr: f64,
    pub alpha: f64,
    pub eps: f64,
    square_avg: Vec<f32>,
}

impl RmsProp {
    pub fn new(len: usize, lr: f64, alpha: f64, eps: f64) -> RmsProp {
        RmsProp { lr, alpha, eps, square_avg: vec![0.0; len] }
    }

    pub fn moments(&self) -> Moments {
        Moments { vectors: vec![self.square_avg.clone()], steps: 0 }
    }

    /// Takes up a saved state; refuses one of another shape, naming it.
    pub fn set_moments(&mut self, m: Moments) -> Result<(), String> {
        m.check(&[self.square_avg.len()])?;
        if let Some(sq) = m.vectors.into_iter().next() {
            self.square_avg = sq;
        }
        Ok(())
    }

    /// One step of `theta` along `grad`.
    pub fn step(&mut self, theta: &mut [f32], grad: &[f32]) {
        assert_eq!((theta.len(), grad.len()), (self.square_avg.len(), self.square_avg.len()), "RMSprop over a vector of another size");
        let (a, lr, eps) = (self.alpha as f32, self.lr as f32, self.eps as f32);
        for ((p, &g), sq) in theta.iter_mut().zip(grad).zip(&mut self.square_avg) {
            *sq = *sq * a + g * g * (1.0 - a);
            *p -= g / (sq.sqrt() + eps) * lr;
        }
    }
}

/// Scales `grad` so its L2 norm is at most `max_norm` (as `torch.nn.utils.clip_grad_norm_`);
/// returns the norm before clipping.
pub fn clip_global_norm(grad: &mut [f32], max_norm: f64) -> f64 {
    let norm = grad.iter().map(|&g| f64::from(g) * f64::from(g)).sum::<f64>().sqrt();
    if norm > max_norm {
        let s = (max_norm / (norm + 1e-6)) as f32;
        grad.iter_mut().for_each(|g| *g *= s);
    }
    norm
}
