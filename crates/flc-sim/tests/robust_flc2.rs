//! Robust FLC v2 (issue 24; `controller = "flc-robust"`) and its odometry variant
//! (`flc-robust-odo`) against issue 24's targets: every test runs both laws ([`LAWS`]), each held
//! to every target.

mod common;

use common::robust::{comfort_miss, own_gap};
use flc_sim::suite::{Suite, default_root};
use flc_sim::{ControllerKind, LidarFault, Patch, Phase, RunOptions, RunResult, Scenario, TrackSpec};

/// The laws under test: v2 on the paper's inputs, and v2 with wheel odometry.
const LAWS: [ControllerKind; 2] = [ControllerKind::FlcRobust, ControllerKind::FlcRobustOdo];

/// Every law of [`LAWS`] at each speed, km/h.
fn law_speeds(speeds: &[f64]) -> Vec<(ControllerKind, f64)> {
    LAWS.iter().flat_map(|&l| speeds.iter().map(move |&v| (l, v))).collect()
}

/// `(name, patch)`: the impairments of issue 24, each alone.
fn impairments() -> Vec<(&'static str, Patch)> {
    let mut none = Patch::new();
    none.set("lidar.rate_hz", toml::Value::Float(20.0));
    let mut brakes = Patch::new();
    brakes.set("follower.vehicle.max_brake", toml::Value::Float(6.0));
    let mut actuator = Patch::new();
    actuator.set("follower.vehicle.dead_time", toml::Value::Float(0.3)).set("follower.vehicle.lag", toml::Value::Float(0.3));
    let mut lidar = Patch::new();
    lidar
        .set("lidar.rate_hz", toml::Value::Float(10.0))
        .set("lidar.latency_frames", toml::Value::Integer(1))
        .set("lidar.range_noise_std", toml::Value::Float(0.03));
    vec![("default", none), ("brakes 6 m/s²", brakes), ("dead time 0.3 s + lag 0.3 s", actuator), ("LiDAR 10 Hz, 100 ms, 3 cm", lidar)]
}

/// Whether `r` braked as hard as its speed controller can from the first frame with a detection to
/// its end.
fn full_braking_from_first_detection(r: &RunResult) -> bool {
    let s = &r.series;
    let full = -r.scenario.follower.speed_controller.max_decel + 1e-9;
    s.detected_distance.iter().position(|d| d.is_finite()).is_some_and(|i| s.accel_command[i + 1..].iter().all(|&a| a <= full))
}

/// The ideal observer under the same detector and actuator: `s` with a law that brakes fully from
/// the first frame on which the detector reports anything (v2 with a 100 m standstill gap: every
/// distance the suites report is "too close").
fn brake_on_first_detection(s: &Scenario) -> Scenario {
    let mut p = Patch::new();
    p.set("flc_robust.law.standstill_gap", toml::Value::Float(100.0));
    s.patched(&p).unwrap()
}

/// Runs every suite run with the reference and `kind` under `patch`; returns the number of runs,
/// the runs the reference avoids and `kind` does not (`suite/run: impact speed`), and those of
/// them that are a bound of the perception: `kind` braked fully from its first detection on, and
/// the ideal observer of [`brake_on_first_detection`] does not avoid contact either (the object
/// was first seen too close for any law fed by this detector).
fn failures(kind: ControllerKind, patch: &Patch) -> (usize, Vec<String>, Vec<String>) {
    let reference = ControllerKind::parse("careful-driver").unwrap();
    let mut runs = Vec::new();
    for suite in Suite::find(&default_root().expect("suites folder"), "all").unwrap() {
        for r in suite.runs(&[reference, kind]).unwrap() {
            let s = r.scenario.patched(patch).unwrap();
            runs.push((format!("{}/{}", suite.spec.name, r.run), s));
        }
    }
    let results: Vec<_> =
        RunOptions::default().run_batch(&runs.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>()).into_iter().map(|r| r.unwrap()).collect();
    let (mut bad, mut candidates) = (Vec::new(), Vec::new());
    for (pair, res) in runs.chunks(2).zip(results.chunks(2)) {
        if let ([(name, _), (_, own_s)], [refr, own]) = (pair, res) {
            if !refr.metrics.collision && own.metrics.collision {
                let line = format!("{name}: contact at {:.1} m/s", own.metrics.impact_speed);
                if full_braking_from_first_detection(own) {
                    candidates.push((line, brake_on_first_detection(own_s)))
                } else {
                    bad.push(line)
                }
            }
        }
    }
    let ideal = RunOptions::default().run_batch(&candidates.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>());
    let mut bound = Vec::new();
    for ((line, _), r) in candidates.into_iter().zip(ideal) {
        let m = r.unwrap().metrics;
        if m.collision {
            bound.push(format!("{line} (braking fully from the first detection: {:.1} m/s)", m.impact_speed));
        } else {
            bad.push(format!("{line}; braking fully from the first detection avoids it (min gap {:.2} m)", m.min_gap));
        }
    }
    (runs.len() / 2, bad, bound)
}

