//! The data path: the measured-data CSV directory (round trip, and every kind of bad data refused
//! with the file and row named), the MCAP run log, and the experiment's schedule.

mod common;
use common::*;
use ipc_types::{
    GyroSample, InclinometerSample, MagnetometerSample, SampleHeader, WheelCommand, WheelTelemetry,
};
use std::path::{Path, PathBuf};
use testbed_ident::experiment::ExperimentOptions;
use testbed_ident::{Dataset, Options, csv, identify, runlog};
use testbed_log::{RunInfo, RunLogWriter};

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("testbed-ident-data-{}-{tag}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// A clean 120 s record written as a CSV directory.
fn clean_dir(tag: &str) -> (PathBuf, Dataset) {
    let data = experiment_data(&nominal(), 5, 120.0);
    let dir = temp_dir(tag);
    csv::write_dir(&dir, &data).expect("write");
    (dir, data)
}

/// Read the directory and identify: the error text, if any.
fn identify_dir(dir: &Path) -> Result<String, String> {
    let data = csv::read_dir(dir).map_err(|e| e.to_string())?;
    identify(&data, &nominal(), &Options::default())
        .map(|id| id.report.verdict)
        .map_err(|e| e.to_string())
}

/// Replace line `line` (1 = header) of a file.
fn edit_line(path: &Path, line: usize, f: impl Fn(&str) -> String) {
    let text = std::fs::read_to_string(path).expect("read");
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == line { f(l) } else { l.to_string() })
        .collect();
    std::fs::write(path, lines.join("\n") + "\n").expect("write");
}

