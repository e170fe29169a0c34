//! What every figure shares: the embedded font, the palette, the frame and axes ([`axes`]), the
//! legend's style, the axis formats, and [`write_figure`], which draws a [`Figure`] as PNG and
//! SVG. The figures themselves
//! are the learning curves (`crate::curves`, drawn by `crate::plot`), the trade-off
//! (`crate::tradeoff`) and the long-budget view (`crate::windows`); none of them imports another.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::error::{ReportError, Result};
use crate::io::write_atomic;

/// DejaVu Sans (Bitstream Vera license, see assets/DejaVuSans-LICENSE.txt), so that text is drawn
/// the same everywhere without fontconfig or freetype.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
pub(crate) const FONT_NAME: &str = "sans-serif";

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

/// `base` with `.ext` appended: a base may hold dots of its own (`margin0.02`), which
/// `Path::with_extension` would take for an extension and cut.
fn with_suffix(base: &Path, ext: &str) -> PathBuf {
    let mut name = base.as_os_str().to_owned();
    name.push(".");
    name.push(ext);
    PathBuf::from(name)
}

/// Draws `figure` as `base.png` and `base.svg`, `w` x `h` pixels, each written atomically.
pub(crate) fn write_figure(figure: &impl Figure, base: &Path, (w, h): (u32, u32)) -> Result<Vec<PathBuf>> {
    let png_path = with_suffix(base, "png");
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

    let svg_path = with_suffix(base, "svg");
    let mut svg = String::new();
    {
        let backend = SVGBackend::with_string(&mut svg, (w, h));
        figure.draw(backend.into_drawing_area()).map_err(plot_err(&svg_path))?;
    }
    write_atomic(&svg_path, svg.as_bytes())?;
    Ok(vec![png_path, svg_path])
}

/// Formats a step count for an axis: 500, 20k, 1.5M.
pub(crate) fn steps_label(x: f64) -> String {
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

/// The chart type of every figure: f64 on both axes.
pub(crate) type Plot<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// What sets one figure's axes apart from another's: the title, the ranges, what each axis
/// measures and how its ticks read. The rest of the frame is [`axes`]'s, the same for all.
pub(crate) struct Axes<'f> {
    pub(crate) title: &'f str,
    pub(crate) x: std::ops::Range<f64>,
    pub(crate) y: std::ops::Range<f64>,
    pub(crate) x_desc: &'f str,
    pub(crate) y_desc: &'f str,
    pub(crate) x_ticks: &'f dyn Fn(&f64) -> String,
    pub(crate) y_ticks: &'f dyn Fn(&f64) -> String,
}

/// Whole numbers on an axis (crashes, % Crash, returns).
pub(crate) fn whole(v: &f64) -> String {
    format!("{v:.0}")
}

/// Fills `root` white and draws the frame every figure shares on it: the title, the margins and
/// label areas, both axes with their descriptions, and the light grid. Kept in one place so that
/// the figures of a report look alike and a change of style is made once.
pub(crate) fn axes<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, Shift>,
    axes: &Axes<'_>,
) -> Result<Plot<'a, DB>, String>
where
    DB::ErrorType: 'static,
{
    let e = |err: DrawingAreaErrorKind<DB::ErrorType>| err.to_string();
    root.fill(&WHITE).map_err(e)?;
    let mut plot = ChartBuilder::on(root)
        .caption(axes.title, (FONT_NAME, 22))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(75)
        .build_cartesian_2d(axes.x.clone(), axes.y.clone())
        .map_err(e)?;
    plot.configure_mesh()
        .x_desc(axes.x_desc)
        .y_desc(axes.y_desc)
        .x_label_formatter(axes.x_ticks)
        .y_label_formatter(axes.y_ticks)
        .label_style((FONT_NAME, 14))
        .axis_desc_style((FONT_NAME, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    Ok(plot)
}

/// Draws the legend at `position`, in the style all figures share, and presents `root`.
pub(crate) fn finish<'a, DB: DrawingBackend + 'a>(
    plot: &mut Plot<'a, DB>,
    root: &DrawingArea<DB, Shift>,
    position: SeriesLabelPosition,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    legend(plot, position)?;
    root.present().map_err(|e| e.to_string())
}

/// Draws the legend at `position`, in the style all figures share. A figure of several panels
/// draws each panel's legend with this and presents once at the end: the SVG backend closes
/// its document when presented, so nothing drawn after that would show.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a>(
    plot: &mut Plot<'a, DB>,
    position: SeriesLabelPosition,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    plot.configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT_NAME, 14))
        .draw()
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_labels_are_short() {
        assert_eq!(steps_label(500.0), "500");
        assert_eq!(steps_label(20_000.0), "20k");
        assert_eq!(steps_label(1_500_000.0), "1.5M");
        assert_eq!(file_safe("Hopper-v5 (a/b)"), "Hopper-v5__a_b_");
    }

    #[test]
    fn a_label_with_dots_keeps_all_of_it_before_the_extension() {
        let base =
            Path::new("plots").join(format!("{}_crash", file_safe("sac (demos+BC, margin0.02+own50)")));
        assert_eq!(with_suffix(&base, "png"), Path::new("plots/sac__demos_BC__margin0.02_own50__crash.png"));
    }
}
