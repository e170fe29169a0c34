//! `defender ablate`: the offline ablation of SPEC section 7, ranking filtering strategies by
//! replaying recorded episodes against the demonstrations.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use defender::{AblationRow, CostOptions, EpisodeSet, Mode, Scoring, Strategy, Window};

use crate::progress;
use defender_config::profile::Profile;

/// The recorded episodes the authors' ablation scores: their first 500 (`MAX_EPISODES` of their
/// `util/ablations/dtw_extract.py`).
pub const AUTHORS_EPISODES: usize = 500;
use crate::text_table::{Column, TextTable};

/// Arguments of `defender ablate`.
#[derive(Debug, Args)]
#[command(after_help = "Examples:
  defender train --env Hopper-v5 --steps 100000 --out runs/bare --record-episodes hopper-episodes.npz
  defender ablate --demos data/demos/Hopper-v5.npz --episodes hopper-episodes.npz --out scores.csv
  defender ablate --demos a.npz --episodes a-ep.npz --demos b.npz --episodes b-ep.npz --out scores.csv
  defender ablate ... --strategies MeanDemoW5/MeanDemoW10,MinBoth/MinTrajW10
  defender ablate ... --strategies all --no-equal     (skip the Equal window: it costs O(n^2) per step)
  defender ablate --combine hopper.csv walker.csv --out both.csv   (rank tasks ablated apart)

Several --demos/--episodes pairs (one per task) rank the strategies by the mean score over tasks;
--combine ranks the same way from rankings already written (one CSV per task, the same strategies
and mode), so tasks can be ablated apart (one at a time, on other machines) and ranked together.
score = mean episode-length ratio x safe-episode rate (SPEC section 7); the CSV has one row per
strategy (SPEC section 9) and the top 10 are printed.

