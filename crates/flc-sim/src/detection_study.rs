//! The detector study (issue 23, `docs/detector.md`): how well the LiDAR lead detector that is in
//! the tree sees a lead on the ego's path, measured with the real [`Lidar`] (its noise, dropout
//! and seed) in the rapier world of the preset tracks, and how often it sees one where there is
//! none.
//!
//! - **Range study** ([`RangeStudy`]): static placements. The ego stands on the centreline at arc
//!   position `s` with the road's heading, a target body (a rectangle aligned with the road) stands
//!   in the same lane with its rear face about `range` m (along the centreline) ahead of the
//!   sensor. Many frames per range bin: stratified `s` positions along the track, a random range
//!   inside the bin, a LiDAR seed per frame and condition. The detector gets the path curvature
//!   the follower would give it (the arc through the target's true rear-face centre in the sensor
//!   frame, `kappa = 2 y / (x² + y²)`, as `sim/follower.rs` computes from the last detection).
//!   Ground truth: the sensor-frame x of the nearest point of the rear face (what the detector
//!   reports as `distance`). The target is *visible* when an impairment-free scan sees its
//!   nearest point (a return on it within [`ACCURATE`] of that distance) and at least half its
//!   width. Guard rails hide the target, or part of it, in curves: such frames are counted apart
//!   (*partly hidden*: some rays on the target; *hidden*: none), with their own detection counts,
//!   and the rates are over the visible frames.
//! - **Clutter run** ([`ClutterRun`]): the ego drives along the tracks without any lead, one scan
//!   every `speed / 20 Hz` of distance; every frame with a detection is a false detection.
//!
//! Deterministic: every frame's randomness comes from the study's seed and the frame's indices,
//! frames are independent (own LiDAR; world poses set before each cast), and their results are
//! added in frame order, so they do not depend on rayon's thread count (tested).

use std::fmt::Write;

use flc_core::{DetectorParams, LeadDetector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::lidar::{Lidar, LidarParams};
use crate::svg::{Chart, Line, Panel, bars};
use crate::track::Track;
use crate::vehicle::{VehicleParams, VehicleState};
use crate::world::{Body, World};

/// A target's footprint (a rectangle aligned with the road).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Name in tables and figures.
    pub name: &'static str,
    /// Width, m.
    pub width: f64,
    /// Length, m.
    pub length: f64,
}

/// A car, 1.8 m x 4.7 m (the default vehicle's footprint).
pub const CAR: Target = Target { name: "car", width: 1.8, length: 4.7 };
/// A truck, 2.55 m x 12 m (the EU width limit).
pub const TRUCK: Target = Target { name: "truck", width: 2.55, length: 12.0 };
/// A motorcycle-width target, 0.8 m x 2.2 m.
pub const MOTORCYCLE: Target = Target { name: "motorcycle", width: 0.8, length: 2.2 };

/// The preset tracks of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackKind {
    /// [`Track::straight`] (5.2 km): guard rails, posts, parked cars in the next lane.
    Straight,
    /// [`Track::curvy`] (the route with curves of radius 120-250 m): guard rails, posts.
    Curvy,
}

impl TrackKind {
    /// Both, straight first.
    pub const ALL: [TrackKind; 2] = [TrackKind::Straight, TrackKind::Curvy];

    /// Name in tables and figures.
    pub fn name(self) -> &'static str {
        match self {
            TrackKind::Straight => "straight",
            TrackKind::Curvy => "curvy",
        }
    }

    /// The track.
    pub fn track(self) -> Track {
        match self {
            TrackKind::Straight => Track::straight(5200.0),
            TrackKind::Curvy => Track::curvy(),
        }
    }
}

/// A LiDAR configuration of the study.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// Name in tables and figures.
    pub name: String,
    /// The LiDAR.
    pub lidar: LidarParams,
}

impl Condition {
    /// The default LiDAR ([`LidarParams::default`], its own range noise included).
    pub fn clean() -> Self {
        Self { name: "clean".into(), lidar: LidarParams::default() }
    }

    /// The default LiDAR with per-ray dropout probability `p`.
    pub fn dropout(p: f64) -> Self {
        Self { name: format!("{:.0} % dropout", 100.0 * p), lidar: LidarParams { dropout_prob: p, ..LidarParams::default() } }
    }

    /// The default LiDAR with Gaussian range noise of `std` m.
    pub fn noise(std: f64) -> Self {
        Self { name: format!("{:.0} cm noise", 100.0 * std), lidar: LidarParams { range_noise_std: std, ..LidarParams::default() } }
    }

