//! A grid of cut-ins judged against the UN R157 careful driver (`docs/detector.md`, "Cut-ins seen
//! coming"): the ego keeps its lane at a steady speed; a 1.85 m wide car in the next lane, its
//! rear bumper `gap` m ahead of the ego's front bumper, starts a sinusoidal lane change into the
//! ego's lane taking `duration` s, then holds its speed. Each case runs with the law under test
//! and with the careful driver (ground truth, R157 Annex 3), under the same sensor / vehicle
//! impairment; a case fails when the careful driver has no contact and the law has.
//!
//! [`Grid::cases`] lists the cases, [`run_grid`] runs them, [`table`] sums them up per sensor
//! and law (the table of `scenario cut-in-grid`).

use crate::error::SimError;
use crate::runner::RunOptions;
use crate::scenario::{ControllerKind, Scenario, TrackSpec};
use crate::track::Track;
use crate::vehicle::VehicleParams;
use crate::{Metrics, Patch, units::KMH};

/// The lane width, m.
const LW: f64 = 3.5;
/// Where the ego starts, m along the centreline.
const EGO_S: f64 = 100.0;
/// When the lane change starts, s into the run.
const BEFORE: f64 = 2.0;

/// The impairments of the grid, each alone (besides the default sensor): the issue's four.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Impairment {
    /// The default LiDAR (20 Hz, no latency) and vehicle.
    Default,
    /// LiDAR at 10 Hz.
    Lidar10Hz,
    /// 100 ms of LiDAR latency (2 frames at 20 Hz).
    Latency100ms,
    /// Actuators: dead time 0.3 s and first-order lag 0.3 s.
    Actuators,
    /// Wet road: brakes limited to 4 m/s² (the robust FLC's stop envelope assumes the same).
    Wet,
}

impl Impairment {
    /// Every impairment, the default first.
    pub const ALL: [Impairment; 5] = [Self::Default, Self::Lidar10Hz, Self::Latency100ms, Self::Actuators, Self::Wet];

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Default => "default sensor",
            Self::Lidar10Hz => "LiDAR 10 Hz",
            Self::Latency100ms => "latency 100 ms",
            Self::Actuators => "actuators 0.3 s + 0.3 s",
            Self::Wet => "wet road (4 m/s²)",
        }
    }

    /// The patch that applies it.
    pub fn patch(self) -> Patch {
        let mut p = Patch::new();
        match self {
            Self::Default => {}
            Self::Lidar10Hz => {
                p.set("lidar.rate_hz", toml::Value::Float(10.0));
            }
            Self::Latency100ms => {
                p.set("lidar.latency_frames", toml::Value::Integer(2));
            }
            Self::Actuators => {
                p.set("follower.vehicle.dead_time", toml::Value::Float(0.3)).set("follower.vehicle.lag", toml::Value::Float(0.3));
            }
            Self::Wet => {
                p.set("follower.vehicle.max_brake", toml::Value::Float(4.0));
            }
        }
        p
    }
}

/// The road: straight, or an arc of 1000 m radius turning towards the car's lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Road {
    /// Straight.
    Straight,
    /// An arc of this radius (m) turning left (the car comes from the inside of the curve).
    Arc(f64),
}

impl Road {
    fn name(self) -> String {
        match self {
            Road::Straight => "straight".into(),
            Road::Arc(r) => format!("R {r:.0} m"),
        }
    }
}

/// One cut-in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Case {
    /// The ego's speed, km/h.
    pub ego_kmh: f64,
    /// How much slower the car is, km/h (0: equally fast).
    pub slower_kmh: f64,
    /// Bumper-to-bumper gap when the lane change starts, m.
    pub gap: f64,
    /// Duration of the lane change, s.
    pub duration: f64,
    /// The road.
    pub road: Road,
    /// The impairment.
    pub impairment: Impairment,
}

impl Case {
    /// `"100 -> 70 km/h, 30 m, 2.5 s, straight, default sensor"`.
    pub fn label(&self) -> String {
        format!(
            "{} -> {} km/h, {} m, {} s, {}, {}",
            self.ego_kmh,
            self.ego_kmh - self.slower_kmh,
            self.gap,
            self.duration,
            self.road.name(),
            self.impairment.name()
        )
    }

