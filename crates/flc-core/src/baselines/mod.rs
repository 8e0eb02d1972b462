//! Baseline longitudinal controllers under identical sensing (issue 6).
//!
//! Four published car-following / cruise laws, each fed exactly what the FLC gets — the LiDAR
//! bumper-to-bumper distance (`None` when the detector found no lead) and the own speed, once per
//! LiDAR frame — plus the time since the previous frame, `dt`. Where a law needs the lead's speed
//! it *estimates* it from the distance signal with the alpha-beta filter of [`estimator`], as a
//! real fallback without V2V would: `lead speed = own speed + range rate`.
//!
//! | module | controller | source |
//! |---|---|---|
//! | [`idm`] | [`IdmController`] | Treiber, Hennecke & Helbing, *Phys. Rev. E* 62, 1805 (2000) |
//! | [`acc`] | [`AccController`] | Milanés & Shladover, *Transp. Res. C* 48 (2014), as implemented in SUMO's `MSCFModel_ACC` |
//! | [`rss`] | [`RssController`] | Shalev-Shwartz, Shammah & Shashua, arXiv:1708.06374 (2017), Def. 1; cruise structure of Autoware's `obstacle_cruise_planner` |
//! | [`carla_behavior`] | [`CarlaBehaviorController`] | CARLA `PythonAPI/carla/agents/navigation/behavior_agent.py` (`car_following_manager`, `emergency_stop`), `behavior_types.py` (`Normal`) |
//! | [`gipps`] | [`GippsController`] | Gipps, *Transp. Res. B* 15(2), 105 (1981), Eq. (5); SUMO-compatible defaults (not in [`Baseline`] / [`BaselineKind`]) |
//! | [`careful_driver`] | [`CarefulDriver`] | UN R157 (2021 original), Annex 3, Appendix 3: the careful and competent human driver (a reference, not a follower under identical sensing; not in [`Baseline`] / [`BaselineKind`]) |
//!
//! All four return the same [`LongitudinalCommand`] as the FLC and the PID, so the simulator can
//! swap them in: `speed = clamp(own_speed + command_gain * accel, 0, max_speed)` with
//! `command_gain = 1 s` by default (the FLC's "incorporated into the current speed"; for SUMO's
//! ACC it is exactly SUMO's `speed + ACCEL2SPEED(accel)` at SUMO's default 1 s step). The CARLA
//! follower produces a target speed directly; its `accel` is `(speed - own_speed) / command_gain`.
//!
//! Common rules (the same as [`crate::flc`] and [`crate::pid`]):
//! * own speed NaN / infinite / outside `[-1, max_speed]` → [`Status::InvalidSpeed`];
//!   `dt` NaN / infinite / `<= 0` / `> 10 s` → [`Status::InvalidDt`]; distance NaN / infinite /
//!   negative / beyond `max_distance` → [`Status::InvalidDistance`]. Each gives the safe command
//!   `own_speed - fault_brake_step` (0 if the speed itself is unusable) and resets the estimator.
//! * no lead (`None`): see [`NoLeadPolicy`]. The estimator is reset either way, so the first
//!   frames after a detection gap run on a fresh estimate.
//! * the gap the laws use is the measured distance itself (what the FLC sees); only the lead speed
//!   comes from the filter.
//!
//! Each baseline is its equations only, a [`CarFollowingLaw`] (e.g. [`Idm`]); the shared skeleton
//! (input checks, no-lead policy, range-rate estimator, command mapping) is [`EstimatingFollower`]
//! ([`follower`]), and the controllers are `pub type IdmController = EstimatingFollower<Idm>` etc.,
//! all implementing [`crate::LongitudinalController`]. A new law is one file: its parameters (with
//! the six shared fields of [`FollowerSettings`] kept flat, for the scenario files), its terms and
//! its `impl CarFollowingLaw`.
//!
//! [`Baseline`] wraps any of the four behind one `step` (no allocation), and [`BaselineKind`]
//! gives the names used by the scenario files (`"idm" | "acc" | "rss" | "carla-behavior"`).
//! Sources, equations, defaults and the choices made where a source is silent:
//! `docs/baselines.md`.

