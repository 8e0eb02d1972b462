//! Signal helpers of the metrics: sample durations, windowed jerk, weighted means.

/// Tolerance on time comparisons, s.
pub(super) const TIME_EPS: f64 = 1e-9;

/// Braking harder than this is uncomfortable (`time_hard_braking`), m/s².
pub const HARD_BRAKING: f64 = 3.5;

pub(super) fn finite_or(x: f64, fallback: f64) -> f64 {
    if x.is_finite() { x } else { fallback }
}

/// Duration covered by each sample: sample `i >= 1` covers `(t[i-1], t[i]]`; sample 0 covers one
/// step before it (`t[1] - t[0]`; 0 for a single sample). Negative or non-finite spans count 0.
pub(super) fn step_durations(t: &[f64]) -> Vec<f64> {
    let span = |a: f64, b: f64| {
        let d = b - a;
        if d.is_finite() && d > 0.0 { d } else { 0.0 }
    };
    let mut out = Vec::with_capacity(t.len());
    for i in 0..t.len() {
        out.push(match i {
            0 => t.get(1).map_or(0.0, |&t1| span(t[0], t1)),
            _ => span(t[i - 1], t[i]),
        });
    }
    out
}

/// `max |a(t_i) - a(t_k)| / (t_i - t_k)` where `t_k` is the latest sample at least `window`
/// before `t_i`: the mean jerk over a window of (at least) `window` seconds, i.e. the step jerk
/// smoothed by a box filter of that width. 0 if the series is shorter than the window.
pub(super) fn max_abs_jerk(t: &[f64], a: &[f64], window: f64) -> f64 {
    let mut k = 0usize;
    let mut best = 0.0f64;
    for i in 1..t.len().min(a.len()) {
        while k + 1 < i && t[i] - t[k + 1] >= window - TIME_EPS {
            k += 1;
        }
        let span = t[i] - t[k];
        if span.is_finite() && span > 0.0 && span >= window - TIME_EPS {
            let j = ((a[i] - a[k]) / span).abs();
            if j.is_finite() {
                best = best.max(j);
            }
        }
    }
    best
}

/// Weighted mean of the finite values; equal weights if the weights sum to 0; `None` if empty.
pub(super) fn weighted_mean(items: impl Iterator<Item = (f64, f64)>) -> Option<f64> {
    let (mut sw, mut swx, mut n, mut sx) = (0.0, 0.0, 0usize, 0.0);
    for (w, x) in items.filter(|(_, x)| x.is_finite()) {
        sw += w;
        swx += w * x;
        n += 1;
        sx += x;
    }
    match n {
        0 => None,
        _ if sw > 0.0 => Some(swx / sw),
        _ => Some(sx / n as f64),
    }
}
