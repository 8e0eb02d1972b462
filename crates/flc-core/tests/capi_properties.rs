//! The C interface called from Rust (feature `capi`): for arbitrary parameter structs (invalid
//! enum values and NaNs included) `*_init` accepts exactly what the Rust constructors accept, and
//! every step gives bit-identical outputs to the Rust API. Run by `tests/run_all.sh`:
//! `cargo test -p flc-core --features capi --test capi_properties`.
#![cfg(feature = "capi")]
#![allow(unsafe_code)]

use flc_core::capi::*;
use flc_core::{
    DetectorParams, FallbackController, FlcParams, LeadDetector, NeighbourParams, NeighbourTracker, PidController, PidCore, PidParams,
    Point2, PurePursuit, PurePursuitParams, RobustFallbackController, RobustFallbackController2, RobustFlc2Params, RobustFlcParams,
    Supervisor, SupervisorParams, V2vMessage,
};
use proptest::prelude::*;
use std::mem::MaybeUninit;
use std::ptr::{null, null_mut};

fn num(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    prop_oneof![6 => lo..hi, 1 => proptest::num::f64::ANY, 1 => Just(f64::NAN)]
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

fn same_cmd(c: FlcLongitudinalCommand, r: flc_core::LongitudinalCommand) -> bool {
    same(c.speed, r.speed) && same(c.accel, r.accel) && c.status as u8 == r.status as u8
}

/// A C parameter struct near the defaults with a few fields perturbed (possibly invalid).
fn c_flc_params() -> impl Strategy<Value = FlcFallbackParams> {
    (num(-0.5, 11.0), num(-1.0, 1100.0), num(-1.0, 110.0), 0u8..4, 0u8..3, any::<bool>(), num(-1.0, 110.0)).prop_map(
        |(time_gap, bound_t, negative_multiplier, dist_override, first_frame, clip_dist_s, max_speed)| FlcFallbackParams {
            time_gap,
            bound_t,
            negative_multiplier,
            dist_override,
            first_frame,
            clip_dist_s,
            max_speed,
            ..flc_fallback_params_default()
        },
    )
}

/// A C robust-FLC v1 parameter struct near the defaults with a few fields perturbed.
fn c_robust_params() -> impl Strategy<Value = FlcRobustParams> {
    (num(-0.5, 11.0), num(-1.0, 12.0), num(-1.0, 5.0), 0u8..3, num(-1.0, 110.0)).prop_map(
        |(time_gap, envelope_decel, reveal_jump, first_object, max_speed)| FlcRobustParams {
            time_gap,
            envelope_decel,
            reveal_jump,
            first_object,
            max_speed,
            ..flc_robust_params_default()
        },
    )
}

/// A C robust-FLC v2 parameter struct: perturbed law and event-rule fields.
fn c_robust2_params() -> impl Strategy<Value = FlcRobust2Params> {
    (
        c_robust_params(),
        (num(-1.0, 300.0), num(-1.0, 5.0), num(-1.0, 20.0), num(-0.1, 1.0)),
        (num(-1.0, 20.0), num(-1.0, 10.0), num(-1.0, 20.0)),
        (num(-0.5, 3.0), num(-0.5, 2.0), num(-0.5, 3.0)),
    )
        .prop_map(
            |(
                law,
                (sight_distance, sight_decel, release_speed, release_closing),
                (approach_time_gap, firm_error, firm_gain),
                (memory, response_time, accel),
            )| {
                let comfort = FlcComfortParams { memory, response_time, accel, ..flc_robust2_params_default().comfort };
                FlcRobust2Params {
                    comfort,
                    law,
                    sight_distance,
                    sight_decel,
                    release_speed,
                    release_closing,
                    approach_time_gap,
                    firm_error,
                    firm_gain,
                }
            },
        )
}

#[test]
fn defaults_mirror_rust() {
    assert_eq!(flc_robust_params_default(), RobustFlcParams::default().into());
    assert_eq!(flc_robust2_params_default(), RobustFlc2Params::default().into());
    assert_eq!(RobustFlc2Params::try_from(flc_robust2_params_default()), Ok(RobustFlc2Params::default()));
    assert_eq!(flc_fallback_params_default(), FlcParams::default().into());
    assert_eq!(flc_pid_params_default(), PidParams::default().into());
    assert_eq!(flc_supervisor_params_default(), SupervisorParams::default().into());
    assert_eq!(flc_pursuit_params_default(), PurePursuitParams::default().into());
    assert_eq!(flc_detector_params_default(), DetectorParams::default().into());
    assert_eq!(FlcParams::try_from(flc_fallback_params_default()), Ok(FlcParams::default()));
    assert_eq!(DetectorParams::try_from(flc_detector_params_default()), Ok(DetectorParams::default()));
    assert_eq!(flc_neighbours_params_default(), NeighbourParams::default().into());
    assert_eq!(NeighbourParams::try_from(flc_neighbours_params_default()), Ok(NeighbourParams::default()));
}

#[test]
fn storage_sizes_and_alignment() {
    assert!(size_of::<FlcFallback>() >= 8 + size_of::<FallbackController>());
    assert!(size_of::<FlcRobust>() >= 8 + size_of::<RobustFallbackController>());
    assert!(size_of::<FlcRobust2>() >= 8 + size_of::<RobustFallbackController2>());
    assert!(size_of::<FlcPid>() >= 8 + size_of::<PidCore>());
    assert!(size_of::<FlcSupervisor>() >= 8 + size_of::<Supervisor>());
    assert!(size_of::<FlcPursuit>() >= 8 + size_of::<PurePursuit>());
    assert!(size_of::<FlcDetector>() >= 8 + size_of::<LeadDetector>());
    assert!(size_of::<FlcNeighbours>() >= 8 + size_of::<NeighbourTracker>());
    assert_eq!(align_of::<FlcNeighbours>(), 8);
    assert!(size_of::<FlcDetector>() <= 64 * 1024, "detector storage above 64 KiB");
    assert_eq!(align_of::<FlcDetector>(), 8);
}

#[test]
fn detector_init_in_place_equals_new() {
    let mut storage = Box::new(MaybeUninit::<FlcDetector>::uninit());
    let p = flc_detector_params_default();
    // SAFETY: valid pointers.
    assert_eq!(unsafe { flc_detector_init(storage.as_mut_ptr(), &p, null_mut()) }, FlcResult::Ok);
    let mut rust = Box::new(<LeadDetector>::new(DetectorParams::default()).unwrap());
    let mut pts = Vec::new();
    for i in 0..40 {
        pts.push([20.0, -0.95 + 0.05 * f64::from(i)]);
    }
    let r = rust.detect(&pts, 0.0);
    let mut out = MaybeUninit::uninit();
    // SAFETY: initialised storage, valid points and output.
    assert_eq!(unsafe { flc_detector_detect(storage.as_mut_ptr(), pts.as_ptr().cast(), pts.len(), 0.0, out.as_mut_ptr()) }, FlcResult::Ok);
    // SAFETY: written on Ok.
    let out = unsafe { out.assume_init() };
    assert!(out.has_detection && same(out.detection.distance, r.detection.unwrap().distance));
    // SAFETY: valid pointer; reset keeps it initialised.
    assert_eq!(unsafe { flc_detector_reset(storage.as_mut_ptr()) }, FlcResult::Ok);
    let mut out = MaybeUninit::<FlcDetectorOutput>::uninit();
    // SAFETY: initialised storage; NULL points with a zero count is allowed.
    assert_eq!(unsafe { flc_detector_detect(storage.as_mut_ptr(), null(), 0, 0.0, out.as_mut_ptr()) }, FlcResult::Ok);
    // SAFETY: written on Ok.
    let out = unsafe { out.assume_init() };
    assert_eq!(out.status, FlcDetectorStatus::EmptyScan);
    assert!(!out.has_detection);
}

/// `*_init`'s result `r` agrees with the Rust constructor's `rust`: `Ok` where it succeeds (the
/// value, to step on), `InvalidParams` naming the same field (in `err`) where it fails (`None`).
fn init_agrees<T>(
    r: FlcResult,
    rust: Result<T, flc_core::ParamError>,
    err: &MaybeUninit<FlcParamError>,
) -> Result<Option<T>, TestCaseError> {
    match rust {
        Ok(t) => {
            prop_assert_eq!(r, FlcResult::Ok);
            Ok(Some(t))
        }
        Err(e) => {
            prop_assert_eq!(r, FlcResult::InvalidParams);
            // SAFETY: written on InvalidParams.
            let err = unsafe { err.assume_init_ref() };
            // SAFETY: NUL-terminated by construction (`err` outlives the borrow).
            let field = unsafe { std::ffi::CStr::from_ptr(err.field.as_ptr()) }.to_str().unwrap().to_owned();
            prop_assert_eq!(field, e.field);
            Ok(None)
        }
    }
}

/// One C-equals-Rust case of a robust FLC (v1 or v2): `*_init` accepts exactly what the Rust
/// constructor accepts (naming the same field), then every step (a reset after 20) gives the same
/// command and the same terms (`key` picks the compared terms, compared by their exact `Debug`
/// text, which round-trips every float).
macro_rules! robust_case {
    ($storage:ty, $params:ty, $ctrl:ty, $init:ident, $step:ident, $reset:ident, $terms:ident, $cterms:ty, $cp:expr, $seq:expr, $key:expr) => {{
        let mut s = MaybeUninit::<$storage>::uninit();
        let mut err = MaybeUninit::<FlcParamError>::uninit();
        // SAFETY: valid pointers to local memory.
        let r = unsafe { $init(s.as_mut_ptr(), &$cp, err.as_mut_ptr()) };
        let Some(mut c) = init_agrees(r, <$params>::try_from($cp).and_then(<$ctrl>::new), &err)? else { return Ok(()) };
        let key = $key;
        let bits = |t: $cterms| format!("{:?}", key(t)).replace("NaN", "nan");
        for (k, (has, d, v)) in $seq.into_iter().enumerate() {
            if k == 20 {
                // SAFETY: initialised storage.
                prop_assert_eq!(unsafe { $reset(s.as_mut_ptr()) }, FlcResult::Ok);
                c.reset();
            }
            let (mut out, mut terms) = (MaybeUninit::uninit(), MaybeUninit::uninit());
            // SAFETY: initialised storage, valid outputs.
            prop_assert_eq!(unsafe { $step(s.as_mut_ptr(), has, d, v, out.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: initialised storage, valid output.
            prop_assert_eq!(unsafe { $terms(s.as_ptr(), terms.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on Ok.
            let (got, terms) = unsafe { (out.assume_init(), terms.assume_init()) };
            prop_assert!(same_cmd(got, c.step(has.then_some(d), v)));
            prop_assert_eq!(bits(terms), bits((*c.terms()).into()));
        }
    }};
}

/// A C neighbour-tracker parameter struct: the defaults with some fields perturbed (possibly
/// invalid: NaN, out of range, `max_width < min_width`, `max_misses > 100`).
fn c_neighbour_params() -> impl Strategy<Value = FlcNeighbourParams> {
    let maybe = |lo: f64, hi: f64| prop::option::weighted(0.15, num(lo, hi));
    (
        (maybe(-1.0, 10.0), maybe(-0.5, 3.0), maybe(-1.0, 100.0), maybe(-0.5, 2.0)),
        (maybe(-1.0, 8.0), maybe(-0.5, 2.0), maybe(-0.5, 3.0), maybe(-1.0, 60.0)),
        (maybe(-0.5, 8.0), maybe(-1.0, 5.0), prop::option::weighted(0.15, 0u8..=120)),
    )
        .prop_map(
            |((band, min_width, max_range, wandering), (gate_x, gate_d, full_width, full_range), (max_width, lane_width, max_misses))| {
                let d = flc_neighbours_params_default();
                FlcNeighbourParams {
                    band: band.unwrap_or(d.band),
                    min_width: min_width.unwrap_or(d.min_width),
                    max_range: max_range.unwrap_or(d.max_range),
                    wandering: wandering.unwrap_or(d.wandering),
                    gate_x: gate_x.unwrap_or(d.gate_x),
                    gate_d: gate_d.unwrap_or(d.gate_d),
                    full_width: full_width.unwrap_or(d.full_width),
                    full_range: full_range.unwrap_or(d.full_range),
                    max_width: max_width.unwrap_or(d.max_width),
                    lane_width: lane_width.unwrap_or(d.lane_width),
                    max_misses: max_misses.unwrap_or(d.max_misses),
                }
            },
        )
}

/// Scan `k` of moving cars `(x, y, dx, dy, width)` (rear faces of 24 points): each car at
/// `(x + k dx, y + k dy)`; `nan` makes one point of each car NaN.
fn cars_scan(cars: &[(f64, f64, f64, f64, f64)], k: usize, nan: bool) -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    for &(x, y, dx, dy, w) in cars {
        let (x, y) = (x + k as f64 * dx, y + k as f64 * dy);
        for i in 0..24 {
            let px = if nan && i == 5 { f64::NAN } else { x + 0.01 * f64::from(i % 3) };
            pts.push([px, y - 0.5 * w + w * f64::from(i) / 23.0]);
        }
    }
    pts
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// The neighbour tracker through the C API (behind a C detector) equals the Rust tracker
    /// behind a Rust detector: `*_init` accepts what `NeighbourTracker::new` accepts (naming the
    /// same field), every update gives the same detection (bit for bit) and track count, with lost
    /// scans, NaN points and a reset after 20 scans.
    #[test]
    fn neighbours_c_equal_rust(
        cp in c_neighbour_params(),
        cars in prop::collection::vec((5.0..70.0, -6.0..6.0, -1.0..1.0, -0.3..0.3, 0.5..4.5), 0..4),
        scans in prop::collection::vec((prop::bool::weighted(0.1), 0u8..10), 4..40),
    ) {
        let mut s = MaybeUninit::<FlcNeighbours>::uninit();
        let mut err = MaybeUninit::<FlcParamError>::uninit();
        // SAFETY: valid pointers to local memory.
        let r = unsafe { flc_neighbours_init(s.as_mut_ptr(), &cp, err.as_mut_ptr()) };
        let Some(mut rust) = init_agrees(r, NeighbourParams::try_from(cp).and_then(NeighbourTracker::new), &err)? else { return Ok(()) };
        let mut cdet = Box::new(MaybeUninit::<FlcDetector>::uninit());
        let dp = flc_detector_params_default();
        // SAFETY: valid pointers.
        prop_assert_eq!(unsafe { flc_detector_init(cdet.as_mut_ptr(), &dp, null_mut()) }, FlcResult::Ok);
        let mut det = Box::new(<LeadDetector>::new(DetectorParams::default()).unwrap());
        for (k, (nan, lost)) in scans.into_iter().enumerate() {
            if k == 20 {
                // SAFETY: initialised storage.
                prop_assert_eq!(unsafe { flc_neighbours_reset(s.as_mut_ptr()) }, FlcResult::Ok);
                rust.reset();
            }
            let pts = if lost == 0 { Vec::new() } else { cars_scan(&cars, k, nan) };
            let mut dout = MaybeUninit::uninit();
            // SAFETY: initialised storage, valid points and output.
            prop_assert_eq!(unsafe { flc_detector_detect(cdet.as_mut_ptr(), pts.as_ptr().cast(), pts.len(), 0.0, dout.as_mut_ptr()) }, FlcResult::Ok);
            det.detect(&pts, 0.0);
            let mut out = MaybeUninit::uninit();
            // SAFETY: initialised storages, valid output.
            prop_assert_eq!(unsafe { flc_neighbours_update(s.as_mut_ptr(), cdet.as_ptr(), out.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on Ok.
            let got = unsafe { out.assume_init() };
            let want = rust.update(det.clusters());
            prop_assert_eq!(got.has_detection, want.is_some());
            prop_assert_eq!(got.tracks, rust.tracks().count());
            if let Some(w) = want {
                let g = got.detection;
                prop_assert!(same(g.x, w.position.x) && same(g.y, w.position.y) && same(g.distance, w.distance), "{g:?} {w:?}");
                prop_assert!(same(g.width, w.width) && same(g.depth, w.depth) && same(g.confidence, w.confidence) && g.points == w.points);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn fallback_c_equals_rust(
        cp in c_flc_params(),
        seq in prop::collection::vec((any::<bool>(), num(0.0, 80.0), num(-2.0, 40.0)), 0..48),
    ) {
        let mut s = MaybeUninit::<FlcFallback>::uninit();
        let mut err = MaybeUninit::<FlcParamError>::uninit();
        // SAFETY: valid pointers to local memory.
        let r = unsafe { flc_fallback_init(s.as_mut_ptr(), &cp, err.as_mut_ptr()) };
        let Some(mut c) = init_agrees(r, FlcParams::try_from(cp).and_then(FallbackController::new), &err)? else { return Ok(()) };
        for (has, d, v) in seq {
            let mut out = MaybeUninit::uninit();
            // SAFETY: initialised storage, valid output.
            prop_assert_eq!(unsafe { flc_fallback_step(s.as_mut_ptr(), has, d, v, out.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on Ok.
            let got = unsafe { out.assume_init() };
            prop_assert!(same_cmd(got, c.step(has.then_some(d), v)));
        }
    }

    #[test]
    fn robust_c_equals_rust(
        cp in c_robust_params(),
        seq in prop::collection::vec((any::<bool>(), num(0.0, 80.0), num(-2.0, 40.0)), 0..48),
    ) {
        robust_case!(FlcRobust, RobustFlcParams, RobustFallbackController, flc_robust_init, flc_robust_step, flc_robust_reset,
            flc_robust_terms, FlcRobustTerms, cp, seq, |t: FlcRobustTerms| (t.a, t.target_speed, t.latched));
    }

    #[test]
    fn robust2_c_equals_rust(
        cp in c_robust2_params(),
        seq in prop::collection::vec((any::<bool>(), num(0.0, 80.0), num(-2.0, 40.0)), 0..48),
    ) {
        robust_case!(FlcRobust2, RobustFlc2Params, RobustFallbackController2, flc_robust2_init, flc_robust2_step, flc_robust2_reset,
            flc_robust2_terms, FlcRobust2Terms, cp, seq, |t: FlcRobust2Terms| (t.a, t.distance, t.held, t.pending, t.latched));
    }

    #[test]
    fn pid_and_supervisor_c_equal_rust(
        kp in num(-0.5, 2.0),
        return_after in 0u32..6,
        seq in prop::collection::vec((any::<bool>(), num(0.0, 40.0), 0u32..30, any::<bool>(), num(0.0, 80.0), num(-2.0, 40.0), num(0.0, 0.2)), 0..64),
    ) {
        let mut pp = flc_pid_params_default();
        pp.far.kp = kp;
        let mut sp = flc_supervisor_params_default();
        sp.return_after = return_after;
        sp.pid = pp;
        let mut pid_s = MaybeUninit::<FlcPid>::uninit();
        let mut sup_s = MaybeUninit::<FlcSupervisor>::uninit();
        // SAFETY: valid pointers (the error struct is optional).
        let rp = unsafe { flc_pid_init(pid_s.as_mut_ptr(), &pp, null_mut()) };
        // SAFETY: as above.
        let rs = unsafe { flc_supervisor_init(sup_s.as_mut_ptr(), &sp, null_mut()) };
        let pid = PidController::new(pp.into());
        let sup = SupervisorParams::try_from(sp).and_then(Supervisor::new);
        prop_assert_eq!(rp == FlcResult::Ok, pid.is_ok());
        prop_assert_eq!(rs == FlcResult::Ok, sup.is_ok());
        let (Ok(mut pid), Ok(mut sup)) = (pid, sup) else { return Ok(()) };
        for (has_v2v, lead, seq_no, has_d, d, v, dt) in seq {
            let mut out = MaybeUninit::uninit();
            // SAFETY: initialised storage, valid output.
            prop_assert_eq!(unsafe { flc_pid_step(pid_s.as_mut_ptr(), lead, v, has_d, d, dt, out.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on Ok.
            let got = unsafe { out.assume_init() };
            prop_assert!(same_cmd(got, pid.step(lead, v, has_d.then_some(d), dt)));
            let mut so = MaybeUninit::uninit();
            let m = FlcV2vMessage { lead_speed: lead, seq: seq_no };
            // SAFETY: initialised storage, valid output.
            prop_assert_eq!(unsafe { flc_supervisor_step(sup_s.as_mut_ptr(), has_v2v, m, has_d, d, v, dt, so.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on Ok.
            let so = unsafe { so.assume_init() };
            let ro = sup.step(has_v2v.then_some(V2vMessage::speed_only(lead, seq_no)), has_d.then_some(d), v, dt);
            prop_assert!(same_cmd(so.command, ro.command) && same_cmd(so.flc, ro.flc) && same_cmd(so.pid, ro.pid));
            prop_assert_eq!((so.active as u8, so.reason as u8, so.switched, so.v2v_age_ticks, so.fresh_count, so.association as u8), (ro.active as u8, ro.reason as u8, ro.switched, ro.v2v_age_ticks, ro.fresh_count, ro.association as u8));
        }
    }

    #[test]
    fn pursuit_c_equals_rust(
        law in 0u8..3,
        seq in prop::collection::vec((any::<bool>(), num(-10.0, 100.0), num(-20.0, 20.0), num(-2.0, 40.0)), 0..32),
    ) {
        let mut p = flc_pursuit_params_default();
        p.law = law;
        let mut s = MaybeUninit::<FlcPursuit>::uninit();
        // SAFETY: valid pointers.
        let r = unsafe { flc_pursuit_init(s.as_mut_ptr(), &p, null_mut()) };
        let Ok(pp) = PurePursuitParams::try_from(p).and_then(PurePursuit::new) else {
            prop_assert_eq!(r, FlcResult::InvalidParams);
            return Ok(());
        };
        for (has, x, y, v) in seq {
            let mut out = MaybeUninit::uninit();
            // SAFETY: initialised storage, valid output.
            prop_assert_eq!(unsafe { flc_pursuit_step(s.as_ptr(), has, x, y, v, out.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on Ok.
            let c = unsafe { out.assume_init() };
            let rr = pp.step(has.then(|| Point2::new(x, y)), v);
            prop_assert!(same(c.steer, rr.steer) && same(c.alpha, rr.alpha) && c.status as u8 == rr.status as u8);
        }
    }
}
