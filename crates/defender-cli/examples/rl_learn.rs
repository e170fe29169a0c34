//! Learning check: trains SAC or TD3 (defaults) on a MuJoCo task and prints each evaluation.
//!
//! ```text
//! cargo run --release -p defender-cli --example rl_learn -- sac InvertedDoublePendulum-v5 50000 [seed] [eval_freq]
//! ```
//!
//! Prints one line per evaluation (`total_steps mean_return std_return mean_length`), a line
//! per 10 training episodes, and the final 10-episode evaluation.

use std::time::Instant;

use anyhow::{Context, bail};
use defender_rl::{
    Algo, AlgoConfig, Budget, EpisodeRecord, EvalRecord, HookError, Hooks, RunEnd, Trainer, TrainerConfig,
};

struct Print {
    start: Instant,
    crashed: u64,
}

impl Hooks for Print {
    fn on_episode_end(&mut self, r: &EpisodeRecord) -> Result<(), HookError> {
        self.crashed += u64::from(r.terminated);
        if r.episode % 10 == 9 {
            println!(
                "episode {:>5} steps {:>7} return {:>9.1} length {:>4} crashed so far {} ({:.0} steps/s)",
                r.episode,
                r.total_steps,
                r.episode_return,
                r.length,
                self.crashed,
                r.total_steps as f64 / self.start.elapsed().as_secs_f64()
            );
        }
        Ok(())
    }
    fn on_evaluation(&mut self, e: &EvalRecord) -> Result<(), HookError> {
        println!(
            "eval{} steps {:>7} mean {:>9.1} std {:>8.1} length {:>6.1}",
            if e.is_final { " FINAL" } else { "" },
            e.total_steps,
            e.mean_return,
            e.std_return,
            e.mean_length
        );
        Ok(())
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let algo: Algo = args.first().map(String::as_str).unwrap_or("sac").parse()?;
    let id = args.get(1).map(String::as_str).unwrap_or("InvertedDoublePendulum-v5");
    let steps: u64 = args.get(2).map(|s| s.parse()).transpose().context("steps")?.unwrap_or(50_000);
    let seed: u64 = args.get(3).map(|s| s.parse()).transpose().context("seed")?.unwrap_or(0);
    let eval_freq: u64 = args.get(4).map(|s| s.parse()).transpose().context("eval_freq")?.unwrap_or(5_000);
    if steps == 0 {
        bail!("steps must be positive");
    }
    let env = defender_mujoco::make(id)?;
    let eval_env = defender_mujoco::make(id)?;
    let config = AlgoConfig::default_for(algo);
    let agent = config.build(
        defender_rl::Env::observation_space(&env).dim(),
        defender_rl::Env::action_space(&env).dim(),
        seed,
    )?;
    let trainer_config = TrainerConfig { eval_freq, ..TrainerConfig::new(seed, Budget::Steps(steps)) };
    println!("{} on {id}, {steps} steps, seed {seed}, config {config:?}", algo.as_str());
    let mut trainer = Trainer::new(agent, env, eval_env, trainer_config)?;
    let mut hooks = Print { start: Instant::now(), crashed: 0 };
    if let RunEnd::Complete(e) = trainer.run(&mut hooks)? {
        println!(
            "done: final mean {:.1} +- {:.1} over {} episodes; {} training episodes; {:.0} s ({:.1} steps/s)",
            e.mean_return,
            e.std_return,
            e.episodes,
            trainer.episodes().len(),
            trainer.wall_seconds(),
            steps as f64 / trainer.wall_seconds()
        );
    }
    Ok(())
}
