//! Per-run metrics computed from the per-step time series.
//!
//! The closed loop pushes one [`StepRecord`] per physics step into a [`Series`]; at the end
//! [`Metrics::compute`] turns the series (plus the collision reported by the physics engine) into
//! the numbers of the results table. Every metric is defined precisely, with units and formula, in
//! `docs/v2v-and-metrics.md`. The computation never panics: empty series, NaN samples and columns
//! of unequal length (if edited by hand) are all handled.

mod params;
mod records;
mod signal;

use serde::{Deserialize, Serialize};

pub use params::MetricsParams;
pub use records::{CollisionInfo, ContactRecord, FollowerRun, HitObject, ObjectKind};
pub use signal::HARD_BRAKING;
use signal::{TIME_EPS, finite_or, max_abs_jerk, step_durations, weighted_mean};

pub use crate::series::{ACTIVE_FLC, ACTIVE_PID, Series, StepRecord};

/// The metrics of one run. Field names are a contract (JSON output, Python, results table);
/// definitions in `docs/v2v-and-metrics.md`. `Option`s serialise as `null`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// The vehicles touched.
    pub collision: bool,
    /// Relative impact speed, m/s (0 without collision).
    pub impact_speed: f64,
    /// Time of the first contact, s.
    pub collision_time: Option<f64>,
    /// Smallest bumper-to-bumper gap, m (NaN, serialised `null`, for an empty series).
    pub min_gap: f64,
    /// Gap at the end of the run if both vehicles stand still and they did not collide, m.
    pub final_clearance: Option<f64>,
    /// Smallest time to collision `gap / (v_follower - v_lead)` over the closing samples, s
    /// (`None` if the follower never closed in).
    pub min_ttc: Option<f64>,
    /// Strongest braking of the follower, m/s² (positive; 0 if it never braked).
    pub max_decel: f64,
    /// Largest deceleration rate to avoid a crash, `DRAC = (v_follower - v_lead)² / (2 gap)`,
    /// over the closing samples with a positive gap, m/s² (0 if never closing).
    pub max_drac: f64,
    /// Time the follower braked harder than 3.5 m/s² (the comfort limit), s.
    pub time_hard_braking: f64,
    /// Largest absolute jerk of the follower over a `jerk_window` (0.1 s), m/s³.
    pub max_jerk: f64,
    /// RMS of `gap - desired_gap` during steady following, m (`None` if never steady).
    pub gap_error_rms: Option<f64>,
    /// Time spent in steady following (the samples of `gap_error_rms`), s.
    pub steady_time: f64,
    /// Mean absolute heading error w.r.t. the lane centreline while moving, deg.
    pub rot_error_deg: Option<f64>,
    /// Mean absolute lateral offset from the lane centreline while moving, m.
    pub trans_error_m: Option<f64>,
    /// Time driven by the PID, s.
    pub time_pid: f64,
    /// Time driven by the FLC, s.
    pub time_flc: f64,
    /// Changes of the active controller.
    pub switches: u32,
    /// Time covered by the series, s.
    pub duration: f64,
}

/// The field names of `v`'s serialised form, in order (serde writes struct fields in
/// declaration order; the JSON text keeps it).
fn field_names<T: Serialize>(v: &T) -> Vec<String> {
    struct Keys;
    impl<'de> serde::de::Visitor<'de> for Keys {
        type Value = Vec<String>;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("a map")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut keys = Vec::new();
            while let Some(k) = map.next_key::<String>()? {
                map.next_value::<serde::de::IgnoredAny>()?;
                keys.push(k);
            }
            Ok(keys)
        }
    }
    let text = serde_json::to_string(v).unwrap_or_default();
    serde::Deserializer::deserialize_map(&mut serde_json::Deserializer::from_str(&text), Keys).unwrap_or_default()
}

