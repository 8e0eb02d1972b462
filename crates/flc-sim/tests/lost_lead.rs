//! Issue 23: following through the curves of the paper's route, what the follower steers when it
//! loses the lead (`[follower] lost_lead_steering`), and closing in from far behind at motorway
//! speeds.

use flc_sim::{ControllerKind, LostLeadSteering, Phase, RunResult, Scenario, TrackSpec, run};

const KMH: f64 = 1.0 / 3.6;

fn curvy_follow() -> Scenario {
    Scenario::from_file(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/curvy-follow.toml")))
        .expect("scenarios/curvy-follow.toml")
}

/// The follower alone on the curvy route, starting at 80 km/h 16 m into the right-hand arc of
/// radius 150 m (s 664 .. 900 m) with its only "lead" standing 600 m further on, out of the
/// LiDAR's (and any detector's) reach: it sees no lead from the start and the FLC brakes it to a
/// stop, some 80 m along the arc.
fn alone_on_the_curve(steering: LostLeadSteering) -> RunResult {
    let mut s = Scenario { name: "lost-on-curve".into(), controller: ControllerKind::Flc, duration: 20.0, ..Default::default() };
    s.track = TrackSpec::Curvy;
    s.v2v.enabled = false;
    s.follower.start_s = Some(680.0);
    s.follower.start_offset = 0.4;
    s.follower.initial_speed = 80.0 * KMH;
    s.follower.lost_lead_steering = steering;
    s.lead.s = Some(1280.0);
    s.lead.initial_speed = 0.0;
    s.lead.phases = vec![Phase::Hold { until_x: None, until_t: Some(1e4), duration: None }.into()];
    run(&s).expect("run")
}

/// (a) No lead in view on a curve: with `hold_lane` (the default) the follower stays in its lane
/// (within 0.8 m of the lane centre: the car, 1.8 m wide, inside its 3.5 m lane) and touches nothing;
/// with `straight` (steering 0) the same run drifts more than 1.5 m off the centre, over the lane
/// line (so the check can fail).
#[test]
fn lost_lead_on_a_curve_holds_the_lane() {
    let r = alone_on_the_curve(LostLeadSteering::HoldLane);
    let s = &r.series;
    assert!(s.detected_distance.iter().all(|d| d.is_nan()), "a lead was detected");
    let travelled = (s.follower_x[s.len() - 1] - s.follower_x[0]).hypot(s.follower_y[s.len() - 1] - s.follower_y[0]);
    assert!(travelled > 40.0, "only {travelled:.1} m along the curve");
    let max_lat = s.lateral_offset.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    eprintln!("hold_lane: {travelled:.1} m travelled, max |lateral offset| {max_lat:.2} m");
    assert!(max_lat < 0.8, "max |lateral offset| {max_lat:.2} m");
    assert!(!r.metrics.collision, "{:?}", r.collision);

    let straight = alone_on_the_curve(LostLeadSteering::Straight);
    let max_lat = straight.series.lateral_offset.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    eprintln!("straight: max |lateral offset| {max_lat:.2} m");
    assert!(max_lat > 1.5, "steering straight stayed within {max_lat:.2} m of the centre");
}

/// (a') The lead lost in the shipped example (out of the last right-hand curve, ~112.6 s, where
/// the old detector rejects the obliquely seen car as too wide): the follower holds the lane
/// (never more than 1.2 m off the centre, which pure pursuit of the lead cuts by ~1 m in the
/// 120 m curve), finds the lead again and ends at standstill behind it without contact.
#[test]
fn curvy_follow_ends_without_contact() {
    let r = run(&curvy_follow()).expect("run");
    assert!(!r.metrics.collision, "{:?}", r.collision);
    assert!(r.metrics.final_clearance.is_some_and(|c| c > 2.0), "{:?}", r.metrics.final_clearance);
    let max_lat = r.series.lateral_offset.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    assert!(max_lat < 1.2, "max |lateral offset| {max_lat:.2} m");
}

/// Runs curvy-follow with the lead at `kmh` and checks (b): no collision, and the lead detected
/// in at least 99 % of the steps from 1 s to the lead's stop, with no gap longer than 0.5 s.
fn keeps_the_lead_through_every_curve(kmh: f64) {
    let mut s = curvy_follow();
    s.name = format!("curvy-follow-{kmh}");
    match &mut s.lead.phases[0].phase {
        Phase::Accelerate { speed_kmh, .. } => *speed_kmh = Some(kmh),
        p => panic!("curvy-follow's first lead phase changed: {p:?}"),
    }
    let r = run(&s).expect("run");
    let m = &r.metrics;
    let sr = &r.series;
    assert!(!m.collision, "{kmh} km/h: {:?}", r.collision);
    // The lead's stop: the first step after 10 s at standstill.
    let stop = (0..sr.len()).find(|&i| sr.t[i] > 10.0 && sr.lead_speed[i] < 0.05).expect("the lead stops");
    let first = sr.t.iter().position(|&t| t >= 1.0).expect("t");
    let (mut seen, mut longest, mut since) = (0usize, 0.0_f64, None::<f64>);
    for i in first..=stop {
        if sr.detected_distance[i].is_nan() {
            let t0 = *since.get_or_insert(sr.t[i]);
            longest = longest.max(sr.t[i] - t0);
        } else {
            seen += 1;
            since = None;
        }
    }
    let share = seen as f64 / (stop + 1 - first) as f64;
    assert!(
        share >= 0.99 && longest <= 0.5,
        "{kmh} km/h: lead detected in {:.1} % of the steps to its stop ({:.1} s), longest loss {longest:.2} s",
        100.0 * share,
        sr.t[stop]
    );
}

/// (b) At 50 km/h (the shipped example).
#[test]
fn curvy_follow_keeps_the_lead_at_50_kmh() {
    keeps_the_lead_through_every_curve(50.0);
}

/// (b) At 80 km/h. Needs a detector that sees the lead more than 6 m to the side (the grid of
/// the detector of Sec. III-A.1 is +-6 m wide in the sensor's frame, and in the 150 m curve the
/// lead, ~36 m ahead, is ~6.7 m to the side).
#[test]
fn curvy_follow_keeps_the_lead_at_80_kmh() {
    keeps_the_lead_through_every_curve(80.0);
}

/// (c) Ego and lead at the same speed on a straight, the ego twice its law's desired gap behind
/// (the law's own `desired_gap`): after 200 s the gap is within 0.25 m of the desired gap. The
/// LiDAR is stated (200 m range, 0.1 deg) so the lead is in range from the start.
fn closes_in(controller: ControllerKind, kmh: f64) {
    let v = kmh * KMH;
    let mut s = Scenario { name: format!("close-in-{}-{kmh}", controller.as_str()), controller, duration: 200.0, ..Default::default() };
    s.track = TrackSpec::Straight { length: 8000.0 };
    s.v2v.enabled = false;
    s.lidar.max_range = 200.0;
    s.lidar.resolution_deg = 0.1;
    s.lead.initial_speed = v;
    s.lead.phases = vec![Phase::Hold { until_x: None, until_t: Some(1e4), duration: None }.into()];
    let desired0 = s.base_follower_config().longitudinal().expect("law").desired_gap(v);
    s.follower.initial_speed = v;
    s.follower.initial_gap = 2.0 * desired0;
    let r = run(&s).expect("run");
    assert!(!r.metrics.collision, "{}: {:?}", s.name, r.collision);
    let sr = &r.series;
    let n = sr.len() - 1;
    let (gap, desired) = (sr.gap[n], sr.desired_gap[n]);
    // Within 0.25 m: the laws regulate the detector's distance, a few cm short of the bumper gap,
    // and are still closing the last centimetres (measured after 200 s: FLC -0.201 / +0.071 m,
    // robust FLC +0.085 / +0.071 m at 100 / 130 km/h; the paper FLC swings slowly about its
    // desired gap: +0.250 m at 100 km/h after 150 s once its first frames, before the lead is
    // detected, cruise instead of braking, issue 46). The 10 % this replaced allowed 4.5-5.7 m.
    assert!(
        (gap - desired).abs() <= 0.25,
        "{}: start gap {:.1} m (2 x {desired0:.1}), end gap {gap:.3} m vs desired {desired:.3} m at {:.1} km/h",
        s.name,
        2.0 * desired0,
        sr.follower_speed[n] / KMH
    );
}

#[test]
fn flc_closes_in_from_twice_its_gap_at_100_and_130_kmh() {
    for kmh in [100.0, 130.0] {
        closes_in(ControllerKind::Flc, kmh);
    }
}

#[test]
fn flc_robust_closes_in_from_twice_its_gap_at_100_and_130_kmh() {
    for kmh in [100.0, 130.0] {
        closes_in(ControllerKind::FlcRobust, kmh);
    }
}
