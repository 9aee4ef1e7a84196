//! What a user sees for a wrong command line or a wrong name: one short block, no backtrace.

use std::process::{Command, Output};

fn testbed(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_testbed"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn negative_duration_is_refused_clearly() {
    let out = testbed(&["run", "--duration", "-5"]);
    let text = stderr(&out);
    assert!(!out.status.success());
    assert!(
        text.contains("'-5'") && text.contains("must be a positive number of seconds"),
        "{text}"
    );
    assert!(!text.contains("unexpected argument"), "{text}");
}

#[test]
fn negative_seed_is_refused_clearly() {
    let out = testbed(&["run", "--seed", "-1"]);
    let text = stderr(&out);
    assert!(!out.status.success());
    assert!(text.contains("not negative"), "{text}");
    assert!(!text.contains("unexpected argument"), "{text}");
}

#[test]
fn a_wrong_profile_lists_the_profiles_without_a_backtrace() {
    let out = testbed(&["run", "--profile", "simulaton"]);
    let text = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.starts_with("error: no profile `simulaton`"), "{text}");
    assert!(
        text.contains("simulation") && text.contains("can-sim") && text.contains("platform"),
        "{text}"
    );
    assert!(
        !text.contains("can-sim.run"),
        "a run configuration is not a profile: {text}"
    );
    assert!(
        !text.contains("backtrace") && text.lines().count() <= 3,
        "{text}"
    );
}

#[test]
fn a_missing_file_is_named_once() {
    let out = testbed(&["run", "--profile", "/nonexistent/p.toml"]);
    let text = stderr(&out);
    assert!(!out.status.success());
    assert!(text.contains("/nonexistent/p.toml"), "{text}");
    assert_eq!(text.matches("No such file").count(), 1, "{text}");
    assert!(!text.contains("backtrace"), "{text}");
}
