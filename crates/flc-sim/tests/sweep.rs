//! The sweep engine: rows equal individual runs; re-running a finished sweep does no work.

use flc_sim::sweep::{SweepSpec, run_sweep};

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
    assert_eq!(run_sweep(&s, &points, &out, false).expect("sweep"), 8);
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
    assert_eq!(run_sweep(&s, &points, &out, false).expect("sweep"), 0);
    assert_eq!(std::fs::read_to_string(&out).expect("csv"), text);
    // An interrupted sweep (last row cut) resumes only what is missing.
    let cut: String = text.lines().take(5).map(|l| format!("{l}\n")).collect::<String>() + "7,flc";
    std::fs::write(&out, cut).expect("write");
    assert_eq!(run_sweep(&s, &points, &out, false).expect("sweep"), 4);
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
    assert_eq!(run_sweep(&s, &points, &out, false).expect("sweep"), 8);
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
    assert_eq!(run_sweep(&s, &points, &out, false).expect("sweep"), 0);
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
