//! Issue 7: the robust FLC (`controller = "flc-robust-v1"`, `docs/robust-flc.md`) against each target
//! of the issue, with the thresholds in the tests. The paper's FLC runs through the same scenarios
//! and its own (worse) results are asserted next to it, so the comparison stays visible.
//!
//! Default (realistic) vehicle: 8 m/s² brakes, 0.1 s dead time, 0.2 s lag; LiDAR at 20 Hz. The
//! physical bounds are computed with the simulator's own vehicle model ([`Vehicle`]): an ideal
//! follower that knows the lead's (or obstacle's) state one LiDAR frame after it changes and then
//! demands full braking.

mod common;

use common::robust::{comfort_miss, jerk_1s, own_gap};

use flc_sim::{Calibration, ControllerKind, Phase, Scenario, TrackSpec};
use flc_sim::{RoadsideObject, Track};
use flc_sim::{RunOptions, RunResult};
use flc_sim::{Vehicle, VehicleParams, VehicleState};

const KMH: f64 = 1.0 / 3.6;

/// A table `docs/robust-flc.md` includes (`python -m flc docs`): `docs/figures/<name>` is written
/// with `FLC_BLESS=1` and otherwise must equal `table`.
fn check_doc_table(name: &str, table: &str) {
    common::bless_or_compare(&format!("docs/figures/{name}"), table, "FLC_BLESS=1 cargo test --release -p flc-sim --test robust_flc");
}
const ROBUST: ControllerKind = ControllerKind::FlcRobustV1;
/// The robust FLC v2 (issue 24), held to v1's rate-invariance target and to the stricter
/// comfort figures.
const ROBUST2: ControllerKind = ControllerKind::FlcRobust;
/// v2 with wheel odometry (issue 24's variant), held to v2's targets.
const ODO: ControllerKind = ControllerKind::FlcRobustOdo;
const PAPER: ControllerKind = ControllerKind::Flc;
/// The default LiDAR's range (`LidarParams::max_range`, `docs/detector.md`): the detector's grid
/// reaches 200.5 m ahead of the sensor since issue 23.
const LIDAR_RANGE: f64 = 200.0;

fn batch(scenarios: &[Scenario]) -> Vec<RunResult> {
    RunOptions::default().run_batch(scenarios).into_iter().map(|r| r.expect("run")).collect()
}

/// Steady following at the controller's own gap, then the lead brakes at `decel` to a stop. The
/// lead's brakes are raised to 10 m/s² so that it can brake harder than the follower.
fn steady(controller: ControllerKind, kmh: f64, decel: f64) -> Scenario {
    let v = kmh * KMH;
    let mut s = Scenario { name: format!("steady-{kmh}-{decel}"), controller, duration: 90.0, ..Default::default() };
    s.v2v.enabled = false;
    // Informational, in [1, 250] km/h (`SPEED_RANGE_KMH`); a start from standstill has none.
    s.speed_kmh = (kmh > 0.0).then_some(kmh);
    s.track = TrackSpec::Straight { length: 5000.0 };
    s.lead.initial_speed = v;
    s.lead.vehicle.max_brake = 10.0;
    s.lead.phases = vec![
        Phase::Hold { until_x: None, until_t: None, duration: Some(2.0) }.into(),
        Phase::Brake { decel, speed: None, speed_kmh: None }.into(),
    ];
    s.follower.initial_speed = v;
    s.follower.initial_gap = own_gap(&s, v);
    s
}

/// Gap consumed by an ideal follower behind a lead braking at `lead_decel` from `v`: both start at
/// `v`; the lead's command is `-lead_decel` from t = 0, the follower's `-max_decel` from
/// t = `reaction` (a perfect observer, one LiDAR frame late); both through the same actuator and
/// resistance model as in the simulator. Returns the largest relative displacement, m.
fn ideal_consumed_gap(v: f64, lead_decel: f64, reaction: f64) -> f64 {
    let dt = 0.001;
    let lead_params = VehicleParams { max_brake: 10.0, ..VehicleParams::default() };
    let mut lead = Vehicle::new(lead_params, VehicleState { speed: v, ..Default::default() });
    let mut fol = Vehicle::new(VehicleParams::default(), VehicleState { speed: v, ..Default::default() });
    let (mut t, mut worst) = (0.0, 0.0f64);
    while lead.state().speed > 0.0 || fol.state().speed > 0.0 {
        lead.step(-lead_decel, 0.0, dt);
        fol.step(if t >= reaction { -8.0 } else { 0.0 }, 0.0, dt);
        t += dt;
        worst = worst.max(fol.state().x - lead.state().x);
    }
    worst
}

