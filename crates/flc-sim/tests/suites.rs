//! The standard suites (`scenario suite`): each case's geometry and timing against its protocol,
//! the suite files against their TOML twins (bit for bit), and the CLI's errors.
//! (Thread-count independence and the committed report: `tests/golden.rs`, in release.)

use std::path::Path;

use flc_sim::suite::{Suite, default_root};
use flc_sim::{ControllerKind, RunResult, Scenario, run};

fn suite(name: &str) -> Suite {
    Suite::find(&default_root().expect("suites folder"), name).expect("suite").remove(0)
}

/// The run of `case` whose label contains `label`, driven by `kind`.
fn case_run(s: &Suite, case: &str, label: &str, kind: ControllerKind) -> Scenario {
    let ci = s.spec.cases.iter().position(|c| c.id == case).expect("case");
    s.runs(&[kind]).expect("runs").into_iter().find(|r| r.case == ci && r.run.contains(label)).map(|r| r.scenario).expect("run")
}

fn first_time(r: &RunResult, f: impl Fn(usize) -> bool) -> Option<f64> {
    (0..r.series.len()).find(|&i| f(i)).map(|i| r.series.t[i])
}

#[test]
fn ccrs_target_stands_and_the_test_starts_at_ttc_4s() {
    let s = suite("ncap-ccr");
    for (label, v_kmh) in [("TestSpeed_kmh=10", 10.0), ("TestSpeed_kmh=45", 45.0), ("TestSpeed_kmh=80", 80.0)] {
        let sc = case_run(&s, "CCRs", label, ControllerKind::Idm);
        let v = v_kmh / 3.6;
        assert!((sc.follower.initial_speed - v).abs() < 1e-12, "{label}: test speed");
        let r = run(&sc).expect("run");
        // TTC at T0 = gap / closing speed = 4 s (the first sample is one physics step later).
        let ttc0 = (r.series.gap[0] + v * sc.physics_dt) / v;
        assert!((ttc0 - 4.0).abs() < 0.002, "{label}: TTC at the start {ttc0}");
        assert!(r.series.lead_speed.iter().all(|&x| x == 0.0), "{label}: the CCRs target stands");
        assert!(r.series.lead_x.iter().all(|&x| x == r.series.lead_x[0]), "{label}: and does not move");
    }
}

#[test]
fn ccrm_target_drives_20_kmh_from_ttc_4s() {
    let s = suite("ncap-ccr");
    let r = run(&case_run(&s, "CCRm", "TestSpeed_kmh=60", ControllerKind::Idm)).expect("run");
    let closing = (60.0 - 20.0) / 3.6;
    assert!(((r.series.gap[0] + closing * 0.01) / closing - 4.0).abs() < 0.002);
    assert!(r.series.lead_speed.iter().all(|&x| (x - 20.0 / 3.6).abs() < 1e-9), "the target holds 20 km/h");
}

#[test]
fn ccrb_12_6_target_ramps_to_minus_6_within_1s_and_the_vut_holds_until_the_brake() {
    let s = suite("ncap-ccr");
    let r = run(&case_run(&s, "CCRb", "Headway=12 Decel=6", ControllerKind::Idm)).expect("run");
    let v0 = 50.0 / 3.6;
    assert!((r.series.gap[0] - 12.0).abs() < 1e-6, "headway 12 m: {}", r.series.gap[0]);
    // Before the brake at 2 s: both at the test speed (the VUT held by the story).
    for i in 0..r.series.len() {
        if r.series.t[i] < 2.0 {
            assert!((r.series.lead_speed[i] - v0).abs() < 1e-9 && (r.series.follower_speed[i] - v0).abs() < 1e-9, "t = {}", r.series.t[i]);
        }
    }
    // The ramp: the first deceleration right after 2 s is 1/20 of the level, the full 6 m/s² is
    // reached 1 s later, and the speed lost over the ramp is that of a linear ramp, 6 * 1 / 2 = 3 m/s.
    let start = first_time(&r, |i| r.series.lead_accel[i] < -1e-9).expect("brakes");
    assert!((2.0..2.03).contains(&start), "brake onset {start}");
    let full = first_time(&r, |i| r.series.lead_accel[i] <= -6.0 + 1e-9).expect("reaches -6");
    assert!((3.0..3.03).contains(&full), "-6 m/s² at {full}");
    let min_accel = r.series.lead_accel.iter().copied().fold(f64::INFINITY, f64::min);
    assert!((min_accel + 6.0).abs() < 1e-9, "never beyond -6: {min_accel}");
    let i = (0..r.series.len()).find(|&i| r.series.t[i] >= full).expect("sample");
    let lost = v0 - r.series.lead_speed[i];
    assert!((lost - 3.0).abs() < 0.07, "speed lost over the ramp {lost}");
}

