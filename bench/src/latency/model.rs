//! What a run measured: the rows of the report and how the rounds of one configuration add up
//! to a row.

use crate::latency::protocol::{Transport, WaitCounts};
use crate::latency::stats::{Percentiles, percentiles};
use crate::latency::system::{CpuTime, Machine};
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// What a measurement measures.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// One hop of 48 B (the pipeline's samples), ping-pong with a pause before each exchange.
    #[default]
    Hop,
    /// Gyro gateway → estimator → controller → wheel gateway.
    Chain,
    /// One hop, back to back, across sample sizes.
    Sweep,
}

/// One measured configuration.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Measurement {
    pub kind: Kind,
    pub transport: Transport,
    pub load: bool,
    /// Sample size, bytes (hop and sweep).
    pub size: usize,
    /// The chain ran the real `estimator` and `controller` binaries.
    pub real_binaries: bool,
    /// The chain's four processes were placed on this CPU (`--chain-cpus`); `None`: wherever
    /// the scheduler put them.
    pub chain_cpu: Option<usize>,
    pub latency: Percentiles,
    /// Messages measured (hops or cycles).
    pub messages: usize,
    /// Samples that never arrived or whose time stamps were unusable.
    pub incomplete: usize,
    /// CPU time of all the measurement's processes per message, µs.
    pub cpu_us_per_msg: f64,
    /// Time those processes were runnable but waited for a CPU, per message, µs.
    pub runqueue_us_per_msg: f64,
    pub wall_s: f64,
    /// Share of the machine's CPU time that was busy during the measurement (anyone's).
    pub machine_busy: f64,
    /// How the event loops' data wake-ups came about: (process, counts).
    pub wait: Vec<(String, WaitCounts)>,
    /// Chain: where the time goes, stage by stage (hops and compute).
    pub stages: Vec<(String, Percentiles)>,
    /// Each round on its own, in round order (`None`: the round failed): rows of one run
    /// compared round by round, each pair measured minutes apart at most.
    #[serde(default)]
    pub rounds: Vec<Option<RoundStats>>,
    pub error: Option<String>,
}

/// What one round of a configuration measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RoundStats {
    pub latency: Percentiles,
    /// Share of the machine's CPU time that was busy during the round (anyone's).
    pub machine_busy: f64,
}

impl Measurement {
    /// The transport's name, the binaries if they ran and the chain's CPU if it was placed.
    pub fn label(&self) -> String {
        let mut label = self.transport.label();
        if self.real_binaries {
            label.push_str(" — real `estimator` + `controller` binaries");
        }
        if let Some(cpu) = self.chain_cpu {
            label.push_str(&format!(" — chain on CPU {cpu}"));
        }
        label
    }
}

#[cfg(test)]
impl Measurement {
    /// A successful row for tests: median `p50` and tail `p99` µs (p90, p99.9 and the maximum
    /// at the tail, the mean at the median), 100 messages, 48-B samples for a hop.
    pub(crate) fn test_row(
        kind: Kind,
        transport: Transport,
        load: bool,
        p50: f64,
        p99: f64,
    ) -> Self {
        Measurement {
            kind,
            transport,
            load,
            size: if kind == Kind::Hop { 48 } else { 0 },
            latency: Percentiles {
                n: 100,
                p50,
                p90: p99,
                p99,
                p999: p99,
                max: p99,
                mean: p50,
            },
            messages: 100,
            ..Measurement::default()
        }
    }
}

