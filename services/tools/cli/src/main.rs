//! `testbed`: the test bed's command-line tool (see the library, `testbed_cli`).

fn main() -> std::process::ExitCode {
    testbed_cli::main()
}
