//! Gipps' car-following model as a LiDAR-only follower.
//!
//! P. G. Gipps, "A behavioural car-following model for computer simulation", *Transp. Res. B*
//! 15(2), 105–111 (1981), Eq. (5) (the minimum of his free-flow Eq. (1) and safe-speed Eq. (4)):
//!
//! ```text
//! v_n(t+tau) = min{ v + 2.5 a tau (1 - v/V) (0.025 + v/V)^(1/2),                          (free)
//!                   b tau + sqrt(b² tau² - b [2 (x_{n-1} - s_{n-1} - x_n) - v tau - v_{n-1}² / b̂]) }   (safe)
//! ```
//!
//! with `a` the maximum acceleration, `b < 0` the most severe braking the driver wishes to
//! undertake, `b̂ < 0` the driver's estimate of the lead's, `V` the desired speed, `tau` the
//! reaction time, `v = v_n(t)`, `v_{n-1}` the lead's speed and `x_{n-1} - s_{n-1} - x_n` the gap to
//! the lead's rear less a standstill margin (`s_{n-1}` is the lead's effective size: its length
//! plus the margin the follower keeps at rest). Here the parameters are positive magnitudes,
//! `decel = -b` and `lead_decel = -b̂`, so the safe speed reads
//!
//! ```text
//! g      = gap - min_gap                                   (measured bumper gap less min_gap)
//! v_safe = -decel tau + sqrt(decel² tau² + decel (2 g - v tau + v_lead² / lead_decel))
//! v_free = v + 2.5 accel tau (1 - r) sqrt(0.025 + r),   r = max(v, 0) / V
//! target = min(v_free, v_safe)           (v_free alone without a lead, NoLeadPolicy::Cruise)
//! ```
//!
//! Sensing as for the other baselines: `gap` is the measured distance, `v_lead` the estimate of
//! [`super::estimator`]. Choices where the paper is silent (`docs/baselines.md`, "Gipps"):
//!
//! * **Command.** Gipps' law gives the speed after one reaction time; like the CARLA follower the
//!   target speed is the speed command, `speed = clamp(target, 0, max_speed)` and
//!   `accel = (speed - v) / command_gain` (reporting only; [`super::follower`]).
//! * **Radicand.** A negative radicand (a gap too short to stop behind the lead even braking at
//!   `decel`) is taken as 0: `v_safe = -decel tau < 0`, i.e. the command is 0 (stop).
//! * **Reversing.** `r` uses `max(v, 0)` so that a measured speed in `[-1, 0)` keeps the square
//!   root real.
//!
//! Defaults: SUMO-compatible (SUMO's `Krauss`, itself a Gipps-type safe-speed model, with its
//! default passenger type): `accel = 2.6 m/s²`, `decel = 4.5 m/s²`, `tau = 1 s`, `min_gap = 2.5 m`,
//! desired speed 120 km/h (33.33 m/s); `lead_decel` by Gipps' own rule
//! `b̂ = min(-3, (b - 3) / 2)` = 3.75 m/s² for `b = -4.5`.
//!
//! Equilibrium (desired) gap at equal speeds `v_lead = v_target = v`: setting `v_safe = v` gives
//! `sqrt(decel² tau² + decel (2 g - v tau + v² / lead_decel)) = v + decel tau`; squaring,
//! `decel (2 g - v tau + v² / lead_decel) = v² + 2 v decel tau`, so
//!
//! ```text
//! g*(v)   = 1.5 tau v + (v² / 2) (1 / decel - 1 / lead_decel)
//! gap*(v) = min_gap + max(0, g*(v))
//! ```

