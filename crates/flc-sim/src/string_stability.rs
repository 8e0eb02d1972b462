//! String-stability measures of a platoon (`docs/platoon.md`).
//!
//! Vehicles are numbered 0 (the lead) to N; follower `k` follows vehicle `k - 1`. Per follower:
//!
//! * gap error `e_k(t) = gap_k(t) - g*_k(v_k(t))`, with `g*` the spacing policy the string is
//!   formed with ([`reference_gap`]: the FLC's `D_d + F_shift` for
//!   `flc`, the PID's desired distance for `pid` / `pipeline`, else the recorded `desired_gap`);
//! * speed error `s_k(t) = v_{k-1}(t) - v_k(t)` (0 in equilibrium and at standstill).
//!
//! Over the window `[t0, t1]` (from the lead's brake onset, or `window_start`, to the end of the
//! run), each error has a peak `||x||_inf = max |x|` and an energy `||x||_2 = sqrt(sum x_i^2 dt_i)`.
//! For each consecutive pair of followers `(k - 1, k)`, `k = 2..N`, the ratios
//! `||e_k|| / ||e_{k-1}||` and `||s_k|| / ||s_{k-1}||` (both norms) measure amplification down the
//! string (Ploeg, van de Wouw & Nijmeijer, IEEE TCST 22(2), 2014: `L_p` string stability).
//! The peak accelerations `max |a_k|` and their ratios for `k = 1..N` are reported too.
//!
//! Frequency response: with the lead's speed `v_0 = v + A sin(w t)`, every vehicle's speed
//! settles to a sinusoid at `w`; fitting `c + a sin(w t) + b cos(w t)` to each over whole periods
//! gives amplitudes `|V_k|` and `|Gamma_k(jw)| = |V_k| / |V_{k-1}|`, `k = 1..N`.
//!
//! Verdict: the string is stable if no follower collided, every ratio is `<= 1 + tolerance`
//! (a pair whose follower peak stays below the noise floor, `gap_floor` / `speed_floor`, counts
//! as stable whatever its ratio) and, when measured, every `|Gamma| <= 1 + tolerance`.

use serde::{Deserialize, Serialize};

use flc_core::LongitudinalController;

use crate::metrics::FollowerRun;
use crate::platoon::StringStabilitySpec;

/// `|Gamma(jw)|` at one frequency.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GammaPoint {
    /// Drive frequency, Hz.
    pub freq_hz: f64,
    /// Fitted speed amplitude of each vehicle (0 = lead), m/s.
    pub amplitude: Vec<f64>,
    /// `|Gamma_k| = amplitude[k] / amplitude[k - 1]` for followers `k = 1..N` (index `k - 1`).
    pub gamma: Vec<f64>,
    /// Phase of `Gamma_k` (follower relative to the vehicle in front), degrees (negative = lag).
    pub phase_deg: Vec<f64>,
    /// Whether follower `k`'s `|Gamma_k|` counts: its amplitude is above `gamma_floor`.
    pub counted: Vec<bool>,
    /// `max |Gamma_k|` over the counted followers (NaN, serialised `null`, if none counts).
    pub max_gamma: f64,
    /// Some follower collided during the run (the fit is then meaningless).
    pub collision: bool,
}

