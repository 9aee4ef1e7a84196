//! The ground link (issue 13): the platform side of the ground supervision station. A pure
//! observer of the pipeline — it takes no part in the lockstep start barrier or in any tick —
//! that serves the pipeline's topics to any number of viewers over the Foxglove WebSocket
//! protocol, serves the project's ground page over HTTP from the same port, and passes the
//! ground's commands, once checked, to the controller (`testbed/ground/command`).
//!
//! Threads: the bus stays on the node's thread (iceoryx2 ports are not `Send`); the server
//! ([`server`]) has its own threads and exchanges only bounded queues with the node, so a
//! slow or vanished viewer never holds up the pipeline (what does not fit is dropped and
//! counted). See `docs/ground.md` for the channels, the commands and their limits.

pub mod command;
pub mod protocol;
pub mod server;

use anyhow::Context as _;
use ipc_types::*;
use protocol::Channel;
use serde_json::json;
use server::{Server, Settings, ToBus};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use testbed_bus::{Bus, Flow, LoopExit, SubscriberOptions, TopicPublisher, TopicSubscriber, Wake};
use testbed_log::{LogEncode, LogRecord, foxglove};
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::DEG;
use testbed_model::physics::cmg_pyramid::CmgPyramid;
use testbed_runtime::ground::ENV_GROUND_TOKEN;
use testbed_runtime::{ClockMode, Context, Io, Node, WakeOn};

/// How often the node looks at the viewers' commands and sends the link's own status.
const SERVICE_PERIOD: Duration = Duration::from_millis(100);
/// How often the link drains its subscribers in a lockstep run (see `wake_on`).
const LOCKSTEP_DRAIN: Duration = Duration::from_millis(5);
/// The service period of a paced link with no viewer connected. Nobody sees the samples, so
/// the link keeps only what it tracks for the next viewer (the controller's mode, the
/// simulated time) and its buffers from overflowing (256 samples: 25 s of a 10 Hz topic). A
/// viewer that connects is served within this period, then every [`SERVICE_PERIOD`] (issue
/// 18: waking ten times a second to drain 20 subscribers for nobody was 0.1 % of a core). The
/// runtime's [`QUIET_PERIOD`](testbed_runtime::process::QUIET_PERIOD) (700 ms), with which the
/// link's heartbeat goes out (a 1-s period woke it once more a second for the heartbeat alone).
const UNWATCHED_PERIOD: Duration = testbed_runtime::process::QUIET_PERIOD;
/// Period of `testbed/ground/link`.
const STATUS_PERIOD: Duration = Duration::from_secs(1);

/// Channel ids of what the link derives itself (after the bus topics, 1 to 13).
pub const CH_TF_ESTIMATE: u32 = 14;
pub const CH_TF_TRUTH: u32 = 15;
pub const CH_CMG: u32 = 16;
pub const CH_LINK: u32 = 17;
pub const CH_EVENTS: u32 = 18;
/// Thruster status and commands (runs with thrusters).
pub const CH_THRUSTER_STATUS: u32 = 19;
pub const CH_THRUSTER_COMMAND: u32 = 20;

/// The bus topics served: channel id, whether viewers get it decimated (streams) or whole
/// (events, heartbeats, commands).
fn bus_channel(record: &LogRecord) -> Option<(u32, bool)> {
    Some(match record {
        LogRecord::AttitudeEstimate(_) => (1, true),
        LogRecord::ControllerStatus(_) => (2, true),
        LogRecord::SimTruth(_) => (3, true),
        LogRecord::WheelTelemetry(_) => (4, true),
        LogRecord::WheelCommand(_) => (5, true),
        LogRecord::CmgTelemetry(_) => (6, true),
        LogRecord::CmgCommand(_) => (7, true),
        LogRecord::Gyro(_) => (8, true),
        LogRecord::Heartbeat(_) => (9, false),
        LogRecord::Health(_) => (10, false),
        LogRecord::CanStatus(_) => (11, true),
        LogRecord::GroundCommand(_) => (12, false),
        LogRecord::GroundCommandAck(_) => (13, false),
        LogRecord::ThrusterStatus(_) => (CH_THRUSTER_STATUS, true),
        LogRecord::ThrusterCommand(_) => (CH_THRUSTER_COMMAND, true),
        _ => return None,
    })
}

