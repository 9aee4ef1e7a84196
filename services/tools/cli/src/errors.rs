//! How a failed command is reported: the error and its causes in one short block.

/// `error: <what failed>` and one `  because: <cause>` line per cause, without the causes a
/// message already quotes (an I/O error wrapped as "x: cannot read: No such file" is not
/// repeated) and without a backtrace (`anyhow`'s `{:?}` would add one with
/// `RUST_BACKTRACE=1`; these are the user's errors, not bugs).
pub fn report(error: &anyhow::Error) -> String {
    let mut out = String::new();
    let mut shown: Vec<String> = Vec::new();
    for cause in error.chain() {
        let text = cause.to_string();
        if text.is_empty() || shown.iter().any(|s| s.contains(&text)) {
            continue;
        }
        if shown.is_empty() {
            out.push_str("error: ");
        } else {
            out.push_str("\n  because: ");
        }
        out.push_str(&text);
        shown.push(text);
    }
    out
}

/// The exit status of a failed command: 2 when the computer lacks what a run needs (nothing
/// was started; as the launcher's status for an unusable profile), 1 otherwise.
pub fn status(error: &anyhow::Error) -> u8 {
    if error.is::<crate::run::preflight::Unmet>() {
        2
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[test]
    fn a_cause_already_quoted_is_not_repeated() {
        #[derive(Debug, thiserror::Error)]
        #[error("p.toml: cannot read the profile: {source}")]
        struct Read {
            source: std::io::Error,
        }
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory");
        let e = anyhow::Error::new(Read { source: io }).context("loading the profile");
        let text = report(&e);
        assert_eq!(
            text,
            "error: loading the profile\n  because: p.toml: cannot read the profile: No such file or directory"
        );
        assert_eq!(text.matches("No such file").count(), 1);
    }

    #[test]
    fn no_backtrace_even_when_asked_for() {
        let e: anyhow::Result<()> = Err(anyhow::anyhow!("bad")).context("outer");
        let text = report(&e.unwrap_err());
        assert!(
            !text.contains("Stack backtrace") && !text.contains("backtrace"),
            "{text}"
        );
    }
}
