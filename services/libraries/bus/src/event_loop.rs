//! The event loop of a pipeline process: the process's doorbell, with its subscribers,
//! intervals, deadlines and the heartbeat.

use std::cell::Cell;
use std::rc::Rc;
use std::time::{Duration, Instant};

use iceoryx2_bb_posix::signal::SignalHandler;
use ipc_types::Topic;

use crate::doorbell::{Bell, LocalBell, Woken};
use crate::ports::SubscriberPort;
use crate::wait::Arrivals;
use crate::{BusError, HeartbeatPublisher, TopicSubscriber, WaitFromEnv, WaitStats};
use ipc_types::WaitStrategy;

/// What an [`EventLoop`] without subscribers sleeps on (a process-private futex word that
/// nothing rings: a sleep that a signal interrupts). A loop with subscribers sleeps on the
/// doorbell of the [`Bus`](crate::Bus) they came from instead.
pub struct Waiter {
    local: LocalBell,
}

impl core::fmt::Debug for Waiter {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Waiter").finish_non_exhaustive()
    }
}

impl Waiter {
    /// A waiter; SIGINT/SIGTERM become termination requests of the loops on it.
    pub fn new() -> Result<Self, BusError> {
        Ok(Self {
            local: LocalBell::new(),
        })
    }
}

/// Identifies one attachment of an [`EventLoop`] (returned by the `on_*` methods).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SourceId(usize);

impl SourceId {
    /// Position of the attachment in attachment order.
    pub fn index(self) -> usize {
        self.0
    }
}

/// Why the loop called back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wake {
    /// A subscriber has samples, and its doorbell rang since it was last called back (or, with a
    /// polling [`WaitStrategy`], a poll found them). Read them with [`TopicSubscriber::drain`];
    /// samples left pending are called back again only after the next ring.
    Data(SourceId),
    /// An interval elapsed.
    Tick(SourceId),
    /// A subscriber attached with a deadline received nothing for the whole deadline. Repeats
    /// every deadline period for as long as nothing arrives. Never before the subscriber's
    /// first sample: a stream that has not started cannot be late.
    DeadlineMissed(SourceId),
}

impl Wake {
    /// The attachment that fired.
    pub fn source(self) -> SourceId {
        match self {
            Self::Data(s) | Self::Tick(s) | Self::DeadlineMissed(s) => s,
        }
    }
}

/// What the loop does after a callback.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Flow {
    /// Keep waiting.
    Continue,
    /// Return [`LoopExit::Stopped`].
    Stop,
}

/// Why [`EventLoop::run`] returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LoopExit {
    /// A callback returned [`Flow::Stop`].
    Stopped,
    /// SIGINT or SIGTERM was received: shut down.
    TerminationRequested,
}

/// Longest the loop sleeps without looking at the termination flag: the longest a pipeline
/// process sleeps anyway, its heartbeat going out at most 1.5 periods of 500 ms apart
/// ([`HEARTBEAT_SLACK`]), so that no process has an extra wake-up for it (at 500 ms, a process
/// on a 700-ms interval woke twice a tick). A signal normally interrupts the sleep at once;
/// this bounds the one case where it lands between the check and the sleep.
pub const MAX_SLEEP: Duration = Duration::from_millis(750);

/// How late, in heartbeat periods, a heartbeat may go out while it waits for a wake-up the
/// process has anyway: at most 1.5 periods between heartbeats (750 ms with the pipeline's
/// 500 ms), well within the launcher's 1.5-s hang timeout. Waking for the heartbeat alone
/// cost every pipeline process two wake-ups a second of its paced CPU.
pub const HEARTBEAT_SLACK: f64 = 0.5;