/// Every suite run the careful driver avoids ends without contact under each impairment, with no
/// exception: a run first detected too late to stop in (v2 braked fully from the frame after it
/// first detected the object, and braking fully from that first frame also ends in contact) fails
/// too. Before the neighbour tracker's lane rule R157 4.4_1 p5 was such a run under 0.3 s + 0.3 s
/// actuators; the tracker now reports the intruder when the careful driver perceives it.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn v2_avoids_what_the_careful_driver_avoids_under_each_impairment() {
    let mut all = Vec::new();
    for law in LAWS {
        for (name, patch) in impairments() {
            let (n, bad, bound) = failures(law, &patch);
            let law = law.as_str();
            println!(
                "{law}, {name}: {} of {n} runs with contact where the careful driver avoids; braked fully from the first detection: {bound:?}",
                bad.len()
            );
            all.extend(bad.into_iter().map(|b| format!("{law}, {name}: {b}")));
            if !bound.is_empty() {
                all.push(format!("{law}, {name}: {} runs first detected too late: {bound:?}", bound.len()));
            }
        }
    }
    assert!(all.is_empty(), "{}", all.join("\n"));
}

/// Steady following at the controller's own gap for 60 s (the lead holds its speed), with
/// `dropout` per-ray LiDAR dropout (at 50 % the detector misses frames at range).
fn steady(controller: ControllerKind, kmh: f64, dropout: f64) -> Scenario {
    let v = kmh / 3.6;
    let mut s = Scenario { name: format!("steady-{kmh}"), controller, duration: 60.0, ..Default::default() };
    s.v2v.enabled = false;
    s.speed_kmh = Some(kmh);
    s.track = TrackSpec::Straight { length: 5000.0 };
    s.lead.initial_speed = v;
    s.lead.phases = vec![Phase::Hold { until_x: None, until_t: None, duration: Some(60.0) }.into()];
    s.follower.initial_speed = v;
    s.follower.initial_gap = own_gap(&s, v);
    s.lidar.dropout_prob = dropout;
    s
}

/// No phantom braking: missed detections while following at steady state change the largest
/// deceleration by at most 1 m/s² and never take it above 3.5 m/s² (v1's figures printed beside).
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn missed_detections_while_following_cause_no_phantom_braking() {
    let speeds = [30.0, 50.0, 72.0, 100.0, 130.0];
    let mut runs = Vec::new();
    for kind in [ControllerKind::FlcRobust, ControllerKind::FlcRobustOdo, ControllerKind::FlcRobustV1] {
        for kmh in speeds {
            runs.push(steady(kind, kmh, 0.0));
            runs.push(steady(kind, kmh, 0.5));
        }
    }
    let res: Vec<_> = RunOptions::default().run_batch(&runs).into_iter().map(|r| r.unwrap()).collect();
    let mut bad = Vec::new();
    for (i, pair) in res.chunks(2).enumerate() {
        let (clean, fault) = (&pair[0].metrics, &pair[1].metrics);
        let (kind, kmh) = (runs[2 * i].controller, speeds[i % speeds.len()]);
        println!("{} {kmh} km/h: max decel {:.2} m/s² clean, {:.2} with 50 % ray dropout", kind.as_str(), clean.max_decel, fault.max_decel);
        if LAWS.contains(&kind) && (fault.max_decel > clean.max_decel + 1.0 || fault.max_decel > 3.5 || fault.collision) {
            bad.push(format!("{} {kmh} km/h: {:.2} m/s² (clean {:.2})", kind.as_str(), fault.max_decel, clean.max_decel));
        }
    }
    assert!(bad.is_empty(), "phantom braking: {}", bad.join("; "));
}

