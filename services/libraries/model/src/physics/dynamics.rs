//! Equations of motion of the platform with three reaction wheels and a four-CMG pyramid.
//!
//! Body frame B, rates relative to the level frame L (treated as inertial: the Earth's rotation is
//! a sensor-side effect). With `I` the total inertia about the bearing centre (rotors included),
//! `J` the wheel rotor inertia about its spin axis, `n` the wheel speeds relative to the platform
//! and `h = J n + h_cmg(δ)` the rotors' relative momentum:
//!
//! ```text
//! platform:  I w' + h' + w × (I w + h) = M                       (Euler, body axes)
//! wheel i:   J (w_i' + n_i') = τ_net,i,   τ_net = τ_motor − T_f(n) + T_e(…)
//! CMGs:      h_cmg' = J_cmg(δ) δ',        δ' = servoed gimbal rate
//! ⇒ (I − J·1) w' = M − w × (I w + h) − τ_net − J_cmg(δ) δ'
//!    n' = τ_net / J − w'
//! q' = ½ (0, −w) ⊗ q                                              (Hamilton, L→B, see attitude)
//! ```
//!
//! `T_e` are the wheel effects outside friction, zero unless configured:
//! `effects.wheel_tilt_torque` and `effects.fitted_wheel_torque`
//! ([`super::fitted_wheel_torque`]).
//!
//! A wheel held by static friction (stuck) has `n_i' = 0`: its unknown friction torque is
//! eliminated by moving `J w_i'` to the left, `(I − J·1 + J P_S) w' = …` with `P_S` selecting the
//! stuck wheels, and afterwards recovered to check it against the breakaway torque.
//!
//! The CMG rotors spin at constant speed relative to their gimbals (speed-servoed), and their
//! inertia, like the gimbals', is lumped into `I` as a constant: gimbal motion changes only `h`.

use super::environment::ExternalTorqueModel;
use super::fitted_wheel_torque::FittedWheelTorqueModel;
use super::friction::{Wheel, WheelFrictionModel};
use super::state::{PlatformState, StateVector};
use super::{CmgPyramid, PhysicsError};
use crate::attitude::Attitude;
use crate::config::ModelConfig;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3, Vector4};

/// Friction regime of one wheel over an integration step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WheelMode {
    /// Held to the platform by static friction: `n' = 0`.
    Stuck,
    /// Sliding; `direction` (±1) is the sign of the Coulomb term, frozen for the step.
    Sliding { direction: f64 },
}

/// Everything the derivative needs besides the state, constant over one integration step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepInput {
    /// Motor torque delivered to each wheel, Nm (after limits, scale and speed limiter).
    pub motor_torque_nm: Vector3<f64>,
    /// Gimbal rates, rad/s (after the rate limit).
    pub gimbal_rate_rad_s: Vector4<f64>,
    pub modes: [WheelMode; 3],
}

/// Constant parameters of the equations of motion, resolved from the configuration.
#[derive(Debug, Clone)]
pub struct Dynamics {
    inertia: Matrix3<f64>,
    wheel_inertia: f64,
    cmg: CmgPyramid,
    friction: [WheelFrictionModel; 3],
    /// `effects.wheel_tilt_torque`: per wheel, torque per unit of `G_x` and of `G_y`, Nm.
    wheel_tilt: Option<[[f64; 2]; 3]>,
    /// `effects.fitted_wheel_torque`, resolved (inactive without it).
    fitted_wheel: FittedWheelTorqueModel,
    external: ExternalTorqueModel,
    /// `(I − J·1 + J P_S)⁻¹` for each set S of stuck wheels (bit i = wheel i).
    locked_inverse: [Matrix3<f64>; 8],
    /// Torque of the thrusters over the current substep, Nm, body axes (`None` without
    /// thrusters: the arithmetic of a platform without them is unchanged).
    thruster_torque_b: Option<Vector3<f64>>,
}

