//! Robust FLC v2 (issue 24; the simulator's `controller = "flc-robust"`): the robust FLC's laws (R1)-(R6)
//! ([`crate::flc_robust`]) with event rules that do not brake for what a missed or spurious frame
//! looks like. Same inputs: the LiDAR distance (`None` without a detection) and the own speed, once
//! per LiDAR frame; no timestamp, no `dt`, no lead speed, no V2V.
//!
//! What changes against v1 (`docs/robust-flc.md`, "v2"):
//!
//! - **A missed frame is not a reveal.** v1 forgot the lead on any frame without a detection and
//!   latched the stop envelope on the next one: one missed detection while following at
//!   72-130 km/h commanded about -10 m/s² (phantom braking). v2 keeps the last accepted distance;
//!   a detection within `reveal_jump` of where the last two accepted frames put it
//!   (`last + trend`) is the same object.
//! - **No detection: hold the speed** (`a = 0`) while the sight distance covers the stop envelope,
//!   `v <= V_e(sight_distance)`; above that speed, slow at `sight_decel`. v1 braked by
//!   `fault_brake_step` on every frame without a lead.
//! - **Jumps need a second frame.** A distance more than `reveal_jump` from `last + trend` (up:
//!   something revealed behind the lead; down: a cut-in, or a spurious short return) is held as
//!   *pending* and the frame is handled as a missed one; the next frame confirms it (no farther
//!   than the pending distance plus `reveal_jump`) or not (back on the trend). A confirmed
//!   distance more than `reveal_jump` beyond the last accepted one is a reveal. The trend keeps
//!   the test free of the frame rate: closing at 36 m/s moves the distance 3.6 m per frame at
//!   10 Hz.
//! - **The first detection is a reveal** (possibly standing; `first_object = "unknown"`). On a
//!   reveal frame the law holds at most; the stop envelope applies from the next frame while the
//!   latch survives (a reveal cannot yet show whether the object closes).
//! - **Release when the distance does not close while driving.** Besides v1's release (the
//!   distance grew `reveal_release` above its smallest value since the latch), the latch is
//!   released on a frame whose own speed is at least `release_speed` and whose distance is no more
//!   than `release_closing` below the previous accepted one: the follower moved forward by
//!   `v dt >= release_speed dt` since that frame, so a standing object would have come that much
//!   closer. This holds for frame rates up to `release_speed / (release_closing + 3 sqrt(2) sigma)`
//!   (with range noise `sigma`): 43 Hz with the defaults and 2 cm noise, 38 Hz with 3 cm.
//! - **The stop envelope assumes wet brakes**: `envelope_decel` 4 m/s² (v1: 7), so that an
//!   unknown object is approached in a way that stops before it on a road where the tyres give 6.
//!
//! - **A missed frame keeps the object where it was**: the law at the last accepted distance,
//!   never accelerating.
//! - **(R7) approach**: `v_0`, the own speed at which the distance was seen not to close (against
//!   the distance `d_0` when `v_0` was set, not the previous frame), caps the target speed on a
//!   closing frame at `V_a = v_0 + max(0, d - D_r(v_0)) / H` ([`RobustFlc2Params::approach_speed`]).
//! - **(R8) the lead's least speed**: `(u, d_1)`, the own speed and the distance on the last frame
//!   that showed the lead not closing; a lead that has since come `Δ = d_1 - d` closer may have
//!   braked at up to [`LEAD_DECEL`], so it is at least `u - sqrt(2 LEAD_DECEL Δ)` fast; on a
//!   closing frame the target speed is capped so that the follower stops behind it
//!   ([`RobustFlc2Params::closing_limit`]). (R7)'s `v_0` stays at the lead's old speed while the
//!   follower is faster; (R8) follows a lead that brakes during the approach.
//! - **(R5') braking gain**: `brake_gain` 2.25 on the first `firm_error` of a negative speed
//!   error, `firm_gain` 4 beyond ([`RobustFlc2Params::acceleration`]).
//!
//! - **(C1)-(C2) comfort behind a braking lead** ([`crate::comfort`]): a closing-speed estimate
//!   timed by the law's own motion (`Δτ = Δv / â`, `â` the modelled response to its command) and
//!   IDM's braking strategy for it, never above the command of the rules above.
//!
//! None of the rules counts frames or reads a clock; "the next frame" is the next measurement
//! event.

