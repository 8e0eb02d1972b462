//! What a run records besides its series: per-follower results and the first contact.

use serde::{Deserialize, Serialize};

use super::Metrics;
use crate::series::Series;

/// One follower of a platoon run. Its series' `lead_*` columns are those of the vehicle in front
/// of it (the lead for follower 1), `gap` the gap to that vehicle.
#[derive(Debug, Clone)]
pub struct FollowerRun {
    /// Per-step time series.
    pub series: Series,
    /// Metrics against the vehicle in front.
    pub metrics: Metrics,
    /// Its first contact with the vehicle in front, if any.
    pub collision: Option<CollisionInfo>,
}

/// The first contact between the two vehicles, as reported by the physics engine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CollisionInfo {
    /// Time of the first contact, s.
    pub time: f64,
    /// Relative impact speed `max(0, v_follower - v_lead)`, m/s.
    pub impact_speed: f64,
    /// Lead speed at impact, m/s.
    pub lead_speed: f64,
    /// Follower speed at impact, m/s.
    pub follower_speed: f64,
}
