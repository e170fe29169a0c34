//! What `defender demos risk-horizon` reads off a safety critic: given `Q_risk(s_t, a_t)` along
//! held-out demonstrations, how many steps before the violation the switch (`Q_risk > eps_risk`,
//! [`too_risky`]) first fires on the unsafe ones, and how often it fires on the safe ones.
//!
//! Steps before the violation count from the violating step itself: in an unsafe demonstration
//! of `L` transitions the last one (`t = L - 1`) is the crash (or the step that passed the cost
//! limit), `0` steps before it; transition `t` is `L - 1 - t` steps before it. An ideal critic,
//! `Q_risk = gamma_risk^k` at `k` steps before, fires for every `k < ln(eps) / ln(gamma)`.

use defender_report::quantile;
use defender_rl::safety::recovery::too_risky;

/// `Q_risk` along one held-out demonstration, step by step.
#[derive(Debug, Clone)]
pub struct Scored {
    /// `Q_risk(s_t, a_t)` for each transition `t`.
    pub q: Vec<f32>,
    /// Whether the demonstration ends in a violation (its last transition).
    pub violation: bool,
}

/// The closed form: steps before a violation at which `gamma^k` falls to `eps`,
/// `ln(eps) / ln(gamma)`; an ideal critic fires at every whole `k` below it.
pub fn closed_form_steps(gamma: f64, eps: f64) -> f64 {
    eps.ln() / gamma.ln()
}

/// Lower quartile, median and upper quartile (numpy's linear rule); NaN when empty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quartiles {
    pub q1: f64,
    pub median: f64,
    pub q3: f64,
}

impl Quartiles {
    /// The quartiles of `values`.
    pub fn of(values: &[f64]) -> Self {
        let mut v = values.to_vec();
        Self { q1: quantile(&mut v, 0.25), median: quantile(&mut v, 0.5), q3: quantile(&mut v, 0.75) }
    }
}

/// The switch's behaviour on a held-out set at one `eps_risk`.
#[derive(Debug, Clone, PartialEq)]
pub struct Horizon {
    /// Unsafe demonstrations measured.
    pub unsafe_episodes: usize,
    /// Unsafe demonstrations in which no step passes `eps_risk`.
    pub never_flagged: usize,
    /// Unsafe demonstrations whose first step already passes it: their lead is the whole
    /// demonstration, a lower bound on how early the critic would warn.
    pub flagged_from_start: usize,
    /// Per flagged unsafe demonstration: steps before the violation of its first flagged step.
    pub first_lead: Vec<f64>,
    /// Unsafe demonstrations whose violating step itself is not flagged.
    pub unflagged_at_violation: usize,
    /// Per unsafe demonstration flagged at its violating step: steps before the violation where
    /// the unbroken run of flagged steps that ends at it begins.
    pub held_lead: Vec<f64>,
    /// `Q_risk` at each unsafe demonstration's violating step.
    pub q_at_violation: Vec<f64>,
    /// Safe demonstrations measured, their steps, and how many of each were flagged.
    pub safe_episodes: usize,
    pub safe_steps: usize,
    pub safe_flagged_episodes: usize,
    pub safe_flagged_steps: usize,
}

impl Horizon {
    /// Share of unsafe demonstrations never flagged (NaN without any).
    pub fn never_flagged_share(&self) -> f64 {
        share(self.never_flagged, self.unsafe_episodes)
    }
    /// Share of unsafe demonstrations flagged from their first step.
    pub fn flagged_from_start_share(&self) -> f64 {
        share(self.flagged_from_start, self.unsafe_episodes)
    }
    /// Share of unsafe demonstrations not flagged at the violating step.
    pub fn unflagged_at_violation_share(&self) -> f64 {
        share(self.unflagged_at_violation, self.unsafe_episodes)
    }
    /// Share of the safe demonstrations' steps flagged (false alarms).
    pub fn safe_steps_share(&self) -> f64 {
        share(self.safe_flagged_steps, self.safe_steps)
    }
    /// Share of safe demonstrations with at least one flagged step.
    pub fn safe_episodes_share(&self) -> f64 {
        share(self.safe_flagged_episodes, self.safe_episodes)
    }
}

fn share(part: usize, whole: usize) -> f64 {
    if whole == 0 { f64::NAN } else { part as f64 / whole as f64 }
}