impl Dynamics {
    /// Uses the true inertia (`effects.inertia_error` applied). The configuration must be valid.
    pub fn from_config(config: &ModelConfig) -> Result<Self, PhysicsError> {
        let wheel_inertia = config.wheels.inertia_kgm2;
        let bad = || PhysicsError::InertiaNotPositiveDefinite {
            wheel_inertia_kgm2: wheel_inertia,
        };
        let inertia = config.true_inertia().ok_or_else(bad)?;
        let mut locked_inverse = [Matrix3::zeros(); 8];
        for (mask, inverse) in locked_inverse.iter_mut().enumerate() {
            let stuck = Vector3::from_fn(|i, _| if mask & (1 << i) != 0 { 1.0 } else { 0.0 });
            let m =
                inertia - Matrix3::from_diagonal(&(Vector3::repeat(1.0) - stuck)) * wheel_inertia;
            // Cholesky both proves positive definiteness and gives the inverse.
            *inverse = m.cholesky().ok_or_else(bad)?.inverse();
        }
        Ok(Self {
            inertia,
            wheel_inertia,
            cmg: CmgPyramid::from_config(&config.cmg),
            friction: Wheel::ALL.map(|w| WheelFrictionModel::from_config(config, w)),
            wheel_tilt: config
                .effects
                .wheel_tilt_torque
                .as_ref()
                .map(|t| std::array::from_fn(|i| [t.sin_tilt_x_nm[i], t.sin_tilt_y_nm[i]])),
            fitted_wheel: FittedWheelTorqueModel::from_config(
                config.effects.fitted_wheel_torque.as_ref(),
            ),
            external: ExternalTorqueModel::from_config(config),
            locked_inverse,
            thruster_torque_b: None,
        })
    }

    /// Total inertia `I`, kg m², body axes.
    pub fn inertia(&self) -> &Matrix3<f64> {
        &self.inertia
    }

    /// Wheel rotor inertia `J`, kg m².
    pub fn wheel_inertia(&self) -> f64 {
        self.wheel_inertia
    }

    pub fn cmg(&self) -> &CmgPyramid {
        &self.cmg
    }

    pub fn friction(&self, wheel: Wheel) -> &WheelFrictionModel {
        &self.friction[wheel.index()]
    }

    pub fn external(&self) -> &ExternalTorqueModel {
        &self.external
    }

    /// Re-resolve a time-dependent external torque (`com_drift`) at plant time `t_s` from the
    /// model at time 0 (`base`), and the fitted wheel torque's time terms. Does nothing for
    /// time-independent ones.
    pub fn set_external_time(&mut self, base: &ExternalTorqueModel, t_s: f64) {
        if base.time_dependent() {
            self.external = ExternalTorqueModel::at_time(base, t_s);
        }
        if self.fitted_wheel.uses_time() {
            self.fitted_wheel.set_time(t_s);
        }
    }

    /// Replace the external torque model (the plant's thrusters move the centre of mass).
    pub fn set_external_model(&mut self, model: ExternalTorqueModel) {
        self.external = model;
    }

    /// The thrusters' torque for the next substep, Nm, body axes (`None`: no thrusters).
    pub fn set_thruster_torque(&mut self, torque_b: Option<Vector3<f64>>) {
        self.thruster_torque_b = torque_b;
    }

    /// `(I − J·1)⁻¹`, 1/(kg m²): the platform's response to a torque while every wheel slides.
    pub fn free_platform_inverse(&self) -> &Matrix3<f64> {
        &self.locked_inverse[0]
    }

    /// `(I − J·P_sliding)⁻¹`, 1/(kg m²): the response to an impulse on the structure that the
    /// stuck wheels follow and the sliding wheels (`sliding[i]`) do not.
    pub fn impact_inverse(&self, sliding: &Vector3<bool>) -> &Matrix3<f64> {
        let stuck_mask = (0..3).filter(|i| !sliding[*i]).fold(0, |m, i| m | (1 << i));
        &self.locked_inverse[stuck_mask]
    }

    /// `I⁻¹`, 1/(kg m²): the response with every wheel held to the platform.
    pub fn inertia_inverse(&self) -> &Matrix3<f64> {
        &self.locked_inverse[0b111]
    }

    /// Inertia seen by a torque between wheel i and the platform, `1 / (1/J + [(I − J·1)⁻¹]_ii)`,
    /// kg m²: `n_i' = τ_net,i / J_eff` when nothing else acts.
    pub fn wheel_effective_inertia(&self, wheel: Wheel) -> f64 {
        let i = wheel.index();
        1.0 / (1.0 / self.wheel_inertia + self.locked_inverse[0][(i, i)])
    }

    /// Rotors' momentum relative to the platform, `J n + h_cmg(δ)`, Nms, body axes.
    pub fn rotor_momentum_b(&self, s: &PlatformState) -> Vector3<f64> {
        s.wheel_speed * self.wheel_inertia + self.cmg.momentum(&s.gimbal)
    }

