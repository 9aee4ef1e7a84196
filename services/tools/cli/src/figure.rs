//! Multi-panel time-series figures for the command-line reports, written as SVG and PNG.
//!
//! Text is laid out with `ab_glyph` and a font embedded in the binary (Ubuntu Light, from
//! `epaint_default_fonts`), so neither format needs a system font library. Each panel keeps its
//! legend in a column right of the data; a panel with a fixed y range draws no clipped values
//! (the curve is broken where it leaves the range, and the panel says so).

use anyhow::{Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One curve of a panel.
pub struct Series<'a> {
    /// Legend entry; empty: none (e.g. the lower half of a ± pair).
    pub label: &'a str,
    /// (time s, value) points.
    pub points: Vec<(f64, f64)>,
    /// Drawn dashed (e.g. a bound rather than a measurement).
    pub dashed: bool,
}

/// One panel: a y-axis label and its curves, sharing the figure's time axis.
pub struct Panel<'a> {
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
    /// Fixed y range; values outside it are not drawn (the panel notes it). `None`: autoscale.
    pub y_range: Option<(f64, f64)>,
    /// Draw a ±band (e.g. the settling band), in the panel's units.
    pub band: Option<f64>,
    /// Mark a time with a vertical line and a label (e.g. the settling time).
    pub marker: Option<(f64, String)>,
}

impl<'a> Panel<'a> {
    /// An autoscaled panel without band or marker.
    pub fn new(y_label: &'a str, series: Vec<Series<'a>>) -> Self {
        Self {
            y_label,
            series,
            y_range: None,
            band: None,
            marker: None,
        }
    }
}

/// Colours by curve index; curve `i` of a panel uses colour `i % 3` when the panel has
/// 3 × n curves (X, Y, Z, then their bounds), else `i`.
const COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];
const WIDTH: u32 = 1100;
const PANEL_HEIGHT: u32 = 250;
const LEGEND_WIDTH: u32 = 120;
const FONT: &str = "sans-serif";

/// Makes the embedded font plotters' "sans-serif" (once).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        );
    });
}

/// The horizontal axis of a figure's panels.
#[derive(Debug, Clone, Copy)]
pub enum XAxis<'a> {
    /// One time axis for every panel, in seconds.
    Time,
    /// Each panel its own range, under these labels (one per panel, e.g. an ECDF's metric).
    PerPanel(&'a [&'a str]),
}

/// Writes the panels stacked vertically to `<stem>.svg` and `<stem>.png`; returns the paths.
pub fn write_figure(stem: &Path, title: &str, panels: &[Panel]) -> Result<Vec<PathBuf>> {
    write_figure_on(stem, title, XAxis::Time, panels)
}

/// [`write_figure`] with the horizontal axis `x`.
pub fn write_figure_on(
    stem: &Path,
    title: &str,
    x: XAxis,
    panels: &[Panel],
) -> Result<Vec<PathBuf>> {
    let svg = stem.with_extension("svg");
    let png = stem.with_extension("png");
    write_svg_on(&svg, title, x, panels)?;
    write_png_on(&png, title, x, panels)?;
    Ok(vec![svg, png])
}

fn size(panels: &[Panel]) -> (u32, u32) {
    (WIDTH, 50 + PANEL_HEIGHT * panels.len().max(1) as u32)
}

fn create_dir(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(())
}

/// Writes the panels stacked vertically to an SVG file.
pub fn write_svg(path: &Path, title: &str, panels: &[Panel]) -> Result<()> {
    write_svg_on(path, title, XAxis::Time, panels)
}

fn write_svg_on(path: &Path, title: &str, x: XAxis, panels: &[Panel]) -> Result<()> {
    create_dir(path)?;
    let root = SVGBackend::new(path, size(panels)).into_drawing_area();
    draw(&root, title, x, panels).with_context(|| format!("drawing {}", path.display()))?;
    root.present()
        .map_err(draw_error)
        .with_context(|| format!("writing {}", path.display()))
}

/// Writes the panels stacked vertically to a PNG file.
pub fn write_png(path: &Path, title: &str, panels: &[Panel]) -> Result<()> {
    write_png_on(path, title, XAxis::Time, panels)
}

