//! What no named cause explains: the candidate-function library, the sparse search per equation
//! ([`crate::sparse`]) and the report of an **unexplained effect**.
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

use crate::channels::{TORQUE_COLUMNS, torque_columns};
use crate::effects::{Cause, Kind};
use crate::fit::{Problem, SetFit};
use crate::reconstruct::INNOVATION_LEN;
use crate::sparse::{Design, Rows, SparseOptions, SparseResult, Term, search};
use serde::Serialize;
use testbed_model::attitude;
use testbed_model::config::{
    FittedTorque, FittedTorqueTerm, FittedWheelTorque, FittedWheelTorqueTerm,
};
use testbed_model::physics::fitted_torque::TorqueFunction;
use testbed_model::physics::fitted_wheel_torque::WheelFunction;

/// An effect in the residuals that no named cause explains.
#[derive(Debug, Clone, Serialize)]
pub struct UnexplainedEffect {
    /// The equation: `torque_x` … (Nm per unit of the function), `innovation_field_x` …
    /// (whitened innovation per unit).
    pub equation: String,
    /// Unit of the coefficients.
    pub unit: &'static str,
    /// The proposed term, e.g. `torque_y ≈ +3.1e-3 Nm × t·sin tilt_x − …`.
    pub proposed: String,
    /// The terms found (coefficient, cluster-robust standard error).
    pub terms: Vec<Term>,
    /// The named causes' own regressors in this equation, refitted with the terms.
    pub refitted_named: Vec<Term>,
    /// Evidence: |z| threshold (Bonferroni over the candidates), k-fold cross-validated RMS
    /// ratio and held-out RMS ratio of the equation without / with the terms.
    pub z_threshold: f64,
    pub cv_gain: f64,
    pub held_out_gain: f64,
    /// Rows and clusters (independent units) behind the evidence.
    pub rows: usize,
    pub clusters: usize,
    /// The analysis pass that found it: 1 on the data as measured, 2 after the magnetometer
    /// correction of the first pass's field effects (see `Report::sensor_correction`).
    pub pass: u8,
}

/// Per-row values of every torque candidate, already in the channel's integral form.
pub(super) struct TorqueCandidates {
    pub names: Vec<&'static str>,
    /// `rows × names.len()`.
    pub values: Vec<Vec<f64>>,
}

const TORQUE_NAMES: [&str; 22] = [
    "1",
    "t",
    "sin tilt_x",
    "sin tilt_y",
    "t·sin tilt_x",
    "t·sin tilt_y",
    "cos ψ",
    "sin ψ",
    "cos 2ψ",
    "sin 2ψ",
    "w_x",
    "w_y",
    "w_z",
    "w_x·|w_x|",
    "w_y·|w_y|",
    "w_z·|w_z|",
    "w_x·w_y",
    "w_y·w_z",
    "w_z·w_x",
    "dw_x/dt",
    "dw_y/dt",
    "dw_z/dt",
];
/// Of [`TORQUE_NAMES`], the first index in derivative (direct) form.
const TORQUE_DIRECT_FROM: usize = 19;

