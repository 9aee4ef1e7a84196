//! `testbed`: the test bed's command-line tool.

mod figure;
mod paper;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "testbed", version, about = "Three-axis air-bearing attitude-control test bed")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Reproduce the paper's results (EKF accuracy, stabilisation, CMG slew) beside its numbers.
    Paper(paper::PaperArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match &cli.command {
        Command::Paper(args) => paper::run(args),
    }
}
