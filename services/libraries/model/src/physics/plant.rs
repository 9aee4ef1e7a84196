//! The plant: platform, wheels and CMGs integrated in time, with actuator limits, delay, friction
//! stick–slip and the tilt stop.
//!
//! Each [`Plant::step`] splits its interval at the instants the acting command changes (actuator
//! delay), then into equal RK4 substeps no longer than `max_substep_s`. Every switching decision
//! (acting command, wheel stick/slip and sliding direction, speed limiter) is frozen for a
//! substep, so the right-hand side RK4 sees is smooth.
//!
//! Stick–slip (event-located, no regularisation): a sliding wheel keeps its Coulomb sign for the
//! substep; if its speed changes sign, the substep is redone up to the (linearly interpolated)
//! zero crossing, the wheel is stopped there, and the rest of the substep is integrated with the
//! wheel stuck — or sliding the other way if the motor beats the breakaway torque. A stopped
//! wheel stays stuck, exactly at `n = 0`, while the holding torque is within breakaway (see
//! [`Dynamics::wheel_modes`]). So a wheel neither chatters about zero nor creeps, and friction
//! never needs a stiff smoothing slope that would force tiny steps. (After `MAX_SPLITS` crossings
//! in one substep the remainder is integrated without looking; no test case comes near it.)
//!
//! The tilt stop ([`super::tilt_stop`]) is enforced at the end of every substep, so a strike is
//! timed to within one substep and overshoots the stop by at most one substep of motion before
//! the attitude is put back on it.

use super::PhysicsError;
use super::delay::{CommandDelay, TIME_TOLERANCE_S};
use super::dynamics::{Dynamics, StepInput, WheelMode};
use super::environment::{ExternalTorque, ExternalTorqueModel};
use super::friction::Wheel;
use super::gauss_markov::GaussMarkovProcess;
use super::integrator::rk4_step;
use super::state::{ActuatorCommand, PlatformState, StateVector};
use super::thrusters::{ThrusterBank, ThrusterCommand};
use super::tilt_stop::{self, TiltAxis, TiltStopEvent};
use crate::attitude;
use crate::config::ModelConfig;
use nalgebra::{Vector3, Vector4};

/// A platform within this of its tilt stop is resting on it, rad.
const CONTACT_TOLERANCE_RAD: f64 = 1e-9;

/// Zero crossings located per substep before the rest of it is integrated without looking.
const MAX_SPLITS: usize = 8;

/// Integrator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegratorOptions {
    /// Longest RK4 substep, s. 0.01 s resolves the fastest platform dynamics (wheel friction
    /// stops, contact) far below the 10 Hz control period.
    pub max_substep_s: f64,
}

impl Default for IntegratorOptions {
    fn default() -> Self {
        Self {
            max_substep_s: 0.01,
        }
    }
}

/// What the actuators actually delivered (after delay, limits, scale and the speed limiter).
#[derive(Debug, Clone, PartialEq)]
pub struct AppliedActuation {
    /// Motor torque on each wheel, Nm.
    pub wheel_motor_torque_nm: Vector3<f64>,
    /// Gimbal rates, rad/s.
    pub gimbal_rate_rad_s: Vector4<f64>,
}

/// Outcome of one [`Plant::step`].
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// First new contact with the tilt stop during the step (resting contact is not re-reported).
    pub tilt_stop: Option<TiltStopEvent>,
    /// The platform is against the tilt stop at the end of the step.
    pub at_tilt_stop: bool,
    /// Actuation in the step's last substep.
    pub applied: AppliedActuation,
    /// RK4 substeps taken (zero-crossing splits not counted).
    pub substeps: usize,
}

/// The simulated test bed hardware.
#[derive(Debug, Clone)]
pub struct Plant {
    dynamics: Dynamics,
    /// The external torque model at time 0 (`com_drift` is resolved from it per substep).
    external_t0: ExternalTorqueModel,
    state: PlatformState,
    time_s: f64,
    max_substep_s: f64,
    delay: CommandDelay,
    tilt_limit_rad: f64,
    in_contact: [bool; 2],
    max_torque_nm: f64,
    torque_scale: Vector3<f64>,
    max_speed_rad_s: f64,
    max_gimbal_rate_rad_s: f64,
    applied: AppliedActuation,
    /// The thrusters (`None` unless configured) and the command for the next step.
    thrusters: Option<ThrusterBank>,
    thruster_command: Option<ThrusterCommand>,
    /// `gauss_markov_torque` (`None` unless configured): its process, sampled per substep.
    gauss_markov: Option<GaussMarkovProcess>,
}

