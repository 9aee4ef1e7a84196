//! The controller's safe mode: when it is entered, what it commands, and when it is left.
//!
//! Safe mode is entered when the controller can no longer trust what it would command: the
//! estimate is lost (none for two control periods) or invalid after a valid one, an actuator's
//! telemetry is lost, a wheel runs near its speed limit, or the ground asks for it. In safe mode
//! the wheels get a safe torque (zero, or rate damping on the gyro alone: the estimator may be
//! the very thing that failed), the CMG gimbals are held (zero gimbal rate), and no wheel is
//! driven further towards its speed limit. Safe mode is left once every input has been healthy
//! for `recovery_s` (when `auto_recover`), or on a ground command.
//!
//! Everything here is a pure function of sample times and values (no wall clock), so a lockstep
//! run stays reproducible and the in-process loop behaves as the pipeline does.

use crate::control::{ControlError, check_positive, invalid};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// What the wheels do in safe mode (`controller.safe_mode.wheels`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SafeWheels {
    /// Zero motor torque: the wheels coast (friction slows them).
    Zero,
    /// Damp the body rate measured by the gyro: platform torque `−K·ω`.
    RateDamping,
}

/// Safe-mode configuration (`[controller.safe_mode]`). Defaults are assumed values, chosen for
/// the paper's platform (principal moments 45–63 kg m², wheels 0.1 N m / 6000 rpm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafeModeConfig {
    /// The wheels' safe torque.
    pub wheels: SafeWheels,
    /// Rate-damping gain `K`, N m per rad/s of body rate (platform torque `−K·ω`). With the
    /// default 5 N m s and ~50 kg m² the rate decays with a time constant of ~10 s.
    pub rate_gain_nms: f64,
    /// Enter safe mode when a wheel's speed exceeds this fraction of `wheels.max_speed_rpm`;
    /// in safe mode no torque drives a wheel that is beyond it further out. Dimensionless.
    pub wheel_speed_fraction: f64,
    /// Inputs must be healthy this long before safe mode is left, s of run time.
    pub recovery_s: f64,
    /// Leave safe mode by itself after `recovery_s` of healthy inputs; when false only a
    /// ground command leaves it.
    pub auto_recover: bool,
}

impl Default for SafeModeConfig {
    fn default() -> Self {
        Self {
            wheels: SafeWheels::RateDamping,
            rate_gain_nms: 5.0,
            wheel_speed_fraction: 0.75,
            recovery_s: 5.0,
            auto_recover: true,
        }
    }
}

impl SafeModeConfig {
    /// Refuses non-finite or out-of-range values, naming the key.
    pub fn validate(&self) -> Result<(), ControlError> {
        check_positive("controller.safe_mode.rate_gain_nms", self.rate_gain_nms)?;
        let f = self.wheel_speed_fraction;
        if !(f.is_finite() && f > 0.0 && f < 1.0) {
            return Err(invalid(
                "controller.safe_mode.wheel_speed_fraction",
                f,
                "must be in (0, 1)",
            ));
        }
        let r = self.recovery_s;
        if !(r.is_finite() && r >= 0.0) {
            return Err(invalid(
                "controller.safe_mode.recovery_s",
                r,
                "must be finite and ≥ 0",
            ));
        }
        Ok(())
    }
}

/// Why the controller is in safe mode: a set of [`SafeReason`] bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct SafeReasons(pub u32);

/// One cause of safe mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum SafeReason {
    /// No estimate for two control periods (after the first one).
    EstimateLost = 1,
    /// The estimate is flagged invalid or not finite (after a valid one).
    EstimateInvalid = 2,
    /// No wheel telemetry for two control periods.
    WheelTelemetryLost = 4,
    /// No CMG telemetry for two control periods.
    CmgTelemetryLost = 8,
    /// A wheel beyond `wheel_speed_fraction` of its speed limit.
    WheelSpeedLimit = 16,
    /// Asked for by the ground.
    Ground = 32,
}

impl SafeReason {
    pub const ALL: [SafeReason; 6] = [
        Self::EstimateLost,
        Self::EstimateInvalid,
        Self::WheelTelemetryLost,
        Self::CmgTelemetryLost,
        Self::WheelSpeedLimit,
        Self::Ground,
    ];

    /// A short name for logs and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::EstimateLost => "estimate lost",
            Self::EstimateInvalid => "estimate invalid",
            Self::WheelTelemetryLost => "wheel telemetry lost",
            Self::CmgTelemetryLost => "CMG telemetry lost",
            Self::WheelSpeedLimit => "wheel near its speed limit",
            Self::Ground => "ground command",
        }
    }
}

impl SafeReasons {
    pub const NONE: Self = Self(0);

    pub fn with(self, reason: SafeReason, present: bool) -> Self {
        if present {
            Self(self.0 | reason as u32)
        } else {
            self
        }
    }

