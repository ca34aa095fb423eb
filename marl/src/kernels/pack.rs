//! Which rows of an `(L, N)` batch a chunk of [`super::net`] computes, packed step by step.
//!
//! Why: rows whose outputs nobody reads cost as much as the others. PPO's rows of dead agents
//! (a third of a rollout on 2s3z_vlm at the start of training) are left out of every loss, and
//! the Q-learners' padding past an episode's end is masked. A row nobody reads can be skipped
//! when no row that is read depends on it: for a recurrent network, when every later row of
//! its sequence up to the next episode start (`keep` 0, which zeroes the hidden state) is
//! skipped too. The rows that are read then get the values the full pass gives them.

/// The rows whose outputs (and gradients) the caller reads. The backward pass takes the
/// output gradients of the rows it computed, so a caller gives the rows it does not read
/// gradients of 0 (as a masked loss does): skipping them assumes it.
#[derive(Clone, Copy, Debug, Default)]
pub enum Want<'a> {
    /// Every row.
    #[default]
    All,
    /// `(N)`: sequence `i`'s steps from `lens[i]` on are padding.
    Lens(&'a [usize]),
    /// `(L, N)` time-major: the rows where this is 0 are not read (PPO's inactive rows).
    Mask(&'a [f32]),
}

impl Want<'_> {
    /// Panics (a caller's bug) unless this describes `l` steps of `n` sequences.
    pub(super) fn check(&self, l: usize, n: usize) {
        match self {
            Want::All => {}
            Want::Lens(ls) => assert_eq!(ls.len(), n, "sequence lengths"),
            Want::Mask(m) => assert_eq!(m.len(), l * n, "the rows read"),
        }
    }

    fn wants(&self, t: usize, n: usize, seq: usize) -> bool {
        match self {
            Want::All => true,
            Want::Lens(ls) => t < ls[seq],
            Want::Mask(m) => m[t * n + seq] != 0.0,
        }
    }
}

/// A packed row with no row before it in its sequence (the first step, or a skipped one).
pub(super) const NONE: u32 = u32::MAX;

/// One chunk's computed rows, time-major: step `t`'s rows are `steps[t].0 ..` `+ steps[t].1`.
#[derive(Clone, Debug, Default)]
pub(super) struct Packing {
    /// Each step's first packed row and row count.
    pub steps: Vec<(usize, usize)>,
    /// Each packed row's sequence, counted from the chunk's first.
    pub seqs: Vec<u32>,
    /// Each packed row's packed row at the step before, in the same sequence, or [`NONE`].
    pub prev: Vec<u32>,
}

impl Packing {
    /// The rows of sequences `c0..c1` (of `n`) over `l` steps that `want` reads, or that a
    /// row it reads depends on through the hidden state (`recurrent`), up to an episode
    /// start (`keep` 0).
    pub fn new(want: Want<'_>, keep: Option<&[f32]>, recurrent: bool, l: usize, n: usize, (c0, c1): (usize, usize)) -> Packing {
        let nc = c1 - c0;
        let mut live = vec![false; l * nc];
        for s in 0..nc {
            let mut needed_next = false;
            for t in (0..l).rev() {
                let carried = recurrent && needed_next && t + 1 < l && keep.is_none_or(|k| k[(t + 1) * n + c0 + s] != 0.0);
                let needed = carried || want.wants(t, n, c0 + s);
                live[t * nc + s] = needed;
                needed_next = needed;
            }
        }
        let mut p = Packing { steps: Vec::with_capacity(l), ..Packing::default() };
        let mut at_prev = vec![NONE; nc];
        for t in 0..l {
            let base = p.seqs.len();
            for (s, at) in at_prev.iter_mut().enumerate() {
                if live[t * nc + s] {
                    p.prev.push(*at);
                    *at = p.seqs.len() as u32;
                    p.seqs.push(s as u32);
                } else {
                    *at = NONE;
                }
            }
            p.steps.push((base, p.seqs.len() - base));
        }
        p
    }

    /// The number of packed rows.
    pub fn rows(&self) -> usize {
        self.seqs.len()
    }

