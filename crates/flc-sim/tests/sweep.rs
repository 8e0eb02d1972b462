//! The sweep engine: rows equal individual runs; re-running a finished sweep does no work;
//! resuming never serves rows of other inputs.

use flc_sim::SimError;
use flc_sim::sweep::{SweepSpec, digest_path, inputs_digest, run_sweep};

fn spec(text: &str) -> SweepSpec {
    let de = toml::Deserializer::parse(text).expect("toml");
    serde::Deserialize::deserialize(de).expect("spec")
}

const GRID: &str = r#"
family = "paper"
mode = "grid"
seed = 3
[[axes]]
key = "controller"
values = ["flc", "pid"]
[[axes]]
key = "speed_kmh"
values = [30.0, 90.0]
[[axes]]
key = "lidar.rate_hz"
values = [10.0, 20.0]
"#;

#[test]
fn rows_equal_individual_runs_and_rerun_does_no_work() {
    let s = spec(GRID);
    let points = s.points(None).expect("points");
    assert_eq!(points.len(), 8);
    let out = std::env::temp_dir().join(format!("flc-sweep-{}.csv", std::process::id()));
    let _ = std::fs::remove_file(&out);
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("sweep"), 8);
    let text = std::fs::read_to_string(&out).expect("csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
    assert_eq!(rows.len(), 8);
    for p in &points {
        let row = rows.iter().find(|r| r[0] == p.id.to_string()).expect("row for every point");
        // The scenario the sweep built has the axis values...
        assert_eq!(p.scenario.lidar.rate_hz, row[col("lidar.rate_hz")].parse::<f64>().expect("number"));
        // ...and the row holds exactly what an individual run of it gives.
        let m = flc_sim::run(&p.scenario).expect("run").metrics;
        assert_eq!(row[col("collision")], m.collision.to_string());
        assert_eq!(row[col("min_gap")], serde_json::to_value(m.min_gap).expect("json").to_string());
        assert_eq!(row[col("max_decel")], serde_json::to_value(m.max_decel).expect("json").to_string());
    }
    // Re-running the finished sweep does nothing and leaves the file unchanged.
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("sweep"), 0);
    assert_eq!(std::fs::read_to_string(&out).expect("csv"), text);
    // An interrupted sweep (last row cut) resumes only what is missing.
    let cut: String = text.lines().take(5).map(|l| format!("{l}\n")).collect::<String>() + "7,flc";
    std::fs::write(&out, cut).expect("write");
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("sweep"), 4);
    // The cut line is gone, not glued to the next row: the same rows as the first pass.
    let sorted = |t: &str| {
        let mut rows: Vec<String> = t.lines().skip(1).map(str::to_string).collect();
        rows.sort();
        rows
    };
    assert_eq!(sorted(&std::fs::read_to_string(&out).expect("csv")), sorted(&text));
    let _ = std::fs::remove_file(&out);
}

#[test]
fn a_failing_run_is_a_row_with_its_error_and_the_others_finish() {
    let s = spec(GRID);
    let mut points = s.points(None).expect("points");
    // Made invalid after expansion (the runner validates again): this run fails.
    points[3].scenario.lidar.rate_hz = 0.0;
    let out = std::env::temp_dir().join(format!("flc-sweep-err-{}.csv", std::process::id()));
    let _ = std::fs::remove_file(&out);
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("sweep"), 8);
    let text = std::fs::read_to_string(&out).expect("csv");
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    assert_eq!(header.last(), Some(&"error"));
    let rows: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8);
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    for r in &rows {
        if r[0] == "3" {
            assert_eq!(r[col("min_gap")], "");
            assert_eq!(r[col("collision")], "");
            let error = r[col("error")..].join(",");
            assert!(error.contains("lidar.rate_hz"), "{error}");
        } else {
            assert_eq!(r[col("error")], "", "{r:?}");
            assert!(r[col("min_gap")].parse::<f64>().is_ok(), "{r:?}");
        }
    }
    // The failed run counts as finished: re-running does nothing.
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("sweep"), 0);
    let _ = std::fs::remove_file(&out);
}

#[test]
fn points_cross_as_json_unchanged() {
    let points = spec(GRID).points(None).expect("points");
    for p in &points {
        let back: flc_sim::sweep::SweepPoint = serde_json::from_str(&serde_json::to_string(p).expect("json")).expect("parse");
        assert_eq!(&back, p);
        assert_eq!(flc_sim::sweep::run_point(&back).0, flc_sim::sweep::run_point(p).0);
    }
}

#[test]
fn random_mode_is_deterministic_and_bad_keys_are_named() {
    let text = "family = \"paper\"\nmode = \"random\"\nsamples = 5\nseed = 9\n[[axes]]\nkey = \"lead_decel\"\nfrom = 2.0\nto = 9.0\n";
    let a = spec(text).points(None).expect("points");
    let b = spec(text).points(None).expect("points");
    assert_eq!(a.len(), 5);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.values, y.values);
        assert_eq!(x.scenario, y.scenario);
    }
    let bad = "family = \"paper\"\n[[axes]]\nkey = \"lidar.rate_hzz\"\nvalues = [10.0]\n";
    let e = spec(bad).points(None).expect_err("unknown key");
    assert!(e.to_string().contains("lidar.rate_hzz"), "{e}");
}

const DECEL: &str = r#"
family = "paper"
seed = 5
[[axes]]
key = "speed_kmh"
values = [30.0, 50.0]
[[axes]]
key = "lead_decel"
values = [4.0, 8.0]
"#;

fn tmp_csv(tag: &str) -> std::path::PathBuf {
    let out = std::env::temp_dir().join(format!("flc-sweep-{tag}-{}.csv", std::process::id()));
    let _ = std::fs::remove_file(&out);
    let _ = std::fs::remove_file(digest_path(&out));
    out
}

