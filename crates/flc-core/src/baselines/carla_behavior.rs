//! A follower after CARLA's `BehaviorAgent`: time-to-collision bands plus an emergency stop.
//!
//! CARLA 0.9.x, `PythonAPI/carla/agents/navigation/behavior_agent.py`: `run_step` (emergency stop
//! when `distance < behavior.braking_distance`, else `car_following_manager`) and
//! `car_following_manager`; parameter sets in `behavior_types.py` (`Normal`). Speeds are km/h in
//! CARLA and m/s here:
//!
//! ```text
//! gap < braking_distance                   -> emergency stop            (speed command 0)
//! delta_v = max(min_closing_speed, v - v_lead)                       (CARLA: max(1, dv / 3.6))
//! ttc     = gap / delta_v
//! cap     = min(cruise_speed, speed_limit - speed_lim_dist)
//! 0 < ttc < safety_time                   -> target = min(max(0, v_lead - speed_decrease), cap)
//! safety_time <= ttc < 2 safety_time      -> target = min(max(min_speed, v_lead), cap)
//! otherwise (and without a lead)          -> target = cap               ("normal behaviour")
//! ```
//!
//! Note CARLA's TTC is not `gap / (v - v_lead)`: the closing speed is floored at 1 m/s, so an
//! opening or steady lead still has a finite TTC of `gap / 1 s`, and a lead closer than
//! `2 safety_time * 1 m/s = 6 m` is followed at its speed even when it pulls away.
//!
//! The target speed is the speed command (CARLA hands it to its local planner's PID); `accel` is
//! `(speed - v) / command_gain`. `v_lead` is the estimate of [`super::estimator`]; CARLA takes it
//! from the simulator. CARLA also ignores vehicles beyond `max(min_proximity_threshold,
//! speed_limit / 3)` (km/h read as m) ahead; that look-ahead limit is off by default here (the
//! detector's range is the limit for every controller) and enabled with [`CarlaBehaviorParams::limit_range`].
//!
//! Defaults: CARLA's `Normal` behaviour (`speed_lim_dist` 3 km/h, `speed_decrease` 10 km/h,
//! `safety_time` 3 s, `min_proximity_threshold` 10 m, `braking_distance` 5 m) and the agent's
//! `_min_speed` 5 km/h, except the speeds: `cruise_speed` (CARLA `behavior.max_speed`, 50 km/h in
//! `Normal`) and `speed_limit` (read from the CARLA map) are both 130 km/h, so that the cap is
//! 127 km/h and does not limit the follower below the lead in the speed sweeps.

use super::NoLeadPolicy;
use super::estimator::EstimatorParams;
use super::follower::{CarFollowingLaw, Demand, EstimatingFollower, LeadEstimate, follower_params};
use crate::longitudinal::{Terms, flag};
use crate::params::{ParamError, check_positive, check_range};

/// km/h to m/s.
const fn kmh(v: f64) -> f64 {
    v / 3.6
}

/// Parameters of the CARLA BehaviorAgent follower (SI units; CARLA's km/h values converted).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarlaBehaviorParams {
    /// The agent's own speed cap (CARLA `behavior.max_speed`), m/s. Default 130 km/h (`Normal`: 50 km/h).
    pub cruise_speed: f64,
    /// Road speed limit (CARLA: from the map), m/s. Default 130 km/h.
    pub speed_limit: f64,
    /// Margin below the speed limit (`speed_lim_dist`), m/s. `Normal`: 3 km/h.
    pub speed_lim_dist: f64,
    /// Speed reduction below the lead in the first TTC band (`speed_decrease`), m/s. `Normal`: 10 km/h.
    pub speed_decrease: f64,
    /// TTC band edge (`safety_time`), s. `Normal`: 3.
    pub safety_time: f64,
    /// Least target speed in the second band (the agent's `_min_speed`), m/s. CARLA: 5 km/h.
    pub min_speed: f64,
    /// Emergency stop below this gap (`braking_distance`), m. `Normal`: 5.
    pub braking_distance: f64,
    /// Floor of the closing speed in the TTC (CARLA's `max(1, ...)`), m/s. CARLA: 1.
    pub min_closing_speed: f64,
    /// Apply CARLA's look-ahead limit `max(min_proximity_threshold, speed_limit[km/h] / 3)` m.
    /// Default `false` (the detector's range limits every controller alike).
    pub limit_range: bool,
    /// `min_proximity_threshold` of the look-ahead limit, m. `Normal`: 10.
    pub min_proximity_threshold: f64,
    /// What to do without a lead. Default [`NoLeadPolicy::Cruise`] (normal behaviour).
    pub no_lead: NoLeadPolicy,
    /// The range-rate filter.
    pub estimator: EstimatorParams,
    /// `accel = (v_cmd - v) / command_gain` (reporting only), s. Default 1.
    pub command_gain: f64,
    /// Highest plausible own speed and highest speed command, m/s. Default 70.
    pub max_speed: f64,
    /// Highest plausible distance, m. Default 500.
    pub max_distance: f64,
    /// Safe command on invalid input: `v_cmd = v - fault_brake_step`, m/s. Default 3.
    pub fault_brake_step: f64,
}

