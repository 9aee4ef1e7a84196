//! Latency of the pipeline against sockets and busy-polling, idle and under load: see
//! [`testbed_bench::latency`]. Also the harness's worker processes (`latency worker <spec>`).

fn main() -> anyhow::Result<()> {
    testbed_bench::latency::main()
}