impl Plant {
    /// A plant at time 0 in state `initial`, with the default integrator options.
    pub fn new(config: &ModelConfig, initial: PlatformState) -> Result<Self, PhysicsError> {
        Self::with_options(config, initial, IntegratorOptions::default())
    }

    /// Refuses an invalid configuration, a non-finite initial state, and an initial tilt beyond
    /// the stop.
    pub fn with_options(
        config: &ModelConfig,
        initial: PlatformState,
        options: IntegratorOptions,
    ) -> Result<Self, PhysicsError> {
        config.validate()?;
        if !(options.max_substep_s.is_finite() && options.max_substep_s > 0.0) {
            return Err(PhysicsError::InvalidSubstep {
                max_substep_s: options.max_substep_s,
            });
        }
        if !initial.is_finite() {
            return Err(PhysicsError::NonFinite {
                what: "initial platform state",
            });
        }
        let tilt_limit_rad = config.platform.tilt_limit_rad();
        let tilt = attitude::tilt_angles(&initial.q);
        for axis in [TiltAxis::X, TiltAxis::Y] {
            let angle = tilt[axis.index()];
            if angle.abs() > tilt_limit_rad + 1e-9 {
                return Err(PhysicsError::InitialTiltBeyondStop {
                    axis,
                    angle_deg: angle.to_degrees(),
                    limit_deg: config.platform.tilt_limit_deg,
                });
            }
        }
        let effects = &config.effects;
        let dynamics = Dynamics::from_config(config)?;
        Ok(Self {
            external_t0: *dynamics.external(),
            dynamics,
            state: initial,
            time_s: 0.0,
            max_substep_s: options.max_substep_s,
            delay: CommandDelay::new(effects.actuator_delay.as_ref().map_or(0.0, |d| d.delay_s)),
            tilt_limit_rad,
            in_contact: [false; 2],
            max_torque_nm: config.wheels.max_torque_nm,
            torque_scale: effects
                .wheel_torque_scale
                .as_ref()
                .map_or(Vector3::repeat(1.0), |s| s.scale.into()),
            max_speed_rad_s: config.wheels.max_speed_rad_s(),
            max_gimbal_rate_rad_s: config.cmg.max_gimbal_rate_rad_s(),
            applied: AppliedActuation {
                wheel_motor_torque_nm: Vector3::zeros(),
                gimbal_rate_rad_s: Vector4::zeros(),
            },
            thrusters: ThrusterBank::from_config(config),
            thruster_command: None,
            gauss_markov: effects
                .gauss_markov_torque
                .as_ref()
                .map(GaussMarkovProcess::new),
        })
    }

