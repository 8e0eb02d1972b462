//! A robust fallback longitudinal controller (beyond the paper, issue 7).
//!
//! Same inputs as the paper's FLC ([`crate::flc`]): the LiDAR distance to the lead (`None` when
//! the detector found nothing) and the follower's own speed, once per LiDAR frame. No timestamp,
//! no `dt`, no lead speed, no V2V. Unlike the paper's law, the speed command is a function of the
//! *current* distance and own speed only, so the law itself is the same at every frame rate; its
//! only memory is a latch that is set and released by events in the distance signal (not by frame
//! counts), so it is rate invariant too. Design, derivation, analytic bounds and the stability
//! argument of Sec. III-C redone for this law: `docs/robust-flc.md`.
//!
//! Per frame ([`RobustFallbackController::step`]), with `d` the distance and `v` the own speed:
//!
//! ```text
//! (R1) gap policy      D_r(v)   = d_0 + h v                                   (desired gap)
//! (R2) gap speed       V_g(d)   = max(0, (d - d_0) / h)                       (R1 inverted)
//! (R3) stop envelope   V_e(d)   = b_s (sqrt(T_s^2 + 2 (d - d_s) / b_s) - T_s)  for d > d_s, else 0
//!                                 (the speed from which the follower stops before d_s behind a
//!                                  standing object, reacting after T_s and braking at b_s)
//! (R4) target speed    V*(d)    = V_g(d)                  normally,
//!                      V*(d)    = min(V_g(d), V_e(d))     while the "unknown object" latch is set
//! (R5) acceleration    a        = k_a (V* - v)  if V* >= v,   k_b (V* - v)  otherwise,
//!                      a        = clamp(a, -b_max, a_max)
//! (R6) speed command   v_cmd    = clamp(v + G a, 0, v_max)           (G = command_gain, 1 s)
//! ```
//!
//! The latch (R4) covers the one case a distance-only law cannot infer from `(d, v)`: an object
//! that was not being followed, e.g. a standing car revealed when the lead leaves the lane. It is
//! set when the distance reappears after a frame without a lead, or jumps *up* by more than
//! `reveal_jump` between two frames (farther than the followed lead: a different object), and
//! released once the distance has grown `reveal_release` above its smallest value since the latch
//! was set (a standing object never moves away). Neither condition counts frames or time.
//!
//! In the linear region (no clamp, constant lead speed) the gap error `x_2 = d - D_r(v)` and the
//! speed difference `x_1 = v - v_L` obey `x_1' = (k/h) x_2`, `x_2' = -x_1 - k x_2` with `k = k_a`
//! or `k_b` by the sign of `x_2`, and `V = x_1^2 / 2 + k x_2^2 / (2 h)` has
//! `V' = -(k^2 / h) x_2^2 <= 0`: globally asymptotically stable by LaSalle (the paper's
//! `V = (x_1^2 + x_2^2) / 2` is only partly decreasing).

use crate::command::{LongitudinalCommand, Status, clamp, safe_brake, valid_speed};
use crate::longitudinal::ActiveController;
use crate::longitudinal::{ControlOutput, Frame, LongitudinalController, Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// What the very first detection is taken to be (later ones follow the latch rules).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FirstObject {
    /// The lead the follower was already following (the controller takes over a running
    /// following, like the paper's FLC in the pipeline). Default.
    Lead,
    /// An unknown, possibly standing object: the stop envelope (R3) applies until it moves away.
    Unknown,
}

