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
//! - **(O2) comfort term.** The Intelligent Driver Model's acceleration
//!   ([`crate::baselines::IdmParams::accel`], Treiber et al. 2000) on v2's gap policy
//!   (`s_0` = `law.standstill_gap`, `T` = `law.time_gap`, desired speed `law.max_speed`) with the
//!   lead's speed `v - ĉ`: `a_c = a [1 - (v / v_max)^4 - (s* / d)²]`,
//!   `s* = s_0 + v T + v ĉ / (2 sqrt(a b))` with `a` = `comfort_accel`, `b` = `comfort_decel`.
//! - **The command is `min(a_v2, a_c)`** on a frame with an accepted distance and an estimate;
//!   otherwise v2's. It never exceeds v2's, so every bound of v2 (stop envelope, reveals, missed
//!   frames) holds unchanged; without odometry (`None`) the variant is v2 bit for bit.

use crate::baselines::IdmParams;
use crate::command::{LongitudinalCommand, safe_brake};
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
    /// (O2) IDM's maximum acceleration `a`, m/s². Default 1.0 (Treiber and Kesting's range
    /// 0.3-2.0 for cars; v2's own approach limit is `law.max_accel` = 2).
    pub comfort_accel: f64,
    /// (O2) IDM's comfortable deceleration `b`, m/s². Default 1.67 (Treiber et al. 2000, Table I).
    pub comfort_decel: f64,
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
        Self { closing_memory: 0.5, comfort_accel: 1.0, comfort_decel: 1.67, min_speed: 0.5 }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_positive("closing_memory", self.closing_memory, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("comfort_accel", self.comfort_accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("comfort_decel", self.comfort_decel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("min_speed", self.min_speed, 100.0, "must be finite and in (0, 100] m/s")?;
        Ok(())
    }

    /// (O2) the IDM on v2's gap policy (`base`): `s_0`, `T` and the desired speed from v2's law,
    /// `a` and `b` from these parameters.
    pub fn comfort_model(&self, base: &RobustFlc2Params) -> IdmParams {
        let law = &base.law;
        IdmParams {
            desired_speed: law.max_speed,
            time_headway: law.time_gap,
            min_gap: law.standstill_gap,
            max_accel: self.comfort_accel,
            comfort_decel: self.comfort_decel,
            max_decel: law.max_decel,
            ..IdmParams::treiber2000()
        }
    }
}

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
    /// (O2) comfort acceleration `a_c`, m/s² (0 when it does not apply).
    pub comfort_accel: f64,
    /// Whether (O2) applied on this frame.
    pub comfort: bool,
    /// The commanded acceleration, `min(a_v2, a_c)` or v2's, m/s².
    pub a: f64,
}

impl OdometryFlcTerms {
    /// The names of [`OdometryFlcTerms::to_terms`]: v2's but `held`/`pending`, then the
    /// estimate, the comfort term and the command.
    pub const NAMES: &'static [&'static str] =
        &["distance", "gap_speed", "envelope_speed", "approach_speed", "target_speed", "held", "latched", "a_v2", "closing", "comfort_accel", "comfort", "a"];

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
                self.comfort_accel,
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
    comfort: IdmParams,
    closing: OdometryClosing,
    terms: OdometryFlcTerms,
}

impl OdometryFallbackController {
    /// Validates both parameter sets and builds the controller.
    pub fn new(base: RobustFlc2Params, params: OdometryFlcParams) -> Result<Self, ParamError> {
        params.validate()?;
        let comfort = params.comfort_model(&base);
        Ok(Self { base: RobustFallbackController2::new(base)?, params, comfort, closing: OdometryClosing::default(), terms: OdometryFlcTerms::default() })
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
        let odometer = travelled.filter(|s| s.is_finite());
        // v2's acceptance decides what the estimate may compare: a held frame interrupts (and a
        // pending jump may be another object), a reveal starts over.
        if t.held || out.status != crate::Status::Ok || odometer.is_none() {
            self.closing.anchor = None;
            if t.pending || odometer.is_none() {
                self.closing.forget();
            }
        } else {
            if t.revealed {
                self.closing.forget();
                self.closing.anchor = None;
            }
            self.closing.observe(t.distance, own_speed, odometer.unwrap_or(0.0), &self.params);
        }
        let closing = if t.held { None } else { self.closing.closing(&self.params) };
        let comfort_accel = closing.map(|c| self.comfort.accel(own_speed, own_speed - c, t.distance));
        let a = comfort_accel.map_or(t.a, |ac| t.a.min(ac.max(-self.base.params().law.max_decel)));
        self.terms = OdometryFlcTerms { base: t, closing: closing.unwrap_or(0.0), comfort_accel: comfort_accel.unwrap_or(0.0), comfort: comfort_accel.is_some(), a };
        if comfort_accel.is_none() || a == t.a {
            return out;
        }
        let law = &self.base.params().law;
        let speed = law.speed_command(own_speed, a);
        if !(a.is_finite() && speed.is_finite()) {
            return safe_brake(own_speed, true, law.fault_brake_step, crate::Status::InvalidDistance);
        }
        LongitudinalCommand { speed, accel: a, status: out.status }
    }
}

/// The odometry variant through the common interface: reads `frame.travelled`; `dt` and V2V are
/// never read.
///
/// ```
/// use flc_core::{Frame, LongitudinalController, OdometryFallbackController, OdometryFlcParams, RobustFlc2Params};
///
/// let mut c = OdometryFallbackController::new(RobustFlc2Params::default(), OdometryFlcParams::default())?;
/// // Both at 20 m/s, 40 m apart (v2's desired gap is 33 m): once the distance stays, v2 approaches.
/// let (v, mut s) = (20.0, 0.0);
/// for k in 0..30 {
///     let frame = Frame { travelled: Some(s), ..Frame::new(Some(40.0 - 0.5 * k as f64), v, 0.05) };
///     LongitudinalController::step(&mut c, &frame);
///     s += v * 0.05;
/// }
/// // Closing at 10 m/s per metre driven (0.5 m of gap per metre... per 1 m driven at 20 m/s):
/// // the estimate is ĉ = 20 * 0.5 / 1 = 10 m/s, and the comfort term brakes earlier than v2.
/// let t = c.terms();
/// assert!((t.closing - 10.0).abs() < 1e-9);
/// assert!(t.comfort && t.a < t.base.a);
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
