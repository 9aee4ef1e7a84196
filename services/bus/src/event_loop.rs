//! The event loop of a pipeline process: an iceoryx2 WaitSet with subscribers' listeners,
//! intervals, deadlines and the heartbeat attached.

use std::cell::Cell;
use std::time::Duration;

use iceoryx2::prelude::*;
use iceoryx2::waitset::{WaitSetAttachmentError, WaitSetRunResult};
use ipc_types::Topic;

use crate::ports::{SubscriberPort, drain_listener};
use crate::{BusError, HeartbeatPublisher, TopicSubscriber};

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
    /// [`TopicSubscriber::drain`].
    Data(SourceId),
    /// An interval elapsed.
    Tick(SourceId),
    /// A subscriber attached with a deadline received nothing for the whole deadline. Repeats
    /// every deadline period for as long as nothing arrives.
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
}

/// Waits on subscribers, intervals and deadlines and calls back with the source that fired.
///
/// Never busy-waits: between wake-ups the thread sleeps in `epoll_wait` (iceoryx2 WaitSet),
/// and a data wake-up always drains the subscriber's listener before calling back, so a
/// notification can wake the loop only once.
pub struct EventLoop<'w, 'a> {
    waitset: &'w WaitSet<ipc::Service>,
    attachments: Vec<Attachment<'w, 'a>>,
}

impl<'w, 'a> EventLoop<'w, 'a> {
    /// An empty loop on `waiter`'s WaitSet.
    pub fn new(waiter: &'w Waiter) -> Self {
        Self {
            waitset: &waiter.waitset,
            attachments: Vec::new(),
        }
    }

    fn push(&mut self, guard: Guard<'w, 'a>, kind: Kind<'a>) -> SourceId {
        self.attachments.push(Attachment {
            guard,
            kind,
            missed: Cell::new(0),
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
    pub fn on_data_with_deadline<T: Topic>(
        &mut self,
        subscriber: &'a TopicSubscriber<T>,
        deadline: Duration,
    ) -> Result<SourceId, BusError> {
        let guard = self
            .waitset
            .attach_deadline(SubscriberPort::listener(subscriber), deadline)
            .map_err(Self::attach_error("attaching a subscriber with a deadline"))?;
        Ok(self.push(Guard::Listener(guard), Kind::Data(subscriber)))
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
        let mut failure = None;
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
                        Wake::Data(source)
                    }
                }
                Kind::Interval => Wake::Tick(source),
                Kind::Heartbeat(heartbeat) => {
                    heartbeat.publish_or_count();
                    return CallbackProgression::Continue;
                }
            };
            match on_wake(wake) {
                Flow::Continue => CallbackProgression::Continue,
                Flow::Stop => CallbackProgression::Stop,
            }
        };
        let result = self
            .waitset
            .wait_and_process_once_with_timeout(callback, timeout)
            .map_err(|e| BusError::WaitSet {
                operation: "waiting",
                source: Box::new(e),
            })?;
        match result {
            WaitSetRunResult::TerminationRequest => {
                tracing::info!("termination requested (SIGINT/SIGTERM)");
                Ok(Some(LoopExit::TerminationRequested))
            }
            WaitSetRunResult::StopRequest => match failure {
                Some(e) => Err(e),
                None => Ok(Some(LoopExit::Stopped)),
            },
            // An interrupting signal: the next wait reports it if it asked for termination.
            WaitSetRunResult::Interrupt | WaitSetRunResult::AllEventsHandled => Ok(None),
        }
    }
}