impl Default for CarlaBehaviorParams {
    fn default() -> Self {
        Self::normal()
    }
}

impl CarlaBehaviorParams {
    /// CARLA's `Normal` behaviour with the 130 km/h speeds (identical to `Default`).
    pub const fn normal() -> Self {
        Self {
            cruise_speed: kmh(130.0),
            speed_limit: kmh(130.0),
            speed_lim_dist: kmh(3.0),
            speed_decrease: kmh(10.0),
            safety_time: 3.0,
            min_speed: kmh(5.0),
            braking_distance: 5.0,
            min_closing_speed: 1.0,
            limit_range: false,
            min_proximity_threshold: 10.0,
            no_lead: NoLeadPolicy::Cruise,
            estimator: EstimatorParams { alpha: 0.6, beta: 0.25, max_range_rate: 100.0 },
            command_gain: 1.0,
            max_speed: 70.0,
            max_distance: 500.0,
            fault_brake_step: 3.0,
        }
    }

    /// Checks the law's own fields (the shared ones: [`super::FollowerSettings::validate`]).
    fn validate_law(&self) -> Result<(), ParamError> {
        check_positive("cruise_speed", self.cruise_speed, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_positive("speed_limit", self.speed_limit, 1000.0, "must be finite and in (0, 1000] m/s")?;
        check_range("speed_lim_dist", self.speed_lim_dist, 0.0, self.speed_limit, "must be finite and in [0, speed_limit] m/s")?;
        check_range("speed_decrease", self.speed_decrease, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        check_positive("safety_time", self.safety_time, 100.0, "must be finite and in (0, 100] s")?;
        check_range("min_speed", self.min_speed, 0.0, 100.0, "must be finite and in [0, 100] m/s")?;
        check_range("braking_distance", self.braking_distance, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_positive("min_closing_speed", self.min_closing_speed, 100.0, "must be finite and in (0, 100] m/s")?;
        check_range("min_proximity_threshold", self.min_proximity_threshold, 0.0, 1.0e6, "must be finite and in [0, 1e6] m")?;
        Ok(())
    }

    /// Normal-behaviour target `min(cruise_speed, speed_limit - speed_lim_dist)`, m/s.
    pub fn cap(&self) -> f64 {
        self.cruise_speed.min(self.speed_limit - self.speed_lim_dist)
    }

    /// CARLA's look-ahead `max(min_proximity_threshold, speed_limit[km/h] / 3)`, m.
    pub fn look_ahead(&self) -> f64 {
        self.min_proximity_threshold.max(self.speed_limit * 3.6 / 3.0)
    }

    /// CARLA's time to collision `gap / max(min_closing_speed, v - v_lead)`, s.
    pub fn ttc(&self, gap: f64, own_speed: f64, lead_speed: f64) -> f64 {
        gap / (own_speed - lead_speed).max(self.min_closing_speed)
    }

    /// The band and target speed of `car_following_manager` (and the emergency stop), m/s.
    pub fn target(&self, gap: f64, own_speed: f64, lead_speed: f64) -> (CarlaBand, f64) {
        if gap < self.braking_distance {
            return (CarlaBand::EmergencyStop, 0.0);
        }
        let ttc = self.ttc(gap, own_speed, lead_speed);
        if ttc > 0.0 && ttc < self.safety_time {
            (CarlaBand::SlowDown, (lead_speed - self.speed_decrease).max(0.0).min(self.cap()))
        } else if ttc >= self.safety_time && ttc < 2.0 * self.safety_time {
            (CarlaBand::FollowLead, self.min_speed.max(lead_speed).min(self.cap()))
        } else {
            (CarlaBand::Normal, self.cap())
        }
    }
}

/// Which branch of the agent produced the target speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum CarlaBand {
    /// Normal behaviour (no lead, or TTC >= 2 safety_time): drive at the cap.
    #[default]
    Normal,
    /// `safety_time <= TTC < 2 safety_time`: follow the lead's speed.
    FollowLead,
    /// `0 < TTC < safety_time`: lead speed minus `speed_decrease`.
    SlowDown,
    /// Gap below `braking_distance`: emergency stop.
    EmergencyStop,
}

/// The terms of the last step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CarlaTerms {
    /// A lead was used this step (within the look-ahead when [`CarlaBehaviorParams::limit_range`]).
    pub lead: bool,
    /// Measured gap, m.
    pub gap: f64,
    /// Estimated range rate, m/s.
    pub range_rate: f64,
    /// Estimated lead speed, m/s.
    pub lead_speed: f64,
    /// CARLA's TTC, s (0 without a lead).
    pub ttc: f64,
    /// Active branch.
    pub band: CarlaBand,
    /// Target speed before the `[0, max_speed]` limit, m/s.
    pub target_speed: f64,
}

/// The CARLA BehaviorAgent-style follower: the agent's rules under [`EstimatingFollower`]. The law
/// produces a target speed: `speed = clamp(target, 0, max_speed)`, `accel = (speed - v) / command_gain`.
///
/// ```
/// use flc_core::baselines::{CarlaBehaviorController, CarlaBehaviorParams};
/// use flc_core::{Frame, LongitudinalController};
///
/// let mut carla = CarlaBehaviorController::new(CarlaBehaviorParams::default())?;
/// let out = LongitudinalController::step(&mut carla, &Frame::new(Some(12.0), 20.0, 0.05));
/// // Lead speed = own speed on the first frame: TTC = 12 / max(1, 0) = 12 s >= 2 * 3 s: normal
/// // behaviour, target = min(130, 130 - 3) km/h = 35.2778 m/s.
/// assert!((out.command.speed - 127.0 / 3.6).abs() < 1e-12);
/// // 2 safety_time min_closing_speed = 2 * 3 * 1 = 6 m.
/// assert_eq!(carla.desired_gap(20.0), 6.0);
/// # Ok::<(), flc_core::ParamError>(())
/// ```
pub type CarlaBehaviorController = EstimatingFollower<CarlaBehavior>;

/// The CARLA agent's rules ([`CarFollowingLaw`]); stateless.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CarlaBehavior;

follower_params!(CarlaBehaviorParams, CarlaBehavior);

impl CarlaTerms {
    /// The names of [`CarlaTerms::to_terms`], in field order (`band` as its [`CarlaBand`] discriminant).
    pub const NAMES: &'static [&'static str] = &["lead", "gap", "range_rate", "lead_speed", "ttc", "band", "target_speed"];

