//! The rows of `defender demos risk-horizon`: its CSV file (written atomically) and the table it
//! prints. `defender demos risk-horizon --help` explains each column.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use defender_config::profile::Profile;

use super::risk_measure::{Horizon, Quartiles, closed_form_steps};
use crate::text_table::{Column, TextTable};

/// One seed, `gamma_risk` and `eps_risk`, with what it was measured on.
#[derive(Debug, Clone)]
pub struct Row {
    pub env: String,
    /// Seconds per environment step.
    pub dt: f64,
    pub seed: u64,
    pub gamma: f64,
    pub eps: f64,
    pub pretrain_steps: u64,
    pub pos_fraction: f64,
    pub batch_size: usize,
    pub profile: Profile,
    pub in_sample: bool,
    /// Safe and unsafe demonstrations pretrained on, and measured.
    pub train: (usize, usize),
    pub measured: (usize, usize),
    pub horizon: Horizon,
    pub demos_sha256: String,
}

/// The CSV header.
pub const HEADER: &str = "env,dt_s,seed,gamma_risk,eps_risk,closed_form_steps,closed_form_s,\
pretrain_steps,pos_fraction,batch_size,profile,split,train_safe,train_unsafe,measured_safe,\
measured_unsafe,never_flagged_share,flagged_from_start_share,first_lead_q1_steps,\
first_lead_median_steps,first_lead_q3_steps,first_lead_q1_s,first_lead_median_s,first_lead_q3_s,\
unflagged_at_violation_share,held_lead_q1_steps,held_lead_median_steps,held_lead_q3_steps,\
held_lead_q1_s,held_lead_median_s,held_lead_q3_s,q_at_violation_median,safe_steps_flagged_share,\
safe_episodes_flagged_share,demos_sha256";

impl Row {
    fn split(&self) -> &'static str {
        if self.in_sample { "in-sample" } else { "even-odd" }
    }

    /// The row's CSV line (without the newline).
    pub fn csv(&self) -> String {
        let h = &self.horizon;
        let k = closed_form_steps(self.gamma, self.eps);
        let mut line = format!(
            "{},{},{},{},{},{:.3},{:.4},{},{},{},{},{},{},{},{},{},{:.4},{:.4}",
            self.env,
            self.dt,
            self.seed,
            self.gamma,
            self.eps,
            k,
            k * self.dt,
            self.pretrain_steps,
            self.pos_fraction,
            self.batch_size,
            self.profile.name(),
            self.split(),
            self.train.0,
            self.train.1,
            self.measured.0,
            self.measured.1,
            h.never_flagged_share(),
            h.flagged_from_start_share(),
        );
        let first = Quartiles::of(&h.first_lead);
        self.quartiles(&mut line, first);
        let _ = write!(line, ",{:.4}", h.unflagged_at_violation_share());
        self.quartiles(&mut line, Quartiles::of(&h.held_lead));
        let _ = write!(
            line,
            ",{:.4},{:.4},{:.4},{}",
            Quartiles::of(&h.q_at_violation).median,
            h.safe_steps_share(),
            h.safe_episodes_share(),
            self.demos_sha256
        );
        line
    }

    /// Quartiles in steps, then in seconds.
    fn quartiles(&self, line: &mut String, q: Quartiles) {
        let _ = write!(line, ",{},{},{}", q.q1, q.median, q.q3);
        let _ = write!(line, ",{:.4},{:.4},{:.4}", q.q1 * self.dt, q.median * self.dt, q.q3 * self.dt);
    }
}

/// Writes `rows` to `path` atomically.
pub fn write(path: &Path, rows: &[Row]) -> Result<()> {
    let mut text = String::from(HEADER);
    text.push('\n');
    for row in rows {
        text.push_str(&row.csv());
        text.push('\n');
    }
    defender_io::write_file(path, |w| std::io::Write::write_all(w, text.as_bytes()))
        .map_err(|(at, e)| anyhow::anyhow!("{}: {e}", at.display()))
}

/// Prints the rows as a table: leads as median [quartiles], steps then seconds.
pub fn print(rows: &[Row]) {
    let mut table = TextTable::new(vec![
        Column::left("env"),
        Column::right("seed"),
        Column::right("gamma"),
        Column::right("eps"),
        Column::right("ln eps/ln gamma"),
        Column::right("first lead, steps"),
        Column::right("seconds"),
        Column::right("never%"),
        Column::right("held lead, steps"),
        Column::right("safe steps flagged%"),
    ])
    .with_rule();
    for r in rows {
        let h = &r.horizon;
        let k = closed_form_steps(r.gamma, r.eps);
        let first = Quartiles::of(&h.first_lead);
        let held = Quartiles::of(&h.held_lead);
        let spread = |q: Quartiles, scale: f64| {
            format!("{:.1} [{:.1}-{:.1}]", q.median * scale, q.q1 * scale, q.q3 * scale)
        };
        table.row([
            r.env.clone(),
            r.seed.to_string(),
            r.gamma.to_string(),
            r.eps.to_string(),
            format!("{k:.1} ({:.2} s)", k * r.dt),
            spread(first, 1.0),
            format!("{:.2} [{:.2}-{:.2}]", first.median * r.dt, first.q1 * r.dt, first.q3 * r.dt),
            format!("{:.0}", 100.0 * h.never_flagged_share()),
            spread(held, 1.0),
            format!("{:.2}", 100.0 * h.safe_steps_share()),
        ]);
    }
    put!("{}", table.render());
}
