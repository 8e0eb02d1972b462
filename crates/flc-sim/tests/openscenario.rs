//! The OpenSCENARIO importer end to end: closed-form checks through imported files, the TOML
//! twin (`scenario convert`) giving bit-identical series, distributions, and every unsupported
//! element and hostile input class rejected with exit 2 and one line naming file, line and
//! element (`docs/openscenario.md`).

use std::path::{Path, PathBuf};
use std::process::Command;

use flc_sim::openscenario::{self, ImportOptions};
use flc_sim::story::EgoMode;
use flc_sim::trigger::ElementEvent;
use flc_sim::{Scenario, Simulation};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/openscenario")
}

fn scripted() -> ImportOptions {
    ImportOptions { ego_mode: EgoMode::Scripted, ..ImportOptions::default() }
}

/// Runs `s` to its end; the transitions of its story.
fn transitions(s: &Scenario) -> Vec<(f64, bool, String, ElementEvent)> {
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    while sim.step().unwrap_or_else(|e| panic!("{e}")) {}
    sim.story_transitions()
}

fn when(tr: &[(f64, bool, String, ElementEvent)], name: &str, what: ElementEvent) -> f64 {
    tr.iter().find(|(_, _, n, w)| n == name && *w == what).map(|(t, ..)| *t).unwrap_or_else(|| panic!("{name} {what:?} never happened"))
}

