//! Run directories for tests, written exactly as docs/run-directory.md says `defender train`
//! writes them. Shared with crates/defender-cli/tests/report_cli.rs (through `#[path]`).
#![allow(dead_code, clippy::unwrap_used)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One run to write.
#[derive(Debug, Clone)]
pub struct RunSpec {
    pub env: &'static str,
    pub algo: &'static str,
    pub seed: u64,
    /// `(strategy, mode)`, `None` for a bare run.
    pub defender: Option<(&'static str, &'static str)>,
    /// One per training episode: `crashed`, `filtered` or `truncated`. Each episode is 100 steps
    /// long and returns `10 * index + seed`.
    pub outcomes: Vec<&'static str>,
    /// The final evaluation's mean return; evaluations are made every 100 steps and rise linearly
    /// to it.
    pub acc_reward: f64,
    pub wall_seconds: f64,
    /// Episode returns instead of `10 * index + seed` (as many as `outcomes`).
    pub returns: Option<Vec<f64>>,
    /// Evaluations as `(mean_return, mean_length)`, one every 100 steps, instead of the rising
    /// line; the last one's return becomes the Acc Reward.
    pub evals: Option<Vec<(f64, f64)>>,
    /// Episode costs (as many as `outcomes`), written as `metrics.csv`'s `cost` column; `None`:
    /// no column (a file from before costs: a crash costs 1).
    pub costs: Option<Vec<f64>>,
    /// Evaluation mean costs (as many as the evaluations), written as `eval.csv`'s `mean_cost`.
    pub eval_costs: Option<Vec<f64>>,
    /// Written as `summary.json`'s `episode_cost_limit`.
    pub cost_limit: Option<f64>,
    /// The shielded evaluations `(mean_return, mean_cost, filtered)`, one per evaluation, written
    /// as `eval.csv`'s `shield_*` columns (after `mean_cost`, empty when `eval_costs` is `None`).
    pub shield: Option<Vec<(f64, f64, f64)>>,
    /// Written as `[<algo>] learning_starts`, the learner's random warm-up; `None`: no such table
    /// (the agent's settings under `[algo_config]`, as a peer's converted run has none).
    pub warmup: Option<u64>,
}

impl RunSpec {
    pub fn new(algo: &'static str, seed: u64, defender: Option<(&'static str, &'static str)>) -> Self {
        Self {
            env: "Hopper-v5",
            algo,
            seed,
            defender,
            outcomes: vec!["truncated"; 4],
            acc_reward: 100.0,
            wall_seconds: 10.0,
            returns: None,
            evals: None,
            costs: None,
            eval_costs: None,
            cost_limit: None,
            shield: None,
            warmup: None,
        }
    }

    /// The learner's random warm-up in training steps (`[<algo>] learning_starts`).
    pub fn warmup(mut self, steps: u64) -> Self {
        self.warmup = Some(steps);
        self
    }

    /// The task, e.g. `SafetyHopperVelocity-v1`.
    pub fn env(mut self, env: &'static str) -> Self {
        self.env = env;
        self
    }

    /// Episode costs, one per outcome.
    pub fn costs(mut self, costs: &[f64]) -> Self {
        assert_eq!(costs.len(), self.outcomes.len());
        self.costs = Some(costs.to_vec());
        self
    }

    /// Evaluation mean costs, one per evaluation.
    pub fn eval_costs(mut self, costs: &[f64]) -> Self {
        self.eval_costs = Some(costs.to_vec());
        self
    }

    /// Shielded evaluations `(mean_return, mean_cost, filtered)`, one per evaluation.
    pub fn shield(mut self, shield: &[(f64, f64, f64)]) -> Self {
        self.shield = Some(shield.to_vec());
        self
    }

    /// The episode cost limit `summary.json` records.
    pub fn cost_limit(mut self, limit: f64) -> Self {
        self.cost_limit = Some(limit);
        self
    }

    /// `crashed` episodes first, then `filtered`, then `truncated`, `n` in all.
    pub fn outcomes(mut self, n: usize, crashed: usize, filtered: usize) -> Self {
        self.outcomes = (0..n)
            .map(|i| {
                if i < crashed {
                    "crashed"
                } else if i < crashed + filtered {
                    "filtered"
                } else {
                    "truncated"
                }
            })
            .collect();
        self
    }

    pub fn acc(mut self, acc_reward: f64) -> Self {
        self.acc_reward = acc_reward;
        self
    }

