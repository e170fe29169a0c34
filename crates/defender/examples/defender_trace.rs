//! `defender_trace`: runs `DefenderEnv` over `defender-mujoco`'s task from given initial states
//! with given actions, and prints every step's decision, costs, observation (the dynamics model's
//! prediction on filtered steps), reward and flags as JSON. The Python package's parity test
//! (python/tests/test_parity.py) compares its `DefenderWrapper` around Gymnasium's own MuJoCo task
//! with this, step by step.
//!
//! Usage: `cargo run --release -p defender --example defender_trace -- IN.json > OUT.json`
//!
//! IN.json: `{"env": "Hopper-v5", "demos": "data/demos/Hopper-v5.npz", "strategy":
//! "MeanDemoW5/MeanDemoW10", "mode": "state", "num_demos": null, "r_task": null, "seed": 0,
//! "dynamics": {...DynamicsConfig fields...}, "episodes": [{"qpos": [...], "qvel": [...],
//! "actions": [[...], ...]}, ...]}`. Episode `i` starts as `defender env replay` does (MuJoCo's
//! data reset, then the state set) and takes its actions in order until the episode ends (or the
//! actions run out). The dynamics model is seeded with `ChaCha8Rng::seed_from_u64(seed)`, as
//! `DefenderWrapper(seed=...)` does. The horizon is the task's (1000 steps), as `gymnasium.make`'s.

use std::io::Write;

use defender::{DefenderConfig, DefenderEnv, DynamicsConfig, EpisodeSet};
use defender_mujoco::MujocoEnv;
use defender_rl::{BoxSpace, Env, Step};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Deserialize)]
struct Input {
    env: String,
    demos: String,
    strategy: String,
    #[serde(default)]
    mode: Option<String>,
    #[serde(default)]
    num_demos: Option<usize>,
    #[serde(default)]
    r_task: Option<f64>,
    seed: u64,
    #[serde(default)]
    dynamics: DynamicsConfig,
    episodes: Vec<EpisodeIn>,
}

#[derive(Deserialize)]
struct EpisodeIn {
    qpos: Vec<f64>,
    qvel: Vec<f64>,
    actions: Vec<Vec<f64>>,
}

#[derive(Serialize)]
struct StepOut {
    filtered: bool,
    safe_cost: f64,
    unsafe_cost: f64,
    obs: Vec<f64>,
    reward: f64,
    /// The step's safety cost (defender-mujoco's crash rule; 0 on a filtered step).
    cost: f64,
    terminated: bool,
    truncated: bool,
}

#[derive(Serialize)]
struct EpisodeOut {
    reset_obs: Vec<f64>,
    steps: Vec<StepOut>,
    outcome: Option<&'static str>,
}

#[derive(Serialize)]
struct Output {
    r_task: f64,
    episodes: Vec<EpisodeOut>,
    stats: defender::DefenderStats,
}

/// The MuJoCo task whose `reset` starts episode `k` from the k-th given state, with the task's
/// horizon.
struct FromStates {
    env: MujocoEnv,
    states: Vec<(Vec<f64>, Vec<f64>)>,
    next: usize,
    elapsed: usize,
    horizon: usize,
}

impl Env for FromStates {
    fn id(&self) -> &str {
        self.env.id()
    }
    fn observation_space(&self) -> &BoxSpace {
        self.env.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.env.action_space()
    }
    fn max_episode_steps(&self) -> Option<usize> {
        Some(self.horizon)
    }
    fn reset(&mut self, _seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        let (qpos, qvel) = self.states.get(self.next).cloned().ok_or_else(|| {
            defender_rl::EnvError::Simulator(format!("no initial state for episode {}", self.next))
        })?;
        self.next += 1;
        self.elapsed = 0;
        self.env.reset_to(&qpos, &qvel)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let mut step = self.env.step(action)?;
        self.elapsed += 1;
        if self.elapsed >= self.horizon {
            step.truncated = true;
        }
        Ok(step)
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: defender_trace IN.json > OUT.json")?;
    let input: Input = serde_json::from_str(&std::fs::read_to_string(&path)?)?;
    let env = MujocoEnv::from_id(&input.env)?;
    let horizon = env.task().spec().max_episode_steps;
    let states = input.episodes.iter().map(|e| (e.qpos.clone(), e.qvel.clone())).collect();
    let inner = FromStates { env, states, next: 0, elapsed: 0, horizon };
    let demos = EpisodeSet::load(&input.demos)?;
    let config = DefenderConfig {
        strategy: input.strategy.parse()?,
        mode: input.mode.as_deref().unwrap_or("state").parse()?,
        num_demos: input.num_demos,
        r_task: input.r_task,
        dynamics: input.dynamics,
        ..DefenderConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(input.seed);
    let mut env = DefenderEnv::new(inner, &demos, config, &mut rng)?;
    let mut episodes = Vec::new();
    for e in &input.episodes {
        let reset_obs = env.reset(None)?;
        let mut steps = Vec::new();
        let mut outcome = None;
        for a in &e.actions {
            let step = env.step(a)?;
            let d = env.last_decision().ok_or("no decision after a step")?;
            let done = step.done();
            steps.push(StepOut {
                filtered: d.filtered,
                safe_cost: d.safe_cost,
                unsafe_cost: d.unsafe_cost,
                obs: step.obs,
                reward: step.reward,
                cost: step.cost,
                terminated: step.terminated,
                truncated: step.truncated,
            });
            if done {
                outcome = env.last_outcome().map(|o| o.as_str());
                break;
            }
        }
        episodes.push(EpisodeOut { reset_obs, steps, outcome });
    }
    let out = Output { r_task: env.r_task(), episodes, stats: env.stats() };
    let mut stdout = std::io::stdout().lock();
    serde_json::to_writer(&mut stdout, &out)?;
    stdout.write_all(b"\n")?;
    Ok(())
}
