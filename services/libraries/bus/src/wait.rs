//! How an [`EventLoop`](crate::EventLoop) waits between wake-ups: sleep on the process's
//! doorbell (default), or sleep and poll the subscribers briefly where a sample is expected.
//!
//! Why polling helps: a publisher's ring reaches a sleeping process through `FUTEX_WAKE`, and
//! the scheduler then has to wake the process (on a virtual machine, often a halted virtual
//! CPU). That wake-up, not the shared-memory transfer,
//! is most of a hop's latency. A process that is already polling its subscribers when the
//! sample lands sees it within about a microsecond. Polling all the time burns a core, so the
//! strategies here poll only in short windows: right after a wake-up (bursts), or around the
//! time the next sample of a periodic source is due (learned from its arrivals). The
//! measurements behind the choice are in `bench/` (`latency`).

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use ipc_types::WaitStrategy;

use crate::BusError;

/// This process's name on the bus (its first [`Bus::open`](crate::Bus::open)), for the process
/// list of [`ENV_WAIT`](ipc_types::ENV_WAIT).
static PROCESS_NAME: OnceLock<String> = OnceLock::new();

pub(crate) fn set_process_name(name: &str) {
    let _ = PROCESS_NAME.set(name.to_owned());
}

impl From<ipc_types::WaitStrategyError> for BusError {
    fn from(e: ipc_types::WaitStrategyError) -> Self {
        BusError::Config {
            key: ipc_types::ENV_WAIT,
            value: e.value,
            reason: e.reason,
        }
    }
}

/// The [`WaitStrategy`] of this process from the environment: the process is the one named at
/// its [`Bus::open`](crate::Bus::open).
pub trait WaitFromEnv: Sized {
    /// The strategy [`ENV_WAIT`](ipc_types::ENV_WAIT) gives this process;
    /// [`WaitStrategy::Block`] when unset or empty, or when it names other processes only.
    fn from_env() -> Result<Self, BusError>;
    /// Like [`from_env`](Self::from_env), reading the variable through `lookup`.
    fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> Result<Self, BusError>;
}

impl WaitFromEnv for WaitStrategy {
    fn from_env() -> Result<Self, BusError> {
        Self::from_lookup(|key| std::env::var(key).ok())
    }

    fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> Result<Self, BusError> {
        Ok(Self::from_lookup_for(
            lookup,
            PROCESS_NAME.get().map(String::as_str),
        )?)
    }
}

/// How a loop's wake-ups came about (for benchmarks and diagnostics).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WaitStats {
    /// Data wake-ups delivered by a round of the loop (after a ring, or pending at its start).
    pub woken: u64,
    /// Data wake-ups delivered by polling (no scheduler wake-up on the way).
    pub polled: u64,
    /// Poll windows that ended without a sample.
    pub empty_windows: u64,
    /// Rings that woke the loop with nothing to call back: their samples were already taken
    /// (by polling or by an earlier callback), or the ring announced a new publisher.
    pub stale_notifications: u64,
}

/// Samples of one source seen closer together than this are one arrival (a burst); periods
/// shorter than this are not learned.
pub(crate) const BURST: Duration = Duration::from_micros(100);

/// Narrowest poll window on either side of an expected arrival.
pub(crate) const MIN_WINDOW: Duration = Duration::from_micros(10);

/// Arrival times of one data source, its learned period and how well arrivals are predicted.
///
/// The poll window around the next expected arrival is four times the mean absolute prediction
/// error on either side (at least [`MIN_WINDOW`], at most the strategy's `lead` and `late`):
/// arrivals seen by polling are timed to within a poll and shrink the error; an arrival the
/// loop slept through is timed only by the scheduler's wake-up and widens the window instead
/// (doubling the error), so the next window opens earlier.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Arrivals {
    last: Option<Instant>,
    period: Option<Duration>,
    outliers: u8,
    /// Mean absolute prediction error; `None` until the first prediction was checked.
    error: Option<Duration>,
}

