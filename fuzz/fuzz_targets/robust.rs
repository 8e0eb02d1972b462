//! The robust FLC v1 and v2 on arbitrary parameters and input sequences, through the Rust API and
//! the C API (issue 24), with v2's comfort layer never above its laws, and v2's odometry variant
//! (Rust API) on arbitrary odometer readings.
#![no_main]

#[path = "common.rs"]
mod common;

use arbitrary::Arbitrary;
use common::{Num, Param, same};
use flc_core::capi::{
    FlcLongitudinalCommand, FlcResult, FlcRobust, FlcRobust2, flc_robust_init, flc_robust_step, flc_robust2_init, flc_robust2_step,
};
use flc_core::{
    ComfortParams, FirstObject, LongitudinalCommand, OdometryFallbackController, OdometryFlcParams, RobustFallbackController, RobustFallbackController2,
    RobustFlc2Params, RobustFlcParams, Status,
};
use libfuzzer_sys::fuzz_target;
use std::mem::MaybeUninit;

#[derive(Arbitrary, Debug)]
struct Input {
    law: [Param; 8],
    rules: [Param; 7],
    comfort: [Param; 7],
    min_speed: Param,
    unknown_first: bool,
    travelled: Vec<Option<Num>>,
    resets: u8,
    steps: Vec<(Option<Num>, Num)>,
}

/// What every command of either version satisfies.
fn check(out: LongitudinalCommand, dist: Option<f64>, v: f64, max_speed: f64) {
    assert!(out.speed.is_finite() && out.speed >= 0.0 && out.speed <= max_speed, "{out:?}");
    assert!(out.accel.is_finite(), "{out:?}");
    if out.status == Status::Ok {
        assert!(dist.is_some_and(f64::is_finite) && v.is_finite());
    }
    if matches!(out.status, Status::InvalidSpeed | Status::InvalidDistance) {
        // A fault never accelerates.
        assert!(out.accel <= 0.0, "{out:?}");
    }
}

fn same_cmd(c: FlcLongitudinalCommand, r: LongitudinalCommand) -> bool {
    same(c.speed, r.speed) && same(c.accel, r.accel) && c.status as u8 == r.status as u8
}