--profile authors scores as the paper's authors' code did (docs/SPEC.md, section 10): FastDTW
(radius 1, L1) over the last 20 trajectory steps, one element per transition, ties executed; per
episode of T steps p = k/T with k the first filtered step (else 1); an episode shorter than the
horizon counts as crashed and is avoided if filtered; score = mean(p) x mean(avoided over the
crashed) (mean(p) alone when none crashed); over the first 500 recorded episodes; one task at a
time, as their code ranks; --num-demos N takes N per group chosen for diversity (farthest-point
over FastDTW costs). Its CSV has the same columns, mean_ratio = mean(p) and safe_rate = the share
of crashed episodes avoided, and a last column `scoring` = authors. --combine ranks such files by
the mean of their score over tasks (how the paper's text says its top 5 were chosen); it refuses
a mix of scores.
  defender ablate --profile authors --demos data/demos/Hopper-v5.npz --episodes hopper-episodes.npz \\
                  --num-demos 50 --out hopper-authors.csv
  defender ablate --combine idp-authors.csv hopper-authors.csv walker-authors.csv --out authors.csv")]
pub struct AblateArgs {
    /// Demonstration set of a task (repeat once per task, paired in order with --episodes).
    #[arg(long, required_unless_present = "combine")]
    pub demos: Vec<PathBuf>,
    /// Recorded episode set of the same task (e.g. from `defender train --record-episodes`).
    #[arg(long, required_unless_present = "combine")]
    pub episodes: Vec<PathBuf>,
    /// Rank by the mean over these per-task rankings (CSVs this command wrote) instead of
    /// replaying episodes.
    #[arg(long, num_args = 2.., conflicts_with_all = ["demos", "episodes", "strategies", "no_equal", "num_demos", "horizon"])]
    pub combine: Vec<PathBuf>,
    /// Trajectory elements: states, or state-action pairs.
    #[arg(long, default_value = "state", value_parser = ["state", "state-action"])]
    pub mode: String,
    /// `all`, or a comma-separated list of SAFE/UNSAFE strategies.
    #[arg(long, default_value = "all")]
    pub strategies: String,
    /// Leave out the strategies that use the Equal window (the only non-incremental one).
    #[arg(long)]
    pub no_equal: bool,
    /// Use only the first N demonstrations of each group (--profile authors: N chosen for
    /// diversity).
    #[arg(long)]
    pub num_demos: Option<usize>,
    /// spec (SPEC section 7, the default) or authors: their cost, score and episodes (above);
    /// keeps-learning ranks as spec (it changes a run's filter decision and learner, not the cost).
    #[arg(long, value_enum, default_value = "spec")]
    pub profile: Profile,
    /// With --profile authors: episodes shorter than this count as crashed [default: the task's
    /// horizon, from the files' env_id].
    #[arg(long)]
    pub horizon: Option<usize>,
    /// Rows to print.
    #[arg(long, default_value_t = 10)]
    pub top: usize,
    /// Where to write the scores (CSV, SPEC section 9).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `defender ablate`.
pub fn run(args: AblateArgs) -> Result<()> {
    if args.demos.len() != args.episodes.len() {
        bail!(
            "give one --episodes per --demos (got {} --demos and {} --episodes); they pair up in order",
            args.demos.len(),
            args.episodes.len()
        );
    }
    // The ablation can take minutes to hours: refuse an unwritable --out before it starts.
    crate::run_dir::check_writable(&args.out).context("--out")?;
    if !args.combine.is_empty() {
        return combine(&args);
    }
    if args.profile != Profile::Authors && args.horizon.is_some() {
        bail!("--horizon is for --profile authors (SPEC section 7 reads the recorded `crashed` flags)");
    }
    if args.profile == Profile::Authors && args.demos.len() > 1 {
        bail!(
            "--profile authors ranks one task at a time, as the authors' code did (give one --demos and \
             one --episodes; run it once per task)"
        );
    }
    refuse_repeats("--episodes", &args.episodes)?;
    if args.num_demos == Some(0) {
        bail!("--num-demos 0: give at least 1 demonstration per group (or leave it out for all)");
    }
    let mode: Mode = args.mode.parse()?;
    let mut strategies: Vec<Strategy> = if args.strategies == "all" {
        Strategy::all().collect()
    } else {
        Strategy::parse_list(&args.strategies)?
    };
    if args.no_equal {
        strategies.retain(|s| s.safe.window != Window::Equal && s.unsafe_.window != Window::Equal);
    }
    if strategies.is_empty() {
        bail!("no strategy left to score");
    }
    let mut per_task = Vec::new();
    let mut scoring = Scoring::Spec;
    for (demos_path, episodes_path) in args.demos.iter().zip(&args.episodes) {
        let mut demos = EpisodeSet::load(demos_path)?;
        let mut episodes = EpisodeSet::load(episodes_path)?;
        let options = match args.profile {
            Profile::Spec | Profile::KeepsLearning => {
                if let Some(n) = args.num_demos {
                    demos = demos.select_demos(n)?;
                }
                CostOptions::default()
            }
            Profile::Authors => {
                scoring = Scoring::Authors { horizon: horizon(&args, &demos, &episodes)? };
                if let Some(n) = args.num_demos {
                    demos = choose_diverse(&demos, n, mode)?;
                }
                if episodes.len() > AUTHORS_EPISODES {
                    note!(
                        "{}: scoring its first {AUTHORS_EPISODES} of {} recorded episodes, as the authors' \
                         ablation did",
                        episodes_path.display(),
                        episodes.len()
                    );
                    episodes = episodes.reordered(&(0..AUTHORS_EPISODES).collect::<Vec<_>>())?;
                }
                CostOptions::authors()
            }
        };
        let task = demos.meta().env_id.clone().unwrap_or_else(|| demos_path.display().to_string());
        let bar = progress::bar(episodes.len() as u64, "episodes");
        bar.set_message(format!("{task}: {} strategies, {} mode", strategies.len(), mode));
        let rows =
            defender::ablate_scored(&demos, &episodes, Some(&strategies), mode, options, scoring, &|p| {
                bar.set_position(p.done as u64);
            })
            .with_context(|| {
                format!("ablation of {} against {}", episodes_path.display(), demos_path.display())
            })?;
        bar.finish_and_clear();
        note!("{task}: {} recorded episodes scored", episodes.len());
        per_task.push(rows);
    }
    let rows = if per_task.len() == 1 { per_task.remove(0) } else { defender::rank_tasks(&per_task)? };
    defender::write_csv_scored(&args.out, &rows, scoring)?;
    print_top(&rows, args.top);
    let scored = match scoring {
        Scoring::Spec => String::new(),
        Scoring::Authors { horizon } => format!(" by the authors' score (horizon {horizon})"),
    };
    say!("{} strategies ranked{scored} -> {}", rows.len(), args.out.display());
    Ok(())
}

/// The horizon of the authors' crash test: `--horizon`, else the registered horizon of the task
/// the files name (their code has 1000 written in, the three MuJoCo tasks' horizon).
fn horizon(args: &AblateArgs, demos: &EpisodeSet, episodes: &EpisodeSet) -> Result<usize> {
    if let Some(h) = args.horizon {
        if h == 0 {
            bail!("--horizon 0: give the task's horizon in steps (at least 1)");
        }
        return Ok(h);
    }
    let id = episodes.meta().env_id.as_deref().or(demos.meta().env_id.as_deref());
    match id.and_then(|id| defender_mujoco::registry().iter().find(|t| t.id == id)) {
        Some(task) => Ok(task.max_episode_steps),
        None => bail!(
            "--profile authors counts an episode shorter than the task's horizon as crashed, and the files \
             name no known task ({}); give --horizon STEPS",
            id.map_or("no env_id in their meta".to_string(), |id| format!("env_id \"{id}\""))
        ),
    }
}

/// `n` demonstrations per group chosen for diversity, as the authors' ablation chose them; a
/// group with fewer keeps all of them (as theirs did), said on the terminal.
fn choose_diverse(demos: &EpisodeSet, n: usize, mode: Mode) -> Result<EpisodeSet> {
    let (safe, unsafe_) = demos.group_sizes();
    for (group, size) in [("safe", safe), ("unsafe", unsafe_)] {
        if size < n {
            note!(
                "{}: the {group} group has {size} demonstrations, fewer than --num-demos {n}: all of them \
                 are used (as the authors' choice does)",
                demos.source().display()
            );
        }
    }
    Ok(defender::diversity::select_diverse(demos, n, mode)?)
}

/// `--combine`: the mean over per-task rankings, as the ablation of several tasks ranks them (the
/// paper's text: "ranked by the average score for the three tasks"). Files of the authors' score
/// combine too, into a file of that score; a mix of scores is refused, as is `--profile authors`
/// over SPEC files.
fn combine(args: &AblateArgs) -> Result<()> {
    refuse_repeats("--combine", &args.combine)?;
    let mut per_task = Vec::new();
    // The first file's score; every other file must hold the same.
    let mut first: Option<(String, &PathBuf)> = None;
    for path in &args.combine {
        let scoring = defender::csv_scoring(path).with_context(|| format!("--combine {}", path.display()))?;
        if let Some((first, first_path)) = first.as_ref().filter(|(first, _)| *first != scoring) {
            bail!(
                "--combine {}: its scores are the {scoring} score and {}'s the {first} score (their \
                 `scoring` columns); a mean over tasks needs one score: ablate every task with the same \
                 --profile",
                path.display(),
                first_path.display()
            );
        }
        first.get_or_insert((scoring, path));
        let rows = defender::read_csv(path).with_context(|| format!("--combine {}", path.display()))?;
        if rows.is_empty() {
            bail!("--combine {}: no strategy rows", path.display());
        }
        per_task.push(rows);
    }
    let scoring = match first.as_ref().map(|(name, _)| name.as_str()) {
        // Only the name is written; each task's horizon stays in its own file's ranking.
        Some("authors") => Scoring::Authors { horizon: 0 },
        Some("spec") | None => Scoring::Spec,
        Some(other) => bail!("--combine: unknown score `{other}` in a `scoring` column (spec or authors)"),
    };
    if args.profile == Profile::Authors && scoring == Scoring::Spec {
        bail!(
            "--combine with --profile authors: the files hold SPEC section 7's scores (no `scoring` \
             column); ablate each task with --profile authors first"
        );
    }
    let rows = defender::rank_tasks(&per_task).context(
        "--combine: the rankings must score the same strategies in the same mode (one CSV per task)",
    )?;
    defender::write_csv_scored(&args.out, &rows, scoring)?;
    print_top(&rows, args.top);
    say!(
        "{} strategies ranked over {} tasks by their mean {} score -> {}",
        rows.len(),
        per_task.len(),
        scoring.name(),
        args.out.display()
    );
    Ok(())
}

/// Refuses the same input given twice (the same file by another path, or a copy with the same
/// bytes): its runs would count twice in the mean over tasks, without a word.
fn refuse_repeats(flag: &str, paths: &[PathBuf]) -> Result<()> {
    let mut seen: Vec<(&PathBuf, PathBuf, Vec<u8>)> = Vec::new();
    for path in paths {
        let canonical = std::fs::canonicalize(path).with_context(|| format!("{flag} {}", path.display()))?;
        let bytes = defender_io::read_input(path)
            .with_context(|| format!("{flag} {}: cannot read it", path.display()))?;
        if let Some((first, _, _)) = seen.iter().find(|(_, c, b)| *c == canonical || *b == bytes) {
            bail!(
                "{flag} {} is given twice ({} holds the same {}): each task's input counts once; \
                 remove the repeat",
                path.display(),
                first.display(),
                if canonical == std::fs::canonicalize(first)? { "file" } else { "bytes" }
            );
        }
        seen.push((path, canonical, bytes));
    }
    Ok(())
}

fn print_top(rows: &[AblationRow], top: usize) {
    let mut table = TextTable::new(vec![
        Column::right("rank"),
        Column::left("strategy"),
        Column::right("mean_ratio"),
        Column::right("safe_rate"),
        Column::right("score").min_width(8),
    ]);
    for r in rows.iter().take(top) {
        table.row([
            r.rank.to_string(),
            r.strategy.to_string(),
            format!("{:.4}", r.mean_ratio),
            format!("{:.4}", r.safe_rate),
            format!("{:.4}", r.score),
        ]);
    }
    put!("{}", table.render());
}
