//! Golden outputs: the `scenario` binary's results compared byte for byte (floats are printed in
//! their shortest round-trip form, so equal text = equal bits) with the files in `tests/golden/`.
//!
//! The set: the paper experiment with all eight controllers and both presets (`--json`), the
//! platoon brake demo (`--json`), a 200-run sweep CSV (`sweeps/golden-200.toml`, rows sorted by
//! run id since they are written as runs finish), the per-step series of one run (`--out`), the
//! per-topic message counts and content hashes of one MCAP recording (`--record`), and scripted
//! traffic (`scenarios/traffic-10.toml`: `--json` and the recording's digest).
//!
//! The goldens change only when an issue changes behaviour on purpose; regenerate them with
//!
//! ```sh
//! FLC_BLESS=1 cargo test --release -p flc-sim --test golden
//! ```
//!
//! and say in the commit which results moved. `tests/run_all.sh` runs this test in release (a
//! debug build would take minutes); in a debug `cargo test` it is ignored.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;

mod common;
use common::repo;

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flc-golden-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("mkdir");
    d
}

fn scenario(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_scenario")).current_dir(repo()).args(args).output().expect("run scenario");
    assert!(out.status.success(), "scenario {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

/// Compares `actual` with the golden file `name` (or writes it with `FLC_BLESS=1`).
fn check(name: &str, actual: &str) {
    common::bless_or_compare(&format!("tests/golden/{name}"), actual, "FLC_BLESS=1 cargo test --release -p flc-sim --test golden");
}

const ALL_CONTROLLERS: &str = "flc,pid,pipeline,idm,acc,rss,carla-behavior,flc-robust";

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn paper_experiment_all_controllers_both_presets() {
    check("paper-all.jsonl", &scenario(&["--json", "--controllers", ALL_CONTROLLERS, "--preset", "both"]));
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn platoon_brake_demo() {
    check("brakedemo.jsonl", &scenario(&["--json", "--config", "scenarios/platoon-brakedemo.toml"]));
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn sweep_200_runs() {
    let d = tmpdir("sweep");
    let csv = d.join("sweep.csv");
    let csv_s = csv.to_str().expect("utf-8 path");
    scenario(&["sweep", "sweeps/golden-200.toml", "--out", csv_s]);
    let text = std::fs::read_to_string(&csv).expect("read sweep csv");
    let mut lines = text.lines();
    let header = lines.next().expect("header");
    let mut rows: Vec<&str> = lines.collect();
    rows.sort_by_key(|r| r.split(',').next().and_then(|id| id.parse::<usize>().ok()).unwrap_or(usize::MAX));
    assert_eq!(rows.len(), 200);
    let mut out = String::from(header);
    out.push('\n');
    for r in rows {
        out.push_str(r);
        out.push('\n');
    }
    check("sweep-200.csv", &out);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn series_of_one_run() {
    let d = tmpdir("series");
    scenario(&["--config", "scenarios/curvy-follow.toml", "--out", d.to_str().expect("utf-8 path")]);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&d).expect("read dir").map(|e| e.expect("entry").path()).collect();
    files.sort();
    assert_eq!(files.len(), 1, "{files:?}");
    check("series-curvy-follow.csv", &std::fs::read_to_string(&files[0]).expect("read series"));
}

/// FNV-1a, 64 bit: a content hash that needs no dependency.
fn fnv(h: &mut u64, bytes: &[u8]) {
    for b in bytes {
        *h ^= u64::from(*b);
        *h = h.wrapping_mul(0x100_0000_01b3);
    }
}

/// Per topic of the recording `scenario --config CONFIG --record DIR` writes: the message count
/// and an FNV-1a hash of every message's log time and data, in file order.
fn mcap_digest(tag: &str, config: &str) -> String {
    let d = tmpdir(tag);
    scenario(&["--config", config, "--record", d.to_str().expect("utf-8 path")]);
    let file =
        std::fs::read_dir(&d).expect("read dir").map(|e| e.expect("entry").path()).find(|p| p.extension().is_some_and(|e| e == "mcap"));
    let bytes = std::fs::read(file.expect("an mcap file")).expect("read mcap");
    // topic -> (count, hash of every message's log time and data, in file order)
    let mut per_topic: BTreeMap<String, (u64, u64)> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("mcap") {
        let m = m.expect("message");
        let e = per_topic.entry(m.channel.topic.clone()).or_insert((0, 0xcbf2_9ce4_8422_2325));
        e.0 += 1;
        fnv(&mut e.1, &m.log_time.to_le_bytes());
        fnv(&mut e.1, &m.data);
    }
    let _ = std::fs::remove_dir_all(&d);
    let mut out = String::from("topic,messages,fnv1a64\n");
    for (topic, (n, h)) in per_topic {
        out.push_str(&format!("{topic},{n},{h:016x}\n"));
    }
    out
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn mcap_message_counts_and_contents() {
    check("mcap-paper-70-pipeline.csv", &mcap_digest("mcap", "scenarios/paper-70-pipeline.toml"));
}

/// Scripted traffic (`[[vehicles]]`: eight cars on three lanes, lane changes, a braking car):
/// the run's record (`--json`) and the recording's per-topic digest (`/vehicles`: every car's
/// body, `/tf`: every car's pose at every step).
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn scripted_traffic() {
    check("traffic-10.jsonl", &scenario(&["--json", "--config", "scenarios/traffic-10.toml"]));
    check("mcap-traffic-10.csv", &mcap_digest("mcap-traffic", "scenarios/traffic-10.toml"));
}

/// `scenario suite all`: the same files on 1 and 2 threads, equal to the committed report in
/// `docs/standard-suites/` (made by `scenario suite all --out docs/standard-suites`), including
/// `summary.md` and `summary-line.md`, which `docs/standard-suites.md` and the README include as
/// generated blocks (`python -m flc docs --check` compares them).
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn standard_suites_report() {
    let (one, two) = (tmpdir("suites-1"), tmpdir("suites-2"));
    let summary = scenario(&["suite", "all", "--threads", "1", "--out", one.to_str().expect("utf-8")]);
    assert_eq!(summary, scenario(&["suite", "all", "--threads", "2", "--out", two.to_str().expect("utf-8")]), "summary depends on threads");
    let mut reports = Vec::new();
    let mut files: Vec<String> =
        ["ncap-ccr", "ncap-ccr-2026", "r157"].iter().flat_map(|n| ["md", "json", "svg"].map(|e| format!("{n}.{e}"))).collect();
    files.extend(["summary.md".to_string(), "summary-line.md".to_string()]);
    for file in &files {
        let a = std::fs::read_to_string(one.join(file)).expect("report");
        assert_eq!(a, std::fs::read_to_string(two.join(file)).expect("report"), "{file} depends on the thread count");
        common::bless_or_compare(&format!("docs/standard-suites/{file}"), &a, "FLC_BLESS=1 cargo test --release -p flc-sim --test golden");
        if file.ends_with(".json") {
            reports.push(serde_json::from_str::<flc_sim::suite::SuiteReport>(&a).expect("report json"));
        }
    }
    assert_eq!(summary, flc_sim::suite::summary_table(&reports), "the printed summary is the table of the reports");
    let line = std::fs::read_to_string(one.join("summary-line.md")).expect("summary line");
    assert_eq!(line, format!("Standard suites, runs passed: {}\n", flc_sim::suite::summary_line(&reports)));
    let _ = (std::fs::remove_dir_all(&one), std::fs::remove_dir_all(&two));
}
