//! An ACC after Milanés & Shladover, with SUMO's mode structure and default gains.
//!
//! V. Milanés, S. E. Shladover, "Modeling cooperative and autonomous adaptive cruise control
//! dynamic responses using experimental data", *Transp. Res. Part C* 48, 285–300 (2014) (speed
//! control `a = k1 (v_des - v)`, gap control `a = k2 e + k3 (v_lead - v)` with `e = gap - t_hw v`),
//! and Milanés & Shladover, "Handling cut-in vehicles in strings of cooperative adaptive cruise
//! control vehicles", *J. Intell. Transp. Syst.* 20(2), 178–191 (2016); as implemented in Eclipse
//! SUMO's ACC car-following model (`src/microsim/cfmodels/MSCFModel_ACC.cpp`, user docs
//! "Car-Following-Models/ACC"), which adds the gap-closing and collision-avoidance modes of Xiao,
//! Wang & van Arem (*TRR* 2623, 2017) and the TransAID project. All numbers are SUMO's defaults:
//!
//! ```text
//! gap2pred = gap - min_gap                                   (SUMO's gaps exclude minGap)
//! mode:  gap2pred > 120 m -> speed control; gap2pred < 100 m -> gap control; else keep (hysteresis)
//! speed control       a = speed_control_gain * (v - v_des)              (gain -0.4)
//! gap control, with e = gap2pred - headway_time * v - margin(v), dv = v_lead - v,
//!   margin(v) = 2 m below 10.8 m/s, 75/v - 5 m to 15 m/s, 0 above (SUMO, after Xiao et al. 2018):
//!   |e| < 0.2 m and |v - v_des| < 0.1 m/s   gap   a = 0.07 dv + 0.23 e   (SUMO's test, on v_des)
//!   else e < 0                        collision avoid. a = 0.23 dv + 0.80 e
//!   else                              gap closing      a = 0.80 dv + 0.04 e
//! v_cmd = v + command_gain * a, capped at v_des (SUMO caps the next speed at the desired speed)
//! emergency override (MSCFModel_ACC::followSpeed): v_cmd = min(v_cmd, v_safe + 2 m/s)
//! ```
//!
//! `v_safe` is SUMO's `maximumSafeFollowSpeed` in SUMO's own discrete (Euler) form with the step
//! `command_gain`, including its emergency-deceleration correction ([`AccParams::safe_speed`]).
//! The acceleration is finally limited to `[-max_decel, max_accel]` (SUMO's `emergencyDecel` and
//! `accel` of the default passenger car). `v_lead` is the estimate of [`super::estimator`] (or the
//! measured lead speed with ideal perception). Checked step by step against SUMO 1.28's own ACC
//! (`crates/flc-sim/tests/sumo.rs`: at most 0.004 m/s per step on 12 scenarios).