    /// Episode returns, one per outcome.
    pub fn returns(mut self, returns: &[f64]) -> Self {
        assert_eq!(returns.len(), self.outcomes.len());
        self.returns = Some(returns.to_vec());
        self
    }

    /// Evaluations `(mean_return, mean_length)`; the last return is the Acc Reward.
    pub fn evals(mut self, evals: &[(f64, f64)]) -> Self {
        self.acc_reward = evals.last().unwrap().0;
        self.evals = Some(evals.to_vec());
        self
    }

    pub fn wall(mut self, wall_seconds: f64) -> Self {
        self.wall_seconds = wall_seconds;
        self
    }

    /// A directory name: `hopper-v5_sac_meandemow5-meandemow10_state_s0`.
    pub fn dir_name(&self) -> String {
        let filter = match self.defender {
            None => "bare".to_string(),
            Some((s, m)) => format!("{}_{m}", s.replace('/', "-")),
        };
        format!("{}_{}_{}_s{}", self.env, self.algo, filter, self.seed).to_lowercase()
    }

    /// Writes the run directory `parent/dir_name()` and returns its path.
    pub fn write(&self, parent: &Path) -> PathBuf {
        let dir = parent.join(self.dir_name());
        std::fs::create_dir_all(&dir).unwrap();
        let n = self.outcomes.len() as u64;
        let steps = 100 * n;
        let mut config = format!(
            "env = \"{}\"\nalgo = \"{}\"\nseed = {}\ntotal_steps = {steps}\ntotal_episodes = 0\n",
            self.env, self.algo, self.seed
        );
        if let Some((strategy, mode)) = self.defender {
            write!(
                config,
                "\n[defender]\nstrategy = \"{strategy}\"\nmode = \"{mode}\"\nr_task = -1.0\nnum_demos = 50\n\
                 demos = \"data/demos/{}.npz\"\n",
                self.env
            )
            .unwrap();
        }
        config.push_str("\n[algo_config]\nlearning_rate = 0.0003\nbatch_size = 256\n");
        if let Some(steps) = self.warmup {
            write!(config, "\n[{}]\nlearning_starts = {steps}\n", self.algo).unwrap();
        }
        std::fs::write(dir.join("config.toml"), config).unwrap();

        let mut metrics = String::from("episode,total_steps,return,length,outcome,wall_seconds");
        metrics.push_str(if self.costs.is_some() { ",cost\n" } else { "\n" });
        for (i, outcome) in self.outcomes.iter().enumerate() {
            let i = i as u64;
            let wall = self.wall_seconds * (i + 1) as f64 / n as f64;
            let ret = self.returns.as_ref().map_or((10 * i + self.seed) as f64, |r| r[i as usize]);
            write!(metrics, "{i},{},{ret:?},100,{outcome},{wall}", 100 * (i + 1)).unwrap();
            match &self.costs {
                Some(costs) => writeln!(metrics, ",{}", costs[i as usize]).unwrap(),
                None => metrics.push('\n'),
            }
        }
        std::fs::write(dir.join("metrics.csv"), metrics).unwrap();

        let mut eval = String::from("total_steps,mean_return,std_return,mean_length,episodes");
        eval.push_str(match (&self.eval_costs, &self.shield) {
            (_, Some(_)) => ",mean_cost,shield_mean_return,shield_mean_cost,shield_filtered\n",
            (Some(_), None) => ",mean_cost\n",
            (None, None) => "\n",
        });
        let mut rows = Vec::new();
        match &self.evals {
            None => {
                for k in 1..=n {
                    let mean = self.acc_reward * k as f64 / n as f64;
                    rows.push(format!("{},{mean},1.5,100.0,10", 100 * k));
                }
            }
            Some(evals) => {
                for (k, (mean, length)) in evals.iter().enumerate() {
                    rows.push(format!("{},{mean:?},1.5,{length:?},10", 100 * (k + 1)));
                }
            }
        }
        if let Some(costs) = &self.eval_costs {
            assert_eq!(costs.len(), rows.len(), "one mean cost per evaluation");
            rows.iter_mut().zip(costs).for_each(|(row, cost)| write!(row, ",{cost}").unwrap());
        } else if self.shield.is_some() {
            rows.iter_mut().for_each(|row| row.push(','));
        }
        if let Some(shield) = &self.shield {
            assert_eq!(shield.len(), rows.len(), "one shielded evaluation per evaluation");
            for (row, (ret, cost, filtered)) in rows.iter_mut().zip(shield) {
                write!(row, ",{ret},{cost},{filtered}").unwrap();
            }
        }
        rows.iter().for_each(|row| writeln!(eval, "{row}").unwrap());
        std::fs::write(dir.join("eval.csv"), eval).unwrap();

        let count = |o: &str| self.outcomes.iter().filter(|x| **x == o).count() as f64;
        let crash_pct = count("crashed") * 100.0 / n as f64;
        let filtered_pct = count("filtered") * 100.0 / n as f64;
        let (strategy, mode) = match self.defender {
            None => ("null".to_string(), "null".to_string()),
            Some((s, m)) => (format!("\"{s}\""), format!("\"{m}\"")),
        };
        let summary = format!(
            "{{\n  \"env\": \"{}\", \"algo\": \"{}\", \"seed\": {},\n  \"strategy\": {strategy},\n  \
             \"mode\": {mode},\n  \"acc_reward\": {:?},\n  \"crash_pct\": {crash_pct:?},\n  \
             \"filtered_pct\": {filtered_pct:?},\n  \"episodes\": {n}, \"steps\": {steps}, \
             \"filtered_steps\": {},\n  \"wall_seconds\": {:?}, \"steps_per_second\": {:?},\n  \
             \"complete\": true{}\n}}\n",
            self.env,
            self.algo,
            self.seed,
            self.acc_reward,
            count("filtered") as u64,
            self.wall_seconds,
            steps as f64 / self.wall_seconds,
            self.cost_limit.map(|l| format!(", \"episode_cost_limit\": {l:?}")).unwrap_or_default()
        );
        std::fs::write(dir.join("summary.json"), summary).unwrap();
        dir
    }
}

