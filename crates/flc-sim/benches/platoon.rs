//! Platoon speed (issue 8): a 16-vehicle platoon (the lead and 15 followers, each with its own
//! 961-ray LiDAR at 20 Hz, detector, supervisor, PID with V2V from its predecessor and FLC) driven
//! for 120 s on one core. Goal: >= 100x real time. Results in docs/benchmarks.md.
//!
//! `cargo bench -p flc-sim --bench platoon`

use criterion::{Criterion, criterion_group, criterion_main};
use flc_sim::{Phase, Scenario, TrackSpec};
use flc_sim::{Track, run};

/// The brake demo's string with 15 followers for 120 s: cruise at 120 km/h, brake at -6 m/s² to
/// 72 km/h, cruise, accelerate back to 120 km/h (the run lasts the full 120 s).
fn sixteen(track: TrackSpec) -> Scenario {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/platoon-brakedemo.toml");
    let mut s = Scenario::from_file(std::path::Path::new(path)).expect("platoon-brakedemo.toml");
    s.variants.clear(); // the pid-v2v variant: the pipeline with working V2V
    s.name = "platoon-16-120s".into();
    s.duration = 120.0;
    s.track = track;
    let v = s.lead.initial_speed;
    s.lead.phases = vec![
        Phase::Hold { until_x: None, until_t: None, duration: Some(30.0) }.into(),
        Phase::Brake { decel: 6.0, speed: Some(20.0), speed_kmh: None }.into(),
        Phase::Hold { until_x: None, until_t: None, duration: Some(30.0) }.into(),
        Phase::Accelerate { accel: 2.0, speed: Some(v), speed_kmh: None }.into(),
    ];
    if let Some(p) = s.platoon.as_mut() {
        p.followers = 15;
    }
    s
}

fn platoon(c: &mut Criterion) {
    let cases = [
        // The brake demo's road: guard rails both sides, posts every 50 m, parked cars.
        ("platoon_16_vehicles_120s_straight_rails", sixteen(TrackSpec::Straight { length: 5000.0 })),
        // An open road: nothing but the vehicles (the LiDAR sees only the car in front).
        (
            "platoon_16_vehicles_120s_open_road",
            sixteen(TrackSpec::Custom(Track::new("open", vec![[0.0, 0.0], [5000.0, 0.0]], 3.5, vec![]))),
        ),
    ];
    let mut g = c.benchmark_group("platoon");
    g.sample_size(10);
    for (name, s) in &cases {
        let r = run(s).expect("run");
        let p = r.platoon.as_ref().expect("platoon");
        assert!(p.followers.iter().all(|f| f.collision.is_none()), "{name}: collision");
        eprintln!(
            "{name}: {:.2} s simulated, {} vehicles (real-time factor = this / time per iteration)",
            r.metrics.duration,
            p.followers.len() + 1
        );
        g.bench_function(*name, |b| b.iter(|| run(std::hint::black_box(s))));
    }
    g.finish();
}

criterion_group!(benches, platoon);
criterion_main!(benches);
