//! The event loop's wait strategies deliver what the blocking loop delivers: every sample, in
//! order, one data wake-up per arrival with samples to read, deadlines only when nothing came,
//! and termination requests while polling. Each test uses its own `BusConfig::isolated()`.
//!
//! Time bounds below only keep a broken test from hanging; no test asserts a latency.

use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use ipc_types::{GyroSample, InclinometerSample, SampleHeader, WaitStrategy};
use testbed_bus::{
    Bus, BusConfig, BusError, Delivery, EventLoop, Flow, LoopExit, TopicPublisher, WaitFromEnv,
    Waiter, Wake, remove_all,
};

const HANG_GUARD: Duration = Duration::from_secs(30);

fn gyro(sequence: u64) -> GyroSample {
    GyroSample {
        header: SampleHeader::new(sequence * 100_000_000, sequence, SampleHeader::VALID),
        ..GyroSample::default()
    }
}

/// Publishes from its own thread (ports are not `Send`) once `start` is received.
fn publisher_thread(
    config: &BusConfig,
    publish: impl FnOnce(&TopicPublisher<GyroSample>) + Send + 'static,
) -> (mpsc::Sender<()>, thread::JoinHandle<Result<(), BusError>>) {
    let config = config.clone();
    let (start_tx, start_rx) = mpsc::channel::<()>();
    let (ready_tx, ready_rx) = mpsc::channel::<()>();
    let handle = thread::spawn(move || {
        let bus = Bus::open("publisher", &config)?;
        let publisher = bus.publisher::<GyroSample>()?;
        let _ = ready_tx.send(());
        if start_rx.recv_timeout(HANG_GUARD).is_ok() {
            publish(&publisher);
            // Keep the ports until the receiver has read everything.
            let _ = start_rx.recv_timeout(HANG_GUARD);
        }
        Ok(())
    });
    // Return once the publisher exists and has rung its start-up ring, however slowly a loaded
    // host runs the thread: a caller's next look then sees that ring as already rung. (A thread
    // that failed drops the sender; its error comes with `join`.)
    let _ = ready_rx.recv_timeout(HANG_GUARD);
    (start_tx, handle)
}

const STRATEGIES: [WaitStrategy; 3] = [
    WaitStrategy::Block,
    WaitStrategy::SpinAfterWake {
        spin: Duration::from_micros(300),
    },
    WaitStrategy::Anticipate {
        lead: Duration::from_micros(500),
        late: Duration::from_micros(500),
    },
];

#[test]
fn every_strategy_delivers_every_sample_in_order_without_empty_wakes() {
    const N: u64 = 200;
    for strategy in STRATEGIES {
        let config = BusConfig::isolated().with_delivery(Delivery::Lossless);
        {
            let bus = Bus::open("subscriber", &config).expect("bus");
            let sub = bus.subscriber::<GyroSample>().expect("subscriber");
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::with_wait_strategy(&waiter, strategy);
            assert_eq!(events.wait_strategy(), strategy);
            let on_gyro = events
                .on_data_with_deadline(&sub, Duration::from_millis(100))
                .expect("attach");
            let (start, handle) = publisher_thread(&config, |publisher| {
                // A periodic source with a burst now and then.
                for i in 0..N {
                    publisher.publish(&gyro(i)).expect("publish");
                    if i % 10 != 9 {
                        thread::sleep(Duration::from_millis(2));
                    }
                }
            });
            start.send(()).expect("start");
            let begin = Instant::now();
            let (mut next, mut wakes) = (0, 0_u64);
            while next < N {
                assert!(
                    begin.elapsed() < HANG_GUARD,
                    "{strategy}: timed out at {next}"
                );
                let exit = events
                    .run_once(Duration::from_millis(100), |wake| {
                        assert_eq!(wake, Wake::Data(on_gyro), "{strategy}: {wake:?}");
                        wakes += 1;
                        let n = sub
                            .drain(|s| {
                                assert_eq!(
                                    s.header.sequence, next,
                                    "{strategy}: lost or reordered"
                                );
                                next += 1;
                            })
                            .expect("drain");
                        if strategy.polls() {
                            // Polling strategies call back only when there is something to read.
                            assert!(n > 0, "{strategy}: a data wake-up without data");
                        }
                        Flow::Continue
                    })
                    .expect("event loop");
                assert_eq!(exit, None);
            }
            let stats = events.wait_stats();
            assert_eq!(stats.woken + stats.polled, wakes, "{strategy}: {stats:?}");
            if !strategy.polls() {
                assert_eq!(stats.polled, 0);
            }
            assert_eq!(events.missed_deadlines(on_gyro), 0, "{strategy}");
            println!("{strategy}: {wakes} wake-ups for {N} samples, {stats:?}");
            drop(start);
            handle.join().expect("thread").expect("publisher");
        }
        remove_all(&config).expect("remove_all");
    }
}