fn bus_channel_spec<T: LogEncode>(id: u32) -> Channel {
    Channel {
        id,
        topic: T::NAME,
        schema_name: T::SCHEMA_NAME,
        schema: T::json_schema(),
    }
}

/// Every channel the link advertises.
pub fn channels() -> Vec<Channel> {
    let own = |id, topic, schema_name, schema: String| Channel {
        id,
        topic,
        schema_name,
        schema,
    };
    vec![
        bus_channel_spec::<AttitudeEstimate>(1),
        bus_channel_spec::<ControllerStatus>(2),
        bus_channel_spec::<SimTruth>(3),
        bus_channel_spec::<WheelTelemetry>(4),
        bus_channel_spec::<WheelCommand>(5),
        bus_channel_spec::<CmgTelemetry>(6),
        bus_channel_spec::<CmgCommand>(7),
        bus_channel_spec::<GyroSample>(8),
        bus_channel_spec::<Heartbeat>(9),
        bus_channel_spec::<HealthEvent>(10),
        bus_channel_spec::<CanLinkStatus>(11),
        bus_channel_spec::<GroundCommand>(12),
        bus_channel_spec::<GroundCommandAck>(13),
        bus_channel_spec::<ThrusterStatus>(CH_THRUSTER_STATUS),
        bus_channel_spec::<ThrusterCommand>(CH_THRUSTER_COMMAND),
        own(
            CH_TF_ESTIMATE,
            foxglove::TF_ESTIMATE_TOPIC,
            foxglove::FRAME_TRANSFORM,
            foxglove::frame_transform_schema(),
        ),
        own(
            CH_TF_TRUTH,
            foxglove::TF_TRUTH_TOPIC,
            foxglove::FRAME_TRANSFORM,
            foxglove::frame_transform_schema(),
        ),
        own(
            CH_CMG,
            "testbed/ground/cmg",
            "testbed::ground::Cmg",
            json!({"type": "object", "description": "CMG gimbal angles (rad), rates (rad/s) and the singularity measure sqrt(det(J J^T))/h0^3 (dimensionless) from the CMG telemetry."}).to_string(),
        ),
        own(
            CH_LINK,
            "testbed/ground/link",
            "testbed::ground::Link",
            json!({"type": "object", "description": "The ground link's counters and the controller's target attitude (degrees), every second."}).to_string(),
        ),
        own(
            CH_EVENTS,
            "testbed/ground/events",
            "testbed::ground::Event",
            json!({"type": "object", "description": "Controller mode changes seen by the link: time_ns, text."}).to_string(),
        ),
    ]
}

/// A subscriber whose samples go to the viewers, whatever their type.
trait Streamed {
    fn drain(&self, sink: &mut dyn FnMut(LogRecord)) -> anyhow::Result<usize>;
}

struct Stream<T: Topic>(TopicSubscriber<T>);

impl<T: Topic + LogEncode> Streamed for Stream<T> {
    fn drain(&self, sink: &mut dyn FnMut(LogRecord)) -> anyhow::Result<usize> {
        Ok(self.0.drain(|s| sink(s.into_record()))?)
    }
}

fn stream<T: Topic + LogEncode>(bus: &Bus) -> anyhow::Result<Box<dyn Streamed>> {
    // Deep buffers: in lockstep (lossless delivery) a publisher waits only if the link falls
    // 256 samples behind, and the link's thread does nothing but copy samples to queues.
    // Drained on timers only (see `wake_on`): publishing rings no doorbell of the link.
    Ok(Box::new(Stream(bus.subscriber_with::<T>(
        SubscriberOptions::buffer(256).polled(),
    )?)))
}

