//! Running one round of one configuration: the hop and the chain, each in processes of their
//! own, with a bus and socket addresses of their own.

use crate::latency::model::{Kind, Part, Plan};
use crate::latency::protocol::{Addr, Role, STARTUP, Signal, Transport, WorkerResult, WorkerSpec};
use crate::latency::recording::run_config;
use crate::latency::runner::{Group, Who};
use crate::latency::stats::differences;
use crate::latency::system::{Hog, MachineCpu, pin_process};
use anyhow::{Context, Result, bail};
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Warm-up samples before `n` measured ones.
pub fn warmup(n: usize) -> usize {
    (n / 20).clamp(50, 2_000)
}

/// The `testbed` executable next to this one (target/<profile>/): the pipeline's processes are
/// its roles.
pub fn testbed_binary() -> Option<PathBuf> {
    let path = std::env::current_exe().ok()?.parent()?.join("testbed");
    path.exists().then_some(path)
}

/// What the measurements of a run share.
pub struct Ctx {
    /// Measurements so far (names their buses and socket directories).
    pub n: usize,
    pub hog_cpu: usize,
    pub scratch: PathBuf,
    /// The chain's recording.
    pub recording: PathBuf,
}

/// Per-measurement resources: a bus of its own and a directory for its sockets.
struct Setup {
    prefix: String,
    root: String,
    sock_dir: PathBuf,
}

impl Drop for Setup {
    fn drop(&mut self) {
        let _ = testbed_bus::remove_all(&testbed_bus::BusConfig::new(
            self.prefix.clone(),
            self.root.clone(),
        ));
        let _ = std::fs::remove_dir_all(&self.sock_dir);
    }
}

impl Setup {
    /// The spec of every worker of the measurement (the role set per worker).
    fn spec(
        &self,
        p: &Plan,
        names: &[&str],
        count: usize,
        recording: Option<&Path>,
    ) -> Result<WorkerSpec> {
        let addrs = names
            .iter()
            .map(|n| {
                Ok(match p.transport {
                    Transport::Udp => {
                        Addr::Udp(std::net::UdpSocket::bind("127.0.0.1:0")?.local_addr()?)
                    }
                    _ => Addr::Uds(self.sock_dir.join(format!("{n}.sock"))),
                })
            })
            .collect::<Result<_>>()?;
        Ok(WorkerSpec {
            role: Role::Ping,
            transport: p.transport,
            bus_prefix: self.prefix.clone(),
            bus_root: self.root.clone(),
            addrs,
            size: p.size,
            warmup: warmup(count),
            count,
            interval_us: p.interval_us,
            recording: recording.map(Path::to_path_buf),
        })
    }
}

/// Time and CPU over the measured window.
struct Window {
    cpu: crate::latency::system::CpuTime,
    busy: MachineCpu,
    start: Instant,
}

impl Window {
    fn open(group: &Group) -> Self {
        Self {
            cpu: group.cpu(),
            busy: MachineCpu::now(),
            start: Instant::now(),
        }
    }
    fn close(self, group: &Group, part: &mut Part) {
        part.cpu = group.cpu().since(self.cpu);
        part.busy = MachineCpu::now().busy_since(self.busy);
        part.wall = self.start.elapsed();
    }
}

impl Ctx {
    fn setup(&mut self) -> Result<Setup> {
        self.n += 1;
        let pid = std::process::id();
        let sock_dir = self.scratch.join(format!("s{}", self.n));
        std::fs::create_dir_all(&sock_dir)?;
        Ok(Setup {
            prefix: format!("lt{pid}x{}_", self.n),
            root: format!("/tmp/lt-{pid}-{}/", self.n),
            sock_dir,
        })
    }

    /// One round of `p`, `count` hops or cycles.
    pub fn round(&mut self, p: &Plan, count: usize) -> Result<Part, String> {
        let _hog = p.load.then(|| Hog::start(self.hog_cpu));
        match p.kind {
            Kind::Chain => self.chain(p, count),
            Kind::Hop | Kind::Sweep => self.hop(p, count),
        }
        .map_err(|e| format!("{e:#}"))
    }

    /// Ping-pong: `hops` measured hops, half each way.
    fn hop(&mut self, p: &Plan, hops: usize) -> Result<Part> {
        let setup = self.setup()?;
        let exchanges = hops.div_ceil(2);
        let spec = setup.spec(p, &["ping", "pong"], exchanges, None)?;
        let mut group = Group::default();
        let pong = group.worker(&WorkerSpec {
            role: Role::Pong,
            ..spec.clone()
        })?;
        let ping = group.worker(&WorkerSpec {
            role: Role::Ping,
            ..spec
        })?;
        group.start(&[pong, ping], &[ping], STARTUP)?;
        group.expect(ping, Signal::Measuring, STARTUP)?;
        let window = Window::open(&group);
        group.expect(
            ping,
            Signal::Done,
            Duration::from_secs(60)
                + Duration::from_micros((p.interval_us + 2_000) * exchanges as u64),
        )?;
        let mut part = Part::default();
        window.close(&group, &mut part);
        let ping_result = group.result(ping, STARTUP)?;
        let pong_result = group.result(pong, STARTUP)?;
        group.finish(Duration::from_secs(10))?;
        let (mut there, a) = differences(&ping_result.sent, &pong_result.received);
        let (back, b) = differences(&pong_result.sent, &ping_result.received);
        there.extend(back);
        part.incomplete = a + b;
        part.latencies = there;
        part.wait = [("ping", ping_result), ("pong", pong_result)]
            .into_iter()
            .filter_map(|(n, r)| Some((n.to_string(), r.wait?)))
            .collect();
        Ok(part)
    }

