//! The skeleton every baseline shares: [`EstimatingFollower`] runs a [`CarFollowingLaw`] under the
//! FLC's sensing.
//!
//! Per LiDAR frame ([`EstimatingFollower::step`]):
//!
//! 1. input checks (own speed, `dt`, distance, in this order; see the [module docs](super)): a
//!    fault gives the safe command `own_speed - fault_brake_step` and resets everything;
//! 2. no lead: [`NoLeadPolicy::Brake`] gives the safe command with [`Status::NoLead`],
//!    [`NoLeadPolicy::Cruise`] resets the estimator and runs the law's free-road branch
//!    ([`CarFollowingLaw::free_road`]);
//! 3. a lead: the range-rate estimator ([`super::estimator`]) gives
//!    `lead speed = clamp(own speed + range rate, 0, max_speed)` and the law's following branch
//!    ([`CarFollowingLaw::follow`]) runs on the measured gap and that estimate;
//! 4. the law's [`Demand`] becomes the common [`LongitudinalCommand`]: an acceleration `a` gives
//!    `speed = clamp(v + command_gain a, 0, max_speed)`; a target speed `v*` gives
//!    `speed = clamp(v*, 0, max_speed)` and `accel = (speed - v) / command_gain`. A non-finite
//!    result gives the safe command with [`Status::InvalidDistance`].
//!
//! A law is its equations only: its parameters (with the six shared fields of
//! [`FollowerSettings`] kept flat, so that the scenario files' `[idm]`, `[acc]`, ... sections keep
//! their keys), its terms, and an `impl CarFollowingLaw`. The controller is then
//! `pub type XController = EstimatingFollower<X>`, and [`LongitudinalController`] comes with it.

use super::estimator::{EstimatorParams, RangeRateEstimator};
use super::{Frame as Checked, NoLeadPolicy, accel_command, check_frame, lead_speed};
use crate::command::{LongitudinalCommand, Status, clamp, safe_brake, valid_speed};
use crate::longitudinal::ActiveController;
use crate::longitudinal::{ControlOutput, Frame, LongitudinalController, Terms};
use crate::params::{ParamError, check_positive, check_range};

/// The parameters every estimating follower has (flat fields of each law's parameter struct,
/// collected by [`FollowerParams::settings`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FollowerSettings {
    /// What to do without a lead.
    pub no_lead: NoLeadPolicy,
    /// The range-rate filter.
    pub estimator: EstimatorParams,
    /// `v_cmd = v + command_gain * a` (or `a = (v_cmd - v) / command_gain` for target-speed laws), s.
    pub command_gain: f64,
    /// Highest plausible own speed and highest speed command, m/s.
    pub max_speed: f64,
    /// Highest plausible distance, m.
    pub max_distance: f64,
    /// Safe command on invalid input: `v_cmd = v - fault_brake_step`, m/s.
    pub fault_brake_step: f64,
}