/// The ground link's ports.
pub struct GroundLinkPorts {
    streams: Vec<Box<dyn Streamed>>,
    command: TopicPublisher<GroundCommand>,
    ack: TopicPublisher<GroundCommandAck>,
    /// The service interval's period: [`SERVICE_PERIOD`] while viewers are connected,
    /// [`UNWATCHED_PERIOD`] in a paced run without one.
    service_period: std::cell::Cell<Duration>,
}

/// The ground link process.
pub struct GroundLinkProcess {
    server: Server,
    from_viewers: Receiver<ToBus>,
    /// `<log>.ground.json`: the actual URL and the token, for `testbed run` and tests.
    info_path: PathBuf,
    pyramid: CmgPyramid,
    /// The controller's target as the link knows it (configured, then commanded): heading,
    /// tilt θ, tilt φ, rad.
    target_hpr: [f64; 3],
    /// Target commands sent and not yet answered, by (viewer, command id).
    pending_targets: HashMap<(u32, u64), [f64; 3]>,
    last_mode: Option<u32>,
    last_status: Instant,
    buffer: Vec<u8>,
    /// The records of one wake-up, a buffer kept for the run.
    records: Vec<LogRecord>,
}

/// The run's command token: configured, given by `testbed run`, or made here.
fn token(configured: Option<&String>) -> anyhow::Result<String> {
    if let Some(t) = configured {
        return Ok(t.clone());
    }
    if let Ok(t) = std::env::var(ENV_GROUND_TOKEN)
        && t.len() >= 16
    {
        return Ok(t);
    }
    random_token()
}

