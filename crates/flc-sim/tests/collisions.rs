//! Any contact of a follower is its collision: the vehicle in front, another vehicle, a parked
//! car, a guard rail, a post (`docs/v2v-and-metrics.md`, "Collisions"). Contacts without a
//! follower (the lead touching a road-side object) are listed in `other_contacts`.

use flc_sim::{ObjectKind, RunResult, Scenario};

/// Follower start speed, m/s.
const V0: f64 = 20.0;
/// Where the follower's front bumper starts along the track (rear bumper at 1 m, 4.9 m long).
const FRONT_BUMPER_0: f64 = 5.9;

/// A straight custom track with a rail on each side of the road (objects 0 and 1, split into
/// pieces by the world) plus `target` (object 2), a lead far ahead and a follower at 20 m/s
/// whose speed controller can change its speed by 0.1 m/s² at most: it cannot avoid what is in
/// its lane.
fn scenario_with(target: &str, lead_gap: f64, duration: f64) -> Scenario {
    Scenario::from_toml_str(&scenario_text(target, lead_gap, duration), "collisions test").expect("scenario")
}

/// The text of [`scenario_with`].
fn scenario_text(target: &str, lead_gap: f64, duration: f64) -> String {
    format!(
        r#"
name = "collide"
controller = "flc"
duration = {duration}
[track]
kind = "custom"
centerline = [[0.0, 0.0], [3000.0, 0.0]]
lane_width = 3.5
objects = [
  {{ kind = "guard_rail", offset = 5.0, from_s = 0.0, to_s = 1000.0 }},
  {{ kind = "guard_rail", offset = -5.0, from_s = 0.0, to_s = 1000.0 }},
  {target},
]
[lead]
initial_speed = {V0}
[[lead.phases]]
kind = "hold"
duration = 60.0
[follower]
initial_speed = {V0}
initial_gap = {lead_gap}
lane_keeping = true
[follower.speed_controller]
max_accel = 0.1
max_decel = 0.1
[v2v]
enabled = false
"#
    )
}

fn run(s: &Scenario) -> RunResult {
    flc_sim::run(s).expect("run")
}

/// Runs the follower into `target`, whose near face is at `face_s` along the road, and checks
/// the collision record: kind, index 2, time from the distance at about 20 m/s, speeds.
fn drives_into(target: &str, face_s: f64, kind: ObjectKind) {
    let r = run(&scenario_with(target, 500.0, 20.0));
    let c = r.collision.unwrap_or_else(|| panic!("{kind:?}: no collision; metrics {:?}", r.metrics));
    assert_eq!(c.object.kind, kind);
    assert_eq!((c.object.index, c.object.name.as_deref()), (Some(2), None), "{c:?}");
    assert!(c.object.name().is_none());
    // Contact at the first step whose front bumper (centre + 2.45 m) reaches the face.
    let s = &r.series;
    let reach = s.follower_x.iter().position(|x| x + 2.45 >= face_s).map(|i| s.t[i]);
    assert!(reach.is_some_and(|t| (c.time - t).abs() < 0.011), "{kind:?}: contact at {} s, the face reached at {reach:?}", c.time);
    // The speed controller changes the speed by 0.1 m/s² at most (plus drag and rolling
    // resistance): about 20 m/s, and the time about the distance at 20 m/s.
    assert!((c.follower_speed - V0).abs() < 2.0, "{c:?}");
    let t_expect = (face_s - FRONT_BUMPER_0) / V0;
    assert!(c.time > t_expect && c.time < 1.1 * t_expect, "{kind:?}: contact at {} s, {t_expect:.3} s at 20 m/s", c.time);
    // A standing object straight ahead: the impact speed is the follower's, along the normal too.
    assert!((c.impact_speed - c.follower_speed).abs() < 1e-3 * V0, "{c:?}");
    assert!((c.impact_speed_normal - c.follower_speed).abs() < 0.05 * V0, "{c:?}");
    assert_eq!(c.other_speed, 0.0);
    assert!(c.normal[0] > 0.9, "normal {:?} should point forward", c.normal);
    assert!((c.point[0] - face_s).abs() < 0.5 && c.point[1].abs() < 1.0, "point {:?}", c.point);
    // `lead_speed` keeps its meaning: the lead, far ahead.
    assert!((c.lead_speed - V0).abs() < 0.5);
    // The metrics derive from it; `stop.on_collision` ended the run at the contact.
    assert!(r.metrics.collision && r.metrics.impact_speed == c.impact_speed);
    assert_eq!(r.metrics.collision_time, Some(c.time));
    assert!((r.series.t.last().copied().unwrap_or_default() - c.time).abs() < 1e-9);
    assert!(r.other_contacts.is_empty(), "{:?}", r.other_contacts);
}

