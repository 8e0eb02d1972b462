//! `[story]`: OpenSCENARIO storyboard semantics in the loop, checked against closed forms
//! (speed and lateral transition shapes, event chaining, priorities, variables, the ego's
//! controller hand-over, the vehicle-dynamics mode) and its validation errors.

use flc_sim::trigger::ElementEvent;
use flc_sim::{Scenario, Simulation};

const V50: f64 = 50.0 / 3.6;
const DT: f64 = 0.01;

/// A straight 3-lane road, the ego scripted at 50 km/h at s = 20 m, the lead at s = 100 m and
/// `body` appended (the story's acts and anything else).
fn scenario(body: &str) -> Scenario {
    let text = format!(
        r#"
name = "story-test"
duration = 12.0
[track]
kind = "custom"
centerline = [[0.0, 0.0], [2000.0, 0.0]]
lanes = 3
[follower]
initial_speed = {V50}
start_s = 20.0
[lead]
initial_speed = {V50}
s = 100.0
{body}
"#
    );
    Scenario::from_toml_str(&text, "story-test.toml").unwrap_or_else(|e| panic!("{e}"))
}

/// One act, one group of `actors`, one maneuver holding `events` (TOML of `[[...events]]`).
fn one_act(ego: &str, actors: &str, events: &str) -> String {
    format!(
        r#"
[story]
ego = "{ego}"
[[story.acts]]
name = "act"
[[story.acts.groups]]
name = "group"
actors = [{actors}]
[[story.acts.groups.maneuvers]]
name = "maneuver"
{events}
"#
    )
}

struct Trace {
    t: Vec<f64>,
    speed: Vec<f64>,
    y: Vec<f64>,
}

/// Runs to the end, tracing `name`'s speed and lateral position after every step.
fn run(s: &Scenario, name: &str) -> (Trace, Simulation) {
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    let mut tr = Trace { t: Vec::new(), speed: Vec::new(), y: Vec::new() };
    loop {
        let more = sim.step().unwrap_or_else(|e| panic!("{e}"));
        let st = if name == "ego" { *sim.follower_state(0).expect("ego") } else { *sim.scripted_state(name).expect("entity") };
        tr.t.push(sim.time());
        tr.speed.push(st.speed);
        tr.y.push(st.y);
        if !more {
            break;
        }
    }
    (tr, sim)
}

#[test]
fn linear_speed_by_rate_decelerates_at_exactly_the_rate_and_ends_at_2_22_s() {
    let ev = r#"
[[story.acts.groups.maneuvers.events]]
name = "brake"
start = { kind = "simulation_time", rule = "greater_or_equal", value = 1.0 }
[[story.acts.groups.maneuvers.events.actions]]
name = "brake-action"
kind = "speed"
speed = 0.5555555555555556
shape = "linear"
dimension = "rate"
value = 6.0
"#;
    let (tr, sim) = run(&scenario(&one_act("scripted", "\"lead\"", ev)), "lead");
    // The trigger holds at the evaluation at the start of the step from t = 1.0; from that
    // step on the speed falls by 6 m/s² * 10 ms per step (`tr.t` is the time after the step).
    let k0 = tr.t.iter().position(|&t| t > 1.0 + 1e-9).expect("t = 1");
    assert!((tr.speed[k0 - 1] - V50).abs() < 1e-12, "before: {}", tr.speed[k0 - 1]);
    for k in k0..k0 + 200 {
        let dv = tr.speed[k - 1] - tr.speed[k];
        assert!((dv - 0.06).abs() < 1e-9, "step {k} at t = {}: dv = {dv}", tr.t[k]);
    }
    // (50 - 2) km/h / 6 m/s² = 2.2222 s after the start at t = 1.0.
    let end = tr.t.iter().zip(&tr.speed).find(|(_, v)| (**v - 2.0 / 3.6).abs() < 1e-12).map(|(t, _)| *t).expect("reached 2 km/h");
    assert!((end - (1.0 + 48.0 / 3.6 / 6.0)).abs() <= DT + 1e-9, "ends at {end}");
    assert!(tr.speed.iter().all(|&v| v >= 2.0 / 3.6 - 1e-12), "no undershoot");
    let st = sim.element("brake").expect("event");
    assert!(st.complete && st.holds(ElementEvent::EndTransition), "{st:?}");
    assert!(sim.element("act").expect("act").complete);
}

