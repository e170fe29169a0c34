//! A line chart of curves over environment steps, each the mean over seeds with a shaded
//! min-max band ([`Band`]), and [`band`], which puts the seeds' curves on one step grid.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use crate::figure::{Axes, Figure, axes, color, legend, range, steps_label};
use crate::stats::{interpolate, linspace};

/// A curve: mean over seeds on a step grid, with the min and max over seeds.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Band {
    pub(crate) label: String,
    /// Index into the palette; 0 is the bare algorithm (black).
    pub(crate) color: usize,
    pub(crate) xs: Vec<f64>,
    pub(crate) mean: Vec<f64>,
    pub(crate) lo: Vec<f64>,
    pub(crate) hi: Vec<f64>,
}

/// A line chart: the curves of one quantity, one [`Band`] per configuration.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Chart {
    pub(crate) title: String,
    pub(crate) y_label: String,
    /// The y axis starts exactly here (0 for percentages: a rate is read against zero, and
    /// two plots of the same kind compare at a glance).
    pub(crate) y_from: Option<f64>,
    /// The x axis starts here when it is left of the curves (panels side by side share their
    /// steps axis this way).
    pub(crate) x_from: Option<f64>,
    pub(crate) markers: bool,
    pub(crate) bands: Vec<Band>,
    /// A level the curves are read against (a task's episode cost limit), drawn as a dashed
    /// horizontal line with this legend label; the y axis reaches it.
    pub(crate) limit: Option<(f64, String)>,
}

/// The step grid the seeds' curves are put on.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Grid {
    /// This many evenly spaced points.
    Linear(usize),
    /// The steps at which any seed has a point (evaluations are usually at the same steps).
    Union,
}

pub(crate) type BandData = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// Mean, min and max over seeds on a common grid within the steps all seeds cover; `None` when a
/// seed has no point or the seeds share no step range.
pub(crate) fn band(curves: &[(Vec<f64>, Vec<f64>)], grid: Grid) -> Option<BandData> {
    if curves.is_empty() || curves.iter().any(|(xs, _)| xs.is_empty()) {
        return None;
    }
    let start = curves.iter().map(|(xs, _)| xs[0]).fold(f64::NEG_INFINITY, f64::max);
    let end = curves.iter().map(|(xs, _)| xs[xs.len() - 1]).fold(f64::INFINITY, f64::min);
    if start > end {
        return None;
    }
    let xs = match grid {
        Grid::Linear(points) => linspace(start, end, points),
        Grid::Union => {
            let mut all: Vec<f64> = curves
                .iter()
                .flat_map(|(xs, _)| xs.iter().copied())
                .filter(|x| (start..=end).contains(x))
                .collect();
            all.sort_by(f64::total_cmp);
            all.dedup();
            all
        }
    };
    let mut mean = Vec::with_capacity(xs.len());
    let mut lo = Vec::with_capacity(xs.len());
    let mut hi = Vec::with_capacity(xs.len());
    for &x in &xs {
        let values: Vec<f64> = curves.iter().map(|(cx, cy)| interpolate(cx, cy, x)).collect();
        mean.push(values.iter().sum::<f64>() / values.len() as f64);
        lo.push(values.iter().copied().fold(f64::INFINITY, f64::min));
        hi.push(values.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    }
    Some((xs, mean, lo, hi))
}

impl Figure for Chart {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        draw(&root, self)?;
        root.present().map_err(|e| e.to_string())
    }
}