/// Distance an ideal follower needs to stop from `v` before a standing object it sees now
/// (full braking demand from now on, same vehicle model), m.
fn ideal_stopping_distance(v: f64) -> f64 {
    let dt = 0.001;
    let mut fol = Vehicle::new(VehicleParams::default(), VehicleState { speed: v, ..Default::default() });
    while fol.state().speed > 0.0 {
        fol.step(-8.0, 0.0, dt);
    }
    fol.state().x
}

/// Target 1 (paper scenario): from standstill, lead accelerates to the max speed, brakes at
/// -6 m/s². No collision at every max speed from 30 to 130 km/h in steps of 10. The paper's FLC
/// also stops with the realistic vehicle, but with twice the jerk and hard braking.
#[test]
fn paper_scenario_30_to_130_kmh() {
    let speeds: Vec<f64> = (3..=13).map(|k| 10.0 * k as f64).collect();
    let scenarios: Vec<Scenario> = [ROBUST, PAPER]
        .iter()
        .flat_map(|&c| speeds.iter().map(move |&v| Scenario::paper_experiment(v, c, Calibration::Realistic)))
        .collect();
    let r = batch(&scenarios);
    let (robust, paper) = r.split_at(speeds.len());
    for (v, (a, b)) in speeds.iter().zip(robust.iter().zip(paper)) {
        let (m, p) = (&a.metrics, &b.metrics);
        assert!(!m.collision && m.final_clearance.is_some_and(|c| c > 2.0), "flc-robust-v1 at {v} km/h: {m:?}");
        eprintln!(
            "paper {v:>3} km/h: robust clearance {:.2} m, max jerk {:.1}, hard braking {:.2} s | paper FLC clearance {:.2} m, max jerk {:.1}, hard braking {:.2} s",
            m.final_clearance.unwrap_or(f64::NAN),
            m.max_jerk,
            m.time_hard_braking,
            p.final_clearance.unwrap_or(f64::NAN),
            p.max_jerk,
            p.time_hard_braking
        );
        // The lead brakes at -6: braking harder than 3.5 m/s² for a while is needed; the robust
        // FLC's jerk stays below 10 m/s³, the paper's FLC is above 15.
        assert!(m.max_jerk < 10.0, "robust jerk {} at {v}", m.max_jerk);
        assert!(!p.collision && p.max_jerk > 15.0, "paper FLC at {v}: {p:?}");
    }
}

/// Target 2 (steady following at the controller's own gap, lead braking at -2 ... -9 m/s²): no
/// collision from 30 to 130 km/h. The analytic bound (see [`steady_following_bound`]) is the
/// detection range at every deceleration; physics allows all of this grid.
#[test]
fn steady_following_lead_braking_2_to_9() {
    let speeds = [30.0, 50.0, 70.0, 90.0, 110.0, 130.0];
    let decels = [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];
    let cases: Vec<(f64, f64)> = decels.iter().flat_map(|&b| speeds.iter().map(move |&v| (v, b))).collect();
    let scenarios: Vec<Scenario> = [ROBUST, PAPER].iter().flat_map(|&c| cases.iter().map(move |&(v, b)| steady(c, v, b))).collect();
    let r = batch(&scenarios);
    let (robust, paper) = r.split_at(cases.len());
    let mut paper_min: f64 = f64::INFINITY;
    let mut robust_min: f64 = f64::INFINITY;
    for ((v, b), (a, p)) in cases.iter().zip(robust.iter().zip(paper)) {
        let m = &a.metrics;
        assert!(!m.collision, "flc-robust-v1 collided at {v} km/h, lead -{b}: {m:?}");
        // Stops at a standstill gap of at least 2 m.
        assert!(m.final_clearance.is_some_and(|c| c >= 2.0), "flc-robust-v1 clearance at {v} km/h, lead -{b}: {m:?}");
        robust_min = robust_min.min(m.min_gap);
        paper_min = paper_min.min(p.metrics.min_gap);
        assert!(!p.metrics.collision, "paper FLC collided at {v} km/h, lead -{b} (realistic vehicle: it should not)");
    }
    eprintln!("steady following: smallest gap flc-robust {robust_min:.2} m, paper FLC {paper_min:.2} m");
    assert!(robust_min > 3.0, "{robust_min}");
}

