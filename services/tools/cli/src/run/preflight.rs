//! The pre-flight check of `testbed run`: before anything starts (or is written), whether this
//! computer has what the profile's processes will open — CAN interfaces present, up and at the
//! bus's bit rate, serial ports present and readable and writable — said in one message with
//! the fix for each thing missing.
//!
//! What a run needs ([`needs`]) and what is missing ([`unmet`]) are pure functions of the
//! profile, the run configuration and a [`System`] (what the computer has, as far as the run
//! needs it); only [`System::probe`] looks at the computer.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use ipc_types::Device;
use testbed_config::{CanLink, RunConfig};
use testbed_gateways::GatewayDevice as _;
use testbed_gateways::gateway::Served;
use testbed_launch::profile::Profile;

/// The simulated smart CAN node's program: with `can.link = "socketcan"` it opens
/// `can.interface` too (the far side of a `vcan` run).
const CAN_NODE: &str = "sim-can-node";

/// The link type of a CAN interface (`ARPHRD_CAN`, `/sys/class/net/<if>/type`).
pub const ARPHRD_CAN: u32 = 280;

/// `IFF_UP` in `/sys/class/net/<if>/flags`: the interface is up.
const IFF_UP: u32 = 0x1;

/// What a run needs of the computer.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Needs {
    /// CAN interfaces by name, with the processes that open them.
    pub can: BTreeMap<String, Vec<String>>,
    /// Serial ports by path, with the configuration key that names them
    /// (`can.serial.gyro`) and the processes that open them.
    pub serial: BTreeMap<PathBuf, (String, Vec<String>)>,
    /// The bit rate the CAN interfaces must run at, bit/s (`can.bitrate`).
    pub bitrate: u32,
}

/// What the profile's processes will open, from the run configuration: the CAN gateways their
/// device's serial line (`[can.serial.<device>]`) or else, with `can.link = "socketcan"`,
/// `can.interface`, as does the simulated node. The other links (software bus, candump file)
/// and every other process need nothing of the computer.
pub fn needs(profile: &Profile, config: &RunConfig) -> Needs {
    let can = &config.can;
    let mut needs = Needs {
        bitrate: can.bitrate,
        ..Needs::default()
    };
    let gateways = Device::ALL
        .into_iter()
        .map(Served::Device)
        .chain([Served::Thrusters]);
    for spec in &profile.processes {
        let program = Path::new(&spec.command)
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default();
        let served = gateways.clone().find(|s| s.process_name() == program);
        let serial = served.and_then(|s| Some((s.name(), can.serial.get(s.name())?)));
        let user = spec.name.clone();
        if let Some((device, link)) = serial {
            needs
                .serial
                .entry(link.path.clone())
                .or_insert_with(|| (format!("can.serial.{device}"), Vec::new()))
                .1
                .push(user);
        } else if (served.is_some() || program == CAN_NODE) && can.link == CanLink::Socketcan {
            needs
                .can
                .entry(can.interface.clone())
                .or_default()
                .push(user);
        }
    }
    needs
}

/// A network interface, as far as a run needs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NetInterface {
    /// Its link type (`/sys/class/net/<if>/type`; [`ARPHRD_CAN`] for CAN).
    pub link_type: u32,
    /// Whether it is up (`IFF_UP`).
    pub up: bool,
    /// Whether it is a device's (a CAN adapter's) rather than virtual (`vcan`): only a device's
    /// has a bit rate to set.
    pub hardware: bool,
    /// Its bit rate, bit/s, where it can be read (`ip -details -json link show`).
    pub bitrate: Option<u32>,
}

/// Whether a serial port can be opened for reading and writing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortAccess {
    /// It can.
    ReadWrite,
    /// No such file.
    Missing,
    /// This user may not: the port's group, if known, is the one to join.
    Denied {
        /// The port's group (`dialout` on most systems).
        group: Option<String>,
    },
    /// Another reason (busy, not a device), as the system says it.
    Unusable(String),
}

/// What the computer has of what a run needs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct System {
    /// The network interfaces asked about, by name; absent: no such interface.
    pub net: BTreeMap<String, NetInterface>,
    /// The serial ports asked about, by path.
    pub serial: BTreeMap<PathBuf, PortAccess>,
}

impl System {
    /// Looks at this computer for what `needs` names (sysfs, `ip`, opening the serial ports
    /// without configuring them).
    pub fn probe(needs: &Needs) -> Self {
        Self {
            net: needs
                .can
                .keys()
                .filter_map(|name| Some((name.clone(), probe_interface(name)?)))
                .collect(),
            serial: needs
                .serial
                .keys()
                .map(|path| (path.clone(), probe_port(path)))
                .collect(),
        }
    }
}

