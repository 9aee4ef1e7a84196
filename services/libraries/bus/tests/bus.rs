//! In-process and two-process tests of the bus. Every test uses its own `BusConfig::isolated()`
//! (unique prefix, short root under /tmp) and removes all its files at the end.
//!
//! Time bounds below are only upper limits that keep a broken test from hanging.

use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use ipc_types::{AttitudeEstimate, GyroSample, Heartbeat, ProcessState, SampleHeader};
use testbed_bus::{
    Bus, BusConfig, BusError, Delivery, EventLoop, Flow, LoopExit, SubscriberOptions, Waiter, Wake,
    cleanup_dead_nodes, remove_all,
};

const HANG_GUARD: Duration = Duration::from_secs(30);

/// A test's bus configuration; `finish` removes its files and checks nothing is left.
struct Isolated {
    config: BusConfig,
    finished: bool,
}

impl Isolated {
    fn new(delivery: Delivery) -> Self {
        Self {
            config: BusConfig::isolated().with_delivery(delivery),
            finished: false,
        }
    }

    fn finish(mut self) {
        self.finished = true;
        remove_all(&self.config).expect("remove_all");
        assert!(
            !self.config.root.exists(),
            "root {:?} left behind",
            self.config.root
        );
        let shm: Vec<_> = std::fs::read_dir("/dev/shm")
            .expect("/dev/shm")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|name| name.starts_with(&self.config.prefix))
            .collect();
        assert!(shm.is_empty(), "shared memory left behind: {shm:?}");
    }
}

impl Drop for Isolated {
    fn drop(&mut self) {
        if !self.finished {
            // A failed test: remove what can be removed, ignoring errors.
            let _ = remove_all(&self.config);
        }
    }
}

fn gyro(sequence: u64) -> GyroSample {
    GyroSample {
        header: SampleHeader::new(sequence * 100_000_000, sequence, SampleHeader::VALID),
        ..GyroSample::default()
    }
}

/// Runs `events` until `done` says so, failing after `HANG_GUARD`.
fn run_until(events: &mut EventLoop<'_, '_>, mut on_wake: impl FnMut(Wake) -> bool) {
    let start = Instant::now();
    let mut done = false;
    while !done {
        let left = HANG_GUARD
            .checked_sub(start.elapsed())
            .expect("test timed out");
        let exit = events
            .run_once(left, |wake| {
                done = on_wake(wake);
                if done { Flow::Stop } else { Flow::Continue }
            })
            .expect("event loop");
        assert_ne!(exit, Some(LoopExit::TerminationRequested));
    }
}

/// CPU time (user + system) consumed by the calling thread.
fn thread_cpu_time() -> Duration {
    // SAFETY: getrusage only writes the struct it is given.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        assert_eq!(libc::getrusage(libc::RUSAGE_THREAD, &mut usage), 0);
        usage
    };
    let tv = |t: libc::timeval| Duration::new(t.tv_sec as u64, t.tv_usec as u32 * 1000);
    tv(usage.ru_utime) + tv(usage.ru_stime)
}

/// Spawns a thread that opens its own bus (ports are not `Send`), publishes with `publish`,
/// then keeps its ports alive until the returned sender is dropped or sent to.
fn publisher_thread(
    config: &BusConfig,
    publish: impl FnOnce(&testbed_bus::TopicPublisher<GyroSample>) + Send + 'static,
) -> (mpsc::Sender<()>, thread::JoinHandle<Result<(), BusError>>) {
    let config = config.clone();
    let (done_tx, done_rx) = mpsc::channel::<()>();
    let handle = thread::spawn(move || {
        let bus = Bus::open("publisher", &config)?;
        let publisher = bus.publisher::<GyroSample>()?;
        publish(&publisher);
        let _ = done_rx.recv_timeout(HANG_GUARD);
        Ok(())
    });
    (done_tx, handle)
}

