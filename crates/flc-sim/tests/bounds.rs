//! Sizes first (issue 29): every count a scenario or sweep file controls, set far past its
//! limit, exits 2 within 100 ms with one `error:` line naming the key, whatever would be built
//! from it (7 million follower names, grids of 10^12 points, ...).
//!
//! Release only: the debug binary parses the larger files too slowly for the time limit
//! (tests/run_all.sh runs this with --release).

use std::fmt::Write as _;
use std::process::Command;
use std::time::{Duration, Instant};

/// Time allowed for rejecting the file, on top of parsing its text.
const BUDGET: Duration = Duration::from_millis(100);

fn tmpdir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("flc-bounds-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("mkdir");
    d
}

/// Runs `scenario <args> FILE` on `text`; asserts exit 2, one `error:` line naming `key`, and
/// a wall time under [`BUDGET`] plus four times the time the TOML text alone takes to parse (for the files
/// whose size is the count: a list of 4 million points takes its time to read, whatever follows).
fn rejects(tag: &str, args: &[&str], text: &str, key: &str) {
    let d = tmpdir(tag);
    let f = d.join(format!("{tag}.toml"));
    std::fs::write(&f, text).expect("write");
    let t = Instant::now();
    let _: toml::Table = toml::from_str(text).expect("valid TOML");
    let parse = t.elapsed();
    // Warm the binary (page cache), then time a run.
    let _ = Command::new(env!("CARGO_BIN_EXE_scenario")).arg("--version").output();
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_scenario")).args(args).arg(&f).arg("--threads").arg("1").output().expect("run");
    let took = t.elapsed();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{tag}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{tag}: {err}");
    assert!(err.starts_with("error:"), "{tag}: {err}");
    assert!(err.contains(&format!("`{key}`")), "{tag}: expected key `{key}` in {err}");
    // Typed deserialisation (field paths tracked) costs a few times the plain parse.
    let limit = BUDGET + parse * 4;
    assert!(took < limit, "{tag}: {took:?} (limit {limit:?}, parse alone {parse:?}): {err}");
    println!("{tag}: exit 2 in {took:?} (parse {parse:?}): {}", err.trim_end());
    let _ = std::fs::remove_dir_all(&d);
}

fn config(tag: &str, text: &str, key: &str) {
    rejects(tag, &["--config"], text, key);
}

fn sweep(tag: &str, text: &str, key: &str) {
    rejects(tag, &["sweep"], text, key);
}

fn repeat(n: usize, item: &str) -> String {
    item.repeat(n)
}

const BIG: usize = 7_000_000;
/// Size of the lists (entries each of several bytes; the file stays a few MB).
const LIST: usize = 100_000;

