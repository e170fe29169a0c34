#![doc = include_str!("../README.md")]

mod csv;
mod curves;
mod discover;
mod error;
mod figure;
mod io;
mod plot;
mod render;
mod run;
mod stats;
mod table;
mod tradeoff;

pub use discover::{RunSet, SkippedRun, find_run_dirs, load_runs};
pub use error::{ReportError, Result};
pub use io::write_atomic;
pub use plot::{PlotKind, PlotOptions, Plots, draw_plots};
pub use render::{CSV_HEADER, Format, render};
pub use run::{
    CONFIG_FILE, DYNAMICS_FILE, DYNAMICS_HEADER, DefenderSettings, EVAL_FILE, EVAL_HEADER, EpisodeRow,
    EvalRow, METRICS_FILE, METRICS_HEADER, OutcomeCounts, Run, RunSettings, SUMMARY_FILE, StrategySelection,
    Summary, UPDATES_FILE, UPDATES_HEADER,
};
pub use stats::{Stat, interpolate, linspace, rolling_mean};
pub use table::{Row, Table};