/// Each thing `needs` names that `system` lacks, with how to fix it, one sentence each.
pub fn unmet(needs: &Needs, system: &System) -> Vec<String> {
    let rate = needs.bitrate;
    let mut problems = Vec::new();
    for (name, users) in &needs.can {
        let by = format!("(opened by {})", users.join(", "));
        let up_at_rate = format!("`sudo ip link set {name} up type can bitrate {rate}`");
        let problem = match system.net.get(name) {
            None if name.starts_with("vcan") => format!(
                "{name}: no such network interface {by}: create it with `sudo modprobe vcan && sudo ip link add dev {name} type vcan && sudo ip link set {name} up`"
            ),
            None => format!(
                "{name}: no such network interface {by}: connect the CAN adapter and load its driver (`sudo modprobe can-raw` and the adapter's, e.g. `peak_usb` or `gs_usb`; `ip link` lists the interfaces), then {up_at_rate}; or name the interface in can.interface"
            ),
            Some(i) if i.link_type != ARPHRD_CAN => format!(
                "{name}: not a CAN interface (link type {}, CAN's is {ARPHRD_CAN}) {by}: name the CAN interface in can.interface (`ip -details link` shows each interface's type)",
                i.link_type
            ),
            Some(i) if !i.up && i.hardware => format!("{name}: down {by}: {up_at_rate}"),
            Some(i) if !i.up => format!("{name}: down {by}: `sudo ip link set {name} up`"),
            Some(NetInterface {
                bitrate: Some(actual),
                hardware: true,
                ..
            }) if *actual != rate => format!(
                "{name}: at {actual} bit/s, the bus at {rate} (can.bitrate) {by}: `sudo ip link set {name} down && sudo ip link set {name} up type can bitrate {rate}`, or set can.bitrate to the node's rate"
            ),
            Some(_) => continue,
        };
        problems.push(problem);
    }
    for (path, (key, users)) in &needs.serial {
        let what = format!("{} ({key}, opened by {})", path.display(), users.join(", "));
        let problem = match system.serial.get(path) {
            Some(PortAccess::ReadWrite) => continue,
            None | Some(PortAccess::Missing) => format!(
                "{what}: no such file: connect the device's serial adapter, or set {key}.path (`ls /dev/serial/by-id/` lists the adapters)"
            ),
            Some(PortAccess::Denied { group }) => format!(
                "{what}: this user may not read and write it: `sudo usermod -aG {} $USER`, then log in again",
                group.as_deref().unwrap_or("dialout")
            ),
            Some(PortAccess::Unusable(reason)) => format!("{what}: cannot be opened: {reason}"),
        };
        problems.push(problem);
    }
    problems
}

/// What a profile needs and this computer lacks: the run is refused before anything starts
/// (exit status 2).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct Unmet {
    /// The profile's name.
    pub profile: String,
    /// What is missing and how to fix it ([`unmet`]).
    pub problems: Vec<String>,
}

impl fmt::Display for Unmet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "profile {} needs what this computer lacks; nothing was started:",
            self.profile
        )?;
        for problem in &self.problems {
            write!(f, "\n  {problem}")?;
        }
        Ok(())
    }
}

/// The check of a run of `profile` (its name) on this computer.
pub fn check(name: &str, profile: &Profile, config: &RunConfig) -> Result<(), Unmet> {
    let needs = needs(profile, config);
    let problems = unmet(&needs, &System::probe(&needs));
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Unmet {
            profile: name.to_owned(),
            problems,
        })
    }
}

/// The interface `name` from sysfs (and its bit rate from `ip`), None when there is none.
fn probe_interface(name: &str) -> Option<NetInterface> {
    // A name with a slash would reach outside /sys/class/net: no interface is called that.
    if name.is_empty() || name.contains('/') || name == "." || name == ".." {
        return None;
    }
    let dir = Path::new("/sys/class/net").join(name);
    let read = |file: &str| std::fs::read_to_string(dir.join(file)).ok();
    let link_type = read("type")?.trim().parse().unwrap_or(0);
    let flags = read("flags")
        .and_then(|f| u32::from_str_radix(f.trim().trim_start_matches("0x"), 16).ok())
        .unwrap_or(0);
    let hardware = dir.join("device").exists();
    Some(NetInterface {
        link_type,
        up: flags & IFF_UP != 0,
        hardware,
        bitrate: (link_type == ARPHRD_CAN && hardware)
            .then(|| can_bitrate(name))
            .flatten(),
    })
}

/// A CAN interface's bit rate from `ip -details -json link show` (sysfs does not have it);
/// None without `ip` or before a bit rate was set.
fn can_bitrate(name: &str) -> Option<u32> {
    let out = std::process::Command::new("ip")
        .args(["-details", "-json", "link", "show", "dev", name])
        .output()
        .ok()?;
    let links: serde_json::Value = serde_json::from_slice(&out.stdout).ok()?;
    let rate = links[0]["linkinfo"]["info_data"]["bittiming"]["bitrate"].as_u64()?;
    u32::try_from(rate).ok()
}

