//! `testbed paper`: reproduce the paper's results and print them beside the paper's numbers.

use crate::figure::{self, Panel, Series};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use testbed_model::ModelConfig;
use testbed_model::config::{DEG, RPM};
use testbed_sim::closed_loop::Trace;
use testbed_sim::paper::{self, PaperOptions, PaperResult, PaperTraces};

#[derive(Debug, clap::Args)]
pub struct PaperArgs {
    /// Model configuration (TOML); the digest's defaults when absent.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Monte Carlo runs of the EKF scenario.
    #[arg(long, default_value_t = 20)]
    runs: usize,
    /// First seed (run i uses seed + i).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory for the figures.
    #[arg(long, default_value = "out/paper")]
    out: PathBuf,
    /// Print the results as one JSON object instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &PaperArgs) -> Result<()> {
    let model = match &args.model {
        Some(path) => ModelConfig::load(path)?,
        None => ModelConfig::default(),
    };
    let options = PaperOptions {
        runs: args.runs,
        seed: args.seed,
        ..PaperOptions::default()
    };
    let (result, traces) =
        paper::reproduce(&model, &options).context("running the paper's scenarios")?;
    let figures = write_figures(&args.out, &traces)?;
    if args.json {
        let mut value = serde_json::to_value(&result)?;
        value["figures"] = serde_json::json!(figures);
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print_table(&result, &options);
        println!();
        for f in &figures {
            println!("figure: {f}");
        }
    }
    Ok(())
}

