//! Robust FLC v2 (issue 24, in progress) on the standard suites under the impairments:
//! every run the careful-driver reference avoids must end without contact for `flc-robust-v2`.

use flc_sim::suite::{Suite, default_root};
use flc_sim::{ControllerKind, Patch, Phase, RunOptions, Scenario, TrackSpec};

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
    let mut v = vec![("default", none), ("brakes 6 m/s²", brakes), ("dead time 0.3 s + lag 0.3 s", actuator), ("LiDAR 10 Hz, 100 ms, 3 cm", lidar)];
    if let Ok(t) = std::env::var("FLC_TRY") {
        for (_, p) in &mut v {
            for kv in t.split(',') {
                let (k, x) = kv.split_once('=').unwrap();
                p.set(k, toml::Value::Float(x.parse().unwrap()));
            }
        }
    }
    v
}

/// Runs every suite run with the reference and `kind` under `patch`; returns the runs the
/// reference avoids and `kind` does not, as `suite/run: impact speed`.
fn failures(kind: ControllerKind, patch: &Patch) -> (usize, Vec<String>) {
    let reference = ControllerKind::parse("careful-driver").unwrap();
    let mut runs = Vec::new();
    for suite in Suite::find(&default_root(), "all").unwrap() {
        for r in suite.runs(&[reference, kind]).unwrap() {
            let s = r.scenario.patched(patch).unwrap();
            runs.push((format!("{}/{}", suite.spec.name, r.run), s));
        }
    }
    let results: Vec<_> =
        RunOptions::default().run_batch(&runs.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>()).into_iter().map(|r| r.unwrap()).collect();
    let mut bad = Vec::new();
    for (pair, res) in runs.chunks(2).zip(results.chunks(2)) {
        if let ([(name, _), _], [refr, own]) = (pair, res) {
            if !refr.metrics.collision && own.metrics.collision {
                bad.push(format!("{name}: contact at {:.1} m/s", own.metrics.impact_speed));
            }
        }
    }
    (runs.len() / 2, bad)
}

#[test]
#[ignore = "issue 24 open: CCRb 40 m / 6 m/s² ends in contact with 6 m/s² brakes (4.4 m/s), 0.3 + 0.3 s actuator delay (7.6 m/s) and the 10 Hz LiDAR (1.4 m/s); the R157 4.4_1 cut-in p5 with the actuator delay at 0.1 m/s (docs/robust-flc.md, v2)"]
fn v2_avoids_what_the_careful_driver_avoids_under_each_impairment() {
    let v2 = ControllerKind::parse("flc-robust-v2").unwrap();
    let mut all = Vec::new();
    for (name, patch) in impairments() {
        let (n, bad) = failures(v2, &patch);
        println!("{name}: {} of {n} runs with contact where the careful driver avoids", bad.len());
        all.extend(bad.into_iter().map(|b| format!("{name}: {b}")));
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
    s.follower.initial_gap = match controller {
        ControllerKind::FlcRobust2 => s.flc_robust2.law.desired_gap(v),
        ControllerKind::FlcRobust => s.flc_robust.desired_gap(v),
        other => panic!("no own gap for {}", other.as_str()),
    };
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
    for kind in [ControllerKind::FlcRobust2, ControllerKind::FlcRobust] {
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
        if kind == ControllerKind::FlcRobust2 && (fault.max_decel > clean.max_decel + 1.0 || fault.max_decel > 3.5 || fault.collision) {
            bad.push(format!("{kmh} km/h: {:.2} m/s² (clean {:.2})", fault.max_decel, clean.max_decel));
        }
    }
    assert!(bad.is_empty(), "phantom braking: {}", bad.join("; "));
}

/// Approach: ego and lead at the same speed on a straight, the ego twice v2's desired gap behind;
/// after 20 s the gap is within 10 % of the desired gap, and the ego never brakes harder than
/// 0.5 m/s² on the way (no braking merely because the lead is far).
#[test]
#[ignore = "issue 24 open: v2 reaches its desired gap within 20 s, but its gap policy closes at up to 10 m/s and then brakes at 7.4-8.4 m/s² (docs/robust-flc.md, v2)"]
fn v2_closes_in_from_twice_its_gap_within_20_s() {
    let mut bad = Vec::new();
    for kmh in [50.0, 100.0, 130.0] {
        let v = kmh / 3.6;
        let mut s = steady(ControllerKind::FlcRobust2, kmh, 0.0);
        s.duration = 20.0;
        s.follower.initial_gap *= 2.0;
        let r = flc_sim::run(&s).unwrap();
        let n = r.series.len() - 1;
        let (gap, desired) = (r.series.gap[n], r.series.desired_gap[n]);
        println!("{kmh} km/h: gap {gap:.1} m after 20 s, desired {desired:.1} m, max decel {:.2} m/s²", r.metrics.max_decel);
        if (gap - desired).abs() > 0.1 * desired || r.metrics.max_decel > 0.5 || r.metrics.collision {
            bad.push(format!(
                "{kmh} km/h: gap {gap:.1} m vs desired {desired:.1} m (start {:.1}), max decel {:.2} m/s², speed {:.1} km/h",
                2.0 * s.flc_robust2.law.desired_gap(v),
                r.metrics.max_decel,
                r.series.follower_speed[n] * 3.6
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("; "));
}
