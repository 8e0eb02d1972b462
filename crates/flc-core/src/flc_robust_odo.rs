//! Robust FLC v2 with wheel odometry (issue 24's separately named variant; the simulator's
//! `controller = "flc-robust-odo"`): v2 ([`crate::flc_robust2`]) unchanged, plus one more onboard
//! signal that is free of clocks and synchronisation, the distance the wheels have travelled.
//!
//! Why one more signal (`docs/robust-flc.md`, "v2", "Comfort behind a braking lead: the clock of
//! a law on `(d, v)`"): a law on the distance and the own speed alone tells time only through its
//! own acceleration (`Δt = Δv / a`); it knows its command, not the realized acceleration, and the
//! clock stops while the acceleration crosses zero. In NCAP CCRb 40 m / -2 m/s² that is exactly
//! when the lead's braking has to be seen. The odometry gives the time without trusting the
//! actuator: between two frames the follower drove `Δs`, at the mean speed `v̄`, so the gap's
//! change per metre driven, `Δd / Δs`, is a closing speed, `ĉ = -v̄ Δd / Δs`, whatever the frame
//! rate and whatever the actuator did.
//!
//! The law:
//!
//! - **(O1) closing speed per metre driven.** Between two consecutive accepted frames (v2's
//!   acceptance: a missed or pending frame interrupts, a reveal or a confirmed jump starts over),
//!   `Δτ = Δs / v̄` and `Δd` enter discounted sums with the memory `closing_memory`:
//!   `ĉ = -Σ Δd / Σ Δτ` once the sums cover half of it. No timestamp, no `dt`: `Δτ` comes from the
//!   wheels.
//! - **(O2) comfort term: IDM's braking strategy.** The Intelligent Driver Model (Treiber et
//!   al. 2000) brakes for a closing speed by lengthening its desired gap,
//!   `s* = s_0 + v T + v ĉ / (2 sqrt(a b))`. On v2's gap policy (`s_0` = `law.standstill_gap`,
//!   `T` = `law.time_gap`) the part of IDM's interaction `-a (s* / d)²` that the closing speed
//!   adds is `Δa = -a [(s_0 + v T + ĉ⁺ p)² - (s_0 + v T)²] / d² <= 0`, with the pace
//!   `p = min(v / (2 sqrt(a b)), H)` (`H` = `approach_time_gap`: an approach at (R7)'s pace is
//!   not braked for; IDM's own pace, 14 s at 130 km/h, would not close twice the gap in 20 s)
//!   ([`OdometryFlcParams::closing_brake`]). It is zero without closing, so steady following is
//!   v2's.
//! - **The command** on a frame with an accepted distance and an estimate is
//!   `min(a_v2, a_v2 + Δa)`, limited to IDM's `a` (`comfort_accel`) plus v2's `accel_gain` times
//!   an opening speed (no approach at v2's 2 m/s² toward a lead that may be braking; continuous
//!   where `ĉ` changes sign), and to `-law.max_decel`, blended into v2's below `fade_speed` with
//!   the weight `(v / fade_speed)²` (v2's own stops are comfortable); otherwise it is
//!   v2's. It never exceeds v2's, so every bound of v2 (stop envelope, reveals, missed frames)
//!   holds unchanged; without odometry (`None`) the variant is v2 bit for bit.
//!
//! The comfort target of NCAP CCRb 40 m / -2 m/s² holds for `comfort_accel` in 0.75-1.0 m/s²
//! and not at 0.5 or 1.25 (`odo_comfort_band` in `crates/flc-sim/tests/robust_flc2.rs` prints
//! the map; `docs/robust-flc.md`): a band, reported as such; the default 0.85 sits in it.

use crate::command::{LongitudinalCommand, Status};
use crate::flc_robust2::{RobustFallbackController2, RobustFlc2Params, RobustFlc2Terms};
use crate::longitudinal::{ActiveController, ControlOutput, Frame, LongitudinalController, Terms, flag};
use crate::params::{ParamError, check_positive};

