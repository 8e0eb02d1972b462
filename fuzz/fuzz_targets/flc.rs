//! The FLC on arbitrary parameters and input sequences, through the Rust API and the C API.
#![no_main]

#[path = "common.rs"]
mod common;

use arbitrary::Arbitrary;
use common::{Num, Param, same};
use flc_core::capi::{FlcFallback, FlcLongitudinalCommand, FlcResult, flc_fallback_init, flc_fallback_step};
use flc_core::{DistOverride, FallbackController, FirstFrame, FlcParams, Status};
use libfuzzer_sys::fuzz_target;
use std::mem::MaybeUninit;

#[derive(Arbitrary, Debug)]
struct Input {
    params: [Param; 8],
    dist_override: u8,
    first_frame: bool,
    clip: bool,
    steps: Vec<(Option<Num>, Num)>,
}

fuzz_target!(|inp: Input| {
    let d = FlcParams::paper();
    let [time_gap, base_gap, bound_t, brake_threshold, negative_multiplier, command_gain, max_speed, fault_brake_step] = inp.params;
    let p = FlcParams {
        time_gap: time_gap.get(d.time_gap, -1.0, 12.0),
        base_gap: base_gap.get(d.base_gap, -1.0, 120.0),
        bound_t: bound_t.get(d.bound_t, -1.0, 1100.0),
        brake_threshold: brake_threshold.get(d.brake_threshold, -110.0, 1.0),
        negative_multiplier: negative_multiplier.get(d.negative_multiplier, -1.0, 110.0),
        command_gain: command_gain.get(d.command_gain, -1.0, 110.0),
        max_speed: max_speed.get(d.max_speed, -1.0, 1100.0),
        fault_brake_step: fault_brake_step.get(d.fault_brake_step, -1.0, 110.0),
        dist_override: [DistOverride::Min, DistOverride::Replace, DistOverride::Off][usize::from(inp.dist_override % 3)],
        first_frame: if inp.first_frame { FirstFrame::Braking } else { FirstFrame::Steady },
        clip_dist_s: inp.clip,
        ..d
    };
    let mut storage = MaybeUninit::<FlcFallback>::uninit();
    let cp = p.into();
    // SAFETY: valid pointers to local memory.
    let init = unsafe { flc_fallback_init(storage.as_mut_ptr(), &cp, std::ptr::null_mut()) };
    let Ok(mut c) = FallbackController::new(p) else {
        assert_eq!(init, FlcResult::InvalidParams);
        return;
    };
    assert_eq!(init, FlcResult::Ok);
    for (dist, speed) in inp.steps.into_iter().take(256) {
        let dist = dist.map(|n| n.get(-5.0, 120.0));
        let v = speed.get(-3.0, p.max_speed + 5.0);
        let out = c.step(dist, v);
        assert!(out.speed.is_finite() && out.speed >= 0.0 && out.speed <= p.max_speed, "{out:?}");
        assert!(out.accel.is_finite(), "{out:?}");
        if out.status == Status::Ok {
            assert!(dist.is_some_and(f64::is_finite) && v.is_finite());
        } else {
            // A fault never accelerates.
            assert!(out.accel <= 0.0);
            if v.is_finite() {
                assert!(out.speed <= v.max(0.0));
            }
        }
        let mut co = MaybeUninit::<FlcLongitudinalCommand>::uninit();
        // SAFETY: initialised above, valid output pointer.
        let r = unsafe { flc_fallback_step(storage.as_mut_ptr(), dist.is_some(), dist.unwrap_or(0.0), v, co.as_mut_ptr()) };
        assert_eq!(r, FlcResult::Ok);
        // SAFETY: written on FlcResult::Ok.
        let co = unsafe { co.assume_init() };
        assert!(same(co.speed, out.speed) && same(co.accel, out.accel) && co.status as u8 == out.status as u8);
    }
});