fn write_png_on(path: &Path, title: &str, x: XAxis, panels: &[Panel]) -> Result<()> {
    create_dir(path)?;
    let (width, height) = size(panels);
    let mut rgb = vec![0u8; 3 * width as usize * height as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        draw(&root, title, x, panels).with_context(|| format!("drawing {}", path.display()))?;
        root.present().map_err(draw_error)?;
    }
    encode_png(path, width, height, &rgb).with_context(|| format!("writing {}", path.display()))
}

/// Writes 8-bit RGB pixels, row by row, as a PNG file.
fn encode_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut encoder = png::Encoder::new(file, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // A filter chosen per row: a third smaller than one filter for all (large flat areas and lines).
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(())
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x: XAxis,
    panels: &[Panel],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    register_font();
    root.fill(&WHITE).map_err(draw_error)?;
    let root = root.titled(title, (FONT, 22)).map_err(draw_error)?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    let t_range = time_range(panels);
    for (i, (panel, area)) in panels.iter().zip(areas.iter()).enumerate() {
        match x {
            XAxis::Time => draw_panel(area, panel, "time (s)", t_range)?,
            XAxis::PerPanel(labels) => draw_panel(
                area,
                panel,
                labels.get(i).copied().unwrap_or(""),
                time_range(std::slice::from_ref(panel)),
            )?,
        }
    }
    Ok(())
}

/// The horizontal span of every panel's data (one time axis for the figure).
fn time_range(panels: &[Panel]) -> (f64, f64) {
    let times = panels
        .iter()
        .flat_map(|p| &p.series)
        .flat_map(|s| &s.points)
        .map(|p| p.0)
        .filter(|t| t.is_finite());
    let (t0, t1) = times.fold((f64::MAX, f64::MIN), |(a, b), t| (a.min(t), b.max(t)));
    if t0 > t1 {
        (0.0, 1.0)
    } else {
        (t0, t1.max(t0 + 1e-9))
    }
}