pub mod acc;
pub mod careful_driver;
pub mod carla_behavior;
pub mod estimator;
pub mod follower;
pub mod gipps;
pub mod idm;
pub mod rss;

pub use acc::{Acc, AccController, AccMode, AccParams, AccTerms};
pub use careful_driver::{CarefulDriver, CarefulDriverParams, CarefulDriverTerms, CarefulMode};
pub use carla_behavior::{CarlaBand, CarlaBehavior, CarlaBehaviorController, CarlaBehaviorParams, CarlaTerms};
pub use estimator::{EstimatorParams, RangeEstimate, RangeRateEstimator};
pub use follower::{CarFollowingLaw, Demand, EstimatingFollower, FollowerParams, FollowerSettings, LeadEstimate};
pub use gipps::{Gipps, GippsController, GippsParams, GippsTerms};
pub use idm::{Idm, IdmController, IdmParams, IdmTerms};
pub use rss::{Rss, RssController, RssParams, RssTerms};

use crate::command::{LongitudinalCommand, Status, clamp, valid_speed};
use crate::longitudinal::{ControlOutput, LongitudinalController};

/// `x^y`: the standard library's `f64::powf` with the `std` feature (bit for bit what a `std`
/// user computes), `libm::pow` without it.
#[cfg(feature = "std")]
pub(crate) fn powf(x: f64, y: f64) -> f64 {
    x.powf(y)
}

/// `x^y`: the standard library's `f64::powf` with the `std` feature (bit for bit what a `std`
/// user computes), `libm::pow` without it.
#[cfg(not(feature = "std"))]
pub(crate) fn powf(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// What a baseline does on a frame without a lead (`distance = None`).
///
/// The FLC and the PID brake (they are followers, not cruise controllers). The published laws
/// behind the baselines all have a free-road branch instead: IDM's `a [1 - (v/v0)^delta]`,
/// the ACC's speed-control mode, the RSS controller's cruise term and the CARLA agent's "normal
/// behaviour". Either way the range-rate estimator is reset.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum NoLeadPolicy {
    /// Apply the law's free-road branch (drive towards the desired speed); status [`Status::Ok`].
    /// Default: what each source does when nothing is ahead.
    #[default]
    Cruise,
    /// Issue the safe command `own_speed - fault_brake_step` with [`Status::NoLead`], exactly like
    /// the FLC and the PID.
    Brake,
}

/// The baseline controllers by name, as selected in scenario files.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "kebab-case"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BaselineKind {
    /// [`IdmController`], `"idm"`.
    Idm,
    /// [`AccController`], `"acc"`.
    Acc,
    /// [`RssController`], `"rss"`.
    Rss,
    /// [`CarlaBehaviorController`], `"carla-behavior"`.
    CarlaBehavior,
}

impl BaselineKind {
    /// All kinds, in the order of the docs.
    pub const ALL: [BaselineKind; 4] = [BaselineKind::Idm, BaselineKind::Acc, BaselineKind::Rss, BaselineKind::CarlaBehavior];

    /// The scenario-file name: `"idm"`, `"acc"`, `"rss"`, `"carla-behavior"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            BaselineKind::Idm => "idm",
            BaselineKind::Acc => "acc",
            BaselineKind::Rss => "rss",
            BaselineKind::CarlaBehavior => "carla-behavior",
        }
    }

    /// The kind for a scenario-file name (exact, lower case), `None` if unknown.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.as_str() == name)
    }
}

impl core::fmt::Display for BaselineKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Any baseline controller behind one interface (no allocation, usable from `no_std`).
#[derive(Debug, Clone)]
pub enum Baseline {
    /// Intelligent Driver Model.
    Idm(IdmController),
    /// Milanés & Shladover / SUMO ACC.
    Acc(AccController),
    /// RSS safe-distance controller.
    Rss(RssController),
    /// CARLA BehaviorAgent follower.
    CarlaBehavior(CarlaBehaviorController),
}

