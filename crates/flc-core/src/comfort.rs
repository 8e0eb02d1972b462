//! Robust FLC v2's comfort layer (issue 24): (C1) a closing-speed estimate that needs no
//! timestamp and (C2) IDM's braking strategy for it, on top of v2's laws (R1)-(R7)
//! ([`crate::flc_robust2`]). Used by v2 (`controller = "flc-robust"`) with its own motion as the
//! clock, and by the odometry variant ([`crate::flc_robust_odo`]) with the wheels as the clock.
//!
//! Why (`docs/robust-flc.md`, "Comfort behind a braking lead"): v2's laws see a braking lead only
//! when the gap has fallen below the desired gap; in NCAP CCRb 40 m / -2 m/s² that is 3.8 s after
//! the brake onset, and the stop then needs 6.1 m/s². A careful driver brakes at 2.3 m/s² from
//! the onset because it sees the closing speed. Time is what a law on the distance and the own
//! speed lacks; it has one clock of its own, its motion:
//!
//! - **(C1) closing speed.** Between two consecutive accepted frames (v2's acceptance: a missed
//!   or pending frame interrupts, a reveal starts over) the follower's speed changed by `Δv`
//!   under the acceleration it commanded. The law models how its command is realized, a first
//!   order response with the time constant `response_time` (`â` follows the command `a`:
//!   `â ← a + (â - a) exp(-Δτ / τ_r)`), and reads the frame's duration from its own motion,
//!   `Δτ = Δv / â`, when `|â| >= clock_accel` and `Δv` has the sign of `â`; frames without that
//!   clock (the acceleration near zero) add nothing and the estimate holds. The closing speed is
//!   `ĉ = -Σ Δd / Σ Δτ` over sums discounted with the memory `memory`, once they cover half of
//!   it. No timestamp and no `dt`: `Δτ` is a ratio of the law's own inputs and outputs. A held
//!   estimate is forgotten when the distance contradicts it (it opened by more than v2's
//!   `release_closing` since the last frame with a clock while the estimate says closing, or the
//!   reverse). With the wheel odometry (the variant) `Δτ = Δs / v̄` instead.
//! - **(C2) IDM's braking strategy.** IDM (Treiber et al. 2000) brakes for a closing speed by
//!   lengthening its desired gap by `v ĉ / (2 sqrt(a b))`. On v2's gap policy the part of IDM's
//!   interaction this lengthening causes is
//!   `Δa = -a [(g + ĉ⁺ p)² - g²] / d²` ([`ComfortParams::closing_brake`]), `g = s_0 + v T` (v2's
//!   desired gap), with the pace `p = min(v / (2 sqrt(a b)), H)` capped at v2's approach time gap
//!   `H` (an approach at (R7)'s pace is not braked for). It is 0 without closing: steady
//!   following is v2's.
//! - **The command** is v2's `a_law` with the term, `min(a_law, a_law + Δa)`, limited to IDM's
//!   `a` (`accel`) plus v2's `accel_gain` times an opening speed (no approach at 2 m/s² toward a
//!   lead that may be braking), and to `-max_decel` (5 m/s²: harder braking is v2's laws'
//!   own); before the first estimate it is limited
//!   to `accel`. Below `fade_speed` it blends into `a_law` with the weight `(v / fade_speed)²`
//!   (v2's own stops are comfortable). With the motion clock, where a braking term would hold
//!   the command inside the clock's dead band (`|a| < clock_accel`) against a law that
//!   accelerates, it brakes at `clock_accel`: a law that reads time from its motion must keep
//!   moving to read it (without this a stale estimate cancelled the law for good, 1.1 m behind
//!   the desired gap). The wheels' clock needs no such rule. It never
//!   exceeds `a_law` ([`ComfortParams::compose`]): every bound of v2's laws (stop envelope, reveals,
//!   missed frames) holds unchanged.
//!
//! The clock trusts the vehicle only to realize its command within `response_time`; an error
//! there scales `ĉ` and so the comfort term, never v2's laws underneath it (the issue's
//! impairments, 0.3 + 0.3 s of actuator delay and untold 6 m/s² brakes, are in the tests).