/// Whether this user can open `path` for reading and writing. Opened without waiting for a
/// modem line (`O_NONBLOCK`) and without becoming its controlling terminal, and closed at
/// once: its settings are left as they are.
fn probe_port(path: &Path) -> PortAccess {
    use std::os::unix::fs::{MetadataExt as _, OpenOptionsExt as _};
    let opened = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
        .open(path);
    match opened {
        Ok(_) => PortAccess::ReadWrite,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => PortAccess::Missing,
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => PortAccess::Denied {
            group: std::fs::metadata(path)
                .ok()
                .and_then(|m| group_name(m.gid())),
        },
        Err(e) => PortAccess::Unusable(e.to_string()),
    }
}

/// The name of group `gid` (`/etc/group`).
fn group_name(gid: u32) -> Option<String> {
    let groups = std::fs::read_to_string("/etc/group").ok()?;
    groups.lines().find_map(|line| {
        let mut fields = line.split(':');
        let name = fields.next()?;
        (fields.nth(1)?.parse::<u32>().ok()? == gid).then(|| name.to_owned())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(processes: &[(&str, &str)]) -> Profile {
        let mut text = String::from("[run]\nmode = \"paced\"\n");
        for (name, command) in processes {
            text.push_str(&format!(
                "[[process]]\nname = \"{name}\"\ncommand = \"{command}\"\n"
            ));
        }
        static COUNTER: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("preflight-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join(format!("{n}.toml"));
        std::fs::write(&file, text).unwrap();
        let profile = Profile::load(&file).unwrap();
        let _ = std::fs::remove_file(&file);
        profile
    }

    fn config(text: &str) -> RunConfig {
        RunConfig::from_toml_str(text, "test.run.toml").unwrap()
    }

    const PLATFORM: &[(&str, &str)] = &[
        ("logger", "logger"),
        ("gyro-gateway", "gyro-gateway"),
        ("wheel-gateway", "wheel-gateway"),
        ("estimator", "estimator"),
    ];

    fn can0(up: bool, bitrate: Option<u32>) -> System {
        let interface = NetInterface {
            link_type: ARPHRD_CAN,
            up,
            hardware: true,
            bitrate,
        };
        System {
            net: [("can0".to_owned(), interface)].into(),
            ..System::default()
        }
    }

    #[test]
    fn the_gateways_need_the_configured_interface_or_serial_line() {
        let needs = needs(&profile(PLATFORM), &RunConfig::default());
        assert_eq!(
            needs.can,
            [(
                "can0".to_owned(),
                vec!["gyro-gateway".to_owned(), "wheel-gateway".to_owned()]
            )]
            .into()
        );
        assert!(needs.serial.is_empty());
        assert_eq!(needs.bitrate, 500_000);

        let serial = config("[can.serial.gyro]\npath = \"/dev/ttyUSB3\"\n");
        let needs = super::needs(&profile(PLATFORM), &serial);
        assert_eq!(needs.can["can0"], ["wheel-gateway"]);
        assert_eq!(
            needs.serial[Path::new("/dev/ttyUSB3")],
            (
                "can.serial.gyro".to_owned(),
                vec!["gyro-gateway".to_owned()]
            )
        );
    }

    #[test]
    fn a_simulation_or_a_software_bus_needs_nothing() {
        let simulation = profile(&[("plant", "plant"), ("sim-gyro", "sim-gyro")]);
        assert_eq!(
            needs(&simulation, &RunConfig::default()),
            Needs {
                bitrate: 500_000,
                ..Needs::default()
            }
        );
        let software_bus = config("[can]\nlink = \"software_bus\"\n");
        let can_sim = profile(&[
            ("sim-can-node", "sim-can-node"),
            ("gyro-gateway", "gyro-gateway"),
        ]);
        let needs = needs(&can_sim, &software_bus);
        assert!(needs.can.is_empty() && needs.serial.is_empty(), "{needs:?}");
        assert!(unmet(&needs, &System::default()).is_empty());
    }

    #[test]
    fn the_node_on_socketcan_needs_its_interface() {
        let vcan = config("[can]\nlink = \"socketcan\"\ninterface = \"vcan0\"\n");
        let node = profile(&[("plant", "plant"), ("sim-can-node", "sim-can-node")]);
        let needs = needs(&node, &vcan);
        assert_eq!(needs.can["vcan0"], ["sim-can-node"]);
        let problems = unmet(&needs, &System::default());
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0].contains("vcan0: no such network interface")
                && problems[0].contains("ip link add dev vcan0 type vcan"),
            "{problems:?}"
        );
    }

    #[test]
    fn a_missing_interface_is_one_problem_naming_it_its_users_and_the_fix() {
        let needs = needs(&profile(PLATFORM), &RunConfig::default());
        let problems = unmet(&needs, &System::default());
        assert_eq!(problems.len(), 1, "{problems:?}");
        let p = &problems[0];
        assert!(p.starts_with("can0: no such network interface"), "{p}");
        assert!(p.contains("gyro-gateway, wheel-gateway"), "{p}");
        assert!(
            p.contains("`sudo ip link set can0 up type can bitrate 500000`"),
            "{p}"
        );
    }

    #[test]
    fn an_interface_must_be_can_up_and_at_the_bus_bit_rate() {
        let needs = needs(&profile(PLATFORM), &RunConfig::default());
        assert!(unmet(&needs, &can0(true, Some(500_000))).is_empty());
        // A bit rate that cannot be read is not held against it.
        assert!(unmet(&needs, &can0(true, None)).is_empty());

        let down = unmet(&needs, &can0(false, Some(500_000)));
        assert_eq!(down.len(), 1);
        assert!(
            down[0].starts_with("can0: down")
                && down[0].contains("ip link set can0 up type can bitrate 500000"),
            "{down:?}"
        );
        let fast = unmet(&needs, &can0(true, Some(1_000_000)));
        assert_eq!(fast.len(), 1);
        assert!(
            fast[0].contains("at 1000000 bit/s, the bus at 500000")
                && fast[0].contains("bitrate 500000"),
            "{fast:?}"
        );
        let mut ethernet = can0(true, None);
        ethernet.net.get_mut("can0").unwrap().link_type = 1;
        let not_can = unmet(&needs, &ethernet);
        assert!(not_can[0].contains("not a CAN interface"), "{not_can:?}");

        // The configured bit rate is the one asked for.
        let fast_bus = config("[can]\nbitrate = 1000000\n");
        let needs = super::needs(&profile(PLATFORM), &fast_bus);
        assert!(unmet(&needs, &can0(true, Some(1_000_000))).is_empty());
        assert!(unmet(&needs, &System::default())[0].contains("bitrate 1000000"));
    }

    #[test]
    fn a_virtual_interface_has_no_bit_rate_to_set() {
        let vcan = config("[can]\ninterface = \"vcan0\"\n");
        let needs = needs(&profile(PLATFORM), &vcan);
        let interface = |up| NetInterface {
            link_type: ARPHRD_CAN,
            up,
            hardware: false,
            bitrate: None,
        };
        let system = |up| System {
            net: [("vcan0".to_owned(), interface(up))].into(),
            ..System::default()
        };
        assert!(unmet(&needs, &system(true)).is_empty());
        let down = unmet(&needs, &system(false));
        assert!(
            down[0].contains("`sudo ip link set vcan0 up`") && !down[0].contains("bitrate"),
            "{down:?}"
        );
    }

    #[test]
    fn a_serial_port_must_exist_and_be_readable_and_writable() {
        let serial = config("[can.serial.gyro]\npath = \"/dev/ttyUSB3\"\n");
        let gyro = profile(&[("gyro-gateway", "gyro-gateway")]);
        let needs = needs(&gyro, &serial);
        let with = |access: PortAccess| System {
            serial: [(PathBuf::from("/dev/ttyUSB3"), access)].into(),
            ..System::default()
        };
        assert!(unmet(&needs, &with(PortAccess::ReadWrite)).is_empty());
        let missing = unmet(&needs, &with(PortAccess::Missing));
        assert!(
            missing[0].starts_with(
                "/dev/ttyUSB3 (can.serial.gyro, opened by gyro-gateway): no such file"
            ) && missing[0].contains("can.serial.gyro.path"),
            "{missing:?}"
        );
        let denied = unmet(
            &needs,
            &with(PortAccess::Denied {
                group: Some("uucp".into()),
            }),
        );
        assert!(denied[0].contains("usermod -aG uucp"), "{denied:?}");
    }

    #[test]
    fn the_message_is_one_error_with_a_line_per_problem() {
        let unmet = Unmet {
            profile: "platform".into(),
            problems: vec!["can0: a".into(), "/dev/ttyUSB0: b".into()],
        };
        assert_eq!(
            unmet.to_string(),
            "profile platform needs what this computer lacks; nothing was started:\n  can0: a\n  /dev/ttyUSB0: b"
        );
    }

    #[test]
    fn the_probe_finds_what_this_computer_has() {
        // Loopback exists on every Linux computer and is not CAN; no interface has this name.
        assert!(probe_interface("lo").is_some_and(|lo| lo.link_type != ARPHRD_CAN));
        assert_eq!(probe_interface("no-such-if0"), None);
        assert_eq!(probe_interface("../.."), None);
        assert_eq!(probe_port(Path::new("/dev/null")), PortAccess::ReadWrite);
        assert_eq!(probe_port(Path::new("/no/such/tty")), PortAccess::Missing);
    }
}
