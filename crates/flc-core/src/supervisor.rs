//! The parallel longitudinal controller of Fig. 1.
//!
//! Both controllers are stepped every frame. The PID (which needs the lead's speed) drives while
//! V2V data is fresh; the FLC drives when V2V data is absent or late. Freshness is judged from what
//! actually arrives, counted in local control ticks, so no clock synchronisation between the
//! vehicles is needed:
//!
//! * `age` = control ticks since the last accepted V2V message (0 on a tick that brings one);
//! * V2V is *fresh* while `age <= max_age_ticks`;
//! * PID -> FLC as soon as V2V is not fresh (no hysteresis: safety first);
//! * FLC -> PID only after `return_after` consecutive fresh messages (each arriving within
//!   `max_age_ticks` of the previous one), so a flickering link does not chatter;
//! * the switch to the PID is bumpless: the PID's integrator is preset so that its first command
//!   equals the last command issued; the switch to the FLC takes the FLC's own command;
//! * V2V that is fresh but whose sender is not the object the detector reports
//!   ([`crate::association`]: a car cut in, a cut-out revealed another one) counts as not fresh:
//!   PID -> FLC at once (reason [`SwitchReason::NotAssociated`]), and back only after
//!   `return_after` consecutive fresh messages with the sender associated again;
//! * so does a neighbour entering the path nearer than the sender (the intruder of
//!   [`crate::NeighbourTracker`], given in [`Frame::intruder`]): the FLC then follows it, as the
//!   robust FLC does, before the detector finds it in the path.

use crate::association::{Association, AssociationInput, AssociationParams, AssociationState, OwnFix, SenderState};
use crate::command::LongitudinalCommand;
use crate::flc::{FallbackController, FlcParams};
use crate::longitudinal::{ControlOutput, Frame, LongitudinalController, Terms};
use crate::params::{ParamError, check_range};
use crate::pid::{PidCore, PidParams};

pub use crate::longitudinal::{ActiveController, SwitchReason, V2vMessage};

/// Parameters of the supervisor (and of the two controllers it runs).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupervisorParams {
    /// Highest V2V age, in local control ticks, still counted as fresh. Default 4 (200 ms at the
    /// paper's 20 Hz, i.e. two missed messages at 10 Hz V2V).
    pub max_age_ticks: u32,
    /// Consecutive fresh messages needed before the PID drives again. Default 5.
    pub return_after: u32,
    /// Preset the PID integrator on FLC -> PID so that the command does not jump. Default `true`.
    pub bumpless: bool,
    /// The FLC's parameters.
    pub flc: FlcParams,
    /// The PID's parameters.
    pub pid: PidParams,
    /// Is the detected object the V2V sender? ([`crate::association`]).
    pub association: AssociationParams,
}

impl Default for SupervisorParams {
    fn default() -> Self {
        Self {
            max_age_ticks: 4,
            return_after: 5,
            bumpless: true,
            flc: FlcParams::paper(),
            pid: PidParams::paper(),
            association: AssociationParams::default(),
        }
    }
}

/// Result of one supervisor step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupervisorOutput {
    /// The command to apply.
    pub command: LongitudinalCommand,
    /// Which controller produced it.
    pub active: ActiveController,
    /// Why.
    pub reason: SwitchReason,
    /// `true` on the tick the active controller changed.
    pub switched: bool,
    /// Ticks since the last accepted V2V message (`u32::MAX` if none yet).
    pub v2v_age_ticks: u32,
    /// Consecutive fresh messages counted so far (with the sender associated).
    pub fresh_count: u32,
    /// Is the detected object the V2V sender?
    pub association: AssociationState,
    /// What the FLC commanded this tick.
    pub flc: LongitudinalCommand,
    /// What the PID commanded this tick.
    pub pid: LongitudinalCommand,
}

/// The parallel longitudinal controller.
#[derive(Debug, Clone)]
pub struct Supervisor {
    params: SupervisorParams,
    flc: FallbackController,
    pid: PidCore,
    active: ActiveController,
    age: u32,
    last_seq: Option<u32>,
    lead_speed: Option<f64>,
    sender: Option<SenderState>,
    association: Association,
    fresh_count: u32,
    last_command: Option<f64>,
    last_invalid: bool,
}