#[test]
fn polling_loops_still_serve_intervals_and_report_missed_deadlines() {
    for strategy in &STRATEGIES[1..] {
        let config = BusConfig::isolated();
        {
            let bus = Bus::open("watchdog", &config).expect("bus");
            let sub = bus.subscriber::<GyroSample>().expect("subscriber");
            let publisher = bus.publisher::<GyroSample>().expect("publisher");
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::with_wait_strategy(&waiter, *strategy);
            let on_gyro = events
                .on_data_with_deadline(&sub, Duration::from_millis(40))
                .expect("attach");
            let tick = events
                .on_interval(Duration::from_millis(15))
                .expect("interval");
            // Teach the anticipating loop a period, then stop publishing.
            let (mut ticks, mut missed, mut data) = (0, 0, 0);
            let begin = Instant::now();
            let mut published = 0;
            while missed < 2 || ticks < 5 {
                assert!(begin.elapsed() < HANG_GUARD, "{strategy}: timed out");
                if published < 5 {
                    publisher.publish(&gyro(published)).expect("publish");
                    published += 1;
                }
                events
                    .run_once(Duration::from_millis(5), |wake| {
                        match wake {
                            Wake::Data(s) if s == on_gyro => {
                                data += sub.drain(|_| {}).expect("drain");
                            }
                            Wake::DeadlineMissed(s) if s == on_gyro => missed += 1,
                            Wake::Tick(s) if s == tick => ticks += 1,
                            other => panic!("{strategy}: unexpected {other:?}"),
                        }
                        Flow::Continue
                    })
                    .expect("event loop");
            }
            assert_eq!(data, 5, "{strategy}");
            assert_eq!(events.missed_deadlines(on_gyro), missed, "{strategy}");
        }
        remove_all(&config).expect("remove_all");
    }
}

#[test]
fn a_callback_stops_a_polling_loop() {
    for strategy in &STRATEGIES[1..] {
        let config = BusConfig::isolated();
        {
            let bus = Bus::open("stopper", &config).expect("bus");
            let sub = bus.subscriber::<GyroSample>().expect("subscriber");
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::with_wait_strategy(&waiter, *strategy);
            events.on_data(&sub).expect("attach");
            let (start, handle) = publisher_thread(&config, |publisher| {
                for i in 0..50 {
                    publisher.publish(&gyro(i)).expect("publish");
                    thread::sleep(Duration::from_millis(1));
                }
            });
            start.send(()).expect("start");
            let mut seen = 0;
            let exit = events
                .run(|_| {
                    seen += sub.drain(|_| {}).expect("drain");
                    if seen >= 20 {
                        Flow::Stop
                    } else {
                        Flow::Continue
                    }
                })
                .expect("event loop");
            assert_eq!(exit, LoopExit::Stopped, "{strategy}");
            drop(start);
            handle.join().expect("thread").expect("publisher");
        }
        remove_all(&config).expect("remove_all");
    }
}

#[test]
fn the_environment_chooses_the_strategy_and_bad_values_are_refused_by_name() {
    let lookup = |value: &'static str| {
        move |key: &str| (key == ipc_types::ENV_WAIT).then(|| value.to_owned())
    };
    let config = BusConfig::from_lookup(lookup("anticipate:100,200")).expect("valid");
    assert_eq!(config.delivery, Delivery::Overflow);
    assert_eq!(
        WaitStrategy::from_lookup(lookup("anticipate:100,200")).unwrap(),
        WaitStrategy::Anticipate {
            lead: Duration::from_micros(100),
            late: Duration::from_micros(200)
        }
    );
    let err = BusConfig::from_lookup(lookup("fast")).expect_err("invalid");
    let msg = err.to_string();
    assert!(
        msg.contains(ipc_types::ENV_WAIT) && msg.contains("fast"),
        "{msg}"
    );
}

