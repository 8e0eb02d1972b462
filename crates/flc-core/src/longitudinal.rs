//! One interface for every longitudinal law: [`LongitudinalController`].
//!
//! The paper's FLC ([`crate::flc`], Eqs. (2)-(5)), the robust FLC ([`crate::flc_robust`]), the V2V
//! PID ([`crate::pid`], Sec. III-A.3), the parallel pipeline ([`crate::supervisor`], Fig. 1) and
//! the baselines ([`crate::baselines`]) all step on the same [`Frame`] (one delivered LiDAR scan)
//! and return the same [`ControlOutput`], so that a simulator can hold any of them as
//! `Box<dyn LongitudinalController + Send>`.
//!
//! Each law reads only what it uses: the FLC family ignores [`Frame::dt`] and [`Frame::v2v`]
//! ([`LongitudinalController::uses_dt`] is `false`: time independence), the PID and the supervisor
//! read the V2V message, the baselines read `dt` for their range-rate estimator. Stepping through
//! the trait gives bit for bit the command of the law's own `step` function.
//!
//! ```
//! use flc_core::{FallbackController, FlcParams, Frame, LongitudinalController};
//!
//! let mut law: Box<dyn LongitudinalController + Send> = Box::new(FallbackController::new(FlcParams::paper())?);
//! let out = law.step(&Frame { distance: Some(25.0), own_speed: 10.0, v2v: None, dt: 0.05, lead_speed: None, own_fix: None, travelled: None, intruder: None, path_clear: false });
//! // Eqs. (2)-(5): dist_s = 25 - 16 - 4 = 5, a = 5 (1 - cos(5 pi / 11)) = 4.2884...
//! assert!((out.command.accel - 4.288425808633574).abs() < 1e-12);
//! assert_eq!(out.terms.get("dist_s"), Some(5.0));
//! assert!(!law.uses_dt());
//! # Ok::<(), flc_core::ParamError>(())
//! ```

use crate::association::{AssociationState, OwnFix, SenderState};
use crate::command::LongitudinalCommand;

/// One V2V message as received by the follower.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct V2vMessage {
    /// The lead's speed as broadcast, m/s.
    pub lead_speed: f64,
    /// The sender's sequence number (wrapping). Duplicates and messages older than the newest
    /// accepted one are ignored.
    pub seq: u32,
    /// The rest of the sender's CAM / BSM (id, GNSS position, heading, acceleration, length);
    /// `None` for a message that carries a speed only (e.g. a relayed lead speed). The
    /// supervisor's association rule uses it when present ([`crate::association`]).
    pub sender: Option<SenderState>,
}

impl V2vMessage {
    /// A message with a speed and a sequence number only.
    pub const fn speed_only(lead_speed: f64, seq: u32) -> Self {
        Self { lead_speed, seq, sender: None }
    }
}

/// Which controller produced the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ActiveController {
    /// The fallback longitudinal controller.
    Flc = 0,
    /// The V2V-based PID gap controller.
    Pid = 1,
}

impl ActiveController {
    /// `"flc"` or `"pid"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            ActiveController::Flc => "flc",
            ActiveController::Pid => "pid",
        }
    }
}

/// Why the active controller is the one it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SwitchReason {
    /// V2V is fresh and the PID drives.
    V2vFresh = 0,
    /// No valid V2V message has been received yet.
    NoV2v = 1,
    /// The last valid V2V message is older than `max_age_ticks`.
    V2vStale = 2,
    /// V2V is fresh again but fewer than `return_after` consecutive fresh messages have arrived.
    Recovering = 3,
    /// The last message carried an unusable lead speed (NaN, infinite, implausible).
    InvalidV2v = 4,
    /// V2V is fresh but the object the detector reports is not its sender (a car cut in, or a
    /// cut-out revealed another one): the PID must not combine the two ([`crate::association`]).
    NotAssociated = 5,
}

impl SwitchReason {
    /// Stable lower-case name.
    pub const fn as_str(self) -> &'static str {
        match self {
            SwitchReason::V2vFresh => "v2v_fresh",
            SwitchReason::NoV2v => "no_v2v",
            SwitchReason::V2vStale => "v2v_stale",
            SwitchReason::Recovering => "recovering",
            SwitchReason::InvalidV2v => "invalid_v2v",
            SwitchReason::NotAssociated => "not_associated",
        }
    }
}

