//! Multi-panel time-series figures (SVG) for the command-line reports.

use anyhow::{Context, Result};
use plotters::prelude::*;
use std::path::Path;

/// One curve of a panel.
pub struct Series<'a> {
    pub label: &'a str,
    /// (time s, value) points.
    pub points: Vec<(f64, f64)>,
}

/// One panel: a y-axis label and its curves, sharing the figure's time axis.
pub struct Panel<'a> {
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
    /// Draw the y axis on a symmetric-log-free, plain linear scale clipped to this range if set.
    pub y_range: Option<(f64, f64)>,
}

const COLOURS: [RGBColor; 4] = [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189)];

/// Write panels stacked vertically to an SVG file.
pub fn write_svg(path: &Path, title: &str, panels: &[Panel]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let height = 60 + 260 * panels.len() as u32;
    let root = SVGBackend::new(path, (1000, height)).into_drawing_area();
    root.fill(&WHITE).map_err(draw_error)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(draw_error)?;
    let areas = root.split_evenly((panels.len(), 1));
    for (panel, area) in panels.iter().zip(areas.iter()) {
        draw_panel(area, panel)?;
    }
    root.present().map_err(draw_error).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn draw_panel(area: &DrawingArea<SVGBackend, plotters::coord::Shift>, panel: &Panel) -> Result<()> {
    let all = panel.series.iter().flat_map(|s| s.points.iter());
    let (mut t0, mut t1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(t, y) in all {
        if t.is_finite() && y.is_finite() {
            t0 = t0.min(t);
            t1 = t1.max(t);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if t0 > t1 {
        (t0, t1, y0, y1) = (0.0, 1.0, -1.0, 1.0);
    }
    if let Some((lo, hi)) = panel.y_range {
        (y0, y1) = (lo, hi);
    }
    let pad = ((y1 - y0) * 0.05).max(1e-12);
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(80)
        .build_cartesian_2d(t0..t1.max(t0 + 1e-9), (y0 - pad)..(y1 + pad))
        .map_err(draw_error)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(panel.y_label)
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_error)?;
    for (i, series) in panel.series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let clipped = series.points.iter().map(|&(t, y)| (t, y.clamp(y0 - pad, y1 + pad)));
        chart
            .draw_series(LineSeries::new(clipped, colour.stroke_width(2)))
            .map_err(draw_error)?
            .label(series.label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(draw_error)?;
    Ok(())
}

fn draw_error<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the figure: {e}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_an_svg_with_labels_and_curves() {
        let dir = std::env::temp_dir().join(format!("testbed-figure-{}", std::process::id()));
        let path = dir.join("f.svg");
        let points: Vec<(f64, f64)> = (0..100).map(|i| (i as f64 * 0.1, (i as f64 * 0.1).sin())).collect();
        let panel = Panel {
            y_label: "angle (deg)",
            series: vec![Series { label: "sine", points }],
            y_range: None,
        };
        write_svg(&path, "test figure", &[panel]).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("angle (deg)") && svg.contains("sine") && svg.contains("<polyline"));
        std::fs::remove_dir_all(dir).unwrap();
    }
}
