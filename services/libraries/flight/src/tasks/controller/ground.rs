//! Commands from the ground station: safe mode held or released, a mode in place of the
//! configured law, a new target.

use super::ControllerTask;
use ipc_types::{ControllerMode, GroundCommand, GroundCommandKind};

impl ControllerTask {
    /// A ground command: `true` enters and holds safe mode, `false` releases it.
    pub fn ground_safe_mode(&mut self, safe: bool) {
        self.safe.ground_command(safe);
    }

    /// Applies a command from the ground (validated by the ground link; checked again here):
    /// what was applied, or why it was refused. Mode: idle (zero commands), rate damping (the
    /// wheels damp the estimated body rate, as safe mode does on the gyro), the configured
    /// pointing law (CMG slew if the law named by `controller.law` drives the CMGs, else wheel
    /// pointing), or
    /// safe (held until another mode is commanded). Target: the attitude the pointing law
    /// holds from the next cycle on. Experiments: refused, no runner exists on the platform.
    pub fn ground_command(&mut self, command: &GroundCommand) -> Result<String, String> {
        match command.kind() {
            Some(GroundCommandKind::Mode) => {
                let mode = ControllerMode::from_u32(command.mode)
                    .ok_or_else(|| format!("unknown mode {}", command.mode))?;
                let law = if self.drives.cmgs {
                    ControllerMode::CmgSlew
                } else {
                    ControllerMode::WheelPointing
                };
                match mode {
                    ControllerMode::Safe => {
                        self.ground_safe_mode(true);
                        return Ok("safe mode held by the ground".into());
                    }
                    ControllerMode::Idle | ControllerMode::RateDamping => {
                        self.ground_mode = Some(mode)
                    }
                    m if m == law => self.ground_mode = None,
                    ControllerMode::WheelPointing | ControllerMode::CmgSlew => {
                        return Err(format!(
                            "{mode:?} needs a controller.law that drives the {}",
                            if mode == ControllerMode::CmgSlew {
                                "CMGs (e.g. \"cmg_slew\")"
                            } else {
                                "wheels (e.g. \"pd_friction\")"
                            }
                        ));
                    }
                    ControllerMode::Fault => return Err("Fault is not a mode to command".into()),
                    ControllerMode::MomentumDump | ControllerMode::ThrusterRateDamping => {
                        return Err(format!(
                            "{mode:?} is chosen by the thruster law (controller.thrusters), not commanded"
                        ));
                    }
                }
                self.ground_safe_mode(false);
                Ok(format!("mode {mode:?}"))
            }
            Some(GroundCommandKind::Target) => {
                let angles = [
                    command.target_heading_rad,
                    command.target_pitch_rad,
                    command.target_roll_rad,
                ];
                if !angles.iter().all(|a| a.is_finite()) {
                    return Err("target angles must be finite".into());
                }
                let half_pi = std::f64::consts::FRAC_PI_2;
                if angles[1].abs() >= half_pi || angles[2].abs() >= half_pi {
                    return Err("target tilt must be below 90°".into());
                }
                self.law
                    .set_target(testbed_model::attitude::from_heading_pitch_roll(
                        angles[0], angles[1], angles[2],
                    ));
                Ok("target set".into())
            }
            Some(GroundCommandKind::ExperimentStart | GroundCommandKind::ExperimentAbort) => {
                Err("no identification experiment runner on the platform yet".into())
            }
            _ => Err(format!("unknown command kind {}", command.kind)),
        }
    }

    /// The mode the ground holds the controller in instead of its configured law, if any.
    pub fn ground_mode(&self) -> Option<ControllerMode> {
        self.ground_mode
    }
}