/// The 2026 grid: every speed at the seven impact locations; the target's lateral offset is
/// (impact location - 50 %) of the VUT's width (+ left), and the record says so.
#[test]
fn ncap_2026_grid_offsets_and_records() {
    let s = suite("ncap-ccr-2026");
    let runs = s.runs(&[ControllerKind::Idm]).expect("runs");
    assert_eq!(runs.len(), 8 * 7 + 11 * 7 + 11 * 7, "the calculator's grid");
    for (label, il, offset, overlap, side) in [
        ("TestSpeed_kmh=30 ImpactLocation=125", 125.0, 1.35, 25.0, "left"),
        ("TestSpeed_kmh=30 ImpactLocation=75", 75.0, 0.45, 75.0, "left"),
        ("TestSpeed_kmh=30 ImpactLocation=50", 50.0, 0.0, 100.0, "centre"),
        ("TestSpeed_kmh=30 ImpactLocation=0", 0.0, -0.9, 50.0, "right"),
        ("TestSpeed_kmh=30 ImpactLocation=-25", -25.0, -1.35, 25.0, "right"),
    ] {
        let sc = case_run(&s, "CCRs", label, ControllerKind::Idm);
        assert!((sc.lead.offset - sc.follower.start_offset - offset).abs() < 1e-9, "{label}: offset {}", sc.lead.offset);
        let r = run(&sc).expect("run");
        let rec = flc_sim::suite::NcapRun::of(&sc, &r.metrics, true);
        assert!((rec.impact_location - il).abs() < 1e-6 && (rec.overlap - overlap).abs() < 1e-6 && rec.side == side, "{label}: {rec:?}");
        assert_eq!(rec.vut_speed_kmh, 30.0);
        assert_eq!(rec.target_speed_kmh, 0.0);
        assert_eq!(rec.band, Some(flc_sim::suite::band(30.0, rec.impact_speed_kmh)));
    }
    // CCRm 130/70 from TTC 4 s; CCRb 120 km/h: 12 m headway, the target brakes at 4 m/s² from 2 s.
    let r = run(&case_run(&s, "CCRm", "TestSpeed_kmh=130 TargetSpeed_kmh=70 ImpactLocation=50", ControllerKind::Idm)).expect("run");
    let closing = (130.0 - 70.0) / 3.6;
    assert!(((r.series.gap[0] + closing * 0.01) / closing - 4.0).abs() < 0.002);
    assert!(r.series.lead_speed.iter().all(|&x| (x - 70.0 / 3.6).abs() < 1e-9));
    let r = run(&case_run(&s, "CCRb", "TestSpeed_kmh=120 ImpactLocation=100", ControllerKind::Idm)).expect("run");
    assert!((r.series.gap[0] - 12.0).abs() < 1e-6, "headway {}", r.series.gap[0]);
    let min_accel = r.series.lead_accel.iter().copied().fold(f64::INFINITY, f64::min);
    assert!((min_accel + 4.0).abs() < 1e-9, "decel {min_accel}");
}

/// The 2026 suite's 210 runs against their twins: the same scenario, field for field, for two
/// controllers (the runs are then the same bit for bit, as the 2023 suites' runs show).
#[test]
fn ncap_2026_files_equal_their_twins() {
    let s = suite("ncap-ccr-2026");
    let twins_dir = s.dir.join("twins");
    let kinds = [ControllerKind::FlcRobust, ControllerKind::Idm];
    let runs = s.runs(&kinds).expect("runs");
    for r in &runs {
        let stem = Scenario { controller: ControllerKind::Flc, ..r.scenario.clone() }.run_file_stem();
        let twin = Scenario::from_file(&twins_dir.join(format!("{stem}.toml"))).expect("twin");
        let twin = s.twin_scenario(&twin, r.scenario.controller).expect("twin scenario");
        assert!(twin == r.scenario, "{}: the twin differs", r.run);
    }
    assert_eq!(std::fs::read_dir(&twins_dir).expect("twins").count() * kinds.len(), runs.len(), "one twin per run");
}

