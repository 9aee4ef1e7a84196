//! `targets --from DIR` judges the reports a measuring run left: those of the run of 2026-11-29
//! on the development machine, kept in `bench/tests/fixtures/targets/` (their `measured-by`
//! names the directory they were written to then), copied to a scratch directory (the command
//! writes `targets.md` beside them).

use std::path::{Path, PathBuf};
use std::process::Command;

const SAVED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/targets");

/// The saved reports `targets` reads, copied into a fresh directory named after `test`.
fn scratch_copy(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("targets-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    for file in [
        "chain/report.json",
        "paced-run/report.json",
        "lockstep.json",
        "paced-cpu.json",
        "determinism.json",
        "hot-path-cpu",
        "measured-by",
    ] {
        let to = dir.join(file);
        std::fs::create_dir_all(to.parent().expect("a file in a directory")).expect("mkdir");
        std::fs::copy(Path::new(SAVED).join(file), &to)
            .unwrap_or_else(|e| panic!("copying {file}: {e}"));
    }
    dir
}

fn judge(dir: &Path) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_targets"))
        .arg("--from")
        .arg(dir)
        .output()
        .expect("running targets");
    let written = std::fs::read_to_string(dir.join("targets.md")).expect("targets.md written");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        written,
        "what is printed is what is written"
    );
    (out.status.code(), written)
}

#[test]
fn saved_reports_are_judged_again_one_verdict_per_target() {
    let dir = scratch_copy("all");
    let (code, md) = judge(&dir);
    // The saved run: the chain's idle median 3.04× the floor, the idle hop's p99
    // above the socket's, the paced CPU 0.514 %; the determinism runs (measured by a second
    // run that left the other parts out) byte-identical and equal to the in-process loop.
    assert!(
        md.contains("11 met, 3 not met, 0 without a verdict."),
        "{md}"
    );
    assert!(
        md.contains(
            "| paced CPU ≤ 0.5% of one core, all processes (`simulation`) | 0.514 % steady state"
        ),
        "{md}"
    );
    assert!(
        md.contains(
            "Measured by `target/deploy/targets --out bench/report-targets/session-31` and \
             `target/release/targets --skip chain,lockstep,paced-cpu,paced-run --out \
             bench/report-targets/session-31`, judged again by `"
        ),
        "{md}"
    );
    assert!(md.contains("the chain placed on CPU 0"), "{md}");
    assert!(
        md.contains("1501 estimates, every one equal in every bit | **met** |"),
        "{md}"
    );
    assert_eq!(code, Some(1), "a target not met fails the command");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_report_leaves_its_target_without_a_verdict() {
    let dir = scratch_copy("missing");
    std::fs::remove_file(dir.join("paced-cpu.json")).expect("remove");
    let (code, md) = judge(&dir);
    assert!(
        md.contains("11 met, 2 not met, 1 without a verdict."),
        "{md}"
    );
    assert!(md.contains("| paced CPU | reading "), "{md}");
    assert_eq!(code, Some(1));
    let _ = std::fs::remove_dir_all(&dir);
}