impl FollowerSettings {
    /// Checks the shared fields (after the law's own, so the first offending field is named).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.estimator.validate_named(["estimator.alpha", "estimator.beta", "estimator.max_range_rate"])?;
        check_positive("command_gain", self.command_gain, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("max_speed", self.max_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_positive("max_distance", self.max_distance, 1.0e6, "must be finite and in (0, 1e6] m")?;
        check_range("fault_brake_step", self.fault_brake_step, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        Ok(())
    }
}

/// A law's parameter struct: gives the shared fields (implement with `follower_params!`).
pub trait FollowerParams: Copy + core::fmt::Debug + PartialEq {
    /// The shared fields.
    fn settings(&self) -> FollowerSettings;
}

/// Implements [`FollowerParams`] for a parameter struct with the six flat shared fields, and its
/// inherent `validate()` (the law's fields, then the shared ones).
macro_rules! follower_params {
    ($params:ty, $law:ty) => {
        impl $params {
            /// Checks every field (the law's, then the shared follower fields); the error names the
            /// first offending one.
            pub fn validate(&self) -> Result<(), crate::params::ParamError> {
                <$law as crate::baselines::CarFollowingLaw>::validate(self)?;
                crate::baselines::FollowerParams::settings(self).validate()
            }
        }

        impl crate::baselines::FollowerParams for $params {
            fn settings(&self) -> crate::baselines::FollowerSettings {
                crate::baselines::FollowerSettings {
                    no_lead: self.no_lead,
                    estimator: self.estimator,
                    command_gain: self.command_gain,
                    max_speed: self.max_speed,
                    max_distance: self.max_distance,
                    fault_brake_step: self.fault_brake_step,
                }
            }
        }
    };
}
pub(crate) use follower_params;

/// What the follower knows about the lead on a frame with a detection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeadEstimate {
    /// Measured bumper gap (the detector's distance itself), m.
    pub gap: f64,
    /// Estimated range rate, m/s (negative while closing).
    pub range_rate: f64,
    /// Estimated lead speed `clamp(v + range rate, 0, max_speed)`, m/s.
    pub lead_speed: f64,
}

/// What a law asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Demand {
    /// An acceleration, m/s²: `speed = clamp(v + command_gain a, 0, max_speed)`.
    Accel(f64),
    /// A target speed, m/s: `speed = clamp(target, 0, max_speed)`, `accel = (speed - v) / command_gain`.
    Speed(f64),
}

/// A car-following law's equations: all an [`EstimatingFollower`] needs. The value of the type is
/// the law's own state (e.g. the ACC's control mode), `Default` being the state after a reset.
pub trait CarFollowingLaw: Default + Clone + core::fmt::Debug {
    /// The parameters (with the flat shared fields).
    type Params: FollowerParams;
    /// The terms of one step (`Default`: after a fault).
    type Terms: Copy + core::fmt::Debug + PartialEq + Default;

    /// Checks the law's own fields (the shared ones are checked after them).
    fn validate(params: &Self::Params) -> Result<(), ParamError>;

    /// The following branch: a lead at `lead.gap` with the estimated `lead.lead_speed`.
    fn follow(&mut self, params: &Self::Params, lead: &LeadEstimate, own_speed: f64) -> (Demand, Self::Terms);

    /// The free-road branch (no lead, [`NoLeadPolicy::Cruise`]).
    fn free_road(&mut self, params: &Self::Params, own_speed: f64) -> (Demand, Self::Terms);

    /// The law's gap at equal speeds `v >= 0`, m.
    fn desired_gap(params: &Self::Params, v: f64) -> f64;

    /// The terms as a named list.
    fn terms(terms: &Self::Terms) -> Terms;
}

/// A [`CarFollowingLaw`] under the FLC's sensing: input checks, no-lead policy, range-rate
/// estimator, command mapping (module docs).
#[derive(Debug, Clone)]
pub struct EstimatingFollower<L: CarFollowingLaw> {
    params: L::Params,
    law: L,
    estimator: RangeRateEstimator,
    terms: L::Terms,
}

impl<L: CarFollowingLaw> EstimatingFollower<L> {
    /// Validates `params` (the law's fields, then the shared ones) and builds the controller.
    pub fn new(params: L::Params) -> Result<Self, ParamError> {
        L::validate(&params)?;
        let s = params.settings();
        s.validate()?;
        Ok(Self { params, law: L::default(), estimator: RangeRateEstimator::new_unchecked(s.estimator), terms: L::Terms::default() })
    }

    /// The parameters in use.
    pub fn params(&self) -> &L::Params {
        &self.params
    }

    /// The terms of the last step (all zero after a fault).
    pub fn terms(&self) -> &L::Terms {
        &self.terms
    }

    /// The law's state.
    pub fn law(&self) -> &L {
        &self.law
    }