use crate::comfort::{ClosingEstimate, ComfortParams};
use crate::command::{LongitudinalCommand, Status, safe_brake, valid_speed};
use crate::flc_robust::{FirstObject, RobustFlcParams};
use crate::longitudinal::ActiveController;
use crate::longitudinal::{ControlOutput, Frame, LongitudinalController, Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// (R8) the largest deceleration assumed for the lead since it was last seen not closing, m/s²:
/// about 1 g, what a car's tyres give on a dry road.
pub const LEAD_DECEL: f64 = 10.0;

/// (R8) the deceleration at which both the lead (from its least speed on) and the follower are
/// taken to brake when the approach is capped, m/s²: the weakest brakes of the robust FLC's
/// stated envelope (`docs/robust-flc.md`: 6-8 m/s²; the falsifier's `follower.vehicle.max_brake`
/// range). 4 m/s² (the stop envelope's wet `b_s`) raised CCRb 40 m / -2 m/s²'s braking from 3.2
/// to 3.7 m/s², over the comfort target.
pub const APPROACH_DECEL: f64 = 6.0;

/// Parameters of the robust FLC v2: the v1 law's parameters ([`RobustFlcParams`], same meaning)
/// and the event rules'. `Default` is the documented design.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustFlc2Params {
    /// (R1)-(R6) as in v1; defaults as v1 except `envelope_decel` 4.0 m/s², `brake_gain`
    /// 2.25 1/s (`docs/robust-flc.md`, "v2": the band 2-2.5 that passes both the stop-and-go jerk
    /// and CCRb 40 m / 6 m/s² under the impairments) and `first_object`
    /// [`FirstObject::Unknown`].
    pub law: RobustFlcParams,
    /// Distance within which the detector finds a standing car on the path, m: without a
    /// detection the follower holds its speed up to `V_e(sight_distance)`. Default 200 (the
    /// default detector and LiDAR, `docs/detector.md`).
    pub sight_distance: f64,
    /// Deceleration without a detection above `V_e(sight_distance)`, m/s². Default 2.0.
    pub sight_decel: f64,
    /// Smallest own speed for the "not closing" release, m/s. Default 8 (below 8.9 m/s the stop
    /// envelope at 4 m/s², `2 + 0.5 v + v²/8`, is shorter than the desired gap `3 + 1.5 v`, so
    /// the latch costs nothing while following).
    pub release_speed: f64,
    /// Largest decrease of the distance between two accepted frames that still counts as "not
    /// closing", m. Default 0.1 (3.5 sigma of the difference of two readings with the default
    /// LiDAR's 2 cm noise).
    pub release_closing: f64,
    /// `H`, time gap of the approach (R7), s: the gap policy (R2) asks for a closing speed of the
    /// gap excess over `h`, the approach over `H`. Default 6 (from twice the desired gap, within
    /// 10 % after 20 s at 50-130 km/h).
    pub approach_time_gap: f64,
    /// Speed error (m/s) up to which a negative error is braked for with `brake_gain` (R5').
    /// Default 1.5 (`docs/robust-flc.md`, "v2": the stop-and-go jerk passes at 1 and 2, not at
    /// 0.5; smaller values brake harder for a hard-braking lead).
    pub firm_error: f64,
    /// Gain on the part of a negative speed error beyond `firm_error` (R5'), 1/s. Default 4.0
    /// (v1's `brake_gain`).
    pub firm_gain: f64,
    /// (C1)-(C2) the comfort layer, `[flc_robust.comfort]` ([`ComfortParams`]).
    pub comfort: ComfortParams,
}

impl Default for RobustFlc2Params {
    fn default() -> Self {
        Self::documented()
    }
}

impl RobustFlc2Params {
    /// The documented design (identical to `Default`).
    pub const fn documented() -> Self {
        let mut law = RobustFlcParams::documented();
        law.envelope_decel = 4.0;
        law.brake_gain = 2.25;
        law.first_object = FirstObject::Unknown;
        Self {
            law,
            sight_distance: 200.0,
            sight_decel: 2.0,
            release_speed: 8.0,
            release_closing: 0.1,
            approach_time_gap: 6.0,
            firm_error: 1.5,
            firm_gain: 4.0,
            comfort: ComfortParams::documented(),
        }
    }

    /// (R7) the approach speed `V_a(d, v_0) = v_0 + e / H` with the gap excess
    /// `e = max(0, d - D_r(v_0))` over the desired gap of a lead at `v_0` (R1), m/s.
    pub fn approach_speed(&self, distance: f64, lead_speed: f64) -> f64 {
        lead_speed + (distance - self.law.desired_gap(lead_speed)).max(0.0) / self.approach_time_gap
    }