impl TorqueCandidates {
    pub fn new(problem: &Problem, fit: &SetFit) -> Self {
        let data = problem.data;
        let s = &fit.state;
        let ch = &s.torque;
        let t0 = data.t.first().copied().unwrap_or(0.0);
        let span = (data.t.last().copied().unwrap_or(1.0) - t0).max(1e-9);
        let m = TORQUE_NAMES.len();
        let inst = |k: usize| 0.5 * (s.recon.rate[k - 1] + s.recon.rate[k + 1]);
        let integrand = |k: usize| -> Vec<f64> {
            let t = (data.t[k] - t0) / span;
            let g = attitude::gravity_b(&s.recon.q[k]);
            let psi = attitude::heading(&s.recon.q[k]);
            let w = inst(k);
            vec![
                1.0,
                t,
                g.x,
                g.y,
                t * g.x,
                t * g.y,
                psi.cos(),
                psi.sin(),
                (2.0 * psi).cos(),
                (2.0 * psi).sin(),
                w.x,
                w.y,
                w.z,
                w.x * w.x.abs(),
                w.y * w.y.abs(),
                w.z * w.z.abs(),
                w.x * w.y,
                w.y * w.z,
                w.z * w.x,
            ]
        };
        let direct = |k: usize| -> [f64; 3] {
            let w = inst(k);
            [w.x, w.y, w.z]
        };
        let mut values = vec![vec![0.0; m]; ch.len()];
        for seg in &ch.segments {
            let first = seg.start;
            let k0 = ch.ticks[first];
            let d0 = direct(k0);
            let mut acc = [0.0; TORQUE_DIRECT_FROM];
            let mut prev = integrand(k0);
            for r in seg.clone() {
                let k = ch.ticks[r];
                if r > first {
                    let h = 0.5 * (data.t[k] - data.t[ch.ticks[r - 1]]);
                    let f = integrand(k);
                    for j in 0..TORQUE_DIRECT_FROM {
                        acc[j] += h * (prev[j] + f[j]);
                    }
                    prev = f;
                }
                let d = direct(k);
                values[r][..TORQUE_DIRECT_FROM].copy_from_slice(&acc);
                for j in 0..3 {
                    values[r][TORQUE_DIRECT_FROM + j] = d[j] - d0[j];
                }
            }
            let len = seg.len() as f64;
            for j in 0..m {
                let mean = seg.clone().map(|r| values[r][j]).sum::<f64>() / len;
                for r in seg.clone() {
                    values[r][j] -= mean;
                }
            }
        }
        Self {
            names: TORQUE_NAMES.to_vec(),
            values,
        }
    }
}

/// Folds and clusters: interleaved blocks of `block_s` (block b in fold `b mod folds`).
pub(super) fn fold_of(t: f64, block_s: f64) -> usize {
    (t / block_s).floor().max(0.0) as usize
}

/// Search every equation for what the fit `fit` (of the named causes `named`) leaves.
/// The candidate functions of both channels and the named sensor causes' linearisation, on one
/// fit.
pub(super) struct Candidates {
    pub torque: TorqueCandidates,
    pub innovation: InnovationCandidates,
    pub linear: Option<SensorLinear>,
    pub wheel: super::wheel::WheelCandidates,
}

impl Candidates {
    pub fn new(problem: &Problem, fit: &SetFit, named: &[Cause]) -> Self {
        Self {
            torque: TorqueCandidates::new(problem, fit),
            innovation: InnovationCandidates::new(problem, fit),
            linear: SensorLinear::new(problem, fit, named),
            wheel: super::wheel::WheelCandidates::new(problem, fit),
        }
    }
}

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
    out.extend(super::wheel::search_wheels(
        problem,
        fit,
        named,
        &candidates.wheel,
        block_s,
        options,
    ));
    out
}

/// The torque search's cross-validated residual sum (whitened, summed over the three axes)
/// with the named causes `named`: what a competing explanation is measured against.
pub(super) fn torque_cv_rss(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &TorqueCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Option<f64> {
    search_torque(problem, fit, named, candidates, block_s, options, None).1
}

/// The competing explanation of a named torque cause: the torque search redone without it
/// (its fitted part put back into the residual) and without the candidate functions that are
/// the cause's own form (`1` for a constant torque, the tilt terms for a centre-of-mass offset,
/// rates for drag, accelerations and rate products for the inertia). Returns the effects it
/// finds and its cross-validated residual sum, to set against [`torque_cv_rss`] with the
/// cause: a cause whose part a generic form of another kind explains better stood in for that
/// form.
pub(super) fn competing_explanation(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    cause: Cause,
    candidates: &TorqueCandidates,
    block_s: f64,
    options: &SparseOptions,
) -> Option<(Vec<UnexplainedEffect>, f64)> {
    let others: Vec<Cause> = named.iter().copied().filter(|c| *c != cause).collect();
    let (effects, cv) = search_torque(
        problem,
        fit,
        &others,
        candidates,
        block_s,
        options,
        Some(cause),
    );
    Some((effects, cv?))
}

/// The cause's own form among the torque candidates (excluded from its competitor).
fn own_form(cause: Cause) -> &'static [&'static str] {
    match cause {
        Cause::ConstantTorque => &["1"],
        Cause::ComOffset => &["1", "sin tilt_x", "sin tilt_y"],
        Cause::AeroDrag => &["w_x", "w_y", "w_z", "w_x·|w_x|", "w_y·|w_y|", "w_z·|w_z|"],
        Cause::InertiaError => &[
            "dw_x/dt", "dw_y/dt", "dw_z/dt", "w_x·w_y", "w_y·w_z", "w_z·w_x",
        ],
        _ => &[],
    }
}

