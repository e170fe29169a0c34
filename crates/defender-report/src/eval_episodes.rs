//! `eval_episodes.csv` (docs/run-directory.md): every evaluation episode, one row each, and what
//! the report reads from it on a task with an episode cost limit: the share of the evaluation
//! episodes whose cost is at most the limit, over the same last [`LAST_EVALUATIONS`]
//! evaluations as the evaluation cost. The evaluation's mean cost hides whether 20 of 20
//! episodes kept the limit or 15 did and 5 broke it far.
//!
//! A run written before the file existed has none: its share is `None` (`-` in a table).

use std::path::Path;

use crate::csv::{CsvFile, Row};
use crate::error::{ReportError, Result};
use crate::eval_csv::{EVAL_EPISODES_FILE, EVAL_EPISODES_HEADER};
use crate::measures::LAST_EVALUATIONS;
use crate::run::Run;

/// The shielded pass of one evaluation episode: the same episode (the same reset seed) with
/// DEFENDER's filter kept, stopped at the first step the filter refuses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalEpisodeShield {
    /// Return over the executed steps.
    pub ret: f64,
    /// Cost over the executed steps.
    pub cost: f64,
    /// The filter stopped it.
    pub stopped: bool,
}

/// One row of `eval_episodes.csv`: an evaluation episode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalEpisodeRow {
    /// Environment steps of training when its evaluation ran.
    pub total_steps: u64,
    /// Its index in its evaluation (from 0).
    pub episode: u64,
    /// Its undiscounted return.
    pub ret: f64,
    /// Its cost.
    pub cost: f64,
    /// The same episode with the filter kept; `None` for a run without a filter.
    pub shield: Option<EvalEpisodeShield>,
}

const COLUMNS: &[&str] =
    &["total_steps", "episode", "return", "cost", "shield_return", "shield_cost", "shield_stopped"];

/// Reads `eval_episodes.csv` at `path`. An evaluation's episodes are numbered from 0 in order, at
/// one `total_steps`; the next evaluation starts again at 0, at the same or a later
/// `total_steps`.
///
/// # Errors
/// A file that does not follow the header, a malformed value, episodes out of order or a
/// decreasing `total_steps` (naming file, line and column).
pub fn parse_eval_episodes(path: &Path, text: &str) -> Result<Vec<EvalEpisodeRow>> {
    let file = CsvFile::parse(path, text, EVAL_EPISODES_HEADER, COLUMNS)?;
    let mut rows: Vec<EvalEpisodeRow> = Vec::new();
    for row in file.rows() {
        let episode = EvalEpisodeRow {
            total_steps: row.get(0)?,
            episode: row.get(1)?,
            ret: row.finite(2)?,
            cost: row.finite(3)?,
            shield: shield(&row)?,
        };
        match rows.last() {
            Some(prev) if episode.total_steps < prev.total_steps => {
                return Err(row.error(format!(
                    "total_steps {} decreases (previous row: {})",
                    episode.total_steps, prev.total_steps
                )));
            }
            // Episode 0 starts an evaluation; any other continues the previous row's.
            Some(prev)
                if episode.episode != 0
                    && (episode.total_steps != prev.total_steps || episode.episode != prev.episode + 1) =>
            {
                let expected = if episode.total_steps == prev.total_steps {
                    format!("{} (or 0, starting the next evaluation)", prev.episode + 1)
                } else {
                    "0: an evaluation at a new total_steps starts at episode 0".to_string()
                };
                return Err(
                    row.error(format!("episode {} out of order: expected {expected}", episode.episode))
                );
            }
            None if episode.episode != 0 => {
                return Err(row.error(format!(
                    "episode {} out of order: expected 0, the first episode of an evaluation",
                    episode.episode
                )));
            }
            _ => {}
        }
        rows.push(episode);
    }
    Ok(rows)
}