    /// The terms as a named list ([`Terms`]).
    pub fn to_terms(&self) -> Terms {
        let t = self;
        Terms::new(Self::NAMES, &[flag(t.lead), t.gap, t.range_rate, t.lead_speed, t.ttc, f64::from(t.band as u8), t.target_speed])
    }
}

impl CarFollowingLaw for CarlaBehavior {
    type Params = CarlaBehaviorParams;
    type Terms = CarlaTerms;

    fn validate(p: &CarlaBehaviorParams) -> Result<(), ParamError> {
        p.validate_law()
    }

    /// `car_following_manager` / emergency stop. Beyond CARLA's look-ahead (when limited) the
    /// agent does not see the lead: normal behaviour (the estimator keeps tracking: it is the
    /// detector's track, not the agent's).
    fn follow(&mut self, p: &CarlaBehaviorParams, lead: &LeadEstimate, own_speed: f64) -> (Demand, CarlaTerms) {
        let LeadEstimate { gap, range_rate, lead_speed: v_lead } = *lead;
        let t = if p.limit_range && gap > p.look_ahead() {
            CarlaTerms { gap, range_rate, lead_speed: v_lead, band: CarlaBand::Normal, target_speed: p.cap(), ..CarlaTerms::default() }
        } else {
            let ttc = p.ttc(gap, own_speed, v_lead);
            let (band, target_speed) = p.target(gap, own_speed, v_lead);
            CarlaTerms { lead: true, gap, range_rate, lead_speed: v_lead, ttc, band, target_speed }
        };
        (Demand::Speed(t.target_speed), t)
    }

