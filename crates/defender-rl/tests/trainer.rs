//! The trainer's bookkeeping: outcomes, budgets, evaluation, environment state in checkpoints.

use std::path::Path;

use defender_rl::classic::Pendulum;
use defender_rl::{
    AlgoConfig, BoxSpace, Budget, Env, EnvError, NoHooks, Outcome, RunEnd, SacConfig, Step, Trainer,
    TrainerConfig,
};

/// Pendulum whose every third episode is "filtered" at step 5 and every other third "crashes"
/// at step 7 (terminated by the environment), like a DEFENDER wrapper over a task that falls.
/// Counts its episodes, and keeps that count in checkpoints.
struct Scripted {
    inner: Pendulum,
    t: usize,
    episodes: u64,
}

impl Env for Scripted {
    fn id(&self) -> &str {
        "Scripted"
    }
    fn observation_space(&self) -> &BoxSpace {
        self.inner.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.inner.action_space()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.t = 0;
        self.episodes += 1;
        self.inner.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let mut step = self.inner.step(action)?;
        self.t += 1;
        match (self.episodes % 3, self.t) {
            (1, 5) => {
                step.terminated = true;
                step.info.filtered = true;
                step.info.charged_cost = 3.0;
                step.reward = -100.0;
            }
            (2, 7) => step.terminated = true,
            _ => {}
        }
        Ok(step)
    }
    fn save_state(&self, dir: &Path) -> defender_rl::Result<()> {
        std::fs::write(dir.join("episodes"), self.episodes.to_string())
            .map_err(|e| EnvError::State { path: dir.into(), reason: e.to_string() })
    }
    fn load_state(&mut self, dir: &Path) -> defender_rl::Result<()> {
        let text = std::fs::read_to_string(dir.join("episodes"))
            .map_err(|e| EnvError::State { path: dir.into(), reason: e.to_string() })?;
        self.episodes = text.parse().map_err(|_| EnvError::State { path: dir.into(), reason: text })?;
        Ok(())
    }
}

fn small_sac() -> AlgoConfig {
    AlgoConfig::Sac(SacConfig {
        net_arch: vec![16],
        batch_size: 16,
        learning_starts: 50,
        ..SacConfig::default()
    })
}

#[test]
fn records_outcomes_lengths_and_returns() {
    let env = Scripted { inner: Pendulum::new(), t: 0, episodes: 0 };
    let config = TrainerConfig { final_eval_episodes: 1, ..TrainerConfig::new(0, Budget::Episodes(6)) };
    let mut trainer =
        Trainer::new(small_sac().build(3, 1, 0).unwrap(), env, Pendulum::new(), config).unwrap();
    let RunEnd::Complete(eval) = trainer.run(&mut NoHooks).unwrap() else { panic!("stopped") };
    let outcomes: Vec<Outcome> = trainer.episodes().iter().map(|e| e.outcome()).collect();
    use Outcome::*;
    assert_eq!(outcomes, [Filtered, Crashed, Truncated, Filtered, Crashed, Truncated]);
    let lengths: Vec<u64> = trainer.episodes().iter().map(|e| e.length).collect();
    assert_eq!(lengths, [5, 7, 200, 5, 7, 200]);
    let mut steps = 0;
    for e in trainer.episodes() {
        steps += e.length;
        assert_eq!(e.total_steps, steps);
        assert!(e.wall_seconds >= 0.0);
    }
    assert_eq!(trainer.total_steps(), 424);
    assert!(trainer.episodes()[0].episode_return < -100.0);
    // A cost charged to the learner is not the task's: the recorded episode costs are 0.
    assert!(trainer.episodes().iter().all(|e| e.cost() == 0.0));
    // The evaluation env is the plain task: full 200-step episodes.
    assert_eq!((eval.episodes, eval.mean_length, eval.is_final), (1, 200.0, true));
}

/// Sums the costs of the transitions the agent was given.
#[derive(Default)]
struct LearnedCost(f64);

impl defender_rl::Hooks for LearnedCost {
    fn on_transition(&mut self, t: &defender_rl::Transition<'_>, _env_action: &[f64], _task_cost: f64) {
        self.0 += t.cost;
    }
}

