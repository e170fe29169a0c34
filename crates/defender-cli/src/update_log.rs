//! `updates.csv`: the learner's own numbers as training goes (SB3's logger, CleanRL's
//! TensorBoard scalars), so a user can see why a run diverged: the critics' loss and mean Q, the
//! actor's loss, SAC's entropy coefficient and its loss, for Recovery RL how many steps its
//! recovery policy has acted so far, and a Lagrangian agent's cost critic loss and multiplier,
//! averaged over every `EVERY` environment steps; and `dynamics.csv`: DEFENDER's dynamics model, its prediction error on fresh
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
    /// Recovery RL's count, the last one reported (absent from checkpoints of older runs).
    #[serde(default)]
    recovery_steps: Option<u64>,
    /// Absent from a checkpoint of a run older than these fields: a Lagrangian agent is newer.
    #[serde(default)]
    qc_loss: (f64, u32),
    #[serde(default)]
    lagrange_multiplier: Option<f32>,
    #[serde(default)]
    qc_mean: (f64, u32),
}

fn mean((sum, n): (f64, u32)) -> Option<f64> {
    (n > 0).then(|| sum / f64::from(n))
}

/// An optional CSV field: empty when absent.
fn field<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

/// Parses a CSV field, empty meaning absent.
fn parse_field<T: std::str::FromStr>(s: &str) -> Result<Option<T>, String> {
    if s.is_empty() { Ok(None) } else { s.parse().map(Some).map_err(|_| format!("not a number: '{s}'")) }
}

fn parse_fields(line: &str, n: usize) -> Result<Vec<&str>, String> {
    let fields: Vec<&str> = line.split(',').collect();
    if fields.len() == n { Ok(fields) } else { Err(format!("{} fields, expected {n}", fields.len())) }
}

fn required<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    parse_field(s)?.ok_or_else(|| "an empty required field".to_string())
}

/// One `updates.csv` row: the means over a window of `EVERY` steps.
#[derive(Debug, Clone, PartialEq)]
pub struct UpdateRow {
    /// Environment steps at the window's end.
    pub total_steps: u64,
    /// Gradient updates so far.
    pub n_updates: u64,
    /// The critics' loss.
    pub qf_loss: f64,
    /// The first critic's mean Q.
    pub qf1_mean: f64,
    /// The actor's loss (none in a window without actor update).
    pub actor_loss: Option<f64>,
    /// SAC's entropy coefficient (none for TD3).
    pub ent_coef: Option<f32>,
    /// Its loss (none unless it is learned).
    pub ent_coef_loss: Option<f64>,
    /// Recovery RL: environment steps so far in which the recovery policy acted (none for other
    /// runs, and in rows written before the column existed).
    pub recovery_steps: Option<u64>,
    /// A Lagrangian agent's cost critic loss (none otherwise, and in an older run's rows).
    pub qc_loss: Option<f64>,
    /// Its Lagrange multiplier at the window's last update (none otherwise).
    pub lagrange_multiplier: Option<f32>,
    /// Its mean `Q_c` at the batch's states and the actor's actions, averaged over the window
    /// (none otherwise, and in rows written before the column existed).
    pub qc_mean: Option<f64>,
}

impl UpdateRow {
    /// The CSV row (`defender_report::UPDATES_HEADER`).
    pub fn to_csv(&self) -> String {
        format!(
            "{},{},{},{},{},{},{},{},{},{},{}",
            self.total_steps,
            self.n_updates,
            self.qf_loss,
            self.qf1_mean,
            field(self.actor_loss),
            field(self.ent_coef),
            field(self.ent_coef_loss),
            field(self.recovery_steps),
            field(self.qc_loss),
            field(self.lagrange_multiplier),
            field(self.qc_mean)
        )
    }

    /// Parses a CSV row, of eleven fields or of an older run's seven or ten.
    ///
    /// # Errors
    /// A row that is not one of `updates.csv`, with what is wrong.
    pub fn parse(line: &str) -> Result<Self, String> {
        let f = match line.split(',').count() {
            7 => parse_fields(line, 7)?,
            10 => parse_fields(line, 10)?,
            _ => parse_fields(line, 11)?,
        };
        let late = |k: usize| f.get(k).copied().unwrap_or("");
        Ok(Self {
            total_steps: required(f[0])?,
            n_updates: required(f[1])?,
            qf_loss: required(f[2])?,
            qf1_mean: required(f[3])?,
            actor_loss: parse_field(f[4])?,
            ent_coef: parse_field(f[5])?,
            ent_coef_loss: parse_field(f[6])?,
            recovery_steps: parse_field(late(7))?,
            qc_loss: parse_field(late(8))?,
            lagrange_multiplier: parse_field(late(9))?,
            qc_mean: parse_field(late(10))?,
        })
    }
}

