//! The fallback longitudinal controller (FLC) of Sec. III-B, Eqs. (2)-(5).
//!
//! Inputs per frame: the LiDAR distance to the lead `LF_dist` (from the [`crate::detector`]) and the
//! follower's own speed `S_F`. Nothing else: no timestamp, no `dt`, no lead speed, no V2V. The only
//! state is the previous frame's distance `D_{s-1}`, needed for `Delta_d`.
//!
//! Per frame ([`FallbackController::step`]):
//!
//! ```text
//! (2)  tau_D   = T_G * S_F
//!      D_d     = tau_D + B_gap
//!      Delta_d = D_s - D_{s-1}
//! (3)  Scale_f = min(0.4, 0.1 * S_F / C)
//! (4)  F_shift = max(0, S_F) * Scale_f
//!      dist_s  = LF_dist - D_d - F_shift
//! (5)  a = dist_s * (1   - cos(pi * dist_s / bound_t))   if Delta_d >  -0.3
//!      a = dist_s * (1.5 - cos(pi * dist_s / bound_t))   if Delta_d <= -0.3   (dist_s overridden to -3)
//!      a = a * multiplier                                 if a < 0
//!      speed command = S_F + command_gain * a             ("incorporated into the current speed")
//! ```
//!
//! The choices the paper leaves open are the named fields of [`FlcParams`]; each is discussed in
//! `docs/paper-notes.md`.

use crate::command::{LongitudinalCommand, Status, clamp, safe_brake, valid_speed};
use crate::longitudinal::ActiveController;
use crate::longitudinal::{ControlOutput, Frame, LongitudinalController, Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// How the "`dist_s` is overridden to be -3" rule of Sec. III-B is applied in the fast-braking
/// branch (`Delta_d <= brake_threshold`). The paper states the value, not the form.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DistOverride {
    /// `dist_s = min(dist_s, override_dist)`: never weakens braking when the gap is already far
    /// below the desired one. Default (see `docs/paper-notes.md`).
    Min,
    /// `dist_s = override_dist` whatever it was (the most literal reading).
    Replace,
    /// No override.
    Off,
}

/// What `Delta_d` is on a frame without a usable previous distance (the very first frame, or the
/// first valid frame after a missing / invalid distance). The paper does not say.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FirstFrame {
    /// `Delta_d = 0`: the normal (shift 1) branch. Default.
    Steady,
    /// Take the fast-braking branch (shift 1.5 plus the override) until two frames are available.
    Braking,
}

/// Parameters of the FLC. `Default` is the paper's configuration (Sec. IV) plus the documented
/// choices for what the paper leaves open.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcParams {
    /// `T_G`, time gap of the dynamic threshold `tau_D = T_G * S_F`, s. Paper: 1.0.
    pub time_gap: f64,
    /// `B_gap`, base desired gap, m. Paper: 6.0.
    pub base_gap: f64,
    /// `C`, speed constant of `Scale_f`, m/s. Paper: 5/3.6 (5 km/h).
    pub c: f64,
    /// Gain of `Scale_f = min(scale_cap, scale_gain * S_F / C)`. Paper: 0.1.
    pub scale_gain: f64,
    /// Cap of `Scale_f`. Paper: 0.4.
    pub scale_cap: f64,
    /// `bound_t`, half-period of the truncated cosine, m. Paper: 11.
    pub bound_t: f64,
    /// `Delta_d` at or below which the fast-braking branch applies, m per frame. Paper: -0.3.
    pub brake_threshold: f64,
    /// Shift of the cosine law in the normal branch. Paper: 1.
    pub shift_normal: f64,
    /// Shift of the cosine law in the fast-braking branch. Paper: 1.5.
    pub shift_brake: f64,
    /// Value `dist_s` is overridden to in the fast-braking branch, m. Paper: -3.
    pub override_dist: f64,
    /// How the override applies (paper silent on the form). Default [`DistOverride::Min`].
    pub dist_override: DistOverride,
    /// Multiplier on negative `a` (paper: "a multiplier further scales the negative
    /// acceleration", value not given). Default 2.0.
    pub negative_multiplier: f64,
    /// Clip `dist_s` to `[-bound_t, +bound_t]` before Eq. (5) (paper silent; without it the
    /// cosine law falls back to zero beyond `bound_t`). Default `true`.
    pub clip_dist_s: bool,
    /// How `a` becomes the speed command: `v_cmd = S_F + command_gain * a`, s. Paper: "incorporated
    /// into the current speed", i.e. 1.0.
    pub command_gain: f64,
    /// `Delta_d` when no previous distance exists. Default [`FirstFrame::Steady`].
    pub first_frame: FirstFrame,
    /// Highest plausible own speed and highest speed command, m/s. Default 70 (252 km/h).
    pub max_speed: f64,
    /// Highest plausible distance, m; larger distances are treated as invalid. Default 500.
    pub max_distance: f64,
    /// Safe command on a missing or invalid input: `v_cmd = S_F - fault_brake_step`, m/s.
    /// Default 3.0 (the speed error the paper's override produces, `|(-3)(1.5-cos(3pi/11))|`~2.5,
    /// rounded up).
    pub fault_brake_step: f64,
}