#[test]
fn a_sample_taken_outside_its_own_wake_up_counts_for_its_deadline() {
    // The binaries drain every subscriber on any wake-up, and polling takes samples before
    // their notification is seen: the WaitSet's deadline timer then never sees the listener
    // fire, but the subscriber did receive. That is not a missed deadline.
    for strategy in STRATEGIES {
        let config = BusConfig::isolated();
        {
            let bus = Bus::open("drainer", &config).expect("bus");
            let sub = bus.subscriber::<GyroSample>().expect("subscriber");
            let publisher = bus.publisher::<GyroSample>().expect("publisher");
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::with_wait_strategy(&waiter, strategy);
            let on_gyro = events
                .on_data_with_deadline(&sub, Duration::from_millis(50))
                .expect("attach");
            let begin = Instant::now();
            let mut i = 0;
            while begin.elapsed() < Duration::from_millis(300) {
                // Published and taken (notification included) outside the loop's wake-ups.
                publisher.publish(&gyro(i)).expect("publish");
                assert_eq!(sub.drain(|_| {}).expect("drain"), 1);
                i += 1;
                events
                    .run_once(Duration::from_millis(10), |wake| {
                        panic!("{strategy}: nothing should wake the loop, got {wake:?}")
                    })
                    .expect("event loop");
            }
            assert_eq!(events.missed_deadlines(on_gyro), 0, "{strategy}");
            // Nothing more arrives: the miss is reported.
            let mut missed = false;
            while !missed {
                assert!(begin.elapsed() < HANG_GUARD, "{strategy}: no miss reported");
                events
                    .run_once(Duration::from_millis(10), |wake| {
                        assert_eq!(wake, Wake::DeadlineMissed(on_gyro), "{strategy}");
                        missed = true;
                        Flow::Continue
                    })
                    .expect("event loop");
            }
        }
        remove_all(&config).expect("remove_all");
    }
}

#[test]
fn a_deadline_is_supervised_only_once_its_stream_has_started() {
    // While a pipeline starts, its streams begin one after another: a process cannot be late
    // for a stream that has delivered nothing yet (the paced pipeline's controller counted
    // such start-up "misses" in ControllerStatus.deadline_misses). From the first sample on,
    // a silence longer than the deadline is a miss.
    const DEADLINE: Duration = Duration::from_millis(30);
    for strategy in STRATEGIES {
        let config = BusConfig::isolated();
        {
            let bus = Bus::open("late-starter", &config).expect("bus");
            let sub = bus.subscriber::<GyroSample>().expect("subscriber");
            let publisher = bus.publisher::<GyroSample>().expect("publisher");
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::with_wait_strategy(&waiter, strategy);
            let on_gyro = events
                .on_data_with_deadline(&sub, DEADLINE)
                .expect("attach");
            // Five deadlines without a first sample: nothing is late.
            let begin = Instant::now();
            while begin.elapsed() < 5 * DEADLINE {
                events
                    .run_once(Duration::from_millis(10), |wake| {
                        panic!("{strategy}: nothing should wake the loop before the stream starts, got {wake:?}")
                    })
                    .expect("event loop");
            }
            assert_eq!(events.missed_deadlines(on_gyro), 0, "{strategy}");
            // The stream starts, then falls silent: that is a miss.
            publisher.publish(&gyro(0)).expect("publish");
            let (mut data, mut missed) = (0, 0);
            let begin = Instant::now();
            while missed == 0 {
                assert!(begin.elapsed() < HANG_GUARD, "{strategy}: no miss reported");
                events
                    .run_once(Duration::from_millis(10), |wake| {
                        match wake {
                            Wake::Data(s) if s == on_gyro => {
                                data += sub.drain(|_| {}).expect("drain")
                            }
                            Wake::DeadlineMissed(s) if s == on_gyro => missed += 1,
                            other => panic!("{strategy}: unexpected {other:?}"),
                        }
                        Flow::Continue
                    })
                    .expect("event loop");
            }
            assert_eq!(data, 1, "{strategy}");
            assert!(
                begin.elapsed() >= DEADLINE,
                "{strategy}: a miss {:?} after the first sample",
                begin.elapsed()
            );
            assert_eq!(events.missed_deadlines(on_gyro), 1, "{strategy}");
        }
        remove_all(&config).expect("remove_all");
    }
}