/// The torque search; with `removed` the residual has that cause's fitted part put back and
/// its own form is not a candidate. Also the cross-validated residual sum over the axes,
/// whitened by each axis's noise (`None` if the channel is too short).
fn search_torque(
    problem: &Problem,
    fit: &SetFit,
    named: &[Cause],
    candidates: &TorqueCandidates,
    block_s: f64,
    options: &SparseOptions,
    removed: Option<Cause>,
) -> (Vec<UnexplainedEffect>, Option<f64>) {
    let data = problem.data;
    let ch = &fit.state.torque;
    if ch.len() < 30 {
        return (Vec::new(), None);
    }
    let mut delta = fit.torque_delta;
    if let Some(range) = removed.and_then(torque_columns) {
        for d in &mut delta[range] {
            *d = 0.0;
        }
    }
    let excluded: &[&str] = removed.map_or(&[], own_form);
    let kept_candidates: Vec<usize> = (0..candidates.names.len())
        .filter(|&j| !excluded.contains(&candidates.names[j]))
        .collect();
    let mut cv_total = 0.0;
    let named_cols: Vec<usize> = named
        .iter()
        .filter(|c| c.kind() == Kind::Torque)
        .flat_map(|c| torque_columns(*c).into_iter().flatten())
        .collect();
    let mut segment_of = vec![0; ch.len()];
    for (s, seg) in ch.segments.iter().enumerate() {
        for r in seg.clone() {
            segment_of[r] = s;
        }
    }
    let fold: Vec<usize> = (0..ch.len())
        .map(|r| fold_of(data.t[ch.ticks[ch.segments[segment_of[r]].start]], block_s))
        .collect();
    let held: Vec<bool> = ch.ticks.iter().map(|&k| problem.held_out[k]).collect();
    let mut out = Vec::new();
    for axis in 0..3 {
        // The named causes' columns that act on this axis.
        let forced: Vec<usize> = named_cols
            .iter()
            .copied()
            .filter(|&c| ch.x.iter().any(|row| row[c][axis] != 0.0))
            .collect();
        let mut names: Vec<String> = forced.iter().map(|&c| column_name(c)).collect();
        names.extend(
            kept_candidates
                .iter()
                .map(|&j| candidates.names[j].to_string()),
        );
        let x: Vec<Vec<f64>> = (0..ch.len())
            .map(|r| {
                let mut row: Vec<f64> = forced.iter().map(|&c| ch.x[r][c][axis]).collect();
                row.extend(kept_candidates.iter().map(|&j| candidates.values[r][j]));
                row
            })
            .collect();
        let y: Vec<f64> = (0..ch.len())
            .map(|r| ch.whitened(r, &delta)[axis] * ch.sigma[axis])
            .collect();
        let rows = Rows {
            x: &x,
            y: &y,
            cluster: &segment_of,
            fold: &fold,
            held_out: &held,
        };
        let design = Design::new(names, forced.len(), rows, options.folds);
        let result = search(&design, options);
        cv_total += result.cv_rss / (ch.sigma[axis] * ch.sigma[axis]);
        if let Some(e) = effect(
            format!("torque_{}", "xyz".as_bytes()[axis] as char),
            "Nm",
            result,
            &design,
        ) {
            out.push(e);
        }
    }
    (out, Some(cv_total))
}

/// Per filter innovation (all ticks, in the reconstruction's order): the sensor-channel
/// candidates, evaluated at its tick.
pub(super) struct InnovationCandidates {
    pub names: Vec<&'static str>,
    pub values: Vec<Vec<f64>>,
    /// Per innovation and component: its row in the innovation vector (`usize::MAX`: absent).
    pub row: Vec<[usize; INNOVATION_LEN]>,
}