    /// The scenario with `controller`.
    pub fn scenario(&self, controller: ControllerKind) -> Result<Scenario, SimError> {
        let len = VehicleParams::default().length;
        let car_kmh = self.ego_kmh - self.slower_kmh;
        // The car's rear bumper `gap` ahead of the ego's front bumper at the lane change's start.
        let lead_s = EGO_S + len + self.gap + self.slower_kmh * KMH * BEFORE;
        let text = format!(
            r#"
name = "cut-in-grid"
controller = "{controller}"
duration = {run}

[track]
kind = "custom"
name = "straight"
centerline = [[0.0, 0.0], [6000.0, 0.0]]
lane_width = {LW}
objects = []
lanes = 2
ego_lane = 0

[lead]
initial_speed = {car}
phases = []
s = {lead_s}
offset = {LW}

[lead.vehicle]
width = 1.85

[follower]
initial_speed = {ego}
start_s = {EGO_S}
lane_keeping = true

[v2v]
enabled = false

# The careful driver cruises at the ego's speed (its own desired speed would slow it down).
[careful_driver.normal]
desired_speed = {ego}

[story]
dynamics = "kinematic"
ego = "controller"

[[story.acts]]
name = "CutInAct"

[story.acts.start]
kind = "simulation_time"
value = 0.0
rule = "greater_than"

[[story.acts.groups]]
name = "IntruderGroup"
actors = ["lead"]

[[story.acts.groups.maneuvers]]
name = "IntruderManeuver"

[[story.acts.groups.maneuvers.events]]
name = "ChangeIn"
priority = "override"
max_executions = 1

[story.acts.groups.maneuvers.events.start]
kind = "simulation_time"
value = {BEFORE}
rule = "greater_than"

[[story.acts.groups.maneuvers.events.actions]]
name = "ChangeInAction"
kind = "lane_change"
of = "ego"
lanes = 0
shape = "sinusoidal"
dimension = "time"
value = {duration}
"#,
            controller = controller.as_str(),
            // Long enough to settle behind the car after the lane change.
            run = BEFORE + self.duration + 16.0,
            car = car_kmh * KMH,
            ego = self.ego_kmh * KMH,
            duration = self.duration,
        );
        let mut s = Scenario::from_toml_str(&text, "cut-in-grid")?;
        if let Road::Arc(radius) = self.road {
            // 20 m straight, then the arc (1.6 km of it: the longest run covers about 900 m).
            let track = Track::from_plan("arc", &[(20.0, radius, 1600.0 / radius)], 2.0).with_lanes(2, 0);
            s.track = TrackSpec::Custom(track);
        }
        Ok(s.patched(&self.impairment.patch())?)
    }
}

/// The grid's axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Ego speeds, km/h.
    pub ego_kmh: Vec<f64>,
    /// How much slower the car is, km/h (cases where the car would not be faster than 0 are
    /// left out).
    pub slower_kmh: Vec<f64>,
    /// Gaps at the lane change's start, m.
    pub gaps: Vec<f64>,
    /// Lane-change durations, s.
    pub durations: Vec<f64>,
    /// Roads.
    pub roads: Vec<Road>,
    /// Impairments.
    pub impairments: Vec<Impairment>,
}

impl Grid {
    /// The corners and middles of the issue's ranges (the test's grid).
    pub fn small() -> Self {
        Self {
            ego_kmh: vec![30.0, 80.0, 130.0],
            slower_kmh: vec![0.0, 20.0, 40.0],
            gaps: vec![5.0, 15.0, 30.0, 60.0],
            durations: vec![1.5, 3.0, 5.0],
            roads: vec![Road::Straight, Road::Arc(1000.0)],
            impairments: Impairment::ALL.to_vec(),
        }
    }

    /// A finer grid over the same ranges (the report's).
    pub fn full() -> Self {
        Self {
            ego_kmh: vec![30.0, 50.0, 70.0, 90.0, 110.0, 130.0],
            slower_kmh: vec![0.0, 10.0, 20.0, 30.0, 40.0],
            gaps: vec![5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0],
            durations: vec![1.5, 2.5, 3.5, 5.0],
            roads: vec![Road::Straight, Road::Arc(1000.0)],
            impairments: Impairment::ALL.to_vec(),
        }
    }