    pub fn contains(self, reason: SafeReason) -> bool {
        self.0 & reason as u32 != 0
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The reasons' names, comma-separated ("none" when empty).
    pub fn describe(self) -> String {
        let names: Vec<_> = SafeReason::ALL
            .iter()
            .filter(|r| self.contains(**r))
            .map(|r| r.name())
            .collect();
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        }
    }
}

/// A change of safe mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SafeTransition {
    /// Entered, for these reasons.
    Entered(SafeReasons),
    /// Left after the inputs were healthy for `recovery_s` (or on a ground command).
    Left,
}

/// The safe-mode state machine.
#[derive(Debug, Clone)]
pub struct SafeMode {
    config: SafeModeConfig,
    active: bool,
    /// Reasons of the latest update (what is wrong now).
    reasons: SafeReasons,
    /// Since when (run time, ns) every input has been healthy while in safe mode.
    healthy_since_ns: Option<u64>,
    /// The ground holds safe mode until it releases it.
    ground_hold: bool,
    /// The ground asked to leave safe mode.
    ground_release: bool,
    entries: u64,
}

impl SafeMode {
    pub fn new(config: SafeModeConfig) -> Self {
        Self {
            config,
            active: false,
            reasons: SafeReasons::NONE,
            healthy_since_ns: None,
            ground_hold: false,
            ground_release: false,
            entries: 0,
        }
    }

    pub fn config(&self) -> &SafeModeConfig {
        &self.config
    }

    pub fn is_active(&self) -> bool {
        self.active
    }

    /// What was wrong at the latest update.
    pub fn reasons(&self) -> SafeReasons {
        self.reasons
    }

    /// Times safe mode was entered since start.
    pub fn entries(&self) -> u64 {
        self.entries
    }

    /// A ground command: `true` enters (and holds) safe mode, `false` leaves it at the next
    /// update if no other reason remains.
    pub fn ground_command(&mut self, safe: bool) {
        self.ground_hold = safe;
        self.ground_release = !safe;
    }

    /// Updates with what is wrong at run time `t_ns`; the transition, if any.
    pub fn update(&mut self, t_ns: u64, wrong: SafeReasons) -> Option<SafeTransition> {
        let wrong = wrong.with(SafeReason::Ground, self.ground_hold);
        self.reasons = wrong;
        if !wrong.is_empty() {
            self.healthy_since_ns = None;
            self.ground_release = false;
            if !self.active {
                self.active = true;
                self.entries += 1;
                return Some(SafeTransition::Entered(wrong));
            }
            return None;
        }
        if !self.active {
            return None;
        }
        let since = *self.healthy_since_ns.get_or_insert(t_ns);
        let healthy_s = t_ns.saturating_sub(since) as f64 * 1e-9;
        // Run times are whole nanoseconds: allow for rounding of the recovery time.
        let recovered = self.config.auto_recover && healthy_s >= self.config.recovery_s - 1e-9;
        if recovered || std::mem::take(&mut self.ground_release) {
            self.active = false;
            self.healthy_since_ns = None;
            return Some(SafeTransition::Left);
        }
        None
    }
}

