//! Mixed traffic (issue 25): the pipeline must know which vehicle it follows. A car without V2V
//! that cuts in between the ego and its V2V lead (or is revealed by a cut-out) is not the V2V
//! sender; the supervisor's association rule hands the ego to the FLC before the PID issues a
//! single command on the new object's distance, and back when the sender is the object again.
//!
//! The bound: the PID issues **no** command (0 control ticks) on a detection that is not the V2V
//! sender. A car that enters the gap is entirely between the ego and the sender, so the detector's
//! distance drops by at least its length (4.9 m here, >= 3 m for any car) on the first scan that
//! sees it; the rule's jump threshold (1.5 m) flags that scan, and the supervisor switches on
//! the same tick. The tests count the ticks on which the PID drove while the detector's distance
//! was not the gap to the V2V lead (|detected - gap to the lead| > 1.5 m): that count must be 0.
//! With the neighbour tracker the car is not the sender earlier still: once it has moved towards
//! the ego's path by more than the wandering zone, before the detector finds it in the path.

use flc_sim::{RunResult, Scenario, run};

const LEN: f64 = 4.9;
/// `SwitchReason::NotAssociated as u8`.
const NOT_ASSOCIATED: u8 = 5;
const PID: u8 = 1;

fn kmh(v: f64) -> f64 {
    v / 3.6
}

/// Two lanes; the lead in lane 0 at `v_ego` km/h, the ego (pipeline, default V2V) behind it at
/// its PID's equilibrium gap. A car without V2V in lane 1 at `v_car` km/h, its rear `car_gap` m
/// ahead of the ego's front bumper when it starts a `duration` s lane change into lane 0 at 3 s.
///
/// The paper PID's gap (6 m + 0.5 s v + Scale_f) has no room for a car 20 or 30 m ahead of the
/// ego; where it does not (`car_gap + 4.9 m + 8 m` beyond it), the PID's time gap is raised so
/// that its equilibrium gap is that (the association rule does not depend on it).
fn cut_in(v_ego: f64, v_car: f64, car_gap: f64, duration: f64, run_s: f64) -> (Scenario, f64) {
    let (ve, vc) = (kmh(v_ego), kmh(v_car));
    let t0 = 3.0;
    let mut pid = flc_core::PidParams::paper();
    let need = car_gap + LEN + 8.0;
    if pid.desired_distance(ve) < need {
        pid.time_gap += (need - pid.desired_distance(ve)) / ve;
    }
    let lead_gap = pid.desired_distance(ve);
    let time_gap = pid.time_gap;
    // The ego's front bumper starts at 5.9 m and drives at ve until t0 (the car's centre s).
    let s_car = 5.9 + car_gap + (ve - vc) * t0 + LEN / 2.0;
    let text = format!(
        r#"
name = "assoc-cut-in"
controller = "pipeline"
duration = {run_s}
[track]
kind = "custom"
centerline = [[0.0, 0.0], [8000.0, 0.0]]
lane_width = 3.5
lanes = 2
[lead]
initial_speed = {ve}
[[lead.phases]]
kind = "hold"
duration = 1000.0
[v2v]
enabled = true
[pid]
time_gap = {time_gap}
[follower]
initial_speed = {ve}
initial_gap = {lead_gap}
lane_keeping = true
[[vehicles]]
name = "cutin"
s = {s_car}
lane = 1
initial_speed = {vc}
[[vehicles.phases]]
kind = "lane_change"
lane = 0
duration = {duration}
start = {{ kind = "simulation_time", rule = "greater_or_equal", value = {t0} }}
[[vehicles.phases]]
kind = "hold"
duration = 1000.0
"#
    );
    (Scenario::from_toml_str(&text, "assoc-cut-in.toml").unwrap_or_else(|e| panic!("{e}")), lead_gap)
}