    /// Forgets the range-rate track and the law's state.
    pub fn reset(&mut self) {
        self.estimator.reset();
        self.law = L::default();
        self.terms = L::Terms::default();
    }

    /// One LiDAR frame: `distance` = bumper gap in m (`None` = no lead), `own_speed` in m/s, `dt`
    /// = time since the previous frame in s.
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64, dt: f64) -> LongitudinalCommand {
        self.step_measured(distance, own_speed, dt, None)
    }

    /// [`Self::step`] with the lead's speed measured directly (`Some`: ideal perception, see
    /// [`Frame::lead_speed`]): the law gets it instead of the estimate, with the range rate
    /// `lead speed minus own speed`; the estimator keeps tracking the distance. A measured lead
    /// speed that is NaN, infinite or outside `[0, max_speed]` gives the safe command with
    /// [`Status::InvalidLeadSpeed`].
    pub fn step_measured(
        &mut self,
        distance: Option<f64>,
        own_speed: f64,
        dt: f64,
        lead_speed_measured: Option<f64>,
    ) -> LongitudinalCommand {
        let p = self.params;
        let s = p.settings();
        let gap = match check_frame(distance, own_speed, dt, s.max_speed, s.max_distance) {
            Ok(Checked::Lead(gap)) => Some(gap),
            Ok(Checked::NoLead) if s.no_lead == NoLeadPolicy::Cruise => None,
            Ok(Checked::NoLead) => return self.fault(own_speed, Status::NoLead),
            Err(status) => return self.fault(own_speed, status),
        };
        let (demand, terms) = match gap {
            Some(gap) => {
                let estimated = self.estimator.update(gap, dt).range_rate;
                let lead = match lead_speed_measured {
                    None => LeadEstimate { gap, range_rate: estimated, lead_speed: lead_speed(own_speed, estimated, s.max_speed) },
                    Some(v) if v.is_finite() && (0.0..=s.max_speed).contains(&v) => {
                        LeadEstimate { gap, range_rate: v - own_speed, lead_speed: v }
                    }
                    Some(_) => return self.fault(own_speed, Status::InvalidLeadSpeed),
                };
                self.law.follow(&p, &lead, own_speed)
            }
            None => {
                self.estimator.reset();
                self.law.free_road(&p, own_speed)
            }
        };
        self.terms = terms;
        match demand {
            Demand::Accel(accel) => accel_command(own_speed, accel, s.command_gain, s.max_speed)
                .unwrap_or_else(|| self.fault(own_speed, Status::InvalidDistance)),
            Demand::Speed(target) => {
                let speed = clamp(target, 0.0, s.max_speed);
                let accel = (speed - own_speed) / s.command_gain;
                if !(speed.is_finite() && accel.is_finite()) {
                    return self.fault(own_speed, Status::InvalidDistance);
                }
                LongitudinalCommand { speed, accel, status: Status::Ok }
            }
        }
    }

    fn fault(&mut self, own_speed: f64, status: Status) -> LongitudinalCommand {
        self.reset();
        let s = self.params.settings();
        safe_brake(own_speed, valid_speed(own_speed, s.max_speed), s.fault_brake_step, status)
    }
}

/// Every estimating follower through the common interface: `step(distance, own_speed, dt)`;
/// `desired_gap(v)` is the law's gap at equal speeds `max(v, 0)`.
impl<L: CarFollowingLaw> LongitudinalController for EstimatingFollower<L> {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = EstimatingFollower::step_measured(self, frame.distance, frame.own_speed, frame.dt, frame.lead_speed);
        ControlOutput::single(command, L::terms(&self.terms), ActiveController::Flc)
    }

    fn reset(&mut self) {
        EstimatingFollower::reset(self);
    }

    fn desired_gap(&self, v: f64) -> f64 {
        L::desired_gap(&self.params, v.max(0.0))
    }

    fn uses_dt(&self) -> bool {
        true
    }
}