/// The wheels' motor torque in safe mode, N m per wheel axis (the platform feels the
/// opposite), for gyro rate `gyro_rate_rad_s` (body axes; `None` when no fresh gyro sample:
/// zero torque) and wheel speeds `wheel_speed_rad_s`, limited to `max_torque_nm` and never
/// driving a wheel that is beyond `wheel_speed_fraction · max_speed_rad_s` further out.
pub fn safe_wheel_torque(
    config: &SafeModeConfig,
    gyro_rate_rad_s: Option<&Vector3<f64>>,
    wheel_speed_rad_s: &Vector3<f64>,
    max_torque_nm: f64,
    max_speed_rad_s: f64,
) -> Vector3<f64> {
    let wanted = match (config.wheels, gyro_rate_rad_s) {
        (SafeWheels::RateDamping, Some(rate)) if rate.iter().all(|x| x.is_finite()) => {
            // Platform torque −K·ω is a wheel motor torque +K·ω.
            rate * config.rate_gain_nms
        }
        _ => Vector3::zeros(),
    };
    let limit_speed = config.wheel_speed_fraction * max_speed_rad_s;
    Vector3::from_fn(|i, _| {
        let torque = wanted[i].clamp(-max_torque_nm, max_torque_nm);
        let speed = wheel_speed_rad_s[i];
        let drives_out = torque * speed > 0.0 && speed.abs() >= limit_speed;
        if drives_out || !speed.is_finite() {
            0.0
        } else {
            torque
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn entered_at_once_and_left_after_the_recovery_time_of_healthy_inputs() {
        let mut safe = SafeMode::new(SafeModeConfig {
            recovery_s: 1.0,
            ..SafeModeConfig::default()
        });
        assert_eq!(safe.update(0, SafeReasons::NONE), None);
        let lost = SafeReasons::NONE.with(SafeReason::EstimateLost, true);
        assert_eq!(
            safe.update(100 * MS, lost),
            Some(SafeTransition::Entered(lost))
        );
        assert_eq!(safe.update(200 * MS, lost), None, "entered once");
        // Healthy from 300 ms: still safe at 1.2 s, left at 1.3 s.
        for t in (300..=1200).step_by(100) {
            assert_eq!(safe.update(t * MS, SafeReasons::NONE), None, "t = {t} ms");
            assert!(safe.is_active());
        }
        assert_eq!(
            safe.update(1300 * MS, SafeReasons::NONE),
            Some(SafeTransition::Left)
        );
        assert_eq!(safe.entries(), 1);
    }

    #[test]
    fn a_relapse_restarts_the_recovery_time() {
        let mut safe = SafeMode::new(SafeModeConfig {
            recovery_s: 0.5,
            ..SafeModeConfig::default()
        });
        let wheel = SafeReasons::NONE.with(SafeReason::WheelSpeedLimit, true);
        safe.update(0, wheel);
        safe.update(400 * MS, SafeReasons::NONE);
        safe.update(800 * MS, wheel);
        assert_eq!(safe.update(1000 * MS, SafeReasons::NONE), None);
        assert_eq!(safe.update(1400 * MS, SafeReasons::NONE), None);
        assert_eq!(
            safe.update(1500 * MS, SafeReasons::NONE),
            Some(SafeTransition::Left)
        );
    }

    #[test]
    fn without_auto_recovery_only_the_ground_leaves_safe_mode() {
        let mut safe = SafeMode::new(SafeModeConfig {
            auto_recover: false,
            recovery_s: 0.0,
            ..SafeModeConfig::default()
        });
        safe.update(0, SafeReasons(SafeReason::EstimateInvalid as u32));
        assert_eq!(safe.update(10_000 * MS, SafeReasons::NONE), None);
        safe.ground_command(false);
        assert_eq!(
            safe.update(10_100 * MS, SafeReasons::NONE),
            Some(SafeTransition::Left)
        );
        // A ground request holds safe mode whatever the inputs.
        safe.ground_command(true);
        let t = safe.update(10_200 * MS, SafeReasons::NONE);
        assert_eq!(
            t,
            Some(SafeTransition::Entered(SafeReasons(
                SafeReason::Ground as u32
            )))
        );
        assert_eq!(safe.update(99_000 * MS, SafeReasons::NONE), None);
        assert!(safe.is_active());
    }

    #[test]
    fn rate_damping_opposes_the_body_rate_within_the_torque_limit() {
        let config = SafeModeConfig::default();
        let rate = Vector3::new(0.01, -0.002, 0.1);
        let torque = safe_wheel_torque(&config, Some(&rate), &Vector3::zeros(), 0.1, 628.0);
        // Platform torque −K·ω: wheel motor torque +K·ω, z clipped to 0.1 N m.
        assert_eq!(torque, Vector3::new(0.05, -0.01, 0.1));
        let zero = SafeModeConfig {
            wheels: SafeWheels::Zero,
            ..config.clone()
        };
        let none = safe_wheel_torque(&zero, Some(&rate), &Vector3::zeros(), 0.1, 628.0);
        assert_eq!(none, Vector3::zeros());
        let no_gyro = safe_wheel_torque(&config, None, &Vector3::zeros(), 0.1, 628.0);
        assert_eq!(no_gyro, Vector3::zeros(), "without a gyro: zero torque");
    }

    #[test]
    fn no_torque_drives_a_wheel_beyond_the_speed_fraction_further_out() {
        let config = SafeModeConfig::default(); // 0.75 of the limit
        let rate = Vector3::new(0.01, 0.01, -0.01);
        let max_speed = 628.0;
        let speeds = Vector3::new(0.8 * max_speed, -0.8 * max_speed, 0.8 * max_speed);
        let torque = safe_wheel_torque(&config, Some(&rate), &speeds, 0.1, max_speed);
        // x: +torque on a +speed wheel drives it out: refused; y: +torque slows a −speed
        // wheel: kept; z: −torque slows a +speed wheel: kept.
        assert_eq!(torque, Vector3::new(0.0, 0.05, -0.05));
    }

    #[test]
    fn out_of_range_settings_are_refused_by_name() {
        let bad = SafeModeConfig {
            wheel_speed_fraction: 1.2,
            ..SafeModeConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(
            e.contains("wheel_speed_fraction") && e.contains("1.2"),
            "{e}"
        );
        let nan = SafeModeConfig {
            rate_gain_nms: f64::NAN,
            ..SafeModeConfig::default()
        };
        assert!(
            nan.validate()
                .unwrap_err()
                .to_string()
                .contains("rate_gain")
        );
    }
}