/// One paced `testbed run`.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PacedRun {
    /// `TESTBED_BUS_WAIT` of the run (`+fifo`: real-time priority for the control chain).
    pub wait: String,
    pub load: bool,
    pub duration_s: f64,
    /// Ticks whose wheel command the observer saw.
    pub ticks: usize,
    /// Deadline misses the controller counted (ControllerStatus.deadline_misses, supervised
    /// from the first estimate on): the run summary's, or the observer's last status if that
    /// says more.
    pub deadline_misses: u64,
    /// Ticks whose wheel command arrived after the next tick's truth, or never.
    pub late_commands: u64,
    /// |period − 100 ms| of consecutive wheel-command arrivals, µs.
    pub period_error: Percentiles,
    pub period_min_ms: f64,
    pub period_max_ms: f64,
    /// |period − 100 ms| of the plant's truth samples (the clock that drives the loop), µs.
    pub clock_error: Percentiles,
    /// Truth published → wheel command seen (through gyro gateway, estimator, controller), µs.
    pub truth_to_command: Percentiles,
    /// CPU of the whole pipeline in % of one core.
    pub pipeline_cpu_percent: f64,
    /// Stages of truth → command: (name, distribution in µs).
    pub stages: Vec<(String, Percentiles)>,
    /// CPU and run-queue time of each process of the run, per tick.
    pub processes: Vec<ProcessCost>,
    pub summary: serde_json::Value,
    pub error: Option<String>,
}

/// What one process of a paced run cost.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ProcessCost {
    pub name: String,
    pub cpu_us_per_tick: f64,
    /// Time runnable but waiting for a CPU.
    pub runqueue_us_per_tick: f64,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Report {
    pub machine: Machine,
    pub command: String,
    pub quick: bool,
    pub settings: serde_json::Value,
    pub measurements: Vec<Measurement>,
    pub paced: Vec<PacedRun>,
    pub wall_s: f64,
    /// The run measured everything it planned (false in the reports saved along the way).
    #[serde(default)]
    pub complete: bool,
}

impl Report {
    /// The successful row of this configuration, its processes placed by the scheduler.
    pub fn find(
        &self,
        kind: Kind,
        transport: Transport,
        load: bool,
        size: usize,
        binaries: bool,
    ) -> Option<&Measurement> {
        self.find_placed(kind, transport, load, size, binaries, None)
    }

    /// The successful row of this configuration with the chain on `chain_cpu` (`None`: not
    /// placed).
    pub fn find_placed(
        &self,
        kind: Kind,
        transport: Transport,
        load: bool,
        size: usize,
        binaries: bool,
        chain_cpu: Option<usize>,
    ) -> Option<&Measurement> {
        self.measurements.iter().find(|m| {
            m.kind == kind
                && m.transport == transport
                && m.load == load
                && m.size == size
                && m.real_binaries == binaries
                && m.chain_cpu == chain_cpu
                && m.error.is_none()
        })
    }

    /// The rows of one kind, in measurement order.
    pub fn rows(&self, kind: Kind) -> impl Iterator<Item = &Measurement> {
        self.measurements.iter().filter(move |m| m.kind == kind)
    }
}

/// One configuration of the plan.
#[derive(Debug, Clone)]
pub struct Plan {
    pub kind: Kind,
    pub transport: Transport,
    pub size: usize,
    /// Hops or cycles over all rounds.
    pub count: usize,
    /// Hop: pause before each exchange; chain: period; µs.
    pub interval_us: u64,
    pub load: bool,
    pub binaries: bool,
    /// Chain: place its four processes on this CPU.
    pub chain_cpu: Option<usize>,
}

/// What one round of one configuration measured.
#[derive(Debug, Clone, Default)]
pub struct Part {
    pub latencies: Vec<u64>,
    pub incomplete: usize,
    pub cpu: CpuTime,
    pub busy: f64,
    pub wall: Duration,
    pub wait: Vec<(String, WaitCounts)>,
    /// Chain: time of each stage (hops and compute), ns.
    pub stages: Vec<(String, Vec<u64>)>,
}