/// Target 2, the bound. An ideal follower (it knows the lead's braking one LiDAR frame after the
/// onset and then brakes fully) starting at the robust FLC's own gap never collides behind a lead
/// braking at -2 ... -9 m/s², up to 150 km/h. Before issue 23 the detector's 70.5 m grid bounded
/// the speed (`D_r(v) <= 69.5 m`, 159.6 km/h); the LiDAR's 200 m now puts that bound at
/// `(200 - 3) / 1.5` = 131 m/s, beyond any car, so the kinematics alone are the bound. v1 and v2
/// are collision-free at 140 and 150 km/h where the lead brakes as hard as (-8) or harder (-9)
/// than the follower.
#[test]
fn steady_following_bound() {
    let p = flc_core::RobustFlcParams::default();
    let frame = 1.0 / 20.0;
    let v_range = (LIDAR_RANGE - p.standstill_gap) / p.time_gap;
    assert!(v_range / KMH > 470.0, "{}", v_range / KMH);
    // At every tested speed the ideal follower needs far less than the robust FLC's gap.
    for b in [2.0, 4.0, 6.0, 8.0, 9.0] {
        for kmh in [30.0, 80.0, 130.0, 150.0] {
            let v = kmh * KMH;
            let need = ideal_consumed_gap(v, b, frame);
            assert!(need < p.desired_gap(v) - 10.0, "lead -{b} at {kmh} km/h: ideal needs {need:.1} m of {:.1}", p.desired_gap(v));
        }
    }
    let cases = [(140.0, 8.0), (150.0, 8.0), (140.0, 9.0), (150.0, 9.0)];
    for kind in [ROBUST, ROBUST2] {
        let r = batch(&cases.map(|(v, b)| steady(kind, v, b)));
        for ((v, b), x) in cases.iter().zip(&r) {
            assert!(!x.metrics.collision, "{} at {v} km/h, lead -{b}: {:?}", kind.as_str(), x.metrics);
        }
    }
}

/// The rate-invariance variants of target 3: rate, jitter, LiDAR latency (100 ms at each rate).
const VARIANTS: [(&str, f64, f64, u32); 7] = [
    ("20 Hz", 20.0, 0.0, 0),
    ("10 Hz", 10.0, 0.0, 0),
    ("40 Hz", 40.0, 0.0, 0),
    ("20 Hz +-30 % jitter", 20.0, 0.3, 0),
    ("20 Hz + 100 ms", 20.0, 0.0, 2),
    ("10 Hz + 100 ms", 10.0, 0.0, 1),
    ("40 Hz + 100 ms", 40.0, 0.0, 4),
];