#[test]
fn draining_an_empty_subscriber_leaves_no_sample_behind() {
    // `drain` skips the listener when nothing is pending; every sample still arrives, and a
    // sample published after such a drain still wakes the loop.
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("drainer", &config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let publisher = bus.publisher::<GyroSample>().expect("publisher");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        let on_gyro = events.on_data(&sub).expect("attach");
        assert_eq!(sub.drain(|_| {}).expect("drain"), 0);
        for i in 0..3 {
            publisher.publish(&gyro(i)).expect("publish");
            let mut got = Vec::new();
            let begin = Instant::now();
            while got.is_empty() {
                assert!(
                    begin.elapsed() < HANG_GUARD,
                    "sample {i} never woke the loop"
                );
                events
                    .run_once(Duration::from_millis(100), |wake| {
                        assert_eq!(wake, Wake::Data(on_gyro));
                        sub.drain_into(&mut got).expect("drain");
                        Flow::Continue
                    })
                    .expect("event loop");
            }
            assert_eq!(got, vec![gyro(i)]);
            assert_eq!(sub.drain(|_| {}).expect("drain"), 0);
        }
    }
    remove_all(&config).expect("remove_all");
}

/// CPU time of the calling thread.
fn thread_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: writes one timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

#[test]
fn samples_a_callback_leaves_pending_neither_repeat_nor_make_the_loop_spin() {
    // A callback that does not drain: its samples are not news until the next ring, and a
    // deadline that runs out while they wait is not a miss (they did arrive). The loop must
    // sleep meanwhile, not poll its overdue deadline in a tight loop.
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("lazy", &config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let publisher = bus.publisher::<GyroSample>().expect("publisher");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        let on_gyro = events
            .on_data_with_deadline(&sub, Duration::from_millis(20))
            .expect("attach");
        // One sample taken (the deadline is supervised from then on), one left pending.
        publisher.publish(&gyro(0)).expect("publish");
        assert_eq!(sub.drain(|_| {}).expect("drain"), 1);
        publisher.publish(&gyro(1)).expect("publish");
        let (mut data, mut misses) = (0, 0);
        let cpu_before = thread_cpu();
        let started = Instant::now();
        while started.elapsed() < Duration::from_millis(300) {
            events
                .run_once(Duration::from_millis(50), |wake| {
                    match wake {
                        Wake::Data(_) => data += 1,
                        Wake::DeadlineMissed(_) => misses += 1,
                        Wake::Tick(_) => {}
                    }
                    Flow::Continue
                })
                .expect("event loop");
        }
        let cpu = thread_cpu() - cpu_before;
        assert_eq!(
            data, 1,
            "the pending sample is called back once, for its ring"
        );
        assert_eq!(misses, 0);
        assert_eq!(events.missed_deadlines(on_gyro), 0);
        // Sleeping, the loop uses well under a tenth of the 300 ms; spinning it would use them.
        assert!(cpu < Duration::from_millis(30), "{cpu:?} of CPU in 300 ms");
    }
    remove_all(&config).expect("remove_all");
}

