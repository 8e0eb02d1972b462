//! The one scenario builder of the two-lane fixtures (`in_path.rs`, `cut_in_seen.rs`): a road of
//! two 3.5 m lanes, the ego's (0, the centreline) and one to its left (1), straight or with an
//! arc; the ego keeping its lane, V2V off; the lead (the object under test) somewhere ahead or
//! beside; optionally a scripted lane change of the lead (a cut-in or a cut-out).

use flc_sim::story::Story;
use flc_sim::{ControllerKind, Scenario, Track, TrackSpec};

/// km/h -> m/s.
pub const KMH: f64 = 1.0 / 3.6;
/// The lane width, m.
pub const LW: f64 = 3.5;
/// Where the ego's centre starts, m along the centreline (50 m into the arc of [`Road::Arc`]).
pub const EGO_S: f64 = 100.0;
/// The radii of the curved fixtures, m (those of the published ALKS and NCAP roads).
pub const RADII: [f64; 2] = [250.0, 1000.0];

/// The road under the fixture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Road {
    /// 6 km straight.
    Straight,
    /// A 50 m straight, then 600 m of arc of `radius` m turning left (`left`) or right, then a
    /// 300 m straight.
    Arc { radius: f64, left: bool },
}

impl Road {
    /// The four curved roads: [`RADII`], turning left and right.
    pub fn curves() -> impl Iterator<Item = Road> {
        RADII.into_iter().flat_map(|radius| [true, false].map(|left| Road::Arc { radius, left }))
    }

    /// Its track, two lanes, the ego's lane 0.
    pub fn track(self) -> Track {
        match self {
            Road::Straight => Track::new("straight", vec![[0.0, 0.0], [6000.0, 0.0]], LW, Vec::new()),
            Road::Arc { radius, left } => {
                let angle = if left { 600.0 / radius } else { -600.0 / radius };
                Track::from_plan("arc", &[(50.0, radius, angle), (300.0, 1.0, 0.0)], 2.0)
            }
        }
        .with_lanes(2, 0)
    }
}

impl std::fmt::Display for Road {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Road::Straight => write!(f, "straight"),
            Road::Arc { radius, left } => write!(f, "R = {radius} m {}", if *left { "left" } else { "right" }),
        }
    }
}

/// The ego (`controller`, keeping its lane, V2V off) at `ego_kmh` with its centre at [`EGO_S`]
/// on `road` (the careful driver's desired speed the same); the lead's centre `ahead` m further
/// along the road, `offset` m left of the ego lane's centre, at `lead_kmh` holding its speed (no
/// phases: at 0 it stands). 40 s.
pub fn two_lanes(road: Road, controller: ControllerKind, ego_kmh: f64, ahead: f64, offset: f64, lead_kmh: f64) -> Scenario {
    let mut s = Scenario { name: "two-lanes".into(), controller, duration: 40.0, ..Default::default() };
    s.track = TrackSpec::Custom(road.track());
    s.v2v.enabled = false;
    s.follower.start_s = Some(EGO_S);
    s.follower.initial_speed = ego_kmh * KMH;
    s.follower.lane_keeping = true;
    s.careful_driver.normal.desired_speed = ego_kmh * KMH;
    s.lead.s = Some(EGO_S + ahead);
    s.lead.offset = offset;
    s.lead.initial_speed = lead_kmh * KMH;
    s.lead.phases = Vec::new();
    s
}

/// The lead's centre ahead of the ego's (m) when its rear bumper is `gap` m ahead of the ego's
/// front bumper `at` s into the run, both holding their speeds until then (two default cars).
pub fn ahead_for_gap(gap: f64, ego_kmh: f64, lead_kmh: f64, at: f64) -> f64 {
    let len = flc_sim::VehicleParams::default().length;
    len + gap - (lead_kmh - ego_kmh) * KMH * at
}

/// A story (kinematic: the scripted vehicles follow their profiles exactly; the ego its
/// controller): at `at` s the lead starts a sinusoidal lane change taking `duration` s to the lane
/// `lanes` to the left of the ego's (0: into the ego's lane, a cut-in; 1: into the next lane, a
/// cut-out), then holds its speed.
pub fn lane_change(s: &mut Scenario, at: f64, lanes: i32, duration: f64) {
    lateral_move(s, at, lanes, 0.0, duration);
}

/// [`lane_change`] to `lane_offset` m left of the centre of the lane `lanes` to the left of the
/// ego's (a pedestrian walking across: `lanes` 0 and its end offset).
pub fn lateral_move(s: &mut Scenario, at: f64, lanes: i32, lane_offset: f64, duration: f64) {
    let text = format!(
        r#"
dynamics = "kinematic"
ego = "controller"

[[acts]]
name = "LaneChangeAct"
start = {{ kind = "simulation_time", value = 0.0, rule = "greater_than" }}

[[acts.groups]]
name = "LeadGroup"
actors = ["lead"]

[[acts.groups.maneuvers]]
name = "LeadManeuver"

[[acts.groups.maneuvers.events]]
name = "Change"
priority = "override"
max_executions = 1
start = {{ kind = "simulation_time", value = {at}, rule = "greater_than" }}

[[acts.groups.maneuvers.events.actions]]
name = "ChangeAction"
kind = "lane_change"
of = "ego"
lanes = {lanes}
lane_offset = {lane_offset}
shape = "sinusoidal"
dimension = "time"
value = {duration}
"#
    );
    s.story = Some(toml::from_str::<Story>(&text).expect("story"));
}