    /// Normal behaviour: the cap.
    fn free_road(&mut self, p: &CarlaBehaviorParams, _own_speed: f64) -> (Demand, CarlaTerms) {
        let t = CarlaTerms { band: CarlaBand::Normal, target_speed: p.cap(), ..CarlaTerms::default() };
        (Demand::Speed(t.target_speed), t)
    }

    /// The gap below which a lead at the own speed is followed (TTC `< 2 safety_time` with the
    /// closing speed floored at `min_closing_speed`): `2 safety_time min_closing_speed`.
    fn desired_gap(p: &CarlaBehaviorParams, _v: f64) -> f64 {
        2.0 * p.safety_time * p.min_closing_speed
    }

    fn terms(t: &CarlaTerms) -> Terms {
        t.to_terms()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{LongitudinalCommand, Status};
    use proptest::prelude::*;

    fn carla() -> CarlaBehaviorController {
        CarlaBehaviorController::new(CarlaBehaviorParams::default()).unwrap()
    }

    fn two_frames(c: &mut CarlaBehaviorController, gap: f64, own: f64, lead: f64) -> LongitudinalCommand {
        c.step(Some(gap - (lead - own) * 0.1), own, 0.1);
        c.step(Some(gap), own, 0.1)
    }

    #[test]
    fn ttc_bands_by_hand() {
        let p = CarlaBehaviorParams::default();
        let cap = 127.0 / 3.6; // min(130, 130 - 3) km/h = 35.277778 m/s
        assert!((p.cap() - cap).abs() < 1e-12);
        // v = 20 (72 km/h), v_lead = 15 (54 km/h): delta_v = max(1, 5) = 5.
        // gap 12: TTC = 2.4 < 3 -> 15 - 10/3.6 = 12.222222.
        assert!((p.ttc(12.0, 20.0, 15.0) - 2.4).abs() < 1e-12);
        let (band, v) = p.target(12.0, 20.0, 15.0);
        assert_eq!(band, CarlaBand::SlowDown);
        assert!((v - (15.0 - 10.0 / 3.6)).abs() < 1e-12 && (v - 12.222222).abs() < 1e-6);
        // gap 20: TTC = 4 in [3, 6) -> max(5/3.6, 15) = 15.
        assert_eq!(p.target(20.0, 20.0, 15.0), (CarlaBand::FollowLead, 15.0));
        // gap 40: TTC = 8 >= 6 -> normal, the cap.
        let (band, v) = p.target(40.0, 20.0, 15.0);
        assert!(band == CarlaBand::Normal && (v - cap).abs() < 1e-12);
        // gap 4.9 < braking_distance 5 -> emergency stop.
        assert_eq!(p.target(4.9, 20.0, 15.0), (CarlaBand::EmergencyStop, 0.0));
        // Opening lead (v = 15, v_lead = 20): delta_v = max(1, -5) = 1 -> TTC = gap:
        // gap 5.5 -> follow at 20; gap 8 -> normal.
        assert_eq!(p.target(5.5, 15.0, 20.0), (CarlaBand::FollowLead, 20.0));
        assert_eq!(p.target(8.0, 15.0, 20.0).0, CarlaBand::Normal);
        // Slow lead in the slow-down band: max(0, 2 - 2.78) = 0.
        assert_eq!(p.target(6.0, 10.0, 2.0), (CarlaBand::SlowDown, 0.0));
        // Crawling lead in the follow band: max(min_speed 5/3.6, 0.5) = 1.388889.
        assert_eq!(p.target(12.0, 3.0, 0.5), (CarlaBand::FollowLead, 5.0 / 3.6));
    }

    #[test]
    fn step_outputs_the_target_speed() {
        let mut c = carla();
        let out = two_frames(&mut c, 12.0, 20.0, 15.0);
        // speed = 12.222222, accel = (12.222222 - 20) / 1 s = -7.777778.
        assert_eq!(out.status, Status::Ok);
        assert_eq!(c.terms().band, CarlaBand::SlowDown);
        assert!((out.speed - (15.0 - 10.0 / 3.6)).abs() < 1e-9);
        assert!((out.accel - (15.0 - 10.0 / 3.6 - 20.0)).abs() < 1e-9);
        // Emergency stop: speed 0, accel -20.
        let out = c.step(Some(4.0), 20.0, 0.1);
        assert_eq!((out.speed, out.accel, c.terms().band), (0.0, -20.0, CarlaBand::EmergencyStop));
    }

    #[test]
    fn look_ahead_limit() {
        let p = CarlaBehaviorParams { limit_range: true, ..CarlaBehaviorParams::default() };
        // max(10, 130 / 3) = 43.333 m.
        assert!((p.look_ahead() - 130.0 / 3.0).abs() < 1e-9);
        let mut c = CarlaBehaviorController::new(p).unwrap();
        // Stopped lead at 50 m while doing 20 m/s: invisible to the agent -> the cap.
        let out = two_frames(&mut c, 50.0, 20.0, 0.0);
        assert!(!c.terms().lead);
        assert!((out.speed - 127.0 / 3.6).abs() < 1e-9);
        // At 40 m it is seen: TTC = 40 / 20 = 2 < 3 -> max(0, 0 - 2.78) = 0.
        let out = c.step(Some(40.0), 20.0, 0.5);
        assert!(c.terms().lead);
        assert_eq!(out.speed, 0.0);
    }

    #[test]
    fn no_lead_and_bad_inputs() {
        let mut c = carla();
        let out = c.step(None, 10.0, 0.05);
        assert_eq!(out.status, Status::Ok);
        assert!((out.speed - 127.0 / 3.6).abs() < 1e-9);
        let mut c = CarlaBehaviorController::new(CarlaBehaviorParams { no_lead: NoLeadPolicy::Brake, ..Default::default() }).unwrap();
        let out = c.step(None, 10.0, 0.05);
        assert_eq!((out.status, out.speed, out.accel), (Status::NoLead, 7.0, -3.0));
        assert_eq!(c.step(Some(f64::NAN), 10.0, 0.05).status, Status::InvalidDistance);
        assert_eq!(c.step(Some(10.0), 10.0, -1.0).status, Status::InvalidDt);
        assert_eq!(c.step(Some(10.0), f64::NEG_INFINITY, 0.05).speed, 0.0);
    }

    #[test]
    fn invalid_parameters_name_the_field() {
        let bad = |p: CarlaBehaviorParams| CarlaBehaviorController::new(p).unwrap_err().field;
        assert_eq!(bad(CarlaBehaviorParams { safety_time: 0.0, ..Default::default() }), "safety_time");
        assert_eq!(bad(CarlaBehaviorParams { speed_lim_dist: 100.0, ..Default::default() }), "speed_lim_dist");
        assert_eq!(bad(CarlaBehaviorParams { braking_distance: -1.0, ..Default::default() }), "braking_distance");
        assert_eq!(bad(CarlaBehaviorParams { min_closing_speed: 0.0, ..Default::default() }), "min_closing_speed");
        let est = EstimatorParams { beta: 0.0, ..EstimatorParams::default() };
        assert_eq!(bad(CarlaBehaviorParams { estimator: est, ..Default::default() }), "estimator.beta");
    }

    proptest! {
        #[test]
        fn outputs_are_finite_and_bounded(
            seq in proptest::collection::vec((proptest::option::of(proptest::num::f64::ANY), proptest::num::f64::ANY, proptest::num::f64::ANY), 1..40)
        ) {
            let mut c = carla();
            for (d, v, dt) in seq {
                let out = c.step(d, v, dt);
                prop_assert!(out.speed.is_finite() && (0.0..=70.0).contains(&out.speed));
                // |accel| <= max_speed + 1 (target in [0, 70], speed in [-1, 70]), or the fault step.
                prop_assert!(out.accel.is_finite() && out.accel.abs() <= 71.0);
            }
        }
    }
}