    /// Issue `command` now and advance the plant by `dt_s` seconds.
    ///
    /// Refuses a non-finite or non-positive `dt_s` and a non-finite command (the state is left
    /// untouched).
    pub fn step(
        &mut self,
        command: &ActuatorCommand,
        dt_s: f64,
    ) -> Result<StepReport, PhysicsError> {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(PhysicsError::InvalidStep { dt_s });
        }
        if !command.is_finite() {
            return Err(PhysicsError::NonFinite {
                what: "actuator command",
            });
        }
        let mut report = StepReport {
            tilt_stop: None,
            at_tilt_stop: false,
            applied: self.applied.clone(),
            substeps: 0,
        };
        self.delay.push(self.time_s, command.clone());
        if let (Some(bank), Some(c)) = (&mut self.thrusters, self.thruster_command.take()) {
            bank.command(self.time_s, &c, dt_s);
        }
        let t_end = self.time_s + dt_s;
        while t_end - self.time_s > TIME_TOLERANCE_S {
            let acting = self.delay.in_effect(self.time_s);
            let segment_end = self
                .delay
                .next_change_after(self.time_s)
                .map_or(t_end, |t| t.min(t_end));
            let segment_end = self
                .thrusters
                .as_ref()
                .and_then(|b| b.next_switch_after(self.time_s))
                .map_or(segment_end, |t| t.min(segment_end));
            let (motor, gimbal_rate) = self.actuation(&acting);
            // A whole number of substeps often divides with a rounding error above it
            // (0.1 / 0.01 = 10.000000000000002): allow the clock's tolerance before rounding up,
            // or about half of the steps would take one substep more than they need.
            let span = segment_end - self.time_s;
            let substeps = ((span - TIME_TOLERANCE_S) / self.max_substep_s)
                .ceil()
                .max(1.0) as usize;
            let h = (segment_end - self.time_s) / substeps as f64;
            for _ in 0..substeps {
                self.substep(&motor, &gimbal_rate, h, &mut report);
            }
            report.substeps += substeps;
            // Re-anchor the clock so rounding in the substep sum cannot accumulate.
            self.time_s = segment_end;
        }
        self.time_s = t_end;
        self.delay.discard_before(self.time_s);
        if let Some(bank) = &mut self.thrusters {
            bank.discard_before(self.time_s);
        }
        report.at_tilt_stop = self.in_contact.iter().any(|c| *c);
        report.applied = self.applied.clone();
        Ok(report)
    }

    /// Valve on-times for the next [`Plant::step`] (issued at its start; ignored without
    /// thrusters). Refuses a non-finite command.
    pub fn command_thrusters(&mut self, command: &ThrusterCommand) -> Result<(), PhysicsError> {
        if !command.is_finite() {
            return Err(PhysicsError::NonFinite {
                what: "thruster command",
            });
        }
        self.thruster_command = Some(*command);
        Ok(())
    }

    /// The thrusters, their valves and tank (`None` unless configured).
    pub fn thrusters(&self) -> Option<&ThrusterBank> {
        self.thrusters.as_ref()
    }

    /// The thrusters, to shut their latch valve (`None` unless configured).
    pub fn thrusters_mut(&mut self) -> Option<&mut ThrusterBank> {
        self.thrusters.as_mut()
    }

    pub fn state(&self) -> &PlatformState {
        &self.state
    }

    /// Plant time, s (0 at construction).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    pub fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    /// Total angular momentum about the bearing centre, `I w + J n + h_cmg`, Nms, body axes.
    pub fn angular_momentum_b(&self) -> Vector3<f64> {
        self.dynamics.momentum_b(&self.state)
    }

    /// Total angular momentum, Nms, level frame; constant without external torque.
    pub fn angular_momentum_l(&self) -> Vector3<f64> {
        self.state.q.inverse() * self.angular_momentum_b()
    }

    /// Kinetic energy, J; see [`Dynamics::kinetic_energy`] for what it includes.
    pub fn kinetic_energy_j(&self) -> f64 {
        self.dynamics.kinetic_energy(&self.state)
    }

    /// External torque on the platform now, by cause, Nm, body axes.
    pub fn external_torque_b(&self) -> ExternalTorque {
        self.dynamics
            .external()
            .torque(&self.state.q, &self.state.rate_b)
    }

    /// Delivered motor torque and gimbal rate for an acting command: the drive clamps the torque
    /// to ±max, the motor constant error (`wheel_torque_scale`) scales what it delivers, and the
    /// gimbal servos clamp the rate to ±max.
    fn actuation(&self, command: &ActuatorCommand) -> (Vector3<f64>, Vector4<f64>) {
        let t = self.max_torque_nm;
        let g = self.max_gimbal_rate_rad_s;
        (
            command
                .wheel_torque_nm
                .map(|x| x.clamp(-t, t))
                .component_mul(&self.torque_scale),
            command.gimbal_rate_rad_s.map(|x| x.clamp(-g, g)),
        )
    }

    /// Speed limiter of the wheel drives: a torque that spins a wheel up is capped at what brings
    /// it to max speed by the end of a step of length `h` (friction included), so a wheel
    /// saturates at max speed instead of passing it. Braking torque is never limited.
    fn speed_limited(&self, delivered: &Vector3<f64>, h: f64) -> Vector3<f64> {
        Vector3::from_fn(|i, _| {
            let tau = delivered[i];
            let n = self.state.wheel_speed[i];
            if tau == 0.0 || tau * n < 0.0 {
                return tau;
            }
            let wheel = Wheel::ALL[i];
            let friction = self.dynamics.friction(wheel).torque(n).abs();
            let headroom = friction
                + self.dynamics.wheel_effective_inertia(wheel) * (self.max_speed_rad_s - n.abs())
                    / h;
            tau.signum() * tau.abs().min(headroom.max(0.0))
        })
    }

    /// Advance by `h` at constant delivered actuation, locating wheel zero crossings.
    fn substep(
        &mut self,
        delivered: &Vector3<f64>,
        gimbal_rate: &Vector4<f64>,
        h: f64,
        report: &mut StepReport,
    ) {
        let mut remaining = h;
        self.dynamics
            .set_external_time(&self.external_t0, self.time_s);
        // Thrusters: their torque over the substep (valve switches are segment boundaries),
        // and the weight moment of the propellant used so far.
        let factors = self.thrusters.as_ref().map(|bank| {
            let mut external = ExternalTorqueModel::at_time(&self.external_t0, self.time_s);
            external.weight_moment_b += bank.weight_moment_change_b();
            self.dynamics.set_external_model(external);
            let f = bank.factors_at(self.time_s);
            self.dynamics.set_thruster_torque(Some(bank.torque_b(&f)));
            f
        });
        // The wandering torque, held over the substep, beside the constant torque.
        if let Some(gm) = &mut self.gauss_markov {
            let mut external = if self.thrusters.is_some() || self.external_t0.time_dependent() {
                *self.dynamics.external()
            } else {
                self.external_t0
            };
            external.constant_b += gm.torque_at(self.time_s);
            self.dynamics.set_external_model(external);
        }
        for split in 0..MAX_SPLITS {
            let motor = self.speed_limited(delivered, remaining);
            let modes = self.dynamics.wheel_modes(&self.state, &motor, gimbal_rate);
            let input = StepInput {
                motor_torque_nm: motor,
                gimbal_rate_rad_s: *gimbal_rate,
                modes,
            };
            let y0 = self.state.to_vector();
            let dynamics = &self.dynamics;
            let integrate = |h: f64| rk4_step(0.0, &y0, h, |_, y| dynamics.derivative(y, &input));
            let full = integrate(remaining);
            let crossing = if split + 1 < MAX_SPLITS {
                earliest_zero_crossing(&y0, &full, &modes)
            } else {
                None
            };
            let (taken, y1) = match crossing {
                None => (remaining, full),
                Some((_, fraction)) => (fraction * remaining, integrate(fraction * remaining)),
            };
            self.state = PlatformState::from_vector(&y1);
            // The wheel whose crossing ended the piece stops even if rounding left it a hair
            // short of zero (otherwise it would be split again and again); any other wheel that
            // also reached zero stops with it.
            for (i, mode) in modes.iter().enumerate() {
                if let WheelMode::Sliding { direction } = mode {
                    let reached = y0[7 + i] * direction > 0.0 && y1[7 + i] * direction <= 0.0;
                    if reached || crossing.is_some_and(|(wheel, _)| wheel == i) {
                        self.stop_wheel(i);
                    }
                }
            }
            self.time_s += taken;
            self.applied = AppliedActuation {
                wheel_motor_torque_nm: motor,
                gimbal_rate_rad_s: *gimbal_rate,
            };
            remaining -= taken;
            if crossing.is_none() || remaining <= 1e-12 * h {
                break;
            }
        }
        if let (Some(bank), Some(f)) = (&mut self.thrusters, factors) {
            bank.consume(&f, h);
        }
        // Once per substep, not per piece: contact resolved between the pieces of a split would
        // feed impact and friction stop into each other in ever shorter pieces.
        self.enforce_tilt_stop(report);
    }

    /// Stop wheel `i` that has just reached zero speed. The residual of the linear crossing
    /// estimate is handed to the platform so the total momentum stays exact.
    fn stop_wheel(&mut self, i: usize) {
        let residual = self.state.wheel_speed[i] * self.dynamics.wheel_inertia();
        self.state.wheel_speed[i] = 0.0;
        self.state.rate_b += self.dynamics.inertia_inverse() * Vector3::ith(i, residual);
    }

    fn enforce_tilt_stop(&mut self, report: &mut StepReport) {
        let sliding = self.state.wheel_speed.map(|n| n != 0.0);
        let engaged = tilt_stop::enforce_tilt_stop(
            self.tilt_limit_rad,
            self.dynamics.impact_inverse(&sliding),
            &sliding,
            &mut self.state,
        );
        let angles = attitude::tilt_angles(&self.state.q);
        for axis in [TiltAxis::X, TiltAxis::Y] {
            let k = axis.index();
            let new_strike = !self.in_contact[k] && report.tilt_stop.is_none();
            if let Some(angle_rad) = engaged[k].filter(|_| new_strike) {
                report.tilt_stop = Some(TiltStopEvent {
                    time_s: self.time_s,
                    axis,
                    angle_rad,
                });
            }
            // Contact lasts while the platform sits on the stop (within rounding), so resting
            // contact, which may leave the angle exactly on the limit for a step, is not a new
            // strike.
            self.in_contact[k] = angles[k].abs() >= self.tilt_limit_rad - CONTACT_TOLERANCE_RAD;
        }
    }
}

/// The first sliding wheel to reach zero speed and the fraction of the step (0..1) at which it
/// does, by linear interpolation of its speed; `None` if none does.
fn earliest_zero_crossing(
    y0: &StateVector,
    y1: &StateVector,
    modes: &[WheelMode; 3],
) -> Option<(usize, f64)> {
    (0..3)
        .filter_map(|i| match modes[i] {
            WheelMode::Sliding { direction } => {
                let (n0, n1) = (y0[7 + i] * direction, y1[7 + i] * direction);
                (n0 > 0.0 && n1 < 0.0).then(|| (i, n0 / (n0 - n1)))
            }
            WheelMode::Stuck => None,
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
}