impl Default for FlcParams {
    fn default() -> Self {
        Self::paper()
    }
}

impl FlcParams {
    /// The paper's parameters (identical to `Default`).
    pub const fn paper() -> Self {
        Self {
            time_gap: 1.0,
            base_gap: 6.0,
            c: 5.0 / 3.6,
            scale_gain: 0.1,
            scale_cap: 0.4,
            bound_t: 11.0,
            brake_threshold: -0.3,
            shift_normal: 1.0,
            shift_brake: 1.5,
            override_dist: -3.0,
            dist_override: DistOverride::Min,
            negative_multiplier: 2.0,
            clip_dist_s: true,
            command_gain: 1.0,
            first_frame: FirstFrame::Steady,
            max_speed: 70.0,
            max_distance: 500.0,
            fault_brake_step: 3.0,
        }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("time_gap", self.time_gap, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_range("base_gap", self.base_gap, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_positive("c", self.c, 100.0, "must be finite and in (0, 100] m/s")?;
        check_range("scale_gain", self.scale_gain, 0.0, 10.0, "must be finite and in [0, 10]")?;
        check_range("scale_cap", self.scale_cap, 0.0, 10.0, "must be finite and in [0, 10]")?;
        check_positive("bound_t", self.bound_t, 1000.0, "must be finite and in (0, 1000] m")?;
        check_range("brake_threshold", self.brake_threshold, -100.0, 0.0, "must be finite and in [-100, 0] m")?;
        check_range("shift_normal", self.shift_normal, 0.0, 10.0, "must be finite and in [0, 10]")?;
        check_range("shift_brake", self.shift_brake, 0.0, 10.0, "must be finite and in [0, 10]")?;
        check_range("override_dist", self.override_dist, -1000.0, 0.0, "must be finite and in [-1000, 0] m")?;
        check_range("negative_multiplier", self.negative_multiplier, 0.0, 100.0, "must be finite and in [0, 100]")?;
        check_positive("command_gain", self.command_gain, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("max_speed", self.max_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_positive("max_distance", self.max_distance, 1.0e6, "must be finite and in (0, 1e6] m")?;
        check_range("fault_brake_step", self.fault_brake_step, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        Ok(())
    }

    /// Eq. (2): desired distance `D_d = T_G * S_F + B_gap`, m.
    pub fn desired_distance(&self, own_speed: f64) -> f64 {
        desired_distance(self.time_gap, self.base_gap, own_speed)
    }

    /// Eqs. (3)-(4): speed-dependent extra distance `F_shift = max(0, S_F) * Scale_f`, m.
    pub fn f_shift(&self, own_speed: f64) -> f64 {
        f_shift(self.scale_gain, self.scale_cap, self.c, own_speed)
    }
}

/// Eq. (2): `D_d = T_G * S_F + B_gap`.
pub fn desired_distance(time_gap: f64, base_gap: f64, own_speed: f64) -> f64 {
    time_gap * own_speed + base_gap
}

/// Eq. (3): `Scale_f = min(cap, gain * S_F / C)`.
pub fn scale_factor(gain: f64, cap: f64, c: f64, own_speed: f64) -> f64 {
    (gain * own_speed / c).min(cap)
}

/// Eq. (4), first line: `F_shift = max(0, S_F) * Scale_f`.
pub fn f_shift(gain: f64, cap: f64, c: f64, own_speed: f64) -> f64 {
    own_speed.max(0.0) * scale_factor(gain, cap, c, own_speed)
}

/// Eq. (5) without branch selection: the truncated-cosine law `dist_s * (shift - cos(pi * dist_s / bound_t))`.
pub fn truncated_cosine(dist_s: f64, shift: f64, bound_t: f64) -> f64 {
    dist_s * (shift - libm::cos(core::f64::consts::PI * dist_s / bound_t))
}

/// The intermediate terms of the last FLC step, for logging, plots and tests.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FlcTerms {
    /// `tau_D = T_G * S_F`, m.
    pub tau_d: f64,
    /// `D_d`, m.
    pub d_d: f64,
    /// `Scale_f`.
    pub scale_f: f64,
    /// `F_shift`, m.
    pub f_shift: f64,
    /// `Delta_d = D_s - D_{s-1}`, m per frame (0 on a first frame with [`FirstFrame::Steady`]).
    pub delta_d: f64,
    /// `dist_s` before clipping and override, m.
    pub dist_s_raw: f64,
    /// `dist_s` as used in Eq. (5), m.
    pub dist_s: f64,
    /// `true` when the fast-braking branch (`Delta_d <= threshold`) was taken.
    pub braking_branch: bool,
    /// `true` when the override changed `dist_s`.
    pub overridden: bool,
    /// `a` of Eq. (5) before the negative multiplier.
    pub a_law: f64,
    /// `a` after the negative multiplier.
    pub a: f64,
}

/// The FLC. Construct with [`FallbackController::new`], call [`FallbackController::step`] once per
/// LiDAR frame.
#[derive(Debug, Clone)]
pub struct FallbackController {
    params: FlcParams,
    prev_distance: Option<f64>,
    terms: FlcTerms,
}

impl FallbackController {
    /// Validates `params` and builds the controller.
    pub fn new(params: FlcParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params, prev_distance: None, terms: FlcTerms::default() })
    }

    /// The parameters in use.
    pub fn params(&self) -> &FlcParams {
        &self.params
    }

    /// Forgets the previous distance; the next frame is a first frame.
    pub fn reset(&mut self) {
        self.prev_distance = None;
        self.terms = FlcTerms::default();
    }

    /// The terms of the last step (all zero before the first step or after a fault).
    pub fn terms(&self) -> &FlcTerms {
        &self.terms
    }

    /// One frame of the FLC. `distance` is `LF_dist` in m (`None` when the detector found no lead);
    /// `own_speed` is `S_F` in m/s. No timestamp and no `dt`: the output depends only on the
    /// sequence of inputs, whatever rate produced them.
    ///
    /// On a missing or invalid input the controller brakes (status says why) and forgets its
    /// previous distance.
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64) -> LongitudinalCommand {
        let p = &self.params;
        let speed_ok = valid_speed(own_speed, p.max_speed);
        let status = match distance {
            _ if !speed_ok => Status::InvalidSpeed,
            None => Status::NoLead,
            Some(d) if !(d.is_finite() && d >= 0.0 && d <= p.max_distance) => Status::InvalidDistance,
            Some(_) => Status::Ok,
        };
        let (Status::Ok, Some(d)) = (status, distance) else {
            self.prev_distance = None;
            self.terms = FlcTerms::default();
            return safe_brake(own_speed, speed_ok, p.fault_brake_step, status);
        };

        // Eq. (2)
        let tau_d = p.time_gap * own_speed;
        let d_d = tau_d + p.base_gap;
        let delta_d = match self.prev_distance {
            Some(prev) => d - prev,
            None => match p.first_frame {
                FirstFrame::Steady => 0.0,
                FirstFrame::Braking => p.brake_threshold,
            },
        };
        self.prev_distance = Some(d);
        // Eqs. (3)-(4)
        let scale_f = scale_factor(p.scale_gain, p.scale_cap, p.c, own_speed);
        let f_shift = own_speed.max(0.0) * scale_f;
        let dist_s_raw = d - d_d - f_shift;
        let mut dist_s = if p.clip_dist_s { clamp(dist_s_raw, -p.bound_t, p.bound_t) } else { dist_s_raw };
        // Eq. (5)
        let braking_branch = delta_d <= p.brake_threshold;
        let mut overridden = false;
        let shift = if braking_branch {
            let o = match p.dist_override {
                DistOverride::Min => dist_s.min(p.override_dist),
                DistOverride::Replace => p.override_dist,
                DistOverride::Off => dist_s,
            };
            overridden = o != dist_s;
            dist_s = o;
            p.shift_brake
        } else {
            p.shift_normal
        };
        let a_law = truncated_cosine(dist_s, shift, p.bound_t);
        let a = if a_law < 0.0 { a_law * p.negative_multiplier } else { a_law };
        let speed = clamp(own_speed + p.command_gain * a, 0.0, p.max_speed);
        self.terms = FlcTerms { tau_d, d_d, scale_f, f_shift, delta_d, dist_s_raw, dist_s, braking_branch, overridden, a_law, a };
        // `a` is finite: every term is finite (validated inputs and parameters, clipped or bounded
        // by max_distance/max_speed); guard anyway so that no NaN can ever leave the core.
        if !(a.is_finite() && speed.is_finite()) {
            return safe_brake(own_speed, speed_ok, p.fault_brake_step, Status::InvalidDistance);
        }
        LongitudinalCommand { speed, accel: a, status: Status::Ok }
    }
}

impl FlcTerms {
    /// The names of [`FlcTerms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] =
        &["tau_d", "d_d", "scale_f", "f_shift", "delta_d", "dist_s_raw", "dist_s", "braking_branch", "overridden", "a_law", "a"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[
                t.tau_d,
                t.d_d,
                t.scale_f,
                t.f_shift,
                t.delta_d,
                t.dist_s_raw,
                t.dist_s,
                flag(t.braking_branch),
                flag(t.overridden),
                t.a_law,
                t.a,
            ],
        )
    }
}

