//! Platoon acceptance tests (issue 8): one follower is the same simulator, occlusion, V2V
//! sources and propagating loss, scenario validation, the shipped brake demo and |Gamma(jw)|.

use std::path::Path;

use flc_sim::frequency_response::frequency_response_at;
use flc_sim::{ACTIVE_FLC, Series};
use flc_sim::{ControllerKind, Phase, Scenario, TrackSpec};
use flc_sim::{FollowerOverride, PlatoonSpec, V2vSource};
use flc_sim::{RunResult, run};

/// Every column equal bit for bit (NaN included).
fn same_bits(a: &Series, b: &Series) -> bool {
    let (ca, cb) = (a.columns(), b.columns());
    ca.len() == cb.len()
        && ca
            .iter()
            .zip(&cb)
            .all(|((na, xa), (nb, xb))| na == nb && xa.len() == xb.len() && xa.iter().zip(xb).all(|(x, y)| x.to_bits() == y.to_bits()))
}

fn assert_bit_identical(a: &RunResult, b: &RunResult, what: &str) {
    let (ca, cb) = (a.series.columns(), b.series.columns());
    assert_eq!(ca.len(), cb.len());
    for ((na, xa), (nb, xb)) in ca.iter().zip(&cb) {
        assert_eq!(na, nb);
        assert_eq!(xa.len(), xb.len(), "{what}: {na} length");
        for (i, (x, y)) in xa.iter().zip(xb).enumerate() {
            assert_eq!(x.to_bits(), y.to_bits(), "{what}: {na}[{i}] {x} vs {y}");
        }
    }
    // Debug prints every f64 with its shortest round-trip form: equal strings, equal bits.
    assert_eq!(format!("{:?}", a.metrics), format!("{:?}", b.metrics), "{what}: metrics");
}

/// Lead and follower(s) at 20 m/s, the lead brakes at -6 m/s² after 8 s.
fn short_brake(controller: ControllerKind) -> Scenario {
    let mut s = Scenario { name: "short-brake".into(), controller, duration: 25.0, ..Default::default() };
    s.lead.initial_speed = 20.0;
    s.lead.phases = vec![
        Phase::Hold { until_x: None, until_t: Some(8.0), duration: None }.into(),
        Phase::Brake { decel: 6.0, speed: None, speed_kmh: None }.into(),
    ];
    s.follower.initial_speed = 20.0;
    s.follower.initial_gap = 22.0;
    s.v2v.enabled = controller != ControllerKind::Flc;
    s.v2v.outage_on_brake = controller == ControllerKind::Pipeline;
    s.lidar.scan_drop_prob = 0.05;
    s.v2v.loss_prob = 0.1;
    s
}

fn file(name: &str) -> Scenario {
    Scenario::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios").join(name)).expect("scenario file")
}

#[test]
fn one_follower_platoon_equals_the_single_follower_simulator() {
    let mut curvy = file("curvy-follow.toml");
    curvy.duration = 15.0;
    let mut outage = file("v2v-outage.toml");
    outage.duration = 36.0;
    let cases = [short_brake(ControllerKind::Pipeline), short_brake(ControllerKind::Flc), short_brake(ControllerKind::Pid), curvy, outage];
    for s in cases {
        let single = run(&s).expect("single follower");
        assert!(single.platoon.is_none());
        for source in [V2vSource::Predecessor, V2vSource::Lead, V2vSource::Both] {
            let p = Scenario { platoon: Some(PlatoonSpec { followers: 1, v2v_source: source, ..PlatoonSpec::default() }), ..s.clone() };
            let platoon = run(&p).expect("platoon of one");
            let what = format!("{} {} {source:?}", s.name, s.controller.as_str());
            assert_bit_identical(&single, &platoon, &what);
            let pr = platoon.platoon.as_ref().expect("platoon result");
            assert_eq!(pr.followers.len(), 1);
            assert!(same_bits(&pr.followers[0].series, &single.series), "{what}");
            assert!(pr.string_stability.gap_ratio_peak.is_empty());
        }
    }
}

