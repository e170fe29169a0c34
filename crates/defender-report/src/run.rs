//! One run directory (docs/run-directory.md): its configuration, training episodes, evaluations
//! and summary, read and checked against each other.

use std::path::{Path, PathBuf};

use defender::{FilterOptions, Mode, Strategy};
use defender_rl::{Algo, Budget, Outcome};
use serde::{Deserialize, Serialize};

use crate::csv::CsvFile;
use crate::error::{ReportError, Result};
use crate::eval_csv::parse_eval;
pub use crate::eval_csv::{
    EVAL_EPISODES_FILE, EVAL_EPISODES_HEADER, EVAL_HEADER, EvalRow, EvalShield, eval_episode_rows,
};
pub use crate::label::algo_display;
pub(crate) use crate::label::{RawAgent, algo_label, label_parts};

/// The four files of a run directory.
pub const CONFIG_FILE: &str = "config.toml";
/// Training episodes, one row each.
pub const METRICS_FILE: &str = "metrics.csv";
/// Evaluations of the deterministic policy.
pub const EVAL_FILE: &str = "eval.csv";
/// The run's totals; its presence marks a run directory.
pub const SUMMARY_FILE: &str = "summary.json";

/// The header of `metrics.csv`.
pub const METRICS_HEADER: &str = "episode,total_steps,return,length,outcome,wall_seconds,cost";
/// The learner's statistics every 1000 steps (written by `defender train`, not read by the
/// report).
pub const UPDATES_FILE: &str = "updates.csv";
/// The header of `updates.csv`.
/// The last four columns came later (Recovery RL's count, a Lagrangian agent's cost critic loss,
/// multiplier and mean `Q_c` at the actor's actions): a file of an older run has rows of the
/// first seven or ten only (read as empty).
pub const UPDATES_HEADER: &str = "total_steps,n_updates,qf_loss,qf1_mean,actor_loss,ent_coef,ent_coef_loss,\
recovery_steps,qc_loss,lagrange_multiplier,qc_mean";
/// DEFENDER's dynamics model every 1000 steps, its prediction error on fresh transitions and its
/// training loss (DEFENDER runs only; written by `defender train`, not read by the report).
pub const DYNAMICS_FILE: &str = "dynamics.csv";
/// The header of `dynamics.csv`.
pub const DYNAMICS_HEADER: &str =
    "total_steps,real_steps,gradient_steps,error_last,error_ema,error_mean,loss";

/// Tolerance for comparing a percentage in `summary.json` with the one recomputed from
/// `metrics.csv` (the writer may round to 0.1).
const PCT_TOLERANCE: f64 = 0.051;

/// The DEFENDER settings of a run that a report groups by (from the `[defender]` table of
/// `config.toml`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct DefenderSettings {
    /// `SAFE/UNSAFE`, e.g. `MeanDemoW5/MeanDemoW10`.
    pub strategy: String,
    /// State or state-action trajectories.
    pub mode: Mode,
    /// Demonstrations used per group, when given.
    pub num_demos: Option<u64>,
    /// The strategy was chosen by `--strategy auto` (`config.toml` has `[defender.selection]`):
    /// such runs form rows of their own, labelled `auto: SAFE/UNSAFE`.
    pub auto: bool,
    /// DTW on z-scored features (`[defender.cost] scaling = "zscore"`) rather than SPEC section
    /// 2's plain DTW: rows of their own, labelled `z-score`.
    pub zscore: bool,
    /// The DTW filter decides the end (`[defender.filter] trigger`, `dtw` by default). Another
    /// trigger (docs/SPEC.md section 15) reads no DTW strategy, though its configuration names
    /// one: its table cells say `-` and its plot label `no DTW`, not a strategy it never used.
    pub dtw: bool,
}