use crate::flc_robust::RobustFlcParams;
use crate::params::{ParamError, check_positive};

/// Parameters of the comfort layer (C1)-(C2), `[flc_robust.comfort]` in a scenario file.
/// `Default` is the documented design.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComfortParams {
    /// (C1) memory of the closing-speed estimate, s of the estimate's own time `Δτ`. Default 1.0
    /// (0.3-1.5 meet the comfort target of CCRb 40 m / -2 m/s², 2 and 3 do not:
    /// `docs/robust-flc.md`, "How firm").
    pub memory: f64,
    /// (C1) time constant of the modelled response of the vehicle to the commanded acceleration,
    /// s. Default 0.45 (the default vehicle's 0.1 s dead time and 0.2 s lag behind the speed loop,
    /// `docs/sim-model.md`; CCRb 40 m / -2 m/s² meets the comfort target with 0.2-0.6, on the
    /// limit with 0.1 and 1.0).
    pub response_time: f64,
    /// (C1) smallest modelled acceleration that counts as a clock, m/s². Default 0.3 (near zero
    /// acceleration `Δv / â` tells no time: an error of 0.1 m/s² in the realized acceleration
    /// would be a third of it).
    pub clock_accel: f64,
    /// (C2) IDM's maximum acceleration `a`, m/s²: the scale of the braking strategy and the
    /// acceleration limit while closing. Default 0.85 (IDM's cars use 0.73-1.5: Treiber et al.
    /// 2000, Table I, 0.73; Treiber and Kesting, *Traffic Flow Dynamics*, 2013, 1.0-1.5).
    pub accel: f64,
    /// (C2) IDM's comfortable deceleration `b`, m/s². Default 1.67 (Treiber et al. 2000, Table I).
    pub decel: f64,
    /// Own speed from which (C2) applies in full, m/s; below it the command blends into v2's law
    /// with the weight `(v / fade_speed)²`. Default 14 (about 50 km/h: v2's stops and stop-and-go
    /// are comfortable on their own; with the full term down to standstill the stop-and-go 1-s
    /// jerk was 2.84 m/s³).
    pub fade_speed: f64,
    /// Largest deceleration the comfort layer commands, m/s²; harder braking is left to v2's
    /// laws, the safety layer underneath. Default 5 (the largest deceleration ISO 22179 allows a
    /// full-speed-range ACC, at low speed; without this limit IDM's term, `1 / d²`, braked at
    /// 10 m/s² in emergencies and made the stop depend on the LiDAR's latency: 0.52 m of
    /// standstill gap at 130 km/h behind a lead braking at 9 m/s², against 0.06 m with it).
    pub max_decel: f64,
}

impl Default for ComfortParams {
    fn default() -> Self {
        Self::documented()
    }
}