/// What every longitudinal law sees on one control frame (one delivered LiDAR scan).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Detector distance (bumper-to-bumper), m; `None` = no lead detected this frame.
    pub distance: Option<f64>,
    /// Own speed, m/s.
    pub own_speed: f64,
    /// V2V message received since the previous frame, if any (laws that do not use V2V ignore it).
    pub v2v: Option<V2vMessage>,
    /// Time since the previous frame, s. Read ONLY by laws whose `uses_dt()` is true (PID, the
    /// supervisor, the baselines' range-rate estimator); FLC-family laws never read it.
    pub dt: f64,
    /// The lead's speed measured directly, m/s: only with *ideal perception*, a validation mode
    /// that checks a baseline against its source model (never for the paper's or the envelope's
    /// results). `None` (LiDAR): the laws that need the lead's speed estimate it from the
    /// distance. The FLC family and the PID never read it.
    pub lead_speed: Option<f64>,
    /// The own GNSS fix (read only by the supervisor's association rule; `None`: none).
    pub own_fix: Option<OwnFix>,
    /// The wheel odometry's travelled distance since any fixed origin, m (read only by the
    /// odometry variant of the robust FLC, `flc_robust_odo`; `None`: no odometry). A clock-free
    /// signal: only its change between frames is used.
    pub travelled: Option<f64>,
    /// Distance to the nearest neighbour entering the ego's path ([`crate::NeighbourTracker`]'s
    /// intruder), bumper-to-bumper like `distance`, m (`None`: none, or no tracker). Read only by
    /// the supervisor: its association rule (rule 4, an intruder nearer than the V2V sender) and
    /// its FLC, which follows the nearer of `distance` and `intruder`. The robust FLCs are given
    /// the intruder as their `distance` by the caller.
    pub intruder: Option<f64>,
    /// The path is clear: the last lead was seen leaving it and nothing is in it since
    /// ([`crate::LeadDeparture`]), so no distance is a clear road, not a lost lead. Read only by a
    /// no-target wrapper (the simulator's `NoTargetCruise`, which then drives at the set speed);
    /// the laws themselves never read it. `false` when the caller does not watch.
    pub path_clear: bool,
}

impl Frame {
    /// A frame without V2V.
    pub const fn new(distance: Option<f64>, own_speed: f64, dt: f64) -> Self {
        Self { distance, own_speed, v2v: None, dt, lead_speed: None, own_fix: None, travelled: None, intruder: None, path_clear: false }
    }
}

/// One step's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlOutput {
    /// The command to apply (bit for bit the law's own `step` result).
    pub command: LongitudinalCommand,
    /// The law's terms for plots (as pid-rs's ControlOutput).
    pub terms: Terms,
    /// Which law drove this frame (fixed for single laws: ActiveController::Pid for the PID,
    /// ActiveController::Flc for every other single law; the supervisor reports its state).
    pub active: ActiveController,
    /// Why (single laws: the value the supervisor reports before any V2V, i.e.
    /// SwitchReason::NoV2v; supervisor: its reason).
    pub reason: SwitchReason,
    /// Supervisor only: the active law changed this frame (false otherwise).
    pub switched: bool,
    /// Supervisor only: V2V age in ticks (u32::MAX otherwise).
    pub v2v_age_ticks: u32,
    /// Supervisor only: is the detected object the V2V sender (`Unknown` otherwise).
    pub association: AssociationState,
}

impl ControlOutput {
    /// The output of a single (non-switching) law: `reason = NoV2v`, `switched = false`,
    /// `v2v_age_ticks = u32::MAX`.
    pub const fn single(command: LongitudinalCommand, terms: Terms, active: ActiveController) -> Self {
        Self {
            command,
            terms,
            active,
            reason: SwitchReason::NoV2v,
            switched: false,
            v2v_age_ticks: u32::MAX,
            association: AssociationState::Unknown,
        }
    }
}

/// Most terms a law may report ([`Terms`] is a fixed-size, allocation-free list).
pub const MAX_TERMS: usize = 16;

/// A law's per-term output: a fixed, allocation-free list of named numbers (mode/band enums as their
/// discriminant number, flags as 0 / 1). Each law declares its own term names as a
/// `&'static [&'static str]`, so adding a law touches no shared enum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terms {
    names: &'static [&'static str],
    values: [f64; MAX_TERMS],
}

