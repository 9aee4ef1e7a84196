use super::{CanTransport, TransportError};
use crate::frame::{CanFrame, TimeSource, TimestampedFrame, host_time_ns};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError, channel};
use std::time::Duration;

/// One end of an in-process, loss-free point-to-point link (tests, simulated nodes).
///
/// Frames are stamped with the sender's host time ([`TimeSource::Host`]). When the other end
/// is dropped, `send` and (once drained) `recv` fail with [`TransportError::Closed`].
#[derive(Debug)]
pub struct MemoryTransport {
    tx: Sender<TimestampedFrame>,
    rx: Receiver<TimestampedFrame>,
}

impl MemoryTransport {
    /// Two connected ends: what one sends, the other receives.
    pub fn pair() -> (Self, Self) {
        let (tx_a, rx_b) = channel();
        let (tx_b, rx_a) = channel();
        (Self { tx: tx_a, rx: rx_a }, Self { tx: tx_b, rx: rx_b })
    }
}

impl CanTransport for MemoryTransport {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let stamped = TimestampedFrame {
            frame: *frame,
            time_ns: host_time_ns(),
            source: TimeSource::Host,
        };
        self.tx.send(stamped).map_err(|_| TransportError::Closed)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        if timeout.is_zero() {
            return match self.rx.try_recv() {
                Ok(f) => Ok(Some(f)),
                Err(TryRecvError::Empty) => Ok(None),
                Err(TryRecvError::Disconnected) => Err(TransportError::Closed),
            };
        }
        match self.rx.recv_timeout(timeout) {
            Ok(f) => Ok(Some(f)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(TransportError::Closed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_carries_frames_both_ways() {
        let (mut a, mut b) = MemoryTransport::pair();
        let f = CanFrame::standard(0x123, &[1, 2]).unwrap();
        a.send(&f).unwrap();
        assert_eq!(
            b.recv(Duration::from_millis(100)).unwrap().unwrap().frame,
            f
        );
        assert!(b.recv(Duration::ZERO).unwrap().is_none());
        b.send(&f).unwrap();
        assert_eq!(a.recv(Duration::ZERO).unwrap().unwrap().frame, f);
        drop(a);
        assert!(matches!(
            b.recv(Duration::from_millis(1)),
            Err(TransportError::Closed)
        ));
        assert!(matches!(b.send(&f), Err(TransportError::Closed)));
    }
}
