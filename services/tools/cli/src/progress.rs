//! Progress of a running pipeline, read from its growing MCAP log (the logger writes records
//! unchunked and in time order, so a log being written reads like a cut one): the run's time,
//! real-time factor and the current attitude error, true where the run has a truth (a
//! simulation), estimated otherwise (the platform, a replay). A bar on a terminal (`indicatif`),
//! otherwise a plain line every [`PLAIN_EVERY`] of wall time. Reading the log is passive: the
//! pipeline is not slowed or changed by it (a bus subscriber would be one more participant of a
//! lossless lockstep bus). The log is followed with a [`LogTail`]: each look reads only what
//! was appended since the one before, so following a long paced run costs what the run writes,
//! not its whole log again every half second.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ipc_types::{AttitudeEstimate, SimTruth, Topic};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};
use testbed_flight::convert::{quaternion_from_array, seconds};
use testbed_log::{LogEncode, LogTail};
use testbed_model::attitude::{self, Attitude};
use testbed_model::config::DEG;

/// Nothing is shown for runs shorter than this.
pub const QUIET_FOR: Duration = Duration::from_secs(2);
/// Interval of the plain progress lines when stderr is not a terminal.
pub const PLAIN_EVERY: Duration = Duration::from_secs(10);

/// What to follow.
#[derive(Debug, Clone)]
pub struct Follow {
    /// The run's log.
    pub log: PathBuf,
    /// Simulated duration the run ends at, s (`None`: until the source ends or Ctrl-C).
    pub duration_s: Option<f64>,
    /// The attitude the controller holds.
    pub target: Attitude,
}

/// Which attitude the error shown is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Attitudes {
    /// The simulation's truth (`SimTruth`).
    True,
    /// The estimator's (`AttitudeEstimate`): runs without a truth.
    Estimated,
}

/// The latest state read from the log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// The run's time, s (simulated time in a simulation).
    pub t_s: f64,
    /// Attitude error, rotation vector target → attitude, body axes, degrees.
    pub error_deg: [f64; 3],
    /// Whose attitude.
    pub of: Attitudes,
}

/// Follows a run's log for its attitude: the truth where the run has one, else the estimate.
pub struct Watch {
    tail: LogTail,
    /// A truth sample was seen: this run is a simulation, its estimates are not shown.
    truth_seen: bool,
}

impl Watch {
    pub fn new(log: &std::path::Path) -> Self {
        Self {
            tail: LogTail::new(log),
            truth_seen: false,
        }
    }

    /// The state of the newest truth (or estimate) sample appended since the last look, if any.
    pub fn latest(&mut self, target: &Attitude) -> Option<State> {
        let records = self
            .tail
            .newest(&[SimTruth::NAME, AttitudeEstimate::NAME])
            .ok()?;
        let truth = records.iter().find_map(SimTruth::from_record);
        let estimate = records.iter().find_map(AttitudeEstimate::from_record);
        self.truth_seen |= truth.is_some();
        let (time_ns, quaternion, of) = match (truth, estimate) {
            (Some(t), _) => (t.header.time_ns, t.quaternion, Attitudes::True),
            (None, Some(e)) if !self.truth_seen => {
                (e.header.time_ns, e.quaternion, Attitudes::Estimated)
            }
            _ => return None,
        };
        let q = quaternion_from_array(&quaternion)?;
        let e = attitude::attitude_error(&q, target) / DEG;
        Some(State {
            t_s: seconds(time_ns),
            error_deg: [e.x, e.y, e.z],
            of,
        })
    }
}

/// Interval between two looks at the log on a terminal, and between two tries while the log
/// has nothing to show yet.
pub const LOOK_EVERY: Duration = Duration::from_millis(500);

/// How long to sleep before the next look: [`LOOK_EVERY`] on a terminal (the bar moves), else
/// until the next plain line is due, `since_line` after the last one and `wall` into the run
/// (never less than [`LOOK_EVERY`]). Looking twice a second to print a line every ten was two
/// of `testbed run`'s 2.3 wake-ups a second in a paced run.
fn next_look(terminal: bool, wall: Duration, since_line: Duration) -> Duration {
    if terminal {
        return LOOK_EVERY;
    }
    let line_due = QUIET_FOR
        .saturating_sub(wall)
        .max(PLAIN_EVERY.saturating_sub(since_line));
    line_due.max(LOOK_EVERY)
}

