//! Every shipped example in `scenarios/*.toml` runs here and ends the way its header comment says.
//! `every_scenario_file_has_a_test` fails when a file is added without a test below (the suites
//! in `scenarios/suites/` are run by `tests/golden.rs`'s `standard_suites_report`, which compares
//! each outcome with the committed report, and by `tests/suites.rs`).
//!
//! What a controller does in these scenes compared with another controller belongs to the
//! controllers' tests (`robust_flc.rs`, `closed_loop.rs`, ...); here each file's own outcome is
//! checked, with the file's own controller.

use flc_sim::{ACTIVE_FLC, ACTIVE_PID, ControllerKind, RunResult, Scenario, run};
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios")
}

fn load(name: &str) -> Scenario {
    let p = dir().join(name);
    Scenario::from_file(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn run_file(name: &str) -> (Scenario, RunResult) {
    let s = load(name);
    let r = run(&s).unwrap_or_else(|e| panic!("{name}: {e}"));
    (s, r)
}

/// No contact of the ego and none between any other bodies.
fn no_contact(name: &str, r: &RunResult) {
    assert!(r.collision.is_none() && !r.metrics.collision, "{name}: {:?}", r.collision);
    assert!(r.other_contacts.is_empty(), "{name}: {:?}", r.other_contacts);
}

/// Both at standstill at the end, the ego `clearance` m (±0.05) behind the vehicle in front.
fn stops_at(name: &str, r: &RunResult, clearance: f64) {
    let n = r.series.len();
    assert!(r.series.follower_speed[n - 1] < 0.05, "{name}: ends at {} m/s", r.series.follower_speed[n - 1]);
    let c = r.metrics.final_clearance.unwrap_or(f64::NAN);
    assert!((c - clearance).abs() < 0.05, "{name}: clearance {c} m, header says {clearance} m");
}

/// The first time at or after `t0` when `f(i)` holds.
fn first(r: &RunResult, t0: f64, f: impl Fn(usize) -> bool) -> Option<f64> {
    (0..r.series.len()).find(|&i| r.series.t[i] >= t0 && f(i)).map(|i| r.series.t[i])
}

/// The files the tests below run (sorted; one test per file).
const TESTED: [&str; 10] = [
    "curvy-follow.toml",
    "cut-in.toml",
    "cut-out.toml",
    "highway-three-cars.toml",
    "lead-brakes-on-gap.toml",
    "paper-70-pipeline.toml",
    "platoon-brakedemo.toml",
    "robust-cut-out.toml",
    "traffic-10.toml",
    "v2v-outage.toml",
];

#[test]
fn every_scenario_file_has_a_test() {
    let mut files: Vec<String> = std::fs::read_dir(dir())
        .expect("scenarios/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| p.file_name().expect("name").to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, TESTED, "scenarios/*.toml and the files this test runs");
}

/// "The follower keeps the lead through every curve and stops 4.9 m behind it."
#[test]
fn curvy_follow() {
    let (_, r) = run_file("curvy-follow.toml");
    no_contact("curvy-follow", &r);
    stops_at("curvy-follow", &r, 4.9);
    // The lead is detected on every scan after the first one (the detector keeps it).
    let t0 = 0.2;
    let lost = (0..r.series.len()).filter(|&i| r.series.t[i] > t0 && !r.series.detected_distance[i].is_finite()).count();
    assert_eq!(lost, 0, "curvy-follow: {lost} steps without the lead");
}

/// "The distance the controllers see jumps from ~24 m to ~10 m, and the ego (the robust FLC)
/// drops back", without contact.
#[test]
fn cut_in() {
    let (s, r) = run_file("cut-in.toml");
    assert_eq!(s.controller, ControllerKind::FlcRobust);
    no_contact("cut-in", &r);
    let d = &r.series.detected_distance;
    let before = (0..r.series.len()).filter(|&i| r.series.t[i] > 1.0 && r.series.t[i] < 5.0).map(|i| d[i]);
    assert!(before.clone().all(|x| (x - 24.0).abs() < 1.0), "cut-in: before the cut-in the lead at ~24 m");
    let jump = first(&r, 5.0, |i| d[i] < 12.0).expect("cut-in: the cut-in car is seen");
    assert!(jump < 7.5, "cut-in: seen at {jump} s");
    assert!(r.metrics.min_gap > 9.0 && r.metrics.min_gap < 11.0, "cut-in: min gap {}", r.metrics.min_gap);
    // It drops back: the gap to the car in front is back near the equilibrium 23.8 m at the end.
    let n = r.series.len();
    assert!((r.series.gap[n - 1] - 23.8).abs() < 0.5, "cut-in: final gap {}", r.series.gap[n - 1]);
}

/// "The FLC steers after the lead (pure pursuit) into the left lane and stops 4.8 m behind it;
/// the lead stops behind the parked car without touching it."
#[test]
fn cut_out() {
    let (s, r) = run_file("cut-out.toml");
    assert_eq!(s.controller, ControllerKind::Flc);
    no_contact("cut-out", &r);
    stops_at("cut-out", &r, 4.8);
    let n = r.series.len();
    // In lane 1 (centre 3.5 m left of lane 0's) behind the lead, the lead's front bumper at s = 290 m.
    assert!((r.series.follower_y[n - 1] - 3.5).abs() < 0.2 && (r.series.lead_y[n - 1] - 3.5).abs() < 0.1, "cut-out: not in lane 1");
    let lead_front = r.series.lead_x[n - 1] + s.lead.vehicle.length / 2.0;
    assert!((lead_front - 290.0).abs() < 0.5, "cut-out: the lead's front at {lead_front} m");
}

/// "The passer changes into the ego's lane 15 m in front of it": the ego (the pipeline) brakes,
/// hands over to the FLC (its V2V data describe the lead, not the passer) and follows the passer
/// without contact; the gap never falls below 17 m.
#[test]
fn highway_three_cars() {
    let (s, r) = run_file("highway-three-cars.toml");
    assert_eq!(s.controller, ControllerKind::Pipeline);
    no_contact("highway-three-cars", &r);
    let x = &r.series;
    // The PID drives before the lane change (V2V from the lead), the FLC after it, to the end.
    let cut = first(&r, 1.0, |i| x.gap[i] < 30.0).expect("the passer cuts in");
    assert!(cut > 8.0 && cut < 10.0, "cut-in at {cut} s");
    assert!((0..x.len()).filter(|&i| x.t[i] > 2.0 && x.t[i] < cut - 0.5).all(|i| x.active[i] == ACTIVE_PID));
    assert!((0..x.len()).filter(|&i| x.t[i] > cut + 1.0).all(|i| x.active[i] == ACTIVE_FLC));
    assert!(r.metrics.min_gap > 17.0 && r.metrics.min_gap < 19.0, "min gap {}", r.metrics.min_gap);
}

/// "The pipeline hands over to the FLC and stops; `controller = "pid"` collides."
#[test]
fn lead_brakes_on_gap() {
    let (s, r) = run_file("lead-brakes-on-gap.toml");
    assert_eq!(s.controller, ControllerKind::Pipeline);
    no_contact("lead-brakes-on-gap", &r);
    stops_at("lead-brakes-on-gap", &r, 4.7);
    let n = r.series.len();
    assert_eq!(r.series.active[n - 1], ACTIVE_FLC, "the FLC stops it");
    // The same file with the PID alone: V2V is lost at the brake onset and the PID has nothing
    // else, which the header states as the reason for the fallback (the paper's Sec. IV).
    let mut pid = s.clone();
    pid.controller = ControllerKind::Pid;
    assert!(run(&pid).expect("run").metrics.collision, "lead-brakes-on-gap with the PID");
}

/// "V2V is lost at brake onset": the pipeline hands over to the FLC, which stops it 4.65 m behind
/// the lead without contact.
#[test]
fn paper_70_pipeline() {
    let (s, r) = run_file("paper-70-pipeline.toml");
    assert_eq!(s.controller, ControllerKind::Pipeline);
    no_contact("paper-70-pipeline", &r);
    stops_at("paper-70-pipeline", &r, 4.65);
    let x = &r.series;
    let onset = first(&r, 0.0, |i| x.lead_accel[i] < -3.0).expect("the lead brakes");
    let flc = first(&r, onset, |i| x.active[i] == ACTIVE_FLC).expect("hands over");
    assert!(flc - onset < 0.5, "FLC {} s after the brake onset", flc - onset);
    assert!((0..x.len()).filter(|&i| x.t[i] >= flc).all(|i| x.active[i] == ACTIVE_FLC));
}

/// "Every follower of the three variants stops behind its predecessor without contact."
#[test]
fn platoon_brakedemo() {
    let demo = load("platoon-brakedemo.toml");
    let variants = demo.expand_variants().expect("variants");
    assert_eq!(variants.len(), 3);
    for (v, r) in variants.iter().zip(flc_sim::RunOptions::default().run_batch(&variants)) {
        let r = r.expect("run");
        let name = v.variant.clone().unwrap_or_default();
        let p = r.platoon.as_ref().expect("platoon");
        assert_eq!(p.followers.len(), 7, "{name}");
        for (k, f) in p.followers.iter().enumerate() {
            let c = f.metrics.final_clearance.unwrap_or(f64::NAN);
            assert!(!f.metrics.collision && c > 4.0, "{name}: follower {} collision {} clearance {c}", k + 1, f.metrics.collision);
        }
    }
}

/// "The robust FLC latches the revealed object and stops on its stop envelope", without
/// contact, within the 2-5 m standstill band of issue 24 (the paper's FLC in the same file:
/// `robust_flc.rs`, `scenario_section_and_example_file`).
#[test]
fn robust_cut_out() {
    let (s, r) = run_file("robust-cut-out.toml");
    assert_eq!(s.controller, ControllerKind::FlcRobust);
    no_contact("robust-cut-out", &r);
    // In front of the standing car (rear face at 222.4 - 2.45 m), 2-5 m away at the end.
    let front = s.follower.vehicle.length / 2.0;
    let closest = r.series.follower_x.iter().map(|fx| 222.4 - 2.45 - (fx + front)).fold(f64::INFINITY, f64::min);
    let last = 222.4 - 2.45 - (r.series.follower_x.last().expect("series") + front);
    assert!(closest > 2.0 && (2.0..=5.0).contains(&last), "robust-cut-out: {closest} m to the standing car, {last} m at the end");
    assert!(r.series.follower_speed.iter().rev().take(100).all(|&v| v < 0.1), "robust-cut-out: not stopped");
}

/// "No vehicle touches another (`collision` and `other_contacts` stay empty); the ego brakes for
/// about 0.5 s (up to ~7 m/s²) before the PID takes over."
#[test]
fn traffic_10() {
    let (s, r) = run_file("traffic-10.toml");
    assert_eq!(s.vehicles.len(), 8);
    no_contact("traffic-10", &r);
    let x = &r.series;
    let pid = first(&r, 0.0, |i| x.active[i] == ACTIVE_PID).expect("the PID takes over");
    assert!(pid > 0.3 && pid < 0.7, "PID from {pid} s");
    assert!(r.metrics.max_decel > 6.0 && r.metrics.max_decel < 8.0, "max decel {}", r.metrics.max_decel);
    assert!((0..x.len()).filter(|&i| x.t[i] > pid).all(|i| x.active[i] == ACTIVE_PID), "the PID keeps it");
    assert!(r.series.t[x.len() - 1] > 119.9, "runs the 120 s");
}

/// "V2V drops out for 5 s (30-35 s) and suffers bursty loss throughout. The supervisor switches
/// to the FLC and back", no contact.
#[test]
fn v2v_outage() {
    let (_, r) = run_file("v2v-outage.toml");
    no_contact("v2v-outage", &r);
    let x = &r.series;
    assert!((0..x.len()).filter(|&i| x.t[i] > 30.5 && x.t[i] < 35.0).all(|i| x.active[i] == ACTIVE_FLC), "FLC during the outage");
    assert!(first(&r, 35.0, |i| x.active[i] == ACTIVE_PID).is_some_and(|t| t < 36.0), "back to the PID after the outage");
    // The bursts hand over for short spells; the PID drives most of the run (measured 49.8 of 60 s).
    assert!(r.metrics.time_pid > 40.0 && r.metrics.switches >= 2, "{} s on the PID, {} switches", r.metrics.time_pid, r.metrics.switches);
}
