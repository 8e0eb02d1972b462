//! Is the object the LiDAR detector reports the V2V sender? (issue 25)
//!
//! The pipeline's PID combines the sender's broadcast speed with the detector's distance. That is
//! only right while the detected object *is* the sender: a car without V2V that cuts in between
//! (or is revealed by a cut-out) gives the PID the distance to one vehicle and the speed of
//! another. [`Association`] decides, each control tick, from what the supervisor already has
//! (the detector's distance, the own speed, the V2V message's contents and its age in ticks):
//!
//! 1. **Continuity (jump and rate test).** The distance must change as the reported relative
//!    speed says. A tracked gap `g` is carried on each tick by `(v_s - v_o) dt` (`v_s` the
//!    sender's speed extrapolated with its broadcast acceleration over the message's age) and
//!    pulled towards each detection with time constant `track_tau_s`; a detection with `|d -
//!    g| > jump_m` is a new object. A car entering the gap is entirely between the ego and the
//!    sender, so the distance jumps *down* by at least its length (>= 3 m for a car) on the first
//!    scan that sees it; a cut-out makes it jump *up* by at least the leaving lead's length. An
//!    object whose gap changes at a rate differing by `dv` from the reported relative speed
//!    drifts away from `g` by up to `dv track_tau_s` (the gap's change against the reported
//!    relative speed). Either is a new object: not associated from that tick on.
//! 2. **Dead-reckoned sender gap.** While not associated, the sender's gap is carried on from
//!    the last associated distance with the reported relative speed. A detection that matches it
//!    within `jump_m + speed_error_mps * t` (t since the anchor) is the sender again (e.g. the
//!    car that cut in has left).
//! 3. **Position gate.** When the message carries the sender's GNSS position and the caller
//!    gives the own fix ([`OwnFix`]), the detected distance must lie within
//!    `gate_sigmas * sqrt(2) * gnss_sigma_m + v_s * max_latency_s` of the V2V-predicted gap
//!    `(p_s - p_o) . h_o - L_s` (both positions are CAM reference points, the centre of the
//!    front of the vehicle's bounding box). It is coarse on purpose (25.5 m + 3.6 m at 3 m GNSS
//!    sigma and 130 km/h): it catches a wrong object at start-up and, when the dead reckoning
//!    has grown too wide, an object far from the sender; it never decides a cut-in.
//! 4. **Intruder.** A car entering the lane is reported by the neighbour tracker
//!    ([`crate::NeighbourTracker`]: its near edge has come towards the ego's path by more than the
//!    wandering zone) well before the detector finds it in the path, and before rule 1 can see
//!    its jump. An intruder nearer than the V2V lead, `x_i < g_s - jump_m` with `g_s` the lead's
//!    gap (the detected distance; without a detection, the dead-reckoned sender gap or the
//!    tracked gap), is between the ego and the sender: the object
//!    the ego must follow is not the sender, not associated. The margin `jump_m` keeps the lead
//!    itself (the tracker may hold it too, at the detector's distance) from counting; a car that
//!    cuts in is its own length (>= 3 m) nearer. An intruder beyond the lead changes nothing.
//!    With no gap of the sender yet (never detected), the V2V-predicted gap of rule 3 stands in,
//!    with the position gate as the margin (`x_i < g_v2v - gate`); without positions the rule
//!    cannot tell: the intruder may be the sender itself (a car with V2V cutting in ahead of
//!    an empty lane, as in UN R157's cut-in cases), which the rules 1-3 then associate.
//!    The rule compares positions of the same tick only (no timestamp, no speed).
//!
//! The thresholds and their derivation are in `docs/v2v-and-metrics.md`. No state depends on
//! time other than through ticks and the caller's `dt`; no input can make it panic.

use crate::params::{ParamError, check_range};