/// The odometry variant's own parameters (its base is [`RobustFlc2Params`], `[flc_robust]` in a
/// scenario file). `Default` is the documented design.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryFlcParams {
    /// (O1) memory of the closing-speed estimate, s of the odometry's time `Δs / v̄`. Default 0.5
    /// (the estimate lags the closing speed by about a quarter second; 3 cm of range noise give
    /// about 0.1 m/s).
    pub closing_memory: f64,
    /// (O2) IDM's maximum acceleration `a`, m/s²: the scale of the braking strategy and the
    /// acceleration limit while closing. Default 0.85 (IDM's cars use 0.73-1.5: Treiber et al.
    /// 2000, Table I, 0.73; Treiber and Kesting, *Traffic Flow Dynamics*, 2013, 1.0-1.5; the
    /// comfort target of CCRb 40 m / -2 m/s² holds for 0.75-1.0).
    pub comfort_accel: f64,
    /// (O2) IDM's comfortable deceleration `b`, m/s². Default 1.67 (Treiber et al. 2000, Table I).
    pub comfort_decel: f64,
    /// Own speed from which (O2) applies in full, m/s; below it the command blends into v2's with
    /// the weight `(v / fade_speed)²` (v2's alone at standstill). Default 14 (about 50 km/h: v2's
    /// stops and stop-and-go are comfortable on their own, 2.34 m/s³; with the full term down to
    /// standstill the stop-and-go 1-s jerk is 2.84, with a linear blend from 10 m/s 2.59).
    pub fade_speed: f64,
    /// Lowest mean speed at which a frame's `Δs / v̄` counts, m/s. Default 0.5 (below it the
    /// wheels' distance says little about time; the estimate starts over).
    pub min_speed: f64,
}

impl Default for OdometryFlcParams {
    fn default() -> Self {
        Self::documented()
    }
}

impl OdometryFlcParams {
    /// The documented design (identical to `Default`).
    pub const fn documented() -> Self {
        Self { closing_memory: 0.5, comfort_accel: 0.85, comfort_decel: 1.67, fade_speed: 14.0, min_speed: 0.5 }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_positive("closing_memory", self.closing_memory, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("comfort_accel", self.comfort_accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("comfort_decel", self.comfort_decel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("fade_speed", self.fade_speed, 100.0, "must be finite and in (0, 100] m/s")?;
        check_positive("min_speed", self.min_speed, 100.0, "must be finite and in (0, 100] m/s")?;
        Ok(())
    }

    /// (O2) IDM's braking strategy for the closing speed `c` at own speed `v` and distance `d`,
    /// m/s² (<= 0): `-a [(g + c⁺ p)² - g²] / d²` with v2's desired gap `g = D_r(v)` (R1) and the
    /// pace `p = min(v / (2 sqrt(a b)), H)` (`H` = v2's `approach_time_gap`; `d` floored at
    /// [`MIN_DISTANCE`]).
    ///
    /// ```
    /// use flc_core::{OdometryFlcParams, RobustFlc2Params};
    ///
    /// let (p, base) = (OdometryFlcParams::default(), RobustFlc2Params::default());
    /// // Not closing: nothing (steady following is v2's).
    /// assert_eq!(p.closing_brake(&base, 20.0, 0.0, 33.0), 0.0);
    /// // Closing at 4 m/s at v2's desired gap g = 3 + 1.5 * 20 = 33 m: the pace is
    /// // min(20 / (2 sqrt(0.85 * 1.67)), 6) = min(8.39, 6) = 6 s, so
    /// // Δa = -0.85 ((33 + 4 * 6)² - 33²) / 33² = -1.69 m/s².
    /// let a = p.closing_brake(&base, 20.0, 4.0, 33.0);
    /// assert!((a + 1.686).abs() < 1e-3);
    /// ```
    pub fn closing_brake(&self, base: &RobustFlc2Params, v: f64, c: f64, d: f64) -> f64 {
        let v = v.max(0.0);
        let pace = (v / (2.0 * libm::sqrt(self.comfort_accel * self.comfort_decel))).min(base.approach_time_gap);
        let gap = base.law.desired_gap(v);
        let desired = gap + c.max(0.0) * pace;
        let d = d.max(MIN_DISTANCE);
        -self.comfort_accel * (desired * desired - gap * gap) / (d * d)
    }
}

/// Smallest distance in (O2)'s `(s* / d)²`, m: IDM's `min_gap_floor`
/// ([`crate::baselines::IdmParams`]), so that a distance of 0 brakes fully instead of dividing by 0.
pub const MIN_DISTANCE: f64 = 0.01;

/// (O1) The closing speed from the distance's change per metre driven.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct OdometryClosing {
    /// `(d, v, s)` of the last accepted frame while the next may be compared with it.
    anchor: Option<(f64, f64, f64)>,
    /// Discounted sum of the distance's changes, m.
    sum_d: f64,
    /// Discounted sum of the odometry's times `Δs / v̄`, s.
    sum_t: f64,
}

impl OdometryClosing {
    fn forget(&mut self) {
        self.sum_d = 0.0;
        self.sum_t = 0.0;
    }

    /// Adds an accepted frame at `(d, v)` with the odometer at `s`.
    fn observe(&mut self, d: f64, v: f64, s: f64, p: &OdometryFlcParams) {
        if let Some((d1, v1, s1)) = self.anchor {
            let ds = s - s1;
            let mean = 0.5 * (v + v1);
            if mean >= p.min_speed && ds > 0.0 {
                let dt = ds / mean;
                let keep = (1.0 - dt / p.closing_memory).max(0.0);
                self.sum_d = keep * self.sum_d + (d - d1);
                self.sum_t = keep * self.sum_t + dt;
            } else {
                self.forget();
            }
        }
        self.anchor = Some((d, v, s));
    }

    /// `ĉ = -Σ Δd / Σ Δτ` once the sums cover half the memory, m/s.
    fn closing(&self, p: &OdometryFlcParams) -> Option<f64> {
        (self.sum_t >= 0.5 * p.closing_memory).then(|| -self.sum_d / self.sum_t)
    }
}

/// The terms of one step: v2's, the closing-speed estimate and the comfort term.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometryFlcTerms {
    /// v2's terms (its `a` before the comfort term).
    pub base: RobustFlc2Terms,
    /// (O1) closing speed `ĉ`, m/s (0 without an estimate).
    pub closing: f64,
    /// (O2) the braking strategy's `Δa`, m/s² (0 when it does not apply).
    pub closing_brake: f64,
    /// Whether (O2) applied on this frame.
    pub comfort: bool,
    /// The commanded acceleration (v2's, or with (O2)), m/s².
    pub a: f64,
}

impl OdometryFlcTerms {
    /// The names of [`OdometryFlcTerms::to_terms`]: v2's but `held`/`pending`, then the
    /// estimate, the comfort term and the command.
    pub const NAMES: &'static [&'static str] =
        &["distance", "gap_speed", "envelope_speed", "approach_speed", "target_speed", "held", "latched", "a_v2", "closing", "closing_brake", "comfort", "a"];

