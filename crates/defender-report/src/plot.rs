//! Learning curves as PNG and SVG, drawn with `plotters` and an embedded font (no system font
//! library): per task, algorithm and budget, the bare algorithm against each DEFENDER strategy,
//! mean over seeds with a shaded min-max band; beside them, the trade-off of the final results
//! (`crate::tradeoff`). Both are [`Figure`]s, written by [`write_figure`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::error::{ReportError, Result, io_err};
use crate::io::write_atomic;
use defender_rl::{Budget, Outcome};

use crate::run::{DefenderSettings, Run};
use crate::stats::{interpolate, linspace, rolling_mean};
use crate::tradeoff;

/// DejaVu Sans (Bitstream Vera license, see assets/DejaVuSans-LICENSE.txt), so that text is drawn
/// the same everywhere without fontconfig or freetype.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
pub(crate) const FONT_NAME: &str = "sans-serif";

/// Options of [`draw_plots`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    /// Image width in pixels (PNG) or user units (SVG).
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Points of the common step grid onto which each seed's training curve is interpolated.
    pub grid_points: usize,
    /// The training-return curve is the rolling mean of this many episodes (1: raw returns).
    pub smoothing_episodes: usize,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self { width: 960, height: 600, grid_points: 200, smoothing_episodes: 10 }
    }
}

/// Which curve a plot shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PlotKind {
    /// (a) Training episode return vs environment steps (`*_return`).
    Return,
    /// (b) Cumulative crash rate, % of the episodes so far that crashed, vs steps (`*_crash`).
    CrashRate,
    /// (c) Evaluation return (`eval.csv`) vs steps (`*_eval`).
    Evaluation,
}

impl PlotKind {
    /// All kinds, in file order.
    pub const ALL: [PlotKind; 3] = [PlotKind::Return, PlotKind::CrashRate, PlotKind::Evaluation];

    /// The file-name suffix.
    pub fn suffix(self) -> &'static str {
        match self {
            PlotKind::Return => "return",
            PlotKind::CrashRate => "crash",
            PlotKind::Evaluation => "eval",
        }
    }
}

/// What [`draw_plots`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plots {
    /// The files written (a PNG and an SVG per plot).
    pub files: Vec<PathBuf>,
    /// Curves that could not be drawn, and why.
    pub notes: Vec<String>,
}

/// A curve: mean over seeds on a step grid, with the min and max over seeds.
#[derive(Debug, Clone, PartialEq)]
struct Band {
    label: String,
    /// Index into the palette; 0 is the bare algorithm (black).
    color: usize,
    xs: Vec<f64>,
    mean: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
}

struct Chart {
    title: String,
    y_label: String,
    /// The y axis starts exactly here (0 for percentages: a rate is read against zero, and
    /// two plots of the same kind compare at a glance).
    y_from: Option<f64>,
    markers: bool,
    bands: Vec<Band>,
}