#[test]
fn only_a_subscriber_a_loop_waits_for_wakes_the_process() {
    // A subscriber drained inside another source's callback (a gateway's commands, the
    // plant's commands in a paced run) must not wake the process each time its topic is
    // published: each such wake-up finds nothing to call back and only costs CPU.
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("consumer", &config).expect("bus");
        let waited = bus.subscriber::<GyroSample>().expect("gyro subscriber");
        let drained_along = bus
            .subscriber_with::<InclinometerSample>(testbed_bus::SubscriberOptions::buffer(32))
            .expect("inclinometer subscriber");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        let on_gyro = events.on_data(&waited).expect("attach");

        let publisher_config = config.clone();
        let (ready_tx, ready_rx) = mpsc::channel::<()>();
        let (ports_tx, ports_rx) = mpsc::channel::<()>();
        let publisher = thread::spawn(move || -> Result<(), BusError> {
            let bus = Bus::open("publisher", &publisher_config)?;
            let inclinometer = bus.publisher::<InclinometerSample>()?;
            let gyro_publisher = bus.publisher::<GyroSample>()?;
            let _ = ports_tx.send(());
            let _ = ready_rx.recv_timeout(HANG_GUARD);
            // Apart enough that the consumer is asleep for each.
            for i in 0..20 {
                inclinometer.publish(&InclinometerSample {
                    header: SampleHeader::new(i, i, SampleHeader::VALID),
                    ..InclinometerSample::default()
                })?;
                thread::sleep(Duration::from_millis(5));
            }
            gyro_publisher.publish(&gyro(1))?;
            let _ = ready_rx.recv_timeout(HANG_GUARD);
            Ok(())
        });
        // A new publisher rings its topic's waiting subscribers (they connect to it): the
        // ports exist before the loop first looks, so that ring is not a wake-up.
        ports_rx.recv_timeout(HANG_GUARD).expect("publisher ports");
        ready_tx.send(()).expect("start");
        let (mut gyros, mut inclinations) = (0, 0);
        let begin = Instant::now();
        while gyros == 0 {
            assert!(
                begin.elapsed() < HANG_GUARD,
                "the gyro sample never woke the loop"
            );
            events
                .run_once(Duration::from_secs(1), |wake| {
                    assert_eq!(wake, Wake::Data(on_gyro));
                    gyros += waited.drain(|_| {}).expect("drain gyro");
                    inclinations += drained_along.drain(|_| {}).expect("drain inclinometer");
                    Flow::Continue
                })
                .expect("event loop");
        }
        let _ = ready_tx.send(());
        publisher
            .join()
            .expect("publisher thread")
            .expect("publisher");
        assert_eq!((gyros, inclinations), (1, 20), "every sample is taken");
        let stats = events.wait_stats();
        assert_eq!(
            (stats.woken, stats.stale_notifications),
            (1, 0),
            "one wake-up, for the gyro; none for the 20 inclinometer samples: {stats:?}"
        );
    }
    remove_all(&config).expect("remove_all");
}

/// Watches heartbeats from its own thread and bus node (a polled subscriber looked at every
/// 2 ms) until told to stop, and publishes a gyro sample every 20 ms for its first
/// `samples_for`. The thread returns the times it found new heartbeats.
fn heartbeat_watcher(
    config: &BusConfig,
    samples_for: Duration,
) -> (
    mpsc::Sender<()>,
    thread::JoinHandle<Result<Vec<Instant>, BusError>>,
) {
    let config = config.clone();
    let (done_tx, done_rx) = mpsc::channel::<()>();
    let watcher = thread::spawn(move || -> Result<Vec<Instant>, BusError> {
        let bus = Bus::open("watcher", &config)?;
        let heartbeats = bus.subscriber_with::<ipc_types::Heartbeat>(
            testbed_bus::SubscriberOptions::buffer(64).polled(),
        )?;
        let publisher = bus.publisher::<GyroSample>()?;
        let mut seen = Vec::new();
        let begin = Instant::now();
        let mut next_sample = begin;
        let mut i = 0;
        while done_rx.try_recv().is_err() && begin.elapsed() < HANG_GUARD {
            let now = Instant::now();
            if now < begin + samples_for && now >= next_sample {
                i += 1;
                publisher.publish(&gyro(i))?;
                next_sample += Duration::from_millis(20);
            }
            if heartbeats.drain(|_| {})? > 0 {
                seen.push(now);
            }
            thread::sleep(Duration::from_millis(2));
        }
        Ok(seen)
    });
    (done_tx, watcher)
}

