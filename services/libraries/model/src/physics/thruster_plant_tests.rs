//! The thrusters in the plant, against closed forms.

use super::*;
use crate::attitude;
use crate::config::ModelConfig;
use crate::thruster_config::{G0_MPS2, ThrusterConfig};
use nalgebra::Vector3;

/// Diagonal inertia, frictionless wheels, quiet thrusters: a Z pulse stays on Z.
fn config() -> ModelConfig {
    let mut c = ModelConfig::default();
    c.platform.inertia_kgm2 = [[45.2, 0.0, 0.0], [0.0, 46.1, 0.0], [0.0, 0.0, 62.7]];
    c.wheels.coulomb_nm = [0.0; 3];
    c.wheels.viscous_nm_per_rad_s = [0.0; 3];
    c.thrusters = Some(ThrusterConfig {
        thrust_noise_fraction: 0.0,
        ..ThrusterConfig::default()
    });
    c
}

#[test]
fn a_pulse_train_changes_the_platforms_momentum_by_its_closed_form_impulse() {
    let mut c = config();
    // The tank at the bearing centre: no gravity torque from the propellant used.
    c.thrusters.as_mut().unwrap().tank_position_m = [0.0; 3];
    let t = c.thrusters.clone().unwrap();
    let mut plant = Plant::new(&c, PlatformState::default()).unwrap();
    // Thruster 4 (+Z torque): 5 pulses of 30 ms at 10 Hz, then 2 s of coasting.
    for k in 0..25 {
        let mut cmd = ThrusterCommand::default();
        if k < 5 {
            cmd.on_time_s[4] = 0.03;
        }
        plant.command_thrusters(&cmd).unwrap();
        plant.step(&ActuatorCommand::default(), 0.1).unwrap();
    }
    let impulse = 5.0 * 0.5 * t.thrust_n * (0.03 + t.close_delay_s - t.open_delay_s);
    let h = plant.angular_momentum_l();
    assert!(
        (h.z - impulse).abs() < 1e-12 * impulse.max(1.0),
        "{h:?} vs {impulse}"
    );
    assert!(h.xy().norm() < 1e-15, "{h:?}");
    // The platform turns at impulse / (I_zz − J): the frictionless Z wheel does not follow it.
    let rate = plant.state().rate_b.z;
    let j = c.wheels.inertia_kgm2;
    assert!((rate - impulse / (62.7 - j)).abs() < 1e-15, "{rate}");
    let bank = plant.thrusters().unwrap();
    let used = 5.0 * t.thrust_n * (0.03 + t.close_delay_s - t.open_delay_s) / (t.isp_s * G0_MPS2);
    assert!((bank.propellant_used_kg() - used).abs() < 1e-15);
    // A non-finite command is refused.
    let mut bad = ThrusterCommand::default();
    bad.on_time_s[0] = f64::NAN;
    assert!(plant.command_thrusters(&bad).is_err());
}

#[test]
fn propellant_used_moves_the_gravity_torque_by_the_lost_weight_at_the_tank() {
    let c = config();
    let t = c.thrusters.clone().unwrap();
    let mut plant = Plant::new(&c, PlatformState::default()).unwrap();
    assert_eq!(plant.external_torque_b().gravity_b, Vector3::zeros());
    // Fire the ±X pair together (no net torque) for 20 s.
    for _ in 0..200 {
        let mut cmd = ThrusterCommand::default();
        cmd.on_time_s[0] = 0.1;
        cmd.on_time_s[1] = 0.1;
        plant.command_thrusters(&cmd).unwrap();
        plant.step(&ActuatorCommand::default(), 0.1).unwrap();
    }
    // The last step's torque is resolved at its last substep's start: compare with the
    // propellant used by then, 2 × ṁ × (20 s − 10 ms substep − open delay).
    let used = plant.thrusters().unwrap().propellant_used_kg();
    let want_used = 2.0 * t.mass_flow_kg_s() * (20.0 - t.open_delay_s);
    assert!((used - want_used).abs() < 1e-12, "{used} vs {want_used}");
    plant.step(&ActuatorCommand::default(), 0.1).unwrap();
    let used = plant.thrusters().unwrap().propellant_used_kg();
    let g_b = attitude::gravity_b(&plant.state().q);
    let r_t = Vector3::from(t.tank_position_m);
    let want = (-r_t * used * c.platform.gravity_mps2).cross(&g_b);
    let got = plant.external_torque_b().gravity_b;
    assert!((got - want).norm() < 1e-15, "{got:?} vs {want:?}");
    assert!(got.norm() > 0.0);
}

#[test]
fn without_the_thrusters_table_commands_do_nothing() {
    let mut c = config();
    c.thrusters = None;
    let mut plant = Plant::new(&c, PlatformState::default()).unwrap();
    let cmd = ThrusterCommand {
        on_time_s: [0.1; 6],
    };
    plant.command_thrusters(&cmd).unwrap();
    plant.step(&ActuatorCommand::default(), 0.1).unwrap();
    assert!(plant.thrusters().is_none());
    assert_eq!(plant.state(), &PlatformState::default());
}
