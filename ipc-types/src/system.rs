use crate::SampleHeader;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::*;

/// Lifecycle state of a process, stored as `u32` in [`Heartbeat::state`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum ProcessState {
    /// Initialising (opening devices and services).
    #[default]
    Starting = 0,
    /// Working normally.
    Running = 1,
    /// Working with reduced function (e.g. a device link is down).
    Degraded = 2,
    /// Shutting down.
    Stopping = 3,
    /// Stopped working after an error.
    Faulted = 4,
}

impl ProcessState {
    /// The state with wire value `value`, if any.
    pub const fn from_u32(value: u32) -> Option<Self> {
        Some(match value {
            0 => Self::Starting,
            1 => Self::Running,
            2 => Self::Degraded,
            3 => Self::Stopping,
            4 => Self::Faulted,
            _ => return None,
        })
    }
}

/// Periodic liveness and counter report of one process (all processes share the topic).
///
/// `pid` differs between runs: tools comparing logs for reproducibility should leave this topic
/// out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::Heartbeat.v1")
)]
#[repr(C)]
pub struct Heartbeat {
    /// Common header; `time_ns` is the run's clock when the report was made.
    pub header: SampleHeader,
    /// Process name, UTF-8, NUL-padded (no terminator when all 32 bytes are used). Use
    /// [`name`](Self::name) / [`set_name`](Self::set_name).
    pub name: [u8; Self::NAME_LEN],
    /// OS process id.
    pub pid: u32,
    /// [`ProcessState`] as `u32`.
    pub state: u32,
    /// Samples received since start.
    pub samples_in: u64,
    /// Samples published since start.
    pub samples_out: u64,
    /// Errors since start.
    pub errors: u64,
    /// Device frames decoded successfully since start (gateways; 0 elsewhere).
    pub frames_ok: u64,
    /// Device frames rejected (checksum, framing, range) since start (gateways; 0 elsewhere).
    pub frames_bad: u64,
}

/// Stores `name` NUL-padded in `field`, truncated at a character boundary to the field's 32
/// bytes. Returns `false` if it had to be truncated.
fn store_name(field: &mut [u8; 32], name: &str) -> bool {
    let mut len = name.len().min(field.len());
    while !name.is_char_boundary(len) {
        len -= 1;
    }
    *field = [0; 32];
    field[..len].copy_from_slice(&name.as_bytes()[..len]);
    len == name.len()
}

/// The name stored in `field`: bytes up to the first NUL, cut at the first invalid UTF-8 byte.
fn stored_name(field: &[u8; 32]) -> &str {
    let len = field.iter().position(|&b| b == 0).unwrap_or(field.len());
    let bytes = &field[..len];
    match core::str::from_utf8(bytes) {
        Ok(s) => s,
        // Cannot fail: the prefix up to `valid_up_to` is valid UTF-8.
        Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
    }
}

impl Heartbeat {
    /// Capacity of [`name`](Self::name) in bytes.
    pub const NAME_LEN: usize = 32;

    /// A zeroed heartbeat with `name` set (see [`set_name`](Self::set_name)) and `pid`.
    pub fn new(name: &str, pid: u32) -> Self {
        let mut hb = Self {
            pid,
            ..Self::default()
        };
        hb.set_name(name);
        hb
    }

    /// Stores `name`, truncated at a character boundary to at most [`NAME_LEN`](Self::NAME_LEN)
    /// bytes. Returns `false` if it had to be truncated.
    pub fn set_name(&mut self, name: &str) -> bool {
        store_name(&mut self.name, name)
    }

    /// The stored name: bytes up to the first NUL, cut at the first invalid UTF-8 byte.
    pub fn name(&self) -> &str {
        stored_name(&self.name)
    }

    /// The state, or `None` for an unknown wire value.
    pub const fn state(&self) -> Option<ProcessState> {
        ProcessState::from_u32(self.state)
    }

    /// Sets the state.
    pub const fn set_state(&mut self, state: ProcessState) {
        self.state = state as u32;
    }
}