/// Parameters of the association rule (part of [`crate::SupervisorParams`]).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssociationParams {
    /// `false`: every detection counts as the sender (the paper's pipeline). Default `true`.
    pub enabled: bool,
    /// Largest unexplained change of the distance between two ticks, m, in (0, 100]. Default 1.5:
    /// above the per-tick error (LiDAR noise 3 sigma sqrt 2 = 0.08 m, relative-speed error of a
    /// 100 ms old speed at 8 m/s² times 50 ms = 0.04 m, the detector's nearest point moving on
    /// the rear of a car that is turning, < 0.5 m) and below the shortest car's length (3 m).
    pub jump_m: f64,
    /// Time constant with which the tracked gap follows the detections, s, in [0.05, 100].
    /// Default 2: a relative-speed mismatch above `jump_m / track_tau_s` = 0.75 m/s is a
    /// different object; the sender's speed error after extrapolating with its acceleration
    /// (jerk times latency, a 100 ms air latency at 2.5 m/s² unextrapolated: 0.25 m/s) is well
    /// below.
    pub track_tau_s: f64,
    /// Growth of the dead-reckoned gap's tolerance, m/s, in [0, 10]: the relative error of the
    /// two speeds (the broadcast and the own speedometer). Default 0.05.
    pub speed_error_mps: f64,
    /// 1-sigma GNSS position error assumed for each vehicle, m, in [0, 100]. Default 3.
    pub gnss_sigma_m: f64,
    /// Width of the position gate in sigmas of the gap's GNSS error (`sqrt 2 gnss_sigma_m`), in
    /// [1, 100]. Default 6: by the union bound over an hour's 72 000 control ticks at 20 Hz,
    /// whatever the error's correlation, a false rejection in an hour has probability at most
    /// `72 000 * 2 Phi(-6)` = 1.4e-4 (4.5 sigma would allow 0.49 per hour).
    pub gate_sigmas: f64,
    /// Largest V2V air latency the gate allows for, s, in [0, 10]: the sender has moved on by
    /// `v_s max_latency_s` since its position was taken. Default 0.1.
    pub max_latency_s: f64,
}

impl Default for AssociationParams {
    fn default() -> Self {
        Self {
            enabled: true,
            jump_m: 1.5,
            track_tau_s: 2.0,
            speed_error_mps: 0.05,
            gnss_sigma_m: 3.0,
            gate_sigmas: 6.0,
            max_latency_s: 0.1,
        }
    }
}

impl AssociationParams {
    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("association.jump_m", self.jump_m, 1e-3, 100.0, "must be in [0.001, 100] m")?;
        check_range("association.track_tau_s", self.track_tau_s, 0.05, 100.0, "must be in [0.05, 100] s")?;
        check_range("association.speed_error_mps", self.speed_error_mps, 0.0, 10.0, "must be in [0, 10] m/s")?;
        check_range("association.gnss_sigma_m", self.gnss_sigma_m, 0.0, 100.0, "must be in [0, 100] m")?;
        check_range("association.gate_sigmas", self.gate_sigmas, 1.0, 100.0, "must be in [1, 100]")?;
        check_range("association.max_latency_s", self.max_latency_s, 0.0, 10.0, "must be in [0, 10] s")
    }

    /// Half-width of the position gate at sender speed `v_s`, m.
    pub fn gate_m(&self, v_s: f64) -> f64 {
        self.gate_sigmas * core::f64::consts::SQRT_2 * self.gnss_sigma_m + v_s.abs() * self.max_latency_s
    }
}

/// The sender's state as broadcast (the CAM's / BSM's kinematic fields, see
/// `docs/v2v-and-metrics.md`), in a local east-north frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SenderState {
    /// Station id (CAM `ItsPduHeader.stationID`, BSM `id`).
    pub station_id: u32,
    /// Reference position, m (CAM `ReferencePosition`: the centre of the front of the bounding
    /// box), with the sender's GNSS error.
    pub x: f64,
    /// Reference position, m.
    pub y: f64,
    /// Heading, rad, counter-clockwise from x (CAM `Heading`, BSM `heading`).
    pub heading: f64,
    /// Longitudinal acceleration, m/s² (CAM `LongitudinalAcceleration`, BSM `accelSet.long`).
    pub accel: f64,
    /// Vehicle length, m (CAM `VehicleLength`, BSM `size.length`).
    pub length: f64,
}

/// The receiver's own GNSS fix: the same reference point (centre of the front of its bounding
/// box) and frame as [`SenderState`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OwnFix {
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Heading, rad.
    pub heading: f64,
}

/// The V2V-predicted bumper-to-bumper gap from the sender's reported position, extrapolated by
/// `lead` seconds at its speed `v_s`, as seen from `own`: `(p_s - p_o) . h_o - L_s`.
pub fn predicted_gap(sender: &SenderState, v_s: f64, lead: f64, own: &OwnFix) -> f64 {
    let (sx, sy) = (sender.x + v_s * lead * libm::cos(sender.heading), sender.y + v_s * lead * libm::sin(sender.heading));
    (sx - own.x) * libm::cos(own.heading) + (sy - own.y) * libm::sin(own.heading) - sender.length
}