/// The string-stability measures of one platoon run. Lists indexed by follower hold follower
/// `k` at index `k - 1`; pair lists `(k - 1, k)`, `k = 2..N`, hold pair `k` at index `k - 2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StringStability {
    /// Start of the time-domain window, s.
    pub window_start: f64,
    /// End of the time-domain window (end of the run), s.
    pub window_end: f64,
    /// Ratios up to `1 + tolerance` count as stable.
    pub tolerance: f64,
    /// Peak |gap error| per follower, m.
    pub gap_error_peak: Vec<f64>,
    /// L2 norm of the gap error per follower, m s^0.5.
    pub gap_error_l2: Vec<f64>,
    /// Peak |speed error| (`v_{k-1} - v_k`) per follower, m/s.
    pub speed_error_peak: Vec<f64>,
    /// L2 norm of the speed error per follower, m s^-0.5.
    pub speed_error_l2: Vec<f64>,
    /// Peak |acceleration| per vehicle (0 = lead), m/s².
    pub accel_peak: Vec<f64>,
    /// Peak gap-error ratio per pair of followers `(k - 1, k)`, `k = 2..N`.
    pub gap_ratio_peak: Vec<f64>,
    /// L2 gap-error ratio per pair of followers.
    pub gap_ratio_l2: Vec<f64>,
    /// Peak speed-error ratio per pair of followers.
    pub speed_ratio_peak: Vec<f64>,
    /// L2 speed-error ratio per pair of followers.
    pub speed_ratio_l2: Vec<f64>,
    /// Peak acceleration ratio `accel_peak[k] / accel_peak[k - 1]`, `k = 1..N` (reported, not part
    /// of the verdict).
    pub accel_ratio_peak: Vec<f64>,
    /// Largest gap / speed ratio (both norms) over the pairs whose follower peak is above the
    /// noise floor; `None` without such a pair.
    pub max_ratio: Option<f64>,
    /// Followers that touched the vehicle in front.
    pub collisions: Vec<u32>,
    /// Followers whose supervisor fell back because the vehicle in front was not their V2V sender
    /// (reason `not_associated`, e.g. a car cut in ahead of them; issue 25). Absent if none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_associated: Vec<u32>,
    /// No collision and every counted ratio `<= 1 + tolerance`.
    pub time_domain_stable: bool,
    /// `|Gamma(jw)|` per measured frequency (empty unless measured).
    pub frequency_response: Vec<GammaPoint>,
    /// Largest counted `|Gamma|` over frequencies and followers, if measured.
    pub max_gamma: Option<f64>,
    /// Every counted `|Gamma| <= 1 + tolerance` (and no collision in those runs); `None` if not
    /// measured.
    pub frequency_domain_stable: Option<bool>,
    /// The verdict: time domain stable and, if measured, frequency domain stable.
    pub string_stable: bool,
}

/// The signals the measures are computed from (all sampled at `t`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Signals {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Gap error of each follower (index `k - 1`), m.
    pub gap_error: Vec<Vec<f64>>,
    /// Speed error of each follower, m/s.
    pub speed_error: Vec<Vec<f64>>,
    /// Acceleration of each vehicle (index 0 = lead), m/s².
    pub accel: Vec<Vec<f64>>,
}

/// The spacing policy a string of `law`s is formed with at own speed `v`, m (the law's
/// `formation_gap`: the FLC's `D_d + F_shift`, the PID's desired distance for the PID and the
/// pipeline, a baseline's steady-state gap); `None` where it is not finite.
pub fn reference_gap(law: &dyn LongitudinalController, v: f64) -> Option<f64> {
    let g = law.formation_gap(v);
    g.is_finite().then_some(g)
}

impl Signals {
    /// The signals of a platoon run (`runs` and `laws` per follower): gap errors against each
    /// follower's [`reference_gap`] (the recorded `desired_gap` where it has none), speed errors
    /// against the vehicle in front, accelerations.
    pub fn of(runs: &[FollowerRun], laws: &[&dyn LongitudinalController]) -> Self {
        let t = runs.first().map(|r| r.series.t.clone()).unwrap_or_default();
        let mut sig = Signals { t, ..Signals::default() };
        if let Some(first) = runs.first() {
            sig.accel.push(first.series.lead_accel.clone());
        }
        for (r, law) in runs.iter().zip(laws) {
            let s = &r.series;
            let e: Vec<f64> =
                (0..s.len()).map(|i| s.gap[i] - reference_gap(*law, s.follower_speed[i]).unwrap_or(s.desired_gap[i])).collect();
            sig.gap_error.push(e);
            sig.speed_error.push(s.lead_speed.iter().zip(&s.follower_speed).map(|(a, b)| a - b).collect());
            sig.accel.push(s.follower_accel.clone());
        }
        sig
    }
}