#[test]
fn round_trip_wakes_on_the_paired_event() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let bus = Bus::open("subscriber", &iso.config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::new(&waiter);
        let on_gyro = events.on_data(&sub).expect("attach");

        let (done, handle) = publisher_thread(&iso.config, |publisher| {
            for i in 0..3 {
                publisher.publish(&gyro(i)).expect("publish");
            }
        });
        let mut got = Vec::new();
        run_until(&mut events, |wake| {
            assert_eq!(wake, Wake::Data(on_gyro), "only data can wake this loop");
            sub.drain_into(&mut got).expect("drain");
            got.len() >= 3
        });
        assert_eq!(got, vec![gyro(0), gyro(1), gyro(2)]);
        assert_eq!(sub.received(), 3);
        drop(done);
        handle.join().expect("thread").expect("publisher");
    }
    iso.finish();
}

#[test]
fn lossless_delivery_loses_nothing_in_a_burst() {
    const N: u64 = 10_000;
    let iso = Isolated::new(Delivery::Lossless);
    {
        let bus = Bus::open("slow-subscriber", &iso.config).expect("bus");
        let sub = bus
            .subscriber_with::<GyroSample>(SubscriberOptions::buffer(16))
            .expect("sub");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::new(&waiter);
        events.on_data(&sub).expect("attach");

        // Handshake: the burst starts once the first sample was read, i.e. once the subscriber
        // is attached to the publisher's connection (see `TopicPublisher::publish`).
        let (ack_tx, ack_rx) = mpsc::channel::<()>();
        let (done, handle) = publisher_thread(&iso.config, move |publisher| {
            publisher.publish(&gyro(0)).expect("publish");
            ack_rx
                .recv_timeout(HANG_GUARD)
                .expect("first sample acknowledged");
            for i in 1..N {
                publisher.publish(&gyro(i)).expect("publish");
            }
            assert_eq!(publisher.undelivered(), 0);
        });
        let mut next = 0;
        run_until(&mut events, |_| {
            sub.drain(|s| {
                assert_eq!(s.header.sequence, next, "lost or reordered sample");
                next += 1;
            })
            .expect("drain");
            if next == 1 {
                ack_tx.send(()).expect("ack");
            }
            // A slow consumer: the publisher has to wait for it.
            thread::sleep(Duration::from_micros(200));
            next == N
        });
        assert_eq!(sub.received(), N);
        drop(done);
        handle.join().expect("thread").expect("publisher");
    }
    iso.finish();
}

#[test]
fn overflow_delivery_keeps_the_newest_samples() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let bus = Bus::open("late-reader", &iso.config).expect("bus");
        let sub = bus
            .subscriber_with::<GyroSample>(SubscriberOptions::buffer(16))
            .expect("sub");
        let (published_tx, published_rx) = mpsc::channel();
        let (done, handle) = publisher_thread(&iso.config, move |publisher| {
            for i in 0..1000 {
                publisher.publish(&gyro(i)).expect("publish");
            }
            let _ = published_tx.send(());
        });
        published_rx
            .recv_timeout(HANG_GUARD)
            .expect("publisher finished");
        let mut got = Vec::new();
        sub.drain_into(&mut got).expect("drain");
        let sequences: Vec<u64> = got.iter().map(|s| s.header.sequence).collect();
        assert_eq!(sequences, (984..1000).collect::<Vec<_>>());
        drop(done);
        handle.join().expect("thread").expect("publisher");
    }
    iso.finish();
}

