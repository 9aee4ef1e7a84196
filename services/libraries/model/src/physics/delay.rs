//! Actuator delay (`effects.actuator_delay`): a command issued at `t` acts from `t + delay_s`
//! until the next command takes over (zero-order hold shifted by the delay).

use super::state::ActuatorCommand;
use std::collections::VecDeque;

/// Times closer than this are the same instant: the plant's clock is a sum of step lengths and
/// must not create sliver steps out of rounding.
pub const TIME_TOLERANCE_S: f64 = 1e-9;

/// FIFO of timestamped commands between the flight computer and the actuators.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandDelay {
    delay_s: f64,
    /// (issue time s, command), oldest first, issue times non-decreasing.
    queue: VecDeque<(f64, ActuatorCommand)>,
}

impl CommandDelay {
    /// `delay_s` ≥ 0, s (0: commands act when issued).
    pub fn new(delay_s: f64) -> Self {
        Self {
            delay_s,
            queue: VecDeque::new(),
        }
    }

    pub fn delay_s(&self) -> f64 {
        self.delay_s
    }

    /// Record `command` issued at `issued_s` (s, plant time). A command issued earlier than the
    /// newest one replaces the newer ones: the plant's clock never runs backwards, so that can
    /// only be a re-issue at the same instant.
    pub fn push(&mut self, issued_s: f64, command: ActuatorCommand) {
        while self
            .queue
            .back()
            .is_some_and(|(t, _)| *t >= issued_s - TIME_TOLERANCE_S)
        {
            self.queue.pop_back();
        }
        self.queue.push_back((issued_s, command));
    }

    /// The command acting at `t_s`: the newest issued at or before `t_s − delay_s`. Before the
    /// first command arrives the actuators rest (motors off, gimbals held).
    pub fn in_effect(&self, t_s: f64) -> ActuatorCommand {
        self.queue
            .iter()
            .rev()
            .find(|(issued, _)| issued + self.delay_s <= t_s + TIME_TOLERANCE_S)
            .map_or_else(ActuatorCommand::default, |(_, c)| c.clone())
    }

    /// First instant after `t_s` at which the acting command changes, if any is queued.
    pub fn next_change_after(&self, t_s: f64) -> Option<f64> {
        self.queue
            .iter()
            .map(|(issued, _)| issued + self.delay_s)
            .find(|t| *t > t_s + TIME_TOLERANCE_S)
    }

    /// Forget commands that can no longer act at or after `t_s`.
    pub fn discard_before(&mut self, t_s: f64) {
        while self
            .queue
            .get(1)
            .is_some_and(|(issued, _)| issued + self.delay_s <= t_s + TIME_TOLERANCE_S)
        {
            self.queue.pop_front();
        }
    }

    /// Number of queued commands (bounded by delay / command period + 1).
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn torque(x: f64) -> ActuatorCommand {
        ActuatorCommand {
            wheel_torque_nm: Vector3::new(x, 0.0, 0.0),
            ..Default::default()
        }
    }

    #[test]
    fn commands_act_delay_after_issue_and_hold() {
        let mut d = CommandDelay::new(0.35);
        for k in 0..5 {
            d.push(k as f64 * 0.1, torque(k as f64 + 1.0));
        }
        assert_eq!(d.in_effect(0.3), ActuatorCommand::default());
        assert_eq!(d.in_effect(0.35), torque(1.0));
        assert_eq!(d.in_effect(0.449), torque(1.0));
        assert_eq!(d.in_effect(0.45), torque(2.0));
        assert_eq!(d.in_effect(10.0), torque(5.0));
        assert!((d.next_change_after(0.0).unwrap_or(f64::NAN) - 0.35).abs() < 1e-12);
        assert!((d.next_change_after(0.35).unwrap_or(f64::NAN) - 0.45).abs() < 1e-12);
        assert_eq!(d.next_change_after(0.75), None);
        d.discard_before(0.5);
        assert_eq!(d.len(), 4);
        assert_eq!(d.in_effect(0.5), torque(2.0));
    }

    #[test]
    fn zero_delay_acts_at_once_and_keeps_one_command() {
        let mut d = CommandDelay::new(0.0);
        d.push(1.0, torque(3.0));
        assert_eq!(d.in_effect(1.0), torque(3.0));
        d.push(1.1, torque(4.0));
        d.discard_before(1.1);
        assert_eq!(d.len(), 1);
        assert_eq!(d.in_effect(1.1), torque(4.0));
    }
}