    /// (R8) the speed from which the follower still stops behind a lead that was last seen not
    /// closing at own speed `u` and distance `d_1` and has since come `Δ = d_1 - d` closer: that
    /// lead may have braked at up to `LEAD_DECEL` since, so its speed is at least
    /// `u_l = max(0, u - sqrt(2 LEAD_DECEL Δ))` (a deficit `w` below `u` takes a closing of at least
    /// `w² / (2 LEAD_DECEL)` while the follower is not slower than `u`); it then brakes no harder
    /// than `APPROACH_DECEL` (`b`), and the follower, reacting after the stop envelope's `T_s`
    /// and braking at `b`, stops the envelope's `d_s` behind it: the speed `V` that solves
    /// `d_s + T_s V + V² / (2 b) = d + u_l² / (2 b)` (as (R3) solves it for a standing object), m/s.
    ///
    /// ```
    /// let p = flc_core::RobustFlc2Params::default();
    /// // Seen not closing at 25 m/s and 78 m, now 73 m: the lead is at least 15 m/s fast.
    /// assert!((p.closing_limit(73.0, 25.0, 78.0) - 29.954514106568162).abs() < 1e-9);
    /// ```
    pub fn closing_limit(&self, distance: f64, u: f64, d1: f64) -> f64 {
        let closed = (d1 - distance).max(0.0);
        let lead = (u - libm::sqrt(2.0 * LEAD_DECEL * closed)).max(0.0);
        let b = APPROACH_DECEL;
        let (t, x) = (self.law.envelope_reaction, distance + lead * lead / (2.0 * b) - self.law.envelope_margin);
        if x > 0.0 { b * (libm::sqrt(t * t + 2.0 * x / b) - t) } else { 0.0 }
    }

    /// (R5') the acceleration toward `target_speed`: (R5) with `k_b` on the first
    /// `firm_error` m/s of a negative speed error and `firm_gain` on the rest, clamped to
    /// `[-b_max, a_max]`, m/s².
    pub fn acceleration(&self, target_speed: f64, own_speed: f64) -> f64 {
        let error = target_speed - own_speed;
        if error >= 0.0 {
            return self.law.acceleration(target_speed, own_speed);
        }
        let near = error.max(-self.firm_error);
        let a = self.law.brake_gain * near + self.firm_gain * (error - near);
        a.max(-self.law.max_decel)
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.law.validate().map_err(|e| ParamError { field: law_field(e.field), problem: e.problem })?;
        check_positive("sight_distance", self.sight_distance, 1.0e4, "must be finite and in (0, 1e4] m")?;
        check_positive("sight_decel", self.sight_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_range("release_speed", self.release_speed, 0.0, 1000.0, "must be finite and in [0, 1000] m/s")?;
        check_range("release_closing", self.release_closing, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_range("firm_error", self.firm_error, 0.0, 1000.0, "must be finite and in [0, 1000] m/s")?;
        check_positive("firm_gain", self.firm_gain, 1000.0, "must be finite and in (0, 1000] 1/s")?;
        check_positive("approach_time_gap", self.approach_time_gap, 100.0, "must be finite and in (0, 100] s")?;
        self.comfort.validate().map_err(|e| ParamError { field: comfort_field(e.field), problem: e.problem })?;
        Ok(())
    }
}

/// A v1 field's name inside v2's parameters (`law.<field>`): errors name the key a scenario
/// file or Python sets.
fn law_field(field: &str) -> &'static str {
    crate::params::nested_field!(
        "law",
        field,
        [
            "standstill_gap",
            "time_gap",
            "accel_gain",
            "brake_gain",
            "max_accel",
            "max_decel",
            "envelope_decel",
            "envelope_reaction",
            "envelope_margin",
            "reveal_jump",
            "reveal_release",
            "command_gain",
            "max_speed",
            "max_distance",
            "fault_brake_step",
        ]
    )
}

/// A comfort field's name inside v2's parameters (`comfort.<field>`).
fn comfort_field(field: &str) -> &'static str {
    crate::params::nested_field!("comfort", field, ["memory", "response_time", "clock_accel", "accel", "decel", "fade_speed", "max_decel"])
}

/// The terms of one v2 step (for plots, logs and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RobustFlc2Terms {
    /// The distance the law used (the accepted one), m; 0 on a frame handled as missed.
    pub distance: f64,
    /// (R2) gap speed, m/s.
    pub gap_speed: f64,
    /// (R3) stop-envelope speed, m/s.
    pub envelope_speed: f64,
    /// (R7)-(R8) approach speed, m/s (`max_speed` before the lead's speed has shown).
    pub approach_speed: f64,
    /// (R4) target speed, m/s.
    pub target_speed: f64,
    /// This frame was handled as missed (no detection, or a jump pending confirmation).
    pub held: bool,
    /// A jump is pending confirmation after this frame.
    pub pending: bool,
    /// This frame set the latch.
    pub revealed: bool,
    /// The latch is set after this frame.
    pub latched: bool,
    /// (R5') the laws' acceleration before the comfort layer, m/s².
    pub a_law: f64,
    /// (C1) closing speed `ĉ`, m/s (0 without an estimate).
    pub closing: f64,
    /// (C2) the braking strategy's `Δa`, m/s² (0 without an estimate).
    pub closing_brake: f64,
    /// (C1) an estimate was available on this frame.
    pub comfort: bool,
    /// The commanded acceleration, m/s².
    pub a: f64,
}

