//! Every process of the pipeline, each a [`testbed_runtime::Node`]: a small struct that holds
//! the process's logic (a plain struct of the flight or simulation crates, tested without
//! iceoryx2) and its bus ports. [`roles::ROLES`] names each process and the node it runs; the
//! `testbed` executable started under that name runs it:
//!
//! ```ignore
//! Role::new("estimator", |name| testbed_runtime::run(name, EstimatorProcess::open))
//! ```
//!
//! | process | node | logic |
//! |---|---|---|
//! | `plant` | [`plant::PlantProcess`] | `testbed_sim::plant_task::PlantTask` |
//! | `sim-gyro`, `sim-inclinometer`, `sim-magnetometer`, `sim-wheels`, `sim-cmg` | [`sim_gateway::SimGateway`] | `testbed_sim::sim_devices` |
//! | `sim-devices` (several of them in one process: the profile's `device` list) | [`sim_gateway::SimGateway`] | `testbed_sim::sim_devices` |
//! | `estimator` | [`estimator::EstimatorProcess`] | `testbed_flight::tasks::EstimatorTask` |
//! | `controller` | [`controller::ControllerProcess`] | `testbed_flight::tasks::ControllerTask` |
//! | `logger` | [`logger::LoggerProcess`] | `testbed_log` |
//! | `replay` | [`replay::ReplayProcess`] | [`replay_log`] |
//! | `gyro-gateway`, …, `cmg-gateway` | [`can_gateway::CanGateway`] | `testbed_gateways::gateway` |
//! | `sim-can-node` (the simulated CAN board) | [`can_board::CanBoardProcess`] | `testbed_gateways::can_board` |
//! | `can-replay` | [`can_replay::CanReplayProcess`] | `testbed_can::transport` |
//! | `ground-link` | [`ground_link::GroundLinkProcess`] | [`ground_link::command`], [`ground_link::protocol`] |
//!
//! # Lockstep protocol
//!
//! Tick k at `t_k = k·T` (T the gyro period):
//! 1. the plant publishes `SimTruth(t_k)` and `SimClockTick(k)`;
//! 2. each simulated gateway samples its device from the truth if the schedule says it samples
//!    at `t_k`, and publishes what the real gateway would;
//! 3. the estimator, once it has every sample due at `t_k`, propagates and updates and
//!    publishes `AttitudeEstimate(t_k)` (always, valid or not);
//! 4. the controller, with the estimate and the wheel and CMG telemetry of `t_k`, publishes
//!    `ControllerStatus(t_k)`, `WheelCommand(t_k)` and `CmgCommand(t_k)`;
//! 5. the plant, holding both commands of `t_k`, integrates to `t_{k+1}`.
//!
//! Every step is a pure function of the samples of `t_k` and each process's own state, so the
//! run is deterministic however the OS schedules the processes, and identical to the in-process
//! loop of `testbed_sim::closed_loop` for the same seed.

#![forbid(unsafe_code)]

pub mod can_board;
pub mod can_gateway;
pub mod can_link;
pub mod can_replay;
pub mod controller;
pub mod estimator;
pub mod ground_link;
pub mod logger;
pub mod plant;
pub mod replay;
pub mod replay_log;
pub mod roles;
pub mod scene;
pub mod sim_gateway;
pub mod software_bus;
