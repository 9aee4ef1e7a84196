//! The plant task, the plant process's logic: owns the simulated platform and the clock.
//!
//! Each tick it publishes the true state ([`SimTruth`]) and the tick ([`SimClockTick`]), then
//! waits for the controller's wheel and CMG commands stamped with that tick's time. In lockstep
//! it advances only when both have arrived; paced, it advances on the wall-clock period and
//! holds the previous command when the answer is late (a deadline miss). Like a real actuator
//! drive, it does not hold a command forever: after `run.command_timeout_s` without a command
//! (two periods by default) it applies zero wheel torque and zero gimbal rate until commands
//! come again, so a hung or dead controller cannot leave a wheel accelerating.

use ipc_types::{CmgCommand, SampleHeader, SimClockTick, SimTruth, WheelCommand};
use testbed_config::RunConfig;
use testbed_flight::convert::{Sequence, a3, a4, quaternion_to_array, v3, v4};
use testbed_flight::schedule::Schedule;
use testbed_model::devices::CmgStepperDrive;
use testbed_model::physics::delay::TIME_TOLERANCE_S;
use testbed_model::physics::{ActuatorCommand, PhysicsError, Plant, StepReport};

#[derive(Debug, thiserror::Error)]
pub enum PlantTaskError {
    #[error("plant: {0}")]
    Physics(#[from] PhysicsError),
    #[error("schedule: {0}")]
    Schedule(#[from] testbed_flight::schedule::ScheduleError),
}

/// The simulated platform and the run's clock: truth and tick out, commands in.
pub struct PlantTask {
    plant: Plant,
    stepper: CmgStepperDrive,
    schedule: Schedule,
    tick: u64,
    last_tick: u64,
    wheel: Option<WheelCommand>,
    cmg: Option<CmgCommand>,
    /// The thruster command answering the current tick, if any.
    thrusters: Option<ipc_types::ThrusterCommand>,
    /// Whether each tick's answer includes a thruster command (`controller.thrusters` set).
    expect_thrusters: bool,
    held: ActuatorCommand,
    /// Ticks in a row without both commands.
    unanswered: u64,
    /// Unanswered ticks after which the commands are zeroed (`run.command_timeout_s`).
    zero_after: u64,
    /// Ticks integrated with zeroed commands.
    zeroed_ticks: u64,
    tilt_stop: u32,
    deadline_misses: u64,
    truth_seq: Sequence,
    tick_seq: Sequence,
}

impl PlantTask {
    pub fn new(config: &RunConfig) -> Result<Self, PlantTaskError> {
        let schedule = config.schedule()?;
        Ok(Self {
            plant: Plant::new(&config.model, config.manoeuvre.initial_state())?,
            stepper: CmgStepperDrive::new(&config.model.cmg),
            last_tick: schedule.tick_count(config.run.duration_s),
            schedule,
            tick: 0,
            wheel: None,
            cmg: None,
            thrusters: None,
            expect_thrusters: config.controller.thrusters.is_some(),
            held: ActuatorCommand::default(),
            unanswered: 0,
            // Whole periods in the timeout, within the clock's tolerance (0.2 s / 0.1 s is 2).
            zero_after: ((config.run.command_timeout_s - TIME_TOLERANCE_S) / schedule.period_s())
                .ceil()
                .max(1.0) as u64,
            zeroed_ticks: 0,
            tilt_stop: 0,
            deadline_misses: 0,
            truth_seq: Sequence::default(),
            tick_seq: Sequence::default(),
        })
    }

    pub fn tick(&self) -> u64 {
        self.tick
    }

    pub fn time_ns(&self) -> u64 {
        self.schedule.time_ns(self.tick)
    }

    pub fn deadline_misses(&self) -> u64 {
        self.deadline_misses
    }

    /// The current tick's truth and clock samples (publish truth first).
    pub fn outputs(&mut self) -> (SimTruth, SimClockTick) {
        let s = self.plant.state();
        let t_ns = self.time_ns();
        let truth = SimTruth {
            header: self
                .truth_seq
                .header(t_ns, SampleHeader::VALID | SampleHeader::SIMULATED),
            quaternion: quaternion_to_array(&s.q),
            rate: a3(&s.rate_b),
            wheel_speed: a3(&s.wheel_speed),
            gimbal_angle: a4(&s.gimbal),
            // The gyro's bias lives in the simulated gyro process, not in the plant.
            gyro_bias: [0.0; 3],
            angular_momentum: a3(&self.plant.angular_momentum_l()),
            kinetic_energy: self.plant.kinetic_energy_j(),
            tilt_stop: self.tilt_stop,
            _pad0: 0,
        };
        let clock = SimClockTick {
            header: self
                .tick_seq
                .header(t_ns, SampleHeader::VALID | SampleHeader::SIMULATED),
            tick: self.tick,
            sim_time_ns: t_ns,
            step_ns: self.schedule.period_ns,
        };
        (truth, clock)
    }

    /// A wheel command; kept if it answers the current tick.
    pub fn on_wheel_command(&mut self, c: &WheelCommand) {
        if c.header.time_ns == self.time_ns() {
            self.wheel = Some(*c);
        }
    }

    pub fn on_cmg_command(&mut self, c: &CmgCommand) {
        if c.header.time_ns == self.time_ns() {
            self.cmg = Some(*c);
        }
    }

    /// A thruster command; kept if it answers the current tick (valves shut otherwise).
    pub fn on_thruster_command(&mut self, c: &ipc_types::ThrusterCommand) {
        if c.header.time_ns == self.time_ns() {
            self.thrusters = Some(*c);
        }
    }

    /// Every command of the current tick has arrived: wheels, CMG and, in a run with thruster
    /// control, the thrusters.
    pub fn answered(&self) -> bool {
        self.wheel.is_some()
            && self.cmg.is_some()
            && (!self.expect_thrusters || self.thrusters.is_some())
    }

    /// Whether the platform has thrusters (the model's `[thrusters]`).
    pub fn has_thrusters(&self) -> bool {
        self.plant.thrusters().is_some()
    }

    /// The valves' positions now: bit `i` set if valve `i` is open (0 without thrusters).
    pub fn valves_open(&self) -> u32 {
        let t_s = self.plant.time_s();
        self.plant.thrusters().map_or(0, |bank| {
            (0..testbed_model::thruster_config::THRUSTER_COUNT)
                .filter(|&i| bank.valve_open(i, t_s))
                .fold(0, |bits, i| bits | 1 << i)
        })
    }

    /// Propellant used since start, kg (0 without thrusters).
    pub fn propellant_used_kg(&self) -> f64 {
        self.plant
            .thrusters()
            .map_or(0.0, |bank| bank.propellant_used_kg())
    }

    /// Whether the thrusters' latch valve is shut (false without thrusters).
    pub fn thruster_latch_shut(&self) -> bool {
        self.plant.thrusters().is_some_and(|bank| bank.latch_shut())
    }

    /// Shuts the latch valve upstream of every thruster (a stuck-open valve was found).
    pub fn shut_thruster_latch(&mut self) {
        if let Some(bank) = self.plant.thrusters_mut() {
            bank.set_latch_shut(true);
        }
    }

    /// The last tick has been published (and, in lockstep, answered): the run is over.
    pub fn at_end(&self) -> bool {
        self.tick >= self.last_tick
    }

    /// Ticks integrated with zeroed commands because none came for `run.command_timeout_s`.
    pub fn zeroed_ticks(&self) -> u64 {
        self.zeroed_ticks
    }

    /// Whether the last tick was integrated with zeroed commands.
    pub fn commands_zeroed(&self) -> bool {
        self.unanswered >= self.zero_after
    }

    /// Integrate to the next tick with the current tick's commands, or the held ones if they
    /// did not arrive (counted as a deadline miss), or zero once none came for
    /// `run.command_timeout_s`.
    pub fn advance(&mut self) -> Result<StepReport, PlantTaskError> {
        let mut command = match (&self.wheel, &self.cmg) {
            (Some(w), Some(c)) => {
                self.unanswered = 0;
                ActuatorCommand {
                    wheel_torque_nm: v3(&w.torque),
                    gimbal_rate_rad_s: v4(&c.gimbal_rate),
                }
            }
            _ => {
                self.deadline_misses += 1;
                self.unanswered += 1;
                if self.unanswered >= self.zero_after {
                    self.zeroed_ticks += 1;
                    ActuatorCommand::default()
                } else {
                    self.held.clone()
                }
            }
        };
        command.gimbal_rate_rad_s = self.stepper.command(&command.gimbal_rate_rad_s).rate_rad_s;
        self.held = command.clone();
        if let Some(c) = self.thrusters.take() {
            self.plant
                .command_thrusters(&testbed_model::physics::ThrusterCommand {
                    on_time_s: c.on_time,
                })?;
        }
        let report = self.plant.step(&command, self.schedule.period_s())?;
        if let Some(event) = &report.tilt_stop {
            self.tilt_stop |= 1 << event.axis.index();
        }
        self.tick += 1;
        self.wheel = None;
        self.cmg = None;
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn commands(plant: &mut PlantTask, torque_nm: f64) {
        let header = SampleHeader::new(plant.time_ns(), plant.tick(), SampleHeader::VALID);
        plant.on_wheel_command(&WheelCommand::new(header, [torque_nm; 3]));
        plant.on_cmg_command(&CmgCommand::new(header, [0.0; 4]));
    }

    #[test]
    fn a_command_is_held_one_period_and_zeroed_after_the_timeout() {
        let config = RunConfig::default(); // 0.1 s ticks, command_timeout_s = 0.2
        let mut plant = PlantTask::new(&config).unwrap();
        commands(&mut plant, 0.05);
        let answered = plant.advance().unwrap();
        assert_eq!(
            answered.applied.wheel_motor_torque_nm,
            Vector3::repeat(0.05)
        );
        // The controller falls silent: one period on the last command, then zero.
        let held = plant.advance().unwrap();
        assert_eq!(held.applied.wheel_motor_torque_nm, Vector3::repeat(0.05));
        assert!(!plant.commands_zeroed());
        for _ in 0..5 {
            let silent = plant.advance().unwrap();
            assert_eq!(silent.applied.wheel_motor_torque_nm, Vector3::zeros());
            assert!(plant.commands_zeroed());
        }
        assert_eq!((plant.deadline_misses(), plant.zeroed_ticks()), (6, 5));
        // Commands again: applied at once.
        commands(&mut plant, -0.02);
        let back = plant.advance().unwrap();
        assert_eq!(back.applied.wheel_motor_torque_nm, Vector3::repeat(-0.02));
        assert!(!plant.commands_zeroed());
    }
}
