//! The flight code's steady state allocates nothing: once the estimator has initialised and the
//! controller has run a few cycles, a tick of either (taking its samples, running its cycle,
//! handing out what it computed) makes no heap allocation. A heap allocation per cycle is a
//! latency risk on the platform (the allocator may take a lock or ask the kernel for pages), so
//! this is checked, not assumed: a counting global allocator, switched on only around the calls
//! into the estimator and controller nodes, counts the allocations of 50 s of the default run in
//! memory (the plant, sensors and actuators are not counted).
//!
//! Its own test binary, because the global allocator is the whole program's.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use ipc_types::AttitudeEstimate;
use testbed_flight::controller_node::{ControlCycle, ControllerNode};
use testbed_flight::estimator_node::EstimatorNode;
use testbed_flight::tasks::ControllerTask;
use testbed_runtime::RunConfig;
use testbed_sim::plant_node::PlantNode;
use testbed_sim::sim_devices::{SimCmg, SimGyro, SimInclinometer, SimMagnetometer, SimWheels};

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

/// What the flight nodes allocated from `warm_up_s` into a run of the default configuration.
#[derive(Debug, Default)]
struct Allocations {
    estimator: u64,
    controller: u64,
    ticks: u64,
    estimates: u64,
    cycles: u64,
    vector_updates: u64,
}

fn steady_state_allocations(duration_s: f64, warm_up_s: f64) -> Allocations {
    let mut config = RunConfig::default();
    config.run.duration_s = duration_s;
    let schedule = config.schedule().expect("default schedule");
    let mut plant = PlantNode::new(&config).expect("plant");
    let mut gyro = SimGyro::new(&config, schedule);
    let mut tilt = SimInclinometer::new(&config, schedule);
    let mut field = SimMagnetometer::new(&config, schedule);
    let mut wheels = SimWheels::new(&config, schedule);
    let mut cmg = SimCmg::new(&config, schedule);
    let mut estimator = EstimatorNode::new(config.estimator_config(), schedule);
    let task = ControllerTask::new(&config.controller, &config.model, config.manoeuvre.target())
        .expect("controller task");
    let mut controller =
        ControllerNode::new(task, &config.controller, &config.model.wheels, schedule);
    // The callers' buffers, sized once: a process keeps its own the same way.
    let mut estimates: Vec<AttitudeEstimate> = Vec::with_capacity(4);
    let mut cycles: Vec<ControlCycle> = Vec::with_capacity(4);
    let mut seen = Allocations::default();
    // The filter's count of applied vector updates when counting began.
    let mut first_applied: Option<u64> = None;
    loop {
        let (truth, _) = plant.outputs();
        let counting = truth.header.time_ns as f64 * 1e-9 >= warm_up_s;
        let g = gyro.on_truth(&truth);
        let t = tilt.on_truth(&truth);
        let f = field.on_truth(&truth);
        let w = wheels.on_truth(&truth);
        let c = cmg.on_truth(&truth);

        estimates.clear();
        let ((), n) = counted(|| {
            g.iter().for_each(|s| estimator.on_gyro(s));
            t.iter().for_each(|s| estimator.on_inclinometer(s));
            f.iter().for_each(|s| estimator.on_magnetometer(s));
            estimator.ready_into(&mut estimates);
        });
        let ((), m) = counted(|| {
            w.iter().for_each(|s| controller.on_wheel_telemetry(s));
            c.iter().for_each(|s| controller.on_cmg_telemetry(s));
            estimates.iter().for_each(|e| controller.on_estimate(e));
            cycles.clear();
            controller.ready_into(&mut cycles);
        });
        if counting {
            seen.ticks += 1;
            seen.estimator += n;
            seen.controller += m;
            seen.estimates += estimates.len() as u64;
            seen.cycles += cycles.len() as u64;
            if let (Some(first), Some(last)) = (first_applied, estimates.last()) {
                seen.vector_updates = last.updates_applied - first;
            }
            first_applied = first_applied.or(estimates.first().map(|e| e.updates_applied));
        }
        for cycle in &cycles {
            wheels.on_command(&cycle.wheels);
            cmg.on_command(&cycle.cmg);
            plant.on_wheel_command(&cycle.wheels);
            plant.on_cmg_command(&cycle.cmg);
        }
        if plant.at_end() {
            return seen;
        }
        plant.advance().expect("plant advances");
    }
}

/// 50 s of steady state (from 10 s, when the filter has long initialised and converged):
/// every tick answered with an estimate and a control cycle, the vector update applied at
/// 2.5 Hz, and not one heap allocation in the estimator's or the controller's calls.
#[test]
fn the_estimator_and_controller_allocate_nothing_in_steady_state() {
    let seen = steady_state_allocations(60.0, 10.0);
    println!("{seen:?}");
    assert!(seen.ticks >= 500, "{seen:?}");
    assert_eq!(seen.estimates, seen.ticks, "one estimate a tick: {seen:?}");
    assert_eq!(
        seen.cycles, seen.ticks,
        "one control cycle a tick: {seen:?}"
    );
    assert!(
        seen.vector_updates >= seen.ticks / 4 - 1,
        "the vector update ran at 2.5 Hz: {seen:?}"
    );
    assert_eq!(seen.estimator, 0, "estimator allocations: {seen:?}");
    assert_eq!(seen.controller, 0, "controller allocations: {seen:?}");
}
