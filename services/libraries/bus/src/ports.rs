//! Typed publisher and subscriber ports: one iceoryx2 publish/subscribe service per topic; a
//! publish rings the [doorbell](crate::doorbell) of every process subscribed to the topic.

use std::cell::Cell;
use std::fmt;
use std::rc::Rc;
use std::time::Instant;

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe;
use ipc_types::{Topic, TopicRole};

use crate::doorbell::{Bell, TopicBells};
use crate::{Bus, BusError, Delivery};

/// Options of a [`TopicSubscriber`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SubscriberOptions {
    /// Samples the subscriber's buffer holds (1 to [`crate::ServiceLimits::max_buffer_size`]).
    /// When it is full, the run's [`Delivery`] decides: the oldest is replaced, or the publisher
    /// waits.
    pub buffer_size: usize,
    /// Past samples (per publisher) delivered when the subscriber connects, up to
    /// [`crate::ServiceLimits::history_size`] and `buffer_size`. 0 by default: a lockstep
    /// process must not see a sample from before it joined.
    pub history: usize,
    /// Whether the subscriber may wake an [`crate::EventLoop`] (true by default). Publishing
    /// on the topic rings this process's doorbell only while the subscriber is attached to a
    /// loop ([`crate::EventLoop::on_data`]): a subscriber drained inside another source's
    /// callback or on a timer never wakes the process, since every ring that finds it asleep
    /// costs a wake-up. A [`polled`](Self::polled) subscriber cannot be attached at all.
    pub wake_on_publish: bool,
}

impl Default for SubscriberOptions {
    fn default() -> Self {
        Self {
            buffer_size: 16,
            history: 0,
            wake_on_publish: true,
        }
    }
}

impl SubscriberOptions {
    /// Options with `buffer_size` and no history.
    pub fn buffer(buffer_size: usize) -> Self {
        Self {
            buffer_size,
            ..Self::default()
        }
    }

    /// The same options for a subscriber that is drained on a timer, never woken for: its
    /// topic does not ring the doorbell, and [`crate::EventLoop::on_data`] refuses it.
    pub fn polled(self) -> Self {
        Self {
            wake_on_publish: false,
            ..self
        }
    }
}

/// The delivery mode of `T`'s topic: the run's, except for housekeeping topics (heartbeats,
/// health events), which always overflow ([`TopicRole::Housekeeping`] says why).
pub(crate) fn delivery_of<T: Topic>(bus: &Bus) -> Delivery {
    match T::ROLE {
        TopicRole::Housekeeping => Delivery::Overflow,
        TopicRole::Data | TopicRole::Shared => bus.config().delivery,
    }
}

/// The publisher slots of `T`'s service: few for a topic with one publisher in a run, since
/// every receive visits each slot.
pub(crate) fn max_publishers_of<T: Topic>(limits: &crate::ServiceLimits) -> usize {
    if T::ROLE.has_many_publishers() {
        limits.max_publishers
    } else {
        limits.max_data_publishers
    }
}

fn open_data_service<T: Topic>(
    bus: &Bus,
) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>, BusError> {
    let limits = bus.config().limits;
    bus.node()
        .service_builder(&Bus::service_name(T::NAME)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(delivery_of::<T>(bus) == Delivery::Overflow)
        .subscriber_max_buffer_size(limits.max_buffer_size)
        .history_size(limits.history_size)
        .max_publishers(max_publishers_of::<T>(&limits))
        .max_subscribers(limits.max_subscribers)
        .max_nodes(limits.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::Service {
            service: T::NAME.to_owned(),
            source: Box::new(e),
        })
}

/// Publishes samples of `T` on `T::NAME` and rings the doorbells of its subscribers after each.
pub struct TopicPublisher<T: Topic> {
    // Field order is drop order: ports before their services.
    publisher: Publisher<ipc::Service, T, ()>,
    data: publish_subscribe::PortFactory<ipc::Service, T, ()>,
    bells: TopicBells,
    lossless: bool,
    sent: Cell<u64>,
    undelivered: Cell<u64>,
}

impl<T: Topic> fmt::Debug for TopicPublisher<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("TopicPublisher")
            .field("topic", &T::NAME)
            .field("sent", &self.sent.get())
            .finish_non_exhaustive()
    }
}

