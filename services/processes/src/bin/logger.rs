//! The logger process: the run's MCAP log (see `testbed_processes::logger`).

fn main() -> anyhow::Result<()> {
    testbed_runtime::run("logger", testbed_processes::logger::LoggerProcess::open)
}