    /// Each step's runs of consecutive sequences: `(t, first packed row, first sequence, count)`.
    fn runs(&self) -> impl Iterator<Item = (usize, usize, usize, usize)> + '_ {
        self.steps.iter().enumerate().flat_map(move |(t, &(base, cnt))| {
            let seqs = &self.seqs[base..base + cnt];
            let mut k = 0;
            std::iter::from_fn(move || {
                let start = k;
                let first = *seqs.get(start)? as usize;
                k += 1;
                while k < seqs.len() && seqs[k] as usize == first + (k - start) {
                    k += 1;
                }
                Some((t, base + start, first, k - start))
            })
        })
    }

    /// The packed rows of a `(L, N, w)` array, for the chunk whose first sequence is `c0`.
    pub fn gather<T: Copy>(&self, data: &[T], n: usize, w: usize, c0: usize) -> Vec<T> {
        let mut out = Vec::with_capacity(self.rows() * w);
        for (t, _, s, cnt) in self.runs() {
            let at = (t * n + c0 + s) * w;
            out.extend_from_slice(&data[at..at + cnt * w]);
        }
        out
    }

    /// The inverse of [`Packing::gather`] (rows not packed are left as they are).
    pub fn scatter(&self, data: &mut [f32], part: &[f32], n: usize, w: usize, c0: usize) {
        for (t, row, s, cnt) in self.runs() {
            let at = (t * n + c0 + s) * w;
            data[at..at + cnt * w].copy_from_slice(&part[row * w..(row + cnt) * w]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows a packing computes, as `(t, sequence)`.
    fn computed(p: &Packing) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (t, &(base, cnt)) in p.steps.iter().enumerate() {
            out.extend(p.seqs[base..base + cnt].iter().map(|&s| (t, s as usize)));
        }
        out
    }

    #[test]
    fn skipped_rows_are_those_no_read_row_depends_on() {
        // 4 steps of 2 sequences; sequence 0 dies after step 0, a new episode starts at
        // step 2 (keep 0) and is read at step 3; sequence 1 is read at step 1 only.
        let mask = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0];
        let keep = [1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0];
        let p = Packing::new(Want::Mask(&mask), Some(&keep), true, 4, 2, (0, 2));
        // Sequence 0 at step 2 is its new episode's first step, which step 3 reads through
        // the hidden state; step 1 feeds nothing read. Sequence 1 needs step 0 for step 1.
        assert_eq!(computed(&p), vec![(0, 0), (0, 1), (1, 1), (2, 0), (3, 0)]);
        assert_eq!(p.prev, vec![NONE, NONE, 1, NONE, 3]);
        // Feed-forward: only the rows read.
        let ff = Packing::new(Want::Mask(&mask), Some(&keep), false, 4, 2, (0, 2));
        assert_eq!(computed(&ff), vec![(0, 0), (1, 1), (3, 0)]);
        // Without episode starts, every row before a read one is needed.
        let chained = Packing::new(Want::Mask(&mask), None, true, 4, 2, (0, 2));
        assert_eq!(computed(&chained), vec![(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (3, 0)]);
    }

    #[test]
    fn lengths_pack_each_step_s_running_sequences() {
        let p = Packing::new(Want::Lens(&[3, 1, 2]), None, true, 3, 3, (0, 3));
        assert_eq!(p.steps, vec![(0, 3), (3, 2), (5, 1)]);
        assert_eq!(p.seqs, vec![0, 1, 2, 0, 2, 0]);
        assert_eq!(p.prev, vec![NONE, NONE, NONE, 0, 2, 3]);
    }

    #[test]
    fn gather_and_scatter_are_inverse_on_the_packed_rows() {
        // 3 steps of 5 sequences, 2 values each; the chunk is sequences 1..5.
        let data: Vec<f32> = (0..30).map(|v| v as f32).collect();
        let mask: Vec<f32> = (0..15).map(|i| if i % 3 == 0 { 0.0 } else { 1.0 }).collect();
        let p = Packing::new(Want::Mask(&mask), None, false, 3, 5, (1, 5));
        let part = p.gather(&data, 5, 2, 1);
        assert_eq!(part.len(), p.rows() * 2);
        let mut back = vec![-1.0; 30];
        p.scatter(&mut back, &part, 5, 2, 1);
        for (i, (&b, &d)) in back.iter().zip(&data).enumerate() {
            let (row, seq) = (i / 2, (i / 2) % 5);
            let packed = seq >= 1 && mask[row] != 0.0;
            assert_eq!(b, if packed { d } else { -1.0 }, "value {i}");
        }
    }
}