    /// The four: clean, 25 % and 50 % per-ray dropout, 5 cm range noise.
    pub fn standard() -> Vec<Self> {
        vec![Self::clean(), Self::dropout(0.25), Self::dropout(0.5), Self::noise(0.05)]
    }
}

/// Range bins `[lo, lo + width)` from `from` to `to` m.
pub fn range_bins(from: f64, to: f64, width: f64) -> Vec<(f64, f64)> {
    let n = ((to - from) / width).round() as usize;
    (0..n).map(|i| (from + width * i as f64, from + width * (i + 1) as f64)).collect()
}

/// A detection is *accurate* when its distance is within this of the truth, m (the target).
pub const ACCURATE: f64 = 0.3;
/// A detection belongs to the target when its position lies within the target's footprint grown
/// by this much on every side, m.
const ASSOCIATION_GATE: f64 = 1.0;
/// A point of the impairment-free scan is on the target within this of its footprint, m (the
/// ray casts are f32).
const ON_TARGET: f64 = 0.05;
/// Room left at the track's ends, m.
const END_MARGIN: f64 = 5.0;

/// A range study of one target on one track under several LiDAR conditions.
#[derive(Debug, Clone)]
pub struct RangeStudy {
    /// The track.
    pub track: TrackKind,
    /// The target.
    pub target: Target,
    /// Lateral offset of the target's centre from the lane centre, m (+ left).
    pub lateral_offset: f64,
    /// The LiDAR conditions (each frame is scanned under every one, same placement).
    pub conditions: Vec<Condition>,
    /// Range bins `[lo, hi)`, m along the centreline from the sensor to the rear face.
    pub bins: Vec<(f64, f64)>,
    /// Frames per bin.
    pub frames_per_bin: usize,
    /// The detector's parameters.
    pub detector: DetectorParams,
    /// Seed of every random draw.
    pub seed: u64,
}

impl RangeStudy {
    /// `target` on `track` under [`Condition::standard`], 10-200 m in 10 m bins, 100 frames per
    /// bin, the default detector, seed 23.
    pub fn new(track: TrackKind, target: Target) -> Self {
        Self {
            track,
            target,
            lateral_offset: 0.0,
            conditions: Condition::standard(),
            bins: range_bins(10.0, 200.0, 10.0),
            frames_per_bin: 100,
            detector: DetectorParams::default(),
            seed: 23,
        }
    }
}

/// The counts of one range bin under one condition.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BinResult {
    /// The bin `[lo, hi)`, m.
    pub lo: f64,
    /// The bin `[lo, hi)`, m.
    pub hi: f64,
    /// Frames placed.
    pub frames: usize,
    /// Frames in which the impairment-free scan sees the target's nearest point (a return within
    /// [`ACCURATE`] of the true distance) and at least half its width.
    pub visible: usize,
    /// Frames in which rays of the impairment-free scan hit the target but it is not visible (a
    /// guard rail hides its near corner or more than half of it).
    pub partly_hidden: usize,
    /// Partly hidden frames with a detection of the target (any distance error).
    pub partly_detected: usize,
    /// Visible frames with a detection of the target (any distance error).
    pub detected: usize,
    /// Visible frames with a detection of the target within [`ACCURATE`] of the true distance.
    pub accurate: usize,
    /// Frames with a detection that is not the target.
    pub wrong: usize,
    /// Sum of |distance error| over the detections of the target, m.
    pub sum_abs_error: f64,
    /// Largest |distance error| of a detection of the target, m.
    pub max_abs_error: f64,
}

impl BinResult {
    /// Detections of the target over visible frames (NaN without a visible frame).
    pub fn detection_rate(&self) -> f64 {
        ratio(self.detected, self.visible)
    }

    /// Accurate detections (within [`ACCURATE`]) over visible frames.
    pub fn accurate_rate(&self) -> f64 {
        ratio(self.accurate, self.visible)
    }

    /// Mean |distance error| of the detections of the target, m (NaN without one).
    pub fn mean_abs_error(&self) -> f64 {
        if self.detected == 0 { f64::NAN } else { self.sum_abs_error / self.detected as f64 }
    }

    /// Adds `other`'s counts (the bin limits become the union).
    pub fn merge(&mut self, other: &BinResult) {
        if self.frames == 0 {
            self.lo = other.lo;
            self.hi = other.hi;
        }
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
        self.frames += other.frames;
        self.visible += other.visible;
        self.partly_hidden += other.partly_hidden;
        self.partly_detected += other.partly_detected;
        self.detected += other.detected;
        self.accurate += other.accurate;
        self.wrong += other.wrong;
        self.sum_abs_error += other.sum_abs_error;
        self.max_abs_error = self.max_abs_error.max(other.max_abs_error);
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 { f64::NAN } else { a as f64 / b as f64 }
}

/// The result of a range study under one condition.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Track name.
    pub track: &'static str,
    /// The target.
    pub target: Target,
    /// Condition name.
    pub condition: String,
    /// One per bin.
    pub bins: Vec<BinResult>,
}

