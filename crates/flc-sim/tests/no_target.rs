//! No target is not an emergency (issue 46): every controller of the registry, with nothing in
//! its path and nothing ever detected, drives on at its set speed (the ACC convention, ISO 15622)
//! and never stops more than 50 m short of anything: on a straight road and on an arc of
//! R = 1000 m (the published ALKS roads), with nothing ahead, with a standing car beyond the
//! LiDAR's range in its lane, and with a standing car in the next lane.

use flc_sim::{ControllerKind, Phase, RunResult, Scenario, Track, TrackSpec, run};

const KMH: f64 = 1.0 / 3.6;
/// The set speed (and initial speed) of the ego, m/s.
const V_SET: f64 = 80.0 * KMH;
/// The lane width, m.
const LW: f64 = 3.5;
/// Where the ego starts, m along the centreline.
const EGO_S: f64 = 100.0;
/// The acceptance line: no stop more than this short of anything, m.
const FAR_STOP: f64 = 50.0;

/// The roads: straight, and a 50 m straight then 1000 m of arc of R = 1000 m turning left, then a
/// straight; two lanes, the ego's (0) and one to its left.
fn roads() -> [(&'static str, TrackSpec); 2] {
    [
        ("straight", TrackSpec::Custom(Track::from_plan("straight", &[(1500.0, 1.0, 0.0)], 2.0).with_lanes(2, 0))),
        ("R = 1000 m", TrackSpec::Custom(Track::from_plan("arc", &[(50.0, 1000.0, 1.0), (300.0, 1.0, 0.0)], 2.0).with_lanes(2, 0))),
    ]
}

/// The ego (`controller`, lane keeping, no V2V) at 80 km/h; the lead standing `ahead` m further
/// along the road, `offset` m left of the ego lane's centre (`ahead < 0`: behind the ego, nothing
/// ahead). Every controller's set speed is 80 km/h.
fn fixture(track: &TrackSpec, controller: ControllerKind, ahead: f64, offset: f64) -> Scenario {
    let mut s = Scenario { name: "no-target".into(), controller, duration: 30.0, ..Default::default() };
    s.track = track.clone();
    s.v2v.enabled = false;
    s.follower.start_s = Some(EGO_S);
    s.follower.initial_speed = V_SET;
    s.follower.lane_keeping = true;
    let mut sections = s.sections();
    for k in ControllerKind::ALL {
        k.set_cruise_speed(&mut sections, V_SET);
    }
    s.set_sections(sections);
    s.lead.s = Some(EGO_S + ahead);
    s.lead.offset = offset;
    s.lead.initial_speed = 0.0;
    s.lead.phases = vec![Phase::Stand { duration: None }.into()];
    s
}

/// Every gap-based metric is >= 0 unless a contact happened (the gap is to the vehicle in path;
/// none: no gap).
fn gaps_non_negative(r: &RunResult, tag: &str) {
    let m = &r.metrics;
    if m.collision {
        return;
    }
    assert!(r.series.gap.iter().all(|g| g.is_nan() || *g >= 0.0), "{tag}: a negative gap without contact");
    assert!(m.min_gap.is_nan() || m.min_gap >= 0.0, "{tag}: min_gap {}", m.min_gap);
    assert!(m.min_ttc.is_none_or(|x| x >= 0.0) && m.min_time_headway.is_none_or(|x| x >= 0.0), "{tag}: {m:?}");
    assert!(m.tet >= 0.0 && m.tit >= 0.0 && m.max_drac >= 0.0, "{tag}: {m:?}");
}

/// Where the run ends: the ego's position along the road (m), its final speed and its lowest.
fn end(r: &RunResult, track: &TrackSpec) -> (f64, f64, f64) {
    let TrackSpec::Custom(t) = track else { unreachable!("custom tracks only") };
    let s = &r.series;
    let n = s.len();
    let at = t.project(s.follower_x[n - 1], s.follower_y[n - 1]).s;
    (at, s.follower_speed[n - 1], s.follower_speed.iter().copied().fold(f64::INFINITY, f64::min))
}

#[test]
fn with_nothing_ahead_every_controller_holds_its_set_speed() {
    for (road, track) in roads() {
        for &k in ControllerKind::ALL {
            let tag = format!("{road}: {}", k.as_str());
            let r = run(&fixture(&track, k, -60.0, 0.0)).expect("run");
            gaps_non_negative(&r, &tag);
            assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
            assert!(r.series.gap.iter().all(|g| g.is_nan()), "{tag}: something in path");
            let (_, last, lowest) = end(&r, &track);
            assert!(lowest > 0.95 * V_SET && last > 0.95 * V_SET, "{tag}: lowest {lowest:.2} m/s, last {last:.2} m/s");
        }
    }
}

#[test]
fn a_target_beyond_range_is_driven_to_not_stopped_for() {
    let ahead = 400.0;
    for (road, track) in roads() {
        for &k in ControllerKind::ALL {
            let tag = format!("{road}: {}", k.as_str());
            let mut sc = fixture(&track, k, ahead, 0.0);
            sc.duration = 60.0;
            let r = run(&sc).expect("run");
            gaps_non_negative(&r, &tag);
            let TrackSpec::Custom(t) = &track else { unreachable!("custom tracks only") };
            // Centre to centre less the half lengths: the bumper gap along the road.
            let half = 0.5 * (sc.follower.vehicle.length + sc.lead.vehicle.length);
            let short = |i: usize| EGO_S + ahead - t.project(r.series.follower_x[i], r.series.follower_y[i]).s - half;
            let (_, last, _) = end(&r, &track);
            let n = r.series.len();
            eprintln!("{tag}: ends {:.1} m short at {last:.2} m/s, collision {}", short(n - 1), r.collision.is_some());
            // The target comes into range: every controller detects it before the end.
            assert!(r.series.detected_distance.iter().any(|d| d.is_finite()), "{tag}: never detected");
            // Never at rest far short of it, and at the end at it (or in contact with it).
            let far = (0..n).find(|&i| r.series.follower_speed[i] < 0.1 && short(i) > FAR_STOP);
            assert!(far.is_none(), "{tag}: at rest {:.1} m short at step {far:?}", far.map_or(0.0, short));
            assert!(r.collision.is_some() || short(n - 1) < FAR_STOP, "{tag}: ends {:.1} m short", short(n - 1));
        }
    }
}

#[test]
fn a_standing_car_in_the_next_lane_is_passed() {
    let ahead = 300.0;
    for (road, track) in roads() {
        for &k in ControllerKind::ALL {
            let tag = format!("{road}: {}", k.as_str());
            let r = run(&fixture(&track, k, ahead, LW)).expect("run");
            gaps_non_negative(&r, &tag);
            assert!(r.collision.is_none(), "{tag}: {:?}", r.collision);
            let (at, last, lowest) = end(&r, &track);
            assert!(at > EGO_S + ahead + 50.0, "{tag}: ends at {:.1} m, the car at {:.1} m", at, EGO_S + ahead);
            assert!(lowest > 0.95 * V_SET && last > 0.95 * V_SET, "{tag}: lowest {lowest:.2} m/s, last {last:.2} m/s");
        }
    }
}
