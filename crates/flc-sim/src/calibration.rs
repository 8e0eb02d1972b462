//! The `paper` preset: values for what the paper leaves open, calibrated within physically
//! plausible ranges so that the simulator reproduces the paper's outcome pattern (FLC stops at
//! 30 / 50 / 70 km/h and collides at 90 km/h with a lower impact speed than the PID; the PID stops
//! at 30 / 50 and collides at 70 / 90). Each value and its reason is in `docs/sim-model.md`
//! ("Paper preset").

use crate::scenario::Scenario;

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