/// The `lead_decel` column of a sweep CSV, sorted.
fn decels(out: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(out).expect("csv");
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    let col = header.iter().position(|h| *h == "lead_decel").expect("lead_decel column");
    let mut v: Vec<String> = text.lines().skip(1).map(|l| l.split(',').nth(col).expect("field").to_string()).collect();
    v.sort();
    v
}

#[test]
fn a_changed_sweep_is_refused_never_served_and_restart_starts_over() {
    let out = tmp_csv("changed");
    let old = spec(DECEL);
    let points = old.points(None).expect("points");
    assert_eq!(run_sweep(&old, &points, &out, false, false).expect("sweep"), 4);
    let text = std::fs::read_to_string(&out).expect("csv");
    // The same sweep again: resumed, nothing to do, nothing rewritten.
    assert_eq!(run_sweep(&old, &points, &out, false, false).expect("resume"), 0);
    assert_eq!(std::fs::read_to_string(&out).expect("csv"), text);
    // The issue's case: `lead_decel` [4, 8] -> [2, 9], the same ids. Refused, the file untouched.
    let new = spec(&DECEL.replace("[4.0, 8.0]", "[2.0, 9.0]"));
    let new_points = new.points(None).expect("points");
    let e = run_sweep(&new, &new_points, &out, false, false).expect_err("a changed sweep must not resume");
    assert!(matches!(e, SimError::StaleOutput { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains(&out.display().to_string()) && msg.contains("other inputs") && !msg.contains('\n'), "{msg}");
    assert_eq!(std::fs::read_to_string(&out).expect("csv"), text);
    // Restart: every run of the new sweep, none of the old rows.
    assert_eq!(run_sweep(&new, &new_points, &out, false, true).expect("restart"), 4);
    assert_eq!(decels(&out), ["2.0", "2.0", "9.0", "9.0"]);
    // ...and from then on the new sweep resumes, the old one is refused.
    assert_eq!(run_sweep(&new, &new_points, &out, false, false).expect("resume"), 0);
    assert!(run_sweep(&old, &points, &out, false, false).is_err());
    let _ = std::fs::remove_file(digest_path(&out));
    let _ = std::fs::remove_file(&out);
}

#[test]
fn any_input_of_a_row_changes_the_digest() {
    let base = spec(DECEL);
    let keys: Vec<String> = base.axes.iter().map(|a| a.key.clone()).collect();
    let points = base.points(None).expect("points");
    let d = inputs_digest(&keys, &points);
    // Deterministic: the same sweep expanded again has the same digest.
    assert_eq!(inputs_digest(&keys, &spec(DECEL).points(None).expect("points")), d);
    assert!(d.starts_with("fnv1a128:") && d.len() == "fnv1a128:".len() + 32, "{d}");
    // The seed, the calibration, a value, a field of one scenario the axes do not name.
    for changed in [DECEL.replace("seed = 5", "seed = 6"), format!("calibration = \"paper\"\n{DECEL}"), DECEL.replace("50.0", "50.5")] {
        let s = spec(&changed);
        assert_ne!(inputs_digest(&keys, &s.points(None).expect("points")), d, "{changed}");
    }
    let mut edited = points.clone();
    edited[2].scenario.lidar.rate_hz += 1.0;
    assert_ne!(inputs_digest(&keys, &edited), d);
}

#[test]
fn a_changed_base_scenario_file_is_refused() {
    let dir = std::env::temp_dir().join(format!("flc-sweep-base-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("mkdir");
    let base = dir.join("base.toml");
    std::fs::write(&base, "duration = 20.0\n[lead]\ninitial_speed = 15.0\n").expect("write");
    let sweep = dir.join("s.toml");
    std::fs::write(&sweep, "base = \"base.toml\"\n[[axes]]\nkey = \"lidar.rate_hz\"\nvalues = [10.0, 20.0]\n").expect("write");
    let out = dir.join("s.csv");
    let run = |restart: bool| {
        let (s, d) = SweepSpec::from_file(&sweep).expect("spec");
        let p = s.points(d.as_deref()).expect("points");
        run_sweep(&s, &p, &out, false, restart)
    };
    assert_eq!(run(false).expect("sweep"), 2);
    assert_eq!(run(false).expect("resume"), 0);
    // The sweep file is the same; the scenario it reads is not.
    std::fs::write(&base, "duration = 20.0\n[lead]\ninitial_speed = 16.0\n").expect("write");
    assert!(matches!(run(false), Err(SimError::StaleOutput { .. })));
    assert_eq!(run(true).expect("restart"), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_output_without_a_digest_is_refused_unless_restarted() {
    let out = tmp_csv("nodigest");
    let s = spec(DECEL);
    let points = s.points(None).expect("points");
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("sweep"), 4);
    // As an flc from before the digests left it: rows, no `<out>.digest`.
    std::fs::remove_file(digest_path(&out)).expect("digest written");
    let text = std::fs::read_to_string(&out).expect("csv");
    let e = run_sweep(&s, &points, &out, false, false).expect_err("no digest: cannot tell");
    assert!(e.to_string().contains("no digest"), "{e}");
    assert_eq!(std::fs::read_to_string(&out).expect("csv"), text);
    // A file with a header but no finished row holds nothing to serve: written anew.
    let header = text.lines().next().expect("header").to_string() + "\n";
    std::fs::write(&out, &header).expect("write");
    assert_eq!(run_sweep(&s, &points, &out, false, false).expect("fresh"), 4);
    assert!(digest_path(&out).exists());
    let _ = std::fs::remove_file(digest_path(&out));
    let _ = std::fs::remove_file(&out);
}
