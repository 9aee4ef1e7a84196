//! The platform's hot path allocates nothing in steady state: once the estimator has initialised
//! and the controller has run a few cycles, a tick of the CAN gateways (decoding frames, making
//! samples; limiting and encoding commands), the estimator and the controller (taking samples,
//! running a cycle, handing out what it computed) makes no heap allocation. A heap allocation
//! per cycle is a latency risk on the platform (the allocator may take a lock or ask the kernel
//! for pages), so this is checked, not assumed: a counting global allocator, switched on only
//! around the calls into the gateways and the flight tasks, counts the allocations of 50 s of
//! the default run over the CAN path in memory (the plant and the simulated CAN board are not
//! counted; nor is the bus, whose publish allocates inside iceoryx2 0.10).
//!
//! Its own test binary, because the global allocator is the whole program's.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use ipc_types::{AttitudeEstimate, Device};
use testbed_can::Sample;
use testbed_config::{Actuation, RunConfig};
use testbed_flight::tasks::{ControlCycle, ControllerTask, EstimatorTask};
use testbed_gateways::can_board::{self, SimCanBoard, TxFrame};
use testbed_gateways::gateway::Gateway;
use testbed_sim::plant_task::PlantTask;

/// The system allocator, counting the allocations (and reallocations) of the current thread
/// while its count is switched on.
struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

fn note_allocation() {
    // `try_with`: the thread-local may be gone while the thread is being torn down.
    let _ = COUNTING.try_with(|on| {
        if on.get() {
            let _ = COUNT.try_with(|n| n.set(n.get() + 1));
        }
    });
}

// SAFETY: every call is forwarded unchanged to `System`; the bookkeeping touches only
// const-initialised thread-locals, which do not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` and returns its result with the number of heap allocations it made on this thread.
fn counted<T>(f: impl FnOnce() -> T) -> (T, u64) {
    COUNT.with(|n| n.set(0));
    COUNTING.with(|on| on.set(true));
    let result = f();
    COUNTING.with(|on| on.set(false));
    (result, COUNT.with(Cell::get))
}

/// What the flight code allocated from `warm_up_s` into a run.
#[derive(Debug, Default)]
struct Allocations {
    /// The five gateways: frames decoded, samples made; commands limited and encoded.
    gateways: u64,
    estimator: u64,
    controller: u64,
    ticks: u64,
    estimates: u64,
    cycles: u64,
    samples: u64,
    vector_updates: u64,
}

