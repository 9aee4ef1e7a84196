//! Names every part of a run shares: the platform's devices and who owns time. Defined once
//! here, used by the run configuration, the launch profiles, the gateways and the processes.

use core::fmt;

/// Environment variable the launcher sets for every process: how often the process was
/// restarted in this run (`0` at its first start). A restarted logger writes a new log
/// segment; a clock owner refuses to restart (it would rewind time).
pub const ENV_RESTART_COUNT: &str = "TESTBED_RESTART_COUNT";

/// This process's restart count ([`ENV_RESTART_COUNT`]; 0 when unset or not a number).
pub fn restart_count() -> u32 {
    std::env::var(ENV_RESTART_COUNT)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// Environment variable the launcher sets for a process that serves devices (the profile's
/// `device`): their names, comma-separated (`gyro,inclinometer`).
pub const ENV_SERVED_DEVICES: &str = "TESTBED_SERVED_DEVICES";

/// The devices this process serves ([`ENV_SERVED_DEVICES`]), in the order listed. An error
/// names the variable and the value when it is unset, empty or names an unknown device.
pub fn served_devices() -> Result<Vec<Device>, String> {
    let value = std::env::var(ENV_SERVED_DEVICES).map_err(|_| {
        format!("{ENV_SERVED_DEVICES} is not set (the profile's `device` of this process)")
    })?;
    parse_devices(&value).map_err(|e| format!("{ENV_SERVED_DEVICES}={value:?}: {e}"))
}

/// Devices named in a comma-separated list (`"gyro,inclinometer"`).
pub fn parse_devices(list: &str) -> Result<Vec<Device>, String> {
    // An empty list is one empty name: refused as an unknown device.
    list.split(',').map(|name| name.trim().parse()).collect()
}

/// A device of the platform, as configurations and profiles name it (`"gyro"`, …, `"cmg"`).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Device {
    /// The three fibre-optic rate gyros.
    Gyro,
    /// The two-axis inclinometer.
    Inclinometer,
    /// The three-axis magnetometer.
    Magnetometer,
    /// The three reaction wheels (telemetry in, torque commands out).
    Wheels,
    /// The four control moment gyros (telemetry in, gimbal rate commands out).
    Cmg,
}

impl Device {
    /// Every device.
    pub const ALL: [Device; 5] = [
        Self::Gyro,
        Self::Inclinometer,
        Self::Magnetometer,
        Self::Wheels,
        Self::Cmg,
    ];

    /// The name used in configurations and profiles.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Gyro => "gyro",
            Self::Inclinometer => "inclinometer",
            Self::Magnetometer => "magnetometer",
            Self::Wheels => "wheels",
            Self::Cmg => "cmg",
        }
    }

    /// The device called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }
}

impl core::str::FromStr for Device {
    type Err = String;

    /// The device called `name`; the error names it and the known devices.
    fn from_str(name: &str) -> Result<Self, String> {
        Self::from_name(name).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|d| d.name()).collect();
            format!("unknown device {name:?} (known: {})", known.join(", "))
        })
    }
}

impl fmt::Display for Device {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Who owns time in a run.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum ClockMode {
    /// The plant advances only when the pipeline has answered the current tick: as fast as the
    /// machine allows, and byte-identical logs for the same seed.
    #[default]
    Lockstep,
    /// The plant advances at 1× wall time whether or not the pipeline answered (late answers are
    /// deadline misses).
    Paced,
}

impl ClockMode {
    /// The name used in profiles, configurations and `TESTBED_RUN_MODE`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Lockstep => "lockstep",
            Self::Paced => "paced",
        }
    }
}

impl core::str::FromStr for ClockMode {
    type Err = String;
    /// `"lockstep"` or `"paced"` (command lines).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "lockstep" => Ok(Self::Lockstep),
            "paced" => Ok(Self::Paced),
            other => Err(format!("`{other}` is not a clock mode (lockstep or paced)")),
        }
    }
}

impl fmt::Display for ClockMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn served_devices_parse_in_order_and_unknown_ones_are_named() {
        assert_eq!(
            parse_devices("cmg, gyro"),
            Ok(vec![Device::Cmg, Device::Gyro])
        );
        let err = parse_devices("gyro,compass").unwrap_err();
        assert!(
            err.contains("\"compass\"") && err.contains("known: gyro"),
            "{err}"
        );
        assert!(parse_devices("").is_err());
    }
}
