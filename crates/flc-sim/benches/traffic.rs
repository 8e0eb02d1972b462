//! Scripted traffic speed (issue 17): `scenarios/traffic-10.toml`, ten moving vehicles (the lead,
//! the ego with its 961-ray LiDAR at 20 Hz, detector, supervisor, PID with V2V and FLC, and eight
//! `[[vehicles]]` with lane changes and a time-triggered brake) on a three-lane road with guard
//! rails, 120 s on one core. Prints the real-time factor. Results in docs/benchmarks.md.
//!
//! `cargo bench -p flc-sim --bench traffic`

use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use flc_sim::{Scenario, run};

fn traffic(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/traffic-10.toml");
    let s = Scenario::from_file(std::path::Path::new(path)).expect("traffic-10.toml");
    let r = run(&s).expect("run");
    assert!(r.collision.is_none(), "the ego collided: {:?}", r.collision);
    assert!(r.other_contacts.is_empty(), "traffic contacts: {:?}", r.other_contacts);
    let simulated = r.metrics.duration;
    // A plain timing besides criterion's: the real-time factor of a few runs.
    let runs = 3;
    let t0 = Instant::now();
    for _ in 0..runs {
        std::hint::black_box(run(std::hint::black_box(&s)).expect("run"));
    }
    let wall = t0.elapsed().as_secs_f64() / f64::from(runs);
    eprintln!(
        "traffic-10: {simulated:.2} s simulated, {} vehicles; plain timing {:.1} ms per run (mean of {runs}), real-time factor {:.0}",
        s.vehicles.len() + 2,
        wall * 1e3,
        simulated / wall
    );
    let mut g = c.benchmark_group("traffic");
    g.sample_size(10);
    g.bench_function("traffic_10_vehicles_120s_three_lanes", |b| b.iter(|| run(std::hint::black_box(&s))));
    g.finish();
}

criterion_group!(benches, traffic);
criterion_main!(benches);
