//! Training throughput: environment steps per second of SAC or TD3 with default
//! hyperparameters (batch 256, 256x256 networks, one gradient step per environment step) on a
//! MuJoCo task, environment and updates included, measured after `learning_starts`.
//!
//! ```text
//! cargo run --release -p defender-cli --example rl_speed -- sac Hopper-v5 [measured_steps] [learning_starts]
//! ```
//!
//! The peer is `tools/peers/sb3_speed.py` (Stable-Baselines3 on PyTorch CPU), which measures the same.

use std::time::Instant;

use anyhow::Context;
use defender_rl::{Algo, AlgoConfig, Budget, Hooks, Trainer, TrainerConfig};

/// Timestamps the step at which updates start and the last training step (so the final
/// evaluation is not counted).
struct Clock {
    learning_starts: u64,
    last: u64,
    started: Option<Instant>,
    ended: Option<Instant>,
}

impl Hooks for Clock {
    fn on_step(&mut self, total_steps: u64) {
        if total_steps == self.learning_starts {
            self.started = Some(Instant::now());
        }
        if total_steps == self.last {
            self.ended = Some(Instant::now());
        }
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let algo: Algo = args.first().map(String::as_str).unwrap_or("sac").parse()?;
    let id = args.get(1).map(String::as_str).unwrap_or("Hopper-v5");
    let measured: u64 =
        args.get(2).map(|s| s.parse()).transpose().context("measured_steps")?.unwrap_or(2_000);
    let learning_starts: u64 =
        args.get(3).map(|s| s.parse()).transpose().context("learning_starts")?.unwrap_or(1_000);
    let env = defender_mujoco::make(id)?;
    let eval_env = defender_mujoco::make(id)?;
    let config = match AlgoConfig::default_for(algo) {
        AlgoConfig::Sac(c) => AlgoConfig::Sac(defender_rl::SacConfig { learning_starts, ..c }),
        AlgoConfig::Td3(c) => AlgoConfig::Td3(defender_rl::Td3Config { learning_starts, ..c }),
    };
    let agent = config.build(
        defender_rl::Env::observation_space(&env).dim(),
        defender_rl::Env::action_space(&env).dim(),
        0,
    )?;
    let total = learning_starts + measured;
    let trainer_config =
        TrainerConfig { final_eval_episodes: 1, ..TrainerConfig::new(0, Budget::Steps(total)) };
    let mut trainer = Trainer::new(agent, env, eval_env, trainer_config)?;
    let mut clock = Clock { learning_starts, last: total, started: None, ended: None };
    let whole = Instant::now();
    trainer.run(&mut clock)?;
    let (Some(started), Some(ended)) = (clock.started, clock.ended) else {
        anyhow::bail!("the run did not reach learning_starts and the last step");
    };
    let span = (ended - started).as_secs_f64();
    println!(
        "{} {id}: {measured} steps after learning_starts={learning_starts} in {span:.2} s: {:.1} steps/s; \
         whole run {:.1} s; DEFENDER_NN_THREADS={}",
        algo.as_str(),
        measured as f64 / span,
        whole.elapsed().as_secs_f64(),
        std::env::var("DEFENDER_NN_THREADS").unwrap_or_else(|_| "default (min(2, cores))".into())
    );
    Ok(())
}