/// No gap between the heartbeats `seen` longer than 1.5 `period`s plus 40 ms of scheduling
/// allowance.
fn assert_at_most_one_and_a_half_periods_apart(seen: &[Instant], period: Duration) {
    let longest = seen
        .windows(2)
        .map(|w| w[1] - w[0])
        .max()
        .expect("two heartbeats");
    assert!(
        longest <= period.mul_f64(1.0 + testbed_bus::HEARTBEAT_SLACK) + Duration::from_millis(40),
        "longest gap between heartbeats {longest:?} (period {period:?})"
    );
}

#[test]
fn heartbeats_ride_on_other_wake_ups_and_still_come_when_nothing_else_does() {
    // A heartbeat goes out with the first wake-up from HEARTBEAT_EARLY of a period before it
    // is due, and on its own HEARTBEAT_SLACK of a period after when nothing wakes the loop (the
    // next is due a period after it went out). Bound checked: no gap between heartbeats
    // longer than 1.5 periods plus 40 ms of scheduling allowance, with data every 20 ms (first
    // half) and with none (second half).
    const PERIOD: Duration = Duration::from_millis(100);
    const RUN: Duration = Duration::from_millis(1600);
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("beating", &config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let heartbeat = bus.heartbeat(PERIOD).expect("heartbeat");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        events.on_data(&sub).expect("attach");
        events.with_heartbeat(&heartbeat).expect("heartbeat");

        let (done_tx, watcher) = heartbeat_watcher(&config, RUN / 2);
        let begin = Instant::now();
        while begin.elapsed() < RUN {
            events
                .run_once(RUN, |_| {
                    sub.drain(|_| {}).expect("drain");
                    Flow::Continue
                })
                .expect("event loop");
        }
        done_tx.send(()).expect("stop the watcher");
        let seen = watcher.join().expect("watcher thread").expect("watcher");
        assert!(seen.len() >= 8, "{} heartbeats in {RUN:?}", seen.len());
        assert_at_most_one_and_a_half_periods_apart(&seen, PERIOD);
    }
    remove_all(&config).expect("remove_all");
}

/// Voluntary context switches of the calling thread so far (each sleep of the loop is one).
fn own_sleeps() -> u64 {
    let status = std::fs::read_to_string("/proc/thread-self/status").expect("thread status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("voluntary_ctxt_switches:"))
        .and_then(|v| v.trim().parse().ok())
        .expect("voluntary_ctxt_switches in /proc/thread-self/status")
}

#[test]
fn a_heartbeat_rides_on_every_tick_of_an_interval_a_little_under_one_and_a_half_periods() {
    // The runtime's QUIET_PERIOD (a paced logger, an unwatched ground link) against its
    // heartbeat period. With the heartbeat due on a fixed grid, as before, the loop slept 19
    // times for 11 ticks.
    heartbeat_rides_on_every_tick(1.4);
}

#[test]
fn a_heartbeat_rides_on_every_wake_up_four_fifths_of_a_period_apart() {
    // A 2.5-Hz sensor model against the pipeline's 500 ms heartbeat. With the heartbeat due a
    // period after it went out and sent only from then on, the loop woke for it alone every
    // other tick.
    heartbeat_rides_on_every_tick(0.8);
}

#[test]
fn a_quiet_interval_of_the_pipeline_wakes_its_loop_once_per_tick() {
    // The pipeline's own numbers: heartbeats every 500 ms, the logger's and the unwatched ground
    // link's 700-ms interval (1.4 periods), over 3.5 s. The loop also caps each sleep
    // (MAX_SLEEP, once 500 ms): that cap must not wake it between two ticks either.
    heartbeat_rides_on_every_tick_of(Duration::from_millis(500), 1.4, 7);
}

/// A loop with nothing but an interval of `periods` heartbeat periods sends its heartbeat with
/// every tick and never wakes for it alone. Checked: the loop's thread sleeps at most twice
/// more than it ticks, and heartbeats still come at most 1.5 periods apart, plus 40 ms of
/// scheduling allowance.
fn heartbeat_rides_on_every_tick(periods: f64) {
    heartbeat_rides_on_every_tick_of(Duration::from_millis(100), periods, 15);
}

/// [`heartbeat_rides_on_every_tick`] with a heartbeat `period`, for `run_periods` periods.
fn heartbeat_rides_on_every_tick_of(period: Duration, periods: f64, run_periods: u32) {
    let run = period * run_periods;
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("quiet", &config).expect("bus");
        let heartbeat = bus.heartbeat(period).expect("heartbeat");
        let interval = std::cell::Cell::new(period.mul_f64(periods));
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        events.on_variable_interval(&interval).expect("interval");
        events.with_heartbeat(&heartbeat).expect("heartbeat");

        let (done_tx, watcher) = heartbeat_watcher(&config, Duration::ZERO);
        let begin = Instant::now();
        let sleeps_before = own_sleeps();
        let mut ticks = 0u64;
        while begin.elapsed() < run {
            events
                .run_once(run, |wake| {
                    if matches!(wake, Wake::Tick(_)) {
                        ticks += 1;
                    }
                    Flow::Continue
                })
                .expect("event loop");
        }
        let sleeps = own_sleeps() - sleeps_before;
        done_tx.send(()).expect("stop the watcher");
        let seen = watcher.join().expect("watcher thread").expect("watcher");
        let expected = run.as_secs_f64() / period.mul_f64(periods).as_secs_f64();
        assert!(ticks as f64 >= expected - 2.0, "{ticks} ticks in {run:?}");
        assert!(
            sleeps <= ticks + 2,
            "{sleeps} sleeps for {ticks} ticks: the loop woke between ticks (its heartbeat alone, its sleep cap)"
        );
        assert!(
            seen.len() as u64 >= ticks - 1,
            "{} heartbeats, {ticks} ticks",
            seen.len()
        );
        assert_at_most_one_and_a_half_periods_apart(&seen, period);
    }
    remove_all(&config).expect("remove_all");
}

