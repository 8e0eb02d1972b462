//! The paper's experiment (Sec. IV) in one place: its speeds, the scenario, the `paper` preset
//! (what the paper leaves open, `docs/sim-model.md`), the paper's reported results and a run's
//! verdict against them ([`CellVerdict`]; the summary of a whole run is `crate::paper_verdict`'s).
//!
//! Lead and follower start at standstill 7 m apart on a straight road; the lead accelerates to
//! 30 / 50 / 70 / 90 km/h, covers about 650 m and brakes at -6 m/s² to a stop. The follower is
//! driven by the FLC, the PID or the switching pipeline (V2V lost at brake onset).

use flc_core::{DetectorParams, NeighbourParams, PurePursuitParams};
use serde::{Deserialize, Serialize};

use crate::controllers::ControllerSections;
use crate::follower::FollowerSpec;
use crate::lead::LeadSpec;
use crate::lead::Phase;
use crate::lidar::LidarParams;
use crate::metrics::Metrics;
use crate::scenario::{ControllerKind, KMH, Scenario, StopSpec, TrackSpec};
use crate::v2v::V2vParams;
use crate::vehicle::VehicleParams;

/// The speed range of the paper experiment (owned by the scenario, whose `speed_kmh` it bounds).
pub use crate::scenario::{SPEED_RANGE_KMH, check_speed_kmh};

/// The paper's results (Sec. IV, Fig. 4), per speed of [`PAPER_SPEEDS_KMH`]: clearance at
/// standstill in m, `None` for a collision.
pub const PAPER_FLC_RESULTS: [Option<f64>; 4] = [Some(3.8), Some(4.0), Some(2.3), None];
/// See [`PAPER_FLC_RESULTS`]: the PID's.
pub const PAPER_PID_RESULTS: [Option<f64>; 4] = [Some(7.9), Some(1.2), None, None];

/// The paper's result for `controller` (`"flc"` or `"pid"`) at `speed_kmh`: `Some(Some(clearance))`
/// for a stop, `Some(None)` for a collision, `None` where the paper reports nothing.
pub fn paper_result(controller: &str, speed_kmh: f64) -> Option<Option<f64>> {
    let i = PAPER_SPEEDS_KMH.iter().position(|s| (s - speed_kmh).abs() < 1e-9)?;
    match controller {
        "flc" => PAPER_FLC_RESULTS.get(i).copied(),
        "pid" => PAPER_PID_RESULTS.get(i).copied(),
        _ => None,
    }
}

/// How far a simulated clearance may be from the paper's and still match, m. The paper states
/// its clearances to 0.1 m ("over 3.8, 4 and 2.3 meters", read off the gap plots of Fig. 4)
/// for a CARLA vehicle whose brakes and actuator it does not describe; half a metre is a
/// bumper's length of slack for that, and still separates "stops about where the paper stops"
/// from "stops somewhere" (the clearances span 1.2-7.9 m).
pub const CLEARANCE_TOLERANCE_M: f64 = 0.5;

/// How a run of the paper experiment ended, in the paper's terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OutcomeClass {
    /// Both vehicles at standstill, no contact.
    Stop,
    /// The follower touched something.
    Collision,
    /// No contact, but the run ended before both stood still.
    NoStop,
}

impl OutcomeClass {
    /// The class of a run's metrics.
    pub fn of(m: &Metrics) -> Self {
        if m.collision {
            Self::Collision
        } else if m.final_clearance.is_some() {
            Self::Stop
        } else {
            Self::NoStop
        }
    }

    /// `stop`, `collision` or `no stop`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Stop => "stop",
            Self::Collision => "collision",
            Self::NoStop => "no stop",
        }
    }
}

/// The verdict of one cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Same outcome class; for a stop, the clearance within the tolerance.
    Match,
    /// Both stop, the clearance is off by more than the tolerance.
    ClearanceOff,
    /// Stop where the paper collides, or the other way round (or no stop at all).
    OutcomeDiffers,
}

