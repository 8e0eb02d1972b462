//! The UN R157 careful and competent human driver (`careful-driver`, issue 22) in the closed loop:
//! selected by name, parameterised by `[careful_driver]`, seeing the ground truth of the vehicle
//! in front (not the LiDAR), and stopping in the hand-computed distance plus what the vehicle's
//! actuators add.

use flc_core::baselines::CarefulDriverParams;
use flc_sim::report::RunRecord;
use flc_sim::{ControllerKind, HARD_BRAKING, Scenario, run};

/// A car standing on a straight road; the careful driver approaches at 80 km/h from 120 m with
/// its normal mode's desired speed 80 km/h (so it cruises at exactly that speed with nothing in
/// sight). It sees the car from `sight` metres on; `risk_decel = 2` makes that sudden appearance
/// a disturbance (`a_req = 22.222² / (2 (sight - 2))`, 3.17 m/s² at 80 m).
fn standing_car(sight: f64) -> String {
    format!(
        r#"
name = "careful-driver-standing-car"
controller = "careful-driver"
duration = 20.0

[lead]
initial_speed = 0.0

[[lead.phases]]
kind = "hold"
duration = 100.0

[follower]
initial_speed = 22.2222
initial_gap = 120.0

[v2v]
enabled = false

[careful_driver]
sight_distance = {sight}
risk_decel = 2.0

[careful_driver.normal]
desired_speed = 22.2222
"#
    )
}

/// The hand computation (`docs/careful-driver.md`): `v 1.15 + (v T - A T² / 6) + (v - A T / 2)² / (2 A)`
/// with `A = 0.774 * 9.81`, `T = 0.6`.
/// Whether docs/careful-driver.md contains `sentence` (its line breaks read as spaces).
fn doc_says(sentence: &str) -> bool {
    let doc = include_str!("../../../docs/careful-driver.md");
    doc.split_whitespace().collect::<Vec<_>>().join(" ").contains(sentence)
}

fn by_hand(v: f64) -> f64 {
    let (a, t) = (0.774 * 9.81, 0.6);
    v * 1.15 + (v * t - a * t * t / 6.0) + (v - a * t / 2.0).powi(2) / (2.0 * a)
}

/// What a run gave: the follower's speed when the car came into sight, the distance from there
/// to the first standstill, and the gap left.
fn stop(sight: f64) -> (flc_sim::RunResult, f64, f64, f64) {
    let s = Scenario::from_toml_str(&standing_car(sight), "careful.toml").expect("parse");
    assert_eq!(s.controller, ControllerKind::CarefulDriver);
    assert_eq!(s.careful_driver.sight_distance, sight);
    let r = run(&s).expect("run");
    let ser = &r.series;
    // The onset: the first control frame with the car in sight (the detected distance is the
    // true gap for this controller; NaN before).
    let onset = (0..ser.len()).find(|&i| ser.detected_distance[i] <= sight).expect("the car comes into sight");
    let stopped = (onset..ser.len()).find(|&i| ser.follower_speed[i] <= 0.0).expect("the driver stops");
    let travelled = ser.follower_x[stopped] - ser.follower_x[onset];
    let (gap, v) = (ser.gap[stopped], ser.follower_speed[onset]);
    (r, v, travelled, gap)
}