/// Figures of a run: min gap to whatever is in front, ticks the PID drove on a detection that was
/// not the V2V lead, time from the first such detection to the FLC, time back to the PID.
#[derive(Debug)]
struct Figures {
    min_gap: f64,
    pid_on_wrong_object: usize,
    first_wrong: Option<f64>,
    fallback: Option<f64>,
    handback: Option<f64>,
}

/// `lead_gap0`, `v_lead`: the V2V lead's initial gap (m) and its constant speed (m/s); the
/// series' `lead_*` columns are the vehicle in front, so the lead's gap is computed.
fn figures(r: &RunResult, lead_gap0: f64, v_lead: f64) -> Figures {
    let s = &r.series;
    let lead_gap = |k: usize| lead_gap0 + v_lead * s.t[k] - (s.follower_x[k] - s.follower_x[0]);
    // Before anything happens the detector sees the lead where it is computed to be.
    assert!((1..20).all(|k| s.detected_distance[k].is_nan() || (s.detected_distance[k] - lead_gap(k)).abs() < 0.5));
    let wrong = |k: usize| s.detected_distance[k].is_finite() && (s.detected_distance[k] - lead_gap(k)).abs() > 1.5;
    let first_wrong = (0..s.len()).find(|&k| wrong(k));
    let fallback = (0..s.len()).find(|&k| s.reason[k] == NOT_ASSOCIATED);
    let handback = fallback.and_then(|f| (f..s.len()).find(|&k| s.active[k] == PID));
    Figures {
        min_gap: s.gap.iter().copied().fold(f64::INFINITY, f64::min),
        pid_on_wrong_object: (0..s.len()).filter(|&k| s.active[k] == PID && wrong(k)).count(),
        first_wrong: first_wrong.map(|k| s.t[k]),
        fallback: fallback.map(|k| s.t[k]),
        handback: handback.map(|k| s.t[k]),
    }
}

/// The issue's three cut-ins (the paper-pipeline contact cases) and the same at 130 km/h.
#[test]
fn cut_ins_fall_back_before_the_pid_drives_on_the_new_car_and_do_not_collide() {
    // (ego km/h, car km/h, car gap m, lane change s)
    let cases = [
        (60.0, 50.0, 20.0, 3.0),
        (80.0, 80.0, 8.0, 2.0),
        (100.0, 70.0, 30.0, 2.5),
        (130.0, 120.0, 20.0, 3.0),
        (130.0, 130.0, 8.0, 2.0),
        (130.0, 100.0, 30.0, 2.5),
    ];
    for (ve, vc, gap, dur) in cases {
        let (s, lead_gap) = cut_in(ve, vc, gap, dur, 30.0);
        let r = run(&s).expect("run");
        let f = figures(&r, lead_gap, kmh(ve));
        eprintln!("cut-in {ve}/{vc} km/h {gap} m {dur} s: {f:?} contact {:?}", r.collision.as_ref().map(|c| c.impact_speed));
        assert!(r.collision.is_none() && !r.metrics.collision, "{ve}/{vc}: contact {:?}", r.collision);
        assert!(f.min_gap > 1.0, "{ve}/{vc}: min gap {}", f.min_gap);
        let (w, fb) = (f.first_wrong.expect("the detector sees the car"), f.fallback.expect("a fallback"));
        // The bound: not one tick of PID on the car that cut in; the fallback no later than the
        // first scan that sees it (one 10 ms physics step of slack for the record's order).
        assert_eq!(f.pid_on_wrong_object, 0, "{ve}/{vc}: {f:?}");
        assert!(fb <= w + 0.011, "{ve}/{vc}: fallback {fb} s, first wrong detection {w} s");
        // Without association the pipeline would drive on it: the PID was active until the
        // fallback (which the neighbour tracker's intruder brings before the detector sees the car).
        assert!(r.series.active.iter().zip(&r.series.t).any(|(&a, &t)| a == PID && t < fb && t > fb - 0.5), "{ve}/{vc}: PID before");
    }
}

