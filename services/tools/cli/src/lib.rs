//! The `testbed` command-line tool: its command line ([`Cli`]) and what each command does.
//!
//! A library so that tests can parse the command lines the documentation shows
//! ([`Cli::try_parse_from`](clap::Parser::try_parse_from)); `main.rs` only runs [`main`].

pub mod balance;
pub mod campaign;
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
    /// Balance: the balance masses' moves that bring an identified centre of mass to the target
    /// (horizontal zero, vertical a pendulous offset), with the predicted residual.
    Balance(balance::BalanceArgs),
    /// Simulate an identification experiment and write it as a measured-data CSV directory.
    Experiment(identify::ExperimentArgs),
    /// Monte Carlo campaign: N dispersed runs on the in-process loop across the cores, a report
    /// with statistics and figures, A/B comparison of variants; `merge` joins shards.
    Campaign(campaign::CampaignArgs),
    /// Run-log tools: `testbed log repair IN [OUT]` makes a cut log complete again.
    Log(log::LogArgs),
}

/// The `testbed` executable's main. Started under the name of a role (through a link of that
/// name, see `testbed_launch::roles`), it is that role, busybox style: the launcher
/// (`testbed-launch`) or a pipeline process (`testbed_processes::roles::ROLES`); started under
/// any other name, the command line ([`cli_main`]). The roles are no commands of [`Cli`], so
/// `testbed --help` does not list them.
pub fn main() -> std::process::ExitCode {
    use testbed_launch::roles::{LAUNCHER, invoked_as};
    use testbed_processes::roles;
    match invoked_as().as_deref() {
        Some(LAUNCHER) => testbed_launch::main(&roles::names()),
        // One `error: …` line and status 1 on an error (`testbed_runtime::exit_status`).
        Some(name) => match roles::find(name) {
            Some(role) => testbed_runtime::exit_status(role.run()),
            None => cli_main(),
        },
        None => cli_main(),
    }
}

/// Runs the command line: clap's own message and status for a wrong command line, the error
/// chain in one short block (no backtrace: these are the user's errors, not bugs; a panic keeps
/// its backtrace with `RUST_BACKTRACE=1`) and status 1 for a command that fails, 2 for a run
/// this computer cannot serve ([`errors::status`]).
pub fn cli_main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Paper(args) => paper::run(args),
        Command::Run(args) => run::run(args),
        Command::Identify(args) => identify::run_identify(args),
        Command::Experiment(args) => identify::run_experiment(args),
        Command::Balance(args) => balance::run(args),
        Command::Campaign(args) => campaign::run(args),
        Command::Log(args) => log::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            use std::io::Write as _;
            // One write: a line of its own even beside a process still writing to the terminal.
            let _ = std::io::stderr().write_all(format!("{}\n", errors::report(&e)).as_bytes());
            std::process::ExitCode::from(errors::status(&e))
        }
    }
}