#[test]
fn csv_directory_round_trips_and_identifies_like_memory() {
    let (dir, data) = clean_dir("roundtrip");
    let back: Dataset = csv::read_dir(&dir).expect("read back");
    assert_eq!(back.gyro, data.gyro);
    assert_eq!(back.inclinometer, data.inclinometer);
    assert_eq!(back.magnetometer, data.magnetometer);
    assert_eq!(back.wheels, data.wheels);
    assert!(
        back.cmg.is_empty() && !dir.join("cmg.csv").exists(),
        "no CMGs used, no cmg.csv"
    );
    let a = identify(&data, &nominal(), &Options::default()).expect("in memory");
    let b = identify(&back, &nominal(), &Options::default()).expect("from files");
    assert_eq!(a.report.verdict, "none");
    assert_eq!(b.report.verdict, a.report.verdict);
    assert_eq!(b.report.gain, a.report.gain);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn columns_in_another_order_give_the_same_dataset() {
    let (dir, _) = clean_dir("reordered");
    let before: Dataset = csv::read_dir(&dir).expect("read");
    // Reverse the column order of every file, header and rows alike.
    for name in [
        "gyro.csv",
        "inclinometer.csv",
        "magnetometer.csv",
        "wheels.csv",
    ] {
        let p = dir.join(name);
        let text = std::fs::read_to_string(&p).expect("read");
        let out: Vec<String> = text
            .lines()
            .map(|l| l.split(',').rev().collect::<Vec<_>>().join(","))
            .collect();
        std::fs::write(&p, out.join("\n") + "\n").expect("write");
    }
    let header = std::fs::read_to_string(dir.join("wheels.csv")).expect("read");
    assert!(
        header.starts_with("torque_z,torque_y,torque_x,speed_z,"),
        "{header}"
    );
    let after: Dataset = csv::read_dir(&dir).expect("read reordered");
    assert_eq!(after, before);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_number_truncated_at_the_end_of_a_file_is_refused() {
    let (dir, _) = clean_dir("truncated");
    // The file ends in the middle of the last row's last number, as an interrupted copy would.
    let p = dir.join("inclinometer.csv");
    let text = std::fs::read_to_string(&p).expect("read");
    let lines: Vec<&str> = text.lines().collect();
    let last = lines.len();
    let mut keep = lines[..last - 1].join("\n");
    keep.push_str("\n0.12,3.4,1e");
    std::fs::write(&p, &keep).expect("write");
    let e = csv::read_dir::<Dataset>(&dir).unwrap_err().to_string();
    println!("truncated: {e}");
    for part in [
        "inclinometer.csv",
        &format!("row {}", last - 1),
        &format!("line {last}"),
        "`tilt_y`",
        "`1e`",
        "truncated or malformed",
    ] {
        assert!(e.contains(part), "`{part}` not in: {e}");
    }
    // A number cut before its exponent's digits or after its decimal point, anywhere in a row.
    for cut in ["2.5e-", "2."] {
        let mut keep = lines[..last - 1].join("\n");
        keep.push_str(&format!("\n{cut},0.001,0.002"));
        std::fs::write(&p, &keep).expect("write");
        let e = csv::read_dir::<Dataset>(&dir).unwrap_err().to_string();
        println!("truncated: {e}");
        assert!(
            e.contains(&format!("line {last}")) && e.contains("`t_s`") && e.contains(cut),
            "{e}"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_data_is_refused_naming_the_file_and_row() {
    // (what is wrong, how to break a good data directory, what the error must name)
    type Case<'a> = (&'a str, Box<dyn Fn(&Path)>, Vec<&'a str>);
    let cases: Vec<Case> = vec![
        (
            "missing gyro",
            Box::new(|d: &Path| std::fs::remove_file(d.join("gyro.csv")).expect("rm")),
            vec!["gyro.csv", "missing"],
        ),
        (
            "no vector sensor",
            Box::new(|d: &Path| {
                std::fs::remove_file(d.join("inclinometer.csv")).expect("rm");
                std::fs::remove_file(d.join("magnetometer.csv")).expect("rm");
            }),
            vec!["inclinometer.csv", "magnetometer.csv", "missing"],
        ),
        (
            "wrong column",
            Box::new(|d: &Path| {
                edit_line(&d.join("wheels.csv"), 1, |l| {
                    l.replace("speed_y", "speed_q")
                })
            }),
            vec!["wheels.csv", "header", "`speed_y` is missing"],
        ),
        (
            "extra column",
            Box::new(|d: &Path| {
                let p = d.join("inclinometer.csv");
                let text = std::fs::read_to_string(&p).expect("read");
                let out: Vec<String> = text
                    .lines()
                    .enumerate()
                    .map(|(i, l)| {
                        if i == 0 {
                            format!("{l},temp")
                        } else {
                            format!("{l},20")
                        }
                    })
                    .collect();
                std::fs::write(&p, out.join("\n") + "\n").expect("write");
            }),
            vec!["inclinometer.csv", "unknown column `temp`"],
        ),
        (
            "NaN",
            Box::new(|d: &Path| {
                edit_line(&d.join("magnetometer.csv"), 6, |l| {
                    let mut f: Vec<&str> = l.split(',').collect();
                    f[2] = "NaN";
                    f.join(",")
                })
            }),
            vec![
                "magnetometer.csv",
                "row 5",
                "line 6",
                "`by`",
                "not a finite number",
            ],
        ),
        (
            "not a number",
            Box::new(|d: &Path| {
                edit_line(&d.join("gyro.csv"), 100, |l| l.replacen(',', ",0.1x", 1))
            }),
            vec!["gyro.csv", "row 99", "`wx`", "not a number"],
        ),
        (
            "time goes back",
            Box::new(|d: &Path| {
                edit_line(&d.join("inclinometer.csv"), 11, |l| {
                    let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                    f[0] = "1.0".into();
                    f.join(",")
                })
            }),
            vec!["inclinometer.csv", "row 10", "time order"],
        ),
        (
            "short row",
            Box::new(|d: &Path| {
                edit_line(&d.join("wheels.csv"), 3, |l| {
                    l.rsplit_once(',').map(|x| x.0).unwrap_or("").to_string()
                })
            }),
            vec!["wheels.csv", "row 2", "6 fields"],
        ),
        (
            "too short",
            Box::new(|d: &Path| {
                let p = d.join("gyro.csv");
                let text = std::fs::read_to_string(&p).expect("read");
                let keep: Vec<&str> = text.lines().take(301).collect();
                // Complete rows (a file ending without a newline is refused as cut).
                std::fs::write(&p, keep.join("\n") + "\n").expect("write");
            }),
            vec!["gyro.csv", "29.9 s", "at least 60 s"],
        ),
        (
            "another clock",
            Box::new(|d: &Path| {
                let p = d.join("wheels.csv");
                let text = std::fs::read_to_string(&p).expect("read");
                let out: Vec<String> = text
                    .lines()
                    .enumerate()
                    .map(|(i, l)| {
                        if i == 0 {
                            return l.to_string();
                        }
                        let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                        f[0] = format!("{}", f[0].parse::<f64>().unwrap_or(0.0) + 1.0e4);
                        f.join(",")
                    })
                    .collect();
                std::fs::write(&p, out.join("\n") + "\n").expect("write");
            }),
            vec!["wheels.csv", "one clock"],
        ),
        (
            "empty file",
            Box::new(|d: &Path| std::fs::write(d.join("magnetometer.csv"), "").expect("write")),
            vec!["magnetometer.csv", "empty"],
        ),
    ];
    for (i, (label, corrupt, expect)) in cases.iter().enumerate() {
        let (dir, _) = clean_dir(&format!("bad{i}"));
        corrupt(&dir);
        let message = match identify_dir(&dir) {
            Ok(verdict) => panic!("{label}: accepted (verdict {verdict})"),
            Err(e) => e,
        };
        println!("{label}: {message}");
        for part in expect {
            assert!(
                message.contains(part),
                "{label}: `{part}` not in: {message}"
            );
        }
        std::fs::remove_dir_all(dir).ok();
    }
    // Not data at all.
    let e = csv::read_dir::<Dataset>(Path::new("/nonexistent/testbed"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/testbed"), "{e}");
}

#[test]
fn mcap_run_log_reads_like_the_csv_directory() {
    let data = experiment_data(&nominal(), 6, 120.0);
    let dir = temp_dir("mcap");
    let path = dir.join("run.mcap");
    let info = RunInfo {
        profile: "simulation".into(),
        seed: 6,
        mode: "lockstep".into(),
        config_toml: String::new(),
        start_time_ns: 0,
        extra: Default::default(),
    };
    let mut log = RunLogWriter::create(&path, &info).expect("create log");
    let ns = |t: f64| (t * 1e9).round() as u64;
    let header = |t: f64, seq: usize| {
        SampleHeader::new(
            ns(t),
            seq as u64,
            SampleHeader::VALID | SampleHeader::SIMULATED,
        )
    };
    for (i, r) in data.gyro.iter().enumerate() {
        log.write(&GyroSample::new(header(r.t_s, i), r.rate_rad_s.into()))
            .expect("write");
    }
    for (i, r) in data.inclinometer.iter().enumerate() {
        log.write(&InclinometerSample::new(header(r.t_s, i), r.tilt_rad))
            .expect("write");
    }
    for (i, r) in data.magnetometer.iter().enumerate() {
        log.write(&MagnetometerSample::new(header(r.t_s, i), r.field_t.into()))
            .expect("write");
    }
    for (i, r) in data.wheels.iter().enumerate() {
        log.write(&WheelTelemetry::new(
            header(r.t_s, i),
            r.speed_rad_s.into(),
            [0.0; 3],
        ))
        .expect("write");
        log.write(&WheelCommand::new(header(r.t_s, i), r.torque_nm.into()))
            .expect("write");
    }
    // An invalid sample is left out.
    log.write(&GyroSample::new(
        SampleHeader::new(ns(0.05), 0, 0),
        [1.0; 3],
    ))
    .expect("write");
    log.finish().expect("finish");

    let back = runlog::read_log(&path).expect("read log");
    assert_eq!(back.gyro.len(), data.gyro.len());
    assert_eq!(back.inclinometer.len(), data.inclinometer.len());
    assert_eq!(back.magnetometer.len(), data.magnetometer.len());
    assert_eq!(back.wheels.len(), data.wheels.len());
    for (a, b) in back.wheels.iter().zip(&data.wheels) {
        assert!(
            (a.t_s - b.t_s).abs() < 1e-9
                && a.speed_rad_s == b.speed_rad_s
                && a.torque_nm == b.torque_nm
        );
    }
    let id = identify(&back, &nominal(), &Options::default()).expect("identify the log");
    assert_eq!(id.report.verdict, "none");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn experiment_schedule_stays_within_the_stop_and_sweeps_the_wheels_through_zero() {
    let options = ExperimentOptions {
        duration_s: 1200.0,
        ..ExperimentOptions::default()
    };
    let schedule = options.schedule();
    assert_eq!(schedule.len(), 1201);
    let max_tilt = schedule
        .iter()
        .map(|c| c.pitch_deg.abs().max(c.roll_deg.abs()))
        .fold(0.0, f64::max);
    let max_heading = schedule
        .iter()
        .map(|c| c.heading_deg.abs())
        .fold(0.0, f64::max);
    assert!(
        max_tilt <= 7.0 + 1e-12 && max_heading <= 60.0 + 1e-9,
        "{max_tilt} {max_heading}"
    );
    // The simulated experiment: within the stop, wheels within their speed, each wheel through
    // zero.
    let data = experiment_data(&nominal(), 1, 1200.0);
    let max_measured_tilt = data
        .inclinometer
        .iter()
        .map(|r| r.tilt_rad[0].abs().max(r.tilt_rad[1].abs()))
        .fold(0.0, f64::max);
    assert!(
        max_measured_tilt.to_degrees() < 10.0,
        "{}",
        max_measured_tilt.to_degrees()
    );
    for w in 0..3 {
        let crossings = data
            .wheels
            .windows(2)
            .filter(|p| p[0].speed_rad_s[w] * p[1].speed_rad_s[w] < 0.0)
            .count();
        let slow = data
            .wheels
            .iter()
            .filter(|r| r.speed_rad_s[w].abs() < 2.0)
            .count();
        println!("wheel {w}: {crossings} sign changes, {slow} samples below 2 rad/s");
        assert!(
            crossings >= 2 && slow >= 20,
            "wheel {w}: {crossings} crossings, {slow} slow samples"
        );
        let max = data
            .wheels
            .iter()
            .map(|r| r.speed_rad_s[w].abs())
            .fold(0.0, f64::max);
        assert!(max < 0.9 * 628.3, "wheel {w} reaches {max} rad/s");
    }
}