/// Target 3 (rate invariance), for v1 and v2: the same outcome (collision or not, clearance
/// within 0.5 m) at 10, 20 and 40 Hz, with +-30 % frame-interval jitter and with 100 ms LiDAR latency (at each rate).
/// "Clearance" is the paper's: the gap at standstill. The paper's FLC changes its clearance by
/// several metres with the rate and collides at 40 Hz + 100 ms (130 km/h, lead -9).
#[test]
fn rate_invariance() {
    let cases = [(50.0, 2.0), (130.0, 2.0), (50.0, 6.0), (130.0, 6.0), (50.0, 9.0), (130.0, 9.0)];
    let make = |c: ControllerKind| -> Vec<Scenario> {
        cases
            .iter()
            .flat_map(|&(v, b)| {
                VARIANTS.iter().map(move |&(_, rate, jitter, latency)| {
                    let mut s = steady(c, v, b);
                    s.lidar.rate_hz = rate;
                    s.lidar.jitter = jitter;
                    s.lidar.latency_frames = latency;
                    s
                })
            })
            .collect()
    };
    let robust = batch(&make(ROBUST));
    let robust2 = batch(&make(ROBUST2));
    let odo = batch(&make(ODO));
    let paper = batch(&make(PAPER));
    let mut table = String::from("| scenario | controller |");
    for (name, ..) in VARIANTS {
        table += &format!(" {} |", name.replace("+-", "±"));
    }
    table += &format!("\n|---|---|{}\n", "---|".repeat(VARIANTS.len()));
    for (i, &(v, b)) in cases.iter().enumerate() {
        for (k, (label, runs)) in [("flc-robust-v1", &robust), ("flc-robust", &robust2), ("flc-robust-odo", &odo), ("paper's FLC", &paper)]
            .into_iter()
            .enumerate()
        {
            let scenario = if k == 0 { format!("{v} km/h, −{b}") } else { String::new() };
            table += &format!("| {scenario} | {label} |");
            for r in &runs[i * VARIANTS.len()..(i + 1) * VARIANTS.len()] {
                table += &match (r.metrics.collision, r.metrics.final_clearance) {
                    (true, _) => format!(" X {:.1} m/s |", r.metrics.impact_speed),
                    (false, Some(c)) => format!(" {c:.2} |"),
                    (false, None) => " no stop |".to_string(),
                };
            }
            table += "\n";
        }
    }
    check_doc_table("robust-rate-invariance.md", &table);
    let mut paper_spread: f64 = 0.0;
    let mut paper_collided = false;
    for (i, &(v, b)) in cases.iter().enumerate() {
        let rows = &robust[i * VARIANTS.len()..(i + 1) * VARIANTS.len()];
        let at = |runs: &[flc_sim::RunResult]| runs[i * VARIANTS.len()..(i + 1) * VARIANTS.len()].to_vec();
        for (label, rows) in [("flc-robust-v1", rows.to_vec()), ("flc-robust", at(&robust2)), ("flc-robust-odo", at(&odo))] {
            let reference = rows[0].metrics.final_clearance.expect("reference stops");
            for (row, (name, ..)) in rows.iter().zip(VARIANTS) {
                let m = &row.metrics;
                assert!(!m.collision, "{label} {v} km/h, lead -{b}, {name}: collided");
                let c = m.final_clearance.expect("stops");
                assert!((c - reference).abs() <= 0.5, "{label} {v} km/h, lead -{b}, {name}: clearance {c:.2} vs {reference:.2}");
            }
        }
        let prow = &paper[i * VARIANTS.len()..(i + 1) * VARIANTS.len()];
        let clear: Vec<f64> = prow.iter().filter_map(|r| r.metrics.final_clearance).collect();
        paper_collided |= prow.iter().any(|r| r.metrics.collision);
        if let (Some(lo), Some(hi)) = (clear.iter().copied().reduce(f64::min), clear.iter().copied().reduce(f64::max)) {
            paper_spread = paper_spread.max(hi - lo);
        }
        eprintln!(
            "{v} km/h lead -{b}: robust {:?} | paper {:?}",
            rows.iter().map(|r| (r.metrics.final_clearance.unwrap_or(f64::NAN) * 100.0).round() / 100.0).collect::<Vec<_>>(),
            prow.iter()
                .map(|r| if r.metrics.collision {
                    f64::NAN
                } else {
                    (r.metrics.final_clearance.unwrap_or(f64::NAN) * 100.0).round() / 100.0
                })
                .collect::<Vec<_>>()
        );
    }
    // The paper's Delta_d trigger: clearances several metres apart across rates, and a collision
    // at 40 Hz with 100 ms latency (130 km/h, lead -9).
    assert!(paper_spread > 3.0, "paper FLC clearance spread {paper_spread}");
    assert!(paper_collided, "the paper FLC was expected to collide in one variant");
}