/// One `dynamics.csv` row: DEFENDER's dynamics model at `total_steps`.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsRow {
    /// Environment steps.
    pub total_steps: u64,
    /// Real transitions the model has seen.
    pub real_steps: u64,
    /// Its gradient steps.
    pub gradient_steps: u64,
    /// Prediction error on the last fresh transition.
    pub error_last: f64,
    /// Its exponential moving average.
    pub error_ema: f64,
    /// Its mean over all fresh transitions.
    pub error_mean: f64,
    /// The last training loss (none before the first gradient step).
    pub loss: Option<f32>,
}

impl DynamicsRow {
    /// The CSV row (`defender_report::DYNAMICS_HEADER`).
    pub fn to_csv(&self) -> String {
        format!(
            "{},{},{},{},{},{},{}",
            self.total_steps,
            self.real_steps,
            self.gradient_steps,
            self.error_last,
            self.error_ema,
            self.error_mean,
            field(self.loss)
        )
    }

    /// Parses a CSV row.
    ///
    /// # Errors
    /// A row that is not one of `dynamics.csv`, with what is wrong.
    pub fn parse(line: &str) -> Result<Self, String> {
        let f = parse_fields(line, 7)?;
        Ok(Self {
            total_steps: required(f[0])?,
            real_steps: required(f[1])?,
            gradient_steps: required(f[2])?,
            error_last: required(f[3])?,
            error_ema: required(f[4])?,
            error_mean: required(f[5])?,
            loss: parse_field(f[6])?,
        })
    }
}

impl UpdateLog {
    /// Adds one update's statistics; returns a finished row when `total_steps` closes a window.
    pub fn add(&mut self, total_steps: u64, stats: &defender_rl::UpdateStats) -> Option<UpdateRow> {
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
        if let Some(l) = stats.cost_critic_loss {
            self.qc_loss = (self.qc_loss.0 + f64::from(l), self.qc_loss.1 + 1);
        }
        if stats.lagrange_multiplier.is_some() {
            self.lagrange_multiplier = stats.lagrange_multiplier;
        }
        if let Some(q) = stats.qc_mean {
            self.qc_mean = (self.qc_mean.0 + f64::from(q), self.qc_mean.1 + 1);
        }
        self.n_updates = stats.n_updates;
        self.recovery_steps = stats.recovery_steps.or(self.recovery_steps);
        if !total_steps.is_multiple_of(EVERY) {
            return None;
        }
        let n = f64::from(self.n);
        let row = UpdateRow {
            total_steps,
            n_updates: self.n_updates,
            qf_loss: self.qf_loss / n,
            qf1_mean: self.qf1_mean / n,
            actor_loss: mean(self.actor),
            ent_coef: self.alpha,
            ent_coef_loss: mean(self.alpha_loss),
            recovery_steps: self.recovery_steps,
            qc_loss: mean(self.qc_loss),
            lagrange_multiplier: self.lagrange_multiplier,
            qc_mean: mean(self.qc_mean),
        };
        *self = Self::default();
        Some(row)
    }
}

