//! The equations of the unexplained-effect search and of the falsification, together: the
//! candidate functions of every channel on one fit, the sparse search of every equation
//! ([`crate::sparse`]) and the tests of every named cause.
//!
//! Equations: the torque channel per body axis (the momentum residual, Nms, in the channel's
//! integral form), each filter-innovation component (whitened), and each wheel's spin equation
//! (Nms per interval; its own candidate library, see `wheel`). The candidate functions are
//! of the measured and estimated state and of time, and are the same for every data set:
//!
//! | name | function |
//! |---|---|
//! | `1` | constant |
//! | `t` | time from the record's start over its duration (0 … 1) |
//! | `sin tilt_x`, `sin tilt_y` | horizontal components of the down vector in body axes `G_B` (its vertical one is within 1 % of a constant at the test bed's tilts, so it is not a separate candidate) |
//! | `t·sin tilt_x`, `t·sin tilt_y` | their products with time (a drifting centre of mass) |
//! | `cos ψ`, `sin ψ`, `cos 2ψ`, `sin 2ψ` | heading harmonics |
//! | `t·cos ψ`, `t·sin ψ` | (sensor channels) slowly changing heading-fixed errors |
//! | `w_x`, `w_y`, `w_z` | body rates, rad/s |
//! | `w_x·|w_x|` … | quadratic damping (torque channel) |
//! | `w_x·w_y`, `w_y·w_z`, `w_z·w_x` | rate products (torque channel) |
//! | `dw_x/dt` … | angular accelerations, rad/s² (torque channel) |
//! | `n_x`, `n_y`, `n_z` | wheel speeds, rad/s (sensor channels: fields of the motors) |
//! | `B_x`, `B_y`, `B_z` | the model's lab field in body axes over its magnitude (sensor channels) |
//!
//! Wheel speeds, wheel accelerations and commands are **not** torque-channel candidates: in
//! closed loop the controller makes them follow the integral of (or cancel) whatever external
//! torque acts, so any torque would be "explained" by them without saying its form.
//!
//! In the torque channel a function f enters as the channel's regressors do: `∫ f dt` from the
//! segment's start (rates as instruments, the mean of the neighbouring samples), its segment
//! mean removed; a derivative `dx/dt` enters as `x − x_start`. The coefficient is then a torque
//! per unit of f, Nm.

use super::falsify::{CauseTest, Levels};
use super::innovation::{InnovationCandidates, SensorLinear, search_innovations, sensor_tests};
use super::torque::{JointTorque, TorqueCandidates, search_torque, torque_tests};
use super::unexplained::UnexplainedEffect;
use super::wheel::{WheelCandidates, search_wheels, wheel_tests};
use crate::effects::Cause;
use crate::fit::{Problem, SetFit};
use crate::sparse::SparseOptions;

/// The candidate functions of every channel and the named sensor causes' linearisation, on one
/// fit.
pub(super) struct Candidates {
    pub torque: TorqueCandidates,
    pub innovation: InnovationCandidates,
    pub linear: Option<SensorLinear>,
    pub wheel: WheelCandidates,
}

impl Candidates {
    pub fn new(problem: &Problem, fit: &SetFit, named: &[Cause]) -> Self {
        Self {
            torque: TorqueCandidates::new(problem, fit),
            innovation: InnovationCandidates::new(problem, fit),
            linear: SensorLinear::new(problem, fit, named),
            wheel: WheelCandidates::new(problem, fit),
        }
    }
}

/// Search every equation for what the fit `fit` (of the named causes `named`) leaves.
pub(super) fn search_all(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &Candidates,
    block_s: f64,
    options: &SparseOptions,
) -> Vec<UnexplainedEffect> {
    let mut out = Vec::new();
    out.extend(
        search_torque(
            problem,
            fit,
            named,
            &candidates.torque,
            block_s,
            options,
            None,
        )
        .0,
    );
    out.extend(search_innovations(
        problem,
        fit,
        &candidates.innovation,
        candidates.linear.as_ref(),
        block_s,
        options,
    ));
    out.extend(search_wheels(
        problem,
        fit,
        named,
        &candidates.wheel,
        block_s,
        options,
    ));
    out
}

/// Test every named cause of `fit` in its channel (see `falsify`), beside the unexplained
/// effects `effects`; also the joint fit of the torque causes with the unexplained torque terms.
pub(super) fn test_causes(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    effects: &[UnexplainedEffect],
    candidates: &Candidates,
    levels: &Levels,
) -> (Vec<CauseTest>, Option<JointTorque>) {
    let (mut out, joint) = torque_tests(problem, fit, named, effects, &candidates.torque, levels);
    out.extend(sensor_tests(
        problem,
        fit,
        named,
        effects,
        (&candidates.innovation, candidates.linear.as_ref()),
        levels,
    ));
    out.extend(wheel_tests(
        problem,
        fit,
        named,
        effects,
        &candidates.wheel,
        levels,
    ));
    (out, joint)
}
