//! Geometry helpers of the loop: steering along the centreline, the detector's grid
//! prefilter, the bumper gap, angle wrapping.

use flc_core::{LeadDetector, Point2, PurePursuit};

use crate::error::SimError;
use crate::track::Track;
use crate::vehicle::{VehicleParams, VehicleState};

/// Pure pursuit along the centreline for a scripted vehicle of wheelbase / steering limit `p`.
pub(super) fn centreline_pursuit(p: &VehicleParams) -> Result<PurePursuit, SimError> {
    Ok(PurePursuit::new(flc_core::PurePursuitParams {
        base_lookahead: 6.0,
        lookahead_gain: 0.8,
        law: flc_core::PursuitLaw::Standard,
        wheelbase: p.wheelbase,
        max_steer: p.max_steer,
    })?)
}

/// Steering along the track's centreline (plus `offset`, m, + left) with pure pursuit `pp`, for a
/// vehicle at `state` whose projection on the centreline is at `s`.
pub(super) fn centreline_steer(track: &Track, pp: &PurePursuit, state: &VehicleState, s: f64, offset: f64) -> f64 {
    let d_ahead = pp.lookahead(state.speed);
    let (px, py, _) = track.place(s + d_ahead, offset);
    let (gx, gy) = (px - state.x, py - state.y);
    let (c, sn) = (state.yaw.cos(), state.yaw.sin());
    let local = Point2::new(c * gx + sn * gy, -sn * gx + c * gy);
    pp.step(Some(local), state.speed).steer
}

/// The points of a scan the detector can use for a path of `curvature`: those within 1 cm of
/// the box holding its (bent) grid (plus any non-finite ones, which it counts). The detector ignores every other point (`cell_of` is
/// `None` for them), so its result is the same as on the whole scan, with less work: on a road
/// with guard rails about half the returns lie outside the grid. Scans longer than
/// `max_points` are passed whole (the detector truncates them).
pub(super) fn grid_points<'a>(
    det: &LeadDetector,
    params: &flc_core::DetectorParams,
    points: &'a [[f64; 2]],
    curvature: f64,
    buf: &'a mut Vec<[f64; 2]>,
) -> &'a [[f64; 2]] {
    if points.len() > params.max_points {
        return points;
    }
    let (x0, x1, y0, y1) = det.bounds(curvature);
    let (x0, x1, y0, y1) = (x0 - 0.01, x1 + 0.01, y0 - 0.01, y1 + 0.01);
    buf.clear();
    buf.extend(points.iter().filter(|[x, y]| !(x.is_finite() && y.is_finite()) || (*x >= x0 && *x <= x1 && *y >= y0 && *y <= y1)));
    buf
}

/// Bumper-to-bumper distance along the front vehicle's heading (the "gap"); to a body crossing the
/// back one's course (headings more than 45° apart), along the back one's heading to the front
/// body's extent along it (`front_length` x `front_width`, m).
pub(super) fn bumper_gap(front: &VehicleState, (front_length, front_width): (f64, f64), back: &VehicleState, back_length: f64) -> f64 {
    let (dx, dy) = (front.x - back.x, front.y - back.y);
    let rel = wrap_angle(front.yaw - back.yaw);
    if rel.is_nan() || rel.cos().abs() >= std::f64::consts::FRAC_1_SQRT_2 {
        let centre = dx * front.yaw.cos() + dy * front.yaw.sin();
        return centre - front_length / 2.0 - back_length / 2.0;
    }
    // A body crossing the back one's course (more than 45° apart, a pedestrian walking across):
    // along the back one's heading, to the front body's extent along it.
    let centre = dx * back.yaw.cos() + dy * back.yaw.sin();
    centre - 0.5 * (front_length * rel.cos().abs() + front_width * rel.sin().abs()) - back_length / 2.0
}

pub(super) fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn grid_prefilter_does_not_change_the_detection() {
        // Random scans with points inside, outside and within a few mm of the detector's grid:
        // the detector sees the same scan whether or not the points outside are dropped.
        let params = flc_core::DetectorParams::default();
        let mut a = <LeadDetector>::new(params).unwrap();
        let mut b = <LeadDetector>::new(params).unwrap();
        let (x0, x1, y0, y1) = a.bounds(0.0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut buf = Vec::new();
        for _ in 0..300 {
            let mut pts: Vec<[f64; 2]> = Vec::new();
            // A car somewhere ahead, rails, clutter, edge points.
            let (cx, cy) = (rng.random_range(3.0..190.0), rng.random_range(-5.0..5.0));
            for i in 0..30 {
                pts.push([cx + rng.random_range(-0.02..0.02), cy - 0.9 + 1.8 * f64::from(i) / 29.0]);
            }
            for _ in 0..300 {
                let x: f64 = rng.random_range(-2.0..220.0);
                pts.push([x, if rng.random_bool(0.5) { -3.15 } else { 6.65 } + rng.random_range(-0.03..0.03)]);
            }
            for _ in 0..40 {
                let e = rng.random_range(-0.005..0.005);
                pts.push(match rng.random_range(0..4) {
                    0 => [x0 + e, rng.random_range(y0..y1)],
                    1 => [x1 + e, rng.random_range(y0..y1)],
                    2 => [rng.random_range(x0..x1), y0 + e],
                    _ => [rng.random_range(x0..x1), y1 + e],
                });
            }
            let kappa = if rng.random_bool(0.2) { 0.0 } else { rng.random_range(-0.01..0.01) };
            let full = a.detect(&pts, kappa);
            let filtered = b.detect(grid_points(&b, &params, &pts, kappa, &mut buf), kappa);
            assert_eq!(full.detection, filtered.detection);
            assert_eq!(a.clusters(), b.clusters());
            assert!(buf.len() < pts.len());
        }
    }
}