fuzz_target!(|inp: Input| {
    let d = RobustFlcParams::documented();
    let [time_gap, brake_gain, max_decel, envelope_decel, envelope_reaction, reveal_jump, max_speed, fault_brake_step] = inp.law;
    let law = RobustFlcParams {
        time_gap: time_gap.get(d.time_gap, -1.0, 12.0),
        brake_gain: brake_gain.get(d.brake_gain, -1.0, 60.0),
        max_decel: max_decel.get(d.max_decel, -1.0, 60.0),
        envelope_decel: envelope_decel.get(d.envelope_decel, -1.0, 60.0),
        envelope_reaction: envelope_reaction.get(d.envelope_reaction, -1.0, 12.0),
        reveal_jump: reveal_jump.get(d.reveal_jump, -1.0, 60.0),
        max_speed: max_speed.get(d.max_speed, -1.0, 1100.0),
        fault_brake_step: fault_brake_step.get(d.fault_brake_step, -1.0, 110.0),
        first_object: if inp.unknown_first { FirstObject::Unknown } else { FirstObject::Lead },
        ..d
    };
    let d2 = RobustFlc2Params::documented();
    let [sight_distance, sight_decel, release_speed, release_closing, approach_time_gap, firm_error, firm_gain] = inp.rules;
    let dc = ComfortParams::documented();
    let [memory, response_time, clock_accel, accel, decel, fade_speed, max_decel] = inp.comfort;
    let comfort = ComfortParams {
        memory: memory.get(dc.memory, -1.0, 110.0),
        response_time: response_time.get(dc.response_time, -1.0, 110.0),
        clock_accel: clock_accel.get(dc.clock_accel, -1.0, 25.0),
        accel: accel.get(dc.accel, -1.0, 25.0),
        decel: decel.get(dc.decel, -1.0, 25.0),
        fade_speed: fade_speed.get(dc.fade_speed, -1.0, 110.0),
        max_decel: max_decel.get(dc.max_decel, -1.0, 60.0),
    };
    let p2 = RobustFlc2Params {
        law,
        sight_distance: sight_distance.get(d2.sight_distance, -1.0, 11000.0),
        sight_decel: sight_decel.get(d2.sight_decel, -1.0, 60.0),
        release_speed: release_speed.get(d2.release_speed, -1.0, 1100.0),
        release_closing: release_closing.get(d2.release_closing, -1.0, 110.0),
        approach_time_gap: approach_time_gap.get(d2.approach_time_gap, -1.0, 110.0),
        firm_error: firm_error.get(d2.firm_error, -1.0, 1100.0),
        firm_gain: firm_gain.get(d2.firm_gain, -1.0, 1100.0),
        comfort,
    };
    let (mut s1, mut s2) = (MaybeUninit::<FlcRobust>::uninit(), MaybeUninit::<FlcRobust2>::uninit());
    let (c1, c2) = (law.into(), p2.into());
    // SAFETY: valid pointers to local memory.
    let (i1, i2) = unsafe {
        (flc_robust_init(s1.as_mut_ptr(), &c1, std::ptr::null_mut()), flc_robust2_init(s2.as_mut_ptr(), &c2, std::ptr::null_mut()))
    };
    let mut r1 = RobustFallbackController::new(law).ok();
    let mut r2 = RobustFallbackController2::new(p2).ok();
    let po = OdometryFlcParams { min_speed: inp.min_speed.get(OdometryFlcParams::documented().min_speed, -1.0, 110.0) };
    // The variant, and without odometry a v2 twin on the same frames.
    let mut ro = OdometryFallbackController::new(p2, po).ok().zip(RobustFallbackController2::new(p2).ok());
    let mut odometer = 0.0;
    assert_eq!(i1 == FlcResult::Ok, r1.is_some());
    assert_eq!(i2 == FlcResult::Ok, r2.is_some());
    for (k, (dist, speed)) in inp.steps.into_iter().take(256).enumerate() {
        if inp.resets != 0 && k % usize::from(inp.resets) == usize::from(inp.resets) - 1 {
            r1.as_mut().map(RobustFallbackController::reset);
            r2.as_mut().map(RobustFallbackController2::reset);
            if let Some((o, t)) = ro.as_mut() {
                o.reset();
                t.reset();
            }
            // SAFETY: initialised when the Rust controller exists.
            unsafe {
                if r1.is_some() {
                    reset_v1(s1.as_mut_ptr());
                }
                if r2.is_some() {
                    reset_v2(s2.as_mut_ptr());
                }
            }
        }
        let dist = dist.map(|n| n.get(-5.0, 260.0));
        let v = speed.get(-3.0, law.max_speed + 5.0);
        let mut co = MaybeUninit::<FlcLongitudinalCommand>::uninit();
        if let Some((o, twin)) = ro.as_mut() {
            // Mostly a growing odometer, sometimes missing or arbitrary.
            let s = match inp.travelled.get(k).copied().flatten() {
                Some(n) if k % 7 == 3 => Some(n.get(-1e6, 1e6)),
                Some(n) => {
                    odometer += n.get(0.0, 5.0);
                    Some(odometer)
                }
                None => None,
            };
            let out = o.step(dist, v, s);
            check(out, dist, v, law.max_speed);
            // The comfort layer never commands more than v2's laws.
            assert!(out.status != Status::Ok || out.accel <= o.terms().a_law, "{out:?} {:?}", o.terms());
            let base = twin.step(dist, v);
            assert_eq!(out.status, base.status);
        }
        if let Some(c) = r1.as_mut() {
            let out = c.step(dist, v);
            check(out, dist, v, law.max_speed);
            // SAFETY: initialised above, valid output pointer.
            assert_eq!(unsafe { flc_robust_step(s1.as_mut_ptr(), dist.is_some(), dist.unwrap_or(0.0), v, co.as_mut_ptr()) }, FlcResult::Ok);
            // SAFETY: written on FlcResult::Ok.
            assert!(same_cmd(unsafe { co.assume_init() }, out));
        }
        if let Some(c) = r2.as_mut() {
            let out = c.step(dist, v);
            check(out, dist, v, law.max_speed);
            // On a usable frame v2 asks for at most the law's deceleration (or `sight_decel`); a
            // frame it handles as missed (a jump pending confirmation) applies the law at the last
            // accepted distance and never accelerates.
            if out.status == Status::Ok {
                assert!(out.accel <= c.terms().a_law, "{out:?} {:?}", c.terms());
                assert!(out.accel >= -law.max_decel.max(p2.sight_decel) - 1e-9, "{out:?} {:?}", c.terms());
                assert!(!c.terms().held || out.accel <= 0.0, "{out:?} {:?}", c.terms());
            }
            // SAFETY: initialised above, valid output pointer.
            assert_eq!(
                unsafe { flc_robust2_step(s2.as_mut_ptr(), dist.is_some(), dist.unwrap_or(0.0), v, co.as_mut_ptr()) },
                FlcResult::Ok
            );
            // SAFETY: written on FlcResult::Ok.
            assert!(same_cmd(unsafe { co.assume_init() }, out));
        }
    }
});

/// `flc_robust_reset`, result checked.
unsafe fn reset_v1(s: *mut FlcRobust) {
    // SAFETY: caller contract.
    assert_eq!(unsafe { flc_core::capi::flc_robust_reset(s) }, FlcResult::Ok);
}

/// `flc_robust2_reset`, result checked.
unsafe fn reset_v2(s: *mut FlcRobust2) {
    // SAFETY: caller contract.
    assert_eq!(unsafe { flc_core::capi::flc_robust2_reset(s) }, FlcResult::Ok);
}
