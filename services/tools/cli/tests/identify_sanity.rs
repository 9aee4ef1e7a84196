//! `testbed identify` on a data directory with an export mistake: the data error (file, columns,
//! the unit found and its factor) and exit status 1, no cause named and nothing written.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn testbed(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_testbed"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("testbed runs")
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("testbed-cli-sanity-{}-{tag}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// Multiply the value columns `columns` (by index, 0 = the time) of a CSV file by `factor`.
fn scale_columns(path: &Path, columns: &[usize], factor: f64) {
    let text = std::fs::read_to_string(path).expect("read");
    let mut lines = text.lines();
    let mut out = vec![lines.next().expect("header").to_string()];
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let fields: Vec<String> = line
            .split(',')
            .enumerate()
            .map(|(i, x)| {
                if columns.contains(&i) {
                    let v: f64 = x.trim().parse().expect("a number");
                    (v * factor).to_string()
                } else {
                    x.to_string()
                }
            })
            .collect();
        out.push(fields.join(","));
    }
    std::fs::write(path, out.join("\n") + "\n").expect("write");
}

/// A mistake: its tag, the file to spoil, its columns (by index), the factor, and what the
/// message must say.
type Case = (
    &'static str,
    &'static str,
    &'static [usize],
    f64,
    &'static [&'static str],
);

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create");
    for entry in std::fs::read_dir(from).expect("list") {
        let entry = entry.expect("entry");
        std::fs::copy(entry.path(), to.join(entry.file_name())).expect("copy");
    }
}

#[test]
fn export_mistakes_stop_identify_with_the_file_the_columns_and_the_unit() {
    let dir = scratch("units");
    let clean = dir.join("clean");
    let out = testbed(&[
        "experiment",
        "--out",
        clean.to_str().unwrap(),
        "--duration",
        "150",
        "--seed",
        "3",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let header = std::fs::read_to_string(clean.join("gyro.csv")).expect("gyro.csv");
    assert!(header.starts_with("t_s,wx,wy,wz"), "{header}");
    let model = dir.join("model.toml");
    std::fs::write(&model, "").expect("model");

    let cases: [Case; 3] = [
        (
            "degrees-per-second",
            "gyro.csv",
            &[1, 2, 3],
            180.0 / std::f64::consts::PI,
            &[
                "gyro.csv",
                "columns wx, wy, wz",
                "look like °/s, not rad/s",
                "57.",
            ],
        ),
        (
            "gauss",
            "magnetometer.csv",
            &[1, 2, 3],
            1e4,
            &[
                "magnetometer.csv",
                "columns bx, by, bz",
                "look like gauss, not tesla",
            ],
        ),
        (
            "flipped",
            "gyro.csv",
            &[3],
            -1.0,
            &["gyro.csv", "column wz", "looks sign-flipped"],
        ),
    ];
    for (tag, file, columns, factor, expected) in cases {
        let data = dir.join(tag);
        copy_dir(&clean, &data);
        scale_columns(&data.join(file), columns, factor);
        let report = dir.join(format!("{tag}-out"));
        let out = testbed(&[
            "identify",
            data.to_str().unwrap(),
            "--model",
            model.to_str().unwrap(),
            "--out",
            report.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        println!("{tag}: {stderr}");
        assert_eq!(out.status.code(), Some(1), "{tag}: {stderr}");
        for part in expected.iter().chain(&["no cause is named"]) {
            assert!(stderr.contains(part), "{tag}: `{part}` not in: {stderr}");
        }
        assert!(!stderr.contains("backtrace"), "{stderr}");
        assert!(
            String::from_utf8_lossy(&out.stdout).trim().is_empty(),
            "{tag}: a verdict was printed"
        );
        assert!(
            !report.join("report.json").exists(),
            "{tag}: a report was written"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