/// The FLC through the common interface: `step(distance, own_speed)`; `dt` and V2V are never read.
///
/// ```
/// use flc_core::{FallbackController, FlcParams, Frame, LongitudinalController};
///
/// let mut flc = FallbackController::new(FlcParams::paper())?;
/// let out = LongitudinalController::step(&mut flc, &Frame::new(Some(18.0), 10.0, 0.05));
/// // Eqs. (2)-(5): dist_s = 18 - 16 - 4 = -2, a = 2 * (-2) (1 - cos(2 pi / 11)) = -0.63498...
/// assert!((out.command.accel + 0.6349858686752752).abs() < 1e-12);
/// // Eqs. (2)-(4): D_d + F_shift at 10 m/s = 16 + 4 = 20 m.
/// assert!((flc.desired_gap(10.0) - 20.0).abs() < 1e-12);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for FallbackController {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = FallbackController::step(self, frame.distance, frame.own_speed);
        ControlOutput::single(command, self.terms.to_terms(), ActiveController::Flc)
    }

    fn reset(&mut self) {
        FallbackController::reset(self);
    }

    /// Eqs. (2)-(4): `D_d + F_shift`.
    fn desired_gap(&self, v: f64) -> f64 {
        self.params.desired_distance(v) + self.params.f_shift(v)
    }

    fn uses_dt(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EPS: f64 = 1e-9;

    fn flc() -> FallbackController {
        FallbackController::new(FlcParams::paper()).unwrap()
    }

    #[test]
    fn eqs_2_to_4_by_hand() {
        let p = FlcParams::paper();
        // Eq. (2): tau_D = 1.0 * 10 = 10; D_d = 10 + 6 = 16.
        assert!((p.desired_distance(10.0) - 16.0).abs() < EPS);
        // Eq. (3): 0.1 * 5 / (5/3.6) = 0.36 < 0.4 -> not capped; F_shift = 5 * 0.36 = 1.8.
        assert!((scale_factor(0.1, 0.4, 5.0 / 3.6, 5.0) - 0.36).abs() < EPS);
        assert!((p.f_shift(5.0) - 1.8).abs() < EPS);
        // Cap: 0.1 * 10 / (5/3.6) = 0.72 -> capped at 0.4; F_shift = 10 * 0.4 = 4.
        assert!((scale_factor(0.1, 0.4, 5.0 / 3.6, 10.0) - 0.4).abs() < EPS);
        assert!((p.f_shift(10.0) - 4.0).abs() < EPS);
        // Eq. (4): max(0, S_F) -> no negative shift when rolling backwards.
        assert_eq!(p.f_shift(-0.5), 0.0);
    }

    #[test]
    fn normal_branch_positive_dist_s() {
        let mut c = flc();
        // S_F = 10, LF_dist = 25: dist_s = 25 - 16 - 4 = 5; first frame -> Delta_d = 0 (normal branch).
        // a = 5 * (1 - cos(5 pi / 11)) = 5 * (1 - 0.1423148382732851) = 4.288425808633574.
        let out = c.step(Some(25.0), 10.0);
        assert_eq!(out.status, Status::Ok);
        let t = c.terms();
        assert!((t.dist_s - 5.0).abs() < EPS);
        assert!(!t.braking_branch);
        assert!((out.accel - 4.288425808633574).abs() < 1e-9);
        // v_cmd = S_F + 1.0 * a.
        assert!((out.speed - 14.288425808633574).abs() < 1e-9);
    }

    #[test]
    fn normal_branch_negative_dist_s_gets_multiplier() {
        let mut c = flc();
        // S_F = 10, LF_dist = 18: dist_s = 18 - 16 - 4 = -2.
        // a_law = -2 * (1 - cos(2 pi / 11)) = -2 * (1 - 0.8412535328311812) = -0.3174929343376376;
        // multiplier 2 -> a = -0.6349858686752752.
        let out = c.step(Some(18.0), 10.0);
        let t = c.terms();
        assert!((t.a_law + 0.3174929343376376).abs() < 1e-9);
        assert!((out.accel + 0.6349858686752752).abs() < 1e-9);
        assert!((out.speed - (10.0 - 0.6349858686752752)).abs() < 1e-9);
    }

    #[test]
    fn braking_branch_with_override() {
        let mut c = flc();
        c.step(Some(25.0), 10.0);
        // Delta_d = 24.5 - 25 = -0.5 <= -0.3 -> shift 1.5; dist_s = 24.5 - 20 = 4.5 -> overridden to -3.
        // a_law = -3 * (1.5 - cos(-3 pi / 11)) = -3 * (1.5 - 0.6548607339452850) = -2.535417798164145;
        // multiplier 2 -> -5.07083559632829.
        let out = c.step(Some(24.5), 10.0);
        let t = c.terms();
        assert!((t.delta_d + 0.5).abs() < EPS);
        assert!(t.braking_branch && t.overridden);
        assert_eq!(t.dist_s, -3.0);
        assert!((t.a_law + 2.535417798164145).abs() < 1e-9);
        assert!((out.accel + 5.07083559632829).abs() < 1e-9);
    }

    #[test]
    fn override_forms() {
        // dist_s already below -3 in the braking branch: S_F = 10, LF_dist 12 -> 8 (Delta_d = -4),
        // dist_s = 8 - 20 = -12 -> clipped to -11.
        let run = |form| {
            let mut c = FallbackController::new(FlcParams { dist_override: form, ..FlcParams::paper() }).unwrap();
            c.step(Some(12.0), 10.0);
            c.step(Some(8.0), 10.0);
            *c.terms()
        };
        // Min keeps -11: a_law = -11 * (1.5 - cos(-pi)) = -11 * 2.5 = -27.5.
        let min = run(DistOverride::Min);
        assert_eq!(min.dist_s, -11.0);
        assert!((min.a_law + 27.5).abs() < 1e-9);
        // Replace forces -3: a_law = -2.535417798164145 (weaker braking, which is why Min is the default).
        let rep = run(DistOverride::Replace);
        assert_eq!(rep.dist_s, -3.0);
        assert!((rep.a_law + 2.535417798164145).abs() < 1e-9);
        // Off: no override but shift 1.5.
        let off = run(DistOverride::Off);
        assert_eq!(off.dist_s, -11.0);
        assert!(!off.overridden);
    }

    #[test]
    fn threshold_is_inclusive() {
        let p = FlcParams { brake_threshold: -0.25, ..FlcParams::paper() };
        let mut c = FallbackController::new(p).unwrap();
        c.step(Some(30.0), 10.0);
        c.step(Some(29.75), 10.0); // Delta_d = -0.25 exactly (binary-exact values).
        assert!(c.terms().braking_branch);
        c.step(Some(29.625), 10.0); // Delta_d = -0.125 > -0.25.
        assert!(!c.terms().braking_branch);
    }

    #[test]
    fn clipping_of_dist_s() {
        // S_F = 10, LF_dist = 60: dist_s = 40.
        let mut clipped = flc();
        let out = clipped.step(Some(60.0), 10.0);
        // Clipped to 11: a = 11 * (1 - cos(pi)) = 22.
        assert!((out.accel - 22.0).abs() < 1e-9);
        let mut raw = FallbackController::new(FlcParams { clip_dist_s: false, ..FlcParams::paper() }).unwrap();
        let out = raw.step(Some(60.0), 10.0);
        // Unclipped: 40 * (1 - cos(40 pi / 11)) = 40 * (1 - 0.41541501300188644) = 23.383_399_479_924_54.
        assert!((out.accel - 23.383_399_479_924_54).abs() < 1e-9);
    }

    #[test]
    fn multiplier_value_is_a_parameter() {
        let mut c = FallbackController::new(FlcParams { negative_multiplier: 3.0, ..FlcParams::paper() }).unwrap();
        let out = c.step(Some(18.0), 10.0);
        assert!((out.accel + 3.0 * 0.3174929343376376).abs() < 1e-9);
        // Positive a is never multiplied.
        let out = c.step(Some(25.0), 10.0);
        assert!((out.accel - c.terms().a_law).abs() < EPS && out.accel > 0.0);
    }

    #[test]
    fn missing_or_invalid_distance_brakes_and_resets_history() {
        let mut c = flc();
        c.step(Some(25.0), 10.0);
        let out = c.step(None, 10.0);
        assert_eq!(out.status, Status::NoLead);
        assert_eq!(out.speed, 7.0); // 10 - fault_brake_step 3
        assert!(out.accel < 0.0);
        // After the gap, Delta_d restarts at 0 (FirstFrame::Steady) instead of comparing to 25.
        c.step(Some(20.0), 10.0);
        assert_eq!(c.terms().delta_d, 0.0);
        for d in [f64::NAN, f64::INFINITY, -1.0, 1.0e9] {
            let out = c.step(Some(d), 10.0);
            assert_eq!(out.status, Status::InvalidDistance, "{d}");
            assert_eq!(out.speed, 7.0);
        }
        for v in [f64::NAN, f64::NEG_INFINITY, -5.0, 500.0] {
            let out = c.step(Some(20.0), v);
            assert_eq!(out.status, Status::InvalidSpeed, "{v}");
            assert_eq!(out.speed, 0.0);
        }
    }

    #[test]
    fn first_frame_braking_option() {
        let mut c = FallbackController::new(FlcParams { first_frame: FirstFrame::Braking, ..FlcParams::paper() }).unwrap();
        c.step(Some(25.0), 10.0);
        assert!(c.terms().braking_branch);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let e = FallbackController::new(FlcParams { bound_t: 0.0, ..FlcParams::paper() }).unwrap_err();
        assert_eq!(e.field, "bound_t");
        let e = FallbackController::new(FlcParams { time_gap: f64::NAN, ..FlcParams::paper() }).unwrap_err();
        assert_eq!(e.field, "time_gap");
        let e = FallbackController::new(FlcParams { negative_multiplier: -1.0, ..FlcParams::paper() }).unwrap_err();
        assert_eq!(e.field, "negative_multiplier");
    }

    /// Time independence, part 1: the FLC is a function of the *sequence* of (distance, speed)
    /// pairs only. A steady gap sampled at 10, 20 or 40 Hz, with or without frame-interval jitter,
    /// produces the same command on every frame.
    #[test]
    fn steady_sequence_is_rate_independent() {
        let frames = |n: usize| -> std::vec::Vec<f64> {
            let mut c = flc();
            (0..n).map(|_| c.step(Some(30.0), 12.0).speed).collect()
        };
        let (a, b, d) = (frames(10), frames(20), frames(40));
        assert!(a.iter().chain(&b).chain(&d).all(|&v| v == a[0]));
    }

    /// Time independence, part 2: where the paper's per-frame `Delta_d` makes the FLC
    /// rate-dependent, pin it. The lead closes at 5 m/s: at 10 Hz `Delta_d` = -0.5 m per frame
    /// (braking branch); at 40 Hz `Delta_d` = -0.125 m per frame (normal branch). Same physical
    /// situation, different law (see docs/paper-notes.md, "Delta_d is per frame").
    #[test]
    fn closing_speed_trigger_depends_on_frame_rate() {
        let branch_at = |rate_hz: f64| {
            let mut c = flc();
            let dt = 1.0 / rate_hz;
            let mut braking = std::vec::Vec::new();
            for k in 0..10 {
                c.step(Some(40.0 - 5.0 * dt * k as f64), 10.0);
                braking.push(c.terms().braking_branch);
            }
            braking[1..].iter().all(|&b| b)
        };
        assert!(branch_at(10.0));
        assert!(!branch_at(40.0));
        // Braking iff closing speed / rate >= 0.3 m: for 5 m/s the branch flips at 16.7 Hz.
        assert!(branch_at(16.0) && !branch_at(17.0));
    }

    /// Jittery frame intervals: the FLC does not see time, so two runs over the same closing
    /// trajectory sampled at jittered instants give outputs that depend only on the samples.
    #[test]
    fn jittered_samples_give_the_same_output_as_their_values() {
        let times = [0.0, 0.04, 0.11, 0.15, 0.21, 0.24, 0.30];
        let samples: std::vec::Vec<f64> = times.iter().map(|t| 40.0 - 2.0 * t).collect();
        let mut a = flc();
        let mut b = flc();
        for &d in &samples {
            assert_eq!(a.step(Some(d), 12.0), b.step(Some(d), 12.0));
        }
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = flc();
            let max = c.params().max_speed;
            for (d, v) in seq {
                let out = c.step(d, v);
                prop_assert!(out.speed.is_finite() && out.speed >= 0.0 && out.speed <= max);
                prop_assert!(out.accel.is_finite());
                // Law bound: |a| <= multiplier * bound_t * (shift_brake + 1) = 2 * 11 * 2.5 = 55.
                prop_assert!(out.accel.abs() <= 55.0 + 1e-9);
                if out.status.is_ok() {
                    prop_assert!(v.is_finite());
                } else {
                    // Any fault brakes: never above the measured speed.
                    prop_assert!(out.accel < 0.0);
                    if v.is_finite() { prop_assert!(out.speed <= v.max(0.0)); }
                }
            }
        }

        #[test]
        fn nan_distance_always_gives_the_safe_command(v in 0.0f64..60.0) {
            let mut c = flc();
            let out = c.step(Some(f64::NAN), v);
            prop_assert_eq!(out.status, Status::InvalidDistance);
            prop_assert_eq!(out.speed, (v - 3.0).max(0.0));
        }
    }
}
