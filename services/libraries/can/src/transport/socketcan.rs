//! Linux SocketCAN through the `socketcan` crate.

use super::{CanTransport, TransportError};
use crate::frame::{CanFrame, CanId, TimeSource, TimestampedFrame, host_time_ns};
use crate::protocol::{Device, IdMap};
use socketcan::{EmbeddedFrame, ExtendedId, Frame as _, Id, Socket, SocketOptions, StandardId};
use std::os::fd::AsRawFd;
use std::time::Duration;

/// What [`probe_socketcan`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SocketCanSupport {
    /// The kernel has SocketCAN and the interface exists.
    Available,
    /// The kernel has no SocketCAN (`socket(AF_CAN, SOCK_RAW, CAN_RAW)` failed); the text says why.
    NoKernelSupport(String),
    /// SocketCAN exists but the interface does not.
    NoInterface(String),
}

impl std::fmt::Display for SocketCanSupport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SocketCanSupport::Available => f.write_str("SocketCAN available"),
            SocketCanSupport::NoKernelSupport(why) => {
                write!(f, "kernel has no SocketCAN support: {why}")
            }
            SocketCanSupport::NoInterface(name) => {
                write!(f, "SocketCAN present but no interface {name}")
            }
        }
    }
}

/// Whether SocketCAN works here and `iface` exists (no side effect beyond a short-lived socket).
pub fn probe_socketcan(iface: &str) -> SocketCanSupport {
    // SAFETY: plain socket(2) call; the descriptor is closed right away.
    let fd = unsafe {
        libc::socket(
            libc::AF_CAN,
            libc::SOCK_RAW | libc::SOCK_CLOEXEC,
            libc::CAN_RAW,
        )
    };
    if fd < 0 {
        return SocketCanSupport::NoKernelSupport(std::io::Error::last_os_error().to_string());
    }
    // SAFETY: fd is a descriptor we own.
    unsafe { libc::close(fd) };
    let Ok(name) = std::ffi::CString::new(iface) else {
        return SocketCanSupport::NoInterface(iface.to_string());
    };
    // SAFETY: name is a valid NUL-terminated string.
    if unsafe { libc::if_nametoindex(name.as_ptr()) } == 0 {
        return SocketCanSupport::NoInterface(iface.to_string());
    }
    SocketCanSupport::Available
}

/// A raw CAN socket bound to one interface, with kernel receive time stamps.
///
/// Receives every frame by default; narrow with [`set_device_filters`](Self::set_device_filters)
/// or [`set_filters`](Self::set_filters). Error frames are requested from the kernel with
/// [`report_error_frames`](Self::report_error_frames); they are never returned as frames but
/// counted ([`error_frames`](Self::error_frames), [`bus_off`](Self::bus_off)) and the last one
/// kept ([`last_error`](Self::last_error)).
#[derive(Debug)]
pub struct SocketCanTransport {
    socket: socketcan::CanSocket,
    iface: String,
    error_frames: u64,
    bus_off: u64,
    last_error: Option<u32>,
    /// Frames the kernel dropped because this socket's receive queue was full (`SO_RXQ_OVFL`).
    queue_drops: u64,
}

/// `CAN_ERR_BUSOFF` of `linux/can/error.h`: the controller went bus-off.
pub const CAN_ERR_BUSOFF: u32 = 0x0000_0040;
/// `CAN_ERR_MASK`: every error class.
pub const CAN_ERR_MASK: u32 = 0x1FFF_FFFF;

fn open_error(iface: &str, e: std::io::Error) -> TransportError {
    match e.raw_os_error() {
        Some(libc::EAFNOSUPPORT) | Some(libc::EPROTONOSUPPORT) => TransportError::Unsupported(
            format!("kernel has no SocketCAN support (opening {iface}: {e})"),
        ),
        Some(libc::ENODEV) | Some(libc::ENXIO) => {
            TransportError::NotFound(format!("CAN interface {iface}"))
        }
        _ => TransportError::io(format!("opening CAN interface {iface}"), e),
    }
}