/// How early, in heartbeat periods, a heartbeat may go out with a wake-up the process has
/// anyway. The next heartbeat is due a period after the last one went out; with this and
/// [`HEARTBEAT_SLACK`] it rides on any wake-up 0.75 to 1.5 periods after the last, so a process
/// woken every 0.8 periods (a 2.5-Hz sensor model against the pipeline's 500 ms) or every 1.4
/// (a quiet interval, 700 ms) sends one with every wake-up and never wakes for it alone, where
/// a heartbeat due on a fixed grid, or only from its due time on, woke such a process alone
/// every second or third wake-up. A process woken more often sends one every 0.75 to 1
/// period (every 400 ms at 10 Hz).
pub const HEARTBEAT_EARLY: f64 = 0.25;

/// How soon a loop looks again at a timer that was due but had nothing to fire.
const OVERDUE_RECHECK: Duration = Duration::from_millis(1);

/// Most a poll window is opened early to make up for late timer wake-ups.
const MAX_LATENESS: Duration = Duration::from_micros(200);

enum Kind<'a> {
    Data(&'a dyn SubscriberPort),
    Interval,
    Heartbeat(&'a HeartbeatPublisher),
}

struct Attachment<'a> {
    kind: Kind<'a>,
    /// Intervals and the heartbeat: the period and the next time it is due.
    period: Option<Duration>,
    /// An interval whose period its owner changes ([`EventLoop::on_variable_interval`]).
    variable_period: Option<&'a Cell<Duration>>,
    next_due: Cell<Option<Instant>>,
    /// A subscriber attached with a deadline: the deadline and when the last miss was reported.
    deadline: Option<Duration>,
    last_miss: Cell<Option<Instant>>,
    missed: Cell<u64>,
    /// The doorbell's count when this subscriber was last called back.
    called_at_ring: Cell<Option<u32>>,
    arrivals: Cell<Arrivals>,
}

impl<'a> Attachment<'a> {
    fn new(kind: Kind<'a>) -> Self {
        Self {
            kind,
            period: None,
            variable_period: None,
            next_due: Cell::new(None),
            deadline: None,
            last_miss: Cell::new(None),
            missed: Cell::new(0),
            called_at_ring: Cell::new(None),
            arrivals: Cell::new(Arrivals::default()),
        }
    }

    /// When the deadline of a supervised subscriber runs out: a deadline after its last sample
    /// or its last reported miss, whichever is later. `None` before its first sample.
    fn deadline_due(&self, port: &dyn SubscriberPort) -> Option<Instant> {
        let deadline = self.deadline?;
        let last = port.last_received()?;
        let anchor = self.last_miss.get().map_or(last, |miss| miss.max(last));
        anchor.checked_add(deadline)
    }

    /// When an interval or the heartbeat is next due, and its period.
    fn schedule(&self) -> Option<(Instant, Duration)> {
        Some((self.next_due.get()?, self.period?))
    }

    /// The next time this attachment has something to do without a ring. A heartbeat is due
    /// at `next_due` but goes out with the first wake-up from [`HEARTBEAT_EARLY`] of a period
    /// before it, whatever its reason; the loop wakes for it alone only [`HEARTBEAT_SLACK`] of
    /// a period after it. A process woken by its data more often than that never wakes for its
    /// heartbeat.
    fn next_timer(&self) -> Option<Instant> {
        match self.kind {
            Kind::Data(port) => self.deadline_due(port),
            Kind::Interval => self.next_due.get(),
            Kind::Heartbeat(_) => {
                let slack = self
                    .period
                    .map_or(Duration::ZERO, |p| p.mul_f64(HEARTBEAT_SLACK));
                self.next_due.get().and_then(|due| due.checked_add(slack))
            }
        }
    }
}

