//! The identification report as text: the verdict first, then the evidence.

use std::fmt::Write as _;
use testbed_ident::identify::Report;

/// The report as text: the verdict first, then the evidence.
pub(super) fn render_report(r: &Report) -> Result<String, std::fmt::Error> {
    let mut out = String::new();
    writeln!(out, "VERDICT")?;
    for line in &r.summary {
        writeln!(out, "  {line}")?;
    }
    writeln!(out)?;
    writeln!(out, "EVIDENCE")?;
    writeln!(
        out,
        "data: {} ({:.0} s, {} gyro rows at {:.3} s; {}); {}",
        r.data.source,
        r.data.duration_s,
        r.data.gyro_rows,
        r.data.period_s,
        r.data.devices.join(", "),
        if r.options.folds >= 2 {
            format!(
                "fits on all the data, {}-fold cross-validation over {:.0}-s blocks ({:.0} % of the ticks predicted out of fold)",
                r.options.folds,
                r.options.block_s,
                100.0 * r.data.held_out_fraction
            )
        } else {
            format!(
                "{:.0} % held out of the fits",
                100.0 * r.data.held_out_fraction
            )
        }
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "1. What the nominal model gets wrong (predictions re-initialised every {} s; equation errors)",
        r.options.horizon_s
    )?;
    render_components(&mut out, &r.nominal_residuals)?;
    writeln!(out)?;
    writeln!(
        out,
        "2. Candidate causes (forward selection; significant: LR > threshold; chosen: best held-out LR; with k-fold cross-validation LR held-out is the cross-validated one, computed for candidates significant at 1 %, NaN otherwise)"
    )?;
    for (i, step) in r.steps.iter().enumerate() {
        writeln!(out, "  step {}", i + 1)?;
        writeln!(
            out,
            "    {:<22} {:>3} {:>12} {:>10} {:>12} {:>12}",
            "cause", "k", "LR fit", "threshold", "ΔBIC", "LR held-out"
        )?;
        for c in step {
            let mark = if c.chosen {
                "  <- chosen"
            } else if c.significant {
                "  significant"
            } else {
                ""
            };
            writeln!(
                out,
                "    {:<22} {:>3} {:>12.1} {:>10.1} {:>12.1} {:>12.1}{mark}{}",
                c.name,
                c.k,
                c.lr_fit,
                c.threshold,
                c.delta_bic,
                c.lr_held_out,
                if c.note.is_empty() || !c.significant {
                    String::new()
                } else {
                    format!(" ({})", c.note)
                }
            )?;
        }
    }
    writeln!(out)?;
    writeln!(out)?;
    writeln!(
        out,
        "3. Causes and their falsification tests (a cause is named only if it passes)"
    )?;
    for t in &r.cause_tests {
        writeln!(out, "  {:<22} {}", t.name, t.verdict)?;
    }
    writeln!(out, "  named: {}", r.verdict)?;
    for c in &r.causes {
        writeln!(out, "  {} — {}", c.name, c.description)?;
        for (key, value) in &c.parameters {
            let se = c.stderr.get(key);
            let unit = c.units.get(key).and_then(|u| u.as_str()).unwrap_or("");
            let pair = |v: &serde_json::Value, e: Option<&serde_json::Value>| {
                testbed_ident::identify::with_error(
                    v.as_f64().unwrap_or(f64::NAN),
                    e.and_then(|e| e.as_f64()).unwrap_or(f64::NAN),
                )
            };
            let text = match (value, se) {
                (serde_json::Value::Array(v), Some(serde_json::Value::Array(e))) => format!(
                    "[{}]",
                    v.iter()
                        .zip(e)
                        .map(|(v, e)| pair(v, Some(e)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                (v, e) => pair(v, e),
            };
            writeln!(out, "    {key} = {text}  [{unit}]")?;
        }
        if !c.note.is_empty() {
            writeln!(out, "    ({})", c.note)?;
        }
    }
    writeln!(out)?;
    writeln!(
        out,
        "4. Unexplained effects (sparse regression on the candidate functions; |z| beyond the Bonferroni threshold, k-fold cross-validated)"
    )?;
    if r.unexplained.is_empty() {
        writeln!(out, "  none")?;
    }
    for e in &r.unexplained {
        let pass = match (&r.sensor_correction, e.pass) {
            (Some(_), 1) => " (first pass, carried as the magnetometer correction)",
            (Some(_), _) => " (second pass)",
            (None, _) => "",
        };
        writeln!(
            out,
            "  {}{pass}: {} rows in {} clusters; |z| threshold {:.2}; held-out gain {:.3}, cross-validated gain {:.3}",
            e.equation, e.rows, e.clusters, e.z_threshold, e.held_out_gain, e.cv_gain
        )?;
        for t in &e.terms {
            writeln!(
                out,
                "    {:<14} {}  [{}]  z = {:+.1}",
                t.name,
                testbed_ident::identify::with_error(t.value, t.stderr),
                e.unit,
                t.value / t.stderr
            )?;
        }
        for t in &e.refitted_named {
            writeln!(
                out,
                "    (named, refitted) {:<28} {}",
                t.name,
                testbed_ident::identify::with_error(t.value, t.stderr)
            )?;
        }
    }
    if let Some(c) = &r.sensor_correction {
        writeln!(
            out,
            "  magnetometer correction of the second pass ([effects.fitted_field], from {}): field residual RMS {:.1} nT before, {:.1} nT after; {} filter runs; first pass: {} (gain {:.2}x)",
            c.equations.join(", "),
            c.residual_rms_before_t * 1e9,
            c.residual_rms_after_t * 1e9,
            c.iterations,
            c.first_pass_verdict,
            c.first_pass_gain
        )?;
        for t in &c.fitted_field.terms {
            writeln!(
                out,
                "    {} {:<14} {:+.3e}  [T per unit]",
                t.axis, t.function, t.coefficient
            )?;
        }
        if !c.not_carried.is_empty() {
            writeln!(out, "    not carried: {}", c.not_carried.join(", "))?;
        }
    }
    writeln!(out, "  {}", r.remaining.message)?;
    for c in &r.remaining.correlations {
        writeln!(
            out,
            "    {} correlates with {}: r = {:+.2}",
            c.residual, c.signal, c.r
        )?;
    }
    writeln!(out)?;
    writeln!(out)?;
    writeln!(
        out,
        "5. Gain on held-out data (multi-step prediction error, RMS; normalised by the sensor noise; with k-fold cross-validation each fold predicted by the model fitted without it)"
    )?;
    writeln!(
        out,
        "    {:<10} {:>14} {:>14} {:>10} {:>10}",
        "component", "nominal", "extended", "unit", "gain"
    )?;
    for (name, a) in &r.baseline_rms.components {
        if let Some(b) = r.extended_rms.components.get(name) {
            let unit = testbed_ident::predict::UNITS[testbed_ident::predict::COMPONENTS
                .iter()
                .position(|c| c == name)
                .unwrap_or(0)];
            writeln!(
                out,
                "    {:<10} {:>14.4e} {:>14.4e} {:>10} {:>10.3}",
                name,
                a.rms,
                b.rms,
                unit,
                a.rms / b.rms
            )?;
        }
    }
    for (group, a) in &r.baseline_rms.groups {
        if let Some(b) = r.extended_rms.groups.get(group) {
            writeln!(
                out,
                "    {:<14} normalised {:>8.3} -> {:>8.3}  gain {:.3}",
                group,
                a,
                b,
                a / b
            )?;
        }
    }
    writeln!(
        out,
        "    overall (normalised) {:.3} -> {:.3}: gain {:.3}",
        r.baseline_rms.overall, r.extended_rms.overall, r.gain
    )?;
    Ok(out)
}

fn render_components(
    out: &mut String,
    report: &testbed_ident::identify::ResidualReport,
) -> std::fmt::Result {
    writeln!(
        out,
        "    {:<20} {:>12} {:>10} {:>12} {:>14} {:>7}",
        "residual", "RMS", "RMS/noise", "bias", "trend per h", "lag-1"
    )?;
    // No whiteness p-value: prediction errors over a window and the integrated momentum
    // residual are serially correlated by construction, so the white-noise null does not apply
    // to them; structure is judged by the unexplained-effect search instead.
    for c in report.prediction.iter().chain(&report.equation_error) {
        writeln!(
            out,
            "    {:<20} {:>12.4e} {:>10.2} {:>12.3e} {:>14.3e} {:>7.2}  {}",
            c.name,
            c.stats.rms,
            c.normalised_rms,
            c.stats.mean,
            c.stats.trend_per_h,
            c.stats.lag1,
            c.unit
        )?;
    }
    let rms: Vec<String> = report
        .channel_rms_held_out
        .iter()
        .map(|(k, v)| format!("{k} {v:.2}"))
        .collect();
    writeln!(
        out,
        "    equation-error channels, whitened RMS on held-out data (1 = noise as modelled): {}",
        rms.join(", ")
    )?;
    Ok(())
}