impl Baseline {
    /// Which controller this is.
    pub fn kind(&self) -> BaselineKind {
        match self {
            Baseline::Idm(_) => BaselineKind::Idm,
            Baseline::Acc(_) => BaselineKind::Acc,
            Baseline::Rss(_) => BaselineKind::Rss,
            Baseline::CarlaBehavior(_) => BaselineKind::CarlaBehavior,
        }
    }

    /// One LiDAR frame: `distance` is the bumper gap in m (`None` = no lead), `own_speed` in m/s,
    /// `dt` the time since the previous frame in s. See the module docs for the fault rules.
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64, dt: f64) -> LongitudinalCommand {
        match self {
            Baseline::Idm(c) => c.step(distance, own_speed, dt),
            Baseline::Acc(c) => c.step(distance, own_speed, dt),
            Baseline::Rss(c) => c.step(distance, own_speed, dt),
            Baseline::CarlaBehavior(c) => c.step(distance, own_speed, dt),
        }
    }

    /// Forgets all state (estimator, ACC control mode).
    pub fn reset(&mut self) {
        match self {
            Baseline::Idm(c) => c.reset(),
            Baseline::Acc(c) => c.reset(),
            Baseline::Rss(c) => c.reset(),
            Baseline::CarlaBehavior(c) => c.reset(),
        }
    }

    /// The lead-speed estimate of the last step, m/s (`None` without a lead or after a fault).
    pub fn lead_speed_estimate(&self) -> Option<f64> {
        let (lead, v) = match self {
            Baseline::Idm(c) => (c.terms().lead, c.terms().lead_speed),
            Baseline::Acc(c) => (c.terms().lead, c.terms().lead_speed),
            Baseline::Rss(c) => (c.terms().lead, c.terms().lead_speed),
            Baseline::CarlaBehavior(c) => (c.terms().lead, c.terms().lead_speed),
        };
        lead.then_some(v)
    }
}

/// Dispatches to the wrapped controller.
impl LongitudinalController for Baseline {
    fn step(&mut self, frame: &crate::longitudinal::Frame) -> ControlOutput {
        match self {
            Baseline::Idm(c) => LongitudinalController::step(c, frame),
            Baseline::Acc(c) => LongitudinalController::step(c, frame),
            Baseline::Rss(c) => LongitudinalController::step(c, frame),
            Baseline::CarlaBehavior(c) => LongitudinalController::step(c, frame),
        }
    }

    fn reset(&mut self) {
        Baseline::reset(self);
    }

    fn desired_gap(&self, v: f64) -> f64 {
        match self {
            Baseline::Idm(c) => c.desired_gap(v),
            Baseline::Acc(c) => c.desired_gap(v),
            Baseline::Rss(c) => c.desired_gap(v),
            Baseline::CarlaBehavior(c) => c.desired_gap(v),
        }
    }

    fn uses_dt(&self) -> bool {
        true
    }
}

impl From<IdmController> for Baseline {
    fn from(c: IdmController) -> Self {
        Baseline::Idm(c)
    }
}

impl From<AccController> for Baseline {
    fn from(c: AccController) -> Self {
        Baseline::Acc(c)
    }
}

impl From<RssController> for Baseline {
    fn from(c: RssController) -> Self {
        Baseline::Rss(c)
    }
}

impl From<CarlaBehaviorController> for Baseline {
    fn from(c: CarlaBehaviorController) -> Self {
        Baseline::CarlaBehavior(c)
    }
}

/// The validated inputs of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Frame {
    /// A lead at this gap, m.
    Lead(f64),
    /// No lead detected.
    NoLead,
}

/// Longest accepted time step, s (as the PID).
pub(crate) const MAX_DT: f64 = 10.0;