impl Curve {
    /// The bins with `hi <= up_to` merged into one.
    pub fn pooled(&self, up_to: f64) -> BinResult {
        let mut all = BinResult::default();
        for b in self.bins.iter().filter(|b| b.hi <= up_to + 1e-9) {
            all.merge(b);
        }
        all
    }
}

/// splitmix64: independent seeds from a few indices.
fn mix(parts: &[u64]) -> u64 {
    let mut h = 0x9E37_79B9_7F4A_7C15_u64;
    for &p in parts {
        let mut z = h ^ p.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        h = z ^ (z >> 31);
    }
    h
}

/// A rigid 2D frame: `to_local` maps world points into it.
#[derive(Debug, Clone, Copy)]
struct Frame2 {
    x: f64,
    y: f64,
    yaw: f64,
}

impl Frame2 {
    fn to_local(self, p: [f64; 2]) -> [f64; 2] {
        let (c, s) = (self.yaw.cos(), self.yaw.sin());
        let (dx, dy) = (p[0] - self.x, p[1] - self.y);
        [c * dx + s * dy, -s * dx + c * dy]
    }

    fn to_world(self, p: [f64; 2]) -> [f64; 2] {
        let (c, s) = (self.yaw.cos(), self.yaw.sin());
        [self.x + c * p[0] - s * p[1], self.y + s * p[0] + c * p[1]]
    }
}

/// The sensor's frame for an ego at `pose` with LiDAR `p`.
fn sensor_frame(pose: &VehicleState, p: &LidarParams) -> Frame2 {
    let body = Frame2 { x: pose.x, y: pose.y, yaw: pose.yaw };
    let [x, y] = body.to_world([p.mount_x, p.mount_y]);
    Frame2 { x, y, yaw: pose.yaw + p.mount_yaw_deg.to_radians() }
}

/// The geometry of one placement, in the sensor frame.
#[derive(Debug, Clone, Copy)]
struct Truth {
    /// Sensor-frame x of the rear face's nearest point, m.
    distance: f64,
    /// The path curvature the follower would give the detector, 1/m.
    curvature: f64,
    /// The target's own frame, expressed in the sensor frame.
    target: Frame2,
}

fn truth(sensor: &Frame2, target: &VehicleState, t: &Target) -> Truth {
    let body = Frame2 { x: target.x, y: target.y, yaw: target.yaw };
    let corner = |side: f64| sensor.to_local(body.to_world([-t.length / 2.0, side * t.width / 2.0]));
    let (a, b) = (corner(-1.0), corner(1.0));
    let [xr, yr] = sensor.to_local(body.to_world([-t.length / 2.0, 0.0]));
    let r2 = xr * xr + yr * yr;
    let [cx, cy] = sensor.to_local([target.x, target.y]);
    Truth {
        distance: a[0].min(b[0]),
        curvature: if r2 > 1.0 { 2.0 * yr / r2 } else { 0.0 },
        target: Frame2 { x: cx, y: cy, yaw: target.yaw - sensor.yaw },
    }
}

/// `true` if the sensor-frame point `p` lies within `margin` of the target's footprint.
fn on_target(tr: &Truth, t: &Target, p: [f64; 2], margin: f64) -> bool {
    let [u, v] = tr.target.to_local(p);
    u.abs() <= t.length / 2.0 + margin && v.abs() <= t.width / 2.0 + margin
}

/// `(visible, partly hidden)` from an impairment-free scan: visible when a return on the target
/// lies within [`ACCURATE`] of the true distance and the returns cover at least half the
/// target's width across its axis (their extent plus one beam spacing at their range, as the
/// detector's width test counts it); partly hidden when some return is on the target otherwise.
fn visibility(tr: &Truth, t: &Target, points: &[[f64; 2]], spacing_rad: f64) -> (bool, bool) {
    let (mut any, mut near) = (false, false);
    let (mut v_lo, mut v_hi, mut range) = (f64::INFINITY, f64::NEG_INFINITY, 0.0_f64);
    for p in points.iter().filter(|p| on_target(tr, t, **p, ON_TARGET)) {
        any = true;
        near |= (p[0] - tr.distance).abs() <= ACCURATE;
        let v = tr.target.to_local(*p)[1];
        v_lo = v_lo.min(v);
        v_hi = v_hi.max(v);
        range = range.max(p[0].hypot(p[1]));
    }
    let visible = near && v_hi - v_lo + range * spacing_rad >= 0.5 * t.width;
    (visible, any && !visible)
}