impl Terms {
    /// No terms.
    pub const NONE: Terms = Terms { names: &[], values: [0.0; MAX_TERMS] };

    /// The terms `names[i] = values[i]`. The list is as long as the shorter of the two (and at
    /// most [`MAX_TERMS`]); extra names or values are dropped.
    pub fn new(names: &'static [&'static str], values: &[f64]) -> Self {
        let n = names.len().min(values.len()).min(MAX_TERMS);
        let mut out = [0.0; MAX_TERMS];
        for (o, v) in out.iter_mut().zip(values.iter().take(n)) {
            *o = *v;
        }
        Self { names: names.get(..n).unwrap_or(&[]), values: out }
    }

    /// The term names, in the law's order.
    pub fn names(&self) -> &'static [&'static str] {
        self.names
    }

    /// The values, in the order of [`Terms::names`].
    pub fn values(&self) -> &[f64] {
        self.values.get(..self.names.len()).unwrap_or(&[])
    }

    /// The value of the term `name`, `None` if the law has no such term.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.iter().find(|(n, _)| *n == name).map(|(_, v)| v)
    }

    /// `(name, value)` pairs in the law's order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, f64)> + '_ {
        self.names.iter().copied().zip(self.values().iter().copied())
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// `true` without terms.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

impl Default for Terms {
    fn default() -> Self {
        Self::NONE
    }
}

#[cfg(feature = "serde")]
impl serde::Serialize for Terms {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(self.len()))?;
        for (name, value) in self.iter() {
            map.serialize_entry(name, &value)?;
        }
        map.end()
    }
}