/// The comfort scenarios of target 4: lead speed changes at +-1 m/s², lead braking at -2 m/s² to a
/// stop, stop and go.
fn comfort_scenarios(c: ControllerKind) -> Vec<(String, Scenario)> {
    let mut out = Vec::new();
    for kmh in [50.0, 100.0, 130.0] {
        let v = kmh * KMH;
        let mut s = steady(c, kmh, 1.0);
        s.lead.phases = vec![
            Phase::Hold { until_x: None, until_t: None, duration: Some(5.0) }.into(),
            Phase::Brake { decel: 1.0, speed: Some(v - 20.0 * KMH), speed_kmh: None }.into(),
            Phase::Hold { until_x: None, until_t: None, duration: Some(10.0) }.into(),
            Phase::Accelerate { accel: 1.0, speed: Some(v), speed_kmh: None }.into(),
            Phase::Hold { until_x: None, until_t: None, duration: Some(15.0) }.into(),
        ];
        s.duration = 60.0;
        out.push((format!("+-1 m/s² at {kmh} km/h"), s));
    }
    for kmh in [30.0, 70.0, 130.0] {
        let mut s = steady(c, kmh, 2.0);
        s.lead.phases[0] = Phase::Hold { until_x: None, until_t: None, duration: Some(5.0) }.into();
        out.push((format!("lead -2 m/s² from {kmh} km/h"), s));
    }
    let mut s = steady(c, 0.0, 2.0);
    let hold = |d: f64| Phase::Hold { until_x: None, until_t: None, duration: Some(d) };
    let go = |kmh: f64| Phase::Accelerate { accel: 1.0, speed: None, speed_kmh: Some(kmh) };
    let stop = || Phase::Brake { decel: 2.0, speed: None, speed_kmh: None };
    s.lead.phases = [hold(3.0), go(50.0), hold(10.0), stop(), hold(5.0), go(30.0), hold(5.0), stop(), hold(5.0), go(20.0), stop()]
        .map(Into::into)
        .to_vec();
    s.follower.initial_gap = match c {
        ROBUST => s.flc_robust_v1.standstill_gap,
        ROBUST2 | ODO => s.flc_robust.law.standstill_gap,
        _ => 7.0,
    };
    s.duration = 150.0;
    out.push(("stop and go".to_string(), s));
    out
}