impl Metrics {
    /// The metric names, in the order of `scenario --json` and of the sweep CSV's metric
    /// columns: the struct's fields (derived, not listed).
    pub fn names() -> &'static [String] {
        static NAMES: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
        NAMES.get_or_init(|| field_names(&Metrics::compute(&Series::default(), None)))
    }

    /// Computes the metrics with the default thresholds.
    pub fn compute(series: &Series, collision: Option<CollisionInfo>) -> Metrics {
        Self::compute_with(series, collision, &MetricsParams::default())
    }

    /// Computes the metrics with explicit thresholds.
    pub fn compute_with(s: &Series, collision: Option<CollisionInfo>, p: &MetricsParams) -> Metrics {
        let collision = collision.as_ref();
        let n = s.len();
        let t = &s.t[..n];
        let dts = step_durations(t);
        let duration: f64 = dts.iter().sum();

        // Collision.
        let impact_speed = collision.map_or(0.0, |c| finite_or(c.impact_speed, 0.0).max(0.0));
        let collision_time = collision.map(|c| c.time).filter(|x| x.is_finite());

        // Gap, TTC.
        let min_gap = s.gap[..n].iter().copied().filter(|g| g.is_finite()).fold(f64::NAN, f64::min);
        let mut min_ttc: Option<f64> = None;
        let mut max_drac: f64 = 0.0;
        for i in 0..n {
            let (gap, closing) = (s.gap[i], s.follower_speed[i] - s.lead_speed[i]);
            if !gap.is_finite() || !closing.is_finite() {
                continue;
            }
            if gap > 0.0 && closing > p.ttc_min_closing {
                max_drac = max_drac.max(closing * closing / (2.0 * gap));
            }
            let ttc = if gap <= 0.0 {
                0.0
            } else if closing > p.ttc_min_closing {
                gap / closing
            } else {
                continue;
            };
            min_ttc = Some(min_ttc.map_or(ttc, |m| m.min(ttc)));
        }

        // Final clearance.
        let final_clearance = match n.checked_sub(1) {
            Some(last) if collision.is_none() => {
                let still = s.follower_speed[last].abs() < p.standstill_speed && s.lead_speed[last].abs() < p.standstill_speed;
                Some(s.gap[last]).filter(|g| still && g.is_finite())
            }
            _ => None,
        };

        // Decel and jerk.
        let accel = &s.follower_accel[..n];
        let max_decel = accel.iter().copied().filter(|a| a.is_finite()).fold(0.0, |m: f64, a| m.max(-a));
        let max_jerk = max_abs_jerk(t, accel, p.jerk_window);
        let time_hard_braking = accel.iter().zip(&dts).filter(|(a, _)| **a < -HARD_BRAKING).fold(0.0, |acc, (_, d)| acc + d);

        // Steady following.
        let mut run_start: Option<f64> = None;
        let (mut sq_sum, mut steady_time, mut steady_n, mut sq_sum_n) = (0.0, 0.0, 0usize, 0.0);
        for i in 0..n {
            let (vl, vf, al) = (s.lead_speed[i], s.follower_speed[i], s.lead_accel[i]);
            let err = s.gap[i] - s.desired_gap[i];
            let ok = t[i].is_finite()
                && err.is_finite()
                && (vf - vl).abs() < p.steady_speed_diff
                && al.abs() < p.steady_lead_accel
                && vl >= p.steady_min_speed;
            if !ok {
                run_start = None;
                continue;
            }
            let start = *run_start.get_or_insert(t[i]);
            if t[i] - start >= p.steady_min_time - TIME_EPS {
                sq_sum += dts[i] * err * err;
                steady_time += dts[i];
                sq_sum_n += err * err;
                steady_n += 1;
            }
        }
        let gap_error_rms = match steady_n {
            0 => None,
            _ if steady_time > 0.0 => Some((sq_sum / steady_time).sqrt()),
            k => Some((sq_sum_n / k as f64).sqrt()),
        };

        // Tracking errors while moving.
        let moving = |i: usize| s.follower_speed[i] >= p.tracking_min_speed;
        let rot_error_deg = weighted_mean((0..n).filter(|&i| moving(i)).map(|i| (dts[i], s.heading_error[i].abs().to_degrees())));
        let trans_error_m = weighted_mean((0..n).filter(|&i| moving(i)).map(|i| (dts[i], s.lateral_offset[i].abs())));

        // Controller shares and switches.
        let active = &s.active[..n];
        let time_of = |code: u8| active.iter().zip(&dts).filter(|(a, _)| **a == code).fold(0.0, |acc, (_, d)| acc + d);
        let switches = active.windows(2).filter(|w| w[0] != w[1]).count();

        Metrics {
            collision: collision.is_some(),
            impact_speed,
            collision_time,
            min_gap,
            final_clearance,
            min_ttc,
            max_decel,
            max_drac,
            time_hard_braking,
            max_jerk,
            gap_error_rms,
            steady_time,
            rot_error_deg,
            trans_error_m,
            time_pid: time_of(ACTIVE_PID),
            time_flc: time_of(ACTIVE_FLC),
            switches: u32::try_from(switches).unwrap_or(u32::MAX),
            duration,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A contact with the vehicle in front (as a run reports it).
    fn crash(time: f64, impact_speed: f64, lead_speed: f64, follower_speed: f64) -> CollisionInfo {
        CollisionInfo {
            time,
            impact_speed,
            lead_speed,
            follower_speed,
            object: HitObject::vehicle(0),
            other_speed: lead_speed,
            impact_speed_normal: impact_speed,
            point: [0.0, 0.0],
            normal: [1.0, 0.0],
        }
    }

    const DT: f64 = 0.01;

    #[test]
    fn metric_names_are_the_fields_in_order() {
        let names = Metrics::names();
        assert_eq!(names.first().map(String::as_str), Some("collision"));
        assert_eq!(names.last().map(String::as_str), Some("duration"));
        let json = serde_json::to_value(Metrics::compute(&Series::default(), None)).expect("json");
        let obj = json.as_object().expect("object");
        assert_eq!(names.len(), obj.len());
        assert!(names.iter().all(|n| obj.contains_key(n)));
        // Declaration order, not alphabetical.
        let pos = |n: &str| names.iter().position(|x| x == n);
        assert!(pos("min_gap") < pos("final_clearance") && pos("final_clearance") < pos("max_decel"));
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// A series of `n` steps at `DT` (t = DT, 2 DT, ...) built by `f(t)` from a neutral record.
    fn series(n: usize, f: impl Fn(f64, &mut StepRecord)) -> Series {
        let mut s = Series::default();
        for i in 1..=n {
            let t = i as f64 * DT;
            let mut r = StepRecord {
                t,
                lead_speed: 10.0,
                follower_speed: 10.0,
                gap: 20.0,
                desired_gap: 20.0,
                detected_distance: f64::NAN,
                v2v_age: f64::NAN,
                ..StepRecord::default()
            };
            f(t, &mut r);
            s.push(r);
        }
        s
    }

    #[test]
    fn empty_series_gives_neutral_metrics_without_panicking() {
        let m = Metrics::compute(&Series::default(), None);
        assert!(!m.collision);
        assert!(m.min_gap.is_nan());
        assert_eq!((m.min_ttc, m.final_clearance, m.gap_error_rms, m.rot_error_deg, m.trans_error_m), (None, None, None, None, None));
        assert_eq!((m.max_decel, m.max_jerk, m.time_pid, m.time_flc, m.duration, m.switches), (0.0, 0.0, 0.0, 0.0, 0.0, 0));
        // JSON: NaN and None become null.
        let j = serde_json::to_value(&m).unwrap();
        assert!(j["min_gap"].is_null() && j["min_ttc"].is_null());
        // A single sample and a collision on an empty series do not panic either.
        let one = series(1, |_, _| {});
        let m = Metrics::compute(&one, Some(crash(0.0, f64::NAN, 0.0, 0.0)));
        assert_eq!((m.duration, m.impact_speed, m.max_jerk), (0.0, 0.0, 0.0));
        let m = Metrics::compute(&Series::default(), Some(crash(1.0, 3.0, 0.0, 3.0)));
        assert!(m.collision && m.impact_speed == 3.0 && m.collision_time == Some(1.0));
    }

    #[test]
    fn constant_closing_speed_gives_known_ttc() {
        // Lead at 10 m/s, follower at 15 m/s: closing at 5 m/s from a 50 m gap to 5 m over 9 s.
        let s = series(900, |t, r| {
            r.follower_speed = 15.0;
            r.gap = 50.0 - 5.0 * t;
        });
        let m = Metrics::compute(&s, None);
        assert!(close(m.min_gap, 5.0, 1e-9), "{}", m.min_gap);
        assert!(close(m.min_ttc.unwrap(), 1.0, 1e-9), "{:?}", m.min_ttc);
        // Down to contact: TTC 0.
        let s = series(1000, |t, r| {
            r.follower_speed = 15.0;
            r.gap = 50.0 - 5.0 * t;
        });
        assert!(close(Metrics::compute(&s, None).min_ttc.unwrap(), 0.0, 1e-9));
        // Opening gap: no TTC.
        let s = series(100, |t, r| {
            r.follower_speed = 5.0;
            r.gap = 20.0 + 5.0 * t;
        });
        assert_eq!(Metrics::compute(&s, None).min_ttc, None);
    }

    #[test]
    fn drac_and_hard_braking_time() {
        // Closing at 5 m/s down to a 5 m gap: DRAC = 25 / (2 * 5) = 2.5 m/s².
        let s = series(900, |t, r| {
            r.follower_speed = 15.0;
            r.gap = 50.0 - 5.0 * t;
            // Braking at 4 m/s² (beyond the 3.5 comfort limit) from 2 s to 5 s.
            r.follower_accel = if (2.0..5.0).contains(&t) { -4.0 } else { -1.0 };
        });
        let m = Metrics::compute(&s, None);
        assert!(close(m.max_drac, 2.5, 1e-9), "{}", m.max_drac);
        assert!(close(m.time_hard_braking, 3.0, 0.011), "{}", m.time_hard_braking);
    }

    #[test]
    fn decel_profile_gives_known_max_decel_and_jerk() {
        // a = 0 until 2 s, ramps to -6 m/s² over 0.6 s (jerk -10), holds, ramps back to 0 over
        // 0.3 s from 5 s (jerk +20).
        let a = |t: f64| {
            if t <= 2.0 {
                0.0
            } else if t <= 2.6 {
                -10.0 * (t - 2.0)
            } else if t <= 5.0 {
                -6.0
            } else if t <= 5.3 {
                -6.0 + 20.0 * (t - 5.0)
            } else {
                0.0
            }
        };
        let s = series(800, |t, r| r.follower_accel = a(t));
        let m = Metrics::compute(&s, None);
        assert!(close(m.max_decel, 6.0, 1e-9), "{}", m.max_decel);
        assert!(close(m.max_jerk, 20.0, 1e-6), "{}", m.max_jerk);
        // A step of 3 m/s² in one sample reads as 3 / 0.1 s = 30 m/s³, not 300.
        let s = series(300, |t, r| r.follower_accel = if t > 1.0 { -3.0 } else { 0.0 });
        assert!(close(Metrics::compute(&s, None).max_jerk, 30.0, 1e-6));
        // Accelerating only: max_decel 0.
        let s = series(100, |_, r| r.follower_accel = 1.5);
        assert_eq!(Metrics::compute(&s, None).max_decel, 0.0);
    }

    #[test]
    fn switches_and_time_shares_from_the_active_column() {
        // 10 s: FLC for 0-3 s, PID 3-8 s, FLC 8-10 s.
        let s = series(1000, |t, r| r.active = if t > 3.0 + 1e-9 && t <= 8.0 + 1e-9 { ACTIVE_PID } else { ACTIVE_FLC });
        let m = Metrics::compute(&s, None);
        assert_eq!(m.switches, 2);
        assert!(close(m.duration, 10.0, 1e-9), "{}", m.duration);
        assert!(close(m.time_pid, 5.0, 1e-9), "{}", m.time_pid);
        assert!(close(m.time_flc, 5.0, 1e-9), "{}", m.time_flc);
        assert_eq!(ACTIVE_FLC, 0);
        assert_eq!(ACTIVE_PID, 1);
    }

    #[test]
    fn final_clearance_only_at_standstill_without_collision() {
        let stopping = |t: f64, r: &mut StepRecord| {
            r.lead_speed = (10.0 - 2.0 * t).max(0.0);
            r.follower_speed = (10.0 - 2.0 * t).max(0.0);
            r.gap = 3.7;
        };
        let s = series(800, stopping);
        assert_eq!(Metrics::compute(&s, None).final_clearance, Some(3.7));
        let hit = crash(4.0, 1.0, 2.0, 3.0);
        let m = Metrics::compute(&s, Some(hit));
        assert_eq!(m.final_clearance, None);
        assert!(m.collision && m.impact_speed == 1.0 && m.collision_time == Some(4.0));
        // Still moving at the end.
        let s = series(300, stopping);
        assert_eq!(Metrics::compute(&s, None).final_clearance, None);
    }

    #[test]
    fn rot_and_trans_errors_of_a_constant_offset() {
        let s = series(500, |_, r| {
            r.lateral_offset = -0.25;
            r.heading_error = 0.5_f64.to_radians();
        });
        let m = Metrics::compute(&s, None);
        assert!(close(m.trans_error_m.unwrap(), 0.25, 1e-12));
        assert!(close(m.rot_error_deg.unwrap(), 0.5, 1e-12));
        // Standing still does not count.
        let s = series(500, |t, r| {
            r.follower_speed = if t <= 2.5 { 10.0 } else { 0.0 };
            r.lateral_offset = if t <= 2.5 { 0.1 } else { 3.0 };
        });
        assert!(close(Metrics::compute(&s, None).trans_error_m.unwrap(), 0.1, 1e-12));
    }

    #[test]
    fn gap_error_rms_only_counts_steady_following_after_two_seconds() {
        // 0-5 s the lead accelerates (not steady); from 5 s on steady, but the first 2 s of the
        // stretch (5-7 s, gap error +80 m) are settling time; then +1 m for 4 s and -3 m for 4 s.
        let s = series(1500, |t, r| {
            r.lead_accel = if t <= 5.0 { 1.0 } else { 0.0 };
            r.gap = if t <= 7.0 {
                100.0
            } else if t <= 11.0 {
                21.0
            } else {
                17.0
            };
        });
        let m = Metrics::compute(&s, None);
        // Steady samples: (7, 15] = 8 s with errors +1 (4 s) and -3 (4 s): RMS sqrt((1 + 9) / 2).
        assert!(close(m.steady_time, 8.0, 0.011), "{}", m.steady_time);
        assert!(close(m.gap_error_rms.unwrap(), 5.0_f64.sqrt(), 0.02), "{:?}", m.gap_error_rms);
        // Never steady (speeds differ by 1 m/s).
        let s = series(1000, |_, r| r.follower_speed = 11.0);
        assert_eq!(Metrics::compute(&s, None).gap_error_rms, None);
    }

    #[test]
    fn columns_are_named_and_aligned() {
        let s = series(3, |t, r| {
            r.active = ACTIVE_PID;
            r.gap = t;
        });
        let cols = s.columns();
        assert_eq!(cols.len(), Series::COLUMNS.len());
        assert!(cols.iter().all(|(_, c)| c.len() == 3));
        let get = |name: &str| cols.iter().find(|(n, _)| *n == name).map(|(_, c)| c.clone()).unwrap();
        assert_eq!(get("active"), vec![1.0; 3]);
        assert_eq!(get("gap"), s.t);
        assert_eq!(s.get(2).map(|r| r.gap), Some(s.t[2]));
        assert_eq!(s.get(3), None);
        // Unequal columns (edited by hand): the shortest wins, nothing panics.
        let mut bad = s.clone();
        bad.gap.pop();
        assert_eq!(bad.len(), 2);
        assert_eq!(bad.columns()[0].1.len(), 2);
        let _ = Metrics::compute(&bad, None);
    }

    proptest::proptest! {
        #[test]
        fn never_panics_on_arbitrary_series(
            rows in proptest::collection::vec(
                (proptest::prelude::any::<f64>(), -100.0f64..100.0, proptest::prelude::any::<f64>(), 0u8..3, -50.0f64..50.0),
                0..60,
            )
        ) {
            let mut s = Series::default();
            for (i, (x, v, a, act, g)) in rows.into_iter().enumerate() {
                let t = if i % 7 == 3 { x } else { i as f64 * DT };
                s.push(StepRecord { t, lead_speed: v, follower_speed: x, follower_accel: a, lead_accel: a, active: act, gap: g, desired_gap: x, heading_error: x, lateral_offset: g, ..StepRecord::default() });
            }
            let m = Metrics::compute(&s, None);
            proptest::prop_assert!(m.max_decel >= 0.0 && m.max_jerk >= 0.0 && m.duration >= 0.0);
            proptest::prop_assert!(m.time_pid + m.time_flc <= m.duration * (1.0 + 1e-9) + 1e-9);
            let _ = serde_json::to_string(&m);
        }
    }
}
