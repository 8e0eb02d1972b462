//! The baseline PID gap controller of Sec. III-A.3 (the "primary longitudinal controller").
//!
//! It assumes V2V: inputs are the lead speed `S_L` (received over V2V), the own speed `S_F`, the
//! inter-vehicle distance and the time step. The desired distance is the paper's
//! `D_d + F_shift` (Eqs. (2)-(4)), with the PID's own time gap (0.5 s). Two gain sets (far / near)
//! are selected by distance. The output has the same speed-command form as the FLC,
//! `v_cmd = S_F + command_gain * u`, so the [`crate::supervisor`] can switch between them.
//!
//! ```text
//! e     = distance - (T_G,pid * S_F + B_gap + F_shift(S_F))      gap error, m
//! e_dot = S_L - S_F                                               gap-error rate from V2V, m/s
//! u     = kp * e + ki * integral(e dt) + kd * e_dot               (far or near gains)
//! ```
//!
//! Anti-windup: the integrator is clamped to `+-integral_limit` and frozen while the command
//! saturates in the direction that would grow it (conditional integration).
//! Unlike the FLC this controller uses `dt`: it is the time-dependent baseline.

use crate::command::{LongitudinalCommand, Status, clamp, safe_brake, valid_speed};
use crate::flc::{desired_distance, f_shift};
use crate::longitudinal::ActiveController;
use crate::longitudinal::{ControlOutput, Frame, LongitudinalController, Terms};
use crate::params::{ParamError, check_positive, check_range};

/// One set of PID gains (the output `u` is a speed increment in m/s).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain on the gap error, (m/s)/m.
    pub kp: f64,
    /// Integral gain, (m/s)/(m·s).
    pub ki: f64,
    /// Derivative gain on the gap-error rate `S_L - S_F`, (m/s)/(m/s).
    pub kd: f64,
}

/// Parameters of the PID gap controller. The paper gives the time gap (0.5 s) and the structure
/// (two gain sets, far / near); the gains and the switching distance are documented choices
/// (`docs/paper-notes.md`).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidParams {
    /// Desired time gap, s. Paper: 0.5.
    pub time_gap: f64,
    /// Base desired gap `B_gap`, m (shared with the FLC). Paper: 6.0.
    pub base_gap: f64,
    /// `C` of `Scale_f` (shared with the FLC), m/s. Paper: 5/3.6.
    pub c: f64,
    /// Gain of `Scale_f` (shared with the FLC). Paper: 0.1.
    pub scale_gain: f64,
    /// Cap of `Scale_f` (shared with the FLC). Paper: 0.4.
    pub scale_cap: f64,
    /// Gains used when `distance >= desired + near_margin`.
    pub far: PidGains,
    /// Gains used when `distance < desired + near_margin`.
    pub near: PidGains,
    /// Switching margin above the desired distance, m. Default 5.
    pub near_margin: f64,
    /// Clamp of the integral term `ki * integral(e)`, m/s. Default 2.
    pub integral_limit: f64,
    /// `v_cmd = S_F + command_gain * u`, dimensionless. Default 1.
    pub command_gain: f64,
    /// Highest plausible speed (own and lead) and highest speed command, m/s. Default 70.
    pub max_speed: f64,
    /// Highest plausible distance, m. Default 500.
    pub max_distance: f64,
    /// Safe command on invalid input: `v_cmd = S_F - fault_brake_step`, m/s. Default 3.
    pub fault_brake_step: f64,
}

impl Default for PidParams {
    fn default() -> Self {
        Self::paper()
    }
}