impl Supervisor {
    /// Validates all parameters (FLC and PID included) and builds the supervisor. It starts with
    /// the FLC driving and no V2V.
    pub fn new(params: SupervisorParams) -> Result<Self, ParamError> {
        check_range("max_age_ticks", f64::from(params.max_age_ticks), 0.0, 1.0e6, "must be in [0, 1e6] ticks")?;
        check_range("return_after", f64::from(params.return_after), 1.0, 1.0e6, "must be in [1, 1e6] messages")?;
        Ok(Self {
            params,
            flc: FallbackController::new(params.flc)?,
            pid: PidCore::new(params.pid)?,
            active: ActiveController::Flc,
            age: u32::MAX,
            last_seq: None,
            lead_speed: None,
            sender: None,
            association: Association::new(params.association)?,
            fresh_count: 0,
            last_command: None,
            last_invalid: false,
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &SupervisorParams {
        &self.params
    }

    /// The FLC (for its terms).
    pub fn flc(&self) -> &FallbackController {
        &self.flc
    }

    /// The PID (for its terms).
    pub fn pid(&self) -> &PidCore {
        &self.pid
    }

    /// The controller that drove the last step ([`ActiveController::Flc`] before the first).
    pub fn active(&self) -> ActiveController {
        self.active
    }

    /// Back to the initial state (FLC, no V2V).
    pub fn reset(&mut self) {
        self.flc.reset();
        self.pid.reset();
        self.active = ActiveController::Flc;
        self.age = u32::MAX;
        self.last_seq = None;
        self.lead_speed = None;
        self.sender = None;
        self.association.reset();
        self.fresh_count = 0;
        self.last_command = None;
        self.last_invalid = false;
    }

    /// One control tick. `v2v` is the message received since the previous tick (if any),
    /// `distance` the LiDAR distance (`None`: no lead detected), `own_speed` in m/s, `dt` the PID's
    /// time step in s (the FLC ignores it).
    pub fn step(&mut self, v2v: Option<V2vMessage>, distance: Option<f64>, own_speed: f64, dt: f64) -> SupervisorOutput {
        self.step_with_fix(v2v, distance, own_speed, dt, None)
    }

    /// [`Self::step`] with the own GNSS fix for the association rule's position gate.
    pub fn step_with_fix(
        &mut self,
        v2v: Option<V2vMessage>,
        distance: Option<f64>,
        own_speed: f64,
        dt: f64,
        own_fix: Option<OwnFix>,
    ) -> SupervisorOutput {
        self.step_frame(&Frame { v2v, own_fix, ..Frame::new(distance, own_speed, dt) })
    }

    /// One control tick from a whole [`Frame`]: `v2v`, `distance`, `own_speed`, `dt`, `own_fix`
    /// as in [`Self::step_with_fix`], and `intruder`, the distance to a neighbour entering the
    /// path ([`crate::NeighbourTracker`]). An intruder nearer than the V2V sender breaks the
    /// association ([`crate::association`], rule 4): the FLC drives at once and, like the FLC of
    /// the robust family, follows the intruder (the nearer of `distance` and `intruder`); the PID
    /// keeps the detector's distance to the sender. Back to the PID as for any other loss of
    /// association, after `return_after` fresh messages with the sender associated again.
    pub fn step_frame(&mut self, frame: &Frame) -> SupervisorOutput {
        let (v2v, distance, own_speed, dt, own_fix) = (frame.v2v, frame.distance, frame.own_speed, frame.dt, frame.own_fix);
        let intruder = frame.intruder.filter(|x| x.is_finite());
        self.receive(v2v);
        let fresh = self.age <= self.params.max_age_ticks;
        let tick = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let association = self.association.step(&AssociationInput {
            distance,
            own_speed,
            sender_speed: if fresh { self.lead_speed } else { None },
            sender: self.sender.as_ref(),
            message_age: f64::from(self.age.min(1_000_000)) * tick,
            own_fix,
            dt,
            intruder,
        });
        let not_associated = fresh && association == AssociationState::NotAssociated;
        if not_associated {
            // The hand-back counts messages from the tick the sender is associated again.
            self.fresh_count = 0;
        }

        // The FLC follows whatever is nearest in front: an intruder nearer than the detection.
        let nearest = match (distance, intruder) {
            (Some(d), Some(x)) if x < d => Some(x),
            (None, Some(x)) => Some(x),
            _ => distance,
        };
        let flc = self.flc.step(nearest, own_speed);
        // Without any lead speed the PID is stepped with zero relative speed; its output is then
        // only logged (the FLC drives until V2V has been fresh for `return_after` messages).
        let lead_speed = self.lead_speed.unwrap_or(own_speed);
        let mut pid = self.pid.step(lead_speed, own_speed, distance, dt);

        let previous = self.active;
        self.active = match self.active {
            ActiveController::Pid if !fresh || not_associated => ActiveController::Flc,
            ActiveController::Flc if fresh && !not_associated && self.fresh_count >= self.params.return_after => ActiveController::Pid,
            same => same,
        };
        let switched = previous != self.active;
        if switched && self.active == ActiveController::Pid && self.params.bumpless && pid.status.is_ok() {
            if let Some(last) = self.last_command {
                pid.speed = self.pid.preset_output(last, own_speed);
                pid.accel = self.pid.terms().u;
            }
        }
        let reason = if self.last_invalid {
            SwitchReason::InvalidV2v
        } else if self.last_seq.is_none() {
            SwitchReason::NoV2v
        } else if !fresh {
            SwitchReason::V2vStale
        } else if not_associated {
            SwitchReason::NotAssociated
        } else if self.active == ActiveController::Flc {
            SwitchReason::Recovering
        } else {
            SwitchReason::V2vFresh
        };
        let command = match self.active {
            ActiveController::Flc => flc,
            ActiveController::Pid => pid,
        };
        self.last_command = Some(command.speed);
        SupervisorOutput {
            command,
            active: self.active,
            reason,
            switched,
            v2v_age_ticks: self.age,
            fresh_count: self.fresh_count,
            association,
            flc,
            pid,
        }
    }

    /// Updates age, sequence and the consecutive-fresh count from this tick's message.
    fn receive(&mut self, v2v: Option<V2vMessage>) {
        let max_speed = self.params.pid.max_speed;
        let accepted = match v2v {
            Some(m) if !(m.lead_speed.is_finite() && m.lead_speed >= -1.0 && m.lead_speed <= max_speed) => {
                self.last_invalid = true;
                self.fresh_count = 0;
                None
            }
            Some(m) => {
                self.last_invalid = false;
                // Wrapping comparison: newer iff (seq - last) is in (0, 2^31).
                let newer = self.last_seq.is_none_or(|last| {
                    let d = m.seq.wrapping_sub(last);
                    d != 0 && d < 1 << 31
                });
                newer.then_some(m)
            }
            None => None,
        };
        match accepted {
            Some(m) => {
                let in_time = self.age <= self.params.max_age_ticks;
                self.fresh_count = if in_time { self.fresh_count.saturating_add(1) } else { 1 };
                self.age = 0;
                self.last_seq = Some(m.seq);
                self.lead_speed = Some(m.lead_speed);
                self.sender = m.sender;
            }
            None => {
                self.age = self.age.saturating_add(1);
                if self.age > self.params.max_age_ticks {
                    self.fresh_count = 0;
                }
            }
        }
    }
}

impl SupervisorOutput {
    /// The names of [`SupervisorOutput::to_terms`].
    pub const NAMES: &'static [&'static str] = &["flc_speed", "flc_accel", "pid_speed", "pid_accel", "fresh_count"];

    /// What both controllers commanded and the fresh-message count, as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        Terms::new(Self::NAMES, &[self.flc.speed, self.flc.accel, self.pid.speed, self.pid.accel, f64::from(self.fresh_count)])
    }
}

/// The pipeline through the common interface: [`Supervisor::step_frame`].
///
/// ```
/// use flc_core::{ActiveController, Frame, LongitudinalController, Supervisor, SupervisorParams, SwitchReason};
///
/// let mut s = Supervisor::new(SupervisorParams::default())?;
/// let out = LongitudinalController::step(&mut s, &Frame::new(Some(25.0), 10.0, 0.05));
/// // No V2V yet: the FLC drives, Eqs. (2)-(5) give a = 5 (1 - cos(5 pi / 11)).
/// assert_eq!((out.active, out.reason, out.v2v_age_ticks), (ActiveController::Flc, SwitchReason::NoV2v, u32::MAX));
/// assert!((out.command.accel - 4.288425808633574).abs() < 1e-12);
/// // The FLC's D_d + F_shift while it drives; the PID's spacing for the string.
/// assert!((s.desired_gap(10.0) - 20.0).abs() < 1e-12);
/// assert_eq!(s.formation_gap(10.0), 15.0);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
impl LongitudinalController for Supervisor {
    fn step(&mut self, frame: &Frame) -> ControlOutput {
        let o = Supervisor::step_frame(self, frame);
        ControlOutput {
            command: o.command,
            terms: o.to_terms(),
            active: o.active,
            reason: o.reason,
            switched: o.switched,
            v2v_age_ticks: o.v2v_age_ticks,
            association: o.association,
        }
    }