/// The robust FLC v2. Construct with [`RobustFallbackController2::new`], call
/// [`RobustFallbackController2::step`] once per LiDAR frame.
#[derive(Debug, Clone)]
pub struct RobustFallbackController2 {
    params: RobustFlc2Params,
    /// Last accepted distance, kept across missed frames.
    last: Option<f64>,
    /// A jump waiting for the next frame's confirmation.
    pending: Option<f64>,
    /// Change of the distance between the last two accepted frames when they were consecutive
    /// (0 after a reveal or a frame handled as missed), m: the next frame is expected at
    /// `last + trend`.
    trend: f64,
    /// Smallest distance since the latch was set; `None` while not latched.
    latch_min: Option<f64>,
    /// `(v_0, d_0)` of (R7): `v_0` estimates the lead's speed from below, `d_0` is the distance
    /// when it was last lowered or first set (`None` until the first frame after a reveal).
    reference: Option<(f64, f64)>,
    /// `(u, d)` of (R8): the own speed and the distance on the last frame that showed the lead
    /// not closing (`None` until the first such frame after a reveal).
    pulling: Option<(f64, f64)>,
    /// (C1) the closing-speed estimate.
    estimate: ClosingEstimate,
    terms: RobustFlc2Terms,
}

impl RobustFallbackController2 {
    /// Validates `params` and builds the controller.
    pub fn new(params: RobustFlc2Params) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self {
            params,
            last: None,
            pending: None,
            trend: 0.0,
            latch_min: None,
            reference: None,
            pulling: None,
            estimate: ClosingEstimate::default(),
            terms: RobustFlc2Terms::default(),
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &RobustFlc2Params {
        &self.params
    }

    /// Forgets everything; the next detection is a first detection.
    pub fn reset(&mut self) {
        self.last = None;
        self.pending = None;
        self.trend = 0.0;
        self.latch_min = None;
        self.reference = None;
        self.pulling = None;
        self.estimate = ClosingEstimate::default();
        self.terms = RobustFlc2Terms::default();
    }

    /// The terms of the last step.
    pub fn terms(&self) -> &RobustFlc2Terms {
        &self.terms
    }

    /// Whether the "possibly standing object" latch is set.
    pub fn latched(&self) -> bool {
        self.latch_min.is_some()
    }

    /// One LiDAR frame: `distance` in m (`None` without a detection), `own_speed` in m/s.
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64) -> LongitudinalCommand {
        self.step_timed(distance, own_speed, None)
    }

    /// One frame, the comfort layer's clock from the law's motion (`wheels = None`) or from the
    /// wheels (`Some((odometer, min_speed))`, the odometry variant).
    pub(crate) fn step_timed(&mut self, distance: Option<f64>, own_speed: f64, wheels: Option<(f64, f64)>) -> LongitudinalCommand {
        let out = self.step_laws(distance, own_speed);
        let mut t = self.terms;
        let c = self.params.comfort;
        // v2's acceptance decides what the estimate may compare: a held frame interrupts (and a
        // pending jump may be another object), a reveal starts over.
        let (estimate, a) = if !t.held && out.status == Status::Ok {
            if t.revealed {
                self.estimate = ClosingEstimate::default();
            }
            match wheels {
                Some((s, min_speed)) => self.estimate.observe_wheels(t.distance, own_speed, s, min_speed, &c),
                None => self.estimate.observe_motion(t.distance, own_speed, self.params.release_closing, &c),
            }
            let (law, h) = (&self.params.law, self.params.approach_time_gap);
            let estimate = self.estimate.closing(&c).map(|k| (k, c.closing_brake(law, h, own_speed, k, t.distance)));
            (estimate, c.compose(law, own_speed, t.a, estimate, wheels.is_none()))
        } else {
            self.estimate.interrupt();
            if t.pending {
                self.estimate.forget();
            }
            (None, t.a)
        };
        self.estimate.commanded(a);
        t.a_law = t.a;
        (t.closing, t.closing_brake) = estimate.unwrap_or((0.0, 0.0));
        t.comfort = estimate.is_some();
        t.a = a;
        self.terms = t;
        if a == t.a_law { out } else { self.command(own_speed, a, out.status) }
    }