#[test]
fn idle_loop_sleeps_and_wakes_on_interval_and_data() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let bus = Bus::open("idle", &iso.config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::new(&waiter);
        let on_gyro = events.on_data(&sub).expect("attach data");
        let tick = events
            .on_interval(Duration::from_millis(100))
            .expect("attach interval");

        let (done, handle) = publisher_thread(&iso.config, |publisher| {
            thread::sleep(Duration::from_millis(450));
            publisher.publish(&gyro(7)).expect("publish");
        });
        let cpu_before = thread_cpu_time();
        let wall = Instant::now();
        let (mut ticks, mut data) = (0, Vec::new());
        run_until(&mut events, |wake| {
            match wake {
                Wake::Tick(s) if s == tick => ticks += 1,
                Wake::Data(s) if s == on_gyro => {
                    sub.drain_into(&mut data).expect("drain");
                }
                other => panic!("unexpected {other:?}"),
            }
            ticks == 10
        });
        let wall = wall.elapsed();
        let cpu = thread_cpu_time() - cpu_before;
        assert_eq!(data, vec![gyro(7)]);
        println!("idle loop: {cpu:?} CPU in {wall:?} wall");
        // About 1 s of waiting; a busy or sleep-polling loop would burn a large share of it.
        assert!(
            wall >= Duration::from_millis(900),
            "10 ticks of 100 ms took {wall:?}"
        );
        assert!(cpu * 20 < wall, "loop used {cpu:?} of CPU in {wall:?}");
        drop(done);
        handle.join().expect("thread").expect("publisher");
    }
    iso.finish();
}

#[test]
fn missed_deadlines_are_reported_and_counted() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let bus = Bus::open("watchdog", &iso.config).expect("bus");
        let sub = bus.subscriber::<GyroSample>().expect("subscriber");
        let publisher = bus.publisher::<GyroSample>().expect("publisher");
        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::new(&waiter);
        let on_gyro = events
            .on_data_with_deadline(&sub, Duration::from_millis(50))
            .expect("attach");
        // Deadlines are supervised once the stream has started.
        publisher.publish(&gyro(0)).expect("publish");
        let mut missed = 0;
        run_until(&mut events, |wake| {
            match wake {
                Wake::Data(s) if s == on_gyro => {
                    assert_eq!(sub.latest().expect("drain"), Some(gyro(0)));
                }
                other => {
                    assert_eq!(other, Wake::DeadlineMissed(on_gyro));
                    missed += 1;
                }
            }
            missed == 3
        });
        assert_eq!(events.missed_deadlines(on_gyro), 3);

        publisher.publish(&gyro(1)).expect("publish");
        run_until(&mut events, |wake| {
            // A deadline may still expire just before the sample is seen.
            wake == Wake::Data(on_gyro) && sub.latest().expect("drain") == Some(gyro(1))
        });
    }
    iso.finish();
}

#[test]
fn processes_must_agree_on_the_delivery_mode() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let first = Bus::open("first", &iso.config).expect("bus");
        let _publisher = first.publisher::<GyroSample>().expect("publisher");
        let lossless = iso.config.clone().with_delivery(Delivery::Lossless);
        let second = Bus::open("second", &lossless).expect("bus");
        let err = second
            .subscriber::<GyroSample>()
            .expect_err("mismatch refused");
        assert!(err.to_string().contains(ipc_types::topic::GYRO), "{err}");
    }
    iso.finish();
}

#[test]
fn a_data_topic_has_few_publisher_slots_and_a_shared_topic_many() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let limits = iso.config.limits;
        assert!(limits.max_data_publishers < limits.max_publishers);
        let bus = Bus::open("slots", &iso.config).expect("bus");
        let gyros: Vec<_> = (0..limits.max_data_publishers)
            .map(|_| {
                bus.publisher::<GyroSample>()
                    .expect("publisher within the limit")
            })
            .collect();
        let err = bus
            .publisher::<GyroSample>()
            .expect_err("one publisher more than the data topic's slots");
        assert!(err.to_string().contains(ipc_types::topic::GYRO), "{err}");
        let heartbeats: Vec<_> = (0..limits.max_publishers)
            .map(|_| bus.publisher::<Heartbeat>().expect("heartbeat publisher"))
            .collect();
        drop((gyros, heartbeats));
    }
    iso.finish();
}