/// One line of progress.
pub fn describe(state: &State, duration_s: Option<f64>, wall: Duration) -> String {
    let of = duration_s.map_or_else(String::new, |d| format!(" of {d:.0}"));
    let factor = state.t_s / wall.as_secs_f64().max(1e-3);
    let [x, y, z] = state.error_deg;
    let (time, whose) = match state.of {
        Attitudes::True => ("simulated s", "true"),
        Attitudes::Estimated => ("s", "estimated"),
    };
    format!(
        "{:.1}{of} {time}, {factor:.1}× real time, {whose} attitude error X {x:+.3}° Y {y:+.3}° Z {z:+.3}°",
        state.t_s
    )
}

/// A thread showing the progress until [`finish`](Self::finish).
pub struct Progress {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Progress {
    /// Starts following the run (call when the pipeline starts).
    pub fn start(follow: Follow) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("progress".into())
            .spawn(move || show(&follow, &flag))
            .ok();
        Self { stop, thread }
    }

    /// Stops and clears the display.
    pub fn finish(mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            thread.thread().unpark();
            let _ = thread.join();
        }
    }
}

fn show(follow: &Follow, stop: &AtomicBool) {
    let started = Instant::now();
    let started_at = SystemTime::now();
    let terminal = std::io::stderr().is_terminal();
    let mut bar: Option<ProgressBar> = None;
    let mut last_line = started;
    let mut watch = Watch::new(&follow.log);
    loop {
        std::thread::park_timeout(next_look(terminal, started.elapsed(), last_line.elapsed()));
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let wall = started.elapsed();
        if wall < QUIET_FOR || (!terminal && last_line.elapsed() < PLAIN_EVERY) {
            continue;
        }
        // A log left by an earlier run is not this run's.
        let fresh = std::fs::metadata(&follow.log)
            .and_then(|m| m.modified())
            .is_ok_and(|t| t >= started_at);
        let Some(state) = fresh.then(|| watch.latest(&follow.target)).flatten() else {
            continue;
        };
        let message = describe(&state, follow.duration_s, wall);
        if terminal {
            let bar = bar.get_or_insert_with(|| new_bar(follow.duration_s));
            if follow.duration_s.is_some() {
                bar.set_position((state.t_s * 10.0) as u64);
            }
            bar.set_message(message);
        } else {
            eprintln!("testbed run: {message}");
            last_line = Instant::now();
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
}

fn new_bar(duration_s: Option<f64>) -> ProgressBar {
    let bar = match duration_s {
        Some(d) => {
            ProgressBar::with_draw_target(Some((d * 10.0) as u64), ProgressDrawTarget::stderr())
        }
        None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr()),
    };
    let template = if duration_s.is_some() {
        "{elapsed:>4} [{bar:25}] {msg}"
    } else {
        "{elapsed:>4} {spinner} {msg}"
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn without_a_terminal_the_thread_sleeps_until_the_next_line() {
        let s = Duration::from_secs;
        // On a terminal the bar is fed every look.
        assert_eq!(next_look(true, s(30), s(3)), LOOK_EVERY);
        // A plain line every ten seconds: the first ten seconds after the start, then the rest
        // of the ten after each line.
        assert_eq!(
            next_look(false, Duration::ZERO, Duration::ZERO),
            PLAIN_EVERY
        );
        assert_eq!(next_look(false, s(34), s(4)), s(6));
        // A line overdue (the log had nothing fresh): tried again a look later, not at once.
        assert_eq!(next_look(false, s(40), s(12)), LOOK_EVERY);
    }
    use ipc_types::SampleHeader;
    use testbed_log::{RunInfo, RunLogWriter, WriterOptions};

    /// The platform turned 10° about body z, `[x, y, z, w]`.
    fn turned() -> [f64; 4] {
        let half = 5.0 * DEG;
        [0.0, 0.0, half.sin(), half.cos()]
    }

    fn header(i: u64) -> SampleHeader {
        SampleHeader {
            time_ns: i * 100_000_000,
            ..SampleHeader::default()
        }
    }

    /// A truth sample at `i` × 0.1 s, the platform turned 10° about body z.
    fn truth(i: u64) -> SimTruth {
        SimTruth {
            header: header(i),
            quaternion: turned(),
            ..SimTruth::default()
        }
    }

    /// An estimate at `i` × 0.1 s: level (the error shown must be the truth's, if any).
    fn estimate(i: u64) -> AttitudeEstimate {
        AttitudeEstimate {
            header: header(i),
            quaternion: [0.0, 0.0, 0.0, 1.0],
            ..AttitudeEstimate::default()
        }
    }

    /// A log written as the logger writes during a run: unchunked, handed to the OS as it goes.
    fn log_writer(path: &std::path::Path) -> RunLogWriter {
        let info = RunInfo {
            profile: "test".into(),
            seed: 1,
            mode: "paced".into(),
            config_toml: String::new(),
            start_time_ns: 0,
            extra: Default::default(),
        };
        let options = WriterOptions {
            buffer_bytes: 0,
            indexed: false,
            ..WriterOptions::default()
        };
        RunLogWriter::create_with(path, &info, options).unwrap()
    }

    fn temp_log(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!(
            "testbed-progress-{}-{name}.mcap",
            std::process::id()
        ))
    }

    #[test]
    fn each_look_gives_the_newest_truth_appended_since_the_last() {
        let path = temp_log("truth");
        let target = Attitude::identity();
        let mut watch = Watch::new(&path);
        assert_eq!(watch.latest(&target), None, "no log yet");

        let mut writer = log_writer(&path);
        for i in 0..20 {
            writer.write(&truth(i)).unwrap();
            writer.write(&estimate(i)).unwrap();
        }
        writer.flush().unwrap();
        let state = watch.latest(&target).unwrap();
        assert!((state.t_s - 1.9).abs() < 1e-12, "{state:?}");
        assert_eq!(state.of, Attitudes::True);
        let [x, y, z] = state.error_deg;
        assert!(
            x.abs() < 1e-9 && y.abs() < 1e-9 && (z.abs() - 10.0).abs() < 1e-9,
            "{state:?}"
        );
        assert_eq!(watch.latest(&target), None, "nothing appended");

        for i in 20..35 {
            writer.write(&truth(i)).unwrap();
        }
        writer.write(&estimate(35)).unwrap();
        writer.flush().unwrap();
        let state = watch.latest(&target).unwrap();
        assert!((state.t_s - 3.4).abs() < 1e-12, "{state:?}");
        writer.write(&estimate(36)).unwrap();
        writer.flush().unwrap();
        assert_eq!(
            watch.latest(&target),
            None,
            "a run with a truth shows only the truth"
        );
        drop(writer);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_run_without_a_truth_shows_the_estimate() {
        let path = temp_log("estimate");
        let target = Attitude::identity();
        let mut watch = Watch::new(&path);
        let mut writer = log_writer(&path);
        for i in 0..12 {
            writer
                .write(&AttitudeEstimate {
                    quaternion: turned(),
                    ..estimate(i)
                })
                .unwrap();
        }
        writer.flush().unwrap();
        let state = watch.latest(&target).unwrap();
        assert_eq!(state.of, Attitudes::Estimated);
        assert!((state.t_s - 1.1).abs() < 1e-12, "{state:?}");
        assert!((state.error_deg[2].abs() - 10.0).abs() < 1e-9, "{state:?}");
        drop(writer);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_line_gives_time_factor_and_whose_error() {
        let state = State {
            t_s: 30.0,
            error_deg: [0.5, -0.25, 1.0],
            of: Attitudes::True,
        };
        let line = describe(&state, Some(150.0), Duration::from_secs(10));
        assert_eq!(
            line,
            "30.0 of 150 simulated s, 3.0× real time, true attitude error X +0.500° Y -0.250° Z +1.000°"
        );
        let estimated = State {
            of: Attitudes::Estimated,
            ..state
        };
        assert_eq!(
            describe(&estimated, None, Duration::from_secs(30)),
            "30.0 s, 1.0× real time, estimated attitude error X +0.500° Y -0.250° Z +1.000°"
        );
    }
}
