//! Closed-loop speed: one paper run (real-time factor) and the default experiment (8 runs).
//! Results and the machine are recorded in docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use flc_sim::{Calibration, ControllerKind, PAPER_SPEEDS_KMH, Scenario};
use flc_sim::{RunOptions, run};

fn single_run(c: &mut Criterion) {
    let s = Scenario::paper_experiment(70.0, ControllerKind::Flc, Calibration::Realistic);
    let simulated = run(&s).map(|r| r.metrics.duration).unwrap_or(f64::NAN);
    eprintln!("paper 70 km/h FLC run: {simulated:.2} s simulated (real-time factor = this / time per iteration)");
    let mut g = c.benchmark_group("closed_loop");
    g.sample_size(20);
    g.bench_function("paper_70kmh_flc_default_lidar", |b| b.iter(|| run(std::hint::black_box(&s))));
    g.finish();
}

fn default_experiment(c: &mut Criterion) {
    let scenarios: Vec<Scenario> = PAPER_SPEEDS_KMH
        .iter()
        .flat_map(|&v| [ControllerKind::Flc, ControllerKind::Pid].map(|k| Scenario::paper_experiment(v, k, Calibration::Realistic)))
        .collect();
    let mut g = c.benchmark_group("closed_loop");
    g.sample_size(10);
    g.bench_function("default_experiment_8_runs_all_cores", |b| {
        b.iter(|| RunOptions::default().run_batch(std::hint::black_box(&scenarios)))
    });
    g.finish();
}

criterion_group!(benches, single_run, default_experiment);
criterion_main!(benches);