/// Draws `chart` on `root` (a whole figure or one panel of it) without presenting it.
pub(crate) fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, chart: &Chart) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
    let fold = |f: fn(&Band) -> &Vec<f64>, init: f64, op: fn(f64, f64) -> f64| {
        chart.bands.iter().flat_map(|b| f(b).iter().copied()).fold(init, op)
    };
    let (mut x0, x1) = range(
        fold(|b| &b.xs, f64::INFINITY, f64::min),
        fold(|b| &b.xs, f64::NEG_INFINITY, f64::max),
        0.0,
        0.0,
    );
    // Head room above the curves for the legend.
    let level = chart.limit.as_ref().map(|(y, _)| *y);
    let (mut y0, y1) = range(
        fold(|b| &b.lo, level.unwrap_or(f64::INFINITY), f64::min),
        fold(|b| &b.hi, level.unwrap_or(f64::NEG_INFINITY), f64::max),
        0.05,
        0.35,
    );
    if let Some(from) = chart.y_from {
        y0 = from;
    }
    if let Some(from) = chart.x_from.filter(|&from| from < x0) {
        x0 = from;
    }
    // As many decimals as the axis needs: 4000, 12.5, 0.25.
    let y_decimals = match y1 - y0 {
        span if span >= 20.0 => 0,
        span if span >= 2.0 => 1,
        _ => 2,
    };
    let y_ticks = |y: &f64| format!("{y:.y_decimals$}");
    let mut plot = axes(
        root,
        &Axes {
            title: &chart.title,
            x: x0..x1,
            y: y0..y1,
            x_desc: "environment steps",
            y_desc: &chart.y_label,
            x_ticks: &|x| steps_label(*x),
            y_ticks: &y_ticks,
        },
    )?;
    for band in &chart.bands {
        let c = color(band.color);
        if band.xs.len() > 1 {
            let outline: Vec<(f64, f64)> = band
                .xs
                .iter()
                .copied()
                .zip(band.lo.iter().copied())
                .chain(band.xs.iter().copied().zip(band.hi.iter().copied()).rev())
                .collect();
            plot.draw_series(std::iter::once(Polygon::new(outline, c.mix(0.18).filled()))).map_err(e)?;
        } else {
            let pairs = band.xs.iter().zip(band.lo.iter().zip(&band.hi));
            plot.draw_series(
                pairs.map(|(&x, (&lo, &hi))| PathElement::new(vec![(x, lo), (x, hi)], c.stroke_width(2))),
            )
            .map_err(e)?;
        }
    }
    for band in &chart.bands {
        let c = color(band.color);
        let points: Vec<(f64, f64)> = band.xs.iter().copied().zip(band.mean.iter().copied()).collect();
        plot.draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
            .map_err(e)?
            .label(band.label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3)));
        if chart.markers || points.len() == 1 {
            plot.draw_series(points.iter().map(|&p| Circle::new(p, 4, c.filled()))).map_err(e)?;
        }
    }
    if let Some((y, label)) = &chart.limit {
        let style = RGBColor(90, 90, 90).stroke_width(2);
        let line = DashedPathElement::new(vec![(x0, *y), (x1, *y)], 10, 6, style);
        plot.draw_series(std::iter::once(line))
            .map_err(e)?
            .label(label.as_str())
            .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 24, y)], 6, 4, style));
    }
    legend(&mut plot, SeriesLabelPosition::UpperLeft)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_interpolates_on_the_shared_step_range() {
        // Seed A: 0..100, seed B: 50..150; shared range 50..100.
        let curves = vec![(vec![0.0, 100.0], vec![0.0, 100.0]), (vec![50.0, 150.0], vec![0.0, 10.0])];
        let (xs, mean, lo, hi) = band(&curves, Grid::Linear(3)).unwrap();
        assert_eq!(xs, vec![50.0, 75.0, 100.0]);
        // A: 50, 75, 100; B: 0, 2.5, 5.
        assert_eq!(mean, vec![25.0, 38.75, 52.5]);
        assert_eq!(lo, vec![0.0, 2.5, 5.0]);
        assert_eq!(hi, vec![50.0, 75.0, 100.0]);
        let disjoint = vec![(vec![0.0, 1.0], vec![0.0, 1.0]), (vec![2.0, 3.0], vec![0.0, 1.0])];
        assert!(band(&disjoint, Grid::Linear(3)).is_none());
        let evals = vec![(vec![10.0, 20.0, 30.0], vec![1.0, 2.0, 3.0]), (vec![10.0, 20.0], vec![3.0, 4.0])];
        let (xs, mean, _, _) = band(&evals, Grid::Union).unwrap();
        assert_eq!((xs, mean), (vec![10.0, 20.0], vec![2.0, 3.0]));
    }
}
