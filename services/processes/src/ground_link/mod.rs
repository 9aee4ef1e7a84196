//! The ground link: the platform side of the ground supervision station. A pure
//! observer of the pipeline — it takes no part in the lockstep start barrier or in any tick —
//! that serves the pipeline's topics to any number of viewers over the Foxglove WebSocket
//! protocol, serves the project's ground page over HTTP from the same port (both over TLS when
//! `ground.tls_cert` is set), and passes the commands of connections in the command role, once
//! checked, to the controller (`testbed/ground/command`).
//!
//! Threads: the bus stays on the node's thread (iceoryx2 ports are not `Send`); the server
//! ([`server`]) has its own threads and exchanges only bounded queues with the node, so a
//! slow or vanished viewer never holds up the pipeline (what does not fit is dropped and
//! counted). See `docs/ground.md` for the channels, the commands and their limits.

pub mod command;
mod connection;
mod http;
pub mod protocol;
pub mod server;
mod shared;
mod stats;
pub mod tls;

use anyhow::Context as _;
use ipc_types::ClockMode;
use ipc_types::*;
use protocol::Channel;
use serde_json::json;
use server::{Server, Settings, ToBus};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use testbed_bus::{AnySubscribers, Flow, LoopExit, SubscriberOptions, TopicPublisher, Wake};
use testbed_config::ENV_GROUND_TOKEN;
use testbed_log::{LogRecord, TopicJson as _, derived_channel_id, foxglove};
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::DEG;
use testbed_model::physics::cmg_pyramid::CmgPyramid;
use testbed_runtime::{Context, Io, Node, WakeOn};

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

/// The channel id of a bus topic: its channel id in the run log ([`testbed_log::channel_id`]).
pub fn bus_channel_id(topic: TopicId) -> u32 {
    testbed_log::channel_id(topic).into()
}

/// Channel ids of what the link derives, after the table's topics: the run log's derived
/// channels ([`foxglove::DERIVED_TOPICS`]: transforms, pose, events, scene), then the link's
/// own channels.
pub const CH_TF_ESTIMATE: u32 = derived_channel_id(0) as u32;
pub const CH_TF_TRUTH: u32 = derived_channel_id(1) as u32;
pub const CH_POSE: u32 = derived_channel_id(2) as u32;
pub const CH_EVENTS: u32 = derived_channel_id(3) as u32;
pub const CH_SCENE: u32 = derived_channel_id(4) as u32;
pub const CH_CMG: u32 = derived_channel_id(foxglove::DERIVED_TOPICS.len()) as u32;
pub const CH_LINK: u32 = CH_CMG + 1;

/// Every channel the link advertises: the topics of the table it shows
/// ([`GroundView`]), then its own.
pub fn channels() -> Vec<Channel> {
    let own = |id, topic, schema_name, schema: String| Channel {
        id,
        topic,
        schema_name,
        schema,
    };
    let shown = TopicId::ALL
        .iter()
        .filter(|topic| topic.ground_view() != GroundView::Hidden);
    let mut channels: Vec<Channel> = shown
        .map(|&topic| {
            own(
                bus_channel_id(topic),
                topic.name(),
                topic.schema_name(),
                topic.json_schema(),
            )
        })
        .collect();
    channels.extend(
        foxglove::DERIVED_TOPICS
            .iter()
            .zip(foxglove::derived_schemas())
            .enumerate()
            .map(|(i, (&topic, (name, schema)))| {
                own(derived_channel_id(i).into(), topic, name, schema.to_owned())
            }),
    );
    channels.extend([
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
    ]);
    channels
}