impl ComfortParams {
    /// The documented design (identical to `Default`).
    pub const fn documented() -> Self {
        Self { memory: 1.0, response_time: 0.45, clock_accel: 0.3, accel: 0.85, decel: 1.67, fade_speed: 14.0, max_decel: 5.0 }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_positive("memory", self.memory, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("response_time", self.response_time, 100.0, "must be finite and in (0, 100] s")?;
        check_positive("clock_accel", self.clock_accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("accel", self.accel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("decel", self.decel, 20.0, "must be finite and in (0, 20] m/s²")?;
        check_positive("fade_speed", self.fade_speed, 100.0, "must be finite and in (0, 100] m/s")?;
        check_positive("max_decel", self.max_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        Ok(())
    }

    /// (C2) IDM's braking strategy for the closing speed `c` at own speed `v` and distance `d`,
    /// m/s² (<= 0): `-a [(g + c⁺ p)² - g²] / d²` with v2's desired gap `g = D_r(v)` ((R1) of
    /// `law`) and the pace `p = min(v / (2 sqrt(a b)), H)` (`H` = v2's `approach_time_gap`; `d`
    /// floored at [`MIN_DISTANCE`]).
    ///
    /// ```
    /// use flc_core::{ComfortParams, RobustFlc2Params};
    ///
    /// let (p, base) = (ComfortParams::default(), RobustFlc2Params::default());
    /// let (law, h) = (&base.law, base.approach_time_gap);
    /// // Not closing: nothing (steady following is v2's).
    /// assert_eq!(p.closing_brake(law, h, 20.0, 0.0, 33.0), 0.0);
    /// // Closing at 4 m/s at v2's desired gap g = 3 + 1.5 * 20 = 33 m: the pace is
    /// // min(20 / (2 sqrt(0.85 * 1.67)), 6) = min(8.39, 6) = 6 s, so
    /// // Δa = -0.85 ((33 + 4 * 6)² - 33²) / 33² = -1.69 m/s².
    /// let a = p.closing_brake(law, h, 20.0, 4.0, 33.0);
    /// assert!((a + 1.686).abs() < 1e-3);
    /// ```
    pub fn closing_brake(&self, law: &RobustFlcParams, approach_time_gap: f64, v: f64, c: f64, d: f64) -> f64 {
        let v = v.max(0.0);
        let pace = (v / (2.0 * libm::sqrt(self.accel * self.decel))).min(approach_time_gap);
        let gap = law.desired_gap(v);
        let desired = gap + c.max(0.0) * pace;
        let d = d.max(MIN_DISTANCE);
        -self.accel * (desired * desired - gap * gap) / (d * d)
    }

    /// The command at own speed `v` from v2's laws' `a_law` (with `law`'s `accel_gain` and
    /// `max_decel`), with the closing speed `c` and its term `brake` =
    /// [`ComfortParams::closing_brake`] when there is an estimate (`None`: before the first,
    /// limited to `accel`), m/s². Never above `a_law`. With `motion_clock` (v2: the estimate is
    /// timed by the law's own motion) a braking term never parks the command in the clock's dead
    /// band against a law that accelerates (it would hold a stale estimate forever); there it
    /// brakes at `clock_accel`. The wheels' clock (the odometry variant) has no dead band.
    pub fn compose(&self, law: &RobustFlcParams, v: f64, a_law: f64, estimate: Option<(f64, f64)>, motion_clock: bool) -> f64 {
        let floor = -law.max_decel.min(self.max_decel);
        let full = match estimate {
            // IDM's acceleration limit `a`, raised by v2's gain on an opening speed: no approach
            // at v2's 2 m/s² toward a lead that may be braking, and no step where `ĉ` changes
            // sign.
            Some((c, brake)) => (a_law + brake).min(self.accel + law.accel_gain * (-c).max(0.0)).max(floor),
            None => a_law.min(self.accel),
        }
        .min(a_law);
        let share = (v / self.fade_speed).clamp(0.0, 1.0);
        let a = a_law + share * share * (full - a_law);
        let braking = estimate.is_some_and(|(_, brake)| brake < 0.0);
        if motion_clock && braking && a_law >= self.clock_accel && libm::fabs(a) < self.clock_accel {
            (-self.clock_accel).max(floor)
        } else {
            a
        }
    }
}

/// Smallest distance in (C2)'s `(s* / d)²`, m: IDM's `min_gap_floor`
/// ([`crate::baselines::IdmParams`]), so that a distance of 0 brakes fully instead of dividing by 0.
pub const MIN_DISTANCE: f64 = 0.01;

/// (C1) The closing-speed estimate: discounted sums of the distance's changes and of the clock's
/// times between consecutive accepted frames.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct ClosingEstimate {
    /// `(d, v, s)` of the last accepted frame while the next may be compared with it (`s`: the
    /// odometer, `None` when the frame was timed by the law's motion).
    anchor: Option<(f64, f64, Option<f64>)>,
    /// Discounted sum of the distance's changes, m.
    sum_d: f64,
    /// Discounted sum of the clock's times `Δτ`, s.
    sum_t: f64,
    /// The modelled realized acceleration `â`, m/s².
    response: f64,
    /// The acceleration commanded on the last frame, m/s².
    command: f64,
    /// The distance of the last frame that had a clock (`None` after [`ClosingEstimate::forget`]), m.
    clocked: Option<f64>,
}

impl ClosingEstimate {
    /// Drops the sums (the next comparison starts a new estimate).
    pub(crate) fn forget(&mut self) {
        self.sum_d = 0.0;
        self.sum_t = 0.0;
        self.clocked = None;
    }

    /// The next frame is not compared with the last one.
    pub(crate) fn interrupt(&mut self) {
        self.anchor = None;
    }

    /// The acceleration the law commanded on this frame (the command clock's input).
    pub(crate) fn commanded(&mut self, a: f64) {
        self.command = a;
    }

    fn add(&mut self, dd: f64, dt: f64, p: &ComfortParams) {
        let keep = (1.0 - dt / p.memory).max(0.0);
        self.sum_d = keep * self.sum_d + dd;
        self.sum_t = keep * self.sum_t + dt;
    }

    /// An accepted frame at `(d, v)`, timed by the law's own motion: `Δτ = Δv / â`. Without a
    /// clock the estimate holds until the distance contradicts it: once it has moved more than
    /// `noise` against the estimate's sign since the last frame with a clock (opened while it
    /// says closing, or closed while it says opening), it is forgotten.
    pub(crate) fn observe_motion(&mut self, d: f64, v: f64, noise: f64, p: &ComfortParams) {
        if let Some((d1, v1, _)) = self.anchor {
            let (dv, a) = (v - v1, self.response);
            let dt = (libm::fabs(a) >= p.clock_accel && dv * a > 0.0).then(|| dv / a);
            // The modelled response follows the command over the frame's time; without a clock
            // it is taken to have settled.
            self.response = match dt {
                Some(dt) => self.command + (a - self.command) * libm::exp(-dt / p.response_time),
                None => self.command,
            };
            match (dt, self.clocked, self.closing(p)) {
                (Some(dt), ..) => {
                    self.add(d - d1, dt, p);
                    self.clocked = Some(d);
                }
                (None, Some(dc), Some(c)) if (c > 0.0 && d > dc + noise) || (c < 0.0 && d < dc - noise) => self.forget(),
                _ => {}
            }
        }
        self.anchor = Some((d, v, None));
    }

    /// An accepted frame at `(d, v)` with the odometer at `s`, timed by the wheels:
    /// `Δτ = Δs / v̄` (a mean speed below `min_speed` starts over).
    pub(crate) fn observe_wheels(&mut self, d: f64, v: f64, s: f64, min_speed: f64, p: &ComfortParams) {
        if let Some((d1, v1, Some(s1))) = self.anchor {
            let (ds, mean) = (s - s1, 0.5 * (v + v1));
            if mean >= min_speed && ds > 0.0 {
                self.add(d - d1, ds / mean, p);
            } else {
                self.forget();
            }
        }
        self.anchor = Some((d, v, Some(s)));
    }

    /// `ĉ = -Σ Δd / Σ Δτ` once the sums cover half the memory, m/s.
    pub(crate) fn closing(&self, p: &ComfortParams) -> Option<f64> {
        (self.sum_t >= 0.5 * p.memory).then(|| -self.sum_d / self.sum_t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{RobustFallbackController2, Status};
    use proptest::prelude::*;

    /// Frames at irregular, unknown times of a follower accelerating exactly as commanded (`a`)
    /// while the gap closes at `c`: the estimate is `c` whatever the frame times.
    fn estimate_at(a: f64, c: f64, times: &[f64]) -> Option<f64> {
        let p = ComfortParams::default();
        let mut e = ClosingEstimate::default();
        e.commanded(a);
        // Settled: the first frame's comparison has no clock and takes the response as the command.
        e.response = a;
        for &t in times {
            e.observe_motion(60.0 - c * t, 20.0 + a * t, 0.1, &p);
            e.commanded(a);
        }
        e.closing(&p)
    }

    #[test]
    fn the_motion_clock_reads_the_closing_speed_at_any_frame_times() {
        let regular: std::vec::Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        // 10-40 Hz with jitter: the frame times never enter the law.
        let irregular: std::vec::Vec<f64> = (0..40).map(|k| 0.05 * k as f64 + 0.015 * ((k * 7 % 5) as f64 - 2.0)).collect();
        for times in [&regular, &irregular] {
            let c = estimate_at(1.0, 3.0, times).unwrap();
            assert!((c - 3.0).abs() < 1e-9, "{c}");
            let c = estimate_at(-2.0, 5.0, times).unwrap();
            assert!((c - 5.0).abs() < 1e-9, "{c}");
        }
        // Near zero acceleration there is no clock: no estimate.
        assert_eq!(estimate_at(0.1, 3.0, &regular), None);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let mut p = crate::RobustFlc2Params::default();
        p.comfort.response_time = 0.0;
        assert_eq!(RobustFallbackController2::new(p).unwrap_err().field, "comfort.response_time");
        p.comfort = ComfortParams { max_decel: f64::NAN, ..ComfortParams::default() };
        assert_eq!(RobustFallbackController2::new(p).unwrap_err().field, "comfort.max_decel");
    }

    #[test]
    fn the_dead_band_rule_brakes_only_for_an_estimate_of_the_motion_clock_and_within_the_limits() {
        let law = crate::RobustFlcParams::default();
        // Found by the `robust` fuzz target: with IDM's `a` below `clock_accel` and no estimate
        // the rule braked at `clock_accel` while the law accelerated.
        let p = ComfortParams { accel: 0.1, ..ComfortParams::default() };
        assert!((p.compose(&law, 20.0, 2.0, None, true) - 0.1).abs() < 1e-12);
        // With a braking estimate it brakes at `clock_accel`, never beyond the laws' limit.
        let p = ComfortParams::default();
        assert_eq!(p.compose(&law, 20.0, 0.5, Some((1.0, -0.6)), true), -0.3);
        // The wheels' clock has no dead band: the composition stands, 0.5 - 0.6 = -0.1.
        assert!((p.compose(&law, 20.0, 0.5, Some((1.0, -0.6)), false) + 0.1).abs() < 1e-12);
        let weak = crate::RobustFlcParams { max_decel: 0.2, ..law };
        assert_eq!(p.compose(&weak, 20.0, 0.5, Some((1.0, -0.6)), true), -0.2);
        // Outside the dead band the composition stands: 0.5 - 1.5 = -1.0.
        assert!((p.compose(&law, 20.0, 0.5, Some((1.0, -1.5)), true) + 1.0).abs() < 1e-12);
    }

    fn input() -> impl Strategy<Value = (Option<f64>, f64)> {
        let d = prop_oneof![8 => (0.0..150.0f64).prop_map(Some), 1 => Just(None), 1 => proptest::num::f64::ANY.prop_map(Some)];
        let v = prop_oneof![9 => 0.0..40.0f64, 1 => proptest::num::f64::ANY];
        (d, v)
    }

    proptest! {
        /// Whatever the inputs, v2's command is finite and never above its laws' (the comfort
        /// layer only brakes, and never harder than `max(law.max_decel, comfort.max_decel)`
        /// beyond them).
        #[test]
        fn the_comfort_layer_never_exceeds_the_laws(seq in proptest::collection::vec(input(), 1..120)) {
            let mut c = RobustFallbackController2::new(crate::RobustFlc2Params::default()).unwrap();
            for (d, v) in seq {
                let out = c.step(d, v);
                let t = *c.terms();
                prop_assert!(out.accel.is_finite() && out.speed.is_finite());
                if out.status == Status::Ok {
                    prop_assert!(out.accel <= t.a_law, "{out:?} {t:?}");
                    prop_assert!(out.accel >= t.a_law.min(-c.params().comfort.max_decel) - 1e-9, "{out:?} {t:?}");
                }
            }
        }
    }
}
