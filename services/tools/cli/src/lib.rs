//! The `testbed` command-line tool: its command line ([`Cli`]) and what each command does.
//!
//! A library so that tests can parse the command lines the documentation shows
//! ([`Cli::try_parse_from`](clap::Parser::try_parse_from)); `main.rs` only runs [`main`].

pub mod errors;
pub mod figure;
pub mod identify;
pub mod log;
pub mod paper;
pub mod progress;
pub mod run;
pub mod summary;

use clap::{Parser, Subcommand};

/// The `testbed` command line.
#[derive(Debug, Parser)]
#[command(
    name = "testbed",
    version,
    about = "Three-axis air-bearing attitude-control test bed"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The commands of [`Cli`].
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Reproduce the paper's results (EKF accuracy, stabilisation, CMG slew) beside its numbers.
    Paper(paper::PaperArgs),
    /// Launch the pipeline of a profile as real processes, then summarise its log.
    Run(run::RunArgs),
    /// Find what the model gets wrong in measured data: residuals, cause, extended model, gain.
    Identify(identify::IdentifyArgs),
    /// Simulate an identification experiment and write it as a measured-data CSV directory.
    Experiment(identify::ExperimentArgs),
    /// Run-log tools: `testbed log repair IN [OUT]` makes a cut log complete again.
    Log(log::LogArgs),
}

/// Runs the command line: clap's own message and status for a wrong command line, the error
/// chain in one short block (no backtrace: these are the user's errors, not bugs; a panic keeps
/// its backtrace with `RUST_BACKTRACE=1`) and status 1 for a command that fails.
pub fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Paper(args) => paper::run(args),
        Command::Run(args) => run::run(args),
        Command::Identify(args) => identify::run_identify(args),
        Command::Experiment(args) => identify::run_experiment(args),
        Command::Log(args) => log::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{}", errors::report(&e));
            std::process::ExitCode::FAILURE
        }
    }
}