    /// The terms as a named list ([`Terms`]; flags as 0 / 1).
    pub fn to_terms(&self) -> Terms {
        let b = &self.base;
        Terms::new(
            Self::NAMES,
            &[
                b.distance,
                b.gap_speed,
                b.envelope_speed,
                b.approach_speed,
                b.target_speed,
                flag(b.held),
                flag(b.latched),
                b.a,
                self.closing,
                self.closing_brake,
                flag(self.comfort),
                self.a,
            ],
        )
    }
}

/// Robust FLC v2 with wheel odometry. Construct with [`OdometryFallbackController::new`], call
/// [`OdometryFallbackController::step`] once per LiDAR frame.
#[derive(Debug, Clone)]
pub struct OdometryFallbackController {
    base: RobustFallbackController2,
    params: OdometryFlcParams,
    closing: OdometryClosing,
    terms: OdometryFlcTerms,
}

impl OdometryFallbackController {
    /// Validates both parameter sets and builds the controller.
    pub fn new(base: RobustFlc2Params, params: OdometryFlcParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { base: RobustFallbackController2::new(base)?, params, closing: OdometryClosing::default(), terms: OdometryFlcTerms::default() })
    }

    /// The variant's own parameters.
    pub fn params(&self) -> &OdometryFlcParams {
        &self.params
    }

    /// v2 inside.
    pub fn base(&self) -> &RobustFallbackController2 {
        &self.base
    }

    /// The terms of the last step.
    pub fn terms(&self) -> &OdometryFlcTerms {
        &self.terms
    }

    /// Forgets everything; the next detection is a first detection.
    pub fn reset(&mut self) {
        self.base.reset();
        self.closing = OdometryClosing::default();
        self.terms = OdometryFlcTerms::default();
    }

    /// One LiDAR frame: `distance` in m (`None` without a detection), `own_speed` in m/s,
    /// `travelled` the odometer in m (`None`: no odometry on this frame; the frame is v2's).
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64, travelled: Option<f64>) -> LongitudinalCommand {
        let out = self.base.step(distance, own_speed);
        let t = *self.base.terms();
        // v2's acceptance decides what the estimate may compare: a held frame interrupts (and a
        // pending jump may be another object), a reveal or a frame without odometry starts over.
        match travelled.filter(|s| s.is_finite()) {
            Some(s) if !t.held && out.status == Status::Ok => {
                if t.revealed {
                    self.closing = OdometryClosing::default();
                }
                self.closing.observe(t.distance, own_speed, s, &self.params);
            }
            odometer => {
                self.closing.anchor = None;
                if t.pending || odometer.is_none() {
                    self.closing.forget();
                }
            }
        }
        let p = &self.params;
        let law = &self.base.params().law;
        let closing = if t.held { None } else { self.closing.closing(p) };
        let brake = closing.map(|c| p.closing_brake(self.base.params(), own_speed, c, t.distance));
        let a = match (closing, brake) {
            (Some(c), Some(da)) => {
                // IDM's acceleration limit `a`, raised by v2's gain on an opening speed: no
                // approach at v2's 2 m/s² toward a lead that may be braking, and no step where `ĉ`
                // changes sign. Never above v2's command; blended into it below `fade_speed`.
                let cap = p.comfort_accel + law.accel_gain * (-c).max(0.0);
                let full = (t.a + da).min(cap).max(-law.max_decel).min(t.a);
                let share = (own_speed / p.fade_speed).clamp(0.0, 1.0);
                t.a + share * share * (full - t.a)
            }
            _ => t.a,
        };
        self.terms = OdometryFlcTerms { base: t, closing: closing.unwrap_or(0.0), closing_brake: brake.unwrap_or(0.0), comfort: brake.is_some(), a };
        if a == t.a { out } else { self.base.command(own_speed, a, out.status) }
    }
}

