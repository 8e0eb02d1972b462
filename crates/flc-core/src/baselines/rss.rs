//! An RSS-style safe-distance follower.
//!
//! The safe longitudinal distance is Definition 1 of S. Shalev-Shwartz, S. Shammah, A. Shashua,
//! "On a Formal Model of Safe and Scalable Self-driving Cars", arXiv:1708.06374 (2017):
//!
//! ```text
//! d_min = [ v_r rho + a_accel rho^2 / 2 + (v_r + rho a_accel)^2 / (2 b_min) - v_f^2 / (2 b_max) ]_+
//! ```
//!
//! with `v_r` the rear (own) speed, `v_f` the front (lead) speed, `rho` the response time,
//! `a_accel` the rear car's maximum acceleration during the response time, `b_min` its minimum
//! (guaranteed) braking and `b_max` the front car's maximum braking. Following the structure of
//! Autoware's `obstacle_cruise_planner` (cruise planning keeps `rss distance + safe_distance_margin`
//! to the obstacle, `planning/autoware_obstacle_cruise_planner`), the controller regulates the gap
//! to `d_min + margin` and never exceeds the desired speed:
//!
//! ```text
//! a_gap    = gap_gain (gap - d_min - margin) + speed_gain_rel (v_lead - v)
//! a_cruise = cruise_gain (v_des - v)
//! a        = min(a_gap, a_cruise)
//! a        = min(a, -b_min)              if gap < d_min   (RSS "proper response": brake >= b_min)
//! a        = clamp(a, -b_max, a_accel)
//! ```
//!
//! The RSS paper fixes the form, not the numbers. Defaults (documented choices, `docs/baselines.md`):
//! `rho = 0.5 s`, `a_accel = 2 m/s²`, `b_min = 4 m/s²`, `b_max = 8 m/s²` (a lead can brake as hard
//! as the tyres allow), margin 2 m; gains 0.3 s⁻² / 0.8 s⁻¹ (damping ratio `0.8 / (2 sqrt 0.3) =
//! 0.73`) and the cruise gain 0.4 s⁻¹ (SUMO's ACC speed-control gain). `v_lead` is the estimate of
//! [`super::estimator`].

use super::NoLeadPolicy;
use super::estimator::EstimatorParams;
use super::follower::{CarFollowingLaw, Demand, EstimatingFollower, LeadEstimate, follower_params};
use crate::command::clamp;
use crate::longitudinal::{Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// Parameters of the RSS follower.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RssParams {
    /// Response time `rho`, s. Default 0.5.
    pub response_time: f64,
    /// Own maximum acceleration during the response time `a_max,accel`, m/s²; also the output's
    /// upper limit. Default 2.
    pub accel_max: f64,
    /// Own minimum braking `a_min,brake`, m/s²; the least braking while the gap is unsafe. Default 4.
    pub brake_min: f64,
    /// Lead's maximum braking `a_max,brake`, m/s²; also the output's braking limit. Default 8.
    pub brake_max: f64,
    /// Extra gap kept above `d_min` (Autoware's `safe_distance_margin`), m. Default 2.
    pub margin: f64,
    /// Gain on the gap error `gap - d_min - margin`, 1/s². Default 0.3.
    pub gap_gain: f64,
    /// Gain on the speed difference `v_lead - v`, 1/s. Default 0.8.
    pub speed_gain: f64,
    /// Desired (cruise) speed, m/s. Default 130/3.6.
    pub desired_speed: f64,
    /// Cruise gain on `v_des - v`, 1/s. Default 0.4.
    pub cruise_gain: f64,
    /// What to do without a lead. Default [`NoLeadPolicy::Cruise`] (the cruise term).
    pub no_lead: NoLeadPolicy,
    /// The range-rate filter.
    pub estimator: EstimatorParams,
    /// `v_cmd = v + command_gain * a`, s. Default 1.
    pub command_gain: f64,
    /// Highest plausible own speed and highest speed command, m/s. Default 70.
    pub max_speed: f64,
    /// Highest plausible distance, m. Default 500.
    pub max_distance: f64,
    /// Safe command on invalid input: `v_cmd = v - fault_brake_step`, m/s. Default 3.
    pub fault_brake_step: f64,
}