/// The association decision of one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum AssociationState {
    /// No fresh V2V or no detection: nothing to associate (the supervisor's other rules decide).
    Unknown = 0,
    /// The detected object is the V2V sender.
    Associated = 1,
    /// The detected object is not the V2V sender (a new object after a jump, or outside the gate),
    /// or an intruding neighbour is nearer than the sender (rule 4).
    NotAssociated = 2,
}

impl AssociationState {
    /// Stable lower-case name.
    pub const fn as_str(self) -> &'static str {
        match self {
            AssociationState::Unknown => "unknown",
            AssociationState::Associated => "associated",
            AssociationState::NotAssociated => "not_associated",
        }
    }
}

/// One tick's inputs: everything the supervisor knows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssociationInput<'a> {
    /// Detector distance, m (`None`: nothing detected).
    pub distance: Option<f64>,
    /// Own speed, m/s.
    pub own_speed: f64,
    /// The sender's last speed, m/s (`None`: no fresh V2V).
    pub sender_speed: Option<f64>,
    /// The sender's last state (position etc.), if the message carried one.
    pub sender: Option<&'a SenderState>,
    /// Seconds since that message arrived (ticks times `dt`).
    pub message_age: f64,
    /// The own GNSS fix, if any.
    pub own_fix: Option<OwnFix>,
    /// Time since the previous tick, s.
    pub dt: f64,
    /// Distance to the nearest intruding neighbour ([`crate::NeighbourTracker::update`]), m, on
    /// the same scale as `distance` (`None`: none). Rule 4.
    pub intruder: Option<f64>,
}

/// The association rule's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Association {
    params: AssociationParams,
    state: AssociationState,
    /// The tracked gap of the object followed (m): carried on with the reported relative speed,
    /// pulled towards the detections.
    track: Option<f64>,
    /// Dead-reckoned sender gap (m) and seconds since it was anchored on an associated detection.
    sender_gap: Option<f64>,
    since_anchor: f64,
    /// Outcome of the last jump test (`true`: the object changed on that tick).
    jumped: bool,
}