/// Parameters of the robust FLC. `Default` is the documented design (`docs/robust-flc.md`,
/// "Defaults").
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustFlcParams {
    /// `d_0`, gap at standstill, m. Default 3.0.
    pub standstill_gap: f64,
    /// `h`, time gap of the gap policy (R1), s. Default 1.5.
    pub time_gap: f64,
    /// `k_a`, gain on a positive speed error `V* - v` (speeding up), 1/s. Default 1.0.
    pub accel_gain: f64,
    /// `k_b`, gain on a negative speed error (slowing down), 1/s. Default 4.0 (gap loop damping
    /// `sqrt(k_b h) / 2 = 1.22`; see `docs/robust-flc.md`, "Gains").
    pub brake_gain: f64,
    /// `a_max`, largest acceleration the law asks for, m/s². Default 2.0 (the ACC limit of
    /// ISO 15622 at speed).
    pub max_accel: f64,
    /// `b_max`, largest deceleration the law asks for, m/s². Default 10 (above any tyre limit, so
    /// that an emergency saturates the vehicle's brakes).
    pub max_decel: f64,
    /// `b_s`, deceleration of the stop envelope (R3), m/s². Default 7.0 (below the 8 m/s² the
    /// default vehicle can brake, which leaves the margin for the tracking lag).
    pub envelope_decel: f64,
    /// `T_s`, reaction time of the stop envelope (R3), s. Default 0.5 (frame, sensor latency,
    /// actuator dead time and lag).
    pub envelope_reaction: f64,
    /// `d_s`, distance the stop envelope keeps to a standing object, m. Default 2.0.
    pub envelope_margin: f64,
    /// An upward jump of the distance between two frames larger than this is a different object
    /// (sets the latch), m. Default 3.0 (less than a car length: an object revealed behind the
    /// followed lead is at least one lead length farther).
    pub reveal_jump: f64,
    /// The latch is released once the distance exceeds its smallest value since the latch by
    /// this much, m. Default 0.5 (25 times the LiDAR's 2 cm range noise).
    pub reveal_release: f64,
    /// What the first detection is. Default [`FirstObject::Lead`].
    pub first_object: FirstObject,
    /// `G`, `v_cmd = v + G a`, s. Default 1.0 (the paper's "incorporated into the current speed").
    pub command_gain: f64,
    /// Highest plausible own speed and highest speed command, m/s. Default 70 (252 km/h).
    pub max_speed: f64,
    /// Highest plausible distance, m; larger distances are treated as invalid. Default 500.
    pub max_distance: f64,
    /// Safe command without a lead or on invalid input: `v_cmd = v - fault_brake_step`, m/s.
    /// Default 3.0 (as the paper's FLC).
    pub fault_brake_step: f64,
}

impl Default for RobustFlcParams {
    fn default() -> Self {
        Self::documented()
    }
}