impl DefenderSettings {
    /// What sets these settings apart from a fixed strategy on plain DTW, as a label prefix:
    /// `auto: `, `z-score: `, `auto, z-score: ` or nothing.
    fn prefix(&self) -> &'static str {
        match (self.auto, self.zscore) {
            (false, false) => "",
            (true, false) => "auto: ",
            (false, true) => "z-score: ",
            (true, true) => "auto, z-score: ",
        }
    }

    /// The strategy as a table or plot names it: `SAFE/UNSAFE`, or `auto: SAFE/UNSAFE` (see
    /// [`DefenderSettings::prefix`]).
    pub fn name(&self) -> String {
        if !self.dtw {
            return "no DTW".to_string();
        }
        format!("{}{}", self.prefix(), self.strategy)
    }

    /// The safe group's column of a table: [`DefenderSettings::safe`], with the same prefix.
    pub fn safe_cell(&self) -> String {
        if !self.dtw {
            return "-".to_string();
        }
        format!("{}{}", self.prefix(), self.safe())
    }

    /// The strategy of the safe group (before the `/`); `-` for another trigger than DTW.
    pub fn safe(&self) -> &str {
        if !self.dtw {
            return "-";
        }
        self.strategy.split_once('/').map_or(self.strategy.as_str(), |(s, _)| s)
    }

    /// The strategy of the unsafe group (after the `/`); `-` for another trigger than DTW.
    pub fn unsafe_(&self) -> &str {
        if !self.dtw {
            return "-";
        }
        self.strategy.split_once('/').map_or(self.strategy.as_str(), |(_, u)| u)
    }
}

/// What the report needs from `config.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSettings {
    /// Gymnasium id, e.g. `Hopper-v5`.
    pub env: String,
    /// `sac` or `td3`.
    pub algo: String,
    /// The run's seed.
    pub seed: u64,
    /// Steps or episodes.
    pub budget: Budget,
    /// `None` for a bare run.
    pub filter: Option<DefenderSettings>,
    /// The learner's random warm-up in training steps (`learning_starts` of `[sac]` or `[td3]`);
    /// `None` for a run whose configuration does not say (a peer library's run).
    pub warmup_steps: Option<u64>,
}

/// `summary.json`: written by `defender train` (early with `complete: false`, then after every
/// episode and at the end), read and validated by [`Run::load`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Gymnasium id.
    pub env: String,
    /// `sac` or `td3`.
    pub algo: Algo,
    /// The run's seed.
    pub seed: u64,
    /// `SAFE/UNSAFE`, `None` for a bare run.
    pub strategy: Option<Strategy>,
    /// `state` or `state-action`, `None` for a bare run.
    pub mode: Option<Mode>,
    /// Mean return of the final evaluation (the paper's Acc Reward); `None` (null) until it ran.
    /// [`Run::load`] accepts a complete run only with a finite value, see [`Run::acc_reward`].
    pub acc_reward: Option<f64>,
    /// Crashed training episodes / all training episodes x 100.
    pub crash_pct: f64,
    /// Filtered training episodes / all training episodes x 100.
    pub filtered_pct: f64,
    /// Training episodes.
    pub episodes: u64,
    /// Environment steps.
    pub steps: u64,
    /// Steps DEFENDER filtered.
    pub filtered_steps: u64,
    /// Wall-clock seconds of the whole run.
    pub wall_seconds: f64,
    /// Environment steps per wall-clock second.
    pub steps_per_second: f64,
    /// `false` while the run is in progress or after it was stopped.
    pub complete: bool,
    /// Violations counted as the field counts them (absent, all zero, in summaries written
    /// before they existed; `defender report` computes them from `metrics.csv`).
    #[serde(flatten, default)]
    pub violations: crate::violations::Violations,
    /// How the strategy was chosen, for a run configured with `strategy = "auto"`; absent
    /// otherwise. The same record as `config.toml`'s `[defender.selection]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection: Option<StrategySelection>,
    /// The episode cost limit of the run's task (25 for the velocity tasks), from the task
    /// registry `defender train` ran it with; absent for a task without one and in summaries
    /// written before it existed. `defender report` uses it when not told the task's limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub episode_cost_limit: Option<f64>,
}

/// How `defender train --strategy auto` chose the strategy of a run (`defender select`'s
/// criterion, docs/decisions.md): the `[defender.selection]` table of `config.toml` and the
/// `selection` object of `summary.json`. The chosen strategy itself is the run's `strategy`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrategySelection {
    /// `"auto"`.
    pub chosen_by: String,
    /// Strategies ranked.
    pub candidates: usize,
    /// Whether the strategies of the Equal window were among them.
    pub equal: bool,
    /// L: the lead time (steps before the crash) a prevented crash needed.
    pub min_lead: usize,
    /// The false-alarm budget: strategies with a higher false-alarm rate were not chosen.
    pub max_false_alarm: f64,
    /// Safe demonstrations used.
    pub safe_demos: usize,
    /// Unsafe demonstrations used.
    pub unsafe_demos: usize,
    /// The chosen strategy's held-out safe demonstrations filtered / safe ones.
    pub false_alarm_rate: f64,
    /// Its held-out unsafe demonstrations filtered in time / unsafe ones.
    pub crash_prevention_rate: f64,
    /// Mean fraction of the held-out safe demonstrations executed before a filtered step.
    pub safe_allowed: f64,
    /// Mean lead time of the prevented crashes, in steps.
    pub mean_lead: f64,
    /// `(1 - false_alarm_rate) x crash_prevention_rate`.
    pub score: f64,
    /// Seconds the selection took.
    pub seconds: f64,
    /// The feature scalings compared when the run set none (`["none", "zscore"]`; the one chosen
    /// is `[defender.cost] scaling`); empty when the run's own scaling was used.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scalings: Vec<String>,
}