/// The same LiDAR without impairments (for the visibility scan).
fn unimpaired(p: &LidarParams) -> LidarParams {
    LidarParams { range_noise_std: 0.0, dropout_prob: 0.0, scan_drop_prob: 0.0, ..p.clone() }
}

/// Per-thread state: a world with the ego (and the target) and a detector.
struct Bench {
    world: World,
    ego: Body,
    target: Option<Body>,
    detector: Box<LeadDetector>,
}

impl Bench {
    fn new(track: &Track, target: Option<&Target>, detector: DetectorParams) -> Self {
        let mut world = World::new(track);
        let ego = world.add_vehicle(&VehicleParams::default(), &VehicleState::default());
        let target = target.map(|t| {
            let p = VehicleParams { width: t.width, length: t.length, ..VehicleParams::default() };
            world.add_vehicle(&p, &VehicleState { x: -1e4, ..Default::default() })
        });
        let detector = Box::new(<LeadDetector>::new(detector).expect("detector parameters"));
        Self { world, ego, target, detector }
    }
}

/// Runs a range study: one [`Curve`] per condition, in the order of `study.conditions`.
pub fn run_range_study(study: &RangeStudy) -> Vec<Curve> {
    let track = study.track.track();
    let t = study.target;
    let nb = study.bins.len();
    let nc = study.conditions.len();
    let frames: Vec<(usize, usize)> = (0..nb).flat_map(|b| (0..study.frames_per_bin).map(move |k| (b, k))).collect();
    let per_frame = frames
        .par_iter()
        .map_init(
            || Bench::new(&track, Some(&t), study.detector),
            |bench, &(b, k)| {
                let mut out = Vec::with_capacity(nc);
                let (lo, hi) = study.bins[b];
                let mut rng = ChaCha8Rng::seed_from_u64(mix(&[study.seed, 1, b as u64, k as u64]));
                let range = lo + (hi - lo) * rng.random::<f64>();
                let mount = study.conditions.first().map_or(0.0, |c| c.lidar.mount_x);
                let span = track.length() - 2.0 * END_MARGIN - range - t.length - mount;
                let s = END_MARGIN + span.max(0.0) * (k as f64 + rng.random::<f64>()) / study.frames_per_bin as f64;
                let (x, y, yaw) = track.pose_at(s);
                let ego = VehicleState { x, y, yaw, ..Default::default() };
                let (tx, ty, tyaw) = track.place(s + mount + range + t.length / 2.0, study.lateral_offset);
                let target = VehicleState { x: tx, y: ty, yaw: tyaw, ..Default::default() };
                bench.world.set_pose(bench.ego, &ego);
                if let Some(body) = bench.target {
                    bench.world.set_pose(body, &target);
                }
                bench.world.step(0.01);
                let mut last_clean: Option<(LidarParams, (bool, bool))> = None;
                for (c, cond) in study.conditions.iter().enumerate() {
                    let sensor = sensor_frame(&ego, &cond.lidar);
                    let tr = truth(&sensor, &target, &t);
                    let clean = unimpaired(&cond.lidar);
                    let (visible, partly) = match &last_clean {
                        Some((p, v)) if *p == clean => *v,
                        _ => {
                            let scan = Lidar::new(clean.clone(), 0).capture(0.0, &bench.world, bench.ego, &ego);
                            let v = visibility(&tr, &t, &scan.points, clean.resolution_deg.to_radians());
                            last_clean = Some((clean, v));
                            v
                        }
                    };
                    let seed = mix(&[study.seed, 2, b as u64, k as u64, c as u64]);
                    let scan = Lidar::new(cond.lidar.clone(), seed).capture(0.0, &bench.world, bench.ego, &ego);
                    let det = bench.detector.detect(&scan.points, tr.curvature).detection;
                    let mut r = BinResult {
                        lo,
                        hi,
                        frames: 1,
                        visible: usize::from(visible),
                        partly_hidden: usize::from(partly),
                        ..Default::default()
                    };
                    if let Some(d) = det {
                        if on_target(&tr, &t, [d.position.x, d.position.y], ASSOCIATION_GATE) {
                            r.partly_detected = usize::from(partly);
                            if visible {
                                let e = (d.distance - tr.distance).abs();
                                r.detected = 1;
                                r.accurate = usize::from(e <= ACCURATE);
                                r.sum_abs_error = e;
                                r.max_abs_error = e;
                            }
                        } else {
                            r.wrong = 1;
                        }
                    }
                    out.push((b * nc + c, r));
                }
                out
            },
        )
        .collect::<Vec<_>>();
    // Added in frame order (not rayon's): the same sums whatever the thread count.
    let mut sums = vec![BinResult::default(); nb * nc];
    for (i, r) in per_frame.iter().flatten() {
        sums[*i].merge(r);
    }
    study
        .conditions
        .iter()
        .enumerate()
        .map(|(c, cond)| Curve {
            track: study.track.name(),
            target: t,
            condition: cond.name.clone(),
            bins: (0..nb)
                .map(|b| {
                    let mut r = sums[b * nc + c];
                    r.lo = study.bins[b].0;
                    r.hi = study.bins[b].1;
                    r
                })
                .collect(),
        })
        .collect()
}

