//! Followers driven from outside the loop ([`Simulation::drive`], what `flc.Simulation` and
//! `flc.gym` use): the law's own commands given from outside reproduce the run bit for bit (the
//! paper experiment with its LiDAR, and every follower of the platoon demo); an acceleration
//! command bypasses the speed controller; bad commands and indices are errors naming them.

use flc_core::FallbackController;
use flc_sim::{Calibration, ControllerKind, DriveCommand, DriveOptions, RunResult, Scenario, Series, Simulation, run};

fn same_series(a: &Series, b: &Series) {
    let (ca, cb) = (a.columns(), b.columns());
    assert_eq!(ca.len(), cb.len());
    for ((name, x), (_, y)) in ca.iter().zip(&cb) {
        assert_eq!(x.len(), y.len(), "{name}: lengths");
        for (i, (p, q)) in x.iter().zip(y).enumerate() {
            assert!(p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()), "{name}[{i}]: {p} != {q}");
        }
    }
}

fn same_result(a: &RunResult, b: &RunResult) {
    same_series(&a.series, &b.series);
    assert_eq!(format!("{:?}", a.metrics), format!("{:?}", b.metrics));
    assert_eq!(a.platoon.is_some(), b.platoon.is_some());
    if let (Some(p), Some(q)) = (&a.platoon, &b.platoon) {
        for (f, g) in p.followers.iter().zip(&q.followers) {
            same_series(&f.series, &g.series);
        }
        assert_eq!(format!("{:?}", p.string_stability), format!("{:?}", q.string_stability));
    }
}

#[test]
fn an_flc_outside_the_loop_reproduces_the_run_bit_for_bit() {
    let s = Scenario::paper_experiment(50.0, ControllerKind::Flc, Calibration::Realistic);
    let reference = run(&s).expect("runs");
    let mut sim = Simulation::new(&s).expect("valid");
    sim.drive(&[1], DriveOptions { points: true, beams: 16 }).expect("follower 1 exists");
    let mut law = FallbackController::new(s.flc).expect("valid");
    let mut ticks = 0;
    let mut seen_points = false;
    while sim.advance().expect("steps") {
        let (m, fresh, _) = sim.measurement(1).expect("driven");
        assert!(fresh, "one driven follower: every pause is its scan");
        let beams = sim.beams(1).expect("driven");
        assert_eq!(beams.len(), 16);
        assert!(beams.iter().all(|r| *r > 0.0 && *r <= 200.0));
        seen_points |= !m.points.is_empty();
        let cmd = FallbackController::step(&mut law, m.distance, m.own_speed);
        sim.command(1, DriveCommand::Speed(cmd.speed)).expect("driven");
        ticks += 1;
    }
    assert!(seen_points);
    // 20 Hz scans over the run's duration.
    let expected = (reference.series.t.last().copied().unwrap_or(0.0) * 20.0) as i64;
    assert!((ticks - expected).abs() <= 2, "{ticks} scans, about {expected} expected");
    same_result(&sim.result(), &reference);
    same_result(&sim.finish(), &reference);
}

#[test]
fn a_platoon_driven_by_its_own_laws_from_outside_is_the_run() {
    let s = flc_sim::presets::brakedemo();
    let reference = run(&s).expect("runs");
    let mut sim = Simulation::new(&s).expect("valid");
    let n = sim.n_followers();
    let all: Vec<usize> = (1..=n).collect();
    sim.drive(&all, DriveOptions::default()).expect("all exist");
    let mut pauses = 0;
    while sim.advance().expect("steps") {
        for k in 1..=n {
            sim.command(k, DriveCommand::Law).expect("driven");
        }
        pauses += 1;
    }
    assert!(pauses > 100);
    same_result(&sim.finish(), &reference);
}

#[test]
fn an_acceleration_command_bypasses_the_speed_controller() {
    let mut s = Scenario::paper_experiment(50.0, ControllerKind::Flc, Calibration::Realistic);
    s.follower.initial_gap = 150.0;
    s.duration = 3.0;
    let mut sim = Simulation::new(&s).expect("valid");
    sim.drive(&[1], DriveOptions::default()).expect("exists");
    while sim.advance().expect("steps") {
        sim.command(1, DriveCommand::Accel(1.0)).expect("driven");
    }
    let r = sim.finish();
    // After the actuator's dead time and lag the follower accelerates at the demand less the
    // driving resistance (rolling, drag: no speed controller compensates it).
    let last = r.series.follower_accel.last().copied().unwrap_or(f64::NAN);
    assert!(last > 0.8 && last < 1.0, "accel {last}");
    assert!(r.series.speed_command.iter().skip(1).all(|v| v.is_nan()), "no speed command while accel-commanded");
    let v = r.series.follower_speed.last().copied().unwrap_or(0.0);
    assert!(v > 1.5 && v < 3.0, "speed after 3 s at 1 m/s² (with the actuator's lag): {v}");
}

#[test]
fn bad_commands_and_indices_are_errors_naming_them() {
    let s = Scenario::paper_experiment(30.0, ControllerKind::Flc, Calibration::Realistic);
    let mut sim = Simulation::new(&s).expect("valid");
    let e = sim.drive(&[2], DriveOptions::default()).expect_err("one follower only");
    assert!(e.to_string().contains("drive") && e.to_string().contains("follower 2"), "{e}");
    let e = sim.command(1, DriveCommand::Speed(1.0)).expect_err("not driven");
    assert!(e.to_string().contains("not driven"), "{e}");
    sim.drive(&[1], DriveOptions::default()).expect("exists");
    assert!(sim.advance().expect("first scan"));
    let e = sim.command(1, DriveCommand::Accel(f64::NAN)).expect_err("NaN");
    assert!(e.to_string().contains("command.accel"), "{e}");
    let truth = sim.ground_truth(1).expect("exists");
    assert!((truth.gap - s.follower.initial_gap).abs() < 1e-6, "{truth:?}");
    assert!(sim.ground_truth(2).is_none());
}