/// Three FLC followers behind a lead at 20 m/s, in formation.
fn string_of_three() -> Scenario {
    let mut s = Scenario { name: "three".into(), controller: ControllerKind::Flc, duration: 12.0, ..Default::default() };
    s.lead.initial_speed = 20.0;
    s.lead.phases = vec![Phase::Hold { until_x: None, until_t: Some(1000.0), duration: None }.into()];
    s.follower.initial_speed = 20.0;
    s.v2v.enabled = false;
    s.platoon = Some(PlatoonSpec { followers: 3, equilibrium_start: true, ..PlatoonSpec::default() });
    s
}

#[test]
fn each_detector_sees_its_predecessor_not_the_vehicle_two_ahead() {
    let r = run(&string_of_three()).expect("run");
    let p = r.platoon.expect("platoon");
    for (k, f) in p.followers.iter().enumerate() {
        let s = &f.series;
        let mut seen = 0;
        for i in 0..s.len() {
            let d = s.detected_distance[i];
            if !d.is_finite() {
                continue;
            }
            seen += 1;
            // The detected distance is the gap to the vehicle in front (LiDAR noise, one physics
            // step of motion between scan and record)...
            assert!((d - s.gap[i]).abs() < 0.25, "follower {}: detected {d} vs gap {} at t = {}", k + 1, s.gap[i], s.t[i]);
            // ... never the one two ahead, whose rear is a car length and a gap further.
            if k >= 1 {
                let two_ahead = s.gap[i] + 4.9 + p.followers[k - 1].series.gap[i];
                assert!(d < two_ahead - 10.0, "follower {}: {d} vs {two_ahead}", k + 1);
            }
        }
        assert!(seen as f64 > 0.95 * s.len() as f64, "follower {}: lead detected in {seen} of {} steps", k + 1, s.len());
        // In formation: the FLC's desired gap at 20 m/s, D_d + F_shift = 20 + 6 + 8 = 34 m.
        assert!((s.gap[0] - 34.0).abs() < 0.05, "{}", s.gap[0]);
    }
}

#[test]
fn follower_series_are_against_the_vehicle_in_front() {
    let r = run(&string_of_three()).expect("run");
    let p = r.platoon.expect("platoon");
    let (f1, f2) = (&p.followers[0].series, &p.followers[1].series);
    assert_eq!(f2.lead_x, f1.follower_x);
    assert_eq!(f2.lead_speed, f1.follower_speed);
    assert!(same_bits(&r.series, f1));
    // Gaps: front of follower 2 to rear of follower 1.
    let i = f2.len() - 1;
    // Along the front vehicle's heading (bumper_gap), lengths 4.9 m.
    let (dx, dy, yaw) = (f2.lead_x[i] - f2.follower_x[i], f2.lead_y[i] - f2.follower_y[i], f1.follower_yaw[i]);
    assert!((dx * yaw.cos() + dy * yaw.sin() - 4.9 - f2.gap[i]).abs() < 1e-9, "{dx} {dy} {yaw} {}", f2.gap[i]);
}

/// Four pipeline followers at 20 m/s; the link into follower 2 is down from t = 5 s.
fn broken_link(source: V2vSource, relay: bool) -> RunResult {
    let mut s = string_of_three();
    s.controller = ControllerKind::Pipeline;
    s.v2v.enabled = true;
    s.duration = 9.0;
    let patch: toml::Table = toml::from_str("v2v = { outages = [{ start = 5.0, end = 1e9 }] }").expect("toml");
    s.platoon = Some(PlatoonSpec {
        followers: 4,
        v2v_source: source,
        relay,
        equilibrium_start: true,
        overrides: vec![FollowerOverride { followers: vec![2], patch }],
        ..PlatoonSpec::default()
    });
    run(&s).expect("run")
}

/// Share of the last 2 s each follower drove with the FLC.
fn flc_share_at_end(r: &RunResult) -> Vec<f64> {
    r.platoon
        .as_ref()
        .expect("platoon")
        .followers
        .iter()
        .map(|f| {
            let s = &f.series;
            let last: Vec<u8> = s.active.iter().zip(&s.t).filter(|(_, t)| **t > 7.0).map(|(a, _)| *a).collect();
            last.iter().filter(|a| **a == ACTIVE_FLC).count() as f64 / last.len() as f64
        })
        .collect()
}