use super::NoLeadPolicy;
use super::estimator::EstimatorParams;
use super::follower::{CarFollowingLaw, Demand, EstimatingFollower, LeadEstimate, follower_params};
use crate::command::clamp;
use crate::longitudinal::{Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// Parameters of the ACC. `Default`: SUMO's `MSCFModel_ACC` defaults and SUMO's default passenger
/// vehicle type, with the desired speed 130 km/h.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccParams {
    /// Desired (set) speed `v_des`, m/s. Default 130/3.6.
    pub desired_speed: f64,
    /// Desired time gap `t_hw` (SUMO: the vType's `tau`), s. SUMO default 1.0.
    pub headway_time: f64,
    /// Standstill gap excluded from the controlled gap (SUMO `minGap`), m. SUMO default 2.5.
    pub min_gap: f64,
    /// Speed-control gain on `v - v_des` (SUMO `speedControlGain`, its sign), 1/s. SUMO: -0.4.
    pub speed_control_gain: f64,
    /// Gap-closing gain on `v_lead - v` (SUMO `gapClosingControlGainSpeed`), 1/s. SUMO: 0.8.
    pub gap_closing_gain_speed: f64,
    /// Gap-closing gain on the spacing error (SUMO `gapClosingControlGainSpace`), 1/s². SUMO: 0.04.
    pub gap_closing_gain_space: f64,
    /// Gap-control gain on `v_lead - v` (SUMO `gapControlGainSpeed`), 1/s. SUMO: 0.07.
    pub gap_gain_speed: f64,
    /// Gap-control gain on the spacing error (SUMO `gapControlGainSpace`), 1/s². SUMO: 0.23.
    pub gap_gain_space: f64,
    /// Collision-avoidance gain on `v_lead - v` (SUMO `collisionAvoidanceGainSpeed`), 1/s. SUMO: 0.23.
    pub collision_avoidance_gain_speed: f64,
    /// Collision-avoidance gain on the spacing error (SUMO `collisionAvoidanceGainSpace`), 1/s².
    /// SUMO: 0.8.
    pub collision_avoidance_gain_space: f64,
    /// Gap above which speed control takes over (SUMO `GAP_THRESHOLD_SPEEDCTRL`), m. SUMO: 120.
    pub speed_control_gap: f64,
    /// Gap below which gap control takes over (SUMO `GAP_THRESHOLD_GAPCTRL`), m. SUMO: 100.
    pub gap_control_gap: f64,
    /// Gap mode only within this spacing error, m. SUMO: 0.2.
    pub gap_mode_spacing: f64,
    /// Gap mode only within this speed difference, m/s. SUMO: 0.1.
    pub gap_mode_speed: f64,
    /// Apply SUMO's safe-speed override (`vSafe + 2 m/s`). Default `true` (SUMO always does).
    pub emergency_override: bool,
    /// Margin of the override above `v_safe` (SUMO `DEFAULT_EMERGENCY_OVERRIDE_THRESHOLD`), m/s. 2.0.
    pub override_threshold: f64,
    /// Own deceleration `b` of the safe speed (SUMO vType `decel`), m/s². SUMO passenger: 4.5.
    pub decel: f64,
    /// Assumed lead deceleration `b_lead` (SUMO: the leader's `apparentDecel` = `decel`), m/s². 4.5.
    pub lead_decel: f64,
    /// Acceleration limit (SUMO vType `accel`), m/s². SUMO passenger: 2.6.
    pub max_accel: f64,
    /// Braking limit (SUMO vType `emergencyDecel`), m/s². SUMO passenger: 9.0.
    pub max_decel: f64,
    /// What to do without a lead. Default [`NoLeadPolicy::Cruise`] (speed control).
    pub no_lead: NoLeadPolicy,
    /// The range-rate filter.
    pub estimator: EstimatorParams,
    /// `v_cmd = v + command_gain * a`, s. Default 1 (SUMO's default step length).
    pub command_gain: f64,
    /// Highest plausible own speed and highest speed command, m/s. Default 70.
    pub max_speed: f64,
    /// Highest plausible distance, m. Default 500.
    pub max_distance: f64,
    /// Safe command on invalid input: `v_cmd = v - fault_brake_step`, m/s. Default 3.
    pub fault_brake_step: f64,
}

impl Default for AccParams {
    fn default() -> Self {
        Self::sumo()
    }
}