/// Checks one frame's inputs in the order speed, dt, distance; `Err` carries the fault status.
pub(crate) fn check_frame(distance: Option<f64>, own_speed: f64, dt: f64, max_speed: f64, max_distance: f64) -> Result<Frame, Status> {
    if !valid_speed(own_speed, max_speed) {
        return Err(Status::InvalidSpeed);
    }
    if !(dt.is_finite() && dt > 0.0 && dt <= MAX_DT) {
        return Err(Status::InvalidDt);
    }
    match distance {
        None => Ok(Frame::NoLead),
        Some(d) if d.is_finite() && d >= 0.0 && d <= max_distance => Ok(Frame::Lead(d)),
        Some(_) => Err(Status::InvalidDistance),
    }
}

/// The speed command `clamp(own_speed + command_gain * accel, 0, max_speed)` with `status = Ok`,
/// or `None` if anything is non-finite (the caller then brakes).
pub(crate) fn accel_command(own_speed: f64, accel: f64, command_gain: f64, max_speed: f64) -> Option<LongitudinalCommand> {
    let speed = clamp(own_speed + command_gain * accel, 0.0, max_speed);
    (speed.is_finite() && accel.is_finite()).then_some(LongitudinalCommand { speed, accel, status: Status::Ok })
}

/// Lead speed from own speed and range rate, limited to `[0, max_speed]` (the lead is not
/// assumed to reverse), m/s.
pub(crate) fn lead_speed(own_speed: f64, range_rate: f64, max_speed: f64) -> f64 {
    clamp(own_speed + range_rate, 0.0, max_speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for k in BaselineKind::ALL {
            assert_eq!(BaselineKind::from_name(k.as_str()), Some(k));
        }
        assert_eq!(BaselineKind::from_name("carla-behavior"), Some(BaselineKind::CarlaBehavior));
        assert_eq!(BaselineKind::from_name("flc"), None);
        assert_eq!(BaselineKind::from_name("IDM"), None);
    }

    #[test]
    fn frame_checks_in_order() {
        assert_eq!(check_frame(Some(10.0), f64::NAN, f64::NAN, 70.0, 500.0), Err(Status::InvalidSpeed));
        assert_eq!(check_frame(Some(f64::NAN), 10.0, 0.0, 70.0, 500.0), Err(Status::InvalidDt));
        assert_eq!(check_frame(Some(f64::NAN), 10.0, 0.05, 70.0, 500.0), Err(Status::InvalidDistance));
        assert_eq!(check_frame(Some(501.0), 10.0, 0.05, 70.0, 500.0), Err(Status::InvalidDistance));
        assert_eq!(check_frame(Some(-0.1), 10.0, 0.05, 70.0, 500.0), Err(Status::InvalidDistance));
        assert_eq!(check_frame(None, 10.0, 0.05, 70.0, 500.0), Ok(Frame::NoLead));
        assert_eq!(check_frame(Some(0.0), 10.0, 10.0, 70.0, 500.0), Ok(Frame::Lead(0.0)));
        assert_eq!(check_frame(Some(1.0), 10.0, 10.1, 70.0, 500.0), Err(Status::InvalidDt));
    }

    #[test]
    fn wrapper_dispatches() {
        let mut all = [
            Baseline::from(IdmController::new(IdmParams::default()).unwrap()),
            Baseline::from(AccController::new(AccParams::default()).unwrap()),
            Baseline::from(RssController::new(RssParams::default()).unwrap()),
            Baseline::from(CarlaBehaviorController::new(CarlaBehaviorParams::default()).unwrap()),
        ];
        for (b, k) in all.iter_mut().zip(BaselineKind::ALL) {
            assert_eq!(b.kind(), k);
            b.step(Some(30.5), 20.0, 0.1);
            let out = b.step(Some(30.0), 20.0, 0.1);
            assert_eq!(out.status, Status::Ok);
            // Two frames 0.1 s apart closing by 0.5 m: lead speed 20 - 5 = 15 m/s.
            assert!((b.lead_speed_estimate().unwrap() - 15.0).abs() < 1e-9, "{k}");
            b.reset();
            assert_eq!(b.lead_speed_estimate(), None);
            assert_eq!(b.step(Some(30.0), f64::NAN, 0.1).status, Status::InvalidSpeed);
        }
    }
}
