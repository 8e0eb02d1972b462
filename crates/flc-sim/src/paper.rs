//! The paper's experiment (Sec. IV) in one place: its speeds, the scenario, the `paper` preset
//! (what the paper leaves open, `docs/sim-model.md`) and the paper's reported results.
//!
//! Lead and follower start at standstill 7 m apart on a straight road; the lead accelerates to
//! 30 / 50 / 70 / 90 km/h, covers about 650 m and brakes at -6 m/s² to a stop. The follower is
//! driven by the FLC, the PID or the switching pipeline (V2V lost at brake onset).

use flc_core::{DetectorParams, PurePursuitParams};
use serde::{Deserialize, Serialize};

use crate::controllers::ControllerSections;
use crate::follower::FollowerSpec;
use crate::lead::LeadSpec;
use crate::lead::Phase;
use crate::lidar::LidarParams;
use crate::scenario::{ControllerKind, KMH, Scenario, StopSpec, TrackSpec};
use crate::v2v::V2vParams;
use crate::vehicle::VehicleParams;

/// The speeds (km/h) the paper experiment takes, inclusive: the one limit of every entry point
/// (`scenario --speeds`, a scenario's `speed_kmh`, `flc.Scenario.paper`, `python -m flc figures
/// --speeds`; checked by [`check_speed_kmh`]). The lead must move (1 km/h) and stay below the
/// lead's speed limit of 70 m/s (252 km/h).
pub const SPEED_RANGE_KMH: (f64, f64) = (1.0, 250.0);

/// Checks a paper-experiment speed against [`SPEED_RANGE_KMH`]; the error names `key`.
pub fn check_speed_kmh(key: &str, speed_kmh: f64) -> Result<(), crate::ConfigError> {
    crate::check_range(key, speed_kmh, SPEED_RANGE_KMH.0, SPEED_RANGE_KMH.1, "km/h")
}

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

/// One tracking run of [`Scenario::paper_tracking`] for [`other_numbers`].
pub struct TrackingRun<'a> {
    /// `flc` or `pid`.
    pub controller: &'a str,
    /// Mean |heading error|, deg.
    pub rot_error_deg: Option<f64>,
    /// Mean |lateral offset|, m.
    pub trans_error_m: Option<f64>,
    /// How the run ended ([`crate::RunRecord::outcome`]): the errors are averages up to that end.
    pub outcome: String,
    /// Simulated time of the run, s.
    pub duration: f64,
}

/// The paper's other numbers next to the simulated ones: the tracking errors of `tracking` (runs
/// of [`Scenario::paper_tracking`], with how each run ended) and, from `impacts` (controller,
/// impact speed at 90 km/h), whether the FLC's crash at 90 km/h is less severe than the PID's.
pub fn other_numbers(tracking: &[TrackingRun<'_>], impacts: &[(&str, f64)]) -> String {
    let mut out = String::from("the paper's other numbers:\n");
    for TrackingRun { controller: c, rot_error_deg: rot, trans_error_m: trans, outcome, duration } in tracking {
        let paper = PAPER_TRACKING.iter().find(|(n, _, _)| n == c);
        let f = |x: &Option<f64>, d: usize| x.map_or("-".to_string(), |v| format!("{v:.d$}"));
        out.push_str(&format!(
            "  tracking on the curved route, {c}: rotational {} deg, translational {} m (paper {} deg, {} m); the run ends after {duration:.2} s: {}\n",
            f(rot, 4),
            f(trans, 4),
            paper.map_or("-".into(), |p| p.1.to_string()),
            paper.map_or("-".into(), |p| p.2.to_string()),
            outcome.split_whitespace().collect::<Vec<_>>().join(" ")
        ));
    }
    let get = |n: &str| impacts.iter().find(|(c, _)| *c == n).map(|(_, v)| *v);
    if let (Some(f), Some(p)) = (get("flc"), get("pid")) {
        let verdict = if f < p { "holds" } else { "does not hold" };
        out.push_str(&format!(
            "  at 90 km/h the FLC's crash is less severe than the PID's (paper): impact {f:.2} vs {p:.2} m/s, {verdict}\n"
        ));
    }
    out
}

/// One line on how large the matching region is (printed under the results table).
pub fn matching_region_line() -> String {
    let (map, random) = PAPER_MATCHING_REGION;
    format!(
        "paper preset (brake authority {PAPER_MAX_DECEL} m/s², actuator response {PAPER_ACTUATOR_RESPONSE} s): all 8 cells match the paper on {map:.1} % of the brake x response map and {random:.1} % of a random sample over 7 constants, a narrow ridge (docs/paper-reproduction.md)\n"
    )
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
