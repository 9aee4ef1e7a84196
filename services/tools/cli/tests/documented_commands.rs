//! Every command line the documentation shows must exist: the `testbed …`, `launch/launch.sh …`
//! and `cargo run … -p testbed-cli -- …` lines of README.md and launch/README.md (code blocks
//! and inline code) and of the launch profiles' comments are parsed with the real command line
//! (`Cli::try_parse_from`), and a `testbed run` line's profile must be found. A documented flag
//! that does not exist fails this test.

use clap::Parser;
use std::path::{Path, PathBuf};
use testbed_cli::{Cli, Command};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// Candidate command lines of a Markdown file: code-block lines and inline code spans.
fn markdown_lines(text: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let mut in_block = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            continue;
        }
        if in_block {
            lines.push(line.to_string());
        } else {
            lines.extend(line.split('`').skip(1).step_by(2).map(str::to_string));
        }
    }
    lines
}

/// Candidate command lines of a profile: its comments, as lines and inline code spans.
fn comment_lines(text: &str) -> Vec<String> {
    let mut lines = Vec::new();
    for line in text
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix('#'))
    {
        lines.push(line.to_string());
        lines.extend(line.split('`').skip(1).step_by(2).map(str::to_string));
    }
    lines
}

/// The `testbed` argument vector a documented line stands for, if it is a `testbed` command.
fn as_testbed_args(line: &str) -> Option<Vec<String>> {
    let line = line
        .split(" # ")
        .next()
        .unwrap_or("")
        .replace(['[', ']'], " ");
    let mut words: Vec<&str> = line
        .split_whitespace()
        .filter(|w| !matches!(*w, "..." | "…" | "options" | "OPTIONS"))
        .collect();
    // Leading environment assignments (RUST_LOG=debug …).
    while words
        .first()
        .is_some_and(|w| w.contains('=') && !w.starts_with('-'))
    {
        words.remove(0);
    }
    let (first, rest) = words.split_first()?;
    // A bare `testbed` in prose names the tool; it is not a command line.
    if rest.is_empty() && *first == "testbed" {
        return None;
    }
    let rest: Vec<String> = rest.iter().map(|w| placeholder(w)).collect();
    let mut args = vec!["testbed".to_string()];
    match *first {
        "testbed" | "target/deploy/testbed" | "target/release/testbed" | "target/debug/testbed" => {
            args.extend(rest)
        }
        "launch/launch.sh" => {
            args.push("run".into());
            let mut rest = rest.into_iter().peekable();
            if let Some(profile) = rest.next_if(|w| !w.starts_with('-')) {
                args.extend(["--profile".to_string(), profile]);
            }
            args.extend(rest);
        }
        "cargo" if rest.first().is_some_and(|w| w == "run") => {
            let split = rest.iter().position(|w| w == "--")?;
            if split + 1 == rest.len() {
                return None; // `cargo run -p testbed-cli --` in prose: no command line
            }
            let package = rest
                .windows(2)
                .find(|w| w[0] == "-p" || w[0] == "--package")
                .map(|w| w[1].as_str());
            if package != Some("testbed-cli") && !rest.iter().any(|w| w == "--bin=testbed") {
                return None;
            }
            args.extend(rest[split + 1..].iter().cloned());
        }
        _ => return None,
    }
    Some(args)
}

/// A sample value for a placeholder (`N`, `S`, `NAME`, …); other words as they are.
fn placeholder(word: &str) -> String {
    match word {
        "N" => "1",
        "S" => "60",
        "NAME" | "PROFILE" => "simulation",
        other => other,
    }
    .to_string()
}

/// Parses one documented command line; the reason when it does not work.
fn check(args: &[String]) -> Result<(), String> {
    let cli = Cli::try_parse_from(args).map_err(|e| e.to_string())?;
    if let Command::Run(run) = &cli.command {
        testbed_cli::run::find_profile(run.profile_name()).map_err(|e| format!("{e:#}"))?;
    }
    Ok(())
}

fn documented() -> Vec<(String, String)> {
    let root = root();
    let mut found = Vec::new();
    for doc in ["README.md", "launch/README.md"] {
        let text = std::fs::read_to_string(root.join(doc)).unwrap();
        found.extend(
            markdown_lines(&text)
                .into_iter()
                .map(|l| (doc.to_string(), l)),
        );
    }
    let mut profiles: Vec<PathBuf> = std::fs::read_dir(root.join("launch/profiles"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    profiles.sort();
    for profile in profiles {
        let text = std::fs::read_to_string(&profile).unwrap();
        let name = profile
            .strip_prefix(&root)
            .unwrap_or(&profile)
            .display()
            .to_string();
        found.extend(comment_lines(&text).into_iter().map(|l| (name.clone(), l)));
    }
    found
}

#[test]
fn every_documented_command_line_parses() {
    let mut checked = 0;
    let mut failures = Vec::new();
    for (file, line) in documented() {
        let Some(args) = as_testbed_args(&line) else {
            continue;
        };
        checked += 1;
        if let Err(e) = check(&args) {
            failures.push(format!("{file}: `{}`:\n{e}", line.trim()));
        }
    }
    assert!(
        failures.is_empty(),
        "documented command lines that do not work:\n\n{}",
        failures.join("\n\n")
    );
    assert!(
        checked >= 10,
        "only {checked} documented command lines found: is the extraction broken?"
    );
}

#[test]
fn a_flag_that_does_not_exist_is_caught() {
    for line in [
        "launch/launch.sh simulation --duration-s 60",
        "testbed run --mode fast",
        "testbed run --profile nosuch",
    ] {
        let args = as_testbed_args(line).unwrap();
        assert!(check(&args).is_err(), "{line} should not parse");
    }
    let args =
        as_testbed_args("RUST_LOG=debug launch/launch.sh simulation [--seed 7] --json   # comment")
            .unwrap();
    assert_eq!(
        args,
        [
            "testbed",
            "run",
            "--profile",
            "simulation",
            "--seed",
            "7",
            "--json"
        ]
    );
    let args = as_testbed_args("cargo run --release -p testbed-cli -- paper --runs 2").unwrap();
    assert_eq!(args, ["testbed", "paper", "--runs", "2"]);
    assert!(as_testbed_args("cargo run -p bench -- x").is_none());
}
