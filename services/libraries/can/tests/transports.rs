//! The transports end to end: candump logs (recording, replay, pacing, malformed lines), serial
//! over a pseudo-terminal pair, SocketCAN (or a clear skip when the kernel has none), and a
//! gateway-style loop over the in-memory transport.

use serialport::SerialPort;
use std::io::Write;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use testbed_can::transport::serial::{MAX_WIRE, encode_packet};
use testbed_can::transport::*;
use testbed_can::*;

/// `TTYPort::pair()` is not thread-safe (ptsname): one pty test at a time.
static PTY: Mutex<()> = Mutex::new(());

fn gyro(t: u32, x: f64) -> Message {
    Message::Gyro(GyroMsg {
        node_time_us: t,
        status: DeviceStatus::default(),
        rate_rad_s: [x, -x, 0.5 * x],
    })
}

/// Receive until `n` messages are decoded or `timeout` passes.
fn receive_messages<T: CanTransport>(
    t: &mut T,
    dec: &mut Decoder,
    n: usize,
    timeout: Duration,
) -> Vec<Received> {
    let deadline = Instant::now() + timeout;
    let mut out = vec![];
    while out.len() < n && Instant::now() < deadline {
        match t.recv(Duration::from_millis(20)) {
            Ok(Some(f)) => out.extend(dec.decode(&f.frame).message),
            Ok(None) => {}
            Err(TransportError::Closed) => break,
            Err(e) => panic!("receive failed: {e}"),
        }
    }
    out
}

#[test]
fn gateway_loop_over_memory_transport() {
    let (mut node, mut gateway) = MemoryTransport::pair();
    let p = Protocol::default();
    let mut node_enc = Encoder::new(p);
    for i in 0..50u32 {
        for f in &node_enc
            .encode(&gyro(i * 100_000, 1e-3 * f64::from(i)))
            .unwrap()
        {
            node.send(f).unwrap();
        }
    }
    // Commands go the other way.
    let mut gw_enc = Encoder::new(p);
    let cmd = ipc_types::WheelCommand::new(ipc_types::SampleHeader::default(), [0.01, -0.02, 0.1]);
    for f in &gw_enc
        .encode(&Message::WheelCommand(WheelCommandMsg::from(&cmd)))
        .unwrap()
    {
        gateway.send(f).unwrap();
    }

    let mut dec = Decoder::with_devices(p, DeviceSet::of(&[Device::Gyro]));
    let got = receive_messages(&mut gateway, &mut dec, 50, Duration::from_secs(2));
    assert_eq!(got.len(), 50);
    let mut clock = NodeClock::new();
    for (i, r) in got.iter().enumerate() {
        let t_us = clock.extend(r.message.node_time_us().unwrap());
        let header = ipc_types::SampleHeader::new(t_us as u64 * 1000, i as u64, 0);
        let Some(Sample::Gyro(s)) = r.message.to_sample(header, r.clipped) else {
            panic!("not a gyro sample")
        };
        assert!(s.header.is_valid());
        assert_eq!(s.header.time_ns, i as u64 * 100_000_000);
        assert!((s.rate[0] - 1e-3 * i as f64).abs() <= Quantity::GyroRate.lsb_si() / 2.0);
    }
    assert_eq!(dec.stats().ok, 100);

    let mut node_dec = Decoder::new(p);
    let cmds = receive_messages(&mut node, &mut node_dec, 1, Duration::from_secs(1));
    let Message::WheelCommand(c) = cmds[0].message else {
        panic!("not a wheel command")
    };
    assert!((c.torque_nm[2] - 0.1).abs() < 1e-9);
}

fn write_log(path: &std::path::Path, frames: &[(u64, CanFrame)]) {
    let file = std::fs::File::create(path).unwrap();
    let mut w = CandumpWriter::new(std::io::BufWriter::new(file), "can0").unwrap();
    for (t, f) in frames {
        w.write(*t, f).unwrap();
    }
    w.flush().unwrap();
}

fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("testbed-can-{}-{name}", std::process::id()))
}