/// Publishes gyro samples 1 to `count` from another thread, 50 ms apart (late enough that the
/// loop has had its look and is asleep for each: a sample already there at a loop's look
/// before it sleeps is taken at once), and runs `events` until `sub` has taken them all. Each
/// data wake-up drains `sub` into one batch and then calls `after_batch`. Returns the batches
/// and the data wake-ups they took.
fn take_slow_samples(
    config: &BusConfig,
    events: &mut EventLoop<'_, '_>,
    sub: &testbed_bus::TopicSubscriber<GyroSample>,
    source: testbed_bus::SourceId,
    count: u64,
    mut after_batch: impl FnMut(),
) -> (Vec<Vec<u64>>, u64) {
    let (start, publisher) = publisher_thread(config, move |publisher| {
        for i in 1..=count {
            thread::sleep(Duration::from_millis(50));
            publisher.publish(&gyro(i)).expect("publish");
        }
    });
    // The publisher's own start-up ring (subscribers connect to a new publisher) came before
    // `publisher_thread` returned: this first look attaches to the publisher and leaves that
    // ring behind.
    events
        .run_once(Duration::ZERO, |_| Flow::Continue)
        .expect("first look");
    let woken_before = events.wait_stats().woken;
    start.send(()).expect("start");
    let mut batches: Vec<Vec<u64>> = Vec::new();
    let begin = Instant::now();
    while batches.iter().map(Vec::len).sum::<usize>() < count as usize {
        assert!(begin.elapsed() < HANG_GUARD, "a sample never woke the loop");
        events
            .run_once(Duration::from_secs(1), |wake| {
                assert_eq!(wake, Wake::Data(source));
                let mut batch = Vec::new();
                sub.drain(|s| batch.push(s.header.sequence)).expect("drain");
                batches.push(batch);
                after_batch();
                Flow::Continue
            })
            .expect("event loop");
    }
    let _ = start.send(());
    publisher
        .join()
        .expect("publisher thread")
        .expect("publisher");
    (batches, events.wait_stats().woken - woken_before)
}

#[test]
fn a_subscriber_woken_from_a_time_on_sleeps_through_earlier_samples_and_takes_them_all() {
    // A 2.5-Hz sensor model on a 10-Hz stream asks to be woken only for the sample of its own
    // tick: the three before it arrive unrung and are taken with it.
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("consumer", &config).expect("bus");
        let truth = bus.subscriber::<GyroSample>().expect("subscriber");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        let source = events.on_data(&truth).expect("attach");
        // Samples are stamped `sequence` × 100 ms: wake for the fourth.
        truth.wake_from(gyro(4).header.time_ns);
        let (batches, woken) = take_slow_samples(&config, &mut events, &truth, source, 4, || {});
        assert_eq!(
            batches,
            [vec![1, 2, 3, 4]],
            "every sample is taken, in order, in one wake-up for the fourth"
        );
        assert_eq!(woken, 1, "{:?}", events.wait_stats());
    }
    remove_all(&config).expect("remove_all");
}