/// From about 80 km/h the careful driver stops in the hand-computed distance plus what the
/// vehicle model adds. The car comes into sight below 80 km/h (driving resistance slowed the
/// cruise, the speed command `v + 1 s * a` follows the measured speed and the integrator is
/// slow); the measured figures are in docs/careful-driver.md, checked here. What the vehicle
/// model adds:
/// * the actuator's dead time (0.1 s) and first-order lag (0.2 s) delay the braking by about
///   0.3 s: `v * 0.3 = 6.7 m`;
/// * the speed interface: the command `v + 1 s * a` is 0 below `A * 1 s = 7.59 m/s`, and the
///   low-level P controller (`kp = 1`) then asks for `-v`, a deceleration falling with the
///   speed: the last 7.59 m/s take up to `7.59 m` instead of `7.59² / (2 A) = 3.8 m`;
/// * driving resistance (drag and rolling, about 0.2 m/s² at 80 km/h) shortens it a little.
///
/// So the measured distance lies between the hand computation and that plus 0.3 s of travel plus
/// 3.8 m; the test asserts this window and that the car is not hit.
#[test]
fn the_careful_driver_stops_in_the_hand_computed_distance_plus_the_actuators() {
    let (r, v, travelled, gap) = stop(80.0);
    assert!(!r.metrics.collision, "collided");
    assert!((v - 22.2222).abs() < 0.5, "speed at the onset {v}");
    let hand = by_hand(v);
    assert!((by_hand(80.0 / 3.6) - 64.627).abs() < 1e-3);
    let actuators = v * (0.1 + 0.2) + 7.59294 / 2.0;
    assert!(travelled > hand && travelled < hand + actuators, "travelled {travelled} m, hand {hand} m, + actuators {actuators} m");
    // The car stood 80 m (less up to one frame's travel) ahead at the onset.
    assert!((gap - (80.0 - travelled)).abs() < v * 0.05 + 0.01, "gap {gap}");
    // The figures docs/careful-driver.md ("In the closed loop") states are this run's.
    let claim = format!(
        "travels {travelled:.2} m from the frame the car comes into sight (at {v:.2} m/s: driving resistance slowed the cruise) to standstill, where the hand computation at that speed gives {hand:.2} m, and stops {gap:.1} m short."
    );
    assert!(doc_says(&claim), "docs/careful-driver.md should say: {claim}");
    // The record says the reference saw the ground truth.
    let rec = RunRecord::from_run(None, &r);
    assert_eq!(rec.perception.as_deref(), Some("truth"));
    assert_eq!(rec.controller, "careful-driver");
}

/// Seen only 60 m ahead the hand computation already says it cannot stop (64.63 m > 60 m): it
/// hits the car.
#[test]
fn the_careful_driver_hits_a_car_it_sees_too_late() {
    let r = run(&Scenario::from_toml_str(&standing_car(60.0), "careful.toml").expect("parse")).expect("run");
    assert!(r.metrics.collision);
}

/// Without a disturbance (the car in sight from 150 m, `a_req = 22.222² / 296 = 1.67 m/s²`, with
/// the default `risk_decel = 3.5`) the normal mode (the IDM, limited to 3.5 m/s²) stops behind
/// it without ever braking near the R157 deceleration (7.59 m/s²).
#[test]
fn the_normal_mode_stops_gently() {
    let text = standing_car(150.0).replace("risk_decel = 2.0\n", "").replace("initial_gap = 120.0", "initial_gap = 200.0");
    let s = Scenario::from_toml_str(&text, "careful.toml").expect("parse");
    assert_eq!(s.careful_driver.risk_decel, CarefulDriverParams::default().risk_decel);
    let r = run(&s).expect("run");
    assert!(!r.metrics.collision);
    let hardest = r.series.follower_accel.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(hardest > -3.5, "{hardest}");
    let claim = format!("the IDM stops behind it braking at most {:.2} m/s²", -hardest);
    assert!(doc_says(&claim), "docs/careful-driver.md should say: {claim}");
    assert!(r.metrics.min_gap > 2.0, "{}", r.metrics.min_gap);
}

/// `[careful_driver]` keys are checked like every section's: the error names the dotted key.
#[test]
fn bad_parameters_name_the_key() {
    let err = Scenario::from_toml_str(&standing_car(-1.0), "careful.toml").unwrap_err().to_string();
    assert!(err.contains("careful_driver.sight_distance"), "{err}");
    let text = standing_car(80.0).replace("desired_speed = 22.2222", "time_headway = -1.0");
    let err = Scenario::from_toml_str(&text, "careful.toml").unwrap_err().to_string();
    assert!(err.contains("careful_driver.normal.time_headway"), "{err}");
}

/// The registry: the reference perceives the truth, no other controller does; its disturbance
/// threshold is the simulator's comfort limit.
#[test]
fn only_the_reference_perceives_the_truth() {
    assert_eq!(CarefulDriverParams::default().risk_decel, HARD_BRAKING);
    for k in ControllerKind::ALL {
        assert_eq!(k.perceives_truth(), *k == ControllerKind::CarefulDriver, "{}", k.as_str());
    }
    assert_eq!(ControllerKind::parse("careful-driver").ok(), Some(ControllerKind::CarefulDriver));
}