/// Draws the learning curves of `runs` into `dir` (created if needed): for each task x algorithm
/// (x budget, when a task and algorithm were run with several), `{env}_{algo}_return`,
/// `{env}_{algo}_crash` and `{env}_{algo}_eval`, and the final results' trade-off
/// `{env}_{algo}_tradeoff` (% Crash against Acc Reward, one point per configuration), each as
/// `.png` and `.svg`.
///
/// Each seed's curve is interpolated linearly onto a grid over the steps all seeds reached
/// (from the latest first point to the earliest last point), so the mean never mixes a
/// different number of seeds; the band is the min and max over seeds.
///
/// # Errors
///
/// [`ReportError::Io`] when `dir` cannot be created or a file written, [`ReportError::Plot`] when
/// drawing fails.
pub fn draw_plots(runs: &[Run], dir: impl AsRef<Path>, options: &PlotOptions) -> Result<Plots> {
    let dir = dir.as_ref();
    register_font();
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    type Key<'a> = (&'a str, &'a str, Budget);
    let mut groups: BTreeMap<Key<'_>, BTreeMap<Option<&DefenderSettings>, Vec<&Run>>> = BTreeMap::new();
    for run in runs {
        let c = &run.config;
        groups
            .entry((c.env.as_str(), c.algo.as_str(), c.budget))
            .or_default()
            .entry(c.filter.as_ref())
            .or_default()
            .push(run);
    }
    let budgets: BTreeMap<(&str, &str), usize> = groups.keys().fold(BTreeMap::new(), |mut m, (e, a, _)| {
        *m.entry((*e, *a)).or_default() += 1;
        m
    });
    let mut plots = Plots::default();
    for ((env, algo, budget), by_filter) in &groups {
        let mut stem = format!("{}_{}", file_safe(env), file_safe(algo));
        if budgets.get(&(*env, *algo)).copied().unwrap_or(0) > 1 {
            stem.push_str(&format!("_{}", file_safe(&budget.to_string())));
        }
        let modes: BTreeSet<_> = by_filter.keys().flatten().map(|f| f.mode).collect();
        let demos: BTreeSet<_> = by_filter.keys().flatten().map(|f| f.num_demos).collect();
        let label = |filter: Option<&DefenderSettings>, seeds: usize| {
            let mut text = match filter {
                None => format!("{} (bare)", algo.to_uppercase()),
                Some(f) => f.name(),
            };
            if let Some(f) = filter {
                if modes.len() > 1 {
                    text.push_str(&format!(", {}", f.mode));
                }
                if demos.len() > 1 {
                    text.push_str(&format!(", {} demos", f.num_demos.map_or("?".into(), |n| n.to_string())));
                }
            }
            text.push_str(&format!(" [{seeds} seed{}]", if seeds == 1 { "" } else { "s" }));
            text
        };
        // Colour i of the curves is the same strategy's colour in the trade-off.
        let color_of = |i: usize, filter: Option<&DefenderSettings>| {
            if filter.is_none() { 0 } else { i + usize::from(!by_filter.contains_key(&None)) }
        };
        for kind in PlotKind::ALL {
            let mut bands = Vec::new();
            for (i, (filter, seeds)) in by_filter.iter().enumerate() {
                let curves: Vec<(Vec<f64>, Vec<f64>)> =
                    seeds.iter().map(|r| curve(r, kind, options)).collect();
                let grid = match kind {
                    PlotKind::Evaluation => Grid::Union,
                    _ => Grid::Linear(options.grid_points),
                };
                let label = label(*filter, seeds.len());
                match band(&curves, grid) {
                    // BTreeMap order puts the bare run (None) first: colour 0.
                    Some((xs, mean, lo, hi)) => {
                        bands.push(Band { label, color: color_of(i, *filter), xs, mean, lo, hi });
                    }
                    None => plots.notes.push(format!(
                        "{stem}_{}: {label}: the seeds' {} share no step range; not drawn",
                        kind.suffix(),
                        kind.suffix()
                    )),
                }
            }
            if bands.is_empty() {
                continue;
            }
            let chart = Chart {
                title: title(env, algo, *budget, kind),
                y_label: y_label(kind, options),
                y_from: (kind == PlotKind::CrashRate).then_some(0.0),
                markers: kind == PlotKind::Evaluation,
                bands,
            };
            let base = dir.join(format!("{stem}_{}", kind.suffix()));
            plots.files.extend(write_figure(&chart, &base, options)?);
        }
        let points = by_filter
            .iter()
            .enumerate()
            .map(|(i, (filter, seeds))| {
                tradeoff::Point::of(label(*filter, seeds.len()), color_of(i, *filter), seeds)
            })
            .collect();
        let figure = tradeoff::Tradeoff::new(
            format!("{env}, {}, {budget}: final results", algo.to_uppercase()),
            points,
        );
        plots.files.extend(write_figure(&figure, &dir.join(format!("{stem}_tradeoff")), options)?);
    }
    Ok(plots)
}

pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in and known good; a failure would only mean no text, not a panic.
        let _ = plotters::style::register_font(FONT_NAME, FontStyle::Normal, FONT);
    });
}

pub(crate) fn file_safe(text: &str) -> String {
    text.chars().map(|c| if c.is_ascii_alphanumeric() || "-_.".contains(c) { c } else { '_' }).collect()
}

fn title(env: &str, algo: &str, budget: Budget, kind: PlotKind) -> String {
    let what = match kind {
        PlotKind::Return => "training episode return",
        PlotKind::CrashRate => "cumulative crash rate",
        PlotKind::Evaluation => "evaluation return",
    };
    format!("{env}, {}, {budget}: {what}", algo.to_uppercase())
}

fn y_label(kind: PlotKind, options: &PlotOptions) -> String {
    match kind {
        PlotKind::Return if options.smoothing_episodes > 1 => {
            format!("episode return (mean of last {} episodes)", options.smoothing_episodes)
        }
        PlotKind::Return => "episode return".into(),
        PlotKind::CrashRate => "crashed episodes so far (%)".into(),
        PlotKind::Evaluation => "mean evaluation return".into(),
    }
}

/// One seed's curve: x = environment steps.
fn curve(run: &Run, kind: PlotKind, options: &PlotOptions) -> (Vec<f64>, Vec<f64>) {
    let steps = || run.episodes.iter().map(|e| e.total_steps as f64).collect::<Vec<_>>();
    match kind {
        PlotKind::Return => {
            let returns: Vec<f64> = run.episodes.iter().map(|e| e.ret).collect();
            (steps(), rolling_mean(&returns, options.smoothing_episodes))
        }
        PlotKind::CrashRate => {
            let mut crashed = 0usize;
            let rate = run
                .episodes
                .iter()
                .enumerate()
                .map(|(i, e)| {
                    crashed += usize::from(e.outcome == Outcome::Crashed);
                    crashed as f64 * 100.0 / (i + 1) as f64
                })
                .collect();
            (steps(), rate)
        }
        PlotKind::Evaluation => (
            run.evaluations.iter().map(|e| e.total_steps as f64).collect(),
            run.evaluations.iter().map(|e| e.mean_return).collect(),
        ),
    }
}

#[derive(Debug, Clone, Copy)]
enum Grid {
    /// This many evenly spaced points.
    Linear(usize),
    /// The steps at which any seed has a point (evaluations are usually at the same steps).
    Union,
}

type BandData = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// Mean, min and max over seeds on a common grid within the steps all seeds cover; `None` when a
/// seed has no point or the seeds share no step range.
fn band(curves: &[(Vec<f64>, Vec<f64>)], grid: Grid) -> Option<BandData> {
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

/// Tableau 10; the bare algorithm is black.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

pub(crate) fn color(index: usize) -> RGBColor {
    if index == 0 { BLACK } else { PALETTE[(index - 1) % PALETTE.len()] }
}

/// Something drawn the same way on any `plotters` backend (PNG pixels, SVG text).
pub(crate) trait Figure {
    /// Draws the figure on `root`.
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static;
}

impl Figure for Chart {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        draw(root, self)
    }
}

/// Draws `figure` as `base.png` and `base.svg`, each written atomically.
pub(crate) fn write_figure(figure: &impl Figure, base: &Path, options: &PlotOptions) -> Result<Vec<PathBuf>> {
    let (w, h) = (options.width, options.height);
    let png_path = base.with_extension("png");
    let plot_err = |path: &Path| {
        let path = path.to_path_buf();
        move |message: String| ReportError::Plot { path, message }
    };
    let mut pixels = vec![0u8; w as usize * h as usize * 3];
    {
        let backend =
            BitMapBackend::<plotters::backend::RGBPixel>::with_buffer_and_format(&mut pixels, (w, h))
                .map_err(|e| plot_err(&png_path)(e.to_string()))?;
        figure.draw(backend.into_drawing_area()).map_err(plot_err(&png_path))?;
    }
    let mut png_bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut png_bytes, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| plot_err(&png_path)(e.to_string()))?;
        writer.write_image_data(&pixels).map_err(|e| plot_err(&png_path)(e.to_string()))?;
        writer.finish().map_err(|e| plot_err(&png_path)(e.to_string()))?;
    }
    write_atomic(&png_path, &png_bytes)?;

    let svg_path = base.with_extension("svg");
    let mut svg = String::new();
    {
        let backend = SVGBackend::with_string(&mut svg, (w, h));
        figure.draw(backend.into_drawing_area()).map_err(plot_err(&svg_path))?;
    }
    write_atomic(&svg_path, svg.as_bytes())?;
    Ok(vec![png_path, svg_path])
}