/// Waits on subscribers, intervals and deadlines and calls back with the source that fired.
///
/// With the default [`WaitStrategy::Block`] it never busy-waits: between wake-ups the thread
/// sleeps on its process's doorbell (a futex), which every publisher to any of its subscribers
/// rings after sending. Each round reads the doorbell first, then calls back every due interval,
/// every missed deadline and every subscriber that has samples and was rung for, in attachment
/// order; it sleeps only when a round found nothing, and only while the doorbell still has the
/// count it read (so a sample published during the round is never slept through). The other
/// strategies poll the subscribers in short windows (see [`WaitStrategy`]); the process's
/// [`ENV_WAIT`](ipc_types::ENV_WAIT) chooses the strategy of [`EventLoop::new`].
pub struct EventLoop<'w, 'a> {
    waiter: &'w Waiter,
    /// The doorbell of the subscribers' bus (all must come from one bus).
    bell: Option<Rc<Bell>>,
    attachments: Vec<Attachment<'a>>,
    wait: WaitStrategy,
    /// End of the current poll-after-wake window ([`WaitStrategy::SpinAfterWake`]).
    spin_until: Cell<Option<Instant>>,
    stats: Cell<WaitStats>,
    /// How late timed wake-ups for poll windows come (moving average).
    lateness: Cell<Duration>,
    /// The previous sleep ended with a ring (for [`WaitStats::stale_notifications`]).
    was_rung: Cell<bool>,
    /// Rings to sleep through before a data wake-up ([`EventLoop::wake_after_rings`]).
    rings_awaited: Option<&'a Cell<u32>>,
}

impl<'w, 'a> EventLoop<'w, 'a> {
    /// An empty loop on `waiter`, waiting as [`ENV_WAIT`](ipc_types::ENV_WAIT) says
    /// ([`WaitStrategy::Block`] when unset; an invalid value is logged and ignored —
    /// [`BusConfig::from_env`](crate::BusConfig::from_env) refuses it with its name).
    pub fn new(waiter: &'w Waiter) -> Self {
        let wait = WaitStrategy::from_env().unwrap_or_else(|e| {
            tracing::warn!("{e}; waiting with \"block\"");
            WaitStrategy::Block
        });
        Self::with_wait_strategy(waiter, wait)
    }

    /// An empty loop on `waiter` that waits with `wait`.
    ///
    /// [`WaitStrategy::Anticipate`] sets the calling thread's timer slack to 1 µs, so that it
    /// wakes when a poll window opens rather than up to 50 µs later.
    pub fn with_wait_strategy(waiter: &'w Waiter, wait: WaitStrategy) -> Self {
        precise_timers(wait);
        Self {
            waiter,
            bell: None,
            attachments: Vec::new(),
            wait,
            spin_until: Cell::new(None),
            stats: Cell::new(WaitStats::default()),
            lateness: Cell::new(Duration::ZERO),
            was_rung: Cell::new(false),
            rings_awaited: None,
        }
    }

    /// How this loop waits.
    pub fn wait_strategy(&self) -> WaitStrategy {
        self.wait
    }

    /// Changes how this loop waits from the next wait on.
    pub fn set_wait_strategy(&mut self, wait: WaitStrategy) {
        precise_timers(wait);
        self.wait = wait;
        self.spin_until.set(None);
    }

    /// How the data wake-ups so far came about.
    pub fn wait_stats(&self) -> WaitStats {
        self.stats.get()
    }

    fn push(&mut self, attachment: Attachment<'a>) -> SourceId {
        self.attachments.push(attachment);
        SourceId(self.attachments.len() - 1)
    }

    fn attach_subscriber(
        &mut self,
        subscriber: &'a dyn SubscriberPort,
        deadline: Option<Duration>,
    ) -> Result<SourceId, BusError> {
        let Some(bell) = subscriber.bell() else {
            return Err(BusError::EventLoop {
                operation: "attaching a subscriber",
                source: format!(
                    "the subscriber of {} was created polled (SubscriberOptions::polled): its \
                     topic rings no doorbell, so it cannot wake a loop; drain it on an interval",
                    subscriber.topic()
                )
                .into(),
            });
        };
        match &self.bell {
            None => self.bell = Some(bell.clone()),
            Some(mine) if Rc::ptr_eq(mine, bell) => {}
            Some(_) => {
                return Err(BusError::EventLoop {
                    operation: "attaching a subscriber",
                    source: "the subscribers of one event loop must come from one Bus \
                             (they ring that bus's doorbell)"
                        .into(),
                });
            }
        }
        // Samples published before this are found by the first round, which looks at every
        // subscriber whatever the doorbell says.
        subscriber.start_ringing();
        let mut attachment = Attachment::new(Kind::Data(subscriber));
        attachment.deadline = deadline;
        Ok(self.push(attachment))
    }