/// The pipeline runs the neighbour tracker (`flc_core::NeighbourTracker`) after each scan: a car
/// entering the lane nearer than the V2V lead is an intruder, not the sender (association rule 4),
/// so the supervisor hands the ego to its FLC, which follows the car, before the detector finds
/// the car in the path. The same six cut-ins with the tracker off (`neighbours.max_range = 0`,
/// the pipeline before it ran the tracker), measured: the fallback 1.20, 0.65, 0.70, 1.05, 0.60
/// and 0.65 s earlier, the least gap 8.48 -> 11.88, 11.25 -> 11.28, 15.69 -> 21.40, 15.39 ->
/// 18.42, 11.69 -> 11.75 and 18.76 -> 24.20 m (the two 8 m cases at the ego's speed gain little:
/// the car is in the path before the ego closes on it).
#[test]
fn the_neighbour_tracker_hands_the_pipeline_to_its_flc_before_the_detector_sees_the_cut_in() {
    let cases = [
        (60.0, 50.0, 20.0, 3.0),
        (80.0, 80.0, 8.0, 2.0),
        (100.0, 70.0, 30.0, 2.5),
        (130.0, 120.0, 20.0, 3.0),
        (130.0, 130.0, 8.0, 2.0),
        (130.0, 100.0, 30.0, 2.5),
    ];
    for (ve, vc, gap, dur) in cases {
        let (s, lead_gap) = cut_in(ve, vc, gap, dur, 30.0);
        let mut off = s.clone();
        off.neighbours.max_range = 0.0;
        let (with, without) = (run(&s).expect("run"), run(&off).expect("run"));
        let (f, g) = (figures(&with, lead_gap, kmh(ve)), figures(&without, lead_gap, kmh(ve)));
        let tag = format!("{ve}/{vc} km/h {gap} m {dur} s");
        let (fb, fb_off, w) = (f.fallback.expect("fallback"), g.fallback.expect("fallback"), f.first_wrong.expect("seen"));
        eprintln!(
            "{tag}: fallback {fb:.2} s (without the tracker {fb_off:.2} s, {:.2} s earlier), detector first sees the car at {w:.2} s; \
             least gap {:.2} m (without {:.2} m)",
            fb_off - fb,
            f.min_gap,
            g.min_gap
        );
        assert!(with.collision.is_none() && without.collision.is_none(), "{tag}");
        // Without the tracker the fallback waits for the detector's first sight of the car ...
        assert!((fb_off - w).abs() < 0.011, "{tag}: without the tracker, fallback at {fb_off} s, first detection {w} s");
        // ... with it the car is not the sender well before (at least 3 scans at 20 Hz) ...
        assert!(fb < w - 0.15, "{tag}: fallback at {fb} s, first detection {w} s");
        assert_eq!(f.pid_on_wrong_object, 0, "{tag}");
        // ... and the ego, its FLC following the car sooner, keeps a larger least gap.
        assert!(f.min_gap > g.min_gap, "{tag}: least gap {} m, without the tracker {} m", f.min_gap, g.min_gap);
    }
}

/// The same cut-in with association off: the PID drives on the distance to the car that cut in (the rule is what prevents it).
#[test]
fn without_association_the_pid_drives_on_the_car_that_cut_in() {
    let (mut s, lead_gap) = cut_in(80.0, 80.0, 8.0, 2.0, 30.0);
    s.supervisor.association.enabled = false;
    let r = run(&s).expect("run");
    let f = figures(&r, lead_gap, kmh(80.0));
    eprintln!("association off: {f:?} contact {:?}", r.collision.as_ref().map(|c| c.impact_speed));
    assert!(f.pid_on_wrong_object > 0);
}