/// Formats a step count for an axis: 500, 20k, 1.5M.
fn steps_label(x: f64) -> String {
    let a = x.abs();
    let (value, unit) = if a >= 1e6 {
        (x / 1e6, "M")
    } else if a >= 1e3 {
        (x / 1e3, "k")
    } else {
        (x, "")
    };
    let text = format!("{value:.1}");
    let text = text.strip_suffix(".0").unwrap_or(&text);
    format!("{text}{unit}")
}

pub(crate) fn range(lo: f64, hi: f64, pad_below: f64, pad_above: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 0.0 {
        (lo - span * pad_below, hi + span * pad_above)
    } else {
        let d = lo.abs().max(1.0) * 0.1;
        (lo - d, hi + d * 3.0)
    }
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, chart: &Chart) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
    root.fill(&WHITE).map_err(e)?;
    let fold = |f: fn(&Band) -> &Vec<f64>, init: f64, op: fn(f64, f64) -> f64| {
        chart.bands.iter().flat_map(|b| f(b).iter().copied()).fold(init, op)
    };
    let (x0, x1) = range(
        fold(|b| &b.xs, f64::INFINITY, f64::min),
        fold(|b| &b.xs, f64::NEG_INFINITY, f64::max),
        0.0,
        0.0,
    );
    // Head room above the curves for the legend.
    let (mut y0, y1) = range(
        fold(|b| &b.lo, f64::INFINITY, f64::min),
        fold(|b| &b.hi, f64::NEG_INFINITY, f64::max),
        0.05,
        0.35,
    );
    if let Some(from) = chart.y_from {
        y0 = from;
    }
    // As many decimals as the axis needs: 4000, 12.5, 0.25.
    let y_decimals = match y1 - y0 {
        span if span >= 20.0 => 0,
        span if span >= 2.0 => 1,
        _ => 2,
    };
    let mut plot = ChartBuilder::on(&root)
        .caption(&chart.title, (FONT_NAME, 22))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(75)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(e)?;
    plot.configure_mesh()
        .x_desc("environment steps")
        .y_desc(chart.y_label.as_str())
        .x_label_formatter(&|x| steps_label(*x))
        .y_label_formatter(&|y| format!("{y:.y_decimals$}"))
        .label_style((FONT_NAME, 14))
        .axis_desc_style((FONT_NAME, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
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
    finish(&mut plot, &root, SeriesLabelPosition::UpperLeft)
}

/// The chart type of every figure: f64 on both axes.
pub(crate) type Plot<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws the legend at `position`, in the style all figures share, and presents `root`.
pub(crate) fn finish<'a, DB: DrawingBackend + 'a>(
    plot: &mut Plot<'a, DB>,
    root: &DrawingArea<DB, Shift>,
    position: SeriesLabelPosition,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
    plot.configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT_NAME, 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
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

    #[test]
    fn step_labels_are_short() {
        assert_eq!(steps_label(500.0), "500");
        assert_eq!(steps_label(20_000.0), "20k");
        assert_eq!(steps_label(1_500_000.0), "1.5M");
        assert_eq!(file_safe("Hopper-v5 (a/b)"), "Hopper-v5__a_b_");
    }
}
