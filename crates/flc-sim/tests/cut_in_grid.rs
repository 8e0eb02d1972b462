//! The grid of cut-ins (`flc_sim::cut_in_grid`): ego 30-130 km/h, the car 0-40 km/h slower, gaps
//! 5-60 m at the lane change's start, lane changes of 1.5-5 s, straight and R = 1000 m, with the
//! default sensor and under each of the four impairments; flc-robust and its odometry variant have
//! no contact in any case the careful driver (ground truth, R157 Annex 3) avoids.

use flc_sim::cut_in_grid::{Grid, bound_table, run_grid, table};
use flc_sim::{ControllerKind, RunOptions};

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn flc_robust_has_no_contact_the_careful_driver_avoids() {
    let cases = Grid::small().cases();
    let mut bad = Vec::new();
    for law in [ControllerKind::FlcRobust, ControllerKind::FlcRobustOdo] {
        let out = run_grid(&cases, law, &RunOptions::default()).expect("runs");
        assert_eq!(out.len(), cases.len());
        println!("{}", table(law, &out));
        if law == ControllerKind::FlcRobust {
            println!("The careful driver has contact up to these gaps:\n{}", bound_table(&out));
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
}
