//! A gateway's links as the run configuration chooses them: the software CAN bus, a serial line
//! for a directly wired sensor, a candump file, and SocketCAN (or a clear skip where the kernel
//! has none).

use ipc_types::ClockMode;
use ipc_types::{SampleHeader, can_source};
use std::io::Write;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, BusConfig, Delivery, remove_all};
use testbed_can::transport::{SerialTransport, SocketCanSupport, probe_socketcan};
use testbed_can::{CanFrame, CanTransport, DeviceStatus, Encoder, GyroMsg, Message, Sample};
use testbed_config::{CanLink, RunConfig, SerialLinkConfig};
use testbed_gateways::can_board;
use testbed_gateways::gateway::{Gateway, board_stamp_us};
use testbed_processes::can_link::Link;
use testbed_processes::software_bus::SoftwareBusTransport;

fn gyro_frames(encoder: &mut Encoder, k: u64) -> Vec<CanFrame> {
    let m = Message::Gyro(GyroMsg {
        node_time_us: board_stamp_us(k * 100_000_000),
        status: DeviceStatus::default(),
        rate_rad_s: [1e-3 * k as f64, 0.0, -1e-3],
    });
    encoder.encode(&m).unwrap().iter().copied().collect()
}

fn paced_config() -> RunConfig {
    let mut config = RunConfig::default();
    config.run.mode = ClockMode::Paced;
    config
}

/// Polls `link` through a free-running gyro gateway until `n` samples came (or 5 s passed).
fn gyro_samples(link: &mut Link, config: &RunConfig, n: usize) -> Vec<Sample> {
    let mut gateway = Gateway::new(
        ipc_types::Device::Gyro,
        can_board::protocol(config).unwrap(),
        config.schedule().unwrap(),
        false,
    );
    let mut out = Vec::new();
    let start = Instant::now();
    while out.len() < n && start.elapsed() < Duration::from_secs(5) {
        match link.poll() {
            Ok(Some(f)) => out.extend(gateway.on_frame(&f.frame).sample),
            Ok(None) => std::thread::sleep(Duration::from_millis(1)),
            Err(e) => panic!("{e}"),
        }
    }
    out
}

#[test]
fn the_software_bus_skips_own_frames_and_drops_corrupted_ones() {
    let bus_config = BusConfig::isolated().with_delivery(Delivery::Lossless);
    {
        let bus = Bus::open("links-test", &bus_config).unwrap();
        let board =
            SoftwareBusTransport::open(&bus, can_source::NODE, SampleHeader::VALID, 32).unwrap();
        let gateway =
            SoftwareBusTransport::open(&bus, can_source::GYRO, SampleHeader::VALID, 32).unwrap();
        let frame = CanFrame::standard(0x120, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap();
        board.set_time_ns(300_000_000);
        board.send_frame(&frame).unwrap();
        board.send_corrupted(&frame, 77).unwrap();
        board.send_frame(&frame).unwrap();
        let mut rx = &gateway;
        let got = rx.recv(Duration::from_secs(2)).unwrap().unwrap();
        assert_eq!((got.frame, got.time_ns), (frame, 300_000_000));
        assert_eq!(
            rx.recv(Duration::from_secs(2)).unwrap().unwrap().frame,
            frame
        );
        assert!(rx.recv(Duration::from_millis(20)).unwrap().is_none());
        let s = gateway.stats();
        assert_eq!((s.received, s.check_errors), (2, 1));
        // The sender does not hear itself.
        assert!(board.poll().unwrap().is_none());
        assert_eq!(board.stats().own, 3);
    }
    remove_all(&bus_config).unwrap();
}

#[test]
fn a_directly_wired_sensor_on_a_serial_line() {
    use serialport::SerialPort;
    let (master, slave) = serialport::TTYPort::pair().expect("pseudo-terminal pair");
    let path = slave.name().expect("the slave's path");
    drop(slave);
    let mut config = paced_config();
    config.can.serial.insert(
        "gyro".into(),
        SerialLinkConfig {
            path: path.into(),
            baud: 115_200,
        },
    );
    let bus_config = BusConfig::isolated();
    {
        let bus = Bus::open("gyro-gateway", &bus_config).unwrap();
        let mut link = Link::open(&bus, &config, ipc_types::Device::Gyro).unwrap();
        assert!(matches!(link, Link::Serial(_)));
        let mut device = SerialTransport::from_port(Box::new(master), "sensor");
        let mut encoder = Encoder::new(can_board::protocol(&config).unwrap());
        for k in 1..=5 {
            for f in gyro_frames(&mut encoder, k) {
                device.send(&f).unwrap();
            }
        }
        let samples = gyro_samples(&mut link, &config, 5);
        let times: Vec<u64> = samples
            .iter()
            .map(|s| match s {
                Sample::Gyro(g) => g.header.time_ns,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(times, (1..=5).map(|k| k * 100_000_000).collect::<Vec<_>>());
    }
    remove_all(&bus_config).unwrap();
}

#[test]
fn a_candump_file_replayed_as_fast_as_possible_then_closed() {
    let dir = std::env::temp_dir().join(format!("gateway-links-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bus.candump.log");
    let mut encoder = Encoder::new(testbed_can::Protocol::default());
    let mut text = std::fs::File::create(&file).unwrap();
    for k in 0..4 {
        for f in gyro_frames(&mut encoder, k) {
            writeln!(
                text,
                "{}",
                testbed_can::transport::format_candump_line(k * 100_000_000, "can0", &f)
            )
            .unwrap();
        }
        writeln!(text, "garbage line").unwrap();
    }
    drop(text);
    let mut config = paced_config();
    config.can.link = CanLink::Candump;
    config.can.candump = Some(file);
    config.can.replay_speed = 0.0;
    let bus_config = BusConfig::isolated();
    {
        let bus = Bus::open("gyro-gateway", &bus_config).unwrap();
        let mut link = Link::open(&bus, &config, ipc_types::Device::Gyro).unwrap();
        assert_eq!(gyro_samples(&mut link, &config, 4).len(), 4);
        assert!(matches!(
            link.poll(),
            Err(testbed_can::TransportError::Closed)
        ));
        assert_eq!(link.rejected(), 4, "the malformed lines");
    }
    remove_all(&bus_config).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn socketcan_is_opened_on_the_configured_interface_or_refused_clearly() {
    let config = paced_config();
    let bus_config = BusConfig::isolated();
    {
        let bus = Bus::open("gyro-gateway", &bus_config).unwrap();
        let result = Link::open(&bus, &config, ipc_types::Device::Gyro);
        match probe_socketcan(&config.can.interface) {
            SocketCanSupport::Available => assert!(matches!(result, Ok(Link::SocketCan(_)))),
            why => {
                let err = format!("{:#}", result.err().expect("no SocketCAN here: refused"));
                assert!(err.contains("can0"), "{why}: {err}");
                eprintln!("SocketCAN not available here ({why}); checked the refusal only");
            }
        }
    }
    remove_all(&bus_config).unwrap();
}