fn print_table(r: &PaperResult, o: &PaperOptions) {
    let opt = |x: Option<f64>| x.map_or_else(|| "never".to_string(), |s| format!("{s:.1} s"));
    let verdict = |ok: bool| if ok { "ok" } else { "MISSED" };
    println!("{:<52} {:>12} {:>12}  ", "quantity", "paper", "project");
    println!("{}", "-".repeat(84));
    println!(
        "EKF, {} Monte Carlo runs, pooled {}–{} s (Fig. 8)",
        r.ekf.runs, o.ekf_from_s, o.ekf_duration_s
    );
    let e = &r.ekf;
    let within = |ours: f64, paper: f64| (ours / paper - 1.0).abs() <= 0.3;
    println!(
        "  {:<50} {:>12} {:>12.5}  {}",
        "3σ attitude error X/Y (deg)",
        e.paper_err3s_xy_deg,
        e.err3s_xy_deg,
        verdict(within(e.err3s_xy_deg, e.paper_err3s_xy_deg))
    );
    println!(
        "  {:<50} {:>12} {:>12.5}  {}",
        "3σ attitude error Z (deg)",
        e.paper_err3s_z_deg,
        e.err3s_z_deg,
        verdict(within(e.err3s_z_deg, e.paper_err3s_z_deg))
    );
    println!(
        "  {:<50} {:>12} {:>12}",
        "filter's own 3σ X, Y, Z (deg)",
        "",
        format!(
            "{:.5}, {:.5}, {:.4}",
            e.filter_3s_deg[0], e.filter_3s_deg[1], e.filter_3s_deg[2]
        )
    );
    let consistent = e.nees_mean >= e.nees_interval[0] && e.nees_mean <= e.nees_interval[1];
    println!(
        "  {:<50} {:>12} {:>12.2}  {} (95 % interval [{:.2}, {:.2}])",
        format!("mean NEES ({} dof)", e.nees_dof),
        "",
        e.nees_mean,
        verdict(consistent),
        e.nees_interval[0],
        e.nees_interval[1]
    );
    println!(
        "  {:<50} {:>12} {:>12}",
        "gate rejections", "", e.gate_rejections
    );
    let c = &r.control;
    println!("Stabilisation from 5° X/Y tilt, 20° heading (Fig. 11–12)");
    println!(
        "  {:<50} {:>12} {:>12}  {}",
        format!("settling time, band {}° (s)", c.settle_band_deg),
        format!("~{}", c.paper_settle_s),
        opt(c.settle_s),
        verdict(c.settle_s.is_some_and(|s| s <= 1.2 * c.paper_settle_s))
    );
    println!(
        "  {:<50} {:>12} {:>12.4}  {}",
        format!("steady error X/Y, last {} s (deg)", c.steady_window_s),
        format!("< {}", c.paper_steady_xy_deg),
        c.steady_xy_deg,
        verdict(c.steady_xy_deg < c.paper_steady_xy_deg)
    );
    println!(
        "  {:<50} {:>12} {:>12.4}  {}",
        "steady error Z (deg)",
        format!("< {}", c.paper_steady_z_deg),
        c.steady_z_deg,
        verdict(c.steady_z_deg < c.paper_steady_z_deg)
    );
    println!(
        "  {:<50} {:>12} {:>12.4}",
        "steady error X/Y without friction compensation", "worse", c.steady_xy_deg_no_compensation
    );
    println!(
        "  {:<50} {:>12} {:>12.4}",
        "steady error Z without friction compensation", "worse", c.steady_z_deg_no_compensation
    );
    println!(
        "  {:<50} {:>12} {:>12.0}",
        "peak wheel speed (rpm, limit 6000)", "", c.peak_wheel_speed_rpm
    );
    let g = &r.cmg;
    println!("CMG pyramid, {}° heading slew", g.slew_angle_deg);
    println!(
        "  {:<50} {:>12} {:>12}",
        format!("slew time to within {}° (s)", g.slew_band_deg),
        "",
        opt(g.slew_s)
    );
    println!(
        "  {:<50} {:>12} {:>12.1}  {}",
        "largest gimbal rate (deg/s)",
        format!("≤ {}", g.gimbal_rate_limit_deg_s),
        g.max_gimbal_rate_deg_s,
        verdict(g.max_gimbal_rate_deg_s <= g.gimbal_rate_limit_deg_s + 1e-9)
    );
    println!(
        "  {:<50} {:>12} {:>12.3}",
        "smallest singularity measure (0 = singular)", "", g.min_singularity_measure
    );
    println!(
        "  {:<50} {:>12.4} {:>12.4}",
        "momentum envelope X/Y (Nms): analytic, geometry",
        g.envelope_xy_analytic_nms,
        g.envelope_xy_nms
    );
    println!(
        "  {:<50} {:>12.4} {:>12.4}",
        "momentum envelope Z (Nms): analytic, geometry",
        g.envelope_z_analytic_nms,
        g.envelope_z_nms
    );
}

fn write_figures(dir: &Path, traces: &PaperTraces) -> Result<Vec<String>> {
    let ekf = dir.join("ekf_fig8.svg");
    figure::write_svg(
        &ekf,
        "EKF attitude estimation error, first Monte Carlo run (cf. paper Fig. 8)",
        &ekf_panels(&traces.ekf),
    )?;
    let control = dir.join("control_fig11.svg");
    figure::write_svg(
        &control,
        "Stabilisation from 5°/5° tilt and 20° heading (cf. paper Fig. 11–12)",
        &control_panels(&traces.control, &traces.control_no_compensation),
    )?;
    let cmg = dir.join("cmg_slew.svg");
    figure::write_svg(
        &cmg,
        "90° heading slew with the CMG pyramid",
        &cmg_panels(&traces.cmg),
    )?;
    Ok([ekf, control, cmg]
        .iter()
        .map(|p| p.display().to_string())
        .collect())
}

const AXES: [&str; 3] = ["X", "Y", "Z"];

fn series<'a>(
    trace: &Trace,
    label: &'a str,
    f: impl Fn(&testbed_sim::closed_loop::TickRecord) -> Option<f64>,
) -> Series<'a> {
    Series {
        label,
        points: trace
            .ticks
            .iter()
            .filter_map(|t| f(t).map(|y| (t.t_s, y)))
            .collect(),
        dashed: false,
    }
}

