//! The one place this crate calls a matrix-product kernel by pointer: the `gemm` crate
//! (the kernel candle's CPU back end itself uses, AVX-512/AVX2/FMA by run-time dispatch),
//! behind a safe, bounds-checked view type. Everything else in [`super`] is safe code.

use std::fmt;

/// A read-only strided matrix view: element `(i, j)` is `data[i * rs + j * cs]`.
#[derive(Clone, Copy)]
pub(crate) struct Mat<'a> {
    data: &'a [f32],
    rows: usize,
    cols: usize,
    rs: usize,
    cs: usize,
}

impl fmt::Debug for Mat<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Mat({}x{}, rs {}, cs {})", self.rows, self.cols, self.rs, self.cs)
    }
}

impl<'a> Mat<'a> {
    /// A row-major `rows x cols` matrix. Panics if `data` is too short (a caller's bug).
    pub(crate) fn rows(data: &'a [f32], rows: usize, cols: usize) -> Mat<'a> {
        Mat::strided(data, rows, cols, cols, 1)
    }
    /// The transpose of a row-major `cols x rows` matrix, as a `rows x cols` view.
    pub(crate) fn t(data: &'a [f32], rows: usize, cols: usize) -> Mat<'a> {
        Mat::strided(data, rows, cols, 1, rows)
    }
    pub(crate) fn strided(data: &'a [f32], rows: usize, cols: usize, rs: usize, cs: usize) -> Mat<'a> {
        let last = if rows == 0 || cols == 0 { 0 } else { (rows - 1) * rs + (cols - 1) * cs + 1 };
        assert!(last <= data.len(), "matrix view {rows}x{cols} (rs {rs}, cs {cs}) over {} values", data.len());
        Mat { data, rows, cols, rs, cs }
    }
}

/// `c = (accumulate ? c : 0) + a * b` with `c` row-major `a.rows x b.cols` (leading
/// dimension `ldc`). Single-threaded: callers split the work in fixed chunks, so results do
/// not depend on the number of threads.
pub(crate) fn matmul(c: &mut [f32], ldc: usize, a: Mat<'_>, b: Mat<'_>, accumulate: bool) {
    let (m, k, n) = (a.rows, a.cols, b.cols);
    assert_eq!(k, b.rows, "inner dimensions {k} and {}", b.rows);
    assert!(ldc >= n, "leading dimension {ldc} for {n} columns");
    if m == 0 || n == 0 {
        return;
    }
    assert!((m - 1) * ldc + n <= c.len(), "output {m}x{n} (ld {ldc}) over {} values", c.len());
    if k == 0 {
        if !accumulate {
            for row in c.chunks_mut(ldc).take(m) {
                row[..n].fill(0.0);
            }
        }
        return;
    }
    // SAFETY: the views' and the output's extents were checked against their slices above
    // (every index the kernel reads or writes is below them), the output does not alias the
    // inputs (a `&mut` and two `&` borrows), and `gemm` is called single-threaded.
    #[allow(unsafe_code)]
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            c.as_mut_ptr(),
            1,
            ldc as isize,
            accumulate,
            a.data.as_ptr(),
            a.cs as isize,
            a.rs as isize,
            b.data.as_ptr(),
            b.cs as isize,
            b.rs as isize,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(a: Mat<'_>, b: Mat<'_>) -> Vec<f32> {
        let mut out = vec![0f32; a.rows * b.cols];
        for i in 0..a.rows {
            for j in 0..b.cols {
                out[i * b.cols + j] = (0..a.cols)
                    .map(|p| f64::from(a.data[i * a.rs + p * a.cs]) * f64::from(b.data[p * b.rs + j * b.cs]))
                    .sum::<f64>() as f32;
            }
        }
        out
    }

    #[test]
    fn products_match_a_plain_loop_for_every_layout() {
        let (m, k, n) = (7, 5, 3);
        let a: Vec<f32> = (0..m * k).map(|i| (i as f32 * 0.37).sin()).collect();
        let b: Vec<f32> = (0..k * n).map(|i| (i as f32 * 0.11).cos()).collect();
        for (av, bv) in [
            (Mat::rows(&a, m, k), Mat::rows(&b, k, n)),
            (Mat::t(&a, m, k), Mat::rows(&b, k, n)),
            (Mat::rows(&a, m, k), Mat::t(&b, k, n)),
            (Mat::t(&a, m, k), Mat::t(&b, k, n)),
        ] {
            let want = naive(av, bv);
            let mut c = vec![1f32; m * n];
            matmul(&mut c, n, av, bv, false);
            for (x, y) in c.iter().zip(&want) {
                assert!((x - y).abs() < 1e-5, "{x} vs {y}");
            }
            matmul(&mut c, n, av, bv, true);
            for (x, y) in c.iter().zip(&want) {
                assert!((x - 2.0 * y).abs() < 1e-5, "{x} vs 2 x {y}");
            }
        }
    }

    #[test]
    #[should_panic(expected = "matrix view")]
    fn a_view_past_its_data_is_refused() {
        let a = [0f32; 5];
        let _ = Mat::rows(&a, 2, 3);
    }
}