/// A run along the tracks without any lead.
#[derive(Debug, Clone)]
pub struct ClutterRun {
    /// The tracks driven, each from start to end.
    pub tracks: Vec<TrackKind>,
    /// Speed range, km/h: the speed follows a triangle wave between the two along the way.
    pub speed_kmh: (f64, f64),
    /// Period of the speed's triangle wave, m.
    pub speed_period: f64,
    /// The LiDAR (one scan every `speed / rate_hz` of distance).
    pub lidar: LidarParams,
    /// The detector's parameters.
    pub detector: DetectorParams,
    /// Seed of the LiDAR noise.
    pub seed: u64,
}

impl Default for ClutterRun {
    /// Both tracks (5.2 km straight + the 2 km curvy route), 30-130 km/h with a 1 km period,
    /// the default LiDAR and detector, seed 23.
    fn default() -> Self {
        Self {
            tracks: TrackKind::ALL.to_vec(),
            speed_kmh: (30.0, 130.0),
            speed_period: 1000.0,
            lidar: LidarParams::default(),
            detector: DetectorParams::default(),
            seed: 23,
        }
    }
}

/// A false detection of a clutter run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FalseDetection {
    /// Where the ego was, m along the centreline.
    pub s: f64,
    /// The path curvature given to the detector, 1/m.
    pub curvature: f64,
    /// The detection's sensor-frame position, m.
    pub position: [f64; 2],
    /// Its width, m.
    pub width: f64,
    /// Its depth, m.
    pub depth: f64,
    /// Its number of points.
    pub points: usize,
}

/// The result of a clutter run on one track.
#[derive(Debug, Clone, PartialEq)]
pub struct ClutterResult {
    /// Track name.
    pub track: &'static str,
    /// Distance driven, km.
    pub km: f64,
    /// Frames scanned.
    pub frames: usize,
    /// False detections with the road curvature at the ego as the path ([`Track::curvature_at`]).
    pub false_road_curvature: Vec<FalseDetection>,
    /// False detections with a straight path (curvature 0: the follower with
    /// `lost_lead_steering = "straight"`).
    pub false_zero_curvature: Vec<FalseDetection>,
}

impl ClutterResult {
    /// False detections per km, road curvature / zero curvature.
    pub fn per_km(&self) -> (f64, f64) {
        (self.false_road_curvature.len() as f64 / self.km, self.false_zero_curvature.len() as f64 / self.km)
    }
}

/// Speed at `s` of the triangle wave, m/s.
fn clutter_speed(run: &ClutterRun, s: f64) -> f64 {
    let (lo, hi) = run.speed_kmh;
    let phase = (s / run.speed_period).rem_euclid(1.0);
    let tri = 1.0 - (2.0 * phase - 1.0).abs();
    (lo + (hi - lo) * tri) / 3.6
}

/// Runs the clutter run: one result per track.
pub fn run_clutter(run: &ClutterRun) -> Vec<ClutterResult> {
    run.tracks
        .iter()
        .enumerate()
        .map(|(ti, kind)| {
            let track = kind.track();
            let end = track.length() - END_MARGIN;
            let mut stations = Vec::new();
            let mut s = 0.0;
            while s <= end {
                stations.push(s);
                s += clutter_speed(run, s) / run.lidar.rate_hz;
            }
            let found: Vec<(Option<FalseDetection>, Option<FalseDetection>)> = stations
                .par_iter()
                .enumerate()
                .map_init(
                    || Bench::new(&track, None, run.detector),
                    |bench, (k, &s)| {
                        let (x, y, yaw) = track.pose_at(s);
                        let ego = VehicleState { x, y, yaw, ..Default::default() };
                        bench.world.set_pose(bench.ego, &ego);
                        bench.world.step(0.01);
                        let seed = mix(&[run.seed, 3, ti as u64, k as u64]);
                        let scan = Lidar::new(run.lidar.clone(), seed).capture(0.0, &bench.world, bench.ego, &ego);
                        let kappa = track.curvature_at(s);
                        let mut detect = |curvature: f64| {
                            bench.detector.detect(&scan.points, curvature).detection.map(|d| FalseDetection {
                                s,
                                curvature,
                                position: [d.position.x, d.position.y],
                                width: d.width,
                                depth: d.depth,
                                points: d.points,
                            })
                        };
                        (detect(kappa), detect(0.0))
                    },
                )
                .collect::<Vec<_>>();
            let road: Vec<FalseDetection> = found.iter().filter_map(|(a, _)| *a).collect();
            let zero: Vec<FalseDetection> = found.iter().filter_map(|(_, b)| *b).collect();
            ClutterResult {
                track: kind.name(),
                km: stations.last().copied().unwrap_or(0.0) / 1000.0,
                frames: stations.len(),
                false_road_curvature: road,
                false_zero_curvature: zero,
            }
        })
        .collect()
}