    /// The chain (with the real estimator and controller processes if `p.binaries`).
    fn chain(&mut self, p: &Plan, cycles: usize) -> Result<Part> {
        let setup = self.setup()?;
        let spec = setup.spec(
            p,
            &["estimator", "controller", "wheels"],
            cycles,
            Some(&self.recording),
        )?;
        let mut group = Group::default();
        let mut nodes: Vec<(Role, Who)> = Vec::new();
        let mut programs = Vec::new();
        if p.binaries {
            let Transport::IoxEvent(wait) = p.transport else {
                bail!("the binaries use the bus")
            };
            let config_path = setup.sock_dir.join("run.toml");
            let mut config = run_config();
            config.run.mode = ipc_types::ClockMode::Paced;
            std::fs::write(&config_path, config.to_toml_string())?;
            let testbed = testbed_binary().context("the testbed executable")?;
            for name in ["estimator", "controller"] {
                let mut command = Command::new(&testbed);
                // The role is the name the executable is started under (`argv[0]`).
                command
                    .arg0(name)
                    .env(testbed_bus::ENV_PREFIX, &setup.prefix)
                    .env(testbed_bus::ENV_ROOT, &setup.root)
                    .env(testbed_bus::ENV_DELIVERY, "overflow")
                    .env(ipc_types::ENV_WAIT, wait.to_string())
                    .env(testbed_config::ENV_RUN_CONFIG, &config_path)
                    .env("RUST_LOG", "warn");
                programs.push(group.program(name, command)?);
            }
        } else {
            for role in [Role::Estimator, Role::Controller] {
                nodes.push((
                    role,
                    group.worker(&WorkerSpec {
                        role,
                        ..spec.clone()
                    })?,
                ));
            }
        }
        let wheels = group.worker(&WorkerSpec {
            role: Role::Wheels,
            ..spec.clone()
        })?;
        let gyro = group.worker(&WorkerSpec {
            role: Role::Gyro,
            ..spec.clone()
        })?;
        let workers: Vec<Who> = nodes
            .iter()
            .map(|&(_, w)| w)
            .chain([wheels, gyro])
            .collect();
        if let Some(cpu) = p.chain_cpu {
            // Placed before any sample flows (they start on `go`); the iceoryx2 threads a
            // process may have started by then are not on the chain's path.
            for &who in workers.iter().chain(&programs) {
                let pid = group.pid(who);
                pin_process(pid, cpu).with_context(|| format!("placing pid {pid} on CPU {cpu}"))?;
            }
        }
        group.start(&workers, &[wheels, gyro], STARTUP)?;
        group.expect(
            gyro,
            Signal::Measuring,
            STARTUP + Duration::from_micros(p.interval_us * spec.warmup as u64),
        )?;
        let window = Window::open(&group);
        group.expect(
            wheels,
            Signal::Done,
            Duration::from_secs(60) + Duration::from_micros(p.interval_us * 3 * cycles as u64),
        )?;
        let mut part = Part::default();
        window.close(&group, &mut part);
        let gyro_result = group.result(gyro, STARTUP)?;
        let wheels_result = group.result(wheels, STARTUP)?;
        let mut results: Vec<(Role, WorkerResult)> = Vec::new();
        for &(role, w) in &nodes {
            results.push((role, group.result(w, STARTUP)?));
        }
        if let [(_, estimator), (_, controller)] = &results[..] {
            let stage = |from: &[u64], to: &[u64]| differences(from, to).0;
            part.stages = vec![
                (
                    "gyro gateway → estimator".into(),
                    stage(&gyro_result.sent, &estimator.received),
                ),
                (
                    "estimator (MEKF)".into(),
                    stage(&estimator.received, &estimator.sent),
                ),
                (
                    "estimator → controller".into(),
                    stage(&estimator.sent, &controller.received),
                ),
                (
                    "controller".into(),
                    stage(&controller.received, &controller.sent),
                ),
                (
                    "controller → wheel gateway".into(),
                    stage(&controller.sent, &wheels_result.received),
                ),
            ];
        }
        for &program in &programs {
            group.terminate(program);
        }
        group.finish(Duration::from_secs(10))?;
        (part.latencies, part.incomplete) = differences(&gyro_result.sent, &wheels_result.received);
        results.push((Role::Wheels, wheels_result));
        part.wait = results
            .iter()
            .filter_map(|(role, r)| Some((role.name().to_string(), r.wait?)))
            .collect();
        let out_of_range = results.last().map_or(0, |(_, r)| r.out_of_range);
        if out_of_range > 0 {
            bail!("{out_of_range} wheel commands out of range");
        }
        Ok(part)
    }
}