#[test]
fn speed_shapes_follow_their_closed_forms() {
    // From 50 km/h to 20 m/s over 4 s (time) or over 80 m (distance), starting at t = 0.
    for (shape, dim, value) in [("cubic", "time", 4.0), ("sinusoidal", "time", 4.0), ("linear", "distance", 80.0), ("step", "time", 0.0)] {
        let ev = format!(
            r#"
[[story.acts.groups.maneuvers.events]]
name = "e"
[[story.acts.groups.maneuvers.events.actions]]
name = "a"
kind = "speed"
speed = 20.0
shape = "{shape}"
dimension = "{dim}"
value = {value}
"#
        );
        let (tr, _) = run(&scenario(&one_act("scripted", "\"lead\"", &ev)), "lead");
        let duration = match dim {
            "distance" => value / (0.5 * (V50 + 20.0)),
            _ => value,
        };
        for (k, &t) in tr.t.iter().enumerate().take(1200) {
            let p = if duration > 0.0 { (t / duration).min(1.0) } else { 1.0 };
            let f = match shape {
                "cubic" => p * p * (3.0 - 2.0 * p),
                "sinusoidal" => 0.5 - 0.5 * (std::f64::consts::PI * p).cos(),
                "linear" => p,
                _ => 1.0,
            };
            let want = V50 + (20.0 - V50) * f;
            assert!((tr.speed[k] - want).abs() < 1e-9, "{shape}/{dim} at t = {t}: {} vs {want}", tr.speed[k]);
        }
    }
}

#[test]
fn sinusoidal_lane_change_over_3_s_follows_its_shape() {
    // The lead changes to the lane on the left (offset +3.5 m) in 3 s from t = 0.5 s.
    let ev = r#"
[[story.acts.groups.maneuvers.events]]
name = "lc"
start = { kind = "simulation_time", rule = "greater_or_equal", value = 0.5 }
[[story.acts.groups.maneuvers.events.actions]]
name = "lc-action"
kind = "lane_change"
offset = 3.5
shape = "sinusoidal"
dimension = "time"
value = 3.0
"#;
    let (tr, sim) = run(&scenario(&one_act("scripted", "\"lead\"", ev)), "lead");
    for (k, &t) in tr.t.iter().enumerate() {
        let p = ((t - 0.5) / 3.0).clamp(0.0, 1.0);
        let want = 3.5 * (0.5 - 0.5 * (std::f64::consts::PI * p).cos());
        assert!((tr.y[k] - want).abs() < 1e-9, "t = {t}: y = {} vs {want}", tr.y[k]);
        assert!((tr.speed[k] - V50).abs() < 1e-12, "speed held");
    }
    assert!(sim.element("lc").expect("event").complete);
}