impl SocketCanTransport {
    /// Open interface `iface` (e.g. `can0`, `vcan0`).
    ///
    /// [`TransportError::Unsupported`] if the kernel has no SocketCAN,
    /// [`TransportError::NotFound`] if the interface does not exist.
    pub fn open(iface: &str) -> Result<Self, TransportError> {
        match probe_socketcan(iface) {
            SocketCanSupport::Available => {}
            SocketCanSupport::NoKernelSupport(why) => {
                return Err(TransportError::Unsupported(format!(
                    "kernel has no SocketCAN support: {why}"
                )));
            }
            SocketCanSupport::NoInterface(name) => {
                return Err(TransportError::NotFound(format!("CAN interface {name}")));
            }
        }
        let socket = socketcan::CanSocket::open(iface).map_err(|e| open_error(iface, e))?;
        socket
            .set_recv_timestamp(true)
            .map_err(|e| TransportError::io(format!("enabling time stamps on {iface}"), e))?;
        socket
            .set_socket_option(libc::SOL_SOCKET, libc::SO_RXQ_OVFL, &(1 as libc::c_int))
            .map_err(|e| TransportError::io(format!("enabling drop counts on {iface}"), e))?;
        Ok(Self {
            socket,
            iface: iface.to_string(),
            error_frames: 0,
            bus_off: 0,
            last_error: None,
            queue_drops: 0,
        })
    }

    /// Asks for a receive queue of `bytes` (`SO_RCVBUF`; the kernel caps it at
    /// `net.core.rmem_max` and doubles it for its bookkeeping): for a reader of the whole bus
    /// that may fall behind for a while, e.g. a recorder. The size granted.
    pub fn set_receive_buffer(&mut self, bytes: usize) -> Result<usize, TransportError> {
        let want = libc::c_int::try_from(bytes).unwrap_or(libc::c_int::MAX);
        self.socket
            .set_socket_option(libc::SOL_SOCKET, libc::SO_RCVBUF, &want)
            .map_err(|e| {
                TransportError::io(format!("sizing the receive queue on {}", self.iface), e)
            })?;
        let mut got: libc::c_int = 0;
        let mut len = std::mem::size_of::<libc::c_int>() as libc::socklen_t;
        // SAFETY: getsockopt writes at most `len` bytes into `got`.
        let rc = unsafe {
            libc::getsockopt(
                self.socket.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                (&mut got as *mut libc::c_int).cast(),
                &mut len,
            )
        };
        if rc < 0 {
            return Err(TransportError::io(
                format!("reading the receive queue size on {}", self.iface),
                std::io::Error::last_os_error(),
            ));
        }
        Ok(usize::try_from(got).unwrap_or(0))
    }

    /// Frames the kernel dropped so far because this socket's receive queue was full (the
    /// reader too slow for the bus, e.g. under a flood): `SO_RXQ_OVFL`, as of the last frame
    /// received.
    pub fn queue_drops(&self) -> u64 {
        self.queue_drops
    }

    /// Asks the kernel for error frames of every class (`CAN_RAW_ERR_FILTER = CAN_ERR_MASK`):
    /// bus errors, controller problems, bus-off, restarts. They are counted, not returned.
    pub fn report_error_frames(&mut self) -> Result<(), TransportError> {
        self.socket.set_error_filter(CAN_ERR_MASK).map_err(|e| {
            TransportError::io(format!("requesting error frames on {}", self.iface), e)
        })
    }

    /// Error frames that went bus-off (`CAN_ERR_BUSOFF`).
    pub fn bus_off(&self) -> u64 {
        self.bus_off
    }

    /// The error class bits (`can_id & CAN_ERR_MASK`) of the last error frame.
    pub fn last_error(&self) -> Option<u32> {
        self.last_error
    }

    /// Whether the interface is administratively up (`IFF_UP` of `SIOCGIFFLAGS`): `ip link set
    /// IFACE down` clears it, and no frame goes out or comes in until it is up again.
    pub fn is_up(&self) -> Result<bool, TransportError> {
        // SAFETY: ifreq is plain data; zeroed is a valid value.
        let mut req: libc::ifreq = unsafe { std::mem::zeroed() };
        let name = self.iface.as_bytes();
        if name.len() >= req.ifr_name.len() {
            return Err(TransportError::Config(format!(
                "interface name {:?} longer than {} bytes",
                self.iface,
                req.ifr_name.len() - 1
            )));
        }
        for (dst, &src) in req.ifr_name.iter_mut().zip(name) {
            *dst = src as libc::c_char;
        }
        // SAFETY: SIOCGIFFLAGS reads the name and writes the flags of one valid ifreq; a CAN
        // socket passes the request to the network device layer.
        let rc = unsafe {
            libc::ioctl(
                self.socket.as_raw_fd(),
                libc::SIOCGIFFLAGS as _,
                &mut req as *mut libc::ifreq,
            )
        };
        if rc < 0 {
            return Err(TransportError::io(
                format!("reading the flags of {}", self.iface),
                std::io::Error::last_os_error(),
            ));
        }
        // SAFETY: SIOCGIFFLAGS filled the flags member of the union.
        let flags = unsafe { req.ifr_ifru.ifru_flags };
        Ok(i32::from(flags) & libc::IFF_UP != 0)
    }

