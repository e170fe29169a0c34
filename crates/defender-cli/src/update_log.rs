//! `updates.csv`: the learner's own numbers as training goes (SB3's logger, CleanRL's
//! TensorBoard scalars), so a user can see why a run diverged: the critics' loss and mean Q, the
//! actor's loss, SAC's entropy coefficient and its loss, averaged over every `EVERY` environment
//! steps; and `dynamics.csv`: DEFENDER's dynamics model, its prediction error on fresh
//! transitions and its training loss, every `EVERY` environment steps.
//!
//! The files' names and headers are the run directory's (`defender_report::UPDATES_FILE`,
//! `DYNAMICS_FILE` and their headers); this module makes their rows.

/// The accumulator's file in a checkpoint's extra directory.
pub const CHECKPOINT_FILE: &str = "update_log.json";
/// Environment steps per row.
pub const EVERY: u64 = 1000;

/// Averages the update statistics of one window of `EVERY` steps. Kept in the checkpoint
/// (`extra/update_log.json`), so a resumed run's rows equal those of the run left alone.
#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct UpdateLog {
    n: u32,
    qf_loss: f64,
    qf1_mean: f64,
    actor: (f64, u32),
    alpha: Option<f32>,
    alpha_loss: (f64, u32),
    n_updates: u64,
}

fn mean((sum, n): (f64, u32)) -> String {
    if n == 0 { String::new() } else { format!("{}", sum / f64::from(n)) }
}

impl UpdateLog {
    /// Adds one update's statistics; returns a finished row when `total_steps` closes a window.
    pub fn add(&mut self, total_steps: u64, stats: &defender_rl::UpdateStats) -> Option<String> {
        self.n += 1;
        self.qf_loss += f64::from(stats.qf_loss);
        self.qf1_mean += f64::from(stats.qf1_mean);
        if let Some(a) = stats.actor_loss {
            self.actor = (self.actor.0 + f64::from(a), self.actor.1 + 1);
        }
        if stats.alpha.is_some() {
            self.alpha = stats.alpha;
        }
        if let Some(l) = stats.alpha_loss {
            self.alpha_loss = (self.alpha_loss.0 + f64::from(l), self.alpha_loss.1 + 1);
        }
        self.n_updates = stats.n_updates;
        if !total_steps.is_multiple_of(EVERY) {
            return None;
        }
        let n = f64::from(self.n);
        let row = format!(
            "{total_steps},{},{},{},{},{},{}",
            self.n_updates,
            self.qf_loss / n,
            self.qf1_mean / n,
            mean(self.actor),
            self.alpha.map_or(String::new(), |a| a.to_string()),
            mean(self.alpha_loss)
        );
        *self = Self::default();
        Some(row)
    }
}

/// The `dynamics.csv` row at `total_steps`, or `None` between rows. Every value is the model's own
/// (checkpointed) state, so a resumed run writes the rows the run left alone would.
pub fn dynamics_row(total_steps: u64, model: &defender::DynamicsModel) -> Option<String> {
    if !total_steps.is_multiple_of(EVERY) {
        return None;
    }
    let e = model.prediction_error();
    let loss = model.last_loss();
    Some(format!(
        "{total_steps},{},{},{},{},{},{}",
        model.real_steps(),
        model.gradient_steps(),
        e.last,
        e.ema,
        e.mean,
        if loss.is_nan() { String::new() } else { loss.to_string() }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn dynamics_rows_come_every_1000_steps_with_the_models_numbers() {
        let config = defender::DynamicsConfig {
            hidden: vec![8],
            batch_size: 4,
            buffer_size: 100,
            ..Default::default()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut model = defender::DynamicsModel::new(2, 1, config, &mut rng).unwrap();
        assert_eq!(dynamics_row(999, &model), None);
        let fresh = dynamics_row(1000, &model).unwrap();
        assert_eq!(fresh, "1000,0,0,0,0,0,", "no data, no loss yet");
        for t in 0..20 {
            model.observe(&[t as f64, 1.0], &[0.5], &[t as f64 + 0.5, 1.0]).unwrap();
        }
        let row = dynamics_row(2000, &model).unwrap();
        let fields: Vec<&str> = row.split(',').collect();
        assert_eq!(fields.len(), defender_report::DYNAMICS_HEADER.split(',').count());
        assert_eq!(fields[..2], ["2000", "20"]);
        assert_eq!(fields[2].parse::<u64>().unwrap(), model.gradient_steps());
        assert_eq!(fields[4].parse::<f64>().unwrap(), model.prediction_error().ema);
        assert!(fields[6].parse::<f32>().unwrap().is_finite());
    }
}
