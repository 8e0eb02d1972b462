//! The C interface from C, against the release static library, as a firmware build would use it.
//!
//! Once per test run this builds `libflc_core.a` the firmware way (`no_std`, no `alloc`,
//! `panic = "abort"`, features `capi,panic-handler`) into `target/tmp/flc-capi`, compiles
//! `examples/c/main.c` and `examples/c/stack_usage.c` with the system C compiler (`$CC` or `cc`)
//! against the committed header `include/flc.h`, links them with `--gc-sections`, and checks:
//!
//! * every output of the C program equals the Rust API's on the same inputs, bit for bit;
//! * the linked program contains no panic machinery at all: with `panic = "abort"` every panic in
//!   Rust goes through `core::panicking::panic_fmt` and the panic handler, so when the linker's
//!   garbage collection has dropped them, no code reachable from the `flc_*` functions can panic;
//! * the static library contains nothing of the `alloc` crate;
//! * the peak stack use of every C API function stays within the bounds documented in
//!   `docs/firmware.md`.

mod common;

use common::{FNV_OFFSET, Lcg, SPECIAL, hash_f64, scan};
use flc_core::{
    ActiveController, DetectorParams, FallbackController, FlcParams, Frame, GainSet, LeadDetector, LongitudinalCommand, NeighbourParams,
    NeighbourTracker, PidController, PidCore, PidParams, Point2, PurePursuit, PurePursuitParams, Reprojection, RobustFallbackController,
    RobustFallbackController2, RobustFlc2Params, RobustFlcParams, Supervisor, SupervisorParams, SwitchReason, V2vMessage,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

struct Built {
    lib: PathBuf,
    example: PathBuf,
    stack_usage: PathBuf,
}

fn manifest_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{cmd:?} failed ({}):\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    stdout
}