pub const A: Option<(&str, &str)> = Some(("MeanDemoW5/MeanDemoW10", "state"));
pub const B: Option<(&str, &str)> = Some(("MinDemoW5/MinDemoW10", "state"));

/// The main fixture: SAC and TD3 on Hopper-v5, seeds 0, 1, 2, bare and two DEFENDER strategies
/// (state mode); 18 runs. The values are chosen so that the table can be computed by hand (see
/// the tests that use it).
pub fn paper_fixture(root: &Path) -> Vec<PathBuf> {
    let mut specs = Vec::new();
    // SAC bare: acc 100, 200, 300; crashes 2, 1, 3 of 4; wall 10, 20, 40.
    for (seed, acc, crashed, wall) in [(0, 100.0, 2, 10.0), (1, 200.0, 1, 20.0), (2, 300.0, 3, 40.0)] {
        specs.push(RunSpec::new("sac", seed, None).outcomes(4, crashed, 0).acc(acc).wall(wall));
    }
    // SAC A: acc 110, 110, 140; crashes 1, 0, 1 of 4, filtered 1, 2, 1; wall 15, 30, 40.
    for (seed, acc, crashed, filtered, wall) in
        [(0, 110.0, 1, 1, 15.0), (1, 110.0, 0, 2, 30.0), (2, 140.0, 1, 1, 40.0)]
    {
        specs.push(RunSpec::new("sac", seed, A).outcomes(4, crashed, filtered).acc(acc).wall(wall));
    }
    // SAC B: acc -4 always; no crash, all filtered; wall 2x the bare's.
    for (seed, wall) in [(0, 20.0), (1, 40.0), (2, 80.0)] {
        specs.push(RunSpec::new("sac", seed, B).outcomes(4, 0, 4).acc(-4.0).wall(wall));
    }
    // TD3 bare: acc 50, 60, 70; crashes 4, 4, 2 of 5; wall 100 each.
    for (seed, acc, crashed) in [(0, 50.0, 4), (1, 60.0, 4), (2, 70.0, 2)] {
        specs.push(RunSpec::new("td3", seed, None).outcomes(5, crashed, 0).acc(acc).wall(100.0));
    }
    // TD3 A and B: acc 80 and 10; 1 and 0 crashes of 5; wall 150 and 300.
    for seed in 0..3 {
        specs.push(RunSpec::new("td3", seed, A).outcomes(5, 1, 1).acc(80.0).wall(150.0));
        specs.push(RunSpec::new("td3", seed, B).outcomes(5, 0, 5).acc(10.0).wall(300.0));
    }
    specs.iter().map(|s| s.write(root)).collect()
}
