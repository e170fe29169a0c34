//! `eval.csv` (docs/run-directory.md): one row per evaluation of the deterministic policy, its
//! writer's row format and its reader. Columns came in three steps, and a file of each is read:
//! the first five; `mean_cost` (costs); the shielded evaluation's three (a DEFENDER run's
//! evaluations with the filter kept, empty for a run without one).

use std::path::Path;

use crate::csv::{CsvFile, Row};
use crate::error::Result;

/// The header of `eval.csv`.
pub const EVAL_HEADER: &str = "total_steps,mean_return,std_return,mean_length,episodes,mean_cost,\
shield_mean_return,shield_mean_cost,shield_filtered";

/// The shielded pass of an evaluation (`defender_rl::ShieldedEval`): the same episodes (the same
/// reset seeds) with DEFENDER's filter kept, each stopped at the first step the filter refuses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalShield {
    /// Mean return over the executed steps.
    pub mean_return: f64,
    /// Mean cost over the executed steps.
    pub mean_cost: f64,
    /// Share of the episodes the filter ended (0 to 1).
    pub filtered: f64,
}

/// One row of `eval.csv`: an evaluation of the deterministic policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalRow {
    /// Environment steps of training when it was made.
    pub total_steps: u64,
    /// Mean undiscounted return over the evaluation episodes.
    pub mean_return: f64,
    /// Their standard deviation.
    pub std_return: f64,
    /// Their mean length.
    pub mean_length: f64,
    /// How many episodes.
    pub episodes: u64,
    /// Their mean cost (`None` in files from before costs existed).
    pub mean_cost: Option<f64>,
    /// The same episodes with the filter kept: `None` for a run without a filter and in files
    /// from before the shielded evaluation existed.
    pub shield: Option<EvalShield>,
}

impl EvalRow {
    /// The row as `eval.csv` holds it (without the newline); the shield's columns empty without
    /// one.
    pub fn to_csv(&self) -> String {
        let optional = |v: Option<f64>| v.map(|c| c.to_string()).unwrap_or_default();
        let shield = self.shield;
        format!(
            "{},{},{},{},{},{},{},{},{}",
            self.total_steps,
            self.mean_return,
            self.std_return,
            self.mean_length,
            self.episodes,
            optional(self.mean_cost),
            optional(shield.map(|s| s.mean_return)),
            optional(shield.map(|s| s.mean_cost)),
            optional(shield.map(|s| s.filtered)),
        )
    }
}

/// Every evaluation episode, one row each (the evaluation's mean hides whether 20 of 20 episodes
/// kept a limit or 15 did): written by `defender train`, read by the tools that judge a limit.
pub const EVAL_EPISODES_FILE: &str = "eval_episodes.csv";
/// Its header; the shield's columns are empty for a run without a filter.
pub const EVAL_EPISODES_HEADER: &str =
    "total_steps,episode,return,cost,shield_return,shield_cost,shield_stopped";

/// The rows of `eval_episodes.csv` for one evaluation (none for a record that kept no
/// per-episode costs).
pub fn eval_episode_rows(r: &defender_rl::EvalRecord) -> Vec<String> {
    let shield =
        r.shield.as_ref().filter(|s| s.costs.len() == r.costs.len() && s.stopped.len() == r.costs.len());
    (0..r.costs.len())
        .map(|k| {
            let shielded = shield.map_or(",,".to_string(), |s| {
                format!("{},{},{}", s.returns[k], s.costs[k], u8::from(s.stopped[k]))
            });
            format!("{},{k},{},{},{shielded}", r.total_steps, r.returns[k], r.costs[k])
        })
        .collect()
}

const EVAL_COLUMNS: &[&str] = &["total_steps", "mean_return", "std_return", "mean_length", "episodes"];

/// The shield's columns, in [`EvalShield`]'s order.
const SHIELD_COLUMNS: [&str; 3] = ["shield_mean_return", "shield_mean_cost", "shield_filtered"];

