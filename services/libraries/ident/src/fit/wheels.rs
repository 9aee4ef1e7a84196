//! Wheel causes (`wheel_torque_scale`, `wheel_friction`, `actuator_delay`): per-wheel least
//! squares, linear for a given delay and Stribeck speed; the delay and each wheel's Stribeck
//! speed found by 1-D search, their standard errors from the curvature of the residual sum.
//! Also [`WheelModel`], the wheels' drive and friction as a configuration has them.

use super::{FittedCause, Problem, State, solve_fixed};
use crate::channels::{GL4, WheelChannel, WheelInterval, friction_integral, friction_regressors};
use crate::data::Aligned;
use crate::effects::Cause;
use crate::error::IdentError;
use crate::stats::{NormalEquations, chi_square_quantile};
use nalgebra::DVector;
use rayon::prelude::*;
use testbed_model::ModelConfig;
use testbed_model::physics::fitted_wheel_torque::FittedWheelTorqueModel;
use testbed_model::physics::{Wheel, WheelFrictionModel};

impl Problem<'_> {
    pub(super) fn fit_wheels(
        &self,
        state: &State,
        set: &[Cause],
    ) -> Result<Vec<FittedCause>, IdentError> {
        let ch = &state.wheel;
        if ch.len() < 10 {
            return Err(IdentError::Failed(
                "too few usable wheel-channel intervals to fit".into(),
            ));
        }
        let fit_scale = set.contains(&Cause::WheelTorqueScale);
        let fit_friction = set.contains(&Cause::WheelFriction);
        let fit_delay = set.contains(&Cause::ActuatorDelay);
        let base = WheelModel::from_config(&self.base);
        let wheel_rows = self.wheel_rows(ch);
        let mut delay = base.delay_s;
        // Friction model per wheel: None = no Stribeck term.
        let mut stribeck: [Option<f64>; 3] = [None; 3];
        let mut result: [WheelSolve; 3] = Default::default();
        let mut delay_se = f64::NAN;
        let rounds = if fit_delay && fit_friction { 3 } else { 1 };
        for _ in 0..rounds {
            if fit_delay {
                let total = |d: f64| -> f64 {
                    (0..3)
                        .map(|w| {
                            let drive = wheel_rows.drive_integrals(w, d);
                            wheel_rows
                                .solve(&base, w, &drive, fit_scale, fit_friction, stribeck[w])
                                .map_or(0.0, |s| s.rss)
                        })
                        .sum()
                };
                let (d, se) = search_1d(total, 0.0, self.options.max_delay_s, 41);
                delay = d;
                delay_se = se;
            }
            for w in 0..3 {
                // The commanded torque's integrals at this delay, shared by the friction
                // search's many solves.
                let drive = wheel_rows.drive_integrals(w, delay);
                if fit_friction {
                    let none = wheel_rows.solve(&base, w, &drive, fit_scale, true, None);
                    let rss_of = |ns: f64| {
                        wheel_rows
                            .solve(&base, w, &drive, fit_scale, true, Some(ns))
                            .map_or(f64::INFINITY, |s| s.rss)
                    };
                    let (log_ns, log_se) =
                        search_1d(|x: f64| rss_of(x.exp()), 0.02f64.ln(), 30.0f64.ln(), 31);
                    let with =
                        wheel_rows.solve(&base, w, &drive, fit_scale, true, Some(log_ns.exp()));
                    let threshold = stribeck_threshold(ch.rows[w].len(), self.options.alpha);
                    let (choice, model) = match (none, with) {
                        (Some(a), Some(b)) if a.rss - b.rss > threshold && b.theta[3] > 0.0 => {
                            let mut b = b;
                            b.ns = Some((log_ns.exp(), log_ns.exp() * log_se));
                            (b, Some(log_ns.exp()))
                        }
                        (Some(a), _) => (a, None),
                        (None, Some(b)) => (b, Some(log_ns.exp())),
                        (None, None) => (WheelSolve::default(), None),
                    };
                    stribeck[w] = model;
                    result[w] = choice;
                } else {
                    result[w] = wheel_rows
                        .solve(&base, w, &drive, fit_scale, false, None)
                        .unwrap_or_default();
                }
            }
        }

        let mut out = Vec::new();
        if fit_scale {
            let mut values = vec![0.0; 3];
            let mut se = vec![f64::NAN; 3];
            for w in 0..3 {
                values[w] = if result[w].valid {
                    result[w].theta[0]
                } else {
                    base.scale[w]
                };
                se[w] = if result[w].valid {
                    result[w].stderr[0]
                } else {
                    f64::NAN
                };
            }
            out.push(FittedCause::estimated(Cause::WheelTorqueScale, values, se));
        }
        if fit_friction {
            let nominal = Cause::WheelFriction.values(&self.base);
            let mut values = nominal.clone();
            let mut se = vec![f64::NAN; 15];
            let mut notes = Vec::new();
            let mut free = 0;
            for w in 0..3 {
                let r = &result[w];
                if !r.valid {
                    notes.push(format!(
                        "wheel {}: no usable data, nominal kept",
                        "XYZ".as_bytes()[w] as char
                    ));
                    continue;
                }
                // theta: [scale, c_pos, c_neg, t_s, k]
                let (cp, cn, ts, k) = (r.theta[1], r.theta[2], r.theta[3], r.theta[4]);
                values[w] = cp;
                values[3 + w] = cn;
                values[6 + w] = k;
                se[w] = r.stderr[1];
                se[3 + w] = r.stderr[2];
                se[6 + w] = r.stderr[4];
                match r.ns {
                    Some((ns, ns_se)) => {
                        values[9 + w] = ts;
                        values[12 + w] = ns;
                        se[9 + w] = r.stderr[3];
                        se[12 + w] = ns_se;
                        notes.push(format!(
                            "wheel {}: asymmetric with Stribeck term",
                            "XYZ".as_bytes()[w] as char
                        ));
                    }
                    None => {
                        // No Stribeck term: breakaway at the larger Coulomb level, the Stribeck
                        // speed so small the term vanishes for any speed the data resolve.
                        values[9 + w] = cp.max(cn);
                        values[12 + w] = 1e-3;
                        notes.push(format!(
                            "wheel {}: asymmetric, no Stribeck term",
                            "XYZ".as_bytes()[w] as char
                        ));
                    }
                }
                free += r.free.saturating_sub(usize::from(fit_scale)) + usize::from(r.ns.is_some());
            }
            out.push(FittedCause {
                cause: Cause::WheelFriction,
                values,
                stderr: se,
                free,
                note: notes.join("; "),
            });
        }
        if fit_delay {
            out.push(FittedCause::estimated(
                Cause::ActuatorDelay,
                vec![delay],
                vec![delay_se],
            ));
        }
        Ok(out)
    }
}

