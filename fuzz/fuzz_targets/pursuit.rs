//! The pure-pursuit lateral controller on arbitrary parameters and lead positions.
#![no_main]

#[path = "common.rs"]
mod common;

use arbitrary::Arbitrary;
use common::{Num, Param};
use flc_core::{Point2, PurePursuit, PurePursuitParams, PursuitLaw, Status};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    params: [Param; 4],
    standard: bool,
    steps: Vec<(Option<(Num, Num)>, Num)>,
}

fuzz_target!(|inp: Input| {
    let d = PurePursuitParams::default();
    let [base, gain, wheelbase, max_steer] = inp.params;
    let p = PurePursuitParams {
        base_lookahead: base.get(d.base_lookahead, -1.0, 1100.0),
        lookahead_gain: gain.get(d.lookahead_gain, -1.0, 110.0),
        wheelbase: wheelbase.get(d.wheelbase, -1.0, 110.0),
        max_steer: max_steer.get(d.max_steer, -0.1, 1.7),
        law: if inp.standard { PursuitLaw::Standard } else { PursuitLaw::Paper },
    };
    let Ok(pp) = PurePursuit::new(p) else { return };
    for (lead, speed) in inp.steps.into_iter().take(256) {
        let lead = lead.map(|(x, y)| Point2::new(x.get(-20.0, 120.0), y.get(-30.0, 30.0)));
        let out = pp.step(lead, speed.get(-3.0, 80.0));
        assert!(out.steer.is_finite() && out.steer.abs() <= p.max_steer, "{out:?}");
        if out.status != Status::Ok {
            assert_eq!(out.steer, 0.0);
        }
    }
});