fn ekf_panels(trace: &Trace) -> Vec<Panel<'static>> {
    let mut panels: Vec<Panel> = (0..3)
        .map(|axis| Panel {
            y_label: ["error X (deg)", "error Y (deg)", "error Z (deg)"][axis],
            series: vec![
                series(trace, "estimate − truth", |t| {
                    t.estimate
                        .as_ref()
                        .map(|e| e.attitude_error_rad[axis] / DEG)
                }),
                series(trace, "+3σ", |t| {
                    t.estimate
                        .as_ref()
                        .map(|e| 3.0 * e.attitude_sigma_rad[axis] / DEG)
                }),
                series(trace, "−3σ", |t| {
                    t.estimate
                        .as_ref()
                        .map(|e| -3.0 * e.attitude_sigma_rad[axis] / DEG)
                }),
            ],
            // Start-up transients dwarf the steady error; show the steady scale.
            y_range: Some(if axis < 2 {
                (-0.004, 0.004)
            } else {
                (-0.06, 0.06)
            }),
            band: None,
            marker: None,
        })
        .collect();
    panels.push(Panel {
        y_label: "bias error (deg/s)",
        series: (0..3)
            .map(|axis| {
                series(trace, AXES[axis], move |t| {
                    t.estimate
                        .as_ref()
                        .map(|e| (t.bias_true[axis] - e.bias_rad_s[axis]) / DEG)
                })
            })
            .collect(),
        y_range: None,
        band: None,
        marker: None,
    });
    panels
}

fn control_panels(with: &Trace, without: &Trace) -> Vec<Panel<'static>> {
    let error = |trace: &Trace| -> Vec<Series<'static>> {
        (0..3)
            .map(|axis| {
                series(trace, AXES[axis], move |t| {
                    Some(t.pointing_error_rad[axis] / DEG)
                })
            })
            .collect()
    };
    vec![
        Panel {
            y_label: "attitude error (deg)",
            series: error(with),
            y_range: None,
            band: None,
            marker: None,
        },
        Panel {
            y_label: "error, steady scale (deg)",
            series: error(with),
            y_range: Some((-0.05, 0.05)),
            band: None,
            marker: None,
        },
        Panel {
            y_label: "body rate (deg/s)",
            series: (0..3)
                .map(|axis| series(with, AXES[axis], move |t| Some(t.truth.rate_b[axis] / DEG)))
                .collect(),
            y_range: None,
            band: None,
            marker: None,
        },
        Panel {
            y_label: "wheel speed (rpm)",
            series: (0..3)
                .map(|axis| {
                    series(with, AXES[axis], move |t| {
                        Some(t.truth.wheel_speed[axis] / RPM)
                    })
                })
                .collect(),
            y_range: None,
            band: None,
            marker: None,
        },
        Panel {
            y_label: "no compensation: error (deg)",
            series: error(without),
            y_range: Some((-0.6, 0.6)),
            band: None,
            marker: None,
        },
    ]
}

fn cmg_panels(trace: &Trace) -> Vec<Panel<'static>> {
    vec![
        Panel {
            y_label: "attitude error (deg)",
            series: (0..3)
                .map(|axis| {
                    series(trace, AXES[axis], move |t| {
                        Some(t.pointing_error_rad[axis] / DEG)
                    })
                })
                .collect(),
            y_range: None,
            band: None,
            marker: None,
        },
        Panel {
            y_label: "gimbal angle (deg)",
            series: (0..4)
                .map(|i| {
                    series(trace, ["CMG 1", "CMG 2", "CMG 3", "CMG 4"][i], move |t| {
                        Some(t.truth.gimbal[i] / DEG)
                    })
                })
                .collect(),
            y_range: None,
            band: None,
            marker: None,
        },
        Panel {
            y_label: "singularity measure",
            series: vec![series(trace, "sqrt det(J Jᵀ)/h0³", |t| {
                t.singularity_measure
            })],
            y_range: None,
            band: None,
            marker: None,
        },
    ]
}
