//! How a process of the pipeline waits for its next sample ([`WaitStrategy`]): named here, where
//! the run configuration (`run.lockstep_wait`) and the bus's event loop both see it; the bus
//! implements it (`testbed_bus::EventLoop`).

use core::fmt;
use core::str::FromStr;
use std::time::Duration;

/// Environment variable selecting the [`WaitStrategy`] of every event loop a process creates:
/// `block` (default), `spin:<µs>`, `anticipate` or `anticipate:<lead µs>,<late µs>`, optionally
/// followed by `@` and the bus names of the processes it applies to
/// (`anticipate@estimator,controller`); the others then block. One variable for a whole run
/// (the launcher passes its environment to every process) can so choose the strategy of a few.
pub const ENV_WAIT: &str = "TESTBED_BUS_WAIT";

/// A wait strategy that does not parse: the text and why ([`ENV_WAIT`]'s syntax).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("invalid bus configuration {ENV_WAIT} = {value:?}: {reason}")]
pub struct WaitStrategyError {
    /// The text refused.
    pub value: String,
    /// What is wrong with it.
    pub reason: String,
}

/// How an event loop waits for its next wake-up.
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

    /// Whether [`ENV_WAIT`] is set (and not empty): it then chooses every loop's strategy,
    /// over any default a process has for its mode.
    pub fn set_in_env() -> bool {
        std::env::var_os(ENV_WAIT).is_some_and(|v| !v.is_empty())
    }

    /// The strategy [`ENV_WAIT`], read through `lookup`, gives the process named `process` on
    /// the bus; [`WaitStrategy::Block`] when unset or empty, or when it names other processes
    /// only.
    pub fn from_lookup_for(
        lookup: impl Fn(&str) -> Option<String>,
        process: Option<&str>,
    ) -> Result<Self, WaitStrategyError> {
        let Some(value) = lookup(ENV_WAIT).filter(|v| !v.is_empty()) else {
            return Ok(Self::Block);
        };
        let Some((strategy, names)) = value.split_once('@') else {
            return value.parse();
        };
        let strategy: Self = strategy.parse().map_err(|_| WaitStrategyError {
            value: value.clone(),
            reason: "expected <strategy>@<process>,<process>...".to_owned(),
        })?;
        let mut names = names
            .split(',')
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .peekable();
        if names.peek().is_none() {
            return Err(WaitStrategyError {
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
    type Err = WaitStrategyError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let invalid = |reason: &str| WaitStrategyError {
            value: s.to_owned(),
            reason: reason.to_owned(),
        };
        let micros = |v: &str| -> Result<Duration, WaitStrategyError> {
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
            WaitStrategy::from_lookup_for(|_| None, None).unwrap(),
            WaitStrategy::Block
        );
        assert_eq!(
            WaitStrategy::from_lookup_for(|_| Some(String::new()), None).unwrap(),
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
}
