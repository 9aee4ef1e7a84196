//! A campaign's results directory: the machine-readable results (`runs.csv`, `runs.json`,
//! `series.csv`, `summary.json`, `manifest.json`, the campaign file as run), the figures and a
//! short `report.md`; and the lines printed at the end.

use super::figures;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use testbed_campaign::CampaignFile;
use testbed_campaign::file::BASE_VARIANT;
use testbed_campaign::metrics::Metric;
use testbed_campaign::paired::sig3;
use testbed_campaign::results::{self, Manifest, RunRow, files};
use testbed_campaign::summary::{self, CampaignSummary, MetricSummary, VariantSummary};

/// Writes every file of the results of `rows` into `out`; returns the summary.
pub fn write(
    out: &Path,
    file: &CampaignFile,
    manifest: &Manifest,
    rows: &[RunRow],
) -> Result<CampaignSummary> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let write = |name: &str, text: &str| {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))
    };
    let keys = file.keys();
    let summary = summary::summarise(file, rows);
    write(files::RUNS_CSV, &results::runs_csv(&keys, rows))?;
    write(
        files::RUNS_JSON,
        &serde_json::to_string_pretty(&results::runs_json(&keys, rows))?,
    )?;
    write(
        files::SERIES_CSV,
        &results::series_csv(rows, file.metrics.series_step_s),
    )?;
    write(
        files::SUMMARY_JSON,
        &serde_json::to_string_pretty(&summary)?,
    )?;
    write(
        files::MANIFEST_JSON,
        &serde_json::to_string_pretty(manifest)?,
    )?;
    write(files::CAMPAIGN_TOML, &file.text)?;
    let figures = figures::write(out, file, &summary, rows)?;
    write(
        files::REPORT_MD,
        &markdown(&summary, manifest, &figures, out),
    )?;
    Ok(summary)
}

/// The command that runs run `index` of `variant` through the real processes.
pub fn reproduce(summary: &CampaignSummary, index: u64, variant: &str) -> String {
    let variant = if variant == BASE_VARIANT {
        String::new()
    } else {
        format!(" --campaign-variant {variant}")
    };
    format!(
        "testbed run --campaign {} --campaign-run {index}{variant}",
        summary.campaign
    )
}

fn value(x: Option<f64>, unit: &str) -> String {
    match (x, unit) {
        (None, _) => "–".into(),
        (Some(x), "") => sig3(x),
        (Some(x), unit) => format!("{} {unit}", sig3(x)),
    }
}

fn metric_line(m: &MetricSummary) -> String {
    let undefined = if m.runs_undefined > 0 {
        format!("{} ({})", m.runs_undefined, m.undefined_means)
    } else {
        "0".into()
    };
    format!(
        "| `{}` | {} | {undefined} | {} | {} | {} | {} | {}{} |\n",
        m.metric,
        m.runs_defined,
        value(m.median, m.unit),
        value(m.p5, m.unit),
        value(m.p95, m.unit),
        value(m.mean, m.unit),
        value(m.worst, m.unit),
        m.worst_run
            .map_or_else(String::new, |k| format!(" (run {k})")),
    )
}

fn variant_section(out: &mut String, summary: &CampaignSummary, v: &VariantSummary) {
    let _ = writeln!(out, "## {} ({} runs)\n", v.variant, v.runs);
    out.push_str("| metric | runs | undefined | median | 5 % | 95 % | mean | worst |\n");
    out.push_str("|---|---|---|---|---|---|---|---|\n");
    for m in &v.metrics {
        out.push_str(&metric_line(m));
    }
    let c = &v.consistency;
    let _ = writeln!(
        out,
        "\nEstimator consistency: mean NEES per degree of freedom {} (1 if the filter's covariance is right); \
         the ensemble's mean NEES over {} runs lies inside its 95 % chi-square interval {} at {} of {} series times \
         (about 95 % if consistent).",
        value(c.mean_nees_per_dof, ""),
        c.runs,
        c.interval_per_dof.map_or_else(
            || "–".into(),
            |[lo, hi]| format!("[{}, {}] per dof", sig3(lo), sig3(hi))
        ),
        c.fraction_inside
            .map_or_else(|| "–".into(), |f| format!("{} %", sig3(100.0 * f))),
        c.times,
    );
    let _ = writeln!(
        out,
        "\nSafe mode: the in-process loop has none; in {} of {} runs a wheel passed the controller's safe-mode \
         limit (`controller.safe_mode.wheel_speed_fraction` × the wheels' speed limit), where the real pipeline \
         would enter safe mode. Tilt stops in {} runs; {} vector updates rejected by the innovation gate in all. \
         Deadline misses: {}.",
        v.safe_mode_limit_runs,
        v.runs,
        v.tilt_stop_runs,
        v.gate_rejections,
        summary.deadline_misses
    );
    if !v.failed.is_empty() {
        let _ = writeln!(out, "\nRuns the closed loop could not finish:\n");
        for f in &v.failed {
            let _ = writeln!(out, "- run {}: {}", f.index, f.error);
        }
    }
    let _ = writeln!(
        out,
        "\nWorst runs (failed, never settled, then latest to settle), each reproduced through the processes by its command:\n"
    );
    for w in &v.worst_runs {
        let _ = writeln!(
            out,
            "- run {}: settled {}, steady error {}: `{}`",
            w.index,
            w.settle_s
                .map_or_else(|| "never".into(), |s| format!("at {} s", sig3(s))),
            value(w.steady_error_deg, "°"),
            reproduce(summary, w.index, &v.variant)
        );
    }
    out.push('\n');
}