impl<T: Topic> TopicPublisher<T> {
    pub(crate) fn create(bus: &Bus) -> Result<Self, BusError> {
        let data = open_data_service::<T>(bus)?;
        let strategy = match delivery_of::<T>(bus) {
            Delivery::Lossless => BackpressureStrategy::RetryUntilDelivered,
            Delivery::Overflow => BackpressureStrategy::DiscardData,
        };
        let publisher = data
            .publisher_builder()
            .backpressure_strategy(strategy)
            .create()
            .map_err(|e| BusError::Port {
                port: "publisher",
                service: T::NAME.to_owned(),
                source: Box::new(e),
            })?;
        let bells = bus.doorbells().topic(T::NAME)?;
        // Subscribers connect to a new publisher the next time they look at their samples:
        // wake them for that before the first sample (see `Delivery::Lossless`).
        bells.ring();
        Ok(Self {
            publisher,
            data,
            bells,
            lossless: delivery_of::<T>(bus) == Delivery::Lossless,
            sent: Cell::new(0),
            undelivered: Cell::new(0),
        })
    }

    /// Sends a copy of `sample` to every subscriber, then rings their doorbells. Returns the
    /// number of subscribers the sample was delivered to. Same as [`publish_with`](Self::publish_with)
    /// with `|slot| *slot = *sample`.
    pub fn publish(&self, sample: &T) -> Result<usize, BusError> {
        self.publish_with(|slot| *slot = *sample)
    }

    /// Loans a sample in shared memory (initialised with `T::default()`), lets `write` fill it
    /// in place, sends it to every subscriber and rings their doorbells (those that asked for
    /// this sample's time, [`TopicSubscriber::wake_from`]). Returns the number of
    /// subscribers the sample was delivered to.
    ///
    /// In [`Delivery::Lossless`] runs this blocks while an attached subscriber's buffer is full.
    /// A subscriber attaches to a publisher's connection the first time it reads after the
    /// publisher appeared (its doorbell is rung for that when the publisher is created); until
    /// then up to its buffer size of samples are queued for it, and iceoryx2 drops what does
    /// not fit rather than block on a reader that may never come. Such a drop is logged and
    /// counted in [`undelivered`](Self::undelivered). Start bursts only after a first sample
    /// was answered (lockstep does this by construction).
    pub fn publish_with(&self, write: impl FnOnce(&mut T)) -> Result<usize, BusError> {
        let io_error = |operation| {
            move |e: Box<dyn std::error::Error + Send + Sync>| BusError::Io {
                operation,
                service: T::NAME.to_owned(),
                source: e,
            }
        };
        let subscribers = if self.lossless {
            self.subscriber_count()
        } else {
            0
        };
        let mut sample = self
            .publisher
            .loan()
            .map_err(|e| io_error("loan")(Box::new(e)))?;
        write(sample.payload_mut());
        let sequence = sample.payload().header().sequence;
        let sample_time_ns = sample.payload().header().time_ns;
        let delivered = sample.send().map_err(|e| io_error("send")(Box::new(e)))?;
        self.sent.set(self.sent.get() + 1);
        if delivered < subscribers {
            let missed = (subscribers - delivered) as u64;
            if self.undelivered.get() == 0 {
                tracing::warn!(
                    topic = T::NAME,
                    sequence,
                    "lossless delivery: sample dropped for {missed} subscriber(s) that have not \
                     attached yet and whose buffer is full (further drops are only counted)"
                );
            }
            self.undelivered.set(self.undelivered.get() + missed);
        }
        self.bells.ring_for(sample_time_ns);
        Ok(delivered)
    }

    /// Samples published so far.
    pub fn sent(&self) -> u64 {
        self.sent.get()
    }

    /// In [`Delivery::Lossless`] runs: deliveries dropped because a subscriber had not attached
    /// yet (see [`publish`](Self::publish)). Always 0 in overflow runs.
    pub fn undelivered(&self) -> u64 {
        self.undelivered.get()
    }

