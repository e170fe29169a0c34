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
