//! `DefenderEnv` lends its filter as a shield (`FilterShield`): each evaluation runs again with a
//! copy of the filter as it stands, stopping an episode where training would have filtered it,
//! and the training filter never sees an evaluation step.

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

#[path = "common/line.rs"]
mod line;

use std::path::Path;
use std::sync::{Arc, Mutex};

use defender::{DefenderEnv, DefenderStats, FilterShield};
use defender_rl::{
    Agent, BoxSpace, Budget, Env, EpisodeRecord, EvalRecord, NoHooks, Outcome, RlError, Shield, Step,
    TimeLimit, Trainer, TrainerConfig, Transition, UpdateStats,
};
use line::{Line, config, line_demos};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Always moves right by `SPEED` (the line's actions are in [-1, 1], as the agent's).
struct Constant {
    steps: u64,
}

const SPEED: f32 = 0.5;

impl Agent for Constant {
    fn algo(&self) -> &'static str {
        "constant"
    }
    fn obs_dim(&self) -> usize {
        2
    }
    fn act_dim(&self) -> usize {
        1
    }
    fn num_timesteps(&self) -> u64 {
        self.steps
    }
    fn act(&mut self, _obs: &[f64], _deterministic: bool, action: &mut [f32]) -> Result<(), RlError> {
        action[0] = SPEED;
        Ok(())
    }
    fn act_with(
        &mut self,
        _obs: &[f64],
        _rng: &mut rand_chacha::ChaCha8Rng,
        action: &mut [f32],
    ) -> Result<(), RlError> {
        action[0] = SPEED;
        Ok(())
    }
    fn observe(&mut self, _transition: &Transition<'_>) -> Result<(), RlError> {
        self.steps += 1;
        Ok(())
    }
    fn store_demonstration(&mut self, _transition: &Transition<'_>, _bc: bool) -> Result<(), RlError> {
        Ok(())
    }
    fn update(&mut self) -> Result<Option<UpdateStats>, RlError> {
        Ok(None)
    }
    fn save(&self, _dir: &Path) -> Result<(), RlError> {
        Ok(())
    }
    fn load(&mut self, _dir: &Path) -> Result<(), RlError> {
        Ok(())
    }
    fn save_actor(&self, _path: &Path) -> Result<(), RlError> {
        Ok(())
    }
}

type Trace = Arc<Mutex<Vec<(f64, f64, bool)>>>;

/// DEFENDER on the line, noting every training step's decision; it lends its shield or hides it.
struct Probe {
    inner: DefenderEnv<TimeLimit<Line>>,
    lend: bool,
    trace: Trace,
}

impl Env for Probe {
    fn id(&self) -> &str {
        self.inner.id()
    }
    fn observation_space(&self) -> &BoxSpace {
        self.inner.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.inner.action_space()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.inner.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let step = self.inner.step(action)?;
        let d = self.inner.last_decision().unwrap();
        self.trace.lock().unwrap().push((d.safe_cost, d.unsafe_cost, d.filtered));
        Ok(step)
    }
    fn shield(&self) -> Option<Box<dyn Shield>> {
        if self.lend { self.inner.shield() } else { None }
    }
}

const HORIZON: usize = 20;

struct Run {
    episodes: Vec<EpisodeRecord>,
    evaluations: Vec<EvalRecord>,
    trace: Vec<(f64, f64, bool)>,
    stats: DefenderStats,
}

fn run(lend: bool) -> Run {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let wrapped = DefenderEnv::new(
        TimeLimit::new(Line::new(), HORIZON),
        &line_demos(),
        config("MinBothW5/MinBothW5"),
        &mut rng,
    )
    .unwrap();
    let trace = Trace::default();
    let env = Probe { inner: wrapped, lend, trace: Arc::clone(&trace) };
    // Evaluations every 3 steps fall inside training episodes, while the filter holds a trajectory.
    let config = TrainerConfig {
        eval_freq: 3,
        eval_episodes: 2,
        final_eval_episodes: 2,
        ..TrainerConfig::new(0, Budget::Steps(40))
    };
    let eval_env = TimeLimit::new(Line::new(), HORIZON);
    let mut trainer = Trainer::new(Constant { steps: 0 }, env, eval_env, config).unwrap();
    trainer.run(&mut NoHooks).unwrap();
    let without_wall = |e: &EpisodeRecord| EpisodeRecord { wall_seconds: 0.0, ..e.clone() };
    let trace = trace.lock().unwrap().clone();
    Run {
        episodes: trainer.episodes().iter().map(without_wall).collect(),
        evaluations: trainer.evaluations().to_vec(),
        trace,
        stats: trainer.env().inner.stats(),
    }
}

#[test]
fn the_shield_stops_where_training_filters_and_leaves_the_training_filter_alone() {
    let (hidden, lent) = (run(false), run(true));
    // The training filter decided every training step as without evaluations shielded.
    assert_eq!(lent.trace, hidden.trace);
    assert_eq!(lent.episodes, hidden.episodes);
    assert_eq!(lent.stats, hidden.stats);
    let unfiltered: Vec<EvalRecord> =
        lent.evaluations.iter().map(|e| EvalRecord { shield: None, ..e.clone() }).collect();
    assert_eq!(unfiltered, hidden.evaluations);

    // Running right at 0.5 a step looks like the unsafe demonstrations: training filters every
    // episode at the same step k, before the crash (|x| > 3 at step 7).
    let k = lent.episodes[0].length;
    assert!(lent.episodes.iter().all(|e| e.outcome() == Outcome::Filtered && e.length == k));
    assert!((2..7).contains(&k), "filtered at step {k}");
    assert!(lent.evaluations.len() > 10);
    for eval in &lent.evaluations {
        // Unfiltered, the policy crashes at step 7, the crash step costing 1.
        assert_eq!((eval.mean_length, eval.mean_return, eval.mean_cost), (7.0, 7.0, Some(1.0)));
        let shield = eval.shield.as_ref().unwrap();
        // Shielded, every episode stops before step k: k - 1 executed steps of reward 1 (the
        // filtered step's R_task, -7, is no reward here) and no cost.
        let executed = (k - 1) as f64;
        assert_eq!(shield.filtered, 1.0);
        assert_eq!((shield.mean_length, shield.mean_return, shield.mean_cost), (executed, executed, 0.0));
        assert_eq!(shield.returns, vec![executed; eval.episodes]);
    }
}

#[test]
fn a_filter_shield_decides_as_the_filter() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut env =
        DefenderEnv::new(Line::new(), &line_demos(), config("MinBothW5/MinBothW5"), &mut rng).unwrap();
    let mut shield = FilterShield::new(env.filter().clone());
    assert_eq!(shield.filter().mode(), env.filter().mode());
    let mut obs = env.reset(None).unwrap();
    shield.reset();
    // Midway through an episode: a second shield, lent now, starts from an empty trajectory.
    let mut lent_later = env.shield().unwrap();
    lent_later.reset();
    for t in 0..10 {
        let action = [if t < 3 { 0.05 } else { 1.0 }];
        let allowed = shield.allows(&obs, &action).unwrap();
        let step = env.step(&action).unwrap();
        assert_eq!(allowed, !step.info.filtered, "step {t}");
        if step.done() {
            assert!(step.info.filtered, "the run to the right is filtered before it crashes");
            break;
        }
        obs = step.obs;
    }
    assert!(lent_later.allows(&[0.0, 1.0], &[0.0]).unwrap(), "standing at 0 is safe");
    assert!(shield.allows(&[0.0], &[0.0]).is_err(), "a wrong length is an error");
}