/// The end of a run: every process leaves with samples its subscribers have not taken yet
/// (the logger takes the last health events after the others have stopped). A subscriber keeps
/// the connections of departed publishers so that it can still take their samples; it must
/// keep as many as a topic can have publishers.
#[test]
fn samples_of_every_publisher_that_left_are_still_received() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let max = iso.config.limits.max_publishers;
        let bus = Bus::open("departed", &iso.config).expect("bus");
        let subscriber = bus
            .subscriber_with::<Heartbeat>(SubscriberOptions::buffer(4))
            .expect("subscriber");
        let publishers: Vec<_> = (0..max)
            .map(|_| bus.publisher::<Heartbeat>().expect("publisher"))
            .collect();
        assert_eq!(subscriber.drain(|_| {}).expect("connect"), 0);
        for (k, publisher) in publishers.iter().enumerate() {
            let mut beat = Heartbeat::default();
            beat.header.sequence = k as u64;
            publisher.publish(&beat).expect("publish");
        }
        drop(publishers);
        let mut received = Vec::new();
        subscriber
            .drain(|beat| received.push(beat.header.sequence))
            .expect("drain");
        received.sort_unstable();
        assert_eq!(received, (0..max as u64).collect::<Vec<_>>());
    }
    iso.finish();
}

#[test]
fn subscriber_options_are_checked() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let bus = Bus::open("options", &iso.config).expect("bus");
        for options in [
            SubscriberOptions {
                buffer_size: 0,
                history: 0,
                ..SubscriberOptions::default()
            },
            SubscriberOptions {
                buffer_size: 100_000,
                history: 0,
                ..SubscriberOptions::default()
            },
            SubscriberOptions {
                buffer_size: 4,
                history: 5,
                ..SubscriberOptions::default()
            },
        ] {
            let err = bus
                .subscriber_with::<GyroSample>(options)
                .expect_err("invalid options");
            assert!(matches!(err, BusError::Config { .. }), "{err}");
        }
    }
    iso.finish();
}

struct Child {
    child: Option<std::process::Child>,
}

