//! Reaction wheel bearing friction.
//!
//! Nominal model (paper eq. 3), per wheel: `T_f(n) = T_f0 sign(n) + K n`, n the wheel speed
//! relative to the platform (rad/s), `T_f` the torque the bearing exerts against the wheel's
//! relative motion (Nm). With `effects.wheel_friction` the Coulomb level depends on the direction
//! and rises towards the breakaway torque `T_s` near zero speed (Stribeck):
//! `T_f(n) = (T_c(dir) + (T_s − T_c(dir)) exp(−(n/n_s)²)) sign(n) + K n`.
//!
//! `effects.wheel_drag` adds `c n |n|` (windage), outside identification's library.
//!
//! At `n = 0` friction is not a function of speed: it is whatever torque keeps the wheel stuck, up
//! to the breakaway torque. [`wheel_friction_torque`] therefore returns 0 there, and the plant
//! decides stick or slip from [`WheelFrictionModel::breakaway_nm`] (see `plant`).

use crate::config::ModelConfig;

/// One of the three reaction wheels, named by the body axis it spins about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wheel {
    X,
    Y,
    Z,
}

impl Wheel {
    pub const ALL: [Wheel; 3] = [Wheel::X, Wheel::Y, Wheel::Z];

    /// Index into body-axis vectors (X = 0).
    pub fn index(self) -> usize {
        self as usize
    }
}

/// Friction parameters of one wheel, from the nominal configuration or the friction effect.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelFrictionModel {
    /// Coulomb level while turning in the positive direction, Nm.
    pub coulomb_pos_nm: f64,
    /// Coulomb level (magnitude) while turning in the negative direction, Nm.
    pub coulomb_neg_nm: f64,
    /// Viscous coefficient `K`, Nm/(rad/s).
    pub viscous_nm_per_rad_s: f64,
    /// Largest friction torque that holds a stopped wheel (breakaway, `T_s`), Nm.
    pub breakaway_nm: f64,
    /// Stribeck speed `n_s`, rad/s; `None` for the nominal model (no Stribeck term).
    pub stribeck_speed_rad_s: Option<f64>,
    /// Quadratic drag `c` of `effects.wheel_drag` (`c n |n|`), Nm/(rad/s)²; 0 without it.
    pub quadratic_nm_per_rad2_s2: f64,
}

impl WheelFrictionModel {
    /// The model of `wheel`: `effects.wheel_friction` when present, else the nominal eq. 3 with
    /// `wheels.coulomb_nm` also as the breakaway torque.
    pub fn from_config(config: &ModelConfig, wheel: Wheel) -> Self {
        let i = wheel.index();
        let quadratic_nm_per_rad2_s2 = config
            .effects
            .wheel_drag
            .as_ref()
            .map_or(0.0, |d| d.quadratic_nm_per_rad2_s2[i]);
        match &config.effects.wheel_friction {
            Some(f) => Self {
                coulomb_pos_nm: f.coulomb_pos_nm[i],
                coulomb_neg_nm: f.coulomb_neg_nm[i],
                viscous_nm_per_rad_s: f.viscous_nm_per_rad_s[i],
                breakaway_nm: f.stribeck_nm[i],
                stribeck_speed_rad_s: Some(f.stribeck_speed_rad_s[i]),
                quadratic_nm_per_rad2_s2,
            },
            None => Self {
                coulomb_pos_nm: config.wheels.coulomb_nm[i],
                coulomb_neg_nm: config.wheels.coulomb_nm[i],
                viscous_nm_per_rad_s: config.wheels.viscous_nm_per_rad_s[i],
                breakaway_nm: config.wheels.coulomb_nm[i],
                stribeck_speed_rad_s: None,
                quadratic_nm_per_rad2_s2,
            },
        }
    }

    /// Friction torque (Nm, opposing the relative motion) at speed `n` (rad/s), 0 at `n = 0`.
    pub fn torque(&self, n: f64) -> f64 {
        if n == 0.0 {
            0.0
        } else {
            self.sliding_torque(n, n.signum())
        }
    }

