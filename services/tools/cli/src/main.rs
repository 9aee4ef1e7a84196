//! `testbed`: the test bed's command-line tool.

mod figure;
mod identify;
mod paper;
mod run;
mod summary;

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
    /// Launch the pipeline of a profile as real processes, then summarise its log.
    Run(run::RunArgs),
    /// Find what the model gets wrong in measured data: residuals, cause, extended model, gain.
    Identify(identify::IdentifyArgs),
    /// Simulate an identification experiment and write it as a measured-data CSV directory.
    Experiment(identify::ExperimentArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match &cli.command {
        Command::Paper(args) => paper::run(args),
        Command::Run(args) => run::run(args),
        Command::Identify(args) => identify::run_identify(args),
        Command::Experiment(args) => identify::run_experiment(args),
    }
}