/// A wheel channel's rows as a fit sees them (those not held out), for the least squares of
/// each wheel: shared by threads, so the 1-D searches spread over the cores.
#[derive(Clone, Copy)]
pub(crate) struct WheelRows<'a> {
    pub data: &'a Aligned,
    pub held_out: &'a [bool],
    pub channel: &'a WheelChannel,
}

impl Problem<'_> {
    /// The rows of the wheel channel `channel` this problem fits.
    pub(crate) fn wheel_rows<'s>(&'s self, channel: &'s WheelChannel) -> WheelRows<'s> {
        WheelRows {
            data: self.data,
            held_out: &self.held_out,
            channel,
        }
    }
}

impl WheelRows<'_> {
    /// The commanded torque of wheel `w` integrated over each of its rows not held out, the
    /// commands acting `delay` s late (the drive column of [`WheelRows::normal_equations`]).
    pub(crate) fn drive_integrals(&self, w: usize, delay: f64) -> Vec<f64> {
        let ch = self.channel;
        ch.rows[w]
            .iter()
            .filter(|r| !self.held_out[r.k])
            .map(|row| {
                self.data
                    .wheel_cmd_integral(row.t0, row.t1, delay, ch.max_torque_nm)[w]
            })
            .collect()
    }

    /// Least squares of one wheel with the chosen unknowns, its commands' integrals `drive`
    /// ([`WheelRows::drive_integrals`]). The unknown vector is always reported as
    /// `[scale, coulomb_pos, coulomb_neg, stribeck, viscous]`, with the base values where not
    /// fitted.
    fn solve(
        &self,
        base: &WheelModel,
        w: usize,
        drive: &[f64],
        fit_scale: bool,
        fit_friction: bool,
        ns: Option<f64>,
    ) -> Option<WheelSolve> {
        let (ne, n) = self.normal_equations(base, w, drive, fit_scale, fit_friction, ns);
        let base_friction = &base.friction[w];
        if n < 10 {
            return None;
        }
        // Undetermined columns (no data in that direction, no Stribeck term, not fitted) are
        // held at their base values.
        let base_theta = [
            base.scale[w],
            base_friction.coulomb_pos_nm,
            base_friction.coulomb_neg_nm,
            base_friction.breakaway_nm,
            base_friction.viscous_nm_per_rad_s,
        ];
        let mut fixed: Vec<(usize, f64)> = Vec::new();
        for j in 0..5 {
            let used = match j {
                0 => fit_scale,
                3 => fit_friction && ns.is_some(),
                _ => fit_friction,
            };
            if !used {
                fixed.push((j, 0.0));
            } else if !ne_diag_positive(&ne, j) || column_negligible(&ne, j) {
                fixed.push((j, base_theta[j]));
            }
        }
        // Active set for the bounds (friction ≥ 0, scale > 0).
        let (theta, stderr) = loop {
            let (theta, stderr) = solve_fixed(&ne, &fixed)?;
            let worst = (0..5)
                .filter(|j| !fixed.iter().any(|(f, _)| f == j))
                .filter(|&j| theta[j] < 0.0)
                .min_by(|a, b| theta[*a].total_cmp(&theta[*b]));
            match worst {
                Some(j) => fixed.push((j, 0.0)),
                None => break (theta, stderr),
            }
        };
        let rss = ne.rss_at(&DVector::from_column_slice(&theta));
        let mut full = theta;
        let mut se = stderr;
        for j in 0..5 {
            let fit_j = match j {
                0 => fit_scale,
                3 => fit_friction && ns.is_some(),
                _ => fit_friction,
            };
            if !fit_j {
                full[j] = base_theta[j];
                se[j] = f64::NAN;
            }
        }
        let free = se.iter().filter(|s| s.is_finite()).count();
        let theta: [f64; 5] = std::array::from_fn(|j| full[j]);
        let stderr: [f64; 5] = std::array::from_fn(|j| se[j]);
        Some(WheelSolve {
            valid: true,
            theta,
            stderr,
            rss,
            free,
            ns: None,
        })
    }

    /// Normal equations of wheel `w`'s least squares with its commands' integrals `drive`
    /// ([`WheelRows::drive_integrals`]; unknowns `[scale, coulomb_pos, coulomb_neg, stribeck,
    /// viscous]`, a column zero where not fitted) on the intervals not held out, rows whitened by
    /// the channel's σ: `XᵀX` is the Fisher information of those unknowns for noise as modelled.
    /// Also the number of rows.
    pub(crate) fn normal_equations(
        &self,
        base: &WheelModel,
        w: usize,
        drive: &[f64],
        fit_scale: bool,
        fit_friction: bool,
        ns: Option<f64>,
    ) -> (NormalEquations, usize) {
        let ch = self.channel;
        let rows = &ch.rows[w];
        // Unknown layout: [s, c_pos, c_neg, t_s, k]; the Stribeck column only with `ns`.
        let mut ne = NormalEquations::new(5);
        let mut x = [0.0; 5];
        let mut n = 0usize;
        let base_friction = &base.friction[w];
        for (row, &tau) in rows.iter().filter(|r| !self.held_out[r.k]).zip(drive) {
            let mut y = row.ja;
            if fit_scale {
                x[0] = tau;
            } else {
                x[0] = 0.0;
                y -= base.scale[w] * tau;
            }
            if fit_friction {
                let r = friction_regressors(row, ns);
                x[1] = -r[0];
                x[2] = -r[1];
                x[3] = if ns.is_some() { -r[2] } else { 0.0 };
                x[4] = -r[3];
            } else {
                x[1..].fill(0.0);
                y += friction_integral(base_friction, row);
            }
            let s = ch.sigma;
            ne.add(&x.map(|v| v / s), y / s);
            n += 1;
        }
        (ne, n)
    }
}