impl Drop for Child {
    fn drop(&mut self) {
        // A failed test must not leave its child running.
        if let Some(child) = &mut self.child {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

impl Child {
    fn spawn_echo(config: &BusConfig) -> Self {
        let child = Command::new(env!("CARGO_BIN_EXE_bus-echo"))
            .envs(config.env_vars())
            .env("RUST_LOG", "warn")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .spawn()
            .expect("spawn bus-echo");
        Self { child: Some(child) }
    }

    fn signal(&self, signal: libc::c_int) {
        let pid = libc::pid_t::try_from(self.child.as_ref().expect("child").id()).expect("pid");
        // SAFETY: plain kill(2) on our own child.
        assert_eq!(unsafe { libc::kill(pid, signal) }, 0);
    }

    /// Waits (in a helper thread, bounded) for the child and returns its output.
    fn wait(mut self) -> std::process::Output {
        let (tx, rx) = mpsc::channel();
        let child = self.child.take().expect("child");
        let pid = child.id();
        thread::spawn(move || {
            let _ = tx.send(child.wait_with_output());
        });
        match rx.recv_timeout(HANG_GUARD) {
            Ok(output) => output.expect("wait"),
            Err(_) => {
                // SAFETY: plain kill(2) on our own child.
                unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
                panic!("bus-echo did not exit");
            }
        }
    }
}

/// Waits for a `Running` heartbeat of node `name`.
fn wait_for_running(
    events: &mut EventLoop<'_, '_>,
    heartbeats: &testbed_bus::TopicSubscriber<Heartbeat>,
    name: &str,
) {
    run_until(events, |_| {
        let mut running = false;
        heartbeats
            .drain(|hb| running |= hb.name() == name && hb.state() == Some(ProcessState::Running))
            .expect("drain heartbeats");
        running
    });
}

#[test]
fn two_processes_round_trip_and_stop_on_sigint() {
    const N: u64 = 100;
    let iso = Isolated::new(Delivery::Lossless);
    {
        let bus = Bus::open("parent", &iso.config).expect("bus");
        let heartbeats = bus
            .subscriber_with::<Heartbeat>(SubscriberOptions {
                buffer_size: 16,
                history: 1,
                ..SubscriberOptions::default()
            })
            .expect("heartbeat subscriber");
        // Room for every answer: the parent publishes the whole burst before reading, and in
        // lossless mode a full buffer on the way back would block the child, which would then
        // stop reading and block the parent (a cycle deadlock, see `Delivery::Lossless`).
        let estimates = bus
            .subscriber_with::<AttitudeEstimate>(SubscriberOptions::buffer(128))
            .expect("sub");
        let publisher = bus.publisher::<GyroSample>().expect("publisher");
        let child = Child::spawn_echo(&iso.config);
        {
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::new(&waiter);
            events.on_data(&heartbeats).expect("attach heartbeats");
            wait_for_running(&mut events, &heartbeats, "echo");
        }
        // Heartbeats always overflow: an unread heartbeat buffer never blocks the child.
        drop(heartbeats);

        let waiter = Waiter::new().expect("waiter");
        let mut events = EventLoop::new(&waiter);
        events.on_data(&estimates).expect("attach estimates");
        // One sample and its answer first: after that both sides are attached to each other's
        // connections and the burst cannot lose anything.
        let mut next = 0;
        for burst in [0..1, 1..N] {
            let end = burst.end;
            for i in burst {
                publisher.publish(&gyro(i)).expect("publish");
            }
            run_until(&mut events, |_| {
                estimates
                    .drain(|e| {
                        assert_eq!(e.header, gyro(next).header, "lost or reordered sample");
                        next += 1;
                    })
                    .expect("drain");
                next == end
            });
        }
        assert_eq!(publisher.undelivered(), 0);

        child.signal(libc::SIGINT);
        let output = child.wait();
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(
            output.status.success(),
            "bus-echo: {:?}\n{stdout}",
            output.status
        );
        assert!(stdout.contains("exit: TerminationRequested"), "{stdout}");
        assert!(stdout.contains(&format!("echoed: {N}")), "{stdout}");
        // The child ended cleanly: nothing of it is left to clean up.
        let report = cleanup_dead_nodes(&iso.config).expect("cleanup");
        assert!(report.cleaned.is_empty(), "{report:?}");
    }
    iso.finish();
}

#[test]
fn resources_of_a_killed_process_are_cleaned_up() {
    let iso = Isolated::new(Delivery::Overflow);
    {
        let bus = Bus::open("observer", &iso.config).expect("bus");
        let heartbeats = bus
            .subscriber_with::<Heartbeat>(SubscriberOptions {
                buffer_size: 16,
                history: 1,
                ..SubscriberOptions::default()
            })
            .expect("heartbeat subscriber");
        let child = Child::spawn_echo(&iso.config);
        {
            let waiter = Waiter::new().expect("waiter");
            let mut events = EventLoop::new(&waiter);
            events.on_data(&heartbeats).expect("attach heartbeats");
            wait_for_running(&mut events, &heartbeats, "echo");
        }
        child.signal(libc::SIGKILL);
        let output = child.wait();
        assert!(!output.status.success());

        let report = cleanup_dead_nodes(&iso.config).expect("cleanup");
        assert_eq!(report.cleaned.len(), 1, "{report:?}");
        assert!(report.cleaned[0].starts_with("echo (pid "), "{report:?}");
        assert!(report.failed.is_empty(), "{report:?}");
        assert_eq!(report.alive, 1, "the observer itself");

        // remove_all refuses while a node of the bus is alive.
        let err = remove_all(&iso.config).expect_err("observer still alive");
        assert!(err.to_string().contains("still alive"), "{err}");
    }
    iso.finish();
}