/// Colours of the conditions, in [`Condition::standard`] order.
const COLORS: [&str; 6] = ["#1f77b4", "#ff7f0e", "#d62728", "#2ca02c", "#9467bd", "#8c564b"];

/// Panels: one per (track, target) of `curves`, rows = tracks, columns = targets.
/// A second, dashed line per condition: its legend suffix and its value per bin.
type Extra<'a> = Option<(&'a str, &'a dyn Fn(&BinResult) -> f64)>;

fn panels(curves: &[Curve], y: impl Fn(&BinResult) -> f64, extra: Extra<'_>) -> (Vec<Panel>, usize) {
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for c in curves {
        if !keys.contains(&(c.track, c.target.name)) {
            keys.push((c.track, c.target.name));
        }
    }
    let mut targets: Vec<&str> = Vec::new();
    for (_, t) in &keys {
        if !targets.contains(t) {
            targets.push(t);
        }
    }
    let mut conditions: Vec<&str> = Vec::new();
    for c in curves {
        if !conditions.contains(&c.condition.as_str()) {
            conditions.push(&c.condition);
        }
    }
    let panels = keys
        .iter()
        .map(|&(track, target)| {
            let mut lines = Vec::new();
            for c in curves.iter().filter(|c| c.track == track && c.target.name == target) {
                let i = conditions.iter().position(|n| *n == c.condition).unwrap_or(0);
                let color = COLORS[i % COLORS.len()];
                let mid = |b: &BinResult| (b.lo + b.hi) / 2.0;
                lines.push(Line {
                    label: c.condition.clone(),
                    color,
                    dashed: false,
                    points: c.bins.iter().map(|b| (mid(b), y(b))).collect(),
                });
                if let Some((suffix, f)) = extra {
                    lines.push(Line {
                        label: format!("{} ({suffix})", c.condition),
                        color,
                        dashed: true,
                        points: c.bins.iter().map(|b| (mid(b), f(b))).collect(),
                    });
                }
            }
            let w = curves.iter().find(|c| c.target.name == target).map(|c| c.target);
            let size = w.map_or(String::new(), |t| format!(" ({} x {} m)", t.width, t.length));
            Panel { title: format!("{track} track, {target}{size}"), lines }
        })
        .collect();
    (panels, targets.len().max(1))
}

fn max_range(curves: &[Curve]) -> f64 {
    curves.iter().flat_map(|c| &c.bins).map(|b| b.hi).fold(0.0, f64::max)
}

/// Figure: detection rate (over visible frames) vs range, one panel per track and target.
pub fn rate_svg(curves: &[Curve], label: &str) -> String {
    let (panels, columns) = panels(curves, |b| 100.0 * b.detection_rate(), None);
    let xmax = max_range(curves);
    Chart {
        title: format!("Lead detection rate vs range — {label}"),
        subtitle: "Target on the ego's path; % of the frames in which it is visible (a ray hits it); missing points: never visible. \
                   Targets: 99.5 % to 150 m (car, clean), 98 % to 100 m (car, 50 % dropout), 99 % to 80 m (motorcycle)."
            .into(),
        x_label: "range to the rear face (along the road), m".into(),
        y_label: "detected, % of visible frames".into(),
        x_range: (0.0, xmax),
        y_range: (0.0, 100.0),
        x_ticks: (0..=(xmax / 50.0) as usize).map(|i| 50.0 * i as f64).collect(),
        y_ticks: vec![0.0, 25.0, 50.0, 75.0, 100.0],
        h_refs: vec![],
        v_refs: vec![(80.0, "80 m".into()), (100.0, "100 m".into()), (150.0, "150 m".into())],
        columns,
        panels,
    }
    .to_svg()
}