#[test]
fn a_broken_link_cuts_off_only_its_follower_unless_the_lead_is_relayed() {
    // Direct links (predecessor or lead broadcasts): only follower 2 falls back to the FLC.
    for source in [V2vSource::Predecessor, V2vSource::Lead] {
        let share = flc_share_at_end(&broken_link(source, false));
        assert_eq!(share, vec![0.0, 1.0, 0.0, 0.0], "{source:?}");
    }
    // The lead's speed relayed hop by hop: the loss propagates to everyone behind follower 2.
    let share = flc_share_at_end(&broken_link(V2vSource::Lead, true));
    assert_eq!(share, vec![0.0, 1.0, 1.0, 1.0]);
    // Both links: follower 2 loses its predecessor link (which the PID needs); 3 and 4 keep theirs.
    let share = flc_share_at_end(&broken_link(V2vSource::Both, false));
    assert_eq!(share, vec![0.0, 1.0, 0.0, 0.0]);
}

#[test]
fn platoon_keys_are_validated_with_dotted_names() {
    let base = "controller = \"pipeline\"\n[platoon]\nfollowers = 3\n";
    let err = |extra: &str| Scenario::from_toml_str(&format!("{base}{extra}"), "t.toml").expect_err(extra).to_string();
    assert!(Scenario::from_toml_str(base, "t.toml").is_ok());
    let e = Scenario::from_toml_str("[platoon]\nfollowers = 0\n", "t.toml").expect_err("0 followers").to_string();
    assert!(e.contains("`platoon.followers`") && e.contains("[1, 64]"), "{e}");
    let e = err("lead_weight = 2.0\n");
    assert!(e.contains("`platoon.lead_weight`"), "{e}");
    let e = err("v2v_source = \"everyone\"\n");
    assert!(e.contains("platoon.v2v_source") && e.contains("predecessor"), "{e}");
    let e = err("bogus = 1\n");
    assert!(e.contains("platoon") && e.contains("bogus"), "{e}");
    let e = err("[[platoon.overrides]]\nfollowers = [4]\n");
    assert!(e.contains("`platoon.overrides[0].followers[0]`") && e.contains("[1, 3]"), "{e}");
    let e = err("[[platoon.overrides]]\nfollowers = [2]\nv2v = { loss_prob = 1.5 }\n");
    assert!(e.contains("`platoon.overrides[0].v2v.loss_prob`"), "{e}");
    let e = err("[[platoon.overrides]]\nfollowers = [2]\nlidar = { bogus = 1 }\n");
    assert!(e.contains("platoon.overrides[0].lidar") && e.contains("bogus"), "{e}");
    let e = err("[[platoon.overrides]]\nfollowers = [2]\nlead = { initial_speed = 1 }\n");
    assert!(e.contains("platoon.overrides[0]") && e.contains("lead"), "{e}");
    let e = err("[platoon.string_stability]\nfrequencies_hz = [0.1, 9.0]\n");
    assert!(e.contains("`platoon.string_stability.frequencies_hz[1]`"), "{e}");
    let e = err("[[variants]]\nname = \"x\"\nv2v = { rate_hz = 0 }\n");
    assert!(e.contains("`variants[0].v2v.rate_hz`"), "{e}");
    let e = err("[[variants]]\nname = \"x\"\nplatoon = { followers = 99 }\n");
    assert!(e.contains("`variants[0].platoon.followers`"), "{e}");
    // Overrides patch key by key: the rest of [v2v] is kept.
    let s = Scenario::from_toml_str(
        &format!("{base}[v2v]\nrate_hz = 20.0\n[[platoon.overrides]]\nfollowers = [2, 3]\nv2v = {{ loss_prob = 0.5 }}\n"),
        "t.toml",
    )
    .expect("ok");
    let c = s.follower_configs().expect("configs");
    assert_eq!((c[0].v2v.loss_prob, c[1].v2v.loss_prob, c[2].v2v.loss_prob), (0.0, 0.5, 0.5));
    assert!(c.iter().all(|c| c.v2v.rate_hz == 20.0));
    // Round trip through TOML and JSON.
    let back = Scenario::from_toml_str(&s.to_toml().expect("toml"), "back.toml").expect("round trip");
    assert_eq!(back, s);
    let json: Scenario = serde_json::from_str(&serde_json::to_string(&s).expect("json")).expect("json back");
    assert_eq!(json, s);
}

