//! The `scenario` binary: exit codes, one-line errors naming file / key / problem, JSON fields,
//! the paper experiment's verdicts, `--set`, `--controllers` on TOML files, `--quiet` and the
//! subcommands' own flags.

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
    let out = scenario().args(["--speeds", "30", "--preset", "paper", "--controllers", "flc,pid"]).output().unwrap();
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

/// Runs `scenario` with `args`; stdout, stderr, exit code.
fn run(args: &[&str]) -> (String, String, Option<i32>) {
    let out = scenario().args(args).output().expect("run");
    (String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned(), out.status.code())
}

/// `--json` lines of a successful run.
fn json_lines(args: &[&str]) -> Vec<serde_json::Value> {
    let (stdout, stderr, code) = run(args);
    assert_eq!(code, Some(0), "{args:?}: {stderr}");
    stdout.lines().map(|l| serde_json::from_str(l).expect("a JSON line")).collect()
}

/// The verdict is the run's, not a constant: the paper preset's FLC collides at 90 km/h as in the
/// paper; with the realistic vehicle's brake authority (8 m/s² instead of 4.9) it stops, and the
/// record and the summary say the outcome differs.
#[test]
fn the_paper_verdict_changes_with_the_calibration() {
    let base = ["--json", "--speeds", "90", "--controllers", "flc", "--preset", "paper"];
    let lines = json_lines(&base);
    assert_eq!(lines.len(), 2, "one record and the summary: {lines:?}");
    let (rec, sum) = (&lines[0], &lines[1]["paper_summary"]);
    assert_eq!(rec["collision"], true);
    let v = &rec["paper_verdict"];
    assert_eq!(
        (v["paper_outcome"].as_str(), v["outcome"].as_str(), v["verdict"].as_str()),
        (Some("collision"), Some("collision"), Some("match"))
    );
    assert_eq!(v["outcome_match"], true);
    assert!(v["clearance_error"].is_null() && v["clearance_within"].is_null());
    let presets = sum["presets"].as_array().expect("presets");
    assert_eq!(presets.len(), 1, "only the paper preset ran: {sum}");
    assert_eq!(
        (presets[0]["preset"].as_str(), presets[0]["cells"].as_u64(), presets[0]["outcome_matches"].as_u64()),
        (Some("paper"), Some(1), Some(1))
    );
    // Only the FLC ran: its tracking run, no PID's, no order, no 90 km/h impact comparison.
    let tracking = sum["tracking"].as_array().expect("tracking");
    assert_eq!(tracking.iter().map(|t| t["controller"].as_str().unwrap()).collect::<Vec<_>>(), ["flc"]);
    assert!(sum.get("tracking_order").is_none() && presets[0].get("impact_90").is_none(), "{sum}");
    assert_eq!(sum["matching_region"]["map_percent"].as_f64(), Some(flc_sim::paper::PAPER_MATCHING_REGION.0));
    assert!(sum["matching_region"]["source"].as_str().unwrap().contains("not this run"));

    let set = "follower.speed_controller.max_decel=8.0";
    let lines = json_lines(&[&base[..], &["--set", set]].concat());
    let (rec, sum) = (&lines[0], &lines[1]["paper_summary"]);
    assert_eq!(rec["collision"], false, "the stronger brakes stop: {rec}");
    assert_eq!(
        (rec["paper_verdict"]["outcome"].as_str(), rec["paper_verdict"]["verdict"].as_str()),
        (Some("stop"), Some("outcome_differs"))
    );
    assert_eq!(sum["presets"][0]["outcome_matches"].as_u64(), Some(0));
    assert_eq!(sum["overrides"], serde_json::json!([set]));
}

