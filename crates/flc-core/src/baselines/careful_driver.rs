//! The "careful and competent human driver" of UN Regulation No. 157 (ALKS) as a reference
//! controller (issue 22).
//!
//! Source: UN Regulation No. 157, original version (ECE/TRANS/WP.29/2020/81; published in the
//! EU Official Journal L 82, 9.3.2021, as 2021/389), Annex 3 "Guidance on traffic disturbance
//! critical scenarios for ALKS", Appendix 3 (the performance models of a careful and competent
//! human driver; issue 22 calls it "Annex 4"; no paragraph number is cited here because none could
//! be checked against the text). In our own words, the model there says: a careful and competent
//! driver needs a *risk perception time* of 0.4 s from the moment a disturbance starts (e.g. the
//! vehicle in front starts braking hard) until it is perceived as a risk; then a *reaction time*
//! of 0.75 s until the brake is applied, during which the driver keeps doing what it did; then the
//! deceleration builds up linearly to 0.774 g within 0.6 s and is held. `g = 9.81 m/s²` here
//! ([`STANDARD_GRAVITY`]), so the full deceleration is `0.774 * 9.81 = 7.59294 m/s²`.
//!
//! The regulation is silent on the driver's normal behaviour and on when a situation becomes a
//! disturbance; the choices made here (`docs/careful-driver.md`):
//!
//! * **Normal mode** is the Intelligent Driver Model ([`super::idm`], its defaults), its output
//!   limited to `[-risk_decel, a]`: a driver following or cruising without emergency braking.
//! * **Onset of a disturbance**: the deceleration needed to stay `min_gap` behind the lead,
//!   [`CarefulDriverParams::required_decel`],
//!   `a_req = max( c² / (2 (s - s_m)),  v² / (2 (s - s_m + v_l² / (2 b_l))) )` with the closing
//!   speed `c = v - v_l` (first term only for `c > 0`), the lead's deceleration `b_l` (second term
//!   only for `b_l > 0`), the gap `s` and the margin `s_m = min_gap`; `s <= s_m` while closing is
//!   an infinite need. A disturbance starts on the first frame with `a_req > risk_decel`
//!   (3.5 m/s², the comfort limit of the simulator's `time_hard_braking` metric).
//! * **Perception and reaction** (`risk_perception_time + reaction_time = 1.15 s` after the
//!   onset frame): the acceleration commanded on the frame before the onset is held.
//! * **A disturbance already there on the first frame** (a scenario that starts with the ego
//!   closing in fast, as esmini's `acc-test`: 120 km/h, 75 m behind a car at 30 km/h): its onset
//!   lies before the driver's first frame, while it was already driving and looking ahead, so it
//!   is taken as perceived and reacted to: the braking ramp starts on that frame (from 0). Only
//!   the very first frame after [`CarefulDriver::new`] counts; a fault's reset does not.
//! * **Braking**: the command ramps from `min(held, 0)` to `-max_decel` with the jerk
//!   `max_decel / decel_ramp_time` and then holds it. Each frame commands the ramp's value in the
//!   middle of the coming frame interval (`tau + dt / 2` after the brake start, the interval
//!   assumed as long as the last one): under a zero-order hold this gives the ramp's exact speed
//!   loss over the interval.
//! * **End**: back to normal mode when the driver no longer closes in (`v <= v_l`, or no lead in
//!   sight) and `a_req <= risk_decel`, or at standstill (`v <= STANDSTILL_SPEED`).
//! * **Perception**: a human sees the scene, not a LiDAR: with `Frame::lead_speed` given (the
//!   simulator gives this reference the ground truth) that speed is used, otherwise
//!   `own speed + range rate` of the alpha-beta filter ([`super::estimator`]). The lead's
//!   deceleration is the difference of successive lead speeds over `dt`. Nothing beyond
//!   `sight_distance` is seen.
//!
//! Input checks, the safe command and the command mapping are those of the other baselines
//! ([`super::follower`]), with the shared settings of `normal` ([`super::FollowerSettings`]):
//! speed NaN / infinite / outside `[-1, max_speed]` → [`Status::InvalidSpeed`]; `dt` NaN /
//! infinite / `<= 0` / `> 10 s` → [`Status::InvalidDt`]; distance NaN / infinite / negative →
//! [`Status::InvalidDistance`] (a finite distance beyond `sight_distance` is "nothing in sight",
//! not a fault: `normal.max_distance` is not used); a measured lead speed NaN / infinite / outside
//! `[-max_speed, max_speed]` → [`Status::InvalidLeadSpeed`] (a human sees a lead reversing: a
//! negative speed is a measurement, and only a forward-moving lead's stopping distance counts as
//! room in `a_req`). Each gives `own_speed - fault_brake_step`
//! and resets the state. The command is `speed = clamp(v + command_gain a, 0, max_speed)`.

use super::FollowerParams;
use super::estimator::RangeRateEstimator;
use super::idm::IdmParams;
use super::{Frame as Checked, NoLeadPolicy, accel_command, check_frame, lead_speed};
use crate::command::{LongitudinalCommand, Status, clamp, safe_brake, valid_speed};
use crate::longitudinal::{ActiveController, ControlOutput, Frame, LongitudinalController, Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// The gravitational acceleration used for "0.774 g", m/s² (standard `g` rounded as 9.81).
pub const STANDARD_GRAVITY: f64 = 9.81;

/// Own speed at or below which the driver counts as standing still (ends a braking), m/s: 1 cm/s,
/// so that a braking is not handed back to the normal mode while still rolling.
pub const STANDSTILL_SPEED: f64 = 0.01;

/// The timing comparisons (`time since onset >= 1.15 s`) allow this much rounding of the summed
/// frame times, s: 23 frames of 0.05 s are 1.15 s even when their float sum is 1.1499999999999997.
pub const TIME_EPSILON: f64 = 1e-9;

/// A reported `a_req` is at most this (an infinite need is reported as this value), m/s².
pub const REPORTED_NEED_CAP: f64 = 1000.0;

/// Parameters of the careful driver. `Default`: the R157 values, `g = 9.81 m/s²`, and the
/// choices of the module docs.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarefulDriverParams {
    /// From the onset of the disturbance to its perception, s. R157: 0.4.
    pub risk_perception_time: f64,
    /// From perception to the start of braking (no response meanwhile), s. R157: 0.75.
    pub reaction_time: f64,
    /// The deceleration finally reached and held, m/s². R157: 0.774 g = 0.774 * 9.81 = 7.59294.
    pub max_decel: f64,
    /// Time for the linear build-up from 0 to `max_decel`, s (0: a step). R157: 0.6.
    pub decel_ramp_time: f64,
    /// A situation is a disturbance when it needs more than this deceleration, m/s². Default 3.5
    /// (the comfort limit of the simulator's `time_hard_braking`; the regulation gives none).
    pub risk_decel: f64,
    /// The margin the driver stops behind the lead (`s_m` in `a_req`), m. Default 2.
    pub min_gap: f64,
    /// A human's useful sight: a lead farther than this is not seen, m. Default 150.
    pub sight_distance: f64,
    /// The normal behaviour: the IDM (default: its Table I defaults, [`IdmParams::default`]),
    /// limited to `-risk_decel`; its shared fields (`no_lead`, `estimator`, `command_gain`,
    /// `max_speed`, `fault_brake_step`) are the careful driver's too.
    pub normal: IdmParams,
}

