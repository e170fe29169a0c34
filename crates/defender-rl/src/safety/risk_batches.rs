//! The safety critic's batches with the violations over-sampled, as Recovery RL's
//! `ConstraintReplayMemory.sample(batch_size, pos_fraction)` draws them: `floor(b f)` rows from
//! the stored violations (cost > 0), the rest from the transitions without one. Their scripts set
//! `f = 0.3`; our crash tasks' demonstrations hold about 0.1% violations (the last step of each
//! unsafe demonstration), so uniform batches would show the critic one violation in four batches.
//! Rows are drawn with replacement (this project's buffers; theirs without, within each group,
//! which needs more violations than a batch's share). With `f = 0` or before any violation is
//! stored, batches are uniform, exactly as [`ReplayBuffer::sample_into`] draws them.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::error::RlError;
use crate::replay::{Batch, ReplayBuffer, Transition};

/// The over-sampling share and the slots of the stored violations, ascending (so that an index
/// rebuilt from a loaded buffer equals the one kept while the run went on: a resumed run draws
/// the same rows).
#[derive(Debug, Clone)]
pub(crate) struct RiskBatches {
    pos_fraction: f64,
    violations: Vec<usize>,
}

impl RiskBatches {
    /// No violation stored yet.
    pub(crate) fn new(pos_fraction: f64) -> Self {
        Self { pos_fraction, violations: Vec::new() }
    }

    /// Stores `t` in `buffer`, keeping the index of violations.
    pub(crate) fn push(&mut self, buffer: &mut ReplayBuffer, t: &Transition<'_>) -> Result<(), RlError> {
        let slot = buffer.next_slot();
        buffer.push(t)?;
        if let Ok(k) = self.violations.binary_search(&slot) {
            self.violations.remove(k); // overwritten (the buffer was full)
        }
        if t.cost > 0.0
            && let Err(k) = self.violations.binary_search(&slot)
        {
            self.violations.insert(k, slot);
        }
        Ok(())
    }

    /// The index of a buffer read from a checkpoint.
    pub(crate) fn rebuild(&mut self, buffer: &ReplayBuffer) {
        self.violations = (0..buffer.len()).filter(|&i| buffer.cost(i) > 0.0).collect();
    }

    /// Violations stored.
    #[cfg(test)]
    pub(crate) fn violations(&self) -> usize {
        self.violations.len()
    }

    /// Fills `batch`: its first `floor(size pos_fraction)` rows from the violations, the others
    /// from the other transitions (by rejection: violations are rare; all rows from the
    /// violations if nothing else is stored).
    pub(crate) fn sample(
        &self,
        buffer: &ReplayBuffer,
        rng: &mut ChaCha8Rng,
        batch: &mut Batch,
    ) -> Result<(), RlError> {
        let pos_size = (batch.size as f64 * self.pos_fraction).floor() as usize;
        if pos_size == 0 || self.violations.is_empty() {
            return buffer.sample_into(rng, batch);
        }
        buffer.check_batch(batch)?;
        let n = buffer.len();
        let only_violations = self.violations.len() == n;
        for row in 0..batch.size {
            let i = if row < pos_size || only_violations {
                self.violations[rng.random_range(0..self.violations.len())]
            } else {
                loop {
                    let i = rng.random_range(0..n);
                    if buffer.cost(i) <= 0.0 {
                        break i;
                    }
                }
            };
            buffer.copy_row(i, batch, row);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn push(b: &mut RiskBatches, buffer: &mut ReplayBuffer, x: f64, cost: f64) {
        let (obs, next, act) = ([x], [x], [0.0f32]);
        let t = Transition {
            obs: &obs,
            action: &act,
            reward: 0.0,
            cost,
            next_obs: &next,
            terminated: cost > 0.0,
            truncated: false,
        };
        b.push(buffer, &t).unwrap();
    }

    #[test]
    fn a_share_of_each_batch_is_violations_and_the_rest_is_not() {
        let mut buffer = ReplayBuffer::new(1000, 1, 1).unwrap();
        let mut b = RiskBatches::new(0.3);
        for i in 0..1000 {
            push(&mut b, &mut buffer, f64::from(i), if i % 100 == 7 { 1.0 } else { 0.0 });
        }
        assert_eq!(b.violations(), 10);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut batch = Batch::new(20, 1, 1);
        b.sample(&buffer, &mut rng, &mut batch).unwrap();
        // floor(20 * 0.3) = 6 violation rows, then 14 without.
        assert!(batch.costs[..6].iter().all(|&c| c == 1.0), "{:?}", batch.costs);
        assert!(batch.costs[6..].iter().all(|&c| c == 0.0), "{:?}", batch.costs);
        assert!(
            batch.obs[..6].iter().all(|&x| x as usize % 100 == 7)
                && batch.terminated[..6].iter().all(|&t| t == 1.0)
        );
        // Uniform: about 1% violations, as the buffer holds.
        let uniform = RiskBatches::new(0.0);
        let mut seen = 0;
        for _ in 0..50 {
            uniform.sample(&buffer, &mut rng, &mut batch).unwrap();
            seen += batch.costs.iter().filter(|&&c| c > 0.0).count();
        }
        assert!(seen < 40, "{seen} of 1000 rows");
    }

    #[test]
    fn the_index_follows_overwrites_and_a_rebuilt_one_draws_the_same_rows() {
        let mut buffer = ReplayBuffer::new(10, 1, 1).unwrap();
        let mut b = RiskBatches::new(0.5);
        for i in 0..25 {
            push(&mut b, &mut buffer, f64::from(i), if i % 4 == 0 { 1.0 } else { 0.0 });
        }
        // Slots hold 20..24 (slots 0-4) and 15..19 (slots 5-9): violations 16, 20, 24.
        assert_eq!(b.violations, vec![0, 4, 6]);
        let mut rebuilt = RiskBatches::new(0.5);
        rebuilt.rebuild(&buffer);
        assert_eq!(rebuilt.violations, b.violations);
        let (mut x, mut y) = (Batch::new(8, 1, 1), Batch::new(8, 1, 1));
        b.sample(&buffer, &mut ChaCha8Rng::seed_from_u64(3), &mut x).unwrap();
        rebuilt.sample(&buffer, &mut ChaCha8Rng::seed_from_u64(3), &mut y).unwrap();
        assert_eq!(x.obs, y.obs);
    }
}
