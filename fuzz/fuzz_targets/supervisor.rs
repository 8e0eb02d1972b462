//! The supervisor (FLC + PID + switching) on arbitrary V2V / LiDAR / speed sequences.
#![no_main]

#[path = "common.rs"]
mod common;

use arbitrary::Arbitrary;
use common::Num;
use flc_core::{ActiveController, Supervisor, SupervisorParams, V2vMessage};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    max_age_ticks: u8,
    return_after: u8,
    bumpless: bool,
    steps: Vec<(Option<(Num, u32)>, Option<Num>, Num, Num)>,
}

fuzz_target!(|inp: Input| {
    let params = SupervisorParams {
        max_age_ticks: u32::from(inp.max_age_ticks % 16),
        return_after: u32::from(inp.return_after % 16),
        bumpless: inp.bumpless,
        ..SupervisorParams::default()
    };
    let Ok(mut s) = Supervisor::new(params) else {
        assert_eq!(params.return_after, 0);
        return;
    };
    let max = params.flc.max_speed.min(params.pid.max_speed);
    for (v2v, dist, own, dt) in inp.steps.into_iter().take(512) {
        let msg = v2v.map(|(n, seq)| V2vMessage::speed_only(n.get(-3.0, 75.0), seq));
        let out = s.step(msg, dist.map(|n| n.get(-5.0, 120.0)), own.get(-3.0, 75.0), dt.get(-0.1, 0.5));
        assert!(out.command.speed.is_finite() && out.command.speed >= 0.0 && out.command.speed <= max, "{out:?}");
        assert!(out.command.accel.is_finite());
        let expected = match out.active {
            ActiveController::Flc => out.flc,
            ActiveController::Pid => out.pid,
        };
        assert_eq!(out.command, expected);
        if out.active == ActiveController::Pid {
            assert!(out.v2v_age_ticks <= params.max_age_ticks);
        }
    }
});