    /// Total angular momentum about the bearing centre, `I w + h`, Nms, body axes.
    pub fn momentum_b(&self, s: &PlatformState) -> Vector3<f64> {
        self.inertia * s.rate_b + self.rotor_momentum_b(s)
    }

    /// Kinetic energy of the platform with the CMG rotors locked in it and of the free wheels, J:
    /// `½ wᵀ(I − J·1)w + ½ Σ J (n_i + w_i)²`.
    ///
    /// The CMG rotors' spin relative to their gimbals is left out: its speed is servoed constant,
    /// so its energy `Σ (½ h0²/J_r + w·h_cmg,i)` changes only by the work of the spin motors. The
    /// quantity returned is therefore an integral of torque-free motion at fixed gimbals, as the
    /// gyrostat theory has it; moving gimbals exchange energy with the gimbal servos.
    pub fn kinetic_energy(&self, s: &PlatformState) -> f64 {
        let w = &s.rate_b;
        let platform = (self.inertia - Matrix3::identity() * self.wheel_inertia) * w;
        let wheels: f64 = (s.wheel_speed + w).map(|x| x * x).sum() * self.wheel_inertia;
        0.5 * (w.dot(&platform) + wheels)
    }

    /// Platform and wheel accelerations `(w', n')`, rad/s², at the given state.
    pub fn accelerations(
        &self,
        q: &Attitude,
        rate_b: &Vector3<f64>,
        wheel_speed: &Vector3<f64>,
        gimbal: &Vector4<f64>,
        input: &StepInput,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (cmg_momentum, cmg_jacobian) = self.cmg.momentum_and_jacobian(gimbal);
        let h = wheel_speed * self.wheel_inertia + cmg_momentum;
        let mut rhs = self.external.torque(q, rate_b).total_b()
            - rate_b.cross(&(self.inertia * rate_b + h))
            - cmg_jacobian * input.gimbal_rate_rad_s;
        if let Some(thrust) = &self.thruster_torque_b {
            rhs += thrust;
        }
        let mut net = Vector3::zeros();
        let mut mask = 0;
        let g = self.wheel_tilt.map(|_| crate::attitude::gravity_b(q));
        let fitted = self
            .fitted_wheel
            .is_active()
            .then(|| self.fitted_wheel.platform(q, rate_b));
        for i in 0..3 {
            match input.modes[i] {
                WheelMode::Stuck => mask |= 1 << i,
                WheelMode::Sliding { direction } => {
                    net[i] = input.motor_torque_nm[i]
                        - self.friction[i].sliding_torque(wheel_speed[i], direction);
                    if let (Some(tilt), Some(g)) = (&self.wheel_tilt, &g) {
                        net[i] += tilt[i][0] * g.x + tilt[i][1] * g.y;
                    }
                    if let Some(platform) = &fitted {
                        net[i] += self.fitted_wheel.torque(
                            i,
                            wheel_speed[i],
                            direction,
                            input.motor_torque_nm[i],
                            platform,
                        );
                    }
                    rhs[i] -= net[i];
                }
            }
        }
        let w_dot = self.locked_inverse[mask] * rhs;
        let n_dot = Vector3::from_fn(|i, _| match input.modes[i] {
            WheelMode::Stuck => 0.0,
            WheelMode::Sliding { .. } => net[i] / self.wheel_inertia - w_dot[i],
        });
        (w_dot, n_dot)
    }

    /// Time derivative of the state vector (layout of [`StateVector`]).
    pub fn derivative(&self, y: &StateVector, input: &StepInput) -> StateVector {
        let q = Quaternion::from(y.fixed_rows::<4>(0).into_owned());
        let rate_b: Vector3<f64> = y.fixed_rows::<3>(4).into_owned();
        let wheel_speed: Vector3<f64> = y.fixed_rows::<3>(7).into_owned();
        let gimbal: Vector4<f64> = y.fixed_rows::<4>(10).into_owned();
        // Stage states leave the unit sphere slightly; the torques want a proper rotation.
        let attitude = UnitQuaternion::new_normalize(q);
        let (w_dot, n_dot) = self.accelerations(&attitude, &rate_b, &wheel_speed, &gimbal, input);
        let q_dot = Quaternion::from_imag(-rate_b) * q * 0.5;
        let mut dy = StateVector::zeros();
        dy.fixed_rows_mut::<4>(0).copy_from(&q_dot.coords);
        dy.fixed_rows_mut::<3>(4).copy_from(&w_dot);
        dy.fixed_rows_mut::<3>(7).copy_from(&n_dot);
        dy.fixed_rows_mut::<4>(10)
            .copy_from(&input.gimbal_rate_rad_s);
        dy
    }

