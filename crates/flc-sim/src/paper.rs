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

/// Brake authority of the low-level speed controller in the paper preset, m/s². The paper feeds
/// its speed command into CARLA's default vehicle controller, whose agents cap the brake pedal
/// (`max_brake` < 1 in CARLA's local planner); 4.8 m/s² is 60 % of the tyres' 8 m/s².
pub const PAPER_MAX_DECEL: f64 = 4.8;

/// Derivative gain of the PID's near gain set in the paper preset (the paper gives no gains).
pub const PAPER_PID_NEAR_KD: f64 = 0.6;

/// Applies the paper preset.
pub fn apply_paper(s: &mut Scenario) {
    s.follower.speed_controller.max_decel = PAPER_MAX_DECEL;
    s.pid.near.kd = PAPER_PID_NEAR_KD;
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
                Phase::Accelerate { accel: 2.5, speed: None, speed_kmh: Some(speed_kmh) },
                Phase::Hold { until_x: Some(650.0), until_t: None, duration: None },
                Phase::Brake { decel: 6.0, speed: None, speed_kmh: None },
            ],
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
            FollowerSpec::default(),
            LidarParams::default(),
            v2v,
            DetectorParams::default(),
            PurePursuitParams::default(),
            StopSpec::default(),
            Some(speed_kmh),
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