#[test]
fn events_chain_on_element_states_with_delays_and_variables() {
    // e1 at t >= 1 sets a variable; e2 waits for the variable; e3 starts 1 s after e2 ends.
    let body = r#"
[story]
ego = "scripted"
variables = [{ name = "go", value = false }]
[[story.acts]]
name = "act"
[[story.acts.groups]]
name = "group"
actors = ["lead"]
[[story.acts.groups.maneuvers]]
name = "maneuver"
[[story.acts.groups.maneuvers.events]]
name = "e1"
priority = "parallel"
start = { kind = "simulation_time", rule = "greater_or_equal", value = 1.0 }
actions = [{ name = "set", kind = "variable_set", variable = "go", value = true }]
[[story.acts.groups.maneuvers.events]]
name = "e2"
priority = "parallel"
start = { kind = "variable", variable = "go", rule = "equal_to", value = true }
actions = [{ name = "slow", kind = "speed", speed = 10.0, shape = "step", dimension = "time", value = 0.0 }]
[[story.acts.groups.maneuvers.events]]
name = "e3"
priority = "parallel"
start = { kind = "element_state", element = "e2", state = "end_transition", delay = 1.0 }
actions = [{ name = "stop", kind = "speed", speed = 0.0, shape = "linear", dimension = "rate", value = 5.0 }]
"#;
    let (tr, sim) = run(&scenario(body), "lead");
    let first = |pred: &dyn Fn(f64) -> bool| tr.t.iter().zip(&tr.speed).find(|(_, v)| pred(**v)).map(|(t, _)| *t).expect("happens");
    // e1 fires at the evaluation at t = 1.0 and sets `go`; e2, evaluated after it in the same
    // step (document order, as esmini), sees it and steps to 10 m/s in that step (t = 1.01
    // after it); it ends in that step, which conditions see from the next evaluation (1.01):
    // with the 1 s delay e3 starts at 2.01 and shows at 2.02.
    assert!((first(&|v| v == 10.0) - 1.01).abs() < 1e-9, "e2: {}", first(&|v| v == 10.0));
    assert!((first(&|v| v < 10.0 - 1e-9) - 2.02).abs() < 1e-9, "e3: {}", first(&|v| v < 10.0 - 1e-9));
    assert_eq!(sim.variable("go"), Some(flc_sim::trigger::VarValue::Bool(true)));
    assert!(sim.element("maneuver").expect("maneuver").complete);
}

#[test]
fn override_stops_the_running_event_and_skip_does_not_start() {
    let body = |prio: &str| {
        format!(
            r#"
[[story.acts.groups.maneuvers.events]]
name = "slow"
actions = [{{ name = "slow-a", kind = "speed", speed = 0.0, shape = "linear", dimension = "rate", value = 1.0 }}]
[[story.acts.groups.maneuvers.events]]
name = "second"
priority = "{prio}"
start = {{ kind = "simulation_time", rule = "greater_or_equal", value = 2.0 }}
actions = [{{ name = "second-a", kind = "speed", speed = 20.0, shape = "step", dimension = "time", value = 0.0 }}]
"#
        )
    };
    let (tr, sim) = run(&scenario(&one_act("scripted", "\"lead\"", &body("override"))), "lead");
    assert!(tr.speed.last().is_some_and(|&v| v == 20.0), "override: ends at 20 m/s");
    assert!(sim.element("slow").expect("slow").holds(ElementEvent::StopTransition));
    let (tr, sim) = run(&scenario(&one_act("scripted", "\"lead\"", &body("skip"))), "lead");
    assert!(tr.speed.iter().all(|&v| v < V50 + 1e-9), "skip: never 20 m/s");
    assert!(!sim.element("second").expect("second").complete);
}

#[test]
fn the_controller_drives_the_ego_until_a_controller_action_hands_it_to_the_story() {
    // Controller mode: a speed action on the ego does not run; after `controller` with
    // `longitudinal = false` at t = 3 s the ego follows its story (a step to 5 m/s at t = 4 s).
    let body = r#"
[story]
ego = "controller"
[[story.acts]]
name = "act"
[[story.acts.groups]]
name = "group"
actors = ["ego"]
[[story.acts.groups.maneuvers]]
name = "maneuver"
[[story.acts.groups.maneuvers.events]]
name = "ignored"
priority = "parallel"
actions = [{ name = "ignored-a", kind = "speed", speed = 30.0, shape = "step", dimension = "time", value = 0.0 }]
[[story.acts.groups.maneuvers.events]]
name = "handover"
priority = "parallel"
start = { kind = "simulation_time", rule = "greater_or_equal", value = 3.0 }
actions = [{ name = "handover-a", kind = "controller", longitudinal = false }]
[[story.acts.groups.maneuvers.events]]
name = "crawl"
priority = "parallel"
start = { kind = "simulation_time", rule = "greater_or_equal", value = 4.0 }
actions = [{ name = "crawl-a", kind = "speed", speed = 5.0, shape = "step", dimension = "time", value = 0.0 }]
"#;
    let (tr, sim) = run(&scenario(body), "ego");
    assert!(tr.speed.iter().all(|&v| v < 29.0), "the speed action before the hand-over never ran");
    assert!(sim.ego_scripted());
    let k = tr.t.iter().position(|&t| t > 4.0 + 1e-9).expect("t > 4");
    assert!(tr.speed[k..].iter().all(|&v| v == 5.0), "scripted after 4 s: {}", tr.speed[k]);
    // Before the hand-over the controller drove: its speed is not the story's constant 50 km/h.
    assert!(tr.speed[..299].iter().any(|&v| (v - V50).abs() > 0.05), "the controller acted");
}

