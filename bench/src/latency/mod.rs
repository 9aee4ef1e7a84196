//! Latency of the pipeline's process chain against the alternatives, on the same machine, in
//! the same run: one hop and the gyro → estimator → controller → wheel-command chain over the
//! bus (iceoryx2 + event service, with each `WaitStrategy`), over Unix datagram sockets and UDP
//! on loopback (blocking reads), and over iceoryx2 with busy-polling (the floor); idle and with
//! a CPU hog on the last core; across payload sizes from 64 B to 64 KiB; and the 10 Hz loop's
//! period jitter and deadline misses in a paced `testbed run`.
//!
//! ```sh
//! cargo build --profile deploy --workspace --bins  # the paced run needs `testbed` and the pipeline
//! target/deploy/latency --out bench/report
//! target/deploy/latency --quick --out /tmp/latency-smoke
//! ```
//!
//! The `deploy` profile is what `launch/launch.sh` runs (the whole program optimised as one);
//! `--release` measures the tests' build.
//!
//! Writes `report.md` (tables, and the conclusions in `conclusions.md`), `latency.svg` (figure)
//! and `report.json` (every number) to `--out`. Never use these numbers without their
//! baselines: the machine is shared.
//!
//! Modules and what each uses (no module uses one that uses it back):
//!
//! - leaves: [`protocol`] (harness ↔ worker: specs, roles, transports, signals, results),
//!   [`stats`], [`system`], [`payload`] (sample types, their `Pod` twins), [`recording`];
//! - the worker side: [`transport`] → protocol; [`topics`] → transport, payload, system;
//!   [`chain`] → topics, transport, protocol, recording, system; [`worker`] (`latency worker <spec>`) → chain, transport, payload,
//!   protocol, system;
//! - the harness side: [`runner`] → protocol, system; [`model`] → protocol, stats, system;
//!   [`tables`] → model, protocol, stats; [`report`] → tables, model, stats; [`figure`] →
//!   model, protocol, stats; [`measure`] → runner, model, protocol, recording, stats, system;
//!   [`paced`] → measure, runner, model, protocol, recording, stats, system; [`harness`] (the
//!   command line) → all of the harness side, and worker to run a worker.

pub mod chain;
pub mod figure;
pub mod harness;
pub mod measure;
pub mod model;
pub mod paced;
pub mod payload;
pub mod protocol;
pub mod recording;
pub mod report;
pub mod runner;
pub mod stats;
pub mod system;
pub mod tables;
pub mod topics;
pub mod transport;
pub mod worker;

pub use harness::main;
