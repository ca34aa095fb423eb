//! Layer normalisation over rows (PyTorch's `nn.LayerNorm`, eps 1e-5, biased variance) with
//! a tape for its backward pass: the MAPPO repository's networks normalise their inputs and
//! every hidden layer's output ([`super::NetLayout`]'s `norm`).

const EPS: f32 = 1e-5;

/// What a normalisation keeps for its backward pass: each row normalised (before its scale
/// and shift) and each row's `1 / sqrt(var + eps)`.
#[derive(Debug, Default)]
pub(super) struct NormTape {
    xhat: Vec<f32>,
    rstd: Vec<f32>,
}

/// Normalises each `width`-wide row of `x` in place: `gamma * (x - mean) / sqrt(var + eps)
/// + beta`.
pub(super) fn norm_forward(x: &mut [f32], width: usize, gamma: &[f32], beta: &[f32]) -> NormTape {
    let rows = x.len() / width.max(1);
    let mut tape = NormTape { xhat: vec![0f32; x.len()], rstd: vec![0f32; rows] };
    for ((row, xh), rstd) in x.chunks_exact_mut(width).zip(tape.xhat.chunks_exact_mut(width)).zip(&mut tape.rstd) {
        let mean = row.iter().sum::<f32>() / width as f32;
        let var = row.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / width as f32;
        let r = 1.0 / (var + EPS).sqrt();
        *rstd = r;
        for (((v, h), g), b) in row.iter_mut().zip(xh.iter_mut()).zip(gamma).zip(beta) {
            *h = (*v - mean) * r;
            *v = g * *h + b;
        }
    }
    tape
}

/// The backward pass: `d` holds the gradient with respect to the normalised rows and is
/// turned into the gradient with respect to their inputs; the scale's and shift's gradients
/// are added to `d_gamma` and `d_beta`.
pub(super) fn norm_backward(d: &mut [f32], tape: &NormTape, width: usize, gamma: &[f32], d_gamma: &mut [f32], d_beta: &mut [f32]) {
    let w = width as f32;
    for ((row, xh), &r) in d.chunks_exact_mut(width).zip(tape.xhat.chunks_exact(width)).zip(&tape.rstd) {
        let (mut mean_g, mut mean_gx) = (0f32, 0f32);
        for (k, (&dy, &h)) in row.iter().zip(xh).enumerate() {
            d_gamma[k] += dy * h;
            d_beta[k] += dy;
            let g = dy * gamma[k];
            mean_g += g;
            mean_gx += g * h;
        }
        mean_g /= w;
        mean_gx /= w;
        for (k, (v, &h)) in row.iter_mut().zip(xh).enumerate() {
            *v = r * (*v * gamma[k] - mean_g - h * mean_gx);
        }
    }
}

/// [`norm_backward`] for a norm whose scale sits at `at` in the flat parameters `theta` and its
/// shift right after, its gradients added to the same places of `g`.
pub(super) fn norm_backward_at(theta: &[f32], d: &mut [f32], tape: &NormTape, width: usize, at: usize, g: &mut [f32]) {
    let (dg, db) = g[at..at + 2 * width].split_at_mut(width);
    norm_backward(d, tape, width, &theta[at..at + width], dg, db);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic gradients against central differences of `sum(y * w)`.
    #[test]
    fn backward_matches_finite_differences() {
        let (width, rows) = (5, 3);
        let x: Vec<f32> = (0..width * rows).map(|i| ((i * 37 % 11) as f32 - 5.0) * 0.3).collect();
        let gamma = [1.0, 0.5, -0.7, 2.0, 1.3];
        let beta = [0.1, -0.2, 0.0, 0.3, 0.5];
        let wts: Vec<f32> = (0..width * rows).map(|i| ((i * 13 % 7) as f32 - 3.0) * 0.25).collect();
        let loss = |x: &[f32], g: &[f32], b: &[f32]| {
            let mut y = x.to_vec();
            norm_forward(&mut y, width, g, b);
            y.iter().zip(&wts).map(|(a, b)| (a * b) as f64).sum::<f64>()
        };
        let mut y = x.clone();
        let tape = norm_forward(&mut y, width, &gamma, &beta);
        let mut d = wts.clone();
        let (mut dg, mut db) = (vec![0f32; width], vec![0f32; width]);
        norm_backward(&mut d, &tape, width, &gamma, &mut dg, &mut db);
        let h = 1e-3f32;
        for i in 0..x.len() {
            let (mut a, mut b) = (x.clone(), x.clone());
            a[i] += h;
            b[i] -= h;
            let num = (loss(&a, &gamma, &beta) - loss(&b, &gamma, &beta)) / (2.0 * h as f64);
            assert!((num - d[i] as f64).abs() < 2e-3, "dx[{i}]: numeric {num}, analytic {}", d[i]);
        }
        for k in 0..width {
            let (mut a, mut b) = (gamma, gamma);
            a[k] += h;
            b[k] -= h;
            let num = (loss(&x, &a, &beta) - loss(&x, &b, &beta)) / (2.0 * h as f64);
            assert!((num - dg[k] as f64).abs() < 2e-3, "dgamma[{k}]: numeric {num}, analytic {}", dg[k]);
            let (mut a, mut b) = (beta, beta);
            a[k] += h;
            b[k] -= h;
            let num = (loss(&x, &gamma, &a) - loss(&x, &gamma, &b)) / (2.0 * h as f64);
            assert!((num - db[k] as f64).abs() < 2e-3, "dbeta[{k}]: numeric {num}, analytic {}", db[k]);
        }
    }
}
