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
mod ssm;

use serde::{Deserialize, Serialize};

pub use params::MetricsParams;
pub use records::{CollisionInfo, ContactRecord, FollowerRun, HitObject, ObjectKind, PairContact};
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
    /// Smallest bumper-to-bumper gap to the vehicle in path, m (NaN, serialised `null`, when no
    /// vehicle was ever in path; read back from `null` as NaN).
    #[serde(deserialize_with = "nan_if_null")]
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
    /// Time Exposed TTC (Minderhoud & Bovy 2001): `Σ Δ_i` over the samples with
    /// `TTC_i <= TTC*` (`ttc_threshold`, 3 s; a sample with `gap <= 0` has `TTC_i = 0`), s.
    pub tet: f64,
    /// Time Integrated TTC (Minderhoud & Bovy 2001): `Σ Δ_i (TTC* − TTC_i)` over the same samples,
    /// s².
    pub tit: f64,
    /// Smallest time headway `max(gap, 0) / v_follower` (bumper to bumper, SUMO's TGAP) over the
    /// samples with `v_follower > headway_min_speed` (0.5 m/s), s (`None` if never that fast).
    pub min_time_headway: Option<f64>,
    /// Smallest post-encroachment time of a cut-in, s: time from a vehicle entering the
    /// follower's path in front of it until the follower's front bumper reaches the point where
    /// that vehicle's rear was then (`None` without a cut-in, or if never reached).
    pub pet: Option<f64>,
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