/// Peak `max |x|` and L2 norm `sqrt(sum x_i^2 dt_i)` of `x` over the samples with `t` in
/// `[t0, t1]`; `dt_i = t_i - t_{i-1}` (the first sample weighs like the second). NaN samples are
/// skipped.
pub fn norms(t: &[f64], x: &[f64], t0: f64, t1: f64) -> (f64, f64) {
    let (mut peak, mut energy) = (0.0f64, 0.0f64);
    let n = t.len().min(x.len());
    for i in 0..n {
        if !(t[i] >= t0 - 1e-9 && t[i] <= t1 + 1e-9 && x[i].is_finite()) {
            continue;
        }
        let dt = match i {
            0 => t.get(1).map_or(0.0, |t1| t1 - t[0]),
            _ => t[i] - t[i - 1],
        };
        peak = peak.max(x[i].abs());
        energy += x[i] * x[i] * dt.max(0.0);
    }
    (peak, energy.sqrt())
}

fn ratio(num: f64, den: f64) -> f64 {
    if den > 0.0 {
        num / den
    } else if num > 0.0 {
        f64::INFINITY
    } else {
        1.0
    }
}

/// Fits `c + a sin(w t) + b cos(w t)` (least squares) to the samples with `t` in `[t0, t1]`;
/// returns `(amplitude sqrt(a² + b²), phase atan2(b, a) in rad, offset c)`. `None` with fewer
/// than 3 samples or a singular system.
pub fn fit_sinusoid(t: &[f64], x: &[f64], freq_hz: f64, t0: f64, t1: f64) -> Option<(f64, f64, f64)> {
    let w = std::f64::consts::TAU * freq_hz;
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    let mut count = 0;
    for (&ti, &xi) in t.iter().zip(x) {
        if !(ti >= t0 - 1e-9 && ti <= t1 + 1e-9 && xi.is_finite()) {
            continue;
        }
        let phi = [1.0, (w * ti).sin(), (w * ti).cos()];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += phi[i] * phi[j];
            }
            r[i] += phi[i] * xi;
        }
        count += 1;
    }
    if count < 3 {
        return None;
    }
    let [c, a, b] = solve3(m, r)?;
    Some((a.hypot(b), b.atan2(a), c))
}

