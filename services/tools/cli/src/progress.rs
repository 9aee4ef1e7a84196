//! Progress of a running pipeline, read from its growing MCAP log (the logger writes records
//! unchunked and in time order, so a log being written reads like a cut one): simulated time,
//! real-time factor and the current true attitude error. A bar on a terminal (`indicatif`),
//! otherwise a plain line every [`PLAIN_EVERY`] of wall time. Reading the log is passive: the
//! pipeline is not slowed or changed by it (a bus subscriber would be one more participant of a
//! lossless lockstep bus). The log is followed with a [`LogTail`]: each look reads only what
//! was appended since the one before, so following a long paced run costs what the run writes,
//! not its whole log again every half second.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ipc_types::SimTruth;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};
use testbed_flight::convert::{quaternion_from_array, seconds};
use testbed_log::LogTail;
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

/// The latest state read from the log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Simulated time, s.
    pub t_s: f64,
    /// True attitude error, rotation vector target → truth, body axes, degrees.
    pub error_deg: [f64; 3],
}

/// The newest truth sample appended to the log since the tail's last look, if any.
pub fn latest(tail: &mut LogTail, target: &Attitude) -> Option<State> {
    let last = tail.latest::<SimTruth>().ok()??;
    let q = quaternion_from_array(&last.quaternion)?;
    let e = attitude::attitude_error(&q, target) / DEG;
    Some(State {
        t_s: seconds(last.header.time_ns),
        error_deg: [e.x, e.y, e.z],
    })
}

/// Interval between two looks at the log.
pub const LOOK_EVERY: Duration = Duration::from_millis(500);

/// One line of progress.
pub fn describe(state: &State, duration_s: Option<f64>, wall: Duration) -> String {
    let of = duration_s.map_or_else(String::new, |d| format!(" of {d:.0}"));
    let factor = state.t_s / wall.as_secs_f64().max(1e-3);
    let [x, y, z] = state.error_deg;
    format!(
        "{:.1}{of} simulated s, {factor:.1}× real time, attitude error X {x:+.3}° Y {y:+.3}° Z {z:+.3}°",
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
    let mut tail = LogTail::new(&follow.log);
    loop {
        std::thread::park_timeout(LOOK_EVERY);
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
        let Some(state) = fresh.then(|| latest(&mut tail, &follow.target)).flatten() else {
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
    use ipc_types::SampleHeader;
    use testbed_log::{RunInfo, RunLogWriter, WriterOptions};

    /// A truth sample at `i` × 0.1 s, the platform turned 10° about body z.
    fn truth(i: u64) -> SimTruth {
        let half = 5.0 * DEG;
        SimTruth {
            header: SampleHeader {
                time_ns: i * 100_000_000,
                ..SampleHeader::default()
            },
            quaternion: [0.0, 0.0, half.sin(), half.cos()],
            ..SimTruth::default()
        }
    }

    #[test]
    fn each_look_gives_the_newest_truth_appended_since_the_last() {
        let path =
            std::env::temp_dir().join(format!("testbed-progress-{}.mcap", std::process::id()));
        let target = Attitude::identity();
        let mut tail = LogTail::new(&path);
        assert_eq!(latest(&mut tail, &target), None, "no log yet");

        // As the logger writes during a run: unchunked, handed to the OS as it goes.
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
        let mut writer = RunLogWriter::create_with(&path, &info, options).unwrap();
        for i in 0..20 {
            writer.write(&truth(i)).unwrap();
        }
        writer.flush().unwrap();
        let state = latest(&mut tail, &target).unwrap();
        assert!((state.t_s - 1.9).abs() < 1e-12, "{state:?}");
        let [x, y, z] = state.error_deg;
        assert!(
            x.abs() < 1e-9 && y.abs() < 1e-9 && (z.abs() - 10.0).abs() < 1e-9,
            "{state:?}"
        );
        assert_eq!(latest(&mut tail, &target), None, "nothing appended");

        for i in 20..35 {
            writer.write(&truth(i)).unwrap();
        }
        writer.flush().unwrap();
        let state = latest(&mut tail, &target).unwrap();
        assert!((state.t_s - 3.4).abs() < 1e-12, "{state:?}");
        drop(writer);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_line_gives_time_factor_and_error() {
        let state = State {
            t_s: 30.0,
            error_deg: [0.5, -0.25, 1.0],
        };
        let line = describe(&state, Some(150.0), Duration::from_secs(10));
        assert_eq!(
            line,
            "30.0 of 150 simulated s, 3.0× real time, attitude error X +0.500° Y -0.250° Z +1.000°"
        );
    }
}