/// The switch at `eps_risk` on `episodes`.
pub fn measure(episodes: &[Scored], eps_risk: f64) -> Horizon {
    let mut h = Horizon {
        unsafe_episodes: 0,
        never_flagged: 0,
        flagged_from_start: 0,
        first_lead: Vec::new(),
        unflagged_at_violation: 0,
        held_lead: Vec::new(),
        q_at_violation: Vec::new(),
        safe_episodes: 0,
        safe_steps: 0,
        safe_flagged_episodes: 0,
        safe_flagged_steps: 0,
    };
    for e in episodes.iter().filter(|e| !e.q.is_empty()) {
        let flagged: Vec<bool> = e.q.iter().map(|&q| too_risky(q, eps_risk)).collect();
        let n_flagged = flagged.iter().filter(|&&f| f).count();
        if !e.violation {
            h.safe_episodes += 1;
            h.safe_steps += flagged.len();
            h.safe_flagged_steps += n_flagged;
            h.safe_flagged_episodes += usize::from(n_flagged > 0);
            continue;
        }
        let last = flagged.len() - 1;
        h.unsafe_episodes += 1;
        h.q_at_violation.push(f64::from(e.q[last]));
        match flagged.iter().position(|&f| f) {
            None => h.never_flagged += 1,
            Some(first) => {
                h.first_lead.push((last - first) as f64);
                h.flagged_from_start += usize::from(first == 0);
            }
        }
        if flagged[last] {
            let start = flagged.iter().rposition(|&f| !f).map_or(0, |t| t + 1);
            h.held_lead.push((last - start) as f64);
        } else {
            h.unflagged_at_violation += 1;
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scored(q: &[f32], violation: bool) -> Scored {
        Scored { q: q.to_vec(), violation }
    }

    #[test]
    fn leads_count_steps_before_the_violating_step() {
        let episodes = [
            // First flagged at t = 1 of 6 (4 steps before t = 5); the run ending at the
            // violation starts at t = 3 (2 steps before).
            scored(&[0.1, 0.5, 0.2, 0.6, 0.7, 0.9], true),
            // Flagged only at the violating step: lead 0 both ways.
            scored(&[0.1, 0.1, 0.8], true),
            // Never flagged (0.3 is not above 0.3: the switch is strict).
            scored(&[0.1, 0.3, 0.2], true),
            // Flagged from the start, not at the violation.
            scored(&[0.4, 0.35, 0.1], true),
            // Safe: 2 of 4 steps flagged; another with none.
            scored(&[0.31, 0.0, 0.9, 0.1], false),
            scored(&[0.0, 0.0], false),
        ];
        let h = measure(&episodes, 0.3);
        assert_eq!(h.unsafe_episodes, 4);
        assert_eq!(h.first_lead, vec![4.0, 0.0, 2.0]);
        assert_eq!(h.held_lead, vec![2.0, 0.0]);
        assert_eq!((h.never_flagged, h.flagged_from_start, h.unflagged_at_violation), (1, 1, 2));
        assert_eq!(
            h.q_at_violation,
            vec![f64::from(0.9f32), f64::from(0.8f32), f64::from(0.2f32), f64::from(0.1f32)]
        );
        assert_eq!(
            (h.safe_episodes, h.safe_steps, h.safe_flagged_steps, h.safe_flagged_episodes),
            (2, 6, 2, 1)
        );
        assert!((h.safe_steps_share() - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(h.safe_episodes_share(), 0.5);
        assert_eq!(h.never_flagged_share(), 0.25);
    }

    #[test]
    fn an_ideal_critic_fires_below_the_closed_form() {
        // Q = gamma^k at k steps before the violation, over 200 steps.
        for (gamma, eps) in [(0.5, 0.3), (0.8, 0.3), (0.9, 0.3), (0.95, 0.3), (0.99, 0.5), (0.99, 0.3)] {
            let q: Vec<f32> = (0..200).rev().map(|k| (gamma as f32).powi(k)).collect();
            let h = measure(&[scored(&q, true)], eps);
            let k = closed_form_steps(gamma, eps);
            let expect = k.ceil() - 1.0;
            assert_eq!(h.first_lead, vec![expect], "gamma {gamma} eps {eps}: k = {k}");
            assert_eq!(h.held_lead, vec![expect]);
        }
        assert!((closed_form_steps(0.9, 0.3) - 11.427).abs() < 1e-3);
        assert!((closed_form_steps(0.99, 0.5) - 68.968).abs() < 1e-3);
    }

    #[test]
    fn quartiles_follow_numpy_and_empty_sets_give_nan() {
        let q = Quartiles::of(&[4.0, 1.0, 3.0, 2.0, 5.0]);
        assert_eq!((q.q1, q.median, q.q3), (2.0, 3.0, 4.0));
        let q = Quartiles::of(&[0.0, 10.0]);
        assert_eq!((q.q1, q.median, q.q3), (2.5, 5.0, 7.5));
        assert!(Quartiles::of(&[]).median.is_nan());
        let h = measure(&[], 0.3);
        assert!(h.never_flagged_share().is_nan() && h.safe_steps_share().is_nan());
    }
}
