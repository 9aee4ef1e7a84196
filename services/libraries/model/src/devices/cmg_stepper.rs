//! The CMG gimbal stepper drives: what gimbal rate a rate command actually produces.

use crate::config::{CmgConfig, DEG};
use nalgebra::Vector4;

/// What the drives do over one command period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepperOutput {
    /// Realised gimbal rate over the period, rad/s: a whole number of steps per period.
    pub rate_rad_s: Vector4<f64>,
    /// Steps taken over the period (signed).
    pub steps: [i64; 4],
    /// Per gimbal: the command exceeded the rate limit and was clipped.
    pub saturated: [bool; 4],
    /// Per gimbal: the command was not a number and was treated as zero.
    pub rejected: [bool; 4],
}

/// Stepper drives of the four gimbals.
///
/// Each command period a gimbal can only advance by whole steps. The drive clamps the command to
/// the rate limit, adds the angle owed from earlier periods (the remainder), takes the nearest
/// whole number of steps (at most the limit's worth) and carries the rest, so the realised gimbal
/// angle stays within half a step of the integrated (clamped) command. Angle lost to the limit is
/// not carried: a saturated gimbal cannot catch up later without overshooting the command.
#[derive(Debug, Clone)]
pub struct CmgStepperDrive {
    period_s: f64,
    step_rad: f64,
    max_rate_rad_s: f64,
    /// Commanded minus realised angle, rad, per gimbal; |remainder| ≤ ½ step.
    remainder_rad: Vector4<f64>,
}

impl CmgStepperDrive {
    /// The drives of `config`. Commands arrive once per telemetry period (the control loop
    /// rate), `1 / telemetry_rate_hz`; a step of 0 means an ideal (continuous) drive.
    pub fn new(config: &CmgConfig) -> Self {
        Self {
            period_s: 1.0 / config.telemetry_rate_hz,
            step_rad: config.stepper_step_deg * DEG,
            max_rate_rad_s: config.max_gimbal_rate_rad_s(),
            remainder_rad: Vector4::zeros(),
        }
    }

    /// Command period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// One step at the gimbal, rad.
    pub fn step_rad(&self) -> f64 {
        self.step_rad
    }

    /// Angle commanded but not yet stepped, rad, per gimbal.
    pub fn remainder_rad(&self) -> Vector4<f64> {
        self.remainder_rad
    }

    /// Forget the carried remainders (drives re-initialised).
    pub fn reset(&mut self) {
        self.remainder_rad = Vector4::zeros();
    }

    /// Apply gimbal rate command `rate_cmd_rad_s` (rad/s) for one command period.
    pub fn command(&mut self, rate_cmd_rad_s: &Vector4<f64>) -> StepperOutput {
        let mut out = StepperOutput {
            rate_rad_s: Vector4::zeros(),
            steps: [0; 4],
            saturated: [false; 4],
            rejected: [false; 4],
        };
        let max_angle = self.max_rate_rad_s * self.period_s;
        for i in 0..4 {
            let mut cmd = rate_cmd_rad_s[i];
            if !cmd.is_finite() {
                // A NaN would poison the remainder for good; ±inf has no meaningful sign of
                // intent from a broken controller either.
                out.rejected[i] = true;
                cmd = 0.0;
            }
            if cmd.abs() > self.max_rate_rad_s {
                out.saturated[i] = true;
                cmd = self.max_rate_rad_s.copysign(cmd);
            }
            if self.step_rad <= 0.0 {
                out.rate_rad_s[i] = cmd;
                continue;
            }
            let owed = cmd * self.period_s + self.remainder_rad[i];
            // The remainder may round the step count past the limit's worth; the 1e-9 keeps an
            // exact multiple (90 °/s · 0.1 s = 1250 steps of 0.0072°) from losing a step to
            // rounding.
            let max_steps = (max_angle / self.step_rad * (1.0 + 1e-9)).floor();
            let steps = (owed / self.step_rad).round().clamp(-max_steps, max_steps);
            let taken = steps * self.step_rad;
            self.remainder_rad[i] = (owed - taken).clamp(-0.5 * self.step_rad, 0.5 * self.step_rad);
            out.steps[i] = steps as i64;
            out.rate_rad_s[i] = taken / self.period_s;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_command_is_realised_in_whole_steps_tracking_the_integral() {
        let config = CmgConfig::default();
        let mut drive = CmgStepperDrive::new(&config);
        let step = drive.step_rad();
        let dt = drive.period_s();
        // 0.05 °/s over 0.1 s is 0.69 steps: most periods take 1 step, some 0.
        let cmd = Vector4::new(0.05, -0.05, 1.234, 0.0) * DEG;
        let mut angle = Vector4::<f64>::zeros();
        for k in 1..=1000 {
            let out = drive.command(&cmd);
            for i in 0..4 {
                let steps_exact = out.rate_rad_s[i] * dt / step;
                assert!((steps_exact - out.steps[i] as f64).abs() < 1e-9);
            }
            assert_eq!(out.saturated, [false; 4]);
            angle += out.rate_rad_s * dt;
            let commanded = cmd * (k as f64 * dt);
            for i in 0..4 {
                assert!(
                    (angle[i] - commanded[i]).abs() <= 0.5 * step * (1.0 + 1e-9),
                    "period {k} gimbal {i}"
                );
            }
        }
        assert!(angle[3] == 0.0);
    }

    #[test]
    fn command_beyond_limit_is_clipped_without_windup() {
        let config = CmgConfig::default();
        let mut drive = CmgStepperDrive::new(&config);
        let limit = config.max_gimbal_rate_rad_s();
        let over = Vector4::new(200.0, -200.0, 90.0, f64::NAN) * DEG;
        for _ in 0..10 {
            let out = drive.command(&over);
            assert_eq!(out.saturated, [true, true, false, false]);
            assert_eq!(out.rejected, [false, false, false, true]);
            assert!((out.rate_rad_s[0] - limit).abs() < 1e-12);
            assert!((out.rate_rad_s[1] + limit).abs() < 1e-12);
            assert!((out.rate_rad_s[2] - limit).abs() < 1e-12);
            assert_eq!(out.steps[0], 1250);
            assert_eq!(out.rate_rad_s[3], 0.0);
        }
        // After saturation the gimbal does not keep stepping to make up the clipped angle.
        let out = drive.command(&Vector4::zeros());
        assert_eq!(out.steps, [0; 4]);
    }

    #[test]
    fn ideal_drive_passes_the_clamped_command() {
        let config = CmgConfig {
            stepper_step_deg: 0.0,
            ..CmgConfig::default()
        };
        let mut drive = CmgStepperDrive::new(&config);
        let out = drive.command(&Vector4::new(0.0123, -0.5, 3.0, 0.0));
        assert_eq!(out.rate_rad_s[0], 0.0123);
        assert_eq!(out.rate_rad_s[1], -0.5);
        assert!((out.rate_rad_s[2] - config.max_gimbal_rate_rad_s()).abs() < 1e-15);
        assert_eq!(out.saturated, [false, false, true, false]);
    }
}
