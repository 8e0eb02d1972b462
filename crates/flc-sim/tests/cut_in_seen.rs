//! Cut-ins seen coming (issue 47): flc-robust follows a car from the next lane once it has moved
//! towards the ego's path by more than the wandering zone (`flc_core::NeighbourTracker`), not only
//! once the detector finds it in the path.

use flc_sim::{ControllerKind, RunResult, Scenario, VehicleParams, run};

const KMH: f64 = 1.0 / 3.6;
/// The lane width, m.
const LW: f64 = 3.5;
/// Where the ego starts, m along the centreline.
const EGO_S: f64 = 100.0;

/// The ego (`controller`, keeping its lane) at `ego_kmh`; a 1.85 m wide car at `car_kmh` in the
/// next lane, its rear bumper `gap` m ahead of the ego's front bumper when it starts (at 2 s) a
/// sinusoidal lane change into the ego's lane taking `duration` s (a scripted story, kinematic:
/// the car follows the profile exactly), then holds its speed.
fn cut_in(controller: ControllerKind, ego_kmh: f64, car_kmh: f64, gap: f64, duration: f64) -> Scenario {
    let (ego_len, car_len) = (VehicleParams::default().length, VehicleParams::default().length);
    let lead_s = EGO_S + 0.5 * (ego_len + car_len) + gap - (car_kmh - ego_kmh) * KMH * BEFORE;
    let text = format!(
        r#"
name = "cut-in-seen"
controller = "{controller}"
duration = 20.0

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
        car = car_kmh * KMH,
        ego = ego_kmh * KMH,
    );
    Scenario::from_toml_str(&text, "cut-in-seen").expect("scenario")
}

/// When the lane change starts, s.
const BEFORE: f64 = 2.0;

/// When the controller was first given a distance (the tracker's or the detector's): the time
/// (s into the run) and how far the car's centre had then come from its lane's centre, m.
fn first_seen(r: &RunResult) -> Option<(f64, f64)> {
    let s = &r.series;
    s.detected_distance.iter().position(|d| d.is_finite()).map(|i| (s.t[i], LW - s.lead_y[i]))
}

/// The two cases measured on main (issue 47): ego 100 km/h, a car at 70 km/h cutting in 30 m
/// ahead in 2.5 s (contact at 5.7 m/s: first detection 2.36 s into the lane change), and 130 ->
/// 90 km/h from 40 m (contact at 8.7 m/s). In this fixture (the car follows the sinusoid
/// exactly) those two had no contact before the tracker either (first seen 1.26 s into the lane
/// change, 1.75 m from its lane's centre); the same two closer, from 12 m and 20 m, had contact at
/// 6.0 and 2.0 m/s. With the neighbour tracker flc-robust is given the car once
/// its near edge has come 0.75 m towards the path, and has no contact; so has its odometry
/// variant.
#[test]
fn flc_robust_sees_the_measured_cut_ins_coming() {
    for controller in [ControllerKind::FlcRobust, ControllerKind::FlcRobustOdo] {
        for (ego, car, gap) in [(100.0, 70.0, 30.0), (130.0, 90.0, 40.0), (100.0, 70.0, 12.0), (130.0, 90.0, 20.0)] {
            let before = BEFORE;
            let r = run(&cut_in(controller, ego, car, gap, 2.5)).expect("run");
            let tag = format!("{}: {ego} -> {car} km/h from {gap} m", controller.as_str());
            let (t, moved) = first_seen(&r).expect("seen");
            let min_gap = r.series.gap.iter().copied().filter(|g| g.is_finite()).fold(f64::INFINITY, f64::min);
            eprintln!(
                "{tag}: first seen {:.2} s into the lane change, the car {moved:.2} m from its lane's centre; min gap {min_gap:.2} m, {:?}",
                t - before,
                r.collision
            );
            assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
            // Its near edge 0.75 m towards the path (twice the wandering zone from the middle of
            // its band); the body turning towards the lane brings the edge in a little sooner.
            assert!(moved > 0.4 && moved < 0.9, "{tag}: first seen {moved:.2} m into the lane change");
        }
    }
}

/// No false cut-ins (a short stand-in for issue 47's hour of traffic): a car weaving ±0.3 m in
/// the next lane 25 m ahead at the ego's speed, and a car overtaking in the next lane from 30 m
/// behind at 30 km/h more: flc-robust is never given a distance and drives exactly as with the
/// car starting far behind and slower (never in view).
#[test]
fn flc_robust_takes_no_weaving_or_overtaking_neighbour_for_a_cut_in() {
    let weave: String = (0..12)
        .map(|k| {
            let o = if k % 2 == 0 { LW - 0.3 } else { LW + 0.3 };
            format!("[[lead.phases]]\nkind = \"lane_change\"\noffset = {o}\nduration = 2.0\n")
        })
        .collect();
    let scenario = |ahead: f64, car_kmh: f64, phases: &str| {
        let text = format!(
            r#"
name = "neighbour"
controller = "flc-robust"
duration = 24.0

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
s = {s}
offset = {LW}
{phases}
[follower]
initial_speed = {ego}
start_s = {EGO_S}
lane_keeping = true

[v2v]
enabled = false
"#,
            car = car_kmh * KMH,
            s = EGO_S + ahead,
            ego = 100.0 * KMH,
        );
        run(&Scenario::from_toml_str(&text, "neighbour").expect("scenario")).expect("run")
    };
    let alone = scenario(-500.0, 60.0, "");
    for (what, r) in [("weaving", scenario(25.0, 100.0, &weave)), ("overtaking", scenario(-30.0, 130.0, ""))] {
        assert!(r.collision.is_none(), "{what}: {:?}", r.collision);
        let seen = r.series.detected_distance.iter().filter(|d| d.is_finite()).count();
        assert_eq!(seen, 0, "{what}: given a distance in {seen} steps");
        assert_eq!(r.series.follower_speed, alone.series.follower_speed, "{what}: changed the ego's speed");
    }
}