#[test]
fn a_follower_driven_into_a_parked_car_collides_with_it() {
    // Rear face at 110 - 2.35 m.
    drives_into(r#"{ kind = "parked_car", s = 110.0, offset = 0.0 }"#, 107.65, ObjectKind::ParkedCar);
}

#[test]
fn a_follower_driven_into_a_post_collides_with_it() {
    drives_into(r#"{ kind = "post", s = 110.0, offset = 0.0, radius = 0.3 }"#, 109.7, ObjectKind::Post);
}

#[test]
fn a_follower_driven_into_a_guard_rail_in_its_lane_collides_with_it() {
    // The rail's end (a piece's box reaches 5 cm past its end) faces the follower.
    drives_into(r#"{ kind = "guard_rail", offset = 0.0, from_s = 110.0, to_s = 160.0 }"#, 109.95, ObjectKind::GuardRail);
}

#[test]
fn the_lead_touching_a_parked_car_is_another_contact_not_the_followers_collision() {
    // Lead's rear bumper 30 m ahead of the follower's front, its front at 5.9 + 30 + 4.9 m; the
    // parked car's rear face 60 m further: the lead touches it after 3 s; the run ends before
    // the follower gets there.
    let lead_front = FRONT_BUMPER_0 + 30.0 + 4.9;
    let r = run(&scenario_with(&format!(r#"{{ kind = "parked_car", s = {}, offset = 0.0 }}"#, lead_front + 60.0 + 2.35), 30.0, 3.5));
    assert!(r.collision.is_none() && !r.metrics.collision, "{:?}", r.collision);
    assert_eq!(r.other_contacts.len(), 1, "first contact of the pair only: {:?}", r.other_contacts);
    let c = &r.other_contacts[0];
    assert_eq!((c.a.kind, c.a.name().as_deref()), (ObjectKind::Vehicle, Some("lead")));
    assert_eq!((c.b.kind, c.b.index), (ObjectKind::ParkedCar, Some(2)));
    assert!((c.time - 3.0).abs() < 0.05, "{c:?}");
    assert!((c.speed - V0).abs() < 0.1 && (c.impact_speed_normal - V0).abs() < 1.0, "{c:?}");
    // The run went on to its end (no stop on the lead's contact).
    assert!(r.series.t.last().copied().unwrap_or_default() > 3.4);
}

#[test]
fn a_follower_without_brakes_runs_into_the_car_revealed_by_the_cut_out() {
    // scenarios/robust-cut-out.toml with a follower that cannot brake (demand limited to
    // 0.1 m/s², friction to 0.5 m/s²): the lead leaves the lane, the follower keeps it and hits
    // the standing car (the scripted vehicle "stopped") at speed; the lead passes it. Whether a
    // controller stops there is a controller's outcome, tested in tests/robust_flc.rs.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/robust-cut-out.toml");
    let mut s = Scenario::from_file(&path).expect("scenario");
    s.follower.speed_controller.max_decel = 0.1;
    s.follower.vehicle.max_brake = 0.5;
    let r = run(&s);
    let c = r.collision.expect("a follower without brakes runs into the standing car");
    assert_eq!((c.object.kind, c.object.name.as_deref()), (ObjectKind::Vehicle, Some("stopped")));
    // Hardly slowed from 80 km/h; the standing car has no speed of its own.
    assert!(c.impact_speed > 15.0 && (c.impact_speed - c.follower_speed).abs() < 0.05, "{c:?}");
    assert!((c.point[0] - (222.4 - 2.45)).abs() < 0.5, "{c:?}");
    assert!(r.other_contacts.is_empty(), "the lead changed lanes before the car: {:?}", r.other_contacts);
    assert!(r.metrics.collision && r.metrics.impact_speed == c.impact_speed, "{:?}", r.metrics.impact_speed);
}

#[test]
fn the_json_record_names_what_was_hit_and_runs_without_contact_have_no_new_fields() {
    let r = run(&scenario_with(r#"{ kind = "post", s = 110.0, offset = 0.0, radius = 0.3 }"#, 500.0, 20.0));
    let v = serde_json::to_value(flc_sim::report::RunRecord::from_run(None, &r)).expect("json");
    assert_eq!(v["collision"], true);
    let info = &v["collision_info"];
    assert_eq!(info["object"], serde_json::json!({ "kind": "post", "index": 2 }));
    for k in ["time", "impact_speed", "lead_speed", "follower_speed", "other_speed", "impact_speed_normal", "point", "normal"] {
        assert!(info.get(k).is_some(), "collision_info.{k} missing: {info}");
    }
    assert!(v.get("other_contacts").is_none());
    let text = flc_sim::report::table(&[flc_sim::report::RunRecord::from_run(None, &r)]);
    assert!(text.contains("post #2"), "{text}");
    // No contact: neither field.
    let far = run(&scenario_with(r#"{ kind = "post", s = 2900.0, offset = 0.0, radius = 0.3 }"#, 500.0, 2.0));
    let v = serde_json::to_value(flc_sim::report::RunRecord::from_run(None, &far)).expect("json");
    assert!(v.get("collision_info").is_none() && v.get("other_contacts").is_none(), "{v}");
}

#[test]
fn in_a_platoon_a_rear_end_contact_is_the_first_contact_of_both_followers() {
    // Follower 2 starts 20 m behind follower 1, 5 m/s faster, and can hardly brake.
    let text = scenario_text(r#"{ kind = "post", s = 2900.0, offset = 0.0, radius = 0.3 }"#, 30.0, 20.0);
    let patch = r#"
[platoon]
followers = 2
[[platoon.overrides]]
followers = [2]
follower = { initial_speed = 25.0, initial_gap = 20.0 }
"#;
    let r = run(&Scenario::from_toml_str(&(text + patch), "platoon collision test").expect("scenario"));
    let p = r.platoon.as_ref().expect("platoon result");
    let (c1, c2) =
        (p.followers[0].collision.clone().expect("follower 1 is hit"), p.followers[1].collision.clone().expect("follower 2 hits"));
    // Follower 2 ran into the vehicle in front: the old record's meaning.
    assert_eq!(c2.object.name().as_deref(), Some("follower 1"));
    assert_eq!(c2.impact_speed, (c2.follower_speed - c2.lead_speed).max(0.0));
    assert!((c2.impact_speed - 5.0).abs() < 1.0 && c2.other_speed == c2.lead_speed, "{c2:?}");
    // Follower 1 was hit from behind: its first contact too, with the closing speed.
    assert_eq!(c1.object.name().as_deref(), Some("follower 2"));
    assert_eq!(c1.time, c2.time);
    assert!((c1.impact_speed - c2.impact_speed).abs() < 1e-3 && (c1.impact_speed_normal - c2.impact_speed_normal).abs() < 1e-3);
    assert!(c1.normal[0] < -0.9 && c2.normal[0] > 0.9, "{:?} {:?}", c1.normal, c2.normal);
    // Gap 20 m closed at about 5 m/s.
    assert!((c2.time - 4.0).abs() < 0.5, "{c2:?}");
    assert_eq!(r.collision, Some(c1));
    assert!(r.metrics.collision && p.followers[1].metrics.collision);
    assert!(r.other_contacts.is_empty());
}

#[test]
fn a_recording_marks_the_contact_on_the_collisions_topic() {
    let dir = std::env::temp_dir().join(format!("flc-collisions-mcap-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let s = scenario_with(r#"{ kind = "parked_car", s = 110.0, offset = 0.0 }"#, 500.0, 20.0);
    let r = flc_sim::RunOptions { record: Some(&dir), ..Default::default() }.run(&s).expect("run");
    let c = r.collision.expect("collision");
    let file = std::fs::read_dir(&dir).expect("dir").map(|e| e.expect("entry").path()).find(|p| p.extension().is_some_and(|e| e == "mcap"));
    let bytes = std::fs::read(file.expect("an mcap file")).expect("read");
    let marks: Vec<(u64, Vec<u8>)> = mcap::MessageStream::new(&bytes)
        .expect("mcap")
        .map(|m| m.expect("message"))
        .filter(|m| m.channel.topic == flc_sim::record::TOPIC_COLLISIONS)
        .map(|m| (m.log_time, m.data.to_vec()))
        .collect();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(marks.len(), 1, "one marker");
    assert_eq!(marks[0].0, flc_sim::record::time_ns(c.time));
    // Protobuf keeps strings as they are: the entity id and the label naming the object.
    let text = String::from_utf8_lossy(&marks[0].1).into_owned();
    assert!(text.contains("collision/follower 1") && text.contains("follower 1 hit parked_car #2"), "{text}");
}