#[test]
fn cut_in_finishes_its_lateral_move_in_the_lane_change_time() {
    let s = suite("r157");
    for (label, t_lc) in [("IntruderSpeed_kmh=40 LaneChangeTime=3", 3.0), ("IntruderSpeed_kmh=30 LaneChangeTime=4", 4.0)] {
        let r = run(&case_run(&s, "4.4_1", label, ControllerKind::Flc)).expect("run");
        // The intruder starts on the centre of the lane to the left (y = -1.75) and ends on the
        // ego's (y = -5.25).
        let y0 = r.series.lead_y[0];
        assert!((y0 + 1.75).abs() < 1e-9, "{label}: starts in the left lane, y = {y0}");
        let start = first_time(&r, |i| (r.series.lead_y[i] - y0).abs() > 1e-9).expect("moves");
        let end = first_time(&r, |i| (r.series.lead_y[i] + 5.25).abs() < 1e-6).expect("arrives");
        assert!(((end - start) - t_lc).abs() <= 0.011, "{label}: lateral move {start} .. {end}");
        // Paragraph 5.2.5.2: had both kept their speeds, the time to collision at the lane
        // intrusion would be v_rel/12 + 0.35 s plus the case's 0.5 s margin. The intrusion: the
        // intruder's reference point has moved 0.85 m (its side on the marking), a fraction
        // acos(1 - 2 * 0.85 / 3.5) / pi of the sinusoidal lane change. The ego is held at its
        // speed until the lane change starts, so the gap then fixes the TTC (the intruder is the
        // scenario's lead: `lead_gap`, its gap while it is still in the next lane, where `gap`,
        // against the vehicle in path, is NaN).
        let v_rel = r.series.follower_speed[0] - r.series.lead_speed[0];
        let intrusion = start + t_lc * (1.0 - 2.0 * 0.85 / 3.5_f64).acos() / std::f64::consts::PI;
        let i = (0..r.series.len()).find(|&i| r.series.t[i] >= start).expect("sample");
        let ttc = (r.series.lead_gap[i] - v_rel * (intrusion - start)) / v_rel;
        let want = v_rel / 12.0 + 0.35 + 0.5;
        // Tolerance: two physics steps (the trigger fires on the step after the gap crosses,
        // the lateral motion shows one step later).
        assert!((ttc - want).abs() < 0.025, "{label}: TTC at intrusion {ttc}, want {want}");
        // 5.2.5.2 (b): the lateral movement was visible for at least 0.72 s before the intrusion.
        assert!(intrusion - start >= 0.72, "{label}: visible for {} s", intrusion - start);
    }
}

#[test]
fn r157_cases_start_at_the_minimum_following_distance() {
    let s = suite("r157");
    for (case, label, v_kmh, gap) in
        [("4.3_2", "EgoSpeed_kmh=60", 60.0, 1.6), ("4.3_2", "EgoSpeed_kmh=30", 30.0, 1.3), ("4.5_1", "EgoSpeed_kmh=40", 40.0, 1.4)]
    {
        let r = run(&case_run(&s, case, label, ControllerKind::Flc)).expect("run");
        let want = gap * v_kmh / 3.6;
        assert!((r.series.gap[0] - want).abs() < 1e-6, "{case} {label}: gap {} want {want}", r.series.gap[0]);
    }
    // 4.3_2: the lead brakes at 6 m/s² from 2 s; 4.5_1: the blocker, revealed, is what the ego meets.
    let r = run(&case_run(&s, "4.3_2", "EgoSpeed_kmh=60", ControllerKind::Flc)).expect("run");
    let onset = first_time(&r, |i| r.series.lead_accel[i] < -1e-9).expect("brakes");
    assert!((2.0..2.03).contains(&onset), "{onset}");
    assert!(r.series.lead_accel.iter().all(|&a| a >= -6.0 - 1e-9));
    let r = run(&case_run(&s, "4.5_1", "EgoSpeed_kmh=60 TimeGap=1.6 CutOutGap=50", ControllerKind::FlcRobust)).expect("run");
    assert!(r.series.lead_speed.iter().rev().take(10).all(|&v| v == 0.0), "at the end the vehicle in front is the stationary one");
}

/// The R157 careful driver perceives a cut-in once the intruder has moved more than the lateral
/// wandering zone (0.375 m) toward its lane, and a cut-out once the lead has moved more than that
/// out of it (then it sees the stationary car the lead revealed).
#[test]
fn careful_driver_perceives_cut_in_and_cut_out_after_the_wandering_zone() {
    let s = suite("r157");
    let careful = ControllerKind::parse("careful-driver").expect("registry");
    let r = run(&case_run(&s, "4.4_1", "IntruderSpeed_kmh=40 LaneChangeTime=3", careful)).expect("run");
    let y0 = r.series.lead_y[0];
    let seen = (0..r.series.len()).find(|&i| r.series.detected_distance[i].is_finite()).expect("perceived");
    let moved = (r.series.lead_y[seen] - y0).abs();
    // Perception runs at the LiDAR frame rate (20 Hz): at most one frame's lateral travel late.
    assert!((0.375..0.375 + 0.12).contains(&moved), "cut-in perceived after {moved} m of lateral movement");
    assert!(!r.metrics.collision);

    let r = run(&case_run(&s, "4.5_1", "EgoSpeed_kmh=60 TimeGap=1.6 CutOutGap=50", careful)).expect("run");
    let y0 = r.series.lead_y[0];
    // The distance the driver perceives jumps from the lead's to the stationary car's.
    let d = &r.series.detected_distance;
    let switch = (1..r.series.len()).find(|&i| d[i].is_finite() && d[i - 1].is_finite() && d[i] > d[i - 1] + 5.0).expect("revealed");
    let lead_moved = (r.series.lead_y[switch - 1] - y0).abs();
    assert!((0.375..0.375 + 0.12).contains(&lead_moved), "cut-out perceived after {lead_moved} m of the lead's lateral movement");
    assert!(!r.metrics.collision);
}

