//! `testbed log repair`: make a cut run log (killed logger, full disk) a complete MCAP file.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use testbed_log::{LogEnd, RepairReport, RunLog};

#[derive(Debug, clap::Args)]
pub struct LogArgs {
    #[command(subcommand)]
    pub command: LogCommand,
}

/// The `testbed log` commands.
#[derive(Debug, clap::Subcommand)]
pub enum LogCommand {
    /// Rewrite a cut log (its logger died) as a complete, indexed MCAP file that every reader
    /// opens (Python `mcap`'s `make_reader`, viewers): every complete record is kept, the
    /// incomplete one at the cut is dropped.
    Repair {
        /// The log to repair.
        input: PathBuf,
        /// Where to write the repaired log [default: replace INPUT, once the copy is complete].
        output: Option<PathBuf>,
    },
}

pub fn run(args: &LogArgs) -> Result<()> {
    match &args.command {
        LogCommand::Repair { input, output } => {
            let output = output.as_deref().unwrap_or(input);
            if output == input.as_path() && RunLog::open(input).is_ok_and(|log| log.is_complete()) {
                println!(
                    "{}: complete (footer present); nothing to repair",
                    input.display()
                );
                return Ok(());
            }
            let report = repair(input, output)?;
            println!("{}", describe(input, &report));
            Ok(())
        }
    }
}

/// Repairs `input` into `output` (may be the same path).
pub fn repair(input: &Path, output: &Path) -> Result<RepairReport> {
    testbed_log::repair(input, output)
        .with_context(|| format!("repairing the log {}", input.display()))
}

/// One line saying what the repair found and kept.
pub fn describe(input: &Path, report: &RepairReport) -> String {
    let found = match report.end {
        LogEnd::Complete => "complete".to_owned(),
        LogEnd::Truncated { offset, file_len } => format!(
            "cut at byte {file_len} (complete records end at byte {offset}; {} bytes of an incomplete record dropped)",
            report.dropped_bytes
        ),
    };
    format!(
        "{}: {found}; wrote {}: {} messages (every complete one, up to t = {:.3} s), with summary, index and footer",
        input.display(),
        report.output.display(),
        report.messages,
        report.last_time_ns as f64 * 1e-9
    )
}