    /// Wakes with [`Wake::Data`] when `subscriber` has samples.
    pub fn on_data<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
    ) -> Result<SourceId, BusError> {
        self.attach_subscriber(subscriber, None)
    }

    /// Like [`on_data`](Self::on_data), and also wakes with [`Wake::DeadlineMissed`] when
    /// nothing arrived for `deadline` (again after every further `deadline` without data).
    ///
    /// The deadline is supervised from the subscriber's first sample on: while a pipeline
    /// starts, its streams begin one after another, and a process cannot be late for a stream
    /// that has not delivered anything yet. A stream that never starts is for start-up checks
    /// to catch (in the pipeline: the plant counts every tick it advances unanswered), not a
    /// missed deadline.
    ///
    /// "Nothing arrived" means that the subscriber took no sample
    /// ([`TopicSubscriber::last_received`]) for the whole deadline and has none pending: a
    /// sample taken by a `drain` in another source's callback, or by polling, counts.
    pub fn on_data_with_deadline<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
        deadline: Duration,
    ) -> Result<SourceId, BusError> {
        self.attach_subscriber(subscriber, Some(deadline))
    }

    fn attach_periodic(&mut self, kind: Kind<'a>, period: Duration) -> Result<SourceId, BusError> {
        if period.is_zero() {
            return Err(BusError::EventLoop {
                operation: "attaching an interval",
                source: "the period must be longer than zero".into(),
            });
        }
        let mut attachment = Attachment::new(kind);
        attachment.period = Some(period);
        attachment.next_due.set(Instant::now().checked_add(period));
        Ok(self.push(attachment))
    }

    /// Wakes with [`Wake::Tick`] every `period` (a tick that could not be served in time is
    /// served once, late, and the next one is a period after it).
    pub fn on_interval(&mut self, period: Duration) -> Result<SourceId, BusError> {
        self.attach_periodic(Kind::Interval, period)
    }

    /// Wakes with [`Wake::Tick`] every `period`, read anew at each tick: the owner may change it
    /// from any callback, and the next tick is then the new period after the callback returned
    /// (no catching up). A zero period counts as one millisecond.
    pub fn on_variable_interval(
        &mut self,
        period: &'a Cell<Duration>,
    ) -> Result<SourceId, BusError> {
        let source = self.attach_periodic(Kind::Interval, variable(period))?;
        self.attachments[source.0].variable_period = Some(period);
        Ok(source)
    }

    /// Publishes `heartbeat` now and then every [`HeartbeatPublisher::period`], without calling
    /// back. A failed heartbeat is logged and counted in the heartbeat's error counter.
    pub fn with_heartbeat(
        &mut self,
        heartbeat: &'a HeartbeatPublisher,
    ) -> Result<SourceId, BusError> {
        let source = self.attach_periodic(Kind::Heartbeat(heartbeat), heartbeat.period())?;
        heartbeat.publish_or_count();
        Ok(source)
    }

    /// Sleeps until `awaited` rings of the doorbell have come instead of the first (read before
    /// each sleep; the owner changes it from its callbacks; 0 counts as 1): for a process
    /// that knows how many more samples it needs before it can act, such as an estimator
    /// waiting for a tick's gyro, inclinometer and magnetometer samples, which would otherwise
    /// wake once per sample as their publishers happen to be scheduled. Intervals, deadlines
    /// and the heartbeat wake it as before, and a ring that comes while it is awake still
    /// makes its next look at once.
    ///
    /// `awaited` must not count more than the process needs: every sample it counts must be
    /// one that rings this loop's doorbell. Counting too many delays the process until
    /// further samples or a deadline; counting too few costs a wake-up.
    pub fn wake_after_rings(&mut self, awaited: &'a Cell<u32>) {
        self.rings_awaited = Some(awaited);
    }

    /// Missed deadlines of `source` so far.
    pub fn missed_deadlines(&self, source: SourceId) -> u64 {
        self.attachments.get(source.0).map_or(0, |a| a.missed.get())
    }

    /// Calls `on_wake` for every wake-up until it returns [`Flow::Stop`] or SIGINT/SIGTERM
    /// arrives.
    pub fn run(&mut self, mut on_wake: impl FnMut(Wake) -> Flow) -> Result<LoopExit, BusError> {
        loop {
            if let Some(exit) = self.wait_once(Duration::MAX, &mut on_wake)? {
                return Ok(exit);
            }
        }
    }

    /// Waits for at most `timeout` for one round of wake-ups and handles them. Returns
    /// `Some(exit)` when the loop should end, `None` otherwise (also on timeout).
    pub fn run_once(
        &mut self,
        timeout: Duration,
        mut on_wake: impl FnMut(Wake) -> Flow,
    ) -> Result<Option<LoopExit>, BusError> {
        self.wait_once(timeout, &mut on_wake)
    }

    /// The doorbell's count now.
    fn rings(&self) -> u32 {
        match &self.bell {
            Some(bell) => bell.rings(),
            None => self.waiter.local.rings(),
        }
    }

    /// Sleeps until the doorbell rings after `seen`, `timeout` passes or a signal arrives.
    fn sleep(&self, seen: u32, timeout: Duration) -> Woken {
        let rings = self.rings_awaited.map_or(1, Cell::get);
        let woken = match &self.bell {
            Some(bell) => bell.wait_for_rings(seen, rings, timeout),
            None => self.waiter.local.wait(seen, timeout),
        };
        self.was_rung.set(woken == Woken::Rung);
        woken
    }

    fn wait_once(
        &self,
        timeout: Duration,
        on_wake: &mut impl FnMut(Wake) -> Flow,
    ) -> Result<Option<LoopExit>, BusError> {
        let end = Instant::now().checked_add(timeout);
        loop {
            if SignalHandler::termination_requested() {
                tracing::info!("termination requested (SIGINT/SIGTERM)");
                return Ok(Some(LoopExit::TerminationRequested));
            }
            let seen = self.rings();
            // Whether this round follows a sleep that a ring ended: only then is a round that
            // finds nothing a stale notification (not the look before the next sleep that
            // follows a round that handled something).
            let after_ring = self.was_rung.replace(false);
            match self.dispatch(seen, on_wake)? {
                Round::Exit(exit) => return Ok(Some(exit)),
                Round::Handled => return Ok(None),
                Round::Nothing => {
                    if after_ring {
                        self.count(|s| s.stale_notifications += 1);
                    }
                }
            }
            let now = Instant::now();
            let left = end.map_or(Duration::MAX, |end| end.saturating_duration_since(now));
            if left.is_zero() {
                return Ok(None);
            }
            // A timer still due after a round that handled nothing is a deadline whose subscriber
            // has samples its callback left pending: not a miss, and not a reason to spin.
            let until_timer = match self.next_timer() {
                None => Duration::MAX,
                Some(t) if t <= now => OVERDUE_RECHECK,
                Some(t) => t - now,
            };
            let sleep = left.min(until_timer).min(MAX_SLEEP);
            match self.poll_window(now) {
                Window::Open(close) => {
                    let close = close.min(now + sleep);
                    if let Polled::Handled(exit) = self.poll_until(close, on_wake)? {
                        return Ok(exit);
                    }
                }
                Window::OpensAt(open) => {
                    let open = open.checked_sub(self.lateness.get()).unwrap_or(open);
                    let to_open = open.saturating_duration_since(now);
                    if self.sleep(seen, sleep.min(to_open)) == Woken::TimedOut && to_open <= sleep {
                        let late = Instant::now()
                            .saturating_duration_since(open)
                            .min(MAX_LATENESS);
                        self.lateness.set((self.lateness.get() * 3 + late) / 4);
                    }
                }
                Window::None => {
                    self.sleep(seen, sleep);
                }
            }
        }
    }

    /// The earliest interval, heartbeat or deadline still to come.
    fn next_timer(&self) -> Option<Instant> {
        self.attachments
            .iter()
            .filter_map(Attachment::next_timer)
            .min()
    }

    /// One round: calls back, in attachment order, every due interval (and publishes a due
    /// heartbeat), every missed deadline and every subscriber with samples rung for since its
    /// last callback (`seen`: the doorbell's count read before the round).
    fn dispatch(
        &self,
        seen: u32,
        on_wake: &mut impl FnMut(Wake) -> Flow,
    ) -> Result<Round, BusError> {
        let now = Instant::now();
        if self.wait.polls() {
            self.observe_arrivals(now, false)?;
        }
        let mut handled = false;
        for (index, attachment) in self.attachments.iter().enumerate() {
            let source = SourceId(index);
            let wake = match attachment.kind {
                Kind::Heartbeat(heartbeat) => {
                    let Some((due, period)) = attachment.schedule() else {
                        continue;
                    };
                    if due > now + period.mul_f64(HEARTBEAT_EARLY) {
                        continue;
                    }
                    // The next is due a period after this one went out, not after this one was
                    // due: a heartbeat that rode on a later wake-up is not due again sooner.
                    attachment.next_due.set(Some(now + period));
                    heartbeat.publish_or_count();
                    continue;
                }
                Kind::Interval => {
                    let Some((due, period)) = attachment.schedule() else {
                        continue;
                    };
                    if due > now {
                        continue;
                    }
                    let next = due + period;
                    attachment
                        .next_due
                        .set(Some(if next > now { next } else { now + period }));
                    Wake::Tick(source)
                }
                Kind::Data(port) => {
                    let pending = port.attach()?;
                    if pending {
                        if attachment.called_at_ring.get() == Some(seen) {
                            continue;
                        }
                        attachment.called_at_ring.set(Some(seen));
                        self.count(|s| s.woken += 1);
                        Wake::Data(source)
                    } else {
                        match attachment.deadline_due(port) {
                            Some(due) if due <= now => {
                                attachment.last_miss.set(Some(now));
                                attachment.missed.set(attachment.missed.get() + 1);
                                Wake::DeadlineMissed(source)
                            }
                            _ => continue,
                        }
                    }
                }
            };
            handled = true;
            let flow = on_wake(wake);
            if let (Wake::Tick(_), Some(period)) = (wake, attachment.variable_period) {
                attachment
                    .next_due
                    .set(Instant::now().checked_add(variable(period)));
            }
            if matches!(wake, Wake::Data(_)) {
                self.handled_data();
            }
            if flow == Flow::Stop {
                return Ok(Round::Exit(LoopExit::Stopped));
            }
        }
        Ok(if handled {
            Round::Handled
        } else {
            Round::Nothing
        })
    }

    /// Where the current poll window stands at `now`.
    fn poll_window(&self, now: Instant) -> Window {
        match self.wait {
            WaitStrategy::Block => Window::None,
            WaitStrategy::SpinAfterWake { .. } => match self.spin_until.get() {
                Some(close) if close > now => Window::Open(close),
                _ => Window::None,
            },
            WaitStrategy::Anticipate { lead, late } => {
                // The earliest window of any source; if it is open, poll until the latest
                // close among the open ones.
                let windows = self
                    .data_attachments()
                    .filter_map(|(_, a, _)| a.arrivals.get().window(now, lead, late));
                let (mut open, mut close) = (None::<Instant>, None::<Instant>);
                for (o, c) in windows {
                    if o <= now {
                        close = Some(close.map_or(c, |close| close.max(c)));
                    }
                    open = Some(open.map_or(o, |open| open.min(o)));
                }
                match (open, close) {
                    (_, Some(close)) => Window::Open(close),
                    (Some(open), None) => Window::OpensAt(open),
                    (None, None) => Window::None,
                }
            }
        }
    }

    fn data_attachments(
        &self,
    ) -> impl Iterator<Item = (usize, &Attachment<'a>, &'a dyn SubscriberPort)> {
        self.attachments
            .iter()
            .enumerate()
            .filter_map(|(i, a)| match a.kind {
                Kind::Data(port) => Some((i, a, port)),
                _ => None,
            })
    }

    /// Records, at `now`, an arrival for every data source with samples pending; `polled`: the
    /// loop was polling (the time is exact), not woken.
    fn observe_arrivals(&self, now: Instant, polled: bool) -> Result<(), BusError> {
        let cap = match self.wait {
            WaitStrategy::Anticipate { lead, .. } => lead,
            _ => Duration::ZERO,
        };
        for (_, attachment, port) in self.data_attachments() {
            if port.attach()? {
                let mut arrivals = attachment.arrivals.get();
                arrivals.note(now, polled, cap);
                attachment.arrivals.set(arrivals);
            }
        }
        Ok(())
    }

    fn count(&self, update: impl FnOnce(&mut WaitStats)) {
        let mut stats = self.stats.get();
        update(&mut stats);
        self.stats.set(stats);
    }

    /// A data callback was handled: start the poll-after-wake window.
    fn handled_data(&self) {
        if let WaitStrategy::SpinAfterWake { spin } = self.wait {
            self.spin_until.set(Instant::now().checked_add(spin));
        }
    }

    /// Polls every data source until one has samples (calls back for it) or `close` passes,
    /// yielding the CPU between polls: the publisher the loop waits for may share its CPU
    /// (the scheduler likes to put processes that wake each other on one CPU), and a poll
    /// loop that kept the CPU would delay the very sample it waits for.
    fn poll_until(
        &self,
        close: Instant,
        on_wake: &mut impl FnMut(Wake) -> Flow,
    ) -> Result<Polled, BusError> {
        loop {
            for (index, attachment, port) in self.data_attachments() {
                if port.attach()? {
                    let now = Instant::now();
                    self.observe_arrivals(now, true)?;
                    self.count(|s| s.polled += 1);
                    attachment.called_at_ring.set(Some(self.rings()));
                    let flow = on_wake(Wake::Data(SourceId(index)));
                    self.handled_data();
                    return Ok(Polled::Handled(match flow {
                        Flow::Continue => None,
                        Flow::Stop => Some(LoopExit::Stopped),
                    }));
                }
            }
            if Instant::now() >= close {
                self.count(|s| s.empty_windows += 1);
                self.spin_until.set(None);
                return Ok(Polled::Nothing);
            }
            std::thread::yield_now();
        }
    }
}