/// A number, or NaN for JSON `null` (how NaN is written).
fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(<Option<f64> as Deserialize>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl Metrics {
    /// Every metric as `(name, type, unit)`, in [`Metrics::names`] order: the one list of metric
    /// types and units (the sweep's Parquet schema; definitions in `docs/v2v-and-metrics.md`).
    /// Types are `"bool"`, `"u32"` or `"f64"` (an `Option` is a nullable `f64`); unit `""` is a
    /// flag or a count; ASCII as the series units (`m/s^2`). A test keeps it equal to the struct's fields.
    pub const COLUMNS: &'static [(&'static str, &'static str, &'static str)] = &[
        ("collision", "bool", ""),
        ("impact_speed", "f64", "m/s"),
        ("collision_time", "f64", "s"),
        ("min_gap", "f64", "m"),
        ("final_clearance", "f64", "m"),
        ("min_ttc", "f64", "s"),
        ("max_decel", "f64", "m/s^2"),
        ("max_drac", "f64", "m/s^2"),
        ("tet", "f64", "s"),
        ("tit", "f64", "s^2"),
        ("min_time_headway", "f64", "s"),
        ("pet", "f64", "s"),
        ("time_hard_braking", "f64", "s"),
        ("max_jerk", "f64", "m/s^3"),
        ("gap_error_rms", "f64", "m"),
        ("steady_time", "f64", "s"),
        ("rot_error_deg", "f64", "deg"),
        ("trans_error_m", "f64", "m"),
        ("time_pid", "f64", "s"),
        ("time_flc", "f64", "s"),
        ("switches", "u32", ""),
        ("duration", "f64", "s"),
    ];

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

        // Gap, TTC, time headway.
        let min_gap = s.gap[..n].iter().copied().filter(|g| g.is_finite()).fold(f64::NAN, f64::min);
        let mut min_ttc: Option<f64> = None;
        let mut min_time_headway: Option<f64> = None;
        let (mut max_drac, mut tet, mut tit): (f64, f64, f64) = (0.0, 0.0, 0.0);
        for (i, &dt) in dts.iter().enumerate() {
            let (gap, vf, closing) = (s.gap[i], s.follower_speed[i], s.follower_speed[i] - s.lead_speed[i]);
            if gap.is_finite() && vf.is_finite() && vf > p.headway_min_speed {
                let thw = gap.max(0.0) / vf;
                min_time_headway = Some(min_time_headway.map_or(thw, |m| m.min(thw)));
            }
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
            if ttc <= p.ttc_threshold {
                tet += dt;
                tit += dt * (p.ttc_threshold - ttc);
            }
        }
        let pet = ssm::min_cut_in_pet(t, &s.gap[..n], &s.lead_speed[..n], &s.follower_speed[..n], p.cut_in_gap_drop);

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
            tet,
            tit,
            min_time_headway,
            pet,
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

    #[test]
    fn columns_name_every_metric_in_order_with_its_json_type() {
        let names: Vec<&str> = Metrics::COLUMNS.iter().map(|(n, _, _)| *n).collect();
        assert_eq!(names, Metrics::names().iter().map(String::as_str).collect::<Vec<_>>());
        let s = crate::series::Series::default();
        let v = serde_json::to_value(Metrics::compute(&s, None)).expect("json");
        for (name, ty, _) in Metrics::COLUMNS {
            let x = &v[*name];
            let ok = match *ty {
                "bool" => x.is_boolean(),
                "u32" => x.is_u64(),
                "f64" => x.is_f64() || x.is_null(),
                _ => false,
            };
            assert!(ok, "{name}: {ty} vs {x}");
        }
    }

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
        // The surrogate safety measures follow max_drac.
        let drac = pos("max_drac").expect("max_drac");
        let ssm: Vec<Option<usize>> = ["tet", "tit", "min_time_headway", "pet"].iter().map(|n| pos(n)).collect();
        assert_eq!(ssm, (1..=4).map(|k| Some(drac + k)).collect::<Vec<_>>());
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// A series of `n` steps at `DT` (t = DT, 2 DT, ...) built by `f(t)` from a neutral record.
    fn series(n: usize, f: impl Fn(f64, &mut StepRecord)) -> Series {
        series_dt(n, DT, f)
    }

    /// [`series`] with step `dt` (t = dt, 2 dt, ..., n dt).
    fn series_dt(n: usize, dt: f64, f: impl Fn(f64, &mut StepRecord)) -> Series {
        let mut s = Series::default();
        for i in 1..=n {
            let t = i as f64 * dt;
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
        assert_eq!((m.tet, m.tit, m.min_time_headway, m.pet), (0.0, 0.0, None, None));
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
    fn tet_and_tit_of_a_linear_approach_to_contact() {
        // Follower 20 m/s, lead 10 m/s, gap 40 - 10 t: contact at t = 4 s, TTC = gap / 10 = 4 - t,
        // at or below TTC* = 3 s for t in [1, 4]: TET = 3 s, TIT = ∫_1^4 (3 - (4 - t)) dt = 4.5 s².
        // Samples t = k dt cover (t - dt, t]: the rectangle sums are TET = 3 + dt and
        // TIT = dt² N (N + 1) / 2 with N = 3 / dt, i.e. 4.5 + 1.5 dt.
        let dt = 1e-3;
        // The approach sampled for `n` steps.
        let approach = |n: usize| {
            series_dt(n, dt, |t, r| {
                r.follower_speed = 20.0;
                r.gap = 40.0 - 10.0 * t;
            })
        };
        let s = approach(4000);
        let m = Metrics::compute(&s, None);
        assert!(close(m.tet, 3.0 + dt, 1e-9), "{}", m.tet);
        assert!(close(m.tit, 4.5 + 1.5 * dt, 1e-6), "{}", m.tit);
        assert!(close(m.min_ttc.unwrap(), 0.0, 1e-9));
        // Past contact (gap <= 0 is TTC 0): one more second adds 1 s to TET and 3 s² to TIT.
        let s = approach(5000);
        let m = Metrics::compute(&s, None);
        assert!(close(m.tet, 4.0 + dt, 1e-9), "{}", m.tet);
        assert!(close(m.tit, 7.5 + 1.5 * dt, 1e-6), "{}", m.tit);
        // A lower threshold: TTC* = 1 s exposes t in [3, 4]: TET 1 s, TIT ∫_3^4 (t - 3) dt = 0.5 s².
        let p = MetricsParams { ttc_threshold: 1.0, ..MetricsParams::default() };
        let s = approach(4000);
        let m = Metrics::compute_with(&s, None, &p);
        assert!(close(m.tet, 1.0 + dt, 1e-9), "{}", m.tet);
        assert!(close(m.tit, 0.5 + 0.5 * dt, 1e-6), "{}", m.tit);
    }

    #[test]
    fn tet_and_tit_are_zero_when_never_below_the_threshold() {
        // Never closing (equal speeds, then opening).
        let s = series(1000, |t, r| {
            r.follower_speed = if t < 5.0 { 10.0 } else { 8.0 };
            r.gap = 20.0;
        });
        let m = Metrics::compute(&s, None);
        assert_eq!((m.tet, m.tit, m.min_ttc), (0.0, 0.0, None));
        // Closing, but TTC = (50 - 5 t) / 5 >= 4 s over t <= 6 s: never exposed.
        let s = series(600, |t, r| {
            r.follower_speed = 15.0;
            r.gap = 50.0 - 5.0 * t;
        });
        let m = Metrics::compute(&s, None);
        assert!(close(m.min_ttc.unwrap(), 4.0, 1e-9));
        assert_eq!((m.tet, m.tit), (0.0, 0.0));
    }

    #[test]
    fn min_time_headway_only_while_moving() {
        // 0-4 s: 25 m/s at 30 m (1.2 s); 4-8 s: 10 m/s at 8 m (0.8 s); 8-10 s: creeping at
        // 0.3 m/s (below headway_min_speed 0.5) 0.1 m behind (0.33 s, not counted).
        let s = series(1000, |t, r| {
            (r.follower_speed, r.gap) = if t <= 4.0 {
                (25.0, 30.0)
            } else if t <= 8.0 {
                (10.0, 8.0)
            } else {
                (0.3, 0.1)
            };
            r.lead_speed = r.follower_speed;
        });
        let m = Metrics::compute(&s, None);
        assert!(close(m.min_time_headway.unwrap(), 0.8, 1e-12), "{:?}", m.min_time_headway);
        // With the threshold below the creeping speed, 0.1 / 0.3 counts.
        let p = MetricsParams { headway_min_speed: 0.2, ..MetricsParams::default() };
        assert!(close(Metrics::compute_with(&s, None, &p).min_time_headway.unwrap(), 0.1 / 0.3, 1e-12));
        // Overlapping (gap < 0) reads 0, not a negative headway.
        let s = series(100, |t, r| r.gap = if t > 0.5 { -0.2 } else { 5.0 });
        assert_eq!(Metrics::compute(&s, None).min_time_headway, Some(0.0));
        // Never moving: None.
        let s = series(100, |_, r| {
            r.follower_speed = 0.0;
            r.lead_speed = 0.0;
        });
        assert_eq!(Metrics::compute(&s, None).min_time_headway, None);
    }

    #[test]
    fn pet_of_a_cut_in() {
        // Follower at 20 m/s 50 m behind a vehicle at 20 m/s; at t = 2 s a vehicle at 15 m/s
        // enters its path 10 m ahead: its rear is at P, 10 m ahead of the follower's front
        // bumper, which reaches P after 10 / 20 = 0.5 s.
        let cut_in = |t: f64, r: &mut StepRecord| {
            r.follower_speed = 20.0;
            (r.lead_speed, r.gap) = if t < 2.0 - 1e-9 { (20.0, 50.0) } else { (15.0, 10.0 - 5.0 * (t - 2.0)) };
        };
        let m = Metrics::compute(&series(400, cut_in), None);
        assert!(close(m.pet.unwrap(), 0.5, 1e-9), "{:?}", m.pet);
        // Braking at 2 m/s² from the cut-in: 20 τ - τ² = 10, τ = 10 - sqrt(90) = 0.513 s.
        let braking = |t: f64, r: &mut StepRecord| {
            cut_in(t, r);
            r.follower_speed = if t < 2.0 { 20.0 } else { 20.0 - 2.0 * (t - 2.0) };
            // The gap the new front vehicle keeps: 10 m + its 15 m/s minus what the follower covers.
            if t >= 2.0 - 1e-9 {
                let tau = t - 2.0;
                r.gap = 10.0 + 15.0 * tau - (20.0 * tau - tau * tau);
            }
        };
        let m = Metrics::compute(&series(400, braking), None);
        assert!(close(m.pet.unwrap(), 10.0 - 90.0_f64.sqrt(), 1e-9), "{:?}", m.pet);
        // Stopping (5 m/s, 5 m/s²: 2.5 m) before P: never reached.
        let stops = |t: f64, r: &mut StepRecord| {
            cut_in(t, r);
            r.follower_speed = if t < 2.0 { 20.0 } else { (5.0 - 5.0 * (t - 2.0)).max(0.0) };
        };
        assert_eq!(Metrics::compute(&series(600, stops), None).pet, None);
        // The series ends before the follower reaches P (0.3 s after the cut-in).
        assert_eq!(Metrics::compute(&series(230, cut_in), None).pet, None);
    }

    #[test]
    fn no_pet_without_a_cut_in() {
        // Plain following, closing, braking lead, cut-out (the gap jumps up): no encroachment.
        let closing = series(900, |t, r| {
            r.follower_speed = 15.0;
            r.gap = 50.0 - 5.0 * t;
        });
        let braking_lead = series(500, |t, r| {
            r.lead_speed = (10.0 - 6.0 * t).max(0.0);
            r.lead_accel = if 10.0 - 6.0 * t > 0.0 { -6.0 } else { 0.0 };
            // Gap of a lead braking from 10 m/s at 6 m/s² in front of a follower at 10 m/s.
            let tb = t.min(10.0 / 6.0);
            r.gap = 30.0 + (10.0 * tb - 3.0 * tb * tb) - 10.0 * t;
        });
        let cut_out = series(400, |t, r| r.gap = if t < 2.0 { 10.0 } else { 60.0 });
        for s in [closing, braking_lead, cut_out] {
            assert_eq!(Metrics::compute(&s, None).pet, None);
        }
        assert_eq!(Metrics::compute(&Series::default(), None).pet, None);
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
            proptest::prop_assert!(m.tet >= 0.0 && m.tit >= 0.0 && m.tet <= m.duration * (1.0 + 1e-9) + 1e-9);
            proptest::prop_assert!(m.pet.is_none_or(|x| x >= 0.0) && m.min_time_headway.is_none_or(|x| x >= 0.0));
            let _ = serde_json::to_string(&m);
        }
    }
}