/// Builds the static library and the two C programs once.
fn built() -> &'static Built {
    static BUILT: OnceLock<Built> = OnceLock::new();
    BUILT.get_or_init(|| {
        let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("flc-capi");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        run(Command::new(cargo)
            .current_dir(manifest_dir())
            .env("CARGO_TARGET_DIR", &target_dir)
            .args([
                "rustc",
                "--locked",
                "-q",
                "-p",
                "flc-core",
                "--lib",
                "--release",
                "--no-default-features",
                "--features",
                "capi,panic-handler",
            ])
            .args(["--crate-type", "staticlib", "--config", "profile.release.panic=\"abort\""]));
        let lib = target_dir.join("release/libflc_core.a");
        assert!(lib.is_file(), "{} was not built", lib.display());
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let compile = |source: &str, out: &str| {
            let exe = target_dir.join(out);
            run(Command::new(&cc)
                .args(["-std=c11", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off", "-ffunction-sections", "-fdata-sections"])
                .arg("-I")
                .arg(manifest_dir().join("include"))
                .arg(manifest_dir().join(source))
                .arg(&lib)
                .args(["-lm", "-Wl,--gc-sections", "-o"])
                .arg(&exe));
            exe
        };
        let example = compile("examples/c/main.c", "flc-example");
        let stack_usage = compile("examples/c/stack_usage.c", "flc-stack-usage");
        Built { lib, example, stack_usage }
    })
}

fn x(v: f64) -> String {
    format!("{:016x}", v.to_bits())
}

/// A detection as the C program prints it: `has x y distance width depth confidence points`, all
/// zero when there is none (as the C outputs' `FlcDetection`).
fn detection(d: Option<flc_core::Detection>) -> String {
    let t = d.unwrap_or(flc_core::Detection {
        position: Point2::new(0.0, 0.0),
        distance: 0.0,
        width: 0.0,
        depth: 0.0,
        points: 0,
        confidence: 0.0,
    });
    format!(
        "{} {} {} {} {} {} {} {}",
        u8::from(d.is_some()),
        x(t.position.x),
        x(t.position.y),
        x(t.distance),
        x(t.width),
        x(t.depth),
        x(t.confidence),
        t.points
    )
}

fn cmd(out: &mut String, c: LongitudinalCommand) {
    let _ = write!(out, " {} {} {}", c.status as u8, x(c.speed), x(c.accel));
}

fn special(k: usize) -> f64 {
    SPECIAL[k % 5]
}

/// What `examples/c/main.c` must print, computed with the Rust API on the same inputs.
fn expected() -> Vec<String> {
    let mut o = String::new();

    // FLC
    let mut c = FallbackController::new(FlcParams::default()).unwrap();
    let (mut rng, mut h, mut dist) = (Lcg(1), FNV_OFFSET, 30.0);
    for k in 0..400 {
        let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
        let has = u1 >= 0.05;
        dist += (u2 - 0.55) * 1.2;
        if dist < 3.0 {
            dist = 40.0;
        }
        let d = if (0.05..0.09).contains(&u1) { special(k) } else { dist };
        let v = if u3 >= 0.97 { special(k + 2) } else { 25.0 * u3 };
        hash_f64(&mut h, d);
        hash_f64(&mut h, v);
        if k == 200 {
            c.reset();
        }
        let r = c.step(has.then_some(d), v);
        let _ = write!(o, "flc {k}");
        cmd(&mut o, r);
        let t = c.terms();
        let _ = writeln!(
            o,
            "\nflct {k} {} {} {} {} {} {} {} {} {} {} {}",
            x(t.tau_d),
            x(t.d_d),
            x(t.scale_f),
            x(t.f_shift),
            x(t.delta_d),
            x(t.dist_s_raw),
            x(t.dist_s),
            x(t.a_law),
            x(t.a),
            u8::from(t.braking_branch),
            u8::from(t.overridden)
        );
    }
    let _ = writeln!(o, "hash flc {h:016x}");

    // Robust FLC v1 and v2, same frames
    let mut r1 = RobustFallbackController::new(RobustFlcParams::default()).unwrap();
    let mut r2 = RobustFallbackController2::new(RobustFlc2Params::default()).unwrap();
    let (mut rng, mut dist) = (Lcg(7), 30.0);
    for k in 0..400 {
        let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
        let has = u1 >= 0.08;
        dist += (u2 - 0.5) * 0.8;
        if u2 >= 0.96 {
            dist += 8.0;
        }
        if u2 < 0.03 {
            dist -= 8.0;
        }
        if dist < 3.0 {
            dist = 40.0;
        }
        let d = if (0.08..0.1).contains(&u1) { special(k) } else { dist };
        let v = if u3 >= 0.98 { special(k + 1) } else { 5.0 + 25.0 * u3 };
        if k == 250 {
            r1.reset();
            r2.reset();
        }
        let c = r1.step(has.then_some(d), v);
        let _ = write!(o, "rob {k}");
        cmd(&mut o, c);
        let t = r1.terms();
        let _ = writeln!(
            o,
            "\nrobt {k} {} {} {} {} {} {} {} {} {}",
            x(t.desired_gap),
            x(t.gap_error),
            x(t.gap_speed),
            x(t.envelope_speed),
            x(t.target_speed),
            x(t.latch_min_distance),
            x(t.a),
            u8::from(t.revealed),
            u8::from(t.latched)
        );
        let c = r2.step(has.then_some(d), v);
        let _ = write!(o, "rob2 {k}");
        cmd(&mut o, c);
        let t = r2.terms();
        let _ = writeln!(
            o,
            "\nrob2t {k} {} {} {} {} {} {} {} {} {} {}",
            x(t.distance),
            x(t.gap_speed),
            x(t.envelope_speed),
            x(t.approach_speed),
            x(t.target_speed),
            x(t.a),
            u8::from(t.held),
            u8::from(t.pending),
            u8::from(t.revealed),
            u8::from(t.latched)
        );
    }

    // PID
    let mut c = PidController::new(PidParams::default()).unwrap();
    let (mut rng, mut h, mut dist) = (Lcg(2), FNV_OFFSET, 25.0);
    let bad_dt = [f64::NAN, f64::INFINITY, 0.0, -0.05, 20.0];
    for k in 0..400 {
        let (u1, u2, u3, u4, u5) = (rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform());
        let lead = if u5 >= 0.98 { special(k) } else { 15.0 + 10.0 * u1 };
        let own = 15.0 + 10.0 * u2;
        dist += (u3 - 0.55) * 1.2;
        if dist < 3.0 {
            dist = 40.0;
        }
        let dt = if u3 >= 0.97 { bad_dt[k % 5] } else { 0.05 };
        let has = u4 >= 0.03;
        for v in [lead, own, dist, dt] {
            hash_f64(&mut h, v);
        }
        if k == 300 {
            c.reset();
        }
        let r = c.step(lead, own, has.then_some(dist), dt);
        let _ = write!(o, "pid {k}");
        cmd(&mut o, r);
        let t = c.terms();
        let gains = match t.gains {
            GainSet::Far => 0,
            GainSet::Near => 1,
        };
        let _ = writeln!(o, "\npidt {k} {} {} {} {} {} {gains}", x(t.desired), x(t.error), x(t.error_rate), x(t.integral), x(t.u));
    }
    let _ = writeln!(o, "hash pid {h:016x}");

    // Supervisor
    let mut s = Supervisor::new(SupervisorParams::default()).unwrap();
    let (mut rng, mut h, mut dist, mut seq) = (Lcg(3), FNV_OFFSET, 20.0, 0u32);
    for k in 0..600 {
        let (u1, u2, u3, u4, u5) = (rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform());
        let has_v2v = u1 < 0.8 && !(200..260).contains(&k);
        if u2 >= 0.05 {
            seq += 1;
        }
        let lead_speed = if u2 > 0.98 { special(k) } else { 15.0 + 5.0 * u3 };
        dist += (u4 - 0.55) * 0.8;
        if dist < 3.0 {
            dist = 30.0;
        }
        let own = 14.0 + 4.0 * u4;
        let has_dist = u5 >= 0.02;
        for v in [lead_speed, dist, own] {
            hash_f64(&mut h, v);
        }
        if k == 450 {
            s.reset();
        }
        // A neighbour entering the path at half the distance on ticks 100-129, beyond the lead on
        // 130-139 (`flc_supervisor_step_intruder`).
        let intruder = (100..140).contains(&k).then_some(if k < 130 { 0.5 * dist } else { 2.0 * dist });
        let frame = Frame {
            v2v: has_v2v.then_some(V2vMessage::speed_only(lead_speed, seq)),
            intruder,
            ..Frame::new(has_dist.then_some(dist), own, 0.05)
        };
        let r = s.step_frame(&frame);
        let active = match r.active {
            ActiveController::Flc => 0,
            ActiveController::Pid => 1,
        };
        let reason = match r.reason {
            SwitchReason::V2vFresh => 0,
            SwitchReason::NoV2v => 1,
            SwitchReason::V2vStale => 2,
            SwitchReason::Recovering => 3,
            SwitchReason::InvalidV2v => 4,
            SwitchReason::NotAssociated => 5,
        };
        let association = r.association as u8;
        let _ = write!(o, "sup {k} {active} {reason} {} {} {} {association}", u8::from(r.switched), r.v2v_age_ticks, r.fresh_count);
        cmd(&mut o, r.command);
        cmd(&mut o, r.flc);
        cmd(&mut o, r.pid);
        o.push('\n');
    }
    let _ = writeln!(o, "hash sup {h:016x}");

    // Pure pursuit
    let pp = PurePursuit::new(PurePursuitParams::default()).unwrap();
    let (mut rng, mut h) = (Lcg(4), FNV_OFFSET);
    for k in 0..200 {
        let (u1, u2, u3, u4) = (rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform());
        let has = u1 >= 0.05;
        let (mut px, mut py, v) = (-5.0 + 60.0 * u2, -10.0 + 20.0 * u3, 30.0 * u4);
        if (0.05..0.08).contains(&u1) {
            px = special(k);
        }
        if k == 17 {
            (px, py) = (0.0, 0.0);
        }
        for v in [px, py, v] {
            hash_f64(&mut h, v);
        }
        let r = pp.step(has.then(|| Point2::new(px, py)), v);
        let _ = writeln!(
            o,
            "pp {k} {} {} {} {} {} {}",
            r.status as u8,
            x(r.steer),
            x(r.lookahead),
            x(r.alpha),
            x(r.lookahead_point.x),
            x(r.lookahead_point.y)
        );
    }
    let _ = writeln!(o, "hash pp {h:016x}");

    // Detector
    let mut det = <LeadDetector>::new(DetectorParams::default()).unwrap();
    let mut det2 =
        <LeadDetector>::new(DetectorParams { reprojection: Reprojection::CellCenter, max_points: 1000, ..DetectorParams::default() })
            .unwrap();
    let mut detect = |d: &mut LeadDetector, label: &str, pts: &[[f64; 2]], curvature: f64| {
        let mut h = FNV_OFFSET;
        for p in pts {
            hash_f64(&mut h, p[0]);
            hash_f64(&mut h, p[1]);
        }
        hash_f64(&mut h, curvature);
        let r = d.detect(pts, curvature);
        let _ = writeln!(
            o,
            "det {label} {h:016x} {} {} {} {} {}",
            r.status as u8,
            detection(r.detection),
            r.points_used,
            r.points_rejected,
            r.clusters
        );
    };
    let s1 = scan(11, 20.0, 0.3, 1.9, 900, true);
    detect(&mut det, "car20_rails_900", &s1, 0.0);
    detect(&mut det, "car20_rails_900_nan_curvature", &s1, f64::NAN);
    let s2 = scan(12, 45.0, -0.5, 1.8, 1800, true);
    detect(&mut det, "car45_rails_1800", &s2, -0.0005);
    detect(&mut det2, "car45_rails_1800_cell_truncated", &s2, -0.0005);
    let s3 = scan(13, 30.0, 3.7, 1.9, 600, false);
    detect(&mut det, "next_lane_straight", &s3, 0.0);
    detect(&mut det, "next_lane_curve", &s3, 0.0082);
    det.set_path_profile(10.0, &[0.0, 1.2, 2.5, 3.7]).unwrap();
    detect(&mut det, "next_lane_profile", &s3, 0.0);
    det.set_path_profile(0.0, &[]).unwrap();
    detect(&mut det, "next_lane_profile_cleared", &s3, 0.0);
    let mut s4 = scan(14, 25.0, 0.0, 1.9, 900, true);
    for p in s4.iter_mut().step_by(50) {
        p[0] = f64::NAN;
    }
    detect(&mut det, "car25_nan_points", &s4, 0.0);
    det.reset();
    detect(&mut det, "empty", &[], 0.0);

    // Neighbour tracker behind the detector: a car in the next lane, steady for 15 scans, then
    // changing lanes towards the path (3 m in 40 scans); a scan lost at k = 30; left, then right.
    let mut det = <LeadDetector>::new(DetectorParams::default()).unwrap();
    let mut nb = NeighbourTracker::new(NeighbourParams::default()).unwrap();
    for s in 0..2 {
        let side = if s == 0 { 1.0 } else { -1.0 };
        if s == 1 {
            nb.reset();
        }
        for k in 0..60 {
            let u = if k < 15 {
                0.0
            } else if k > 55 {
                1.0
            } else {
                f64::from(k - 15) / 40.0
            };
            let yc = side * (3.5 - 3.0 * u);
            let d = 25.0 - 0.1 * f64::from(k);
            let pts = if k == 30 { Vec::new() } else { scan(20 + k as u64, d, yc, 1.9, 300, false) };
            det.detect(&pts, 0.0);
            let r = nb.update(det.clusters());
            let _ = writeln!(o, "nb {s} {k} {} {}", detection(r), nb.tracks().count());
        }
    }

    // Error paths: FlcResult codes (0 ok, 1 null_pointer, 2 misaligned, 3 not_initialized,
    // 4 invalid_params, 5 invalid_argument) and the field named by FlcParamError.
    for (what, code, field) in [
        ("fallback_step_null_self", 1, ""),
        ("fallback_step_null_out", 1, ""),
        ("fallback_step_uninitialised", 3, ""),
        ("fallback_step_wrong_type", 3, ""),
        ("fallback_reset_uninitialised", 3, ""),
        ("fallback_init_bound_t", 4, "bound_t"),
        ("fallback_init_dist_override", 4, "dist_override"),
        ("fallback_init_no_error_struct", 4, ""),
        ("fallback_init_null_params", 1, ""),
        ("fallback_still_uninitialised", 3, ""),
        ("robust_step_wrong_type", 3, ""),
        ("robust2_step_uninitialised", 3, ""),
        ("robust2_init_sight_decel", 4, "sight_decel"),
        ("robust2_init_first_object", 4, "first_object"),
        ("pid_init_near_kd", 4, "near.kd"),
        ("pid_step_after_failed_init", 0, ""),
        ("supervisor_init_return_after", 4, "return_after"),
        ("supervisor_init_first_frame", 4, "first_frame"),
        ("supervisor_step_null_out", 1, ""),
        ("pursuit_init_law", 4, "law"),
        ("pursuit_step_null", 1, ""),
        ("detector_init_max_width", 4, "max_width"),
        ("detector_init_reprojection", 4, "reprojection"),
        ("detector_init_max_points", 4, "max_points"),
        ("detector_detect_misaligned", 2, ""),
        ("detector_detect_null_points", 1, ""),
        ("detector_detect_huge_count", 5, ""),
        ("detector_detect_null_self", 1, ""),
        ("detector_profile_spacing", 4, "spacing"),
        ("detector_profile_count", 4, "offsets"),
        ("detector_profile_null_offsets", 1, ""),
        ("supervisor_step_null", 1, ""),
        ("neighbours_init_max_misses", 4, "max_misses"),
        ("neighbours_init_wandering", 4, "wandering"),
        ("neighbours_init_max_width", 4, "max_width"),
        ("neighbours_update_uninitialised", 3, ""),
        ("neighbours_update_uninitialised_detector", 3, ""),
        ("neighbours_update_wrong_detector_type", 3, ""),
        ("neighbours_update_null_detector", 1, ""),
        ("neighbours_update_null_out", 1, ""),
        ("neighbours_reset_null", 1, ""),
    ] {
        let name = ["ok", "null_pointer", "misaligned", "not_initialized", "invalid_params", "invalid_argument"][code];
        let field = if field.is_empty() { String::new() } else { format!(" {field}") };
        let _ = writeln!(o, "err {what} {code} {name}{field}");
    }
    let _ = writeln!(o, "names invalid_params invalid_distance empty_scan unknown");
    let _ = writeln!(o, "version {}", env!("CARGO_PKG_VERSION"));
    let _ = writeln!(o, "done 0");
    o.lines().map(str::to_owned).collect()
}

#[test]
fn c_example_outputs_equal_rust() {
    let b = built();
    let out = run(&mut Command::new(&b.example));
    let mut lines = out.lines();
    // Storage struct sizes as C sees them: each holds its controller plus the magic word.
    let sizes: Vec<usize> = lines.next().unwrap().strip_prefix("sizes ").unwrap().split(' ').map(|s| s.parse().unwrap()).collect();
    let rust = [
        size_of::<FallbackController>(),
        size_of::<PidCore>(),
        size_of::<Supervisor>(),
        size_of::<PurePursuit>(),
        size_of::<LeadDetector>(),
        size_of::<RobustFallbackController>(),
        size_of::<RobustFallbackController2>(),
        size_of::<NeighbourTracker>(),
    ];
    assert_eq!(sizes.len(), rust.len());
    for (c, r) in sizes.iter().zip(rust) {
        assert!(*c >= r + 8 && *c <= r + 8 + 8, "C storage {c} bytes for a {r}-byte controller");
    }
    let got: Vec<&str> = lines.collect();
    let want = expected();
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g, w, "line {} of the C program differs from Rust", i + 2);
    }
    assert_eq!(got.len(), want.len(), "the C program printed {} lines, Rust {}", got.len(), want.len());
    // docs/firmware.md's claims table quotes the count ("prints 4 173 lines").
    let count = want.len().to_string();
    let (head, tail) = count.split_at(count.len().saturating_sub(3));
    let count = if head.is_empty() { tail.to_owned() } else { format!("{head} {tail}") };
    let doc = std::fs::read_to_string(manifest_dir().join("../../docs/firmware.md")).unwrap();
    assert!(doc.contains(&format!("prints {count} lines")), "docs/firmware.md: the C program prints {count} lines");
    // The sequences exercise every status, both controllers of the supervisor and detections.
    assert!(got.iter().any(|l| l.starts_with("sup ") && l.split(' ').nth(2) == Some("1")), "the PID never drove");
    assert!(got.iter().any(|l| l.starts_with("sup ") && l.split(' ').nth(4) == Some("1")), "the supervisor never switched");
    assert!(got.iter().any(|l| l.starts_with("sup ") && l.split(' ').nth(3) == Some("5")), "never not associated");
    assert!(got.iter().filter(|l| l.starts_with("det ") && l.split(' ').nth(4) == Some("1")).count() >= 4, "too few detections");
    // The path profile takes the next lane's car into the path; cleared, it is off the path again.
    let has = |label: &str| got.iter().find(|l| l.starts_with(&format!("det {label} "))).and_then(|l| l.split(' ').nth(4)) == Some("1");
    assert!(!has("next_lane_straight") && has("next_lane_profile") && !has("next_lane_profile_cleared"), "the path profile");
    // The car changing lanes intrudes on either side, and not while it keeps its lane (k < 15).
    for side in ["0", "1"] {
        let intruding: Vec<u32> = got
            .iter()
            .filter_map(|l| l.strip_prefix("nb "))
            .map(|l| l.split(' ').collect::<Vec<_>>())
            .filter(|f| f[0] == side && f[2] == "1")
            .map(|f| f[1].parse().unwrap())
            .collect();
        assert!(intruding.len() >= 10 && intruding.iter().all(|&k| k >= 15), "side {side}: intruding at scans {intruding:?}");
    }
    // The robust sequences hold for missed frames, confirm jumps and latch on reveals.
    let flag = |prefix: &str, i: usize| got.iter().filter(|l| l.starts_with(prefix) && l.split(' ').nth(i) == Some("1")).count();
    assert!(flag("robt ", 9) > 0 && flag("robt ", 10) > 0, "v1 never revealed / latched");
    assert!(flag("rob2t ", 8) > 0 && flag("rob2t ", 9) > 0 && flag("rob2t ", 10) > 0, "v2 never held / pending / revealed");
    for status in 0..=5 {
        assert!(
            got.iter().any(|l| (l.starts_with("flc ") || l.starts_with("pid ")) && l.split(' ').nth(2) == Some(&status.to_string())),
            "status {status} never seen"
        );
    }
}

