//! The estimator task on simulated sensor samples: how it answers ticks with bad samples.

use ipc_types::{
    AttitudeEstimate, GyroSample, InclinometerSample, MagnetometerSample, SampleHeader,
};
use testbed_config::RunConfig;
use testbed_flight::tasks::{EstimatorCounters, EstimatorTask};
use testbed_sim::plant_task::PlantTask;
use testbed_sim::sim_devices::{SimGyro, SimInclinometer, SimMagnetometer};

/// One tick's sensor samples.
type Tick = (
    GyroSample,
    Option<InclinometerSample>,
    Option<MagnetometerSample>,
);

/// 8 s of the default run's sensor samples (the plant coasting without commands).
fn samples() -> (RunConfig, Vec<Tick>) {
    let mut config = RunConfig::default();
    config.run.duration_s = 8.0;
    let schedule = config.schedule().unwrap();
    let mut plant = PlantTask::new(&config).unwrap();
    let (mut gyro, mut tilt, mut field) = (
        SimGyro::new(&config, schedule),
        SimInclinometer::new(&config, schedule),
        SimMagnetometer::new(&config, schedule),
    );
    let mut out = Vec::new();
    loop {
        let (truth, _) = plant.outputs();
        out.push((
            gyro.on_truth(&truth).unwrap(),
            tilt.on_truth(&truth),
            field.on_truth(&truth),
        ));
        if plant.at_end() {
            return (config, out);
        }
        plant.advance().unwrap();
    }
}

fn run(config: &RunConfig, samples: &[Tick]) -> (Vec<AttitudeEstimate>, EstimatorCounters) {
    let mut estimator = EstimatorTask::new(
        config.estimator_setup().unwrap(),
        config.schedule().unwrap(),
    );
    let mut out = Vec::new();
    for (g, t, f) in samples {
        estimator.on_gyro(g);
        t.iter().for_each(|t| estimator.on_inclinometer(t));
        f.iter().for_each(|f| estimator.on_magnetometer(f));
        out.extend(estimator.ready());
    }
    (out, estimator.counters())
}

#[test]
fn an_invalid_gyro_sample_answers_its_tick_with_the_last_valid_rate() {
    let (config, samples) = samples();
    let (reference, counters) = run(&config, &samples);
    assert_eq!(reference.len(), samples.len());
    assert_eq!(counters.gyro_held, 0);
    // Ticks 20 and 21: the gateway publishes stale samples (values repeated, not VALID).
    let mut stale = samples.clone();
    let mut held = samples.clone();
    for k in [20, 21] {
        let g = &mut stale[k].0;
        g.header.flags = SampleHeader::STALE;
        g.rate = [9.0; 3]; // never used
        held[k].0.rate = samples[19].0.rate;
    }
    let (with_stale, counters) = run(&config, &stale);
    let (with_held, _) = run(&config, &held);
    assert_eq!(counters.gyro_held, 2);
    assert_eq!(with_stale.len(), samples.len(), "every tick answered");
    assert_eq!(with_stale, with_held);
    assert_ne!(with_stale, reference);
}

/// What the estimator process sleeps through: the samples its next estimate still lacks, at
/// each step of a tick, whatever order they come in, and when one never comes.
#[test]
fn the_estimator_awaits_the_samples_its_next_tick_lacks() {
    let (config, samples) = samples();
    let schedule = config.schedule().unwrap();
    let mut estimator = EstimatorTask::new(config.estimator_setup().unwrap(), schedule);
    let due = |k: u64| 1 + u32::from(schedule.tilt_due(k)) + u32::from(schedule.field_due(k));
    // The first tick is not known before its first sample.
    assert_eq!(estimator.samples_awaited(), 1);
    let mut vector_ticks = 0;
    for (k, (g, t, f)) in samples.iter().enumerate().take(40) {
        let k = k as u64;
        if k > 0 {
            assert_eq!(
                estimator.samples_awaited(),
                due(k),
                "tick {k}, before its samples"
            );
        }
        // The vector samples first on odd ticks, the gyro first on even ones.
        if k % 2 == 1 {
            t.iter().for_each(|t| estimator.on_inclinometer(t));
            f.iter().for_each(|f| estimator.on_magnetometer(f));
            estimator.on_gyro(g);
        } else {
            estimator.on_gyro(g);
            if due(k) == 3 {
                vector_ticks += 1;
                assert_eq!(estimator.samples_awaited(), 2, "tick {k}, gyro in");
                estimator.on_inclinometer(t.as_ref().unwrap());
                assert_eq!(estimator.samples_awaited(), 1, "tick {k}, gyro and tilt in");
            } else {
                t.iter().for_each(|t| estimator.on_inclinometer(t));
            }
            f.iter().for_each(|f| estimator.on_magnetometer(f));
        }
        assert_eq!(estimator.ready().len(), 1, "tick {k} answered");
    }
    assert!(vector_ticks > 0, "the 40 ticks include vector ticks");

    // A magnetometer sample that never comes: the tick waits for it or the next gyro sample
    // (one more sample either way), and the next gyro sample answers both ticks.
    let k = (40..).find(|&k| due(k) == 3).unwrap();
    for (g, t, f) in &samples[40..k as usize] {
        estimator.on_gyro(g);
        t.iter().for_each(|t| estimator.on_inclinometer(t));
        f.iter().for_each(|f| estimator.on_magnetometer(f));
        assert_eq!(estimator.ready().len(), 1);
    }
    let (g, t, _) = &samples[k as usize];
    estimator.on_gyro(g);
    estimator.on_inclinometer(t.as_ref().unwrap());
    assert!(estimator.ready().is_empty());
    assert_eq!(estimator.samples_awaited(), 1);
    estimator.on_gyro(&samples[k as usize + 1].0);
    assert_eq!(
        estimator.ready().len(),
        2,
        "the next gyro sample overtakes the tick"
    );
    assert_eq!(estimator.samples_awaited(), due(k + 2));
}
