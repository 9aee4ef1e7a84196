//! The chain's topics: which samples flow between its processes ([`Kind`], [`Msg`]), how a
//! socket carries them (a tag and the sample's `Pod` twin), and a process's ports on a bus of
//! either family ([`Ports`]).

use crate::latency::payload::Payload;
use crate::latency::system::now_ns;
use crate::latency::transport::{Events, Family};
use anyhow::{Context, Result};
use ipc_types::*;
use testbed_bus::{Bus, EventLoop};

macro_rules! chain_topics {
    ($(($v:ident, $t:ty, $f:ident)),* $(,)?) => {
        /// Which topic.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Kind { $($v),* }

        /// A sample of one of the chain's topics (by value, as the bus hands them out).
        #[derive(Debug, Clone, Copy)]
        #[allow(clippy::large_enum_variant)]
        pub enum Msg { $($v($t)),* }

        impl Msg {
            pub fn kind(&self) -> Kind {
                match self { $(Self::$v(_) => Kind::$v),* }
            }
            pub fn header(&self) -> SampleHeader {
                match self { $(Self::$v(s) => s.header),* }
            }
            /// An empty sample of `kind` with `header` (the chain's stop marker).
            pub fn empty(kind: Kind, header: SampleHeader) -> Self {
                match kind { $(Kind::$v => Self::$v(<$t>::default()).with_header(header)),* }
            }
            fn with_header(mut self, header: SampleHeader) -> Self {
                match &mut self { $(Self::$v(s) => s.header = header),* }
                self
            }
            /// Tag and the sample's plain-bytes twin, as a socket sends them.
            pub fn encode(&self, out: &mut Vec<u8>) {
                out.clear();
                out.extend_from_slice(&(self.kind() as u32).to_le_bytes());
                out.extend_from_slice(&[0; 4]);
                match self { $(Self::$v(s) => out.extend_from_slice(bytemuck::bytes_of(&s.to_wire()))),* }
            }
            pub fn decode(bytes: &[u8]) -> Option<Self> {
                let tag = u32::from_le_bytes(bytes.get(..4)?.try_into().ok()?);
                let body = bytes.get(8..)?;
                $(
                    if tag == Kind::$v as u32 {
                        let ok = body.len() == size_of::<<$t as Payload>::Wire>();
                        return ok.then(|| Self::$v(<$t>::from_wire(&bytemuck::pod_read_unaligned(body))));
                    }
                )*
                None
            }
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
                match msg {
                    $(Msg::$v(v) => F::send(self.$f.0.as_ref().with_context(|| format!("no publisher for {:?}", msg.kind()))?, v),)*
                }
            }
            pub fn subscribers(&self, kind: Kind) -> usize {
                match kind { $(Kind::$v => self.$f.0.as_ref().map_or(0, F::subscribers)),* }
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
    (Tilt, InclinometerSample, tilt),
    (Field, MagnetometerSample, field),
    (Estimate, AttitudeEstimate, estimate),
    (WheelTm, WheelTelemetry, wheel_tm),
    (CmgTm, CmgTelemetry, cmg_tm),
    (Status, ControllerStatus, status),
    (WheelCmd, WheelCommand, wheel_cmd),
    (CmgCmd, CmgCommand, cmg_cmd),
}
