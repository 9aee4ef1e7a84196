//! The pipeline's processes wired together in memory, tick by tick, with the samples of each
//! stage delivered in a caller-chosen order. Used to test the lockstep protocol (and that the
//! process split computes exactly what the in-process loop computes) without iceoryx2.

use crate::plant_task::PlantTask;
use crate::sim_devices::{SimCmg, SimGyro, SimInclinometer, SimMagnetometer, SimWheels};
use ipc_types::{AttitudeEstimate, SimTruth};
use testbed_config::RunConfig;
use testbed_flight::tasks::{ControllerTask, EstimatorTask};

/// Everything the estimator and the plant published, in tick order.
pub struct InMemoryRun {
    pub estimates: Vec<AttitudeEstimate>,
    pub truths: Vec<SimTruth>,
}

/// Run `config` to its end. `shuffle(k, n)` returns a permutation of `0..n` deciding in which
/// order tick k's sensor samples reach the estimator and the controller.
pub fn run(
    config: &RunConfig,
    mut shuffle: impl FnMut(u64, usize) -> Vec<usize>,
) -> anyhow::Result<InMemoryRun> {
    let schedule = config.schedule()?;
    let mut plant = PlantTask::new(config)?;
    let mut gyro = SimGyro::new(config, schedule);
    let mut tilt = SimInclinometer::new(config, schedule);
    let mut field = SimMagnetometer::new(config, schedule);
    let mut wheels = SimWheels::new(config, schedule);
    let mut cmg = SimCmg::new(config, schedule);
    let mut estimator = EstimatorTask::new(config.estimator_setup()?, schedule);
    let mut controller = ControllerTask::new(
        &config.controller,
        &config.model,
        config.manoeuvre.target(),
        schedule,
    )?;
    let mut run = InMemoryRun {
        estimates: Vec::new(),
        truths: Vec::new(),
    };
    loop {
        let (truth, _clock) = plant.outputs();
        run.truths.push(truth);
        enum Sample {
            Gyro(ipc_types::GyroSample),
            Tilt(ipc_types::InclinometerSample),
            Field(ipc_types::MagnetometerSample),
            Wheels(ipc_types::WheelTelemetry),
            Cmg(ipc_types::CmgTelemetry),
        }
        let mut samples: Vec<Sample> = Vec::new();
        samples.extend(gyro.on_truth(&truth).map(Sample::Gyro));
        samples.extend(tilt.on_truth(&truth).map(Sample::Tilt));
        samples.extend(field.on_truth(&truth).map(Sample::Field));
        samples.extend(wheels.on_truth(&truth).map(Sample::Wheels));
        samples.extend(cmg.on_truth(&truth).map(Sample::Cmg));
        let order = shuffle(plant.tick(), samples.len());
        let mut estimates = Vec::new();
        for i in order {
            match &samples[i] {
                Sample::Gyro(s) => estimator.on_gyro(s),
                Sample::Tilt(s) => estimator.on_inclinometer(s),
                Sample::Field(s) => estimator.on_magnetometer(s),
                Sample::Wheels(s) => controller.on_wheel_telemetry(s),
                Sample::Cmg(s) => controller.on_cmg_telemetry(s),
            }
            estimates.extend(estimator.ready());
        }
        for e in &estimates {
            controller.on_estimate(e);
        }
        run.estimates.extend(estimates);
        for cycle in controller.ready() {
            wheels.on_command(&cycle.wheels);
            cmg.on_command(&cycle.cmg);
            plant.on_wheel_command(&cycle.wheels);
            plant.on_cmg_command(&cycle.cmg);
            if let Some(t) = &cycle.thrusters {
                plant.on_thruster_command(t);
            }
        }
        anyhow::ensure!(plant.answered(), "tick {} was not answered", plant.tick());
        if plant.at_end() {
            return Ok(run);
        }
        plant.advance()?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed_loop;
    use testbed_flight::convert::quaternion_from_array;

    fn config() -> RunConfig {
        let mut config = RunConfig::default();
        config.run.duration_s = 30.0;
        config.run.seed = 5;
        config
    }

    /// A fixed-seed permutation (xorshift), so the arrival order differs from tick to tick.
    fn scrambled(seed: u64) -> impl FnMut(u64, usize) -> Vec<usize> {
        let mut state = seed | 1;
        move |_, n| {
            let mut order: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                order.swap(i, (state % (i as u64 + 1)) as usize);
            }
            order
        }
    }

    /// Asserts the pipeline's estimate `sample` has the in-process loop's attitude at `tick`
    /// (bit for bit) and returns the loop's estimate.
    fn same_attitude<'a>(
        sample: &AttitudeEstimate,
        tick: &'a closed_loop::TickRecord,
    ) -> &'a closed_loop::EstimateRecord {
        let expected = tick
            .estimate
            .as_ref()
            .expect("estimator initialised at t = 0");
        assert_eq!(
            quaternion_from_array(&sample.quaternion).unwrap(),
            expected.attitude,
            "t = {}",
            tick.t_s
        );
        expected
    }

    #[test]
    fn the_process_split_computes_exactly_what_the_in_process_loop_computes() {
        let config = config();
        let pipeline = run(&config, |_, n| (0..n).collect()).unwrap();
        let trace = closed_loop::run(&closed_loop::Scenario::from_run(&config)).unwrap();
        assert_eq!(pipeline.estimates.len(), trace.ticks.len());
        for (sample, tick) in pipeline.estimates.iter().zip(&trace.ticks) {
            let expected = same_attitude(sample, tick);
            assert_eq!(
                sample.gyro_bias,
                [
                    expected.bias_rad_s.x,
                    expected.bias_rad_s.y,
                    expected.bias_rad_s.z
                ]
            );
        }
    }

    #[test]
    fn with_thrusters_the_process_split_still_computes_exactly_the_in_process_loop() {
        use testbed_flight::thruster_control::ThrusterControlConfig;
        use testbed_model::thruster_config::ThrusterConfig;
        let mut config = config();
        config.model.thrusters = Some(ThrusterConfig::default());
        config.controller.thrusters = Some(ThrusterControlConfig::default());
        // Wheels just past the dump threshold (0.5 Nms = 3000 rpm), the Z wheel spun against the
        // heading slew so that no wheel reaches the safe-mode limit (the in-process loop has no
        // safe mode): the thrusters fire from the first ticks.
        config.manoeuvre.initial_wheel_speed_rpm = [3100.0, -3100.0, -3100.0];
        let pipeline = run(&config, scrambled(7)).unwrap();
        let (trace, _, thrusters) =
            closed_loop::run_with_thrusters(&closed_loop::Scenario::from_run(&config)).unwrap();
        assert!(
            thrusters.pulses.iter().sum::<u64>() > 10,
            "{:?}",
            thrusters.pulses
        );
        assert_eq!(pipeline.estimates.len(), trace.ticks.len());
        for ((sample, truth), tick) in pipeline
            .estimates
            .iter()
            .zip(&pipeline.truths)
            .zip(&trace.ticks)
        {
            same_attitude(sample, tick);
            assert_eq!(
                truth.wheel_speed,
                [
                    tick.truth.wheel_speed.x,
                    tick.truth.wheel_speed.y,
                    tick.truth.wheel_speed.z
                ]
            );
        }
    }

    #[test]
    fn arrival_order_does_not_change_the_result() {
        let config = config();
        let in_order = run(&config, |_, n| (0..n).collect()).unwrap();
        let reversed = run(&config, |_, n| (0..n).rev().collect()).unwrap();
        let shuffled = run(&config, scrambled(99)).unwrap();
        assert_eq!(in_order.estimates, reversed.estimates);
        assert_eq!(in_order.estimates, shuffled.estimates);
        assert_eq!(in_order.truths, shuffled.truths);
    }
}