#[test]
fn the_brake_demo_file_is_the_built_in_scenario() {
    assert_eq!(file("platoon-brakedemo.toml"), flc_sim::presets::brakedemo());
}

#[test]
fn the_brake_demo_stops_every_variant_without_collision() {
    let demo = file("platoon-brakedemo.toml");
    let variants = demo.expand_variants().expect("variants");
    let names: Vec<&str> = variants.iter().map(|v| v.variant.as_deref().unwrap_or("")).collect();
    assert_eq!(names, ["pid-v2v", "flc", "pipeline-outage"]);
    let results = flc_sim::RunOptions::default().run_batch(&variants);
    let mut gap_peak = Vec::new();
    for (v, r) in variants.iter().zip(results) {
        let r = r.expect("run");
        let name = v.variant.clone().unwrap_or_default();
        let p = r.platoon.as_ref().expect("platoon");
        assert_eq!(p.followers.len(), 7);
        let ss = &p.string_stability;
        assert!((ss.window_start - 20.0).abs() < 0.011, "{name}: window starts at the brake onset, {}", ss.window_start);
        assert_eq!(ss.gap_ratio_peak.len(), 6);
        assert!(ss.collisions.is_empty(), "{name}: {:?}", ss.collisions);
        for (k, f) in p.followers.iter().enumerate() {
            let m = &f.metrics;
            assert!(!m.collision, "{name}: follower {} collided", k + 1);
            let c = m.final_clearance.unwrap_or(f64::NAN);
            assert!(c > 4.5 && c < 7.0, "{name}: follower {} clearance {c}", k + 1);
            let s = &f.series;
            let after = |t0: f64, t1: f64| s.active.iter().zip(&s.t).filter(move |(_, t)| **t > t0 && **t < t1).map(|(a, _)| *a);
            match name.as_str() {
                // With V2V the PID drives every follower through the braking.
                "pid-v2v" => assert!(after(20.0, 30.0).all(|a| a != ACTIVE_FLC), "follower {}", k + 1),
                "flc" => assert_eq!(m.time_pid, 0.0),
                // Every link is lost at the onset: every follower hands over to the FLC within
                // max_age_ticks (4 scans, 0.2 s) plus one V2V period.
                _ => assert!(after(20.35, 30.0).all(|a| a == ACTIVE_FLC), "follower {}", k + 1),
            }
        }
        gap_peak.push(ss.gap_error_peak.iter().copied().fold(0.0, f64::max));
    }
    // The FLC taking over (larger desired gap) opens the gaps: the largest gap errors w.r.t. the
    // PID's spacing policy.
    assert!(gap_peak[2] > 2.0 * gap_peak[0], "{gap_peak:?}");
}

#[test]
fn frequency_response_separates_the_flc_from_the_pid() {
    // |Gamma(jw)| at 0.1 Hz for a string of three: the FLC amplifies the lead's oscillation, the
    // PID with V2V passes it on almost unchanged.
    let mut s = string_of_three();
    s.track = TrackSpec::Straight { length: 3000.0 };
    s.platoon.as_mut().expect("platoon").string_stability.min_fit_time = 20.0;
    let flc = frequency_response_at(&s, &[0.1]).expect("flc");
    s.controller = ControllerKind::Pipeline;
    s.v2v.enabled = true;
    let pid = frequency_response_at(&s, &[0.1]).expect("pid");
    let (gf, gp) = (&flc[0], &pid[0]);
    assert_eq!(gf.gamma.len(), 3);
    assert!(!gf.collision && !gp.collision);
    assert!((gf.amplitude[0] - 1.0).abs() < 0.15, "lead amplitude {}", gf.amplitude[0]);
    assert!(gf.gamma[0] > 1.3, "FLC {:?}", gf.gamma);
    assert!(gp.gamma.iter().all(|g| (0.9..1.1).contains(g)), "PID {:?}", gp.gamma);
}