/// One run of the paper experiment against the paper's cell (the `paper_verdict` object of
/// `scenario --json`, `docs/scenarios.md`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CellVerdict {
    /// The paper's outcome: `stop` or `collision`.
    pub paper_outcome: OutcomeClass,
    /// The paper's clearance, m (`None` for a collision).
    pub paper_clearance: Option<f64>,
    /// This run's outcome: `stop`, `collision` or `no_stop`.
    pub outcome: OutcomeClass,
    /// The two outcome classes are equal.
    pub outcome_match: bool,
    /// This run's clearance minus the paper's, m (`None` unless both stop).
    pub clearance_error: Option<f64>,
    /// [`CLEARANCE_TOLERANCE_M`].
    pub clearance_tolerance: f64,
    /// `|clearance_error| <= clearance_tolerance` (`None` unless both stop).
    pub clearance_within: Option<bool>,
    /// The verdict.
    pub verdict: Verdict,
}

impl CellVerdict {
    /// The verdict of a run of `controller` at `speed_kmh` with `metrics`; `None` where the
    /// paper reports nothing (the pipeline, the baselines, other speeds).
    pub fn of(controller: &str, speed_kmh: f64, metrics: &Metrics) -> Option<Self> {
        let paper = paper_result(controller, speed_kmh)?;
        let paper_outcome = if paper.is_some() { OutcomeClass::Stop } else { OutcomeClass::Collision };
        let outcome = OutcomeClass::of(metrics);
        let outcome_match = outcome == paper_outcome;
        let clearance_error = match (metrics.final_clearance, paper) {
            (Some(c), Some(p)) if outcome == OutcomeClass::Stop => Some(c - p),
            _ => None,
        };
        let clearance_within = clearance_error.map(|e| e.abs() <= CLEARANCE_TOLERANCE_M);
        let verdict = match (outcome_match, clearance_within) {
            (false, _) => Verdict::OutcomeDiffers,
            (true, Some(false)) => Verdict::ClearanceOff,
            (true, _) => Verdict::Match,
        };
        Some(Self {
            paper_outcome,
            paper_clearance: paper,
            outcome,
            outcome_match,
            clearance_error,
            clearance_tolerance: CLEARANCE_TOLERANCE_M,
            clearance_within,
            verdict,
        })
    }

    /// The table's verdict column: `ok, +0.20 m`, `off by -1.48 m`, `ok` (both collide),
    /// `OUTCOME DIFFERS`.
    pub fn short(&self) -> String {
        match (self.verdict, self.clearance_error) {
            (Verdict::OutcomeDiffers, _) => "OUTCOME DIFFERS".to_string(),
            (Verdict::ClearanceOff, Some(e)) => format!("off by {e:+.2} m"),
            (_, Some(e)) => format!("ok, {e:+.2} m"),
            (_, None) => "ok".to_string(),
        }
    }
}

impl Default for Scenario {
    /// The paper's experiment at 50 km/h with the FLC and the realistic vehicle, unnamed (file
    /// scenarios take their file name).
    fn default() -> Self {
        Self { name: String::new(), speed_kmh: None, ..Self::paper_experiment(50.0, ControllerKind::Flc, Calibration::Realistic) }
    }
}

/// Which set of choices for what the paper leaves open.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Calibration {
    /// The physically realistic default vehicle (`VehicleParams::default()`).
    Realistic,
    /// Calibrated (within plausible ranges) to reproduce the paper's outcome pattern
    /// (`docs/sim-model.md`, "paper preset").
    Paper,
}

impl Calibration {
    /// `"realistic"` or `"paper"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Calibration::Realistic => "realistic",
            Calibration::Paper => "paper",
        }
    }
}

/// How far above the lead's cruise speed the baselines' set speed is in the paper experiment, km/h.
pub const BASELINE_SET_SPEED_MARGIN_KMH: f64 = 20.0;