    /// The interface name.
    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// Error frames received and dropped.
    pub fn error_frames(&self) -> u64 {
        self.error_frames
    }

    /// Receive only standard-ID frames matching one of `(id, mask)` (`received & mask == id & mask`).
    pub fn set_filters(&mut self, filters: &[(u16, u16)]) -> Result<(), TransportError> {
        let filters: Vec<socketcan::CanFilter> = filters
            .iter()
            // CAN_EFF_FLAG | CAN_RTR_FLAG in the mask: extended and remote frames never match.
            .map(|&(id, mask)| {
                socketcan::CanFilter::new(
                    u32::from(id & 0x7FF),
                    u32::from(mask & 0x7FF)
                        | crate::frame::EXTENDED_FLAG
                        | crate::frame::REMOTE_FLAG,
                )
            })
            .collect();
        self.socket
            .set_filters(&filters)
            .map_err(|e| TransportError::io(format!("setting filters on {}", self.iface), e))
    }

    /// Receive only the identifier blocks of `devices` (one kernel filter per device).
    pub fn set_device_filters(
        &mut self,
        ids: &IdMap,
        devices: &[Device],
    ) -> Result<(), TransportError> {
        let filters: Vec<(u16, u16)> = devices.iter().map(|&d| ids.device_filter(d)).collect();
        self.set_filters(&filters)
    }

    /// Receive every frame again.
    pub fn accept_all(&mut self) -> Result<(), TransportError> {
        self.socket
            .set_filter_accept_all()
            .map_err(|e| TransportError::io(format!("clearing filters on {}", self.iface), e))
    }
}

/// The crate's frame as a `socketcan` frame.
pub(crate) fn to_socketcan(frame: &CanFrame) -> Option<socketcan::CanFrame> {
    let id: Id = match frame.id() {
        CanId::Standard(id) => Id::Standard(StandardId::new(id)?),
        CanId::Extended(id) => Id::Extended(ExtendedId::new(id)?),
    };
    if frame.is_remote() {
        socketcan::CanFrame::new_remote(id, usize::from(frame.dlc()))
    } else {
        socketcan::CanFrame::new(id, frame.data())
    }
}

/// A `socketcan` frame as the crate's frame (None for error frames).
pub(crate) fn from_socketcan(frame: &socketcan::CanFrame) -> Option<CanFrame> {
    let id = match frame.id() {
        Id::Standard(id) => CanId::Standard(id.as_raw()),
        Id::Extended(id) => CanId::Extended(id.as_raw()),
    };
    match frame {
        socketcan::CanFrame::Data(_) => CanFrame::new(id, frame.data()).ok(),
        socketcan::CanFrame::Remote(_) => {
            CanFrame::remote(id, u8::try_from(frame.dlc()).ok()?).ok()
        }
        socketcan::CanFrame::Error(_) => None,
    }
}

/// One frame as `recvmsg` returned it, with its ancillary data.
struct Received {
    frame: libc::can_frame,
    /// The kernel's receive time stamp (`SO_TIMESTAMPNS`), ns since the Unix epoch.
    time_ns: Option<u64>,
    /// The socket's drop counter (`SO_RXQ_OVFL`), cumulative, wrapping at 2³².
    drops: Option<u32>,
}

