//! When a link's counters are published ([`CanLinkStatus`]).

use ipc_types::{CanLinkStatus, SampleHeader};

/// Run-clock time between two status samples when nothing changes, ns.
pub const STATUS_PERIOD_NS: u64 = 1_000_000_000;

/// Decides when a link's status is published: when a count other than the good-frame counts
/// (`frames_ok`, `frames_sent`) changed, and at least every [`STATUS_PERIOD_NS`] of run time.
/// Driven by run-clock times only, so a lockstep log holds the same status samples every time.
#[derive(Debug, Clone)]
pub struct StatusTracker {
    source: u32,
    sequence: u64,
    last: Option<(u64, CanLinkStatus)>,
}

impl StatusTracker {
    /// A tracker for the link `source` (`ipc_types::can_source`).
    pub fn new(source: u32) -> Self {
        Self {
            source,
            sequence: 0,
            last: None,
        }
    }

    /// The status sample to publish at `t_ns` for `counts` (header ignored), if one is due.
    pub fn due(&mut self, t_ns: u64, counts: CanLinkStatus) -> Option<CanLinkStatus> {
        let counts = CanLinkStatus {
            header: SampleHeader::default(),
            ..counts
        };
        let troubles = |s: &CanLinkStatus| CanLinkStatus {
            frames_ok: 0,
            frames_sent: 0,
            ..*s
        };
        let due = match self.last {
            None => true,
            Some((t, previous)) => {
                troubles(&previous) != troubles(&counts)
                    || t_ns >= t.saturating_add(STATUS_PERIOD_NS)
            }
        };
        if !due {
            return None;
        }
        self.last = Some((t_ns, counts));
        let header =
            SampleHeader::new(t_ns, self.sequence, SampleHeader::VALID).with_source(self.source);
        self.sequence += 1;
        Some(CanLinkStatus { header, ..counts })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_on_change_and_once_a_second() {
        let mut t = StatusTracker::new(2);
        let mut counts = CanLinkStatus::default();
        let first = t.due(0, counts).expect("first");
        assert_eq!((first.header.sequence, first.header.source_id), (0, 2));
        assert!(t.due(100_000_000, counts).is_none());
        counts.frames_ok = 10;
        assert!(t.due(150_000_000, counts).is_none());
        counts.lost_frames = 1;
        assert_eq!(
            t.due(200_000_000, counts).map(|s| s.header.time_ns),
            Some(200_000_000)
        );
        assert!(t.due(1_100_000_000, counts).is_none());
        assert_eq!(
            t.due(1_200_000_000, counts).map(|s| s.header.sequence),
            Some(2)
        );
    }
}