    /// Subscribers currently registered on the topic (from any process).
    pub fn subscriber_count(&self) -> usize {
        self.data.dynamic_config().number_of_subscribers()
    }

    /// The topic name.
    pub fn topic(&self) -> &'static str {
        T::NAME
    }
}

/// Receives samples of `T` from `T::NAME`; every publish on the topic rings the doorbell of the
/// [`Bus`] it was created from, which that bus's [`crate::EventLoop`]s wait on.
pub struct TopicSubscriber<T: Topic> {
    subscriber: Subscriber<ipc::Service, T, ()>,
    data: publish_subscribe::PortFactory<ipc::Service, T, ()>,
    bell: Rc<Bell>,
    bells: TopicBells,
    /// It may be attached to an event loop ([`SubscriberOptions::wake_on_publish`]).
    wakes: bool,
    /// Event loops it is attached to: while there is one, publishes ring `bell`.
    ringing: Cell<u32>,
    received: Cell<u64>,
    last_received: Cell<Option<Instant>>,
}

impl<T: Topic> fmt::Debug for TopicSubscriber<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("TopicSubscriber")
            .field("topic", &T::NAME)
            .field("received", &self.received.get())
            .finish_non_exhaustive()
    }
}

impl<T: Topic> TopicSubscriber<T> {
    pub(crate) fn create(bus: &Bus, options: SubscriberOptions) -> Result<Self, BusError> {
        let limits = bus.config().limits;
        let port_error = |port, service: &str, source| BusError::Port {
            port,
            service: service.to_owned(),
            source,
        };
        if options.buffer_size == 0
            || options.buffer_size > limits.max_buffer_size
            || options.history > options.buffer_size.min(limits.history_size)
        {
            return Err(BusError::Config {
                key: "SubscriberOptions",
                value: format!("{options:?}"),
                reason: format!(
                    "buffer_size must be 1 to {} and history at most min(buffer_size, {})",
                    limits.max_buffer_size, limits.history_size
                ),
            });
        }
        let data = open_data_service::<T>(bus)?;
        let subscriber = data
            .subscriber_builder()
            .buffer_size(options.buffer_size)
            .history_request(options.history)
            .create()
            .map_err(|e| port_error("subscriber", T::NAME, Box::new(e)))?;
        let bells = bus.doorbells().topic(T::NAME)?;
        let bell = bus.bell().clone();
        let this = Self {
            subscriber,
            data,
            bell,
            bells,
            wakes: options.wake_on_publish,
            ringing: Cell::new(0),
            received: Cell::new(0),
            last_received: Cell::new(None),
        };
        this.attach()?;
        Ok(this)
    }

    /// Calls `visit` with every pending sample, oldest first, by reference into shared memory
    /// (no copy); each sample is released when `visit` returns. Returns the number visited.
    ///
    /// A sample published while draining is either visited now or rings the doorbell after the
    /// event loop read it, which wakes the loop again: none is left behind without a wake-up.
    pub fn drain(&self, mut visit: impl FnMut(&T)) -> Result<usize, BusError> {
        let mut count = 0;
        while self.receive_one(&mut visit)? {
            count += 1;
        }
        Ok(count)
    }

    /// Like [`drain`](Self::drain), appending the samples to `out`.
    pub fn drain_into(&self, out: &mut Vec<T>) -> Result<usize, BusError> {
        self.drain(|sample| out.push(*sample))
    }

    /// Drains everything pending and returns the newest sample, if any.
    pub fn latest(&self) -> Result<Option<T>, BusError> {
        let mut last = None;
        self.drain(|sample| last = Some(*sample))?;
        Ok(last)
    }

    /// Takes a copy of one pending sample. Inside an [`crate::EventLoop`] callback prefer
    /// [`drain`](Self::drain): samples left in the buffer are only revisited at the next
    /// wake-up of this source.
    pub fn try_receive(&self) -> Result<Option<T>, BusError> {
        let mut value = None;
        self.receive_one(&mut |sample: &T| value = Some(*sample))?;
        Ok(value)
    }

