//! Acceptance tests of the lead detector (issue 23, `docs/detector.md`), measured by
//! `flc_sim::detection_study` on whatever detector and default LiDAR are in the tree: a car on
//! the ego's path to 150 m (clean) and to 100 m (50 % per-ray dropout), a motorcycle-width target
//! to 80 m, on the straight and the curved track; no false detection over 5 km of clutter; the
//! baselines stop behind a braking motorcycle-width lead in the closed loop.
//!
//! Rates are over the frames in which the target is visible (an impairment-free scan sees its
//! nearest point and at least half its width; guard rails hide it, or part of it, in curves),
//! pooled over the 10 m range bins up to the limit. A
//! frame counts when the target is detected within 0.3 m of its true distance. The range tests
//! are heavy in debug builds: `tests/run_all.sh` runs them with `--release` (like the goldens).

mod common;

use flc_sim::detection_study::{
    ACCURATE, CAR, ClutterRun, Condition, Curve, MOTORCYCLE, RangeStudy, Target, TrackKind, range_bins, run_clutter, run_range_study,
};
use flc_sim::{ControllerKind, Scenario, run};

/// Frames per 10 m bin (pooled over the bins: 1 400 frames for 10-150 m).
const FRAMES: usize = 100;

fn study(track: TrackKind, target: Target, condition: Condition, up_to: f64, frames: usize) -> Curve {
    let s = RangeStudy {
        conditions: vec![condition],
        bins: range_bins(10.0, up_to, 10.0),
        frames_per_bin: frames,
        ..RangeStudy::new(track, target)
    };
    run_range_study(&s).remove(0)
}