/// Solves the 3x3 system `m x = r` by Gaussian elimination with partial pivoting.
fn solve3(mut m: [[f64; 3]; 3], mut r: [f64; 3]) -> Option<[f64; 3]> {
    let scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    for col in 0..3 {
        let pivot = (col..3).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[pivot][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, pivot);
        r.swap(col, pivot);
        let pivot_row = m[col];
        for row in col + 1..3 {
            let f = m[row][col] / pivot_row[col];
            for (x, p) in m[row].iter_mut().zip(pivot_row).skip(col) {
                *x -= f * p;
            }
            r[row] -= f * r[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|k| m[row][k] * x[k]).sum();
        x[row] = (r[row] - s) / m[row][row];
    }
    Some(x)
}

fn wrap_deg(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

/// `|Gamma|` at `freq_hz` from the vehicles' speeds (index 0 = lead) over `[t0, t1]`; followers
/// whose amplitude is below `floor` (m/s) do not count in `max_gamma` (NaN if none counts).
pub fn gamma_from_speeds(t: &[f64], speeds: &[&[f64]], freq_hz: f64, t0: f64, t1: f64, floor: f64) -> GammaPoint {
    let fits: Vec<(f64, f64)> =
        speeds.iter().map(|v| fit_sinusoid(t, v, freq_hz, t0, t1).map_or((f64::NAN, f64::NAN), |(a, p, _)| (a, p))).collect();
    let amplitude: Vec<f64> = fits.iter().map(|f| f.0).collect();
    let gamma: Vec<f64> = fits.windows(2).map(|w| ratio(w[1].0, w[0].0)).collect();
    let phase_deg: Vec<f64> = fits.windows(2).map(|w| wrap_deg((w[1].1 - w[0].1).to_degrees())).collect();
    let counted: Vec<bool> = amplitude.iter().skip(1).map(|&a| a > floor).collect();
    let max_gamma = gamma.iter().zip(&counted).filter(|(_, c)| **c).map(|(g, _)| *g).fold(f64::NAN, f64::max);
    GammaPoint { freq_hz, amplitude, gamma, phase_deg, counted, max_gamma, collision: false }
}

impl StringStability {
    /// The time-domain measures of `sig` over `[t0, t1]` (`collisions`: followers that collided).
    pub fn from_signals(sig: &Signals, t0: f64, t1: f64, spec: &StringStabilitySpec, collisions: Vec<u32>) -> Self {
        let t = &sig.t;
        let each = |xs: &[Vec<f64>]| -> (Vec<f64>, Vec<f64>) { xs.iter().map(|x| norms(t, x, t0, t1)).unzip() };
        let (gap_error_peak, gap_error_l2) = each(&sig.gap_error);
        let (speed_error_peak, speed_error_l2) = each(&sig.speed_error);
        let (accel_peak, _) = each(&sig.accel);
        let pairs = |v: &[f64]| -> Vec<f64> { v.windows(2).map(|w| ratio(w[1], w[0])).collect() };
        let gap_ratio_peak = pairs(&gap_error_peak);
        let gap_ratio_l2 = pairs(&gap_error_l2);
        let speed_ratio_peak = pairs(&speed_error_peak);
        let speed_ratio_l2 = pairs(&speed_error_l2);
        let accel_ratio_peak = pairs(&accel_peak);
        // Ratios that count: the follower's peak error is above the noise floor.
        let mut counted = Vec::new();
        for (i, (rp, r2)) in gap_ratio_peak.iter().zip(&gap_ratio_l2).enumerate() {
            if gap_error_peak.get(i + 1).is_some_and(|&p| p > spec.gap_floor) {
                counted.extend([*rp, *r2]);
            }
        }
        for (i, (rp, r2)) in speed_ratio_peak.iter().zip(&speed_ratio_l2).enumerate() {
            if speed_error_peak.get(i + 1).is_some_and(|&p| p > spec.speed_floor) {
                counted.extend([*rp, *r2]);
            }
        }
        let max_ratio = counted.iter().copied().reduce(f64::max);
        let time_domain_stable = collisions.is_empty() && counted.iter().all(|&r| r <= 1.0 + spec.tolerance);
        Self {
            window_start: t0,
            window_end: t1,
            tolerance: spec.tolerance,
            gap_error_peak,
            gap_error_l2,
            speed_error_peak,
            speed_error_l2,
            accel_peak,
            gap_ratio_peak,
            gap_ratio_l2,
            speed_ratio_peak,
            speed_ratio_l2,
            accel_ratio_peak,
            max_ratio,
            collisions,
            not_associated: Vec::new(),
            time_domain_stable,
            frequency_response: Vec::new(),
            max_gamma: None,
            frequency_domain_stable: None,
            string_stable: time_domain_stable,
        }
    }

    /// The measures of a platoon run: `sig` its signals ([`Signals::of`]), `runs` per follower,
    /// `brake_onset` the lead's.
    pub fn measure(spec: &StringStabilitySpec, sig: &Signals, runs: &[FollowerRun], brake_onset: Option<f64>) -> Self {
        let t0 = spec.window_start.or(brake_onset).unwrap_or(0.0);
        let t1 = sig.t.last().copied().unwrap_or(0.0);
        let collisions = runs.iter().enumerate().filter(|(_, r)| r.collision.is_some()).map(|(k, _)| k as u32 + 1).collect();
        let mut out = Self::from_signals(sig, t0, t1, spec, collisions);
        let not_associated = flc_core::SwitchReason::NotAssociated as u8;
        out.not_associated =
            runs.iter().enumerate().filter(|(_, r)| r.series.reason.contains(&not_associated)).map(|(k, _)| k as u32 + 1).collect();
        out
    }

    /// Adds the frequency response and updates the verdict.
    pub fn set_frequency_response(&mut self, points: Vec<GammaPoint>) {
        if points.is_empty() {
            self.frequency_response = points;
            self.max_gamma = None;
            self.frequency_domain_stable = None;
            self.string_stable = self.time_domain_stable;
            return;
        }
        let max = points.iter().map(|p| p.max_gamma).fold(f64::NAN, f64::max);
        // NaN (no follower counted) passes: nothing was amplified above the noise floor.
        let ok = points.iter().all(|p| !p.collision && (p.max_gamma.is_nan() || p.max_gamma <= 1.0 + self.tolerance));
        self.max_gamma = max.is_finite().then_some(max);
        self.frequency_domain_stable = Some(ok);
        self.string_stable = self.time_domain_stable && ok;
        self.frequency_response = points;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    fn times(n: usize) -> Vec<f64> {
        (1..=n).map(|i| i as f64 * DT).collect()
    }

    /// A smooth bump of height `h` centred at `c`, 2 s wide (zero outside).
    fn bump(t: f64, c: f64, h: f64) -> f64 {
        let u = (t - c) / 1.0;
        if u.abs() < 1.0 { h * (0.5 + 0.5 * (std::f64::consts::PI * u).cos()) } else { 0.0 }
    }

    fn synthetic(gain: f64, n_followers: usize) -> Signals {
        // Follower k's errors: gain^(k-1) times a bump delayed by k * 0.5 s (a whole number of
        // samples), entirely inside the window.
        let t = times(3000);
        let err =
            |k: usize, h: f64| -> Vec<f64> { t.iter().map(|&ti| gain.powi(k as i32 - 1) * bump(ti, 5.0 + 0.5 * k as f64, h)).collect() };
        Signals {
            gap_error: (1..=n_followers).map(|k| err(k, 2.0)).collect(),
            speed_error: (1..=n_followers).map(|k| err(k, 1.5)).collect(),
            accel: (0..=n_followers)
                .map(|k| t.iter().map(|&ti| -6.0 * gain.powi(k as i32) * bump(ti, 5.0 + 0.5 * k as f64, 1.0)).collect())
                .collect(),
            t,
        }
    }

    #[test]
    fn ratios_of_exact_gains() {
        let spec = StringStabilitySpec::default();
        for gain in [0.5, 2.0] {
            let ss = StringStability::from_signals(&synthetic(gain, 5), 0.0, 30.0, &spec, vec![]);
            assert_eq!(ss.gap_ratio_peak.len(), 4);
            assert_eq!(ss.accel_ratio_peak.len(), 5);
            for list in [&ss.gap_ratio_peak, &ss.gap_ratio_l2, &ss.speed_ratio_peak, &ss.speed_ratio_l2, &ss.accel_ratio_peak] {
                for r in list.iter() {
                    assert!((r - gain).abs() < 1e-12, "gain {gain}: {list:?}");
                }
            }
            // Peak of follower 1's gap error: the bump's height.
            assert!((ss.gap_error_peak[0] - 2.0).abs() < 1e-12);
            // L2 of a raised-cosine bump of height h and half-width 1 s: h sqrt(3/4) (Riemann sum).
            assert!((ss.gap_error_l2[0] - 2.0 * 0.75f64.sqrt()).abs() < 1e-6, "{}", ss.gap_error_l2[0]);
            let stable = gain < 1.0;
            assert_eq!(ss.time_domain_stable, stable);
            assert_eq!(ss.string_stable, stable);
            assert!((ss.max_ratio.unwrap() - gain).abs() < 1e-12);
        }
    }

    #[test]
    fn tolerance_floor_and_collisions() {
        let spec = StringStabilitySpec::default();
        // 1 % amplification is within the 2 % tolerance.
        assert!(StringStability::from_signals(&synthetic(1.01, 4), 0.0, 30.0, &spec, vec![]).time_domain_stable);
        assert!(!StringStability::from_signals(&synthetic(1.03, 4), 0.0, 30.0, &spec, vec![]).time_domain_stable);
        // Amplified noise below the floors does not count.
        let mut sig = synthetic(2.0, 3);
        for x in sig.gap_error.iter_mut().chain(sig.speed_error.iter_mut()) {
            for v in x.iter_mut() {
                *v *= 0.01;
            }
        }
        let ss = StringStability::from_signals(&sig, 0.0, 30.0, &spec, vec![]);
        assert!(ss.time_domain_stable && ss.max_ratio.is_none(), "{ss:?}");
        // A collision is never stable.
        assert!(!StringStability::from_signals(&synthetic(0.5, 3), 0.0, 30.0, &spec, vec![2]).string_stable);
        // The window cuts the signals: only follower 1's bump (at 5.5 s) is inside [0, 5.7].
        let ss = StringStability::from_signals(&synthetic(0.5, 3), 0.0, 5.7, &spec, vec![]);
        assert!(ss.gap_error_peak[0] > 1.9 && ss.gap_error_peak[1] < 1.0);
    }

    #[test]
    fn frequency_response_of_exact_gains() {
        for gain in [0.5f64, 2.0] {
            for f in [0.05, 0.2, 0.5] {
                let w = std::f64::consts::TAU * f;
                let t = times((4.0 / f / DT) as usize);
                let speeds: Vec<Vec<f64>> =
                    (0..5).map(|k| t.iter().map(|&ti| 30.0 + 1.3 * gain.powi(k) * (w * ti - 0.4 * k as f64).sin()).collect()).collect();
                let refs: Vec<&[f64]> = speeds.iter().map(Vec::as_slice).collect();
                let t1 = *t.last().unwrap();
                let g = gamma_from_speeds(&t, &refs, f, t1 - 3.0 / f, t1, 0.05);
                assert_eq!(g.gamma.len(), 4);
                assert!((g.amplitude[0] - 1.3).abs() < 1e-9, "{:?}", g.amplitude);
                for (gk, ph) in g.gamma.iter().zip(&g.phase_deg) {
                    assert!((gk - gain).abs() < 1e-9, "f {f} gain {gain}: {:?}", g.gamma);
                    assert!((ph + 0.4f64.to_degrees()).abs() < 1e-6, "{:?}", g.phase_deg);
                }
                assert!((g.max_gamma - gain).abs() < 1e-9);
                let mut ss = StringStability::from_signals(&synthetic(0.5, 4), 0.0, 30.0, &StringStabilitySpec::default(), vec![]);
                ss.set_frequency_response(vec![g]);
                assert_eq!(ss.frequency_domain_stable, Some(gain < 1.0));
                assert_eq!(ss.string_stable, gain < 1.0);
            }
        }
    }

    #[test]
    fn fit_ignores_offset_and_noise_free_phase() {
        let f = 0.1;
        let t = times(5000);
        let x: Vec<f64> = t.iter().map(|&ti| 7.0 + 2.0 * (std::f64::consts::TAU * f * ti + 0.3).sin()).collect();
        let (a, p, c) = fit_sinusoid(&t, &x, f, 0.0, 50.0).unwrap();
        assert!((a - 2.0).abs() < 1e-9 && (p - 0.3).abs() < 1e-9 && (c - 7.0).abs() < 1e-9, "{a} {p} {c}");
        assert!(fit_sinusoid(&t[..2], &x[..2], f, 0.0, 50.0).is_none());
    }

    #[test]
    fn norms_by_hand() {
        let t = [0.1, 0.2, 0.3, 0.4];
        let x = [1.0, -3.0, f64::NAN, 2.0];
        let (p, l2) = norms(&t, &x, 0.0, 1.0);
        assert_eq!(p, 3.0);
        assert!((l2 - ((1.0 + 9.0 + 4.0) * 0.1f64).sqrt()).abs() < 1e-12);
        let (p, _) = norms(&t, &x, 0.15, 0.25);
        assert_eq!(p, 3.0);
    }
}
