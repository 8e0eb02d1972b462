//! Ideal perception (`[follower] perception = "ideal"`, validation only): the controllers get the
//! true bumper gap and the true speed of the vehicle in front, whatever the LiDAR does, and every
//! output says so.

use flc_core::longitudinal::Frame;
use flc_sim::report::RunRecord;
use flc_sim::{ControllerKind, Perception, Phase, Scenario, run};

fn steady(controller: ControllerKind, perception: Perception) -> Scenario {
    let mut s = Scenario { name: "ideal".into(), controller, duration: 60.0, ..Default::default() };
    s.lead.phases = vec![
        Phase::Accelerate { accel: 1.0, speed: Some(15.0), speed_kmh: None }.into(),
        Phase::Hold { until_x: None, until_t: Some(30.0), duration: None }.into(),
        Phase::Brake { decel: 3.0, speed: None, speed_kmh: None }.into(),
    ];
    s.v2v.enabled = false;
    s.idm.desired_speed = 20.0;
    // A LiDAR so noisy that its distance is never within 1 cm of the truth twice in a row.
    s.lidar.range_noise_std = 0.5;
    s.follower.perception = perception;
    s
}

#[test]
fn ideal_perception_gives_the_true_gap_at_every_control_frame() {
    let r = run(&steady(ControllerKind::Idm, Perception::Ideal)).expect("run");
    let s = &r.series;
    let mut ticks = 0;
    for i in 1..s.len() {
        let d = s.detected_distance[i];
        // Held between frames; on a frame, the gap at the start of the step (the previous record).
        if d.to_bits() != s.detected_distance[i - 1].to_bits() {
            assert_eq!(d.to_bits(), s.gap[i - 1].to_bits(), "step {i}: {d} vs true gap {}", s.gap[i - 1]);
            ticks += 1;
        }
    }
    assert!(ticks > 500, "{ticks} control frames");
    assert!(!r.metrics.collision);
    // With the LiDAR the distance is the noisy detection instead.
    let l = run(&steady(ControllerKind::Idm, Perception::Lidar)).expect("run");
    let off = (1..l.series.len()).filter(|&i| (l.series.detected_distance[i] - l.series.gap[i - 1]).abs() > 0.01).count();
    assert!(off > l.series.len() / 4, "{off} of {} steps off the truth", l.series.len());
}

#[test]
fn outputs_say_when_ideal_perception_was_on() {
    let ideal = run(&steady(ControllerKind::Acc, Perception::Ideal)).expect("run");
    let rec = RunRecord::from_run(None, &ideal);
    let json = serde_json::to_value(&rec).expect("json");
    assert_eq!(json["perception"], "ideal");
    assert!(flc_sim::report::table(&[rec]).contains("ideal [ideal]"));
    let lidar = run(&steady(ControllerKind::Acc, Perception::Lidar)).expect("run");
    let json = serde_json::to_value(RunRecord::from_run(None, &lidar)).expect("json");
    assert!(json.get("perception").is_none(), "{json}");
}

/// The true lead speed reaches the ACC: replaying the law on the run's true inputs at every
/// control frame (the gap, own speed and lead speed at the start of the step) with the lead speed
/// given reproduces the recorded speed commands bit for bit; the same replay without it (the
/// law's range-rate estimate from the same true gaps) does not.
#[test]
fn the_acc_gets_the_true_lead_speed() {
    let s = steady(ControllerKind::Acc, Perception::Ideal);
    let r = run(&s).expect("run");
    let x = &r.series;
    let dt = 1.0 / s.lidar.rate_hz;
    let steps = (dt / s.physics_dt).round() as usize;
    let replay = |with_speed: bool| {
        let mut law = s.base_follower_config().longitudinal().expect("law");
        let (mut same, mut frames) = (0, 0);
        // Control frames every `steps` records (no jitter, no drops, no latency by default).
        for i in (steps..x.len()).step_by(steps) {
            let mut f = Frame::new(Some(x.gap[i - 1]), x.follower_speed[i - 1], dt);
            f.lead_speed = with_speed.then_some(x.lead_speed[i - 1]);
            let out = law.step(&f);
            frames += 1;
            same += usize::from(out.command.speed.to_bits() == x.speed_command[i].to_bits());
        }
        (same, frames)
    };
    let (same, frames) = replay(true);
    assert!(frames > 500, "{frames} frames");
    assert_eq!(same, frames, "replay with the true lead speed: {same} of {frames} commands equal");
    let (same, _) = replay(false);
    assert!(same < frames / 2, "replay with the estimate: {same} of {frames} commands equal");
}

#[test]
fn a_bad_perception_names_the_key() {
    let err = Scenario::from_toml_str("[follower]\nperception = \"telepathy\"\n", "bad.toml").expect_err("bad").to_string();
    assert!(err.contains("follower.perception") && err.contains("bad.toml"), "{err}");
    let s = Scenario::from_toml_str("[follower]\nperception = \"ideal\"\n", "ok.toml").expect("ideal");
    assert_eq!(s.follower.perception, Perception::Ideal);
}