#[test]
fn candump_record_and_replay_as_fast_as_possible() {
    let p = Protocol::default();
    let mut enc = Encoder::new(p);
    let (mut node, gateway) = MemoryTransport::pair();
    let log_path = temp_path("record.log");
    let file = std::fs::File::create(&log_path).unwrap();
    let mut rec = Recorder::new(gateway, CandumpWriter::new(file, "can0").unwrap());
    for i in 0..20u32 {
        for f in &enc.encode(&gyro(i * 100_000, 0.01)).unwrap() {
            node.send(f).unwrap();
        }
    }
    let mut live = Decoder::new(p);
    assert_eq!(
        receive_messages(&mut rec, &mut live, 20, Duration::from_secs(2)).len(),
        20
    );
    rec.send(&CanFrame::standard(0x100, &[0, 0, 0, 0, 0, 0, 0]).unwrap())
        .unwrap();
    let (_, writer) = rec.into_parts();
    drop(writer);

    // Append a malformed line and a blank line: replay reports them and goes on.
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&log_path)
        .unwrap();
    f.write_all(b"\nthis is not a frame\n(1.0) can0 121#00\n")
        .unwrap();
    drop(f);

    let mut replay = CandumpReplay::open(&log_path, Pacing::AsFastAsPossible).unwrap();
    let mut dec = Decoder::new(p);
    let start = Instant::now();
    let got = receive_messages(&mut replay, &mut dec, usize::MAX, Duration::from_secs(5));
    assert!(start.elapsed() < Duration::from_secs(1));
    // 20 gyro samples and the wheel command that was sent.
    assert_eq!(
        got.iter()
            .filter(|r| r.message.kind() == MessageKind::Gyro)
            .count(),
        20
    );
    assert_eq!(
        got.iter()
            .filter(|r| r.message.kind() == MessageKind::WheelCommand)
            .count(),
        1
    );
    assert!(matches!(
        replay.recv(Duration::ZERO),
        Err(TransportError::Closed)
    ));
    let s = replay.stats();
    assert_eq!((s.frames, s.blank, s.malformed), (42, 1, 1));
    assert_eq!(s.first_malformed[0].line, 43);
    assert_eq!(dec.stats().wrong_dlc, 1, "the short 121#00 frame");
    std::fs::remove_file(&log_path).ok();
}

#[test]
fn candump_replay_is_paced_by_time_stamps() {
    let p = Protocol::default();
    let enc = Encoder::new(p);
    let t0 = 1_700_000_000_000_000_000u64;
    // Six single-frame commands 40 ms apart: 200 ms of log.
    let frames: Vec<(u64, CanFrame)> = (0..6u8)
        .map(|i| {
            let m = Message::WheelCommand(WheelCommandMsg {
                torque_nm: [0.0; 3],
            });
            (
                t0 + u64::from(i) * 40_000_000,
                enc.encode_with_counter(&m, i).unwrap().as_slice()[0],
            )
        })
        .collect();
    let path = temp_path("paced.log");
    write_log(&path, &frames);

    for (speed, nominal_ms) in [(1.0, 200.0), (4.0, 50.0)] {
        let mut replay = CandumpReplay::open(&path, Pacing::Timed { speed }).unwrap();
        let mut times = vec![];
        let mut start = None;
        loop {
            match replay.recv(Duration::from_millis(15)) {
                Ok(Some(f)) => {
                    let now = Instant::now();
                    let s = *start.get_or_insert(now);
                    times.push(((now - s).as_secs_f64() * 1e3, f.time_ns));
                }
                Ok(None) => {}
                Err(TransportError::Closed) => break,
                Err(e) => panic!("{e}"),
            }
        }
        assert_eq!(times.len(), 6);
        for (i, (t_ms, stamp)) in times.iter().enumerate() {
            assert_eq!(*stamp, frames[i].0, "log time stamps are kept");
            let want = nominal_ms * i as f64 / 5.0;
            assert!(
                *t_ms >= want - 1.0 && *t_ms < want + 150.0,
                "speed {speed}: frame {i} at {t_ms:.1} ms, want {want} ms"
            );
        }
        eprintln!(
            "speed {speed}: frames at {:?} ms",
            times.iter().map(|t| t.0.round()).collect::<Vec<_>>()
        );
    }
    assert!(matches!(
        CandumpReplay::open(&path, Pacing::Timed { speed: 0.0 }),
        Err(TransportError::Config(_))
    ));
    std::fs::remove_file(&path).ok();
    assert!(matches!(
        CandumpReplay::open(&path, Pacing::AsFastAsPossible),
        Err(TransportError::NotFound(_))
    ));
}