impl RobustFlcParams {
    /// The documented design (identical to `Default`).
    pub const fn documented() -> Self {
        Self {
            standstill_gap: 3.0,
            time_gap: 1.5,
            accel_gain: 1.0,
            brake_gain: 4.0,
            max_accel: 2.0,
            max_decel: 10.0,
            envelope_decel: 7.0,
            envelope_reaction: 0.5,
            envelope_margin: 2.0,
            reveal_jump: 3.0,
            reveal_release: 0.5,
            first_object: FirstObject::Lead,
            command_gain: 1.0,
            max_speed: 70.0,
            max_distance: 500.0,
            fault_brake_step: 3.0,
        }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("standstill_gap", self.standstill_gap, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_positive("time_gap", self.time_gap, 10.0, "must be finite and in (0, 10] s")?;
        check_positive("accel_gain", self.accel_gain, 100.0, "must be finite and in (0, 100] 1/s")?;
        check_positive("brake_gain", self.brake_gain, 100.0, "must be finite and in (0, 100] 1/s")?;
        check_positive("max_accel", self.max_accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("max_decel", self.max_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_positive("envelope_decel", self.envelope_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_range("envelope_reaction", self.envelope_reaction, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_range("envelope_margin", self.envelope_margin, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_positive("reveal_jump", self.reveal_jump, 1000.0, "must be finite and in (0, 1000] m")?;
        check_positive("reveal_release", self.reveal_release, 1000.0, "must be finite and in (0, 1000] m")?;
        check_positive("command_gain", self.command_gain, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("max_speed", self.max_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_positive("max_distance", self.max_distance, 1.0e6, "must be finite and in (0, 1e6] m")?;
        check_range("fault_brake_step", self.fault_brake_step, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        Ok(())
    }

    /// (R1) desired gap `D_r(v) = d_0 + h max(v, 0)`, m.
    pub fn desired_gap(&self, own_speed: f64) -> f64 {
        self.standstill_gap + self.time_gap * own_speed.max(0.0)
    }

    /// (R2) the speed at which `d` is the desired gap, `V_g(d) = max(0, (d - d_0) / h)`, m/s.
    pub fn gap_speed(&self, distance: f64) -> f64 {
        ((distance - self.standstill_gap) / self.time_gap).max(0.0)
    }

    /// (R3) the stop envelope `V_e(d)`: the highest speed from which the follower, reacting after
    /// `T_s` and then braking at `b_s`, stops at least `d_s` behind a standing object `d` ahead,
    /// m/s. `V_e` solves `d = d_s + T_s V + V² / (2 b_s)`.
    pub fn envelope_speed(&self, distance: f64) -> f64 {
        let (b, t) = (self.envelope_decel, self.envelope_reaction);
        let x = distance - self.envelope_margin;
        if x > 0.0 { b * (libm::sqrt(t * t + 2.0 * x / b) - t) } else { 0.0 }
    }

    /// (R5) the acceleration toward `target_speed` from `own_speed`: `k_a` or `k_b` by the sign
    /// of the speed error, clamped to `[-b_max, a_max]`, m/s².
    pub fn acceleration(&self, target_speed: f64, own_speed: f64) -> f64 {
        let error = target_speed - own_speed;
        let gain = if error >= 0.0 { self.accel_gain } else { self.brake_gain };
        clamp(gain * error, -self.max_decel, self.max_accel)
    }

    /// (R6) the speed command `clamp(v + G a, 0, v_max)`, m/s.
    pub fn speed_command(&self, own_speed: f64, a: f64) -> f64 {
        clamp(own_speed + self.command_gain * a, 0.0, self.max_speed)
    }

    /// The inverse of (R3): the distance needed to stop from `own_speed` before a standing object,
    /// `d_s + T_s v + v² / (2 b_s)`, m.
    pub fn envelope_distance(&self, own_speed: f64) -> f64 {
        let v = own_speed.max(0.0);
        self.envelope_margin + self.envelope_reaction * v + v * v / (2.0 * self.envelope_decel)
    }
}

/// The terms of one robust FLC step (for plots, logs and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RobustFlcTerms {
    /// (R1) desired gap at the current speed, m.
    pub desired_gap: f64,
    /// Gap error `d - D_r(v)`, m (`x_2` of the stability analysis).
    pub gap_error: f64,
    /// (R2) gap speed `V_g(d)`, m/s.
    pub gap_speed: f64,
    /// (R3) stop-envelope speed `V_e(d)`, m/s (computed on every frame, used only while latched).
    pub envelope_speed: f64,
    /// (R4) target speed `V*`, m/s.
    pub target_speed: f64,
    /// This frame set the latch (an object was revealed).
    pub revealed: bool,
    /// The "unknown object" latch is set after this frame: the envelope applies.
    pub latched: bool,
    /// Smallest distance since the latch was set, m (0 while not latched).
    pub latch_min_distance: f64,
    /// (R5) acceleration term, m/s².
    pub a: f64,
}

/// The robust FLC. Construct with [`RobustFallbackController::new`], call
/// [`RobustFallbackController::step`] once per LiDAR frame.
#[derive(Debug, Clone)]
pub struct RobustFallbackController {
    params: RobustFlcParams,
    /// Last valid distance; `None` before the first one and after a frame without a lead.
    prev_distance: Option<f64>,
    /// A valid distance was seen at least once (distinguishes the first detection from a
    /// reappearance).
    seen: bool,
    /// Smallest distance since the latch was set; `None` while not latched.
    latch_min: Option<f64>,
    terms: RobustFlcTerms,
}

impl RobustFallbackController {
    /// Validates `params` and builds the controller.
    pub fn new(params: RobustFlcParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params, prev_distance: None, seen: false, latch_min: None, terms: RobustFlcTerms::default() })
    }

    /// The parameters in use.
    pub fn params(&self) -> &RobustFlcParams {
        &self.params
    }

    /// Forgets everything; the next detection is a first detection.
    pub fn reset(&mut self) {
        self.prev_distance = None;
        self.seen = false;
        self.latch_min = None;
        self.terms = RobustFlcTerms::default();
    }

    /// The terms of the last step (all zero before the first step; after a fault all zero except
    /// the latch state).
    pub fn terms(&self) -> &RobustFlcTerms {
        &self.terms
    }

    /// Whether the "unknown object" latch is set (the stop envelope applies).
    pub fn latched(&self) -> bool {
        self.latch_min.is_some()
    }

    /// One LiDAR frame. `distance` in m (`None` when the detector found no lead), `own_speed` in
    /// m/s. No timestamp and no `dt`: the command depends on the current frame and on the latch,
    /// which only distance events set and release.
    ///
    /// Without a lead or on invalid input the controller brakes (`v - fault_brake_step`, status
    /// says why); the next valid distance is then a reappearance and sets the latch.
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64) -> LongitudinalCommand {
        let p = self.params;
        let speed_ok = valid_speed(own_speed, p.max_speed);
        let status = match distance {
            _ if !speed_ok => Status::InvalidSpeed,
            None => Status::NoLead,
            Some(d) if !(d.is_finite() && d >= 0.0 && d <= p.max_distance) => Status::InvalidDistance,
            Some(_) => Status::Ok,
        };
        let (Status::Ok, Some(d)) = (status, distance) else {
            // Lost track: whatever is seen next is an unknown object. The latch is kept.
            self.prev_distance = None;
            self.terms =
                RobustFlcTerms { latched: self.latched(), latch_min_distance: self.latch_min.unwrap_or(0.0), ..RobustFlcTerms::default() };
            return safe_brake(own_speed, speed_ok, p.fault_brake_step, status);
        };

        // The latch: set on a reveal, released once the object has moved away.
        let revealed = match self.prev_distance {
            Some(prev) => d - prev > p.reveal_jump,
            None if self.seen => true,
            None => p.first_object == FirstObject::Unknown,
        };
        self.prev_distance = Some(d);
        self.seen = true;
        if revealed {
            self.latch_min = Some(d);
        }
        if let Some(m) = self.latch_min {
            let m = m.min(d);
            self.latch_min = if d >= m + p.reveal_release { None } else { Some(m) };
        }
        let latched = self.latch_min.is_some();

        let v = own_speed;
        let desired_gap = p.desired_gap(v);
        let gap_speed = p.gap_speed(d);
        let envelope_speed = p.envelope_speed(d);
        let target_speed = if latched { gap_speed.min(envelope_speed) } else { gap_speed };
        let a = p.acceleration(target_speed, v);
        let speed = p.speed_command(v, a);
        self.terms = RobustFlcTerms {
            desired_gap,
            gap_error: d - desired_gap,
            gap_speed,
            envelope_speed,
            target_speed,
            revealed,
            latched,
            latch_min_distance: self.latch_min.unwrap_or(0.0),
            a,
        };
        // Every term is finite (validated inputs and parameters); guard anyway so that no NaN can
        // ever leave the core.
        if !(a.is_finite() && speed.is_finite()) {
            return safe_brake(own_speed, speed_ok, p.fault_brake_step, Status::InvalidDistance);
        }
        LongitudinalCommand { speed, accel: a, status: Status::Ok }
    }
}

impl RobustFlcTerms {
    /// The names of [`RobustFlcTerms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] =
        &["desired_gap", "gap_error", "gap_speed", "envelope_speed", "target_speed", "revealed", "latched", "latch_min_distance", "a"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[
                t.desired_gap,
                t.gap_error,
                t.gap_speed,
                t.envelope_speed,
                t.target_speed,
                flag(t.revealed),
                flag(t.latched),
                t.latch_min_distance,
                t.a,
            ],
        )
    }
}

/// The robust FLC through the common interface: `step(distance, own_speed)`; `dt` and V2V are
/// never read.
///
/// ```
/// use flc_core::{Frame, LongitudinalController, RobustFallbackController, RobustFlcParams};
///
/// let mut c = RobustFallbackController::new(RobustFlcParams::default())?;
/// let out = LongitudinalController::step(&mut c, &Frame::new(Some(33.0), 20.0, 0.05));
/// // (R1)-(R5): D_r(20) = 3 + 1.5 * 20 = 33 = d, so V* = (33 - 3) / 1.5 = 20 = v and a = 0.
/// assert_eq!(out.command.accel, 0.0);
/// assert_eq!(c.desired_gap(20.0), 33.0);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for RobustFallbackController {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = RobustFallbackController::step(self, frame.distance, frame.own_speed);
        ControlOutput::single(command, self.terms.to_terms(), ActiveController::Flc)
    }

    fn reset(&mut self) {
        RobustFallbackController::reset(self);
    }

    /// (R1): `d_0 + h max(v, 0)`.
    fn desired_gap(&self, v: f64) -> f64 {
        self.params.desired_gap(v)
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

    fn ctl() -> RobustFallbackController {
        RobustFallbackController::new(RobustFlcParams::default()).unwrap()
    }

    #[test]
    fn policy_and_envelope_by_hand() {
        let p = RobustFlcParams::default();
        // (R1) D_r(20) = 3 + 1.5 * 20 = 33; negative speeds count as 0.
        assert!((p.desired_gap(20.0) - 33.0).abs() < EPS);
        assert_eq!(p.desired_gap(-0.5), 3.0);
        // (R2) V_g(33) = (33 - 3) / 1.5 = 20; below d_0 it is 0.
        assert!((p.gap_speed(33.0) - 20.0).abs() < EPS);
        assert_eq!(p.gap_speed(1.0), 0.0);
        // (R3) V_e(30): x = 28; 7 (sqrt(0.25 + 56 / 7) - 0.5) = 7 (sqrt(8.25) - 0.5)
        //     = 7 (2.8722813232690143 - 0.5) = 16.6059692628831.
        assert!((p.envelope_speed(30.0) - 16.605_969_262_883_1).abs() < 1e-9);
        // ... and its inverse: 2 + 0.5 * 16.60597 + 16.60597² / 14 = 30.
        assert!((p.envelope_distance(p.envelope_speed(30.0)) - 30.0).abs() < 1e-9);
        // At and below d_s the envelope is a stop.
        assert_eq!(p.envelope_speed(2.0), 0.0);
        assert_eq!(p.envelope_speed(0.0), 0.0);
        // Stopping distance from 100 km/h: 2 + 0.5 * 27.78 + 27.78² / 14 = 70.99 m.
        let v = 100.0 / 3.6;
        assert!((p.envelope_distance(v) - (2.0 + 0.5 * v + v * v / 14.0)).abs() < EPS);
    }

    #[test]
    fn at_the_desired_gap_the_command_is_the_own_speed() {
        let mut c = ctl();
        // v = 20 m/s at d = 33 m: V* = 20, a = 0, v_cmd = 20.
        let out = c.step(Some(33.0), 20.0);
        assert_eq!(out.status, Status::Ok);
        assert!(out.accel.abs() < EPS && (out.speed - 20.0).abs() < EPS);
        assert!(!c.latched() && c.terms().gap_error.abs() < EPS);
    }

    #[test]
    fn too_close_brakes_with_the_brake_gain() {
        let mut c = ctl();
        // v = 20, d = 30: V_g = 18, error -2, a = 4 * -2 = -8, v_cmd = 12.
        let out = c.step(Some(30.0), 20.0);
        assert!((out.accel + 8.0).abs() < EPS, "{out:?}");
        assert!((out.speed - 12.0).abs() < EPS);
        assert!((c.terms().gap_error + 3.0).abs() < EPS);
        // Far too close: clamped at -b_max = -10 (v = 20, d = 10: V_g = 4.667, a = -61.3 -> -10).
        let out = c.step(Some(10.0), 20.0);
        assert!((out.accel + 10.0).abs() < EPS && (out.speed - 10.0).abs() < EPS);
    }

    #[test]
    fn too_far_accelerates_with_the_accel_gain_up_to_a_max() {
        let mut c = ctl();
        // v = 20, d = 34.2: V_g = 20.8, error 0.8, a = 1.0 * 0.8 = 0.8.
        let out = c.step(Some(34.2), 20.0);
        assert!((out.accel - 0.8).abs() < 1e-9 && (out.speed - 20.8).abs() < 1e-9);
        // v = 20, d = 60: V_g = 38, a = 18 -> a_max 2.
        let out = c.step(Some(60.0), 20.0);
        assert!((out.accel - 2.0).abs() < EPS && (out.speed - 22.0).abs() < EPS);
    }

    #[test]
    fn never_reverses() {
        let mut c = ctl();
        // Standing, object closer than d_0: V* = 0, command 0 (never negative).
        let out = c.step(Some(1.0), 0.0);
        assert_eq!(out.speed, 0.0);
        assert!(out.accel <= 0.0);
        let out = c.step(Some(1.0), 0.5);
        assert_eq!(out.speed, 0.0);
    }

    #[test]
    fn reveal_by_upward_jump_sets_the_envelope_until_the_object_moves_away() {
        let mut c = ctl();
        // Following at 30 m/s, 48 m (= D_r(30)).
        let out = c.step(Some(48.0), 30.0);
        assert!(out.accel.abs() < EPS && !c.latched());
        // +2.9 m in one frame: same object (below reveal_jump = 3 m).
        c.step(Some(50.9), 30.0);
        assert!(!c.latched());
        // The lead leaves; a standing car at 80 m appears (jump +29.1 m): latched.
        let out = c.step(Some(80.0), 30.0);
        let t = *c.terms();
        assert!(t.revealed && t.latched && t.latch_min_distance == 80.0);
        // V_g(80) = 51.33 but V_e(80) = 7 (sqrt(0.25 + 156/7) - 0.5) = 7 (4.74342 - 0.5) = 29.7039...
        let ve = 7.0 * ((0.25f64 + 156.0 / 7.0).sqrt() - 0.5);
        assert!((t.envelope_speed - ve).abs() < 1e-9 && (t.target_speed - ve).abs() < 1e-9);
        // a = 4 (29.7039 - 30) = -1.184...
        assert!((out.accel - 4.0 * (ve - 30.0)).abs() < 1e-9);
        // Closing in: still latched, min follows.
        c.step(Some(70.0), 28.0);
        assert!(c.latched() && c.terms().latch_min_distance == 70.0);
        // Moves away by 0.4 m: still latched; by 0.5 m: released (>= min + reveal_release).
        c.step(Some(70.4), 20.0);
        assert!(c.latched());
        c.step(Some(70.5), 20.0);
        assert!(!c.latched() && !c.terms().latched);
        // Released: the gap policy alone (V_g(70.5) = 45).
        assert!((c.terms().target_speed - 45.0).abs() < 1e-9);
    }

    #[test]
    fn downward_jumps_do_not_latch_the_gap_policy_already_brakes() {
        let mut c = ctl();
        c.step(Some(48.0), 30.0);
        // A car cuts in at 12 m: V_g = 6, a = 4 (6 - 30) = -96 -> -10.
        let out = c.step(Some(12.0), 30.0);
        assert!(!c.latched());
        assert!((out.accel + 10.0).abs() < EPS);
    }

    #[test]
    fn reappearance_after_a_lost_frame_latches() {
        let mut c = ctl();
        c.step(Some(48.0), 30.0);
        let out = c.step(None, 30.0);
        assert_eq!(out.status, Status::NoLead);
        assert_eq!(out.speed, 27.0); // 30 - fault_brake_step 3
        assert!(out.accel < 0.0);
        c.step(Some(48.0), 30.0);
        assert!(c.terms().revealed && c.latched());
        // V_e(48) = 7 (sqrt(0.25 + 92/7) - 0.5) = 7 (3.6596 - 0.5) = 22.12 < V_g(48) = 30.
        assert!((c.terms().target_speed - 7.0 * ((0.25f64 + 92.0 / 7.0).sqrt() - 0.5)).abs() < 1e-9);
    }

    #[test]
    fn first_detection_policy() {
        let mut lead = ctl();
        lead.step(Some(48.0), 30.0);
        assert!(!lead.latched());
        let mut unknown =
            RobustFallbackController::new(RobustFlcParams { first_object: FirstObject::Unknown, ..RobustFlcParams::default() }).unwrap();
        unknown.step(Some(48.0), 30.0);
        assert!(unknown.latched());
        // A first frame without a lead does not make the next detection a reappearance.
        let mut c = ctl();
        c.step(None, 10.0);
        c.step(Some(20.0), 10.0);
        assert!(!c.latched());
        // reset() forgets the history.
        let mut c = ctl();
        c.step(Some(20.0), 10.0);
        c.step(None, 10.0);
        c.reset();
        c.step(Some(20.0), 10.0);
        assert!(!c.latched());
    }

    #[test]
    fn invalid_inputs_brake_and_name_the_reason() {
        let mut c = ctl();
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
    fn invalid_parameters_name_the_field() {
        let bad = |f: fn(&mut RobustFlcParams)| {
            let mut p = RobustFlcParams::default();
            f(&mut p);
            RobustFallbackController::new(p).unwrap_err().field
        };
        assert_eq!(bad(|p| p.time_gap = 0.0), "time_gap");
        assert_eq!(bad(|p| p.brake_gain = f64::NAN), "brake_gain");
        assert_eq!(bad(|p| p.envelope_decel = -1.0), "envelope_decel");
        assert_eq!(bad(|p| p.reveal_release = 0.0), "reveal_release");
        assert_eq!(bad(|p| p.standstill_gap = f64::INFINITY), "standstill_gap");
    }

    /// Rate invariance of the law: the same physical approach sampled at 10, 20, 40 Hz and at
    /// jittered instants gives, at every sample, the command that is a function of that sample
    /// alone (no dependence on the sample before), unlike the paper's `Delta_d` trigger.
    #[test]
    fn command_is_a_function_of_the_current_sample() {
        let closing = |t: f64| 60.0 - 5.0 * t; // lead 5 m/s slower
        let fresh = |d: f64| ctl().step(Some(d), 25.0);
        for rate in [10.0, 20.0, 40.0] {
            let mut c = ctl();
            for k in 0..20 {
                let d = closing(k as f64 / rate);
                assert_eq!(c.step(Some(d), 25.0), fresh(d), "{rate} Hz frame {k}");
            }
        }
        let mut c = ctl();
        for t in [0.0, 0.04, 0.11, 0.15, 0.21, 0.24, 0.30] {
            assert_eq!(c.step(Some(closing(t)), 25.0), fresh(closing(t)));
        }
    }

    /// The latch is released by how far the object moved, not by how many frames it took.
    #[test]
    fn latch_release_does_not_count_frames() {
        for n in [1usize, 2, 5, 40] {
            let mut c = ctl();
            c.step(Some(40.0), 10.0);
            c.step(Some(80.0), 10.0); // reveal
            // Object moves away by 0.6 m in n equal frames.
            let mut released_at = None;
            for k in 1..=n {
                c.step(Some(80.0 + 0.6 * k as f64 / n as f64), 10.0);
                if !c.latched() && released_at.is_none() {
                    released_at = Some(0.6 * k as f64 / n as f64);
                }
            }
            let at = released_at.expect("released");
            assert!(at >= 0.5 - 1e-12 && at < 0.5 + 0.6 / n as f64 + 1e-12, "{n}: {at}");
        }
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = ctl();
            let p = *c.params();
            for (d, v) in seq {
                let out = c.step(d, v);
                prop_assert!(out.speed.is_finite() && out.speed >= 0.0 && out.speed <= p.max_speed);
                prop_assert!(out.accel.is_finite());
                prop_assert!(out.accel >= -p.max_decel - 1e-12 && out.accel <= p.max_accel + 1e-12);
                if out.status.is_ok() {
                    // The command never exceeds what the law allows above the own speed.
                    prop_assert!(out.speed <= v.max(0.0) + p.command_gain * p.max_accel + 1e-9);
                } else {
                    prop_assert!(out.accel < 0.0);
                    if v.is_finite() { prop_assert!(out.speed <= v.max(0.0)); }
                }
            }
        }

        /// Closer is never faster: at a given speed the command is non-decreasing in the distance.
        #[test]
        fn command_is_monotone_in_distance(v in 0.0f64..60.0, d1 in 0.0f64..200.0, d2 in 0.0f64..200.0) {
            let (lo, hi) = if d1 <= d2 { (d1, d2) } else { (d2, d1) };
            let a = ctl().step(Some(lo), v).speed;
            let b = ctl().step(Some(hi), v).speed;
            prop_assert!(a <= b + 1e-12);
            let mut l = RobustFallbackController::new(RobustFlcParams { first_object: FirstObject::Unknown, ..RobustFlcParams::default() }).unwrap();
            let mut h = l.clone();
            prop_assert!(l.step(Some(lo), v).speed <= h.step(Some(hi), v).speed + 1e-12);
        }
    }
}