/// 128 random bits from the OS, hex.
pub fn random_token() -> anyhow::Result<String> {
    use std::io::Read as _;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .context("reading /dev/urandom for the ground token")?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Heading and the inclinometer's tilt angles θ (body x) and φ (body y) of `q`, rad: what the
/// ground page shows for the estimate and the truth too.
fn hpr(q: &Attitude) -> [f64; 3] {
    let [pitch, roll] = attitude::tilt_angles(q);
    [attitude::heading(q), pitch, roll]
}

impl GroundLinkProcess {
    pub fn open(cx: &Context) -> anyhow::Result<(Self, GroundLinkPorts)> {
        let (config, bus) = (cx.config, cx.bus);
        let ground = &config.ground;
        let token = token(ground.token.as_ref())?;
        let (to_bus, from_viewers) = std::sync::mpsc::sync_channel(64);
        let start_time_ns = config
            .run
            .start_time_ns
            .unwrap_or_else(testbed_log::unix_time_ns);
        let settings = Settings {
            channels: channels(),
            start_time_ns,
            metadata: json!({
                // Message times are this plus the run clock (a string: exact in JavaScript).
                "start_time_ns": start_time_ns.to_string(),
                "profile": config.run.profile,
                "mode": config.run.mode.as_str(),
                "seed": config.run.seed,
                "duration_s": config.run.duration_s,
                "max_target_tilt_deg": ground.max_target_tilt_deg,
            }),
            limits: command::Limits {
                token: token.clone(),
                max_tilt_rad: ground.max_target_tilt_deg * DEG,
            },
            viewer_rate_hz: ground.viewer_rate_hz,
            max_viewer_rate_hz: ground.max_viewer_rate_hz,
            max_viewers: ground.max_viewers,
            viewer_queue: ground.viewer_queue,
            max_message_bytes: ground.max_message_bytes,
            command_burst: ground.command_burst,
            command_rate_hz: ground.command_rate_hz,
            to_bus,
            command_topic: topic::GROUND_COMMAND,
        };
        let server = Server::start(&ground.bind, ground.port, settings)
            .with_context(|| format!("listening on {}:{}", ground.bind, ground.port))?;
        let addr = server.addr;
        let info_path = config.run.log.with_extension("ground.json");
        let info = json!({
            "url": format!("http://{addr}/"),
            "ws": format!("ws://{addr}/"),
            "token": token,
        });
        write_private(&info_path, info.to_string().as_bytes())
            .with_context(|| format!("writing {}", info_path.display()))?;
        tracing::info!("ground station on http://{addr}/ (Foxglove WebSocket ws://{addr}/)");
        let streams = vec![
            stream::<AttitudeEstimate>(bus)?,
            stream::<ControllerStatus>(bus)?,
            stream::<SimTruth>(bus)?,
            stream::<WheelTelemetry>(bus)?,
            stream::<WheelCommand>(bus)?,
            stream::<CmgTelemetry>(bus)?,
            stream::<CmgCommand>(bus)?,
            stream::<GyroSample>(bus)?,
            stream::<Heartbeat>(bus)?,
            stream::<HealthEvent>(bus)?,
            stream::<CanLinkStatus>(bus)?,
            stream::<GroundCommand>(bus)?,
            stream::<GroundCommandAck>(bus)?,
            stream::<ThrusterStatus>(bus)?,
            stream::<ThrusterCommand>(bus)?,
        ];
        let ports = GroundLinkPorts {
            streams,
            command: bus.publisher()?,
            ack: bus.publisher()?,
            service_period: std::cell::Cell::new(SERVICE_PERIOD),
        };
        Ok((
            Self {
                server,
                from_viewers,
                info_path,
                pyramid: CmgPyramid::from_config(&config.model.cmg),
                target_hpr: hpr(&config.manoeuvre.target()),
                pending_targets: HashMap::new(),
                last_mode: None,
                last_status: Instant::now() - STATUS_PERIOD,
                buffer: Vec::with_capacity(1024),
                records: Vec::new(),
            },
            ports,
        ))
    }

    fn serve(&mut self, record: &LogRecord) {
        let Some((channel, decimate)) = bus_channel(record) else {
            return;
        };
        let shared = &self.server.shared;
        let header = *record.header();
        if !matches!(record, LogRecord::Heartbeat(_)) {
            shared.now_ns.fetch_max(header.time_ns, Ordering::Relaxed);
        }
        let t = header.time_ns;
        // Encoding for nobody is most of the link's work on a bus with no viewer connected.
        let watched = shared.has_viewers();
        if watched {
            self.buffer.clear();
            record.encode_json(&mut self.buffer);
            shared.broadcast(
                channel,
                header.source_id,
                decimate,
                header.time_ns,
                &self.buffer,
            );
        }
        if watched && let Some((topic, child, q)) = foxglove::transform_of(record) {
            let text = foxglove::frame_transform_json(shared.start_time_ns + t, child, &q);
            let channel = if topic == foxglove::TF_ESTIMATE_TOPIC {
                CH_TF_ESTIMATE
            } else {
                CH_TF_TRUTH
            };
            shared.broadcast(channel, 0, true, t, text.as_bytes());
        }
        match record {
            LogRecord::CmgTelemetry(c) if watched => {
                let measure = testbed_flight::cmg_steering::singularity_measure(
                    &self.pyramid,
                    &nalgebra::Vector4::from(c.gimbal_angle),
                );
                let text = json!({
                    "time_ns": t,
                    "gimbal_angle": c.gimbal_angle,
                    "gimbal_rate": c.gimbal_rate,
                    "singularity_measure": measure,
                })
                .to_string();
                shared.broadcast(CH_CMG, 0, true, t, text.as_bytes());
            }
            LogRecord::ControllerStatus(s) if self.last_mode != Some(s.mode) => {
                let name = |m: u32| {
                    ControllerMode::from_u32(m)
                        .map_or_else(|| format!("mode {m}"), |m| format!("{m:?}"))
                };
                let text = match self.last_mode {
                    Some(old) => format!("controller mode {} → {}", name(old), name(s.mode)),
                    None => format!("controller mode {}", name(s.mode)),
                };
                self.last_mode = Some(s.mode);
                let event = json!({"time_ns": t, "text": text}).to_string();
                shared.broadcast(CH_EVENTS, 0, false, t, event.as_bytes());
            }
            LogRecord::GroundCommandAck(a) if a.decided_by == GroundCommandAck::BY_CONTROLLER => {
                if let Some(target) = self.pending_targets.remove(&(a.client_id, a.command_id))
                    && a.status() == Some(GroundAckStatus::Applied)
                {
                    self.target_hpr = target;
                }
            }
            _ => {}
        }
    }

    fn status(&self) {
        let shared = &self.server.shared;
        let [h, p, r] = self.target_hpr.map(|a| a / DEG);
        let mut value = shared.stats.to_json();
        value["target_deg"] = json!({"heading": h, "tilt_x": p, "tilt_y": r});
        value["time_ns"] = shared.now_ns.load(Ordering::Relaxed).into();
        let t = shared.now_ns.load(Ordering::Relaxed);
        shared.broadcast(CH_LINK, 0, false, t, value.to_string().as_bytes());
    }
}

/// Writes `bytes` to `path`, readable by the owner only (it holds the token).
fn write_private(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)?;
    file.write_all(bytes)
}