impl Summary {
    /// Sets `episodes`, `crash_pct`, `filtered_pct`, `violations` and `steps_per_second` from the
    /// outcomes and costs of the training episodes and the `steps` and `wall_seconds` already set, as [`Run::load`] checks them.
    /// `costs`: the episodes' costs, for [`Summary::violations`].
    pub fn count(&mut self, outcomes: impl IntoIterator<Item = (Outcome, f64)>) {
        let mut counts = OutcomeCounts::default();
        let mut cost = 0.0;
        outcomes.into_iter().for_each(|(o, c)| {
            counts.add(o);
            cost += c;
        });
        self.violations =
            crate::violations::Violations::new(counts.crashed, cost, self.steps, self.filtered_steps);
        self.episodes = counts.episodes;
        self.crash_pct = counts.crash_pct();
        self.filtered_pct = counts.filtered_pct();
        self.steps_per_second =
            if self.wall_seconds > 0.0 { self.steps as f64 / self.wall_seconds } else { 0.0 };
    }
}

/// Training episodes by outcome: the one count behind `summary.json`'s percentages, the check of
/// a run directory, and a training run's progress line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct OutcomeCounts {
    /// Episodes counted.
    pub episodes: u64,
    /// Of which crashed.
    pub crashed: u64,
    /// Of which DEFENDER ended.
    pub filtered: u64,
}

impl OutcomeCounts {
    /// Counts one episode.
    pub fn add(&mut self, outcome: Outcome) {
        self.episodes += 1;
        self.crashed += u64::from(outcome == Outcome::Crashed);
        self.filtered += u64::from(outcome == Outcome::Filtered);
    }

    /// Crashed episodes / all x 100 (0 without episodes).
    pub fn crash_pct(&self) -> f64 {
        self.pct(self.crashed)
    }

    /// Filtered episodes / all x 100 (0 without episodes).
    pub fn filtered_pct(&self) -> f64 {
        self.pct(self.filtered)
    }

    fn pct(&self, k: u64) -> f64 {
        if self.episodes == 0 { 0.0 } else { 100.0 * k as f64 / self.episodes as f64 }
    }
}

/// One row of `metrics.csv`: a training episode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeRow {
    /// 0-based index.
    pub episode: u64,
    /// Environment steps taken by the end of this episode.
    pub total_steps: u64,
    /// Undiscounted return.
    pub ret: f64,
    /// Steps in this episode.
    pub length: u64,
    /// How it ended.
    pub outcome: Outcome,
    /// Wall-clock seconds since the run started, at the end of this episode.
    pub wall_seconds: f64,
    /// Sum of the steps' costs (a file from before costs existed, all of crash tasks: 1 for a
    /// crashed episode, else 0).
    pub cost: f64,
}

impl EpisodeRow {
    /// The row as `metrics.csv` holds it (without the newline).
    pub fn to_csv(&self) -> String {
        format!(
            "{},{},{},{},{},{:.3},{}",
            self.episode,
            self.total_steps,
            self.ret,
            self.length,
            self.outcome.as_str(),
            self.wall_seconds,
            self.cost
        )
    }
}

/// A complete run directory, read and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The directory.
    pub dir: PathBuf,
    /// From `config.toml`.
    pub config: RunSettings,
    /// From `summary.json`.
    pub summary: Summary,
    /// From `metrics.csv`, in order.
    pub episodes: Vec<EpisodeRow>,
    /// From `eval.csv`, in order; the last one is the final evaluation.
    pub evaluations: Vec<EvalRow>,
    /// From `interventions.csv`, in order: every episode DEFENDER ended; `None` for a run
    /// without the file (a bare run, or one written before it existed).
    pub interventions: Option<Vec<crate::interventions::InterventionRow>>,
    /// From `eval_episodes.csv`, in order: every evaluation episode; `None` for a run without
    /// the file (one written before it existed).
    pub eval_episodes: Option<Vec<crate::eval_episodes::EvalEpisodeRow>>,
}