#[test]
fn a_charged_cost_reaches_the_agent_but_not_the_episode_records() {
    let env = Scripted { inner: Pendulum::new(), t: 0, episodes: 0 };
    let config = TrainerConfig { final_eval_episodes: 1, ..TrainerConfig::new(0, Budget::Episodes(6)) };
    let mut trainer =
        Trainer::new(small_sac().build(3, 1, 0).unwrap(), env, Pendulum::new(), config).unwrap();
    let mut learned = LearnedCost::default();
    trainer.run(&mut learned).unwrap();
    // Two filtered episodes, each charged 3 at its filtered step.
    assert_eq!(learned.0, 6.0);
    assert_eq!(trainer.episodes().iter().map(|e| e.cost()).sum::<f64>(), 0.0);
}

#[test]
fn a_step_budget_stops_mid_episode_without_recording_it() {
    let config = TrainerConfig { final_eval_episodes: 1, ..TrainerConfig::new(0, Budget::Steps(450)) };
    let mut trainer =
        Trainer::new(small_sac().build(3, 1, 0).unwrap(), Pendulum::new(), Pendulum::new(), config).unwrap();
    trainer.run(&mut NoHooks).unwrap();
    assert_eq!(trainer.total_steps(), 450);
    assert_eq!(trainer.episodes().len(), 2);
    assert_eq!(trainer.agent().num_timesteps(), 450);
}

#[test]
fn the_env_state_goes_into_the_checkpoint_and_comes_back() {
    let root = tempfile::tempdir().unwrap();
    let ckpt = root.path().join("checkpoint");
    let env = Scripted { inner: Pendulum::new(), t: 0, episodes: 0 };
    let config = TrainerConfig {
        checkpoint_every_episodes: 2,
        final_eval_episodes: 1,
        ..TrainerConfig::new(0, Budget::Episodes(4))
    };
    let mut trainer = Trainer::new(small_sac().build(3, 1, 0).unwrap(), env, Pendulum::new(), config)
        .unwrap()
        .with_checkpoint_dir(&ckpt);
    trainer.run(&mut NoHooks).unwrap();
    assert_eq!(std::fs::read_to_string(ckpt.join("env/episodes")).unwrap(), "4");
    let env = Scripted { inner: Pendulum::new(), t: 0, episodes: 0 };
    let config = TrainerConfig::new(0, Budget::Episodes(4));
    let mut again = Trainer::new(small_sac().build(3, 1, 0).unwrap(), env, Pendulum::new(), config).unwrap();
    again.resume(&ckpt, &mut NoHooks).unwrap();
    assert_eq!(again.env().episodes, 4);
    assert!(again.is_complete());
    assert_eq!(again.episodes(), trainer.episodes());
}

#[test]
fn refuses_environments_that_do_not_fit_the_agent() {
    let agent = small_sac().build(4, 1, 0).unwrap();
    let config = TrainerConfig::new(0, Budget::Steps(10));
    assert!(Trainer::new(agent, Pendulum::new(), Pendulum::new(), config).is_err());
}

/// Pendulum whose reward turns NaN at the run's 30th step.
struct NanAt30(Pendulum, u64);

impl Env for NanAt30 {
    fn id(&self) -> &str {
        "NanAt30"
    }
    fn observation_space(&self) -> &BoxSpace {
        self.0.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.0.action_space()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.0.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let mut step = self.0.step(action)?;
        self.1 += 1;
        if self.1 == 30 {
            step.reward = f64::NAN;
        }
        Ok(step)
    }
}

/// A NaN from the environment stops the run naming the step, not a NaN in the agent's losses
/// or in the tables later.
#[test]
fn a_non_finite_reward_stops_the_run_naming_the_step() {
    let config = TrainerConfig { final_eval_episodes: 1, ..TrainerConfig::new(0, Budget::Steps(100)) };
    let mut trainer = Trainer::new(
        small_sac().build(3, 1, 0).unwrap(),
        NanAt30(Pendulum::new(), 0),
        Pendulum::new(),
        config,
    )
    .unwrap();
    let err = trainer.run(&mut NoHooks).unwrap_err().to_string();
    assert!(err.contains("non-finite reward (NaN, element 0) at step 30 (episode 0)"), "{err}");
}
