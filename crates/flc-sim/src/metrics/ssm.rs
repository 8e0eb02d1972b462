//! Post-encroachment time of a cut-in (`Metrics::pet`).
//!
//! The series records, per sample, the gap to and the speed of the vehicle in front of the
//! follower (the nearest vehicle in its path), not *which* vehicle that is. A cut-in shows as a
//! gap that drops, within one sample, well below what the previous sample predicts for the same
//! vehicle: a vehicle entered the follower's path between it and the vehicle it followed. That is
//! what [`min_cut_in_pet`] detects and measures.

/// Speeds as the distance integral reads them: negative and non-finite count 0, m/s.
fn speed(v: f64) -> f64 {
    if v.is_finite() { v.max(0.0) } else { 0.0 }
}

/// Time from `t[0]` until a vehicle whose speed is `v` (linear between samples) has covered `d`
/// metres, s; `None` if it does not within the samples. Within the sample interval where the
/// distance is reached, `d` is solved exactly for the linear speed:
/// `v0 τ + a τ² / 2 = r` ⇒ `τ = 2 r / (v0 + sqrt(v0² + 2 a r))`. Time spans that are not
/// positive and finite count 0 (as in the sample durations of the other metrics).
fn time_to_cover(t: &[f64], v: &[f64], d: f64) -> Option<f64> {
    t.first()?;
    if d <= 0.0 {
        return Some(0.0);
    }
    let (mut covered, mut elapsed) = (0.0, 0.0);
    for j in 1..t.len().min(v.len()) {
        let dt = t[j] - t[j - 1];
        if !(dt.is_finite() && dt > 0.0) {
            continue;
        }
        let (v0, v1) = (speed(v[j - 1]), speed(v[j]));
        let seg = 0.5 * (v0 + v1) * dt;
        if covered + seg >= d {
            let r = d - covered;
            let a = (v1 - v0) / dt;
            let root = (v0 * v0 + 2.0 * a * r).max(0.0).sqrt();
            let tau = if v0 + root > 0.0 { (2.0 * r / (v0 + root)).clamp(0.0, dt) } else { dt };
            return Some(elapsed + tau);
        }
        covered += seg;
        elapsed += dt;
    }
    None
}

/// Smallest post-encroachment time over the cut-ins of a series, s; `None` without a cut-in or if
/// the follower reached no cut-in's encroachment point before the series ended.
///
/// Sample `c >= 1` is a **cut-in** if its gap is more than `drop` below the gap predicted from
/// sample `c - 1` for the same vehicle, `ĝ = g[c-1] + Δ_c (v_l[c-1] + v_l[c] − v_f[c-1] − v_f[c]) / 2`
/// (exact for speeds linear within the step). At `t[c]` the new vehicle in front has its rear
/// bumper at the **encroachment point** `P`, `g[c]` ahead of the follower's front bumper along
/// its path. PET is the time from `t[c]` (the encroacher occupies `P` and leaves it forward) to
/// the follower's front bumper reaching `P`: the smallest `τ` with
/// `∫_{t[c]}^{t[c]+τ} v_f dt = max(g[c], 0)` (speed linear between samples). A cut-out (the gap
/// jumps up) is not an encroachment.
pub(super) fn min_cut_in_pet(t: &[f64], gap: &[f64], lead_speed: &[f64], follower_speed: &[f64], drop: f64) -> Option<f64> {
    let n = t.len().min(gap.len()).min(lead_speed.len()).min(follower_speed.len());
    let mut best: Option<f64> = None;
    for c in 1..n {
        let dt = t[c] - t[c - 1];
        if !(dt.is_finite() && dt > 0.0) {
            continue;
        }
        let predicted = gap[c - 1] + dt * (lead_speed[c - 1] + lead_speed[c] - follower_speed[c - 1] - follower_speed[c]) / 2.0;
        if !(predicted.is_finite() && gap[c].is_finite() && predicted - gap[c] > drop) {
            continue;
        }
        if let Some(pet) = time_to_cover(&t[c..n], &follower_speed[c..n], gap[c].max(0.0)) {
            best = Some(best.map_or(pet, |b: f64| b.min(pet)));
        }
    }
    best
}