/// The car that cut in leaves again: the sender is the detected object again and the PID drives.
#[test]
fn the_pid_drives_again_when_the_car_that_cut_in_leaves() {
    let (mut s, lead_gap) = cut_in(80.0, 80.0, 8.0, 2.0, 40.0);
    let text = r#"
kind = "lane_change"
lane = 1
duration = 3.0
start = { kind = "simulation_time", rule = "greater_or_equal", value = 15.0 }
"#;
    let back: flc_sim::ScriptedPhase = toml::from_str(text).expect("phase");
    s.vehicles[0].phases.insert(1, back);
    let r = run(&s).expect("run");
    let f = figures(&r, lead_gap, kmh(80.0));
    eprintln!("cut-in and out: {f:?}");
    assert!(r.collision.is_none());
    assert_eq!(f.pid_on_wrong_object, 0);
    let hb = f.handback.expect("the PID drives again");
    assert!(hb > 15.0 && hb < 22.0, "{f:?}");
}

/// A cut-out: the V2V lead changes lanes and reveals a slower car without V2V.
#[test]
fn a_cut_out_revealing_a_car_without_v2v_falls_back_at_once() {
    for v in [80.0, 130.0] {
        let ve = kmh(v);
        let lead_gap = 25.0;
        // The hidden car: 60 m ahead of the lead's front, 30 km/h slower (the lead leaves from
        // 2 to 5 s, before it reaches the car).
        let s_hidden = 5.9 + lead_gap + LEN + 60.0 + LEN / 2.0;
        let text = format!(
            r#"
name = "assoc-cut-out"
controller = "pipeline"
duration = 30.0
[track]
kind = "custom"
centerline = [[0.0, 0.0], [8000.0, 0.0]]
lane_width = 3.5
lanes = 2
[lead]
initial_speed = {ve}
[[lead.phases]]
kind = "hold"
duration = 2.0
[[lead.phases]]
kind = "lane_change"
lane = 1
duration = 3.0
[[lead.phases]]
kind = "hold"
duration = 1000.0
[v2v]
enabled = true
[follower]
initial_speed = {ve}
initial_gap = {lead_gap}
lane_keeping = true
[[vehicles]]
name = "hidden"
s = {s_hidden}
lane = 0
initial_speed = {vc}
[[vehicles.phases]]
kind = "hold"
duration = 1000.0
"#,
            vc = ve - kmh(30.0)
        );
        let sc = Scenario::from_toml_str(&text, "assoc-cut-out.toml").expect("scenario");
        let r = run(&sc).expect("run");
        let f = figures(&r, lead_gap, ve);
        eprintln!("cut-out {v} km/h: {f:?} contact {:?}", r.collision.as_ref().map(|c| c.impact_speed));
        assert!(r.collision.is_none() && !r.metrics.collision, "{v}: {:?}", r.collision);
        assert_eq!(f.pid_on_wrong_object, 0, "{v}: {f:?}");
        let (w, fb) = (f.first_wrong.expect("the hidden car is seen"), f.fallback.expect("fallback"));
        assert!(fb <= w + 0.011, "{v}: {f:?}");
    }
}

/// Association losses of a run: the ticks on which the supervisor reported `not_associated`
/// (there is no car but the V2V lead in these runs, so each is a false fallback), and the
/// simulated time.
fn losses(r: &RunResult) -> (usize, f64) {
    let s = &r.series;
    let n = (1..s.len()).filter(|&k| s.reason[k] == NOT_ASSOCIATED && s.reason[k - 1] != NOT_ASSOCIATED).count();
    (n, s.t.last().copied().unwrap_or(0.0))
}

fn with_gnss(s: &mut Scenario, sigma: f64, latency: f64) {
    s.v2v.gnss.sigma_m = sigma;
    s.v2v.latency = latency;
    s.v2v.jitter = 0.005;
}

