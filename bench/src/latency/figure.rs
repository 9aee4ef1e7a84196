//! The report's SVG figure (plotters, as in `services/tools/cli/src/figure.rs`): latency percentile
//! ladders of the chain and the hop, the payload sweep, and the paced 10 Hz loop.

use crate::latency::model::{Kind, Measurement, Report};
use crate::latency::protocol::Transport;
use crate::latency::stats::Percentiles;
use anyhow::{Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
];

const LADDER: [&str; 5] = ["p50", "p90", "p99", "p99.9", "max"];

struct Curve {
    label: String,
    colour: RGBColor,
    faint: bool,
    points: Vec<(f64, f64)>,
}

fn ladder(m: &Measurement) -> Vec<(f64, f64)> {
    let l = &m.latency;
    [l.p50, l.p90, l.p99, l.p999, l.max]
        .iter()
        .enumerate()
        .map(|(i, &v)| (i as f64, v.max(0.01)))
        .collect()
}

/// One colour per transport, binaries and placement, the same in every panel.
fn colour_key(transport: Transport, binaries: bool, chain_cpu: Option<usize>) -> String {
    format!("{transport}{binaries}{chain_cpu:?}")
}

fn colour_of(transports: &mut Vec<String>, key: &str) -> RGBColor {
    let i = transports.iter().position(|t| t == key).unwrap_or_else(|| {
        transports.push(key.to_string());
        transports.len() - 1
    });
    COLOURS[i % COLOURS.len()]
}