impl Arrivals {
    /// Records a sample seen at `now`, `polled` if the loop was polling when it came (the time
    /// is exact) rather than woken by its notification. A sighting within [`BURST`] of the
    /// previous one is the same arrival (a burst); an interval far from the period counts as an
    /// outlier, and three in a row replace the period.
    pub(crate) fn note(&mut self, now: Instant, polled: bool, cap: Duration) {
        let Some(last) = self.last else {
            self.last = Some(now);
            return;
        };
        let dt = now.saturating_duration_since(last);
        if dt < BURST {
            return;
        }
        if let Some(p) = self.period.filter(|p| !p.is_zero()) {
            let error = self.error.unwrap_or(cap / 4);
            self.error = Some(if polled {
                // Distance to the nearest slot of the predicted schedule.
                let phase = dt.as_nanos() % p.as_nanos();
                let miss = Duration::from_nanos(phase.min(p.as_nanos() - phase) as u64);
                (error * 3 + miss) / 4
            } else {
                (error * 2 + Duration::from_micros(5)).min(cap)
            });
        }
        match self.period {
            None => self.period = Some(dt),
            Some(p) if dt >= p / 2 && dt <= p + p / 2 => {
                // First-order filter with gain 1/8: follows drift, shrugs off jitter.
                let p_ns = p.as_nanos() as i128;
                let next = p_ns + (dt.as_nanos() as i128 - p_ns) / 8;
                self.period = Some(Duration::from_nanos(next.max(1) as u64));
                self.outliers = 0;
            }
            Some(_) => {
                self.outliers += 1;
                if self.outliers >= 3 {
                    self.period = Some(dt);
                    self.outliers = 0;
                }
            }
        }
        self.last = Some(now);
    }

    /// The poll window `(open, close)` around the next expected sample: the first slot of the
    /// period after the last arrival whose window has not closed at `now`. `None` while no
    /// period is known.
    pub(crate) fn window(
        &self,
        now: Instant,
        lead: Duration,
        late: Duration,
    ) -> Option<(Instant, Instant)> {
        let (last, period) = (self.last?, self.period?);
        if period.is_zero() {
            return None;
        }
        let spread = self.error.map_or(lead.max(late), |e| e * 4);
        let before = spread.clamp(MIN_WINDOW.min(lead), lead);
        let after = spread.clamp(MIN_WINDOW.min(late), late);
        let mut due = last + period;
        if due + after < now {
            let behind = now.saturating_duration_since(due + after).as_nanos();
            let skip = behind / period.as_nanos() + 1;
            due += period * u32::try_from(skip).ok()?;
        }
        Some((due.checked_sub(before).unwrap_or(due), due + after))
    }

    #[cfg(test)]
    pub(crate) fn period(&self) -> Option<Duration> {
        self.period
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn learns_a_period_and_predicts_the_next_arrival() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let us = Duration::from_micros;
        let (lead, late) = (us(200), us(300));
        let mut a = Arrivals::default();
        assert_eq!(a.window(t0, lead, late), None);
        for k in 0..20u32 {
            // 100 ms with 20 µs of jitter, seen by polling.
            let jitter = if k % 2 == 0 { us(20) } else { Duration::ZERO };
            a.note(t0 + ms(100) * k + jitter, true, lead);
        }
        let p = a.period().unwrap();
        assert!(p > ms(99) && p < ms(101), "{p:?}");
        let last = t0 + ms(1900);
        let (open, close) = a.window(last, lead, late).unwrap();
        // A window around the next slot, narrowed to the observed jitter.
        assert!(
            open > last + ms(99) && close < last + ms(101),
            "{:?} {:?}",
            open - last,
            close - last
        );
        assert!(close - open < us(200), "{:?}", close - open);
        // An arrival slept through widens the window.
        a.note(last + ms(100) + us(40), false, lead);
        let (open2, close2) = a.window(last + ms(100) + us(40), lead, late).unwrap();
        assert!(close2 - open2 > close - open);
        // A burst is one arrival.
        let p = a.period();
        a.note(last + ms(100) + us(50), true, lead);
        assert_eq!(a.period(), p);
        // Missed samples: the window moves on to the next slot.
        let much_later = last + ms(450);
        let (open, close) = a.window(much_later, lead, late).unwrap();
        assert!(
            close >= much_later && open < much_later + ms(100),
            "{:?}",
            open - much_later
        );
        // A new rate replaces the old one after three outliers.
        let mut t = last + ms(120);
        for _ in 0..4 {
            t += ms(10);
            a.note(t, true, lead);
        }
        let p = a.period().unwrap();
        assert!(p >= ms(9) && p <= ms(11), "{p:?}");
    }
}
