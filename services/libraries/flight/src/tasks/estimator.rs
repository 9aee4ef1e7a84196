//! The estimator task: the attitude filter chosen by name (`estimator.filter`,
//! [`crate::estimators`]; the paper's MEKF by default) fed by gyro, inclinometer and
//! magnetometer samples, one estimate per tick. Gyro samples are body rates (rad/s, bias included), vector samples
//! inclinometer angles (rad) and the magnetometer field (T, body axes), times in nanoseconds;
//! the estimate is the attitude level frame to body frame.
//!
//! Samples are grouped by their time stamp. A tick is processed when its gyro sample is in and
//! every vector sample the schedule expects at that tick has arrived — or, if one never comes,
//! as soon as a later tick's gyro sample shows that the tick is over (the missing update is
//! skipped and counted). Within a tick the order is fixed: propagate, then update, so the result
//! does not depend on the order in which samples arrived.
//!
//! A gyro sample without `VALID` (a CAN gateway publishes one, flagged `STALE`, when the tick's
//! frames did not all arrive by the CAN board's tick sync) still answers its tick: the filter
//! propagates with the last valid rate (zero before the first), counted in
//! [`EstimatorCounters::gyro_held`]. Invalid vector samples skip their update.
//!
//! Start-up: the filter is initialised (the MEKF by TRIAD) from the first tick that has both a
//! tilt and a field measurement, and until then the task only remembers the gyro.
//!
//! The pipeline's estimator process feeds samples ([`EstimatorTask::on_gyro`], …,
//! [`EstimatorTask::ready_into`]); the in-process closed loop, which makes its ticks itself,
//! calls [`EstimatorTask::propagate`] and [`EstimatorTask::update`] directly. Both run the same
//! start-up and filter.

use crate::convert::{Sequence, a3, quaternion_to_array, v3};
use crate::estimators::{AttitudeFilter, FilterEstimate, FilterSetup};
use crate::mekf::{MekfError, UpdateReport, VectorMeasurements};
use crate::schedule::Schedule;
use ipc_types::{
    AttitudeEstimate, GyroSample, InclinometerSample, MagnetometerSample, SampleHeader,
};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use testbed_model::attitude;

#[derive(Debug, Default, Clone, Copy)]
struct Pending {
    /// `Some(None)`: the sample arrived but is invalid (as for the vectors).
    gyro: Option<Option<[f64; 3]>>,
    /// `Some(None)`: the sample arrived but is invalid.
    tilt: Option<Option<[f64; 2]>>,
    field: Option<Option<[f64; 3]>>,
}

/// Counters beyond the filter's own.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct EstimatorCounters {
    /// Samples whose time is not on a tick of the schedule, or older than the last processed tick.
    pub samples_refused: u64,
    /// Expected vector samples that never arrived.
    pub vectors_missing: u64,
    /// Filter errors (out-of-order or non-finite samples).
    pub filter_errors: u64,
    /// Ticks whose gyro sample was invalid: propagated with the last valid rate instead.
    pub gyro_held: u64,
}

/// The estimator: tick assembly, start-up and the filter.
#[derive(Debug)]
pub struct EstimatorTask {
    setup: FilterSetup,
    /// The filter, once initialised.
    filter: Option<Box<dyn AttitudeFilter>>,
    /// The latest gyro rate given: time (ns) and rate (rad/s). The filter initialised at that
    /// time propagates it.
    last_gyro: Option<(u64, Vector3<f64>)>,
    schedule: Schedule,
    pending: BTreeMap<u64, Pending>,
    last_processed: Option<u64>,
    /// The rate of the latest valid gyro sample processed.
    last_valid_rate: Option<[f64; 3]>,
    counters: EstimatorCounters,
    seq: Sequence,
}

impl EstimatorTask {
    /// The task of the filter `setup` names (see
    /// [`crate::estimators::EstimatorConfig::setup`]) on `schedule`.
    pub fn new(setup: FilterSetup, schedule: Schedule) -> Self {
        Self {
            setup,
            filter: None,
            last_gyro: None,
            schedule,
            pending: BTreeMap::new(),
            last_processed: None,
            last_valid_rate: None,
            counters: EstimatorCounters::default(),
            seq: Sequence::default(),
        }
    }

