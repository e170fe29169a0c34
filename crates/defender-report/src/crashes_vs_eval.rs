//! What each arm bought with its crashes, as the safe-RL field reads it: per task and algorithm,
//! every seed's total crashes over the run (x) against its mean of the last 10 evaluations (y),
//! a small point per seed and the arm's mean as a ring. Better is up and to the left. Unlike the
//! trade-off figure (% Crash, which the filter's own episodes dilute), both axes count over the
//! same budget.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::figure::{Axes, Figure, axes, color, finish, range, whole};
use crate::run::Run;

/// One arm: its legend label, its colour in the curves, and its seeds' `(crashes, last-10 eval)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Arm {
    label: String,
    color: usize,
    seeds: Vec<(f64, f64)>,
}

impl Arm {
    pub(crate) fn of(label: String, color: usize, runs: &[&Run]) -> Arm {
        let seeds = runs.iter().map(|r| (r.violations().crashes as f64, r.last_evaluations())).collect();
        Arm { label, color, seeds }
    }

    fn mean(&self) -> (f64, f64) {
        let n = self.seeds.len().max(1) as f64;
        let (x, y) = self.seeds.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
        (x / n, y / n)
    }
}

/// The figure of one task and algorithm.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CrashesVsEval {
    pub(crate) title: String,
    pub(crate) arms: Vec<Arm>,
}

impl Figure for CrashesVsEval {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
        let all = || self.arms.iter().flat_map(|a| a.seeds.iter().copied());
        let x_max = all().map(|p| p.0).fold(1.0, f64::max);
        let (y_lo, y_hi) =
            all().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.1), h.max(p.1)));
        let (y0, y1) = range(y_lo, y_hi, 0.05, 0.45);
        let mut plot = axes(
            &root,
            &Axes {
                title: &self.title,
                x: 0.0..x_max * 1.05,
                y: y0..y1,
                x_desc: "crashes over the run (training episodes that crashed)",
                y_desc: "mean of the last 10 evaluations",
                x_ticks: &whole,
                y_ticks: &whole,
            },
        )?;
        for arm in &self.arms {
            let c = color(arm.color);
            plot.draw_series(arm.seeds.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(e)?;
            let ring = c.stroke_width(3);
            plot.draw_series(std::iter::once(Circle::new(arm.mean(), 10, ring)))
                .map_err(e)?
                .label(format!("{} (ring: mean)", arm.label))
                .legend(move |(x, y)| Circle::new((x + 12, y), 6, ring));
        }
        finish(&mut plot, &root, SeriesLabelPosition::UpperRight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_is_over_the_seeds() {
        let arm = Arm { label: "a".into(), color: 0, seeds: vec![(10.0, 100.0), (30.0, 300.0)] };
        assert_eq!(arm.mean(), (20.0, 200.0));
    }
}
