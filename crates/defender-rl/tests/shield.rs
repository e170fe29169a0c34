//! Evaluation with a shield kept (crate::evaluation): a training environment that lends a
//! shield gets every evaluation's episodes run again shielded, on the same reset seeds, each
//! stopped before the first action the shield refuses; the unfiltered evaluations and training
//! are those of the same run without a shield, bit for bit.
#![allow(clippy::unwrap_used)] // helpers outside #[test] fns fail loudly on purpose

use std::sync::{Arc, Mutex};

use defender_rl::classic::Pendulum;
use defender_rl::{
    AlgoConfig, BoxSpace, Budget, Env, EpisodeRecord, EvalRecord, NoHooks, SacConfig, SeedPurpose, Shield,
    Step, Trainer, TrainerConfig, derive_seed,
};

/// What the evaluation environment saw of one episode.
#[derive(Debug, Clone, PartialEq)]
struct EpisodeLog {
    seed: Option<u64>,
    first_obs: Vec<f64>,
    rewards: Vec<f64>,
    costs: Vec<f64>,
}

type Log = Arc<Mutex<Vec<EpisodeLog>>>;

/// Pendulum that logs every episode it runs; each step costs a tenth of its reward's size, so
/// that costs are not all zero.
struct Logged {
    inner: Pendulum,
    log: Log,
}