impl Run {
    /// Reads the run directory `dir`.
    ///
    /// # Errors
    ///
    /// [`ReportError::Incomplete`] when `summary.json` says `"complete": false` (checked first, so
    /// a run in progress is recognised whatever the state of its other files); otherwise an error
    /// naming the file at fault when a file is missing, unreadable, does not follow
    /// docs/run-directory.md, or contradicts another file (the seed, task, algorithm or strategy of
    /// `summary.json` and `config.toml`; the episode and step counts and the crash and filtered
    /// percentages of `summary.json` and `metrics.csv`; `acc_reward` and the last row of `eval.csv`).
    pub fn load(dir: impl AsRef<Path>) -> Result<Run> {
        let dir = dir.as_ref();
        let summary_path = dir.join(SUMMARY_FILE);
        let summary_text = read(&summary_path)?;
        let summary_value = summary_json(dir, &summary_path, &summary_text)?;
        // config.toml before the summary's typed fields, so that a malformed strategy is reported
        // against the file that configures it.
        let config_path = dir.join(CONFIG_FILE);
        let config = parse_config(&config_path, &read(&config_path)?)?;
        let summary = parse_summary(&summary_path, summary_value)?;
        let metrics_path = dir.join(METRICS_FILE);
        let episodes = parse_metrics(&metrics_path, &read(&metrics_path)?)?;
        let eval_path = dir.join(EVAL_FILE);
        let evaluations = parse_eval(&eval_path, &read(&eval_path)?)?;
        let interventions = crate::interventions::load_interventions(dir)?;
        let eval_episodes = crate::eval_episodes::load_eval_episodes(dir)?;
        let run = Run {
            dir: dir.to_path_buf(),
            config,
            summary,
            episodes,
            evaluations,
            interventions,
            eval_episodes,
        };
        run.check()?;
        Ok(run)
    }

    /// The paper's Acc Reward: the mean return of the final evaluation. [`Run::load`] refuses a
    /// run without a finite one, so this is never NaN for a loaded run.
    pub fn acc_reward(&self) -> f64 {
        self.summary.acc_reward.unwrap_or(f64::NAN)
    }

    /// Training episodes that crashed.
    pub fn crashed(&self) -> usize {
        self.episodes.iter().filter(|e| e.outcome == Outcome::Crashed).count()
    }

    /// Training episodes that crashed after the learner's random warm-up (ending after its
    /// `learning_starts` training steps): the crashes a learner's own choices caused, which a
    /// baseline acting through its learner can only affect from then on (a filter acts from the
    /// first step). `None` when the configuration does not give the warm-up.
    pub fn crashed_after_warmup(&self) -> Option<usize> {
        let warmup = self.config.warmup_steps?;
        Some(self.episodes.iter().filter(|e| e.outcome == Outcome::Crashed && e.total_steps > warmup).count())
    }

