//! `testbed identify`: what the simulation gets wrong in measured data, the cause, the extended
//! model and its gain; `testbed experiment`: a simulated identification experiment written as a
//! measured-data CSV directory. The report's text is in `report`, its figures in `figures`.

mod figures;
mod report;

use figures::write_figures;
use report::render_report;

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use testbed_ident::design::{self, Design, DesignOptions, Limit};
use testbed_ident::experiment::{self, ExperimentOptions};
use testbed_ident::separability::UNSEPARABLE_CORRELATION;
use testbed_ident::{Dataset, Options, csv, runlog};
use testbed_model::ModelConfig;
use testbed_model::config::{DEG, RPM};

#[derive(Debug, clap::Args)]
pub struct IdentifyArgs {
    /// Measured data: a directory of CSV files (the contract of docs/measured-data.md) or an MCAP
    /// run log of the pipeline.
    data: PathBuf,
    /// The nominal model configuration (TOML) to test against the data.
    #[arg(long)]
    model: PathBuf,
    /// Directory for the extended model, the report and the figures.
    #[arg(long, default_value = "out/identify")]
    out: PathBuf,
    /// Print the report as one JSON object instead of the tables.
    #[arg(long)]
    json: bool,
    /// k-fold cross-validation of the selection and the gain over 30-s blocks (block b in fold
    /// b mod K; the fits use all the data); 0: one third of the blocks held out of the fits
    /// instead.
    #[arg(long, default_value_t = 5)]
    folds: usize,
    /// Candidate causes only these (comma-separated names of the library); default all. A
    /// targeted identification, e.g. `com_offset` for `testbed balance` (docs/balance.md).
    #[arg(long, value_delimiter = ',')]
    causes: Vec<String>,
    /// No search for unexplained effects: the named causes only.
    #[arg(long)]
    no_unexplained: bool,
    /// Analyse the data from this time on, s from the record's start (the first gyro row): the
    /// part after a change within the record that the report found.
    #[arg(long)]
    from_s: Option<f64>,
    /// Analyse the data up to this time, s from the record's start.
    #[arg(long)]
    to_s: Option<f64>,
}

#[derive(Debug, clap::Args)]
pub struct ExperimentArgs {
    /// Directory to write the measured-data CSV files to.
    #[arg(long)]
    out: PathBuf,
    /// The simulated test bed's configuration (TOML), hidden effects included; the defaults of
    /// docs/parameters.md when absent.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Simulated duration, s.
    #[arg(long, default_value_t = 600.0)]
    duration: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The thruster programme instead: heading held, tilt steps, the wheels past the dump
    /// threshold and momentum dumping on the thrusters (the model needs `[thrusters]`; a
    /// constant disturbance in it makes every thruster fire): data for thruster_torque_scale
    /// and propellant_com_shift.
    #[arg(long, conflicts_with = "design")]
    thrusters: bool,
    /// Design the programme first: search the heading amplitude and rate, tilt step and dwell
    /// and initial wheel momentum for the largest information (D-optimal) on the target causes
    /// within the tilt and wheel-speed limits, each candidate simulated on the model at this
    /// duration; print the design beside the default programme with the predicted standard
    /// errors, then run the designed programme.
    #[arg(long)]
    design: bool,
    /// Causes the design targets (comma-separated names of the library; all but
    /// actuator_delay and the thrusters' causes can be targeted); default all of those.
    #[arg(long, value_delimiter = ',', requires = "design")]
    targets: Vec<String>,
    /// Unmodelled horizontal centre-of-mass offset, m, the designed programme must survive
    /// within the limits (each candidate is also simulated with it along ±X and ±Y); 0: none.
    #[arg(long, default_value_t = 2e-7, requires = "design")]
    com_allowance_m: f64,
}

/// Read measured data: a CSV directory or an MCAP run log.
fn load_data(path: &Path) -> Result<Dataset> {
    if path.is_dir() {
        csv::read_dir(path)
            .with_context(|| format!("reading the measured-data directory {}", path.display()))
    } else if path.is_file() {
        runlog::read_log(path).with_context(|| format!("reading the run log {}", path.display()))
    } else {
        bail!(
            "{}: no such directory or file (expected a measured-data CSV directory or an MCAP run log)",
            path.display()
        )
    }
}