#[test]
fn linear_speed_by_rate_from_50_to_2_kmh_ends_2_22_s_after_it_starts() {
    let import = openscenario::import(&data().join("speed_linear_rate.xosc"), &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let tr = transitions(&import.runs[0].scenario);
    let (t0, t1) = (when(&tr, "BrakeAction", ElementEvent::StartTransition), when(&tr, "BrakeAction", ElementEvent::EndTransition));
    // (50 - 2) / 3.6 / 6 = 2.2222 s: the action ends in the step that reaches 2 km/h.
    assert!((t1 - t0 - 48.0 / 3.6 / 6.0).abs() <= 0.01, "{t0} -> {t1}");
    assert!((t0 - 1.01).abs() < 1e-9, "starts at the first evaluation with t > 1 s: {t0}");
}

/// A two-car file: Ego at `v_ego` 50 m (freespace) behind Target at `v_target`, Target brakes
/// when the freespace gap falls below 20 m.
fn closing(v_ego: f64, v_target: f64) -> String {
    let car = |name: &str| {
        format!(
            r#"<ScenarioObject name="{name}"><Vehicle name="{name}" vehicleCategory="car"><BoundingBox><Center x="1.4" y="0" z="0.75"/><Dimensions width="1.8" length="4.5" height="1.5"/></BoundingBox><Performance maxSpeed="70" maxAcceleration="10" maxDeceleration="10"/><Axles><FrontAxle maxSteering="0.5" wheelDiameter="0.6" trackWidth="1.6" positionX="2.8" positionZ="0.3"/><RearAxle maxSteering="0" wheelDiameter="0.6" trackWidth="1.6" positionX="0" positionZ="0.3"/></Axles></Vehicle></ScenarioObject>"#
        )
    };
    let init = |name: &str, s: f64, v: f64| {
        format!(
            r#"<Private entityRef="{name}"><PrivateAction><TeleportAction><Position><LanePosition roadId="1" laneId="-2" offset="0" s="{s}"/></Position></TeleportAction></PrivateAction><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/><SpeedActionTarget><AbsoluteTargetSpeed value="{v}"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Private>"#
        )
    };
    format!(
        r#"<?xml version="1.0"?>
<OpenSCENARIO><FileHeader revMajor="1" revMinor="2" date="2026-01-01T00:00:00" author="flc" description="closing"/>
<RoadNetwork><LogicFile filepath="{road}"/></RoadNetwork>
<Entities>{ego}{target}</Entities>
<Storyboard><Init><Actions>{i1}{i2}</Actions></Init>
<Story name="S"><Act name="A"><ManeuverGroup name="G" maximumExecutionCount="1"><Actors selectTriggeringEntities="false"><EntityRef entityRef="Target"/></Actors>
<Maneuver name="M"><Event name="Brake" priority="override" maximumExecutionCount="1"><Action name="BrakeAction"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="linear" dynamicsDimension="rate" value="6"/><SpeedActionTarget><AbsoluteTargetSpeed value="0"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>
<StartTrigger><ConditionGroup><Condition name="Gap" delay="0" conditionEdge="none"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule="any"><EntityRef entityRef="Ego"/></TriggeringEntities><EntityCondition><RelativeDistanceCondition entityRef="Target" relativeDistanceType="longitudinal" freespace="true" rule="lessThan" value="20"/></EntityCondition></ByEntityCondition></Condition></ConditionGroup></StartTrigger></Event></Maneuver></ManeuverGroup>
<StartTrigger><ConditionGroup><Condition name="Go" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="0" rule="greaterOrEqual"/></ByValueCondition></Condition></ConditionGroup></StartTrigger></Act></Story>
<StopTrigger><ConditionGroup><Condition name="End" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="6" rule="greaterThan"/></ByValueCondition></Condition></ConditionGroup></StopTrigger></Storyboard></OpenSCENARIO>"#,
        road = data().join("roads/straight.xodr").display(),
        ego = car("Ego"),
        target = car("Target"),
        i1 = init("Ego", 50.0, v_ego),
        i2 = init("Target", 50.0 + 4.5 + 50.0, v_target),
    )
}

#[test]
fn relative_distance_fires_at_the_step_where_the_freespace_gap_crosses() {
    let dir = tempdir("closing");
    for (v_ego, v_target) in [(20.0, 10.0), (25.0, 5.0), (13.0, 7.0)] {
        let file = dir.join("closing.xosc");
        std::fs::write(&file, closing(v_ego, v_target)).unwrap_or_else(|e| panic!("{e}"));
        let import = openscenario::import(&file, &scripted()).unwrap_or_else(|e| panic!("{e}"));
        let t = when(&transitions(&import.runs[0].scenario), "Brake", ElementEvent::StartTransition);
        // The gap 50 - (v_ego - v_target) t falls below 20 m after t* = 30 / (v_ego - v_target);
        // the first evaluation at a step start t_k with gap < 20 is the first t_k > t*.
        let crossing = 30.0 / (v_ego - v_target);
        assert!(t > crossing - 1e-9 && t <= crossing + 0.01 + 1e-9, "{v_ego}/{v_target}: fired at {t}, crossing at {crossing}");
    }
}

#[test]
fn a_controller_the_file_names_drives_the_ego_unless_the_command_line_says_otherwise() {
    // from_catalogs.xosc: the ego's ObjectController is the catalog entry `flc-robust`.
    let file = data().join("from_catalogs.xosc");
    let own = openscenario::import(&file, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(own.runs[0].scenario.controller, flc_sim::ControllerKind::FlcRobust);
    let opts = ImportOptions { controller: Some(flc_sim::ControllerKind::Idm), ..ImportOptions::default() };
    let idm = openscenario::import(&file, &opts).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(idm.runs[0].scenario.controller, flc_sim::ControllerKind::Idm);
    // Without a controller in the file: flc.
    let plain = openscenario::import(&data().join("target_brakes.xosc"), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(plain.runs[0].scenario.controller, flc_sim::ControllerKind::Flc);
}

#[test]
fn a_2x2_distribution_gives_4_runs_with_their_parameters_in_esminis_order() {
    let import = openscenario::import(&data().join("distribution_2x2.xosc"), &scripted()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(import.runs.len(), 4);
    let values: Vec<(f64, f64)> = import
        .runs
        .iter()
        .map(|r| {
            let get = |k: &str| r.params.iter().find(|(n, _)| n == k).and_then(|(_, v)| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
            (get("EgoSpeed_kmh"), get("TargetSpeed_kmh"))
        })
        .collect();
    assert_eq!(values, vec![(40.0, 10.0), (40.0, 20.0), (60.0, 10.0), (60.0, 20.0)]);
    // Each run's scenario carries its parameters: the ego's speed is EgoSpeed_kmh / 3.6.
    for (r, (ego, _)) in import.runs.iter().zip(&values) {
        assert!((r.scenario.follower.initial_speed - ego / 3.6).abs() < 1e-9, "{}", r.scenario.follower.initial_speed);
        assert!(r.scenario.variant.is_some());
    }
}

/// Bit-identical series of two runs.
fn same_series(a: &Scenario, b: &Scenario) -> bool {
    let ra = flc_sim::run(a).unwrap_or_else(|e| panic!("{e}"));
    let rb = flc_sim::run(b).unwrap_or_else(|e| panic!("{e}"));
    let (ca, cb) = (ra.series.columns(), rb.series.columns());
    ca.len() == cb.len()
        && ca
            .iter()
            .zip(&cb)
            .all(|((na, va), (nb, vb))| na == nb && va.len() == vb.len() && va.iter().zip(vb).all(|(x, y)| x.to_bits() == y.to_bits()))
}

#[test]
fn every_fixture_and_its_toml_twin_give_bit_identical_series() {
    let mut n = 0;
    for entry in std::fs::read_dir(data()).unwrap_or_else(|e| panic!("{e}")) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        if path.extension().is_none_or(|x| x != "xosc") {
            continue;
        }
        for opts in [ImportOptions::default(), scripted()] {
            let import = openscenario::import(&path, &opts).unwrap_or_else(|e| panic!("{e}"));
            for run in import.runs.iter().take(2) {
                let toml = run.scenario.to_toml().unwrap_or_else(|e| panic!("{e}"));
                let twin = Scenario::from_toml_str(&toml, "twin.toml").unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                assert_eq!(twin, run.scenario, "{}: the twin reads back as the same scenario", path.display());
                let short = Scenario { duration: run.scenario.duration.min(20.0), ..run.scenario.clone() };
                let short_twin = Scenario { duration: short.duration, ..twin };
                assert!(same_series(&short, &short_twin), "{}: series differ", path.display());
                n += 1;
            }
        }
    }
    assert!(n >= 30, "{n} runs compared");
}

fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flc-osc-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{e}"));
    d
}

/// `scenario --config FILE` on `text` written as `dir/name`: (exit code, stderr).
fn cli(dir: &Path, name: &str, text: &str, extra: &[&str]) -> (i32, String) {
    let file = dir.join(name);
    std::fs::write(&file, text).unwrap_or_else(|e| panic!("{e}"));
    let out =
        Command::new(env!("CARGO_BIN_EXE_scenario")).arg("--config").arg(&file).args(extra).output().unwrap_or_else(|e| panic!("{e}"));
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The fixture `target_brakes.xosc` with `from` replaced by `to` (its road and catalog paths made
/// absolute, so that the text works from any folder).
fn target_brakes_with(from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(data().join("target_brakes.xosc")).unwrap_or_else(|e| panic!("{e}"));
    assert!(text.contains(from), "fixture lacks {from}");
    text.replacen(from, to, 1)
        .replace("roads/straight.xodr", &data().join("roads/straight.xodr").display().to_string())
        .replace(r#"<Directory path="catalogs"/>"#, &format!(r#"<Directory path="{}"/>"#, data().join("catalogs").display()))
}

/// `target_brakes.xosc` with the target's `<Vehicle>` element replaced by `with`.
fn target_replaced_by(with: &str) -> String {
    let text = target_brakes_with("x", "x");
    let a = text.find("<Vehicle name=\"lead\"").unwrap_or_else(|| panic!("no lead vehicle"));
    let b = a + text[a..].find("</Vehicle>").unwrap_or_else(|| panic!("no end")) + "</Vehicle>".len();
    format!("{}{with}{}", &text[..a], &text[b..])
}

#[test]
fn unsupported_elements_and_hostile_inputs_exit_2_naming_file_line_and_element() {
    let dir = tempdir("bad");
    let speed = r#"<AbsoluteTargetSpeed value="0.0"/>"#;
    let text = std::fs::read_to_string(data().join("target_brakes.xosc")).unwrap_or_default();
    assert!(text.contains("<Init>"));
    let routing = r#"<Init><Actions><Private entityRef="Ego"><PrivateAction><RoutingAction><AssignRouteAction><Route name="r" closed="false"/></AssignRouteAction></RoutingAction></PrivateAction></Private>"#;
    let cases: Vec<(&str, String, &str)> = vec![
        // Unsupported elements that would change motion.
        ("routing.xosc", target_brakes_with("<Init>\n      <Actions>", routing), "<AssignRouteAction>: unsupported"),
        // A pedestrian outside its box range, of an unknown category, or with a NaN mass.
        ("pedestrian.xosc", target_replaced_by("<Pedestrian name=\"walker\" mass=\"80\" pedestrianCategory=\"pedestrian\"><BoundingBox><Center x=\"0\" y=\"0\" z=\"0.9\"/><Dimensions width=\"0.5\" length=\"40\" height=\"1.8\"/></BoundingBox><Properties/></Pedestrian>"), "pedestrian range"),
        ("pedcategory.xosc", target_replaced_by("<Pedestrian name=\"walker\" mass=\"80\" pedestrianCategory=\"robot\"><BoundingBox><Center x=\"0\" y=\"0\" z=\"0.9\"/><Dimensions width=\"0.5\" length=\"0.5\" height=\"1.8\"/></BoundingBox><Properties/></Pedestrian>"), "pedestrianCategory"),
        ("pednan.xosc", target_replaced_by("<Pedestrian name=\"walker\" mass=\"NaN\" pedestrianCategory=\"pedestrian\"><BoundingBox><Center x=\"0\" y=\"0\" z=\"0.9\"/><Dimensions width=\"0.5\" length=\"0.5\" height=\"1.8\"/></BoundingBox><Properties/></Pedestrian>"), "mass"),
        ("stochastic.xosc", "<?xml version=\"1.0\"?>\n<OpenSCENARIO><FileHeader revMajor=\"1\" revMinor=\"2\" date=\"2026-01-01T00:00:00\" author=\"x\" description=\"d\"/>\n<ParameterValueDistribution><ScenarioFile filepath=\"target_brakes.xosc\"/><Stochastic numberOfTestRuns=\"3\"/></ParameterValueDistribution></OpenSCENARIO>".into(), "<Stochastic>"),
        // Hostile inputs.
        ("dtd.xosc", "<?xml version=\"1.0\"?>\n<!DOCTYPE x [<!ENTITY a \"aaaaaaaaaa\"><!ENTITY b \"&a;&a;&a;&a;&a;&a;\">]>\n<OpenSCENARIO>&b;</OpenSCENARIO>".into(), "DTD"),
        ("external.xosc", "<?xml version=\"1.0\"?>\n<!DOCTYPE x [<!ENTITY e SYSTEM \"file:///etc/passwd\">]>\n<OpenSCENARIO>&e;</OpenSCENARIO>".into(), "DTD"),
        ("deep.xosc", format!("<?xml version=\"1.0\"?>\n{}{}", "<a>".repeat(200), "</a>".repeat(200)), "nested deeper"),
        ("broken.xosc", "<?xml version=\"1.0\"?>\n<OpenSCENARIO>\n<FileHeader>\n</OpenSCENARIO>".into(), "not well-formed"),
        ("nan.xosc", target_brakes_with(speed, r#"<AbsoluteTargetSpeed value="NaN"/>"#).replace(speed, r#"<AbsoluteTargetSpeed value="NaN"/>"#), "NaN"),
        ("negative.xosc", target_brakes_with(r#"dynamicsDimension="rate" value="$Decel""#, r#"dynamicsDimension="time" value="-2""#), "value"),
        ("selfref.xosc", target_brakes_with(r#"name="Gap" parameterType="double" value="12.0""#, r#"name="Gap" parameterType="double" value="${$Gap + 1}""#), "Gap"),
        ("unknownparam.xosc", target_brakes_with(r#"value="$Decel""#, r#"value="$Nope""#), "Nope"),
        ("million.xosc", format!("<?xml version=\"1.0\"?>\n<OpenSCENARIO><FileHeader revMajor=\"1\" revMinor=\"2\" date=\"2026-01-01T00:00:00\" author=\"x\" description=\"d\"/>\n<ParameterValueDistribution><ScenarioFile filepath=\"{}\"/><Deterministic>{}</Deterministic></ParameterValueDistribution></OpenSCENARIO>", data().join("target_brakes.xosc").display(), ["Gap", "Decel", "BrakeTime"].map(|p| format!("<DeterministicSingleParameterDistribution parameterName=\"{p}\"><DistributionRange stepWidth=\"0.001\"><Range lowerLimit=\"1\" upperLimit=\"100\"/></DistributionRange></DeterministicSingleParameterDistribution>")).join("")), "combinations"),
        // Non-finite numbers in attributes flc does not use for motion (issue 45 item 14).
        ("wheelnan.xosc", target_brakes_with(r#"wheelDiameter="0.6""#, r#"wheelDiameter="NaN""#), "wheelDiameter"),
        ("trackinf.xosc", target_brakes_with(r#"trackWidth="1.6""#, r#"trackWidth="inf""#), "trackWidth"),
        ("centerz.xosc", target_brakes_with(r#"z="0.75""#, r#"z="Infinity""#), "<Center@z>"),
        ("revmajor.xosc", target_brakes_with(r#"revMajor="1""#, r#"revMajor="1e999""#), "revMajor"),
        ("noroad.xosc", target_brakes_with("roads/straight.xodr", "roads/missing.xodr"), "missing.xodr"),
    ];
    for (name, text, needle) in &cases {
        // `--strict`: a negative dynamics value is an error (without it, a warning: below).
        let (code, err) = cli(&dir, name, text, &["--strict"]);
        assert_eq!(code, 2, "{name}: exit {code}, stderr {err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(lines.len(), 1, "{name}: one error line: {err}");
        let line = lines[0];
        assert!(line.contains(name) && line.contains(needle), "{name}: `{line}` should name the file and `{needle}`");
        // FILE:LINE: <Element>: the line number follows the file name.
        let after = line.split(name).nth(1).unwrap_or("");
        assert!(
            after.starts_with(':') && after[1..].split(':').next().is_some_and(|n| n.parse::<u32>().is_ok()),
            "{name}: no line number in `{line}`"
        );
    }
    // Without `--strict`, a negative dynamics value plays with its magnitude, warned once (as esmini).
    let neg = target_brakes_with(r#"dynamicsDimension="rate" value="$Decel""#, r#"dynamicsDimension="time" value="-2""#);
    let (code, err) = cli(&dir, "negative.xosc", &neg, &[]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(err.lines().filter(|l| l.contains("negative SpeedActionDynamics value")).count(), 1, "{err}");
    // A file over the size limit is refused before it is parsed.
    let huge = format!("<?xml version=\"1.0\"?>\n<OpenSCENARIO>{}</OpenSCENARIO>", " ".repeat(33 * 1024 * 1024));
    let (code, err) = cli(&dir, "huge.xosc", &huge, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("huge.xosc") && err.contains("limit"), "{err}");
    // A missing road runs with --road straight; an unknown --param is an error.
    let (code, err) = cli(&dir, "noroad.xosc", &target_brakes_with("roads/straight.xodr", "roads/missing.xodr"), &["--road", "straight"]);
    assert_eq!(code, 0, "{err}");
    let (code, err) = cli(&dir, "target_brakes.xosc", &target_brakes_with("x", "x"), &["--param", "Nope=1"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("Nope"), "{err}");
    // Catalog cycles.
    let cat = dir.join("cat");
    std::fs::create_dir_all(&cat).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(cat.join("C.xosc"), "<?xml version=\"1.0\"?>\n<OpenSCENARIO><FileHeader revMajor=\"1\" revMinor=\"2\" date=\"2026-01-01T00:00:00\" author=\"x\" description=\"d\"/>\n<Catalog name=\"Cat\">\n<Vehicle name=\"loop\"><CatalogReference catalogName=\"Cat\" entryName=\"loop\"/></Vehicle></Catalog></OpenSCENARIO>").unwrap_or_else(|e| panic!("{e}"));
    let cyclic = target_replaced_by("<CatalogReference catalogName=\"Cat\" entryName=\"loop\"/>").replacen(
        "<CatalogLocations/>",
        &format!("<CatalogLocations><VehicleCatalog><Directory path=\"{}\"/></VehicleCatalog></CatalogLocations>", cat.display()),
        1,
    );
    let (code, err) = cli(&dir, "cycle.xosc", &cyclic, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.lines().filter(|l| l.starts_with("error:")).count() == 1, "{err}");
}

#[test]
fn a_test_track_lane_of_28_m_imports_with_one_warning_and_runs() {
    // Euro NCAP's test-track roads have lanes of 28 m; OpenDRIVE allows any positive width.
    let dir = tempdir("wide");
    let road = std::fs::read_to_string(data().join("roads/straight.xodr")).unwrap_or_else(|e| panic!("{e}"));
    assert!(road.contains(r#"a="3.5""#), "fixture road changed");
    let wide = dir.join("wide.xodr");
    std::fs::write(&wide, road.replace(r#"a="3.5""#, r#"a="28""#)).unwrap_or_else(|e| panic!("{e}"));
    let text = target_brakes_with("x", "x").replace(&data().join("roads/straight.xodr").display().to_string(), &wide.display().to_string());
    let file = dir.join("wide.xosc");
    std::fs::write(&file, &text).unwrap_or_else(|e| panic!("{e}"));
    let imp = openscenario::import(&file, &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let s = &imp.runs[0].scenario;
    let flc_sim::TrackSpec::Custom(track) = &s.track else { panic!("not a custom track") };
    assert_eq!(track.lane_width, 28.0);
    // Both in lane -2: the target straight ahead of the ego, on the lane's centre line.
    assert!(s.lead.offset.abs() < 1e-9 && s.follower.start_offset.abs() < 1e-9, "{} {}", s.lead.offset, s.follower.start_offset);
    let (code, err) = cli(&dir, "wide_cli.xosc", &text, &["--ego-mode", "scripted"]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("28 m wide")).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].starts_with("warning:") && lines[0].contains("usual 2-6 m"), "{err}");
}

#[test]
fn oncoming_traffic_drives_against_the_road_and_meets_the_ego_head_on() {
    // oncoming.xosc: Passing (heading pi in lane 1) and HeadOn (lane 1's driving direction, -s)
    // drive towards Ego; HeadOn changes into Ego's lane, the boxes touch at t = 10.908 s.
    let file = data().join("oncoming.xosc");
    let import = openscenario::import(&file, &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let s = &import.runs[0].scenario;
    let flc_name = |osc: &str| {
        import.runs[0].entities.iter().find(|e| e.osc_name == osc).map(|e| e.flc_name.clone()).unwrap_or_else(|| panic!("no {osc}"))
    };
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    let x0 = sim.scripted_state(&flc_name("HeadOn")).map(|st| st.x).unwrap_or(f64::NAN);
    for _ in 0..700 {
        assert!(sim.step().unwrap_or_else(|e| panic!("{e}")));
    }
    for name in ["HeadOn", "Passing"] {
        let st = sim.scripted_state(&flc_name(name)).copied().unwrap_or_else(|| panic!("no {name}"));
        assert!((st.yaw.abs() - std::f64::consts::PI).abs() < 1e-3, "{name} faces -x: {}", st.yaw);
    }
    let x1 = sim.scripted_state(&flc_name("HeadOn")).map(|st| st.x).unwrap_or(f64::NAN);
    // 7 s at 40 km/h in -x, less what the sinusoidal lane change (3.5 m over L = 33.3 m) costs
    // along x: about (pi 3.5 / (2 L))² L / 4 = 0.23 m.
    let l = 3.0 * 40.0 / 3.6;
    let lost = (std::f64::consts::PI * 3.5 / (2.0 * l)).powi(2) * l / 4.0;
    assert!((x0 - x1 - (7.0 * 40.0 / 3.6 - lost)).abs() < 0.02, "{x0} -> {x1} (lane change: {lost} m)");
    let r = flc_sim::run(s).unwrap_or_else(|e| panic!("{e}"));
    let pairs: Vec<(String, String, f64, f64)> = r
        .contacts
        .iter()
        .map(|c| (c.a.name.clone().unwrap_or_default(), c.b.name.clone().unwrap_or_default(), c.time, c.relative_speed))
        .collect();
    assert_eq!(pairs.len(), 1, "one contact episode, Ego and HeadOn: {pairs:?}");
    let (a, b, t, v) = &pairs[0];
    assert!(a == "follower 1" && b == "HeadOn", "the ego (flc's follower 1) and HeadOn: {pairs:?}");
    assert!((10.90..=10.93).contains(t), "first step with touching boxes (esmini: 10.92 s): {t}");
    assert!((v - 25.0).abs() < 1e-6, "closing speed 50 + 40 km/h: {v}");
}

#[test]
fn a_continuous_longitudinal_distance_is_kept_every_step_also_for_an_oncoming_pair() {
    // long_distance_continuous.xosc: Keeper keeps 20 m of free space behind Lead (which brakes
    // at 3 m/s² from t = 2 s), Escort 10 m ahead of Oncoming in its direction (-x), from t = 0.
    let import = openscenario::import(&data().join("long_distance_continuous.xosc"), &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let run = &import.runs[0];
    let name = |osc: &str| run.entities.iter().find(|e| e.osc_name == osc).map(|e| e.flc_name.clone()).unwrap_or_default();
    let mut sim = Simulation::new(&run.scenario).unwrap_or_else(|e| panic!("{e}"));
    let state = |sim: &Simulation, osc: &str| sim.scripted_state(&name(osc)).copied().unwrap_or_else(|| panic!("no {osc}"));
    let mut worst = 0.0f64;
    for k in 0..900 {
        let (lead, keeper) = (state(&sim, "Lead"), state(&sim, "Keeper"));
        let (onc, esc) = (state(&sim, "Oncoming"), state(&sim, "Escort"));
        // Box centres 4.5 m long: free space = centre distance - 4.5 m. The keeper is placed from
        // the start-of-step position and moves at the start-of-step speed: it lags by at most
        // |dv| dt = 0.03 m/s * 0.01 s.
        worst = worst.max((lead.x - keeper.x - 4.5 - 20.0).abs()).max((onc.x - esc.x - 4.5 - 10.0).abs());
        assert!(esc.x < onc.x, "step {k}: Escort ahead of Oncoming in -x");
        if k > 0 {
            assert!((keeper.speed - lead.speed).abs() <= 0.03 + 1e-9, "step {k}: {} vs {}", keeper.speed, lead.speed);
        }
        assert!(sim.step().unwrap_or_else(|e| panic!("{e}")));
    }
    assert!(worst < 1e-3, "largest deviation from the kept free space: {worst} m");
    // Lead ends at 20 km/h, Oncoming at 10 km/h; their keepers with them.
    let (lead, keeper, esc) = (state(&sim, "Lead"), state(&sim, "Keeper"), state(&sim, "Escort"));
    assert!((lead.speed - 20.0 / 3.6).abs() < 1e-9 && (keeper.speed - lead.speed).abs() < 1e-9, "{lead:?} {keeper:?}");
    assert!((esc.speed - 10.0 / 3.6).abs() < 1e-9, "{esc:?}");
}

#[test]
fn pedestrians_are_scripted_boxes_that_the_lidar_sees_and_that_count_in_contacts() {
    use flc_sim::{BodyKind, ObjectKind};
    let file = data().join("pedestrians.xosc");
    // Scripted: the ego runs on at 10 m/s into `Standing` (catalog pedestrian, 0.4 x 0.7 m,
    // reference point 0.1 m behind its centre, at s = 100): the ego's front (20 + 1.4 + 2.25 m)
    // meets its rear (100 + 0.1 - 0.2 m) at t = 76.25 / 10 = 7.625 s.
    let imp = openscenario::import(&file, &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let s = &imp.runs[0].scenario;
    assert_eq!((s.lead.vehicle.body, s.lead.vehicle.width, s.lead.vehicle.length), (BodyKind::Pedestrian, 0.7, 0.4));
    assert!(s.vehicles.iter().any(|v| v.name == "Walker" && v.vehicle.body == BodyKind::Pedestrian));
    assert!(!s.v2v.enabled, "a pedestrian sends no V2V");
    let r = flc_sim::run(s).unwrap_or_else(|e| panic!("{e}"));
    let hits: Vec<_> = r.contacts.iter().filter(|c| c.a.kind == ObjectKind::Pedestrian || c.b.kind == ObjectKind::Pedestrian).collect();
    assert_eq!(hits.len(), 1, "{:?}", r.contacts);
    let c = hits[0];
    let names = [c.a.label(), c.b.label()];
    // The ego is follower 1; `Standing`, the only body ahead in its lane, is the lead.
    assert_eq!(names, ["follower 1".to_string(), "lead".to_string()]);
    assert_eq!((c.a.kind, c.b.kind), (ObjectKind::Vehicle, ObjectKind::Pedestrian));
    assert!((c.time - 7.625).abs() <= 0.011, "contact at {}", c.time);
    // The walker moves by its actions: one lane to the left by rate 0.5 m/s (7 s, linear).
    let tr = transitions(s);
    let (t0, t1) = (when(&tr, "WalkerCross", ElementEvent::StartTransition), when(&tr, "WalkerCross", ElementEvent::EndTransition));
    assert!((t1 - t0 - 3.5 / 0.5).abs() <= 0.011, "{t0} -> {t1}");
    // flc's controller drives the ego: its LiDAR sees the 0.7 m wide pedestrian and stops short.
    let imp = openscenario::import(&file, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let r = flc_sim::run(&imp.runs[0].scenario).unwrap_or_else(|e| panic!("{e}"));
    assert!(!r.metrics.collision, "the ego hit the pedestrian: {:?}", r.collision);
    assert!(r.metrics.min_gap > 0.5 && r.metrics.min_gap < 10.0, "min gap {}", r.metrics.min_gap);
}

#[test]
fn lane_changes_by_rate_last_the_shapes_peak_slope_times_the_change_over_the_rate() {
    let imp = openscenario::import(&data().join("lane_change_rate.xosc"), &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let tr = transitions(&imp.runs[0].scenario);
    // Peak lateral speed `rate` (esmini): sinusoidal pi/2 * 3.5 / 1.0, cubic 1.5 * 3.5 / 1.2,
    // linear 3.5 / 0.7.
    for (action, expected) in
        [("ALaneChange", std::f64::consts::FRAC_PI_2 * 3.5 / 1.0), ("BLaneChange", 1.5 * 3.5 / 1.2), ("CLaneChange", 3.5 / 0.7)]
    {
        let (t0, t1) = (when(&tr, action, ElementEvent::StartTransition), when(&tr, action, ElementEvent::EndTransition));
        assert!((t1 - t0 - expected).abs() <= 0.011, "{action}: {t0} -> {t1}, expected {expected}");
    }
}

/// `through_junction.xosc` on a copy of `roads/x_junction.xodr` with `road_from` replaced by
/// `road_to`, and the scenario's `from` by `to`, written into `dir` (exit code, stderr).
fn junction_case(dir: &Path, name: &str, road_from: &str, road_to: &str, from: &str, to: &str) -> (i32, String) {
    let road = std::fs::read_to_string(data().join("roads/x_junction.xodr")).unwrap_or_else(|e| panic!("{e}"));
    assert!(road.contains(road_from), "road lacks {road_from}");
    let road_file = dir.join(format!("{name}.xodr"));
    std::fs::write(&road_file, road.replacen(road_from, road_to, 1)).unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(data().join("through_junction.xosc")).unwrap_or_else(|e| panic!("{e}"));
    assert!(text.contains(from), "fixture lacks {from}");
    let text = text
        .replacen(from, to, 1)
        .replace("roads/x_junction.xodr", &road_file.display().to_string())
        .replace(r#"<Directory path="catalogs"/>"#, &format!(r#"<Directory path="{}"/>"#, data().join("catalogs").display()));
    cli(dir, name, &text, &[])
}

#[test]
fn junction_routes_and_hostile_road_networks() {
    let dir = tempdir("junction");
    let lead = r#"roadId="10""#;
    // The fixture runs, and names the route it takes.
    let (code, err) = junction_case(&dir, "ok.xosc", "<OpenDRIVE>", "<OpenDRIVE>", lead, lead);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("the ego's route through the road file's 8 roads: 1 -> 10 -> 2"), "{err}");
    // The lead on road 2, beyond the junction (its s 5).
    let (code, err) = junction_case(&dir, "onroad2.xosc", "<OpenDRIVE>", "<OpenDRIVE>", lead, r#"roadId="2""#);
    assert_eq!(code, 0, "{err}");
    let cases: [(&str, &str, &str, &str, &str); 6] = [
        // An entity on a road off the route (the north arm).
        ("offroute.xosc", "<OpenDRIVE>", "<OpenDRIVE>", r#"roadId="4""#, "road `4` is not on the ego's route (1 -> 10 -> 2)"),
        // The connection names a connecting road that is not in the file.
        ("noconn.xosc", r#"connectingRoad="10""#, r#"connectingRoad="99""#, lead, "connecting road `99` is not in the file"),
        // A link to a junction that is not in the file.
        (
            "nojunction.xosc",
            r#"<successor elementType="junction" elementId="100"/>"#,
            r#"<successor elementType="junction" elementId="7"/>"#,
            lead,
            "junction `7`",
        ),
        // The straight connecting road is moved 2 m off the arms' ends.
        (
            "gap.xosc",
            r#"x="150.0" y="0.0" hdg="0.0" length="20.0""#,
            r#"x="150.0" y="2.0" hdg="0.0" length="20.0""#,
            lead,
            "starts 2.000 m from its end",
        ),
        // A malformed contact point.
        ("contact.xosc", r#"elementId="2" contactPoint="start""#, r#"elementId="2" contactPoint="middle""#, lead, "contactPoint"),
        // A loop: road 2 leads back into road 1 (the route stops before closing it), so a lead on
        // the connecting road is found; then a lead on road 3 is off the route.
        (
            "loop.xosc",
            r#"<predecessor elementType="junction" elementId="100"/></link>"#,
            r#"<predecessor elementType="junction" elementId="100"/><successor elementType="road" elementId="1" contactPoint="start"/></link>"#,
            r#"roadId="10""#,
            "",
        ),
    ];
    for (name, road_from, road_to, to, needle) in cases {
        let (code, err) = junction_case(&dir, name, road_from, road_to, lead, to);
        if needle.is_empty() {
            assert_eq!(code, 0, "{name}: {err}");
            continue;
        }
        assert_eq!(code, 2, "{name}: exit {code}, stderr {err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(lines.len(), 1, "{name}: one error line: {err}");
        assert!(lines[0].contains(needle), "{name}: `{}` should say `{needle}`", lines[0]);
    }
}

#[test]
fn an_ego_in_a_positive_lane_meets_a_crossing_pedestrian_and_stops_at_the_road_start() {
    use flc_sim::ObjectKind;
    // crossing.xosc: Ego in lane 1 (driven in -s) from s = 60 at 10 m/s; Walker crosses on a
    // polyline trajectory from t = 0.51 s (1.55 m/s across) into its path.
    let file = data().join("crossing.xosc");
    let imp = openscenario::import(&file, &scripted()).unwrap_or_else(|e| panic!("{e}"));
    let run = &imp.runs[0];
    let walker = run.entities.iter().find(|e| e.osc_name == "Walker").map(|e| e.flc_name.clone()).expect("walker");
    let mut sim = Simulation::new(&run.scenario).unwrap_or_else(|e| panic!("{e}"));
    let mut rows = Vec::new();
    while sim.step().unwrap_or_else(|e| panic!("{e}")) {
        let w = *sim.scripted_state(&walker).expect("walker state");
        let e = *sim.follower_state(0).expect("ego");
        rows.push((sim.time(), w, e));
    }
    let at = |t: f64| rows.iter().find(|r| (r.0 - t).abs() < 5e-3).copied().unwrap_or_else(|| panic!("no row at {t}"));
    // The ego drives -x (heading pi) and stands at the road's start from 6.02 s: its reference
    // point at x = 0, its box centre 1.4 m ahead of it (x = -1.4).
    let (_, _, e3) = at(3.0);
    assert!((e3.yaw.abs() - std::f64::consts::PI).abs() < 1e-9 && (e3.x - (30.0 - 1.4)).abs() < 1e-6, "{e3:?}");
    for t in [6.02, 7.0, 9.0] {
        let (_, _, e) = at(t);
        assert!(e.speed == 0.0 && (e.x + 1.4).abs() < 1e-6, "t = {t}: {e:?}");
    }
    let (_, _, e6) = at(6.01);
    assert!(e6.speed == 10.0, "the end is reached at 6.00 s, the speed kept one step: {e6:?}");
    // The walker crosses (y of its box centre 0.1 m ahead along heading 1.4) at 1.55 m/s and,
    // after its last vertex (5.01 s), walks on along the road (+x) at that speed.
    let (_, w3, _) = at(3.0);
    let (_, w4, _) = at(4.0);
    assert!((w4.y - w3.y - 1.55).abs() < 1e-6 && (w4.x - w3.x).abs() < 1e-9 && (w3.speed - 1.55).abs() < 1e-9, "{w3:?} {w4:?}");
    assert!((w3.yaw - 1.4).abs() < 1e-9, "the pedestrian keeps its heading: {w3:?}");
    let (_, w7, _) = at(7.0);
    let (_, w8, _) = at(8.0);
    assert!((w8.x - w7.x - 1.55).abs() < 1e-6 && (w8.y - w7.y).abs() < 1e-9, "{w7:?} {w8:?}");
    // One contact, with the walker, at 2.61 s (esmini: 2.61 s).
    let r = flc_sim::run(&run.scenario).unwrap_or_else(|e| panic!("{e}"));
    let hits: Vec<_> = r.contacts.iter().filter(|c| c.b.kind == ObjectKind::Pedestrian || c.a.kind == ObjectKind::Pedestrian).collect();
    assert_eq!(hits.len(), 1, "{:?}", r.contacts);
    assert!((hits[0].time - 2.61).abs() <= 0.011, "contact at {}", hits[0].time);
    // flc's controller drives the ego: its LiDAR sees the pedestrian as it enters the lane
    // (a detection before the scripted contact) and it brakes hard.
    let imp = openscenario::import(&file, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = Simulation::new(&imp.runs[0].scenario).unwrap_or_else(|e| panic!("{e}"));
    while sim.step().unwrap_or_else(|e| panic!("{e}")) {}
    let series = sim.series(1).expect("series");
    let seen = series.detected_distance.iter().zip(&series.t).find(|(d, _)| d.is_finite()).map(|(_, t)| *t);
    assert!(seen.is_some_and(|t| t < 2.6), "first detection at {seen:?}");
    let r = sim.result();
    assert!(r.metrics.max_decel > 3.0, "max deceleration {}", r.metrics.max_decel);
}

/// The R157 careful driver drives the ego's own speed in the file (as esmini's ReferenceDriver
/// keeps the speed it takes over at); the baselines cruise 20 km/h above the file's fastest
/// speed (target_brakes.xosc: both cars at EgoSpeed_kmh = 50, the lead then brakes).
#[test]
fn the_careful_driver_drives_the_egos_speed_the_baselines_20_kmh_above_the_fastest() {
    let file = data().join("target_brakes.xosc");
    let import = openscenario::import(&file, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let s = &import.runs[0].scenario;
    assert!((s.careful_driver.normal.desired_speed - 50.0 / 3.6).abs() < 1e-9, "{}", s.careful_driver.normal.desired_speed);
    assert!((s.idm.desired_speed - 70.0 / 3.6).abs() < 1e-9, "{}", s.idm.desired_speed);
    let opts = ImportOptions { params: vec![("EgoSpeed_kmh".into(), "80".into())], ..ImportOptions::default() };
    let fast = openscenario::import(&file, &opts).unwrap_or_else(|e| panic!("{e}"));
    let s = &fast.runs[0].scenario;
    assert!((s.careful_driver.normal.desired_speed - 80.0 / 3.6).abs() < 1e-9, "{}", s.careful_driver.normal.desired_speed);
    assert!((s.idm.desired_speed - 100.0 / 3.6).abs() < 1e-9, "{}", s.idm.desired_speed);
}