    fn reset(&mut self) {
        Supervisor::reset(self);
    }

    /// The driving law's: the PID's desired distance while it is active, else the FLC's
    /// `D_d + F_shift` (Eqs. (2)-(4)), for the state after the last step.
    fn desired_gap(&self, v: f64) -> f64 {
        match self.active {
            ActiveController::Pid => self.params.pid.desired_distance(v),
            ActiveController::Flc => self.params.flc.desired_distance(v) + self.params.flc.f_shift(v),
        }
    }

    /// The PID's desired distance (the law that drives while V2V is fresh).
    fn formation_gap(&self, v: f64) -> f64 {
        self.params.pid.desired_distance(v)
    }

    fn uses_dt(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::Status;
    use proptest::prelude::*;

    const DT: f64 = 0.05;

    fn msg(seq: u32) -> Option<V2vMessage> {
        Some(V2vMessage::speed_only(10.0, seq))
    }

    #[test]
    fn starts_on_flc_and_returns_to_pid_after_n_fresh_messages() {
        let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
        let out = s.step(None, Some(20.0), 10.0, DT);
        assert_eq!((out.active, out.reason), (ActiveController::Flc, SwitchReason::NoV2v));
        for seq in 1..5 {
            let out = s.step(msg(seq), Some(20.0), 10.0, DT);
            assert_eq!((out.active, out.reason), (ActiveController::Flc, SwitchReason::Recovering));
        }
        let out = s.step(msg(5), Some(20.0), 10.0, DT);
        assert_eq!(out.active, ActiveController::Pid);
        assert!(out.switched);
        assert_eq!(out.fresh_count, 5);
    }

    #[test]
    fn falls_back_when_v2v_is_older_than_max_age_and_reports_why() {
        let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
        for seq in 1..=5 {
            s.step(msg(seq), Some(20.0), 10.0, DT);
        }
        // Age 1..4 ticks: still fresh (max_age_ticks = 4).
        for age in 1..=4 {
            let out = s.step(None, Some(20.0), 10.0, DT);
            assert_eq!((out.active, out.v2v_age_ticks), (ActiveController::Pid, age));
        }
        // Age 5: stale -> FLC at once, with the FLC's own command.
        let out = s.step(None, Some(20.0), 10.0, DT);
        assert_eq!((out.active, out.reason, out.switched), (ActiveController::Flc, SwitchReason::V2vStale, true));
        assert_eq!(out.command, out.flc);
        // A single message does not bring the PID back...
        let out = s.step(msg(6), Some(20.0), 10.0, DT);
        assert_eq!((out.active, out.reason, out.fresh_count), (ActiveController::Flc, SwitchReason::Recovering, 1));
        // ...five consecutive ones do.
        for seq in 7..=10 {
            s.step(msg(seq), Some(20.0), 10.0, DT);
        }
        assert_eq!(s.active, ActiveController::Pid);
    }

    #[test]
    fn the_return_to_pid_is_bumpless() {
        let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
        let mut last = 0.0;
        for seq in 1..=5 {
            let out = s.step(msg(seq), Some(22.0), 10.0, DT);
            if out.switched {
                assert_eq!(out.active, ActiveController::Pid);
                assert!((out.command.speed - last).abs() < 1e-12, "{} vs {}", out.command.speed, last);
            }
            last = out.command.speed;
        }
        // Without bumpless transfer the PID's raw command differs from the FLC's last one.
        let mut raw = Supervisor::new(SupervisorParams { bumpless: false, ..Default::default() }).unwrap();
        let mut last = 0.0;
        let mut jump = 0.0;
        for seq in 1..=5 {
            let out = raw.step(msg(seq), Some(22.0), 10.0, DT);
            if out.switched {
                jump = (out.command.speed - last).abs();
            }
            last = out.command.speed;
        }
        assert!(jump > 0.1);
    }

    #[test]
    fn duplicates_and_old_messages_do_not_refresh() {
        let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
        s.step(msg(7), Some(20.0), 10.0, DT);
        let out = s.step(msg(7), Some(20.0), 10.0, DT);
        assert_eq!(out.v2v_age_ticks, 1);
        let out = s.step(msg(3), Some(20.0), 10.0, DT);
        assert_eq!(out.v2v_age_ticks, 2);
        // Wrapping sequence numbers are newer.
        let mut w = Supervisor::new(SupervisorParams::default()).unwrap();
        w.step(msg(u32::MAX), Some(20.0), 10.0, DT);
        assert_eq!(w.step(msg(0), Some(20.0), 10.0, DT).v2v_age_ticks, 0);
    }

    #[test]
    fn an_intruder_nearer_than_the_sender_hands_over_to_the_flc_which_follows_it() {
        let frame = |seq: u32, intruder: Option<f64>| Frame { v2v: msg(seq), intruder, ..Frame::new(Some(20.0), 10.0, DT) };
        let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
        for seq in 1..=6 {
            let active = s.step_frame(&frame(seq, None)).active;
            assert_eq!(active == ActiveController::Pid, seq >= 5, "seq {seq}");
        }
        // A car entering the path 9 m ahead, the sender at 20 m: the FLC at once, on the car.
        let out = s.step_frame(&frame(7, Some(9.0)));
        assert_eq!((out.active, out.reason, out.switched), (ActiveController::Flc, SwitchReason::NotAssociated, true));
        assert_eq!(out.association, AssociationState::NotAssociated);
        let mut on_car = FallbackController::new(FlcParams::paper()).unwrap();
        let mut on_lead = FallbackController::new(FlcParams::paper()).unwrap();
        let (car, lead) = (on_car.step(Some(9.0), 10.0), on_lead.step(Some(20.0), 10.0));
        assert!(car.accel < lead.accel, "{car:?} vs {lead:?}");
        // The supervisor's FLC has been stepped on the lead so far: compare with the same history.
        let mut twin = FallbackController::new(FlcParams::paper()).unwrap();
        for _ in 1..=6 {
            twin.step(Some(20.0), 10.0);
        }
        assert_eq!(out.command, twin.step(Some(9.0), 10.0));
        // An intruder beyond the sender changes nothing; one nearer keeps the FLC; when it has
        // gone, the PID drives again after `return_after` messages.
        let mut t = Supervisor::new(SupervisorParams::default()).unwrap();
        for seq in 1..=6 {
            t.step_frame(&frame(seq, None));
        }
        let out = t.step_frame(&frame(7, Some(40.0)));
        assert_eq!((out.active, out.association), (ActiveController::Pid, AssociationState::Associated));
        for seq in 8..=20 {
            assert_eq!(s.step_frame(&frame(seq, Some(9.0))).active, ActiveController::Flc);
        }
        let back: [ActiveController; 6] = core::array::from_fn(|k| s.step_frame(&frame(21 + k as u32, None)).active);
        assert_eq!(
            back,
            [
                ActiveController::Flc,
                ActiveController::Flc,
                ActiveController::Flc,
                ActiveController::Flc,
                ActiveController::Pid,
                ActiveController::Pid
            ]
        );
        // `step` and the trait's step without an intruder are `step_frame` with none.
        let (mut a, mut b) = (Supervisor::new(SupervisorParams::default()).unwrap(), Supervisor::new(SupervisorParams::default()).unwrap());
        for seq in 1..=8 {
            assert_eq!(a.step(msg(seq), Some(20.0), 10.0, DT), b.step_frame(&frame(seq, None)));
        }
    }

    #[test]
    fn invalid_v2v_is_reported_and_not_used() {
        let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
        for seq in 1..=5 {
            s.step(msg(seq), Some(20.0), 10.0, DT);
        }
        let out = s.step(Some(V2vMessage::speed_only(f64::NAN, 6)), Some(20.0), 10.0, DT);
        assert_eq!(out.reason, SwitchReason::InvalidV2v);
        assert_eq!(out.fresh_count, 0);
        assert!(out.command.speed.is_finite());
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let e = Supervisor::new(SupervisorParams { return_after: 0, ..Default::default() }).unwrap_err();
        assert_eq!(e.field, "return_after");
        let mut p = SupervisorParams::default();
        p.flc.bound_t = -1.0;
        assert_eq!(Supervisor::new(p).unwrap_err().field, "bound_t");
    }

    proptest! {
        #[test]
        fn any_input_sequence_gives_a_finite_command(
            seq in proptest::collection::vec((proptest::option::of((proptest::num::f64::ANY, 0u32..20)), proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::num::f64::ANY), 1..60)
        ) {
            let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
            for (m, d, v, dt) in seq {
                let out = s.step(m.map(|(lead_speed, seq)| V2vMessage::speed_only(lead_speed, seq)), d, v, dt);
                prop_assert!(out.command.speed.is_finite() && out.command.speed >= 0.0 && out.command.speed <= 70.0);
                if !v.is_finite() { prop_assert_eq!(out.command.status, Status::InvalidSpeed); }
            }
        }
    }
}