/// The per-bin table of a curve, for failure messages.
fn table(c: &Curve) -> String {
    c.bins
        .iter()
        .map(|b| {
            format!(
                "  {:>3.0}-{:<3.0} m: visible {:>3}/{:<3} detected {:>3} accurate {:>3} wrong {:>2} mean |err| {:.3} max {:.3}",
                b.lo,
                b.hi,
                b.visible,
                b.frames,
                b.detected,
                b.accurate,
                b.wrong,
                b.mean_abs_error(),
                b.max_abs_error
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Asserts that the accurate-detection rate over visible frames, pooled up to `up_to`, is at
/// least `required` on `tracks`.
fn require(tracks: &[TrackKind], target: Target, condition: Condition, up_to: f64, required: f64) {
    let mut failures = Vec::new();
    for &track in tracks {
        let c = study(track, target, condition.clone(), up_to, FRAMES);
        let p = c.pooled(up_to);
        assert!(
            p.visible >= p.frames / 4,
            "{}: the target is visible in only {} of {} frames\n{}",
            track.name(),
            p.visible,
            p.frames,
            table(&c)
        );
        let rate = p.accurate_rate();
        eprintln!(
            "{} {} {} to {up_to} m: {:.2} % accurate ({} / {} visible, {} frames), max |err| {:.3} m",
            target.name,
            track.name(),
            condition.name,
            100.0 * rate,
            p.accurate,
            p.visible,
            p.frames,
            p.max_abs_error
        );
        if rate.is_nan() || rate < required {
            failures.push(format!(
                "{} track: {:.2} % of the visible frames detected within {ACCURATE} m (required {:.1} %)\n{}",
                track.name(),
                100.0 * rate,
                100.0 * required,
                table(&c)
            ));
        }
    }
    assert!(failures.is_empty(), "{} ({}), 10-{up_to} m:\n{}", target.name, condition.name, failures.join("\n"));
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn a_car_on_the_path_is_detected_to_150_m_with_the_clean_default_lidar() {
    require(&[TrackKind::Straight], CAR, Condition::clean(), 150.0, 0.995);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn a_car_on_the_curvy_route_is_detected_to_150_m_with_the_clean_default_lidar() {
    require(&[TrackKind::Curvy], CAR, Condition::clean(), 150.0, 0.995);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn a_car_on_the_path_is_detected_to_100_m_with_half_the_rays_dropped() {
    require(&[TrackKind::Straight], CAR, Condition::dropout(0.5), 100.0, 0.98);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn a_car_on_the_curvy_route_is_detected_to_100_m_with_half_the_rays_dropped() {
    require(&[TrackKind::Curvy], CAR, Condition::dropout(0.5), 100.0, 0.98);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn a_motorcycle_sized_target_on_the_path_is_detected_to_80_m() {
    for width in [0.7, 0.8, 0.9] {
        require(&[TrackKind::Straight], Target { width, ..MOTORCYCLE }, Condition::clean(), 80.0, 0.99);
    }
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn a_motorcycle_sized_target_on_the_curvy_route_is_detected_to_80_m() {
    for width in [0.7, 0.8, 0.9] {
        require(&[TrackKind::Curvy], Target { width, ..MOTORCYCLE }, Condition::clean(), 80.0, 0.99);
    }
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn no_false_detection_over_5_km_of_clutter_at_30_to_130_kmh() {
    no_false_detection(&[TrackKind::Straight]);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn no_false_detection_on_the_curvy_route() {
    no_false_detection(&[TrackKind::Curvy]);
}

fn no_false_detection(tracks: &[TrackKind]) {
    let runs = run_clutter(&ClutterRun { tracks: tracks.to_vec(), ..ClutterRun::default() });
    let km: f64 = runs.iter().map(|r| r.km).sum();
    // The straight run alone is the issue's 5 km; the curvy route is 2 km long.
    let min_km = if tracks.contains(&TrackKind::Straight) { 5.0 } else { 1.9 };
    assert!(km >= min_km, "only {km} km driven");
    let mut failures = Vec::new();
    for r in &runs {
        let (road, zero) = r.per_km();
        eprintln!(
            "{}: {:.2} km, {} frames, {road:.3} false/km (road curvature), {zero:.3} false/km (straight path)",
            r.track, r.km, r.frames
        );
        for (name, list) in [("road curvature", &r.false_road_curvature), ("straight path", &r.false_zero_curvature)] {
            if !list.is_empty() {
                let first: Vec<String> = list
                    .iter()
                    .take(5)
                    .map(|f| format!("s {:.1} m: at ({:.1}, {:.1}) m, {:.2} m wide", f.s, f.position[0], f.position[1], f.width))
                    .collect();
                failures.push(format!(
                    "{} ({name}): {} false detections ({:.3}/km), first: {}",
                    r.track,
                    list.len(),
                    list.len() as f64 / r.km,
                    first.join("; ")
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The study gives the same numbers whatever the thread count (and is cheap enough for debug).
#[test]
fn the_study_does_not_depend_on_the_thread_count() {
    let s = RangeStudy {
        conditions: vec![Condition::clean(), Condition::dropout(0.5)],
        bins: range_bins(10.0, 40.0, 10.0),
        frames_per_bin: 6,
        ..RangeStudy::new(TrackKind::Curvy, CAR)
    };
    let pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("pool");
    let one = pool(1).install(|| run_range_study(&s));
    let three = pool(3).install(|| run_range_study(&s));
    assert_eq!(one, three);
    assert_eq!(one.len(), 2);
    // A car 10-40 m ahead is visible in every frame and detected close to the truth.
    for b in &one[0].bins {
        assert_eq!(b.visible, b.frames, "{b:?}");
    }
}

/// The motorcycle-width lead of the closed-loop test: 0.8 m x 2.2 m (wheelbase 1.45 m, a
/// motorcycle's; the car's default 2.9 m does not fit in 2.2 m), from 50 km/h braking at
/// 6 m/s² to a stop after 8 s of cruising; the ego follows at 50 km/h, 30 m behind.
fn braking_motorcycle(controller: &str) -> Scenario {
    braking_lead(controller, "width = 0.8\nlength = 2.2\nwheelbase = 1.45\n")
}

/// The braking-lead scenario with `vehicle` as the lead's `[lead.vehicle]` section.
fn braking_lead(controller: &str, vehicle: &str) -> Scenario {
    let text = format!(
        r#"
name = "motorcycle-brakes"
controller = "{controller}"
duration = 30.0

[lead]
initial_speed = 13.889

[lead.vehicle]
{vehicle}
[[lead.phases]]
kind = "hold"
duration = 8.0

[[lead.phases]]
kind = "brake"
decel = 6.0

[follower]
initial_speed = 13.889
initial_gap = 30.0

[v2v]
enabled = false

[idm]
desired_speed = 13.889

[acc]
desired_speed = 13.889

[gipps]
desired_speed = 13.889

[rss]
desired_speed = 13.889
"#
    );
    Scenario::from_toml_str(&text, "motorcycle-brakes.toml").expect("scenario")
}

/// Runs the braking-lead scenario for every baseline; the failures: a collision, or still faster
/// than 0.5 m/s at the end (RSS creeps up to its minimum gap).
fn stop_failures(scenario: impl Fn(&str) -> Scenario) -> Vec<String> {
    let mut failures = Vec::new();
    for name in ["idm", "acc", "gipps", "rss"] {
        let s = scenario(name);
        let r = run(&s).expect("run");
        let n = r.series.len();
        let (gap, v) = (r.series.gap[n - 1], r.series.follower_speed[n - 1]);
        let seen = r.series.detected_distance.iter().filter(|d| d.is_finite()).count();
        eprintln!(
            "{name}: collision {}, final gap {gap:.2} m, final speed {v:.2} m/s, lead detected in {seen} / {n} steps",
            r.metrics.collision
        );
        if r.metrics.collision || v > 0.5 {
            failures.push(format!(
                "{name}: collision {} (impact {:.2} m/s), final gap {gap:.2} m, speed {v:.2} m/s, lead detected in {seen} of {n} steps",
                r.metrics.collision, r.metrics.impact_speed
            ));
        }
    }
    failures
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn the_baselines_stop_behind_a_braking_motorcycle() {
    let failures = stop_failures(braking_motorcycle);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The same scenario with a car-sized lead (the default vehicle): the scenario itself leaves
/// every baseline room to stop, so a failure above is the detector's.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn the_baselines_stop_behind_a_braking_car_in_the_same_scenario() {
    let failures = stop_failures(|c| braking_lead(c, ""));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_motorcycle_scenario_parses_with_its_vehicle() {
    let s = braking_motorcycle("idm");
    assert_eq!((s.lead.vehicle.width, s.lead.vehicle.length), (0.8, 2.2));
    assert_eq!(s.controller, ControllerKind::Idm);
}

/// The study `docs/detector.md` includes (`docs/figures/detector-study.md`) is what the detector
/// and LiDAR in the tree give: recomputed here with the committed file's command line (its
/// defaults) and compared line by line. `cargo run --release -p flc-sim --example detector_study
/// -- --out docs/figures` rewrites it.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn the_committed_detector_study_is_the_code_s() {
    let (label, frames) = ("the detector in the tree", 200);
    let (curves, clutter) = flc_sim::detection_study::full_study(frames, |_| {});
    let command = flc_sim::detection_study::study_command("docs/figures", "detector", label, frames);
    let now = flc_sim::detection_study::markdown(&curves, &clutter, label, "detector", &command);
    common::compare(
        "docs/figures/detector-study.md",
        &now,
        "cargo run --release -p flc-sim --example detector_study -- --out docs/figures",
    );
}
