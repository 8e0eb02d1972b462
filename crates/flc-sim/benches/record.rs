//! Cost of an MCAP recording: the 70 km/h paper run with and without `--record` (goal: recording
//! at most 2x the run's time), and the file size per simulated minute. Results in
//! docs/foxglove.md ("Size and cost") and docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use flc_sim::{Calibration, ControllerKind, Scenario};
use flc_sim::{RunOptions, run};

fn recording(c: &mut Criterion) {
    let s = Scenario::paper_experiment(70.0, ControllerKind::Pipeline, Calibration::Realistic);
    let dir = std::env::temp_dir().join(format!("flc-bench-record-{}", std::process::id()));
    let r = RunOptions { record: Some(&dir), ..RunOptions::default() }.run(&s).expect("run");
    let path = dir.join(flc_sim::record::recording_file_name(&s));
    let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let minutes = r.metrics.duration / 60.0;
    eprintln!(
        "paper 70 km/h pipeline: {:.2} s simulated, recording {:.2} MB = {:.2} MB per simulated minute",
        r.metrics.duration,
        bytes as f64 / 1e6,
        bytes as f64 / 1e6 / minutes
    );
    let mut g = c.benchmark_group("record");
    g.sample_size(20);
    g.bench_function("paper_70kmh_pipeline_no_recording", |b| b.iter(|| run(std::hint::black_box(&s))));
    g.bench_function("paper_70kmh_pipeline_recording", |b| {
        b.iter(|| RunOptions { record: Some(&dir), ..RunOptions::default() }.run(std::hint::black_box(&s)))
    });
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, recording);
criterion_main!(benches);