impl Default for RssParams {
    fn default() -> Self {
        Self::documented()
    }
}

impl RssParams {
    /// The documented defaults (identical to `Default`).
    pub const fn documented() -> Self {
        Self {
            response_time: 0.5,
            accel_max: 2.0,
            brake_min: 4.0,
            brake_max: 8.0,
            margin: 2.0,
            gap_gain: 0.3,
            speed_gain: 0.8,
            desired_speed: 130.0 / 3.6,
            cruise_gain: 0.4,
            no_lead: NoLeadPolicy::Cruise,
            estimator: EstimatorParams { alpha: 0.6, beta: 0.25, max_range_rate: 100.0 },
            command_gain: 1.0,
            max_speed: 70.0,
            max_distance: 500.0,
            fault_brake_step: 3.0,
        }
    }

    /// Checks the law's own fields (the shared ones: [`super::FollowerSettings::validate`]).
    fn validate_law(&self) -> Result<(), ParamError> {
        check_range("response_time", self.response_time, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_positive("accel_max", self.accel_max, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("brake_min", self.brake_min, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_range("brake_max", self.brake_max, self.brake_min, 50.0, "must be finite and in [brake_min, 50] m/s²")?;
        check_range("margin", self.margin, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_range("gap_gain", self.gap_gain, 0.0, 100.0, "must be finite and in [0, 100]")?;
        check_range("speed_gain", self.speed_gain, 0.0, 100.0, "must be finite and in [0, 100]")?;
        check_positive("desired_speed", self.desired_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_positive("cruise_gain", self.cruise_gain, 100.0, "must be finite and in (0, 100]")?;
        Ok(())
    }

    /// RSS Definition 1: the minimal safe distance behind a lead at `lead_speed`, m.
    pub fn safe_distance(&self, own_speed: f64, lead_speed: f64) -> f64 {
        let (vr, vf, rho) = (own_speed.max(0.0), lead_speed.max(0.0), self.response_time);
        let after = vr + rho * self.accel_max;
        let d = vr * rho + 0.5 * self.accel_max * rho * rho + after * after / (2.0 * self.brake_min) - vf * vf / (2.0 * self.brake_max);
        d.max(0.0)
    }

    /// Cruise term `cruise_gain (v_des - v)`, m/s².
    pub fn cruise_accel(&self, own_speed: f64) -> f64 {
        self.cruise_gain * (self.desired_speed - own_speed)
    }
}

/// The terms of the last RSS step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RssTerms {
    /// A lead was used this step.
    pub lead: bool,
    /// Measured gap, m.
    pub gap: f64,
    /// Estimated range rate, m/s.
    pub range_rate: f64,
    /// Estimated lead speed, m/s.
    pub lead_speed: f64,
    /// RSS safe distance `d_min`, m.
    pub safe_distance: f64,
    /// Regulated gap `d_min + margin`, m.
    pub target_gap: f64,
    /// Gap law, m/s².
    pub gap_accel: f64,
    /// Cruise term, m/s².
    pub cruise_accel: f64,
    /// The gap was below `d_min`: braking of at least `brake_min` was imposed.
    pub proper_response: bool,
    /// Output acceleration, m/s².
    pub accel: f64,
}

/// The RSS safe-distance follower: the RSS equations under [`EstimatingFollower`].
///
/// ```
/// use flc_core::baselines::{RssController, RssParams};
/// use flc_core::{Frame, LongitudinalController};
///
/// let mut rss = RssController::new(RssParams::default())?;
/// let out = LongitudinalController::step(&mut rss, &Frame::new(Some(40.0), 20.0, 0.05));
/// // Lead speed = own speed = 20 on the first frame: d_min = 20 * 0.5 + 0.25 + 21^2 / 8 - 400 / 16
/// // = 10 + 0.25 + 55.125 - 25 = 40.375 > 40: proper response, a = min(., -b_min) = -4.
/// assert_eq!(out.command.accel, -4.0);
/// // d_min(20, 20) + margin = 42.375.
/// assert!((rss.desired_gap(20.0) - 42.375).abs() < 1e-12);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
pub type RssController = EstimatingFollower<Rss>;

/// The RSS follower's equations ([`CarFollowingLaw`]); stateless.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Rss;

follower_params!(RssParams, Rss);

impl RssTerms {
    /// The names of [`RssTerms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] = &[
        "lead",
        "gap",
        "range_rate",
        "lead_speed",
        "safe_distance",
        "target_gap",
        "gap_accel",
        "cruise_accel",
        "proper_response",
        "accel",
    ];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[
                flag(t.lead),
                t.gap,
                t.range_rate,
                t.lead_speed,
                t.safe_distance,
                t.target_gap,
                t.gap_accel,
                t.cruise_accel,
                flag(t.proper_response),
                t.accel,
            ],
        )
    }
}

impl CarFollowingLaw for Rss {
    type Params = RssParams;
    type Terms = RssTerms;