/// Figure: mean (solid) and largest (dashed) |distance error| vs range.
pub fn error_svg(curves: &[Curve], label: &str) -> String {
    let max_err = |b: &BinResult| if b.detected == 0 { f64::NAN } else { b.max_abs_error };
    let (panels, columns) = panels(curves, BinResult::mean_abs_error, Some(("max", &max_err)));
    let xmax = max_range(curves);
    Chart {
        title: format!("Distance error vs range — {label}"),
        subtitle: "|detected distance - sensor-frame x of the rear face's nearest point| over the detections of the target: \
                   mean solid, largest dashed (clipped at 1 m). Target: within 0.3 m."
            .into(),
        x_label: "range to the rear face (along the road), m".into(),
        y_label: "|distance error|, m".into(),
        x_range: (0.0, xmax),
        y_range: (0.0, 1.0),
        x_ticks: (0..=(xmax / 50.0) as usize).map(|i| 50.0 * i as f64).collect(),
        y_ticks: vec![0.0, 0.25, 0.5, 0.75, 1.0],
        h_refs: vec![(ACCURATE, "0.3 m".into())],
        v_refs: vec![],
        columns,
        panels,
    }
    .to_svg()
}

/// Figure: false detections per km of the clutter runs.
pub fn false_svg(runs: &[ClutterResult], label: &str) -> String {
    let mut rows = Vec::new();
    for r in runs {
        let (road, zero) = r.per_km();
        rows.push((format!("{} ({:.2} km), path = road curvature", r.track, r.km), road, "#d62728"));
        rows.push((format!("{} ({:.2} km), path = straight", r.track, r.km), zero, "#ff7f0e"));
    }
    bars(
        &format!("False lead detections per km, no lead on the road — {label}"),
        "Guard rails, posts, parked cars in the next lane; 30-130 km/h, one scan per 1/20 s of driving. Target: none.",
        "/km",
        &rows,
    )
}

fn pct(x: f64) -> String {
    if x.is_finite() { format!("{:.1}", 100.0 * x) } else { "-".into() }
}

fn metres(x: f64) -> String {
    if x.is_finite() { format!("{x:.3}") } else { "-".into() }
}

/// The whole study of `docs/detector.md`: every track and target (car, truck, motorcycle) with
/// `frames` frames per range bin and condition, and the clutter run. `progress` is told what is
/// done.
pub fn full_study(frames: usize, mut progress: impl FnMut(&str)) -> (Vec<Curve>, Vec<ClutterResult>) {
    let mut curves = Vec::new();
    for track in TrackKind::ALL {
        for target in [CAR, TRUCK, MOTORCYCLE] {
            let study = RangeStudy { frames_per_bin: frames, ..RangeStudy::new(track, target) };
            curves.extend(run_range_study(&study));
            progress(&format!("{} / {}", track.name(), target.name));
        }
    }
    let clutter = run_clutter(&ClutterRun::default());
    progress("clutter run");
    (curves, clutter)
}

/// The command line that writes the study (`examples/detector_study.rs`), as its tables cite it.
pub fn study_command(out: &str, prefix: &str, label: &str, frames: usize) -> String {
    format!(
        "cargo run --release -p flc-sim --example detector_study -- --out {out} --prefix {prefix} --label \"{label}\" --frames {frames}"
    )
}

