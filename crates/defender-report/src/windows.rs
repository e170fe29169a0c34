//! For reading long budgets: per task, the crash rate over a rolling window of environment steps
//! beside the evaluation return, one curve per configuration (mean over seeds, shaded min-max).
//! The cumulative crash rate (`*_crash`) hides a run that stops crashing late, since its early
//! crashes stay in the average; the rate over the last W steps shows when it changes, and the
//! evaluation return beside it shows what the agent gave up for it (standing still, say). The
//! same reading as scripts/crash_by_window.py, rolling instead of in fixed blocks.

use plotters::coord::Shift;
use plotters::prelude::*;

use defender_rl::Outcome;

use crate::curves::{Chart, draw};
use crate::figure::{FONT_NAME, Figure};
use crate::run::{EpisodeRow, Run};

/// The crash rate of one run (its training episodes, in order) over a rolling window of `window` environment steps: at the end of
/// each episode that ends at step `x >= window`, crashed / all episodes ending in `(x - window,
/// x]`, in % (filtered episodes count in the denominator, as in % Crash). Empty when the run ends
/// before `window` steps.
pub(crate) fn crash_rate(episodes: &[EpisodeRow], window: u64) -> (Vec<f64>, Vec<f64>) {
    let window = window.max(1);
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    // Two pointers over the episodes in step order: `start` is the first inside the window.
    let (mut start, mut crashed) = (0usize, 0usize);
    for (end, episode) in episodes.iter().enumerate() {
        crashed += usize::from(episode.outcome == Outcome::Crashed);
        let x = episode.total_steps;
        while episodes[start].total_steps + window <= x {
            crashed -= usize::from(episodes[start].outcome == Outcome::Crashed);
            start += 1;
        }
        if x >= window {
            xs.push(x as f64);
            ys.push(100.0 * crashed as f64 / (end + 1 - start) as f64);
        }
    }
    (xs, ys)
}

/// The default window of a group of runs: a tenth of the steps they reach, to two significant
/// digits (300,000 steps: 30,000; 30,000 steps: 3,000), so that each window holds tens of
/// episodes and a run has ten windows' worth of curve.
pub(crate) fn default_window(runs: &[&Run]) -> u64 {
    let end = runs.iter().filter_map(|r| r.episodes.last()).map(|e| e.total_steps).max().unwrap_or(0);
    round2(end / 10).max(1)
}

/// `n` rounded to two significant digits.
fn round2(n: u64) -> u64 {
    let mut scale = 1;
    while n / scale >= 100 {
        scale *= 10;
    }
    (n + scale / 2) / scale * scale
}

/// The two panels side by side, under one title.
pub(crate) struct Windows {
    pub(crate) title: String,
    /// The rolling crash rate.
    pub(crate) crash: Chart,
    /// The evaluation return.
    pub(crate) eval: Chart,
}

impl Figure for Windows {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
        root.fill(&WHITE).map_err(e)?;
        let body = root.titled(&self.title, (FONT_NAME, 24)).map_err(e)?;
        let panels = body.split_evenly((1, 2));
        draw(&panels[0], &self.crash)?;
        draw(&panels[1], &self.eval)?;
        root.present().map_err(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn episode(total_steps: u64, outcome: Outcome) -> EpisodeRow {
        EpisodeRow { episode: 0, total_steps, ret: 0.0, length: 0, outcome, wall_seconds: 0.0, cost: 0.0 }
    }

    #[test]
    fn the_crash_rate_counts_the_episodes_ending_in_the_last_window_steps() {
        use Outcome::{Crashed as C, Filtered as F, Truncated as T};
        // Episodes end at steps 10, 20, 30, 45, 50, 100; window 30: (x - 30, x].
        let episodes: Vec<EpisodeRow> =
            [(10, C), (20, C), (30, F), (45, T), (50, C), (100, T)].map(|(s, o)| episode(s, o)).to_vec();
        let (xs, ys) = crash_rate(&episodes, 30);
        // At 30: 10, 20, 30 -> 2 of 3 crashed. At 45: 20, 30, 45 -> 1 of 3 (10 is out: 10 <= 15).
        // At 50: 30, 45, 50 -> 1 of 3 (20 <= 20 is out). At 100: only 100 -> 0 of 1.
        assert_eq!(xs, vec![30.0, 45.0, 50.0, 100.0]);
        let want = [200.0 / 3.0, 100.0 / 3.0, 100.0 / 3.0, 0.0];
        assert!(ys.iter().zip(want).all(|(y, w)| (y - w).abs() < 1e-12), "{ys:?}");
        // A run shorter than the window has no point; a zero window is one step.
        assert_eq!(crash_rate(&episodes, 101), (vec![], vec![]));
        assert_eq!(crash_rate(&episodes, 0).1, vec![100.0, 100.0, 0.0, 0.0, 100.0, 0.0]);
    }

    #[test]
    fn windows_round_to_two_digits() {
        assert_eq!(round2(30_000), 30_000);
        assert_eq!(round2(3_457), 3_500);
        assert_eq!(round2(99), 99);
        assert_eq!(round2(12_345_678), 12_000_000);
        assert_eq!(round2(0), 0);
    }
}