impl Env for Logged {
    fn id(&self) -> &str {
        "Logged"
    }
    fn observation_space(&self) -> &BoxSpace {
        self.inner.observation_space()
    }
    fn action_space(&self) -> &BoxSpace {
        self.inner.action_space()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        let obs = self.inner.reset(seed)?;
        let entry = EpisodeLog { seed, first_obs: obs.clone(), rewards: vec![], costs: vec![] };
        self.log.lock().unwrap().push(entry);
        Ok(obs)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<Step> {
        let mut step = self.inner.step(action)?;
        step.cost = 0.1 * step.reward.abs();
        let mut log = self.log.lock().unwrap();
        let entry = log.last_mut().unwrap();
        entry.rewards.push(step.reward);
        entry.costs.push(step.cost);
        Ok(step)
    }
}

/// Refuses the `STOP_AT`-th step of every other episode (the first, third, ... since it was
/// lent), and notes the first observation of each episode it sees.
struct EveryOther {
    episodes: usize,
    t: usize,
    seen: Arc<Mutex<Vec<Vec<f64>>>>,
}

const STOP_AT: usize = 4;

impl Shield for EveryOther {
    fn reset(&mut self) {
        self.episodes += 1;
        self.t = 0;
    }
    fn allows(&mut self, obs: &[f64], action: &[f64]) -> defender_rl::Result<bool> {
        assert_eq!(action.len(), 1);
        assert!(action[0].abs() <= 2.0, "the action in the environment's bounds: {action:?}");
        self.t += 1;
        if self.t == 1 {
            self.seen.lock().unwrap().push(obs.to_vec());
        }
        Ok(!(self.episodes % 2 == 1 && self.t == STOP_AT))
    }
}

/// The training task: Pendulum, lending an [`EveryOther`] shield or none.
struct Training {
    inner: Pendulum,
    lend: bool,
    seen: Arc<Mutex<Vec<Vec<f64>>>>,
}

impl Env for Training {
    fn id(&self) -> &str {
        "Training"
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
        self.inner.step(action)
    }
    fn shield(&self) -> Option<Box<dyn Shield>> {
        self.lend
            .then(|| Box::new(EveryOther { episodes: 0, t: 0, seen: self.seen.clone() }) as Box<dyn Shield>)
    }
}

struct Run {
    episodes: Vec<EpisodeRecord>,
    evaluations: Vec<EvalRecord>,
    log: Vec<EpisodeLog>,
    seen: Vec<Vec<f64>>,
}

const EPISODES: usize = 3;

fn run(lend: bool) -> Run {
    let algo = AlgoConfig::Sac(SacConfig {
        net_arch: vec![16],
        batch_size: 16,
        learning_starts: 100,
        ..SacConfig::default()
    });
    let (log, seen) = (Log::default(), Arc::default());
    let env = Training { inner: Pendulum::new(), lend, seen: Arc::clone(&seen) };
    let eval_env = Logged { inner: Pendulum::new(), log: Arc::clone(&log) };
    let config = TrainerConfig {
        eval_freq: 250,
        eval_episodes: EPISODES,
        final_eval_episodes: EPISODES,
        ..TrainerConfig::new(7, Budget::Steps(600))
    };
    let mut trainer = Trainer::new(algo.build(3, 1, 7).unwrap(), env, eval_env, config).unwrap();
    trainer.run(&mut NoHooks).unwrap();
    let without_wall = |e: &EpisodeRecord| EpisodeRecord { wall_seconds: 0.0, ..e.clone() };
    Run {
        episodes: trainer.episodes().iter().map(without_wall).collect(),
        evaluations: trainer.evaluations().to_vec(),
        log: log.lock().unwrap().clone(),
        seen: seen.lock().unwrap().clone(),
    }
}

#[test]
fn the_shielded_pass_replays_the_evaluation_seeds_and_counts_only_executed_steps() {
    let (bare, shielded) = (run(false), run(true));
    assert_eq!(bare.evaluations.len(), 3, "at 250 and 500 steps, and the final one");

    // Training and the unfiltered evaluations are the bare run's, bit for bit.
    assert_eq!(shielded.episodes, bare.episodes);
    let unfiltered: Vec<EvalRecord> =
        shielded.evaluations.iter().map(|e| EvalRecord { shield: None, ..e.clone() }).collect();
    assert_eq!(unfiltered, bare.evaluations);
    assert!(bare.evaluations.iter().all(|e| e.shield.is_none()), "no shield lent, none kept");

    // The bare run's evaluation seeds follow the evaluation counter, one per episode.
    let seeds: Vec<Option<u64>> = bare.log.iter().map(|e| e.seed).collect();
    let expected: Vec<Option<u64>> =
        (0..3 * EPISODES as u64).map(|k| Some(derive_seed(7, SeedPurpose::EvalEpisode, k))).collect();
    assert_eq!(seeds, expected);

    // Each evaluation of the shielded run: its unfiltered episodes, then the same seeds shielded.
    assert_eq!(shielded.log.len(), 2 * bare.log.len());
    assert_eq!(shielded.seen.len(), bare.log.len(), "the shield saw every shielded episode");
    for (i, eval) in shielded.evaluations.iter().enumerate() {
        let plain = &shielded.log[2 * EPISODES * i..2 * EPISODES * i + EPISODES];
        let kept = &shielded.log[2 * EPISODES * i + EPISODES..2 * EPISODES * (i + 1)];
        assert_eq!(plain, &bare.log[EPISODES * i..EPISODES * (i + 1)], "evaluation {i}: unfiltered pass");
        let part = eval.shield.as_ref().expect("a lent shield is kept");
        let (mut total_cost, mut stopped) = (0.0, 0);
        for (k, (p, s)) in plain.iter().zip(kept).enumerate() {
            assert_eq!(s.seed, p.seed, "evaluation {i} episode {k}: the paired seed");
            assert_eq!(s.first_obs, p.first_obs);
            assert_eq!(
                shielded.seen[EPISODES * i + k],
                p.first_obs,
                "the shield sees the environment's state"
            );
            // The shield refuses step STOP_AT of episodes 0 and 2: the environment never runs it,
            // and the episode is the unfiltered one up to there.
            let refused = k % 2 == 0;
            let executed = if refused { STOP_AT - 1 } else { p.rewards.len() };
            assert_eq!(s.rewards.len(), executed, "evaluation {i} episode {k}: executed steps");
            assert_eq!(s.rewards[..], p.rewards[..executed]);
            assert_eq!(part.returns[k], s.rewards.iter().sum::<f64>(), "only executed steps' rewards");
            total_cost += s.costs.iter().sum::<f64>();
            stopped += usize::from(refused);
        }
        let n = EPISODES as f64;
        assert_eq!(part.filtered, stopped as f64 / n);
        assert_eq!(part.filtered, 2.0 / 3.0);
        assert!((part.mean_cost - total_cost / n).abs() < 1e-12);
        assert_eq!(part.mean_length, (2.0 * (STOP_AT - 1) as f64 + 200.0) / n);
        assert!((part.mean_return - part.returns.iter().sum::<f64>() / n).abs() < 1e-9);
        assert_eq!(part.returns[1], eval.returns[1], "an episode it never refused is the unfiltered one");
    }
}