fn symbols(path: &Path) -> Vec<String> {
    run(Command::new("nm").arg("-C").arg(path)).lines().map(str::to_owned).collect()
}

#[test]
fn linked_c_program_contains_no_panic_path() {
    let b = built();
    let syms = symbols(&b.example);
    let defined = |name: &str| syms.iter().any(|s| s.ends_with(&format!(" T {name}")));
    // The check is not vacuous: every entry point is linked in ...
    for f in [
        "flc_fallback_init",
        "flc_fallback_step",
        "flc_fallback_reset",
        "flc_fallback_terms",
        "flc_robust_init",
        "flc_robust_step",
        "flc_robust_reset",
        "flc_robust_terms",
        "flc_robust2_init",
        "flc_robust2_step",
        "flc_robust2_reset",
        "flc_robust2_terms",
        "flc_pid_init",
        "flc_pid_step",
        "flc_pid_reset",
        "flc_pid_terms",
        "flc_supervisor_init",
        "flc_supervisor_step",
        "flc_supervisor_step_intruder",
        "flc_supervisor_reset",
        "flc_pursuit_init",
        "flc_pursuit_step",
        "flc_detector_init",
        "flc_detector_detect",
        "flc_detector_reset",
        "flc_detector_set_path_profile",
        "flc_neighbours_init",
        "flc_neighbours_update",
        "flc_neighbours_reset",
    ] {
        assert!(defined(f), "{f} is not in the linked C program");
    }
    // ... and the library does carry core's panic machinery, which would be linked if referenced.
    let lib_syms = symbols(&b.lib);
    assert!(lib_syms.iter().any(|s| s.contains("core::panicking::panic_fmt")), "negative control: panic_fmt not in the library");
    let panicky: Vec<&String> = syms
        .iter()
        .filter(|s| {
            let l = s.to_lowercase();
            l.contains("panic") || l.contains("begin_unwind") || l.contains("unwrap_failed") || l.contains("expect_failed")
        })
        .collect();
    assert!(
        panicky.is_empty(),
        "code reachable from the C API can panic; linked panic symbols:\n{panicky:#?}\n\
         Find the caller with: cc ... -B$(rustc --print sysroot)/lib/rustlib/x86_64-unknown-linux-gnu/bin/gcc-ld -fuse-ld=lld \
         -Wl,--gc-sections -Wl,--why-live=<mangled symbol> (docs/firmware.md)"
    );
}

