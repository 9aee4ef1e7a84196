use crate::SampleHeader;
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("testbed::Heartbeat.v1")]
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
        let mut len = name.len().min(Self::NAME_LEN);
        while !name.is_char_boundary(len) {
            len -= 1;
        }
        self.name = [0; Self::NAME_LEN];
        self.name[..len].copy_from_slice(&name.as_bytes()[..len]);
        len == name.len()
    }

    /// The stored name: bytes up to the first NUL, cut at the first invalid UTF-8 byte.
    pub fn name(&self) -> &str {
        let len = self
            .name
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(Self::NAME_LEN);
        let bytes = &self.name[..len];
        match core::str::from_utf8(bytes) {
            Ok(s) => s,
            // Cannot fail: the prefix up to `valid_up_to` is valid UTF-8.
            Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
        }
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