/// No false fallback: an hour of steady following at 100 km/h for each GNSS error (1, 2, 3 m
/// sigma; the supervisor's gate assumes 3 m) with 100 ms V2V latency, and the paper experiment's
/// pipeline cells at 20 ms and 100 ms, five seeds each (> 1 h of driving per GNSS error): no
/// association loss at all, and the paper cells' outcomes as in the paper's table.
#[test]
fn no_association_loss_in_an_hour_of_following_with_gnss_error_and_latency() {
    let mut steady = Vec::new();
    for sigma in [1.0, 2.0, 3.0] {
        let v = kmh(100.0);
        let text = format!(
            r#"
name = "assoc-steady"
controller = "pipeline"
duration = 3600.0
[track]
kind = "custom"
centerline = [[0.0, 0.0], [110000.0, 0.0]]
[lead]
initial_speed = {v}
[[lead.phases]]
kind = "hold"
duration = 4000.0
[v2v]
enabled = true
[follower]
initial_speed = {v}
initial_gap = 21.0
"#
        );
        let mut s = Scenario::from_toml_str(&text, "assoc-steady.toml").expect("scenario");
        with_gnss(&mut s, sigma, 0.1);
        s.seed = sigma as u64;
        steady.push(s);
    }
    let mut paper = Vec::new();
    for sigma in [1.0, 2.0, 3.0] {
        for latency in [0.02, 0.1] {
            for v in flc_sim::PAPER_SPEEDS_KMH {
                for seed in 1..=5 {
                    let mut s = Scenario::paper_experiment(v, flc_sim::ControllerKind::Pipeline, flc_sim::Calibration::Paper);
                    with_gnss(&mut s, sigma, latency);
                    s.seed = seed;
                    paper.push(s);
                }
            }
        }
    }
    // The paper cells as they are (default GNSS and latency), for the comparison below.
    let plain: Vec<Scenario> = paper
        .iter()
        .filter(|s| s.v2v.gnss.sigma_m == 1.0 && s.v2v.latency == 0.02)
        .map(|s| {
            let mut p =
                Scenario::paper_experiment(s.speed_kmh.expect("paper"), flc_sim::ControllerKind::Pipeline, flc_sim::Calibration::Paper);
            p.seed = s.seed;
            p
        })
        .collect();
    let all: Vec<Scenario> = steady.iter().chain(&paper).chain(&plain).cloned().collect();
    let results: Vec<RunResult> = flc_sim::RunOptions::default().run_batch(&all).into_iter().map(|r| r.expect("run")).collect();
    let (checked, reference) = results.split_at(steady.len() + paper.len());
    let mut total = (0usize, 0.0f64);
    for (s, r) in all.iter().zip(checked) {
        let (n, t) = losses(r);
        total = (total.0 + n, total.1 + t);
        assert_eq!(n, 0, "{} sigma {} latency {} seed {}: {n} association losses", s.name, s.v2v.gnss.sigma_m, s.v2v.latency, s.seed);
    }
    // The paper table's pipeline rows stay as they are: at the default latency the GNSS error
    // changes no metric of any cell (bit for bit), whatever its sigma.
    let paper_runs = &checked[steady.len()..];
    for (s, r) in paper.iter().zip(paper_runs).filter(|(s, _)| s.v2v.latency == 0.02) {
        let p = plain.iter().position(|p| p.speed_kmh == s.speed_kmh && p.seed == s.seed).expect("reference");
        assert_eq!(r.metrics, reference[p].metrics, "{} sigma {} seed {}", s.name, s.v2v.gnss.sigma_m, s.seed);
    }
    eprintln!("association losses: {} in {:.0} s of simulated driving", total.0, total.1);
    assert_eq!(total.0, 0);
    assert!(total.1 > 3.0 * 3600.0, "{} s", total.1);
}

