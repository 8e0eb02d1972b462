//! Runs each step function a fixed number of times in its own non-inlined function, for
//! instruction counting with callgrind (`benches/callgrind.sh`, results in docs/benchmarks.md).
//! Instruction counts do not depend on the machine's load, unlike times.
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use common::{Lcg, scan};
use flc_core::{
    DetectorParams, FallbackController, FlcParams, LeadDetector, NeighbourParams, NeighbourTracker, OdometryFallbackController,
    OdometryFlcParams, PidController, PidParams, Point2, PurePursuit, PurePursuitParams, RobustFallbackController,
    RobustFallbackController2, RobustFlc2Params, RobustFlcParams, Supervisor, SupervisorParams, V2vMessage,
};
use std::hint::black_box;

/// Steps per controller.
pub const STEPS: usize = 10_000;
/// Scans per detector size.
pub const SCANS: usize = 100;

fn inputs() -> Vec<(f64, f64, f64)> {
    let mut rng = Lcg(7);
    let mut d = 25.0;
    (0..STEPS)
        .map(|_| {
            d += (rng.uniform() - 0.5) * 1.0;
            if d < 5.0 {
                d = 30.0;
            }
            (d, 10.0 + 5.0 * rng.uniform(), 10.0 + 5.0 * rng.uniform())
        })
        .collect()
}

#[inline(never)]
fn flc_steps(c: &mut FallbackController, inputs: &[(f64, f64, f64)]) -> f64 {
    inputs.iter().map(|&(d, v, _)| black_box(c.step(Some(d), v)).speed).sum()
}

#[inline(never)]
fn robust_steps(c: &mut RobustFallbackController, inputs: &[(f64, f64, f64)]) -> f64 {
    inputs.iter().map(|&(d, v, _)| black_box(c.step(Some(d), v)).speed).sum()
}

#[inline(never)]
fn robust2_steps(c: &mut RobustFallbackController2, inputs: &[(f64, f64, f64)]) -> f64 {
    inputs.iter().map(|&(d, v, _)| black_box(c.step(Some(d), v)).speed).sum()
}

/// The odometry variant on the same input, its odometer advancing by `v` x 0.05 s per frame.
#[inline(never)]
fn odo_steps(c: &mut OdometryFallbackController, inputs: &[(f64, f64, f64)]) -> f64 {
    let mut s = 0.0;
    inputs
        .iter()
        .map(|&(d, v, _)| {
            s += 0.05 * v;
            black_box(c.step(Some(d), v, Some(s))).speed
        })
        .sum()
}

#[inline(never)]
fn pid_steps(c: &mut PidController, inputs: &[(f64, f64, f64)]) -> f64 {
    inputs.iter().map(|&(d, v, l)| black_box(c.step(l, v, Some(d), 0.05)).speed).sum()
}

#[inline(never)]
fn supervisor_steps(s: &mut Supervisor, inputs: &[(f64, f64, f64)]) -> f64 {
    let mut seq = 0u32;
    inputs
        .iter()
        .map(|&(d, v, l)| {
            seq += 1;
            let msg = (seq & 1 == 0).then_some(V2vMessage::speed_only(l, seq));
            black_box(s.step(msg, Some(d), v, 0.05)).command.speed
        })
        .sum()
}

#[inline(never)]
fn pursuit_steps(p: &PurePursuit, inputs: &[(f64, f64, f64)]) -> f64 {
    inputs.iter().map(|&(d, v, l)| black_box(p.step(Some(Point2::new(d, l - 12.5)), v)).steer).sum()
}

#[inline(never)]
fn detector_scans(det: &mut LeadDetector, pts: &[[f64; 2]]) -> f64 {
    (0..SCANS).map(|_| black_box(det.detect(black_box(pts), 0.0)).detection.map_or(0.0, |d| d.distance)).sum()
}

/// The detector followed by the neighbour tracker's update on the scan's clusters.
#[inline(never)]
fn tracker_scans(det: &mut LeadDetector, nb: &mut NeighbourTracker, pts: &[[f64; 2]]) -> f64 {
    (0..SCANS)
        .map(|_| {
            black_box(det.detect(black_box(pts), 0.0));
            black_box(nb.update(det.clusters())).map_or(0.0, |d| d.distance)
        })
        .sum()
}

/// `instructions [flc|robust|robust2|odo|pid|supervisor|pursuit|detector900|detector1800|tracker1800|all]`: runs one workload
/// (so that callgrind only has to count that one) or all of them.
fn main() {
    let which = std::env::args().nth(1).unwrap_or_else(|| "all".into());
    let run = |name: &str| which == "all" || which == name;
    let inputs = inputs();
    let mut total = 0.0;
    if run("flc") {
        total += flc_steps(&mut FallbackController::new(FlcParams::default()).unwrap(), &inputs);
    }
    if run("robust") {
        total += robust_steps(&mut RobustFallbackController::new(RobustFlcParams::default()).unwrap(), &inputs);
    }
    if run("robust2") {
        total += robust2_steps(&mut RobustFallbackController2::new(RobustFlc2Params::default()).unwrap(), &inputs);
    }
    if run("odo") {
        total +=
            odo_steps(&mut OdometryFallbackController::new(RobustFlc2Params::default(), OdometryFlcParams::default()).unwrap(), &inputs);
    }
    if run("pid") {
        total += pid_steps(&mut PidController::new(PidParams::default()).unwrap(), &inputs);
    }
    if run("supervisor") {
        total += supervisor_steps(&mut Supervisor::new(SupervisorParams::default()).unwrap(), &inputs);
    }
    if run("pursuit") {
        total += pursuit_steps(&PurePursuit::new(PurePursuitParams::default()).unwrap(), &inputs);
    }
    let mut det = Box::new(<LeadDetector>::new(DetectorParams::default()).unwrap());
    for n in [900, 1800] {
        if run(&format!("detector{n}")) {
            total += detector_scans(&mut det, &scan(42, 30.0, 0.2, 1.9, n, true));
        }
    }
    if run("tracker1800") {
        let mut nb = NeighbourTracker::new(NeighbourParams::default()).unwrap();
        total += tracker_scans(&mut det, &mut nb, &scan(42, 30.0, 0.2, 1.9, 1800, true));
    }
    println!("{which}: checksum {total}, {STEPS} steps / {SCANS} scans");
}