    /// Cross-checks the four files.
    fn check(&self) -> Result<()> {
        let (c, s) = (&self.config, &self.summary);
        let summary_path = self.dir.join(SUMMARY_FILE);
        let invalid = |message: String| ReportError::Invalid { path: summary_path.clone(), message };
        // The row's algorithm label carries the arm in brackets after the algorithm's name.
        let algo = c.algo.split(' ').next().unwrap_or_default();
        if (s.env.as_str(), s.algo.as_str(), s.seed) != (c.env.as_str(), algo, c.seed) {
            return Err(invalid(format!(
                "env/algo/seed {}/{}/{} disagree with config.toml's {}/{}/{}",
                s.env, s.algo, s.seed, c.env, c.algo, c.seed
            )));
        }
        let config_filter = c.filter.as_ref().map(|f| (f.strategy.clone(), f.mode));
        let summary_filter = s.strategy.map(|st| st.to_string()).zip(s.mode);
        if config_filter != summary_filter || s.strategy.is_some() != s.mode.is_some() {
            let show = |v: Option<String>| v.map_or("null".to_string(), |v| format!("{v:?}"));
            return Err(invalid(format!(
                "strategy/mode {}/{} disagree with config.toml's [defender] table {:?}",
                show(s.strategy.map(|st| st.to_string())),
                show(s.mode.map(|m| m.to_string())),
                config_filter.map(|(st, m)| (st, m.to_string()))
            )));
        }
        let n = self.episodes.len() as u64;
        if s.episodes != n {
            return Err(invalid(format!("episodes = {} but metrics.csv has {n} episodes", s.episodes)));
        }
        let last_steps = self.episodes.last().map_or(0, |e| e.total_steps);
        if s.steps < last_steps {
            return Err(invalid(format!(
                "steps = {} but metrics.csv's last episode ends at total_steps {last_steps}",
                s.steps
            )));
        }
        let mut counts = OutcomeCounts::default();
        self.episodes.iter().for_each(|e| counts.add(e.outcome));
        let crash = counts.crash_pct();
        if (s.crash_pct - crash).abs() > PCT_TOLERANCE {
            return Err(invalid(format!(
                "crash_pct = {} but metrics.csv has {} crashed of {n} episodes ({crash:.3}%)",
                s.crash_pct, counts.crashed
            )));
        }
        let filtered = counts.filtered_pct();
        if (s.filtered_pct - filtered).abs() > PCT_TOLERANCE {
            return Err(invalid(format!(
                "filtered_pct = {} but metrics.csv has {} filtered of {n} episodes ({filtered:.3}%)",
                s.filtered_pct, counts.filtered
            )));
        }
        let Some(last_eval) = self.evaluations.last() else {
            return Err(ReportError::Invalid {
                path: self.dir.join(EVAL_FILE),
                message: "no evaluation row; a complete run ends with its final evaluation".into(),
            });
        };
        let tolerance = 0.01 + 1e-6 * last_eval.mean_return.abs();
        if (self.acc_reward() - last_eval.mean_return).abs() > tolerance {
            return Err(invalid(format!(
                "acc_reward = {} but the last row of eval.csv has mean_return {}",
                self.acc_reward(),
                last_eval.mean_return
            )));
        }
        Ok(())
    }
}

fn read(path: &Path) -> Result<String> {
    defender_io::read_input_to_string(path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound {
            ReportError::MissingFile { path: path.to_path_buf() }
        } else {
            ReportError::Io { path: path.to_path_buf(), source }
        }
    })
}

/// `summary.json` as JSON, checked for `"complete": true` first: an incomplete run may lack the
/// totals.
fn summary_json(dir: &Path, path: &Path, text: &str) -> Result<serde_json::Value> {
    let json_err = |source| ReportError::Json { path: path.to_path_buf(), source };
    let value: serde_json::Value = serde_json::from_str(text).map_err(json_err)?;
    match value.get("complete") {
        Some(serde_json::Value::Bool(true)) => {}
        Some(serde_json::Value::Bool(false)) => {
            return Err(ReportError::Incomplete { dir: dir.to_path_buf() });
        }
        other => {
            return Err(ReportError::Invalid {
                path: path.to_path_buf(),
                message: format!("\"complete\" must be true or false, found {other:?}"),
            });
        }
    }
    Ok(value)
}

fn parse_summary(path: &Path, value: serde_json::Value) -> Result<Summary> {
    let summary: Summary = serde_json::from_value(value)
        .map_err(|source| ReportError::Json { path: path.to_path_buf(), source })?;
    let Some(acc_reward) = summary.acc_reward else {
        return Err(ReportError::Invalid {
            path: path.to_path_buf(),
            message: "acc_reward is missing or null, but a complete run ends with its final evaluation"
                .into(),
        });
    };
    let finite = [
        ("acc_reward", acc_reward),
        ("crash_pct", summary.crash_pct),
        ("filtered_pct", summary.filtered_pct),
        ("wall_seconds", summary.wall_seconds),
    ];
    if let Some((name, v)) = finite.iter().find(|(_, v)| !v.is_finite()) {
        return Err(ReportError::Invalid {
            path: path.to_path_buf(),
            message: format!("{name} = {v} is not a finite number"),
        });
    }
    if summary.wall_seconds <= 0.0 {
        return Err(ReportError::Invalid {
            path: path.to_path_buf(),
            message: format!("wall_seconds = {} must be positive", summary.wall_seconds),
        });
    }
    Ok(summary)
}