/// `report.md`: what ran, each variant's metrics, the comparisons, the figures.
pub fn markdown(
    summary: &CampaignSummary,
    manifest: &Manifest,
    figures: &[PathBuf],
    out_dir: &Path,
) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# Campaign {}\n", summary.campaign);
    let _ = writeln!(
        out,
        "{} runs{}, campaign seed {}, variants: {}. Each run k is determined by the seed and k; \
         `{}` and `{}` hold one row per run, `{}` the summary (docs/campaigns.md says what each metric means).\n",
        summary.runs,
        manifest
            .shard
            .as_ref()
            .map_or_else(String::new, |s| format!(
                " (this directory: shard {s}, {} runs)",
                manifest.runs_here
            )),
        summary.seed,
        summary.variants.join(", "),
        files::RUNS_CSV,
        files::RUNS_JSON,
        files::SUMMARY_JSON,
    );
    if !summary.dispersions.is_empty() {
        out.push_str("| dispersed key | distribution | applied |\n|---|---|---|\n");
        for d in &summary.dispersions {
            let _ = writeln!(
                out,
                "| `{}` | {} | {} |",
                d.key,
                serde_json::to_string(&d.distribution).unwrap_or_default(),
                serde_json::to_string(&d.apply)
                    .unwrap_or_default()
                    .trim_matches('"')
            );
        }
        out.push('\n');
    }
    let o = &summary.metric_options;
    let _ = writeln!(
        out,
        "Settling band {}°, steady error over the final {} s, estimator metrics from {} s, series every {} s.\n",
        o.settle_band_deg, o.steady_window_s, o.estimation_from_s, o.series_step_s
    );
    for v in &summary.per_variant {
        variant_section(&mut out, summary, v);
    }
    for c in &summary.comparisons {
        let _ = writeln!(out, "## {} against {}\n", c.b, c.a);
        let _ = writeln!(out, "Paired on the same runs; {}.\n", c.method);
        for m in &c.metrics {
            let _ = writeln!(out, "- {}", m.verdict);
        }
        let _ = writeln!(out, "\n**Overall:** {}.\n", c.overall);
    }
    out.push_str("## Figures\n\n");
    for f in figures
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
    {
        let name = f.strip_prefix(out_dir).unwrap_or(f).display().to_string();
        let _ = writeln!(out, "![{name}]({name})");
    }
    out
}

/// The lines printed when a campaign or a merge has written its results.
pub fn print(summary: &CampaignSummary, out: &Path, timing: Option<(f64, usize, usize)>) {
    if let Some((wall_s, runs, workers)) = timing {
        println!(
            "{runs} runs in {wall_s:.1} s on {workers} worker(s) ({:.1} runs/s)",
            runs as f64 / wall_s.max(1e-9)
        );
    }
    for v in &summary.per_variant {
        let get = |metric: Metric| &v.metrics[metric as usize];
        let settle = get(Metric::SettleS);
        println!(
            "{}: {} runs; settled in {} (median {}, 95 % {}, never {}); steady error median X {} Y {} Z {}; mean NEES/dof {}; safe-mode limit reached in {} runs; {} failed",
            v.variant,
            v.runs,
            settle.runs_defined,
            value(settle.median, "s"),
            value(settle.p95, "s"),
            settle.runs_undefined,
            value(get(Metric::SteadyErrorXDeg).median, "°"),
            value(get(Metric::SteadyErrorYDeg).median, "°"),
            value(get(Metric::SteadyErrorZDeg).median, "°"),
            value(v.consistency.mean_nees_per_dof, ""),
            v.safe_mode_limit_runs,
            v.failed.len(),
        );
        if let Some(w) = v.worst_runs.first() {
            println!(
                "  worst run {}: {}",
                w.index,
                reproduce(summary, w.index, &v.variant)
            );
        }
    }
    for c in &summary.comparisons {
        println!("{}", c.overall);
    }
    println!(
        "results in {}: {}, {}, {}, {}",
        out.display(),
        files::REPORT_MD,
        files::SUMMARY_JSON,
        files::RUNS_CSV,
        files::RUNS_JSON
    );
}