/// The four maximum speeds of the paper's experiment, km/h.
pub const PAPER_SPEEDS_KMH: [f64; 4] = [30.0, 50.0, 70.0, 90.0];

/// Brake authority of the follower's low-level speed controller in the paper preset, m/s²
/// (realistic: 8). Chosen from the reproduction map (`docs/paper-reproduction.md`,
/// `python -m flc reproduction`): the point of the brake authority x actuator response map whose
/// worst neighbour still matches 7 of the paper's 8 cells. The same for the FLC and the PID.
pub const PAPER_MAX_DECEL: f64 = 4.9;

/// Actuator dead time + first-order lag of the follower in the paper preset, s (realistic: 0.3),
/// split 1 : 2 like the realistic vehicle. From the same map as [`PAPER_MAX_DECEL`].
pub const PAPER_ACTUATOR_RESPONSE: f64 = 0.5;

/// How large the region is where the paper preset's constants reproduce all 8 cells, from the
/// committed map data (`sweeps/paper-reproduction-{map,random}.csv`; checked against them by
/// `crates/flc-sim/tests/paper.rs`): the share of the brake authority x actuator response map
/// and of the random sample over all constants, in percent.
pub const PAPER_MATCHING_REGION: (f64, f64) = (3.0, 1.0);

/// Applies the paper preset: the follower's brake authority and actuator response (the same
/// vehicle for every controller; no controller gain is changed).
pub fn apply_paper(s: &mut Scenario) {
    s.follower.speed_controller.max_decel = PAPER_MAX_DECEL;
    s.follower.vehicle.dead_time = PAPER_ACTUATOR_RESPONSE * (1.0 / 3.0);
    s.follower.vehicle.lag = PAPER_ACTUATOR_RESPONSE * (2.0 / 3.0);
}

/// The paper's average tracking errors on its curved route (Sec. IV, Fig. 3a): controller,
/// rotational (deg), translational (m).
pub const PAPER_TRACKING: [(&str, f64, f64); 2] = [("flc", 0.0176, 0.2258), ("pid", 0.0199, 0.2876)];

impl Scenario {
    /// The curved-route run of the paper's tracking errors: the lead accelerates to 50 km/h
    /// through the curves of Fig. 3a, covers 1600 m and stops at 3 m/s²; the follower starts 7 m
    /// behind with `controller` (the PID with working V2V). Measured as `rot_error_deg` /
    /// `trans_error_m` (mean |heading error| / |lateral offset| from the lane centre,
    /// `docs/v2v-and-metrics.md`).
    pub fn paper_tracking(controller: ControllerKind, calibration: Calibration) -> Self {
        let mut s = Scenario::paper_experiment(50.0, controller, calibration);
        s.name = format!("paper-{}-curved", calibration.as_str());
        s.track = TrackSpec::Curvy;
        s.duration = 200.0;
        s.speed_kmh = None;
        s.v2v.outage_on_brake = false;
        s.lead.phases = vec![
            Phase::Accelerate { accel: 2.0, speed: None, speed_kmh: Some(50.0) }.into(),
            Phase::Hold { until_x: Some(1600.0), until_t: None, duration: None }.into(),
            Phase::Brake { decel: 3.0, speed: None, speed_kmh: None }.into(),
        ];
        s
    }
}