/// A platoon of three pipelines: a car cutting in between followers 1 and 2 makes follower 2
/// fall back (its V2V sender, follower 1, is no longer the vehicle in front) while follower 1 and
/// follower 3 keep V2V; the string-stability figures list follower 2.
#[test]
fn in_a_platoon_only_the_follower_behind_the_cut_in_falls_back() {
    let v = kmh(80.0);
    let gap = flc_core::PidParams::paper().desired_distance(v);
    // Follower 3's front bumper is at 5.9 m, follower 2's at 5.9 + (4.9 + gap) m; the car's rear
    // 7 m ahead of follower 2's (the string spreads to the PID's gap before the car moves).
    let s_car = 5.9 + 7.0 + LEN / 2.0 + (LEN + gap);
    let text = format!(
        r#"
name = "assoc-platoon-cut-in"
controller = "pipeline"
duration = 30.0
[track]
kind = "custom"
centerline = [[0.0, 0.0], [8000.0, 0.0]]
lanes = 2
[lead]
initial_speed = {v}
[[lead.phases]]
kind = "hold"
duration = 1000.0
[v2v]
enabled = true
[follower]
initial_speed = {v}
initial_gap = {gap}
lane_keeping = true
[platoon]
followers = 3
[[vehicles]]
name = "cutin"
s = {s_car}
lane = 1
initial_speed = {v}
[[vehicles.phases]]
kind = "lane_change"
lane = 0
duration = 2.0
start = {{ kind = "simulation_time", rule = "greater_or_equal", value = 5.0 }}
[[vehicles.phases]]
kind = "hold"
duration = 1000.0
"#
    );
    let r = run(&Scenario::from_toml_str(&text, "assoc-platoon.toml").expect("scenario")).expect("run");
    let p = r.platoon.as_ref().expect("platoon");
    assert!(p.followers.iter().all(|f| f.collision.is_none()));
    let fell_back: Vec<bool> = p.followers.iter().map(|f| f.series.reason.contains(&NOT_ASSOCIATED)).collect();
    assert_eq!(fell_back, [false, true, false]);
    // Followers 1 and 3 drive on V2V throughout the cut-in (the PID from 1 s on).
    for k in [0, 2] {
        let s = &p.followers[k].series;
        assert!((0..s.len()).filter(|&i| s.t[i] > 2.0).all(|i| s.active[i] == PID), "follower {}", k + 1);
    }
    // Follower 2 never drove on the car with its V2V sender's speed.
    let s2 = &p.followers[1].series;
    // (follower 1 stays 26 to 30 m ahead of it; the car comes in at ~14 m)
    assert!(p.followers[0].series.gap.iter().all(|&g| g > 25.0));
    assert!(s2.detected_distance.iter().any(|&d| d < 20.0), "follower 2 sees the car");
    assert_eq!((0..s2.len()).filter(|&i| s2.active[i] == PID && s2.detected_distance[i] < 20.0).count(), 0);
    assert_eq!(p.string_stability.not_associated, [2]);
}

/// The defaults the docs list are the code's.
#[test]
fn the_documented_association_defaults_are_the_codes() {
    let p = flc_core::AssociationParams::default();
    let line = format!(
        "`[supervisor.association]`: `enabled` ({}), `jump_m` ({}), `track_tau_s` ({}), `speed_error_mps` ({}), `gnss_sigma_m` ({}), `gate_sigmas` ({}), `max_latency_s` ({})",
        p.enabled, p.jump_m, p.track_tau_s, p.speed_error_mps, p.gnss_sigma_m, p.gate_sigmas, p.max_latency_s
    );
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let scen = std::fs::read_to_string(root.join("docs/scenarios.md")).expect("docs");
    assert!(scen.contains(&line), "docs/scenarios.md should say: {line}");
    let v2v = std::fs::read_to_string(root.join("docs/v2v-and-metrics.md")).expect("docs");
    for row in [
        format!("| `jump_m` | {} m |", p.jump_m),
        format!("| `track_tau_s` | {} s |", p.track_tau_s),
        format!("| `speed_error_mps` | {} m/s |", p.speed_error_mps),
        format!("| `gnss_sigma_m` | {} m |", p.gnss_sigma_m),
        format!("| `gate_sigmas` | {} |", p.gate_sigmas),
        format!("| `max_latency_s` | {} s |", p.max_latency_s),
    ] {
        assert!(v2v.contains(&row), "docs/v2v-and-metrics.md should have {row}");
    }
    let g = flc_sim::gnss::GnssParams::default();
    assert!(v2v.contains(&format!("`{{ sigma_m = {}, tau_s = {} }}`", g.sigma_m, g.tau_s)));
}