impl AccParams {
    /// SUMO's defaults (identical to `Default`).
    pub const fn sumo() -> Self {
        Self {
            desired_speed: 130.0 / 3.6,
            headway_time: 1.0,
            min_gap: 2.5,
            speed_control_gain: -0.4,
            gap_closing_gain_speed: 0.8,
            gap_closing_gain_space: 0.04,
            gap_gain_speed: 0.07,
            gap_gain_space: 0.23,
            collision_avoidance_gain_speed: 0.23,
            collision_avoidance_gain_space: 0.8,
            speed_control_gap: 120.0,
            gap_control_gap: 100.0,
            gap_mode_spacing: 0.2,
            gap_mode_speed: 0.1,
            emergency_override: true,
            override_threshold: 2.0,
            decel: 4.5,
            lead_decel: 4.5,
            max_accel: 2.6,
            max_decel: 9.0,
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
        const GAIN: &str = "must be finite and in [0, 100]";
        check_positive("desired_speed", self.desired_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_range("headway_time", self.headway_time, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_range("min_gap", self.min_gap, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_range("speed_control_gain", self.speed_control_gain, -100.0, 0.0, "must be finite and in [-100, 0] (SUMO's sign)")?;
        check_range("gap_closing_gain_speed", self.gap_closing_gain_speed, 0.0, 100.0, GAIN)?;
        check_range("gap_closing_gain_space", self.gap_closing_gain_space, 0.0, 100.0, GAIN)?;
        check_range("gap_gain_speed", self.gap_gain_speed, 0.0, 100.0, GAIN)?;
        check_range("gap_gain_space", self.gap_gain_space, 0.0, 100.0, GAIN)?;
        check_range("collision_avoidance_gain_speed", self.collision_avoidance_gain_speed, 0.0, 100.0, GAIN)?;
        check_range("collision_avoidance_gain_space", self.collision_avoidance_gain_space, 0.0, 100.0, GAIN)?;
        check_range("speed_control_gap", self.speed_control_gap, 0.0, 1.0e6, "must be finite and in [0, 1e6] m")?;
        check_range(
            "gap_control_gap",
            self.gap_control_gap,
            0.0,
            self.speed_control_gap,
            "must be finite and in [0, speed_control_gap] m",
        )?;
        check_range("gap_mode_spacing", self.gap_mode_spacing, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_range("gap_mode_speed", self.gap_mode_speed, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        check_range("override_threshold", self.override_threshold, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        check_positive("decel", self.decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_positive("lead_decel", self.lead_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_positive("max_accel", self.max_accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("max_decel", self.max_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        Ok(())
    }

    /// Speed-control law `speed_control_gain * (v - v_des)`, m/s².
    pub fn speed_control_accel(&self, own_speed: f64) -> f64 {
        self.speed_control_gain * (own_speed - self.desired_speed)
    }

    /// SUMO's dynamic gap margin (after Xiao et al. 2018), added to the spacing SUMO's gap control
    /// keeps: 2 m below 10.8 m/s, `75 / v - 5` m from 10.8 to 15 m/s, 0 above.
    pub fn dynamic_margin(own_speed: f64) -> f64 {
        if own_speed < 10.8 {
            2.0
        } else if own_speed <= 15.0 {
            75.0 / own_speed - 5.0
        } else {
            0.0
        }
    }

    /// Gap-control law (gap / collision-avoidance / gap-closing) for the bumper gap `gap`, as
    /// SUMO's `MSCFModel_ACC::accelGapControl`: returns the sub-mode, the spacing error
    /// `e = gap - min_gap - headway_time v - margin(v)` ([`Self::dynamic_margin`])
    /// and the acceleration. The gap mode applies when `|e| < gap_mode_spacing` and the speed error
    /// `|v - desired_speed| < gap_mode_speed` (SUMO tests its own speed against the desired speed
    /// there, not the lead's).
    pub fn gap_control_accel(&self, gap: f64, own_speed: f64, lead_speed: f64) -> (AccMode, f64, f64) {
        let e = gap - self.min_gap - self.headway_time * own_speed - Self::dynamic_margin(own_speed);
        let dv = lead_speed - own_speed;
        if e.abs() < self.gap_mode_spacing && (own_speed - self.desired_speed).abs() < self.gap_mode_speed {
            (AccMode::Gap, e, self.gap_gain_speed * dv + self.gap_gain_space * e)
        } else if e < 0.0 {
            (AccMode::CollisionAvoidance, e, self.collision_avoidance_gain_speed * dv + self.collision_avoidance_gain_space * e)
        } else {
            (AccMode::GapClosing, e, self.gap_closing_gain_speed * dv + self.gap_closing_gain_space * e)
        }
    }

    /// SUMO's safe follow speed (`MSCFModel::maximumSafeFollowSpeed`, Euler update) for the
    /// bumper gap `gap`, own speed `v` and lead speed `v_lead`, m/s, with the step `command_gain`:
    /// 1. the lead's braking distance, braking at `max(decel, lead_decel)` step by step, is added
    ///    to the controlled gap `gap - min_gap` (`brakeGap`);
    /// 2. the result is the highest speed that stops within it, after a reaction of `headway_time`,
    ///    braking `decel dt` per step (`maximumSafeStopSpeedEuler`);
    /// 3. if that speed needs more than `decel`, the deceleration is replaced by 1.2 times the
    ///    emergency deceleration that just avoids the lead (never below `decel`, never above the
    ///    original request; `calculateEmergencyDeceleration`).
    pub fn safe_speed(&self, gap: f64, own_speed: f64, lead_speed: f64) -> f64 {
        let dt = self.command_gain;
        let gap2pred = gap - self.min_gap;
        let vl = lead_speed.max(0.0);
        // 1. The lead's braking distance, step by step.
        let reduction = self.decel.max(self.lead_decel) * dt;
        let steps = libm::floor(vl / reduction);
        let lead_brake = dt * (steps * vl - reduction * steps * (steps + 1.0) / 2.0);
        // 2. Stop within g: n full braking steps of b = decel dt after a reaction of t = headway.
        let g = gap2pred + lead_brake - 0.001;
        let mut x = if g <= 0.0 {
            0.0
        } else {
            let (b, t) = (self.decel * dt, self.headway_time);
            let n = libm::floor(0.5 - (t - 0.5 * libm::sqrt(dt * dt + 4.0 * (dt * (2.0 * g / b - t) + t * t))) / dt);
            let h = 0.5 * n * (n - 1.0) * b * dt + n * b * t;
            n * b + (g - h) / (n * dt + t)
        };
        // 3. The emergency correction when more than `decel` is needed.
        if self.decel != self.max_decel {
            let requested = (own_speed - x) / dt;
            if requested > self.decel + 0.001 {
                let b1 = 0.5 * own_speed * own_speed / (gap2pred + 0.5 * vl * vl / self.lead_decel);
                let emergency = if b1 <= self.lead_decel {
                    b1
                } else if gap2pred <= 0.0 {
                    -self.max_decel * dt
                } else {
                    0.5 * (own_speed * own_speed - vl * vl) / gap2pred
                };
                let decel = (1.2 * emergency).max(self.decel).min(requested);
                x = (own_speed - decel * dt).max(0.0);
            }
        }
        x
    }
}

/// The ACC's active law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum AccMode {
    /// Speed (cruise) control.
    #[default]
    Speed,
    /// Gap-closing control.
    GapClosing,
    /// Gap (time-gap keeping) control.
    Gap,
    /// Collision-avoidance control.
    CollisionAvoidance,
}

/// The terms of the last ACC step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AccTerms {
    /// A lead was used this step.
    pub lead: bool,
    /// Measured bumper gap, m.
    pub gap: f64,
    /// Estimated range rate, m/s.
    pub range_rate: f64,
    /// Estimated lead speed, m/s.
    pub lead_speed: f64,
    /// Active law.
    pub mode: AccMode,
    /// Spacing error `gap - min_gap - headway_time * v`, m (0 in speed control).
    pub spacing_error: f64,
    /// The law's acceleration before the cap, override and limits, m/s².
    pub law_accel: f64,
    /// Safe speed `v_safe` (0 without a lead), m/s.
    pub safe_speed: f64,
    /// The emergency override set the command.
    pub overridden: bool,
    /// Output acceleration, m/s².
    pub accel: f64,
}

/// The ACC follower: the ACC's equations under [`EstimatingFollower`].
///
/// ```
/// use flc_core::baselines::{AccController, AccParams};
/// use flc_core::{Frame, LongitudinalController};
///
/// let mut acc = AccController::new(AccParams::default())?;
/// let out = LongitudinalController::step(&mut acc, &Frame::new(Some(30.0), 20.0, 0.05));
/// // Gap control (gap2pred = 27.5 < 100 m), e = 30 - 2.5 - 1.0 * 20 = 7.5 > 0.2, lead speed = own
/// // speed on the first frame: gap closing a = 0.8 * 0 + 0.04 * 7.5 = 0.3.
/// assert!((out.command.accel - 0.3).abs() < 1e-12);
/// // min_gap + headway_time v + margin(v) = 2.5 + 20 + 0 (no margin above 15 m/s).
/// assert_eq!(acc.desired_gap(20.0), 22.5);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
pub type AccController = EstimatingFollower<Acc>;

/// The ACC's equations ([`CarFollowingLaw`]); the state is SUMO's control mode.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Acc {
    /// SUMO's `ACC_ControlMode`: `true` = gap control (kept between the two thresholds). Starts
    /// in speed control, as SUMO.
    pub gap_control: bool,
}

follower_params!(AccParams, Acc);

impl AccTerms {
    /// The names of [`AccTerms::to_terms`], in field order (`mode` as its [`AccMode`] discriminant).
    pub const NAMES: &'static [&'static str] =
        &["lead", "gap", "range_rate", "lead_speed", "mode", "spacing_error", "law_accel", "safe_speed", "overridden", "accel"];

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
                f64::from(t.mode as u8),
                t.spacing_error,
                t.law_accel,
                t.safe_speed,
                flag(t.overridden),
                t.accel,
            ],
        )
    }
}

impl CarFollowingLaw for Acc {
    type Params = AccParams;
    type Terms = AccTerms;

    fn validate(p: &AccParams) -> Result<(), ParamError> {
        p.validate_law()
    }

    /// Mode hysteresis, the mode's law, the cap at `v_des`, the emergency override, the limits.
    fn follow(&mut self, p: &AccParams, lead: &LeadEstimate, own_speed: f64) -> (Demand, AccTerms) {
        let cap = (p.desired_speed - own_speed) / p.command_gain;
        let gap = lead.gap;
        let mut t = AccTerms { lead: true, gap, range_rate: lead.range_rate, lead_speed: lead.lead_speed, ..AccTerms::default() };
        let gap2pred = gap - p.min_gap;
        if gap2pred > p.speed_control_gap {
            self.gap_control = false;
        } else if gap2pred < p.gap_control_gap {
            self.gap_control = true;
        }
        if self.gap_control {
            (t.mode, t.spacing_error, t.law_accel) = p.gap_control_accel(gap, own_speed, t.lead_speed);
        } else {
            t.mode = AccMode::Speed;
            t.law_accel = p.speed_control_accel(own_speed);
        }
        let mut accel = t.law_accel.min(cap);
        t.safe_speed = p.safe_speed(gap, own_speed, t.lead_speed);
        if p.emergency_override && t.safe_speed + p.override_threshold < own_speed + p.command_gain * accel {
            t.overridden = true;
            accel = (t.safe_speed + p.override_threshold - own_speed) / p.command_gain;
        }
        t.accel = clamp(accel, -p.max_decel, p.max_accel);
        (Demand::Accel(t.accel), t)
    }

    /// Nothing in range: SUMO's speed control (the mode memory is kept, as SUMO does).
    fn free_road(&mut self, p: &AccParams, own_speed: f64) -> (Demand, AccTerms) {
        let cap = (p.desired_speed - own_speed) / p.command_gain;
        let law_accel = p.speed_control_accel(own_speed);
        let accel = clamp(law_accel.min(cap), -p.max_decel, p.max_accel);
        (Demand::Accel(accel), AccTerms { law_accel, accel, ..AccTerms::default() })
    }

    /// `min_gap + headway_time v + margin(v)`: where the gap-control law is at rest (spacing
    /// error 0) behind a lead at the same speed.
    fn desired_gap(p: &AccParams, v: f64) -> f64 {
        p.min_gap + p.headway_time * v + AccParams::dynamic_margin(v)
    }

    fn terms(t: &AccTerms) -> Terms {
        t.to_terms()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{LongitudinalCommand, Status};
    use proptest::prelude::*;

    fn acc() -> AccController {
        AccController::new(AccParams::default()).unwrap()
    }

    /// Two frames 0.1 s apart so that the estimate is `lead_speed` at the second frame `gap`.
    fn two_frames(c: &mut AccController, gap: f64, own: f64, lead: f64) -> LongitudinalCommand {
        c.step(Some(gap - (lead - own) * 0.1), own, 0.1);
        c.step(Some(gap), own, 0.1)
    }

    #[test]
    fn gap_closing_by_hand() {
        let mut c = acc();
        // v = 20, v_lead = 18, gap 40: gap2pred = 37.5 < 100 -> gap control.
        // e = 37.5 - 1.0 * 20 = 17.5 >= 0.2 -> gap closing: 0.8 * (-2) + 0.04 * 17.5 = -0.9.
        // v_safe (SUMO's Euler form, step 1 s): the lead brakes 4.5 per step, floor(18 / 4.5) = 4
        // steps, 4 * 18 - 4.5 * 4 * 5 / 2 = 27 m; g = 37.5 + 27 - 0.001 = 64.499; n = 4 braking
        // steps, h = 0.5 * 4 * 3 * 4.5 + 4 * 4.5 * 1 = 45; v_safe = 4 * 4.5 + (64.499 - 45) / 5
        // = 21.8998; +2 = 23.90 > 19.1 -> no override.
        let out = two_frames(&mut c, 40.0, 20.0, 18.0);
        let t = *c.terms();
        assert_eq!(t.mode, AccMode::GapClosing);
        assert!((t.spacing_error - 17.5).abs() < 1e-9);
        assert!((out.accel + 0.9).abs() < 1e-9);
        assert!((out.speed - 19.1).abs() < 1e-9);
        assert!((t.safe_speed - 21.8998).abs() < 1e-9);
        assert!(!t.overridden);
    }

    #[test]
    fn collision_avoidance_by_hand() {
        let mut c = acc();
        // v = v_lead = 20, gap 15: e = 12.5 - 20 = -7.5 < 0 -> CA: 0.23 * 0 + 0.8 * (-7.5) = -6.
        // v_safe: lead 4 steps, 4 * 20 - 45 = 35 m; g = 12.5 + 35 - 0.001 = 47.499; n = 4, h = 45;
        // v_safe = 18 + 2.499 / 5 = 18.4998; +2 = 20.50 > 14 -> no override. Command 20 - 6 = 14.
        let out = two_frames(&mut c, 15.0, 20.0, 20.0);
        assert_eq!(c.terms().mode, AccMode::CollisionAvoidance);
        assert!((out.accel + 6.0).abs() < 1e-9);
        assert!((out.speed - 14.0).abs() < 1e-9);
        assert!((c.terms().safe_speed - 18.4998).abs() < 1e-9);
    }

    #[test]
    fn gap_mode_by_hand() {
        // SUMO's gap mode: |e| < 0.2 and the own speed within 0.1 of the desired speed.
        let p = AccParams { desired_speed: 20.0, ..AccParams::default() };
        // v = v_lead = 20, gap = 2.5 + 20 + 0.1 (margin 0 above 15 m/s): e = 0.1 -> gap mode:
        // 0.07 * 0 + 0.23 * 0.1 = 0.023.
        let (mode, e, a) = p.gap_control_accel(22.6, 20.0, 20.0);
        assert_eq!(mode, AccMode::Gap);
        assert!((e - 0.1).abs() < 1e-9 && (a - 0.023).abs() < 1e-9);
        // The lead 0.5 faster: still gap mode (SUMO looks at v - v_des): 0.07 * 0.5 + 0.023 = 0.058.
        let (mode, _, a) = p.gap_control_accel(22.6, 20.0, 20.5);
        assert_eq!(mode, AccMode::Gap);
        assert!((a - 0.058).abs() < 1e-9);
        // Set speed 130 km/h, far from v: gap closing, 0.8 * 0.5 + 0.04 * 0.1 = 0.404.
        let (mode, _, a) = AccParams::default().gap_control_accel(22.6, 20.0, 20.5);
        assert_eq!(mode, AccMode::GapClosing);
        assert!((a - 0.404).abs() < 1e-9);
        // The dynamic margin (Xiao et al. 2018, as in SUMO): 2 m below 10.8 m/s, 75/v - 5 to 15 m/s.
        assert_eq!(AccParams::dynamic_margin(10.0), 2.0);
        assert!((AccParams::dynamic_margin(12.5) - 1.0).abs() < 1e-12);
        assert_eq!(AccParams::dynamic_margin(15.1), 0.0);
    }

    #[test]
    fn speed_control_hysteresis_and_override_by_hand() {
        let mut c = acc();
        // gap 112.5: gap2pred = 110, between 100 and 120 -> keeps the initial speed control:
        // a = -0.4 * (36 - 36.111111) = 0.044444, command 36.044444.
        // Lead at standstill (estimated from the two frames): g = 110 - 0.001; n = 6 steps of 4.5,
        // h = 0.5 * 6 * 5 * 4.5 + 6 * 4.5 = 94.5; x = 27 + (109.999 - 94.5) / 7 = 29.214143, a
        // request of 6.785857 > 4.5 -> emergency: b2 = 0.5 * 36^2 / 110 = 5.890909 (> 4.5), 1.2 b2
        // = 7.069, limited to the request 6.785857: v_safe = 29.214143; +2 = 31.214143 < 36.044
        // -> override: v_cmd = 31.214143, a = -4.785857.
        let out = two_frames(&mut c, 112.5, 36.0, 0.0);
        let t = *c.terms();
        assert_eq!(t.mode, AccMode::Speed);
        assert!((t.law_accel - 0.4 * (130.0 / 3.6 - 36.0)).abs() < 1e-9);
        assert!(t.overridden);
        assert!((out.speed - 31.214143).abs() < 1e-6);
        assert!((out.accel + 4.785857).abs() < 1e-6);
        // Below 100 m gap2pred -> gap control, and it stays so back in the band.
        c.step(Some(95.0), 20.0, 0.1);
        assert_ne!(c.terms().mode, AccMode::Speed);
        c.step(Some(112.5), 20.0, 0.1);
        assert_ne!(c.terms().mode, AccMode::Speed);
        c.step(Some(125.0), 20.0, 0.1);
        assert_eq!(c.terms().mode, AccMode::Speed);
    }

    #[test]
    fn desired_speed_caps_the_command() {
        let mut c = acc();
        // Lead much faster and far (gap closing would give 0.8 * 10 + 0.04 * 57.5 = 10.3), own speed
        // 35: the command is capped at v_des = 36.111 -> a = 1.111 (< max_accel 2.6).
        let out = two_frames(&mut c, 95.0, 35.0, 45.0);
        assert!((out.speed - 130.0 / 3.6).abs() < 1e-9);
        // Limits: far below v_des with a faster lead -> max_accel.
        let mut c = acc();
        let out = two_frames(&mut c, 60.0, 10.0, 20.0);
        assert_eq!(out.accel, 2.6);
    }

    #[test]
    fn no_lead_and_bad_inputs() {
        let mut c = acc();
        // Speed control: -0.4 * (20 - 36.111111) = 6.444444, limited to 2.6.
        let out = c.step(None, 20.0, 0.05);
        assert_eq!((out.status, out.accel), (Status::Ok, 2.6));
        let mut c = AccController::new(AccParams { no_lead: NoLeadPolicy::Brake, ..AccParams::default() }).unwrap();
        assert_eq!(c.step(None, 20.0, 0.05).status, Status::NoLead);
        assert_eq!(c.step(Some(30.0), 20.0, f64::NAN).status, Status::InvalidDt);
        assert_eq!(c.step(Some(f64::INFINITY), 20.0, 0.05).status, Status::InvalidDistance);
        let out = c.step(Some(30.0), 80.0, 0.05);
        assert_eq!((out.status, out.speed), (Status::InvalidSpeed, 0.0));
        assert_eq!(c.step(Some(30.0), 20.0, 0.05).speed, 20.0 + 1.0 * c.terms().accel);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: AccParams| AccController::new(p).unwrap_err().field;
        assert_eq!(bad(AccParams { speed_control_gain: 0.4, ..Default::default() }), "speed_control_gain");
        assert_eq!(bad(AccParams { gap_control_gap: 130.0, ..Default::default() }), "gap_control_gap");
        assert_eq!(bad(AccParams { collision_avoidance_gain_space: f64::NAN, ..Default::default() }), "collision_avoidance_gain_space");
        assert_eq!(bad(AccParams { decel: 0.0, ..Default::default() }), "decel");
        let est = EstimatorParams { alpha: 0.0, ..EstimatorParams::default() };
        assert_eq!(bad(AccParams { estimator: est, ..Default::default() }), "estimator.alpha");
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = acc();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                prop_assert!(out.accel.is_finite() && (-9.0..=3.0).contains(&out.accel));
            }
        }
    }
}
