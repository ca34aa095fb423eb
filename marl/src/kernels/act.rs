//! Elementwise activations for the fused networks, written so the compiler vectorises them
//! (no calls into libm in the loops): `exp` by range reduction to `[-ln2/2, ln2/2]` and a
//! degree-6 polynomial (relative error about 2e-7, as libm's within a few ulp), and the
//! logistic and hyperbolic tangent from it; and [`simd`], which compiles such loops for the
//! processor's best instruction set.

const LOG2E: f32 = std::f32::consts::LOG2_E;
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;

/// `e^x`, for `x` clamped to `[-87, 88]` (beyond, f32's range ends).
#[inline(always)]
pub(crate) fn exp(x: f32) -> f32 {
    let x = x.clamp(-87.0, 88.0);
    // Round to nearest by the 1.5 * 2^23 trick (no `roundps` on baseline x86-64, where
    // `round_ties_even` becomes a call per element).
    const MAGIC: f32 = 12_582_912.0;
    let n = (x * LOG2E + MAGIC) - MAGIC;
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = 1.0 + r * (1.0 + r * (0.5 + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    let scale = f32::from_bits(((n as i32 + 127) as u32) << 23);
    p * scale
}

/// The logistic function `1 / (1 + e^-x)`.
#[inline(always)]
pub(crate) fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + exp(-x))
}

/// `tanh x`: `(1 - e^-2|x|) / (1 + e^-2|x|)` with the sign of `x`, and its Taylor series
/// near 0, where that quotient loses the low digits.
#[inline(always)]
pub(crate) fn tanh(x: f32) -> f32 {
    let a = x.abs();
    let e = exp(-2.0 * a);
    let big = (1.0 - e) / (1.0 + e);
    let x2 = a * a;
    let small = a * (1.0 - x2 * (1.0 / 3.0 - x2 * (2.0 / 15.0)));
    let t = if a < 0.02 { small } else { big };
    t.copysign(x)
}

/// Runs `f` compiled for the best instruction set this processor has (AVX-512, AVX2+FMA,
/// else baseline), so the elementwise loops inlined into it are vectorised for it.
#[inline(always)]
pub(super) fn simd<R>(f: impl FnOnce() -> R) -> R {
    pulp::Arch::new().dispatch(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn activations_match_libm() {
        let mut worst = [0f64; 3];
        for i in -40_000..=40_000 {
            let x = i as f32 * 5e-4;
            let e = f64::from(exp(x));
            let want = f64::from(x).exp();
            worst[0] = worst[0].max(((e - want) / want).abs());
            worst[1] = worst[1].max((f64::from(sigmoid(x)) - 1.0 / (1.0 + (-f64::from(x)).exp())).abs());
            let t = f64::from(tanh(x));
            let tw = f64::from(x).tanh();
            worst[2] = worst[2].max((t - tw).abs() / tw.abs().max(1e-3));
        }
        assert!(worst[0] < 5e-7, "exp: relative error {}", worst[0]);
        assert!(worst[1] < 2e-7, "sigmoid: absolute error {}", worst[1]);
        assert!(worst[2] < 1e-5, "tanh: relative error {}", worst[2]);
        assert!(exp(-1000.0) > 0.0 && exp(-1000.0) < 1e-37);
        assert!(exp(1000.0).is_finite() && sigmoid(-1000.0) >= 0.0 && sigmoid(1000.0) == 1.0);
        assert_eq!((tanh(50.0), tanh(-50.0), tanh(0.0)), (1.0, -1.0, 0.0));
    }
}
