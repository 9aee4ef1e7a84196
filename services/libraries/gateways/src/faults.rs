//! Seeded bus-fault injection of the simulated CAN board.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use testbed_config::CanFaults;

/// What happens to one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Delivered as sent.
    None,
    /// Lost on the bus: never delivered.
    Drop,
    /// Delivered with bit `bit` of its 16 checked bytes flipped: every receiver's frame check
    /// fails and drops it.
    Corrupt {
        /// Bit index, 0 to 127.
        bit: u32,
    },
    /// Delivered after the tick's deadline (after the board's tick sync frame).
    Delay,
    /// Delivered twice in a row.
    Duplicate,
}

/// Draws a [`Fault`] per frame with the configured probabilities from a seeded generator, so
/// a run's faults are the same every time.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    rates: CanFaults,
    rng: ChaCha8Rng,
}

/// Stream of the fault generator, so it never shares a sequence with the device models that
/// are seeded by the same `run.seed`.
const FAULT_STREAM: u64 = 0xC4A7_F417_5EED_0001;

impl FaultInjector {
    /// An injector with `rates` (validated by the run configuration) seeded by `seed`.
    pub fn new(rates: CanFaults, seed: u64) -> Self {
        Self {
            rates,
            rng: ChaCha8Rng::seed_from_u64(seed ^ FAULT_STREAM),
        }
    }

    /// Whether any fault has a non-zero probability.
    pub fn active(&self) -> bool {
        self.rates.drop + self.rates.corrupt + self.rates.delay + self.rates.duplicate > 0.0
    }

    /// The fate of the next frame (no random number is drawn when no fault is configured).
    pub fn draw(&mut self) -> Fault {
        if !self.active() {
            return Fault::None;
        }
        let u: f64 = self.rng.random();
        let r = &self.rates;
        if u < r.drop {
            Fault::Drop
        } else if u < r.drop + r.corrupt {
            Fault::Corrupt {
                bit: self.rng.random_range(0..128),
            }
        } else if u < r.drop + r.corrupt + r.delay {
            Fault::Delay
        } else if u < r.drop + r.corrupt + r.delay + r.duplicate {
            Fault::Duplicate
        } else {
            Fault::None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_are_honoured_and_the_sequence_is_seeded() {
        let rates = CanFaults {
            drop: 0.02,
            corrupt: 0.01,
            delay: 0.005,
            duplicate: 0.005,
        };
        let draw = |seed| {
            let mut f = FaultInjector::new(rates, seed);
            (0..200_000).map(|_| f.draw()).collect::<Vec<_>>()
        };
        let a = draw(3);
        assert_eq!(a, draw(3));
        assert_ne!(a, draw(4));
        let count =
            |pred: fn(&Fault) -> bool| a.iter().filter(|f| pred(f)).count() as f64 / a.len() as f64;
        assert!((count(|f| *f == Fault::Drop) - 0.02).abs() < 0.002);
        assert!((count(|f| matches!(f, Fault::Corrupt { .. })) - 0.01).abs() < 0.0015);
        assert!((count(|f| *f == Fault::Delay) - 0.005).abs() < 0.001);
        assert!((count(|f| *f == Fault::Duplicate) - 0.005).abs() < 0.001);
        let mut none = FaultInjector::new(CanFaults::default(), 1);
        assert!(!none.active() && (0..100).all(|_| none.draw() == Fault::None));
    }
}