/// Result of one wheel's least squares.
#[derive(Debug, Clone, Default)]
struct WheelSolve {
    valid: bool,
    /// `[scale, coulomb_pos, coulomb_neg, stribeck, viscous]`.
    theta: [f64; 5],
    stderr: [f64; 5],
    rss: f64,
    free: usize,
    /// Stribeck speed and its standard error, when the Stribeck model was chosen.
    ns: Option<(f64, f64)>,
}

/// The wheels' drive and friction as a configuration has them, with its fitted wheel torque
/// (`[effects.fitted_wheel_torque]`, the terms an earlier identification carried).
#[derive(Debug, Clone)]
pub struct WheelModel {
    pub scale: [f64; 3],
    pub friction: [WheelFrictionModel; 3],
    pub delay_s: f64,
    pub fitted: FittedWheelTorqueModel,
}

impl WheelModel {
    pub fn from_config(config: &ModelConfig) -> Self {
        Self {
            scale: config
                .effects
                .wheel_torque_scale
                .as_ref()
                .map_or([1.0; 3], |s| s.scale),
            friction: Wheel::ALL.map(|w| WheelFrictionModel::from_config(config, w)),
            delay_s: config
                .effects
                .actuator_delay
                .as_ref()
                .map_or(0.0, |d| d.delay_s),
            fitted: FittedWheelTorqueModel::from_config(
                config.effects.fitted_wheel_torque.as_ref(),
            ),
        }
    }