impl InnovationCandidates {
    pub fn new(problem: &Problem, fit: &SetFit) -> Self {
        let data = problem.data;
        let s = &fit.state;
        let t0 = data.t.first().copied().unwrap_or(0.0);
        let span = (data.t.last().copied().unwrap_or(1.0) - t0).max(1e-9);
        let field = problem.base.platform.field_l_t();
        let field_n = field / field.norm().max(1e-300);
        let wheels = data.has_wheels();
        let mut names: Vec<&'static str> = vec![
            "1",
            "t",
            "cos ψ",
            "sin ψ",
            "cos 2ψ",
            "sin 2ψ",
            "t·cos ψ",
            "t·sin ψ",
            "sin tilt_x",
            "sin tilt_y",
            "B_x",
            "B_y",
            "B_z",
            "w_x",
            "w_y",
            "w_z",
        ];
        if wheels {
            names.extend(["n_x", "n_y", "n_z"]);
        }
        let mut next = 0;
        let mut row = Vec::with_capacity(s.recon.innovations.len());
        let values = s
            .recon
            .innovations
            .iter()
            .map(|i| {
                let mut r = [usize::MAX; INNOVATION_LEN];
                for (c, slot) in r.iter_mut().enumerate() {
                    if i.mask & (1 << c) != 0 {
                        *slot = next;
                        next += 1;
                    }
                }
                row.push(r);
                let k = i.tick;
                let q = &s.recon.q[k];
                let t = (data.t[k] - t0) / span;
                let psi = attitude::heading(q);
                let g = attitude::gravity_b(q);
                let b = q * field_n;
                let w = s.recon.rate[k];
                let mut v = vec![
                    1.0,
                    t,
                    psi.cos(),
                    psi.sin(),
                    (2.0 * psi).cos(),
                    (2.0 * psi).sin(),
                    t * psi.cos(),
                    t * psi.sin(),
                    g.x,
                    g.y,
                    b.x,
                    b.y,
                    b.z,
                    w.x,
                    w.y,
                    w.z,
                ];
                if wheels {
                    let n = data.wheel_speed_at(k);
                    v.extend([n.x, n.y, n.z]);
                }
                v
            })
            .collect();
        Self { names, values, row }
    }
}

/// The named sensor causes linearised at their fitted values: `∂(innovation vector)/∂θ_j` by
/// forward differences through the filter (one filter run per parameter), over all ticks.
pub(super) struct SensorLinear {
    /// Per column: cause, value index, name.
    pub cols: Vec<(Cause, usize, String)>,
    /// Per column: fitted value minus the value that switches the cause off (`None` for
    /// `earth_rate`, which has no neutral value).
    pub delta: Vec<Option<f64>>,
    /// Per column, per innovation-vector row.
    pub j: Vec<Vec<f64>>,
}

impl SensorLinear {
    pub fn new(problem: &Problem, fit: &SetFit, named: &[Cause]) -> Option<Self> {
        let sensor: Vec<Cause> = named
            .iter()
            .copied()
            .filter(|c| c.kind() == Kind::Sensor)
            .collect();
        if sensor.is_empty() {
            return None;
        }
        let r0 = fit.state.recon.innovation_vector(|_| true);
        let mut cols = Vec::new();
        let mut delta = Vec::new();
        let mut j = Vec::new();
        for cause in sensor {
            let values = cause.values(&fit.config);
            let neutral = cause.values(&problem.base);
            let mut offset = 0;
            for spec in cause.params() {
                for e in 0..spec.len {
                    let i = offset + e;
                    let (lo, hi) = cause.bounds(i);
                    let h = if values[i] + spec.step > hi {
                        -spec.step
                    } else {
                        spec.step
                    };
                    let mut v = values.clone();
                    v[i] = (values[i] + h).clamp(lo, hi);
                    let taken = v[i] - values[i];
                    let mut config = fit.config.clone();
                    cause.apply(&mut config, &v);
                    let r = problem
                        .run_filter(&config)
                        .ok()?
                        .innovation_vector(|_| true);
                    if r.len() != r0.len() || taken == 0.0 {
                        return None;
                    }
                    j.push(r.iter().zip(&r0).map(|(a, b)| (a - b) / taken).collect());
                    cols.push((cause, i, cause.value_name(i)));
                    delta.push((cause != Cause::EarthRate).then(|| values[i] - neutral[i]));
                }
                offset += spec.len;
            }
        }
        Some(Self { cols, delta, j })
    }
}

