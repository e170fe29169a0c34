//! The trade-off DEFENDER makes, as a figure: per task and algorithm, each configuration's final
//! results as one point, % Crash (x) against Acc Reward (y), mean over seeds with a standard
//! deviation bar each way. A filter that protects without costing the task sits left of the bare
//! algorithm and as high; the shaded corner is where a configuration has at most half the bare
//! algorithm's crashes and at least 90% of its Acc Reward (the bar `--strategy auto` is held to,
//! docs/results.md). The curves show how a run got there; this shows where it ended.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::figure::{Axes, Figure, axes, color, finish, range, whole};
use crate::run::Run;
use crate::stats::Stat;

/// One configuration: its legend label, its colour in the curves, and its results over seeds.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Point {
    label: String,
    /// Index into the curves' palette; 0 is the bare algorithm.
    color: usize,
    crash_pct: Stat,
    acc_reward: Stat,
}

impl Point {
    /// The point of a configuration run with `seeds` (at least one run).
    pub(crate) fn of(label: String, color: usize, seeds: &[&Run]) -> Option<Point> {
        let crash: Vec<f64> = seeds.iter().map(|r| r.summary.crash_pct).collect();
        let acc: Vec<f64> = seeds.iter().map(|r| r.acc_reward()).collect();
        Some(Point { label, color, crash_pct: Stat::of(&crash)?, acc_reward: Stat::of(&acc)? })
    }
}

/// The figure of one task and algorithm.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Tradeoff {
    title: String,
    points: Vec<Point>,
}

impl Tradeoff {
    pub(crate) fn new(title: String, points: Vec<Option<Point>>) -> Tradeoff {
        Tradeoff { title, points: points.into_iter().flatten().collect() }
    }

    /// The corner at most half the bare algorithm's % Crash and at least 90% of its Acc Reward,
    /// as (max % Crash, min Acc Reward); `None` without a bare point or when its Acc Reward is not
    /// positive (90% of a negative reward is no bar).
    fn target(&self) -> Option<(f64, f64)> {
        let bare = self.points.iter().find(|p| p.color == 0)?;
        (bare.acc_reward.mean > 0.0).then(|| (bare.crash_pct.mean / 2.0, 0.9 * bare.acc_reward.mean))
    }
}

impl Figure for Tradeoff {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
        let lo =
            self.points.iter().map(|p| p.acc_reward.mean - p.acc_reward.std).fold(f64::INFINITY, f64::min);
        let hi = self
            .points
            .iter()
            .map(|p| p.acc_reward.mean + p.acc_reward.std)
            .fold(f64::NEG_INFINITY, f64::max);
        let target = self.target();
        let lo = target.map_or(lo, |(_, acc)| lo.min(acc));
        // Head room above the points for the legend.
        let (y0, y1) = range(lo, hi, 0.05, 0.45);
        let mut plot = axes(
            &root,
            &Axes {
                title: &self.title,
                x: 0.0..105.0,
                y: y0..y1,
                x_desc: "% Crash: training episodes that crashed (%)",
                y_desc: "Acc Reward: final evaluation return",
                x_ticks: &whole,
                y_ticks: &whole,
            },
        )?;
        if let Some((crash, acc)) = target {
            let shade = RGBColor(44, 160, 44).mix(0.12);
            plot.draw_series(std::iter::once(Rectangle::new([(0.0, acc), (crash, y1)], shade.filled())))
                .map_err(e)?
                .label("≤ half the bare crashes, ≥ 90% of its Acc Reward")
                .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 24, y + 6)], shade.filled()));
        }
        for p in &self.points {
            let c = color(p.color);
            let (x, y) = (p.crash_pct.mean, p.acc_reward.mean);
            let (dx, dy) = (p.crash_pct.std, p.acc_reward.std);
            let bars = [vec![(x - dx, y), (x + dx, y)], vec![(x, y - dy), (x, y + dy)]];
            plot.draw_series(bars.into_iter().map(|b| PathElement::new(b, c.stroke_width(2)))).map_err(e)?;
            let style = if p.color == 0 { c.stroke_width(3) } else { c.filled() };
            let radius = if p.color == 0 { 9 } else { 6 };
            plot.draw_series(std::iter::once(Circle::new((x, y), radius, style)))
                .map_err(e)?
                .label(p.label.as_str())
                .legend(move |(x, y)| Circle::new((x + 12, y), 6, style));
        }
        // The bare algorithm's ring again on top, so that a strategy on the same spot cannot hide it.
        for p in self.points.iter().filter(|p| p.color == 0) {
            let ring = Circle::new((p.crash_pct.mean, p.acc_reward.mean), 9, BLACK.stroke_width(3));
            plot.draw_series(std::iter::once(ring)).map_err(e)?;
        }
        finish(&mut plot, &root, SeriesLabelPosition::UpperRight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(color: usize, crash: f64, acc: f64) -> Option<Point> {
        let stat = |v: f64| Stat { mean: v, std: 0.0, n: 1 };
        Some(Point { label: format!("p{color}"), color, crash_pct: stat(crash), acc_reward: stat(acc) })
    }

    #[test]
    fn the_target_corner_is_half_the_bare_crashes_and_ninety_percent_of_its_reward() {
        let t = Tradeoff::new("t".into(), vec![point(0, 80.0, 2000.0), point(1, 10.0, 1500.0)]);
        assert_eq!(t.target(), Some((40.0, 1800.0)));
        assert_eq!(Tradeoff::new("t".into(), vec![point(1, 10.0, 1500.0)]).target(), None, "no bare run");
        assert_eq!(Tradeoff::new("t".into(), vec![point(0, 80.0, -5.0)]).target(), None, "negative reward");
    }
}
