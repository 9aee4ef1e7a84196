//! The real platform path: the device gateways' logic, the simulated CAN board and the replay
//! of recorded bus traffic, without the bus: their processes are in `testbed-processes`, and so
//! is the software CAN bus over iceoryx2 (`software_bus`).
//!
//! The CAN board is the platform's microcontroller board that reads the sensors, drives the
//! actuators and talks to the computer over the one CAN bus (PROTOCOL.md's "smart CAN node");
//! its simulated stand-in runs as the process `sim-can-node`.
//!
//! ```text
//!              SimTruth                       testbed/can/bus (CanBusFrame)
//!  plant ─────────────────► sim-can-node ◄──────────────────────────────────┐
//!    ▲                        │ sensor frames, tick sync                    │ command frames
//!    │ AppliedWheelCommand    ▼                                             │
//!    │ AppliedCmgCommand   gyro- / inclinometer- / magnetometer- /  wheel- / cmg-gateway
//!    └────────────────────    │ GyroSample … CmgTelemetry                   ▲ WheelCommand
//!                             ▼                                             │ CmgCommand
//!                          estimator ─────────────────────────────────► controller
//! ```
//!
//! - [`gateway`]: a gateway's logic — frames in, the very samples the simulated gateways
//!   publish out (same topics, types and time stamps); commands limited (clamped, or refused
//!   and replaced by zero) and encoded; every frame counted ([`ipc_types::CanLinkStatus`], and
//!   `frames_ok` / `frames_bad` / `errors` in the process heartbeat).
//! - [`can_board`]: the simulated CAN board — the simulated gateways' device models on the
//!   plant's truth, encoded with the board's protocol; commands decoded and handed to the plant
//!   as [`ipc_types::AppliedWheelCommand`] / [`ipc_types::AppliedCmgCommand`]
//!   (`run.actuation = "can_node"`); seeded fault injection ([`faults`]).
//! - [`run`]: the processes (`gyro-gateway`, `inclinometer-gateway`, `magnetometer-gateway`,
//!   `wheel-gateway`, `cmg-gateway`, `sim-can-node`, `can-replay`). A gateway's link comes from
//!   the run configuration (`[can]`): SocketCAN, the software bus, a `candump -L` file, or a
//!   serial line for a directly wired device (`[can.serial.<device>]`).
//!
//! # Lockstep when frames are lost
//!
//! In lockstep the estimator, controller and plant each wait for the samples of tick `k`; a
//! lost frame must not leave them waiting forever, and what happens must not depend on timing.
//! The board therefore ends every tick's frames with its heartbeat, stamped with the tick's
//! time: the **tick sync**. The sync is the tick's deadline on the bus:
//!
//! 1. A sensor gateway publishes at the sync, and only then: the complete sample of the tick
//!    if all its frames came before the sync, otherwise the last good values flagged `STALE`
//!    and not `VALID` (counted as `stale_samples`). Every due sample of every tick is published
//!    exactly once, so nothing downstream waits for a frame that never comes.
//! 2. A frame of an already closed tick (delayed past the sync) is *late*: counted, and the
//!    sample it completes is not used (see [`gateway`]).
//! 3. The estimator propagates an invalid gyro sample with the last valid rate and skips
//!    invalid vector updates (`testbed_flight::tasks::EstimatorTask`); the controller uses the
//!    repeated actuator telemetry.
//! 4. The board closes a tick when it has *received* the tick's three command frames (the
//!    gateways always send one command per tick: a refused command is replaced by zero), and
//!    only then applies its faults to them: a lost or corrupted command holds the previous one,
//!    and the plant always gets exactly one applied command of each kind per tick.
//! 5. The sync itself is never faulted: it stands for the board's deadline timer, which on the
//!    platform does not travel over the bus.
//!
//! Every decision depends only on the order of one sender's frames (iceoryx2 keeps it) and on
//! seeded fault draws, so a lockstep run with faults is as reproducible as one without.
//! On hardware (paced runs) the gateways publish each sample as it completes instead, and the
//! board's heartbeat only tells them the board is alive.

#![forbid(unsafe_code)]

pub mod can_board;
pub mod faults;
pub mod gateway;
pub mod status;
pub mod thrusters;

pub use can_board::SimCanBoard;
pub use gateway::{Gateway, GatewayDevice};