pub fn write(path: &Path, report: &Report) -> Result<()> {
    // plotters draws text with ab_glyph and no system fonts: register the embedded one.
    static FONT: std::sync::Once = std::sync::Once::new();
    FONT.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        );
    });
    let root = SVGBackend::new(path, (1400, 1100)).into_drawing_area();
    root.fill(&WHITE).map_err(draw_error)?;
    let root = root
        .titled(
            &format!(
                "Pipeline latency — {} ({} CPUs), {}",
                report.machine.cpu_model, report.machine.cpus, report.machine.started
            ),
            ("sans-serif", 20),
        )
        .map_err(draw_error)?;
    let areas = root.split_evenly((2, 2));
    let mut transports = Vec::new();
    for (area, kind, title) in [
        (
            &areas[0],
            Kind::Chain,
            "chain: gyro gateway → wheel command (idle solid, load faint)",
        ),
        (
            &areas[1],
            Kind::Hop,
            "one hop, 48 B (idle solid, load faint)",
        ),
    ] {
        let curves: Vec<Curve> = report
            .measurements
            .iter()
            .filter(|m| m.kind == kind && m.error.is_none() && m.latency.n > 0)
            .map(|m| Curve {
                label: format!(
                    "{}{}{} {}",
                    m.transport.label(),
                    if m.real_binaries { " [bin]" } else { "" },
                    m.chain_cpu
                        .map_or(String::new(), |cpu| format!(" [CPU {cpu}]")),
                    if m.load { "load" } else { "idle" }
                ),
                colour: colour_of(
                    &mut transports,
                    &colour_key(m.transport, m.real_binaries, m.chain_cpu),
                ),
                faint: m.load,
                points: ladder(m),
            })
            .collect();
        panel(area, title, &curves, false, "percentile", |x| {
            LADDER
                .get(x.round() as usize)
                .map_or(String::new(), |s| s.to_string())
        })?;
    }
    let sweep: Vec<Curve> = {
        let mut keys: Vec<(Transport, bool)> = Vec::new();
        for m in report
            .measurements
            .iter()
            .filter(|m| m.kind == Kind::Sweep && m.error.is_none())
        {
            if !keys.contains(&(m.transport, m.load)) {
                keys.push((m.transport, m.load));
            }
        }
        keys.iter()
            .map(|(t, load)| {
                let rows: Vec<&Measurement> = report
                    .measurements
                    .iter()
                    .filter(|m| {
                        m.kind == Kind::Sweep
                            && m.transport == *t
                            && m.load == *load
                            && m.error.is_none()
                    })
                    .collect();
                Curve {
                    label: format!(
                        "{} {} p50",
                        rows[0].transport.label(),
                        if *load { "load" } else { "idle" }
                    ),
                    colour: colour_of(&mut transports, &colour_key(*t, false, None)),
                    faint: *load,
                    points: rows
                        .iter()
                        .map(|m| (m.size as f64, m.latency.p50.max(0.01)))
                        .collect(),
                }
            })
            .collect()
    };
    panel(
        &areas[2],
        "payload sweep: median of one hop vs sample size (idle solid, load faint)",
        &sweep,
        true,
        "sample size (bytes)",
        |x| format!("{x:.0}"),
    )?;
    let paced: Vec<Curve> = report
        .paced
        .iter()
        .filter(|p| p.error.is_none())
        .enumerate()
        .flat_map(|(i, p)| {
            let l = |s: &Percentiles| {
                [s.p50, s.p90, s.p99, s.p999, s.max]
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (i as f64, v.max(0.01)))
                    .collect::<Vec<_>>()
            };
            [
                Curve {
                    label: format!("truth→command, {}", p.wait),
                    colour: COLOURS[(i * 2) % COLOURS.len()],
                    faint: false,
                    points: l(&p.truth_to_command),
                },
                Curve {
                    label: format!("|period − 100 ms|, {}", p.wait),
                    colour: COLOURS[(i * 2 + 1) % COLOURS.len()],
                    faint: true,
                    points: l(&p.period_error),
                },
            ]
        })
        .collect();
    panel(
        &areas[3],
        "10 Hz paced run under load: latency and period jitter",
        &paced,
        false,
        "percentile",
        |x| {
            LADDER
                .get(x.round() as usize)
                .map_or(String::new(), |s| s.to_string())
        },
    )?;
    root.present()
        .map_err(draw_error)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn panel(
    area: &DrawingArea<SVGBackend, Shift>,
    title: &str,
    curves: &[Curve],
    log_x: bool,
    x_desc: &str,
    x_label: impl Fn(&f64) -> String,
) -> Result<()> {
    let ys = curves.iter().flat_map(|c| c.points.iter().map(|p| p.1));
    let (mut y0, mut y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    if y0 > y1 {
        (y0, y1) = (1.0, 10.0);
    }
    let (y0, y1) = (y0 / 1.5, y1 * 1.5);
    let xs = curves.iter().flat_map(|c| c.points.iter().map(|p| p.0));
    let (mut x0, mut x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    if x0 > x1 {
        (x0, x1) = (0.0, 4.0);
    }
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(title, ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    if log_x {
        let mut chart = builder
            .build_cartesian_2d((x0 / 1.5..x1 * 1.5).log_scale(), (y0..y1).log_scale())
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc("µs (log)")
            .x_label_formatter(&x_label)
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(draw_error)?;
        draw_curves(&mut chart, curves)?;
    } else {
        let mut chart = builder
            .build_cartesian_2d(x0 - 0.3..x1 + 0.3, (y0..y1).log_scale())
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc("µs (log)")
            .x_labels(5)
            .x_label_formatter(&x_label)
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(draw_error)?;
        draw_curves(&mut chart, curves)?;
    }
    Ok(())
}

fn draw_curves<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    curves: &[Curve],
) -> Result<()>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for c in curves {
        let colour = c.colour;
        let style = if c.faint {
            colour.mix(0.45).stroke_width(2)
        } else {
            colour.stroke_width(2)
        };
        chart
            .draw_series(LineSeries::new(c.points.iter().copied(), style))
            .map_err(draw_error)?
            .label(c.label.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
        let marker = if c.faint {
            colour.mix(0.45).filled()
        } else {
            colour.filled()
        };
        chart
            .draw_series(c.points.iter().map(|&p| Circle::new(p, 3, marker)))
            .map_err(draw_error)?;
    }
    if !curves.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", 11))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(draw_error)?;
    }
    Ok(())
}

fn draw_error<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing the figure: {e}")
}