impl PidParams {
    /// The paper's structure with the documented default gains.
    pub const fn paper() -> Self {
        Self {
            time_gap: 0.5,
            base_gap: 6.0,
            c: 5.0 / 3.6,
            scale_gain: 0.1,
            scale_cap: 0.4,
            far: PidGains { kp: 0.2, ki: 0.01, kd: 0.6 },
            near: PidGains { kp: 0.5, ki: 0.02, kd: 1.0 },
            near_margin: 5.0,
            integral_limit: 2.0,
            command_gain: 1.0,
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
        check_gains(&self.far, ["far.kp", "far.ki", "far.kd"])?;
        check_gains(&self.near, ["near.kp", "near.ki", "near.kd"])?;
        check_range("near_margin", self.near_margin, -100.0, 1000.0, "must be finite and in [-100, 1000] m")?;
        check_range("integral_limit", self.integral_limit, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        check_positive("command_gain", self.command_gain, 100.0, "must be finite and in (0, 100]")?;
        check_positive("max_speed", self.max_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_positive("max_distance", self.max_distance, 1.0e6, "must be finite and in (0, 1e6] m")?;
        check_range("fault_brake_step", self.fault_brake_step, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        Ok(())
    }

    /// Desired distance `D_d + F_shift` (Eqs. (2)-(4) with the PID's time gap), m.
    pub fn desired_distance(&self, own_speed: f64) -> f64 {
        desired_distance(self.time_gap, self.base_gap, own_speed) + f_shift(self.scale_gain, self.scale_cap, self.c, own_speed)
    }
}

fn check_gains(g: &PidGains, names: [&'static str; 3]) -> Result<(), ParamError> {
    let [kp, ki, kd] = names;
    check_range(kp, g.kp, 0.0, 100.0, "must be finite and in [0, 100]")?;
    check_range(ki, g.ki, 0.0, 100.0, "must be finite and in [0, 100]")?;
    check_range(kd, g.kd, 0.0, 100.0, "must be finite and in [0, 100]")
}

/// Which gain set the last step used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum GainSet {
    /// Far gains.
    #[default]
    Far,
    /// Near gains.
    Near,
}

/// The terms of the last PID step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PidTerms {
    /// Desired distance, m.
    pub desired: f64,
    /// Gap error `distance - desired`, m.
    pub error: f64,
    /// Gap-error rate `S_L - S_F`, m/s.
    pub error_rate: f64,
    /// Integral term `ki * integral(e dt)` after clamping, m/s.
    pub integral: f64,
    /// Gain set used.
    pub gains: GainSet,
    /// Controller output `u`, m/s.
    pub u: f64,
}

/// The PID gap controller law: the lead speed is an argument of every step. This is what the
/// [`crate::supervisor`] and the C interface run; [`PidController`] adds the hold of the last
/// received V2V lead speed used by [`LongitudinalController::step`].
#[derive(Debug, Clone)]
pub struct PidCore {
    params: PidParams,
    /// Integral term, already multiplied by `ki` (so gain switches are bumpless), m/s.
    integral: f64,
    terms: PidTerms,
}

impl PidCore {
    /// Validates `params` and builds the controller.
    pub fn new(params: PidParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self { params, integral: 0.0, terms: PidTerms::default() })
    }

    /// The parameters in use.
    pub fn params(&self) -> &PidParams {
        &self.params
    }

    /// Clears the integrator.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.terms = PidTerms::default();
    }

    /// The terms of the last step.
    pub fn terms(&self) -> &PidTerms {
        &self.terms
    }

    /// Bumpless transfer: sets the integral term so that, for the inputs of the last step, the
    /// output is `speed_command` (as far as `+-integral_limit` allows) and returns the resulting
    /// speed command. Non-finite arguments leave the state unchanged.
    pub fn preset_output(&mut self, speed_command: f64, own_speed: f64) -> f64 {
        let p = &self.params;
        let g = match self.terms.gains {
            GainSet::Far => p.far,
            GainSet::Near => p.near,
        };
        let proportional = g.kp * self.terms.error + g.kd * self.terms.error_rate;
        if speed_command.is_finite() && own_speed.is_finite() {
            let wanted = (speed_command - own_speed) / p.command_gain - proportional;
            self.integral = clamp(wanted, -p.integral_limit, p.integral_limit);
        }
        self.terms.integral = self.integral;
        self.terms.u = proportional + self.integral;
        clamp(own_speed + p.command_gain * self.terms.u, 0.0, p.max_speed)
    }

    /// One step. `lead_speed` is `S_L` from V2V, `own_speed` `S_F`, `distance` the gap in m
    /// (`None` = no lead detected), `dt` the time since the previous step in s.
    pub fn step(&mut self, lead_speed: f64, own_speed: f64, distance: Option<f64>, dt: f64) -> LongitudinalCommand {
        let p = self.params;
        let speed_ok = valid_speed(own_speed, p.max_speed);
        let status = match distance {
            _ if !speed_ok => Status::InvalidSpeed,
            _ if !valid_speed(lead_speed, p.max_speed) => Status::InvalidLeadSpeed,
            _ if !(dt.is_finite() && dt > 0.0 && dt <= 10.0) => Status::InvalidDt,
            None => Status::NoLead,
            Some(d) if !(d.is_finite() && d >= 0.0 && d <= p.max_distance) => Status::InvalidDistance,
            Some(_) => Status::Ok,
        };
        let (Status::Ok, Some(d)) = (status, distance) else {
            return safe_brake(own_speed, speed_ok, p.fault_brake_step, status);
        };
        let desired = p.desired_distance(own_speed);
        let error = d - desired;
        let error_rate = lead_speed - own_speed;
        let (gains, g) = if d < desired + p.near_margin { (GainSet::Near, p.near) } else { (GainSet::Far, p.far) };
        let candidate = clamp(self.integral + g.ki * error * dt, -p.integral_limit, p.integral_limit);
        let u_of = |i: f64| g.kp * error + i + g.kd * error_rate;
        let raw = own_speed + p.command_gain * u_of(candidate);
        // Conditional integration: do not integrate further into a saturated command.
        let saturated_high = raw > p.max_speed && candidate > self.integral;
        let saturated_low = raw < 0.0 && candidate < self.integral;
        if !(saturated_high || saturated_low) {
            self.integral = candidate;
        }
        let u = u_of(self.integral);
        let speed = clamp(own_speed + p.command_gain * u, 0.0, p.max_speed);
        self.terms = PidTerms { desired, error, error_rate, integral: self.integral, gains, u };
        if !speed.is_finite() {
            return safe_brake(own_speed, speed_ok, p.fault_brake_step, Status::InvalidDistance);
        }
        LongitudinalCommand { speed, accel: u, status: Status::Ok }
    }
}

impl PidTerms {
    /// The names of [`PidTerms::to_terms`], in field order (`gains`: 0 = far, 1 = near).
    pub const NAMES: &'static [&'static str] = &["desired", "error", "error_rate", "integral", "gains", "u"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        let gains = match t.gains {
            GainSet::Far => 0.0,
            GainSet::Near => 1.0,
        };
        Terms::new(Self::NAMES, &[t.desired, t.error, t.error_rate, t.integral, gains, t.u])
    }
}