use super::NoLeadPolicy;
use super::estimator::EstimatorParams;
use super::follower::{CarFollowingLaw, Demand, EstimatingFollower, LeadEstimate, follower_params};
use crate::longitudinal::{Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// Parameters of the Gipps follower. `Default`: SUMO-compatible values (module docs), desired
/// speed 120 km/h.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GippsParams {
    /// Desired speed `V`, m/s. Default 120/3.6 (33.33 m/s).
    pub desired_speed: f64,
    /// Maximum acceleration `a`, m/s². Default 2.6 (SUMO `accel`; Gipps: 1.7).
    pub accel: f64,
    /// Most severe braking the driver wishes to undertake, `-b`, m/s² (positive). Default 4.5
    /// (SUMO `decel`; Gipps: 3.4).
    pub decel: f64,
    /// The driver's estimate of the lead's braking, `-b̂`, m/s² (positive). Default 3.75 (Gipps'
    /// rule `b̂ = min(-3, (b - 3) / 2)` for `b = -4.5`).
    pub lead_decel: f64,
    /// Reaction time `tau`, s. Default 1.0 (SUMO `tau`; Gipps: 2/3).
    pub reaction_time: f64,
    /// Standstill margin taken off the measured gap (the margin part of Gipps' effective size
    /// `s_{n-1}`), m. Default 2.5 (SUMO `minGap`).
    pub min_gap: f64,
    /// What to do without a lead. Default [`NoLeadPolicy::Cruise`] (the free-flow branch).
    pub no_lead: NoLeadPolicy,
    /// The range-rate filter.
    pub estimator: EstimatorParams,
    /// `accel = (v_cmd - v) / command_gain` (reporting only), s. Default 1.
    pub command_gain: f64,
    /// Highest plausible own speed and highest speed command, m/s. Default 70.
    pub max_speed: f64,
    /// Highest plausible distance, m. Default 500.
    pub max_distance: f64,
    /// Safe command on invalid input: `v_cmd = v - fault_brake_step`, m/s. Default 3.
    pub fault_brake_step: f64,
}

impl Default for GippsParams {
    fn default() -> Self {
        Self::sumo()
    }
}

impl GippsParams {
    /// The SUMO-compatible defaults (identical to `Default`).
    pub const fn sumo() -> Self {
        Self {
            desired_speed: 120.0 / 3.6,
            accel: 2.6,
            decel: 4.5,
            lead_decel: 3.75,
            reaction_time: 1.0,
            min_gap: 2.5,
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
        check_positive("accel", self.accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("decel", self.decel, 50.0, "must be finite and in (0, 50] m/s² (the magnitude of Gipps' b)")?;
        check_positive("lead_decel", self.lead_decel, 50.0, "must be finite and in (0, 50] m/s² (the magnitude of Gipps' b̂)")?;
        check_positive("reaction_time", self.reaction_time, 10.0, "must be finite and in (0, 10] s")?;
        check_range("min_gap", self.min_gap, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        Ok(())
    }

    /// Free-flow branch `v + 2.5 a tau (1 - r) sqrt(0.025 + r)`, `r = max(v, 0) / V`, m/s.
    pub fn free_speed(&self, own_speed: f64) -> f64 {
        let r = own_speed.max(0.0) / self.desired_speed;
        own_speed + 2.5 * self.accel * self.reaction_time * (1.0 - r) * libm::sqrt(0.025 + r)
    }

    /// Safe-speed branch `-d tau + sqrt(d² tau² + d (2 (gap - min_gap) - v tau + v_lead² / d̂))`
    /// (`d = decel`, `d̂ = lead_decel`; a negative radicand counts as 0), m/s.
    pub fn safe_speed(&self, gap: f64, own_speed: f64, lead_speed: f64) -> f64 {
        let (d, tau) = (self.decel, self.reaction_time);
        let g = gap - self.min_gap;
        let radicand = d * d * tau * tau + d * (2.0 * g - own_speed * tau + lead_speed * lead_speed / self.lead_decel);
        -d * tau + libm::sqrt(radicand.max(0.0))
    }

    /// The equilibrium bumper gap at equal speeds `v`: `min_gap + max(0, 1.5 tau v + v²/2 (1/d - 1/d̂))`, m.
    pub fn equilibrium_gap(&self, v: f64) -> f64 {
        let g = 1.5 * self.reaction_time * v + 0.5 * v * v * (1.0 / self.decel - 1.0 / self.lead_decel);
        self.min_gap + g.max(0.0)
    }
}

/// The terms of the last Gipps step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GippsTerms {
    /// A lead was used this step.
    pub lead: bool,
    /// Measured gap, m.
    pub gap: f64,
    /// Estimated range rate, m/s.
    pub range_rate: f64,
    /// Estimated lead speed, m/s.
    pub lead_speed: f64,
    /// Free-flow speed, m/s.
    pub free_speed: f64,
    /// Safe speed (0 without a lead), m/s.
    pub safe_speed: f64,
    /// The safe speed was the smaller one (the lead constrains).
    pub constrained: bool,
    /// Target speed `min(free, safe)` before the `[0, max_speed]` limit, m/s.
    pub target_speed: f64,
}

impl GippsTerms {
    /// The names of [`GippsTerms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] =
        &["lead", "gap", "range_rate", "lead_speed", "free_speed", "safe_speed", "constrained", "target_speed"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[flag(t.lead), t.gap, t.range_rate, t.lead_speed, t.free_speed, t.safe_speed, flag(t.constrained), t.target_speed],
        )
    }
}

/// The Gipps follower: Gipps' equations under [`EstimatingFollower`].
///
/// ```
/// use flc_core::baselines::{GippsController, GippsParams};
/// use flc_core::{Frame, LongitudinalController};
///
/// let mut gipps = GippsController::new(GippsParams::default())?;
/// let out = LongitudinalController::step(&mut gipps, &Frame::new(Some(30.0), 20.0, 0.05));
/// // Lead speed = own speed = 20 on the first frame, g = 27.5:
/// // v_safe = -4.5 + sqrt(20.25 + 4.5 (55 - 20 + 400 / 3.75)) = -4.5 + sqrt(657.75) = 21.1466 < v_free = 22.0555.
/// assert!((out.command.speed - 21.146637).abs() < 1e-6);
/// // 2.5 + 1.5 * 20 + 200 (1/4.5 - 1/3.75) = 23.6111.
/// assert!((gipps.desired_gap(20.0) - 23.611111).abs() < 1e-6);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
pub type GippsController = EstimatingFollower<Gipps>;

/// Gipps' equations ([`CarFollowingLaw`]); stateless.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Gipps;

follower_params!(GippsParams, Gipps);

impl CarFollowingLaw for Gipps {
    type Params = GippsParams;
    type Terms = GippsTerms;

