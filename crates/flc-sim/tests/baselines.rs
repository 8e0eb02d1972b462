//! The baseline controllers of issue 6 inside the closed loop: selected by name, parameterised by
//! their scenario sections, fed only the LiDAR detector's distance and the own speed.

use flc_sim::run;
use flc_sim::{ControllerKind, Phase, Scenario};

const BASELINES: [ControllerKind; 4] = [ControllerKind::Idm, ControllerKind::Acc, ControllerKind::Rss, ControllerKind::CarlaBehavior];

/// A lead that accelerates gently to 20 m/s and holds it; every baseline's set speed is 25 m/s.
fn steady(controller: ControllerKind) -> Scenario {
    let mut s = Scenario { name: "steady".into(), controller, duration: 120.0, ..Default::default() };
    s.lead.phases = vec![
        Phase::Accelerate { accel: 0.5, speed: Some(20.0), speed_kmh: None }.into(),
        Phase::Hold { until_x: None, until_t: Some(1000.0), duration: None }.into(),
    ];
    s.v2v.enabled = false;
    s.idm.desired_speed = 25.0;
    s.acc.desired_speed = 25.0;
    s.rss.desired_speed = 25.0;
    s.carla_behavior.cruise_speed = 25.0;
    s.carla_behavior.speed_limit = 25.0;
    s
}

/// Gap, speed and recorded desired gap at the end of the run.
fn final_gap_and_speed(s: &Scenario) -> (f64, f64, f64) {
    let r = run(s).expect("run");
    assert!(!r.metrics.collision, "{}: collided", s.controller.as_str());
    let n = r.series.len();
    (r.series.gap[n - 1], r.series.follower_speed[n - 1], r.series.desired_gap[n - 1])
}

/// Mean speed, smallest and largest gap over the last `window` seconds.
fn tail_stats(s: &Scenario, window: f64) -> (f64, f64, f64) {
    let r = run(s).expect("run");
    assert!(!r.metrics.collision, "{}: collided", s.controller.as_str());
    let t_end = r.series.t[r.series.len() - 1];
    let idx: Vec<usize> = (0..r.series.len()).filter(|&i| r.series.t[i] >= t_end - window).collect();
    let mean = idx.iter().map(|&i| r.series.follower_speed[i]).sum::<f64>() / idx.len() as f64;
    let lo = idx.iter().map(|&i| r.series.gap[i]).fold(f64::INFINITY, f64::min);
    let hi = idx.iter().map(|&i| r.series.gap[i]).fold(f64::NEG_INFINITY, f64::max);
    (mean, lo, hi)
}

/// The desired gap of the scenario's law at own speed `v`, m.
fn law_gap(s: &Scenario, v: f64) -> f64 {
    s.base_follower_config().longitudinal().expect("law").desired_gap(v)
}

/// Every baseline ends up at the lead's speed and at its own law's steady-state gap
/// (its `desired_gap`, the law's own formula in flc-core): IDM's equilibrium, the ACC's `min_gap + t_hw v`, RSS's
/// `d_min + margin`; the CARLA agent, which has no gap law, settles inside its second TTC band.
#[test]
fn every_baseline_follows_a_steady_lead_at_its_own_gap() {
    for c in [ControllerKind::Idm, ControllerKind::Acc, ControllerKind::Rss] {
        let s = steady(c);
        let (gap, v, desired) = final_gap_and_speed(&s);
        assert!((v - 20.0).abs() < 0.3, "{}: speed {v}", c.as_str());
        assert!((desired - law_gap(&s, v)).abs() < 1e-9, "{}: recorded desired gap", c.as_str());
        // The laws regulate the detector's distance, a few cm short of the bumper gap (the first
        // LiDAR return on the lead's rear), so the true gap settles that much long: measured after
        // 120 s ACC +0.042 m, RSS +0.023 m. IDM approaches its equilibrium asymptotically (the
        // (s*/s)² term vanishes only at the equilibrium) and is still 0.23 m (0.5 %) short at
        // 120 s. Bounds: 0.1 m for the ranging bias, 0.5 m for IDM's slow approach (the 10 %
        // these replaced would have passed gaps 2-4 m off).
        let tol = if c == ControllerKind::Idm { 0.5 } else { 0.1 };
        assert!((gap - desired).abs() < tol, "{}: gap {gap} vs desired {desired}", c.as_str());
    }
    // The CARLA agent's speed bands make it hunt around the lead's speed (limit cycle) while the
    // gap stays between the emergency-stop distance and the upper edge of the second band.
    let s = steady(ControllerKind::CarlaBehavior);
    let (mean, lo, hi) = tail_stats(&s, 30.0);
    let p = &s.carla_behavior;
    assert!((mean - 20.0).abs() < 0.5, "carla: mean speed {mean}");
    assert!(lo > p.braking_distance * 0.5 && hi < 2.0 * law_gap(&s, 20.0), "carla: gap in [{lo}, {hi}]");
}

