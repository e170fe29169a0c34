//! Safe demonstrations against the task's horizon. A safe demonstration stands for a run that does
//! not crash on the task being trained: one cut short by a shorter time limit (recorded with
//! another `max_episode_steps`, or by a collector's own cap) did not crash, but never showed a
//! whole episode of the task. `defender train` warns when the safe demonstrations it uses end
//! before the task's horizon, naming how many and their lengths (as `DefenderWrapper` does in
//! Python; docs/decisions-python.md).

use defender::EpisodeSet;

/// The lengths of the safe episodes among `(crashed, length)` (the first `num_demos` safe ones
/// when given, as a run uses them) that are shorter than `horizon`.
fn short_lengths(
    episodes: impl Iterator<Item = (bool, usize)>,
    horizon: usize,
    num_demos: Option<usize>,
) -> Vec<usize> {
    episodes
        .filter(|&(crashed, _)| !crashed)
        .take(num_demos.unwrap_or(usize::MAX))
        .map(|(_, len)| len)
        .filter(|&len| len < horizon)
        .collect()
}

/// The warning for `demos` used with `num_demos` per group on a task of `horizon` steps, if any
/// safe one used is shorter.
pub fn warning(demos: &EpisodeSet, horizon: usize, num_demos: Option<usize>) -> Option<String> {
    let mut short = short_lengths(demos.episodes().map(|e| (e.crashed, e.rew.len())), horizon, num_demos);
    if short.is_empty() {
        return None;
    }
    let n = short.len();
    short.sort_unstable();
    let shown: Vec<String> = short.iter().take(10).map(ToString::to_string).collect();
    Some(format!(
        "{n} safe demonstration(s) end before the task's horizon of {horizon} steps (lengths {}{}): they did \
         not crash, but show less than a whole episode of the task; record safe demonstrations that reach \
         the horizon, or leave those out",
        shown.join(", "),
        if n > 10 { ", ..." } else { "" }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_safe_ones_used_and_shorter_count() {
        let eps = [(false, 40), (true, 10), (false, 1000), (false, 39)];
        assert_eq!(short_lengths(eps.into_iter(), 1000, None), [40, 39]);
        assert_eq!(short_lengths(eps.into_iter(), 1000, Some(1)), [40]);
        assert_eq!(short_lengths(eps.into_iter(), 39, None), Vec::<usize>::new());
    }

    #[test]
    fn the_shipped_sets_reach_their_horizon() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/demos");
        for (task, horizon) in
            [("Hopper-v5", 1000), ("InvertedDoublePendulum-v5", 1000), ("Walker2d-v5", 1000)]
        {
            let demos = EpisodeSet::load(root.join(format!("{task}.npz"))).unwrap();
            assert_eq!(warning(&demos, horizon, None), None, "{task}");
            let w = warning(&demos, horizon + 1, Some(2)).unwrap();
            assert!(w.starts_with("2 safe demonstration(s)"), "{w}");
        }
    }
}
