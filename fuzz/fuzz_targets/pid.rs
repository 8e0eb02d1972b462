//! The PID gap controller on arbitrary parameters and input sequences.
#![no_main]

#[path = "common.rs"]
mod common;

use arbitrary::Arbitrary;
use common::{Num, Param};
use flc_core::{PidController, PidGains, PidParams, Status};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    params: [Param; 10],
    steps: Vec<(Num, Num, Option<Num>, Num)>,
    resets: u8,
}

fuzz_target!(|inp: Input| {
    let d = PidParams::paper();
    let [time_gap, kp, ki, kd, nkp, nki, nkd, integral_limit, near_margin, max_speed] = inp.params;
    let p = PidParams {
        time_gap: time_gap.get(d.time_gap, -1.0, 12.0),
        far: PidGains { kp: kp.get(d.far.kp, -1.0, 110.0), ki: ki.get(d.far.ki, -1.0, 110.0), kd: kd.get(d.far.kd, -1.0, 110.0) },
        near: PidGains { kp: nkp.get(d.near.kp, -1.0, 110.0), ki: nki.get(d.near.ki, -1.0, 110.0), kd: nkd.get(d.near.kd, -1.0, 110.0) },
        integral_limit: integral_limit.get(d.integral_limit, -1.0, 110.0),
        near_margin: near_margin.get(d.near_margin, -110.0, 1100.0),
        max_speed: max_speed.get(d.max_speed, -1.0, 1100.0),
        ..d
    };
    let Ok(mut c) = PidController::new(p) else { return };
    for (k, (lead, own, dist, dt)) in inp.steps.into_iter().take(256).enumerate() {
        if inp.resets != 0 && k % usize::from(inp.resets) == 0 {
            c.reset();
        }
        let v = own.get(-3.0, p.max_speed + 5.0);
        let out = c.step(lead.get(-3.0, p.max_speed + 5.0), v, dist.map(|n| n.get(-5.0, 120.0)), dt.get(-0.1, 0.5));
        assert!(out.speed.is_finite() && out.speed >= 0.0 && out.speed <= p.max_speed, "{out:?}");
        assert!(out.accel.is_finite(), "{out:?}");
        assert!(c.terms().integral.abs() <= p.integral_limit);
        if out.status != Status::Ok {
            assert!(out.accel <= 0.0);
            if v.is_finite() {
                assert!(out.speed <= v.max(0.0));
            }
        }
        // Bumpless preset never panics and stays bounded.
        let preset = c.preset_output(v, v);
        assert!(preset.is_nan() || (preset >= 0.0 && preset <= p.max_speed));
    }
});
