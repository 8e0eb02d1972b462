//! flc's baselines against SUMO's own models, one step at a time (issue 16, first part).
//!
//! `tests/data/sumo/*.csv` (made by `tools/sumo_reference.py` with SUMO 1.28 and libsumo) hold
//! SUMO trajectories. On every step, the law gets what SUMO's model got: the bumper gap, its own
//! speed and the lead's speed, measured directly as with ideal perception. The law's speed
//! command is compared with SUMO's speed one step later. SUMO's step is 0.1 s, and SUMO applies
//! `v + a dt`, so the laws use `command_gain = dt`. The parameters are SUMO's vType values
//! (first line of each file).

use flc_core::baselines::{AccController, AccParams, IdmController, IdmParams};

struct Row {
    lead_speed: f64,
    follower_speed: f64,
    gap: f64,
}

fn rows(name: &str) -> Vec<Row> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/sumo").join(format!("{name}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).expect("column");
    let (ls, fs, g) = (col("lead_speed"), col("follower_speed"), col("gap"));
    lines
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().expect("number")).collect();
            Row { lead_speed: f[ls], follower_speed: f[fs], gap: f[g] }
        })
        .collect()
}

const DT: f64 = 0.1;

/// RMS and max of `law(gap, v, v_lead) - v_next(SUMO)` over a file's steps.
fn residuals(name: &str, mut law: impl FnMut(f64, f64, f64) -> f64) -> (f64, f64) {
    let r = rows(name);
    let errs: Vec<f64> = r.windows(2).map(|w| law(w[0].gap, w[0].follower_speed, w[0].lead_speed) - w[1].follower_speed).collect();
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
    (rms, errs.iter().fold(0.0, |m: f64, e| m.max(e.abs())))
}

const SCENARIOS: [&str; 12] = [
    "paper-30",
    "paper-50",
    "paper-70",
    "paper-90",
    "paper-110",
    "paper-130",
    "steady-accel",
    "steady-decel",
    "brake2-gap12",
    "brake2-gap40",
    "brake6-gap12",
    "brake6-gap40",
];

/// SUMO's IDM vType: accel 2.6, decel 4.5, tau 1, minGap 2.5, delta 4, maxSpeed 50 m/s,
/// emergencyDecel 9.
fn sumo_idm() -> IdmParams {
    IdmParams {
        desired_speed: 50.0,
        time_headway: 1.0,
        min_gap: 2.5,
        max_accel: 2.6,
        comfort_decel: 4.5,
        delta: 4.0,
        max_decel: 9.0,
        command_gain: DT,
        ..IdmParams::default()
    }
}

/// flc's IDM reproduces SUMO's IDM step by step: the same law on the same inputs, so the only
/// difference is floating-point order (tolerance 1e-6 m/s per step; measured at most 3.6e-15 on
/// every file).
#[test]
fn flc_idm_reproduces_sumo_idm_step_by_step() {
    for name in SCENARIOS {
        let mut c = IdmController::new(sumo_idm()).expect("params");
        let (rms, max) = residuals(&format!("idm-{name}"), |gap, v, vl| c.step_measured(Some(gap), v, DT, Some(vl)).speed);
        eprintln!("idm {name}: rms {rms:.3e} max {max:.3e} m/s");
        assert!(max < 1e-6, "idm {name}: rms {rms} max {max} m/s");
    }
}

/// flc's ACC reproduces SUMO's ACC step by step. The vType is accel 2.6, decel 8, tau 1, minGap
/// 2.5, emergencyDecel 9; the lead's apparent decel is the lead vType's 10. The tolerance is
/// 0.005 m/s per step and 0.001 m/s RMS (measured at most 0.004 / 0.0003). The small rest comes
/// from SUMO's final speed limits around `decel`, which the law does not model. Before issue 16
/// fixed the dynamic gap margin, the gap-mode test and the discrete safe speed, the residuals
/// reached 0.8 m/s.
#[test]
fn flc_acc_reproduces_sumo_acc_step_by_step() {
    for name in SCENARIOS {
        let p = AccParams {
            desired_speed: 50.0,
            headway_time: 1.0,
            min_gap: 2.5,
            decel: 8.0,
            lead_decel: 10.0,
            max_accel: 2.6,
            command_gain: DT,
            ..AccParams::default()
        };
        let mut c = AccController::new(p).expect("params");
        let (rms, max) = residuals(&format!("acc-{name}"), |gap, v, vl| c.step_measured(Some(gap), v, DT, Some(vl)).speed);
        eprintln!("acc {name}: rms {rms:.2e} max {max:.2e} m/s");
        assert!(rms < 0.001 && max < 0.005, "acc {name}: rms {rms} max {max} m/s");
    }
}

/// Gipps (1981) against SUMO's Krauss (sigma 0), which is a Gipps-type safe-speed model. The two
/// laws differ by design, so the residuals are not near zero; they are asserted to be the ranges
/// docs/baselines.md quotes (RMS 0.23-0.28 m/s, max 0.43-0.81 m/s per step over the 12 files, to
/// two decimals; measured 0.227-0.277 and 0.427-0.809).
/// Gipps' free-flow branch `v + 2.5 a tau (1 - v/V) sqrt(0.025 + v/V)` is not Krauss'
/// `v + a dt`, and Gipps brakes against `b̂` with a `tau / 2` margin where Krauss uses the
/// leader's `decel`. Both use SUMO's vType: accel 2.6, decel 4.5, tau 1, minGap 2.5, 50 m/s.
#[test]
fn gipps_against_sumo_krauss_is_measured() {
    use flc_core::baselines::{GippsController, GippsParams};
    let (mut rms_range, mut max_range) = ((f64::INFINITY, 0.0_f64), (f64::INFINITY, 0.0_f64));
    for name in SCENARIOS {
        let p = GippsParams {
            desired_speed: 50.0,
            accel: 2.6,
            decel: 4.5,
            reaction_time: DT,
            min_gap: 2.5,
            command_gain: DT,
            ..GippsParams::default()
        };
        let mut c = GippsController::new(p).expect("params");
        let (rms, max) = residuals(&format!("krauss-{name}"), |gap, v, vl| c.step_measured(Some(gap), v, DT, Some(vl)).speed);
        eprintln!("gipps vs krauss {name}: rms {rms:.3} max {max:.3} m/s");
        assert!(rms.is_finite() && max.is_finite(), "gipps vs krauss {name}: rms {rms} max {max}");
        rms_range = (rms_range.0.min(rms), rms_range.1.max(rms));
        max_range = (max_range.0.min(max), max_range.1.max(max));
    }
    let two = |(lo, hi): (f64, f64)| format!("{lo:.2}-{hi:.2}");
    assert_eq!(two(rms_range), "0.23-0.28", "RMS range (docs/baselines.md)");
    assert_eq!(two(max_range), "0.43-0.81", "max range (docs/baselines.md)");
}