/// Target 4 (comfort when nothing is wrong): deceleration within 3.5 m/s², 1-second mean jerk
/// within 5 m/s³, no reversing, standstill gap 2-6 m. The paper's FLC brakes harder than 3.5 m/s²
/// behind a lead braking at -2.
#[test]
fn comfort_in_normal_following() {
    let robust = comfort_scenarios(ROBUST);
    let paper = comfort_scenarios(PAPER);
    let r = batch(&robust.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>());
    let p = batch(&paper.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>());
    // The table of docs/robust-flc.md ("Comfort"), v2 beside v1 (v2's own, stricter target is
    // `comfort_in_normal_following_v2`).
    let v2 = batch(&comfort_scenarios(ROBUST2).into_iter().map(|(_, s)| s).collect::<Vec<_>>());
    let cell = |x: &RunResult| {
        let gap = x.metrics.final_clearance.map_or("–".to_string(), |c| format!("{c:.2}"));
        let hit = if x.metrics.collision { format!(", X {:.1} m/s", x.metrics.impact_speed) } else { String::new() };
        format!("{:.2} / {:.2} / {gap}{hit}", x.metrics.max_decel, jerk_1s(x))
    };
    let mut table = String::from("| scenario | flc-robust-v1 | flc-robust (v2) | paper's FLC |\n|---|---|---|---|\n");
    for ((((name, _), a), b), c) in robust.iter().zip(&r).zip(&v2).zip(&p) {
        table += &format!("| {} | {} | {} | {} |\n", name.replace("+-", "±"), cell(a), cell(b), cell(c));
    }
    check_doc_table("robust-comfort.md", &table);
    let mut paper_worst_decel: f64 = 0.0;
    for (((name, _), a), b) in robust.iter().zip(&r).zip(&p) {
        let m = &a.metrics;
        let jerk = jerk_1s(a);
        eprintln!(
            "{name}: robust max decel {:.2}, 1-s jerk {jerk:.2}, standstill gap {:?} | paper FLC max decel {:.2}, 1-s jerk {:.2}, standstill gap {:?}",
            m.max_decel,
            m.final_clearance,
            b.metrics.max_decel,
            jerk_1s(b),
            b.metrics.final_clearance
        );
        assert!(!m.collision, "{name}");
        assert!(m.max_decel <= 3.5, "{name}: max decel {}", m.max_decel);
        assert!(jerk <= 5.0, "{name}: 1-s jerk {jerk}");
        // No reversing: never a negative speed command, never rolling backwards.
        assert!(a.series.speed_command.iter().all(|&v| v >= 0.0), "{name}: negative speed command");
        assert!(a.series.follower_speed.iter().all(|&v| v >= 0.0), "{name}: reversing");
        if let Some(c) = m.final_clearance {
            assert!((2.0..=6.0).contains(&c), "{name}: standstill gap {c}");
        }
        paper_worst_decel = paper_worst_decel.max(b.metrics.max_decel);
    }
    // The stops end at standstill (gap checked above) in the four stopping scenarios.
    assert_eq!(r.iter().filter(|x| x.metrics.final_clearance.is_some()).count(), 4);
    assert!(paper_worst_decel > 4.0, "paper FLC max decel {paper_worst_decel}");
}

/// Issue 24's comfort target for v2 (ISO 15622 / 22179 figures), on target 4's scenarios: max
/// deceleration <= 3.5 m/s², 1-second mean jerk <= 2.5 m/s³, standstill gap 2-5 m, never reversing.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn comfort_in_normal_following_v2() {
    comfort_targets(ROBUST2);
}

/// The odometry variant under the same comfort targets as v2.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug; tests/run_all.sh runs it with --release")]
fn comfort_in_normal_following_odo() {
    comfort_targets(ODO);
}

fn comfort_targets(law: ControllerKind) {
    let cases = comfort_scenarios(law);
    let r = batch(&cases.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>());
    for ((name, _), a) in cases.iter().zip(&r) {
        let miss = comfort_miss(&format!("{name}: {}", law.as_str()), a);
        assert!(miss.is_none(), "{miss:?}");
        assert!(a.series.speed_command.iter().all(|&v| v >= 0.0), "{name}: negative speed command");
    }
    assert_eq!(r.iter().filter(|x| x.metrics.final_clearance.is_some()).count(), 4);
}

/// A car cuts in at `gap` m, `dv_kmh` slower than the follower, and holds its speed. Modelled as
/// the first detection (the simulator has two vehicles): the moment the cutting car enters the
/// follower's path corridor.
fn cut_in(c: ControllerKind, kmh: f64, dv_kmh: f64, gap: f64) -> Scenario {
    let mut s = steady(c, kmh, 1.0);
    s.lead.initial_speed = (kmh - dv_kmh) * KMH;
    s.lead.phases = vec![Phase::Hold { until_x: None, until_t: None, duration: Some(8.0) }.into()];
    s.follower.initial_gap = gap;
    s.duration = 8.0;
    s
}

