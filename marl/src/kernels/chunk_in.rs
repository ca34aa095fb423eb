//! The first layer's inputs as a chunk of [`super::NetLayout`]'s pass keeps them: rows
//! written out, or rows that share a table (MAPPO's critic: every agent of an environment
//! step reads the one global state), and the first layer's product and gradient on either.

use super::act::simd;
use super::gemm::{Mat, matmul};

/// A chunk's inputs, kept for the backward pass.
#[derive(Debug)]
pub(super) enum ChunkIn {
    /// Packed rows `(rows, input)`.
    Rows(Vec<f32>),
    /// The distinct table rows the chunk reads (`(U, width)`, in table order), each packed
    /// row's index among them, and its id.
    Shared { table: Vec<f32>, width: usize, local: Vec<u32>, ids: Vec<u32> },
}

impl Default for ChunkIn {
    fn default() -> ChunkIn {
        ChunkIn::Rows(Vec::new())
    }
}

impl ChunkIn {
    /// The rows written out `(rows, input)`.
    pub(super) fn into_rows(self, input: usize) -> Vec<f32> {
        match self {
            ChunkIn::Rows(x) => x,
            ChunkIn::Shared { table, width, local, ids } => {
                let mut x = vec![0f32; local.len() * input];
                for ((row, &l), &id) in x.chunks_exact_mut(input.max(1)).zip(&local).zip(&ids) {
                    row[..width].copy_from_slice(&table[l as usize * width..][..width]);
                    row[width + id as usize] = 1.0;
                }
                x
            }
        }
    }

    pub(super) fn shared(table: &[f32], width: usize, idx: &[u32], ids: Vec<u32>) -> ChunkIn {
        let mut distinct = idx.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        // Every index is among the distinct ones, so the search finds it.
        let local = idx.iter().map(|i| distinct.binary_search(i).unwrap_or_else(|at| at) as u32).collect();
        let mut rows = Vec::with_capacity(distinct.len() * width);
        for &d in &distinct {
            rows.extend_from_slice(&table[d as usize * width..(d as usize + 1) * width]);
        }
        ChunkIn::Shared { table: rows, width, local, ids }
    }

    /// Adds `x W1^T` to `a1` (`(rows, h)`, the biases in), `w1` `(h, input)` row-major.
    pub(super) fn first_layer(&self, a1: &mut [f32], w1: &[f32], input: usize, h: usize) {
        let rows = a1.len() / h.max(1);
        match self {
            ChunkIn::Rows(x) => matmul(a1, h, Mat::rows(x, rows, input), Mat::t(w1, input, h), true),
            ChunkIn::Shared { table, width, local, ids } => {
                let w = *width;
                let distinct = table.len() / w.max(1);
                // Each distinct row's product once: `table W_s^T`, `W_s` the first `w` columns.
                let mut proj = vec![0f32; distinct * h];
                matmul(&mut proj, h, Mat::rows(table, distinct, w), Mat::strided(w1, w, h, 1, input), false);
                // The one-hot's product is the id's column of `W1`.
                let id_cols = transpose_cols(w1, input, h, w);
                simd(|| {
                    for (r, row) in a1.chunks_exact_mut(h.max(1)).enumerate() {
                        let pr = &proj[local[r] as usize * h..][..h];
                        let ir = &id_cols[ids[r] as usize * h..][..h];
                        row.iter_mut().zip(pr.iter().zip(ir)).for_each(|(a, (p, c))| *a += p + c);
                    }
                });
            }
        }
    }

    /// Writes `W1`'s gradient (`(h, input)` row-major, into `g`) from `da1` `(rows, h)`.
    pub(super) fn first_layer_grad(&self, g: &mut [f32], da1: &[f32], input: usize, h: usize) {
        let rows = da1.len() / h.max(1);
        match self {
            ChunkIn::Rows(x) => matmul(g, input, Mat::t(da1, h, rows), Mat::rows(x, rows, input), false),
            ChunkIn::Shared { table, width, local, ids } => {
                let w = *width;
                let distinct = table.len() / w.max(1);
                // The rows' gradients summed per distinct table row and per id, then one product.
                let (mut per_row, mut per_id) = (vec![0f32; distinct * h], vec![0f32; (input - w) * h]);
                simd(|| {
                    for (r, d) in da1.chunks_exact(h.max(1)).enumerate() {
                        let pr = &mut per_row[local[r] as usize * h..][..h];
                        pr.iter_mut().zip(d).for_each(|(a, &b)| *a += b);
                        let ir = &mut per_id[ids[r] as usize * h..][..h];
                        ir.iter_mut().zip(d).for_each(|(a, &b)| *a += b);
                    }
                });
                matmul(g, input, Mat::t(&per_row, h, distinct), Mat::rows(table, distinct, w), false);
                for (id, col) in per_id.chunks_exact(h.max(1)).enumerate() {
                    for (j, &v) in col.iter().enumerate() {
                        g[j * input + w + id] = v;
                    }
                }
            }
        }
    }
}

/// Columns `from..input` of a row-major `(h, input)` matrix, as rows `(input - from, h)`.
fn transpose_cols(m: &[f32], input: usize, h: usize, from: usize) -> Vec<f32> {
    let mut out = vec![0f32; (input - from) * h];
    for (j, row) in m.chunks_exact(input.max(1)).take(h).enumerate() {
        for (c, &v) in row[from..].iter().enumerate() {
            out[c * h + j] = v;
        }
    }
    out
}
