//! The `scenario` binary: exit codes, one-line errors naming file / key / problem, JSON fields.

use std::process::Command;

fn scenario() -> Command {
    Command::new(env!("CARGO_BIN_EXE_scenario"))
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn tmpdir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("flc-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("mkdir");
    d
}

#[test]
fn bad_scenarios_exit_2_with_one_line_naming_file_and_key() {
    let d = tmpdir("bad");
    let cases = [
        ("range.toml", "[lidar]\nrate_hz = 0.0\n", "lidar.rate_hz"),
        ("unknown.toml", "[lidar]\nrate_hz = 10.0\nfrobnicate = 1\n", "frobnicate"),
        ("type.toml", "duration = \"long\"\n", "duration"),
        ("phase.toml", "[[lead.phases]]\nkind = \"brake\"\ndecel = -6.0\n", "lead.phases[0].decel"),
        ("syntax.toml", "duration = = 3\n", "syntax.toml"),
    ];
    for (name, text, key) in cases {
        let f = write(&d, name, text);
        let out_dir = d.join(format!("out-{name}"));
        let out = scenario().arg("--config").arg(&f).arg("--out").arg(&out_dir).output().expect("run");
        assert_eq!(out.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
        assert!(err.contains(name) && err.contains(key), "{name}: {err}");
        assert!(out.stdout.is_empty(), "{name}: partial output");
        assert!(!out_dir.exists(), "{name}: output directory written");
    }
    let out = scenario().arg("--speeds").arg("abc").output().expect("run");
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn json_records_have_the_documented_fields_and_collision_exit_code() {
    let d = tmpdir("json");
    let f = write(
        &d,
        "crash.toml",
        "name = \"crash\"\ncontroller = \"flc\"\nduration = 40.0\n[follower]\ninitial_speed = 20.0\ninitial_gap = 8.0\n[follower.speed_controller]\nmax_decel = 1.0\n[lead]\ninitial_speed = 20.0\n[[lead.phases]]\nkind = \"brake\"\ndecel = 8.0\n[v2v]\nenabled = false\n",
    );
    let out = scenario().args(["--json", "--fail-on-collision", "--config"]).arg(&f).output().expect("run");
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let line = String::from_utf8_lossy(&out.stdout);
    let v: serde_json::Value = serde_json::from_str(line.trim()).expect("json");
    for k in [
        "scenario",
        "controller",
        "speed_kmh",
        "collision",
        "impact_speed",
        "min_gap",
        "final_clearance",
        "min_ttc",
        "max_decel",
        "max_jerk",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["collision"], true);
    assert_eq!(v["controller"], "flc");
    assert!(v["impact_speed"].as_f64().expect("number") > 0.0);
    // Without the flag a collision is still a successful run.
    let out = scenario().args(["--json", "--config"]).arg(&f).output().expect("run");
    assert_eq!(out.status.code(), Some(0));
}

#[test]
fn sweep_to_parquet_points_to_the_python_command() {
    let d = tmpdir("parquet");
    let f = write(&d, "s.toml", "family = \"paper\"\n[[axes]]\nkey = \"speed_kmh\"\nvalues = [30.0]\n");
    let out = scenario().arg("sweep").arg(&f).arg("--out").arg(d.join("x.parquet")).output().expect("run");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--out") && err.contains("python -m flc sweep"), "{err}");
    assert!(!d.join("x.parquet").exists());
}

/// `docs/paper-reproduction.md`'s tracking table (a generated block, `python -m flc docs`) says
/// what `scenario` prints under its table: the same errors to the printed digits, and how each
/// run ends.
#[test]
fn paper_reproduction_tracking_table_equals_what_scenario_prints() {
    let out = scenario().args(["--speeds", "30", "--preset", "paper", "--controllers", "flc"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/paper-reproduction.md")).unwrap();
    for c in ["flc", "pid"] {
        let line = text
            .lines()
            .find(|l| l.contains(&format!("tracking on the curved route, {c}:")))
            .unwrap_or_else(|| panic!("no tracking line for {c} in:\n{text}"));
        let num = |key: &str| line.split(key).nth(1).and_then(|r| r.split_whitespace().next()).unwrap().to_string();
        let (rot, trans) = (num("rotational "), num("translational "));
        let ends = line.split("s: ").last().unwrap().trim().replace("  ", " ");
        let row = doc
            .lines()
            .find(|l| l.starts_with(&format!("| {} |", c.to_uppercase())) && l.contains("after"))
            .unwrap_or_else(|| panic!("no tracking row for {c} in docs/paper-reproduction.md"));
        assert!(row.starts_with(&format!("| {} | {rot} | {trans} | ", c.to_uppercase())), "doc row `{row}` vs printed `{line}`");
        let ends_doc = ends.replace("collision ", "collision, ");
        assert!(row.contains(&ends_doc), "doc row `{row}` does not say how the run ends: `{ends}`");
    }
}

/// `scenario sweep`: a sweep file changed since its CSV was written is refused (exit 2, one line
/// naming the CSV and `--restart`), the CSV untouched; `--restart` runs the new sweep.
#[test]
fn sweep_refuses_a_changed_file_and_restart_starts_over() {
    let d = tmpdir("stale");
    let text = "family = \"paper\"\n[[axes]]\nkey = \"speed_kmh\"\nvalues = [30.0]\n[[axes]]\nkey = \"lead_decel\"\nvalues = [4.0, 8.0]\n";
    let f = write(&d, "s.toml", text);
    let csv = d.join("s.csv");
    let ok = scenario().arg("sweep").arg(&f).output().expect("run");
    assert_eq!(ok.status.code(), Some(0), "{}", String::from_utf8_lossy(&ok.stderr));
    let rows = std::fs::read_to_string(&csv).expect("csv");
    assert!(d.join("s.csv.digest").exists());
    write(&d, "s.toml", &text.replace("[4.0, 8.0]", "[2.0, 9.0]"));
    let out = scenario().arg("sweep").arg(&f).output().expect("run");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("s.csv") && err.contains("--restart"), "{err}");
    assert_eq!(std::fs::read_to_string(&csv).expect("csv"), rows);
    let out = scenario().arg("sweep").arg(&f).arg("--restart").output().expect("run");
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let new = std::fs::read_to_string(&csv).expect("csv");
    assert!(new.lines().skip(1).all(|l| l.contains(",2.0,") || l.contains(",9.0,")), "{new}");
    assert_eq!(new.lines().count(), 3);
}

/// `scenario sweep FILE.xosc`: the import options are inputs too; another `--controllers` does
/// not resume the first one's CSV.
#[test]
fn sweep_of_a_distribution_refuses_other_import_options() {
    let d = tmpdir("stale-xosc");
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/openscenario");
    let f = data.join("distribution_2x2.xosc");
    let csv = d.join("x.csv");
    let ok = scenario().arg("sweep").arg(&f).arg("--out").arg(&csv).output().expect("run");
    assert_eq!(ok.status.code(), Some(0), "{}", String::from_utf8_lossy(&ok.stderr));
    let again = scenario().arg("sweep").arg(&f).arg("--out").arg(&csv).output().expect("run");
    assert_eq!(again.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&again.stderr).contains("0 runs done"), "{}", String::from_utf8_lossy(&again.stderr));
    let out = scenario().arg("sweep").arg(&f).arg("--out").arg(&csv).args(["--controllers", "pid"]).output().expect("run");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.lines().last().is_some_and(|l| l.contains("--restart")), "{err}");
}

/// `scenario suite`: the suites are found from the executable, not the working directory; `--root`
/// names their folder (a wrong one: exit 2, one line naming it).
#[test]
fn suite_finds_its_folder_from_any_working_directory_and_takes_root() {
    let d = tmpdir("suite-root");
    // A folder that looks like the suites, in the working directory: not used.
    std::fs::create_dir_all(d.join("scenarios/suites/r157")).expect("mkdir");
    std::fs::write(d.join("scenarios/suites/r157/suite.toml"), "title = \"not this one\"\n").expect("write");
    let out = scenario().current_dir(&d).args(["suite", "r157", "--controllers", "flc"]).output().expect("run");
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("flc"));
    let bad = scenario()
        .current_dir(&d)
        .args(["suite", "r157", "--controllers", "flc", "--root"])
        .arg(d.join("scenarios/suites"))
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("suite.toml"), "{err}");
    let none = scenario().current_dir(&d).args(["suite", "r157", "--root"]).arg(d.join("nowhere")).output().expect("run");
    assert_eq!(none.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&none.stderr).contains("nowhere"));
}
