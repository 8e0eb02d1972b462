//! `scenario --config FILE.xosc --out DIR` writes each run's per-entity trajectory
//! (`<run>-trajectory.csv`: `t,entity,x,y,heading,speed`, the file's entity names, reference
//! points): compared with esmini 3.6.0's committed reference (`tests/data/esmini/`), every row
//! within 0.05 m and 0.05 m/s, the headings within 0.01 rad, and the same rows; plus the
//! `--permutation`, `--permutations` and `--max-duration` interface.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::repo;

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flc-traj-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("mkdir");
    d
}

fn scenario(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_scenario")).current_dir(repo()).args(args).output().expect("run scenario")
}

/// `(step, entity) -> (x, y, heading, speed)` of a `t,entity,x,y,heading,speed...` CSV.
fn rows(path: &Path) -> BTreeMap<(usize, String), [f64; 4]> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = BTreeMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#') && !l.starts_with("t")) {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f.get(i).and_then(|v| v.trim().parse::<f64>().ok()).unwrap_or(f64::NAN);
        out.insert(((num(0) / 0.01).round() as usize, f[1].to_string()), [num(2), num(3), num(4), num(5)]);
    }
    out
}

#[test]
fn trajectory_csv_matches_esmini() {
    let dir = tmpdir("esmini");
    let d = dir.to_str().expect("utf-8");
    let out = scenario(&["--config", "tests/data/openscenario/target_brakes.xosc", "--ego-mode", "scripted", "--out", d, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let file = std::fs::read_dir(&dir)
        .expect("dir")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.to_string_lossy().ends_with("-trajectory.csv"))
        .expect("a trajectory file");
    let text = std::fs::read_to_string(&file).expect("read");
    assert_eq!(text.lines().next(), Some("t,entity,x,y,heading,speed"));
    let mine = rows(&file);
    let theirs = rows(&repo().join("tests/data/esmini/target_brakes.csv"));
    assert!(theirs.len() > 100);
    // The same entities at the same steps, every step esmini wrote.
    assert_eq!(mine.keys().collect::<Vec<_>>(), theirs.keys().collect::<Vec<_>>(), "rows differ");
    for (k, a) in &mine {
        let b = &theirs[k];
        let d = (a[0] - b[0]).hypot(a[1] - b[1]);
        assert!(d <= 0.05, "{k:?}: position {d} m off ({a:?} vs {b:?})");
        assert!((a[3] - b[3]).abs() <= 0.05, "{k:?}: speed {} vs {}", a[3], b[3]);
        let dh = (a[2] - b[2]).abs();
        assert!(dh.min(std::f64::consts::TAU - dh) <= 0.01, "{k:?}: heading {} vs {}", a[2], b[2]);
        assert!(a[2] > -std::f64::consts::PI && a[2] <= std::f64::consts::PI);
    }
    // The JSON says how the run ended: the file's StopTrigger.
    let json = String::from_utf8(out.stdout).expect("utf-8");
    assert!(json.contains("\"end\":\"stop_trigger\""), "{json}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn permutations_and_one_permutation() {
    let f = "tests/data/openscenario/distribution_2x2.xosc";
    let out = scenario(&["--config", f, "--permutations"]);
    assert!(out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "4");
    let all = scenario(&["--config", f, "--json"]);
    let one = scenario(&["--config", f, "--json", "--permutation", "2"]);
    assert!(all.status.success() && one.status.success());
    let all = String::from_utf8(all.stdout).expect("utf-8");
    let one = String::from_utf8(one.stdout).expect("utf-8");
    // Run 2 alone is the third line of the whole distribution, bit for bit.
    assert_eq!(all.lines().count(), 4);
    assert_eq!(one.trim(), all.lines().nth(2).expect("line 2"));
    assert!(one.contains("\"variant\":\"p2 "), "{one}");
    let bad = scenario(&["--config", f, "--permutation", "4"]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("`--permutation`") && err.contains("4 run(s)"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

/// `scenario convert --permutation I` writes the twin of run I alone, the same text as the
/// whole distribution's conversion gives for it; out of range: exit 2 with one line.
#[test]
fn convert_one_permutation() {
    let f = "tests/data/openscenario/distribution_2x2.xosc";
    let dir = std::env::temp_dir().join(format!("flc-convert-perm-{}", std::process::id()));
    let (all, one) = (dir.join("all"), dir.join("one"));
    let a = scenario(&["convert", f, "--out", all.to_str().expect("path"), "-q"]);
    let o = scenario(&["convert", f, "--permutation", "2", "--out", one.to_str().expect("path"), "-q"]);
    assert!(a.status.success() && o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let list = |d: &std::path::Path| {
        let mut v: Vec<_> = std::fs::read_dir(d).expect("dir").map(|e| e.expect("entry").path()).collect();
        v.sort();
        v
    };
    let (every, single) = (list(&all), list(&one));
    assert_eq!((every.len(), single.len()), (4, 1));
    let name = single[0].file_name().expect("name").to_owned();
    let twin = all.join(&name);
    assert!(twin.exists(), "{name:?} is not among the whole conversion's files {every:?}");
    assert_eq!(std::fs::read(&single[0]).expect("read"), std::fs::read(&twin).expect("read"));
    assert!(std::fs::read_to_string(&single[0]).expect("read").contains("p2 "), "not run 2");
    let bad = scenario(&["convert", f, "--permutation", "4"]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("permutation") && err.contains('4'), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn max_duration_cuts_with_a_line_and_a_field() {
    let f = "tests/data/openscenario/target_brakes.xosc";
    let out = scenario(&["--config", f, "--json", "--ego-mode", "scripted", "--max-duration", "1.5"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json = String::from_utf8(out.stdout).expect("utf-8");
    assert!(json.contains("\"end\":\"duration\""), "{json}");
    assert!(json.contains("\"duration\":1.5"), "{json}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cut at --max-duration 1.5 s"), "{err}");
    let bad = scenario(&["--config", f, "--max-duration", "0"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("`--max-duration`"));
}

/// `--ego-mode scripted` runs on after a contact to the StopTrigger and lists every contact
/// (`target_brakes.xosc`: the ego drives into the braking lead at 4.01 s, as in esmini; its
/// StopTrigger moved to 8 s); controller mode keeps ending at the ego's first contact
/// (`stop.on_collision`, tested in `tests/collisions.rs`).
#[test]
fn scripted_runs_on_after_contacts_to_the_stop_trigger() {
    use flc_sim::openscenario::{self, ImportOptions};
    use flc_sim::{Patch, RunEnd, run};
    let path = repo().join("tests/data/openscenario/target_brakes.xosc");
    let mut p = Patch::new();
    p.set_json("stop.trigger", &serde_json::json!({"kind": "simulation_time", "rule": "greater_than", "value": 8.0})).expect("patch");
    let controller = ImportOptions::from_words(Vec::new(), None, "controller", "file", "kinematic", None).expect("opts");
    let s = openscenario::import(&path, &controller).expect("import").runs.remove(0).scenario;
    assert!(s.stop.on_collision && s.stop.on_standstill);
    {
        let (mode, want_end) = ("scripted", RunEnd::StopTrigger);
        let opts = ImportOptions::from_words(Vec::new(), None, mode, "file", "kinematic", Some("flc")).expect("opts");
        let imp = openscenario::import(&path, &opts).expect("import").runs.remove(0);
        assert!(!imp.scenario.stop.on_collision && !imp.scenario.stop.on_standstill);
        let s = imp.scenario.patched(&p).expect("patched");
        let r = run(&s).expect("run");
        assert_eq!(r.end, want_end, "{mode}");
        let first = r.contacts.first().unwrap_or_else(|| panic!("{mode}: no contact"));
        assert!(r.metrics.collision, "{mode}");
        let names = [first.a.label(), first.b.label()];
        assert!(names.contains(&"follower 1".to_string()) && names.contains(&"lead".to_string()), "{mode}: {names:?}");
        assert!(first.relative_speed > 1.0, "{mode}: {first:?}");
        let end = r.series.t.last().copied().unwrap_or_default();
        // On to the StopTrigger (true at the first step after 8 s), well past the contact.
        assert!((end - 8.01).abs() < 1e-6, "{mode}: ended at {end}");
        assert!((first.time - 4.01).abs() < 1e-6, "{first:?}");
    }
}