pub(crate) fn parse_eval(path: &Path, text: &str) -> Result<Vec<EvalRow>> {
    let file = CsvFile::parse(path, text, EVAL_HEADER, EVAL_COLUMNS)?;
    let cost_column = file.optional_column("mean_cost");
    let shield_columns = SHIELD_COLUMNS.map(|name| file.optional_column(name));
    let mut evaluations: Vec<EvalRow> = Vec::new();
    for row in file.rows() {
        let evaluation = EvalRow {
            total_steps: row.get(0)?,
            mean_return: row.finite(1)?,
            std_return: row.finite(2)?,
            mean_length: row.finite(3)?,
            episodes: row.get(4)?,
            mean_cost: cost_column.map(|i| row.optional_finite(i, "mean_cost")).transpose()?.flatten(),
            shield: shield(&row, shield_columns)?,
        };
        if let Some(prev) = evaluations.last()
            && evaluation.total_steps < prev.total_steps
        {
            return Err(row.error(format!(
                "total_steps {} decreases (previous row: {})",
                evaluation.total_steps, prev.total_steps
            )));
        }
        evaluations.push(evaluation);
    }
    Ok(evaluations)
}

/// The row's shielded evaluation: all three columns filled, or none (a run without a filter).
fn shield(row: &Row<'_, '_>, columns: [Option<usize>; 3]) -> Result<Option<EvalShield>> {
    let mut values = [None; 3];
    for (k, (column, name)) in columns.into_iter().zip(SHIELD_COLUMNS).enumerate() {
        values[k] = column.map(|i| row.optional_finite(i, name)).transpose()?.flatten();
    }
    match values {
        [None, None, None] => Ok(None),
        [Some(mean_return), Some(mean_cost), Some(filtered)] if (0.0..=1.0).contains(&filtered) => {
            Ok(Some(EvalShield { mean_return, mean_cost, filtered }))
        }
        [Some(_), Some(_), Some(filtered)] => {
            Err(row.error(format!("column shield_filtered: {filtered} is not a share within [0, 1]")))
        }
        _ => Err(row.error(format!(
            "the columns {} are filled together or left empty together",
            SHIELD_COLUMNS.join(", ")
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<EvalRow>> {
        parse_eval(Path::new("eval.csv"), text)
    }

    #[test]
    fn files_of_five_six_and_nine_columns_read() {
        let five =
            parse("total_steps,mean_return,std_return,mean_length,episodes\n10,1.5,0.5,3,2\n").unwrap();
        assert_eq!((five[0].mean_cost, five[0].shield), (None, None));
        let six =
            parse("total_steps,mean_return,std_return,mean_length,episodes,mean_cost\n10,1.5,0.5,3,2,4\n")
                .unwrap();
        assert_eq!((six[0].mean_cost, six[0].shield), (Some(4.0), None));
        let nine = format!("{EVAL_HEADER}\n10,1.5,0.5,3,2,4,,,\n20,2.5,0.5,3,2,4,1.25,0.5,0.5\n");
        let rows = parse(&nine).unwrap();
        assert_eq!(rows[0].shield, None, "a run without a filter leaves them empty");
        let shield = EvalShield { mean_return: 1.25, mean_cost: 0.5, filtered: 0.5 };
        assert_eq!(rows[1].shield, Some(shield));
        // What the writer writes, the reader reads back.
        let text: String = std::iter::once(EVAL_HEADER.to_string())
            .chain(rows.iter().map(EvalRow::to_csv))
            .collect::<Vec<_>>()
            .join("\n");
        assert_eq!(parse(&text).unwrap(), rows);
        assert_eq!(rows[0].to_csv(), "10,1.5,0.5,3,2,4,,,");
    }

    #[test]
    fn a_shield_part_is_whole_and_its_share_a_share() {
        let err = parse(&format!("{EVAL_HEADER}\n10,1.5,0.5,3,2,4,1.0,,0.5\n")).unwrap_err().to_string();
        assert!(err.contains("eval.csv:2") && err.contains("filled together"), "{err}");
        let err = parse(&format!("{EVAL_HEADER}\n10,1.5,0.5,3,2,4,1.0,0,1.5\n")).unwrap_err().to_string();
        assert!(err.contains("shield_filtered: 1.5"), "{err}");
        let err = parse(&format!("{EVAL_HEADER}\n10,1.5,0.5,3,2,4,nan,0,0.5\n")).unwrap_err().to_string();
        assert!(err.contains("shield_mean_return"), "{err}");
    }
}
