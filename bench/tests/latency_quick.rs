//! The latency harness runs end to end in `--quick` mode and writes a well-formed report.
//! Structure only: no time is asserted (the machine is shared; see the report for numbers).

use std::path::{Path, PathBuf};
use std::process::Command;

/// `target/<profile>/` of this test.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test path");
    exe.parent()
        .and_then(Path::parent)
        .expect("target/<profile>/deps/<test>")
        .to_path_buf()
}

/// The paced part runs `testbed run`, which needs the workspace's binaries beside `latency`.
fn build_workspace_binaries() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args(["build", "--workspace", "--bins", "--quiet"]);
    // `target/debug` is the `dev` profile; any other directory the profile of its name.
    match profile_dir().file_name().and_then(|n| n.to_str()) {
        None | Some("debug") => {}
        Some(name) => {
            cmd.args(["--profile", name]);
        }
    }
    let status = cmd.status().expect("running cargo build");
    assert!(
        status.success(),
        "cargo build --workspace --bins failed: {status}"
    );
}

/// Every Markdown table: header and rows have the same number of cells.
fn check_tables(markdown: &str) -> usize {
    let mut tables = 0;
    let mut columns: Option<usize> = None;
    for (n, line) in markdown.lines().enumerate() {
        if line.starts_with('|') {
            assert!(
                line.ends_with('|'),
                "line {}: table row not closed: {line}",
                n + 1
            );
            let cells = line.matches('|').count() - 1;
            match columns {
                None => {
                    columns = Some(cells);
                    tables += 1;
                }
                Some(c) => assert_eq!(
                    cells,
                    c,
                    "line {}: {cells} cells in a table of {c}: {line}",
                    n + 1
                ),
            }
        } else {
            columns = None;
        }
    }
    tables
}

#[test]
fn quick_mode_writes_a_well_formed_report() {
    build_workspace_binaries();
    let out = std::env::temp_dir().join(format!("latency-quick-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let status = Command::new(env!("CARGO_BIN_EXE_latency"))
        .args(["--quick", "--chain-cpus", "0", "--out"])
        .arg(&out)
        .status()
        .expect("running latency --quick");
    assert!(status.success(), "latency --quick failed: {status}");

    let markdown = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    for heading in [
        "# Latency of the test bed's pipeline",
        "## Machine",
        "## Headline",
        "## Checks",
        "## Decision on the wait strategy",
        "## Chain: gyro gateway → estimator → controller → wheel gateway",
        "## One hop",
        "## Payload sweep",
        "## 10 Hz loop",
        "## Method",
    ] {
        assert!(markdown.contains(heading), "report.md lacks {heading:?}");
    }
    assert!(check_tables(&markdown) >= 6, "too few tables");
    assert!(markdown.contains("quick mode"), "a quick report says so");
    // The conclusions are hand-written text (bench/src/latency/report.md) around the generated
    // tables: one verdict on the wait strategy, and the bus chain explained against the
    // Unix-socket chain (how a doorbell hop works, the checks read).
    assert!(
        markdown.contains("**Keep `block`**") ^ markdown.contains("**Adopt `"),
        "exactly one decision on the wait strategy"
    );
    assert!(
        markdown.contains("## How a bus hop works, and why it now matches a socket")
            && markdown.contains("## The checks, read"),
        "report.md lacks the event chain against the socket chain"
    );
    assert!(
        !markdown.contains("at start-up"),
        "no special case for start-up deadline misses"
    );

    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("report.json")).expect("report.json"),
    )
    .expect("JSON");
    assert!(report["machine"]["cpus"].as_u64().unwrap_or(0) >= 1);
    assert!(
        !report["machine"]["kernel"]
            .as_str()
            .unwrap_or("")
            .is_empty()
    );
    let measurements = report["measurements"].as_array().expect("measurements");
    for kind in ["hop", "chain", "sweep"] {
        for transport in ["iox-event-block", "iox-poll", "uds", "udp"] {
            for load in [false, true] {
                assert!(
                    measurements.iter().any(|m| m["kind"] == kind
                        && m["transport"] == transport
                        && m["load"] == load),
                    "no {kind} row for {transport} (load {load})"
                );
            }
        }
    }
    // `--chain-cpus 0`: the chains that sleep, placed on CPU 0; never the busy-poll floor.
    let placed = |transport: &str| {
        measurements
            .iter()
            .filter(|m| m["kind"] == "chain" && m["transport"] == transport && m["chain_cpu"] == 0)
            .count()
    };
    for transport in ["iox-event-block", "uds", "udp"] {
        assert_eq!(
            placed(transport),
            2,
            "placed {transport} chain rows, idle and load"
        );
    }
    assert_eq!(placed("iox-poll"), 0, "the floor is never placed");
    assert!(
        markdown.contains("— chain on CPU 0"),
        "placed rows are named"
    );
    for m in measurements {
        assert!(m["error"].is_null(), "failed: {m}");
        let l = &m["latency"];
        let q: Vec<f64> = ["p50", "p90", "p99", "p999", "max"]
            .iter()
            .map(|k| l[k].as_f64().expect(k))
            .collect();
        assert!(l["n"].as_u64().unwrap_or(0) > 0, "{m}");
        assert!(
            q.windows(2).all(|w| w[0] <= w[1]),
            "percentiles out of order: {m}"
        );
        assert!(m["cpu_us_per_msg"].as_f64().unwrap_or(-1.0) >= 0.0);
    }
    let paced = report["paced"].as_array().expect("paced");
    assert!(!paced.is_empty(), "no paced run");
    for p in paced {
        assert!(p["error"].is_null(), "paced run failed: {p}");
        assert!(p["ticks"].as_u64().unwrap_or(0) > 0, "{p}");
        assert!(p["deadline_misses"].is_u64());
        // Deadlines are supervised from the first estimate on: starting the pipeline is no
        // miss. (Misses later in a run would be the machine's, not counted here.)
        println!(
            "paced {}: {} deadline misses over {} ticks",
            p["wait"], p["deadline_misses"], p["ticks"]
        );
    }

    let svg = std::fs::read_to_string(out.join("latency.svg")).expect("latency.svg");
    assert!(
        svg.trim_start().starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
        "not an SVG document"
    );
    assert!(
        svg.contains("<polyline") || svg.contains("<path"),
        "the figure has no curves"
    );
    assert!(
        svg.contains("payload sweep") && svg.contains("percentile"),
        "the figure lacks its panels"
    );
    std::fs::remove_dir_all(&out).expect("removing the report");
}