/// The row's shielded pass: its three columns filled, or all empty (a run without a filter).
fn shield(row: &Row<'_, '_>) -> Result<Option<EvalEpisodeShield>> {
    match (row.text(4), row.text(5), row.text(6)) {
        ("", "", "") => Ok(None),
        (_, _, "") | (_, "", _) | ("", _, _) => Err(row.error(format!(
            "the columns {} are filled together or left empty together",
            COLUMNS[4..].join(", ")
        ))),
        (_, _, stopped) => {
            let stopped = match stopped {
                "0" => false,
                "1" => true,
                other => return Err(row.error(format!("column shield_stopped: {other:?} is not 0 or 1"))),
            };
            Ok(Some(EvalEpisodeShield { ret: row.finite(4)?, cost: row.finite(5)?, stopped }))
        }
    }
}

/// The evaluation episodes of the run directory `dir`, `None` when it has no
/// `eval_episodes.csv` (a run written before the file existed).
///
/// # Errors
/// The file exists but cannot be read, or [`parse_eval_episodes`] refuses it.
pub(crate) fn load_eval_episodes(dir: &Path) -> Result<Option<Vec<EvalEpisodeRow>>> {
    let path = dir.join(EVAL_EPISODES_FILE);
    match defender_io::read_input_to_string(&path) {
        Ok(text) => parse_eval_episodes(&path, &text).map(Some),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(ReportError::Io { path, source }),
    }
}

/// `rows` split into evaluations: each starts at an episode 0 ([`parse_eval_episodes`] checked
/// the order).
fn evaluations(rows: &[EvalEpisodeRow]) -> Vec<&[EvalEpisodeRow]> {
    let mut out: Vec<&[EvalEpisodeRow]> = Vec::new();
    let mut start = 0;
    for i in 1..=rows.len() {
        if i == rows.len() || rows[i].episode == 0 {
            out.push(&rows[start..i]);
            start = i;
        }
    }
    out
}

/// The share of `costs` at most `limit` (an episode at the limit kept the constraint); `None`
/// without any.
fn share_within(costs: impl Iterator<Item = f64>, limit: f64) -> Option<f64> {
    let (within, all) = costs.fold((0usize, 0usize), |(w, n), c| (w + usize::from(c <= limit), n + 1));
    (all > 0).then(|| within as f64 / all as f64)
}

impl Run {
    /// The run's evaluations in `eval_episodes.csv`, in order; `None` without the file.
    fn eval_episode_evaluations(&self) -> Option<Vec<&[EvalEpisodeRow]>> {
        self.eval_episodes.as_deref().map(evaluations)
    }

    /// Eval episodes cost <= L (last-10): of the evaluation episodes of the run's last
    /// [`LAST_EVALUATIONS`] evaluations in `eval_episodes.csv` (all of them when there are
    /// fewer), the share whose cost is at most `limit`, pooled over those episodes; `None`
    /// without the file or without a row in it.
    pub fn eval_within_limit(&self, limit: f64) -> Option<f64> {
        let evaluations = self.eval_episode_evaluations()?;
        let last = &evaluations[evaluations.len().saturating_sub(LAST_EVALUATIONS)..];
        share_within(last.iter().flat_map(|e| e.iter().map(|r| r.cost)), limit)
    }

    /// Shielded episodes cost <= L (last-10): the same share of the shielded episodes, over the
    /// last [`LAST_EVALUATIONS`] evaluations that have them (as the shielded columns read
    /// `eval.csv`); `None` for a run without a filter or without the file.
    pub fn shield_within_limit(&self, limit: f64) -> Option<f64> {
        let evaluations = self.eval_episode_evaluations()?;
        let shielded: Vec<&[EvalEpisodeRow]> =
            evaluations.into_iter().filter(|e| e.iter().any(|r| r.shield.is_some())).collect();
        let last = &shielded[shielded.len().saturating_sub(LAST_EVALUATIONS)..];
        share_within(last.iter().flat_map(|e| e.iter().filter_map(|r| r.shield.map(|s| s.cost))), limit)
    }
}