/// A subset gives a summary over only what ran, in the table as in `--json`, and the per-preset
/// counts are those of the records' verdicts.
#[test]
fn a_subset_is_summed_up_over_what_ran() {
    let args = ["--speeds", "70", "--controllers", "flc"];
    let (text, stderr, code) = run(&args);
    assert_eq!(code, Some(0), "{stderr}");
    let line = text.lines().find(|l| l.starts_with("verdict vs the paper")).unwrap_or_else(|| panic!("no summary line in:\n{text}"));
    assert!(line.contains("realistic preset: 1/1 outcome classes") && line.contains("paper preset: 1/1 outcome classes"), "{line}");
    assert!(!text.contains("/8") && !text.contains("all 8 cells match the paper"), "{text}");
    assert!(text.contains("not this run"), "the region figure is labelled as the committed map's:\n{text}");
    let lines = json_lines(&[&args[..], &["--json"]].concat());
    let (records, summary) = lines.split_at(lines.len() - 1);
    assert_eq!(records.len(), 2);
    for p in summary[0]["paper_summary"]["presets"].as_array().expect("presets") {
        let mine: Vec<&serde_json::Value> = records.iter().filter(|r| r["preset"] == p["preset"]).collect();
        assert_eq!(p["cells"].as_u64(), Some(mine.len() as u64));
        let matches = mine.iter().filter(|r| r["paper_verdict"]["outcome_match"] == true).count();
        assert_eq!(p["outcome_matches"].as_u64(), Some(matches as u64));
        let within = mine.iter().filter(|r| r["paper_verdict"]["clearance_within"] == true).count();
        assert_eq!(p["clearances_within"].as_u64(), Some(within as u64));
        // The table's verdict column says the same as the record.
        let row = text.lines().find(|l| l.starts_with(&format!("paper-{}-70 ", p["preset"].as_str().unwrap()))).expect("row");
        let ok = mine[0]["paper_verdict"]["verdict"] == "match";
        assert_eq!(row.contains(" ok"), ok, "{row}");
    }
}

/// A TOML scenario file for the `--set` and `--controllers` tests: the lead brakes hard, the
/// follower's brakes are weak, it collides.
fn crash_file(dir: &std::path::Path) -> std::path::PathBuf {
    write(
        dir,
        "crash.toml",
        "name = \"crash\"\ncontroller = \"flc\"\nduration = 40.0\n[follower]\ninitial_speed = 20.0\ninitial_gap = 8.0\n[follower.speed_controller]\nmax_decel = 1.0\n[lead]\ninitial_speed = 20.0\n[[lead.phases]]\nkind = \"brake\"\ndecel = 8.0\n[v2v]\nenabled = false\n",
    )
}

#[test]
fn set_overrides_keys_of_toml_files_as_python_does() {
    let d = tmpdir("set");
    let f = crash_file(&d);
    let f = f.to_str().unwrap();
    let lines = json_lines(&["--json", "--config", f]);
    assert_eq!((lines[0]["collision"].as_bool(), lines[0]["seed"].as_u64()), (Some(true), Some(1)));
    // The family key, a flat section name, a dotted key, `seed`, applied in order (the last wins).
    let lines = json_lines(&[
        "--json",
        "--config",
        f,
        "--set",
        "lead_decel=1",
        "--set",
        "follower_speed_controller_max_decel=6",
        "--set",
        "seed=7",
        "--set",
        "duration=20",
        "--set",
        "duration=12.5",
    ]);
    let r = &lines[0];
    assert_eq!(lines.len(), 1, "no summary line for files");
    assert_eq!((r["collision"].as_bool(), r["seed"].as_u64()), (Some(false), Some(7)), "{r}");
    assert!(r["duration"].as_f64().unwrap() <= 12.5 + 1e-9, "{r}");
    // A string value without quotes: the controller.
    let lines = json_lines(&["--json", "--config", f, "--set", "controller=pid", "--set", "v2v.enabled=true"]);
    assert_eq!(lines[0]["controller"], "pid");
}

#[test]
fn bad_set_input_exits_2_with_one_line_naming_flag_key_and_problem() {
    let d = tmpdir("badset");
    let f = crash_file(&d);
    let cases = [
        ("lidar.rat_hz=10", &["lidar.rat_hz", "unknown field", "rate_hz", "latency_frames"][..]),
        ("durtion=5", &["durtion", "duration", "lidar"][..]),
        ("lidar_rate_hz", &["KEY=VALUE", "lidar_rate_hz"][..]),
        ("lidar.rate_hz=fast", &["lidar.rate_hz", "fast"][..]),
        ("lidar.rate_hz=0", &["lidar.rate_hz", "[1, 100]"][..]),
        ("lead.phases[3].decel=2", &["lead.phases[3]", "no item 3"][..]),
    ];
    for (arg, words) in cases {
        let out_dir = d.join("out");
        let out = scenario().arg("--config").arg(&f).args(["--set", arg, "--out"]).arg(&out_dir).output().expect("run");
        assert_eq!(out.status.code(), Some(2), "{arg}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{arg}: {err}");
        assert!(err.contains("`--set`"), "{arg}: {err}");
        for w in words {
            assert!(err.contains(w), "{arg}: `{w}` missing in {err}");
        }
        assert!(out.stdout.is_empty() && !out_dir.exists(), "{arg}: output written");
    }
    // On the paper experiment too, before anything runs.
    let (stdout, err, code) = run(&["--speeds", "30", "--set", "lidar.rate_hz=0"]);
    assert_eq!((code, stdout.as_str(), err.trim().lines().count()), (Some(2), "", 1), "{err}");
    assert!(err.contains("`--set`") && err.contains("lidar.rate_hz"), "{err}");
}

