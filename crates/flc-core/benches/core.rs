//! Benchmarks of the flc-core step functions (criterion). Results, machine and command in
//! `docs/benchmarks.md` ("flc-core (firmware)"); instruction counts with callgrind:
//! `crates/flc-core/benches/callgrind.sh`.
//!
//! ```sh
//! cargo bench -p flc-core --bench core
//! ```
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use common::{Lcg, scan};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flc_core::{
    DetectorParams, FallbackController, FlcParams, LeadDetector, NeighbourParams, NeighbourTracker, PidController, PidParams, Point2,
    PurePursuit, PurePursuitParams, RobustFallbackController, RobustFallbackController2, RobustFlc2Params, RobustFlcParams, Supervisor,
    SupervisorParams, V2vMessage,
};
use std::hint::black_box;

/// 1024 plausible (distance, own speed, lead speed) triples, cycled through by the benchmarks so
/// that branches are exercised as in a real run (closing, opening, braking branch).
fn inputs() -> Vec<(f64, f64, f64)> {
    let mut rng = Lcg(7);
    let mut d = 25.0;
    (0..1024)
        .map(|_| {
            d += (rng.uniform() - 0.5) * 1.0;
            if d < 5.0 {
                d = 30.0;
            }
            (d, 10.0 + 5.0 * rng.uniform(), 10.0 + 5.0 * rng.uniform())
        })
        .collect()
}

fn controllers(c: &mut Criterion) {
    let inputs = inputs();
    let mut flc = FallbackController::new(FlcParams::default()).unwrap();
    let mut k = 0usize;
    c.bench_function("flc_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let (d, v, _) = inputs[k];
            flc.step(Some(black_box(d)), black_box(v))
        })
    });
    let mut robust = RobustFallbackController::new(RobustFlcParams::default()).unwrap();
    c.bench_function("robust_flc_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let (d, v, _) = inputs[k];
            robust.step(Some(black_box(d)), black_box(v))
        })
    });
    let mut robust2 = RobustFallbackController2::new(RobustFlc2Params::default()).unwrap();
    c.bench_function("robust_flc2_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let (d, v, _) = inputs[k];
            robust2.step(Some(black_box(d)), black_box(v))
        })
    });
    let mut odo = flc_core::OdometryFallbackController::new(RobustFlc2Params::default(), flc_core::OdometryFlcParams::default()).unwrap();
    let mut travelled = 0.0;
    c.bench_function("robust_flc_odo_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let (d, v, _) = inputs[k];
            travelled += 0.05 * v;
            odo.step(Some(black_box(d)), black_box(v), Some(black_box(travelled)))
        })
    });
    let mut pid = PidController::new(PidParams::default()).unwrap();
    c.bench_function("pid_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let (d, v, l) = inputs[k];
            pid.step(black_box(l), black_box(v), Some(black_box(d)), black_box(0.05))
        })
    });
    let mut sup = Supervisor::new(SupervisorParams::default()).unwrap();
    let mut seq = 0u32;
    c.bench_function("supervisor_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            seq = seq.wrapping_add(1);
            let (d, v, l) = inputs[k];
            // V2V every other tick: the PID drives, freshness bookkeeping runs every tick.
            let msg = (seq & 1 == 0).then_some(V2vMessage::speed_only(l, seq));
            sup.step(black_box(msg), Some(black_box(d)), black_box(v), black_box(0.05))
        })
    });
    let pp = PurePursuit::new(PurePursuitParams::default()).unwrap();
    c.bench_function("pursuit_step", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            let (d, v, l) = inputs[k];
            pp.step(Some(black_box(Point2::new(d, l - 12.5))), black_box(v))
        })
    });
}

fn detector(c: &mut Criterion) {
    let mut group = c.benchmark_group("detector");
    let mut det = Box::new(<LeadDetector>::new(DetectorParams::default()).unwrap());
    for n in [900usize, 1800] {
        // The rear face of a car 30 m ahead plus two guard rails at +-5 m (two thirds of the points).
        let pts = scan(42, 30.0, 0.2, 1.9, n, true);
        assert!(det.detect(&pts, 0.0).detection.is_some());
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("detect_car_and_rails", n), &pts, |b, pts| {
            b.iter(|| det.detect(black_box(pts), black_box(0.0)))
        });
        // The same scan on a curved path (250 m radius): every point's offset from the arc costs a
        // square root and a division.
        group.bench_with_input(BenchmarkId::new("detect_car_and_rails_curved", n), &pts, |b, pts| {
            b.iter(|| det.detect(black_box(pts), black_box(0.004)))
        });
        // The detector followed by the neighbour tracker's update on the scan's clusters (issue 47:
        // the firmware's per-scan work, goal <= 200 us for 1800 points).
        let mut nb = NeighbourTracker::new(NeighbourParams::default()).unwrap();
        group.bench_with_input(BenchmarkId::new("detect_and_track_car_and_rails", n), &pts, |b, pts| {
            b.iter(|| {
                det.detect(black_box(pts), black_box(0.0));
                nb.update(det.clusters())
            })
        });
        // The same with the lane-keeping ego's path: a curved arc and a path profile (an S-bend's
        // reversal ahead), every point's offset also interpolated in the profile.
        // R = 1000 m reversing 40 m ahead: the lane leaves the arc by 0.001 (x - 40)^2.
        let profile: Vec<f64> = (0..64).map(|k| -0.001 * (f64::from(k) * 4.0 - 40.0).max(0.0).powi(2)).collect();
        det.set_path_profile(4.0, &profile).unwrap();
        assert!(det.detect(&pts, 0.001).detection.is_some());
        group.bench_with_input(BenchmarkId::new("detect_and_track_profile", n), &pts, |b, pts| {
            b.iter(|| {
                det.detect(black_box(pts), black_box(0.001));
                nb.update(det.clusters())
            })
        });
        det.set_path_profile(0.0, &[]).unwrap();
    }
    group.finish();
}

criterion_group!(benches, controllers, detector);
criterion_main!(benches);