    fn validate(p: &RssParams) -> Result<(), ParamError> {
        p.validate_law()
    }

    /// `min(a_gap, a_cruise)`, the proper response below `d_min`, the limits.
    fn follow(&mut self, p: &RssParams, lead: &LeadEstimate, own_speed: f64) -> (Demand, RssTerms) {
        let LeadEstimate { gap, range_rate, lead_speed: v_lead } = *lead;
        let cruise_accel = p.cruise_accel(own_speed);
        let safe_distance = p.safe_distance(own_speed, v_lead);
        let target_gap = safe_distance + p.margin;
        let gap_accel = p.gap_gain * (gap - target_gap) + p.speed_gain * (v_lead - own_speed);
        let mut accel = gap_accel.min(cruise_accel);
        let proper_response = gap < safe_distance;
        if proper_response {
            accel = accel.min(-p.brake_min);
        }
        let accel = clamp(accel, -p.brake_max, p.accel_max);
        let t = RssTerms {
            lead: true,
            gap,
            range_rate,
            lead_speed: v_lead,
            safe_distance,
            target_gap,
            gap_accel,
            cruise_accel,
            proper_response,
            accel,
        };
        (Demand::Accel(accel), t)
    }

    /// The cruise term, limited.
    fn free_road(&mut self, p: &RssParams, own_speed: f64) -> (Demand, RssTerms) {
        let cruise_accel = p.cruise_accel(own_speed);
        let accel = clamp(cruise_accel, -p.brake_max, p.accel_max);
        (Demand::Accel(accel), RssTerms { cruise_accel, accel, ..RssTerms::default() })
    }

    /// `d_min(v, v) + margin`.
    fn desired_gap(p: &RssParams, v: f64) -> f64 {
        p.safe_distance(v, v) + p.margin
    }