/// Reads one classic frame from raw CAN socket `fd` with `recvmsg`, parsing the time stamp and
/// the drop counter (the `socketcan` crate's reader skips the latter).
fn recv_frame(fd: i32) -> std::io::Result<Received> {
    // SAFETY: can_frame is plain data; zeroed is a valid value.
    let mut frame: libc::can_frame = unsafe { std::mem::zeroed() };
    let mut iov = libc::iovec {
        iov_base: (&mut frame as *mut libc::can_frame).cast(),
        iov_len: std::mem::size_of::<libc::can_frame>(),
    };
    // u64 elements: cmsghdr alignment. Room for a timespec and a u32 control message.
    let mut control = [0u64; 16];
    // SAFETY: msghdr is plain data; zeroed is a valid value.
    let mut msg: libc::msghdr = unsafe { std::mem::zeroed() };
    msg.msg_iov = &mut iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control.as_mut_ptr().cast();
    msg.msg_controllen = std::mem::size_of_val(&control) as _;
    // SAFETY: msg points at a valid iovec and control buffer that outlive the call.
    let n = unsafe { libc::recvmsg(fd, &mut msg, 0) };
    if n < 0 {
        return Err(std::io::Error::last_os_error());
    }
    if n as usize != std::mem::size_of::<libc::can_frame>() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("a read of {n} bytes is not a classic CAN frame"),
        ));
    }
    let mut received = Received {
        frame,
        time_ns: None,
        drops: None,
    };
    // SAFETY: the CMSG_* macros walk the control buffer recvmsg filled, within msg_controllen;
    // each payload is read unaligned and only when the message is long enough for it.
    unsafe {
        let mut cmsg = libc::CMSG_FIRSTHDR(&msg);
        while !cmsg.is_null() {
            let (level, kind, len) = ((*cmsg).cmsg_level, (*cmsg).cmsg_type, (*cmsg).cmsg_len);
            let data = libc::CMSG_DATA(cmsg);
            let fits = |size: usize| len >= libc::CMSG_LEN(size as u32) as usize;
            if level == libc::SOL_SOCKET {
                if kind == libc::SO_TIMESTAMPNS && fits(std::mem::size_of::<libc::timespec>()) {
                    let t = std::ptr::read_unaligned(data.cast::<libc::timespec>());
                    received.time_ns = u64::try_from(t.tv_sec)
                        .ok()
                        .and_then(|s| s.checked_mul(1_000_000_000))
                        .and_then(|s| s.checked_add(u64::try_from(t.tv_nsec).ok()?));
                } else if kind == libc::SO_RXQ_OVFL && fits(std::mem::size_of::<u32>()) {
                    received.drops = Some(std::ptr::read_unaligned(data.cast::<u32>()));
                }
            }
            cmsg = libc::CMSG_NXTHDR(&msg, cmsg);
        }
    }
    Ok(received)
}

/// Wait up to `timeout` for `fd` to be readable; Ok(false) on time-out.
fn poll_readable(fd: i32, timeout: Duration) -> std::io::Result<bool> {
    let ms = timeout.as_nanos().div_ceil(1_000_000).min(i32::MAX as u128) as i32;
    let mut pfd = libc::pollfd {
        fd,
        events: libc::POLLIN,
        revents: 0,
    };
    loop {
        // SAFETY: one valid pollfd.
        let n = unsafe { libc::poll(&mut pfd, 1, ms) };
        if n >= 0 {
            return Ok(n > 0);
        }
        let e = std::io::Error::last_os_error();
        if e.kind() != std::io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
}

impl CanTransport for SocketCanTransport {
    fn send(&mut self, frame: &CanFrame) -> Result<(), TransportError> {
        let sc = to_socketcan(frame).ok_or(TransportError::FrameNotSupported {
            frame: *frame,
            reason: "not representable as a SocketCAN frame",
        })?;
        self.socket
            .write_frame(&sc)
            .map_err(|e| TransportError::io(format!("sending on {}", self.iface), e))
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<TimestampedFrame>, TransportError> {
        let deadline = super::deadline_after(timeout);
        loop {
            let left = super::time_left(deadline);
            let readable = poll_readable(self.socket.as_raw_fd(), left)
                .map_err(|e| TransportError::io(format!("waiting on {}", self.iface), e))?;
            if !readable {
                return Ok(None);
            }
            let received = recv_frame(self.socket.as_raw_fd())
                .map_err(|e| TransportError::io(format!("receiving on {}", self.iface), e))?;
            if let Some(drops) = received.drops {
                self.queue_drops = u64::from(drops);
            }
            let frame = socketcan::CanFrame::from(received.frame);
            let Some(frame) = from_socketcan(&frame) else {
                let class = frame.id_word() & CAN_ERR_MASK;
                self.error_frames += 1;
                self.bus_off += u64::from(class & CAN_ERR_BUSOFF != 0);
                self.last_error = Some(class);
                continue;
            };
            let (time_ns, source) = match received.time_ns {
                Some(t) => (t, TimeSource::Kernel),
                None => (host_time_ns(), TimeSource::Host),
            };
            return Ok(Some(TimestampedFrame {
                frame,
                time_ns,
                source,
            }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_convert_both_ways() {
        for f in [
            CanFrame::standard(0x123, &[1, 2, 3]).unwrap(),
            CanFrame::standard(0, &[]).unwrap(),
            CanFrame::new(CanId::Extended(0x1FFF_FFFF), &[0xFF; 8]).unwrap(),
            CanFrame::remote(CanId::Standard(0x7FF), 8).unwrap(),
        ] {
            let sc = to_socketcan(&f).unwrap();
            assert_eq!(from_socketcan(&sc), Some(f));
        }
    }
}
