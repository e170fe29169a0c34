//! Experiment files: a declarative grid (tasks x algorithms x strategies x modes x numbers of
//! demonstrations x seeds) with one budget and shared settings, expanded to named runs. Every run
//! is an ordinary run configuration (`config.toml`), so a sweep is many ordinary runs.
//!
//! ```toml
//! description = "Table 1 (state)"
//! [paper]                      # the paper's protocol, recorded for the reader (not run)
//! episodes = 5000
//! seeds = 3
//! [grid]
//! envs = ["InvertedDoublePendulum-v5", "Hopper-v5"]
//! algos = ["sac"]
//! strategies = ["none", "MeanDemoW5/MeanDemoW10"]   # "none": the bare algorithm; "auto": chosen
//! modes = ["state"]
//! num_demos = [50]             # optional: all of the file
//! seeds = [0, 1, 2]
//! [budget]
//! steps = 100000               # or episodes = N
//! per_env = { "InvertedDoublePendulum-v5" = { steps = 30000, eval_freq = 2500 } }
//! [run]                        # any key of a run's config.toml, for every run
//! eval_freq = 5000
//! [[arms]]                     # optional: named variants of the grid, each with its own
//! name = "authors"             # settings over [run] (and optionally its own strategies/algos,
//! strategies = ["none"]        # envs, a subset of grid.envs, and seeds); its runs are named
//! envs = ["Hopper-v5"]         # <algo>-<strategy>[-sa][-nN]-<arm>-s<seed>; one arm may leave
//! seeds = [2]                  # out its name: its runs have no suffix
//! run = { profile = "authors" }
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, bail};
use defender::selection::StrategyChoice;
use defender_rl::Algo;
use serde::Deserialize;
use toml::Spanned;

use crate::run_config::{RunConfig, read_config_str};

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    #[serde(default)]
    description: String,
    #[serde(default)]
    paper: Option<PaperBudget>,
    grid: Grid,
    budget: BudgetSpec,
    #[serde(default)]
    run: Option<toml::Table>,
    #[serde(default)]
    arms: Vec<Arm>,
}

/// A named variant of the grid: its runs get the arm's settings over `[run]`, and `-<name>` in
/// their names, so that variants of one configuration live side by side in one sweep directory.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Arm {
    /// Left out: the arm's runs carry no suffix (at most one such arm), e.g. the bare runs that
    /// the named arms are compared with.
    #[serde(default)]
    name: Option<Spanned<String>>,
    #[serde(default)]
    strategies: Option<Vec<Spanned<String>>>,
    #[serde(default)]
    algos: Option<Vec<Spanned<String>>>,
    /// The tasks of the arm, a subset of `grid.envs` (whose budgets they keep): a setting chosen
    /// per task, as a screen chooses it.
    #[serde(default)]
    envs: Option<Vec<Spanned<String>>>,
    /// The arm's seeds instead of the grid's: e.g. only the seed that another experiment's
    /// identical runs do not already hold.
    #[serde(default)]
    seeds: Option<Spanned<Vec<u64>>>,
    #[serde(default)]
    run: Option<toml::Table>,
}