    /// Friction regime of each wheel for a step starting at `s` (stick–slip decision).
    ///
    /// A spinning wheel slides in the direction it spins. A stopped wheel stays stuck while the
    /// friction torque needed to hold it, `τ_motor − J w_i'` (with `w'` solved with the stuck
    /// wheels locked), is within its breakaway torque; otherwise it breaks away in the direction
    /// of that torque. Releasing one wheel changes `w'` and so the others' holding torque, hence
    /// the short fixed-point loop (each pass releases at least one wheel or stops).
    pub fn wheel_modes(
        &self,
        s: &PlatformState,
        motor_torque_nm: &Vector3<f64>,
        gimbal_rate: &Vector4<f64>,
    ) -> [WheelMode; 3] {
        let mut input = StepInput {
            motor_torque_nm: *motor_torque_nm,
            gimbal_rate_rad_s: *gimbal_rate,
            modes: [0, 1, 2].map(|i| {
                let n = s.wheel_speed[i];
                if n == 0.0 {
                    WheelMode::Stuck
                } else {
                    WheelMode::Sliding {
                        direction: n.signum(),
                    }
                }
            }),
        };
        for _ in 0..3 {
            let (w_dot, _) = self.accelerations(&s.q, &s.rate_b, &s.wheel_speed, &s.gimbal, &input);
            let mut released = false;
            for i in 0..3 {
                if input.modes[i] == WheelMode::Stuck {
                    let holding = motor_torque_nm[i] - self.wheel_inertia * w_dot[i];
                    if holding.abs() > self.friction[i].breakaway_nm {
                        input.modes[i] = WheelMode::Sliding {
                            direction: holding.signum(),
                        };
                        released = true;
                    }
                }
            }
            if !released {
                break;
            }
        }
        input.modes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `effects.wheel_tilt_torque` adds `a G_x + b G_y` to the sliding wheel's net torque: the
    /// wheel's momentum changes by it, the platform's by its reaction (total momentum unchanged).
    #[test]
    fn wheel_tilt_torque_acts_between_wheel_and_platform() {
        let nominal = ModelConfig::default();
        let mut tilted = nominal.clone();
        tilted.effects.wheel_tilt_torque = Some(crate::config::WheelTiltTorque {
            sin_tilt_x_nm: [1.0e-2, 0.0, 0.0],
            sin_tilt_y_nm: [0.0, 0.0, 2.0e-2],
        });
        // Tilted 0.1 rad about body Y: G_B has an X component.
        let q = UnitQuaternion::from_euler_angles(0.0, 0.1, 0.0);
        let g = crate::attitude::gravity_b(&q);
        let rate = Vector3::zeros();
        let n = Vector3::new(100.0, -50.0, 30.0);
        let input = StepInput {
            motor_torque_nm: Vector3::zeros(),
            gimbal_rate_rad_s: Vector4::zeros(),
            modes: [
                WheelMode::Sliding { direction: 1.0 },
                WheelMode::Sliding { direction: -1.0 },
                WheelMode::Sliding { direction: 1.0 },
            ],
        };
        let gimbal = Vector4::zeros();
        let a = Dynamics::from_config(&nominal).expect("valid");
        let b = Dynamics::from_config(&tilted).expect("valid");
        let (wa, na) = a.accelerations(&q, &rate, &n, &gimbal, &input);
        let (wb, nb) = b.accelerations(&q, &rate, &n, &gimbal, &input);
        let j = nominal.wheels.inertia_kgm2;
        let extra = Vector3::new(1.0e-2 * g.x, 0.0, 2.0e-2 * g.y);
        assert!(g.x.abs() > 0.05, "{g:?}");
        // Wheel momentum J (n' + w') gains the torque; the platform's I w' loses it.
        let dh_wheel = j * ((nb - na) + (wb - wa));
        assert!(
            (dh_wheel - extra).norm() < 1e-12 * extra.norm().max(1.0),
            "{dh_wheel:?} vs {extra:?}"
        );
        let inertia = nominal.true_inertia().expect("valid");
        let dh_total = inertia * (wb - wa) + j * (nb - na);
        assert!(dh_total.norm() < 1e-12, "{dh_total:?}");
    }
}
