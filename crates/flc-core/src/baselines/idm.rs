//! The Intelligent Driver Model (IDM) as a LiDAR-only follower.
//!
//! M. Treiber, A. Hennecke, D. Helbing, "Congested traffic states in empirical observations and
//! microscopic simulations", *Phys. Rev. E* 62(2), 1805–1824 (2000)
//! (with the second jam distance `s1 = 0`, as in its Table I):
//!
//! ```text
//! a_IDM = a [ 1 - (v / v0)^delta - (s*(v, dv) / s)^2 ]
//! s*    = s0 + max(0, v T + v dv / (2 sqrt(a b)))
//! dv    = v - v_lead                       (approach rate, > 0 when closing)
//! ```
//!
//! The `max(0, ...)` on the dynamic part of `s*` is the form of Treiber & Kesting, *Traffic Flow
//! Dynamics* (Springer 2013), ch. 11; in the 2000 form a much faster lead makes
//! `s*` smaller than `s0`, even negative. `v_lead` is the estimate `v + range rate` of
//! [`super::estimator`]; `s` is the measured gap, floored at [`IdmParams::min_gap_floor`] so that
//! a zero gap gives a finite (maximal) braking instead of a division by zero. The law's output is
//! limited to `[-max_decel, a]` (the IDM itself has no braking limit) and turned into the speed
//! command `v + command_gain * a_IDM`.
//!
//! Defaults are Table I of the 2000 paper (`a = 0.73 m/s²`, `b = 1.67 m/s²`, `T = 1.6 s`,
//! `s0 = 2 m`, `delta = 4`) except the desired speed `v0`, which is 130 km/h instead of 120 km/h
//! so that the IDM does not limit the follower below the lead in the speed sweeps.