/// The Markdown tables of a study: per track, target and condition the detection rate by range
/// bin, the summary against the targets, and the clutter runs. `figures` is the file-name prefix
/// of the figures (linked relative to the Markdown file that includes the tables).
pub fn markdown(curves: &[Curve], clutter: &[ClutterResult], label: &str, figures: &str, command: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "Generated by `{command}` ({label}).\n");
    let _ = writeln!(out, "![detection rate vs range]({figures}-rate-vs-range.svg)\n");
    let _ = writeln!(out, "![distance error vs range]({figures}-error-vs-range.svg)\n");
    let _ = writeln!(out, "![false detections per km]({figures}-false-per-km.svg)\n");
    out.push_str("**Against the targets** (rates over visible frames; *accurate*: detected within 0.3 m; *visible*: the scan without impairments sees the nearest point and at least half the width; *partly hidden*: rays on the target but not visible, with the share of them in which the target was detected):\n\n");
    out.push_str("| target | track | condition | ranges | visible / frames | detected | accurate | max \\|error\\| m | partly hidden: frames, detected | required |\n|---|---|---|---|---|---|---|---|---|---|\n");
    let checks: [(&str, &str, f64, &str); 3] = [
        ("car", "clean", 150.0, "≥ 99.5 % accurate"),
        ("car", "50 % dropout", 100.0, "≥ 98 % accurate"),
        ("motorcycle", "clean", 80.0, "≥ 99 % accurate"),
    ];
    for (target, cond, up_to, req) in checks {
        for c in curves.iter().filter(|c| c.target.name == target && c.condition == cond) {
            let p = c.pooled(up_to);
            let _ = writeln!(
                out,
                "| {target} | {} | {cond} | 10-{up_to} m | {} / {} | {} % | {} % | {} | {}, {} % | {req} |",
                c.track,
                p.visible,
                p.frames,
                pct(p.detection_rate()),
                pct(p.accurate_rate()),
                metres(if p.detected == 0 { f64::NAN } else { p.max_abs_error }),
                p.partly_hidden,
                pct(ratio(p.partly_detected, p.partly_hidden))
            );
        }
    }
    out.push('\n');
    out.push_str("**False detections** (no lead; guard rails, posts, parked cars in the next lane; 30-130 km/h):\n\n");
    out.push_str("| track | km | frames | false, path = road curvature | per km | false, path = straight | per km |\n|---|---|---|---|---|---|---|\n");
    let (mut km, mut frames, mut a, mut b) = (0.0, 0, 0, 0);
    for r in clutter {
        let (ra, rb) = r.per_km();
        let _ = writeln!(
            out,
            "| {} | {:.2} | {} | {} | {ra:.3} | {} | {rb:.3} |",
            r.track,
            r.km,
            r.frames,
            r.false_road_curvature.len(),
            r.false_zero_curvature.len()
        );
        km += r.km;
        frames += r.frames;
        a += r.false_road_curvature.len();
        b += r.false_zero_curvature.len();
    }
    if km > 0.0 {
        let _ = writeln!(out, "| all | {km:.2} | {frames} | {a} | {:.3} | {b} | {:.3} |", a as f64 / km, b as f64 / km);
    }
    for r in clutter {
        let first: Vec<String> = r
            .false_road_curvature
            .iter()
            .take(4)
            .map(|f| format!("s = {:.0} m: ({:.1}, {:.1}) m, {:.2} m wide", f.s, f.position[0], f.position[1], f.width))
            .collect();
        if !first.is_empty() {
            let _ = writeln!(
                out,
                "\nFirst false detections on the {} track (path = road curvature; sensor frame): {}.",
                r.track,
                first.join("; ")
            );
        }
    }
    out.push('\n');
    out.push_str("**Detection rate by range** (% of visible frames; `-`: never visible; in brackets the visible frames where fewer than all are):\n\n");
    let Some(first) = curves.first() else { return out };
    let heads: Vec<String> = first.bins.iter().map(|b| format!("{:.0}", b.lo)).collect();
    let _ = writeln!(out, "| target | track | condition | {} |", heads.join(" | "));
    let _ = writeln!(out, "|---|---|---|{}", "---|".repeat(heads.len()));
    for c in curves {
        let cells: Vec<String> = c
            .bins
            .iter()
            .map(|b| {
                let r = pct(b.detection_rate());
                if b.visible < b.frames && b.visible > 0 { format!("{r} ({})", b.visible) } else { r }
            })
            .collect();
        let _ = writeln!(out, "| {} | {} | {} | {} |", c.target.name, c.track, c.condition, cells.join(" | "));
    }
    let _ = writeln!(
        out,
        "\nColumn heads: lower edge of the 10 m range bin, m; {} frames per bin.",
        first.bins.first().map_or(0, |b| b.frames)
    );
    out.push_str("\n**Mean |distance error| by range**, m:\n\n");
    let _ = writeln!(out, "| target | track | condition | {} |", heads.join(" | "));
    let _ = writeln!(out, "|---|---|---|{}", "---|".repeat(heads.len()));
    for c in curves {
        let cells: Vec<String> =
            c.bins.iter().map(|b| if b.detected == 0 { "-".into() } else { format!("{:.3}", b.mean_abs_error()) }).collect();
        let _ = writeln!(out, "| {} | {} | {} | {} |", c.target.name, c.track, c.condition, cells.join(" | "));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_on_a_straight_road_is_the_range() {
        let p = LidarParams::default();
        let ego = VehicleState::default();
        let sensor = sensor_frame(&ego, &p);
        let target = VehicleState { x: p.mount_x + 40.0 + CAR.length / 2.0, ..Default::default() };
        let tr = truth(&sensor, &target, &CAR);
        assert!((tr.distance - 40.0).abs() < 1e-12 && tr.curvature == 0.0);
        assert!(on_target(&tr, &CAR, [40.0, 0.9], 0.01) && !on_target(&tr, &CAR, [39.9, 0.0], 0.01));
    }
}
