//! What a `defender train` run writes for TensorBoard, and when, into its run directory (one
//! event file, so `tensorboard --logdir` over a sweep shows one curve per run directory). Every
//! scalar is indexed by environment steps:
//!
//! * at each episode's end: `episode/return`, `episode/length`, `episode/crashed`,
//!   `episode/filtered` (1 or 0: the outcome), `rollout/ep_rew_mean` and `rollout/ep_len_mean`
//!   (over the last 100 episodes, as Stable-Baselines3), `defender/crash_rate` and
//!   `defender/filter_rate` (cumulative, as `summary.json`), `defender/crash_rate_recent` and
//!   `defender/filter_rate_recent` (the last 100), as `defender_rl.sb3.DefenderCallback` names them,
//!   and the field's counts: `safety/crashes` (crashed episodes so far) and `safety/episode_cost`;
//! * every `update_log::EVERY` steps: the `updates.csv` row (`train/critic_loss`, `train/mean_q`,
//!   `train/actor_loss`, `train/ent_coef`, `train/ent_coef_loss`, `train/n_updates`, as
//!   Stable-Baselines3 names them; Recovery RL's `safety/recovery_steps`, the steps its recovery
//!   policy has acted so far), `time/fps` (environment steps per second), and for a DEFENDER
//!   run the dynamics model (`defender/dynamics_error`: the moving average of its prediction
//!   error on fresh transitions, `defender/dynamics_loss`) and the window's mean costs
//!   (`defender/mean_safe_cost`, `defender/mean_unsafe_cost`, `defender/filtered_step_rate`);
//! * at each evaluation: `eval/mean_reward`, `eval/std_reward`, `eval/mean_ep_length`,
//!   `eval/mean_cost`, and for a DEFENDER run the evaluation with the filter kept
//!   (`eval/shield_mean_reward`, `eval/shield_mean_cost`, `eval/shield_filtered`);
//! * once: `defender/r_task`.
//!
//! A checkpoint records the file's name and length (`extra/tensorboard.json`); a resumed run
//! truncates the file to that length, so the steps after the checkpoint, trained again, appear
//! once (docs/decisions-python.md, "TensorBoard event files").

use std::collections::VecDeque;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use defender_report::EvalRow;
use defender_rl::{EpisodeRecord, EvalRecord, Outcome};
use serde::{Deserialize, Serialize};

use super::event_file::{EventFile, now};
use crate::cost_meter::{self, CostWindow, SharedCosts};
use crate::run_dir;
use crate::update_log::{DynamicsRow, UpdateRow};

/// The board's state in a checkpoint's extra directory.
pub const CHECKPOINT_FILE: &str = "tensorboard.json";
/// Episodes in the recent rates and means (Stable-Baselines3's `stats_window_size`).
pub const WINDOW: usize = 100;
/// Seconds between flushes of the event file as episodes end (TensorBoard reloads every 5 s by
/// default): a flush per episode would be a system call per episode, measurable on tasks whose
/// random-policy episodes last a few steps (docs/benchmarks.md). Checkpoints and the run's end
/// always flush.
const FLUSH_SECONDS: f64 = 1.0;
/// The prefix of TensorBoard's event files.
const PREFIX: &str = "events.out.tfevents.";

/// What a checkpoint records.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Saved {
    /// The event file's name in the run directory.
    file: String,
    /// Its length when the checkpoint was written.
    offset: u64,
    /// The cost window under way (a DEFENDER run).
    #[serde(default)]
    costs: Option<CostWindow>,
}

/// Episode outcomes and lengths, cumulative and over the last `WINDOW` episodes.
#[derive(Debug, Default)]
pub struct Rates {
    recent: VecDeque<(Outcome, f64, u64)>,
    episodes: u64,
    crashed: u64,
    filtered: u64,
}