    pub fn counters(&self) -> EstimatorCounters {
        self.counters
    }

    /// Propagates with a gyro sample (body rate, rad/s, bias included) valid at `t_ns`; before
    /// initialisation the rate is only remembered.
    pub fn propagate(&mut self, t_ns: u64, rate_rad_s: &Vector3<f64>) -> Result<(), MekfError> {
        self.last_gyro = Some((t_ns, *rate_rad_s));
        match &mut self.filter {
            Some(filter) => filter.propagate(t_ns, rate_rad_s),
            None => Ok(()),
        }
    }

    /// Updates from vector samples valid at `t_ns`, or initialises the filter from them.
    /// Returns the update's report once the filter runs, `None` while it still waits for a
    /// complete pair to initialise from.
    pub fn update(
        &mut self,
        t_ns: u64,
        measurements: &VectorMeasurements,
    ) -> Result<Option<UpdateReport>, MekfError> {
        if let Some(filter) = &mut self.filter {
            return filter.update(t_ns, measurements).map(Some);
        }
        let (Some(tilt), Some(field)) = (measurements.tilt_rad, measurements.field_b_t) else {
            return Ok(None);
        };
        let Some(gravity) = attitude::gravity_from_tilt(tilt[0], tilt[1]) else {
            return Ok(None);
        };
        let mut filter = self.setup.initialise(t_ns, &gravity, &field)?;
        if let Some((t_gyro, rate)) = self.last_gyro.filter(|(t, _)| *t == t_ns) {
            filter.propagate(t_gyro, &rate)?;
        }
        self.filter = Some(filter);
        Ok(None)
    }

    /// The current estimate, once initialised.
    pub fn estimate(&self) -> Option<FilterEstimate> {
        self.filter.as_ref().map(|f| f.estimate())
    }

    /// The filter, once initialised.
    pub fn filter(&self) -> Option<&dyn AttitudeFilter> {
        self.filter.as_deref()
    }

    fn slot(&mut self, t_ns: u64) -> Option<&mut Pending> {
        let on_tick = self.schedule.tick_at(t_ns).is_some();
        let fresh = self.last_processed.is_none_or(|last| t_ns > last);
        if on_tick && fresh {
            Some(self.pending.entry(t_ns).or_default())
        } else {
            self.counters.samples_refused += 1;
            None
        }
    }

    pub fn on_gyro(&mut self, s: &GyroSample) {
        let valid = s.header.is_valid();
        if let Some(p) = self.slot(s.header.time_ns) {
            p.gyro = Some(valid.then_some(s.rate));
        }
    }

    pub fn on_inclinometer(&mut self, s: &InclinometerSample) {
        let valid = s.header.is_valid();
        if let Some(p) = self.slot(s.header.time_ns) {
            p.tilt = Some(valid.then_some(s.tilt));
        }
    }

    pub fn on_magnetometer(&mut self, s: &MagnetometerSample) {
        let valid = s.header.is_valid();
        if let Some(p) = self.slot(s.header.time_ns) {
            p.field = Some(valid.then_some(s.field));
        }
    }

    fn complete(&self, t_ns: u64, p: &Pending) -> bool {
        let Some(k) = self.schedule.tick_at(t_ns) else {
            return false;
        };
        p.gyro.is_some()
            && (!self.schedule.tilt_due(k) || p.tilt.is_some())
            && (!self.schedule.field_due(k) || p.field.is_some())
    }

    /// How many sensor samples must still arrive before the next estimate can be made: those
    /// the oldest unprocessed tick lacks (its gyro sample, and its inclinometer and
    /// magnetometer samples if they are due on it), at least 1. A process sleeps through
    /// fewer samples' wake-ups (the runtime's `Node::samples_awaited`): on a tick with
    /// vector samples due, one wake-up instead of one per sensor. A sample that never comes is
    /// made up for by the next tick's gyro sample, which overtakes the tick as before. 1
    /// before the first estimate (the first tick is not known yet).
    pub fn samples_awaited(&self) -> u32 {
        let next = match self.pending.first_key_value() {
            Some((&t_ns, pending)) => self.schedule.tick_at(t_ns).map(|k| (k, *pending)),
            None => self
                .last_processed
                .and_then(|t_ns| self.schedule.tick_at(t_ns))
                .map(|k| (k + 1, Pending::default())),
        };
        let Some((k, p)) = next else {
            return 1;
        };
        let missing = u32::from(p.gyro.is_none())
            + u32::from(self.schedule.tilt_due(k) && p.tilt.is_none())
            + u32::from(self.schedule.field_due(k) && p.field.is_none());
        missing.max(1)
    }