#[test]
fn controllers_apply_to_toml_files() {
    let d = tmpdir("ctrl");
    let f = crash_file(&d);
    let (stdout, stderr, code) = run(&["--json", "--controllers", "flc,pid,idm", "--config", f.to_str().unwrap(), "--speeds", "30"]);
    assert_eq!(code, Some(0), "{stderr}");
    let names: Vec<String> =
        stdout.lines().map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["controller"].as_str().unwrap().to_string()).collect();
    assert_eq!(names, ["flc", "pid", "idm"]);
    // `--speeds` picks the paper experiment's runs: ignored with --config, and said so.
    assert!(stderr.contains("warning: `--speeds` is ignored with --config"), "{stderr}");
    let (_, err, code) = run(&["--controllers", "flc,warp", "--config", f.to_str().unwrap()]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--controllers") && err.contains("warp") && err.contains("pipeline"), "{err}");
}

/// `--quiet` silences the import warnings (the file's skipped elements) and nothing else of the
/// run; `--set` applies to an imported run as to a TOML file.
#[test]
fn quiet_suppresses_import_warnings() {
    let xosc = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/openscenario/target_brakes.xosc");
    let (loud_out, loud_err, code) = run(&["--json", "--config", xosc, "--set", "duration=3"]);
    assert_eq!(code, Some(0), "{loud_err}");
    assert!(loud_err.contains("warning: "), "the file has warnings: {loud_err}");
    let (quiet_out, quiet_err, code) = run(&["--json", "--quiet", "--config", xosc, "--set", "duration=3"]);
    assert_eq!(code, Some(0));
    assert_eq!(quiet_err, "");
    assert_eq!(quiet_out, loud_out, "--quiet changes no result");
    let r: serde_json::Value = serde_json::from_str(quiet_out.trim()).unwrap();
    assert!(r["duration"].as_f64().unwrap() <= 3.0 + 1e-9, "{r}");
    // convert too.
    let (_, err, code) = run(&["convert", "--quiet", xosc]);
    assert_eq!((code, err.as_str()), (Some(0), ""));
}

/// Each subcommand's help lists its own flags; run flags given before a subcommand are refused
/// by name (only `--threads` and `--quiet` apply everywhere).
#[test]
fn subcommands_list_only_their_own_flags() {
    let (help, _, code) = run(&["suite", "--help"]);
    assert_eq!(code, Some(0));
    for f in ["--controllers", "--out", "--threads", "--quiet"] {
        assert!(help.contains(f), "suite --help lacks {f}:\n{help}");
    }
    for f in
        ["--param", "--ego", "--road", "--traffic-dynamics", "--json", "--record", "--speeds", "--preset", "--config", "--set", "--seed"]
    {
        assert!(!help.contains(&format!("{f} ")), "suite --help lists {f}:\n{help}");
    }
    let (help, _, _) = run(&["convert", "--help"]);
    for f in ["--json", "--speeds", "--threads", "--record"] {
        assert!(!help.contains(&format!("{f} ")), "convert --help lists {f}:\n{help}");
    }
    assert!(help.contains("--param"), "{help}");
    let (_, err, code) = run(&["--json", "suite", "r157"]);
    assert_eq!(code, Some(2));
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("`--json`") && err.contains("suite"), "{err}");
    let (_, _, code) = run(&["suite", "r157", "--param", "X=1"]);
    assert_eq!(code, Some(2), "clap refuses a flag the subcommand does not have");
    // A TOML sweep file has no `.xosc` options.
    let d = tmpdir("sweepflags");
    let f = write(&d, "s.toml", "family = \"paper\"\n[[axes]]\nkey = \"speed_kmh\"\nvalues = [30.0]\n");
    let (_, err, code) = run(&["sweep", f.to_str().unwrap(), "--controllers", "pid"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("`--controllers`") && err.contains("controller` axis"), "{err}");
    assert!(!d.join("s.csv").exists());
}