impl Default for CarefulDriverParams {
    fn default() -> Self {
        Self::r157()
    }
}

impl CarefulDriverParams {
    /// The R157 model (identical to `Default`).
    pub const fn r157() -> Self {
        Self {
            risk_perception_time: 0.4,
            reaction_time: 0.75,
            max_decel: 0.774 * STANDARD_GRAVITY,
            decel_ramp_time: 0.6,
            risk_decel: 3.5,
            min_gap: 2.0,
            sight_distance: 150.0,
            normal: IdmParams::treiber2000(),
        }
    }

    /// Checks every field; the error names the first offending one (`normal.time_headway` for
    /// the IDM's).
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("risk_perception_time", self.risk_perception_time, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_range("reaction_time", self.reaction_time, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_positive("max_decel", self.max_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_range("decel_ramp_time", self.decel_ramp_time, 0.0, 10.0, "must be finite and in [0, 10] s")?;
        check_positive("risk_decel", self.risk_decel, 50.0, "must be finite and in (0, 50] m/s²")?;
        check_range("min_gap", self.min_gap, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_positive("sight_distance", self.sight_distance, 1.0e6, "must be finite and in (0, 1e6] m")?;
        self.normal.validate().map_err(|e| ParamError { field: normal_field(e.field), problem: e.problem })
    }

    /// The reaction delay `risk_perception_time + reaction_time` (1.15 s by default), s.
    pub fn response_time(&self) -> f64 {
        self.risk_perception_time + self.reaction_time
    }

    /// The deceleration needed to stay `min_gap` behind the lead, m/s² (module docs):
    /// `max(c² / (2 (s - s_m)), v² / (2 (s - s_m + v_l² / (2 b_l))))`, the first term for a
    /// closing speed `c = v - v_l > 0`, the second for a lead decelerating at `b_l > 0`;
    /// `f64::INFINITY` when the room is used up while closing (resp. moving behind a braking
    /// lead), 0 when neither applies.
    pub fn required_decel(&self, gap: f64, own_speed: f64, lead_speed: f64, lead_decel: f64) -> f64 {
        let v = own_speed.max(0.0);
        let margin = gap - self.min_gap;
        let closing = v - lead_speed;
        let mut need = 0.0;
        if closing > 0.0 {
            if margin <= 0.0 {
                return f64::INFINITY;
            }
            need = closing * closing / (2.0 * margin);
        }
        if lead_decel > 0.0 && v > 0.0 {
            // A reversing lead (`v_l < 0`) does not stop ahead of where it is: no room from it.
            let forward = lead_speed.max(0.0);
            let room = margin + forward * forward / (2.0 * lead_decel);
            if room <= 0.0 {
                return f64::INFINITY;
            }
            need = f64::max(need, v * v / (2.0 * room));
        }
        need
    }

    /// The stopping distance of the model from `v` (m/s) with nothing held (`held = 0`), from
    /// the onset of the disturbance to standstill, m, in continuous time:
    /// `v t_r + (v T - A T² / 6) + (v - A T / 2)² / (2 A)` with `t_r = response_time()`,
    /// `A = max_decel`, `T = decel_ramp_time` (the ramp phase's distance and speed loss are
    /// those of a linear build-up). Assumes the driver is still moving after the ramp
    /// (`v > A T / 2`); below that it stops during the ramp and the value is an upper bound.
    pub fn stopping_distance(&self, v: f64) -> f64 {
        let (a, t) = (self.max_decel, self.decel_ramp_time);
        let after_ramp = v - a * t / 2.0;
        v * self.response_time() + (v * t - a * t * t / 6.0) + after_ramp * after_ramp / (2.0 * a)
    }
}

/// `normal.<field>` for the IDM's field names (a [`ParamError`] names a `&'static str`).
fn normal_field(field: &str) -> &'static str {
    crate::params::nested_field!(
        "normal",
        field,
        [
            "desired_speed",
            "time_headway",
            "min_gap",
            "max_accel",
            "comfort_decel",
            "delta",
            "max_decel",
            "min_gap_floor",
            "estimator.alpha",
            "estimator.beta",
            "estimator.max_range_rate",
            "command_gain",
            "max_speed",
            "max_distance",
            "fault_brake_step",
        ]
    )
}

/// The phase of the careful driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(u8)]
pub enum CarefulMode {
    /// Normal driving: the IDM, limited to `-risk_decel`.
    #[default]
    Normal = 0,
    /// A disturbance has started and is not perceived yet (`risk_perception_time`).
    Perceiving = 1,
    /// Perceived, not reacted yet (`reaction_time`); the held acceleration is commanded.
    Reacting = 2,
    /// Braking: the ramp to `-max_decel`, then holding it.
    Braking = 3,
}

/// The terms of the last step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CarefulDriverTerms {
    /// The phase ([`CarefulMode`] as its number 0..3).
    pub mode: CarefulMode,
    /// A lead was in sight this step.
    pub lead: bool,
    /// Gap to the lead, m (0 without one).
    pub gap: f64,
    /// The lead's speed used (measured or estimated), m/s.
    pub lead_speed: f64,
    /// The lead's deceleration from successive lead speeds, m/s² (positive when braking; limited
    /// to `+-REPORTED_NEED_CAP`).
    pub lead_decel: f64,
    /// The needed deceleration `a_req`, m/s² (at most [`REPORTED_NEED_CAP`]).
    pub a_req: f64,
    /// Time since the onset of the disturbance, s (0 in normal mode).
    pub since_onset: f64,
    /// The acceleration held through perception and reaction, m/s².
    pub held_accel: f64,
    /// The normal mode's (IDM's) acceleration this step, limited, m/s².
    pub normal_accel: f64,
    /// The commanded acceleration, m/s².
    pub accel: f64,
}

impl CarefulDriverTerms {
    /// The names of [`CarefulDriverTerms::to_terms`], in field order (flags as 0 / 1).
    pub const NAMES: &'static [&'static str] =
        &["mode", "lead", "gap", "lead_speed", "lead_decel", "a_req", "since_onset", "held_accel", "normal_accel", "accel"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(
            Self::NAMES,
            &[
                f64::from(t.mode as u8),
                flag(t.lead),
                t.gap,
                t.lead_speed,
                t.lead_decel,
                t.a_req,
                t.since_onset,
                t.held_accel,
                t.normal_accel,
                t.accel,
            ],
        )
    }
}

