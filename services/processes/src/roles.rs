//! The table of roles: every process of the pipeline, by the name the `testbed` executable is
//! started under (busybox style, see `testbed_cli::main`). The launcher starts a role through a
//! symbolic link of that name to `testbed`, so the process is named by its role in `ps` and
//! `/proc/PID/comm` from its `exec` on; a profile's `command` names it.

use ipc_types::Device;
use testbed_gateways::gateway::Served;
use testbed_runtime::run;

use crate::can_board::CanBoardProcess;
use crate::can_gateway::CanGateway;
use crate::can_replay::CanReplayProcess;
use crate::controller::ControllerProcess;
use crate::estimator::EstimatorProcess;
use crate::ground_link::GroundLinkProcess;
use crate::logger::LoggerProcess;
use crate::plant::PlantProcess;
use crate::replay::ReplayProcess;
use crate::sim_gateway::SimGateway;

/// One process of the pipeline.
#[derive(Debug, Clone, Copy)]
pub struct Role {
    /// Its name: the profile's `command`, the process's name in `ps`, its heartbeats' source.
    pub name: &'static str,
    /// Its main, given [`Role::name`].
    main: fn(&'static str) -> anyhow::Result<()>,
}

impl Role {
    const fn new(name: &'static str, main: fn(&'static str) -> anyhow::Result<()>) -> Self {
        Self { name, main }
    }

    /// Runs the process until it ends.
    pub fn run(&self) -> anyhow::Result<()> {
        (self.main)(self.name)
    }
}

/// Every role, the one place that lists them. A gateway's name is its device's
/// `process_name` (checked by a test).
pub const ROLES: &[Role] = &[
    Role::new("plant", |name| run(name, PlantProcess::open)),
    Role::new("sim-gyro", |name| {
        run(name, |cx| SimGateway::open(cx, &[Device::Gyro]))
    }),
    Role::new("sim-inclinometer", |name| {
        run(name, |cx| SimGateway::open(cx, &[Device::Inclinometer]))
    }),
    Role::new("sim-magnetometer", |name| {
        run(name, |cx| SimGateway::open(cx, &[Device::Magnetometer]))
    }),
    Role::new("sim-wheels", |name| {
        run(name, |cx| SimGateway::open(cx, &[Device::Wheels]))
    }),
    Role::new("sim-cmg", |name| {
        run(name, |cx| SimGateway::open(cx, &[Device::Cmg]))
    }),
    // Several simulated devices in one process: the profile's `device` list.
    Role::new("sim-devices", |name| run(name, SimGateway::open_served)),
    Role::new("estimator", |name| run(name, EstimatorProcess::open)),
    Role::new("controller", |name| run(name, ControllerProcess::open)),
    Role::new("logger", |name| run(name, LoggerProcess::open)),
    Role::new("replay", |name| run(name, ReplayProcess::open)),
    Role::new("gyro-gateway", |name| {
        run(name, |cx| CanGateway::open(cx, Device::Gyro))
    }),
    Role::new("inclinometer-gateway", |name| {
        run(name, |cx| CanGateway::open(cx, Device::Inclinometer))
    }),
    Role::new("magnetometer-gateway", |name| {
        run(name, |cx| CanGateway::open(cx, Device::Magnetometer))
    }),
    Role::new("wheel-gateway", |name| {
        run(name, |cx| CanGateway::open(cx, Device::Wheels))
    }),
    Role::new("cmg-gateway", |name| {
        run(name, |cx| CanGateway::open(cx, Device::Cmg))
    }),
    Role::new("thruster-gateway", |name| {
        run(name, |cx| CanGateway::open(cx, Served::Thrusters))
    }),
    Role::new("sim-can-node", |name| run(name, CanBoardProcess::open)),
    Role::new("can-replay", |name| run(name, CanReplayProcess::open)),
    Role::new("ground-link", |name| run(name, GroundLinkProcess::open)),
];

/// The role called `name`.
pub fn find(name: &str) -> Option<&'static Role> {
    ROLES.iter().find(|role| role.name == name)
}

/// The names of every role, in table order.
pub fn names() -> Vec<&'static str> {
    ROLES.iter().map(|role| role.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use testbed_gateways::GatewayDevice as _;

    #[test]
    fn names_are_unique_and_gateways_are_named_as_their_devices() {
        let mut names = names();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), ROLES.len(), "a role is listed twice");
        let gateways = Device::ALL
            .iter()
            .map(|&d| Served::Device(d))
            .chain([Served::Thrusters]);
        for served in gateways {
            assert!(
                find(served.process_name()).is_some(),
                "no role {:?}",
                served.process_name()
            );
        }
    }
}