    /// (R1)-(R7) and the event rules on one frame.
    fn step_laws(&mut self, distance: Option<f64>, own_speed: f64) -> LongitudinalCommand {
        let p = self.params;
        let law = p.law;
        let speed_ok = valid_speed(own_speed, law.max_speed);
        let status = match distance {
            _ if !speed_ok => Status::InvalidSpeed,
            None => Status::NoLead,
            Some(d) if !(d.is_finite() && d >= 0.0 && d <= law.max_distance) => Status::InvalidDistance,
            Some(_) => Status::Ok,
        };
        if !speed_ok || status == Status::InvalidDistance {
            self.pending = None;
            self.terms = RobustFlc2Terms { held: true, latched: self.latched(), ..RobustFlc2Terms::default() };
            return safe_brake(own_speed, speed_ok, law.fault_brake_step, status);
        }
        let v = own_speed;
        // A distance within `reveal_jump` of where the last two frames put it (`last + trend`) is
        // the followed object; a jump waits for the next frame. The next frame confirms it when
        // it is no farther than the jump (plus `reveal_jump`): the object is still there (a cut-in,
        // a revealed object, also when closing fast), and a one-frame spurious short return is
        // not, its next frame is back where the trend puts it. Extrapolating the trend keeps the
        // test free of the frame rate: closing at 36 m/s moves the distance 3.6 m per frame at
        // 10 Hz, 1.8 m at 20 Hz, while the change of that change is at most 0.1 m at 10 m/s².
        let accepted = match (distance, self.last) {
            (None, _) => {
                self.pending = None;
                None
            }
            (Some(d), None) => Some((d, law.first_object == FirstObject::Unknown, 0.0)),
            (Some(d), Some(last)) if libm::fabs(d - (last + self.trend)) <= law.reveal_jump => {
                self.pending = None;
                Some((d, false, d - last))
            }
            (Some(d), Some(last)) => match self.pending.take() {
                Some(q) if d <= q + law.reveal_jump => {
                    let revealed = d > last + law.reveal_jump;
                    Some((d, revealed, if revealed { 0.0 } else { d - q }))
                }
                _ => {
                    self.pending = Some(d);
                    None
                }
            },
        };
        let Some((d, revealed, trend)) = accepted else {
            self.trend = 0.0;
            return self.hold(v, status);
        };
        self.trend = trend;

        let previous = self.last.replace(d);
        // Not closing: the distance fell by at most `release_closing` since the previous accepted
        // frame (`None` on a reveal, whose previous distance belongs to another object).
        let not_closing = if revealed { None } else { previous.map(|prev| d >= prev - p.release_closing) };
        if revealed {
            self.latch_min = Some(d);
        } else if let Some(m) = self.latch_min {
            let m = m.min(d);
            let grew = d >= m + law.reveal_release;
            let moving = v >= p.release_speed && not_closing == Some(true);
            self.latch_min = if grew || moving { None } else { Some(m) };
        }
        // (R7) `v_0`: a distance no smaller than at `d_0` (less `release_closing`) while at `v`
        // shows a lead that was at least as fast on average (raise `v_0` to `v`); a closing frame
        // while slower than `v_0` shows a lead slower than `v` (lower `v_0` to `v`, `d_0` to `d`).
        // Comparing with `d_0` rather than the previous frame keeps the test free of the frame
        // rate: a follower that speeds up past the lead closes by `release_closing` after a
        // distance, not after a frame.
        self.reference = match (not_closing, self.reference) {
            (None, _) if revealed => None,
            (_, None) if previous.is_some() => Some((v, d)),
            (Some(false), Some((v0, _))) if v < v0 => Some((v, d)),
            (_, Some((v0, d0))) if d >= d0 - p.release_closing => Some((v0.max(v), d0)),
            (_, r) => r,
        };
        self.pulling = match not_closing {
            None if revealed => None,
            Some(true) => Some((v, d)),
            _ => self.pulling,
        };
        // (R7) limits a closing speed: it does not apply on a frame that shows none.
        let mut terms = self.law_terms(d, v, revealed, not_closing != Some(true));
        terms.revealed = revealed;
        self.terms = terms;
        self.command(v, terms.a, Status::Ok)
    }

    /// (R2)-(R5), (R7) and (R8) at distance `d` with the current latch and reference.
    fn law_terms(&self, d: f64, v: f64, revealed: bool, approach: bool) -> RobustFlc2Terms {
        let p = self.params;
        let law = p.law;
        let latched = self.latched();
        let gap_speed = law.gap_speed(d);
        let envelope_speed = law.envelope_speed(d);
        let approach_speed = match self.reference {
            Some((v0, _)) if approach => p.approach_speed(d, v0).min(law.max_speed),
            _ => law.max_speed,
        };
        let approach_speed = match self.pulling {
            Some((u, d1)) if approach && d > law.desired_gap(v) => approach_speed.min(p.closing_limit(d, u, d1)),
            _ => approach_speed,
        };
        // On the reveal frame itself the law cannot yet tell a standing object from a moving one:
        // it holds at most (the envelope's reaction time `T_s` covers the frame); from the next
        // frame on, a latch that survived applies the envelope.
        let target_speed = match (revealed, latched) {
            (true, _) => gap_speed.min(v),
            (false, true) => gap_speed.min(envelope_speed),
            (false, false) => gap_speed,
        }
        .min(approach_speed);
        let a = p.acceleration(target_speed, v);
        RobustFlc2Terms { distance: d, gap_speed, envelope_speed, approach_speed, target_speed, latched, a, ..RobustFlc2Terms::default() }
    }

    /// A frame without a usable detection. With an accepted distance, the object is taken to be
    /// still there: the law at the last accepted distance, never accelerating (`min(a, 0)`).
    /// Without one (or when the speed exceeds `V_e(sight_distance)`), hold the speed up to
    /// `V_e(sight_distance)`, slow at `sight_decel` above it.
    fn hold(&mut self, v: f64, status: Status) -> LongitudinalCommand {
        let p = self.params;
        let limit = p.law.envelope_speed(p.sight_distance);
        let sight = if v > limit { -p.sight_decel } else { 0.0 };
        let mut terms = self.last.map_or_else(RobustFlc2Terms::default, |d| self.law_terms(d, v, false, true));
        terms.a = terms.a.min(sight);
        terms.held = true;
        terms.pending = self.pending.is_some();
        terms.latched = self.latched();
        self.terms = terms;
        self.command(v, terms.a, status)
    }