/// Approach: ego and lead at the same speed on a straight, the ego twice v2's desired gap behind;
/// after 30 s the gap is within 10 % of the desired gap. The ego never brakes (beyond 0.3 m/s²)
/// while it is not faster than the lead and more than 10 % beyond its gap, i.e. merely because
/// the lead is far, and sheds its
/// closing speed at no more than 3.5 m/s² (ISO 15622's limit for an ACC). Before (R8) this was
/// 20 s and 2 m/s²; (R8) trades them for no contact when the lead brakes during the approach
/// (`docs/robust-flc.md`, (R8): 25 s and 3.0 m/s² at 130 km/h).
#[test]
fn v2_closes_in_from_twice_its_gap_within_30_s() {
    let mut bad = Vec::new();
    for (law, kmh) in law_speeds(&[50.0, 100.0, 130.0]) {
        let law_name = law.as_str();
        let mut s = steady(law, kmh, 0.0);
        s.duration = 30.0;
        s.follower.initial_gap *= 2.0;
        let r = flc_sim::run(&s).unwrap();
        let x = &r.series;
        let n = x.len() - 1;
        let (gap, desired) = (x.gap[n], x.desired_gap[n]);
        // From t = 1 s: the first second is the vehicles settling into the run (drag before the
        // first commands), the same without any approach (`missed_detections_...`' clean runs).
        let far_brake = (0..=n)
            .filter(|&i| x.t[i] >= 1.0 && x.follower_speed[i] <= x.lead_speed[i] && x.gap[i] > 1.1 * x.desired_gap[i])
            .map(|i| -x.follower_accel[i])
            .fold(0.0, f64::max);
        println!(
            "{law_name} {kmh} km/h: gap {gap:.1} m after 30 s, desired {desired:.1} m, max decel {:.2} m/s², {far_brake:.2} while not faster than the lead",
            r.metrics.max_decel
        );
        if (gap - desired).abs() > 0.1 * desired || r.metrics.max_decel > 3.5 || far_brake > 0.3 || r.metrics.collision {
            bad.push(format!(
                "{law_name} {kmh} km/h: gap {gap:.1} m vs desired {desired:.1} m, max decel {:.2} m/s², {far_brake:.2}",
                r.metrics.max_decel
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("; "));
}

/// The faults of the phantom-braking target, each starting at the 20 Hz frame slot `t0`.
fn faults(t0: f64, gap: f64) -> Vec<(&'static str, LidarFault)> {
    let start = t0 - 0.01;
    vec![
        ("one missed detection", LidarFault::Blind { start, duration: 0.05 }),
        ("0.5 s without detection", LidarFault::Blind { start, duration: 0.5 }),
        ("one-frame spurious short return", LidarFault::Ghost { start, duration: 0.05, range: 0.4 * gap, width: 1.0 }),
    ]
}

/// No phantom braking, fault by fault: while following at steady state at 30-130 km/h, one
/// missed detection, 0.5 s without detection and a one-frame spurious short return (a 1 m face at
/// 40 % of the gap) change the largest deceleration by at most 1 m/s² against the same run
/// without the fault (same seed, same draws) and never take it above 3.5 m/s².
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn v2_single_faults_while_following_cause_no_phantom_braking() {
    let mut runs = Vec::new();
    let mut names = Vec::new();
    for (law, kmh) in law_speeds(&[30.0, 50.0, 72.0, 100.0, 130.0]) {
        let mut clean = steady(law, kmh, 0.0);
        clean.duration = 20.0;
        for (name, f) in faults(10.0, clean.follower.initial_gap) {
            let mut s = clean.clone();
            s.lidar.faults = vec![f];
            runs.push(s);
            names.push((law.as_str(), kmh, name));
        }
        runs.push(clean);
        names.push((law.as_str(), kmh, "clean"));
    }
    let res: Vec<_> = RunOptions::default().run_batch(&runs).into_iter().map(|r| r.unwrap()).collect();
    // The largest deceleration from the fault's onset on (stricter than over the whole run, whose
    // largest value is the first second's settling).
    let after = |r: &RunResult| {
        let x = &r.series;
        (0..x.len()).filter(|&i| x.t[i] >= 9.99).map(|i| -x.follower_accel[i]).fold(0.0, f64::max)
    };
    let mut bad = Vec::new();
    for (chunk, nm) in res.chunks(4).zip(names.chunks(4)) {
        let clean = after(&chunk[3]);
        for (r, (law, kmh, name)) in chunk[..3].iter().zip(nm) {
            let (m, x) = (&r.metrics, &r.series);
            // The fault reached the controller: a frame without a detection, or the ghost's distance.
            let seen = (0..x.len()).filter(|&i| x.t[i] >= 9.99 && x.t[i] < 10.6).any(|i| match r.scenario.lidar.faults[0] {
                LidarFault::Blind { .. } => x.detected_distance[i].is_nan(),
                LidarFault::Ghost { range, .. } => (x.detected_distance[i] - range).abs() < 1.0,
            });
            let decel = after(r);
            println!("{law} {kmh} km/h, {name}: max decel {decel:.2} m/s² from the onset (clean {clean:.2}), fault seen: {seen}");
            if !seen || decel > clean + 1.0 || m.max_decel > 3.5 || m.collision {
                bad.push(format!("{law} {kmh} km/h, {name}: {decel:.2} m/s² (clean {clean:.2}), seen {seen}"));
            }
        }
    }
    assert!(bad.is_empty(), "phantom braking: {}", bad.join("; "));
}

/// A 0.5 s detection dropout that starts at the lead's brake onset (-6 m/s² to a stop), following
/// at v2's own gap at 30-130 km/h: no contact.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn v2_a_dropout_at_the_brake_onset_causes_no_contact() {
    let cases = law_speeds(&[30.0, 50.0, 72.0, 100.0, 130.0]);
    let runs: Vec<_> = cases
        .iter()
        .map(|&(law, kmh)| {
            let mut s = steady(law, kmh, 0.0);
            s.duration = 40.0;
            s.lead.phases = vec![
                Phase::Hold { until_x: None, until_t: Some(10.0), duration: None }.into(),
                Phase::Brake { decel: 6.0, speed: None, speed_kmh: None }.into(),
            ];
            s.lidar.faults = vec![LidarFault::Blind { start: 9.99, duration: 0.5 }];
            s
        })
        .collect();
    let res: Vec<_> = RunOptions::default().run_batch(&runs).into_iter().map(|r| r.unwrap()).collect();
    let mut bad = Vec::new();
    for ((law, kmh), r) in cases.iter().zip(&res) {
        let (m, law) = (&r.metrics, law.as_str());
        println!(
            "{law} {kmh} km/h: min gap {:.2} m, final clearance {:?}, max decel {:.2} m/s²",
            m.min_gap, m.final_clearance, m.max_decel
        );
        if m.collision {
            bad.push(format!("{law} {kmh} km/h: contact at {:.1} m/s", m.impact_speed));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("; "));
}

/// The cases of the impairment target at 30-130 km/h (the suites stop at 80): following at v2's
/// own gap, the lead brakes at 2 or 6 m/s² to a stop after 10 s; the same while the ego
/// approaches from 2 and 3 times its gap (the lead brakes 10 s into the approach: the
/// falsifier's counterexample of `docs/safety-evidence.md`, without its LiDAR faults); and a
/// standing car first in the LiDAR's reach from 250 m away (beyond the detector's 200 m).
fn highway_cases(kmh: f64) -> Vec<(String, Scenario)> {
    let mut out = Vec::new();
    for decel in [2.0, 6.0] {
        for times in [1.0, 2.0, 3.0] {
            let mut s = steady(ControllerKind::FlcRobust, kmh, 0.0);
            s.duration = 10.0 + kmh / 3.6 / decel + 15.0;
            s.follower.initial_gap *= times;
            s.lead.phases = vec![
                Phase::Hold { until_x: None, until_t: Some(10.0), duration: None }.into(),
                Phase::Brake { decel, speed: None, speed_kmh: None }.into(),
            ];
            let from = if times == 1.0 { String::new() } else { format!(" from {times}x its gap") };
            out.push((format!("{kmh} km/h{from}, lead -{decel} m/s²"), s));
        }
    }
    let mut s = steady(ControllerKind::FlcRobust, kmh, 0.0);
    s.lead.initial_speed = 0.0;
    s.lead.phases = vec![Phase::Hold { until_x: None, until_t: None, duration: Some(600.0) }.into()];
    s.follower.initial_gap = 250.0;
    s.duration = 250.0 / (kmh / 3.6) + 30.0;
    out.push((format!("{kmh} km/h, standing car from 250 m"), s));
    out
}

/// The impairments of the suite target at 30-130 km/h: under each one, every case of
/// [`highway_cases`] the careful driver (same scenario, same impairment) avoids ends without
/// contact for v2, and no case needs full braking from the first detection.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn v2_impairments_at_30_to_130_kmh() {
    let reference = ControllerKind::parse("careful-driver").unwrap();
    let mut runs = Vec::new();
    let mut names = Vec::new();
    for (imp, patch) in impairments() {
        for kmh in [30.0, 50.0, 72.0, 100.0, 130.0] {
            for (case, s) in highway_cases(kmh) {
                let s = s.patched(&patch).unwrap();
                runs.push(Scenario { controller: reference, ..s.clone() });
                for law in LAWS {
                    runs.push(Scenario { controller: law, ..s.clone() });
                }
                names.push(format!("{imp}: {case}"));
            }
        }
    }
    let res: Vec<_> = RunOptions::default().run_batch(&runs).into_iter().map(|r| r.unwrap()).collect();
    let mut bad = Vec::new();
    let clear = |m: &flc_sim::Metrics| {
        if m.collision { format!("contact {:.1} m/s", m.impact_speed) } else { format!("min gap {:.2} m", m.min_gap) }
    };
    for (name, group) in names.iter().zip(res.chunks(1 + LAWS.len())) {
        let refr = &group[0].metrics;
        for (law, r) in LAWS.iter().zip(&group[1..]) {
            let own = &r.metrics;
            println!("{name}: careful driver {}, {} {} (max decel {:.2} m/s²)", clear(refr), law.as_str(), clear(own), own.max_decel);
            if !refr.collision && own.collision {
                bad.push(format!("{name}, {}: {}", law.as_str(), clear(own)));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The comfort cases the issue names, for each of `laws`, with `patch`: the six runs of R157
/// 4.3_1 (the lead slows at 1 or 2 m/s² to 20-40 km/h) and NCAP CCRb 40 m / -2 m/s²; names
/// `"<law> <case> <run>"`.
fn comfort_cases(laws: &[ControllerKind], patch: &Patch) -> Vec<(String, Scenario)> {
    let mut runs = Vec::new();
    for suite in Suite::find(&default_root().expect("suites folder"), "all").unwrap() {
        for r in suite.runs(laws).unwrap() {
            let case = &suite.spec.cases[r.case].id;
            if case == "4.3_1" || (case == "CCRb" && r.run.contains("Headway=40 Decel=2")) {
                runs.push((format!("{} {case} {}", r.scenario.controller.as_str(), r.run), r.scenario.patched(patch).unwrap()));
            }
        }
    }
    assert_eq!(runs.len(), 7 * laws.len(), "{:?}", runs.iter().map(|(n, _)| n).collect::<Vec<_>>());
    runs
}

/// The comfort target on the standard cases the issue names ([`comfort_cases`],
/// [`comfort_miss`]), NCAP CCRb 40 m / -2 m/s² included, for both laws.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn v2_comfort_in_the_standard_cases() {
    let runs = comfort_cases(&LAWS, &Patch::new());
    let res = RunOptions::default().run_batch(&runs.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>());
    let bad: Vec<_> = runs.iter().zip(res).filter_map(|((name, _), r)| comfort_miss(name, &r.unwrap())).collect();
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The comfort layer's constants, one at a time, in NCAP CCRb 40 m / -2 m/s² (the case that
/// needs it), for both laws: the map is printed (`docs/robust-flc.md` states it), and the bands
/// the docs give as meeting the target (3.5 m/s², 2.5 m/s³, stop at 2-5 m) are asserted.
/// `(key, value, meets)`: `meets` marks the values inside the stated band.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn comfort_band() {
    /// A constant's key, how to set it, and its values with whether each is inside the stated band.
    type Axis = (&'static str, fn(&mut flc_core::ComfortParams, f64), &'static [(f64, bool)]);
    let axes: [Axis; 3] = [
        (
            "comfort.memory",
            |c, x| c.memory = x,
            &[(0.3, true), (0.5, true), (0.75, true), (1.0, true), (1.5, true), (2.0, false), (3.0, false)],
        ),
        (
            "comfort.response_time",
            |c, x| c.response_time = x,
            &[(0.1, false), (0.2, true), (0.3, true), (0.45, true), (0.6, true), (1.0, false), (2.0, false)],
        ),
        (
            "comfort.accel",
            |c, x| c.accel = x,
            &[(0.5, false), (0.6, false), (0.75, true), (0.85, true), (1.0, true), (1.25, true), (1.5, false), (2.0, false)],
        ),
    ];
    let mut bad = Vec::new();
    for law in LAWS {
        let (_, base) = comfort_cases(&[law], &Patch::new()).into_iter().find(|(n, _)| n.contains("CCRb")).unwrap();
        for (key, set, values) in axes {
            let runs: Vec<_> = values
                .iter()
                .map(|&(x, _)| {
                    let mut s = base.clone();
                    set(&mut s.flc_robust.comfort, x);
                    s
                })
                .collect();
            let res: Vec<_> = RunOptions::default().run_batch(&runs).into_iter().map(|r| r.unwrap()).collect();
            for (&(x, inside), r) in values.iter().zip(&res) {
                let miss = comfort_miss(&format!("{} {key} {x}", law.as_str()), r);
                println!("{} {key} {x}: {}", law.as_str(), if miss.is_none() { "meets" } else { "misses" });
                if inside {
                    bad.extend(miss);
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("; "));
}

/// The odometry variant with a wheel odometry off by ±3 % (a worn or under-inflated tyre is
/// about 1 %): every suite run the careful driver avoids still ends without contact, and the
/// comfort cases of [`v2_comfort_in_the_standard_cases`] still meet the target.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn odo_with_an_odometry_scale_error() {
    let mut bad = Vec::new();
    for scale in [0.97, 1.03] {
        let mut patch = Patch::new();
        patch.set("follower.odometry_scale", toml::Value::Float(scale));
        let (n, contacts, bound) = failures(ControllerKind::FlcRobustOdo, &patch);
        println!("odometry x {scale}: {} of {n} runs with contact where the careful driver avoids ({bound:?})", contacts.len());
        bad.extend(contacts.into_iter().chain(bound).map(|b| format!("x {scale}: {b}")));
        let runs = comfort_cases(&[ControllerKind::FlcRobustOdo], &patch);
        let res = RunOptions::default().run_batch(&runs.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>());
        for ((name, _), r) in runs.iter().zip(res) {
            bad.extend(comfort_miss(&format!("odometry x {scale}, {name}"), &r.unwrap()).map(|m| format!("x {scale}: {m}")));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The four impairments at once (brakes 6 m/s², 0.3 + 0.3 s actuator delay, LiDAR 10 Hz with
/// 100 ms and 3 cm), beyond the list: both laws end in contact only where braking fully
/// from the first detection does too (the R157 cut-ins, first seen too close for this detector and
/// actuator). Without the comfort layer v2 also hit the lead of CCRb 40 m / -6 m/s² here
/// (`docs/robust-flc.md`).
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn under_the_four_impairments_at_once() {
    let mut all = Patch::new();
    for (_, p) in impairments() {
        all.append(&p);
    }
    let mut bad = Vec::new();
    for law in LAWS {
        let (n, contacts, bound) = failures(law, &all);
        println!(
            "{}: {} of {n} runs with contact where the careful driver avoids; perception bound: {bound:?}",
            law.as_str(),
            contacts.len()
        );
        bad.extend(contacts);
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Beyond the list: each pair of the impairments, and brakes limited to 4 m/s²
/// (a wet road, not told): both laws end in contact only where braking fully from the first
/// detection does too (R157 cut-ins first seen too close for the detector and the actuator).
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn under_each_pair_of_impairments_and_4_m_s2_brakes() {
    let imps = impairments();
    let mut combos: Vec<(String, Patch)> = Vec::new();
    for (i, (a, pa)) in imps.iter().enumerate().skip(1) {
        for (b, pb) in imps.iter().skip(i + 1) {
            combos.push((format!("{a} + {b}"), Patch::new().append(pa).append(pb).clone()));
        }
    }
    let mut wet = Patch::new();
    wet.set("follower.vehicle.max_brake", toml::Value::Float(4.0));
    combos.push(("brakes 4 m/s²".into(), wet));
    assert_eq!(combos.len(), 4);
    let mut bad = Vec::new();
    for (name, patch) in &combos {
        for law in LAWS {
            let (n, contacts, bound) = failures(law, patch);
            println!(
                "{name}, {}: {} of {n} runs with contact where the careful driver avoids; perception bound: {bound:?}",
                law.as_str(),
                contacts.len()
            );
            bad.extend(contacts.into_iter().map(|c| format!("{name}, {}: {c}", law.as_str())));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