#[test]
fn no_std_library_contains_no_alloc() {
    let b = built();
    let alloc: Vec<String> = symbols(&b.lib)
        .into_iter()
        .filter(|s| {
            let name = s.rsplit(' ').next().unwrap_or("");
            name.starts_with("alloc::")
                || name.starts_with("<alloc::")
                || s.contains("__rust_alloc")
                || s.contains("__rdl_alloc")
                || s.contains("__rg_alloc")
        })
        .collect();
    assert!(alloc.is_empty(), "the no_std static library links the alloc crate:\n{alloc:#?}");
    // Nor does any source mention it.
    let mut dirs = vec![manifest_dir().join("src")];
    let mut seen = 0;
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            assert!(!text.contains("extern crate alloc") && !text.contains("alloc::"), "{} uses alloc", path.display());
            seen += 1;
        }
    }
    assert!(seen > 5, "only {seen} source files found");
}

#[test]
fn stack_use_of_every_c_function_is_bounded() {
    let b = built();
    let out = run(&mut Command::new(&b.stack_usage));
    // Bounds of docs/firmware.md ("Stack"), host x86_64 figures plus headroom.
    let bounds = [
        ("flc_fallback_init", 1024),
        ("flc_fallback_step", 1024),
        ("flc_robust_init", 1024),
        ("flc_robust_step", 1024),
        ("flc_robust2_init", 2048),
        ("flc_robust2_step", 1024),
        ("flc_pid_init", 1024),
        ("flc_pid_step", 1024),
        ("flc_supervisor_init", 4096),
        ("flc_supervisor_step", 2048),
        ("flc_supervisor_step_intruder", 2048),
        ("flc_pursuit_init", 1024),
        ("flc_pursuit_step", 1024),
        ("flc_detector_init", 1024),
        ("flc_detector_set_path_profile", 1024),
        ("flc_detector_detect", 2048),
        ("flc_neighbours_init", 2048),
        ("flc_neighbours_update", 1024),
    ];
    for (name, bound) in bounds {
        let used: usize = out
            .lines()
            .find_map(|l| l.strip_prefix(&format!("stack {name} ")))
            .unwrap_or_else(|| panic!("{name} not measured:\n{out}"))
            .parse()
            .unwrap();
        eprintln!("stack {name}: {used} bytes (bound {bound})");
        assert!(used > 0 && used <= bound, "{name} uses {used} bytes of stack, bound {bound}");
    }
}
