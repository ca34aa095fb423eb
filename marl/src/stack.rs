//! Frame stacking, as the MAPPO repository's `use_stacked_frames`: the networks read each
//! row's last `k` observations (and the critic the last `k` states) side by side, oldest
//! first, with zeros before the episode's first step. Its SMAC scripts run the feed-forward
//! policy this way on 3s_vs_4z and 3s_vs_5z, where a policy without memory would not know
//! which way its Stalkers were kiting.
//!
//! The networks are sized for the stacked rows ([`crate::Shape::stacked`]); what the game
//! gives (and a trained policy is checked against) stays one observation wide.

use std::borrow::Cow;

/// The last `k - 1` inputs of each of `rows` rows `width` wide (`k` 1: nothing kept).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stack {
    k: usize,
    width: usize,
    /// `rows x (k - 1) x width`, each row's oldest first.
    history: Vec<f32>,
}

impl Stack {
    pub fn new(k: usize, width: usize, rows: usize) -> Stack {
        Stack { k: k.max(1), width, history: vec![0.0; rows * (k.max(1) - 1) * width] }
    }

    /// Whether this stacks anything (`k` above 1).
    pub fn on(&self) -> bool {
        self.k > 1
    }

    fn kept(&self) -> usize {
        (self.k - 1) * self.width
    }

    /// Each row of `x` (`rows x width`) after its history: `rows x k x width`, this step's
    /// input last. The history stays as it was (see [`Stack::push`]).
    pub fn peek<'a>(&self, x: &'a [f32]) -> Cow<'a, [f32]> {
        if !self.on() {
            return Cow::Borrowed(x);
        }
        let kept = self.kept();
        let mut out = Vec::with_capacity(x.len() * self.k);
        for (h, row) in self.history.chunks_exact(kept).zip(x.chunks_exact(self.width.max(1))) {
            out.extend_from_slice(h);
            out.extend_from_slice(row);
        }
        Cow::Owned(out)
    }

    /// [`Stack::peek`], then each row's history moves on by this step's input.
    pub fn push<'a>(&mut self, x: &'a [f32]) -> Cow<'a, [f32]> {
        let out = self.peek(x);
        if self.on() {
            let (kept, w) = (self.kept(), self.width);
            for (h, row) in self.history.chunks_exact_mut(kept).zip(x.chunks_exact(w.max(1))) {
                h.copy_within(w.., 0);
                h[kept - w..].copy_from_slice(row);
            }
        }
        out
    }

    /// Forgets the history of the rows of the groups (environments of `per` rows each) whose
    /// episode ended.
    pub fn clear(&mut self, done: &[bool], per: usize) {
        let span = self.kept() * per;
        if span == 0 {
            return;
        }
        for (h, &d) in self.history.chunks_exact_mut(span).zip(done) {
            if d {
                h.fill(0.0);
            }
        }
    }

    /// The history, `rows x (k - 1) x width` (what a resumed run restores).
    pub fn history(&self) -> &[f32] {
        &self.history
    }

    /// Puts back what [`Stack::history`] gave; its size must be this stack's.
    pub fn set_history(&mut self, history: Vec<f32>) -> Result<(), String> {
        if history.len() != self.history.len() {
            return Err(format!("a stacked-frame history of {} values, {} wanted", history.len(), self.history.len()));
        }
        self.history = history;
        Ok(())
    }

    /// A row's next history after its input `x`, for a caller that keeps each row's
    /// history itself ([`crate::Policy::q_values`]).
    pub(crate) fn advance_row(history: &[f32], x: &[f32]) -> Vec<f32> {
        let mut h = Vec::with_capacity(history.len());
        if !history.is_empty() {
            h.extend_from_slice(&history[x.len().min(history.len())..]);
            h.extend_from_slice(&x[x.len().saturating_sub(history.len())..]);
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_read_their_last_inputs_oldest_first_from_zeros() -> Result<(), String> {
        let mut s = Stack::new(3, 2, 2);
        let step = |t: f32| vec![t, t + 0.5, -t, -t - 0.5];
        assert_eq!(&*s.push(&step(1.0)), &[0.0, 0.0, 0.0, 0.0, 1.0, 1.5, 0.0, 0.0, 0.0, 0.0, -1.0, -1.5]);
        assert_eq!(&*s.push(&step(2.0)), &[0.0, 0.0, 1.0, 1.5, 2.0, 2.5, 0.0, 0.0, -1.0, -1.5, -2.0, -2.5]);
        // A peek shows the next step's rows without moving on.
        let peeked = s.peek(&step(3.0)).into_owned();
        assert_eq!(peeked, [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, -1.0, -1.5, -2.0, -2.5, -3.0, -3.5]);
        assert_eq!(*s.push(&step(3.0)), peeked[..]);
        assert_eq!(&*s.push(&step(4.0)), &[2.0, 2.5, 3.0, 3.5, 4.0, 4.5, -2.0, -2.5, -3.0, -3.5, -4.0, -4.5]);
        // Row 1's episode ended: its history starts again; row 0's goes on.
        s.clear(&[false, true], 1);
        assert_eq!(&*s.push(&step(5.0)), &[3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 0.0, 0.0, 0.0, 0.0, -5.0, -5.5]);
        let kept = s.history().to_vec();
        let mut back = Stack::new(3, 2, 2);
        back.set_history(kept)?;
        assert_eq!(back, s);
        assert!(back.set_history(vec![0.0; 3]).is_err());
        Ok(())
    }

    #[test]
    fn one_frame_is_the_input_itself() {
        let mut s = Stack::new(1, 3, 2);
        let x = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        assert!(matches!(s.push(&x), Cow::Borrowed(_)));
        assert!(s.history().is_empty());
    }

    #[test]
    fn a_row_kept_apart_moves_on_as_the_stack_does() {
        let mut s = Stack::new(4, 2, 1);
        let mut h = vec![0.0; 6];
        for t in 0..6 {
            let x = [t as f32, 10.0 + t as f32];
            s.push(&x);
            h = Stack::advance_row(&h, &x);
            assert_eq!(h, s.history(), "step {t}");
        }
    }
}