/// `over` merged into `base`, table by table; `over`'s values win.
fn merged(base: &Option<toml::Table>, over: &Option<toml::Table>) -> Option<toml::Table> {
    fn merge(base: &mut toml::Table, over: &toml::Table) {
        for (k, v) in over {
            match (base.get_mut(k), v) {
                (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
                _ => {
                    base.insert(k.clone(), v.clone());
                }
            }
        }
    }
    match (base, over) {
        (None, None) => None,
        (b, o) => {
            let mut table = b.clone().unwrap_or_default();
            merge(&mut table, &o.clone().unwrap_or_default());
            Some(table)
        }
    }
}

/// The paper's own budget for this experiment, recorded beside the one this file runs.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PaperBudget {
    /// Training episodes per run in the paper.
    #[serde(default)]
    pub episodes: Option<u64>,
    /// Training steps per run in the paper.
    #[serde(default)]
    pub steps: Option<u64>,
    /// Seeds per configuration in the paper.
    #[serde(default)]
    pub seeds: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Grid {
    envs: Vec<Spanned<String>>,
    #[serde(default = "default_algos")]
    algos: Vec<Spanned<String>>,
    #[serde(default = "default_strategies")]
    strategies: Vec<Spanned<String>>,
    #[serde(default = "default_modes")]
    modes: Vec<Spanned<String>>,
    #[serde(default)]
    num_demos: Vec<usize>,
    seeds: Vec<u64>,
}

fn spanned_list(items: &[&str]) -> Vec<Spanned<String>> {
    items.iter().map(|s| Spanned::new(0..0, (*s).to_string())).collect()
}

fn default_algos() -> Vec<Spanned<String>> {
    spanned_list(&["sac"])
}

fn default_strategies() -> Vec<Spanned<String>> {
    spanned_list(&["none"])
}

fn default_modes() -> Vec<Spanned<String>> {
    spanned_list(&["state"])
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
struct Budget {
    #[serde(default)]
    steps: Option<u64>,
    #[serde(default)]
    episodes: Option<u64>,
    /// Evaluate every this many steps for this task (over `[run] eval_freq`).
    #[serde(default)]
    eval_freq: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct BudgetSpec {
    #[serde(default)]
    steps: Option<u64>,
    #[serde(default)]
    episodes: Option<u64>,
    #[serde(default)]
    per_env: BTreeMap<String, Budget>,
}

/// One run of an experiment: its name (a relative path, `<env>/<algo>-<strategy>-s<seed>`) and
/// its complete configuration.
#[derive(Debug, Clone)]
pub struct PlannedRun {
    /// The run directory relative to the sweep directory.
    pub name: String,
    /// The run's configuration, as `defender train --config` reads it.
    pub config: RunConfig,
}

impl PlannedRun {
    /// The configuration as the run is started in the sweep directory `root`: a relative
    /// `record_episodes` path (e.g. `"episodes.npz"`) is placed inside the run's own directory.
    pub fn config_in(&self, root: &Path) -> RunConfig {
        let mut config = self.config.clone();
        if let Some(path) = &config.record_episodes
            && path.is_relative()
        {
            let root = std::path::absolute(root).unwrap_or_else(|_| root.to_path_buf());
            config.record_episodes = Some(root.join(&self.name).join(path));
        }
        config
    }
}

/// An expanded experiment.
#[derive(Debug)]
pub struct Experiment {
    /// What it reproduces.
    pub description: String,
    /// The paper's budget, if recorded.
    pub paper: Option<PaperBudget>,
    /// The runs, in a stable order (task, algorithm, strategy, mode, demos, seed).
    pub runs: Vec<PlannedRun>,
}

/// The 1-based line of a byte offset in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1
}

/// A file name part for a strategy: `MeanDemoW5/MeanDemoW10` -> `MeanDemoW5-MeanDemoW10`.
pub fn strategy_slug(strategy: &str) -> String {
    if strategy == "none" { "bare".to_string() } else { strategy.replace('/', "-") }
}

/// Reads and expands an experiment file, and checks every run's configuration before any
/// starts (its values, and `num_demos` against its demonstration file); every error names the
/// file, the run and, where it can, the line, the key and the value. `tasks`: the task ids a run
/// may name (the simulator's registry; this crate does not link it).
pub fn load(path: &Path, tasks: &[&str]) -> Result<Experiment> {
    let text =
        defender_io::read_input_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let experiment =
        parse(&text, tasks).with_context(|| format!("{}: not a valid experiment", path.display()))?;
    // Each demonstration file is read once, for all the runs that use it.
    let mut sizes: BTreeMap<std::path::PathBuf, (usize, usize)> = BTreeMap::new();
    let mut read = |demos: &Path| -> Result<(usize, usize)> {
        if let Some(&s) = sizes.get(demos) {
            return Ok(s);
        }
        let s = defender::EpisodeSet::load(demos)
            .with_context(|| format!("cannot read the demonstrations {}", demos.display()))?
            .group_sizes();
        sizes.insert(demos.to_path_buf(), s);
        Ok(s)
    };
    for run in &experiment.runs {
        run.config
            .check_demonstrations(&mut read)
            .with_context(|| format!("{}: not a valid experiment: run '{}'", path.display(), run.name))?;
    }
    Ok(experiment)
}

/// Parses and expands an experiment from its text; `tasks`: the task ids a run may name.
pub fn parse(text: &str, tasks: &[&str]) -> Result<Experiment> {
    let file: ExperimentFile = toml::from_str(text)?;
    let at = |s: &Spanned<String>| {
        if s.span().is_empty() {
            "the default".to_string()
        } else {
            format!("line {}", line_of(text, s.span().start))
        }
    };
    let g = &file.grid;
    for (name, empty) in [
        ("grid.envs", g.envs.is_empty()),
        ("grid.algos", g.algos.is_empty()),
        ("grid.strategies", g.strategies.is_empty()),
        ("grid.modes", g.modes.is_empty()),
        ("grid.seeds", g.seeds.is_empty()),
    ] {
        if empty {
            bail!("{name} is empty: the grid would have no runs");
        }
    }
    for env in &g.envs {
        if !tasks.contains(&env.get_ref().as_str()) {
            bail!("{}: unknown task '{}' in grid.envs (known: {})", at(env), env.get_ref(), tasks.join(", "));
        }
    }
    let parse_algos = |list: &[Spanned<String>]| -> Result<Vec<Algo>> {
        list.iter()
            .map(|a| {
                a.get_ref().parse().map_err(|_| {
                    anyhow::anyhow!("{}: unknown algorithm '{}' (sac or td3)", at(a), a.get_ref())
                })
            })
            .collect()
    };
    let parse_strategies = |list: &[Spanned<String>]| -> Result<Vec<Option<StrategyChoice>>> {
        list.iter()
            .map(|s| {
                Ok(match s.get_ref().as_str() {
                    "none" => None,
                    other => Some(other.parse().with_context(|| format!("{}: grid.strategies", at(s)))?),
                })
            })
            .collect()
    };
    // Without [[arms]], one unnamed arm: the grid as it is.
    struct Expanded<'a> {
        name: Option<&'a str>,
        algos: Vec<Algo>,
        strategies: Vec<Option<StrategyChoice>>,
        spans: &'a [Spanned<String>],
        /// `None`: every task of the grid.
        envs: Option<Vec<&'a str>>,
        seeds: &'a [u64],
        run: Option<toml::Table>,
    }
    let mut arms: Vec<Expanded<'_>> = Vec::new();
    if file.arms.is_empty() {
        arms.push(Expanded {
            name: None,
            algos: parse_algos(&g.algos)?,
            strategies: parse_strategies(&g.strategies)?,
            spans: &g.strategies,
            envs: None,
            seeds: &g.seeds,
            run: file.run.clone(),
        });
    }
    let mut unnamed = 0;
    for arm in &file.arms {
        let name = match &arm.name {
            None => {
                unnamed += 1;
                if unnamed > 1 {
                    bail!(
                        "[[arms]]: more than one arm without a name; name all but one (names become part of run names)"
                    );
                }
                None
            }
            Some(spanned) => {
                let name = spanned.get_ref();
                if name.is_empty()
                    || !name.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-')
                {
                    bail!(
                        "{}: arms.name '{name}': use lowercase letters, digits and '-' (it becomes part of run names)",
                        at(spanned)
                    );
                }
                Some(name.as_str())
            }
        };
        let label = name.unwrap_or("(unnamed)");
        let spans = arm.strategies.as_deref().unwrap_or(&g.strategies);
        let algos = arm.algos.as_deref().unwrap_or(&g.algos);
        if spans.is_empty() || algos.is_empty() {
            bail!("[[arms]] '{label}' has an empty list of strategies or algorithms");
        }
        let envs = match &arm.envs {
            None => None,
            Some(list) if list.is_empty() => {
                bail!("[[arms]] '{label}': envs is empty: the arm would have no runs")
            }
            Some(list) => {
                for env in list {
                    if !g.envs.iter().any(|e| e.get_ref() == env.get_ref()) {
                        bail!(
                            "{}: [[arms]] '{label}': envs names '{}', which is not in grid.envs (an arm's tasks are \
                             some of the grid's, whose budgets they take)",
                            at(env),
                            env.get_ref()
                        );
                    }
                }
                Some(list.iter().map(|e| e.get_ref().as_str()).collect())
            }
        };
        let seeds = match &arm.seeds {
            None => g.seeds.as_slice(),
            Some(list) if list.get_ref().is_empty() => {
                bail!(
                    "line {}: [[arms]] '{label}': seeds is empty: the arm would have no runs",
                    line_of(text, list.span().start)
                )
            }
            Some(list) => list.get_ref().as_slice(),
        };
        arms.push(Expanded {
            name,
            algos: parse_algos(algos)?,
            strategies: parse_strategies(spans)?,
            spans,
            envs,
            seeds,
            run: merged(&file.run, &arm.run),
        });
    }
    let mut modes: Vec<defender::Mode> = Vec::new();
    for m in &g.modes {
        modes.push(m.get_ref().parse().with_context(|| format!("{}: grid.modes", at(m)))?);
    }
    let budget_of = |env: &str| -> Result<(u64, u64)> {
        let own = file.budget.per_env.get(env).copied().filter(|b| b.steps.is_some() || b.episodes.is_some());
        let b = own.unwrap_or(Budget {
            steps: file.budget.steps,
            episodes: file.budget.episodes,
            eval_freq: None,
        });
        match (b.steps, b.episodes) {
            (Some(s), None) if s > 0 => Ok((s, 0)),
            (None, Some(e)) if e > 0 => Ok((0, e)),
            (None, None) => bail!("budget: give steps = N or episodes = N (for {env})"),
            _ => bail!("budget for {env}: give a positive number of steps or of episodes, not both"),
        }
    };
    for env in file.budget.per_env.keys() {
        if !g.envs.iter().any(|e| e.get_ref() == env) {
            bail!("budget.per_env names '{env}', which is not in grid.envs");
        }
    }
    let num_demos: Vec<Option<usize>> =
        if g.num_demos.is_empty() { vec![None] } else { g.num_demos.iter().map(|&n| Some(n)).collect() };
    let mut runs: Vec<PlannedRun> = Vec::new();
    let mut seen: BTreeMap<String, String> = BTreeMap::new();
    for env in &g.envs {
        let env = env.get_ref();
        let (total_steps, total_episodes) = budget_of(env)?;
        let of_env = |arm: &&Expanded<'_>| arm.envs.as_ref().is_none_or(|envs| envs.contains(&env.as_str()));
        for (arm, &algo) in arms.iter().filter(of_env).flat_map(|arm| arm.algos.iter().map(move |a| (arm, a)))
        {
            for (strategy, spanned) in arm.strategies.iter().zip(arm.spans) {
                // A bare run has no mode or demonstrations: one per seed, whatever those lists hold.
                let variants: Vec<(Option<defender::Mode>, Option<usize>)> = match strategy {
                    None => vec![(None, None)],
                    Some(_) => {
                        modes.iter().flat_map(|&m| num_demos.iter().map(move |&n| (Some(m), n))).collect()
                    }
                };
                for (mode, n) in variants {
                    for &seed in arm.seeds {
                        let mut name =
                            format!("{env}/{}-{}", algo.as_str(), strategy_slug(spanned.get_ref()));
                        if mode == Some(defender::Mode::StateAction) {
                            name.push_str("-sa");
                        }
                        if let Some(n) = n {
                            name.push_str(&format!("-n{n}"));
                        }
                        if let Some(arm) = arm.name {
                            name.push_str(&format!("-{arm}"));
                        }
                        name.push_str(&format!("-s{seed}"));
                        if let Some(first) = seen.insert(name.clone(), at(spanned)) {
                            bail!(
                                "{}: run '{name}' appears twice in the grid (first at {first}); remove the repeated entry",
                                at(spanned)
                            );
                        }
                        let mut config = run_config(
                            &arm.run,
                            env,
                            algo,
                            *strategy,
                            mode,
                            n,
                            seed,
                            (total_steps, total_episodes),
                        )
                        .with_context(|| format!("run '{name}'"))?;
                        if let Some(f) = file.budget.per_env.get(env).and_then(|b| b.eval_freq) {
                            config.eval_freq = f;
                        }
                        runs.push(PlannedRun { name, config });
                    }
                }
            }
        }
    }
    Ok(Experiment { description: file.description, paper: file.paper, runs })
}

/// The run configuration of one grid point: the shared `[run]` settings, then the grid's values.
#[allow(clippy::too_many_arguments)]
fn run_config(
    shared: &Option<toml::Table>,
    env: &str,
    algo: Algo,
    strategy: Option<StrategyChoice>,
    mode: Option<defender::Mode>,
    num_demos: Option<usize>,
    seed: u64,
    (total_steps, total_episodes): (u64, u64),
) -> Result<RunConfig> {
    let mut table = shared.clone().unwrap_or_default();
    crate::profile::default_for_new_run(&mut table);
    for key in ["env", "algo", "seed", "total_steps", "total_episodes"] {
        if table.contains_key(key) {
            bail!("[run] may not set '{key}': the grid and the budget set it");
        }
    }
    table.insert("env".into(), env.into());
    table.insert("algo".into(), algo.as_str().into());
    table.insert("seed".into(), toml::Value::Integer(i64::try_from(seed).context("seed too large")?));
    table.insert("total_steps".into(), toml::Value::Integer(i64::try_from(total_steps)?));
    table.insert("total_episodes".into(), toml::Value::Integer(i64::try_from(total_episodes)?));
    match strategy {
        None => {
            if table.contains_key("defender") {
                // Shared DEFENDER settings do not apply to the bare runs.
                table.remove("defender");
            }
        }
        Some(strategy) => {
            let section = table
                .entry("defender")
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .context("[run.defender] must be a table")?;
            section.insert("strategy".into(), strategy.to_string().into());
            if let Some(mode) = mode {
                section.insert("mode".into(), mode.to_string().into());
            }
            if let Some(n) = num_demos {
                section.insert("num_demos".into(), toml::Value::Integer(i64::try_from(n)?));
            }
        }
    }
    let text = toml::to_string(&table)?;
    let config = read_config_str(&text)?;
    config.validate()?;
    Ok(config)
}

#[cfg(test)]
#[path = "experiment_tests.rs"]
mod tests;