/// The odometry variant through the common interface: reads `frame.travelled`; `dt` and V2V are
/// never read.
///
/// ```
/// use flc_core::{Frame, LongitudinalController, OdometryFallbackController, OdometryFlcParams, RobustFlc2Params};
///
/// let mut c = OdometryFallbackController::new(RobustFlc2Params::default(), OdometryFlcParams::default())?;
/// // 20 m/s, 40 m behind a lead at 20 m/s (two frames: v2 releases the first detection's latch
/// // and sets v_0 = 20 m/s), then the lead at 16 m/s: per metre driven the gap falls by 0.2 m.
/// let (v, mut d, mut s) = (20.0, 40.0, 0.0);
/// for _ in 0..2 {
///     LongitudinalController::step(&mut c, &Frame { travelled: Some(s), ..Frame::new(Some(d), v, 0.05) });
///     s += 1.0;
/// }
/// for _ in 0..20 {
///     LongitudinalController::step(&mut c, &Frame { travelled: Some(s), ..Frame::new(Some(d), v, 0.05) });
///     (d, s) = (d - 0.2, s + 1.0);
/// }
/// // (O1) ĉ -> 20 * 0.2 / 1 = 4 m/s (3.88: the memory, 0.5 s, still weighs the first two
/// // frames). v2 alone still approaches (its v_0 is 20 m/s: a = +0.53); (O2) at 36.2 m,
/// // Δa = -0.85 ((33 + 3.885 * 6)² - 33²) / 36.2² = -1.35 m/s², so the command is
/// // 0.53 - 1.35 = -0.82 m/s².
/// let t = *c.terms();
/// assert!((t.closing - 3.885).abs() < 1e-3 && t.comfort);
/// assert!((t.base.a - 0.533).abs() < 1e-3 && (t.closing_brake + 1.350).abs() < 1e-3);
/// assert!((t.a + 0.817).abs() < 1e-3);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for OdometryFallbackController {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = OdometryFallbackController::step(self, frame.distance, frame.own_speed, frame.travelled);
        ControlOutput::single(command, self.terms.to_terms(), ActiveController::Flc)
    }

    fn reset(&mut self) {
        OdometryFallbackController::reset(self);
    }

    /// v2's (R1): `d_0 + h max(v, 0)`.
    fn desired_gap(&self, v: f64) -> f64 {
        self.base.params().law.desired_gap(v)
    }

    fn uses_dt(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ctl() -> OdometryFallbackController {
        OdometryFallbackController::new(RobustFlc2Params::default(), OdometryFlcParams::default()).unwrap()
    }

    fn v2() -> RobustFallbackController2 {
        RobustFallbackController2::new(RobustFlc2Params::default()).unwrap()
    }

    /// Frames of a follower at `v` whose gap falls by `per_m` per metre driven, 1 m apart.
    fn drive(c: &mut OdometryFallbackController, v: f64, d0: f64, per_m: f64, s0: f64, n: usize) -> (f64, f64) {
        let (mut d, mut s) = (d0, s0);
        for _ in 0..n {
            c.step(Some(d), v, Some(s));
            d -= per_m;
            s += 1.0;
        }
        (d, s)
    }

    #[test]
    fn the_closing_speed_is_the_gap_change_per_metre_times_the_speed() {
        let mut c = ctl();
        drive(&mut c, 25.0, 60.0, 0.1, 0.0, 40);
        assert!((c.terms().closing - 2.5).abs() < 1e-9, "{:?}", c.terms());
    }

    #[test]
    fn a_missed_frame_interrupts_but_keeps_the_estimate_and_a_pending_jump_forgets_it() {
        let mut c = ctl();
        let (d, s) = drive(&mut c, 25.0, 60.0, 0.1, 0.0, 40);
        c.step(None, 25.0, Some(s));
        assert!(c.terms().base.held && !c.terms().comfort);
        // Back one frame later: the sums were kept, the estimate is there at once.
        c.step(Some(d - 0.2), 25.0, Some(s + 2.0));
        assert!(c.terms().comfort && (c.terms().closing - 2.5).abs() < 1e-9, "{:?}", c.terms());
        // A jump is pending (maybe another object): the estimate starts over.
        c.step(Some(10.0), 25.0, Some(s + 3.0));
        assert!(c.terms().base.pending);
        c.step(Some(d - 0.4), 25.0, Some(s + 4.0));
        assert!(!c.terms().comfort, "{:?}", c.terms());
    }

    #[test]
    fn without_odometry_it_is_v2() {
        let (mut c, mut b) = (ctl(), v2());
        for k in 0..50 {
            let d = 50.0 - 0.3 * k as f64;
            let (x, y) = (c.step(Some(d), 22.0, if k % 7 == 3 { Some(f64::NAN) } else { None }), b.step(Some(d), 22.0));
            assert_eq!((x.speed.to_bits(), x.accel.to_bits(), x.status), (y.speed.to_bits(), y.accel.to_bits(), y.status));
        }
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let p = OdometryFlcParams { comfort_decel: 0.0, ..OdometryFlcParams::default() };
        assert_eq!(OdometryFallbackController::new(RobustFlc2Params::default(), p).unwrap_err().field, "comfort_decel");
        let mut b = RobustFlc2Params::default();
        b.law.time_gap = f64::NAN;
        assert_eq!(OdometryFallbackController::new(b, OdometryFlcParams::default()).unwrap_err().field, "law.time_gap");
    }

    fn input() -> impl Strategy<Value = (Option<f64>, f64, Option<f64>)> {
        let d = prop_oneof![8 => (0.0..150.0f64).prop_map(Some), 1 => Just(None), 1 => proptest::num::f64::ANY.prop_map(Some)];
        let v = prop_oneof![9 => 0.0..40.0f64, 1 => proptest::num::f64::ANY];
        let s = prop_oneof![8 => (0.0..3.0f64).prop_map(Some), 1 => Just(None), 1 => proptest::num::f64::ANY.prop_map(Some)];
        (d, v, s)
    }

    proptest! {
        /// Whatever the inputs (odometry included), the variant never commands more than v2 on
        /// the same frames, its command is finite, and the common interface ignores `dt`.
        #[test]
        fn never_above_v2_and_free_of_dt(seq in proptest::collection::vec((input(), proptest::num::f64::ANY), 1..80)) {
            let (mut c, mut twin, mut b) = (ctl(), ctl(), v2());
            let mut odometer = 0.0;
            for ((d, v, ds), dt) in seq {
                // A travelled distance that mostly grows, sometimes jumps or is missing.
                let travelled = ds.map(|x| { odometer += x; odometer });
                let x = c.step(d, v, travelled);
                let y = b.step(d, v);
                prop_assert!(x.accel <= y.accel && x.speed <= y.speed, "{x:?} vs v2 {y:?}");
                prop_assert!(x.accel.is_finite() && x.speed.is_finite());
                prop_assert_eq!(x.status, y.status);
                let o = LongitudinalController::step(&mut twin, &Frame { travelled, ..Frame::new(d, v, dt) });
                prop_assert_eq!((o.command.speed.to_bits(), o.command.accel.to_bits()), (x.speed.to_bits(), x.accel.to_bits()));
            }
        }
    }
}