/// The part of `data` from `from_s` to `to_s` (s from the record's start), checked.
fn window(data: Dataset, from_s: Option<f64>, to_s: Option<f64>) -> Result<Dataset> {
    if from_s.is_none() && to_s.is_none() {
        return Ok(data);
    }
    let duration = data.duration_s();
    for (name, value) in [("--from-s", from_s), ("--to-s", to_s)] {
        if let Some(v) = value
            && !(v.is_finite() && (0.0..=duration).contains(&v))
        {
            bail!("{name} {v}: outside the record (0 to {duration:.1} s from its start)");
        }
    }
    if let (Some(a), Some(b)) = (from_s, to_s)
        && a >= b
    {
        bail!("--from-s {a} is not before --to-s {b}");
    }
    Ok(data.between(from_s, to_s))
}

pub fn run_identify(args: &IdentifyArgs) -> Result<()> {
    let model = ModelConfig::load(&args.model)
        .with_context(|| format!("loading the model {}", args.model.display()))?;
    let data = window(load_data(&args.data)?, args.from_s, args.to_s)?;
    let mut options = Options {
        folds: args.folds,
        ..Options::default()
    };
    if !args.causes.is_empty() {
        options.candidates = args
            .causes
            .iter()
            .map(|name| {
                testbed_ident::Cause::from_name(name)
                    .with_context(|| format!("--causes: `{name}` is no cause of the library"))
            })
            .collect::<Result<_>>()?;
    }
    if args.no_unexplained {
        options.sparse.max_terms = 0;
    }
    let result = testbed_ident::identify(&data, &model, &options).with_context(|| {
        format!(
            "identifying {} against {}",
            args.data.display(),
            args.model.display()
        )
    })?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let model_path = args.out.join("extended_model.toml");
    let header = format!(
        "# Extended model: {} plus the effects identified in {} ({}).\n",
        args.model.display(),
        args.data.display(),
        result.report.verdict
    );
    std::fs::write(&model_path, header + &result.extended.to_toml_string())
        .with_context(|| format!("writing {}", model_path.display()))?;
    // The file must load as it is.
    ModelConfig::load(&model_path)
        .with_context(|| format!("re-reading {}", model_path.display()))?;
    let figures = write_figures(&args.out, &result.figures, result.report.options.horizon_s)?;
    let mut value = serde_json::to_value(&result.report)?;
    value["extended_model"] = serde_json::json!(model_path.display().to_string());
    value["figures"] = serde_json::json!(figures);
    let report_path = args.out.join("report.json");
    std::fs::write(&report_path, serde_json::to_string_pretty(&value)?)
        .with_context(|| format!("writing {}", report_path.display()))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print!("{}", render_report(&result.report)?);
        println!();
        println!("extended model: {}", model_path.display());
        println!("report:         {}", report_path.display());
        for f in &figures {
            println!("figure:         {f}");
        }
    }
    Ok(())
}

