//! No false cut-ins (issue 47): an hour of three-lane traffic (60 one-minute segments,
//! `flc_sim::neighbour_traffic`: straight roads, R = 1000 m arcs and S-bends; cars steady and
//! weaving +-0.3 m within their lanes, cars overtaking, trucks beside the ego, guard rails and
//! posts) in which nobody leaves its lane. flc-robust and its odometry variant, following a lead
//! in the middle lane, must never change their target away from it, and no neighbour may make
//! them brake harder than 0.5 m/s² beyond what the same segment without neighbours shows. A real
//! cut-in, judged the same way, must count.
//!
//! Measured 2026-12-07 (`cargo test --release -p flc-sim --test false_cut_ins -- --nocapture`):
//! 0 switches and 0 m/s² for both. Before the detector's path profile the S-bends gave 157
//! switches and 8.3 m/s² (the detector's arc of the ego's curvature left the lane where the
//! curvature reversed); with it, and S-bends whose curvature reverses in one step instead of
//! along 120 m clothoids, 4 (3 for the odometry variant) and 7.6 m/s²: the traffic's lane
//! keeper cuts such a reversal by 0.1-0.14 m. With clothoids of 60 m and of 200 m: 0 and 0.

use flc_sim::neighbour_traffic::{cut_in_segment, segment};
use flc_sim::{ControllerKind, RunResult, run};
use rayon::prelude::*;

/// Segments: one hour.
const SEGMENTS: u64 = 60;
/// How far the distance the controller is given may be from the lead's (bumper to bumper, ground
/// truth) before the target counts as another object, m.
const OFF_LEAD: f64 = 1.0;
/// The largest braking a neighbour may cause, m/s².
const MAX_NEIGHBOUR_BRAKING: f64 = 0.5;

/// What a run shows: the changes of target away from the lead (runs of steps where the distance
/// given differs from the lead's by more than [`OFF_LEAD`]), the steps off it, the time of the
/// first change.
#[derive(Debug, Default, Clone, Copy)]
struct Switches {
    count: usize,
    steps: usize,
    first: Option<f64>,
}

fn switches(r: &RunResult) -> Switches {
    let s = &r.series;
    let mut out = Switches::default();
    let mut off = false;
    for i in 0..s.len() {
        let (d, g) = (s.detected_distance[i], s.lead_gap[i]);
        let now = d.is_finite() && (g.is_nan() || (d - g).abs() > OFF_LEAD);
        if now {
            out.steps += 1;
            if !off {
                out.count += 1;
                out.first.get_or_insert(s.t[i]);
            }
        }
        off = now;
    }
    out
}

/// The ego's braking beyond that of the same segment without neighbours at the same time, m/s²
/// (largest over the run; 0 if it never brakes harder).
fn extra_braking(with: &RunResult, alone: &RunResult) -> (f64, f64) {
    let (a, b) = (&with.series, &alone.series);
    let mut worst = (0.0, f64::NAN);
    for i in 0..a.len().min(b.len()) {
        let extra = (-a.follower_accel[i]).max(0.0) - (-b.follower_accel[i]).max(0.0);
        if extra > worst.0 {
            worst = (extra, a.t[i]);
        }
    }
    worst
}

const CONTROLLERS: [ControllerKind; 2] = [ControllerKind::FlcRobust, ControllerKind::FlcRobustOdo];

/// One segment's outcome.
struct Outcome {
    controller: ControllerKind,
    name: String,
    switches: Switches,
    /// The ego's braking beyond the segment's without neighbours (m/s²) and when (s).
    braking: (f64, f64),
    contact: bool,
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn an_hour_of_three_lane_traffic_has_no_false_cut_in() {
    let jobs: Vec<(ControllerKind, u64)> = CONTROLLERS.iter().flat_map(|&c| (0..SEGMENTS).map(move |k| (c, k))).collect();
    let results: Vec<Outcome> = jobs
        .par_iter()
        .map(|&(controller, k)| {
            let sc = segment(k, controller, true);
            let with = run(&sc).expect("run");
            // The braking beyond the segment's without neighbours is at most the braking itself:
            // that segment is run only when the ego brakes harder than the bound.
            let braking = if with.series.follower_accel.iter().all(|a| -a <= MAX_NEIGHBOUR_BRAKING) {
                (0.0, f64::NAN)
            } else {
                extra_braking(&with, &run(&segment(k, controller, false)).expect("run"))
            };
            Outcome { controller, name: sc.name.clone(), switches: switches(&with), braking, contact: with.collision.is_some() }
        })
        .collect();
    let mut failures = Vec::new();
    for c in CONTROLLERS {
        let mine: Vec<&Outcome> = results.iter().filter(|r| r.controller == c).collect();
        let count: usize = mine.iter().map(|r| r.switches.count).sum();
        let steps: usize = mine.iter().map(|r| r.switches.steps).sum();
        let worst = mine.iter().max_by(|a, b| a.braking.0.total_cmp(&b.braking.0)).expect("segments");
        let first = mine.iter().find_map(|r| r.switches.first.map(|t| (t, &r.name)));
        eprintln!(
            "{}: {count} false target switches ({steps} steps off the lead) in {SEGMENTS} min; largest braking beyond the segment \
             without neighbours {:.2} m/s² ({} at {:.1} s); first switch {first:?}",
            c.as_str(),
            worst.braking.0,
            worst.name,
            worst.braking.1
        );
        let bad = |r: &Outcome| r.switches.count > 0 || r.braking.0 > MAX_NEIGHBOUR_BRAKING || r.contact;
        for r in mine.iter().filter(|r| bad(r)) {
            eprintln!("  {}: {:?}, braking {:.2} m/s² at {:.1} s, contact {}", r.name, r.switches, r.braking.0, r.braking.1, r.contact);
        }
        if mine.iter().any(|r| bad(r)) {
            failures.push(c.as_str());
        }
    }
    assert!(failures.is_empty(), "false cut-ins, neighbour braking or contacts: {failures:?}");
}

/// The control: a car from the left lane cutting in between the ego and its lead on a straight
/// road, an arc and an S-bend. The count above sees it: the ego's target changes to it.
#[test]
fn a_real_cut_in_is_counted() {
    // Seeds whose roads are a straight, an arc and an S-bend (names checked below).
    let seeds = [0u64, 1, 2, 3, 4, 5, 6, 7];
    for c in CONTROLLERS {
        let mut shapes = Vec::new();
        for &k in &seeds {
            let sc = cut_in_segment(k, c);
            let shape = if sc.name.contains("straight") {
                "straight"
            } else if sc.name.contains("S-bend") {
                "S-bend"
            } else {
                "arc"
            };
            if shapes.contains(&shape) {
                continue;
            }
            shapes.push(shape);
            let r = run(&sc).expect("run");
            let n = switches(&r);
            eprintln!("{} {}: {n:?}", c.as_str(), sc.name);
            assert!(n.count >= 1, "{} {}: the cut-in was not counted", c.as_str(), sc.name);
            let t = n.first.expect("counted");
            assert!(t > 10.0 && t < 13.5, "{} {}: counted at {t:.2} s, the lane change runs 10-13 s", c.as_str(), sc.name);
        }
        assert_eq!(shapes.len(), 3, "seeds 0-7 cover the three roads: {shapes:?}");
    }
}
