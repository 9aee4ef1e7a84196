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

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use crate::BusError;

/// Environment variable selecting the [`WaitStrategy`] of every [`EventLoop`](crate::EventLoop)
/// a process creates: `block` (default), `spin:<µs>`, `anticipate` or
/// `anticipate:<lead µs>,<late µs>`, optionally followed by `@` and the bus names of the
/// processes it applies to (`anticipate@estimator,controller`); the others then block. One
/// variable for a whole run (the launcher passes its environment to every process) can so
/// choose the strategy of a few.
pub const ENV_WAIT: &str = "TESTBED_BUS_WAIT";

/// This process's name on the bus (its first [`Bus::open`](crate::Bus::open)), for the process
/// list of [`ENV_WAIT`].
static PROCESS_NAME: OnceLock<String> = OnceLock::new();

pub(crate) fn set_process_name(name: &str) {
    let _ = PROCESS_NAME.set(name.to_owned());
}

/// How an [`EventLoop`](crate::EventLoop) waits for its next wake-up.
///
/// Every strategy delivers the same wake-ups in the same order for the same arrivals; they
/// differ only in how soon a data wake-up follows a sample's arrival and in CPU time. While
/// polling, the loop yields the CPU between polls (`sched_yield`), so a poll window never
/// starves another runnable process, and a window closes early when an interval, a deadline
/// or the heartbeat is due.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum WaitStrategy {
    /// Sleep on the doorbell (a futex) until it rings or a timer is due. Costs no CPU between
    /// wake-ups; every sample that finds the process asleep pays a scheduler wake-up.
    #[default]
    Block,
    /// Sleep, and after every handled data wake-up poll the subscribers for up to `spin`
    /// before sleeping again: a sample following within `spin` (a burst, the next stage of a
    /// fast exchange) is seen without a wake-up. Costs up to `spin` of CPU per wake-up.
    SpinAfterWake {
        /// How long to poll after a data wake-up.
        spin: Duration,
    },
    /// Learn each data source's arrival period; sleep until shortly before the next sample of
    /// a source is due, then poll until a sample arrives or the window closes, then sleep
    /// again. The window adapts to how well arrivals are predicted (four times the mean
    /// prediction error on either side, at least 10 µs), capped at `lead` before and `late`
    /// after the expected time. Costs about the window's width of CPU per expected sample; a
    /// source without a regular period (fewer than two arrivals, or irregular ones) is waited
    /// for by sleeping only.
    Anticipate {
        /// The earliest polling starts before the expected arrival.
        lead: Duration,
        /// The latest polling gives up after the expected arrival.
        late: Duration,
    },
}

impl WaitStrategy {
    /// [`WaitStrategy::Anticipate`] with windows of at most 200 µs before and 300 µs after.
    pub const ANTICIPATE: Self = Self::Anticipate {
        lead: Duration::from_micros(200),
        late: Duration::from_micros(300),
    };

    /// The strategy [`ENV_WAIT`] gives this process; [`WaitStrategy::Block`] when unset or
    /// empty, or when it names other processes only.
    pub fn from_env() -> Result<Self, BusError> {
        Self::from_lookup(|key| std::env::var(key).ok())
    }

    /// Whether [`ENV_WAIT`] is set (and not empty): it then chooses every loop's strategy,
    /// over any default a process has for its mode.
    pub fn set_in_env() -> bool {
        std::env::var_os(ENV_WAIT).is_some_and(|v| !v.is_empty())
    }

    /// Like [`from_env`](Self::from_env), reading the variable through `lookup`.
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> Result<Self, BusError> {
        Self::from_lookup_for(lookup, PROCESS_NAME.get().map(String::as_str))
    }

    /// Like [`from_lookup`](Self::from_lookup) for the process named `process` on the bus.
    pub fn from_lookup_for(
        lookup: impl Fn(&str) -> Option<String>,
        process: Option<&str>,
    ) -> Result<Self, BusError> {
        let Some(value) = lookup(ENV_WAIT).filter(|v| !v.is_empty()) else {
            return Ok(Self::Block);
        };
        let Some((strategy, names)) = value.split_once('@') else {
            return value.parse();
        };
        let strategy: Self = strategy.parse().map_err(|_| BusError::Config {
            key: ENV_WAIT,
            value: value.clone(),
            reason: "expected <strategy>@<process>,<process>...".to_owned(),
        })?;
        let mut names = names
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .peekable();
        if names.peek().is_none() {
            return Err(BusError::Config {
                key: ENV_WAIT,
                value: value.clone(),
                reason: "no process names after '@'".to_owned(),
            });
        }
        Ok(if process.is_some_and(|p| names.any(|n| n == p)) {
            strategy
        } else {
            Self::Block
        })
    }