/// The `dynamics.csv` row at `total_steps`, or `None` between rows. Every value is the model's own
/// (checkpointed) state, so a resumed run writes the rows the run left alone would.
pub fn dynamics_row(total_steps: u64, model: &defender::DynamicsModel) -> Option<DynamicsRow> {
    if !total_steps.is_multiple_of(EVERY) {
        return None;
    }
    let e = model.prediction_error();
    let loss = model.last_loss();
    Some(DynamicsRow {
        total_steps,
        real_steps: model.real_steps(),
        gradient_steps: model.gradient_steps(),
        error_last: e.last,
        error_ema: e.ema,
        error_mean: e.mean,
        loss: (!loss.is_nan()).then_some(loss),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn update_rows_carry_recovery_rls_count_and_older_rows_still_read() {
        let mut log = UpdateLog::default();
        let stats = defender_rl::UpdateStats { n_updates: 3, recovery_steps: Some(42), ..Default::default() };
        assert_eq!(log.add(999, &stats), None);
        let row = log.add(1000, &defender_rl::UpdateStats { n_updates: 4, ..stats }).unwrap();
        assert_eq!(row.recovery_steps, Some(42));
        let csv = row.to_csv();
        assert_eq!(csv.split(',').count(), defender_report::UPDATES_HEADER.split(',').count());
        assert_eq!(UpdateRow::parse(&csv), Ok(row));
        let old = UpdateRow::parse("1000,4,0.5,1.5,-2,0.1,0.01").unwrap();
        assert_eq!((old.recovery_steps, old.ent_coef_loss), (None, Some(0.01)));
        let plain = UpdateRow::parse("1000,4,0.5,1.5,-2,0.1,0.01,,,").unwrap();
        assert_eq!(plain, old, "a run without Recovery RL leaves the column empty");
        let now = UpdateRow::parse("1000,4,0.5,1.5,-2,0.1,0.01,,,,").unwrap();
        assert_eq!(now, old, "nor does an eleven-column row of a plain run");
    }

    #[test]
    fn update_rows_carry_the_lagrangian_columns_and_older_rows_still_read() {
        let mut log = UpdateLog::default();
        let stats = |qc: f32, lambda: f32| defender_rl::UpdateStats {
            n_updates: 1,
            actor_loss: Some(1.0),
            alpha: Some(0.2),
            cost_critic_loss: Some(qc),
            lagrange_multiplier: Some(lambda),
            qc_mean: Some(4.0 * lambda),
            ..Default::default()
        };
        assert_eq!(log.add(999, &stats(1.0, 0.5)), None);
        let row = log.add(1000, &stats(3.0, 0.75)).unwrap();
        assert_eq!((row.qc_loss, row.lagrange_multiplier), (Some(2.0), Some(0.75)));
        // qc_mean is the window's mean, as the losses are (2 and 3).
        assert_eq!(row.qc_mean, Some(2.5));
        let csv = row.to_csv();
        assert_eq!(csv.split(',').count(), defender_report::UPDATES_HEADER.split(',').count());
        assert_eq!(UpdateRow::parse(&csv), Ok(row));
        let old = UpdateRow::parse("1000,5,0.5,1.5,-2,0.2,").unwrap();
        assert_eq!((old.n_updates, old.qc_loss, old.lagrange_multiplier), (5, None, None));
        assert!(csv.ends_with(",,2,0.75,2.5"), "{csv}");
        // A plain agent's row leaves them empty.
        let mut log = UpdateLog::default();
        let plain = defender_rl::UpdateStats { n_updates: 1, ..Default::default() };
        assert!(log.add(1000, &plain).unwrap().to_csv().ends_with(",,,,"));
        assert!(UpdateRow::parse("1,2,3").is_err());
    }

    #[test]
    fn a_checkpointed_accumulator_of_an_older_run_reads() {
        let old = r#"{"n":3,"qf_loss":1.0,"qf1_mean":2.0,"actor":[1.0,1],"alpha":0.5,"alpha_loss":[0.0,0],"n_updates":7}"#;
        let log: UpdateLog = serde_json::from_str(old).unwrap();
        assert_eq!((log.n, log.qc_loss, log.lagrange_multiplier), (3, (0.0, 0), None));
    }

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
        let fresh = dynamics_row(1000, &model).unwrap().to_csv();
        assert_eq!(fresh, "1000,0,0,0,0,0,", "no data, no loss yet");
        for t in 0..20 {
            model.observe(&[t as f64, 1.0], &[0.5], &[t as f64 + 0.5, 1.0]).unwrap();
        }
        let parsed = dynamics_row(2000, &model).unwrap();
        let row = parsed.to_csv();
        assert_eq!(DynamicsRow::parse(&row), Ok(parsed));
        let fields: Vec<&str> = row.split(',').collect();
        assert_eq!(fields.len(), defender_report::DYNAMICS_HEADER.split(',').count());
        assert_eq!(fields[..2], ["2000", "20"]);
        assert_eq!(fields[2].parse::<u64>().unwrap(), model.gradient_steps());
        assert_eq!(fields[4].parse::<f64>().unwrap(), model.prediction_error().ema);
        assert!(fields[6].parse::<f32>().unwrap().is_finite());
    }
}