const HOLD: &str = "[[lead.phases]]\nkind = \"hold\"\nduration = 1.0\n";
const COND: &str = "{ kind = \"simulation_time\", rule = \"greater_or_equal\", value = 1.0 }";

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn followers() {
    config("followers", &format!("[platoon]\nfollowers = {BIG}\n"), "platoon.followers");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn platoon_overrides() {
    config(
        "overrides",
        &format!("[platoon]\nfollowers = 2\n{}", repeat(LIST, "[[platoon.overrides]]\nfollowers = [1]\n")),
        "platoon.overrides",
    );
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn override_followers_list() {
    let list = vec!["1"; 10 * LIST].join(",");
    config(
        "override-list",
        &format!("[platoon]\nfollowers = 2\n[[platoon.overrides]]\nfollowers = [{list}]\n"),
        "platoon.overrides[0].followers",
    );
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn vehicles() {
    let mut s = String::new();
    for i in 0..LIST {
        let _ = writeln!(s, "[[vehicles]]\nname = \"car{i}\"\ns = 50.0");
    }
    config("vehicles", &s, "vehicles");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn lead_phases() {
    config("lead-phases", &repeat(LIST, HOLD), "lead.phases");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn vehicle_phases() {
    let text =
        format!("[[vehicles]]\nname = \"car\"\ns = 50.0\n{}", repeat(LIST, "[[vehicles.phases]]\nkind = \"hold\"\nduration = 1.0\n"));
    config("vehicle-phases", &text, "vehicles[0].phases");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn trigger_groups() {
    let groups = vec![COND; LIST].join(",");
    config("trigger-groups", &format!("[stop]\ntrigger = [{groups}]\n"), "stop.trigger");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn trigger_conditions() {
    let conds = vec![COND; LIST].join(",");
    let text = format!("{}[[lead.phases]]\nkind = \"hold\"\nduration = 1.0\nstart = [[{conds}]]\n", HOLD);
    config("trigger-conditions", &text, "lead.phases[1].start");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn centerline_points() {
    let n = 4_000_001; // one past the limit
    let mut pts = String::with_capacity(n * 12);
    for i in 0..n {
        let _ = write!(pts, "[{i},0],");
    }
    config("centerline", &format!("[track]\nkind = \"custom\"\ncenterline = [{pts}]\n"), "track.centerline");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn roadside_objects() {
    let objs = vec!["{ kind = \"post\", s = 10.0, offset = 5.0, radius = 0.1 }"; LIST].join(",");
    config("objects", &format!("[track]\nkind = \"custom\"\ncenterline = [[0, 0], [1000, 0]]\nobjects = [{objs}]\n"), "track.objects");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn story_elements() {
    let mut s = String::from("[story]\n");
    for i in 0..LIST {
        let _ = writeln!(s, "[[story.acts]]\nname = \"act{i}\"\ngroups = []");
    }
    config("story", &s, "story.acts");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn variants() {
    let mut s = String::new();
    for i in 0..LIST {
        let _ = writeln!(s, "[[variants]]\nname = \"v{i}\"");
    }
    config("variants", &s, "variants");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn frequencies() {
    let list = vec!["0.1"; 10 * LIST].join(",");
    config(
        "frequencies",
        &format!("[platoon]\nfollowers = 2\n[platoon.string_stability]\nfrequencies_hz = [{list}]\n"),
        "platoon.string_stability.frequencies_hz",
    );
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn v2v_outages() {
    let list = vec!["{ start = 1.0, end = 2.0 }"; LIST].join(",");
    config("outages", &format!("[v2v]\noutages = [{list}]\n"), "v2v.outages");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn rates_and_steps() {
    config("lidar-rate", &format!("[lidar]\nrate_hz = {BIG}.0\n"), "lidar.rate_hz");
    config("v2v-rate", &format!("[v2v]\nrate_hz = {BIG}.0\n"), "v2v.rate_hz");
    config("physics-dt", "physics_dt = 1e-9\n", "physics_dt");
    config("duration", &format!("duration = {BIG}.0\n"), "duration");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn sweep_samples() {
    let text = format!("family = \"paper\"\nmode = \"random\"\nsamples = {BIG}\n[[axes]]\nkey = \"speed_kmh\"\nfrom = 30.0\nto = 60.0\n");
    sweep("sweep-samples", &text, "samples");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn sweep_steps_and_grid() {
    let axis = |key: &str, steps: usize| format!("[[axes]]\nkey = \"{key}\"\nfrom = 1.0\nto = 2.0\nsteps = {steps}\n");
    sweep("sweep-steps", &format!("family = \"paper\"\n{}", axis("lead_decel", BIG)), "axes[0].steps");
    let grid = format!("family = \"paper\"\n{}{}{}", axis("lead_decel", 10_000), axis("speed_kmh", 10_000), axis("lidar.rate_hz", 10_000));
    sweep("sweep-grid", &grid, "axes");
    let values = vec!["1.0"; 10 * LIST].join(",");
    sweep("sweep-values", &format!("family = \"paper\"\n[[axes]]\nkey = \"lead_decel\"\nvalues = [{values}]\n"), "axes[0].values");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn sweep_axes() {
    let text = format!("family = \"paper\"\n{}", repeat(LIST, "[[axes]]\nkey = \"lead_decel\"\nvalues = [1.0]\n"));
    sweep("sweep-axes", &text, "axes");
}

/// Within the limits the checks stay linear: 64 vehicles of 1000 phases whose start triggers
/// chain backwards through the entities (the old fixed-point search of the phase-cycle check
/// needed one pass over all 64,000 phases per link of that chain) validate in the time it takes
/// to parse the file.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn phase_checks_are_linear() {
    let (m, p) = (64usize, 1000usize);
    let name = |i: usize| if i == 0 { "lead".to_string() } else { format!("car{i}") };
    let mut s = String::new();
    for i in 0..m {
        if i > 0 {
            let _ = writeln!(s, "[[vehicles]]\nname = \"{}\"\ns = {}", name(i), 20.0 * i as f64 + 20.0);
        }
        let table = if i == 0 { "lead.phases" } else { "vehicles.phases" };
        for k in 0..p {
            let _ = writeln!(s, "[[{table}]]\nkind = \"hold\"\nduration = 1.0");
            let waits = if i + 1 < m { Some((name(i + 1), k)) } else { k.checked_sub(1).map(|j| (name(0), j)) };
            if let Some((e, j)) = waits {
                let _ = writeln!(s, "start = {{ kind = \"phase_state\", entity = \"{e}\", phase = {j}, state = \"started\" }}");
            }
        }
    }
    let t = Instant::now();
    let _: toml::Table = toml::from_str(&s).expect("valid TOML");
    let parse = t.elapsed();
    let t = Instant::now();
    let sc = flc_sim::Scenario::from_toml_str(&s, "chain.toml").expect("valid scenario");
    let took = t.elapsed();
    assert_eq!(sc.vehicles.len(), m - 1);
    let limit = BUDGET + parse * 3;
    assert!(took < limit, "{took:?} (limit {limit:?}, parse alone {parse:?})");
    println!("{} phases validated in {took:?} (parse {parse:?})", m * p);
    // One link closing the chain into a cycle is found and reported.
    let cyclic = s.replacen("entity = \"car1\", phase = 0,", "entity = \"car63\", phase = 999,", 1);
    let t = Instant::now();
    let e = flc_sim::Scenario::from_toml_str(&cyclic, "cycle.toml").expect_err("cycle");
    assert!(t.elapsed() < limit, "{:?}", t.elapsed());
    let msg = e.to_string();
    assert!(msg.lines().count() == 1 && msg.contains("lead.phases[0]"), "{}", &msg[..msg.len().min(300)]);
}

/// The fixture `target_brakes.xosc` with `from` replaced by `to`, its road and catalog paths made
/// absolute (the file is written elsewhere).
fn xosc_with(from: &str, to: &str) -> String {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/openscenario");
    let text = std::fs::read_to_string(data.join("target_brakes.xosc")).expect("fixture");
    assert!(text.contains(from), "fixture lacks {from}");
    text.replacen(from, to, 1)
        .replace("roads/straight.xodr", &data.join("roads/straight.xodr").display().to_string())
        .replace(r#"<Directory path="catalogs"/>"#, &format!(r#"<Directory path="{}"/>"#, data.join("catalogs").display()))
}

/// Runs `scenario --config FILE.xosc` on `text`: exit 2 with one `error:` line naming the file, a
/// line number and `needle`, within [`BUDGET`] plus four times the time the XML alone takes to parse.
fn rejects_xosc(tag: &str, text: &str, needle: &str) {
    let d = tmpdir(tag);
    let f = d.join(format!("{tag}.xosc"));
    std::fs::write(&f, text).expect("write");
    let t = Instant::now();
    let doc = roxmltree::Document::parse(text).expect("well-formed XML");
    let parse = t.elapsed();
    drop(doc);
    let _ = Command::new(env!("CARGO_BIN_EXE_scenario")).arg("--version").output();
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_scenario")).arg("--config").arg(&f).arg("--threads").arg("1").output().expect("run");
    let took = t.elapsed();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{tag}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{tag}: {err}");
    let name = format!("{tag}.xosc:");
    let after = err.split(&name).nth(1).unwrap_or("");
    assert!(err.starts_with("error:") && after.split(':').next().is_some_and(|n| n.parse::<u32>().is_ok()), "{tag}: no file:line in {err}");
    assert!(err.contains(needle), "{tag}: expected `{needle}` in {err}");
    let limit = BUDGET + parse * 4;
    assert!(took < limit, "{tag}: {took:?} (limit {limit:?}, XML parse alone {parse:?}): {err}");
    println!("{tag}: exit 2 in {took:?} (XML parse {parse:?}): {}", err.trim_end());
    let _ = std::fs::remove_dir_all(&d);
}

/// OpenSCENARIO entities (issue 29, "once the importer lands"): 100,000 `ScenarioObject`s.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn xosc_entities() {
    let car = r#"<ScenarioObject name="Ego">"#;
    let many: String = (0..LIST)
        .map(|i| {
            format!("<ScenarioObject name=\"x{i}\"><CatalogReference catalogName=\"VehicleCatalog\" entryName=\"car\"/></ScenarioObject>\n")
        })
        .collect();
    rejects_xosc("entities", &xosc_with(car, &format!("{many}{car}")), "<Entities>: 100002 entities, more than the limit");
}

/// OpenSCENARIO events: 20,000 `Event`s in one maneuver (twice the story's element limit; more
/// would pass the importer's 32 MiB file limit first).
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn xosc_events() {
    let start = r#"<Event name="TargetStops""#;
    let event = r#"<Event name="E{i}" priority="parallel" maximumExecutionCount="1"><Action name="A"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/><SpeedActionTarget><AbsoluteTargetSpeed value="1.0"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action><StartTrigger><ConditionGroup><Condition name="C" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="1" rule="greaterThan"/></ByValueCondition></Condition></ConditionGroup></StartTrigger></Event>"#;
    let many: String = (0..20_000).map(|i| event.replace("{i}", &i.to_string())).collect();
    rejects_xosc("events", &xosc_with(start, &format!("{many}{start}")), "storyboard elements, more than the limit");
}

/// OpenSCENARIO trigger conditions: 100,000 conditions in one group.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn xosc_conditions() {
    let start = r#"<Condition name="AfterBrakeTime""#;
    let cond = r#"<Condition name="C{i}" delay="0" conditionEdge="none"><ByValueCondition><SimulationTimeCondition value="1" rule="greaterThan"/></ByValueCondition></Condition>"#;
    let many: String = (0..LIST).map(|i| cond.replace("{i}", &i.to_string())).collect();
    rejects_xosc("conditions", &xosc_with(start, &format!("{many}{start}")), "100001 conditions, more than the limit");
}