    /// Every case, in axis order.
    pub fn cases(&self) -> Vec<Case> {
        let mut out = Vec::new();
        for &impairment in &self.impairments {
            for &road in &self.roads {
                for &ego_kmh in &self.ego_kmh {
                    for &slower_kmh in self.slower_kmh.iter().filter(|&&d| ego_kmh - d > 0.0) {
                        for &gap in &self.gaps {
                            for &duration in &self.durations {
                                out.push(Case { ego_kmh, slower_kmh, gap, duration, road, impairment });
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// One case's outcome.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// The careful driver's metrics.
    pub reference: Metrics,
    /// The law's metrics.
    pub law: Metrics,
}

impl Outcome {
    /// The law has contact where the careful driver has none.
    pub fn fails(&self) -> bool {
        self.law.collision && !self.reference.collision
    }
}

/// Runs every case of `cases` with `law` and with the careful driver (in parallel).
pub fn run_grid(cases: &[Case], law: ControllerKind, options: &RunOptions<'_>) -> Result<Vec<Outcome>, SimError> {
    let reference = ControllerKind::CarefulDriver;
    let mut scenarios = Vec::with_capacity(2 * cases.len());
    for c in cases {
        scenarios.push(c.scenario(reference)?);
        scenarios.push(c.scenario(law)?);
    }
    let results = options.run_batch(&scenarios);
    let mut out = Vec::with_capacity(cases.len());
    let mut it = results.into_iter();
    for &case in cases {
        let (Some(r), Some(l)) = (it.next(), it.next()) else { break };
        out.push(Outcome { case, reference: r?.metrics, law: l?.metrics });
    }
    Ok(out)
}

/// The Markdown table of `outcomes` of `law`: per impairment, the cases, those where the careful
/// driver has contact, those where the law has contact, and those of them the careful driver
/// avoids; then the cases the careful driver does not avoid (its bound) and the failures.
pub fn table(law: ControllerKind, outcomes: &[Outcome]) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "| impairment | cases | careful driver: contact | {0}: contact | {0}: contact the careful driver avoids | {0}: largest deceleration, m/s² |\n|---|---:|---:|---:|---:|---:|\n",
        law.as_str()
    ));
    let mut imps: Vec<Impairment> = Vec::new();
    for o in outcomes {
        if !imps.contains(&o.case.impairment) {
            imps.push(o.case.impairment);
        }
    }
    for imp in imps {
        let of: Vec<&Outcome> = outcomes.iter().filter(|o| o.case.impairment == imp).collect();
        let count = |f: &dyn Fn(&Outcome) -> bool| of.iter().filter(|o| f(o)).count();
        let max_decel = of.iter().map(|o| o.law.max_decel).fold(0.0, f64::max);
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.2} |\n",
            imp.name(),
            of.len(),
            count(&|o| o.reference.collision),
            count(&|o| o.law.collision),
            count(&|o| o.fails()),
            max_decel
        ));
    }
    s
}

/// The bound where the careful driver has contact: for each ego speed, car speed and lane-change
/// duration (over roads and impairments), the largest gap with contact; one Markdown table,
/// rows `ego -> car`, columns the durations.
pub fn bound_table(outcomes: &[Outcome]) -> String {
    let mut egos: Vec<(f64, f64)> = Vec::new();
    let mut durs: Vec<f64> = Vec::new();
    for o in outcomes {
        let k = (o.case.ego_kmh, o.case.slower_kmh);
        if !egos.contains(&k) {
            egos.push(k);
        }
        if !durs.contains(&o.case.duration) {
            durs.push(o.case.duration);
        }
    }
    let mut s = String::from("| ego -> car, km/h |");
    for d in &durs {
        s.push_str(&format!(" {d} s |"));
    }
    s.push_str("\n|---|");
    s.push_str(&"---:|".repeat(durs.len()));
    s.push('\n');
    for (ego, slower) in egos {
        s.push_str(&format!("| {ego} -> {} |", ego - slower));
        for &d in &durs {
            let worst = outcomes
                .iter()
                .filter(|o| o.case.ego_kmh == ego && o.case.slower_kmh == slower && o.case.duration == d && o.reference.collision)
                .map(|o| o.case.gap)
                .fold(f64::NEG_INFINITY, f64::max);
            if worst.is_finite() {
                s.push_str(&format!(" ≤ {worst} m |"));
            } else {
                s.push_str(" none |");
            }
        }
        s.push('\n');
    }
    s
}