/// The CAN path in memory, as `in_memory_lockstep.rs` wires it (plant → simulated CAN board →
/// five gateways → estimator → controller → wheel and CMG gateways → CAN board → plant),
/// counting the allocations of the gateways', estimator's and controller's calls from
/// `warm_up_s` on.
fn steady_state_allocations(duration_s: f64, warm_up_s: f64) -> Allocations {
    let mut config = RunConfig::default();
    config.run.duration_s = duration_s;
    config.run.actuation = Actuation::CanNode;
    let schedule = config.schedule().expect("default schedule");
    let protocol = can_board::protocol(&config).expect("protocol");
    let mut plant = PlantTask::new(&config).expect("plant");
    let mut board = SimCanBoard::new(&config).expect("CAN board");
    let mut gateways: Vec<Gateway> = Device::ALL
        .iter()
        .map(|&d| Gateway::new(d, protocol, schedule, true))
        .collect();
    let mut estimator = EstimatorTask::new(config.estimator_setup().unwrap(), schedule);
    let mut controller = ControllerTask::new(
        &config.controller,
        &config.model,
        config.manoeuvre.target(),
        schedule,
    )
    .expect("controller task");
    // The callers' buffers, sized once: the processes keep theirs the same way.
    let mut samples: Vec<Sample> = Vec::with_capacity(16);
    let mut estimates: Vec<AttitudeEstimate> = Vec::with_capacity(4);
    let mut cycles: Vec<ControlCycle> = Vec::with_capacity(4);
    let mut seen = Allocations::default();
    // The filter's count of applied vector updates when counting began.
    let mut first_applied: Option<u64> = None;
    loop {
        let (truth, _) = plant.outputs();
        let counting = truth.header.time_ns as f64 * 1e-9 >= warm_up_s;
        let frames = board.on_truth(&truth);

        samples.clear();
        let ((), in_gateways) = counted(|| {
            for gateway in &mut gateways {
                for frame in &frames {
                    if let TxFrame::Send(f) = frame {
                        samples.extend(gateway.on_frame(f).sample);
                    }
                }
            }
        });
        estimates.clear();
        let ((), in_estimator) = counted(|| {
            for sample in &samples {
                match sample {
                    Sample::Gyro(s) => estimator.on_gyro(s),
                    Sample::Inclinometer(s) => estimator.on_inclinometer(s),
                    Sample::Magnetometer(s) => estimator.on_magnetometer(s),
                    _ => {}
                }
            }
            estimator.ready_into(&mut estimates);
        });
        cycles.clear();
        let ((), in_controller) = counted(|| {
            for sample in &samples {
                match sample {
                    Sample::WheelTelemetry(s) => controller.on_wheel_telemetry(s),
                    Sample::CmgTelemetry(s) => controller.on_cmg_telemetry(s),
                    _ => {}
                }
            }
            estimates.iter().for_each(|e| controller.on_estimate(e));
            controller.ready_into(&mut cycles);
        });
        let mut command_frames = [None, None];
        let ((), in_commands) = counted(|| {
            if let Some(cycle) = cycles.last() {
                command_frames = [
                    Some(gateways[3].wheel_command(&cycle.wheels)),
                    Some(gateways[4].cmg_command(&cycle.cmg)),
                ];
            }
        });
        if counting {
            seen.ticks += 1;
            seen.gateways += in_gateways + in_commands;
            seen.estimator += in_estimator;
            seen.controller += in_controller;
            seen.samples += samples.len() as u64;
            seen.estimates += estimates.len() as u64;
            seen.cycles += cycles.len() as u64;
            if let (Some(first), Some(last)) = (first_applied, estimates.last()) {
                seen.vector_updates = last.updates_applied - first;
            }
            first_applied = first_applied.or(estimates.first().map(|e| e.updates_applied));
        }
        let mut applied = None;
        for batch in command_frames.into_iter().flatten() {
            for f in &batch.expect("a limited command encodes") {
                applied = board.on_frame(f).or(applied);
            }
        }
        let applied = applied.expect("the board answers every tick");
        let (wheel_command, cmg_command) = applied.commands();
        plant.on_wheel_command(&wheel_command);
        plant.on_cmg_command(&cmg_command);
        if plant.at_end() {
            return seen;
        }
        plant.advance().expect("plant advances");
    }
}

/// 50 s of steady state (from 10 s, when the filter has long initialised and converged):
/// every tick answered with an estimate and a control cycle, the vector update applied at
/// 2.5 Hz, every sensor and actuator sample through its gateway, and not one heap allocation
/// in the gateways', the estimator's or the controller's calls.
#[test]
fn the_gateways_estimator_and_controller_allocate_nothing_in_steady_state() {
    let seen = steady_state_allocations(60.0, 10.0);
    println!("{seen:?}");
    assert!(seen.ticks >= 500, "{seen:?}");
    assert_eq!(seen.estimates, seen.ticks, "one estimate a tick: {seen:?}");
    assert_eq!(
        seen.cycles, seen.ticks,
        "one control cycle a tick: {seen:?}"
    );
    // Gyro, wheels and CMG every tick; inclinometer and magnetometer every fourth.
    assert!(seen.samples >= 3 * seen.ticks + seen.ticks / 2, "{seen:?}");
    assert!(
        seen.vector_updates >= seen.ticks / 4 - 1,
        "the vector update ran at 2.5 Hz: {seen:?}"
    );
    assert_eq!(seen.gateways, 0, "gateway allocations: {seen:?}");
    assert_eq!(seen.estimator, 0, "estimator allocations: {seen:?}");
    assert_eq!(seen.controller, 0, "controller allocations: {seen:?}");
}
