//! DEFENDER on a task whose safety is a per-step cost (docs/SPEC.md, section 13): the agent's own
//! episodes join the groups by the episode cost limit, an unsafe one up to the step that passed
//! it, and demonstrations labelled by another rule are refused.

#![allow(clippy::unwrap_used)] // test helpers fail loudly on purpose

#[path = "common/line.rs"]
mod line;

use defender::{
    AdaptiveFilter, CostOptions, DefenderEnv, Demonstrations, EPISODE_COST_LIMIT_KEY, EpisodeSet,
    FilterOptions, Mode, OwnEpisodes, UnsafeRule,
};
use defender_rl::Outcome;
use line::{Line, config, line_demos};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The line demonstrations relabelled as if cut by an episode cost limit of 2.
fn cost_labelled() -> EpisodeSet {
    let mut set = line_demos();
    set.meta_mut().extra.insert(EPISODE_COST_LIMIT_KEY.into(), 2.0.into());
    set
}

fn filter(rule: UnsafeRule) -> AdaptiveFilter {
    let demos = Demonstrations::new(&cost_labelled(), Mode::State, CostOptions::default()).unwrap();
    let options = FilterOptions { own_episodes: Some(OwnEpisodes { keep: 10 }), ..Default::default() };
    AdaptiveFilter::new(&demos, "MeanBothW5/MeanBothW5".parse().unwrap(), options).unwrap().with_rule(rule)
}

/// Drives `steps` executed steps of +0.1 (cost `costs[t]`), then ends with `outcome`.
fn episode(f: &mut AdaptiveFilter, costs: &[f64], outcome: Outcome) {
    let mut x = 0.0;
    f.begin(&[x, 1.0]);
    for (t, &c) in costs.iter().enumerate() {
        f.push(&[x, 1.0], &[0.1]).unwrap();
        x += 0.1;
        f.executed(&[0.1], 1.0, &[x, 1.0]).unwrap();
        let last = t + 1 == costs.len();
        f.real_step(c, last && outcome == Outcome::Crashed);
    }
    f.end(outcome).unwrap();
}

/// The lengths of the own episodes a filter saved, unsafe ones last.
fn own_lengths(f: &AdaptiveFilter) -> Vec<(usize, bool)> {
    let dir = tempfile::tempdir().unwrap();
    f.save(dir.path()).unwrap();
    let set = EpisodeSet::load(dir.path().join("own_episodes.npz")).unwrap();
    set.episodes().map(|e| (e.len(), e.crashed)).collect()
}

#[test]
fn own_episodes_join_by_the_episode_cost_limit() {
    let mut f = filter(UnsafeRule::CostAbove(2.0));
    // The horizon of the safe demonstrations is 10 steps.
    // Passes the limit on step 4 (costs 1, 0, 1, 1: 3 > 2), then goes on to the horizon: unsafe,
    // kept up to that step.
    episode(&mut f, &[1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0], Outcome::Truncated);
    assert_eq!(f.own_counts(), (0, 1));
    // Reaches the horizon with cost 2, not above the limit: safe.
    episode(&mut f, &[1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], Outcome::Truncated);
    assert_eq!(f.own_counts(), (1, 1));
    // Falls (terminated) under the limit: no violation, and not safe either.
    episode(&mut f, &[0.0, 1.0, 0.0], Outcome::Crashed);
    assert_eq!(f.own_counts(), (1, 1));
    // Passes the limit, then DEFENDER ends it: the violation happened, it is unsafe.
    episode(&mut f, &[1.0, 1.0, 1.0, 0.0], Outcome::Filtered);
    assert_eq!(f.own_counts(), (1, 2));
    assert_eq!(own_lengths(&f), vec![(10, false), (4, true), (3, true)]);
}

#[test]
fn the_crash_rule_still_counts_terminations_only() {
    let mut f = filter(UnsafeRule::Crash);
    // Costs do not matter: this episode reaches the horizon, so it is safe, whole.
    episode(&mut f, &[1.0; 10], Outcome::Truncated);
    episode(&mut f, &[0.0, 0.0, 0.0], Outcome::Crashed);
    assert_eq!(own_lengths(&f), vec![(10, false), (3, true)]);
}

