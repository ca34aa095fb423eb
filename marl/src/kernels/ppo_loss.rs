//! PPO's loss (MAPPO's: clipped surrogate, entropy bonus, Huber value loss optionally
//! clipped, each a mean over active rows) and its gradient with respect to the actor's
//! logits and the critic's values, in closed form. The reference is
//! [`crate::ppo::PpoLearner::loss`], built from candle operations; a test holds the two
//! together, ties included (candle splits a gradient evenly between equal arguments of a
//! minimum or maximum, and so does this).

/// The settings the loss reads.
#[derive(Clone, Copy, Debug)]
pub struct LossSettings {
    pub clip: f32,
    pub entropy_coef: f32,
    pub value_coef: f32,
    pub huber_delta: f32,
    pub clip_value_loss: bool,
}

/// One batch's rows (`M` of them; `n_actions` logits each).
#[derive(Clone, Copy, Debug)]
pub struct LossRows<'a> {
    pub n_actions: usize,
    pub logits: &'a [f32],
    /// Additive mask: 0 where available, [`crate::ppo::MASKED`] where not.
    pub mask: &'a [f32],
    pub actions: &'a [u32],
    pub old_logp: &'a [f32],
    pub adv: &'a [f32],
    pub active: &'a [f32],
    pub values: &'a [f32],
    pub old_values: &'a [f32],
    pub targets: &'a [f32],
}

/// The loss's parts and its gradients.
#[derive(Clone, Debug, Default)]
pub struct LossGrads {
    pub total: f64,
    pub policy: f64,
    pub value: f64,
    pub entropy: f64,
    /// `M x n_actions`.
    pub d_logits: Vec<f32>,
    /// `M`.
    pub d_values: Vec<f32>,
}

/// Gradient share of the first argument of `min(a, b)` (or `max`): 1, 0, or a half on ties.
fn share(first_wins: bool, tie: bool) -> f32 {
    if tie {
        0.5
    } else if first_wins {
        1.0
    } else {
        0.0
    }
}

/// `huber(e)` and its derivative in `e`.
fn huber(e: f32, delta: f32) -> (f32, f32) {
    if delta <= 0.0 {
        return (0.5 * e * e, e);
    }
    let a = e.abs();
    let q = a.min(delta);
    let dq = if a < delta {
        1.0
    } else if a == delta {
        0.5
    } else {
        0.0
    };
    // 0.5 q^2 + (a - q) delta, with dq/da as candle's minimum gives it.
    let da = q * dq + (1.0 - dq) * delta;
    (0.5 * q * q + (a - q) * delta, da * e.signum())
}

/// The loss and its gradients.
pub fn ppo_loss(r: &LossRows<'_>, s: &LossSettings) -> LossGrads {
    let na = r.n_actions.max(1);
    let m = r.actions.len();
    let n_active = r.active.iter().map(|&a| f64::from(a)).sum::<f64>().max(1.0);
    let inv = (1.0 / n_active) as f32;
    let mut out = LossGrads { d_logits: vec![0.0; m * na], d_values: vec![0.0; m], ..LossGrads::default() };
    let (mut pol, mut ent, mut val) = (0f64, 0f64, 0f64);
    let mut logp = vec![0f32; na];
    for i in 0..m {
        let z = &r.logits[i * na..(i + 1) * na];
        let mk = &r.mask[i * na..(i + 1) * na];
        let w = r.active[i];
        // An inactive row adds nothing, and the network may not have computed its outputs.
        if w == 0.0 {
            continue;
        }
        let mx = z.iter().zip(mk).map(|(a, b)| a + b).fold(f32::NEG_INFINITY, f32::max);
        let mut sum = 0f32;
        for j in 0..na {
            logp[j] = z[j] + mk[j] - mx;
            sum += logp[j].exp();
        }
        let lse = sum.ln();
        let mut h = 0f32;
        for lp in logp.iter_mut() {
            *lp -= lse;
            h -= lp.exp() * *lp;
        }
        let a = r.actions[i] as usize;
        let ratio = (logp[a] - r.old_logp[i]).exp();
        let adv = r.adv[i];
        let (lo, hi) = (1.0 - s.clip, 1.0 + s.clip);
        let clamped = ratio.clamp(lo, hi);
        let (s1, s2) = (ratio * adv, clamped * adv);
        pol += f64::from(w * s1.min(s2));
        ent += f64::from(w * h);
        // d(policy)/d(ratio): through s1 (and through s2 where the clamp passes it).
        let in_range = if ratio > lo && ratio < hi {
            1.0
        } else if ratio == lo || ratio == hi {
            0.5
        } else {
            0.0
        };
        let first = share(s1 < s2, s1 == s2);
        let d_ratio = -(w * inv) * adv * (first + (1.0 - first) * in_range);
        let g_lp = d_ratio * ratio;
        let ge = s.entropy_coef * w * inv;
        let d = &mut out.d_logits[i * na..(i + 1) * na];
        for j in 0..na {
            let p = logp[j].exp();
            let one = if j == a { 1.0 } else { 0.0 };
            // -c_e dH/dz_j = c_e p_j (log p_j + H); the policy term through log p_a.
            d[j] = g_lp * (one - p) + if p > 0.0 { ge * p * (logp[j] + h) } else { 0.0 };
        }
        // The value loss.
        let v = r.values[i];
        let (l1, d1) = huber(r.targets[i] - v, s.huber_delta);
        let (loss_v, d_v) = if s.clip_value_loss {
            let old = r.old_values[i];
            let diff = v - old;
            let dc = if diff > -s.clip && diff < s.clip {
                1.0
            } else if diff == -s.clip || diff == s.clip {
                0.5
            } else {
                0.0
            };
            let vc = old + diff.clamp(-s.clip, s.clip);
            let (l2, d2) = huber(r.targets[i] - vc, s.huber_delta);
            let f = share(l1 > l2, l1 == l2);
            (l1.max(l2), -f * d1 - (1.0 - f) * d2 * dc)
        } else {
            (l1, -d1)
        };
        val += f64::from(w * loss_v);
        out.d_values[i] = s.value_coef * w * inv * d_v;
    }
    out.policy = -pol / n_active;
    out.entropy = ent / n_active;
    out.value = val / n_active;
    out.total = out.policy - f64::from(s.entropy_coef) * out.entropy + f64::from(s.value_coef) * out.value;
    out
}