impl Node for GroundLinkProcess {
    type Ports = GroundLinkPorts;

    fn wake_on<'a>(
        &mut self,
        ports: &'a GroundLinkPorts,
        wake: &mut WakeOn<'_, '_, 'a>,
    ) -> anyhow::Result<()> {
        // The link never wakes per sample: it drains every stream on a timer. Paced, the
        // service period's wake-ups take every sample: a viewer sees it at most one period
        // later (it draws at a few hertz), and the link no longer wakes for each of some 150
        // samples a second (issue 18: it cost 0.5 % of a core with no viewer at all).
        // Lockstep runs as fast as the machine allows: a wake-up for every sample of every
        // topic (about ten a tick) took as much CPU as the tick's own processes, on the same
        // cores. It instead drains everything every LOCKSTEP_DRAIN of wall time: at 10 000
        // ticks per second that is 50 samples a topic, within the 256 of the buffers, so a
        // lossless publisher never waits for the link.
        if wake.mode() == ClockMode::Lockstep {
            wake.interval(LOCKSTEP_DRAIN)?;
        }
        wake.variable_interval(&ports.service_period)?;
        Ok(())
    }

    fn on_wake(&mut self, ports: &GroundLinkPorts, _wake: Wake, io: &Io) -> anyhow::Result<Flow> {
        ports
            .service_period
            .set(if self.server.shared.has_viewers() {
                SERVICE_PERIOD
            } else {
                UNWATCHED_PERIOD
            });
        let mut records = std::mem::take(&mut self.records);
        for s in &ports.streams {
            s.drain(&mut |r| records.push(r))?;
        }
        io.heartbeat.add_samples_in(records.len() as u64);
        for record in records.drain(..) {
            self.serve(&record);
        }
        self.records = records;
        while let Ok(message) = self.from_viewers.try_recv() {
            match message {
                ToBus::Command(command) => {
                    if command.kind() == Some(GroundCommandKind::Target) {
                        let target = attitude::from_heading_pitch_roll(
                            command.target_heading_rad,
                            command.target_pitch_rad,
                            command.target_roll_rad,
                        );
                        self.pending_targets
                            .insert((command.client_id, command.command_id), hpr(&target));
                    }
                    tracing::info!(
                        id = command.command_id,
                        kind = command.kind,
                        "ground command forwarded"
                    );
                    ports.command.publish(&command)?;
                }
                ToBus::Ack(ack) => {
                    tracing::info!(
                        id = ack.command_id,
                        reason = ack.reason(),
                        "ground command rejected"
                    );
                    ports.ack.publish(&ack)?;
                }
            }
            io.heartbeat.add_samples_out(1);
        }
        if self.last_status.elapsed() >= STATUS_PERIOD {
            self.last_status = Instant::now();
            self.status();
        }
        Ok(Flow::Continue)
    }

    fn stop(&mut self, _ports: &GroundLinkPorts, _io: &Io, _exit: LoopExit) -> anyhow::Result<()> {
        self.server.stop();
        let stats = self.server.shared.stats.to_json();
        tracing::info!(%stats, "ground link stopping");
        let _ = std::fs::remove_file(&self.info_path);
        Ok(())
    }
}