impl Rates {
    /// Adds an episode; returns its scalars.
    pub fn add(&mut self, outcome: Outcome, ret: f64, length: u64, cost: f64) -> [(&'static str, f64); 12] {
        if self.recent.len() == WINDOW {
            self.recent.pop_front();
        }
        self.recent.push_back((outcome, ret, length));
        self.episodes += 1;
        self.crashed += u64::from(outcome == Outcome::Crashed);
        self.filtered += u64::from(outcome == Outcome::Filtered);
        let n = self.recent.len() as f64;
        let count = |o: Outcome| self.recent.iter().filter(|e| e.0 == o).count() as f64 / n;
        let total = self.episodes as f64;
        [
            ("episode/return", ret),
            ("episode/length", length as f64),
            ("episode/crashed", f64::from(u8::from(outcome == Outcome::Crashed))),
            ("episode/filtered", f64::from(u8::from(outcome == Outcome::Filtered))),
            ("rollout/ep_rew_mean", self.recent.iter().map(|e| e.1).sum::<f64>() / n),
            ("rollout/ep_len_mean", self.recent.iter().map(|e| e.2 as f64).sum::<f64>() / n),
            ("defender/crash_rate", self.crashed as f64 / total),
            ("defender/filter_rate", self.filtered as f64 / total),
            ("defender/crash_rate_recent", count(Outcome::Crashed)),
            ("defender/filter_rate_recent", count(Outcome::Filtered)),
            ("safety/crashes", self.crashed as f64),
            ("safety/episode_cost", cost),
        ]
    }
}

/// The scalars of an `updates.csv` row.
pub fn update_scalars(row: &UpdateRow) -> Vec<(&'static str, f64)> {
    let mut v = vec![
        ("train/critic_loss", row.qf_loss),
        ("train/mean_q", row.qf1_mean),
        ("train/n_updates", row.n_updates as f64),
    ];
    v.extend(row.actor_loss.map(|a| ("train/actor_loss", a)));
    v.extend(row.ent_coef.map(|a| ("train/ent_coef", f64::from(a))));
    v.extend(row.ent_coef_loss.map(|a| ("train/ent_coef_loss", a)));
    v.extend(row.recovery_steps.map(|n| ("safety/recovery_steps", n as f64)));
    v.extend(row.qc_loss.map(|a| ("train/qc_loss", a)));
    v.extend(row.lagrange_multiplier.map(|a| ("train/lagrange_multiplier", f64::from(a))));
    v.extend(row.qc_mean.map(|a| ("train/qc_mean", a)));
    v
}

/// The scalars of a `dynamics.csv` row.
pub fn dynamics_scalars(row: &DynamicsRow) -> Vec<(&'static str, f64)> {
    let mut v = vec![("defender/dynamics_error", row.error_ema)];
    v.extend(row.loss.map(|l| ("defender/dynamics_loss", f64::from(l))));
    v
}

/// The scalars of an evaluation: its cost where `eval.csv` has one, and for a run with a filter
/// the same episodes with the filter kept (`eval/shield_*`).
pub fn eval_scalars(v: &EvalRow) -> Vec<(&'static str, f64)> {
    let mut out = vec![
        ("eval/mean_reward", v.mean_return),
        ("eval/std_reward", v.std_return),
        ("eval/mean_ep_length", v.mean_length),
    ];
    out.extend(v.mean_cost.map(|c| ("eval/mean_cost", c)));
    if let Some(s) = v.shield {
        out.extend([
            ("eval/shield_mean_reward", s.mean_return),
            ("eval/shield_mean_cost", s.mean_cost),
            ("eval/shield_filtered", s.filtered),
        ]);
    }
    out
}

/// Removes the event files of `dir` other than `keep`: those of an attempt that is being
/// started again (they would show as a second curve of the same run).
pub fn remove_other_event_files(dir: &Path, keep: Option<&str>) -> Result<()> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))?;
    for entry in entries.filter_map(|e| e.ok()) {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with(PREFIX) && Some(name.as_str()) != keep {
            std::fs::remove_file(entry.path())
                .with_context(|| format!("cannot remove {}", entry.path().display()))?;
        }
    }
    Ok(())
}

/// The TensorBoard events of a training run.
pub struct TrainingBoard {
    file: EventFile,
    rates: Rates,
    costs: Option<SharedCosts>,
    clock: (Instant, u64),
    flushed: Instant,
}