/// Notes on a row's evaluation episodes, for the table's notes on a task with the limit
/// `limit`: seeds without `eval_episodes.csv` beside seeds with it (the shares are over the
/// latter), and a run whose file does not hold the same last evaluations as its `eval.csv`
/// (fewer of them, or other steps or episode counts).
pub(crate) fn notes(label: &str, runs: &[&Run], limit: f64) -> Vec<String> {
    let mut notes = Vec::new();
    let column = format!("Eval episodes cost ≤ {limit}");
    let without: Vec<String> =
        runs.iter().filter(|r| r.eval_episodes.is_none()).map(|r| r.config.seed.to_string()).collect();
    if !without.is_empty() && without.len() < runs.len() {
        notes.push(format!(
            "{column} of {label}: no eval_episodes.csv for seed(s) {}; the shares are over the other {} \
             seed(s).",
            without.join(", "),
            runs.len() - without.len()
        ));
    }
    for run in runs {
        let Some(evaluations) = run.eval_episode_evaluations() else { continue };
        let k = evaluations.len().min(LAST_EVALUATIONS);
        let wanted = run.evaluations.len().min(LAST_EVALUATIONS);
        let file: Vec<(u64, u64)> =
            evaluations[evaluations.len() - k..].iter().map(|e| (e[0].total_steps, e.len() as u64)).collect();
        let eval: Vec<(u64, u64)> = run.evaluations[run.evaluations.len().saturating_sub(k)..]
            .iter()
            .map(|e| (e.total_steps, e.episodes))
            .collect();
        let seed = run.config.seed;
        if file != eval {
            notes.push(format!(
                "{label} seed {seed}: the last {k} evaluations of eval_episodes.csv differ from eval.csv's \
                 (total_steps or episodes); {column} reads eval_episodes.csv."
            ));
        } else if k < wanted {
            notes.push(format!(
                "{label} seed {seed}: eval_episodes.csv holds {k} evaluation(s), fewer than the last {wanted} \
                 of eval.csv (a run resumed from a checkpoint made before the file existed); {column} is \
                 over those {k}."
            ));
        }
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<EvalEpisodeRow>> {
        parse_eval_episodes(Path::new("eval_episodes.csv"), text)
    }

    #[test]
    fn evaluations_split_at_episode_zero_even_at_one_total_steps() {
        let text =
            format!("{EVAL_EPISODES_HEADER}\n100,0,1,0,,,\n100,1,1,30,,,\n100,0,2,5,1,2,1\n200,0,3,25,,,\n");
        let rows = parse(&text).unwrap();
        assert_eq!(rows[2].shield, Some(EvalEpisodeShield { ret: 1.0, cost: 2.0, stopped: true }));
        let split: Vec<usize> = evaluations(&rows).iter().map(|e| e.len()).collect();
        assert_eq!(split, [2, 1, 1]);
        assert_eq!(share_within(rows.iter().map(|r| r.cost), 25.0), Some(0.75), "25 is within");
        assert_eq!(share_within(std::iter::empty(), 25.0), None);
    }

    #[test]
    fn what_the_writer_writes_reads_back() {
        let mut record: defender_rl::EvalRecord = serde_json::from_str(
            r#"{"total_steps":300,"mean_return":1.5,"std_return":0.5,"mean_length":3.0,"mean_cost":4.0,
            "episodes":2,"returns":[1.0,2.0],"costs":[3.0,5.0],"is_final":true}"#,
        )
        .unwrap();
        let text =
            format!("{EVAL_EPISODES_HEADER}\n{}\n", crate::eval_csv::eval_episode_rows(&record).join("\n"));
        let rows = parse(&text).unwrap();
        assert_eq!((rows.len(), rows[1].episode, rows[1].cost, rows[1].shield), (2, 1, 5.0, None));
        record.costs.clear();
        assert!(crate::eval_csv::eval_episode_rows(&record).is_empty(), "no per-episode costs, no rows");
    }
}