/// The ground link's ports.
pub struct GroundLinkPorts {
    streams: AnySubscribers<LogRecord>,
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
    /// The controller's mode changes, as events.
    modes: foxglove::events::ModeChanges,
    /// The platform's shape, sent with the status every second.
    scene: foxglove::scene::Scene,
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
    testbed_config::random_token().context("making the ground command token")
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
        let tls = match (&ground.tls_cert, &ground.tls_key) {
            (Some(cert), Some(key)) => Some(tls::server_config(cert, key)?),
            _ => None,
        };
        let (http, ws) = if tls.is_some() {
            ("https", "wss")
        } else {
            ("http", "ws")
        };
        // Read-only parameters: the run configuration, less the command token.
        let parameters = protocol::flatten_parameters(
            &serde_json::to_value(config).context("the run configuration as parameters")?,
            &["ground.token"],
        );
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
            parameters,
            limits: command::Limits {
                token: token.clone(),
                max_tilt_rad: ground.max_target_tilt_deg * DEG,
            },
            ground: ground.clone(),
            tls,
            to_bus,
            command_topic: topic::GROUND_COMMAND,
        };
        let server = Server::start(settings)
            .with_context(|| format!("listening on {}:{}", ground.bind, ground.port))?;
        let addr = server.addr;
        server
            .shared
            .stats
            .latency
            .set_paced(config.run.mode == ClockMode::Paced);
        let info_path = config.run.log.with_extension("ground.json");
        let info = json!({
            "url": format!("{http}://{addr}/"),
            "ws": format!("{ws}://{addr}/"),
            "token": token,
        });
        write_private(&info_path, info.to_string().as_bytes())
            .with_context(|| format!("writing {}", info_path.display()))?;
        tracing::info!("ground station on {http}://{addr}/ (Foxglove WebSocket {ws}://{addr}/)");
        // Deep buffers: in lockstep (lossless delivery) a publisher waits only if the link
        // falls 256 samples behind, and the link's thread does nothing but copy samples to
        // queues. Drained on timers only (see `wake_on`): publishing rings no doorbell of the
        // link.
        let streams = bus.subscribe_each(SubscriberOptions::buffer(256).polled(), |topic| {
            topic.ground_view() != GroundView::Hidden
        })?;
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
                modes: Default::default(),
                scene: crate::scene::platform_scene(&config.model, "body"),
                last_status: Instant::now() - STATUS_PERIOD,
                buffer: Vec::with_capacity(1024),
                records: Vec::new(),
            },
            ports,
        ))
    }

    /// Serves `record`, drained at wall time `wall_ns`.
    fn serve(&mut self, record: &LogRecord, wall_ns: u64) {
        let topic = record.topic_id();
        let decimate = match topic.ground_view() {
            GroundView::Hidden => return,
            GroundView::Decimated => true,
            GroundView::Whole => false,
        };
        let channel = bus_channel_id(topic);
        let shared = &self.server.shared;
        let header = *record.header();
        if !matches!(record, LogRecord::Heartbeat(_)) {
            shared.now_ns.fetch_max(header.time_ns, Ordering::Relaxed);
            shared.stats.latency.observe_stamp(header.time_ns, wall_ns);
        }
        let t = header.time_ns;
        // Encoding for nobody is most of the link's work on a bus with no viewer connected.
        let watched = shared.has_viewers();
        if watched {
            self.buffer.clear();
            record.encode_json(&mut self.buffer);
            // A heartbeat repeats the time of its process's last activity: no latency.
            let stamped = !matches!(record, LogRecord::Heartbeat(_));
            shared.broadcast(
                channel,
                header.source_id,
                decimate,
                header.time_ns,
                stamped,
                &self.buffer,
            );
        }
        let stamp = shared.start_time_ns + t;
        let event = match foxglove::derived_of(record) {
            foxglove::Derived::Transform((topic, child, q)) => {
                if watched {
                    let text = foxglove::frame_transform_json(stamp, child, &q);
                    if topic == foxglove::TF_ESTIMATE_TOPIC {
                        shared.broadcast(CH_TF_ESTIMATE, 0, true, t, true, text.as_bytes());
                        let pose = foxglove::pose_in_frame_json(stamp, &q);
                        shared.broadcast(CH_POSE, 0, true, t, true, pose.as_bytes());
                    } else {
                        shared.broadcast(CH_TF_TRUTH, 0, true, t, true, text.as_bytes());
                    }
                }
                None
            }
            foxglove::Derived::Event(event) => Some(event),
            // Followed even while nobody watches: a viewer that connects later sees changes.
            foxglove::Derived::Mode(mode) => self.modes.event(mode),
            foxglove::Derived::Nothing => None,
        };
        if let Some(event) = event {
            let text = event.log_json(stamp);
            shared.broadcast(CH_EVENTS, 0, false, t, true, text.as_bytes());
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
                shared.broadcast(CH_CMG, 0, true, t, true, text.as_bytes());
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
        shared.broadcast(CH_LINK, 0, false, t, false, value.to_string().as_bytes());
        if shared.has_viewers() {
            let scene = self.scene.update_json(shared.start_time_ns + t);
            shared.broadcast(CH_SCENE, 0, false, t, false, scene.as_bytes());
        }
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
        // samples a second (it cost 0.5 % of a core with no viewer at all).
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
            s.drain_as(&mut |r| records.push(r))?;
        }
        io.heartbeat.add_samples_in(records.len() as u64);
        let wall_ns = testbed_log::unix_time_ns();
        for record in records.drain(..) {
            self.serve(&record, wall_ns);
        }
        self.records = records;
        // The heartbeat describes the run as far as the link has seen it (not time 0: a
        // heartbeat stamped 0 in the log widens every chunk's time range back to the start).
        io.heartbeat
            .set_time_ns(self.server.shared.now_ns.load(Ordering::Relaxed));
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
            self.server.shared.stats.latency.roll();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The ids a viewer sees (those of `docs/ground.md`): a bus topic's is its channel id in the
    /// run log, the derived channels' (transforms, pose, events, scene) too, and the link's own
    /// follow.
    #[test]
    fn channel_ids_are_the_logs_and_pinned() {
        let ids: Vec<(u32, &str)> = channels().iter().map(|c| (c.id, c.topic)).collect();
        assert_eq!(
            ids,
            [
                (1, topic::GYRO),
                (4, topic::WHEEL_TELEMETRY),
                (5, topic::WHEEL_COMMAND),
                (6, topic::CMG_TELEMETRY),
                (7, topic::CMG_COMMAND),
                (8, topic::ATTITUDE_ESTIMATE),
                (9, topic::CONTROLLER_STATUS),
                (10, topic::SIM_TRUTH),
                (12, topic::HEARTBEAT),
                (14, topic::CAN_STATUS),
                (17, topic::HEALTH),
                (18, topic::GROUND_COMMAND),
                (19, topic::GROUND_COMMAND_ACK),
                (20, topic::THRUSTER_COMMAND),
                (21, topic::THRUSTER_STATUS),
                (23, foxglove::TF_ESTIMATE_TOPIC),
                (24, foxglove::TF_TRUTH_TOPIC),
                (25, foxglove::POSE_ESTIMATE_TOPIC),
                (26, foxglove::events::EVENTS_TOPIC),
                (27, foxglove::scene::SCENE_TOPIC),
                (28, "testbed/ground/cmg"),
                (29, "testbed/ground/link"),
            ]
        );
        for channel in channels().iter().take_while(|c| c.id < CH_TF_ESTIMATE) {
            let topic = TopicId::from_name(channel.topic).expect("a topic of the table");
            assert_eq!(channel.id, u32::from(testbed_log::channel_id(topic)));
            assert_eq!(channel.schema_name, topic.schema_name());
        }
    }
}