/// The period of a variable interval now (at least 1 ms: a zero period would spin).
fn variable(period: &Cell<Duration>) -> Duration {
    period.get().max(Duration::from_millis(1))
}

impl Drop for EventLoop<'_, '_> {
    fn drop(&mut self) {
        for (_, _, port) in self.data_attachments() {
            port.stop_ringing();
        }
    }
}

/// What one round of [`EventLoop::dispatch`] did.
enum Round {
    /// A callback stopped the loop.
    Exit(LoopExit),
    /// Something was called back.
    Handled,
    /// Nothing was due.
    Nothing,
}

/// Timer slack of 1 µs for the calling thread if `wait` sleeps until poll windows open.
fn precise_timers(wait: WaitStrategy) {
    if matches!(wait, WaitStrategy::Anticipate { .. }) {
        // SAFETY: PR_SET_TIMERSLACK takes a value and changes only this thread's slack.
        unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, 1000 as libc::c_ulong) };
    }
}

/// The poll window of a polling [`WaitStrategy`] at some instant.
enum Window {
    /// No window: sleep until something fires.
    None,
    /// Poll until this instant.
    Open(Instant),
    /// Sleep until this instant, then poll.
    OpensAt(Instant),
}

enum Polled {
    /// A data source had samples and was called back; the loop's exit, if the callback
    /// stopped it.
    Handled(Option<LoopExit>),
    /// The window closed without a sample.
    Nothing,
}