/// The PID gap controller ([`PidCore`]) plus the hold of the last received V2V lead speed, for
/// [`LongitudinalController::step`]: each `Some(message)` of a frame replaces the held speed
/// before the step, and before any message the own speed stands in (zero relative speed). The
/// inherent [`PidController::step`] takes the lead speed explicitly and leaves the hold alone.
#[derive(Debug, Clone)]
pub struct PidController {
    core: PidCore,
    held_lead_speed: Option<f64>,
}

impl PidController {
    /// Validates `params` and builds the controller.
    pub fn new(params: PidParams) -> Result<Self, ParamError> {
        Ok(Self { core: PidCore::new(params)?, held_lead_speed: None })
    }

    /// The parameters in use.
    pub fn params(&self) -> &PidParams {
        self.core.params()
    }

    /// Clears the integrator and the held lead speed.
    pub fn reset(&mut self) {
        self.core.reset();
        self.held_lead_speed = None;
    }

    /// The terms of the last step.
    pub fn terms(&self) -> &PidTerms {
        self.core.terms()
    }

    /// The lead speed held from the last V2V message ([`LongitudinalController::step`] only).
    pub fn held_lead_speed(&self) -> Option<f64> {
        self.held_lead_speed
    }

    /// The law without the hold.
    pub fn core(&self) -> &PidCore {
        &self.core
    }

    /// See [`PidCore::preset_output`].
    pub fn preset_output(&mut self, speed_command: f64, own_speed: f64) -> f64 {
        self.core.preset_output(speed_command, own_speed)
    }

    /// See [`PidCore::step`] (the held lead speed is neither used nor changed).
    pub fn step(&mut self, lead_speed: f64, own_speed: f64, distance: Option<f64>, dt: f64) -> LongitudinalCommand {
        self.core.step(lead_speed, own_speed, distance, dt)
    }
}

