//! OpenSCENARIO import speed (issue 21): importing typical files (goal < 50 ms each), and a run of
//! an imported file against its TOML twin (`scenario convert`): the same `Scenario`, so the same
//! speed. Results in docs/benchmarks.md.
//!
//! `cargo bench -p flc-sim --bench openscenario`

use std::path::Path;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use flc_sim::openscenario::{ImportOptions, import};
use flc_sim::{Scenario, run};

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/openscenario").join(name)
}

fn openscenario(c: &mut Criterion) {
    let opts = ImportOptions::default();
    let mut g = c.benchmark_group("openscenario");
    g.sample_size(20);
    for name in ["target_brakes.xosc", "merge_in.xosc", "conditions.xosc", "arc_road.xosc", "from_catalogs.xosc", "distribution_2x2.xosc"] {
        let path = fixture(name);
        let t0 = Instant::now();
        let n = 10;
        for _ in 0..n {
            std::hint::black_box(import(&path, &opts).expect("import"));
        }
        eprintln!("import {name}: {:.2} ms (plain mean of {n})", t0.elapsed().as_secs_f64() * 1e3 / f64::from(n));
        g.bench_function(format!("import_{name}"), |b| b.iter(|| import(std::hint::black_box(&path), &opts)));
    }
    // A run of the imported cut-in and of its TOML twin.
    let imported = import(&fixture("merge_in.xosc"), &opts).expect("import").runs.remove(0).scenario;
    let twin = Scenario::from_toml_str(&imported.to_toml().expect("toml"), "twin.toml").expect("twin");
    for (label, s) in [("run_imported_merge_in", &imported), ("run_toml_twin_merge_in", &twin)] {
        let t0 = Instant::now();
        let r = run(s).expect("run");
        eprintln!("{label}: {:.2} s simulated in {:.1} ms", r.metrics.duration, t0.elapsed().as_secs_f64() * 1e3);
        g.bench_function(label, |b| b.iter(|| run(std::hint::black_box(s))));
    }
    g.finish();
}

criterion_group!(benches, openscenario);
criterion_main!(benches);