/// `true` / `false` as a term value (1 / 0).
pub(crate) const fn flag(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

/// Every longitudinal law: paper FLC, robust FLC, PID, the Supervisor pipeline, IDM, ACC, RSS,
/// CARLA behaviour (object safe: the simulator holds `Box<dyn LongitudinalController + Send>`).
pub trait LongitudinalController {
    /// One control frame. The command is bit for bit the one of the law's own `step`.
    fn step(&mut self, frame: &Frame) -> ControlOutput;
    /// Back to the initial state (as the law's own `reset`).
    fn reset(&mut self);
    /// The gap (m) this law aims for at own speed `v` behind a lead at the same speed: the law's
    /// own formula.
    fn desired_gap(&self, v: f64) -> f64;
    /// The spacing policy a string of these vehicles is formed with (default = desired_gap; the
    /// Supervisor: its PID's, the law it drives with while V2V is fresh).
    fn formation_gap(&self, v: f64) -> f64 {
        self.desired_gap(v)
    }
    /// Whether `step` reads `Frame::dt` (false for the FLC family: proves time independence).
    fn uses_dt(&self) -> bool;
}

#[cfg(test)]
mod tests {
    use super::*;

    const NAMES: &[&str] = &["a", "b", "c"];

    #[test]
    fn terms_basics() {
        let t = Terms::new(NAMES, &[1.0, 2.0, 3.0]);
        assert_eq!(t.names(), NAMES);
        assert_eq!(t.values(), &[1.0, 2.0, 3.0]);
        assert_eq!(t.get("b"), Some(2.0));
        assert_eq!(t.get("z"), None);
        assert_eq!(t.iter().collect::<std::vec::Vec<_>>(), std::vec![("a", 1.0), ("b", 2.0), ("c", 3.0)]);
        // Shorter of names and values.
        let short = Terms::new(NAMES, &[1.0]);
        assert_eq!((short.names(), short.values()), (&["a"][..], &[1.0][..]));
        assert!(Terms::NONE.is_empty() && Terms::NONE.values().is_empty());
        assert_eq!(Terms::default(), Terms::NONE);
        // More than MAX_TERMS: truncated, no panic.
        const MANY: &[&str] = &["0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "10", "11", "12", "13", "14", "15", "16", "17"];
        assert_eq!(Terms::new(MANY, &[0.5; 18]).len(), MAX_TERMS);
    }

    #[test]
    fn single_output_defaults() {
        let cmd = LongitudinalCommand { speed: 1.0, accel: 0.0, status: crate::Status::Ok };
        let o = ControlOutput::single(cmd, Terms::NONE, ActiveController::Pid);
        assert_eq!((o.reason, o.switched, o.v2v_age_ticks), (SwitchReason::NoV2v, false, u32::MAX));
    }

    use crate::baselines::{
        AccController, AccParams, CarlaBehaviorController, CarlaBehaviorParams, IdmController, IdmParams, RssController, RssParams,
    };
    use crate::{
        FallbackController, FlcParams, PidController, PidParams, RobustFallbackController, RobustFlcParams, Supervisor, SupervisorParams,
    };
    use proptest::prelude::*;

    fn same(a: LongitudinalCommand, b: LongitudinalCommand) -> bool {
        a.speed.to_bits() == b.speed.to_bits() && a.accel.to_bits() == b.accel.to_bits() && a.status == b.status
    }

    /// Plausible and implausible inputs alike (NaN, negative, huge).
    fn input() -> impl Strategy<Value = (Option<f64>, f64, f64, Option<(f64, u32)>)> {
        let d = prop_oneof![8 => (0.0..120.0f64).prop_map(Some), 1 => Just(None), 1 => proptest::num::f64::ANY.prop_map(Some)];
        let v = prop_oneof![9 => 0.0..40.0f64, 1 => proptest::num::f64::ANY];
        let dt = prop_oneof![9 => 0.01..0.2f64, 1 => proptest::num::f64::ANY];
        let m = proptest::option::of((prop_oneof![9 => 0.0..40.0f64, 1 => proptest::num::f64::ANY], 0u32..40));
        (d, v, dt, m)
    }

    fn frame((distance, own_speed, dt, m): (Option<f64>, f64, f64, Option<(f64, u32)>)) -> Frame {
        Frame {
            distance,
            own_speed,
            dt,
            v2v: m.map(|(lead_speed, seq)| crate::V2vMessage::speed_only(lead_speed, seq)),
            lead_speed: None,
            own_fix: None,
            travelled: None,
            intruder: None,
            path_clear: false,
        }
    }

    proptest! {
        #[test]
        fn trait_step_is_the_inherent_step(seq in proptest::collection::vec(input(), 1..60)) {
            let mut flc = (FallbackController::new(FlcParams::paper()).unwrap(), FallbackController::new(FlcParams::paper()).unwrap());
            let mut rob = (RobustFallbackController::new(RobustFlcParams::default()).unwrap(), RobustFallbackController::new(RobustFlcParams::default()).unwrap());
            let mut pid = (PidController::new(PidParams::paper()).unwrap(), PidController::new(PidParams::paper()).unwrap());
            let mut sup = (Supervisor::new(SupervisorParams::default()).unwrap(), Supervisor::new(SupervisorParams::default()).unwrap());
            let mut idm = (IdmController::new(IdmParams::default()).unwrap(), IdmController::new(IdmParams::default()).unwrap());
            let mut acc = (AccController::new(AccParams::default()).unwrap(), AccController::new(AccParams::default()).unwrap());
            let mut rss = (RssController::new(RssParams::default()).unwrap(), RssController::new(RssParams::default()).unwrap());
            let mut carla = (CarlaBehaviorController::new(CarlaBehaviorParams::default()).unwrap(), CarlaBehaviorController::new(CarlaBehaviorParams::default()).unwrap());
            // The simulator's PID hold, outside the controller.
            let mut last_lead_speed = None;
            for (k, i) in seq.into_iter().enumerate() {
                let f = frame(i);
                if k == 30 {
                    // reset through the trait == inherent reset
                    LongitudinalController::reset(&mut flc.0); flc.1.reset();
                    LongitudinalController::reset(&mut rob.0); rob.1.reset();
                    LongitudinalController::reset(&mut pid.0); pid.1.reset(); last_lead_speed = None;
                    LongitudinalController::reset(&mut sup.0); sup.1.reset();
                    LongitudinalController::reset(&mut idm.0); idm.1.reset();
                    LongitudinalController::reset(&mut acc.0); acc.1.reset();
                    LongitudinalController::reset(&mut rss.0); rss.1.reset();
                    LongitudinalController::reset(&mut carla.0); carla.1.reset();
                }
                let o = LongitudinalController::step(&mut flc.0, &f);
                prop_assert!(same(o.command, flc.1.step(f.distance, f.own_speed)));
                prop_assert_eq!(o.terms, flc.1.terms().to_terms());
                prop_assert_eq!((o.active, o.reason, o.switched, o.v2v_age_ticks), (ActiveController::Flc, SwitchReason::NoV2v, false, u32::MAX));
                let o = LongitudinalController::step(&mut rob.0, &f);
                prop_assert!(same(o.command, rob.1.step(f.distance, f.own_speed)));
                if let Some(m) = f.v2v { last_lead_speed = Some(m.lead_speed); }
                let o = LongitudinalController::step(&mut pid.0, &f);
                prop_assert!(same(o.command, pid.1.step(last_lead_speed.unwrap_or(f.own_speed), f.own_speed, f.distance, f.dt)));
                prop_assert_eq!(o.active, ActiveController::Pid);
                let o = LongitudinalController::step(&mut sup.0, &f);
                let r = sup.1.step(f.v2v, f.distance, f.own_speed, f.dt);
                prop_assert!(same(o.command, r.command));
                prop_assert_eq!((o.active, o.reason, o.switched, o.v2v_age_ticks), (r.active, r.reason, r.switched, r.v2v_age_ticks));
                let v = f.own_speed;
                let want = match r.active { ActiveController::Pid => sup.1.params().pid.desired_distance(v), ActiveController::Flc => sup.1.params().flc.desired_distance(v) + sup.1.params().flc.f_shift(v) };
                prop_assert_eq!(sup.0.desired_gap(v).to_bits(), want.to_bits());
                let o = LongitudinalController::step(&mut idm.0, &f);
                prop_assert!(same(o.command, idm.1.step(f.distance, f.own_speed, f.dt)));
                prop_assert_eq!(o.terms, idm.1.terms().to_terms());
                let o = LongitudinalController::step(&mut acc.0, &f);
                prop_assert!(same(o.command, acc.1.step(f.distance, f.own_speed, f.dt)));
                let o = LongitudinalController::step(&mut rss.0, &f);
                prop_assert!(same(o.command, rss.1.step(f.distance, f.own_speed, f.dt)));
                let o = LongitudinalController::step(&mut carla.0, &f);
                prop_assert!(same(o.command, carla.1.step(f.distance, f.own_speed, f.dt)));
            }
        }

        /// Time independence proven: the FLC, the robust FLC v1 and v2 (its comfort layer
        /// included) and v2's odometry variant give the same outputs whatever `dt` and V2V the
        /// frames carry.
        #[test]
        fn flc_family_ignores_dt_and_v2v(seq in proptest::collection::vec((input(), proptest::num::f64::ANY, proptest::option::of((proptest::num::f64::ANY, any::<u32>()))), 1..60)) {
            let mut flc = (FallbackController::new(FlcParams::paper()).unwrap(), FallbackController::new(FlcParams::paper()).unwrap());
            let mut rob = (RobustFallbackController::new(RobustFlcParams::default()).unwrap(), RobustFallbackController::new(RobustFlcParams::default()).unwrap());
            let v2 = || crate::RobustFallbackController2::new(crate::RobustFlc2Params::default()).unwrap();
            let mut rob2 = (v2(), v2());
            let odo = || crate::OdometryFallbackController::new(crate::RobustFlc2Params::default(), crate::OdometryFlcParams::default()).unwrap();
            let mut odo = (odo(), odo());
            prop_assert!(!flc.0.uses_dt() && !rob.0.uses_dt() && !rob2.0.uses_dt() && !odo.0.uses_dt());
            let mut odometer = 0.0;
            for (i, other_dt, other_v2v) in seq {
                let f = frame(i);
                let g = Frame { dt: other_dt, v2v: other_v2v.map(|(lead_speed, seq)| crate::V2vMessage::speed_only(lead_speed, seq)), ..f };
                let (a, b) = (LongitudinalController::step(&mut flc.0, &f), LongitudinalController::step(&mut flc.1, &g));
                prop_assert!(same(a.command, b.command));
                prop_assert_eq!(a.terms.values().iter().map(|v| v.to_bits()).collect::<std::vec::Vec<_>>(), b.terms.values().iter().map(|v| v.to_bits()).collect::<std::vec::Vec<_>>());
                let (a, b) = (LongitudinalController::step(&mut rob.0, &f), LongitudinalController::step(&mut rob.1, &g));
                prop_assert!(same(a.command, b.command));
                prop_assert_eq!(a.terms.values().iter().map(|v| v.to_bits()).collect::<std::vec::Vec<_>>(), b.terms.values().iter().map(|v| v.to_bits()).collect::<std::vec::Vec<_>>());
                // v2 and its odometry variant (the variant reads the odometer, the same in both).
                odometer += f.own_speed.abs().min(50.0) * 0.05;
                let (f, g) = (Frame { travelled: Some(odometer), ..f }, Frame { travelled: Some(odometer), ..g });
                for (a, b) in [
                    (LongitudinalController::step(&mut rob2.0, &f), LongitudinalController::step(&mut rob2.1, &g)),
                    (LongitudinalController::step(&mut odo.0, &f), LongitudinalController::step(&mut odo.1, &g)),
                ] {
                    prop_assert!(same(a.command, b.command));
                    prop_assert_eq!(a.terms.values().iter().map(|v| v.to_bits()).collect::<std::vec::Vec<_>>(), b.terms.values().iter().map(|v| v.to_bits()).collect::<std::vec::Vec<_>>());
                }
            }
        }

        /// The gaps the simulator computed itself, bit for bit (its expressions, std floats).
        #[test]
        fn desired_gaps_are_the_simulators(v in prop_oneof![-5.0..80.0f64, proptest::num::f64::ANY]) {
            let idm = IdmController::new(IdmParams::default()).unwrap();
            let acc = AccController::new(AccParams::default()).unwrap();
            let rss = RssController::new(RssParams::default()).unwrap();
            let carla = CarlaBehaviorController::new(CarlaBehaviorParams::default()).unwrap();
            let flc = FallbackController::new(FlcParams::paper()).unwrap();
            let rob = RobustFallbackController::new(RobustFlcParams::default()).unwrap();
            let pid = PidController::new(PidParams::paper()).unwrap();
            let w = v.max(0.0);
            let p = idm.params();
            let s_star = p.desired_gap(w, w);
            let free = 1.0 - (w / p.desired_speed).powf(p.delta);
            let want = if free > 1e-6 { s_star / free.sqrt() } else { s_star };
            prop_assert_eq!(idm.desired_gap(v).to_bits(), want.to_bits());
            prop_assert_eq!(acc.desired_gap(v).to_bits(), (acc.params().min_gap + acc.params().headway_time * w + AccParams::dynamic_margin(w)).to_bits());
            prop_assert_eq!(rss.desired_gap(v).to_bits(), (rss.params().safe_distance(w, w) + rss.params().margin).to_bits());
            prop_assert_eq!(carla.desired_gap(v).to_bits(), (2.0 * carla.params().safety_time * carla.params().min_closing_speed).to_bits());
            prop_assert_eq!(flc.desired_gap(v).to_bits(), (flc.params().desired_distance(v) + flc.params().f_shift(v)).to_bits());
            prop_assert_eq!(rob.desired_gap(v).to_bits(), rob.params().desired_gap(v).to_bits());
            prop_assert_eq!(pid.desired_gap(v).to_bits(), pid.params().desired_distance(v).to_bits());
            prop_assert_eq!(pid.formation_gap(v).to_bits(), pid.desired_gap(v).to_bits());
        }

        /// `libm::sqrt` is IEEE exact (the same as std's); `libm::pow` is compared for information
        /// in `libm_pow_against_std` (the IDM gap uses std's `powf` with the `std` feature).
        #[test]
        fn libm_sqrt_is_std_sqrt(x in 0.0..1.0e6f64) {
            prop_assert_eq!(libm::sqrt(x).to_bits(), x.sqrt().to_bits());
        }
    }

    /// How often `libm::pow` differs from std's `powf` over the IDM's range (printed; a difference
    /// is why the IDM gap calls std's `powf` when `std` is available).
    #[test]
    fn libm_pow_against_std() {
        let mut differ = 0u32;
        let n = 200_000u32;
        for i in 0..n {
            let x = f64::from(i) / f64::from(n) * 2.0;
            for d in [1.0, 2.0, 3.5, 4.0, 6.0] {
                if libm::pow(x, d).to_bits() != x.powf(d).to_bits() {
                    differ += 1;
                }
            }
        }
        std::eprintln!("libm::pow != f64::powf in {differ} of {} cases", 5 * n);
        assert_eq!(crate::baselines::powf(0.5, 4.0).to_bits(), 0.5f64.powf(4.0).to_bits());
    }
}