/// The PID through the common interface: `held = msg.lead_speed` for each `Some(msg)`, then
/// `step(held.unwrap_or(own_speed), own_speed, distance, dt)`.
///
/// ```
/// use flc_core::{Frame, LongitudinalController, PidController, PidParams, V2vMessage};
///
/// let mut pid = PidController::new(PidParams::paper())?;
/// let v2v = Some(V2vMessage::speed_only(10.0, 1));
/// let out = LongitudinalController::step(&mut pid, &Frame { distance: Some(15.0), own_speed: 10.0, v2v, dt: 0.1, lead_speed: None, own_fix: None, travelled: None, intruder: None, path_clear: false });
/// // desired = 0.5 * 10 + 6 + 10 * 0.4 = 15 = distance, lead speed = own speed: u = 0.
/// assert_eq!(out.command.accel, 0.0);
/// assert_eq!(pid.desired_gap(10.0), 15.0);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for PidController {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        if let Some(m) = frame.v2v {
            self.held_lead_speed = Some(m.lead_speed);
        }
        let lead_speed = self.held_lead_speed.unwrap_or(frame.own_speed);
        let command = self.core.step(lead_speed, frame.own_speed, frame.distance, frame.dt);
        ControlOutput::single(command, self.core.terms.to_terms(), ActiveController::Pid)
    }

    fn reset(&mut self) {
        PidController::reset(self);
    }

    /// `T_G,pid v + B_gap + F_shift(v)`.
    fn desired_gap(&self, v: f64) -> f64 {
        self.core.params.desired_distance(v)
    }

    fn uses_dt(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pid() -> PidController {
        PidController::new(PidParams::paper()).unwrap()
    }

    #[test]
    fn desired_distance_by_hand() {
        // 0.5 * 10 + 6 = 11, plus F_shift = 10 * min(0.4, 0.72) = 4 -> 15.
        assert!((PidParams::paper().desired_distance(10.0) - 15.0).abs() < 1e-12);
    }

    #[test]
    fn far_gains_by_hand() {
        let mut c = pid();
        // d = 30 >= 15 + 5 -> far. e = 15, e_dot = 12 - 10 = 2, dt = 0.05.
        // I = 0.01 * 15 * 0.05 = 0.0075; u = 0.2 * 15 + 0.0075 + 0.6 * 2 = 4.2075; v = 14.2075.
        let out = c.step(12.0, 10.0, Some(30.0), 0.05);
        assert_eq!(c.terms().gains, GainSet::Far);
        assert!((out.accel - 4.2075).abs() < 1e-12);
        assert!((out.speed - 14.2075).abs() < 1e-12);
    }

    #[test]
    fn near_gains_by_hand() {
        let mut c = pid();
        // d = 18 < 20 -> near. e = 3, e_dot = 8 - 10 = -2.
        // I = 0.02 * 3 * 0.05 = 0.003; u = 0.5 * 3 + 0.003 + 1.0 * (-2) = -0.497; v = 9.503.
        let out = c.step(8.0, 10.0, Some(18.0), 0.05);
        assert_eq!(c.terms().gains, GainSet::Near);
        assert!((out.accel + 0.497).abs() < 1e-12);
        assert!((out.speed - 9.503).abs() < 1e-12);
    }

    #[test]
    fn integral_is_clamped() {
        let mut c = pid();
        for _ in 0..10_000 {
            c.step(10.0, 10.0, Some(100.0), 0.05);
        }
        assert!((c.terms().integral - 2.0).abs() < 1e-12);
        // ...and unwinds as soon as the error changes sign (no windup beyond the clamp).
        let before = c.terms().integral;
        c.step(10.0, 10.0, Some(10.0), 0.05);
        assert!(c.terms().integral < before);
    }

    #[test]
    fn conditional_integration_at_zero_speed_command() {
        let mut c = pid();
        // Far too close at standstill: command saturates at 0, the integrator must not run away.
        for _ in 0..1000 {
            let out = c.step(0.0, 0.0, Some(1.0), 0.05);
            assert_eq!(out.speed, 0.0);
        }
        assert_eq!(c.terms().integral, 0.0);
    }

    #[test]
    fn bumpless_preset() {
        let mut c = pid();
        c.step(12.0, 10.0, Some(30.0), 0.05);
        // Proportional part: 0.2 * 15 + 0.6 * 2 = 4.2. For 13.0 the integral becomes 3.0 - 4.2 = -1.2.
        let v = c.preset_output(13.0, 10.0);
        assert!((v - 13.0).abs() < 1e-12);
        assert!((c.terms().integral + 1.2).abs() < 1e-12);
        // For 10.5 it would need -3.7, beyond integral_limit 2: v = 10 + 4.2 - 2 = 12.2.
        let v = c.preset_output(10.5, 10.0);
        assert!((v - 12.2).abs() < 1e-12);
    }

    #[test]
    fn bad_inputs_give_safe_command() {
        let mut c = pid();
        assert_eq!(c.step(f64::NAN, 10.0, Some(30.0), 0.05).status, Status::InvalidLeadSpeed);
        assert_eq!(c.step(10.0, 10.0, Some(30.0), 0.0).status, Status::InvalidDt);
        assert_eq!(c.step(10.0, 10.0, Some(30.0), f64::NAN).status, Status::InvalidDt);
        assert_eq!(c.step(10.0, 10.0, None, 0.05).status, Status::NoLead);
        assert_eq!(c.step(10.0, 10.0, Some(-2.0), 0.05).status, Status::InvalidDistance);
        let out = c.step(10.0, f64::INFINITY, Some(30.0), 0.05);
        assert_eq!((out.status, out.speed), (Status::InvalidSpeed, 0.0));
        assert_eq!(c.step(10.0, 10.0, None, 0.05).speed, 7.0);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let e = PidController::new(PidParams { near: PidGains { kp: -1.0, ki: 0.0, kd: 0.0 }, ..PidParams::paper() }).unwrap_err();
        assert_eq!(e.field, "near.kp");
        let e = PidController::new(PidParams { time_gap: f64::INFINITY, ..PidParams::paper() }).unwrap_err();
        assert_eq!(e.field, "time_gap");
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::num::f64::ANY, proptest::num::f64::ANY, proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = pid();
            for (sl, sf, d, dt) in seq {
                let out = c.step(sl, sf, d, dt);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                prop_assert!(out.accel.is_finite());
                prop_assert!(c.terms().integral.abs() <= 2.0);
            }
        }
    }
}