/// Target 5a (cut-in at short distance): no collision wherever an ideal follower (full braking at
/// once) avoids it; where physics does not allow it, both controllers collide.
#[test]
fn cut_in_at_short_distance() {
    let mut cases = Vec::new();
    for kmh in [50.0, 130.0] {
        for dv in [0.0, 20.0, 30.0] {
            for gap in [5.0, 10.0, 20.0] {
                cases.push((kmh, dv, gap));
            }
        }
    }
    for c in [ROBUST, PAPER] {
        let r = batch(&cases.iter().map(|&(v, dv, g)| cut_in(c, v, dv, g)).collect::<Vec<_>>());
        for (&(kmh, dv, gap), x) in cases.iter().zip(&r) {
            // Ideal: the relative motion of a full stop from the closing speed dv (the lead holds).
            let need = ideal_stopping_distance(dv * KMH);
            let m = &x.metrics;
            if need < gap - 0.5 {
                assert!(!m.collision, "{} cut-in at {kmh} km/h, {dv} km/h slower, {gap} m (ideal needs {need:.1} m): {m:?}", c.as_str());
            } else if need > gap + 0.5 {
                assert!(m.collision, "{} cut-in at {kmh} km/h, {dv} km/h slower, {gap} m: physics says collision", c.as_str());
            }
        }
    }
}

/// The lead leaves the lane at `kmh` (3 s lane change after 5 s); a standing car waits `ahead` m
/// beyond the point where the lead's rear is when its lane change ends. The follower keeps its
/// lane. Returns the scenario and the parked car's rear position along the track.
fn cut_out(c: ControllerKind, kmh: f64, ahead: f64) -> (Scenario, f64) {
    let v = kmh * KMH;
    let mut s = steady(c, kmh, 1.0);
    let gap = s.follower.initial_gap;
    let follower_s = s.follower.vehicle.length / 2.0 + 1.0;
    let lead_rear0 = follower_s + s.follower.vehicle.length / 2.0 + gap;
    let car_rear = lead_rear0 + v * 8.0 + ahead;
    let objects = vec![RoadsideObject::ParkedCar { s: car_rear + 2.35, offset: 0.0, heading_offset: 0.0, lane: None }];
    s.track = TrackSpec::Custom(Track::new("cut-out", vec![[0.0, 0.0], [5000.0, 0.0]], 3.5, objects));
    s.lead.phases = vec![
        Phase::Hold { until_x: None, until_t: None, duration: Some(5.0) }.into(),
        Phase::LaneChange { offset: Some(3.5), lane: None, duration: 3.0 }.into(),
        Phase::Hold { until_x: None, until_t: None, duration: Some(40.0) }.into(),
    ];
    s.follower.lane_keeping = true;
    s.duration = 40.0;
    s.stop.standstill_time = 1.0;
    (s, car_rear)
}

/// What happened in front of the parked car: the distance and speed when the detector first saw it,
/// and the smallest gap to it (negative = ran into it).
struct Reveal {
    distance: f64,
    speed: f64,
    min_gap: f64,
}

fn reveal_of(r: &RunResult, car_rear: f64, front: f64) -> Reveal {
    let s = &r.series;
    let gap = |i: usize| car_rear - (s.follower_x[i] + front);
    let i = (0..s.len()).find(|&i| (s.detected_distance[i] - gap(i)).abs() < 1.0).expect("the parked car is detected");
    let min_gap = (0..s.len()).map(gap).fold(f64::INFINITY, f64::min);
    Reveal { distance: gap(i), speed: s.follower_speed[i], min_gap }
}

