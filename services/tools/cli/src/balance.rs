//! `testbed balance`: the balance masses' moves that bring the centre of mass an
//! identification found (`testbed identify`'s report) to the target — horizontal zero, vertical
//! the chosen pendulous offset — with the predicted residual. The maths is in
//! `testbed_ident::balance`; here the files, and millimetres and micrometres at the edge.

use anyhow::{Context, Result};
use std::path::PathBuf;
use testbed_config::RunConfig;
use testbed_ident::balance::{self, Plan};

#[derive(Debug, clap::Args)]
pub struct BalanceArgs {
    /// The identification: the JSON report of `testbed identify` (its `report.json`, or what
    /// `--json` printed).
    #[arg(long)]
    identification: PathBuf,
    /// Run configuration with the balance masses (`[balance]`) and the platform's mass
    /// (`[model.platform] mass_kg`); the assumed defaults of docs/balance.md when absent.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Vertical centre-of-mass offset to balance to, µm, body Z up (negative: pendulous);
    /// default `balance.vertical_target_m` (assumed −1 µm).
    #[arg(long, allow_negative_numbers = true)]
    vertical_um: Option<f64>,
    /// Print the plan as one JSON object.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &BalanceArgs) -> Result<()> {
    let config = match &args.config {
        Some(path) => RunConfig::load(path)
            .with_context(|| format!("loading the run configuration {}", path.display()))?,
        None => RunConfig::default(),
    };
    let masses = config.balance.clone().unwrap_or_default();
    masses
        .validate()
        .context("the balance masses (assumed defaults)")?;
    let text = std::fs::read_to_string(&args.identification)
        .with_context(|| format!("reading {}", args.identification.display()))?;
    let report: serde_json::Value = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not JSON (expected the report of `testbed identify`)",
            args.identification.display()
        )
    })?;
    let estimate = balance::com_estimate(&report)
        .with_context(|| format!("reading {}", args.identification.display()))?;
    let vertical_m = args
        .vertical_um
        .map_or(masses.vertical_target_m, |um| um * 1e-6);
    let plan = balance::plan(
        &estimate,
        &masses,
        config.model.platform.mass_kg,
        vertical_m,
    )
    .context("planning the balance")?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&to_json(&plan))?);
    } else {
        print!("{}", render(&plan));
    }
    Ok(())
}

fn um3(v: [f64; 3]) -> [f64; 3] {
    v.map(|x| x * 1e6)
}

/// The plan in edge units: millimetres for the moves, micrometres for the offsets.
pub fn to_json(plan: &Plan) -> serde_json::Value {
    let moves: Vec<serde_json::Value> = plan
        .moves
        .iter()
        .map(|m| {
            serde_json::json!({
                "name": m.name,
                "move_mm": m.delta_m * 1e3,
                "move_stddev_mm": m.delta_stddev_m * 1e3,
                "from_mm": m.from_m * 1e3,
                "to_mm": m.to_m * 1e3,
                "at_limit": m.at_limit,
            })
        })
        .collect();
    let e = &plan.estimate;
    let estimate_stddev_um = [0, 1, 2].map(|i| e.cov_m2[i][i].sqrt() * 1e6);
    let predicted_cov_um2 = plan.predicted_cov_m2.map(|r| r.map(|x| x * 1e12));
    serde_json::json!({
        "estimate_um": um3(e.r_m),
        "estimate_stddev_um": estimate_stddev_um,
        "covariance_source": e.covariance_source,
        "target_um": um3(plan.target_m),
        "moves": moves,
        "predicted_um": um3(plan.predicted_m),
        "predicted_stddev_um": um3(plan.predicted_stddev_m),
        "predicted_cov_um2": predicted_cov_um2,
        "horizontal_rms_um": plan.horizontal_rms_m * 1e6,
        "horizontal_tolerance_um": plan.horizontal_tolerance_m * 1e6,
        "within_tolerance": plan.within_tolerance,
    })
}

/// The plan as the terminal shows it.
pub fn render(plan: &Plan) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let e = &plan.estimate;
    let sd = |c: &[[f64; 3]; 3], i: usize| c[i][i].sqrt() * 1e6;
    let _ = writeln!(
        out,
        "centre of mass (identified): x {:+.4} ± {:.4} µm, y {:+.4} ± {:.4} µm, z {:+.4} ± {:.4} µm ({})",
        e.r_m[0] * 1e6,
        sd(&e.cov_m2, 0),
        e.r_m[1] * 1e6,
        sd(&e.cov_m2, 1),
        e.r_m[2] * 1e6,
        sd(&e.cov_m2, 2),
        e.covariance_source
    );
    let t = plan.target_m;
    let _ = writeln!(
        out,
        "target: x {:+.4} µm, y {:+.4} µm, z {:+.4} µm",
        t[0] * 1e6,
        t[1] * 1e6,
        t[2] * 1e6
    );
    let _ = writeln!(out, "moves:");
    for m in &plan.moves {
        let _ = writeln!(
            out,
            "  {:<8} {:+9.3} ± {:.3} mm   ({:+.3} → {:+.3} mm){}",
            m.name,
            m.delta_m * 1e3,
            m.delta_stddev_m * 1e3,
            m.from_m * 1e3,
            m.to_m * 1e3,
            if m.at_limit {
                "  at its travel limit"
            } else {
                ""
            }
        );
    }
    let p = plan.predicted_m;
    let s = plan.predicted_stddev_m;
    let _ = writeln!(
        out,
        "predicted: x {:+.4} ± {:.4} µm, y {:+.4} ± {:.4} µm, z {:+.4} ± {:.4} µm",
        p[0] * 1e6,
        s[0] * 1e6,
        p[1] * 1e6,
        s[1] * 1e6,
        p[2] * 1e6,
        s[2] * 1e6
    );
    let _ = writeln!(
        out,
        "horizontal residual (RMS): {:.4} µm, tolerance {:.4} µm: {}",
        plan.horizontal_rms_m * 1e6,
        plan.horizontal_tolerance_m * 1e6,
        if plan.within_tolerance {
            "within"
        } else {
            "NOT within: the identification is too uncertain for the tolerance (a longer record)"
        }
    );
    out
}
