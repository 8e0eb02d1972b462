//! The thresholds of the metrics.

use serde::{Deserialize, Serialize};

/// Thresholds of the metrics. [`crate::Metrics::compute`] uses the defaults (documented values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricsParams {
    /// Both speeds below this count as standstill (for `final_clearance`), m/s. Default 0.05
    /// (the closed loop's stop condition).
    pub standstill_speed: f64,
    /// Window of the jerk estimate, s. Default 0.1.
    pub jerk_window: f64,
    /// Steady following: `|v_follower - v_lead|` below this, m/s. Default 0.5.
    pub steady_speed_diff: f64,
    /// Steady following: `|a_lead|` below this, m/s². Default 0.2.
    pub steady_lead_accel: f64,
    /// Steady following: the conditions must have held this long, s. Default 2.
    pub steady_min_time: f64,
    /// Steady following: the lead must move at least this fast, m/s (standstill is not
    /// following). Default 1.
    pub steady_min_speed: f64,
    /// Tracking errors are averaged while the follower moves at least this fast, m/s. Default 0.5.
    pub tracking_min_speed: f64,
    /// Closing speeds at or below this count as "not closing" for TTC, m/s. Default 1e-6.
    pub ttc_min_closing: f64,
    /// TTC threshold `TTC*` of `tet` and `tit` (Minderhoud & Bovy 2001), s. Default 3, SUMO's
    /// SSM device default for TTC (`device.ssm.thresholds`).
    pub ttc_threshold: f64,
    /// `min_time_headway` counts the samples where the follower moves faster than this, m/s
    /// (`gap / v_follower` grows without bound towards standstill and means nothing there).
    /// Default 0.5, as `tracking_min_speed`.
    pub headway_min_speed: f64,
    /// `pet`: a sample whose gap is this much below the gap predicted from the previous sample
    /// (`g[i-1] + Δ_i (v_l[i-1] + v_l[i] - v_f[i-1] - v_f[i]) / 2`) starts a cut-in: a vehicle
    /// entered the follower's path between it and the vehicle it followed, m. Default 1 (the same
    /// vehicle is predicted to within a few cm per step; two vehicles in one path are a vehicle
    /// length apart).
    pub cut_in_gap_drop: f64,
}

impl Default for MetricsParams {
    fn default() -> Self {
        Self {
            standstill_speed: 0.05,
            jerk_window: 0.1,
            steady_speed_diff: 0.5,
            steady_lead_accel: 0.2,
            steady_min_time: 2.0,
            steady_min_speed: 1.0,
            tracking_min_speed: 0.5,
            ttc_min_closing: 1e-6,
            ttc_threshold: 3.0,
            headway_min_speed: 0.5,
            cut_in_gap_drop: 1.0,
        }
    }
}