/// What a [`HealthEvent`] reports, stored as `u32` in [`HealthEvent::kind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum HealthEventKind {
    /// Not a known kind (a zeroed sample).
    #[default]
    Unknown = 0,
    /// An input stream of the reporter stopped for two of its periods; `value` is the time
    /// since its last sample, s.
    InputLost = 1,
    /// A lost input stream delivers again; `value` is how long it was lost, s.
    InputRestored = 2,
    /// A process's heartbeat stopped (hung or stopped); `value` is the heartbeat's age, s.
    ProcessHung = 3,
    /// A process ended while the run went on; `detail` is the exit status, or 128 + the
    /// signal that killed it.
    ProcessExited = 4,
    /// A process was restarted; `detail` is the restart count.
    ProcessRestarted = 5,
    /// The controller entered safe mode; `detail` holds the reason bits (1 estimate lost,
    /// 2 estimate invalid, 4 wheel telemetry lost, 8 CMG telemetry lost, 16 wheel near its
    /// speed limit, 32 ground command).
    SafeModeEntered = 6,
    /// The controller left safe mode.
    SafeModeLeft = 7,
    /// An actuator (gateway or plant) heard no command for its timeout and applies zero;
    /// `value` is the time since the last command, s.
    CommandsZeroed = 8,
    /// Commands arrive again after [`CommandsZeroed`](Self::CommandsZeroed).
    CommandsResumed = 9,
    /// The run was ended because of the subject (e.g. a lockstep run cannot go on without a
    /// process).
    RunAborted = 10,
    /// The thruster gateway found a valve stuck open and disabled the thrusters (latch valve
    /// shut, every command refused); `detail` is the valve (0..6).
    ThrustersDisabled = 11,
}

impl HealthEventKind {
    /// The kind with wire value `value`, if any.
    pub const fn from_u32(value: u32) -> Option<Self> {
        Some(match value {
            0 => Self::Unknown,
            1 => Self::InputLost,
            2 => Self::InputRestored,
            3 => Self::ProcessHung,
            4 => Self::ProcessExited,
            5 => Self::ProcessRestarted,
            6 => Self::SafeModeEntered,
            7 => Self::SafeModeLeft,
            8 => Self::CommandsZeroed,
            9 => Self::CommandsResumed,
            10 => Self::RunAborted,
            11 => Self::ThrustersDisabled,
            _ => return None,
        })
    }

    /// Whether the event is a fault (as opposed to a recovery).
    pub const fn is_fault(self) -> bool {
        matches!(
            self,
            Self::InputLost
                | Self::ProcessHung
                | Self::ProcessExited
                | Self::SafeModeEntered
                | Self::CommandsZeroed
                | Self::RunAborted
                | Self::ThrustersDisabled
        )
    }

    /// A short name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Unknown => "unknown",
            Self::InputLost => "input lost",
            Self::InputRestored => "input restored",
            Self::ProcessHung => "process hung",
            Self::ProcessExited => "process exited",
            Self::ProcessRestarted => "process restarted",
            Self::SafeModeEntered => "safe mode entered",
            Self::SafeModeLeft => "safe mode left",
            Self::CommandsZeroed => "commands zeroed",
            Self::CommandsResumed => "commands resumed",
            Self::RunAborted => "run aborted",
            Self::ThrustersDisabled => "thrusters disabled",
        }
    }
}

/// A fault or recovery seen by a process or the launcher: the run's event list (all
/// reporters share the topic; published only when something happens).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("testbed::HealthEvent.v1")
)]
#[repr(C)]
pub struct HealthEvent {
    /// Common header; `time_ns` is the run's clock when the event was seen (the reporter's
    /// latest sample time; 0 if it has none), `sequence` counts the reporter's events.
    pub header: SampleHeader,
    /// The reporting process (UTF-8, NUL-padded; `launcher` for the supervisor).
    pub reporter: [u8; 32],
    /// What the event is about: a process name, or a topic without its `testbed/` prefix.
    pub subject: [u8; 32],
    /// [`HealthEventKind`] as `u32`.
    pub kind: u32,
    /// Kind-specific detail (exit status, restart count, reason bits).
    pub detail: u32,
    /// Kind-specific value (an age or duration in s).
    pub value: f64,
}

impl HealthEvent {
    /// An event of `kind` about `subject` reported by `reporter` (names truncated to 32 bytes).
    pub fn new(
        header: SampleHeader,
        reporter: &str,
        subject: &str,
        kind: HealthEventKind,
        detail: u32,
        value: f64,
    ) -> Self {
        let mut event = Self {
            header,
            kind: kind as u32,
            detail,
            value,
            ..Self::default()
        };
        store_name(&mut event.reporter, reporter);
        store_name(
            &mut event.subject,
            subject.strip_prefix("testbed/").unwrap_or(subject),
        );
        event
    }

    /// The kind, or `None` for an unknown wire value.
    pub const fn kind(&self) -> Option<HealthEventKind> {
        HealthEventKind::from_u32(self.kind)
    }

    /// The reporting process.
    pub fn reporter(&self) -> &str {
        stored_name(&self.reporter)
    }

    /// What the event is about.
    pub fn subject(&self) -> &str {
        stored_name(&self.subject)
    }
}
