//! The controller process's logic: one command per tick from the estimate and the actuators'
//! telemetry of that tick.

use crate::convert::{Sequence, a3, a4, quaternion_from_array, seconds, v3, v4};
use crate::schedule::Schedule;
use crate::tasks::{ActuatorTelemetry, Actuators, ControllerTask};
use ipc_types::{
    AttitudeEstimate, CmgCommand, CmgTelemetry, ControllerMode, ControllerStatus, SampleHeader,
    WheelCommand, WheelTelemetry,
};
use std::collections::BTreeMap;
use testbed_model::physics::ActuatorCommand;

#[derive(Debug, Default, Clone, Copy)]
struct Pending {
    estimate: Option<AttitudeEstimate>,
    wheels: Option<WheelTelemetry>,
    cmg: Option<CmgTelemetry>,
}

/// One tick's outputs, published status first, then the commands.
#[derive(Debug, Clone, Copy)]
pub struct ControlCycle {
    pub status: ControllerStatus,
    pub wheels: WheelCommand,
    pub cmg: CmgCommand,
}

pub struct ControllerNode {
    task: ControllerTask,
    actuators: Actuators,
    schedule: Schedule,
    pending: BTreeMap<u64, Pending>,
    last_cycle_ns: Option<u64>,
    deadline_misses: u64,
    errors: u64,
    status_seq: Sequence,
    wheel_seq: Sequence,
    cmg_seq: Sequence,
}

impl ControllerNode {
    pub fn new(task: ControllerTask, actuators: Actuators, schedule: Schedule) -> Self {
        Self {
            task,
            actuators,
            schedule,
            pending: BTreeMap::new(),
            last_cycle_ns: None,
            deadline_misses: 0,
            errors: 0,
            status_seq: Sequence::default(),
            wheel_seq: Sequence::default(),
            cmg_seq: Sequence::default(),
        }
    }

    /// A cycle that should have run did not (reported by the process's deadline).
    pub fn count_deadline_miss(&mut self) {
        self.deadline_misses += 1;
    }

    pub fn deadline_misses(&self) -> u64 {
        self.deadline_misses
    }

    pub fn errors(&self) -> u64 {
        self.errors
    }

    fn slot(&mut self, t_ns: u64) -> Option<&mut Pending> {
        let fresh = self.last_cycle_ns.is_none_or(|last| t_ns > last);
        (fresh && self.schedule.tick_at(t_ns).is_some())
            .then(|| self.pending.entry(t_ns).or_default())
    }

    pub fn on_estimate(&mut self, e: &AttitudeEstimate) {
        if let Some(p) = self.slot(e.header.time_ns) {
            p.estimate = Some(*e);
        }
    }

    pub fn on_wheel_telemetry(&mut self, t: &WheelTelemetry) {
        if let Some(p) = self.slot(t.header.time_ns) {
            p.wheels = Some(*t);
        }
    }

    pub fn on_cmg_telemetry(&mut self, t: &CmgTelemetry) {
        if let Some(p) = self.slot(t.header.time_ns) {
            p.cmg = Some(*t);
        }
    }

    /// Cycles for every tick whose estimate and telemetry are all in, oldest first. A tick
    /// overtaken by a later estimate runs with what it has (missing telemetry reads as zero).
    pub fn ready(&mut self) -> Vec<ControlCycle> {
        let newest_estimate = self
            .pending
            .iter()
            .rev()
            .find(|(_, p)| p.estimate.is_some())
            .map(|(t, _)| *t);
        let mut out = Vec::new();
        while let Some((&t_ns, p)) = self.pending.first_key_value() {
            let complete = p.estimate.is_some() && p.wheels.is_some() && p.cmg.is_some();
            let overtaken = newest_estimate.is_some_and(|n| n > t_ns);
            if !(complete || overtaken) {
                break;
            }
            let p = *p;
            self.pending.remove(&t_ns);
            if p.estimate.is_some() {
                out.push(self.cycle(t_ns, &p));
            }
        }
        out
    }

    fn cycle(&mut self, t_ns: u64, p: &Pending) -> ControlCycle {
        let period = self.last_cycle_ns.map_or(0, |last| t_ns - last);
        self.last_cycle_ns = Some(t_ns);
        let telemetry = ActuatorTelemetry {
            wheel_speed_rad_s: v3(&p.wheels.map_or([0.0; 3], |w| w.speed)),
            gimbal_rad: v4(&p.cmg.map_or([0.0; 4], |c| c.gimbal_angle)),
        };
        let estimate = p.estimate.filter(|e| e.header.is_valid());
        let attitude =
            estimate.and_then(|e| quaternion_from_array(&e.quaternion).map(|q| (q, v3(&e.rate))));
        let (command, error, mode, saturated) = match attitude {
            Some((q, rate)) => match self.task.command(seconds(t_ns), &q, &rate, &telemetry) {
                Ok(o) => {
                    let mode = match self.actuators {
                        Actuators::Wheels => ControllerMode::WheelPointing,
                        Actuators::Cmg => ControllerMode::CmgSlew,
                    };
                    (o.command, o.error_rad, mode, o.saturated)
                }
                Err(e) => {
                    tracing::warn!(
                        "control law refused its inputs at t = {} s: {e}",
                        seconds(t_ns)
                    );
                    self.errors += 1;
                    (
                        ActuatorCommand::default(),
                        Default::default(),
                        ControllerMode::Fault,
                        false,
                    )
                }
            },
            None => (
                ActuatorCommand::default(),
                Default::default(),
                ControllerMode::Idle,
                false,
            ),
        };
        let mut status = ControllerStatus {
            header: self.status_seq.header(
                t_ns,
                SampleHeader::VALID
                    | if saturated {
                        SampleHeader::SATURATED_ANY
                    } else {
                        0
                    },
            ),
            attitude_error: a3(&error),
            // The platform feels the opposite of the wheels' motor torque.
            torque_command: a3(&(-command.wheel_torque_nm)),
            deadline_misses: self.deadline_misses,
            loop_period_ns: period,
            ..ControllerStatus::default()
        };
        status.set_mode(mode);
        ControlCycle {
            status,
            wheels: WheelCommand {
                header: self.wheel_seq.header(t_ns, SampleHeader::VALID),
                torque: a3(&command.wheel_torque_nm),
            },
            cmg: CmgCommand {
                header: self.cmg_seq.header(t_ns, SampleHeader::VALID),
                gimbal_rate: a4(&command.gimbal_rate_rad_s),
            },
        }
    }
}