    /// Friction of a wheel known to slide in `direction` (±1), at speed `n`.
    ///
    /// The plant freezes the direction for an integration step so the Coulomb term does not flip
    /// inside the Runge–Kutta stages; at `n = 0` it is the direction the wheel breaks away in.
    pub fn sliding_torque(&self, n: f64, direction: f64) -> f64 {
        let coulomb = if direction > 0.0 {
            self.coulomb_pos_nm
        } else {
            self.coulomb_neg_nm
        };
        let level = match self.stribeck_speed_rad_s {
            Some(ns) => coulomb + (self.breakaway_nm - coulomb) * (-(n / ns).powi(2)).exp(),
            None => coulomb,
        };
        level * direction
            + self.viscous_nm_per_rad_s * n
            + self.quadratic_nm_per_rad2_s2 * n * n.abs()
    }
}

/// Friction torque of `wheel` at relative speed `n` (rad/s), Nm, opposing the motion: eq. 3, or
/// the asymmetric Stribeck model of `effects.wheel_friction` when present. Returns 0 at `n = 0`,
/// where the static friction (up to the breakaway torque) is set by the stick condition instead.
pub fn wheel_friction_torque(config: &ModelConfig, wheel: Wheel, n: f64) -> f64 {
    WheelFrictionModel::from_config(config, wheel).torque(n)
}

/// Breakaway torque of `wheel`, Nm: the largest motor torque a stopped wheel resists.
pub fn wheel_breakaway_torque(config: &ModelConfig, wheel: Wheel) -> f64 {
    WheelFrictionModel::from_config(config, wheel).breakaway_nm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::WheelFriction;

    #[test]
    fn nominal_is_paper_eq3() {
        let config = ModelConfig::default();
        for wheel in Wheel::ALL {
            for n in [-600.0, -1.0, 0.5, 300.0] {
                let expected = 1.5e-3 * f64::signum(n) + 3.0e-6 * n;
                assert!((wheel_friction_torque(&config, wheel, n) - expected).abs() < 1e-15);
            }
            assert_eq!(wheel_friction_torque(&config, wheel, 0.0), 0.0);
            assert_eq!(wheel_breakaway_torque(&config, wheel), 1.5e-3);
        }
    }

    #[test]
    fn wheel_drag_adds_a_quadratic_term_opposing_the_motion() {
        let mut config = ModelConfig::default();
        config.effects.wheel_drag = Some(crate::config::WheelDrag {
            quadratic_nm_per_rad2_s2: [0.0, 2.0e-8, 0.0],
        });
        for n in [-300.0, -2.0, 5.0, 250.0] {
            let nominal = 1.5e-3 * f64::signum(n) + 3.0e-6 * n;
            let y = wheel_friction_torque(&config, Wheel::Y, n);
            assert!(
                (y - (nominal + 2.0e-8 * n * n.abs())).abs() < 1e-15,
                "{n}: {y}"
            );
            assert!((wheel_friction_torque(&config, Wheel::X, n) - nominal).abs() < 1e-15);
        }
    }

    #[test]
    fn effect_gives_asymmetry_and_stribeck_spike() {
        let mut config = ModelConfig::default();
        config.effects.wheel_friction = Some(WheelFriction {
            coulomb_pos_nm: [1.0e-3, 1.0e-3, 2.0e-3],
            coulomb_neg_nm: [1.5e-3, 1.5e-3, 2.5e-3],
            viscous_nm_per_rad_s: [2.0e-6; 3],
            stribeck_nm: [3.0e-3, 3.0e-3, 4.0e-3],
            stribeck_speed_rad_s: [0.5, 0.5, 1.0],
        });
        let z = Wheel::Z;
        // Far from zero the Stribeck term has died out: Coulomb of the direction + viscous.
        assert!((wheel_friction_torque(&config, z, 100.0) - (2.0e-3 + 2.0e-4)).abs() < 1e-12);
        assert!((wheel_friction_torque(&config, z, -100.0) + (2.5e-3 + 2.0e-4)).abs() < 1e-12);
        // At n = n_s: T_c + (T_s − T_c)/e.
        let at_ns = 2.0e-3 + 2.0e-3 / std::f64::consts::E + 2.0e-6;
        assert!((wheel_friction_torque(&config, z, 1.0) - at_ns).abs() < 1e-12);
        // Just off zero, friction approaches breakaway from both sides.
        assert!((wheel_friction_torque(&config, z, 1e-9) - 4.0e-3).abs() < 1e-9);
        assert!((wheel_friction_torque(&config, z, -1e-9) + 4.0e-3).abs() < 1e-9);
        assert_eq!(wheel_breakaway_torque(&config, z), 4.0e-3);
    }
}