#[derive(Deserialize)]
pub(crate) struct RawConfig {
    pub(crate) env: String,
    pub(crate) algo: String,
    pub(crate) seed: u64,
    pub(crate) total_steps: u64,
    pub(crate) total_episodes: u64,
    pub(crate) defender: Option<RawDefender>,
    #[serde(default)]
    pub(crate) profile: Option<String>,
    #[serde(default)]
    pub(crate) sac: Option<RawAgent>,
    #[serde(default)]
    pub(crate) td3: Option<RawAgent>,
    #[serde(default)]
    pub(crate) safety: Option<toml::Table>,
    /// A peer library's run converted to a run directory (`tools/peers/omnisafe_run_dir.py`): its
    /// `name` labels the row.
    #[serde(default)]
    pub(crate) peer: Option<toml::Table>,
}

#[derive(Deserialize)]
pub(crate) struct RawDefender {
    strategy: String,
    mode: String,
    num_demos: Option<u64>,
    selection: Option<toml::Table>,
    #[serde(default)]
    cost: RawCost,
    #[serde(default)]
    pub(crate) filter: FilterOptions,
    /// `violation` when a filtered step charges the learner (docs/SPEC.md section 14).
    #[serde(default)]
    pub(crate) filtered_cost: Option<String>,
}

#[derive(Deserialize, Default)]
struct RawCost {
    #[serde(default)]
    scaling: Option<String>,
}

fn parse_config(path: &Path, text: &str) -> Result<RunSettings> {
    let raw: RawConfig = toml::from_str(text)
        .map_err(|e| ReportError::Toml { path: path.to_path_buf(), source: Box::new(e) })?;
    let invalid = |message: String| ReportError::Invalid { path: path.to_path_buf(), message };
    let budget = match (raw.total_steps, raw.total_episodes) {
        (n, 0) if n > 0 => Budget::Steps(n),
        (0, n) if n > 0 => Budget::Episodes(n),
        (s, e) => {
            return Err(invalid(format!(
                "exactly one of total_steps ({s}) and total_episodes ({e}) must be non-zero"
            )));
        }
    };
    let algo = algo_label(&raw);
    let filter = match raw.defender {
        None => None,
        Some(d) => {
            let mode = d.mode.parse::<Mode>().map_err(|_| {
                invalid(format!("[defender] mode = {:?}: expected \"state\" or \"state-action\"", d.mode))
            })?;
            if d.strategy.split('/').count() != 2 || d.strategy.split('/').any(str::is_empty) {
                return Err(invalid(format!(
                    "[defender] strategy = {:?}: expected SAFE/UNSAFE, e.g. \"MeanDemoW5/MeanDemoW10\"",
                    d.strategy
                )));
            }
            Some(DefenderSettings {
                strategy: d.strategy,
                mode,
                num_demos: d.num_demos,
                auto: d.selection.is_some(),
                zscore: d.cost.scaling.as_deref() == Some("zscore"),
                dtw: d.filter.trigger.is_dtw(),
            })
        }
    };
    let warmup_steps = raw.sac.as_ref().or(raw.td3.as_ref()).and_then(|a| a.learning_starts);
    Ok(RunSettings { env: raw.env, algo, seed: raw.seed, budget, filter, warmup_steps })
}

const METRICS_COLUMNS: &[&str] = &["episode", "total_steps", "return", "length", "outcome", "wall_seconds"];

fn parse_metrics(path: &Path, text: &str) -> Result<Vec<EpisodeRow>> {
    let file = CsvFile::parse(path, text, METRICS_HEADER, METRICS_COLUMNS)?;
    let cost_column = file.optional_column("cost");
    let mut episodes: Vec<EpisodeRow> = Vec::new();
    for row in file.rows() {
        let outcome = Outcome::from_name(row.text(4)).ok_or_else(|| {
            row.error(format!("column outcome: {:?} is not one of crashed, filtered, truncated", row.text(4)))
        })?;
        let episode = EpisodeRow {
            episode: row.get(0)?,
            total_steps: row.get(1)?,
            ret: row.finite(2)?,
            length: row.get(3)?,
            outcome,
            wall_seconds: row.finite(5)?,
            cost: match cost_column {
                Some(i) => row.optional_finite(i, "cost")?.unwrap_or_default(),
                None => f64::from(u8::from(outcome == Outcome::Crashed)),
            },
        };
        let expected = episodes.len() as u64;
        if episode.episode != expected {
            return Err(row.error(format!("episode {} out of order: expected {expected}", episode.episode)));
        }
        if let Some(prev) = episodes.last()
            && episode.total_steps < prev.total_steps
        {
            return Err(row.error(format!(
                "total_steps {} decreases (previous row: {})",
                episode.total_steps, prev.total_steps
            )));
        }
        episodes.push(episode);
    }
    Ok(episodes)
}
