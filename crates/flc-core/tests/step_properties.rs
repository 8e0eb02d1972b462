//! Properties of every step function on arbitrary *valid* parameters and arbitrary input
//! sequences (NaN, infinities, out-of-range values included), with enough cases to matter
//! (2048 per controller; the unit tests of each module add their own). Coverage-guided fuzzing of
//! the same functions lives in `fuzz/` (docs/firmware.md).

use flc_core::detector::CLUSTER_CAPACITY;
use flc_core::{
    ActiveController, DetectorParams, DistOverride, FallbackController, FirstFrame, FlcParams, LeadDetector, PidController, PidGains,
    PidParams, Point2, PurePursuit, PurePursuitParams, PursuitLaw, Reprojection, Status, Supervisor, SupervisorParams, V2vMessage,
};
use proptest::prelude::*;

/// Any double, with the interesting ones over-represented.
fn any_f64(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => lo..hi,
        1 => proptest::num::f64::ANY,
        1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, -1.0, 1e9, f64::MIN_POSITIVE]),
    ]
}

fn flc_params() -> impl Strategy<Value = FlcParams> {
    (
        (0.0f64..10.0, 0.0f64..100.0, 0.01f64..100.0, 0.0f64..10.0, 0.0f64..10.0, 0.1f64..1000.0),
        (-100.0f64..0.0, 0.0f64..10.0, 0.0f64..10.0, -1000.0f64..0.0, 0.0f64..100.0, 0.01f64..100.0),
        (0.5f64..1000.0, 1.0f64..1e6, 0.0f64..100.0, 0usize..3, any::<bool>(), any::<bool>()),
    )
        .prop_map(|(a, b, c)| FlcParams {
            time_gap: a.0,
            base_gap: a.1,
            c: a.2,
            scale_gain: a.3,
            scale_cap: a.4,
            bound_t: a.5,
            brake_threshold: b.0,
            shift_normal: b.1,
            shift_brake: b.2,
            override_dist: b.3,
            negative_multiplier: b.4,
            command_gain: b.5,
            max_speed: c.0,
            max_distance: c.1,
            fault_brake_step: c.2,
            dist_override: [DistOverride::Min, DistOverride::Replace, DistOverride::Off][c.3],
            clip_dist_s: c.4,
            first_frame: if c.5 { FirstFrame::Braking } else { FirstFrame::Steady },
        })
}

fn gains() -> impl Strategy<Value = PidGains> {
    (0.0f64..100.0, 0.0f64..100.0, 0.0f64..100.0).prop_map(|(kp, ki, kd)| PidGains { kp, ki, kd })
}

fn pid_params() -> impl Strategy<Value = PidParams> {
    ((0.0f64..10.0, 0.0f64..100.0, gains(), gains()), (-100.0f64..1000.0, 0.0f64..100.0, 0.01f64..100.0, 0.5f64..1000.0, 0.0f64..100.0))
        .prop_map(|((time_gap, base_gap, far, near), (near_margin, integral_limit, command_gain, max_speed, fault_brake_step))| PidParams {
            time_gap,
            base_gap,
            far,
            near,
            near_margin,
            integral_limit,
            command_gain,
            max_speed,
            fault_brake_step,
            ..PidParams::paper()
        })
}