#[test]
fn vehicle_dynamics_track_the_story_within_the_actuator_lag() {
    let ev = r#"
[[story.acts.groups.maneuvers.events]]
name = "brake"
start = { kind = "simulation_time", rule = "greater_or_equal", value = 1.0 }
actions = [{ name = "b", kind = "speed", speed = 5.0, shape = "linear", dimension = "rate", value = 3.0 }]
"#;
    let kin = scenario(&one_act("scripted", "\"lead\"", ev));
    let mut veh = kin.clone();
    if let Some(st) = veh.story.as_mut() {
        st.dynamics = flc_sim::story::Dynamics::Vehicle;
    }
    let (a, _) = run(&kin, "lead");
    let (b, _) = run(&veh, "lead");
    let worst = a.speed.iter().zip(&b.speed).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    // The default car's actuator lag and dead time: the tracked speed trails the kinematic one
    // by a fraction of a m/s, and ends at the same speed.
    assert!(worst > 0.01 && worst < 1.0, "worst speed difference {worst}");
    assert!((b.speed.last().copied().unwrap_or(0.0) - 5.0).abs() < 0.1, "ends near 5 m/s");
}

#[test]
fn bad_stories_are_errors_naming_the_key() {
    let cases = [
        (
            one_act(
                "scripted",
                "\"nobody\"",
                "[[story.acts.groups.maneuvers.events]]\nname = \"e\"\nactions = [{ name = \"a\", kind = \"speed\", speed = 1.0, shape = \"step\", dimension = \"time\", value = 0.0 }]",
            ),
            "story.acts[0].groups[0].actors[0]",
        ),
        (
            one_act(
                "scripted",
                "\"lead\"",
                "[[story.acts.groups.maneuvers.events]]\nname = \"e\"\nstart = { kind = \"element_state\", element = \"nope\", state = \"end_transition\" }\nactions = [{ name = \"a\", kind = \"speed\", speed = 1.0, shape = \"step\", dimension = \"time\", value = 0.0 }]",
            ),
            "element",
        ),
        (
            one_act(
                "scripted",
                "\"lead\"",
                "[[story.acts.groups.maneuvers.events]]\nname = \"e\"\nactions = [{ name = \"a\", kind = \"speed\", speed = 1.0, shape = \"linear\", dimension = \"rate\", value = -2.0 }]",
            ),
            "actions[0].value",
        ),
        (one_act("scripted", "\"lead\"", "[[story.acts.groups.maneuvers.events]]\nname = \"e\"\nactions = []"), "actions"),
    ];
    for (body, key) in cases {
        let text = format!("[track]\nkind = \"straight\"\nlength = 500.0\n[lead]\ns = 50.0\n{body}");
        let e = Scenario::from_toml_str(&text, "bad.toml").expect_err("rejected").to_string();
        assert!(e.contains(key), "{e} should name {key}");
    }
    let phases = "[track]\nkind = \"straight\"\nlength = 500.0\n[lead]\nphases = [{ kind = \"brake\", decel = 3.0 }]\n[story]\n";
    let e = Scenario::from_toml_str(phases, "bad.toml").expect_err("phases and story").to_string();
    assert!(e.contains("lead.phases"), "{e}");
}
