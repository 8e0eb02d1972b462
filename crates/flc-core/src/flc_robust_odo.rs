//! Robust FLC v2 with wheel odometry (issue 24's separately named variant; the simulator's
//! `controller = "flc-robust-odo"`): v2 ([`crate::flc_robust2`]) with one more onboard signal that
//! is free of clocks and synchronisation, the distance the wheels have travelled, as the clock of
//! its comfort layer ([`crate::comfort`]).
//!
//! v2 times its closing-speed estimate (C1) by its own motion, `Δτ = Δv / â`, which trusts the
//! vehicle to realize the commanded acceleration within `comfort.response_time` and tells no time
//! while the acceleration is near zero. The wheels tell time whatever the actuator did: between
//! two frames the follower drove `Δs` at the mean speed `v̄`, so `Δτ = Δs / v̄` and the gap's change
//! per metre driven is a closing speed, `ĉ = -v̄ Δd / Δs`, whatever the frame rate. Everything else
//! is v2's, with v2's parameters (`[flc_robust]`, `[flc_robust.comfort]`); the variant's own are
//! in [`OdometryFlcParams`] (`[flc_robust_odo]`). Frames without odometry are timed as v2 times
//! them: without odometry the variant is v2 bit for bit.

use crate::command::LongitudinalCommand;
use crate::flc_robust2::{RobustFallbackController2, RobustFlc2Params, RobustFlc2Terms};
use crate::longitudinal::{ActiveController, ControlOutput, Frame, LongitudinalController};
use crate::params::{ParamError, check_positive};

/// The odometry variant's own parameters (its base is [`RobustFlc2Params`], `[flc_robust]` in a
/// scenario file). `Default` is the documented design.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryFlcParams {
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
        Self { min_speed: 0.5 }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_positive("min_speed", self.min_speed, 100.0, "must be finite and in (0, 100] m/s")
    }
}

/// Robust FLC v2 with wheel odometry. Construct with [`OdometryFallbackController::new`], call
/// [`OdometryFallbackController::step`] once per LiDAR frame.
#[derive(Debug, Clone)]
pub struct OdometryFallbackController {
    base: RobustFallbackController2,
    params: OdometryFlcParams,
}

impl OdometryFallbackController {
    /// Validates both parameter sets and builds the controller.
    pub fn new(base: RobustFlc2Params, params: OdometryFlcParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { base: RobustFallbackController2::new(base)?, params })
    }

    /// The variant's own parameters.
    pub fn params(&self) -> &OdometryFlcParams {
        &self.params
    }

    /// v2 inside.
    pub fn base(&self) -> &RobustFallbackController2 {
        &self.base
    }

    /// The terms of the last step (v2's; `closing` from the wheels).
    pub fn terms(&self) -> &RobustFlc2Terms {
        self.base.terms()
    }

    /// Forgets everything; the next detection is a first detection.
    pub fn reset(&mut self) {
        self.base.reset();
    }

    /// One LiDAR frame: `distance` in m (`None` without a detection), `own_speed` in m/s,
    /// `travelled` the odometer in m (`None`: no odometry on this frame; it is timed as v2 times
    /// it).
    pub fn step(&mut self, distance: Option<f64>, own_speed: f64, travelled: Option<f64>) -> LongitudinalCommand {
        let wheels = travelled.filter(|s| s.is_finite()).map(|s| (s, self.params.min_speed));
        self.base.step_timed(distance, own_speed, wheels)
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
/// for _ in 0..30 {
///     LongitudinalController::step(&mut c, &Frame { travelled: Some(s), ..Frame::new(Some(d), v, 0.05) });
///     (d, s) = (d - 0.2, s + 1.0);
/// }
/// // (C1) ĉ -> 20 * 0.2 / 1 = 4 m/s (3.89: the memory, 1 s, still weighs the frames that did
/// // not close). (R7) alone would still approach (v_0 is 20 m/s), but the lead has come 6 m
/// // closer since it was last seen not closing, so (R8) takes it as possibly 20 - sqrt(120) =
/// // 9.05 m/s fast and caps the speed at 18.92 m/s: a_law = -2.42; (C2) at 34.2 m,
/// // Δa = -0.85 ((33 + 3.89 * 6)² - 33²) / 34.2² = -1.52 m/s², so the command is
/// // -2.42 - 1.52 = -3.94 m/s².
/// let t = *c.terms();
/// assert!(t.comfort && (t.closing - 3.889).abs() < 1e-3, "{t:?}");
/// assert!((t.approach_speed - 18.922).abs() < 1e-3, "{t:?}");
/// assert!((t.a_law + 2.425).abs() < 1e-3 && (t.closing_brake + 1.515).abs() < 1e-3, "{t:?}");
/// assert!((t.a + 3.940).abs() < 1e-3, "{t:?}");
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for OdometryFallbackController {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = OdometryFallbackController::step(self, frame.distance, frame.own_speed, frame.travelled);
        ControlOutput::single(command, self.terms().to_terms(), ActiveController::Flc)
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
        drive(&mut c, 25.0, 60.0, 0.1, 0.0, 60);
        assert!((c.terms().closing - 2.5).abs() < 1e-9, "{:?}", c.terms());
    }

    #[test]
    fn a_missed_frame_interrupts_but_keeps_the_estimate_and_a_pending_jump_forgets_it() {
        let mut c = ctl();
        let (d, s) = drive(&mut c, 25.0, 60.0, 0.1, 0.0, 60);
        c.step(None, 25.0, Some(s));
        assert!(c.terms().held && !c.terms().comfort);
        // Back one frame later: the sums were kept, the estimate is there at once.
        c.step(Some(d - 0.2), 25.0, Some(s + 2.0));
        assert!(c.terms().comfort && (c.terms().closing - 2.5).abs() < 1e-9, "{:?}", c.terms());
        // A jump is pending (maybe another object): the estimate starts over.
        c.step(Some(10.0), 25.0, Some(s + 3.0));
        assert!(c.terms().pending);
        c.step(Some(d - 0.4), 25.0, Some(s + 4.0));
        assert!(!c.terms().comfort, "{:?}", c.terms());
    }

    #[test]
    fn without_odometry_it_is_v2() {
        let (mut c, mut b) = (ctl(), v2());
        for k in 0..50 {
            let d = 50.0 - 0.3 * k as f64;
            let v = 22.0 - 0.05 * k as f64;
            let (x, y) = (c.step(Some(d), v, if k % 7 == 3 { Some(f64::NAN) } else { None }), b.step(Some(d), v));
            assert_eq!((x.speed.to_bits(), x.accel.to_bits(), x.status), (y.speed.to_bits(), y.accel.to_bits(), y.status));
        }
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let p = OdometryFlcParams { min_speed: 0.0 };
        assert_eq!(OdometryFallbackController::new(RobustFlc2Params::default(), p).unwrap_err().field, "min_speed");
        let mut b = RobustFlc2Params::default();
        b.law.time_gap = f64::NAN;
        assert_eq!(OdometryFallbackController::new(b, OdometryFlcParams::default()).unwrap_err().field, "law.time_gap");
        b = RobustFlc2Params::default();
        b.comfort.decel = 0.0;
        assert_eq!(OdometryFallbackController::new(b, OdometryFlcParams::default()).unwrap_err().field, "comfort.decel");
    }
}