#[test]
fn serial_over_a_pseudo_terminal_pair() {
    let _guard = PTY.lock().unwrap_or_else(|e| e.into_inner());
    let (master, slave) = serialport::TTYPort::pair().expect("pseudo-terminal pair");
    let mut raw = master.try_clone_native().expect("clone of the master");
    let mut device = SerialTransport::from_port(Box::new(master), "pty master");
    let mut computer = SerialTransport::from_port(Box::new(slave), "pty slave");

    let p = Protocol::default();
    let mut enc = Encoder::new(p);
    let mut dec = Decoder::new(p);
    for i in 0..10u32 {
        if i == 5 {
            // Line noise, a corrupted packet and an over-long packet between two samples.
            raw.write_all(&[0x13, 0x37, 0xFF, 0x00]).unwrap();
            let mut pkt = [0u8; MAX_WIRE];
            let n = encode_packet(&CanFrame::standard(0x120, &[9; 8]).unwrap(), &mut pkt).unwrap();
            pkt[4] ^= 0x40;
            raw.write_all(&pkt[..n]).unwrap();
            raw.write_all(&[0x42; 40]).unwrap();
            raw.write_all(&[0]).unwrap();
        }
        for f in &enc.encode(&gyro(i * 100_000, 0.02)).unwrap() {
            device.send(f).unwrap();
        }
    }
    let got = receive_messages(&mut computer, &mut dec, 10, Duration::from_secs(3));
    assert_eq!(got.len(), 10);
    assert_eq!(
        got.iter().map(|r| r.counter).collect::<Vec<_>>(),
        (0..10).collect::<Vec<u8>>()
    );
    let s = *computer.stats();
    assert_eq!(s.frames, 20);
    assert!(s.dropped() >= 2, "{s:?}");
    assert!(
        s.too_long >= 1 && s.bad_crc + s.bad_stuffing + s.bad_length + s.bad_header >= 1,
        "{s:?}"
    );
    assert_eq!(dec.stats().classified(), 20);
    assert_eq!(dec.stats().ok, 20);

    // And back: a command from the computer to the device.
    let cmd = Message::CmgCommand(CmgCommandMsg {
        gimbal_rate_rad_s: [0.1, -0.1, 0.2, 0.0],
    });
    for f in &Encoder::new(p).encode(&cmd).unwrap() {
        computer.send(f).unwrap();
    }
    let mut dev_dec = Decoder::new(p);
    let back = receive_messages(&mut device, &mut dev_dec, 1, Duration::from_secs(2));
    assert_eq!(back.len(), 1);
    assert_eq!(back[0].message.kind(), MessageKind::CmgCommand);

    // A time-out beyond what `Instant` holds waits without limit instead of panicking.
    device
        .send(&CanFrame::standard(0x150, &[0; 8]).unwrap())
        .unwrap();
    assert!(computer.recv(Duration::MAX).unwrap().is_some());

    // Nothing pending: recv times out.
    let start = Instant::now();
    assert!(computer.recv(Duration::from_millis(50)).unwrap().is_none());
    assert!(start.elapsed() >= Duration::from_millis(45));
    assert!(matches!(
        computer.send(&CanFrame::new(CanId::Extended(1), &[]).unwrap()),
        Err(TransportError::FrameNotSupported { .. })
    ));
}

#[test]
fn serial_open_by_path() {
    let _guard = PTY.lock().unwrap_or_else(|e| e.into_inner());
    assert!(matches!(
        SerialTransport::open(&SerialConfig::new("/dev/no-such-serial-port")),
        Err(TransportError::NotFound(_))
    ));
    let (master, slave) = serialport::TTYPort::pair().expect("pseudo-terminal pair");
    let path = slave.name().expect("slave has a path");
    let mut computer =
        SerialTransport::open(&SerialConfig::new(&path)).expect("open the pty slave by path");
    drop(slave);
    let mut device = SerialTransport::from_port(Box::new(master), "pty master");
    let f = CanFrame::standard(0x150, &[1, 1, 0b111, 0, 0, 0, 0, 0]).unwrap();
    device.send(&f).unwrap();
    let got = computer
        .recv(Duration::from_secs(2))
        .unwrap()
        .expect("frame");
    assert_eq!(got.frame, f);
    assert_eq!(got.source, TimeSource::Host);
}

#[test]
fn socketcan_or_a_clear_skip() {
    let iface = std::env::var("TESTBED_CAN_IFACE").unwrap_or_else(|_| "vcan0".to_string());
    match probe_socketcan(&iface) {
        SocketCanSupport::NoKernelSupport(why) => {
            eprintln!("SKIPPED SocketCAN test: this kernel has no SocketCAN support ({why})");
            let e =
                SocketCanTransport::open(&iface).expect_err("cannot open without kernel support");
            assert!(matches!(e, TransportError::Unsupported(_)), "{e}");
            assert!(e.to_string().contains("SocketCAN"), "{e}");
        }
        SocketCanSupport::NoInterface(name) => {
            eprintln!(
                "SKIPPED SocketCAN test: no interface {name} (create one: ip link add dev vcan0 type vcan && ip link set up vcan0)"
            );
            assert!(matches!(
                SocketCanTransport::open(&iface),
                Err(TransportError::NotFound(_))
            ));
        }
        SocketCanSupport::Available => socketcan_loopback(&iface),
    }
}

/// Two sockets on one (virtual) interface: filters, kernel time stamps, decoding.
fn socketcan_loopback(iface: &str) {
    let p = Protocol::default();
    let mut tx = SocketCanTransport::open(iface).expect("open tx socket");
    let mut rx = SocketCanTransport::open(iface).expect("open rx socket");
    rx.set_device_filters(p.ids(), &[Device::Gyro]).unwrap();
    let mut enc = Encoder::new(p);
    tx.send(&CanFrame::standard(0x7FF, &[1]).unwrap()).unwrap(); // filtered out
    for f in &enc.encode(&gyro(5, 0.1)).unwrap() {
        tx.send(f).unwrap();
    }
    let mut dec = Decoder::new(p);
    let deadline = Instant::now() + Duration::from_secs(2);
    let mut got = vec![];
    while got.len() < 2 && Instant::now() < deadline {
        if let Some(f) = rx.recv(Duration::from_millis(100)).unwrap() {
            assert_eq!(f.source, TimeSource::Kernel);
            got.push(f);
        }
    }
    assert_eq!(got.len(), 2, "both gyro frames, not the filtered one");
    assert!(dec.decode(&got[0].frame).message.is_none());
    assert!(dec.decode(&got[1].frame).message.is_some());
    eprintln!("SocketCAN loopback on {iface} ok");
}