/// The lead as the driver sees it on one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SeenLead {
    gap: f64,
    speed: f64,
    decel: f64,
}

/// The R157 careful and competent human driver (module docs).
///
/// ```
/// use flc_core::baselines::{CarefulDriver, CarefulDriverParams};
/// use flc_core::{Frame, LongitudinalController};
///
/// let mut driver = CarefulDriver::new(CarefulDriverParams::default())?;
/// // Cruising at 80 km/h, nothing in sight: the IDM's free-road term
/// // a = 0.73 (1 - (22.222 / 36.111)^4) = 0.73 (1 - 0.143412) = 0.625309.
/// let out = driver.step(&Frame::new(None, 80.0 / 3.6, 0.05));
/// assert!((out.command.accel - 0.625309).abs() < 1e-6);
/// // A standing car appears 60 m ahead: a_req = 22.222² / (2 (60 - 2)) = 4.2571 > 3.5, a
/// // disturbance; for 1.15 s the driver keeps the acceleration it had.
/// let out = driver.step(&Frame { lead_speed: Some(0.0), ..Frame::new(Some(60.0), 80.0 / 3.6, 0.05) });
/// assert!((out.terms.get("a_req").unwrap() - 4.257131).abs() < 1e-6);
/// assert!((out.command.accel - 0.625309).abs() < 1e-6);
/// assert_eq!(out.terms.get("mode"), Some(1.0));
/// // Stopping distance from 80 km/h: 22.222 * 1.15 + (22.222 * 0.6 - 7.59294 * 0.36 / 6)
/// // + (22.222 - 2.27788)² / (2 * 7.59294) = 25.5556 + 12.8778 + 26.1939 = 64.627 m.
/// assert!((driver.params().stopping_distance(80.0 / 3.6) - 64.627).abs() < 1e-3);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
#[derive(Debug, Clone)]
pub struct CarefulDriver {
    params: CarefulDriverParams,
    estimator: RangeRateEstimator,
    mode: CarefulMode,
    since_onset: f64,
    held: f64,
    last_accel: f64,
    prev_lead_speed: Option<f64>,
    terms: CarefulDriverTerms,
    /// A valid frame has been driven (the first frame's rule, module docs).
    started: bool,
}

