//! A small line world whose every step is visible, with demonstrations of both groups: the
//! environment of the `DefenderEnv` tests.

#![allow(dead_code)] // each test file uses a part

use defender::{DefenderConfig, EpisodeSet, Meta};
use defender_rl::{BoxSpace, Env, Step, StepInfo};

/// A point on a line: the action moves it; |x| > 3 is a crash (terminated). Counts its steps.
#[derive(Debug)]
pub struct Line {
    obs_space: BoxSpace,
    act_space: BoxSpace,
    pub x: f64,
    pub steps: usize,
}

impl Line {
    pub fn new() -> Self {
        Self {
            obs_space: BoxSpace::unbounded(2),
            act_space: BoxSpace::new(vec![-1.0], vec![1.0]).unwrap(),
            x: 0.0,
            steps: 0,
        }
    }
}

impl Env for Line {
    fn id(&self) -> &str {
        "Line-v0"
    }
    fn observation_space(&self) -> &BoxSpace {
        &self.obs_space
    }
    fn action_space(&self) -> &BoxSpace {
        &self.act_space
    }
    fn reset(&mut self, _seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.x = 0.0;
        Ok(vec![self.x, 1.0])
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        self.steps += 1;
        self.x += action[0];
        let terminated = self.x.abs() > 3.0;
        Ok(Step {
            obs: vec![self.x, 1.0],
            reward: 1.0,
            cost: if terminated { 1.0 } else { 0.0 },
            terminated,
            truncated: false,
            info: StepInfo::default(),
        })
    }
}

/// Safe demonstrations stay near 0; unsafe ones run to +4 and crash. Rewards: safe 1, unsafe
/// down to -7 (the default R_task).
pub fn line_demos() -> EpisodeSet {
    let mut set = EpisodeSet::new(2, 1, Meta { env_id: Some("Line-v0".into()), ..Meta::default() }).unwrap();
    for k in 0..3 {
        let xs: Vec<f64> = (0..=10).map(|t| 0.1 * ((t + k) % 3) as f64 - 0.1).collect();
        let obs: Vec<f64> = xs.iter().flat_map(|&x| [x, 1.0]).collect();
        let act: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        set.push_episode_f64(&obs, &act, &[1.0; 10], false).unwrap();
    }
    for k in 0..3 {
        let xs: Vec<f64> = (0..=4).map(|t| t as f64 * (1.0 + 0.05 * k as f64)).collect();
        let obs: Vec<f64> = xs.iter().flat_map(|&x| [x, 1.0]).collect();
        let act: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        set.push_episode_f64(&obs, &act, &[0.0, -1.0, -3.0, -7.0], true).unwrap();
    }
    set
}

pub fn config(strategy: &str) -> DefenderConfig {
    let mut c = DefenderConfig { strategy: strategy.parse().unwrap(), ..DefenderConfig::default() };
    c.dynamics.buffer_size = 1000;
    c.dynamics.hidden = vec![32, 32];
    c.dynamics.batch_size = 16;
    c
}