    /// Samples received so far.
    pub fn received(&self) -> u64 {
        self.received.get()
    }

    /// When the latest sample was taken (by `drain`, `latest` or `try_receive`), if ever.
    pub fn last_received(&self) -> Option<Instant> {
        self.last_received.get()
    }

    /// From now on, publishes wake this process only for samples stamped (header `time_ns`)
    /// at or after `time_ns`; earlier samples are still delivered and taken with the next
    /// wake-up. `0` (the default) wakes for every sample. For a consumer that needs only some
    /// samples of a stream to act — a 2.5-Hz sensor model on the 10-Hz truth — the others
    /// cost it no wake-up. Applies to every subscriber of the topic on this bus, and is reset
    /// when the last of them stops waking its loop.
    ///
    /// Drain once more after calling this: a sample stamped at or after `time_ns` that was
    /// published just before may not have rung, and the loop calls back only for rings.
    pub fn wake_from(&self, time_ns: u64) {
        self.bell.ring_from(&self.bells, time_ns);
    }

    /// Publishers currently registered on the topic (from any process).
    pub fn publisher_count(&self) -> usize {
        self.data.dynamic_config().number_of_publishers()
    }

    /// The topic name.
    pub fn topic(&self) -> &'static str {
        T::NAME
    }

    /// Attaches to the connections of all publishers present (iceoryx2 does this on every
    /// receive; `has_samples` does it without taking a sample).
    fn attach(&self) -> Result<bool, BusError> {
        self.subscriber.has_samples().map_err(|e| BusError::Io {
            operation: "connecting to publishers",
            service: T::NAME.to_owned(),
            source: Box::new(e),
        })
    }

    /// Visits one pending sample in place; false if there was none.
    fn receive_one(&self, visit: &mut impl FnMut(&T)) -> Result<bool, BusError> {
        match self.subscriber.receive() {
            Ok(Some(sample)) => {
                self.received.set(self.received.get() + 1);
                self.last_received.set(Some(Instant::now()));
                visit(sample.payload());
                Ok(true)
            }
            Ok(None) => Ok(false),
            Err(e) => Err(BusError::Io {
                operation: "receive",
                service: T::NAME.to_owned(),
                source: Box::new(e),
            }),
        }
    }
}

impl<T: Topic> Drop for TopicSubscriber<T> {
    fn drop(&mut self) {
        // Loops borrow their subscribers and so end first; this only guards the table.
        for _ in 0..self.ringing.get() {
            self.bell.unsubscribe(&self.bells);
        }
    }
}

/// The type-erased view of a [`TopicSubscriber`] that the event loop needs.
pub(crate) trait SubscriberPort {
    /// The doorbell its publishers ring, if they ring one ([`SubscriberOptions::polled`]).
    fn bell(&self) -> Option<&Rc<Bell>>;
    fn topic(&self) -> &'static str;
    /// Connects to new publishers; whether samples are pending.
    fn attach(&self) -> Result<bool, BusError>;
    /// An event loop waits for it: publishes ring its doorbell from now on.
    fn start_ringing(&self);
    /// Undoes one [`start_ringing`](Self::start_ringing) (the loop has ended).
    fn stop_ringing(&self);
    fn last_received(&self) -> Option<Instant>;
}

impl<T: Topic> SubscriberPort for TopicSubscriber<T> {
    fn bell(&self) -> Option<&Rc<Bell>> {
        self.wakes.then_some(&self.bell)
    }
    fn topic(&self) -> &'static str {
        T::NAME
    }
    fn attach(&self) -> Result<bool, BusError> {
        TopicSubscriber::attach(self)
    }
    fn start_ringing(&self) {
        self.ringing.set(self.ringing.get() + 1);
        self.bell.subscribe(&self.bells);
    }
    fn stop_ringing(&self) {
        if self.ringing.get() > 0 {
            self.ringing.set(self.ringing.get() - 1);
            self.bell.unsubscribe(&self.bells);
        }
    }
    fn last_received(&self) -> Option<Instant> {
        TopicSubscriber::last_received(self)
    }
}
