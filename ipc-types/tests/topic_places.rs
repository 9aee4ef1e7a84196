//! Where the sources name a topic: the rule is one place per topic.
//!
//! The rule: every topic name `testbed/…` appears in the code (outside comments) of exactly one
//! non-test Rust source file of the workspace, and the bus topics' names all in the topic table
//! (`ipc-types/src/topic.rs`); everything else takes them from there (`ipc_types::topic`,
//! `TopicId`, `Topic::NAME`). The derived topics are named where they are made: the log's frame
//! transforms (`testbed-log`'s `foxglove.rs`), the ground link's own channels. Not counted:
//! comments, test code (`tests/` directories, `tests.rs` files, a `#[cfg(test)] mod` and what
//! follows it), non-Rust files (documents, the ground page, run configurations).
//!
//! Run with `--nocapture` to see the list of places.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Directories never scanned: build output, history, and the tree's non-source parts.
const SKIPPED_DIRS: &[&str] = &["target", ".git", "tests", "node_modules", "report-cpu"];

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("ipc-types is inside the workspace")
        .to_path_buf()
}

fn rust_sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for entry in entries {
        let path = entry.expect("directory entry").path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_dir() {
            if !SKIPPED_DIRS.contains(&name) && !name.starts_with('.') {
                rust_sources(&path, out);
            }
        } else if name.ends_with(".rs") && name != "tests.rs" {
            out.push(path);
        }
    }
}

/// The code of `line` without a trailing `//` comment (one outside a string literal).
fn code_of(line: &str) -> &str {
    let bytes = line.as_bytes();
    let mut in_string = false;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'\\' if in_string => i += 1,
            b'"' => in_string = !in_string,
            b'/' if !in_string && bytes.get(i + 1) == Some(&b'/') => return &line[..i],
            _ => {}
        }
        i += 1;
    }
    line
}

/// Every topic name in `code`: `testbed/` followed by a path of lower-case words.
fn topics_in(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("testbed/") {
        let tail = &rest[at + "testbed/".len()..];
        let len = tail
            .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '/'))
            .unwrap_or(tail.len());
        let path = tail[..len].trim_end_matches('/');
        if !path.is_empty() {
            found.push(format!("testbed/{path}"));
        }
        rest = &tail[len..];
    }
    found
}

/// Each topic name and the files (relative, with the line) whose code names it.
fn places() -> BTreeMap<String, Vec<(String, usize)>> {
    let root = workspace_root();
    let mut files = Vec::new();
    rust_sources(&root, &mut files);
    let mut places: BTreeMap<String, Vec<(String, usize)>> = BTreeMap::new();
    for file in files {
        let text =
            std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let relative = file
            .strip_prefix(&root)
            .unwrap_or(&file)
            .display()
            .to_string();
        let lines: Vec<&str> = text.lines().collect();
        for (n, line) in lines.iter().enumerate() {
            let test_module = line.trim() == "#[cfg(test)]"
                && lines
                    .get(n + 1)
                    .is_some_and(|l| l.trim_start().starts_with("mod "));
            if test_module {
                break;
            }
            for topic in topics_in(code_of(line)) {
                places
                    .entry(topic)
                    .or_default()
                    .push((relative.clone(), n + 1));
            }
        }
    }
    places
}

#[test]
fn every_topic_is_named_in_one_place() {
    let places = places();
    let mut report = String::new();
    let mut repeated = Vec::new();
    for (topic, at) in &places {
        let list: Vec<String> = at.iter().map(|(f, n)| format!("{f}:{n}")).collect();
        report.push_str(&format!("{topic}: {}\n", list.join(", ")));
        let files: std::collections::BTreeSet<_> = at.iter().map(|(f, _)| f).collect();
        if at.len() > 1 || files.len() > 1 {
            repeated.push(topic.clone());
        }
    }
    println!("{report}");
    assert!(
        repeated.is_empty(),
        "topics named in more than one place: {repeated:?}\n{report}"
    );
    let table = Path::new("ipc-types")
        .join("src")
        .join("topic.rs")
        .display()
        .to_string();
    for topic in ipc_types::topic::ALL {
        let at = places.get(*topic).map_or(&[][..], Vec::as_slice);
        assert!(
            at.len() == 1 && at[0].0 == table,
            "{topic} is named at {at:?}, not once in {table}"
        );
    }
}

#[test]
fn the_scanner_finds_topics_in_code_not_in_comments() {
    assert_eq!(
        topics_in(code_of(
            r#"let a = "testbed/sensors/gyro"; // testbed/sim/clock"#
        )),
        ["testbed/sensors/gyro"]
    );
    assert_eq!(
        topics_in(code_of(
            r#"format!("(topic testbed/system/health, or --json)")"#
        )),
        ["testbed/system/health"]
    );
    assert!(topics_in(code_of(r#"s.strip_prefix("testbed/")"#)).is_empty());
    assert_eq!(
        topics_in(code_of(r#"x("a//b", "testbed/can/bus")"#)),
        ["testbed/can/bus"]
    );
}
