//! What is in the ego's path on curved roads (issue 46): fixtures of the project's own on arcs of
//! R = 250 and 1000 m turning left and right (two 3.5 m lanes: the ego's and one to its left),
//! with a standing car and a standing motorbike on the lane centre and on the lane marking, a
//! lead weaving ±0.3 m within its lane, a car steady in the next lane, a cut-in and a cut-out.
//! The careful driver (R157's reference, seeing the ground truth through `sim/path.rs`) must
//! brake for what is in its path and ignore the weave and the neighbour; flc-robust (through its
//! LiDAR) must never pass an in-path object with less than the corridor's margin; both keep their
//! lane within [`lane_tolerance`].

mod common;

use common::two_lanes::{KMH, LW, Road, ahead_for_gap, lane_change, lateral_move, two_lanes};
use flc_sim::{BodyKind, ControllerKind, Phase, RunResult, Scenario, ScriptedVehicle, Track, VehicleParams, run};

fn car() -> VehicleParams {
    VehicleParams::default()
}

fn motorbike() -> VehicleParams {
    VehicleParams { length: 2.2, width: 0.8, wheelbase: 1.5, ..VehicleParams::default() }
}

/// The standing objects: what, its body, its offset from the ego lane's centre (m, + left).
fn standing_objects() -> [(&'static str, VehicleParams, f64); 8] {
    [
        ("car on the lane centre", car(), 0.0),
        // Its body 0.25 m into the lane (1.5 m from its centre, 0.55 m from an ego's body on
        // the centre: ALKS 4.2_2's partially blocking target), either side.
        ("car reaching 0.25 m into the lane from the left", car(), LW / 2.0 - 0.25 + 0.5 * car().width),
        ("car reaching 0.25 m into the lane from the right", car(), -LW / 2.0 + 0.25 - 0.5 * car().width),
        // Its body 1.2 m from the lane's centre: 0.25 m from an ego's on the centre.
        ("car half on the left marking", car(), 1.2 + 0.5 * car().width),
        ("car half on the right marking", car(), -1.2 - 0.5 * car().width),
        ("motorbike on the lane centre", motorbike(), 0.0),
        ("motorbike on the left marking", motorbike(), LW / 2.0),
        ("motorbike on the right marking", motorbike(), -LW / 2.0),
    ]
}

/// The ego (`controller`) at 80 km/h on the curved `road`; the lead (the object under test)
/// `ahead` m further along the road, `offset` m left of the ego lane's centre, standing (speed 0)
/// or driving `phases` at `speed` (m/s).
fn fixture(road: Road, controller: ControllerKind, lead: (VehicleParams, f64, f64, f64, Vec<Phase>)) -> Scenario {
    let (vehicle, ahead, offset, speed, phases) = lead;
    let mut s = two_lanes(road, controller, 80.0, ahead, offset, 0.0);
    s.name = "in-path".into();
    s.lead.vehicle = vehicle;
    s.lead.initial_speed = speed;
    s.lead.phases =
        if phases.is_empty() { vec![Phase::Stand { duration: None }.into()] } else { phases.into_iter().map(Into::into).collect() };
    s
}

/// A car at 60 km/h steady in the next lane, its centre `ahead` m ahead of the ego's, for 15 s.
fn neighbour(road: Road, controller: ControllerKind, ahead: f64) -> RunResult {
    let mut sc = fixture(road, controller, (car(), ahead, LW, 60.0 * KMH, vec![]));
    sc.lead.phases = vec![Phase::Hold { until_x: None, until_t: Some(1e4), duration: None }.into()];
    sc.duration = 15.0;
    run(&sc).expect("run")
}

/// A lead's weave: ±0.3 m within its lane, 2 s to each side.
fn weave() -> Vec<Phase> {
    (0..8).map(|k| Phase::LaneChange { offset: Some(if k % 2 == 0 { 0.3 } else { -0.3 }), lane: None, duration: 2.0 }).collect()
}

/// A standing object: the careful driver sees it (its detected distance is the true gap), stops
/// short of it and touches nothing.
#[test]
fn careful_driver_stops_for_standing_objects_in_its_lane_and_on_the_marking() {
    for road in Road::curves() {
        for (what, vehicle, offset) in standing_objects() {
            let tag = format!("{road}: {what}");
            let r = run(&fixture(road, ControllerKind::CarefulDriver, (vehicle, 200.0, offset, 0.0, vec![]))).expect("run");
            assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
            let s = &r.series;
            let n = s.len();
            assert!(s.follower_speed[n - 1] < 0.1, "{tag}: still at {:.1} m/s", s.follower_speed[n - 1]);
            let seen = s.detected_distance.iter().filter(|d| d.is_finite()).count();
            assert!(seen > 0, "{tag}: never seen");
            let final_gap = s.gap[n - 1];
            eprintln!("{tag}: stopped {final_gap:.2} m behind it");
            assert!(final_gap > 0.5 && final_gap < 10.0, "{tag}: final gap {final_gap:.2} m");
        }
    }
}

/// A lead at 60 km/h weaving ±0.3 m within its lane (2 s to each side): the careful driver keeps
/// it as the vehicle in front at every control frame (a weave is not a cut-out), follows it and
/// touches nothing.
#[test]
fn careful_driver_keeps_a_weaving_lead() {
    for road in Road::curves() {
        let tag = format!("{road}");
        let mut sc = fixture(road, ControllerKind::CarefulDriver, (car(), 50.0, 0.0, 60.0 * KMH, weave()));
        sc.duration = 18.0;
        let r = run(&sc).expect("run");
        assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
        let s = &r.series;
        let track = road.track();
        let max_lead_t = (0..s.len()).map(|i| track.project(s.lead_x[i], s.lead_y[i]).lateral_offset.abs()).fold(0.0, f64::max);
        assert!(max_lead_t > 0.25, "{tag}: the lead weaves only {max_lead_t:.2} m");
        // Every frame after the first control tick has the lead in front.
        let first = s.detected_distance.iter().position(|d| d.is_finite()).expect("seen");
        assert!(first < 20, "{tag}: first seen at step {first}");
        let lost = s.detected_distance[first..].iter().filter(|d| !d.is_finite()).count();
        assert_eq!(lost, 0, "{tag}: the lead lost in {lost} steps (max |t| of the lead {max_lead_t:.2} m)");
        let min_gap = s.gap.iter().copied().fold(f64::INFINITY, f64::min);
        eprintln!("{tag}: lead weaving up to {max_lead_t:.2} m, min gap {min_gap:.1} m");
        assert!(min_gap > 10.0, "{tag}: min gap {min_gap:.1} m");
    }
}

/// A car at 60 km/h steady in the next lane, 30 m ahead: the careful driver never takes it for
/// the vehicle in front and drives exactly as it does with the same car starting 60 m behind it
/// (never ahead: the same speed at every step, bit for bit), passes it and touches nothing.
#[test]
fn careful_driver_ignores_a_car_in_the_next_lane() {
    for road in Road::curves() {
        let tag = format!("{road}");
        let (r, alone) = (neighbour(road, ControllerKind::CarefulDriver, 30.0), neighbour(road, ControllerKind::CarefulDriver, -60.0));
        assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
        let s = &r.series;
        assert!(s.detected_distance.iter().all(|d| d.is_nan()), "{tag}: the neighbour was taken for the vehicle in front");
        assert_eq!(s.follower_speed, alone.series.follower_speed, "{tag}: the neighbour changed the ego's speed");
        let track = road.track();
        let n = s.len();
        let (e, l) = (track.project(s.follower_x[n - 1], s.follower_y[n - 1]), track.project(s.lead_x[n - 1], s.lead_y[n - 1]));
        assert!(e.s > l.s + 10.0, "{tag}: did not pass it ({:.1} m vs {:.1} m)", e.s, l.s);
    }
}

// ---------------------------------------------------------------------------------------------
// flc-robust through the LiDAR (issue 46): its lead selection's corridor is the ego's swept path
// plus the margin (`detector.swept_half_width`, filled in as the ego's half width + 0.5 m).
// ---------------------------------------------------------------------------------------------

/// The margin the swept-path corridor keeps around the ego's body, m (`sim/path.rs`).
const MARGIN: f64 = 0.5;

/// The fixture driven by flc-robust through its LiDAR, keeping its lane.
fn robust(road: Road, lead: (VehicleParams, f64, f64, f64, Vec<Phase>)) -> Scenario {
    fixture(road, ControllerKind::FlcRobust, lead)
}

/// The smallest lateral clearance (m) between the ego's body and the object's while they overlap
/// along the road (the ego passing it; their bodies' extents across the road, parallel to it),
/// `None` if the ego never comes alongside.
fn passing_clearance(track: &Track, r: &flc_sim::RunResult, object: &VehicleParams) -> Option<f64> {
    let ego = VehicleParams::default();
    let s = &r.series;
    let mut min: Option<f64> = None;
    for i in 0..s.len() {
        let (e, o) = (track.project(s.follower_x[i], s.follower_y[i]), track.project(s.lead_x[i], s.lead_y[i]));
        if (e.s - o.s).abs() < 0.5 * (ego.length + object.length) {
            let c = (e.lateral_offset - o.lateral_offset).abs() - 0.5 * (ego.width + object.width);
            min = Some(min.map_or(c, |m: f64| m.min(c)));
        }
    }
    min
}

/// Standing objects in the lane and on its markings (in the ego's swept path plus 0.5 m: the
/// motorbike on the marking is 1.75 - 0.4 - 0.95 = 0.4 m from the body of an ego on the lane
/// centre): flc-robust never passes one with less than the margin: it stops behind it, touching
/// nothing, or passes it with at least the margin. Before the swept corridor it passed the
/// motorbike on the marking with 0.37 m (R = 1000 m) and 0.52 m (R = 250 m) of clearance; while
/// the lane keeper steered with the lead's wheelbase it ran 0.92 m (R = 250 m) and 0.25 m (R =
/// 1000 m) to the outside of the curve behind a motorbike and passed the one on the inner marking
/// out of its corridor; with its own wheelbase but the corridor not yet turned into the lane's
/// frame it passed that motorbike on R = 250 m with 0.27 m.
#[test]
fn flc_robust_never_passes_an_in_path_object_within_the_margin() {
    let mut passed = 0;
    for road in Road::curves() {
        for (what, vehicle, offset) in standing_objects() {
            let tag = format!("{road}: {what}");
            let r = run(&robust(road, (vehicle, 200.0, offset, 0.0, vec![]))).expect("run");
            assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
            let track = road.track();
            let clearance = passing_clearance(&track, &r, &vehicle);
            let s = &r.series;
            let n = s.len();
            let final_gap = s.gap[n - 1];
            eprintln!("{tag}: final speed {:.2} m/s, gap {final_gap:.2} m, passing clearance {clearance:?}", s.follower_speed[n - 1]);
            match clearance {
                // Passed: only with the margin (the lane keeper holds the ego up to 0.8 m
                // towards the outside of the R = 250 m arc: a motorbike on the inner
                // marking is then 1.2 m from its body, out of its swept path).
                Some(c) => {
                    assert!(c >= MARGIN, "{tag}: passed it with {c:.2} m of clearance");
                    passed += 1;
                }
                None => {
                    assert!(s.follower_speed[n - 1] < 0.1, "{tag}: still at {:.1} m/s", s.follower_speed[n - 1]);
                    assert!(final_gap > 0.5 && final_gap < 15.0, "{tag}: final gap {final_gap:.2} m");
                }
            }
        }
    }
    // An ego holding its lane centre (within `lane_tolerance`) cannot pass any of the 32 with
    // the margin (the motorbike on a marking is 0.4 m from its body, the car half on the marking
    // 0.25 m) and may not pass one reaching into its lane: it stops for every one. Before the
    // corridor was at least the lane (`lane_keeping_half_width`), flc-robust passed the car
    // reaching 0.25 m into the lane with 0.55 m.
    assert_eq!(passed, 0, "{passed} objects passed");
}

/// A lead at 60 km/h weaving ±0.3 m within its lane: flc-robust follows it through the LiDAR
/// and touches nothing; a car steady at 60 km/h in the next lane, 30 m ahead: flc-robust never
/// detects it and drives exactly as with the same car starting 60 m behind it.
#[test]
fn flc_robust_follows_a_weaving_lead_and_ignores_the_next_lane() {
    for road in Road::curves() {
        let tag = format!("{road}");
        let mut sc = robust(road, (car(), 50.0, 0.0, 60.0 * KMH, weave()));
        sc.duration = 18.0;
        let r = run(&sc).expect("run");
        assert!(r.collision.is_none(), "{tag}: weave: {:?}", r.collision);
        let s = &r.series;
        let first = s.detected_distance.iter().position(|d| d.is_finite()).expect("seen");
        let lost = s.detected_distance[first..].iter().filter(|d| !d.is_finite()).count();
        let min_gap = s.gap.iter().copied().fold(f64::INFINITY, f64::min);
        eprintln!("{tag}: weave: lost in {lost} of {} steps, min gap {min_gap:.1} m", s.len() - first);
        assert!(min_gap > 5.0, "{tag}: weave: min gap {min_gap:.1} m");

        let (r, alone) = (neighbour(road, ControllerKind::FlcRobust, 30.0), neighbour(road, ControllerKind::FlcRobust, -60.0));
        assert!(r.collision.is_none(), "{tag}: neighbour: {:?}", r.collision);
        let s = &r.series;
        let seen = s.detected_distance.iter().filter(|d| d.is_finite()).count();
        assert_eq!(seen, 0, "{tag}: the neighbour was detected in {seen} steps");
        assert_eq!(s.follower_speed, alone.series.follower_speed, "{tag}: the neighbour changed the ego's speed");
    }
}

// ---------------------------------------------------------------------------------------------
// Lane keeping, cut-ins and cut-outs on the curves.
// ---------------------------------------------------------------------------------------------

/// The lane-keeping tolerance on `road`: the largest distance of the ego's centre from its
/// lane's centre, m: 50 m / R on an arc (0.2 m at R = 250 m, 0.05 m at R = 1000 m; R157's
/// wandering zone is 0.375 m), 0.01 m on the straight. Within it stays the lane keeper's own
/// offset: pure pursuit of the lane centre steers the body centre of the kinematic bicycle, which
/// moves at the slip angle `beta ~ L / 2R` to the body's heading, so the ego holds a steady
/// 0.13 m (R = 250 m) or 0.03 m (R = 1000 m) to the inside of the curve.
fn lane_tolerance(road: Road) -> f64 {
    match road {
        Road::Straight => 0.01,
        Road::Arc { radius, .. } => 50.0 / radius,
    }
}

/// The largest distance of the ego's centre from its lane's centre (the centreline) in `r`, m.
fn lane_deviation(r: &RunResult) -> f64 {
    r.series.lateral_offset.iter().map(|t| t.abs()).fold(0.0, f64::max)
}

/// Lane keeping through the whole arc (and out of it) at 80 km/h with nothing in the path (a
/// car or a motorbike standing 60 m behind the ego): the careful driver and flc-robust keep the
/// ego within [`lane_tolerance`] of its lane's centre. The lane keeper used to steer with the
/// lead's pure pursuit (the lead's wheelbase and steering limit): behind a motorbike (wheelbase
/// 1.5 m for the ego's 2.9 m) the ego steered half as much as it needed and ran 0.92 m (R = 250
/// m) and 0.25 m (R = 1000 m) to the outside of the curve.
#[test]
fn the_ego_keeps_its_lane_centre_through_the_curves() {
    for road in Road::curves() {
        for controller in [ControllerKind::CarefulDriver, ControllerKind::FlcRobust] {
            for (what, vehicle) in [("car", car()), ("motorbike", motorbike())] {
                let tag = format!("{road}, {}, a {what} behind", controller.as_str());
                let mut sc = fixture(road, controller, (vehicle, -60.0, 0.0, 0.0, vec![]));
                sc.duration = 30.0;
                let r = run(&sc).expect("run");
                assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
                // Through the whole arc and out of it (it ends 550 m ahead of the ego's start).
                let track = road.track();
                let n = r.series.len();
                let end = track.project(r.series.follower_x[n - 1], r.series.follower_y[n - 1]).s;
                assert!(end > 700.0, "{tag}: only at s = {end:.0} m");
                let dev = lane_deviation(&r);
                eprintln!("{tag}: at most {dev:.3} m from the lane centre");
                assert!(dev <= lane_tolerance(road), "{tag}: {dev:.3} m from the lane centre");
            }
        }
    }
}

/// When the lane change of the cut-ins starts, s.
const CUT_IN_AT: f64 = 2.0;

/// A car at 60 km/h in the next lane (left of the ego's: on the inside of a left curve, the
/// outside of a right one) cuts in front of the ego at 80 km/h: a 3 s sinusoidal lane change
/// starting [`CUT_IN_AT`] s into the run, its rear bumper `gap` m ahead of the ego's front bumper
/// then.
fn cut_in(road: Road, controller: ControllerKind, gap: f64) -> RunResult {
    let mut s = two_lanes(road, controller, 80.0, ahead_for_gap(gap, 80.0, 60.0, CUT_IN_AT), LW, 60.0);
    s.duration = 15.0;
    lane_change(&mut s, CUT_IN_AT, 0, 3.0);
    run(&s).expect("run")
}

/// The gaps of the cut-ins when the lane change starts, m.
const CUT_IN_GAPS: [f64; 4] = [5.0, 10.0, 15.0, 30.0];

/// When the controller was first given a distance, s into the run.
fn first_seen(r: &RunResult) -> Option<f64> {
    let s = &r.series;
    s.detected_distance.iter().position(|d| d.is_finite()).map(|i| s.t[i])
}

/// The careful driver on the cut-ins: on every curve it perceives the car at the same frame as
/// on the straight road (its wandering zone is measured relative to the lane, not to its heading
/// line), brakes below the car's speed, keeps its lane, and has contact only where it has
/// contact on the straight road too (a competent driver cannot avoid that cut-in: from 5 m, at
/// about 4.4 m/s), then no harder than 0.5 m/s more. From 10 m on it touches nothing.
#[test]
fn careful_driver_brakes_for_a_cut_in_on_the_curves_as_on_the_straight() {
    for gap in CUT_IN_GAPS {
        let straight = cut_in(Road::Straight, ControllerKind::CarefulDriver, gap);
        let t0 = first_seen(&straight).expect("seen on the straight");
        if gap >= 10.0 {
            assert!(straight.collision.is_none(), "straight, {gap} m: {:?}", straight.collision);
        }
        for road in Road::curves() {
            let tag = format!("{road}, cut-in from {gap} m");
            let r = cut_in(road, ControllerKind::CarefulDriver, gap);
            let t = first_seen(&r).expect("seen");
            let min_v = r.series.follower_speed.iter().copied().fold(f64::INFINITY, f64::min);
            let impact = r.collision.as_ref().map(|c| c.impact_speed);
            eprintln!(
                "{tag}: seen {:.2} s into the lane change (straight {:.2}), slowest {min_v:.2} m/s, contact at {impact:?} m/s (straight {:?})",
                t - CUT_IN_AT,
                t0 - CUT_IN_AT,
                straight.collision.as_ref().map(|c| c.impact_speed)
            );
            assert!((t - t0).abs() <= 0.05, "{tag}: seen at {t:.2} s, on the straight at {t0:.2} s");
            match (&straight.collision, &r.collision) {
                (None, Some(c)) => panic!("{tag}: contact at {:.2} m/s, none on the straight", c.impact_speed),
                (Some(cs), Some(c)) => {
                    assert!(c.impact_speed <= cs.impact_speed + 0.5, "{tag}: {:.2} m/s vs {:.2}", c.impact_speed, cs.impact_speed)
                }
                (_, None) => assert!(min_v < 60.0 * KMH, "{tag}: never below the car's speed ({min_v:.2} m/s)"),
            }
            assert!(lane_deviation(&r) <= lane_tolerance(road), "{tag}: {:.3} m off the lane centre", lane_deviation(&r));
        }
    }
}

/// flc-robust (through its LiDAR and neighbour tracker) on the same cut-ins: wherever the
/// careful driver avoids contact (from 10 m on, every road) it avoids it too and keeps its lane.
/// From 5 m both have contact; not asserted for flc-robust, which then does worse: on the
/// straight and on three of the four curves the car is never given to it before the contact and it
/// hits at 5.4 m/s without braking (the careful driver: 4.0-4.8 m/s).
#[test]
fn flc_robust_avoids_the_cut_ins_the_careful_driver_avoids_on_the_curves() {
    for gap in CUT_IN_GAPS.into_iter().filter(|&g| g >= 10.0) {
        for road in Road::curves() {
            let tag = format!("{road}, cut-in from {gap} m");
            let r = cut_in(road, ControllerKind::FlcRobust, gap);
            let min_gap = r.series.gap.iter().copied().filter(|g| g.is_finite()).fold(f64::INFINITY, f64::min);
            eprintln!("{tag}: seen at {:?} s, min gap {min_gap:.2} m, {:?}", first_seen(&r), r.collision);
            assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
            assert!(first_seen(&r).is_some_and(|t| t < CUT_IN_AT + 3.0), "{tag}: not seen during the lane change");
            assert!(lane_deviation(&r) <= lane_tolerance(road), "{tag}: {:.3} m off the lane centre", lane_deviation(&r));
        }
    }
}

/// When the lead's lane change of the cut-outs starts, s.
const CUT_OUT_AT: f64 = 8.0;

/// A lead at 60 km/h, its centre 60 m ahead of the ego's (80 km/h), leaves the ego's lane for the
/// next one (a 3 s sinusoidal lane change starting [`CUT_OUT_AT`] s into the run) and reveals a
/// car standing in the ego's lane, its centre `reveal` m ahead of the lead's when the change
/// starts. The run and the standing car's centre, m along the road.
fn cut_out(road: Road, controller: ControllerKind, reveal: f64) -> (RunResult, f64) {
    let mut s = two_lanes(road, controller, 80.0, 60.0, 0.0, 60.0);
    let standing = s.lead.s.expect("lead s") + 60.0 * KMH * CUT_OUT_AT + reveal;
    s.vehicles.push(ScriptedVehicle {
        name: "standing".into(),
        vehicle: car(),
        s: standing,
        lane: Some(0),
        offset: None,
        heading: 0.0,
        initial_speed: 0.0,
        phases: Vec::new(),
    });
    lane_change(&mut s, CUT_OUT_AT, 1, 3.0);
    (run(&s).expect("run"), standing)
}

/// After the cut-out the ego keeps its lane (within [`lane_tolerance`]: it does not follow the
/// lead into the next lane) and stops behind the car it revealed, touching nothing; the careful
/// driver and flc-robust, on every curve, with the car revealed 50 and 70 m ahead of the lead.
#[test]
fn after_a_cut_out_the_ego_keeps_its_lane_and_stops_for_what_it_reveals() {
    for controller in [ControllerKind::CarefulDriver, ControllerKind::FlcRobust] {
        for road in Road::curves() {
            for reveal in [50.0, 70.0] {
                let tag = format!("{road}, {}, car revealed {reveal} m ahead of the lead", controller.as_str());
                let (r, standing) = cut_out(road, controller, reveal);
                assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
                let s = &r.series;
                let n = s.len();
                let track = road.track();
                // The vehicle in front at the end is the standing car, in the ego's lane.
                let front = track.project(s.lead_x[n - 1], s.lead_y[n - 1]);
                assert!((front.s - standing).abs() < 0.5 && front.lateral_offset.abs() < 0.1, "{tag}: in front at the end: {front:?}");
                // The lead was followed before it left.
                let followed = s.t.iter().zip(&s.detected_distance).filter(|(t, d)| **t < CUT_OUT_AT && d.is_finite()).count();
                assert!(followed > 0, "{tag}: the lead never seen before the cut-out");
                let dev = lane_deviation(&r);
                let final_gap = s.gap[n - 1];
                eprintln!(
                    "{tag}: stopped {final_gap:.2} m behind it, at most {dev:.3} m off the lane centre, max decel {:.2} m/s²",
                    r.metrics.max_decel
                );
                assert!(dev <= lane_tolerance(road), "{tag}: {dev:.3} m off the lane centre");
                assert!(s.follower_speed[n - 1] < 0.1, "{tag}: still at {:.2} m/s", s.follower_speed[n - 1]);
                assert!(final_gap > 0.5 && final_gap < 10.0, "{tag}: final gap {final_gap:.2} m");
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A pedestrian crossing the lane (issue 46, ALKS 4.2_3): stop for it, drive on once it has left.

/// A pedestrian as the LiDAR sees it: 0.3 m deep, 0.5 m across the shoulders.
fn pedestrian() -> VehicleParams {
    VehicleParams { length: 0.3, width: 0.5, wheelbase: 0.2, mass: 75.0, body: BodyKind::Pedestrian, ..VehicleParams::default() }
}

/// A pedestrian standing 200 m ahead, `from` m off the ego lane's centre, walking to `to` over 20 s
/// from the start (a story's sinusoidal lane change: 0.57 m/s at its fastest, a slow walk): its
/// body is in the ego's lane from about 6 s to 14 s, when the ego is still 60 m away and would
/// arrive after about 9 s. It starts and ends 3.6 m off, more than the lane width less the
/// wandering zone, where the careful driver's lane rule does not take it for a vehicle in its
/// lane. (Entering the lane only 33 m ahead of the ego at 80 km/h, walking 2.6 m from the next
/// lane's far half, it is hit by flc-robust at 6.7 m/s, where the careful driver, who sees it
/// walking towards its path, stops: the LiDAR laws do not anticipate a narrow crossing object.)
fn crossing(road: Road, controller: ControllerKind, from: f64, to: f64) -> RunResult {
    let mut sc = fixture(road, controller, (pedestrian(), 200.0, from, 0.0, vec![]));
    sc.lead.phases = Vec::new();
    sc.duration = 40.0;
    lateral_move(&mut sc, 0.0, 0, to, 20.0);
    run(&sc).expect("run")
}

/// The careful driver, flc-robust, the paper's FLC and the pipeline (the last three share the
/// no-target cruise) brake for a pedestrian crossing the ego's lane, pass it only once its body is
/// out of the lane and drive on to the set speed: the robust FLC's hold-and-brake keeps a lead that *vanished*, but one seen walking
/// out of the path leaves a clear road (`flc_core::LeadDeparture`). Before the departure watch
/// every one of them stood behind the empty lane to the end (ALKS 4.2_3 p119: a far stop).
#[test]
fn a_pedestrian_who_crossed_the_lane_leaves_a_clear_road() {
    let ego = VehicleParams::default();
    for controller in [ControllerKind::CarefulDriver, ControllerKind::FlcRobust, ControllerKind::Flc, ControllerKind::Pipeline] {
        for road in Road::curves() {
            for (from, to) in [(-3.6, 3.6), (3.6, -3.6)] {
                let tag = format!("{controller:?} {road}: walking from {from} to {to} m");
                let r = crossing(road, controller, from, to);
                assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
                let s = &r.series;
                let n = s.len();
                // It braked for the pedestrian (in the lane when the ego came) ...
                let slowest = s.follower_speed.iter().copied().fold(f64::INFINITY, f64::min);
                assert!(slowest < 0.5 * 80.0 * KMH, "{tag}: slowest {slowest:.2} m/s");
                // ... and drove on: back above 60 % of the set speed (80 km/h) by the end, 28 s
                // after the pedestrian left (the careful driver's IDM nears its desired speed
                // slowly; the gap laws cruise at the set speed).
                assert!(s.follower_speed[n - 1] > 0.6 * 80.0 * KMH, "{tag}: final {:.2} m/s", s.follower_speed[n - 1]);
                // Past it only once its body was out of the lane (the ego on its lane's centre
                // within the lane keeper's few centimetres).
                let clearance = passing_clearance(&road.track(), &r, &pedestrian());
                if let Some(c) = clearance {
                    assert!(c >= 0.5 * (LW - ego.width) - 0.1, "{tag}: passed it with {c:.2} m");
                }
                eprintln!("{tag}: slowest {slowest:.2} m/s, final {:.2} m/s, passing clearance {clearance:?}", s.follower_speed[n - 1]);
            }
        }
    }
}