use super::estimator::EstimatorParams;
use super::follower::{CarFollowingLaw, Demand, EstimatingFollower, LeadEstimate, follower_params};
use super::{NoLeadPolicy, powf};
use crate::command::clamp;
use crate::longitudinal::{Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// Parameters of the IDM follower. `Default`: Treiber et al. (2000), Table I, with `v0 = 130 km/h`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdmParams {
    /// Desired speed `v0`, m/s. Default 130/3.6 (the paper: 120 km/h).
    pub desired_speed: f64,
    /// Safe time headway `T`, s. Paper: 1.6.
    pub time_headway: f64,
    /// Jam distance `s0`, m. Paper: 2.
    pub min_gap: f64,
    /// Maximum acceleration `a`, m/s². Paper: 0.73.
    pub max_accel: f64,
    /// Comfortable deceleration `b`, m/s². Paper: 1.67.
    pub comfort_decel: f64,
    /// Acceleration exponent `delta`. Paper: 4.
    pub delta: f64,
    /// Physical braking limit applied to the law's output, m/s². Default 9 (dry road).
    pub max_decel: f64,
    /// Smallest gap used in `(s*/s)^2`, m. Default 0.01.
    pub min_gap_floor: f64,
    /// What to do without a lead. Default [`NoLeadPolicy::Cruise`] (the free-road term).
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

impl Default for IdmParams {
    fn default() -> Self {
        Self::treiber2000()
    }
}

impl IdmParams {
    /// Table I of Treiber, Hennecke & Helbing (2000), with `v0 = 130 km/h` (identical to `Default`).
    pub const fn treiber2000() -> Self {
        Self {
            desired_speed: 130.0 / 3.6,
            time_headway: 1.6,
            min_gap: 2.0,
            max_accel: 0.73,
            comfort_decel: 1.67,
            delta: 4.0,
            max_decel: 9.0,
            min_gap_floor: 0.01,
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
        check_positive("desired_speed", self.desired_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_range("time_headway", self.time_headway, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_range("min_gap", self.min_gap, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_positive("max_accel", self.max_accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("comfort_decel", self.comfort_decel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("delta", self.delta, 20.0, "must be finite and in (0, 20]")?;
        check_positive("max_decel", self.max_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_positive("min_gap_floor", self.min_gap_floor, 10.0, "must be finite and in (0, 10] m")?;
        Ok(())
    }

    /// Desired gap `s* = s0 + max(0, v T + v dv / (2 sqrt(a b)))`, m, with `dv = v - v_lead`.
    pub fn desired_gap(&self, own_speed: f64, lead_speed: f64) -> f64 {
        let v = own_speed.max(0.0);
        let dynamic = v * self.time_headway + v * (v - lead_speed) / (2.0 * libm::sqrt(self.max_accel * self.comfort_decel));
        self.min_gap + dynamic.max(0.0)
    }

    /// Free-road term `a [1 - (v/v0)^delta]`, m/s².
    pub fn free_accel(&self, own_speed: f64) -> f64 {
        self.max_accel * (1.0 - libm::pow(own_speed.max(0.0) / self.desired_speed, self.delta))
    }

    /// Interaction term `-a (s*/s)^2`, m/s² (`s` floored at `min_gap_floor`).
    pub fn interaction_accel(&self, own_speed: f64, lead_speed: f64, gap: f64) -> f64 {
        let ratio = self.desired_gap(own_speed, lead_speed) / gap.max(self.min_gap_floor);
        -self.max_accel * ratio * ratio
    }

    /// The IDM acceleration before the `[-max_decel, a]` limit, m/s².
    pub fn accel(&self, own_speed: f64, lead_speed: f64, gap: f64) -> f64 {
        self.free_accel(own_speed) + self.interaction_accel(own_speed, lead_speed, gap)
    }
}

/// The terms of the last IDM step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IdmTerms {
    /// A lead was used this step.
    pub lead: bool,
    /// Measured gap `s`, m (0 without a lead).
    pub gap: f64,
    /// Estimated range rate, m/s.
    pub range_rate: f64,
    /// Estimated lead speed `v + range rate` (limited to `[0, max_speed]`), m/s.
    pub lead_speed: f64,
    /// Desired gap `s*`, m.
    pub desired_gap: f64,
    /// Free-road term, m/s².
    pub free_accel: f64,
    /// Interaction term, m/s² (0 without a lead).
    pub interaction_accel: f64,
    /// Output acceleration after the limit, m/s².
    pub accel: f64,
}

/// The IDM follower: the IDM's equations under [`EstimatingFollower`].
///
/// ```
/// use flc_core::baselines::{IdmController, IdmParams};
/// use flc_core::{Frame, LongitudinalController};
///
/// let mut idm = IdmController::new(IdmParams::default())?;
/// let out = LongitudinalController::step(&mut idm, &Frame::new(Some(42.0), 25.0, 0.05));
/// // First frame, lead speed = own speed: s* = 2 + 25 * 1.6 = 42 = s, so
/// // a = 0.73 (1 - (25 / 36.11)^4 - 1) = -0.73 * 0.229719 = -0.167695.
/// assert!((out.command.accel + 0.167695).abs() < 1e-6);
/// // Equilibrium gap s* / sqrt(1 - (v/v0)^4) = 42 / sqrt(0.770281) = 47.854.
/// assert!((idm.desired_gap(25.0) - 47.854).abs() < 1e-3);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
pub type IdmController = EstimatingFollower<Idm>;

/// The IDM's equations ([`CarFollowingLaw`]); stateless.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Idm;

follower_params!(IdmParams, Idm);

impl IdmTerms {
    /// The names of [`IdmTerms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] =
        &["lead", "gap", "range_rate", "lead_speed", "desired_gap", "free_accel", "interaction_accel", "accel"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[flag(t.lead), t.gap, t.range_rate, t.lead_speed, t.desired_gap, t.free_accel, t.interaction_accel, t.accel],
        )
    }
}

impl CarFollowingLaw for Idm {
    type Params = IdmParams;
    type Terms = IdmTerms;

    fn validate(p: &IdmParams) -> Result<(), ParamError> {
        p.validate_law()
    }

    /// `a_IDM` limited to `[-max_decel, a]`.
    fn follow(&mut self, p: &IdmParams, lead: &LeadEstimate, own_speed: f64) -> (Demand, IdmTerms) {
        let free_accel = p.free_accel(own_speed);
        let interaction_accel = p.interaction_accel(own_speed, lead.lead_speed, lead.gap);
        let accel = clamp(free_accel + interaction_accel, -p.max_decel, p.max_accel);
        let desired_gap = p.desired_gap(own_speed, lead.lead_speed);
        let LeadEstimate { gap, range_rate, lead_speed } = *lead;
        (Demand::Accel(accel), IdmTerms { lead: true, gap, range_rate, lead_speed, desired_gap, free_accel, interaction_accel, accel })
    }

    /// The free-road term `a [1 - (v/v0)^delta]`, limited.
    fn free_road(&mut self, p: &IdmParams, own_speed: f64) -> (Demand, IdmTerms) {
        let free_accel = p.free_accel(own_speed);
        let accel = clamp(free_accel, -p.max_decel, p.max_accel);
        (Demand::Accel(accel), IdmTerms { free_accel, accel, ..IdmTerms::default() })
    }

    fn desired_gap(p: &IdmParams, v: f64) -> f64 {
        p.equilibrium_gap(v)
    }

    fn terms(t: &IdmTerms) -> Terms {
        t.to_terms()
    }
}

impl IdmParams {
    /// The equilibrium gap at equal speeds `v` (clamped at 0): `s* / sqrt(1 - (v/v0)^delta)`
    /// (`s*` alone when the root vanishes), m. With `std`, `(v/v0)^delta` is std's `f64::powf`.
    pub fn equilibrium_gap(&self, v: f64) -> f64 {
        let v = v.max(0.0);
        let s_star = self.desired_gap(v, v);
        let free = 1.0 - powf(v / self.desired_speed, self.delta);
        if free > 1e-6 { s_star / libm::sqrt(free) } else { s_star }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::Status;
    use proptest::prelude::*;

    /// The textbook example's numbers: a = 1.5, b = 2 (sqrt(a b) = sqrt(3)), T = 1.5, s0 = 2,
    /// delta = 4, v0 = 40.
    fn example() -> IdmParams {
        IdmParams {
            max_accel: 1.5,
            comfort_decel: 2.0,
            time_headway: 1.5,
            min_gap: 2.0,
            delta: 4.0,
            desired_speed: 40.0,
            ..IdmParams::default()
        }
    }

    /// Ideal perception: a measured lead speed replaces the estimate on the first frame already
    /// (the estimator would still report a range rate of 0), so the command is the law's at the
    /// true closing speed; a bad measurement gives the safe command.
    #[test]
    fn a_measured_lead_speed_replaces_the_estimate() {
        let p = example();
        let mut c = IdmController::new(p).unwrap();
        let cmd = c.step_measured(Some(30.0), 20.0, 0.1, Some(15.0));
        // a = 1.5 (1 - (20/40)^4 - (60.867513 / 30)^2) = 1.5 (0.9375 - 4.116505) = -4.768507
        let expected = p.max_accel * (1.0 - 0.0625 - (p.desired_gap(20.0, 15.0) / 30.0).powi(2));
        assert!((cmd.accel - expected).abs() < 1e-9 && (cmd.accel + 4.768507).abs() < 1e-5, "{}", cmd.accel);
        assert_eq!((c.terms().lead_speed, c.terms().range_rate), (15.0, -5.0));
        // Without the measurement the first frame sees no closing speed.
        let mut e = IdmController::new(p).unwrap();
        assert!(e.step(Some(30.0), 20.0, 0.1).accel > cmd.accel);
        assert_eq!(c.step_measured(Some(30.0), 20.0, 0.1, Some(f64::NAN)).status, Status::InvalidLeadSpeed);
    }

    #[test]
    fn law_by_hand() {
        let p = example();
        // v = 20, v_lead = 15, s = 30: dv = 5.
        // s* = 2 + 20 * 1.5 + 20 * 5 / (2 sqrt(3)) = 2 + 30 + 28.867513 = 60.867513
        assert!((p.desired_gap(20.0, 15.0) - (32.0 + 100.0 / (2.0 * 3f64.sqrt()))).abs() < 1e-12);
        assert!((p.desired_gap(20.0, 15.0) - 60.867513).abs() < 1e-6);
        // free: 1.5 * (1 - (20/40)^4) = 1.5 * (1 - 0.0625) = 1.40625
        assert!((p.free_accel(20.0) - 1.40625).abs() < 1e-12);
        // interaction: -1.5 * (60.867513 / 30)^2 = -1.5 * 4.116505 = -6.174757
        assert!((p.interaction_accel(20.0, 15.0, 30.0) + 6.174757).abs() < 1e-6);
        // a = 1.40625 - 6.174757 = -4.768507
        assert!((p.accel(20.0, 15.0, 30.0) + 4.768507).abs() < 1e-6);
    }

    #[test]
    fn equilibrium_and_faster_lead_by_hand() {
        let p = example();
        // Equal speeds: s* = 2 + 20 * 1.5 = 32; at s = 32 the interaction term is -a, so
        // a = 1.5 * (1 - 0.0625 - 1) = -0.09375.
        assert!((p.accel(20.0, 20.0, 32.0) + 0.09375).abs() < 1e-12);
        // Lead much faster: v T + v dv/(2 sqrt(ab)) = 30 + 20 * (-20) / 3.4641 = -85.47 < 0
        // -> s* = s0 = 2 (the max(0, .) of Treiber & Kesting).
        assert_eq!(p.desired_gap(20.0, 40.0), 2.0);
    }

    #[test]
    fn step_uses_the_estimated_lead_speed() {
        let mut c = IdmController::new(example()).unwrap();
        // Frame 1: no rate yet -> v_lead = v = 20; s* = 32, s = 30.5:
        // a = 1.40625 - 1.5 * (32 / 30.5)^2 = 1.40625 - 1.651169 = -0.244919.
        let first = c.step(Some(30.5), 20.0, 0.1);
        assert!((first.accel + 0.244919).abs() < 1e-6);
        // Frame 2: 30.5 -> 30.0 in 0.1 s: rate -5, v_lead = 15 -> the hand-computed -4.768507,
        // speed command 20 - 4.768507 = 15.231493.
        let out = c.step(Some(30.0), 20.0, 0.1);
        assert_eq!(out.status, Status::Ok);
        assert!((c.terms().lead_speed - 15.0).abs() < 1e-9);
        assert!((out.accel + 4.768507).abs() < 1e-6);
        assert!((out.speed - 15.231493).abs() < 1e-6);
    }

    #[test]
    fn defaults_by_hand() {
        // Treiber et al. Table I: a = 0.73, b = 1.67, T = 1.6, s0 = 2, delta = 4, v0 = 130/3.6.
        let p = IdmParams::default();
        // v = 25, v_lead = 25, s = 42: s* = 2 + 25 * 1.6 = 42 -> a = 0.73 (1 - (25/36.111)^4 - 1)
        //   (25 / 36.111...)^4 = (0.692308)^4 = 0.229719 -> a = -0.73 * 0.229719 = -0.167695.
        assert!((p.accel(25.0, 25.0, 42.0) + 0.73 * (25.0f64 / (130.0 / 3.6)).powi(4)).abs() < 1e-12);
        assert!((p.accel(25.0, 25.0, 42.0) + 0.167695).abs() < 1e-6);
    }

    #[test]
    fn limits_and_zero_gap() {
        let mut c = IdmController::new(IdmParams::default()).unwrap();
        // Zero gap: floored at 0.01 m, braking limited to max_decel = 9.
        let out = c.step(Some(0.0), 10.0, 0.05);
        assert_eq!(out.accel, -9.0);
        assert_eq!(out.speed, 1.0);
        // At standstill with a huge gap: the full a = 0.73.
        let mut c = IdmController::new(IdmParams::default()).unwrap();
        assert!((c.step(Some(400.0), 0.0, 0.05).accel - 0.73).abs() < 1e-4);
    }

    #[test]
    fn no_lead_policies() {
        let mut c = IdmController::new(IdmParams::default()).unwrap();
        // Cruise: free-road term 0.73 * (1 - (10 / 36.111)^4) = 0.73 * (1 - 0.005881) = 0.725707.
        let out = c.step(None, 10.0, 0.05);
        assert_eq!(out.status, Status::Ok);
        assert!((out.accel - 0.725707).abs() < 1e-6);
        assert!(!c.terms().lead);
        let mut c = IdmController::new(IdmParams { no_lead: NoLeadPolicy::Brake, ..IdmParams::default() }).unwrap();
        let out = c.step(None, 10.0, 0.05);
        assert_eq!((out.status, out.speed, out.accel), (Status::NoLead, 7.0, -3.0));
    }

    #[test]
    fn bad_inputs_give_safe_command_and_reset() {
        let mut c = IdmController::new(IdmParams::default()).unwrap();
        c.step(Some(30.5), 20.0, 0.1);
        c.step(Some(30.0), 20.0, 0.1);
        assert_eq!(c.step(Some(f64::NAN), 20.0, 0.1).status, Status::InvalidDistance);
        assert!(!c.terms().lead);
        // The track was reset: the next frame has no rate.
        c.step(Some(29.0), 20.0, 0.1);
        assert_eq!(c.terms().range_rate, 0.0);
        assert_eq!(c.step(Some(30.0), 20.0, 0.0).status, Status::InvalidDt);
        assert_eq!(c.step(Some(30.0), 20.0, f64::INFINITY).status, Status::InvalidDt);
        assert_eq!(c.step(Some(-1.0), 20.0, 0.1).status, Status::InvalidDistance);
        let out = c.step(Some(30.0), f64::NAN, 0.1);
        assert_eq!((out.status, out.speed), (Status::InvalidSpeed, 0.0));
        let out = c.step(Some(30.0), 20.0, -0.1);
        assert_eq!((out.status, out.speed, out.accel), (Status::InvalidDt, 17.0, -3.0));
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: IdmParams| IdmController::new(p).unwrap_err().field;
        assert_eq!(bad(IdmParams { desired_speed: 0.0, ..Default::default() }), "desired_speed");
        assert_eq!(bad(IdmParams { comfort_decel: f64::NAN, ..Default::default() }), "comfort_decel");
        assert_eq!(bad(IdmParams { delta: -4.0, ..Default::default() }), "delta");
        assert_eq!(bad(IdmParams { time_headway: -0.1, ..Default::default() }), "time_headway");
        let est = EstimatorParams { beta: 3.0, ..EstimatorParams::default() };
        assert_eq!(bad(IdmParams { estimator: est, ..Default::default() }), "estimator.beta");
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = IdmController::new(IdmParams::default()).unwrap();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                prop_assert!(out.accel.is_finite() && (-9.0..=3.0).contains(&out.accel));
            }
        }

        #[test]
        fn plausible_sequences_stay_in_the_law_limits(
            seq in proptest::collection::vec((proptest::option::of(0.0..200.0f64), 0.0..40.0f64, 0.01..0.2f64), 1..40)
        ) {
            let mut c = IdmController::new(IdmParams::default()).unwrap();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert_eq!(out.status, Status::Ok);
                prop_assert!((-9.0..=0.73).contains(&out.accel));
            }
        }
    }
}
