//! What a run records besides its series: per-follower results, each follower's first contact
//! and the first contacts between the other bodies.

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
    /// Its first contact with anything (a vehicle, a parked car, a guard rail, a post), if any.
    pub collision: Option<CollisionInfo>,
}

/// What kind of body a contact involves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// The lead, a follower or a scripted vehicle.
    Vehicle,
    /// A scripted pedestrian (`vehicle.body = "pedestrian"`), by name.
    Pedestrian,
    /// A parked car of the track (`RoadsideObject::ParkedCar`).
    ParkedCar,
    /// A guard rail of the track (`RoadsideObject::GuardRail`, any of its pieces).
    GuardRail,
    /// A post of the track (`RoadsideObject::Post`).
    Post,
}

impl ObjectKind {
    /// The name in JSON and in the tables (`vehicle`, `pedestrian`, `parked_car`, `guard_rail`,
    /// `post`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Vehicle => "vehicle",
            Self::Pedestrian => "pedestrian",
            Self::ParkedCar => "parked_car",
            Self::GuardRail => "guard_rail",
            Self::Post => "post",
        }
    }
}

/// One side of a contact: a vehicle (by name: `lead`, `follower 2`, a scripted vehicle's name)
/// or a road-side object (by its index in the track's `objects`). Serialised as `{kind, name}` for
/// a vehicle and `{kind, index}` for an object.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct HitObject {
    /// What it is.
    pub kind: ObjectKind,
    /// For a vehicle: its name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// For a road-side object: its index in the track's `objects`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub index: Option<usize>,
}

impl HitObject {
    /// Vehicle `k` of the string (0 = the lead, `k` = follower `k`).
    pub fn vehicle(k: usize) -> Self {
        Self::named(if k == 0 { "lead".to_string() } else { format!("follower {k}") })
    }

    /// The vehicle called `name`.
    pub fn named(name: String) -> Self {
        Self { kind: ObjectKind::Vehicle, name: Some(name), index: None }
    }

    /// Road-side object `index` of the track, of kind `kind`.
    pub fn object(kind: ObjectKind, index: usize) -> Self {
        Self { kind, name: None, index: Some(index) }
    }

    /// The vehicle's name (`None` for an object).
    pub fn name(&self) -> Option<String> {
        self.name.clone()
    }

    /// A short label for tables and markers: `lead`, `follower 2`, `parked_car #3`.
    pub fn label(&self) -> String {
        match (&self.name, self.index) {
            (Some(n), _) => n.clone(),
            (None, Some(i)) => format!("{} #{i}", self.kind.as_str()),
            (None, None) => self.kind.as_str().to_string(),
        }
    }
}

/// A follower's first contact with anything, as reported by the physics engine.
///
/// `time`, `impact_speed`, `lead_speed` and `follower_speed` keep their meaning from when only
/// the vehicle in front counted; the other fields say what was hit and how.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CollisionInfo {
    /// Time of the first contact, s.
    pub time: f64,
    /// Longitudinal relative impact speed, m/s: `max(0, v_follower - v_front)` for the vehicle in
    /// front; otherwise the closing speed along the follower's heading, towards the side of the
    /// contact (`max(0, v_follower)` for a standing object ahead).
    pub impact_speed: f64,
    /// Speed of the vehicle in front (the lead for follower 1) at impact, m/s.
    pub lead_speed: f64,
    /// Follower speed at impact, m/s.
    pub follower_speed: f64,
    /// What was hit.
    pub object: HitObject,
    /// Speed of what was hit, m/s (0 for a road-side object).
    pub other_speed: f64,
    /// Relative impact speed along the contact normal (closing positive, `>= 0`), m/s.
    pub impact_speed_normal: f64,
    /// Contact point, world frame, m.
    pub point: [f64; 2],
    /// Contact normal, world frame, unit, from the follower towards what it hit.
    pub normal: [f64; 2],
}

/// One contact episode of a pair of bodies (the step they start touching), in a `[story]` run:
/// what `scenario --json` lists as `contacts` (every contact, the ego's included).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairContact {
    /// Time of the step the pair started touching, s.
    pub time: f64,
    /// One body (a vehicle: `{kind, name}`).
    pub a: HitObject,
    /// The other (a vehicle or a road-side object).
    pub b: HitObject,
    /// Magnitude of the relative velocity `v_a - v_b` (world frame), m/s.
    pub relative_speed: f64,
    /// Closing speed along the contact normal (`>= 0`), m/s.
    pub impact_speed_normal: f64,
    /// Contact point, world frame, m.
    pub point: [f64; 2],
}

/// The first contact of a pair of bodies neither of which is a follower (the lead touching a
/// parked car, a guard rail, a post): listed per run, not a follower's collision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContactRecord {
    /// Time of the first contact, s.
    pub time: f64,
    /// The vehicle.
    pub a: HitObject,
    /// What it touched.
    pub b: HitObject,
    /// Speed of `a` at the contact, m/s.
    pub speed: f64,
    /// Relative impact speed along the contact normal (closing positive, `>= 0`), m/s.
    pub impact_speed_normal: f64,
    /// Contact point, world frame, m.
    pub point: [f64; 2],
    /// Contact normal, world frame, unit, from `a` towards `b`.
    pub normal: [f64; 2],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_serialise_with_a_name_or_an_index_and_read_back() {
        let lead = serde_json::to_string(&HitObject::vehicle(0)).unwrap_or_default();
        assert_eq!(lead, r#"{"kind":"vehicle","name":"lead"}"#);
        let f2 = serde_json::to_string(&HitObject::vehicle(2)).unwrap_or_default();
        assert_eq!(f2, r#"{"kind":"vehicle","name":"follower 2"}"#);
        let car = serde_json::to_string(&HitObject::object(ObjectKind::ParkedCar, 3)).unwrap_or_default();
        assert_eq!(car, r#"{"kind":"parked_car","index":3}"#);
        for (text, o) in [(lead, HitObject::vehicle(0)), (f2, HitObject::vehicle(2)), (car, HitObject::object(ObjectKind::ParkedCar, 3))] {
            assert_eq!(serde_json::from_str::<HitObject>(&text).ok(), Some(o));
        }
        assert_eq!(HitObject::named("bus".into()).label(), "bus");
        assert_eq!(HitObject::object(ObjectKind::GuardRail, 0).label(), "guard_rail #0");
    }
}
