//! The grid of cut-ins (`flc_sim::cut_in_grid`): ego 30-130 km/h, the car 0-40 km/h slower, gaps
//! 5-60 m at the lane change's start, lane changes of 1.5-5 s, straight and R = 1000 m, with the
//! default sensor and under each of the four impairments; flc-robust and its odometry variant have
//! no contact in any case the careful driver (ground truth, R157 Annex 3) avoids.

mod common;

use flc_sim::cut_in_grid::{Grid, bound_table, run_grid, table};
use flc_sim::{ControllerKind, RunOptions};

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn flc_robust_has_no_contact_the_careful_driver_avoids() {
    let cases = Grid::small().cases();
    let mut bad = Vec::new();
    // The tables as docs/cut-in-grid.md shows them (checked here; FLC_BLESS=1 writes them).
    let mut doc = String::from(
        "# The cut-in grid\n\nWritten by `FLC_BLESS=1 cargo test --release -p flc-sim --test cut_in_grid` and checked by \
         the same test without `FLC_BLESS` (`crates/flc-sim/tests/cut_in_grid.rs`; the grid: `flc_sim::cut_in_grid`, \
         `docs/detector.md` \"Objects beside the path\"). Each case is run by the controller and by the careful driver \
         (ground truth, R157 Annex 3) under the same impairment.\n",
    );
    for law in [ControllerKind::FlcRobust, ControllerKind::FlcRobustOdo] {
        let out = run_grid(&cases, law, &RunOptions::default()).expect("runs");
        assert_eq!(out.len(), cases.len());
        let t = table(law, &out);
        println!("{t}");
        doc.push_str(&format!("\n## {}\n\n{}\n", law.as_str(), t.trim_end()));
        if law == ControllerKind::FlcRobust {
            let b = bound_table(&out);
            println!("The careful driver has contact up to these gaps:\n{b}");
            doc.push_str(&format!(
                "\nThe bound: the careful driver has contact up to these gaps at the lane change's start (the largest over every \
                 impairment and both roads):\n\n{}\n",
                b.trim_end()
            ));
        }
        for o in out.iter().filter(|o| o.fails()) {
            bad.push(format!(
                "{}, {}: contact at {:.2} m/s (careful driver: min gap {:.2} m)",
                law.as_str(),
                o.case.label(),
                o.law.impact_speed,
                o.reference.min_gap
            ));
        }
    }
    assert!(bad.is_empty(), "{} cases:\n{}", bad.len(), bad.join("\n"));
    common::bless_or_compare("docs/cut-in-grid.md", &doc, "FLC_BLESS=1 cargo test --release -p flc-sim --test cut_in_grid");
}