fn search_innovations(
    problem: &Problem,
    fit: &SetFit,
    candidates: &InnovationCandidates,
    linear: Option<&SensorLinear>,
    block_s: f64,
    options: &SparseOptions,
) -> Vec<UnexplainedEffect> {
    let data = problem.data;
    let s = &fit.state;
    let mut out = Vec::new();
    for c in 0..INNOVATION_LEN {
        let rows: Vec<usize> = (0..s.recon.innovations.len())
            .filter(|&i| candidates.row[i][c] != usize::MAX)
            .collect();
        if rows.len() < 100 {
            continue;
        }
        // The named sensor causes' own columns (their Jacobian rows of this component) are
        // forced, so their values re-adjust with any new term.
        let forced: Vec<usize> = linear.map_or(Vec::new(), |l| {
            (0..l.cols.len())
                .filter(|&j| rows.iter().any(|&i| l.j[j][candidates.row[i][c]] != 0.0))
                .collect()
        });
        let mut names: Vec<String> = forced
            .iter()
            .filter_map(|&j| linear.map(|l| l.cols[j].2.clone()))
            .collect();
        names.extend(candidates.names.iter().map(|n| n.to_string()));
        let x: Vec<Vec<f64>> = rows
            .iter()
            .map(|&i| {
                let mut row: Vec<f64> = forced
                    .iter()
                    .filter_map(|&j| linear.map(|l| l.j[j][candidates.row[i][c]]))
                    .collect();
                row.extend(&candidates.values[i]);
                row
            })
            .collect();
        let inn = &s.recon.innovations;
        let y: Vec<f64> = rows.iter().map(|&i| inn[i].values[c]).collect();
        // Clusters of a third of a block (never across a fit / held-out change).
        let cluster: Vec<usize> = rows
            .iter()
            .map(|&i| fold_of(data.t[inn[i].tick], block_s / 3.0))
            .collect();
        let fold: Vec<usize> = rows
            .iter()
            .map(|&i| fold_of(data.t[inn[i].tick], block_s))
            .collect();
        let held: Vec<bool> = rows
            .iter()
            .map(|&i| problem.held_out[inn[i].tick])
            .collect();
        let rows = Rows {
            x: &x,
            y: &y,
            cluster: &cluster,
            fold: &fold,
            held_out: &held,
        };
        let design = Design::new(names, forced.len(), rows, options.folds);
        let result = search(&design, options);
        if let Some(e) = effect(
            INNOVATION_LABELS[c].to_string(),
            "1 (whitened)",
            result,
            &design,
        ) {
            out.push(e);
        }
    }
    out
}

/// Names of the innovation components (the equations of the sensor channel).
pub(super) const INNOVATION_LABELS: [&str; INNOVATION_LEN] = [
    "innovation_tilt_1",
    "innovation_tilt_2",
    "innovation_field_x",
    "innovation_field_y",
    "innovation_field_z",
];

pub(super) fn effect(
    equation: String,
    unit: &'static str,
    result: SparseResult,
    design: &Design,
) -> Option<UnexplainedEffect> {
    if result.terms.is_empty() {
        return None;
    }
    let mut proposed = format!("{equation} ≈");
    for (i, t) in result.terms.iter().enumerate() {
        let text = super::report::round_to(t.value.abs(), t.stderr);
        let sign = match (i, t.value < 0.0) {
            (0, false) => "",
            (0, true) => "−",
            (_, false) => "+ ",
            (_, true) => "− ",
        };
        proposed.push_str(&format!(" {sign}{text} {unit} × {}", t.name));
    }
    Some(UnexplainedEffect {
        equation,
        unit,
        proposed,
        terms: result.terms,
        refitted_named: result.forced,
        z_threshold: result.z_threshold,
        cv_gain: result.cv_gain,
        held_out_gain: result.held_out_gain,
        rows: design.rows(),
        clusters: design.clusters(),
        pass: 1,
    })
}

/// Name of a torque column (`com_offset.r_m[0]` …).
pub(super) fn column_name(col: usize) -> String {
    debug_assert!(col < TORQUE_COLUMNS);
    let (cause, off) = crate::channels::column_cause(col);
    cause.value_name(off)
}

/// Which fit of a term's coefficient to use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Coefficients {
    /// Fitted on all the data (the extended model written).
    All,
    /// Fitted without the held-out blocks (their prediction).
    FitBlocks,
    /// Fitted without the search's fold f (that fold's prediction).
    WithoutFold(usize),
}