pub fn run_experiment(args: &ExperimentArgs) -> Result<()> {
    let model = match &args.model {
        Some(path) => ModelConfig::load(path)
            .with_context(|| format!("loading the model {}", path.display()))?,
        None => ModelConfig::default(),
    };
    let options = if args.thrusters {
        ExperimentOptions::thruster_programme(args.duration, args.seed)
    } else {
        ExperimentOptions {
            duration_s: args.duration,
            seed: args.seed,
            ..ExperimentOptions::default()
        }
    };
    let design = if args.design {
        let d = run_design(&model, &options, &args.targets, args.com_allowance_m)?;
        print_design(&d, &model);
        Some(d)
    } else {
        None
    };
    let options = design
        .as_ref()
        .map_or(options, |d| d.chosen.options.clone());
    let (mut data, trace) =
        experiment::run(&model, &options).context("running the identification experiment")?;
    data.source = args.out.clone();
    let written = csv::write_dir(&args.out, &data)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let max_tilt = trace
        .ticks
        .iter()
        .map(|t| {
            let [a, b] = testbed_model::attitude::tilt_angles(&t.truth.q);
            a.abs().max(b.abs())
        })
        .fold(0.0, f64::max);
    let max_wheel = trace
        .ticks
        .iter()
        .map(|t| t.truth.wheel_speed.amax())
        .fold(0.0, f64::max);
    // Thruster on-time per thruster, s (all zero without the thruster programme).
    let on_time_s = data.thrusters.iter().fold([0.0; 6], |mut sum, row| {
        for (s, t) in sum.iter_mut().zip(row.on_time_s) {
            *s += t;
        }
        sum
    });
    let info = serde_json::json!({
        "model": args.model.as_ref().map(|p| p.display().to_string()),
        "thruster_on_time_s": on_time_s,
        "options": options,
        "tilt_stop_strikes": trace.tilt_stops.len(),
        "wheel_saturated": max_wheel >= 0.97 * model.wheels.max_speed_rad_s(),
        "max_tilt_deg": max_tilt / DEG,
        "max_wheel_speed_rpm": max_wheel / RPM,
        "design": design,
    });
    let info_path = args.out.join("experiment.json");
    std::fs::write(&info_path, serde_json::to_string_pretty(&info)?)
        .with_context(|| format!("writing {}", info_path.display()))?;
    println!(
        "experiment: {:.0} s, seed {}; heading ±{}° at {}°/s (slow {}°/s near wheel zero crossings), tilt steps {}° every {} s",
        options.duration_s,
        options.seed,
        options.heading_amplitude_deg,
        options.heading_rate_deg_s,
        options.slow_rate_deg_s,
        options.tilt_deg,
        options.tilt_dwell_s
    );
    println!(
        "  max tilt {:.2}° (stop at {}°), {} tilt-stop strikes, max wheel speed {:.0} rpm",
        max_tilt / DEG,
        model.platform.tilt_limit_deg,
        trace.tilt_stops.len(),
        max_wheel / RPM
    );
    if options.thrusters {
        println!(
            "  thrusters: momentum dumping; on-time [{}] s per thruster",
            on_time_s.map(|t| format!("{t:.1}")).join(" ")
        );
        if let Some(idle) = on_time_s.iter().position(|t| *t == 0.0) {
            eprintln!(
                "warning: thruster {idle} never fired: its scale cannot be identified from these data; a constant disturbance in the model makes the wheels fill and every thruster fire"
            );
        }
    }
    // A programme that strikes the stop or saturates a wheel measures the stop and the speed
    // limiter, not the effects it is meant to excite: say so.
    if !trace.tilt_stops.is_empty() {
        eprintln!(
            "warning: the programme hit the tilt stop {} time(s) (max tilt {:.1}° of {}°): the data near those strikes are left out of the torque channel and the platform was not under control; reduce the tilt steps or look for a large centre-of-mass offset in the model",
            trace.tilt_stops.len(),
            max_tilt / DEG,
            model.platform.tilt_limit_deg
        );
    }
    let speed_limit = model.wheels.max_speed_rad_s();
    if max_wheel >= 0.97 * speed_limit {
        eprintln!(
            "warning: a wheel reached {:.0} rpm of its {:.0} rpm limit (saturated): the controller lost authority about that axis; shorten the programme or lower the heading rate",
            max_wheel / RPM,
            speed_limit / RPM
        );
    }
    for f in written.iter().chain(std::iter::once(&info_path)) {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// The design search of `testbed experiment --design` around `baseline` on `model`.
fn run_design(
    model: &ModelConfig,
    baseline: &ExperimentOptions,
    targets: &[String],
    com_allowance_m: f64,
) -> Result<Design> {
    let mut settings = DesignOptions::default();
    settings.limits.com_allowance_m = com_allowance_m;
    if !targets.is_empty() {
        settings.targets = targets
            .iter()
            .map(|name| {
                testbed_ident::Cause::from_name(name.trim())
                    .with_context(|| format!("--targets: `{name}` is not a cause of the library"))
            })
            .collect::<Result<_>>()?;
    }
    let started = std::time::Instant::now();
    let d = design::design(model, baseline, &settings).context("designing the experiment")?;
    println!(
        "design: {} programmes of {:.0} s simulated on the model in {:.1} s, {} pass(es) of coordinate search; limits: no tilt-stop strike, tilt ≤ {:.1}°, wheel speed ≤ {:.0} % of the limit, also with {:.2} µm more centre-of-mass offset along ±X or ±Y",
        d.evaluated,
        baseline.duration_s,
        started.elapsed().as_secs_f64(),
        d.passes,
        model.platform.tilt_limit_deg - d.limits.tilt_margin_deg,
        100.0 * d.limits.wheel_speed_fraction,
        1e6 * d.limits.com_allowance_m,
    );
    let count = |l: Limit| d.rejections.iter().filter(|r| r.limit == l).count();
    println!(
        "  rejected: {} (tilt-stop strike {}, tilt {}, wheel speed {}, simulation failed {})",
        d.rejected,
        count(Limit::TiltStop),
        count(Limit::Tilt),
        count(Limit::WheelSpeed),
        count(Limit::Failed)
    );
    Ok(d)
}

/// The design beside the default programme: options, limits reached, criterion and the
/// predicted standard errors.
fn print_design(d: &Design, model: &ModelConfig) {
    let (a, b) = (&d.baseline, &d.chosen);
    let row = |name: &str, x: String, y: String| println!("  {name:<34} {x:>18} {y:>18}");
    row("", "default".into(), "designed".into());
    type Field = fn(&ExperimentOptions) -> f64;
    let options: [(&str, Field); 4] = [
        ("heading_amplitude_deg", |o| o.heading_amplitude_deg),
        ("heading_rate_deg_s", |o| o.heading_rate_deg_s),
        ("tilt_deg", |o| o.tilt_deg),
        ("tilt_dwell_s", |o| o.tilt_dwell_s),
    ];
    for (name, value) in options {
        row(
            name,
            format!("{}", value(&a.options)),
            format!("{}", value(&b.options)),
        );
    }
    let h = |o: &ExperimentOptions| format!("{:?}", o.wheel_momentum_nms);
    row("wheel_momentum_nms", h(&a.options), h(&b.options));
    row(
        "max tilt, deg",
        format!("{:.1}", a.max_tilt_deg),
        format!("{:.1}", b.max_tilt_deg),
    );
    row(
        "max wheel speed, % of limit",
        format!("{:.0}", 100.0 * a.max_wheel_speed_fraction),
        format!("{:.0}", 100.0 * b.max_wheel_speed_fraction),
    );
    row(
        &format!(
            "  with ±{:.2} µm CoM offset",
            1e6 * d.limits.com_allowance_m
        ),
        format!("{:.0}", 100.0 * a.worst_with_allowance.wheel_fraction),
        format!("{:.0}", 100.0 * b.worst_with_allowance.wheel_fraction),
    );
    row(
        "log det F (typical units)",
        format!("{:.2}", a.criterion.log_det),
        format!("{:.2}", b.criterion.log_det),
    );
    row(
        "undetermined directions",
        a.criterion.unidentified.to_string(),
        b.criterion.unidentified.to_string(),
    );
    if let Some(why) = &a.rejected {
        eprintln!(
            "warning: the default programme breaks the design's limits on this model: it {why}"
        );
    }
    if a.options == b.options {
        println!("  the default programme is already the best found");
    }
    println!(
        "  predicted standard errors (noise as modelled; the tilt stop is at {}°):",
        model.platform.tilt_limit_deg
    );
    println!(
        "  {:<42} {:>12} {:>12} {:>8}",
        "parameter", "default", "designed", "ratio"
    );
    let ratio = d.stderr_ratio();
    for (i, p) in d.parameters.iter().enumerate() {
        println!(
            "  {p:<42} {:>12.3e} {:>12.3e} {:>8.2}",
            a.stderr[i], b.stderr[i], ratio[i]
        );
    }
    if d.unseparable.is_empty() {
        println!(
            "  the designed programme separates every pair of these causes (no predicted \
             correlation at or above {UNSEPARABLE_CORRELATION})"
        );
    } else {
        println!(
            "  causes the designed programme cannot separate (predicted correlation at or \
             above {UNSEPARABLE_CORRELATION}): an effect of one can be named as the other"
        );
        for c in &d.unseparable {
            let how = c.correlation.map_or_else(
                || "not determined apart at all".to_string(),
                |r| format!("correlation {r:+.4}"),
            );
            println!("    {} and {}: {how}", c.first, c.second);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thruster programme writes thruster rows with firings of every thruster when the
    /// truth has a constant disturbance, and refuses a model without thrusters.
    #[test]
    fn the_thruster_programme_writes_firings_and_needs_thrusters() {
        let dir =
            std::env::temp_dir().join(format!("testbed-cli-thrusters-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        let truth = dir.join("truth.toml");
        std::fs::write(
            &truth,
            "[thrusters]\n\n[effects.constant_torque]\ntorque_nm = [1.2e-3, -1.2e-3, 1.8e-3]\n",
        )
        .unwrap();
        let data = dir.join("data");
        run_experiment(&ExperimentArgs {
            out: data.clone(),
            model: Some(truth),
            duration: 600.0,
            seed: 3,
            thrusters: true,
            design: false,
            targets: Vec::new(),
            com_allowance_m: 2e-7,
        })
        .unwrap();
        let read: Dataset = csv::read_dir(&data).unwrap();
        let mut fired = [0usize; 6];
        for row in &read.thrusters {
            for (n, t) in fired.iter_mut().zip(row.on_time_s) {
                *n += usize::from(t > 0.0);
            }
        }
        assert!(
            fired.iter().all(|n| *n > 0),
            "pulses per thruster {fired:?}"
        );
        let bare = dir.join("bare.toml");
        std::fs::write(&bare, "").unwrap();
        let err = run_experiment(&ExperimentArgs {
            out: dir.join("none"),
            model: Some(bare),
            duration: 60.0,
            seed: 3,
            thrusters: true,
            design: false,
            targets: Vec::new(),
            com_allowance_m: 2e-7,
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("[thrusters]"), "{err:#}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `--design` searches, runs the designed programme and records the design in
    /// experiment.json; a target the design does not cover, or no cause at all, is refused by
    /// name.
    #[test]
    fn the_designed_experiment_records_its_design() {
        let dir = std::env::temp_dir().join(format!("testbed-cli-design-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        let data = dir.join("data");
        run_experiment(&ExperimentArgs {
            out: data.clone(),
            model: None,
            duration: 180.0,
            seed: 4,
            thrusters: false,
            design: true,
            targets: vec!["com_offset".into(), "inertia_error".into()],
            com_allowance_m: 2e-7,
        })
        .unwrap();
        assert!(data.join("gyro.csv").is_file());
        let info: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(data.join("experiment.json")).unwrap())
                .unwrap();
        let design = &info["design"];
        assert_eq!(design["parameters"].as_array().unwrap().len(), 9);
        assert!(design["unseparable"].is_array(), "{design}");
        // The programme run is the designed one, at the duration and seed asked for.
        assert_eq!(info["options"], design["chosen"]["options"]);
        assert_eq!(info["options"]["duration_s"], 180.0);
        assert_eq!(info["options"]["seed"], 4);
        let log_det = |e: &serde_json::Value| e["criterion"]["log_det"].as_f64().unwrap();
        assert!(log_det(&design["chosen"]) >= log_det(&design["baseline"]));
        assert_eq!(info["tilt_stop_strikes"], 0);
        let err = run_experiment(&ExperimentArgs {
            out: dir.join("bad"),
            model: None,
            duration: 60.0,
            seed: 4,
            thrusters: false,
            design: true,
            targets: vec!["thruster_torque_scale".into()],
            com_allowance_m: 2e-7,
        })
        .unwrap_err();
        assert!(
            format!("{err:#}").contains("thruster_torque_scale"),
            "{err:#}"
        );
        let err = run_experiment(&ExperimentArgs {
            out: dir.join("bad"),
            model: None,
            duration: 60.0,
            seed: 4,
            thrusters: false,
            design: true,
            targets: vec!["no_such_cause".into()],
            com_allowance_m: 2e-7,
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("no_such_cause"), "{err:#}");
        let err = run_experiment(&ExperimentArgs {
            out: dir.join("bad"),
            model: None,
            duration: 60.0,
            seed: 4,
            thrusters: false,
            design: true,
            targets: Vec::new(),
            com_allowance_m: -1.0,
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("com_allowance_m"), "{err:#}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn experiment_then_identify_writes_model_report_and_figures() {
        let dir = std::env::temp_dir().join(format!("testbed-cli-identify-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).unwrap();
        let truth = dir.join("truth.toml");
        std::fs::write(
            &truth,
            "[effects.wheel_torque_scale]\nscale = [0.95, 1.04, 0.97]\n",
        )
        .unwrap();
        let nominal = dir.join("nominal.toml");
        std::fs::write(&nominal, "").unwrap();
        let data = dir.join("data");
        run_experiment(&ExperimentArgs {
            out: data.clone(),
            model: Some(truth),
            duration: 300.0,
            seed: 3,
            thrusters: false,
            design: false,
            targets: Vec::new(),
            com_allowance_m: 2e-7,
        })
        .unwrap();
        for f in [
            "gyro.csv",
            "inclinometer.csv",
            "magnetometer.csv",
            "wheels.csv",
        ] {
            assert!(data.join(f).is_file(), "{f}");
        }
        let out = dir.join("out");
        run_identify(&IdentifyArgs {
            data: data.clone(),
            model: nominal.clone(),
            out: out.clone(),
            json: true,
            folds: 5,
            causes: Vec::new(),
            no_unexplained: false,
            from_s: None,
            to_s: None,
        })
        .unwrap();
        let extended = ModelConfig::load(&out.join("extended_model.toml")).unwrap();
        let scale = extended
            .effects
            .wheel_torque_scale
            .expect("identified")
            .scale;
        assert!(
            (scale[0] - 0.95).abs() < 0.005 && (scale[1] - 1.04).abs() < 0.005,
            "{scale:?}"
        );
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(report["causes"][0]["name"], "wheel_torque_scale");
        assert!(
            report["causes"][0]["parameters"]["scale"].is_array()
                && report["causes"][0]["stderr"]["scale"].is_array()
        );
        assert!(
            report["baseline_rms"]["overall"].as_f64().unwrap()
                > report["extended_rms"]["overall"].as_f64().unwrap()
        );
        assert!(report["gain"].as_f64().unwrap() > 5.0);
        // The text report: verdict first (the named cause with its rounded parameters), then
        // the evidence; no whiteness p-value (the wrong null for these residuals). With the
        // held-out third instead of cross-validation (`--folds 0`) the same cause.
        let held_out = Options {
            folds: 0,
            ..Options::default()
        };
        let again = testbed_ident::identify(
            &load_data(&data).unwrap(),
            &ModelConfig::default(),
            &held_out,
        )
        .unwrap();
        let text = render_report(&again.report).unwrap();
        assert!(
            text.starts_with("VERDICT\n  Named cause: wheel_torque_scale"),
            "{text}"
        );
        assert!(text.find("VERDICT") < text.find("EVIDENCE"), "{text}");
        assert!(!text.contains("white p"), "{text}");
        assert!(text.contains("held out of the fits"), "{text}");
        // With 5-fold cross-validation (the default): the same cause, a cross-validated gain
        // above 5 (every tick after the filter's start predicted out of fold), and the report
        // says so.
        let cv = testbed_ident::identify(
            &load_data(&data).unwrap(),
            &ModelConfig::default(),
            &Options::default(),
        )
        .unwrap();
        assert_eq!(cv.report.verdict, "wheel_torque_scale");
        assert!(
            cv.report.gain > 5.0,
            "cross-validated gain {}",
            cv.report.gain
        );
        assert!(
            cv.report.data.held_out_fraction > 0.8,
            "{}",
            cv.report.data.held_out_fraction
        );
        let text = render_report(&cv.report).unwrap();
        assert!(text.contains("5-fold cross-validation"), "{text}");
        for f in ["nominal_residuals.svg", "equation_error.svg", "gain.svg"] {
            assert!(out.join(f).is_file(), "{f}");
        }
        // A missing data path is named.
        let err = run_identify(&IdentifyArgs {
            data: dir.join("nothing"),
            model: nominal,
            out,
            json: true,
            folds: 0,
            causes: Vec::new(),
            no_unexplained: false,
            from_s: None,
            to_s: None,
        })
        .unwrap_err();
        assert!(format!("{err:#}").contains("nothing"), "{err:#}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_window_outside_the_record_or_backwards_is_refused_with_its_bounds() {
        use testbed_ident::data::GyroRow;
        let gyro = (0..=100)
            .map(|i| GyroRow {
                t_s: 50.0 + i as f64,
                rate_rad_s: nalgebra::Vector3::zeros(),
            })
            .collect();
        let data = Dataset {
            gyro,
            ..Dataset::default()
        };
        let err = window(data.clone(), Some(120.0), None).unwrap_err();
        assert_eq!(
            err.to_string(),
            "--from-s 120: outside the record (0 to 100.0 s from its start)"
        );
        let err = window(data.clone(), Some(60.0), Some(40.0)).unwrap_err();
        assert_eq!(err.to_string(), "--from-s 60 is not before --to-s 40");
        // Times are from the record's start: rows at 70..=80 s of the data's clock.
        let part = window(data, Some(20.0), Some(30.0)).unwrap();
        assert_eq!(part.gyro.len(), 11);
        assert_eq!(part.gyro[0].t_s, 70.0);
    }
}
