//! `updates.csv`: the learner's own numbers as training goes (SB3's logger, CleanRL's
//! TensorBoard scalars), so a user can see why a run diverged: the critics' loss and mean Q, the
//! actor's loss, SAC's entropy coefficient and its loss, averaged over every `EVERY` environment
//! steps.
//!
//! The file's name and header are the run directory's (`defender_report::UPDATES_FILE`,
//! `UPDATES_HEADER`); this module makes its rows.

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