impl Association {
    /// Validates the parameters.
    pub fn new(params: AssociationParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self::new_unchecked(params))
    }

    /// The parameters.
    pub fn params(&self) -> &AssociationParams {
        &self.params
    }

    /// The last decision.
    pub fn state(&self) -> AssociationState {
        self.state
    }

    /// `true` if the last tick's detection was a new object (a distance jump).
    pub fn jumped(&self) -> bool {
        self.jumped
    }

    /// Back to the initial state.
    pub fn reset(&mut self) {
        *self = Self::new_unchecked(self.params);
    }

    fn new_unchecked(params: AssociationParams) -> Self {
        Self { params, state: AssociationState::Unknown, track: None, sender_gap: None, since_anchor: 0.0, jumped: false }
    }

    /// Rule 4: `intruder` is nearer than the sender's gap by more than `jump_m` (the gap: the
    /// detection `d`, else the dead-reckoned sender gap, else the tracked gap); with none of
    /// them, nearer than the V2V-predicted gap `predicted` (rule 3) by more than the position
    /// gate. Nothing known of where the sender is: the rule cannot tell (the intruder may be the
    /// sender itself, a V2V car cutting in ahead of an empty lane).
    fn intruder_nearer(&self, intruder: Option<f64>, d: Option<f64>, predicted: Option<f64>, v_s: f64) -> bool {
        let Some(x) = intruder.filter(|x| x.is_finite()) else { return false };
        match (d.or(self.sender_gap).or(self.track), predicted) {
            (Some(g), _) => x < g - self.params.jump_m,
            (None, Some(g)) => x < g - self.params.gate_m(v_s),
            (None, None) => false,
        }
    }

    /// One tick: returns the decision (also kept as [`Self::state`]).
    pub fn step(&mut self, input: &AssociationInput<'_>) -> AssociationState {
        let p = self.params;
        let dt = if input.dt.is_finite() && input.dt > 0.0 { input.dt.min(1.0) } else { 0.0 };
        let d = input.distance.filter(|d| d.is_finite());
        let v_o = if input.own_speed.is_finite() { input.own_speed } else { 0.0 };
        let Some(v_s) = input.sender_speed.filter(|v| v.is_finite()).filter(|_| p.enabled) else {
            // No V2V (or association off): nothing to associate; forget the sender's gap.
            self.state = if p.enabled || input.sender_speed.is_none() { AssociationState::Unknown } else { AssociationState::Associated };
            self.track = d;
            self.sender_gap = None;
            self.jumped = false;
            return self.state;
        };
        let accel = input.sender.map_or(0.0, |s| if s.accel.is_finite() { s.accel } else { 0.0 });
        let age = if input.message_age.is_finite() { input.message_age.clamp(0.0, 1.0) } else { 0.0 };
        let v_now = (v_s + accel * age).max(0.0);
        let closing = (v_now - v_o) * dt;
        if let Some(g) = self.track.as_mut() {
            *g += closing;
        }
        if let Some(g) = self.sender_gap.as_mut() {
            *g += closing;
            self.since_anchor += dt;
        }
        // The V2V-predicted gap (rule 3), when the message carries the sender's position and the
        // own fix is known.
        let predicted = match (input.sender, input.own_fix) {
            (Some(s), Some(own)) => Some(predicted_gap(s, v_s, input.message_age.max(0.0), &own)).filter(|g| g.is_finite()),
            _ => None,
        };
        let Some(d) = d else {
            // No detection: keep the decision (rule 4 aside), carry the expected change to the
            // next one.
            self.jumped = false;
            if self.intruder_nearer(input.intruder, None, predicted, v_s) {
                self.state = AssociationState::NotAssociated;
            }
            return self.state;
        };
        self.jumped = self.track.is_some_and(|g| libm::fabs(d - g) > p.jump_m);
        self.track = match self.track {
            Some(g) if !self.jumped => Some(g + (d - g) * (dt / p.track_tau_s).min(1.0)),
            // A new object (or the first): track it from here.
            _ => Some(d),
        };

        let in_gate = predicted.is_none_or(|g| libm::fabs(d - g) <= p.gate_m(v_s));
        let matches_dead_reckoning = self.sender_gap.is_none_or(|g| libm::fabs(d - g) <= p.jump_m + p.speed_error_mps * self.since_anchor);
        self.state = match self.state {
            // The same object as before unless it jumped.
            AssociationState::Associated if !self.jumped && in_gate => AssociationState::Associated,
            AssociationState::Associated => AssociationState::NotAssociated,
            // First detection with V2V: the gate decides (no dead reckoning yet).
            AssociationState::Unknown if self.sender_gap.is_none() => {
                if in_gate {
                    AssociationState::Associated
                } else {
                    AssociationState::NotAssociated
                }
            }
            // Not associated: a detection where the sender is dead-reckoned to be is the sender.
            _ if in_gate && self.sender_gap.is_some() && matches_dead_reckoning => AssociationState::Associated,
            // No anchor yet (never associated): a continuous object inside the gate is taken
            // as the sender only if it never jumped since the last decision.
            _ if in_gate && self.sender_gap.is_none() && !self.jumped => AssociationState::Associated,
            _ => AssociationState::NotAssociated,
        };
        if self.state == AssociationState::Associated {
            self.sender_gap = Some(d);
            self.since_anchor = 0.0;
        }
        // Rule 4: an intruder nearer than the sender is what the ego must follow. The detection
        // still anchors the sender's gap when it is the sender (above), so that the PID can take
        // over again once the intruder has gone or is the detected object.
        if self.intruder_nearer(input.intruder, Some(d), predicted, v_s) {
            self.state = AssociationState::NotAssociated;
        }
        self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.05;

    fn input(d: Option<f64>, v_o: f64, v_s: f64) -> AssociationInput<'static> {
        AssociationInput {
            distance: d,
            own_speed: v_o,
            sender_speed: Some(v_s),
            sender: None,
            message_age: 0.0,
            own_fix: None,
            dt: DT,
            intruder: None,
        }
    }

    #[test]
    fn steady_following_with_closing_stays_associated() {
        let mut a = Association::new(AssociationParams::default()).unwrap();
        let mut d = 30.0;
        for _ in 0..200 {
            assert_eq!(a.step(&input(Some(d), 20.0, 18.0)), AssociationState::Associated);
            d += (18.0 - 20.0) * DT;
        }
    }

    #[test]
    fn a_cut_in_jump_is_a_new_object_and_its_leaving_brings_the_sender_back() {
        let mut a = Association::new(AssociationParams::default()).unwrap();
        for _ in 0..10 {
            a.step(&input(Some(25.0), 20.0, 20.0));
        }
        // A 4.5 m car cuts in: 25 -> 12 m.
        assert_eq!(a.step(&input(Some(12.0), 20.0, 20.0)), AssociationState::NotAssociated);
        assert!(a.jumped());
        // It stays (continuous): still not the sender.
        for _ in 0..100 {
            assert_eq!(a.step(&input(Some(12.0), 20.0, 20.0)), AssociationState::NotAssociated);
        }
        // It leaves: the sender is where dead reckoning put it.
        assert_eq!(a.step(&input(Some(25.1), 20.0, 20.0)), AssociationState::Associated);
        // A cut-out that reveals a car further ahead: a jump up, not the sender.
        assert_eq!(a.step(&input(Some(45.0), 20.0, 20.0)), AssociationState::NotAssociated);
    }

    /// `input` with an intruding neighbour at `x` m.
    fn with_intruder(d: Option<f64>, x: Option<f64>) -> AssociationInput<'static> {
        AssociationInput { intruder: x, ..input(d, 25.0, 20.0) }
    }

    #[test]
    fn an_intruder_nearer_than_the_sender_breaks_the_association() {
        let mut a = Association::new(AssociationParams::default()).unwrap();
        // The lead closes at 5 m/s from 40 m.
        let mut d = 40.0;
        let next = |a: &mut Association, d: &mut f64, x: Option<f64>| {
            *d += (20.0 - 25.0) * DT;
            a.step(&with_intruder(Some(*d), x))
        };
        for _ in 0..10 {
            assert_eq!(next(&mut a, &mut d, None), AssociationState::Associated);
        }
        // A car entering the lane 20 m ahead, the lead (continuous, no jump) at 39 m: not the
        // sender that the ego must follow, at once.
        assert_eq!(next(&mut a, &mut d, Some(20.0)), AssociationState::NotAssociated);
        assert!(!a.jumped());
        for _ in 0..40 {
            assert_eq!(next(&mut a, &mut d, Some(20.0)), AssociationState::NotAssociated);
        }
        // It turns away (no longer intruding): the detection is the sender, associated again.
        assert_eq!(next(&mut a, &mut d, None), AssociationState::Associated);
        // One intruding beyond the lead, or the lead itself reported by the tracker at the
        // detector's distance (give or take the detector's noise): nothing changes.
        for offset in [10.0, -0.05, -1.0] {
            let x = d - 5.0 * DT + offset;
            assert_eq!(next(&mut a, &mut d, Some(x)), AssociationState::Associated, "intruder at {x} m, lead at {d} m");
        }
        // The same car 4.5 m nearer (its length) is between them.
        let x = d - 5.0 * DT - 4.5;
        assert_eq!(next(&mut a, &mut d, Some(x)), AssociationState::NotAssociated);
    }

    #[test]
    fn without_a_detection_an_intruder_is_compared_with_the_dead_reckoned_sender() {
        let mut a = Association::new(AssociationParams::default()).unwrap();
        a.step(&with_intruder(Some(40.0), None));
        // The lead not detected on this scan (dead-reckoned at 39.75 m): an intruder beyond it
        // keeps the decision, one nearer breaks it.
        assert_eq!(a.step(&with_intruder(None, Some(45.0))), AssociationState::Associated);
        assert_eq!(a.step(&with_intruder(None, Some(30.0))), AssociationState::NotAssociated);
        // Nothing known of the sender's gap (no detection yet): the V2V-predicted gap (55.5 m,
        // gate 6 sqrt(2) + 2 = 10.5 m) stands in; without positions the rule cannot tell.
        let p = AssociationParams { gnss_sigma_m: 1.0, ..Default::default() };
        let sender = SenderState { station_id: 7, x: 60.0, y: 0.0, heading: 0.0, accel: 0.0, length: 4.5 };
        let own = OwnFix { x: 0.0, y: 0.0, heading: 0.0 };
        let located = |x| AssociationInput { sender: Some(&sender), own_fix: Some(own), ..with_intruder(None, Some(x)) };
        for (x, state) in [(56.0, AssociationState::Unknown), (46.0, AssociationState::Unknown), (44.0, AssociationState::NotAssociated)] {
            let mut b = Association::new(p).unwrap();
            assert_eq!(b.step(&with_intruder(None, Some(x))), AssociationState::Unknown, "intruder at {x} m, no position");
            assert_eq!(b.step(&located(x)), state, "intruder at {x} m, the sender predicted at 55.5 m");
        }
        // Without V2V, or with association off, there is nothing to break.
        let none = AssociationInput { sender_speed: None, ..with_intruder(Some(40.0), Some(10.0)) };
        assert_eq!(a.step(&none), AssociationState::Unknown);
        let mut off = Association::new(AssociationParams { enabled: false, ..Default::default() }).unwrap();
        assert_eq!(off.step(&with_intruder(Some(40.0), Some(10.0))), AssociationState::Associated);
    }

    #[test]
    fn missing_detections_carry_the_expected_change() {
        let mut a = Association::new(AssociationParams::default()).unwrap();
        a.step(&input(Some(30.0), 20.0, 10.0));
        for _ in 0..20 {
            a.step(&input(None, 20.0, 10.0));
        }
        // 21 ticks at -10 m/s: 30 - 10.5.
        assert_eq!(a.step(&input(Some(19.5), 20.0, 10.0)), AssociationState::Associated);
        assert!(!a.jumped());
    }

    #[test]
    fn the_position_gate_rejects_an_object_far_from_the_sender() {
        let p = AssociationParams { gnss_sigma_m: 1.0, ..Default::default() };
        let mut a = Association::new(p).unwrap();
        let sender = SenderState { station_id: 7, x: 60.0, y: 0.0, heading: 0.0, accel: 0.0, length: 4.5 };
        let own = OwnFix { x: 0.0, y: 0.0, heading: 0.0 };
        assert!((predicted_gap(&sender, 0.0, 0.0, &own) - 55.5).abs() < 1e-12);
        let inp = |d| AssociationInput { sender: Some(&sender), own_fix: Some(own), ..input(Some(d), 20.0, 20.0) };
        // 6 sqrt(2) + 2 = 10.5 m gate.
        assert_eq!(a.step(&inp(20.0)), AssociationState::NotAssociated);
        let mut b = Association::new(p).unwrap();
        assert_eq!(b.step(&inp(50.0)), AssociationState::Associated);
    }

    #[test]
    fn without_v2v_nothing_is_associated_and_disabled_always_is() {
        let mut a = Association::new(AssociationParams::default()).unwrap();
        let none = AssociationInput { sender_speed: None, ..input(Some(20.0), 10.0, 0.0) };
        assert_eq!(a.step(&none), AssociationState::Unknown);
        let mut off = Association::new(AssociationParams { enabled: false, ..Default::default() }).unwrap();
        off.step(&input(Some(25.0), 20.0, 20.0));
        assert_eq!(off.step(&input(Some(5.0), 20.0, 20.0)), AssociationState::Associated);
    }

    #[test]
    fn the_default_gate_is_the_documented_one() {
        // docs/v2v-and-metrics.md 1.11: 25.5 m plus 0.1 v_s (3.6 m at 130 km/h).
        let p = AssociationParams::default();
        assert!((p.gate_m(0.0) - 25.5).abs() < 0.05, "{}", p.gate_m(0.0));
        // The union bound of the docs: 72 000 ticks * 2 Phi(-6) = 1.4e-4 (2 Phi(-6) = 1.973e-9).
        assert!((72_000.0 * 1.973e-9 - 1.4e-4f64).abs() < 0.05e-4);
        assert!((p.gate_m(130.0 / 3.6) - p.gate_m(0.0) - 3.6).abs() < 0.05);
    }

    #[test]
    fn bad_parameters_name_the_field() {
        let e = Association::new(AssociationParams { jump_m: 0.0, ..Default::default() }).unwrap_err();
        assert_eq!(e.field, "association.jump_m");
    }

    proptest::proptest! {
        #[test]
        fn any_input_gives_a_decision(seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY), 1..50)) {
            let mut a = Association::new(AssociationParams::default()).unwrap();
            let s = SenderState { station_id: 1, x: f64::NAN, y: 1e308, heading: f64::INFINITY, accel: 0.0, length: 4.0 };
            for (d, v, vs, dt) in seq {
                let own = OwnFix { x: v, y: 0.0, heading: dt };
                a.step(&AssociationInput { distance: d, own_speed: v, sender_speed: vs, sender: Some(&s), message_age: dt, own_fix: Some(own), dt, intruder: d.map(|x| x - 3.0) });
            }
        }
    }
}