    /// Whether the loop polls at all.
    pub fn polls(self) -> bool {
        !matches!(self, Self::Block)
    }
}

impl fmt::Display for WaitStrategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Block => f.write_str("block"),
            Self::SpinAfterWake { spin } => write!(f, "spin:{}", spin.as_micros()),
            Self::Anticipate { lead, late } => {
                write!(f, "anticipate:{},{}", lead.as_micros(), late.as_micros())
            }
        }
    }
}

impl FromStr for WaitStrategy {
    type Err = BusError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let invalid = |reason: &str| BusError::Config {
            key: ENV_WAIT,
            value: s.to_owned(),
            reason: reason.to_owned(),
        };
        let micros = |v: &str| -> Result<Duration, BusError> {
            let us: u64 = v
                .trim()
                .parse()
                .map_err(|_| invalid("durations are whole microseconds"))?;
            if us > 100_000 {
                return Err(invalid("a poll window longer than 100 ms is a busy loop"));
            }
            Ok(Duration::from_micros(us))
        };
        let (name, args) = s.split_once(':').unwrap_or((s, ""));
        match (name.trim(), args.trim()) {
            ("block", "") => Ok(Self::Block),
            ("spin", us) if !us.is_empty() => Ok(Self::SpinAfterWake { spin: micros(us)? }),
            ("anticipate", "") => Ok(Self::ANTICIPATE),
            ("anticipate", window) => {
                let (lead, late) = window
                    .split_once(',')
                    .ok_or_else(|| invalid("expected anticipate:<lead µs>,<late µs>"))?;
                Ok(Self::Anticipate {
                    lead: micros(lead)?,
                    late: micros(late)?,
                })
            }
            _ => Err(invalid(
                "expected \"block\", \"spin:<µs>\", \"anticipate\" or \
                 \"anticipate:<lead µs>,<late µs>\"",
            )),
        }
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
    fn parses_and_prints_every_strategy() {
        for (text, strategy) in [
            ("block", WaitStrategy::Block),
            (
                "spin:50",
                WaitStrategy::SpinAfterWake {
                    spin: Duration::from_micros(50),
                },
            ),
            ("anticipate", WaitStrategy::ANTICIPATE),
            (
                "anticipate:100,250",
                WaitStrategy::Anticipate {
                    lead: Duration::from_micros(100),
                    late: Duration::from_micros(250),
                },
            ),
        ] {
            let parsed: WaitStrategy = text.parse().expect(text);
            assert_eq!(parsed, strategy);
            assert_eq!(
                parsed.to_string().parse::<WaitStrategy>().unwrap(),
                strategy
            );
        }
        assert_eq!(
            WaitStrategy::from_lookup(|_| None).unwrap(),
            WaitStrategy::Block
        );
        assert_eq!(
            WaitStrategy::from_lookup(|_| Some(String::new())).unwrap(),
            WaitStrategy::Block
        );
    }

    #[test]
    fn a_process_list_chooses_who_polls() {
        let env = |value: &'static str| move |_: &str| Some(value.to_owned());
        let anticipate = "anticipate@estimator, controller";
        for (process, expected) in [
            (Some("estimator"), WaitStrategy::ANTICIPATE),
            (Some("controller"), WaitStrategy::ANTICIPATE),
            (Some("logger"), WaitStrategy::Block),
            (None, WaitStrategy::Block),
        ] {
            assert_eq!(
                WaitStrategy::from_lookup_for(env(anticipate), process).unwrap(),
                expected
            );
        }
        for bad in ["anticipate@", "fast@estimator", "anticipate@ , "] {
            let err = WaitStrategy::from_lookup_for(env(bad), Some("x"))
                .expect_err(bad)
                .to_string();
            assert!(err.contains(ENV_WAIT) && err.contains(bad), "{err}");
        }
    }

    #[test]
    fn refuses_bad_values_by_name() {
        for bad in [
            "spin",
            "spin:x",
            "poll",
            "anticipate:5",
            "spin:1000000",
            "block:3",
        ] {
            let err = bad.parse::<WaitStrategy>().expect_err(bad).to_string();
            assert!(err.contains(ENV_WAIT) && err.contains(bad), "{err}");
        }
    }

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
