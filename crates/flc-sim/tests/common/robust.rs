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

/// The comfort target of issue 24 (ISO 15622 / 22179 figures): no contact, deceleration within
/// 3.5 m/s², 1-s mean jerk within 2.5 m/s³, at 2-5 m where it stops, never reversing. Prints the
/// figures; `Some(why)` when `r` misses it.
pub fn comfort_miss(name: &str, r: &RunResult) -> Option<String> {
    let (m, jerk) = (&r.metrics, jerk_1s(r));
    println!("{name}: max decel {:.2} m/s², 1-s jerk {jerk:.2} m/s³, standstill gap {:?}", m.max_decel, m.final_clearance);
    let stand_ok = m.final_clearance.is_none_or(|c| (2.0..=5.0).contains(&c));
    let ok = !m.collision && m.max_decel <= 3.5 && jerk <= 2.5 && stand_ok && r.series.follower_speed.iter().all(|&v| v >= 0.0);
    (!ok).then(|| format!("{name}: max decel {:.2}, jerk {jerk:.2}, standstill {:?}", m.max_decel, m.final_clearance))
}