/// Every run of every case, imported and as its committed TOML twin, gives identical metrics and
/// series for a LiDAR law and a V2V one; one run for every controller.
#[test]
fn suite_files_and_their_toml_twins_are_bit_identical() {
    for name in ["ncap-ccr", "r157"] {
        let s = suite(name);
        let twins_dir = s.dir.join("twins");
        let kinds = [ControllerKind::FlcRobust, ControllerKind::Pipeline];
        let runs = s.runs(&kinds).expect("runs");
        let mut checked = 0;
        for (n, r) in runs.iter().enumerate() {
            let stem = Scenario { controller: ControllerKind::Flc, ..r.scenario.clone() }.run_file_stem();
            let twin = Scenario::from_file(&twins_dir.join(format!("{stem}.toml"))).expect("twin");
            let twin = s.twin_scenario(&twin, r.scenario.controller).expect("twin scenario");
            let all = n == 0;
            let kinds_here: Vec<ControllerKind> = if all { ControllerKind::ALL.to_vec() } else { vec![r.scenario.controller] };
            for k in kinds_here {
                let a = s.twin_scenario(&r.scenario, k).expect("a");
                let b = s.twin_scenario(&twin, k).expect("b");
                let (ra, rb) = (run(&a).expect("run a"), run(&b).expect("run b"));
                let ja = serde_json::to_string(&ra.metrics).expect("json");
                assert_eq!(ja, serde_json::to_string(&rb.metrics).expect("json"), "{name} {} {}", r.run, k.as_str());
                // Series as JSON text (shortest round-trip floats: equal text is equal bits; NaN
                // columns, no detection, are `null` on both sides).
                let (sa, sb) = (serde_json::to_string(&ra.series).expect("json"), serde_json::to_string(&rb.series).expect("json"));
                assert!(sa == sb, "{name} {} {}: series differ", r.run, k.as_str());
                checked += 1;
            }
        }
        let files = std::fs::read_dir(&twins_dir).expect("twins").count();
        assert_eq!(files * kinds.len(), runs.len(), "{name}: one twin per run");
        assert!(checked >= runs.len());
    }
}

fn cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_scenario"))
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."))
        .output()
        .expect("run scenario")
}

#[test]
fn cli_suite_errors_exit_2_with_one_line() {
    for (args, want) in [
        (&["suite", "no-such-suite"][..], "suite `no-such-suite`: not found"),
        (&["suite", "r157", "--controllers", "frobnicate"][..], "`--controllers`"),
        (&["--param", "EgoSpeed_kmh=50", "suite", "r157"][..], "`--param` does not apply to `suite`"),
    ] {
        let out = cli(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(want), "{err}");
    }
    // After the subcommand, `--param` is not one of its flags: clap refuses it (exit 2, naming it).
    let out = cli(&["suite", "r157", "--param", "EgoSpeed_kmh=50"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--param"));
    // A broken suite.toml names the file and the key.
    let dir = std::env::temp_dir().join(format!("flc-suite-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(
        dir.join("suite.toml"),
        "name = \"x\"\ntitle = \"x\"\nsource = \"x\"\n[[cases]]\nid = \"a\"\nfile = \"a.xosc\"\nsection = \"s\"\ncriterion = \"maybe\"\n",
    )
    .expect("write");
    let out = cli(&["suite", dir.to_str().expect("utf-8")]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("suite.toml") && err.contains("cases[0].criterion"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cli_suite_prints_the_summary_and_writes_the_reports() {
    let dir = std::env::temp_dir().join(format!("flc-suite-out-{}", std::process::id()));
    let out = cli(&["suite", "ncap-ccr", "--controllers", "idm", "--out", dir.to_str().expect("utf-8")]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.lines().any(|l| l.starts_with("| ncap-ccr | idm | ")), "{text}");
    for ext in ["md", "json", "svg"] {
        assert!(dir.join(format!("ncap-ccr.{ext}")).is_file(), "{ext}");
    }
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("ncap-ccr.json")).expect("json")).expect("parse");
    assert_eq!(json["results"].as_array().map(Vec::len).unwrap_or(0) % 30, 0, "30 NCAP runs per controller");
    let _ = std::fs::remove_dir_all(&dir);
}