/// Target 5b (a lead leaving the lane reveals a standing car): no collision where physics allows
/// it. "Physics allows" = an ideal follower braking fully from the frame in which the car is first
/// detected stops in the distance at which it was revealed; across the speeds this gives a speed
/// bound. The robust FLC's stop envelope keeps a design margin (7 of the 8.3 m/s², 0.5 s of the
/// 0.3 s actuator delay, 2 m), so it meets the bound within 10 % of the speed: collision-free at
/// every speed up to 90 % of it. The paper's FLC, which keeps its gap policy towards the far
/// object, runs into the car well below that.
#[test]
fn cut_out_reveals_a_standing_car() {
    let speeds: Vec<f64> = (0..11).map(|k| 60.0 + 4.0 * k as f64).collect();
    let front = VehicleParams::default().length / 2.0;
    let mut paper_first_hit = f64::INFINITY;
    let mut robust_bound = 0.0;
    let mut sentence = String::new();
    for c in [ROBUST, PAPER] {
        let runs: Vec<(Scenario, f64)> = speeds.iter().map(|&v| cut_out(c, v, 0.0)).collect();
        let r = batch(&runs.iter().map(|(s, _)| s.clone()).collect::<Vec<_>>());
        let mut bound: f64 = 0.0;
        let mut first_hit = f64::INFINITY;
        for ((&kmh, (_, car)), x) in speeds.iter().zip(&runs).zip(&r) {
            let rv = reveal_of(x, *car, front);
            let need = ideal_stopping_distance(rv.speed);
            if need < rv.distance {
                bound = kmh;
            }
            if rv.min_gap <= 0.0 {
                first_hit = first_hit.min(kmh);
            }
            eprintln!(
                "{} cut-out at {kmh} km/h: revealed at {:.1} m at {:.1} m/s (ideal stop {need:.1} m), min gap {:.2}",
                c.as_str(),
                rv.distance,
                rv.speed,
                rv.min_gap
            );
        }
        eprintln!("{}: first contact at {first_hit} km/h, physics bound {bound} km/h", c.as_str());
        let hit =
            if first_hit.is_finite() { format!("first contact at {first_hit} km/h") } else { "no contact up to 100 km/h".to_string() };
        sentence += &format!("- `{}`: {hit}; the physics bound (an ideal follower, one frame late) is {bound} km/h.\n", c.as_str());
        if c == ROBUST {
            assert!(bound >= 80.0, "bound {bound}");
            assert!(first_hit > 0.9 * bound, "flc-robust-v1 hit the car at {first_hit} km/h, bound {bound} km/h");
            robust_bound = bound;
        } else {
            paper_first_hit = first_hit;
        }
    }
    // The paper's FLC hits the car where the robust FLC stops.
    assert!(paper_first_hit < 0.9 * robust_bound, "paper FLC first contact {paper_first_hit} km/h");
    check_doc_table("robust-cut-out.md", &format!("Cut-out at 60-100 km/h in steps of 4 km/h:\n\n{sentence}"));
}

/// `[flc_robust]` (v2, its v1 law in `[flc_robust.law]`) and `[flc_robust_v1]` errors name the
/// dotted key; `scenarios/robust-cut-out.toml` (v2) parses and stops before the standing car, as
/// v1 does (the paper's FLC, same file, does not).
#[test]
fn scenario_section_and_example_file() {
    let err = |name: &str, section: &str, body: &str| {
        Scenario::from_toml_str(&format!("controller = \"{name}\"\n[{section}]\n{body}\n"), "t.toml").unwrap_err().to_string()
    };
    for (name, section) in [("flc-robust-v1", "flc_robust_v1"), ("flc-robust", "flc_robust.law")] {
        let e = err(name, section, "tme_gap = 1.0");
        assert!(e.contains(&format!("`{section}.tme_gap`")), "{e}");
        assert!(err(name, section, "brake_gain = -1.0").contains(&format!("{section}.brake_gain")));
        assert!(err(name, section, "first_object = \"maybe\"").contains(&format!("{section}.first_object")));
    }
    let e = err("flc-robust", "flc_robust", "firm_gain = 0.0");
    assert!(e.contains("flc_robust.firm_gain"), "{e}");
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/robust-cut-out.toml"));
    let s = Scenario::from_file(path).expect("scenario");
    assert_eq!(s.controller, ROBUST2);
    let car_rear = 222.4 - 2.45;
    let front = s.follower.vehicle.length / 2.0;
    let with = |c| {
        let mut x = s.clone();
        x.controller = c;
        x
    };
    let r = batch(&[with(ROBUST2), with(ROBUST), with(PAPER)]);
    let min_gap = |x: &RunResult| x.series.follower_x.iter().map(|fx| car_rear - (fx + front)).fold(f64::INFINITY, f64::min);
    assert!(min_gap(&r[0]) > 2.0, "flc-robust: {}", min_gap(&r[0]));
    assert!(min_gap(&r[1]) > 2.0, "flc-robust-v1: {}", min_gap(&r[1]));
    assert!(min_gap(&r[2]) < 0.0, "paper FLC: {}", min_gap(&r[2]));
}