#[test]
fn a_loop_awaiting_several_samples_wakes_once_for_them() {
    // An estimator on a tick with three samples due asks to be woken at the third ring: the
    // first two arrive unrung (while it sleeps) and are taken with the third. Then it awaits
    // one, and each sample wakes it again.
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("consumer", &config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let waiter = Waiter::new().expect("waiter");
        let awaited = std::cell::Cell::new(3);
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        let source = events.on_data(&sub).expect("attach");
        events.wake_after_rings(&awaited);
        // Three taken: from then on every sample is awaited alone.
        let (batches, woken) =
            take_slow_samples(&config, &mut events, &sub, source, 5, || awaited.set(1));
        assert_eq!(
            batches,
            [vec![1, 2, 3], vec![4], vec![5]],
            "the first three samples in one wake-up, then one each"
        );
        assert_eq!(woken, 3, "{:?}", events.wait_stats());
    }
    remove_all(&config).expect("remove_all");
}

#[test]
fn only_a_ring_that_finds_nothing_counts_as_a_stale_notification() {
    // The look a loop takes before it sleeps again, after a round that handled a sample, is
    // not a wake-up; a ring that wakes the loop to nothing (here a new publisher's start-up
    // ring) is.
    let config = BusConfig::isolated();
    {
        let bus = Bus::open("consumer", &config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::with_wait_strategy(&waiter, WaitStrategy::Block);
        events.on_data(&sub).expect("attach");
        let (start, publisher) = publisher_thread(&config, |publisher| {
            thread::sleep(Duration::from_millis(50));
            publisher.publish(&gyro(1)).expect("publish");
        });
        events
            .run_once(Duration::ZERO, |_| Flow::Continue)
            .expect("first look");
        start.send(()).expect("start");
        let mut taken = 0;
        let begin = Instant::now();
        while taken == 0 {
            assert!(
                begin.elapsed() < HANG_GUARD,
                "the sample never woke the loop"
            );
            events
                .run_once(Duration::from_secs(1), |_| {
                    taken += sub.drain(|_| {}).expect("drain");
                    Flow::Continue
                })
                .expect("event loop");
        }
        events
            .run_once(Duration::from_millis(20), |wake| {
                panic!("nothing was published: {wake:?}")
            })
            .expect("event loop");
        let stats = events.wait_stats();
        assert_eq!(
            (stats.woken, stats.stale_notifications),
            (1, 0),
            "one wake-up, no stale notification: {stats:?}"
        );

        // A second publisher appears while the loop sleeps (its ring finds nothing), and a
        // while later publishes (that ring ends the round). Both delays are long against the
        // loop's way to sleep and back.
        let second_config = config.clone();
        let second = thread::spawn(move || -> Result<(), BusError> {
            thread::sleep(Duration::from_millis(100));
            let bus = Bus::open("second", &second_config)?;
            let publisher = bus.publisher::<GyroSample>()?;
            thread::sleep(Duration::from_millis(200));
            publisher.publish(&gyro(2))?;
            Ok(())
        });
        let mut taken = 0;
        events
            .run_once(HANG_GUARD, |_| {
                taken += sub.drain(|_| {}).expect("drain");
                Flow::Continue
            })
            .expect("event loop");
        second
            .join()
            .expect("second thread")
            .expect("second publisher");
        assert_eq!(taken, 1, "the second publisher's sample");
        let stats = events.wait_stats();
        assert_eq!(
            (stats.woken, stats.stale_notifications),
            (2, 1),
            "the new publisher's ring woke the loop to nothing: {stats:?}"
        );
        let _ = start.send(());
        publisher
            .join()
            .expect("publisher thread")
            .expect("publisher");
    }
    remove_all(&config).expect("remove_all");
}