/// Tick label: enough decimals for the axis span, and never `-0`.
fn tick_label(value: f64, span: f64) -> String {
    let decimals = (1.0 - span.abs().max(1e-12).log10().floor()).clamp(0.0, 6.0) as usize;
    let text = format!("{value:.decimals$}");
    if text.parse::<f64>().is_ok_and(|v| v == 0.0) {
        "0".to_string()
    } else {
        text
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    x_label: &str,
    (t0, t1): (f64, f64),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (plot_area, legend_area) = area.split_horizontally(area.dim_in_pixel().0 - LEGEND_WIDTH);
    let finite = panel
        .series
        .iter()
        .flat_map(|s| &s.points)
        .map(|p| p.1)
        .filter(|y| y.is_finite());
    let (mut y0, mut y1) = finite.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    if y0 > y1 {
        (y0, y1) = (-1.0, 1.0);
    }
    if let Some(band) = panel.band {
        (y0, y1) = (y0.min(-band), y1.max(band));
    }
    let mut clipped = 0usize;
    if let Some((lo, hi)) = panel.y_range {
        clipped = panel
            .series
            .iter()
            .flat_map(|s| &s.points)
            .filter(|p| p.1 < lo || p.1 > hi)
            .count();
        (y0, y1) = (lo, hi);
    }
    let pad = if panel.y_range.is_some() {
        0.0
    } else {
        ((y1 - y0) * 0.05).max(1e-9)
    };
    let (y0, y1) = (y0 - pad, y1 + pad);
    let span = y1 - y0;
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(70)
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(draw_error)?;
    let x_span = t1 - t0;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(panel.y_label)
        .x_label_formatter(&|v| tick_label(*v, x_span))
        .y_label_formatter(&|v| tick_label(*v, span))
        .axis_desc_style((FONT, 14))
        .label_style((FONT, 13))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(draw_error)?;
    if let Some(band) = panel.band {
        let grey = RGBColor(120, 120, 120);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(t0, -band), (t1, band)],
                grey.mix(0.12).filled(),
            )))
            .map_err(draw_error)?;
        for y in [-band, band] {
            chart
                .draw_series(DashedLineSeries::new(
                    [(t0, y), (t1, y)],
                    6,
                    4,
                    grey.stroke_width(1),
                ))
                .map_err(draw_error)?;
        }
    }
    let groups = if panel.series.len().is_multiple_of(3) {
        3
    } else {
        COLOURS.len()
    };
    let colour = |i: usize| COLOURS[i % groups];
    for (i, series) in panel.series.iter().enumerate() {
        let style = colour(i).stroke_width(if series.dashed { 1 } else { 2 });
        // Break the curve where it leaves the range: no clipped value is drawn at the edge.
        for run in series
            .points
            .split(|p| !(p.1.is_finite() && p.1 >= y0 && p.1 <= y1))
        {
            if run.len() < 2 {
                continue;
            }
            if series.dashed {
                chart
                    .draw_series(DashedLineSeries::new(run.iter().copied(), 5, 4, style))
                    .map_err(draw_error)?;
            } else {
                chart
                    .draw_series(LineSeries::new(run.iter().copied(), style))
                    .map_err(draw_error)?;
            }
        }
    }
    let note_style = TextStyle::from((FONT, 13).into_font()).color(&BLACK);
    let plotting = chart.plotting_area();
    if let Some((t, label)) = &panel.marker {
        plotting
            .draw(&PathElement::new(
                [(*t, y0), (*t, y1)],
                BLACK.stroke_width(1),
            ))
            .map_err(draw_error)?;
        plotting
            .draw(
                &(EmptyElement::at((*t, y1))
                    + Text::new(label.clone(), (4, 4), note_style.clone())),
            )
            .map_err(draw_error)?;
    }
    if clipped > 0 {
        let note = format!(
            "{clipped} values outside [{}, {}] not drawn",
            tick_label(y0, span),
            tick_label(y1, span)
        );
        plotting
            .draw(&(EmptyElement::at((t0, y0)) + Text::new(note, (6, -18), note_style.clone())))
            .map_err(draw_error)?;
    }
    // Legend in its own column, beside the data.
    for (row, (i, series)) in panel
        .series
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.label.is_empty())
        .enumerate()
    {
        let y = 20 + 20 * row as i32;
        let style = colour(i).stroke_width(2);
        if series.dashed {
            for x in [4, 14] {
                legend_area
                    .draw(&PathElement::new([(x, y), (x + 6, y)], style))
                    .map_err(draw_error)?;
            }
        } else {
            legend_area
                .draw(&PathElement::new([(4, y), (24, y)], style))
                .map_err(draw_error)?;
        }
        legend_area
            .draw(&Text::new(series.label, (30, y - 7), note_style.clone()))
            .map_err(draw_error)?;
    }
    Ok(())
}

fn draw_error<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the figure: {e}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_png_with_labels_and_curves() {
        let dir = std::env::temp_dir().join(format!("testbed-figure-{}", std::process::id()));
        let points: Vec<(f64, f64)> = (0..100)
            .map(|i| (i as f64 * 0.1, (i as f64 * 0.1).sin()))
            .collect();
        let panel = Panel {
            band: Some(0.1),
            marker: Some((3.0, "settled 3.0 s".to_string())),
            y_range: Some((-0.5, 0.5)),
            ..Panel::new(
                "angle (deg)",
                vec![Series {
                    label: "sine",
                    points,
                    dashed: false,
                }],
            )
        };
        let paths = write_figure(&dir.join("f"), "test figure", &[panel]).unwrap();
        let svg = std::fs::read_to_string(&paths[0]).unwrap();
        assert!(svg.contains("angle (deg)") && svg.contains("sine") && svg.contains("<polyline"));
        assert!(svg.contains("not drawn") && svg.contains("settled 3.0 s"));
        assert!(
            !svg.contains(">-0<") && !svg.contains(">-0.0<"),
            "no negative zero tick"
        );
        let png = std::fs::read(&paths[1]).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn ticks_have_no_negative_zero() {
        assert_eq!(tick_label(-0.0, 1.0), "0");
        assert_eq!(tick_label(-1e-17, 0.2), "0");
        assert_eq!(tick_label(-0.05, 0.2), "-0.05");
        assert_eq!(tick_label(120.0, 300.0), "120");
    }
}
