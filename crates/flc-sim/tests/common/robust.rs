//! What the robust-FLC test crates (`robust_flc.rs`, `robust_flc2.rs`) share.

use flc_sim::{ControllerKind, Metrics, MetricsParams, RunResult, Scenario};

/// The gap the controller of `s` keeps behind a lead at its own speed `v`, m.
pub fn own_gap(s: &Scenario, v: f64) -> f64 {
    match s.controller {
        ControllerKind::FlcRobustV1 => s.flc_robust_v1.desired_gap(v),
        ControllerKind::FlcRobust | ControllerKind::FlcRobustOdo => s.flc_robust.law.desired_gap(v),
        ControllerKind::Flc => s.flc.desired_distance(v) + s.flc.f_shift(v),
        other => panic!("no own gap for {}", other.as_str()),
    }
}

/// Largest 1-second mean jerk `max |a(t) - a(t - 1 s)| / 1 s`, m/s³.
pub fn jerk_1s(r: &RunResult) -> f64 {
    Metrics::compute_with(&r.series, None, &MetricsParams { jerk_window: 1.0, ..MetricsParams::default() }).max_jerk
}
