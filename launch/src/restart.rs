//! Whether a process with `on_exit = "restart"` is started again.
//!
//! Up to `max_restarts` times, except for a start-up that failed the same way twice: a process
//! that exits by itself with a non-zero status before it ever reported `Running` (or
//! `Degraded`) in a heartbeat, with the same status as its previous life, which also never ran.
//! Such a failure is a missing device, a bad setting or a refused resource: starting it again
//! would only print the same error again. A process that ran and then died, or that was killed
//! by a signal (a hang, a crash, a `kill`), is restarted as before, with its budget. Whether a
//! process ran is the launcher's heartbeat watchdog's to say, from the heartbeats it took (it
//! looks every half second and once more when the process ended; a process that dies within
//! moments of saying `Running` may go unseen, and counts as failing its start-up); without a
//! watchdog (`heartbeat_timeout_s = 0`) no start-up failure is recognised and the budget alone
//! decides.

use crate::sys::ExitHow;

/// What the supervisor does with a process that ended with `on_exit = "restart"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Restart {
    /// Start it again (its `restarts + 1`-th restart).
    Again,
    /// Its `max_restarts` are used up.
    OutOfRestarts,
    /// It failed its start-up as its previous life did ([`StartFailure`]): not started again.
    SameStartFailure,
}

/// The exit status of a life that ended by itself, non-zero, before the process reported
/// `Running`: a failed start-up, compared with the next life's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StartFailure(pub i32);

impl StartFailure {
    /// The start-up failure a life that ended `how` was, if it was one; `ran`: whether the
    /// process reported `Running` (None: unknown, no watchdog).
    pub fn of(how: ExitHow, ran: Option<bool>) -> Option<Self> {
        match (how, ran) {
            (ExitHow::Code(code), Some(false)) if code != 0 => Some(Self(code)),
            _ => None,
        }
    }
}

/// The decision for a process that ended (`this`: the start-up failure this life was, if any)
/// after `restarts` restarts, with its previous life's start-up failure `previous`.
pub fn decide(
    restarts: u32,
    max_restarts: u32,
    previous: Option<StartFailure>,
    this: Option<StartFailure>,
) -> Restart {
    if this.is_some() && this == previous {
        Restart::SameStartFailure
    } else if restarts < max_restarts {
        Restart::Again
    } else {
        Restart::OutOfRestarts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NOT_RUN: Option<bool> = Some(false);

    #[test]
    fn a_start_up_failure_is_a_non_zero_exit_before_running() {
        assert_eq!(
            StartFailure::of(ExitHow::Code(1), NOT_RUN),
            Some(StartFailure(1))
        );
        assert_eq!(StartFailure::of(ExitHow::Code(1), Some(true)), None);
        assert_eq!(StartFailure::of(ExitHow::Code(0), NOT_RUN), None);
        assert_eq!(StartFailure::of(ExitHow::Signal(9), NOT_RUN), None);
        assert_eq!(StartFailure::of(ExitHow::Code(1), None), None, "unknown");
    }

    #[test]
    fn the_same_start_up_failure_twice_is_not_restarted() {
        let failed = StartFailure::of(ExitHow::Code(1), NOT_RUN);
        // The first failure is retried: a device may just have been slow to appear.
        assert_eq!(decide(0, 3, None, failed), Restart::Again);
        assert_eq!(decide(1, 3, failed, failed), Restart::SameStartFailure);
        // Even with the budget used up, the reason said is the repeated failure.
        assert_eq!(decide(3, 3, failed, failed), Restart::SameStartFailure);
    }

    #[test]
    fn other_endings_use_the_budget() {
        let code = |c| StartFailure::of(ExitHow::Code(c), NOT_RUN);
        // A different status is a different failure.
        assert_eq!(decide(1, 3, code(1), code(2)), Restart::Again);
        // A life that ran, or was killed, after a failed start: restarted.
        assert_eq!(decide(1, 3, code(1), None), Restart::Again);
        // A failed start after one that ran: retried once more.
        assert_eq!(decide(1, 3, None, code(1)), Restart::Again);
        assert_eq!(decide(3, 3, None, None), Restart::OutOfRestarts);
        assert_eq!(decide(3, 3, code(1), code(2)), Restart::OutOfRestarts);
    }
}
