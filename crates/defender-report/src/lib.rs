#![doc = include_str!("../README.md")]

mod bootstrap;
mod cells;
mod costs;
mod crashes_vs_eval;
mod csv;
mod csv_out;
mod curves;
mod discover;
mod error;
mod eval_csv;
mod eval_episodes;
mod figure;
mod intervention_columns;
mod interventions;
mod io;
mod label;
mod latex;
mod markdown;
mod measures;
mod plot;
mod render;
mod run;
mod run_violations;
mod shield;
mod stats;
mod status;
mod table;
mod tradeoff;
mod violations;
mod windows;

pub use bootstrap::{
    Interval, LEVEL, RESAMPLES, SEED, bootstrap_ci, bootstrap_ci_with, percentile_ci, quantile,
};
pub use costs::{CostColumns, CostLimits};
pub use csv_out::CSV_HEADER;
pub use discover::{RunSet, find_run_dirs, load_runs};
pub use error::{ReportError, Result};
pub use eval_episodes::{EvalEpisodeRow, EvalEpisodeShield, parse_eval_episodes};
pub use intervention_columns::InterventionColumns;
pub use interventions::{
    INTERVENTIONS_FILE, INTERVENTIONS_HEADER, InterventionRow, InterventionSummary, intervention_row,
    parse_interventions,
};
pub use io::write_atomic;
pub use measures::{LAST_EVALUATIONS, STANDING_TOLERANCE, horizon, is_standing};
pub use plot::{PlotKind, PlotOptions, Plots, draw_plots};
pub use render::{Format, render};
pub use run::{
    CONFIG_FILE, DYNAMICS_FILE, DYNAMICS_HEADER, DefenderSettings, EVAL_EPISODES_FILE, EVAL_EPISODES_HEADER,
    EVAL_FILE, EVAL_HEADER, EpisodeRow, EvalRow, EvalShield, METRICS_FILE, METRICS_HEADER, OutcomeCounts,
    Run, RunSettings, SUMMARY_FILE, StrategySelection, Summary, UPDATES_FILE, UPDATES_HEADER,
    eval_episode_rows,
};
pub use shield::ShieldColumns;
pub use stats::{Estimate, Stat, interpolate, linspace, rolling_mean};
pub use status::{SkipKind, SkippedRun, lock_holder};
pub use table::{Row, Table, TableOptions};
pub use violations::Violations;