    fn terms(t: &RssTerms) -> Terms {
        t.to_terms()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{LongitudinalCommand, Status};
    use proptest::prelude::*;

    fn rss() -> RssController {
        RssController::new(RssParams::default()).unwrap()
    }

    fn two_frames(c: &mut RssController, gap: f64, own: f64, lead: f64) -> LongitudinalCommand {
        c.step(Some(gap - (lead - own) * 0.1), own, 0.1);
        c.step(Some(gap), own, 0.1)
    }

    #[test]
    fn safe_distance_by_hand() {
        let p = RssParams::default();
        // v_r = 20, v_f = 15, rho = 0.5, a = 2, b_min = 4, b_max = 8:
        // 20 * 0.5 + 0.5 * 2 * 0.25 + (20 + 1)^2 / 8 - 15^2 / 16 = 10 + 0.25 + 55.125 - 14.0625
        // = 51.3125
        assert!((p.safe_distance(20.0, 15.0) - 51.3125).abs() < 1e-12);
        // Equal speeds 25: 12.5 + 0.25 + 26^2 / 8 - 625 / 16 = 12.75 + 84.5 - 39.0625 = 58.1875
        assert!((p.safe_distance(25.0, 25.0) - 58.1875).abs() < 1e-12);
        // Slow follower, fast lead: 5 * 0.5 + 0.25 + 36 / 8 - 900 / 16 < 0 -> 0.
        assert_eq!(p.safe_distance(5.0, 30.0), 0.0);
    }

    #[test]
    fn proper_response_by_hand() {
        let mut c = rss();
        // v = 20, v_lead = 15, gap 40 < d_min = 51.3125 -> proper response.
        // a_gap = 0.3 (40 - 53.3125) + 0.8 (15 - 20) = -3.99375 - 4 = -7.99375 (< -4, > -8).
        let out = two_frames(&mut c, 40.0, 20.0, 15.0);
        assert!(c.terms().proper_response);
        assert!((c.terms().target_gap - 53.3125).abs() < 1e-9);
        assert!((out.accel + 7.99375).abs() < 1e-9);
        assert!((out.speed - 12.00625).abs() < 1e-9);
    }

    #[test]
    fn proper_response_imposes_brake_min() {
        let mut c = rss();
        // v = v_lead = 20, gap 40: d_min = 10 + 0.25 + 55.125 - 25 = 40.375 > 40 -> unsafe.
        // a_gap = 0.3 (40 - 42.375) + 0 = -0.7125 -> min with -4 -> -4.
        let out = two_frames(&mut c, 40.0, 20.0, 20.0);
        assert!(c.terms().proper_response);
        assert!((c.terms().safe_distance - 40.375).abs() < 1e-9);
        assert!((out.accel + 4.0).abs() < 1e-9);
    }

    #[test]
    fn following_and_cruise_by_hand() {
        let mut c = rss();
        // v = 20, v_lead = 15, gap 60 >= 51.3125:
        // a_gap = 0.3 (60 - 53.3125) + 0.8 (-5) = 2.00625 - 4 = -1.99375;
        // cruise 0.4 (36.111 - 20) = 6.444 -> min -> -1.99375.
        let out = two_frames(&mut c, 60.0, 20.0, 15.0);
        assert!(!c.terms().proper_response);
        assert!((out.accel + 1.99375).abs() < 1e-9);
        // Far lead at the same speed: gap law large -> cruise 0.4 (36.111 - 35) = 0.444444.
        let mut c = rss();
        let out = two_frames(&mut c, 300.0, 35.0, 35.0);
        assert!((out.accel - 0.4 * (130.0 / 3.6 - 35.0)).abs() < 1e-9);
        // Strong gap law limited to accel_max = 2.
        let mut c = rss();
        assert_eq!(two_frames(&mut c, 300.0, 10.0, 10.0).accel, 2.0);
        // Unsafe and closing hard: limited to -brake_max = -8.
        let mut c = rss();
        assert_eq!(two_frames(&mut c, 10.0, 25.0, 5.0).accel, -8.0);
    }

    #[test]
    fn no_lead_and_bad_inputs() {
        let mut c = rss();
        // Cruise: 0.4 * (130/3.6 - 34) = 0.844444.
        let out = c.step(None, 34.0, 0.05);
        assert_eq!(out.status, Status::Ok);
        assert!((out.accel - 0.4 * (130.0 / 3.6 - 34.0)).abs() < 1e-12);
        let mut c = RssController::new(RssParams { no_lead: NoLeadPolicy::Brake, ..RssParams::default() }).unwrap();
        assert_eq!(c.step(None, 20.0, 0.05).status, Status::NoLead);
        assert_eq!(c.step(Some(30.0), 20.0, 11.0).status, Status::InvalidDt);
        assert_eq!(c.step(Some(600.0), 20.0, 0.05).status, Status::InvalidDistance);
        assert_eq!(c.step(Some(30.0), -2.0, 0.05).status, Status::InvalidSpeed);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: RssParams| RssController::new(p).unwrap_err().field;
        assert_eq!(bad(RssParams { response_time: f64::NAN, ..Default::default() }), "response_time");
        assert_eq!(bad(RssParams { brake_max: 3.0, ..Default::default() }), "brake_max");
        assert_eq!(bad(RssParams { brake_min: 0.0, ..Default::default() }), "brake_min");
        assert_eq!(bad(RssParams { cruise_gain: 0.0, ..Default::default() }), "cruise_gain");
        let est = EstimatorParams { max_range_rate: -1.0, ..EstimatorParams::default() };
        assert_eq!(bad(RssParams { estimator: est, ..Default::default() }), "estimator.max_range_rate");
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = rss();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                prop_assert!(out.accel.is_finite() && (-8.0..=2.0).contains(&out.accel));
            }
        }
    }
}
