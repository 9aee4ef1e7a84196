//! The test bed's processes as library code: the logic of each process is a plain struct fed
//! with samples and returning samples ([`plant_node`], [`sim_devices`], [`estimator_node`],
//! [`controller_node`]), so it is tested without iceoryx2; the binaries in `src/bin/` are thin
//! shells that move samples between these structs and the bus.
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

pub mod replay_node;