    /// Process every tick that is complete or overtaken, oldest first; one estimate each.
    pub fn ready(&mut self) -> Vec<AttitudeEstimate> {
        let mut out = Vec::new();
        self.ready_into(&mut out);
        out
    }

    /// [`Self::ready`] appending to `out`, which is not cleared: a process keeps one buffer for
    /// the run, so that a tick allocates nothing.
    pub fn ready_into(&mut self, out: &mut Vec<AttitudeEstimate>) {
        let newest_gyro = self
            .pending
            .iter()
            .rev()
            .find(|(_, p)| p.gyro.is_some())
            .map(|(t, _)| *t);
        while let Some((&t_ns, pending)) = self.pending.first_key_value() {
            let overtaken = newest_gyro.is_some_and(|newest| newest > t_ns);
            if !(self.complete(t_ns, pending) || overtaken) {
                break;
            }
            let pending = *pending;
            self.pending.remove(&t_ns);
            self.last_processed = Some(t_ns);
            if let Some(estimate) = self.process(t_ns, &pending) {
                out.push(estimate);
            }
        }
    }

    fn process(&mut self, t_ns: u64, p: &Pending) -> Option<AttitudeEstimate> {
        let k = self.schedule.tick_at(t_ns)?;
        let Some(reading) = p.gyro else {
            // Vector samples of a tick whose gyro sample was lost: nothing to propagate with.
            self.counters.samples_refused += 1;
            return None;
        };
        let rate = match reading {
            Some(rate) => {
                self.last_valid_rate = Some(rate);
                rate
            }
            None => {
                self.counters.gyro_held += 1;
                self.last_valid_rate.unwrap_or([0.0; 3])
            }
        };
        if self.propagate(t_ns, &v3(&rate)).is_err() {
            self.counters.filter_errors += 1;
        }
        let missing = u64::from(self.schedule.tilt_due(k) && p.tilt.is_none())
            + u64::from(self.schedule.field_due(k) && p.field.is_none());
        self.counters.vectors_missing += missing;
        let vectors = VectorMeasurements {
            tilt_rad: p.tilt.flatten(),
            field_b_t: p.field.flatten().map(|f| v3(&f)),
        };
        if (vectors.tilt_rad.is_some() || vectors.field_b_t.is_some())
            && self.update(t_ns, &vectors).is_err()
        {
            self.counters.filter_errors += 1;
        }
        Some(self.sample(t_ns))
    }

    fn sample(&mut self, t_ns: u64) -> AttitudeEstimate {
        let mut out = AttitudeEstimate::default();
        match self.estimate() {
            Some(e) => {
                out.header = self.seq.header(t_ns, SampleHeader::VALID);
                out.quaternion = quaternion_to_array(&e.attitude);
                out.rate = a3(&e.rate_rad_s);
                out.gyro_bias = a3(&e.bias_rad_s);
                for (i, x) in e.covariance.transpose().iter().enumerate() {
                    // nalgebra iterates column-major; the transpose gives row-major order.
                    out.covariance[i] = *x;
                }
                if let Some(update) = &e.last_update {
                    let (innovation, mask) = update.normalised_array();
                    out.innovation = innovation;
                    out.innovation_mask = mask;
                    out.innovation_time_ns = update.t_ns;
                }
                out.updates_applied = e.counters.updates_applied;
                out.updates_skipped = e.counters.updates_skipped;
                out.updates_rejected = e.counters.updates_rejected;
            }
            None => {
                // Not initialised yet: still answer the tick so the controller can hold.
                out.header = self.seq.header(t_ns, 0);
                out.quaternion = ipc_types::IDENTITY_QUATERNION;
                out.rate = a3(&Vector3::zeros());
            }
        }
        out
    }
}