impl Plan {
    /// The measurement of all rounds together (a failed round is reported; the others count).
    pub fn merge(&self, parts: Vec<Result<Part, String>>) -> Measurement {
        let mut m = Measurement {
            kind: self.kind,
            transport: self.transport,
            load: self.load,
            size: self.size,
            real_binaries: self.binaries,
            chain_cpu: self.chain_cpu,
            ..Measurement::default()
        };
        let (mut all, mut stages) = (Vec::new(), Vec::<(String, Vec<u64>)>::new());
        let (mut cpu, mut busy, mut wall) = (CpuTime::default(), 0.0, Duration::ZERO);
        let errors: Vec<String> = parts
            .iter()
            .filter_map(|p| p.as_ref().err().cloned())
            .collect();
        for part in parts {
            let Ok(mut part) = part else {
                m.rounds.push(None);
                continue;
            };
            // Sorted in place by `percentiles`; the pooled distribution does not need the order.
            m.rounds
                .push((!part.latencies.is_empty()).then(|| RoundStats {
                    latency: percentiles(&mut part.latencies),
                    machine_busy: part.busy,
                }));
            all.extend(part.latencies);
            for (name, times) in part.stages {
                match stages.iter_mut().find(|(n, _)| *n == name) {
                    Some((_, all)) => all.extend(times),
                    None => stages.push((name, times)),
                }
            }
            m.incomplete += part.incomplete;
            cpu = CpuTime::sum([cpu, part.cpu]);
            busy += part.busy * part.wall.as_secs_f64();
            wall += part.wall;
            for (process, w) in part.wait {
                match m.wait.iter_mut().find(|(p, _)| *p == process) {
                    Some((_, sum)) => sum.add(w),
                    None => m.wait.push((process, w)),
                }
            }
        }
        if !errors.is_empty() {
            m.error = Some(format!(
                "{} of the rounds failed: {}",
                errors.len(),
                errors.join("; ")
            ));
        }
        if all.is_empty() {
            m.error.get_or_insert_with(|| "nothing measured".into());
            return m;
        }
        m.messages = all.len();
        m.latency = percentiles(&mut all);
        m.stages = stages
            .into_iter()
            .map(|(name, mut times)| (name, percentiles(&mut times)))
            .collect();
        let n = m.messages as f64;
        m.cpu_us_per_msg = cpu.run_ns as f64 / 1e3 / n;
        m.runqueue_us_per_msg = cpu.wait_ns as f64 / 1e3 / n;
        m.wall_s = wall.as_secs_f64();
        m.machine_busy = if m.wall_s > 0.0 { busy / m.wall_s } else { 0.0 };
        m
    }
}

/// The ratio `value(a) / value(b)` of every round that both rows measured (round i of one
/// against round i of the other: the configurations take turns within a round), in round order.
pub fn round_ratios(
    a: &Measurement,
    b: &Measurement,
    value: impl Fn(&Percentiles) -> f64,
) -> Vec<f64> {
    a.rounds
        .iter()
        .zip(&b.rounds)
        .filter_map(|(a, b)| Some(value(&a.as_ref()?.latency) / value(&b.as_ref()?.latency)))
        .filter(|ratio| ratio.is_finite())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(latencies_us: &[u64]) -> Result<Part, String> {
        Ok(Part {
            latencies: latencies_us.iter().map(|us| us * 1000).collect(),
            busy: 0.25,
            wall: Duration::from_secs(1),
            ..Part::default()
        })
    }

    fn plan() -> Plan {
        Plan {
            kind: Kind::Chain,
            transport: Transport::Uds,
            size: 0,
            count: 6,
            interval_us: 500,
            load: false,
            binaries: false,
            chain_cpu: None,
        }
    }

    #[test]
    fn rounds_keep_their_order_and_a_failed_round_its_place() {
        let m = plan().merge(vec![
            part(&[10, 20]),
            Err("slow start".into()),
            part(&[30, 40]),
        ]);
        let p50s: Vec<Option<f64>> = m
            .rounds
            .iter()
            .map(|r| r.as_ref().map(|r| r.latency.p50))
            .collect();
        assert_eq!(p50s, [Some(10.0), None, Some(30.0)]);
        assert_eq!(m.rounds[0].map(|r| r.machine_busy), Some(0.25));
        assert_eq!(
            m.latency.n, 4,
            "the pooled distribution has every round that ran"
        );
    }

    #[test]
    fn round_ratios_pair_round_i_with_round_i_and_skip_a_round_either_lacks() {
        let a = plan().merge(vec![part(&[20]), part(&[30]), Err("x".into()), part(&[50])]);
        let b = plan().merge(vec![
            part(&[10]),
            Err("y".into()),
            part(&[10]),
            part(&[100]),
        ]);
        assert_eq!(round_ratios(&a, &b, |l| l.p50), [2.0, 0.5]);
    }
}