    fn validate(p: &GippsParams) -> Result<(), ParamError> {
        p.validate_law()
    }

    /// `min(v_free, v_safe)`.
    fn follow(&mut self, p: &GippsParams, lead: &LeadEstimate, own_speed: f64) -> (Demand, GippsTerms) {
        let LeadEstimate { gap, range_rate, lead_speed } = *lead;
        let free_speed = p.free_speed(own_speed);
        let safe_speed = p.safe_speed(gap, own_speed, lead_speed);
        let constrained = safe_speed < free_speed;
        let target_speed = if constrained { safe_speed } else { free_speed };
        (
            Demand::Speed(target_speed),
            GippsTerms { lead: true, gap, range_rate, lead_speed, free_speed, safe_speed, constrained, target_speed },
        )
    }

    /// `v_free`.
    fn free_road(&mut self, p: &GippsParams, own_speed: f64) -> (Demand, GippsTerms) {
        let free_speed = p.free_speed(own_speed);
        (Demand::Speed(free_speed), GippsTerms { free_speed, target_speed: free_speed, ..GippsTerms::default() })
    }

    fn desired_gap(p: &GippsParams, v: f64) -> f64 {
        p.equilibrium_gap(v)
    }

    fn terms(t: &GippsTerms) -> Terms {
        t.to_terms()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LongitudinalController;
    use crate::command::Status;
    use proptest::prelude::*;

    fn gipps() -> GippsController {
        GippsController::new(GippsParams::default()).unwrap()
    }

    #[test]
    fn branches_by_hand() {
        let p = GippsParams::default();
        // Free: v = 20, V = 33.333: r = 0.6, 2.5 * 2.6 * 1.0 * (1 - 0.6) * sqrt(0.625)
        //   = 6.5 * 0.4 * 0.790569 = 2.055480 -> 22.055480.
        assert!((p.free_speed(20.0) - 22.055480).abs() < 1e-6);
        // At V the free branch holds the speed: (1 - 1) = 0.
        assert_eq!(p.free_speed(120.0 / 3.6), 120.0 / 3.6);
        // Safe: gap 30, v = v_lead = 20: g = 27.5; radicand = 4.5^2 + 4.5 (55 - 20 + 400/3.75)
        //   = 20.25 + 4.5 * 141.666667 = 657.75; -4.5 + sqrt(657.75) = -4.5 + 25.646637 = 21.146637.
        assert!((p.safe_speed(30.0, 20.0, 20.0) - 21.146637).abs() < 1e-6);
        // Closing lead: gap 20, v = 20, v_lead = 15: g = 17.5; radicand = 20.25 + 4.5 (35 - 20 + 225/3.75)
        //   = 20.25 + 4.5 * 75 = 357.75; -4.5 + sqrt(357.75) = -4.5 + 18.914280 = 14.414280.
        assert!((p.safe_speed(20.0, 20.0, 15.0) - 14.414280).abs() < 1e-6);
        // Too close to stop: gap 2.5 (g = 0), v = 30, lead standing: radicand = 20.25 + 4.5 (0 - 30 + 0) < 0
        //   -> 0, v_safe = -4.5 (the command will be 0).
        assert_eq!(p.safe_speed(2.5, 30.0, 0.0), -4.5);
    }

    #[test]
    fn equilibrium_gap_by_hand() {
        let p = GippsParams::default();
        // g* = 1.5 * 1 * 20 + 400/2 (1/4.5 - 1/3.75) = 30 + 200 (0.222222 - 0.266667) = 30 - 8.888889
        //   -> gap* = 2.5 + 21.111111 = 23.611111.
        assert!((p.equilibrium_gap(20.0) - 23.611111).abs() < 1e-6);
        assert_eq!(p.equilibrium_gap(0.0), 2.5);
        // With lead_decel = decel the quadratic term vanishes: 2.5 + 1.5 * 20 = 32.5.
        let q = GippsParams { lead_decel: 4.5, ..p };
        assert!((q.equilibrium_gap(20.0) - 32.5).abs() < 1e-12);
        // g* < 0 beyond v = 3 tau / (1/d̂ - 1/d) = 3 / 0.044444 = 67.5 m/s: floored at min_gap.
        assert_eq!(p.equilibrium_gap(69.0), 2.5);
    }

    #[test]
    fn at_the_equilibrium_gap_the_speed_is_held() {
        for v in [5.0, 10.0, 20.0, 30.0] {
            let mut c = gipps();
            let gap = c.params().equilibrium_gap(v);
            // First frame: estimated lead speed = own speed (equal speeds).
            let out = c.step(Some(gap), v, 0.05);
            assert_eq!(out.status, Status::Ok);
            assert!(c.terms().constrained, "{v}");
            assert!((out.speed - v).abs() < 1e-9, "{v}: {}", out.speed);
            assert!(out.accel.abs() < 1e-9);
            // Through the trait: the same gap.
            assert_eq!(LongitudinalController::desired_gap(&c, v), gap);
        }
    }

    #[test]
    fn step_uses_the_estimated_lead_speed() {
        let mut c = gipps();
        // Frame 1: gap 20.5, no rate yet; frame 2: 20.0 after 0.1 s -> rate -5, v_lead = 15: the
        // hand-computed closing case, 14.414280; accel = (14.414280 - 20) / 1 = -5.585720.
        c.step(Some(20.5), 20.0, 0.1);
        let out = c.step(Some(20.0), 20.0, 0.1);
        assert_eq!(out.status, Status::Ok);
        assert!((c.terms().lead_speed - 15.0).abs() < 1e-9);
        assert!((out.speed - 14.414280).abs() < 1e-6);
        assert!((out.accel + 5.585720).abs() < 1e-6);
        // Far lead: the free branch drives (22.055480).
        let mut c = gipps();
        let out = c.step(Some(300.0), 20.0, 0.1);
        assert!(!c.terms().constrained);
        assert!((out.speed - 22.055480).abs() < 1e-6);
        // Too close to a standing lead: 4 m -> 1 m in 0.1 s at 30 m/s (rate -30, v_lead = 0):
        // g = -1.5, radicand = 20.25 + 4.5 (-3 - 30 + 0) = -128.25 < 0 -> v_safe = -4.5: stop,
        // speed 0 and accel (0 - 30) / 1 = -30.
        let mut c = gipps();
        c.step(Some(4.0), 30.0, 0.1);
        let out = c.step(Some(1.0), 30.0, 0.1);
        assert_eq!(c.terms().lead_speed, 0.0);
        assert_eq!((out.status, out.speed, out.accel), (Status::Ok, 0.0, -30.0));
    }

    #[test]
    fn no_lead_policies() {
        let mut c = gipps();
        // Cruise: v_free(10) = 10 + 6.5 (1 - 0.3) sqrt(0.325) = 10 + 6.5 * 0.7 * 0.570088 = 12.593899.
        let out = c.step(None, 10.0, 0.05);
        assert_eq!(out.status, Status::Ok);
        assert!((out.speed - 12.593899).abs() < 1e-6);
        assert!(!c.terms().lead);
        let mut c = GippsController::new(GippsParams { no_lead: NoLeadPolicy::Brake, ..GippsParams::default() }).unwrap();
        let out = c.step(None, 10.0, 0.05);
        assert_eq!((out.status, out.speed, out.accel), (Status::NoLead, 7.0, -3.0));
    }

    #[test]
    fn bad_inputs_give_safe_command_and_reset() {
        let mut c = gipps();
        c.step(Some(30.5), 20.0, 0.1);
        c.step(Some(30.0), 20.0, 0.1);
        assert_eq!(c.step(Some(f64::NAN), 20.0, 0.1).status, Status::InvalidDistance);
        assert!(!c.terms().lead);
        // The track was reset: the next frame has no rate.
        c.step(Some(29.0), 20.0, 0.1);
        assert_eq!(c.terms().range_rate, 0.0);
        assert_eq!(c.step(Some(30.0), 20.0, 0.0).status, Status::InvalidDt);
        assert_eq!(c.step(Some(-1.0), 20.0, 0.1).status, Status::InvalidDistance);
        assert_eq!(c.step(Some(1.0e9), 20.0, 0.1).status, Status::InvalidDistance);
        let out = c.step(Some(30.0), f64::NAN, 0.1);
        assert_eq!((out.status, out.speed), (Status::InvalidSpeed, 0.0));
        let out = c.step(Some(30.0), 20.0, -0.1);
        assert_eq!((out.status, out.speed, out.accel), (Status::InvalidDt, 17.0, -3.0));
        // Reversing slightly (v = -0.5 is plausible): finite.
        let out = c.step(Some(30.0), -0.5, 0.1);
        assert!(out.status.is_ok() && out.speed.is_finite() && out.accel.is_finite());
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: GippsParams| GippsController::new(p).unwrap_err().field;
        assert_eq!(bad(GippsParams { desired_speed: 0.0, ..Default::default() }), "desired_speed");
        assert_eq!(bad(GippsParams { accel: f64::NAN, ..Default::default() }), "accel");
        assert_eq!(bad(GippsParams { decel: -4.5, ..Default::default() }), "decel");
        assert_eq!(bad(GippsParams { lead_decel: 0.0, ..Default::default() }), "lead_decel");
        assert_eq!(bad(GippsParams { reaction_time: 0.0, ..Default::default() }), "reaction_time");
        assert_eq!(bad(GippsParams { min_gap: -1.0, ..Default::default() }), "min_gap");
        assert_eq!(bad(GippsParams { command_gain: 0.0, ..Default::default() }), "command_gain");
        let est = EstimatorParams { alpha: 0.0, ..EstimatorParams::default() };
        assert_eq!(bad(GippsParams { estimator: est, ..Default::default() }), "estimator.alpha");
        assert_eq!(GippsParams { decel: 0.0, ..Default::default() }.validate().unwrap_err().field, "decel");
        assert!(GippsParams::default().validate().is_ok());
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = gipps();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                prop_assert!(out.accel.is_finite());
                if !out.status.is_ok() { prop_assert!(out.accel < 0.0); }
            }
        }

        #[test]
        fn plausible_sequences_are_ok_and_below_the_free_speed(
            seq in proptest::collection::vec((proptest::option::of(0.0..200.0f64), 0.0..40.0f64, 0.01..0.2f64), 1..40)
        ) {
            let mut c = gipps();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert_eq!(out.status, Status::Ok);
                // Never faster than the free-flow branch (at most accel * tau * 2.5 * 0.4 * sqrt(0.425) above v).
                prop_assert!(out.speed <= c.params().free_speed(v) + 1e-12);
            }
        }
    }
}