fn check_command(out: flc_core::LongitudinalCommand, own_speed: f64, max_speed: f64) -> Result<(), TestCaseError> {
    prop_assert!(out.speed.is_finite() && out.speed >= 0.0 && out.speed <= max_speed, "{out:?}");
    prop_assert!(out.accel.is_finite(), "{out:?}");
    if !out.status.is_ok() {
        // A fault never accelerates.
        prop_assert!(out.accel <= 0.0);
        if own_speed.is_finite() {
            prop_assert!(out.speed <= own_speed.max(0.0));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    #[test]
    fn flc_any_params_any_inputs(
        p in flc_params(),
        seq in prop::collection::vec((prop::option::of(any_f64(0.0, 80.0)), any_f64(-2.0, 40.0)), 1..64),
    ) {
        let mut c = FallbackController::new(p).unwrap();
        let mut fresh = FallbackController::new(p).unwrap();
        let mut outs = Vec::new();
        for &(d, v) in &seq {
            let out = c.step(d, v);
            check_command(out, v, p.max_speed)?;
            if out.status == Status::Ok {
                prop_assert!(d.is_some_and(f64::is_finite) && v.is_finite());
            }
            outs.push(out);
        }
        // After reset the controller behaves exactly like a new one.
        c.reset();
        for (&(d, v), _) in seq.iter().zip(&outs) {
            prop_assert_eq!(c.step(d, v), fresh.step(d, v));
        }
    }

    #[test]
    fn pid_any_params_any_inputs(
        p in pid_params(),
        seq in prop::collection::vec((any_f64(0.0, 40.0), any_f64(-2.0, 40.0), prop::option::of(any_f64(0.0, 80.0)), any_f64(0.001, 0.2)), 1..64),
    ) {
        let mut c = PidController::new(p).unwrap();
        for (lead, own, d, dt) in seq {
            let out = c.step(lead, own, d, dt);
            check_command(out, own, p.max_speed)?;
            prop_assert!(c.terms().integral.abs() <= p.integral_limit);
        }
    }

    #[test]
    fn supervisor_any_inputs(
        max_age_ticks in 0u32..10,
        return_after in 1u32..10,
        bumpless in any::<bool>(),
        seq in prop::collection::vec((prop::option::of((any_f64(0.0, 40.0), 0u32..50)), prop::option::of(any_f64(0.0, 80.0)), any_f64(-2.0, 40.0)), 1..128),
    ) {
        let params = SupervisorParams { max_age_ticks, return_after, bumpless, ..SupervisorParams::default() };
        let mut s = Supervisor::new(params).unwrap();
        for (msg, d, own) in seq {
            let out = s.step(msg.map(|(lead_speed, seq)| V2vMessage::speed_only(lead_speed, seq)), d, own, 0.05);
            check_command(out.command, own, params.flc.max_speed)?;
            let expected = match out.active {
                ActiveController::Flc => out.flc,
                ActiveController::Pid => out.pid,
            };
            prop_assert_eq!(out.command, expected);
            if out.active == ActiveController::Pid {
                prop_assert!(out.v2v_age_ticks <= max_age_ticks);
            }
        }
    }

    #[test]
    fn pursuit_any_inputs(
        base in 0.1f64..100.0,
        gain in 0.0f64..10.0,
        wheelbase in 0.5f64..10.0,
        max_steer in 0.01f64..1.5,
        standard in any::<bool>(),
        seq in prop::collection::vec((prop::option::of((any_f64(-10.0, 100.0), any_f64(-20.0, 20.0))), any_f64(-2.0, 40.0)), 1..32),
    ) {
        let law = if standard { PursuitLaw::Standard } else { PursuitLaw::Paper };
        let pp = PurePursuit::new(PurePursuitParams { base_lookahead: base, lookahead_gain: gain, law, wheelbase, max_steer }).unwrap();
        for (lead, v) in seq {
            let out = pp.step(lead.map(|(x, y)| Point2::new(x, y)), v);
            prop_assert!(out.steer.is_finite() && out.steer.abs() <= max_steer, "{out:?}");
            if !out.status.is_ok() {
                prop_assert_eq!(out.steer, 0.0);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// `reinit` (in place, used by the C API) gives the same detector as `new`, and the outputs
    /// respect the documented bounds for any parameters and any points.
    #[test]
    fn detector_reinit_equals_new(
        cell_size in 0.05f64..0.5,
        dilation_radius in 0u8..4,
        min_cluster_points in 1usize..8,
        max_points in 1usize..2000,
        refined in any::<bool>(),
        pts in prop::collection::vec((any_f64(-2.0, 75.0), any_f64(-7.0, 7.0)), 0..800),
        curvature in any_f64(-0.03, 0.03),
    ) {
        let reprojection = if refined { Reprojection::PointRefined } else { Reprojection::CellCenter };
        let p = DetectorParams { cell_size, dilation_radius, min_cluster_points, max_points, reprojection, ..DetectorParams::default() };
        let pts: Vec<[f64; 2]> = pts.into_iter().map(|(x, y)| [x, y]).collect();
        let mut a = Box::new(<LeadDetector>::new(p).unwrap());
        let mut b = Box::new(<LeadDetector>::new(DetectorParams::default()).unwrap());
        b.detect(&pts, 0.01);
        b.reinit(p).unwrap();
        prop_assert!(b.clusters().is_empty());
        let out = a.detect(&pts, curvature);
        prop_assert_eq!(out, b.detect(&pts, curvature));
        prop_assert_eq!(a.clusters(), b.clusters());
        prop_assert!(out.clusters <= CLUSTER_CAPACITY);
        prop_assert!(out.points_used + out.points_rejected <= pts.len().min(max_points));
        if let Some(d) = out.detection {
            prop_assert!(d.distance.is_finite() && d.position.y.is_finite() && (0.0..=1.0).contains(&d.confidence));
        }
    }
}
