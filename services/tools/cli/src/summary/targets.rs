//! The target attitude in force over a run: the configured one, until the controller applies a
//! ground `target` command. Settling and steady error are measured against it, so a run whose
//! target the ground moved is judged against where it was asked to point.

use ipc_types::{GroundAckStatus, GroundCommand, GroundCommandAck, GroundCommandKind};
use serde::Serialize;
use std::collections::HashMap;
use testbed_flight::convert::seconds;
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::DEG;

/// A target the controller applied from a ground command.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetChange {
    /// Run time the controller applied it (its acknowledgement's time), s.
    pub t_s: f64,
    /// The commanded heading, pitch and roll, degrees.
    pub heading_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
}

/// The targets in force over a run, in time order.
#[derive(Debug, Clone)]
pub struct TargetsInForce {
    configured: Attitude,
    /// `(time, ns; target from then on)`, sorted by time.
    changes: Vec<(u64, Attitude, TargetChange)>,
}

impl TargetsInForce {
    /// The configured target, changed by every `target` command the controller acknowledged as
    /// applied. A command is matched to its acknowledgement by `(client_id, command_id)`; an
    /// acknowledgement whose command is not in the log (a log cut before it) is skipped.
    pub fn new(
        configured: Attitude,
        commands: &[GroundCommand],
        acks: &[GroundCommandAck],
    ) -> Self {
        let asked: HashMap<(u32, u64), &GroundCommand> = commands
            .iter()
            .filter(|c| c.kind() == Some(GroundCommandKind::Target))
            .map(|c| ((c.client_id, c.command_id), c))
            .collect();
        let mut changes: Vec<_> = acks
            .iter()
            .filter(|a| {
                a.decided_by == GroundCommandAck::BY_CONTROLLER
                    && a.status() == Some(GroundAckStatus::Applied)
                    && GroundCommandKind::from_u32(a.kind) == Some(GroundCommandKind::Target)
            })
            .filter_map(|a| {
                let c = asked.get(&(a.client_id, a.command_id))?;
                let target = attitude::from_heading_pitch_roll(
                    c.target_heading_rad,
                    c.target_pitch_rad,
                    c.target_roll_rad,
                );
                let change = TargetChange {
                    t_s: seconds(a.header.time_ns),
                    heading_deg: c.target_heading_rad / DEG,
                    pitch_deg: c.target_pitch_rad / DEG,
                    roll_deg: c.target_roll_rad / DEG,
                };
                Some((a.header.time_ns, target, change))
            })
            .collect();
        changes.sort_by_key(|(t, ..)| *t);
        Self {
            configured,
            changes,
        }
    }

    /// The target in force at run time `t_ns`: the latest change at or before it.
    pub fn at(&self, t_ns: u64) -> &Attitude {
        let applied = self.changes.partition_point(|(t, ..)| *t <= t_ns);
        applied
            .checked_sub(1)
            .map_or(&self.configured, |i| &self.changes[i].1)
    }

    /// The changes, in time order.
    pub fn changes(&self) -> Vec<TargetChange> {
        self.changes.iter().map(|(.., c)| c.clone()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::SampleHeader;

    fn command(client_id: u32, command_id: u64, heading_deg: f64) -> GroundCommand {
        GroundCommand {
            kind: GroundCommandKind::Target as u32,
            target_heading_rad: heading_deg * DEG,
            command_id,
            client_id,
            ..GroundCommand::default()
        }
    }

    fn ack(
        t_ns: u64,
        client_id: u32,
        command_id: u64,
        status: GroundAckStatus,
    ) -> GroundCommandAck {
        GroundCommandAck::new(
            SampleHeader {
                time_ns: t_ns,
                ..SampleHeader::default()
            },
            command_id,
            GroundCommandKind::Target as u32,
            status,
            client_id,
            GroundCommandAck::BY_CONTROLLER,
            "target set",
        )
    }

    fn is_heading(q: &Attitude, heading_deg: f64) -> bool {
        let expected = attitude::from_heading_pitch_roll(heading_deg * DEG, 0.0, 0.0);
        attitude::attitude_error(q, &expected).norm() < 1e-9
    }

    #[test]
    fn the_configured_target_holds_until_an_applied_command_moves_it() {
        let configured = attitude::from_heading_pitch_roll(0.0, 0.0, 0.0);
        let commands = [
            command(1, 7, 30.0),
            command(1, 8, 60.0),
            command(2, 7, 90.0),
        ];
        let acks = [
            // Applied out of log order: sorted by time.
            ack(20_000_000_000, 2, 7, GroundAckStatus::Applied),
            ack(10_000_000_000, 1, 7, GroundAckStatus::Applied),
            // Rejected: no change.
            ack(15_000_000_000, 1, 8, GroundAckStatus::Rejected),
            // No such command in the log: skipped.
            ack(12_000_000_000, 3, 1, GroundAckStatus::Applied),
        ];
        let targets = TargetsInForce::new(configured, &commands, &acks);
        assert!(is_heading(targets.at(0), 0.0));
        assert!(is_heading(targets.at(9_999_999_999), 0.0));
        assert!(is_heading(targets.at(10_000_000_000), 30.0));
        assert!(is_heading(targets.at(19_000_000_000), 30.0));
        assert!(is_heading(targets.at(25_000_000_000), 90.0));
        let changes = targets.changes();
        assert_eq!(changes.len(), 2);
        assert_eq!((changes[0].t_s, changes[1].t_s), (10.0, 20.0));
        assert!((changes[1].heading_deg - 90.0).abs() < 1e-12);
    }

    #[test]
    fn a_link_rejection_is_not_a_change() {
        let mut by_link = ack(5_000_000_000, 1, 7, GroundAckStatus::Applied);
        by_link.decided_by = GroundCommandAck::BY_LINK;
        let targets = TargetsInForce::new(Attitude::identity(), &[command(1, 7, 45.0)], &[by_link]);
        assert!(targets.changes().is_empty());
        assert!(is_heading(targets.at(u64::MAX), 0.0));
    }
}