/// The `[idm]` section of a scenario file reaches the controller: a 1 s longer time headway
/// means a gap longer by about `v * 1 s / sqrt(1 - (v/v0)^4)` at 20 m/s (26 m at v0 = 25 m/s).
#[test]
fn baseline_parameters_come_from_the_scenario_file() {
    let base = steady(ControllerKind::Idm).to_toml().expect("toml");
    let with = |t: f64| {
        let text = base.replace("[idm]\n", &format!("[idm]\ntime_headway = {t}\n")).replacen("time_headway = 1.6\n", "", 1);
        Scenario::from_toml_str(&text, "idm.toml").expect("parse")
    };
    let (g1, _, _) = final_gap_and_speed(&with(1.0));
    let (g2, _, _) = final_gap_and_speed(&with(2.0));
    let expected = 20.0 / (1.0_f64 - (20.0_f64 / 25.0).powi(4)).sqrt();
    // IDM is still approaching both equilibria at 120 s, the longer one more slowly: measured
    // 25.63 m against 26.03 m; 1 m allows for that approach.
    assert!(((g2 - g1) - expected).abs() < 1.0, "gap grew by {} m, expected {expected}", g2 - g1);
}

/// Out-of-range and unknown baseline parameters are errors naming the dotted key.
#[test]
fn bad_baseline_parameters_name_the_key() {
    let cases = [
        ("controller = \"acc\"\n[acc]\nheadway_time = -1.0\n", "acc.headway_time"),
        ("controller = \"rss\"\n[rss]\nresponse_time = nan\n", "rss.response_time"),
        ("controller = \"idm\"\n[idm]\nbogus = 1.0\n", "idm"),
        ("controller = \"carla-behavior\"\n[carla_behavior]\nsafety_time = 0.0\n", "carla_behavior.safety_time"),
        ("controller = \"idm-ish\"\n", "controller"),
    ];
    for (text, key) in cases {
        let err = Scenario::from_toml_str(text, "bad.toml").expect_err(text).to_string();
        assert!(err.contains(key), "`{text}` -> {err}");
    }
    assert!(Scenario::from_toml_str("controller = \"idm-ish\"\n", "bad.toml").unwrap_err().to_string().contains("carla-behavior"));
}

/// Identical sensing: a baseline never sees V2V, so switching the V2V link on changes nothing,
/// bit for bit.
#[test]
fn baselines_ignore_v2v() {
    for c in BASELINES {
        let mut a = Scenario::paper_experiment(50.0, c, flc_sim::Calibration::Realistic);
        a.duration = 20.0;
        let mut b = a.clone();
        b.v2v.enabled = true;
        let (ra, rb) = (run(&a).expect("run"), run(&b).expect("run"));
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&ra.series.follower_speed), bits(&rb.series.follower_speed), "{}", c.as_str());
    }
}
