//! Closed-loop integration tests of the simulator (issue: simulator acceptance).

use flc_sim::{Calibration, ControllerKind, Phase, Scenario, TrackSpec};
use flc_sim::{RunOptions, run};

fn paper(speed: f64, c: ControllerKind, cal: Calibration) -> flc_sim::Metrics {
    run(&Scenario::paper_experiment(speed, c, cal)).expect("run").metrics
}

/// With the realistic vehicle (8 m/s² brakes, full brake authority) the FLC stops safely at all
/// four speeds.
#[test]
fn realistic_preset_flc_stops_at_all_paper_speeds() {
    for speed in [30.0, 50.0, 70.0, 90.0] {
        let m = paper(speed, ControllerKind::Flc, Calibration::Realistic);
        assert!(!m.collision && m.final_clearance.is_some(), "{speed}: {m:?}");
    }
}

fn steady(controller: ControllerKind) -> Scenario {
    let mut s = Scenario { name: "steady".into(), controller, duration: 90.0, ..Default::default() };
    s.lead.phases = vec![
        Phase::Accelerate { accel: 1.5, speed: Some(20.0), speed_kmh: None }.into(),
        Phase::Hold { until_x: None, until_t: Some(1000.0), duration: None }.into(),
    ];
    s.v2v.enabled = controller != ControllerKind::Flc;
    s
}

/// A lead that never brakes is followed at the FLC's desired gap D_d + F_shift (Eqs. (2)-(4))
/// within 1 m.
#[test]
fn flc_follows_at_its_desired_gap() {
    let r = run(&steady(ControllerKind::Flc)).expect("run");
    let s = &r.series;
    let n = s.len();
    let (gap, v) = (s.gap[n - 1], s.follower_speed[n - 1]);
    let desired = r.scenario.flc.desired_distance(v) + r.scenario.flc.f_shift(v);
    assert!((v - 20.0).abs() < 0.3, "speed {v}");
    assert!((gap - desired).abs() < 1.0, "gap {gap} vs desired {desired}");
    assert!(!r.metrics.collision);
}

/// A V2V outage switches the pipeline to the FLC and back, and the counts are reported.
#[test]
fn v2v_outage_switches_to_flc_and_back() {
    let mut s = steady(ControllerKind::Pipeline);
    s.duration = 60.0;
    s.v2v.outages = vec![flc_sim::Outage { start: 30.0, end: 35.0 }];
    let r = run(&s).expect("run");
    let m = &r.metrics;
    // Starts on the FLC (no V2V yet) -> PID after 5 messages -> FLC in the outage -> PID again.
    assert_eq!(m.switches, 3, "{m:?}");
    assert!(m.time_flc > 5.0 && m.time_flc < 7.5, "time_flc {}", m.time_flc);
    assert!((m.time_pid + m.time_flc - m.duration).abs() < 0.02);
    // During the outage the FLC drives (active code 0 = FLC, see metrics docs).
    let i = r.series.t.iter().position(|&t| t > 33.0).expect("t");
    assert_eq!(r.series.active[i], 0);
    let j = r.series.t.iter().position(|&t| t > 40.0).expect("t");
    assert_eq!(r.series.active[j], 1);
}

/// Same seed: bit-identical metrics and series, repeated and on 1 or 2 threads.
#[test]
fn deterministic_across_runs_and_thread_counts() {
    let mut s = Scenario::paper_experiment(50.0, ControllerKind::Pipeline, Calibration::Realistic);
    s.lidar.range_noise_std = 0.05;
    s.lidar.dropout_prob = 0.1;
    s.lidar.jitter = 0.2;
    s.v2v.loss_prob = 0.2;
    let scenarios = vec![s.clone(), s.clone(), s];
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("pool");
    let one = pool(1).install(|| RunOptions::default().run_batch(&scenarios));
    let two = pool(2).install(|| RunOptions::default().run_batch(&scenarios));
    let key = |r: &Result<flc_sim::RunResult, flc_sim::SimError>| {
        let r = r.as_ref().expect("run");
        (serde_json::to_string(&r.metrics).expect("json"), r.series.gap.iter().map(|g| g.to_bits()).collect::<Vec<_>>())
    };
    let k0 = key(&one[0]);
    for r in one.iter().chain(&two) {
        assert_eq!(key(r), k0);
    }
    // A different seed changes the noisy run.
    let mut other = scenarios[0].clone();
    other.seed = 2;
    assert_ne!(key(&run(&other)), k0);
}

/// On the curved track the FLC-driven follower tracks the lane: mean |lateral offset| below
/// 0.3 m and mean |heading error| below 1 deg (measured 0.215 m / 0.586 deg; the paper's Fig. 3a
/// FLC: 0.2258 m / 0.0176 deg, docs/paper-reproduction.md). The bound is what pure pursuit of the
/// lead allows on these curves: the follower cuts each curve by the chord of its look-ahead, a
/// few tenths of a metre at 50 km/h; 0.3 m keeps 40 % headroom over the measured value. The
/// errors are averages over the run, so the run must cover the whole route to the lead's stop
/// (no contact, both at standstill, the lead in sight): with either lost-lead steering, since the lead is kept through every curve (what
/// `hold_lane` does when a lead is lost is tested in `tests/lost_lead.rs`).
#[test]
fn curved_track_tracking_error() {
    let s = Scenario::from_file(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/curvy-follow.toml")))
        .expect("scenario");
    assert!(matches!(s.track, TrackSpec::Curvy));
    let mut straight = s.clone();
    straight.follower.lost_lead_steering = flc_sim::LostLeadSteering::Straight;
    for s in [s, straight] {
        let r = run(&s).expect("run");
        let m = &r.metrics;
        let (trans, rot) = (m.trans_error_m.expect("tracking error"), m.rot_error_deg.expect("tracking error"));
        assert!(trans < 0.3, "{:?}: translational error {trans} m", s.follower.lost_lead_steering);
        assert!(rot < 1.0, "{:?}: rotational error {rot} deg", s.follower.lost_lead_steering);
        // The errors cover the whole route: the lead stopped after 1600 m and the follower behind it.
        let n = r.series.len();
        assert!(r.series.lead_speed[n - 1] == 0.0 && r.series.follower_speed[n - 1] < 0.1, "the run ends at the stop");
        assert!(r.collision.is_none(), "{:?}", r.collision);
        assert!(r.metrics.final_clearance.is_some_and(|c| c > 2.0), "{:?}", r.metrics.final_clearance);
        assert!(r.series.detected_distance.iter().rev().take(100).all(|d| d.is_finite()), "the lead is in sight at the stop");
    }
}
