//! The follower pipeline driven by a host simulator ([`flc_sim::ExternalFollower`], what
//! `flc.sumo` uses): fed the world of flc's own ideal-perception run step by step, it reproduces
//! that run's follower bit for bit, for every controller; its V2V link and gap sensor behave as
//! configured; bad input is an error naming the field.

use flc_sim::{ControllerKind, ExternalFollower, ExternalInput, Perception, RunResult, Scenario, Simulation, run};

/// The paper experiment with ideal perception and a clean sensor schedule (no jitter, drops or
/// latency), so that the host replay and the simulator tick at the same instants.
fn ideal(controller: ControllerKind, speed_kmh: f64) -> Scenario {
    let mut s = Scenario::paper_experiment(speed_kmh, controller, flc_sim::Calibration::Realistic);
    s.follower.perception = Perception::Ideal;
    s.lidar.jitter = 0.0;
    s.lidar.scan_drop_prob = 0.0;
    s.lidar.latency_frames = 0;
    s
}

/// Replays `r`'s world (the state at the start of each step) into an external follower and
/// returns the speeds it sets.
fn replay(s: &Scenario, r: &RunResult, outage_at: Option<f64>) -> Vec<f64> {
    let mut f = ExternalFollower::new(s.base_follower_config(), s.seed).expect("valid");
    let ser = &r.series;
    // The gap at t = 0 as the simulator computes it from the initial poses (`bumper_gap`), which is
    // `initial_gap` only up to rounding.
    let sim = Simulation::new(s).expect("valid");
    let (l, b) = (sim.lead_state(), sim.follower_state(0).expect("one follower"));
    let gap0 = (l.x - b.x) * l.yaw.cos() + (l.y - b.y) * l.yaw.sin() - s.lead.vehicle.length / 2.0 - s.follower.vehicle.length / 2.0;
    let mut out = Vec::with_capacity(ser.len());
    for k in 0..ser.len() {
        let (t, gap, front, own) = if k == 0 {
            (0.0, gap0, s.lead.initial_speed, s.follower.initial_speed)
        } else {
            (ser.t[k - 1], ser.gap[k - 1], ser.lead_speed[k - 1], ser.follower_speed[k - 1])
        };
        if outage_at.is_some_and(|o| (o - t).abs() < 1e-9) {
            f.v2v_mut().start_outage(t);
        }
        let o = f.step(&ExternalInput { t, dt: s.physics_dt, gap: Some(gap), front_speed: Some(front), own_speed: own }).expect("step");
        out.push(o.speed);
    }
    out
}

#[test]
fn a_host_replaying_the_world_gets_the_simulators_follower_bit_for_bit() {
    for kind in [ControllerKind::Flc, ControllerKind::FlcRobust, ControllerKind::Idm, ControllerKind::Acc, ControllerKind::Pid] {
        for v in [50.0, 110.0] {
            let s = ideal(kind, v);
            let r = run(&s).expect("run");
            let speeds = replay(&s, &r, None);
            for (k, (a, b)) in speeds.iter().zip(&r.series.follower_speed).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "{kind:?} {v} km/h step {k}: {a} vs {b}");
            }
        }
    }
}

#[test]
fn the_pipeline_hands_over_on_the_same_step_when_the_host_cuts_v2v() {
    // The paper's pipeline run loses V2V at the lead's brake onset (`outage_on_brake`); the host
    // starts the same outage on the same step.
    let s = ideal(ControllerKind::Pipeline, 70.0);
    let r = run(&s).expect("run");
    // The brake phase starts on the first step that begins with the lead 650 m from its start.
    let x0 = Simulation::new(&s).expect("valid").lead_state().x;
    let onset = (1..r.series.len()).find(|&k| r.series.lead_x[k - 1] - x0 >= 650.0).map(|k| r.series.t[k - 1]).expect("brakes");
    let speeds = replay(&s, &r, Some(onset));
    for (k, (a, b)) in speeds.iter().zip(&r.series.follower_speed).enumerate() {
        assert_eq!(a.to_bits(), b.to_bits(), "step {k}: {a} vs {b}");
    }
    assert!(r.series.active.contains(&flc_sim::ACTIVE_PID) && r.series.active.last() == Some(&flc_sim::ACTIVE_FLC));
}

#[test]
fn the_sensor_delays_and_blurs_what_the_controller_sees() {
    let mut s = ideal(ControllerKind::Flc, 50.0);
    s.follower.perception = Perception::Lidar;
    s.lidar.latency_frames = 2;
    s.lidar.range_noise_std = 0.1;
    let mut f = ExternalFollower::new(s.base_follower_config(), 3).expect("valid");
    // A gap that grows by 1 m per step at 100 Hz, sensed at 20 Hz two scans late.
    let (mut errs, mut ticks) = (Vec::new(), 0);
    for k in 0..4000 {
        let t = k as f64 * 0.01;
        let o = f
            .step(&ExternalInput { t, dt: 0.01, gap: Some(20.0 + (k % 50) as f64 * 0.1), front_speed: Some(10.0), own_speed: 10.0 })
            .unwrap();
        if o.control_tick {
            ticks += 1;
            // Measured two scans (10 steps) ago.
            let truth = 20.0 + ((k - 10) % 50) as f64 * 0.1;
            errs.push(o.distance.expect("in range") - truth);
        }
    }
    assert_eq!(ticks, 800 - 2);
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    let sd = (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / errs.len() as f64).sqrt();
    assert!(mean.abs() < 0.02 && (sd - 0.1).abs() < 0.015, "mean {mean}, sd {sd}");
}

#[test]
fn bad_host_input_is_an_error_naming_the_field() {
    let s = ideal(ControllerKind::Flc, 50.0);
    let mut f = ExternalFollower::new(s.base_follower_config(), 1).expect("valid");
    let ok = ExternalInput { t: 0.0, dt: 0.01, gap: Some(10.0), front_speed: Some(5.0), own_speed: 5.0 };
    for (bad, field) in [
        (ExternalInput { own_speed: f64::NAN, ..ok }, "own_speed"),
        (ExternalInput { dt: 0.0, ..ok }, "dt"),
        (ExternalInput { gap: Some(f64::NAN), ..ok }, "gap"),
        (ExternalInput { front_speed: Some(-1.0), ..ok }, "front_speed"),
        (ExternalInput { t: f64::INFINITY, ..ok }, "t"),
    ] {
        let e = f.step(&bad).expect_err("rejected").to_string();
        assert!(e.contains(field), "{e}");
    }
    // Nothing in front: the FLC brakes (its no-lead policy), the speed never goes negative.
    let o = f.step(&ExternalInput { gap: None, front_speed: None, ..ok }).unwrap();
    assert!(o.speed_command < 5.0 && o.speed >= 0.0, "{o:?}");
    // An invalid configuration names its key.
    let mut bad = s.base_follower_config();
    bad.lidar.rate_hz = -1.0;
    let e = ExternalFollower::new(bad, 1).err().expect("rejected").to_string();
    assert!(e.contains("lidar.rate_hz"), "{e}");
}
