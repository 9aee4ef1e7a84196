//! The chain's topics: which samples flow between its processes (a [`Msg`] is the run log's
//! record of the topic table, a [`Kind`] the table's topic), how a socket carries them (a tag
//! and the sample's `Pod` twin), and a process's ports on a bus of either family ([`Ports`]).

use crate::latency::payload::Payload;
use crate::latency::system::now_ns;
use crate::latency::transport::{Events, Family};
use anyhow::{Context, Result};
use ipc_types::*;
use testbed_bus::{Bus, EventLoop};

/// Which topic: the table's.
pub use ipc_types::TopicId as Kind;

/// A sample of one of the chain's topics (by value, as the bus hands them out).
pub type Msg = testbed_log::LogRecord;

macro_rules! chain_topics {
    ($(($v:ident, $t:ident, $f:ident)),* $(,)?) => {
        /// An empty sample of `kind` with `header` (the chain's stop marker); `None` for a
        /// topic outside the chain.
        pub fn empty(kind: Kind, header: SampleHeader) -> Option<Msg> {
            match kind {
                $(Kind::$v => Some(Msg::$v($t { header, ..Default::default() })),)*
                _ => None,
            }
        }

        /// Tag and the sample's plain-bytes twin, as a socket sends them.
        pub fn encode(msg: &Msg, out: &mut Vec<u8>) -> Result<()> {
            out.clear();
            out.extend_from_slice(&(msg.topic_id() as u32).to_le_bytes());
            out.extend_from_slice(&[0; 4]);
            match msg {
                $(Msg::$v(s) => out.extend_from_slice(bytemuck::bytes_of(&s.to_wire())),)*
                _ => anyhow::bail!("{} is not a topic of the chain", msg.topic()),
            }
            Ok(())
        }

        pub fn decode(bytes: &[u8]) -> Option<Msg> {
            let tag = u32::from_le_bytes(bytes.get(..4)?.try_into().ok()?);
            let body = bytes.get(8..)?;
            $(
                if tag == Kind::$v as u32 {
                    let ok = body.len() == size_of::<<$t as Payload>::Wire>();
                    return ok.then(|| Msg::$v(<$t>::from_wire(&bytemuck::pod_read_unaligned(body))));
                }
            )*
            None
        }

        /// The ports of one chain process on a bus, of one family.
        pub struct Ports<F: Family> {
            $($f: (Option<F::Pub<$t>>, Option<F::Sub<$t>>),)*
        }

        impl<F: Family> Ports<F> {
            pub fn new(bus: &Bus, publishes: &[Kind], subscribes: &[Kind]) -> Result<Self> {
                Ok(Self { $($f: (
                    if publishes.contains(&Kind::$v) { Some(F::publisher::<$t>(bus)?) } else { None },
                    if subscribes.contains(&Kind::$v) { Some(F::subscriber::<$t>(bus)?) } else { None },
                ),)* })
            }
            /// Every pending sample, topic by topic in declaration order (the binaries' order).
            pub fn drain(&self, out: &mut Vec<(Msg, u64)>) -> Result<()> {
                $( if let Some(s) = &self.$f.1 { F::drain(s, |v| out.push((Msg::$v(v), now_ns())))?; } )*
                Ok(())
            }
            pub fn send(&self, msg: &Msg) -> Result<()> {
                let no_publisher = || format!("no publisher for {}", msg.topic());
                match msg {
                    $(Msg::$v(v) => F::send(self.$f.0.as_ref().with_context(no_publisher)?, v),)*
                    _ => Err(anyhow::anyhow!(no_publisher())),
                }
            }
            pub fn subscribers(&self, kind: Kind) -> usize {
                match kind {
                    $(Kind::$v => self.$f.0.as_ref().map_or(0, F::subscribers),)*
                    _ => 0,
                }
            }
        }

        impl Ports<Events> {
            pub fn attach<'a>(&'a self, events: &mut EventLoop<'_, 'a>) -> Result<()> {
                $( if let Some(s) = &self.$f.1 { events.on_data(s)?; } )*
                Ok(())
            }
        }
    };
}

chain_topics! {
    (Gyro, GyroSample, gyro),
    (Inclinometer, InclinometerSample, tilt),
    (Magnetometer, MagnetometerSample, field),
    (AttitudeEstimate, AttitudeEstimate, estimate),
    (WheelTelemetry, WheelTelemetry, wheel_tm),
    (CmgTelemetry, CmgTelemetry, cmg_tm),
    (ControllerStatus, ControllerStatus, status),
    (WheelCommand, WheelCommand, wheel_cmd),
    (CmgCommand, CmgCommand, cmg_cmd),
}