impl Scenario {
    /// The paper's experiment (Sec. IV): both vehicles at standstill 7 m apart on the straight
    /// track; the lead accelerates to `speed_kmh`, covers about 650 m and brakes at -6 m/s² to a
    /// stop. For [`ControllerKind::Pipeline`], V2V is lost at the brake onset.
    pub fn paper_experiment(speed_kmh: f64, controller: ControllerKind, calibration: Calibration) -> Self {
        let mut v2v = V2vParams::default();
        let lead = LeadSpec {
            initial_speed: 0.0,
            vehicle: VehicleParams::default(),
            phases: vec![
                Phase::Accelerate { accel: 2.5, speed: None, speed_kmh: Some(speed_kmh) }.into(),
                Phase::Hold { until_x: Some(650.0), until_t: None, duration: None }.into(),
                Phase::Brake { decel: 6.0, speed: None, speed_kmh: None }.into(),
            ],
            ..LeadSpec::default()
        };
        match controller {
            ControllerKind::Pid => {}
            ControllerKind::Pipeline => v2v.outage_on_brake = true,
            // LiDAR-only controllers: no V2V at all.
            _ => v2v.enabled = false,
        }
        // The baselines' set speed (they are cruise controllers, the lead is a follower's
        // business only while it is ahead): 20 km/h above the lead's cruise speed, so that they
        // follow the lead rather than cruise behind it (`docs/baselines.md`, "In the simulator").
        let set_speed = (speed_kmh + BASELINE_SET_SPEED_MARGIN_KMH) * KMH;
        let mut sections = ControllerSections::default();
        for kind in ControllerKind::ALL {
            kind.set_cruise_speed(&mut sections, set_speed);
        }
        let mut s = Self::assemble(
            format!("paper-{}-{}", calibration.as_str(), speed_kmh),
            1,
            controller,
            150.0,
            0.01,
            TrackSpec::Straight { length: 2000.0 },
            lead,
            Vec::new(),
            FollowerSpec::default(),
            LidarParams::default(),
            v2v,
            DetectorParams::default(),
            NeighbourParams::default(),
            PurePursuitParams::default(),
            StopSpec::default(),
            Some(speed_kmh),
            None,
            None,
            Vec::new(),
            None,
            sections,
        );
        if calibration == Calibration::Paper {
            apply_paper(&mut s);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(collision: bool, clearance: Option<f64>) -> Metrics {
        // A real run's metrics, then the two fields the verdict reads.
        let mut m = crate::run(&crate::Scenario { duration: 1.0, ..crate::Scenario::default() }).expect("run").metrics;
        m.collision = collision;
        m.final_clearance = clearance;
        m.impact_speed = if collision { 3.0 } else { 0.0 };
        m
    }

    #[test]
    fn a_cell_matches_on_class_and_clearance_within_the_tolerance() {
        // FLC 30 km/h: the paper stops 3.8 m short.
        let ok = CellVerdict::of("flc", 30.0, &metrics(false, Some(4.2))).expect("cell");
        assert_eq!((ok.verdict, ok.outcome_match, ok.clearance_within), (Verdict::Match, true, Some(true)));
        assert!((ok.clearance_error.expect("both stop") - 0.4).abs() < 1e-12);
        let off = CellVerdict::of("flc", 30.0, &metrics(false, Some(4.31))).expect("cell");
        assert_eq!((off.verdict, off.clearance_within), (Verdict::ClearanceOff, Some(false)));
        let crash = CellVerdict::of("flc", 30.0, &metrics(true, None)).expect("cell");
        assert_eq!((crash.verdict, crash.outcome, crash.clearance_error), (Verdict::OutcomeDiffers, OutcomeClass::Collision, None));
        let no_stop = CellVerdict::of("flc", 30.0, &metrics(false, None)).expect("cell");
        assert_eq!((no_stop.verdict, no_stop.outcome), (Verdict::OutcomeDiffers, OutcomeClass::NoStop));
        // PID 70 km/h: the paper collides.
        let both = CellVerdict::of("pid", 70.0, &metrics(true, None)).expect("cell");
        assert_eq!((both.verdict, both.clearance_within), (Verdict::Match, None));
        assert_eq!(CellVerdict::of("pid", 70.0, &metrics(false, Some(7.0))).expect("cell").verdict, Verdict::OutcomeDiffers);
        // No paper figure: the pipeline, other speeds.
        assert!(CellVerdict::of("pipeline", 70.0, &metrics(false, Some(4.0))).is_none());
        assert!(CellVerdict::of("flc", 60.0, &metrics(false, Some(4.0))).is_none());
    }
}
