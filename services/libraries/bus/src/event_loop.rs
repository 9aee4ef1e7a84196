//! The event loop of a pipeline process: an iceoryx2 WaitSet with subscribers' listeners,
//! intervals, deadlines and the heartbeat attached.

use std::cell::Cell;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use iceoryx2::waitset::{WaitSetAttachmentError, WaitSetRunResult};
use ipc_types::Topic;

use crate::ports::{SubscriberPort, drain_listener};
use crate::wait::Arrivals;
use crate::{BusError, HeartbeatPublisher, TopicSubscriber, WaitStats, WaitStrategy};

/// Owns the iceoryx2 WaitSet that an [`EventLoop`] attaches to (the loop borrows it, which is
/// what lets the loop hold the attachment guards).
pub struct Waiter {
    waitset: WaitSet<ipc::Service>,
}

impl core::fmt::Debug for Waiter {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Waiter")
            .field("attachments", &self.waitset.len())
            .finish()
    }
}

impl Waiter {
    /// A WaitSet that reports SIGINT/SIGTERM as termination requests.
    pub fn new() -> Result<Self, BusError> {
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
            .create::<ipc::Service>()
            .map_err(|e| BusError::WaitSet {
                operation: "creating the WaitSet",
                source: Box::new(e),
            })?;
        Ok(Self { waitset })
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
    /// A subscriber was notified; its listener has already been drained. Read its samples with
    /// [`TopicSubscriber::drain`]. With a polling [`WaitStrategy`] this also means that a
    /// poll found samples pending (the notification is drained by a later round, and a
    /// notification whose samples were already taken calls nothing back).
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

enum Kind<'a> {
    Data(&'a dyn SubscriberPort),
    Interval,
    Heartbeat(&'a HeartbeatPublisher),
}

/// WaitSet guards of intervals borrow nothing but the WaitSet (`'static` attachment).
enum Guard<'w, 'a> {
    Listener(WaitSetGuard<'w, 'a, ipc::Service>),
    Interval(WaitSetGuard<'w, 'static, ipc::Service>),
}

impl Guard<'_, '_> {
    fn fired(&self, id: &WaitSetAttachmentId<ipc::Service>) -> bool {
        match self {
            Self::Listener(g) => id.has_event_from(g) || id.has_missed_deadline(g),
            Self::Interval(g) => id.has_event_from(g),
        }
    }

    fn missed_deadline(&self, id: &WaitSetAttachmentId<ipc::Service>) -> bool {
        match self {
            Self::Listener(g) => id.has_missed_deadline(g),
            Self::Interval(_) => false,
        }
    }
}

struct Attachment<'w, 'a> {
    guard: Guard<'w, 'a>,
    kind: Kind<'a>,
    missed: Cell<u64>,
    arrivals: Cell<Arrivals>,
    /// The deadline of a subscriber attached with one.
    deadline: Option<Duration>,
}

/// How often the loop looks at every subscriber's listener and samples without having been
/// woken for them.
///
/// iceoryx2 0.10's inter-process event (`UnixDatagramShmCountingBitSet`) skips the wake-up
/// datagram while its shared state says one is pending. That state can be left set after the
/// listener has already consumed the datagram: the listener resets the state, a notifier
/// marks it pending and sends, the listener's drain empties the socket (taking that datagram),
/// then the notifier marks the state "notified". From then on every notifier skips the
/// datagram and the listener is never woken again, with its samples piling up. Seen under
/// heavy load (two cores, a CPU hog, two can-sim pipelines): one gateway's CAN listener went
/// deaf with its state byte at "notified", an empty socket and 53 activations pending, and the
/// lockstep run stopped. Draining the listener by hand (`try_wait`) resets the state, so a
/// sweep turns that permanent stop into a delay. The sweep rides on the loop's other wake-ups
/// (data, intervals, the heartbeat) at most every this period, so it costs no wake-up of its
/// own; a loop with subscribers never sleeps longer than [`LISTENER_SWEEP_MAX_SLEEP`]. Samples
/// it finds are called back and counted ([`WaitStats::swept`]).
pub const LISTENER_SWEEP_PERIOD: Duration = Duration::from_millis(100);

/// Longest a loop with subscribers sleeps without sweeping its listeners
/// ([`LISTENER_SWEEP_PERIOD`]): the pipeline's heartbeat period, so that a pipeline process,
/// which wakes for its heartbeat anyway, has no extra wake-up.
pub const LISTENER_SWEEP_MAX_SLEEP: Duration = Duration::from_millis(500);

/// How often a polling loop serves the WaitSet (termination, intervals, deadlines) at least.
const SERVICE_PERIOD: Duration = Duration::from_millis(1);

/// Most a poll window is opened early to make up for late timer wake-ups.
const MAX_LATENESS: Duration = Duration::from_micros(200);

/// Granularity of the WaitSet's timeouts (epoll: whole milliseconds, rounded up).
const COARSE: Duration = Duration::from_millis(1);

/// Waits on subscribers, intervals and deadlines and calls back with the source that fired.
///
/// With the default [`WaitStrategy::Block`] it never busy-waits: between wake-ups the thread
/// sleeps in `epoll_wait` (iceoryx2 WaitSet), and a data wake-up always drains the subscriber's
/// listener before calling back, so a notification can wake the loop only once. The other
/// strategies poll the subscribers in short windows (see [`WaitStrategy`]); the process's
/// [`ENV_WAIT`](crate::ENV_WAIT) chooses the strategy of [`EventLoop::new`].
pub struct EventLoop<'w, 'a> {
    waitset: &'w WaitSet<ipc::Service>,
    attachments: Vec<Attachment<'w, 'a>>,
    wait: WaitStrategy,
    /// End of the current poll-after-wake window ([`WaitStrategy::SpinAfterWake`]).
    spin_until: Cell<Option<Instant>>,
    /// Last time the WaitSet was asked (polling strategies serve it every [`SERVICE_PERIOD`]).
    last_round: Cell<Instant>,
    stats: Cell<WaitStats>,
    /// How late timed wake-ups for poll windows come (moving average).
    lateness: Cell<Duration>,
    /// When the listeners were last swept ([`LISTENER_SWEEP_PERIOD`]).
    last_sweep: Cell<Instant>,
}

impl<'w, 'a> EventLoop<'w, 'a> {
    /// An empty loop on `waiter`'s WaitSet, waiting as [`ENV_WAIT`](crate::ENV_WAIT) says
    /// ([`WaitStrategy::Block`] when unset; an invalid value is logged and ignored —
    /// [`BusConfig::from_env`](crate::BusConfig::from_env) refuses it with its name).
    pub fn new(waiter: &'w Waiter) -> Self {
        let wait = WaitStrategy::from_env().unwrap_or_else(|e| {
            tracing::warn!("{e}; waiting with \"block\"");
            WaitStrategy::Block
        });
        Self::with_wait_strategy(waiter, wait)
    }

    /// An empty loop on `waiter`'s WaitSet that waits with `wait`.
    ///
    /// [`WaitStrategy::Anticipate`] sets the calling thread's timer slack to 1 µs, so that it
    /// wakes when a poll window opens rather than up to 50 µs later.
    pub fn with_wait_strategy(waiter: &'w Waiter, wait: WaitStrategy) -> Self {
        precise_timers(wait);
        Self {
            waitset: &waiter.waitset,
            attachments: Vec::new(),
            wait,
            spin_until: Cell::new(None),
            last_round: Cell::new(Instant::now()),
            stats: Cell::new(WaitStats::default()),
            lateness: Cell::new(Duration::ZERO),
            last_sweep: Cell::new(Instant::now()),
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

    fn push(&mut self, guard: Guard<'w, 'a>, kind: Kind<'a>) -> SourceId {
        self.push_with_deadline(guard, kind, None)
    }

    fn push_with_deadline(
        &mut self,
        guard: Guard<'w, 'a>,
        kind: Kind<'a>,
        deadline: Option<Duration>,
    ) -> SourceId {
        self.attachments.push(Attachment {
            guard,
            kind,
            missed: Cell::new(0),
            arrivals: Cell::new(Arrivals::default()),
            deadline,
        });
        SourceId(self.attachments.len() - 1)
    }

    fn attach_error(operation: &'static str) -> impl FnOnce(WaitSetAttachmentError) -> BusError {
        move |e| BusError::WaitSet {
            operation,
            source: Box::new(e),
        }
    }

    /// Wakes with [`Wake::Data`] when `subscriber` is notified.
    pub fn on_data<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
    ) -> Result<SourceId, BusError> {
        let guard = self
            .waitset
            .attach_notification(SubscriberPort::listener(subscriber))
            .map_err(Self::attach_error("attaching a subscriber"))?;
        Ok(self.push(Guard::Listener(guard), Kind::Data(subscriber)))
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
    /// ([`TopicSubscriber::last_received`]) for the whole deadline: a sample whose notification
    /// was consumed by a `drain` in another source's callback, or taken by polling, counts.
    /// The WaitSet's timer only sees notifications, so in that case the miss is reported
    /// between one and two deadlines after the last sample.
    pub fn on_data_with_deadline<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
        deadline: Duration,
    ) -> Result<SourceId, BusError> {
        let guard = self
            .waitset
            .attach_deadline(SubscriberPort::listener(subscriber), deadline)
            .map_err(Self::attach_error("attaching a subscriber with a deadline"))?;
        Ok(self.push_with_deadline(
            Guard::Listener(guard),
            Kind::Data(subscriber),
            Some(deadline),
        ))
    }

    /// The sweep ([`LISTENER_SWEEP_PERIOD`]): drains every subscriber's listener (which also
    /// resets a listener left deaf) and calls back [`Wake::Data`] for every subscriber with
    /// samples pending.
    fn sweep(&self, on_wake: &mut impl FnMut(Wake) -> Flow) -> Result<(Flow, bool), BusError> {
        let mut handled = false;
        for (index, _, port) in self.data_attachments() {
            // `attach` also connects to publishers created since the last look.
            let pending = drain_listener(port.listener(), port.event_name())?;
            if !port.attach()? {
                continue;
            }
            self.count(|s| s.swept += 1);
            tracing::debug!(
                service = port.event_name(),
                notified = pending.samples,
                "samples found by the listener sweep"
            );
            handled = true;
            let flow = on_wake(Wake::Data(SourceId(index)));
            self.handled_data();
            if flow == Flow::Stop {
                return Ok((Flow::Stop, true));
            }
        }
        Ok((Flow::Continue, handled))
    }

    /// Wakes with [`Wake::Tick`] every `period`.
    pub fn on_interval(&mut self, period: Duration) -> Result<SourceId, BusError> {
        let guard = self
            .waitset
            .attach_interval(period)
            .map_err(Self::attach_error("attaching an interval"))?;
        Ok(self.push(Guard::Interval(guard), Kind::Interval))
    }

    /// Publishes `heartbeat` now and then every [`HeartbeatPublisher::period`], without calling
    /// back. A failed heartbeat is logged and counted in the heartbeat's error counter.
    pub fn with_heartbeat(
        &mut self,
        heartbeat: &'a HeartbeatPublisher,
    ) -> Result<SourceId, BusError> {
        let guard = self
            .waitset
            .attach_interval(heartbeat.period())
            .map_err(Self::attach_error("attaching the heartbeat interval"))?;
        heartbeat.publish_or_count();
        Ok(self.push(Guard::Interval(guard), Kind::Heartbeat(heartbeat)))
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

    fn wait_once(
        &self,
        timeout: Duration,
        on_wake: &mut impl FnMut(Wake) -> Flow,
    ) -> Result<Option<LoopExit>, BusError> {
        if !self.wait.polls() {
            return self.waitset_round(timeout, on_wake).map(|(exit, _)| exit);
        }
        let end = Instant::now().checked_add(timeout);
        loop {
            let now = Instant::now();
            let left = end.map_or(Duration::MAX, |end| end.saturating_duration_since(now));
            let window = self.poll_window(now);
            let exit_or_handled = match window {
                // Poll until the window closes (or the caller's timeout).
                Window::Open(close) => {
                    if now.saturating_duration_since(self.last_round.get()) >= SERVICE_PERIOD {
                        let (exit, handled) = self.waitset_round(Duration::ZERO, on_wake)?;
                        if exit.is_some() || handled {
                            return Ok(exit);
                        }
                    }
                    let close = end.map_or(close, |end| close.min(end));
                    match self.poll_until(close, on_wake)? {
                        Polled::Handled(exit) => return Ok(exit),
                        Polled::Nothing => (None, false),
                    }
                }
                // Sleep until the window opens (or something fires). The WaitSet rounds its
                // timeout up to whole milliseconds, so it sleeps the bulk and `ppoll` on the
                // listeners (nanosecond timeout) the last stretch.
                // Timer wake-ups are late themselves (on a virtual machine, tens of µs when the
                // CPU had halted): open that much earlier, as measured.
                Window::OpensAt(open) => {
                    let open = open.checked_sub(self.lateness.get()).unwrap_or(open);
                    let wait = left.min(open.saturating_duration_since(now));
                    if wait > 2 * COARSE {
                        self.waitset_round(wait - COARSE, on_wake)?
                    } else if self.ppoll_listeners(wait)? {
                        self.waitset_round(Duration::ZERO, on_wake)?
                    } else {
                        if wait == open.saturating_duration_since(now) {
                            let late = Instant::now()
                                .saturating_duration_since(open)
                                .min(MAX_LATENESS);
                            self.lateness.set((self.lateness.get() * 3 + late) / 4);
                        }
                        (None, false)
                    }
                }
                Window::None => self.waitset_round(left, on_wake)?,
            };
            match exit_or_handled {
                (Some(exit), _) => return Ok(Some(exit)),
                (None, true) => return Ok(None),
                (None, false) if left.is_zero() => return Ok(None),
                (None, false) => {}
            }
        }
    }

    /// Sleeps until a data listener is notified or `timeout` has passed (precisely, unlike the
    /// WaitSet); true if a listener was notified. Intervals and deadlines wait meanwhile (at
    /// most [`COARSE`] twice over).
    fn ppoll_listeners(&self, timeout: Duration) -> Result<bool, BusError> {
        let mut fds: Vec<libc::pollfd> = self
            .data_attachments()
            .map(|(_, _, port)| libc::pollfd {
                // SAFETY: the listener outlives this call; the descriptor is only polled.
                fd: unsafe { port.listener().file_descriptor().native_handle() },
                events: libc::POLLIN,
                revents: 0,
            })
            .collect();
        let ts = libc::timespec {
            tv_sec: timeout.as_secs() as libc::time_t,
            tv_nsec: timeout.subsec_nanos() as libc::c_long,
        };
        // SAFETY: ppoll reads `fds.len()` pollfds and the timespec, writes only `revents`.
        let n = unsafe {
            libc::ppoll(
                fds.as_mut_ptr(),
                fds.len() as libc::nfds_t,
                &ts,
                std::ptr::null(),
            )
        };
        if n < 0 {
            let e = std::io::Error::last_os_error();
            if e.kind() == std::io::ErrorKind::Interrupted {
                // A signal: the next WaitSet round reports a termination request.
                return Ok(true);
            }
            return Err(BusError::WaitSet {
                operation: "polling the listeners",
                source: Box::new(e),
            });
        }
        Ok(n > 0)
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
    ) -> impl Iterator<Item = (usize, &Attachment<'w, 'a>, &'a dyn SubscriberPort)> {
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
            for (index, _, port) in self.data_attachments() {
                if port.attach()? {
                    let now = Instant::now();
                    self.observe_arrivals(now, true)?;
                    self.count(|s| s.polled += 1);
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

    /// One round of the WaitSet, sleeping at most `timeout`. Returns the exit, if any, and
    /// whether anything was called back.
    fn waitset_round(
        &self,
        timeout: Duration,
        on_wake: &mut impl FnMut(Wake) -> Flow,
    ) -> Result<(Option<LoopExit>, bool), BusError> {
        let polls = self.wait.polls();
        let mut failure = None;
        let mut handled = false;
        let mut observed = false;
        let attachments = &self.attachments;
        let callback = |id: WaitSetAttachmentId<ipc::Service>| {
            let Some((index, attachment)) = attachments
                .iter()
                .enumerate()
                .find(|(_, a)| a.guard.fired(&id))
            else {
                return CallbackProgression::Continue;
            };
            let source = SourceId(index);
            let wake = match attachment.kind {
                Kind::Data(port) => {
                    if attachment.guard.missed_deadline(&id) {
                        // Supervised only once the stream has started: before its first
                        // sample nothing can be late (the pipeline is still starting).
                        let Some(last) = port.last_received() else {
                            return CallbackProgression::Continue;
                        };
                        let received_in_time = attachment
                            .deadline
                            .is_some_and(|deadline| last.elapsed() < deadline);
                        if received_in_time {
                            return CallbackProgression::Continue;
                        }
                        attachment.missed.set(attachment.missed.get() + 1);
                        Wake::DeadlineMissed(source)
                    } else {
                        // Drain before calling back: an undrained listener keeps its file
                        // descriptor readable and the WaitSet would spin.
                        let pending = match drain_listener(port.listener(), port.event_name()) {
                            Ok(pending) => pending,
                            Err(e) => {
                                failure = Some(e);
                                return CallbackProgression::Stop;
                            }
                        };
                        if pending.new_publisher
                            && let Err(e) = port.attach()
                        {
                            failure = Some(e);
                            return CallbackProgression::Stop;
                        }
                        if !pending.samples {
                            return CallbackProgression::Continue;
                        }
                        if polls {
                            // Polling may have taken the samples before their notification
                            // came; then there is nothing to call back for.
                            let now = Instant::now();
                            if !observed {
                                if let Err(e) = self.observe_arrivals(now, false) {
                                    failure = Some(e);
                                    return CallbackProgression::Stop;
                                }
                                observed = true;
                            }
                            match port.attach() {
                                Ok(true) => self.count(|s| s.woken += 1),
                                Ok(false) => {
                                    self.count(|s| s.stale_notifications += 1);
                                    return CallbackProgression::Continue;
                                }
                                Err(e) => {
                                    failure = Some(e);
                                    return CallbackProgression::Stop;
                                }
                            }
                        } else {
                            self.count(|s| s.woken += 1);
                        }
                        Wake::Data(source)
                    }
                }
                Kind::Interval => Wake::Tick(source),
                Kind::Heartbeat(heartbeat) => {
                    heartbeat.publish_or_count();
                    return CallbackProgression::Continue;
                }
            };
            handled = true;
            let flow = on_wake(wake);
            if matches!(wake, Wake::Data(_)) {
                self.handled_data();
            }
            match flow {
                Flow::Continue => CallbackProgression::Continue,
                Flow::Stop => CallbackProgression::Stop,
            }
        };
        let has_data = self.data_attachments().next().is_some();
        let timeout = if has_data {
            timeout.min(LISTENER_SWEEP_MAX_SLEEP)
        } else {
            timeout
        };
        let result = self
            .waitset
            .wait_and_process_once_with_timeout(callback, timeout)
            .map_err(|e| BusError::WaitSet {
                operation: "waiting",
                source: Box::new(e),
            });
        self.last_round.set(Instant::now());
        match result? {
            WaitSetRunResult::TerminationRequest => {
                tracing::info!("termination requested (SIGINT/SIGTERM)");
                Ok((Some(LoopExit::TerminationRequested), handled))
            }
            WaitSetRunResult::StopRequest => match failure {
                Some(e) => Err(e),
                None => Ok((Some(LoopExit::Stopped), handled)),
            },
            // An interrupting signal: the next wait reports it if it asked for termination.
            WaitSetRunResult::Interrupt | WaitSetRunResult::AllEventsHandled => {
                let now = Instant::now();
                if !has_data
                    || now.saturating_duration_since(self.last_sweep.get()) < LISTENER_SWEEP_PERIOD
                {
                    return Ok((None, handled));
                }
                self.last_sweep.set(now);
                match self.sweep(on_wake)? {
                    (Flow::Continue, swept) => Ok((None, handled || swept)),
                    (Flow::Stop, _) => Ok((Some(LoopExit::Stopped), true)),
                }
            }
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Bus, BusConfig, remove_all};
    use ipc_types::{GyroSample, SampleHeader};

    fn gyro(sequence: u64) -> GyroSample {
        GyroSample {
            header: SampleHeader::new(sequence, sequence, SampleHeader::VALID),
            ..GyroSample::default()
        }
    }

    /// Whether `fd` becomes readable within `timeout`.
    fn readable(fd: i32, timeout: Duration) -> bool {
        let mut pfd = libc::pollfd {
            fd,
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        unsafe { libc::poll(&mut pfd, 1, timeout.as_millis() as libc::c_int) == 1 }
    }

    /// Puts a listener into the state iceoryx2's notifier/listener race leaves behind (see
    /// [`LISTENER_SWEEP_PERIOD`]): its wake-up datagram consumed while the shared state still
    /// says "notified". Further notifications then send nothing; the sweep must still deliver.
    #[test]
    fn the_sweep_delivers_samples_to_a_listener_whose_wake_up_was_lost() {
        let config = BusConfig::isolated();
        {
            let bus = Bus::open("deaf", &config).expect("bus");
            let subscriber = bus.subscriber::<GyroSample>().expect("subscriber");
            let publisher = bus.publisher::<GyroSample>().expect("publisher");
            // SAFETY: the listener outlives its descriptor's use here.
            let fd = unsafe {
                SubscriberPort::listener(&subscriber)
                    .file_descriptor()
                    .native_handle()
            };
            // Drop the publisher-created wake-up so that the socket starts empty.
            let _ = drain_listener(SubscriberPort::listener(&subscriber), "test");

            publisher.publish(&gyro(0)).expect("publish 0");
            assert!(
                readable(fd, Duration::from_secs(5)),
                "a first notification wakes the listener"
            );
            let mut byte = [0u8; 16];
            // SAFETY: reads at most 16 bytes into `byte`.
            let n =
                unsafe { libc::recv(fd, byte.as_mut_ptr().cast(), byte.len(), libc::MSG_DONTWAIT) };
            assert_eq!(n, 1, "the wake-up is one datagram");

            publisher.publish(&gyro(1)).expect("publish 1");
            // iceoryx2 0.10 behaviour behind the sweep: with the state still "notified", the
            // next notification sends no datagram (if this starts failing, iceoryx2 changed and
            // the sweep may be unnecessary).
            assert!(
                !readable(fd, Duration::from_millis(300)),
                "the listener stays deaf"
            );

            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
            let source = events.on_data(&subscriber).expect("attach");
            let mut received = Vec::new();
            let started = Instant::now();
            while received.len() < 2 && started.elapsed() < Duration::from_secs(10) {
                events
                    .run_once(Duration::from_secs(1), |wake| {
                        assert_eq!(wake, Wake::Data(source));
                        subscriber
                            .drain(|s| received.push(s.header.sequence))
                            .expect("drain");
                        Flow::Continue
                    })
                    .expect("run_once");
            }
            assert_eq!(received, vec![0, 1], "both samples delivered by the sweep");
            assert!(events.wait_stats().swept >= 1, "{:?}", events.wait_stats());
            assert_eq!(
                events.wait_stats().woken,
                0,
                "no wake-up came through the WaitSet"
            );
        }
        remove_all(&config).expect("remove_all");
    }
}