    /// `∫ T_fitted dt` over `row` for wheel `w`, Nms: the fitted wheel torque with the speed
    /// linear over the interval, the platform's state at its mean, the delivered motor torque
    /// at its mean (`tau_integral`: the clamped command's integral, Nm s) and the terms' time
    /// from the record's start `record_start_s` (4-point Gauss–Legendre: exact for the
    /// polynomial terms up to degree 7).
    fn fitted_integral(
        &self,
        record_start_s: f64,
        w: usize,
        row: &WheelInterval,
        tau_integral: f64,
    ) -> f64 {
        if !self.fitted.is_active() {
            return 0.0;
        }
        let dt = row.t1 - row.t0;
        if dt <= 0.0 {
            return 0.0;
        }
        let direction = row.n0.signum();
        let tau = self.scale[w] * tau_integral / dt;
        GL4.iter()
            .map(|(s, weight)| {
                let mut model = self.fitted;
                model.set_time(row.t0 + s * dt - record_start_s);
                let n = row.n0 + s * (row.n1 - row.n0);
                weight * model.torque(w, n, direction, tau, &row.platform)
            })
            .sum::<f64>()
            * dt
    }

    /// Wheel-channel residual of a row, Nms: what the drive, the friction and the fitted
    /// wheel torque leave of the measured change of the wheel's momentum.
    pub fn residual(
        &self,
        data: &Aligned,
        ch: &WheelChannel,
        w: usize,
        row: &WheelInterval,
    ) -> f64 {
        let tau = data.wheel_cmd_integral(row.t0, row.t1, self.delay_s, ch.max_torque_nm)[w];
        let record_start_s = data.t.first().copied().unwrap_or(0.0);
        row.ja - self.scale[w] * tau + friction_integral(&self.friction[w], row)
            - self.fitted_integral(record_start_s, w, row, tau)
    }
}

/// Extra residual reduction the Stribeck term must bring (two more parameters): the larger of
/// the information criterion's `2 ln n` and the χ²₂ quantile at `1 − alpha`.
fn stribeck_threshold(n: usize, alpha: f64) -> f64 {
    let bic = 2.0 * (n.max(2) as f64).ln();
    bic.max(chi_square_quantile(1.0 - alpha, 2.0).unwrap_or(27.6))
}

fn ne_diag_positive(ne: &NormalEquations, j: usize) -> bool {
    let d = ne.diag(j);
    d.is_finite() && d > 0.0
}

/// A column whose weight is below 1e-12 of the largest is not determined by the data.
fn column_negligible(ne: &NormalEquations, j: usize) -> bool {
    let max = (0..ne.params()).map(|i| ne.diag(i)).fold(0.0, f64::max);
    ne.diag(j) <= 1e-12 * max
}

/// Minimise `f` on `[lo, hi]`: a grid of `points`, then golden-section refinement between the
/// best point's neighbours. Returns the minimiser and its standard error from the curvature,
/// `sqrt(2 s² / f'')` with `s² = 1` (f is a whitened residual sum); NaN when the minimum is on a
/// bound or flat.
fn search_1d(f: impl Fn(f64) -> f64 + Sync, lo: f64, hi: f64, points: usize) -> (f64, f64) {
    let n = points.max(3);
    let xs: Vec<f64> = (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect();
    // The grid's points are independent: across the cores.
    let fs: Vec<f64> = xs.par_iter().map(|&x| f(x)).collect();
    let best = (0..n).min_by(|a, b| fs[*a].total_cmp(&fs[*b])).unwrap_or(0);
    let (mut a, mut b) = (xs[best.saturating_sub(1)], xs[(best + 1).min(n - 1)]);
    let g = 0.618_033_988_749_895;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..20 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    let x = 0.5 * (a + b);
    // Curvature from a symmetric difference around the minimum.
    let h = (hi - lo) / (n - 1) as f64 * 0.25;
    let (fm, f0, fp) = (f(x - h), f(x), f(x + h));
    let curvature = (fp - 2.0 * f0 + fm) / (h * h);
    let at_bound = x - lo < 0.5 * h || hi - x < 0.5 * h;
    let se = if curvature > 0.0 && !at_bound {
        (2.0 / curvature).sqrt()
    } else {
        f64::NAN
    };
    (x, se)
}