impl Coefficients {
    /// `term`'s coefficient of this kind (NaN for a fold it was not fitted without).
    fn of(self, term: &Term) -> f64 {
        match self {
            Self::All => term.value,
            Self::FitBlocks => term.value_fit_blocks,
            Self::WithoutFold(f) => term.value_without_fold.get(f).copied().unwrap_or(f64::NAN),
        }
    }
}

/// The torque-channel unexplained effects as a model extension, `[effects.fitted_torque]`:
/// each term's function in the plant's form (identification's `t`, 0…1 over the record of
/// `span_s` seconds, becomes `t_s` in seconds from its start, its coefficient divided by the
/// span), with the coefficients `which` says. The second value lists the terms a forward
/// simulation cannot carry (angular accelerations: an inertia change, `inertia_error`'s
/// domain), as `equation: function`.
pub(super) fn fitted_torque(
    effects: &[UnexplainedEffect],
    span_s: f64,
    which: Coefficients,
) -> (Option<FittedTorque>, Vec<String>) {
    let mut terms = Vec::new();
    let mut not_carried = Vec::new();
    for effect in effects {
        let Some(axis) = effect.equation.strip_prefix("torque_") else {
            continue;
        };
        for term in &effect.terms {
            let value = which.of(term);
            let (name, per_unit) = match term.name.strip_prefix('t') {
                Some(rest) if rest.is_empty() || rest.starts_with('·') => {
                    (format!("t_s{rest}"), 1.0 / span_s)
                }
                _ => (term.name.clone(), 1.0),
            };
            match TorqueFunction::from_name(&name) {
                Some(f) if value.is_finite() => terms.push(FittedTorqueTerm {
                    axis: axis.to_string(),
                    function: f.name().to_string(),
                    coefficient: value * per_unit,
                }),
                _ => not_carried.push(format!("{}: {}", effect.equation, term.name)),
            }
        }
    }
    let fitted = (!terms.is_empty()).then_some(FittedTorque {
        start_time_s: 0.0,
        terms,
    });
    (fitted, not_carried)
}