#[test]
fn demonstrations_of_another_rule_are_refused_naming_the_setting() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut with_limit = config("MeanBothW5/MeanBothW5");
    with_limit.episode_cost_limit = Some(2.0);
    let err =
        DefenderEnv::new(Line::new(), &line_demos(), with_limit.clone(), &mut rng).unwrap_err().to_string();
    assert!(err.contains("carry no costs") && err.contains("episode_cost_limit"), "{err}");
    assert!(DefenderEnv::new(Line::new(), &cost_labelled(), with_limit.clone(), &mut rng).is_ok());
    let err = DefenderEnv::new(Line::new(), &cost_labelled(), config("MeanBothW5/MeanBothW5"), &mut rng)
        .unwrap_err()
        .to_string();
    assert!(err.contains("counts crashes"), "{err}");
    with_limit.episode_cost_limit = Some(0.0);
    let err = DefenderEnv::new(Line::new(), &cost_labelled(), with_limit, &mut rng).unwrap_err().to_string();
    assert!(err.contains("episode_cost_limit = 0"), "{err}");
}

/// The line where every executed step costs `per_step` (a velocity task in miniature).
struct CostlyLine(Line, f64);

impl defender_rl::Env for CostlyLine {
    fn id(&self) -> &str {
        self.0.id()
    }
    fn observation_space(&self) -> &defender_rl::BoxSpace {
        self.0.observation_space()
    }
    fn action_space(&self) -> &defender_rl::BoxSpace {
        self.0.action_space()
    }
    fn reset(&mut self, seed: Option<u64>) -> defender_rl::Result<Vec<f64>> {
        self.0.reset(seed)
    }
    fn step(&mut self, action: &[f64]) -> defender_rl::Result<defender_rl::Step> {
        let mut s = self.0.step(action)?;
        s.cost = self.1;
        s.terminated = false;
        Ok(s)
    }
}

/// Runs right until the filter stops the episode; the executed steps' summed cost and the
/// filtered step.
fn run_until_filtered(env: &mut impl defender_rl::Env) -> (f64, defender_rl::Step) {
    env.reset(None).unwrap();
    let mut cost = 0.0;
    for _ in 0..20 {
        let s = env.step(&[1.0]).unwrap();
        if s.info.filtered {
            return (cost, s);
        }
        cost += s.cost;
    }
    panic!("the run to the right was never filtered");
}

#[test]
fn a_filtered_step_charges_the_learner_the_violation_it_prevented_and_records_nothing() {
    use defender::{DefenderConfig, FilteredCost};
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let charge = DefenderConfig { filtered_cost: FilteredCost::Violation, ..config("MinBothW5/MinBothW5") };
    // A crash task: the violation prevented is a crash, 1.
    let mut env = DefenderEnv::new(Line::new(), &line_demos(), charge.clone(), &mut rng).unwrap();
    let (_, s) = run_until_filtered(&mut env);
    assert_eq!((s.cost, s.info.charged_cost), (0.0, 1.0), "nothing reached the task; the learner pays 1");
    // SPEC's filtered step charges nothing.
    let mut env =
        DefenderEnv::new(Line::new(), &line_demos(), config("MinBothW5/MinBothW5"), &mut rng).unwrap();
    let (_, s) = run_until_filtered(&mut env);
    assert_eq!((s.cost, s.info.charged_cost), (0.0, 0.0));
    // A cost task with limit 2, each executed step costing 0.5: topped up to 2 + 1.
    let cost_task = DefenderConfig { episode_cost_limit: Some(2.0), ..charge };
    let mut env =
        DefenderEnv::new(CostlyLine(Line::new(), 0.5), &cost_labelled(), cost_task, &mut rng).unwrap();
    let (spent, s) = run_until_filtered(&mut env);
    assert!(spent > 0.0 && spent < 3.0, "{spent}");
    assert_eq!(s.cost, 0.0);
    assert!((spent + s.info.charged_cost - 3.0).abs() < 1e-12, "{spent} + {}", s.info.charged_cost);
    // The next episode starts from nothing spent.
    let (spent2, s2) = run_until_filtered(&mut env);
    assert_eq!((spent2, s2.info.charged_cost), (spent, s.info.charged_cost));
}