    /// The speed command for acceleration `a` at own speed `v` (`law.speed_command`), or the safe
    /// brake when either is not finite.
    fn command(&self, v: f64, a: f64, status: Status) -> LongitudinalCommand {
        let law = self.params.law;
        let speed = law.speed_command(v, a);
        if !(a.is_finite() && speed.is_finite()) {
            return safe_brake(v, true, law.fault_brake_step, Status::InvalidDistance);
        }
        LongitudinalCommand { speed, accel: a, status }
    }
}

impl RobustFlc2Terms {
    /// The names of [`RobustFlc2Terms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] = &[
        "distance",
        "gap_speed",
        "envelope_speed",
        "approach_speed",
        "target_speed",
        "held",
        "pending",
        "revealed",
        "latched",
        "a_law",
        "closing",
        "closing_brake",
        "comfort",
        "a",
    ];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[
                t.distance,
                t.gap_speed,
                t.envelope_speed,
                t.approach_speed,
                t.target_speed,
                flag(t.held),
                flag(t.pending),
                flag(t.revealed),
                flag(t.latched),
                t.a_law,
                t.closing,
                t.closing_brake,
                flag(t.comfort),
                t.a,
            ],
        )
    }
}

/// The robust FLC v2 through the common interface; `dt` and V2V are never read.
///
/// ```
/// use flc_core::{Frame, LongitudinalController, RobustFallbackController2, RobustFlc2Params};
///
/// let mut c = RobustFallbackController2::new(RobustFlc2Params::default())?;
/// // The first detection, 33 m ahead at 20 m/s, is possibly standing: hold on this frame.
/// let out = LongitudinalController::step(&mut c, &Frame::new(Some(33.0), 20.0, 0.05));
/// assert_eq!(out.command.accel, 0.0);
/// // Next frame 1 m closer: still closing, so the stop envelope at 4 m/s² applies:
/// // V_e(32) = 4 (sqrt(0.25 + 2 * 30 / 4) - 0.5) = 13.62 m/s, a = 2.25 (13.62 - 20) = -14.4,
/// // clamped to -10.
/// let out = LongitudinalController::step(&mut c, &Frame::new(Some(32.0), 20.0, 0.05));
/// assert_eq!(out.command.accel, -10.0);
/// // Next frame at the same distance while driving at 20 m/s: it moves, the latch is released.
/// let out = LongitudinalController::step(&mut c, &Frame::new(Some(32.0), 20.0, 0.05));
/// assert!(!c.latched() && out.command.accel > -4.0);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for RobustFallbackController2 {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = RobustFallbackController2::step(self, frame.distance, frame.own_speed);
        ControlOutput::single(command, self.terms.to_terms(), ActiveController::Flc)
    }

    fn reset(&mut self) {
        RobustFallbackController2::reset(self);
    }

    /// (R1): `d_0 + h max(v, 0)`.
    fn desired_gap(&self, v: f64) -> f64 {
        self.params.law.desired_gap(v)
    }

    fn uses_dt(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ctl() -> RobustFallbackController2 {
        RobustFallbackController2::new(RobustFlc2Params::default()).unwrap()
    }

    /// Following at the desired gap at `v` (the first detection's latch released by the lead
    /// moving away by `reveal_release`).
    fn following(v: f64) -> (RobustFallbackController2, f64) {
        let mut c = ctl();
        let d = c.params.law.desired_gap(v);
        c.step(Some(d), v);
        c.step(Some(d + 0.6), v);
        c.step(Some(d), v);
        assert!(!c.latched());
        (c, d)
    }

    #[test]
    fn law_errors_name_the_law_key() {
        // Every field v1 checks, made non-finite: v2 names it as `law.<field>`, and the names
        // agree with v1's own error.
        macro_rules! bad {
            ($f:ident) => {
                let mut p = RobustFlc2Params::default();
                p.law.$f = f64::NAN;
                let v1 = p.law.validate().unwrap_err().field;
                assert_eq!(v1, stringify!($f));
                assert_eq!(p.validate().unwrap_err().field, concat!("law.", stringify!($f)));
            };
        }
        bad!(standstill_gap);
        bad!(time_gap);
        bad!(accel_gain);
        bad!(brake_gain);
        bad!(max_accel);
        bad!(max_decel);
        bad!(envelope_decel);
        bad!(envelope_reaction);
        bad!(envelope_margin);
        bad!(reveal_jump);
        bad!(reveal_release);
        bad!(command_gain);
        bad!(max_speed);
        bad!(max_distance);
        bad!(fault_brake_step);
    }

    #[test]
    fn fast_closing_frames_are_accepted_at_any_rate() {
        // A standing car first seen 190 m ahead at 36 m/s: at 10 Hz the distance falls 3.6 m per
        // frame, more than `reveal_jump`. After the first two frames every frame is where the
        // trend puts it: none is held, and the law brakes before the envelope runs out.
        let mut c = ctl();
        let v = 36.0;
        let mut held = 0;
        for k in 0..20 {
            c.step(Some(190.0 - 3.6 * k as f64), v);
            held += usize::from(c.terms().held);
        }
        assert!(held <= 1, "{held} frames held");
        assert!(c.terms().a < -1.0, "{:?}", c.terms());
        // A one-frame spurious short return among them is held, never used; it costs the trend,
        // so the next true frame (7.2 m on) waits one frame and the one after confirms it.
        let last = 190.0 - 3.6 * 19.0;
        let a = c.terms().a;
        let out = c.step(Some(0.4 * last), v);
        assert!(c.terms().held && c.terms().pending && out.accel <= a.min(0.0) + 1e-9, "{:?}", c.terms());
        c.step(Some(last - 7.2), v);
        assert!(c.terms().held && c.terms().pending, "{:?}", c.terms());
        c.step(Some(last - 10.8), v);
        let t = *c.terms();
        assert!(!t.held && !t.revealed && t.distance == last - 10.8, "{t:?}");
    }

    #[test]
    fn a_missed_frame_while_following_holds_the_speed() {
        for kmh in [30.0, 72.0, 100.0, 130.0] {
            let v = kmh / 3.6;
            let (mut c, d) = following(v);
            let out = c.step(None, v);
            assert_eq!((out.accel, out.speed, out.status), (0.0, v, Status::NoLead), "{kmh} km/h");
            // The lead is back at about the same distance: the same object, no latch.
            let out = c.step(Some(d - 0.05), v);
            assert!(!c.latched() && out.accel > -0.5, "{kmh} km/h: {out:?}");
        }
    }

    #[test]
    fn a_one_frame_spurious_short_return_is_held_not_braked_for() {
        let v = 25.0;
        let (mut c, d) = following(v);
        let out = c.step(Some(4.0), v);
        assert_eq!(out.accel, 0.0);
        assert!(c.terms().pending);
        let out = c.step(Some(d), v);
        assert!(out.accel.abs() < 1e-9 && !c.latched());
    }

    #[test]
    fn a_confirmed_cut_in_is_braked_for_one_frame_later() {
        let v = 25.0;
        let (mut c, _) = following(v);
        assert_eq!(c.step(Some(12.0), v).accel, 0.0);
        let out = c.step(Some(11.9), v);
        assert_eq!(out.accel, -10.0);
        // A downward jump is not a reveal: the gap policy already brakes.
        assert!(!c.latched());
    }

    #[test]
    fn a_confirmed_upward_jump_is_a_reveal() {
        let v = 25.0;
        let (mut c, d) = following(v);
        c.step(Some(d + 30.0), v);
        assert!(!c.latched());
        c.step(Some(d + 29.0), v);
        assert!(c.latched() && c.terms().revealed);
    }

    #[test]
    fn the_first_detection_is_possibly_standing_until_it_does_not_close() {
        let mut c = ctl();
        let v = 22.2;
        // CCRs-80: a standing car first seen at 88.9 m is latched and stays latched while the
        // distance closes as the follower drives (1.1 m per frame at 20 Hz).
        c.step(Some(88.9), v);
        assert!(c.latched());
        c.step(Some(87.8), v);
        c.step(Some(86.7), v);
        assert!(c.latched());
        // A lead at the same speed: the distance stays, released on the second frame.
        let mut c = ctl();
        c.step(Some(88.9), v);
        c.step(Some(88.88), v);
        assert!(!c.latched());
        // Below release_speed only growth releases.
        let mut c = ctl();
        c.step(Some(20.0), 6.0);
        c.step(Some(20.0), 6.0);
        assert!(c.latched());
        c.step(Some(20.6), 6.0);
        assert!(!c.latched());
    }

    #[test]
    fn without_a_detection_the_speed_is_held_up_to_the_sight_limit() {
        let mut c = ctl();
        let limit = c.params.law.envelope_speed(c.params.sight_distance);
        assert!(limit > 130.0 / 3.6, "V_e(200 m) = {limit} m/s");
        assert_eq!(c.step(None, 30.0).accel, 0.0);
        assert_eq!(c.step(None, limit + 1.0).accel, -2.0);
    }

    #[test]
    fn the_approach_closes_no_faster_than_the_excess_gap_over_h_prime() {
        // Both at 25 m/s, twice the desired gap (78 m) apart: the first detection holds, the
        // second shows the lead moving (not closing) and sets v_0 = 25 m/s.
        let mut c = ctl();
        let (v, d) = (25.0, 2.0 * c.params.law.desired_gap(25.0));
        c.step(Some(d), v);
        let out = c.step(Some(d), v);
        assert!(!c.latched() && out.accel > 0.0);
        // Closing at 27 m/s: V_a = 25 + (d - 0.15 - 40.5) / 6 = 31.2 m/s while V_g = 49.6 m/s
        // ((R8) allows 31.9 m/s after 0.15 m of closing).
        let out = c.step(Some(d - 0.15), 27.0);
        let t = *c.terms();
        assert!((t.approach_speed - (25.0 + (d - 0.15 - 40.5) / 6.0)).abs() < 1e-9, "{t:?}");
        assert!(c.params.closing_limit(d - 0.15, 25.0, d) > t.approach_speed + 0.5);
        assert_eq!(t.target_speed, t.approach_speed);
        assert!(t.gap_speed > t.approach_speed + 15.0);
        assert!((t.a_law - 2.0).abs() < 1e-12, "{t:?}");
        // (C2) limits the command to IDM's `a` before its first estimate (blended in at 27 m/s).
        assert!((out.accel - c.params.comfort.accel).abs() < 1e-12, "{out:?}");
        // Closing at 33 m/s, beyond V_a: the law slows although the gap is still large.
        let out = c.step(Some(d - 3.0), 33.0);
        assert!(out.accel < 0.0, "{out:?}");
        // A frame that does not close shows no closing speed to limit: the gap policy alone.
        let out = c.step(Some(d - 3.0), 26.0);
        assert_eq!(c.terms().approach_speed, c.params.law.max_speed);
        assert_eq!(c.terms().a_law, 2.0);
        assert!(out.accel <= 2.0);
    }

    #[test]
    fn a_closing_approach_is_capped_by_the_lead_s_least_speed() {
        // Both at 25 m/s, twice the desired gap apart; then 5 m of closing (in frames of 0.5 m)
        // at 25 m/s: the lead
        // may have lost sqrt(2 * 10 * 5) = 10 m/s, so (R8) caps the speed at
        // 30.50 m/s (the envelope's form at 6 m/s², from 76 + 15² / 12 m), below (R7)'s
        // 25 + (76 - 40.5) / 6 = 30.9 m/s.
        let mut c = ctl();
        let d = 2.0 * c.params.law.desired_gap(25.0);
        assert_eq!(d, 81.0);
        c.step(Some(d), 25.0);
        c.step(Some(d), 25.0);
        for k in 1..=10 {
            c.step(Some(d - 0.5 * f64::from(k)), 25.0);
        }
        let t = *c.terms();
        assert!((t.approach_speed - 30.49626844888845).abs() < 1e-9, "{t:?}");
        assert_eq!(t.approach_speed, c.params.closing_limit(d - 5.0, 25.0, d));
        // A frame that does not close starts over from its own speed and distance.
        c.step(Some(d - 5.0), 25.0);
        assert_eq!(c.terms().approach_speed, c.params.law.max_speed);
        for k in 1..=12 {
            c.step(Some(d - 5.0 - 0.5 * f64::from(k)), 25.0);
        }
        let t = *c.terms();
        assert_eq!(t.approach_speed, c.params.closing_limit(d - 11.0, 25.0, d - 5.0));
        assert!(t.approach_speed < c.params.approach_speed(d - 11.0, 25.0));
    }

    #[test]
    fn a_missed_frame_close_behind_an_object_brakes_as_at_its_last_distance() {
        let v = 16.0;
        let (mut c, _) = following(v);
        let seen = c.step(Some(1.5), v);
        assert_eq!(seen.accel, 0.0, "a jump is pending first");
        let seen = c.step(Some(1.4), v);
        assert_eq!(seen.accel, -10.0);
        // The object is lost from sight at 1.4 m: the law still brakes for it.
        let out = c.step(None, v);
        assert_eq!((out.accel, out.status), (-10.0, Status::NoLead));
        // While following, a missed frame never accelerates.
        let (mut c, d) = following(20.0);
        c.step(Some(d + 2.0), 20.0);
        assert!(c.terms().a > 0.0);
        assert_eq!(c.step(None, 20.0).accel, 0.0);
    }

    #[test]
    fn invalid_inputs_brake_and_name_the_reason() {
        let mut c = ctl();
        assert_eq!(c.step(Some(f64::NAN), 10.0).status, Status::InvalidDistance);
        assert_eq!(c.step(Some(10.0), f64::NAN).status, Status::InvalidSpeed);
        assert!(c.step(Some(-1.0), 10.0).accel < 0.0);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let p = RobustFlc2Params { sight_distance: f64::NAN, ..RobustFlc2Params::default() };
        assert_eq!(RobustFallbackController2::new(p).unwrap_err().field, "sight_distance");
        let mut p = RobustFlc2Params::default();
        p.law.time_gap = 0.0;
        assert_eq!(RobustFallbackController2::new(p).unwrap_err().field, "law.time_gap");
    }
}