impl TrainingBoard {
    /// Starts the event file of a new run in `dir` (replacing those of an earlier attempt);
    /// `costs` is a DEFENDER run's cost window, `r_task` its filtered-step reward.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn create(dir: &Path, costs: Option<SharedCosts>, r_task: Option<f64>) -> Result<Self> {
        let wall = now();
        let name = EventFile::file_name(wall, "defender");
        remove_other_event_files(dir, None)?;
        let mut file = EventFile::create(&dir.join(&name), wall)?;
        if let Some(r) = r_task {
            file.scalars(0, wall, &[("defender/r_task", r)])?;
        }
        file.flush()?;
        Ok(Self { file, rates: Rates::default(), costs, clock: (Instant::now(), 0), flushed: Instant::now() })
    }

    /// Continues the event file of a resumed run from what its checkpoint recorded (`saved`):
    /// the file is cut back to its length then. Without a usable record (a checkpoint written
    /// before event files were, or a file removed since), a new file is started and the
    /// checkpoint's episodes and evaluations are written into it first.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn resume(
        dir: &Path,
        saved: Option<&Saved>,
        episodes: &[EpisodeRecord],
        evals: &[EvalRecord],
        steps: u64,
        costs: Option<SharedCosts>,
        r_task: Option<f64>,
    ) -> Result<Self> {
        let continued = saved.and_then(|s| match EventFile::truncate_to(&dir.join(&s.file), s.offset) {
            Ok(file) => Some((file, s)),
            Err(e) => {
                note!(
                    "warning: TensorBoard: {e:#}; starting a new event file from the checkpoint's episodes"
                );
                None
            }
        });
        let mut rates = Rates::default();
        let mut board = match continued {
            Some((file, s)) => {
                remove_other_event_files(dir, Some(&s.file))?;
                if let (Some(shared), Some(window)) = (&costs, s.costs) {
                    cost_meter::restore(shared, window);
                }
                for r in episodes {
                    rates.add(r.outcome(), r.episode_return, r.length, r.cost());
                }
                Self { file, rates, costs, clock: (Instant::now(), steps), flushed: Instant::now() }
            }
            None => {
                let mut board = Self::create(dir, costs, r_task)?;
                for r in episodes {
                    board.episode(r)?;
                }
                for r in evals {
                    board.evaluation(r)?;
                }
                board
            }
        };
        board.clock = (Instant::now(), steps);
        board.file.flush()?;
        Ok(board)
    }

    /// Reads what a checkpoint recorded (`None` for a checkpoint without it).
    ///
    /// # Errors
    /// A record that cannot be read.
    pub fn load(extra: &Path) -> Result<Option<Saved>> {
        let path = extra.join(CHECKPOINT_FILE);
        match std::fs::read(&path) {
            Ok(bytes) => Ok(Some(
                serde_json::from_slice(&bytes)
                    .with_context(|| format!("{}: not a TensorBoard record", path.display()))?,
            )),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e).with_context(|| format!("cannot read {}", path.display())),
        }
    }

    /// Flushes the file and records its length (and the cost window) into a checkpoint's extra
    /// directory.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn save(&mut self, extra: &Path) -> Result<()> {
        self.flush()?;
        let saved = Saved {
            file: self.file_name(),
            offset: self.file.offset(),
            costs: self.costs.as_ref().map(|c| *c.lock().unwrap_or_else(std::sync::PoisonError::into_inner)),
        };
        let bytes = serde_json::to_vec(&saved)?;
        defender_io::write_bytes(&extra.join(CHECKPOINT_FILE), &bytes)
            .map_err(|(path, e)| anyhow::anyhow!("cannot write {}: {e}", path.display()))
    }

    fn file_name(&self) -> String {
        self.file.path().file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned())
    }

    /// A finished training episode (flushed at most every `FLUSH_SECONDS`, so TensorBoard sees
    /// it live).
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn episode(&mut self, r: &EpisodeRecord) -> Result<()> {
        let values = self.rates.add(r.outcome(), r.episode_return, r.length, r.cost());
        self.file.scalars(r.total_steps, now(), &values)?;
        if self.flushed.elapsed().as_secs_f64() >= FLUSH_SECONDS {
            self.flush()?;
        }
        Ok(())
    }

    /// Writes what is buffered into the file.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn flush(&mut self) -> Result<()> {
        self.flushed = Instant::now();
        self.file.flush()
    }

    /// An evaluation.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn evaluation(&mut self, r: &EvalRecord) -> Result<()> {
        self.file.scalars(r.total_steps, now(), &eval_scalars(&run_dir::eval_row(r)))?;
        self.flush()
    }

    /// An `updates.csv` row.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn updates(&mut self, row: &UpdateRow) -> Result<()> {
        self.file.scalars(row.total_steps, now(), &update_scalars(row))
    }

    /// Every `update_log::EVERY` steps: the speed since the last call, the dynamics model's row
    /// (a DEFENDER run) and the mean costs of the steps since the last call.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn window(&mut self, total_steps: u64, dynamics: Option<&DynamicsRow>) -> Result<()> {
        let elapsed = self.clock.0.elapsed().as_secs_f64();
        let mut values = Vec::with_capacity(8);
        if total_steps > self.clock.1 && elapsed > 0.0 {
            values.push(("time/fps", (total_steps - self.clock.1) as f64 / elapsed));
        }
        self.clock = (Instant::now(), total_steps);
        if let Some(row) = dynamics {
            values.extend(dynamics_scalars(row));
        }
        if let Some((safe, unsafe_, filtered)) = self.costs.as_ref().and_then(|c| cost_meter::take(c).means())
        {
            values.extend([
                ("defender/mean_safe_cost", safe),
                ("defender/mean_unsafe_cost", unsafe_),
                ("defender/filtered_step_rate", filtered),
            ]);
        }
        self.file.scalars(total_steps, now(), &values)
    }
}