/// The wheel-channel unexplained effects as a model extension, `[effects.fitted_wheel_torque]`:
/// each term of equation `wheel_x|y|z` on that wheel, in the plant's form. Identification's `t`
/// (0…1 over the record of `span_s` seconds) becomes `t_s` in seconds from its start, its
/// coefficient divided by the span; its `τ` (the commanded torque, clamped, at the model's
/// delay) becomes the plant's delivered torque, which is that times the wheel's torque scale
/// (`scale`, 1 without `wheel_torque_scale`), so its coefficient is divided by the scale. The
/// coefficients are those `which` says. The second value lists terms the plant cannot apply
/// (none of the wheel candidates today), as `equation: function`.
pub(super) fn fitted_wheel_torque(
    effects: &[UnexplainedEffect],
    span_s: f64,
    scale: [f64; 3],
    which: Coefficients,
) -> (Option<FittedWheelTorque>, Vec<String>) {
    let mut terms = Vec::new();
    let mut not_carried = Vec::new();
    for effect in effects {
        let Some(wheel) = effect.equation.strip_prefix("wheel_") else {
            continue;
        };
        let Some(index) = testbed_model::physics::fitted_torque::axis_index(wheel) else {
            continue;
        };
        for term in &effect.terms {
            let value = which.of(term);
            let (name, divisor) = match term.name.as_str() {
                "t" => ("t_s", span_s),
                "τ" => ("τ", scale[index]),
                other => (other, 1.0),
            };
            let coefficient = value / divisor;
            match WheelFunction::from_name(name) {
                Some(f) if coefficient.is_finite() => terms.push(FittedWheelTorqueTerm {
                    wheel: wheel.to_string(),
                    function: f.name().to_string(),
                    coefficient,
                }),
                _ => not_carried.push(format!("{}: {}", effect.equation, term.name)),
            }
        }
    }
    let fitted = (!terms.is_empty()).then_some(FittedWheelTorque {
        start_time_s: 0.0,
        terms,
    });
    (fitted, not_carried)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn effect(equation: &str, terms: &[(&str, f64)]) -> UnexplainedEffect {
        UnexplainedEffect {
            equation: equation.into(),
            unit: "Nm",
            proposed: String::new(),
            terms: terms
                .iter()
                .map(|(name, value)| Term {
                    name: name.to_string(),
                    value: *value,
                    stderr: 0.1 * value.abs(),
                    value_fit_blocks: 0.5 * value,
                    value_without_fold: vec![0.25 * value],
                })
                .collect(),
            refitted_named: Vec::new(),
            z_threshold: 4.6,
            cv_gain: 2.0,
            held_out_gain: 2.0,
            rows: 100,
            clusters: 10,
            pass: 1,
        }
    }

    #[test]
    fn torque_terms_become_a_fitted_torque_with_time_in_seconds() {
        let effects = [
            effect(
                "torque_x",
                &[("t", 3e-3), ("t·sin tilt_x", -6e-4), ("dw_x/dt", 2.0)],
            ),
            effect("torque_z", &[("1", 1e-3), ("sin 2ψ", 8e-4)]),
            effect("innovation_field_x", &[("B_x", 0.3)]),
        ];
        let (fitted, not_carried) = fitted_torque(&effects, 600.0, Coefficients::All);
        let fitted = fitted.expect("torque terms carried");
        let got: Vec<(&str, &str, f64)> = fitted
            .terms
            .iter()
            .map(|t| (t.axis.as_str(), t.function.as_str(), t.coefficient))
            .collect();
        assert_eq!(
            got,
            [
                ("x", "t_s", 3e-3 / 600.0),
                ("x", "t_s·sin tilt_x", -6e-4 / 600.0),
                ("z", "1", 1e-3),
                ("z", "sin 2ψ", 8e-4),
            ]
        );
        assert_eq!(not_carried, ["torque_x: dw_x/dt"]);
        // The held-out prediction's values: fitted without the held-out blocks.
        let (held, _) = fitted_torque(&effects, 600.0, Coefficients::FitBlocks);
        assert_eq!(held.expect("carried").terms[2].coefficient, 0.5e-3);
        let (fold, _) = fitted_torque(&effects, 600.0, Coefficients::WithoutFold(0));
        assert_eq!(fold.expect("carried").terms[2].coefficient, 0.25e-3);
        // Sensor effects alone: nothing to carry into the plant.
        assert_eq!(
            fitted_torque(&effects[2..], 600.0, Coefficients::All),
            (None, Vec::new())
        );
    }

    #[test]
    fn wheel_terms_become_a_fitted_wheel_torque_in_the_plants_form() {
        let effects = [
            effect("wheel_y", &[("n·|n|", -1e-8), ("t", 6e-4), ("τ", 0.04)]),
            effect("wheel_x", &[("sin tilt_x", 1e-2)]),
            effect("torque_z", &[("1", 1e-3)]),
        ];
        let scale = [1.0, 0.8, 1.0];
        let (fitted, not_carried) = fitted_wheel_torque(&effects, 600.0, scale, Coefficients::All);
        let fitted = fitted.expect("wheel terms carried");
        let got: Vec<(&str, &str, f64)> = fitted
            .terms
            .iter()
            .map(|t| (t.wheel.as_str(), t.function.as_str(), t.coefficient))
            .collect();
        assert_eq!(
            got,
            [
                ("y", "n·|n|", -1e-8),
                ("y", "t_s", 6e-4 / 600.0),
                ("y", "τ", 0.04 / 0.8),
                ("x", "sin tilt_x", 1e-2),
            ]
        );
        assert!(not_carried.is_empty(), "{not_carried:?}");
        // Every term loads as the model's configuration.
        let mut config = testbed_model::ModelConfig::default();
        config.effects.fitted_wheel_torque = Some(fitted);
        config.validate().expect("valid fitted wheel torque");
        let (held, _) = fitted_wheel_torque(&effects, 600.0, scale, Coefficients::FitBlocks);
        assert_eq!(held.expect("carried").terms[3].coefficient, 0.5e-2);
        let (fold, _) = fitted_wheel_torque(&effects, 600.0, scale, Coefficients::WithoutFold(0));
        assert_eq!(fold.expect("carried").terms[0].coefficient, -0.25e-8);
        // Torque effects alone: nothing for the wheels.
        assert_eq!(
            fitted_wheel_torque(&effects[2..], 600.0, scale, Coefficients::All),
            (None, Vec::new())
        );
    }
}