impl CarefulDriver {
    /// Validates `params` and builds the driver (normal mode, nothing held).
    pub fn new(params: CarefulDriverParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self {
            estimator: RangeRateEstimator::new_unchecked(params.normal.estimator),
            params,
            mode: CarefulMode::Normal,
            since_onset: 0.0,
            held: 0.0,
            last_accel: 0.0,
            prev_lead_speed: None,
            terms: CarefulDriverTerms::default(),
            started: false,
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &CarefulDriverParams {
        &self.params
    }

    /// The terms of the last step (all zero after a fault).
    pub fn terms(&self) -> &CarefulDriverTerms {
        &self.terms
    }

    /// The current phase.
    pub fn mode(&self) -> CarefulMode {
        self.mode
    }

    /// Back to normal mode; forgets the range-rate track, the lead's last speed and the held
    /// acceleration.
    pub fn reset(&mut self) {
        self.estimator.reset();
        self.mode = CarefulMode::Normal;
        self.since_onset = 0.0;
        self.held = 0.0;
        self.last_accel = 0.0;
        self.prev_lead_speed = None;
        self.terms = CarefulDriverTerms::default();
    }

    /// One frame: `distance` = gap in m (`None` = nothing ahead), `own_speed` in m/s, `dt` = time
    /// since the previous frame in s, `lead_speed_measured` the lead's speed when the driver sees
    /// it directly (`None`: estimated from the distance).
    pub fn step_measured(
        &mut self,
        distance: Option<f64>,
        own_speed: f64,
        dt: f64,
        lead_speed_measured: Option<f64>,
    ) -> LongitudinalCommand {
        let p = self.params;
        let s = p.normal.settings();
        // The baselines' input checks; any finite distance is valid (beyond `sight_distance` it
        // is "nothing in sight", not a fault).
        let in_sight = match check_frame(distance, own_speed, dt, s.max_speed, f64::MAX) {
            Ok(Checked::Lead(d)) => (d <= p.sight_distance).then_some(d),
            Ok(Checked::NoLead) => None,
            Err(status) => return self.fault(own_speed, status),
        };
        let lead = match in_sight {
            Some(gap) => {
                let estimated = self.estimator.update(gap, dt).range_rate;
                let speed = match lead_speed_measured {
                    None => lead_speed(own_speed, estimated, s.max_speed),
                    // A lead that reverses (ALKS 4.3_1's lead braking through zero) is seen doing
                    // so: a negative speed is a measurement, not a fault.
                    Some(v) if v.is_finite() && (-s.max_speed..=s.max_speed).contains(&v) => v,
                    Some(_) => return self.fault(own_speed, Status::InvalidLeadSpeed),
                };
                // Limited to +-REPORTED_NEED_CAP: a tiny `dt` would make it meaningless.
                let decel = self.prev_lead_speed.map_or(0.0, |prev| clamp((prev - speed) / dt, -REPORTED_NEED_CAP, REPORTED_NEED_CAP));
                self.prev_lead_speed = Some(speed);
                Some(SeenLead { gap, speed, decel })
            }
            None if s.no_lead == NoLeadPolicy::Brake => return self.fault(own_speed, Status::NoLead),
            None => {
                self.estimator.reset();
                self.prev_lead_speed = None;
                None
            }
        };
        let a_req = lead.map_or(0.0, |l| p.required_decel(l.gap, own_speed, l.speed, l.decel));
        let closing = lead.is_some_and(|l| own_speed > l.speed);

        // The normal mode's acceleration (computed every frame, for the terms).
        let idm = &p.normal;
        let raw = match lead {
            Some(l) => idm.accel(own_speed, l.speed, l.gap),
            None => idm.free_accel(own_speed),
        };
        let normal_accel = clamp(raw, -p.risk_decel, idm.max_accel);

        // The state machine: onset, then the clock of perception and reaction, then the end of
        // a braking (checked after the clock, so a disturbance gone by the end of the reaction
        // time is not braked for).
        let t_response = p.response_time();
        if self.mode == CarefulMode::Normal {
            if a_req > p.risk_decel && !self.started {
                // Already there on the first frame: perceived and reacted to before it.
                self.mode = CarefulMode::Braking;
                self.since_onset = t_response;
                self.held = 0.0;
            } else if a_req > p.risk_decel {
                // The onset frame: nothing perceived yet, the previous command is kept.
                self.mode = CarefulMode::Perceiving;
                self.since_onset = 0.0;
                self.held = self.last_accel;
            }
        } else {
            self.since_onset += dt;
        }
        self.started = true;
        if matches!(self.mode, CarefulMode::Perceiving | CarefulMode::Reacting) {
            self.mode = if self.since_onset + TIME_EPSILON >= t_response {
                CarefulMode::Braking
            } else if self.since_onset + TIME_EPSILON >= p.risk_perception_time {
                CarefulMode::Reacting
            } else {
                CarefulMode::Perceiving
            };
        }
        if self.mode == CarefulMode::Braking && (own_speed <= STANDSTILL_SPEED || (!closing && a_req <= p.risk_decel)) {
            self.mode = CarefulMode::Normal;
            self.since_onset = 0.0;
        }
        let accel = match self.mode {
            CarefulMode::Normal => normal_accel,
            CarefulMode::Perceiving | CarefulMode::Reacting => self.held,
            CarefulMode::Braking => {
                let tau = (self.since_onset - t_response).max(0.0) + 0.5 * dt;
                let start = self.held.min(0.0);
                let ramp = if p.decel_ramp_time > 0.0 { start - p.max_decel * tau / p.decel_ramp_time } else { -p.max_decel };
                ramp.max(-p.max_decel)
            }
        };
        let Some(command) = accel_command(own_speed, accel, s.command_gain, s.max_speed) else {
            return self.fault(own_speed, Status::InvalidDistance);
        };
        self.last_accel = accel;
        self.terms = CarefulDriverTerms {
            mode: self.mode,
            lead: lead.is_some(),
            gap: lead.map_or(0.0, |l| l.gap),
            lead_speed: lead.map_or(0.0, |l| l.speed),
            lead_decel: lead.map_or(0.0, |l| l.decel),
            a_req: a_req.min(REPORTED_NEED_CAP),
            since_onset: if self.mode == CarefulMode::Normal { 0.0 } else { self.since_onset },
            held_accel: self.held,
            normal_accel,
            accel,
        };
        command
    }

    fn fault(&mut self, own_speed: f64, status: Status) -> LongitudinalCommand {
        self.reset();
        let s = self.params.normal.settings();
        safe_brake(own_speed, valid_speed(own_speed, s.max_speed), s.fault_brake_step, status)
    }
}

/// The careful driver through the common interface; `desired_gap(v)` is the normal mode's (the
/// IDM's equilibrium gap at `max(v, 0)`).
impl LongitudinalController for CarefulDriver {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let command = self.step_measured(frame.distance, frame.own_speed, frame.dt, frame.lead_speed);
        ControlOutput::single(command, self.terms.to_terms(), ActiveController::Flc)
    }

    fn reset(&mut self) {
        CarefulDriver::reset(self);
    }

    fn desired_gap(&self, v: f64) -> f64 {
        self.params.normal.equilibrium_gap(v.max(0.0))
    }

    fn uses_dt(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// 20 Hz frames.
    const DT: f64 = 0.05;
    /// 0.774 g with g = 9.81, and the ramp time: the R157 values, written out.
    const A: f64 = 0.774 * 9.81;
    const T: f64 = 0.6;

    /// The careful driver cruising at `v`: the normal mode's desired speed is `v` (as the
    /// simulator's `cruise` sets it), so that with nothing in sight it commands exactly 0.
    fn cruising(v: f64) -> CarefulDriverParams {
        let mut p = CarefulDriverParams::default();
        p.normal.desired_speed = v;
        p
    }

    /// The hand computation: `v 1.15 + (v T - A T² / 6) + (v - A T / 2)² / (2 A)`.
    fn by_hand(v: f64) -> f64 {
        v * 1.15 + (v * T - A * T * T / 6.0) + (v - A * T / 2.0).powi(2) / (2.0 * A)
    }

    /// What a kinematic run against a standing obstacle gave.
    struct Stop {
        /// Travelled from the onset frame to standstill, m.
        distance: f64,
        /// Time from the onset frame to the first frame commanding a negative acceleration, s.
        first_brake: f64,
        /// Every command before 1.15 s after the onset was the held one (0).
        held: bool,
    }

    /// Cruises at `v0` for 1 s with nothing in sight, then a standing obstacle appears `d` ahead
    /// (the driver sees its true speed 0). The commanded acceleration is integrated exactly under
    /// a zero-order hold, `x += v dt + a dt² / 2`, `v += a dt`, and within the last frame to the
    /// stop at `v² / (2 |a|)`.
    fn against_obstacle(p: CarefulDriverParams, v0: f64, d: f64) -> Stop {
        let mut c = CarefulDriver::new(p).unwrap();
        for _ in 0..20 {
            let out = c.step_measured(None, v0, DT, None);
            assert_eq!((out.status, out.accel, out.speed), (Status::Ok, 0.0, v0));
        }
        let (mut x, mut v, mut t) = (0.0, v0, 0.0);
        let (mut first_brake, mut held) = (None, true);
        for _ in 0..2000 {
            let out = c.step_measured(Some(d - x), v, DT, Some(0.0));
            assert_eq!(out.status, Status::Ok);
            let a = out.accel;
            if a < 0.0 && first_brake.is_none() {
                first_brake = Some(t);
            }
            if t < 1.15 - 1e-9 && a != 0.0 {
                held = false;
            }
            if a < 0.0 && v + a * DT <= 0.0 {
                x += v * v / (2.0 * -a);
                return Stop { distance: x, first_brake: first_brake.unwrap_or(f64::NAN), held };
            }
            x += v * DT + 0.5 * a * DT * DT;
            v += a * DT;
            t += DT;
            if a < 0.0 && v <= STANDSTILL_SPEED {
                // At most 1 cm/s left: the driver counts as standing (the rest, v² / (2 A), is
                // below 0.01 mm).
                return Stop { distance: x, first_brake: first_brake.unwrap_or(f64::NAN), held };
            }
        }
        panic!("no stop within 100 s");
    }

    #[test]
    fn stopping_distance_from_80_kmh_by_hand() {
        let v = 80.0 / 3.6;
        // 22.2222 * 1.15 = 25.5556; 22.2222 * 0.6 - 7.59294 * 0.36 / 6 = 13.3333 - 0.4556 = 12.8778;
        // (22.2222 - 2.27788)² / (2 * 7.59294) = 397.777 / 15.1859 = 26.1939 -> 64.627 m.
        assert!((by_hand(v) - 64.627).abs() < 1e-3, "{}", by_hand(v));
        assert!((CarefulDriverParams::default().stopping_distance(v) - by_hand(v)).abs() < 1e-12);
        // The obstacle appears 70 m ahead: a_req = 22.2222² / (2 * 68) = 3.6311 > 3.5.
        let stop = against_obstacle(cruising(v), v, 70.0);
        assert!((stop.distance - by_hand(v)).abs() < v * DT, "{} vs {}", stop.distance, by_hand(v));
        // Sampled in the middle of each frame, the discrete ramp loses the continuous ramp's
        // speed exactly: far closer than one frame's travel (1.11 m).
        assert!((stop.distance - by_hand(v)).abs() < 0.05, "{} vs {}", stop.distance, by_hand(v));
        assert!((stop.first_brake - 1.15).abs() <= DT + 1e-9, "{}", stop.first_brake);
        assert!(stop.held);
    }

    #[test]
    fn stopping_distance_from_50_kmh_by_hand() {
        let v = 50.0 / 3.6;
        // 13.8889 * 1.15 = 15.9722; 8.3333 - 0.4556 = 7.8778; (13.8889 - 2.27788)² / 15.1859
        // = 134.815 / 15.1859 = 8.8777 -> 32.728 m.
        assert!((by_hand(v) - 32.728).abs() < 1e-2, "{}", by_hand(v));
        // From 50 km/h no obstacle that needs more than 3.5 m/s² (closer than
        // 13.8889² / 7 + 2 = 29.56 m) can be avoided after 1.15 s of reaction (32.7 m): a
        // disturbance threshold of 2 m/s² (closer than 50.2 m) makes the stop measurable; the
        // stopping distance does not depend on it.
        let p = CarefulDriverParams { risk_decel: 2.0, ..cruising(v) };
        let stop = against_obstacle(p, v, 45.0);
        assert!((stop.distance - by_hand(v)).abs() < 0.05, "{} vs {}", stop.distance, by_hand(v));
        assert!((stop.first_brake - 1.15).abs() <= DT + 1e-9, "{}", stop.first_brake);
        assert!(stop.held);
    }

    /// The table of `docs/careful-driver.md`: the hand formula at each speed (m, 3 decimals),
    /// and the discrete run (20 Hz) within 0.05 m of it. The obstacle appears 10 m beyond the
    /// stopping distance; a disturbance threshold of 0.5 m/s² makes it one at every speed.
    #[test]
    fn the_documented_table() {
        // The table of docs/careful-driver.md ("Stopping distances"), read from the document:
        // every column to its printed 3 decimals, and the driver's own stop at the last one.
        let doc = include_str!("../../../../docs/careful-driver.md");
        let rows: std::vec::Vec<[f64; 5]> = doc
            .lines()
            .filter(|l| l.starts_with("| ") && l.contains(" km/h |"))
            .map(|l| {
                let cells: std::vec::Vec<f64> = l
                    .split('|')
                    .map(|c| c.trim().trim_end_matches(" km/h").trim_end_matches(" m"))
                    .filter(|c| !c.is_empty())
                    .map(|c| c.parse().unwrap_or_else(|e| panic!("docs/careful-driver.md: {l}: {e}")))
                    .collect();
                assert_eq!(cells.len(), 5, "docs/careful-driver.md: {l}");
                [cells[0], cells[1], cells[2], cells[3], cells[4]]
            })
            .collect();
        assert_eq!(rows.len(), 6, "the stopping-distance table of docs/careful-driver.md");
        for [kmh, reaction, ramp, full, metres] in rows {
            let v = kmh / 3.6;
            let parts = [v * 1.15, v * T - A * T * T / 6.0, (v - A * T / 2.0).powi(2) / (2.0 * A), by_hand(v)];
            for (doc, code) in [reaction, ramp, full, metres].into_iter().zip(parts) {
                assert!((code - doc).abs() <= 5e-4 + 1e-9, "docs/careful-driver.md at {kmh} km/h: {doc} printed, {code:.4} computed");
            }
            assert!((CarefulDriverParams::default().stopping_distance(v) - by_hand(v)).abs() < 1e-12);
            let p = CarefulDriverParams { risk_decel: 0.5, ..cruising(v) };
            let stop = against_obstacle(p, v, metres + 10.0);
            assert!((stop.distance - metres).abs() < 0.05, "{kmh}: {} vs {metres}", stop.distance);
            assert!(stop.held && (stop.first_brake - 1.15).abs() <= DT + 1e-9);
        }
    }

    #[test]
    fn phases_and_their_timing() {
        let v = 80.0 / 3.6;
        let mut c = CarefulDriver::new(cruising(v)).unwrap();
        c.step_measured(None, v, DT, None);
        // Onset frame: frame 0; perception until 0.4 s (frames 0..7), reaction until 1.15 s
        // (frames 8..22), braking from frame 23 with the ramp's mid-frame value
        // -7.59294 * 0.025 / 0.6 = -0.316373, then 0.05 s later -0.949118, ...
        let mut modes = std::vec::Vec::new();
        let mut accels = std::vec::Vec::new();
        for k in 0..40 {
            let out = c.step_measured(Some(60.0 - f64::from(k) * v * DT), v, DT, Some(0.0));
            modes.push(c.mode());
            accels.push(out.accel);
        }
        assert!(modes[..8].iter().all(|m| *m == CarefulMode::Perceiving), "{modes:?}");
        assert!(modes[8..23].iter().all(|m| *m == CarefulMode::Reacting), "{modes:?}");
        assert!(modes[23..].iter().all(|m| *m == CarefulMode::Braking), "{modes:?}");
        assert!(accels[..23].iter().all(|a| *a == 0.0));
        assert!((accels[23] + A * 0.025 / 0.6).abs() < 1e-9, "{}", accels[23]);
        assert!((accels[24] + A * 0.075 / 0.6).abs() < 1e-9, "{}", accels[24]);
        // The ramp is complete 0.6 s after the brake start: from frame 23 + 12 on, -A.
        assert!((accels[34] + A * 0.575 / 0.6).abs() < 1e-9, "{}", accels[34]);
        assert_eq!(accels[35], -A);
        assert_eq!(c.terms().mode, CarefulMode::Braking);
        assert!((c.terms().since_onset - 39.0 * DT).abs() < 1e-9);
    }

    /// A disturbance already there on the very first frame (esmini's acc-test: 120 km/h, 75 m
    /// behind a car at 30 km/h: a_req = 25² / (2 * 73) = 4.28 m/s²) is braked for on that frame,
    /// with the ramp from 0; the same situation arising on a later frame waits 1.15 s. The
    /// first frame alone: after a fault the driver is still driving.
    #[test]
    fn a_disturbance_on_the_first_frame_was_perceived_before_it() {
        let (v, lead) = (120.0 / 3.6, 30.0 / 3.6);
        let mut c = CarefulDriver::new(cruising(v)).unwrap();
        let out = c.step_measured(Some(75.0), v, DT, Some(lead));
        assert_eq!(c.mode(), CarefulMode::Braking);
        assert!((c.terms().a_req - 25.0 * 25.0 / (2.0 * 73.0)).abs() < 1e-9, "{}", c.terms().a_req);
        assert!((out.accel + A * 0.025 / 0.6).abs() < 1e-9, "{}", out.accel);
        let out = c.step_measured(Some(75.0 - 25.0 * DT), v, DT, Some(lead));
        assert!((out.accel + A * 0.075 / 0.6).abs() < 1e-9, "{}", out.accel);
        // Seen on the second frame instead: perceived and reacted to first.
        let mut c = CarefulDriver::new(cruising(v)).unwrap();
        c.step_measured(None, v, DT, None);
        let out = c.step_measured(Some(75.0), v, DT, Some(lead));
        assert_eq!((c.mode(), out.accel), (CarefulMode::Perceiving, 0.0));
        // A fault's reset keeps the driver driving: the next disturbance waits.
        let mut c = CarefulDriver::new(cruising(v)).unwrap();
        c.step_measured(None, v, DT, None);
        let fault = c.step_measured(Some(f64::NAN), v, DT, None);
        assert_eq!(fault.status, Status::InvalidDistance);
        c.step_measured(Some(75.0), v, DT, Some(lead));
        assert_eq!(c.mode(), CarefulMode::Perceiving);
    }

    #[test]
    fn the_held_acceleration_is_the_previous_command() {
        // Cruising below the desired speed (default 130 km/h) at 80 km/h: the IDM accelerates at
        // 0.625309 m/s², and keeps doing so for 1.15 s after a standing car appears 60 m ahead;
        // the ramp then starts from 0 (min(held, 0)).
        let v = 80.0 / 3.6;
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        let free = c.step_measured(None, v, DT, None).accel;
        assert!((free - 0.625309).abs() < 1e-6);
        for k in 0..23 {
            let out = c.step_measured(Some(60.0 - f64::from(k)), v, DT, Some(0.0));
            assert_eq!(out.accel, free, "{k}");
            assert_eq!(c.terms().held_accel, free);
        }
        let out = c.step_measured(Some(37.0), v, DT, Some(0.0));
        assert!((out.accel + A * 0.025 / 0.6).abs() < 1e-9);
        // Braking already at -3.5 when the disturbance starts: the ramp starts from there.
        let p = CarefulDriverParams::default();
        let mut c = CarefulDriver::new(p).unwrap();
        c.last_accel = -3.5;
        c.started = true;
        c.step_measured(Some(30.0), 20.0, DT, Some(0.0));
        assert_eq!(c.terms().held_accel, -3.5);
        for _ in 0..22 {
            assert_eq!(c.step_measured(Some(30.0), 20.0, DT, Some(0.0)).accel, -3.5);
        }
        let out = c.step_measured(Some(30.0), 20.0, DT, Some(0.0));
        assert!((out.accel - (-3.5 - A * 0.025 / 0.6)).abs() < 1e-9, "{}", out.accel);
    }

    #[test]
    fn required_deceleration_by_hand() {
        let p = CarefulDriverParams::default();
        // Closing at 10 m/s with 38 m of room: 100 / 76 = 1.315789.
        assert!((p.required_decel(40.0, 20.0, 10.0, 0.0) - 1.315789).abs() < 1e-6);
        // Equal speeds, the lead braking at 6: 400 / (2 (38 + 400 / 12)) = 400 / 142.6667 = 2.803738.
        assert!((p.required_decel(40.0, 20.0, 20.0, 6.0) - 2.803738).abs() < 1e-6);
        // Both apply: the larger. Closing 20 - 15 = 5: 25 / 76 = 0.3289; stop-behind
        // 400 / (2 (38 + 225 / 12)) = 400 / 113.5 = 3.524229.
        assert!((p.required_decel(40.0, 20.0, 15.0, 6.0) - 3.524229).abs() < 1e-6);
        // No room while closing, or behind a braking lead: infinite.
        assert_eq!(p.required_decel(2.0, 20.0, 10.0, 0.0), f64::INFINITY);
        assert_eq!(p.required_decel(1.0, 20.0, 0.0, 6.0), f64::INFINITY);
        // Not closing, lead not braking (or accelerating): nothing needed.
        assert_eq!(p.required_decel(1.0, 20.0, 25.0, 0.0), 0.0);
        assert_eq!(p.required_decel(40.0, 20.0, 20.0, -2.0), 0.0);
        // Standing still behind a standing lead.
        assert_eq!(p.required_decel(1.0, 0.0, 0.0, 0.0), 0.0);
    }

    /// A lead braking at 6 m/s² to a stop from 80 km/h, 40 m ahead at equal speeds: the lead
    /// stops after 22.2222² / 12 = 41.15 m, 81.15 m ahead of the driver's start; even reacting
    /// from the brake onset on with nothing held the driver would need 64.63 m, so it stops
    /// behind it. The disturbance is recognised (mode Braking) and the driver stops without
    /// contact.
    #[test]
    fn a_braking_lead_is_a_disturbance_and_the_driver_stops_behind_it() {
        let v0 = 80.0 / 3.6;
        let mut c = CarefulDriver::new(cruising(v0)).unwrap();
        let (mut x, mut v) = (0.0, v0);
        let (mut xl, mut vl) = (40.0, v0);
        let (mut braked, mut min_gap, mut onset, mut first_stop) = (false, f64::INFINITY, None, None);
        for k in 0..400 {
            let gap = xl - x;
            min_gap = min_gap.min(gap);
            let out = c.step_measured(Some(gap), v, DT, Some(vl));
            assert_eq!(out.status, Status::Ok);
            if c.mode() != CarefulMode::Normal && onset.is_none() {
                onset = Some(k);
            }
            braked |= c.mode() == CarefulMode::Braking;
            let a = if v + out.accel * DT < 0.0 { -v / DT } else { out.accel };
            x += v * DT + 0.5 * a * DT * DT;
            v += a * DT;
            let al = if vl - 6.0 * DT < 0.0 { -vl / DT } else { -6.0 };
            xl += vl * DT + 0.5 * al * DT * DT;
            vl += al * DT;
            if v <= 0.0 && first_stop.is_none() {
                first_stop = Some(xl - x);
            }
        }
        // Measured: the disturbance starts 0.6 s (frame 12) after the lead's brake onset, when
        // a_req passes 3.5 m/s² (the IDM's milder braking falls behind); braking from 1.75 s;
        // standstill 16.2 m behind the lead.
        assert!(braked);
        assert_eq!(onset, Some(12));
        let first_stop = first_stop.unwrap_or(f64::NAN);
        assert!((first_stop - 16.2).abs() < 0.05, "{first_stop}");
        // Afterwards the normal mode (the IDM) creeps up to about its jam distance (2 m); no
        // contact.
        assert!(min_gap > 1.5, "{min_gap}");
        assert!(v == 0.0 && vl == 0.0, "{v} {vl}");
    }

    #[test]
    fn the_end_of_a_disturbance() {
        // Closing on a 10 m/s lead at 15 m: a_req = 100 / 26 = 3.85 > 3.5 (after a first frame
        // with nothing in sight: a disturbance on the first frame brakes at once).
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        c.step_measured(None, 20.0, DT, None);
        c.step_measured(Some(15.0), 20.0, DT, Some(10.0));
        assert_eq!(c.mode(), CarefulMode::Perceiving);
        // The lead speeds up to 25 m/s meanwhile: the reaction still runs its course...
        for _ in 0..22 {
            c.step_measured(Some(15.0), 20.0, DT, Some(25.0));
            assert_ne!(c.mode(), CarefulMode::Normal);
        }
        // ... and at its end (1.15 s) no braking is needed any more: back to normal.
        c.step_measured(Some(15.0), 20.0, DT, Some(25.0));
        assert_eq!(c.mode(), CarefulMode::Normal);
        // Standstill ends a braking too.
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        for _ in 0..30 {
            c.step_measured(Some(15.0), 20.0, DT, Some(0.0));
        }
        assert_eq!(c.mode(), CarefulMode::Braking);
        c.step_measured(Some(3.0), 0.05, DT, Some(0.0));
        assert_eq!(c.mode(), CarefulMode::Braking);
        c.step_measured(Some(3.0), 0.01, DT, Some(0.0));
        assert_eq!(c.mode(), CarefulMode::Normal);
    }

    #[test]
    fn sight_distance() {
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        // 150.1 m: not seen (free road), a finite distance beyond sight is no fault.
        let out = c.step_measured(Some(150.1), 20.0, DT, Some(0.0));
        assert_eq!(out.status, Status::Ok);
        assert!(!c.terms().lead);
        let out = c.step_measured(Some(1.0e12), 20.0, DT, None);
        assert_eq!(out.status, Status::Ok);
        assert!(c.step_measured(Some(150.0), 20.0, DT, Some(0.0)).status.is_ok() && c.terms().lead);
    }

    #[test]
    fn the_lead_speed_is_estimated_without_a_measurement() {
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        c.step_measured(Some(30.5), 20.0, 0.1, None);
        c.step_measured(Some(30.0), 20.0, 0.1, None);
        // 0.5 m closer in 0.1 s: range rate -5, lead speed 15 (as the other baselines).
        assert!((c.terms().lead_speed - 15.0).abs() < 1e-9);
        // The lead's speed dropped from 20 (first frame: own speed) to 15 in 0.1 s: 50 m/s².
        assert!((c.terms().lead_decel - 50.0).abs() < 1e-9);
    }

    #[test]
    fn bad_inputs_give_the_safe_command() {
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        for _ in 0..10 {
            c.step_measured(Some(15.0), 20.0, DT, Some(0.0));
        }
        assert_ne!(c.mode(), CarefulMode::Normal);
        let out = c.step_measured(Some(f64::NAN), 20.0, DT, None);
        assert_eq!((out.status, out.speed, out.accel), (Status::InvalidDistance, 17.0, -3.0));
        // The fault reset the state.
        assert_eq!(c.mode(), CarefulMode::Normal);
        assert_eq!(*c.terms(), CarefulDriverTerms::default());
        assert_eq!(c.step_measured(Some(-0.1), 20.0, DT, None).status, Status::InvalidDistance);
        assert_eq!(c.step_measured(Some(f64::INFINITY), 20.0, DT, None).status, Status::InvalidDistance);
        let out = c.step_measured(Some(30.0), f64::NAN, DT, None);
        assert_eq!((out.status, out.speed), (Status::InvalidSpeed, 0.0));
        assert_eq!(c.step_measured(Some(30.0), 71.0, DT, None).status, Status::InvalidSpeed);
        assert_eq!(c.step_measured(Some(30.0), 20.0, 0.0, None).status, Status::InvalidDt);
        assert_eq!(c.step_measured(Some(30.0), 20.0, f64::NAN, None).status, Status::InvalidDt);
        assert_eq!(c.step_measured(Some(30.0), 20.0, 10.5, None).status, Status::InvalidDt);
        assert_eq!(c.step_measured(Some(30.0), 20.0, DT, Some(f64::NAN)).status, Status::InvalidLeadSpeed);
        assert_eq!(c.step_measured(Some(30.0), 20.0, DT, Some(-71.0)).status, Status::InvalidLeadSpeed);
        // Brake without a lead when asked to (the normal mode's no-lead policy).
        let mut p = CarefulDriverParams::default();
        p.normal.no_lead = NoLeadPolicy::Brake;
        let out = CarefulDriver::new(p).unwrap().step_measured(None, 10.0, DT, None);
        assert_eq!((out.status, out.speed), (Status::NoLead, 7.0));
    }

    #[test]
    fn a_reversing_lead_is_seen_not_a_fault() {
        // ALKS 4.3_1 (p0): the lead brakes through zero and reverses towards a driver at 5 km/h,
        // 75 m ahead. Its negative speed is a measurement: the driver goes on in normal mode
        // (before: InvalidLeadSpeed, a fault brake to a stop 75 m short).
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        for k in 0..10 {
            let out = c.step_measured(Some(75.0 - 0.25 * f64::from(k)), 1.39, DT, Some(-1.0 - 0.05 * f64::from(k)));
            assert_eq!(out.status, Status::Ok, "{k}");
            assert!(out.speed > 1.0, "{k}: {out:?}");
        }
        assert_eq!(c.mode(), CarefulMode::Normal);
        // Its stopping distance is no room: a_req against a lead reversing at 2 m/s and braking
        // (its speed falling further) is the closing term's or the own stop's, whichever is more.
        let p = CarefulDriverParams::default();
        let (gap, v) = (12.0, 10.0);
        let own_stop = v * v / (2.0 * (gap - p.min_gap));
        let closing = (v + 2.0) * (v + 2.0) / (2.0 * (gap - p.min_gap));
        assert_eq!(p.required_decel(gap, v, -2.0, 1.0), closing.max(own_stop));
        assert!(p.required_decel(gap, v, -2.0, 1.0) > p.required_decel(gap, v, 2.0, 1.0));
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: CarefulDriverParams| CarefulDriver::new(p).unwrap_err().field;
        let d = CarefulDriverParams::default;
        assert_eq!(bad(CarefulDriverParams { risk_perception_time: -0.1, ..d() }), "risk_perception_time");
        assert_eq!(bad(CarefulDriverParams { reaction_time: f64::NAN, ..d() }), "reaction_time");
        assert_eq!(bad(CarefulDriverParams { max_decel: 0.0, ..d() }), "max_decel");
        assert_eq!(bad(CarefulDriverParams { decel_ramp_time: f64::INFINITY, ..d() }), "decel_ramp_time");
        assert_eq!(bad(CarefulDriverParams { risk_decel: 0.0, ..d() }), "risk_decel");
        assert_eq!(bad(CarefulDriverParams { min_gap: -1.0, ..d() }), "min_gap");
        assert_eq!(bad(CarefulDriverParams { sight_distance: 0.0, ..d() }), "sight_distance");
        let mut p = d();
        p.normal.time_headway = -1.0;
        assert_eq!(bad(p), "normal.time_headway");
        let mut p = d();
        p.normal.estimator.alpha = 0.0;
        assert_eq!(bad(p), "normal.estimator.alpha");
        assert!(d().validate().is_ok());
        // The documented defaults.
        let p = d();
        assert_eq!((p.risk_perception_time, p.reaction_time, p.decel_ramp_time), (0.4, 0.75, 0.6));
        assert_eq!(p.max_decel, 0.774 * 9.81);
        assert_eq!((p.risk_decel, p.min_gap, p.sight_distance), (3.5, 2.0, 150.0));
        assert_eq!(p.normal, IdmParams::default());
    }

    #[test]
    fn through_the_trait() {
        let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
        c.step_measured(None, 20.0, DT, None);
        let mut d = c.clone();
        let f = Frame { lead_speed: Some(10.0), ..Frame::new(Some(15.0), 20.0, DT) };
        let o = LongitudinalController::step(&mut c, &f);
        assert_eq!(o.command, d.step_measured(Some(15.0), 20.0, DT, Some(10.0)));
        assert_eq!(o.terms, d.terms().to_terms());
        assert_eq!(o.terms.get("mode"), Some(1.0));
        assert!(c.uses_dt());
        assert_eq!(LongitudinalController::desired_gap(&c, 25.0), IdmParams::default().equilibrium_gap(25.0));
        LongitudinalController::reset(&mut c);
        assert_eq!(c.mode(), CarefulMode::Normal);
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((
                proptest::option::of(prop_oneof![3 => 0.0..200.0f64, 1 => proptest::num::f64::ANY]),
                prop_oneof![3 => 0.0..40.0f64, 1 => proptest::num::f64::ANY],
                prop_oneof![3 => 0.01..0.2f64, 1 => proptest::num::f64::ANY],
                proptest::option::of(prop_oneof![3 => 0.0..40.0f64, 1 => proptest::num::f64::ANY]),
            ), 1..80)
        ) {
            let mut c = CarefulDriver::new(CarefulDriverParams::default()).unwrap();
            for (d, v, dt, vl) in seq {
                let out = c.step_measured(d, v, dt, vl);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                prop_assert!(out.accel.is_finite());
                prop_assert!(c.terms().to_terms().values().iter().all(|x| x.is_finite()));
                if out.status.is_ok() {
                    prop_assert!(out.accel >= -A - 1e-12 && out.accel <= 0.73 + 1e-12);
                } else {
                    prop_assert!(out.accel < 0.0);
                }
            }
        }
    }
}
