//! A 2D scanning LiDAR synthesised by ray casts through rapier's query pipeline (ego excluded),
//! with range noise, per-ray dropout, whole-scan drops, latency and frame-interval jitter.

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};
use crate::noise::NormalStream;
use crate::vehicle::VehicleState;
use crate::world::{Body, NO_HIT, RayFan, World, f32_dir};
use rapier2d::prelude::Vector;

/// LiDAR parameters. `Default`: a forward-looking automotive unit of the current generation
/// (sources and numbers in `docs/sim-model.md`, section LiDAR):
///
/// * `rate_hz` 20: the paper's 20 fps (Hesai AT128: 10 Hz; Ouster OS1: 10 / 20 Hz);
/// * `fov_deg` 120: the horizontal field of view of the Hesai AT128 and the Luminar Iris;
/// * `resolution_deg` 0.1: the AT128's horizontal resolution (1201 rays per scan; Iris 0.05);
/// * `max_range` 200 m: the AT128's range at 10 % reflectivity (Iris: 250 m at < 10 %);
/// * `mount_x`, `mount_y`, `mount_yaw_deg` 2.0 m, 0, 0: roof / windscreen-top mount, 0.45 m
///   behind the front bumper of the default 4.9 m car;
/// * `range_noise_std` 0.02 m: within the AT128's +-3 cm accuracy, between the Ouster OS1's 1 sigma
///   repeatability of +-1.5 cm (SNR > 250) and +-3 cm (SNR 100);
/// * `dropout_prob`, `dropout_at_max_range`, `scan_drop_prob`, `latency_frames`, `jitter`: 0
///   (impairments off unless a scenario asks for them).
///
/// Rays are infinitely thin: beam divergence (Ouster OS1: 0.13-0.18 deg FWHM; the AT128's beam is
/// of the order of its 0.1 x 0.2 deg cell) is not modelled, so a target narrower than the ray
/// spacing (0.35 m at 200 m) can fall between two rays.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarParams {
    /// Scan rate, Hz.
    pub rate_hz: f64,
    /// Horizontal field of view, centred forward, degrees.
    pub fov_deg: f64,
    /// Angular resolution, degrees.
    pub resolution_deg: f64,
    /// Maximum range, m.
    pub max_range: f64,
    /// Mounting position ahead of the body centre, m.
    pub mount_x: f64,
    /// Mounting position left of the body centre, m.
    pub mount_y: f64,
    /// Mounting yaw, degrees.
    pub mount_yaw_deg: f64,
    /// Standard deviation of the Gaussian range noise, m.
    pub range_noise_std: f64,
    /// Probability that a ray returns nothing (at every range; with `dropout_at_max_range > 0`,
    /// at range 0).
    pub dropout_prob: f64,
    /// Range-dependent dropout, off at 0: the probability that a ray whose hit lies at
    /// `max_range` returns nothing. A ray hitting at range `r` is then lost with
    /// `dropout_prob + (dropout_at_max_range - dropout_prob) (r / max_range)^2`, the quadratic
    /// growth of the received power's `1 / r^2` fall-off (`docs/sim-model.md`). At least
    /// `dropout_prob` when on.
    pub dropout_at_max_range: f64,
    /// Probability that a whole scan is lost.
    pub scan_drop_prob: f64,
    /// Scans are delivered this many scan periods after capture.
    pub latency_frames: u32,
    /// Frame-interval jitter: each interval is `(1 + U(-jitter, +jitter)) / rate_hz`.
    pub jitter: f64,
    /// Scripted faults ([`LidarFault`]): scans captured while one is active are blinded or get
    /// a spurious return. None by default.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub faults: Vec<LidarFault>,
}

/// A scripted sensor fault, active for the scans captured at `start <= t < start + duration`
/// (s): for fault-injection tests (`docs/sim-model.md`, "Scripted faults"). A fault changes the
/// rays' returns only; every random draw of the scan is made as without it, so a run with a fault
/// differs from the same run without it by the fault alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LidarFault {
    /// No ray returns anything (a blinded or stalled sensor; the detector finds nothing).
    Blind {
        /// Start, s.
        start: f64,
        /// Duration, s.
        duration: f64,
    },
    /// A spurious return: a flat face `width` m wide, `range` m straight ahead of the sensor,
    /// nearer than whatever the rays hit behind it (spray, a reflection, a bird).
    Ghost {
        /// Start, s.
        start: f64,
        /// Duration, s.
        duration: f64,
        /// Distance of the face ahead of the sensor, m.
        range: f64,
        /// Width of the face, m. Default 1.0.
        #[serde(default = "default_ghost_width")]
        width: f64,
    },
}

fn default_ghost_width() -> f64 {
    1.0
}

impl LidarFault {
    /// Whether the fault acts on a scan captured at `t`.
    pub fn active(&self, t: f64) -> bool {
        let (Self::Blind { start, duration } | Self::Ghost { start, duration, .. }) = *self;
        t >= start && t < start + duration
    }

    /// What the fault makes of a return at range `r` (m, `f64::INFINITY` for none) along a ray at
    /// `angle` (rad, sensor frame): none while blind; the ghost's face where the ray crosses it.
    pub fn apply(&self, r: f64, angle: f64) -> f64 {
        match *self {
            Self::Blind { .. } => f64::INFINITY,
            Self::Ghost { range, width, .. } => {
                let (s, c) = angle.sin_cos();
                if c > 0.0 && (range * s / c).abs() <= 0.5 * width { r.min(range / c) } else { r }
            }
        }
    }

    fn validate(&self, max_range: f64) -> Result<(), ConfigError> {
        let (Self::Blind { start, duration } | Self::Ghost { start, duration, .. }) = *self;
        check_range("start", start, 0.0, 1.0e6, "s")?;
        check_range("duration", duration, 1.0e-6, 1.0e6, "s")?;
        if let Self::Ghost { range, width, .. } = *self {
            check_range("range", range, 0.01, max_range, "m (at most max_range)")?;
            check_range("width", width, 0.01, 10.0, "m")?;
        }
        Ok(())
    }
}

impl Default for LidarParams {
    fn default() -> Self {
        Self {
            rate_hz: 20.0,
            fov_deg: 120.0,
            resolution_deg: 0.1,
            max_range: 200.0,
            mount_x: 2.0,
            mount_y: 0.0,
            mount_yaw_deg: 0.0,
            range_noise_std: 0.02,
            dropout_prob: 0.0,
            dropout_at_max_range: 0.0,
            scan_drop_prob: 0.0,
            latency_frames: 0,
            jitter: 0.0,
            faults: Vec::new(),
        }
    }
}

impl LidarParams {
    /// Checks every field; errors name the key and range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_range("rate_hz", self.rate_hz, 1.0, 100.0, "Hz")?;
        check_range("fov_deg", self.fov_deg, 1.0, 360.0, "deg")?;
        check_range("resolution_deg", self.resolution_deg, 0.01, 10.0, "deg")?;
        if self.fov_deg / self.resolution_deg > 20_000.0 {
            return Err(ConfigError::new("resolution_deg", "gives more than 20000 rays per scan"));
        }
        check_range("max_range", self.max_range, 1.0, 500.0, "m")?;
        check_range("mount_x", self.mount_x, -10.0, 10.0, "m")?;
        check_range("mount_y", self.mount_y, -5.0, 5.0, "m")?;
        check_range("mount_yaw_deg", self.mount_yaw_deg, -180.0, 180.0, "deg")?;
        check_range("range_noise_std", self.range_noise_std, 0.0, 5.0, "m")?;
        check_range("dropout_prob", self.dropout_prob, 0.0, 1.0, "")?;
        check_range("dropout_at_max_range", self.dropout_at_max_range, 0.0, 1.0, "")?;
        if self.dropout_at_max_range > 0.0 && self.dropout_at_max_range < self.dropout_prob {
            return Err(ConfigError::new(
                "dropout_at_max_range",
                format!("must be 0 (off) or at least dropout_prob ({}), got {}", self.dropout_prob, self.dropout_at_max_range),
            ));
        }
        check_range("scan_drop_prob", self.scan_drop_prob, 0.0, 1.0, "")?;
        check_range("latency_frames", f64::from(self.latency_frames), 0.0, 100.0, "scans")?;
        check_range("jitter", self.jitter, 0.0, 0.9, "(fraction of the frame interval)")?;
        for (i, f) in self.faults.iter().enumerate() {
            f.validate(self.max_range).map_err(|e| e.within(&format!("faults[{i}]")))?;
        }
        Ok(())
    }

    /// Number of rays per scan.
    pub fn rays(&self) -> usize {
        (self.fov_deg / self.resolution_deg).round() as usize + 1
    }
}

/// One delivered scan.
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    /// Capture time, s.
    pub t_captured: f64,
    /// Hit points in the sensor frame (x forward, y left), m.
    pub points: Vec<[f64; 2]>,
}

/// When a scan-based sensor measures and when it delivers, from its [`LidarParams`]: a
/// measurement at the first call at or after each slot, slots `(1 + jitter) / rate_hz` apart
/// from t = 0, delivered `latency_frames` measurements late. Shared by [`Lidar`] and
/// [`crate::GapSensor`].
#[derive(Debug, Clone)]
pub(crate) struct ScanSchedule<T> {
    next_t: f64,
    /// Measurements waiting for delivery (`None`: dropped).
    queue: VecDeque<Option<T>>,
}

impl<T> ScanSchedule<T> {
    pub(crate) fn new() -> Self {
        Self { next_t: 0.0, queue: VecDeque::new() }
    }

    /// Time of the next measurement, s.
    pub(crate) fn next_t(&self) -> f64 {
        self.next_t
    }

    /// `true` if a measurement is due at `t`.
    pub(crate) fn due(&self, t: f64) -> bool {
        t + 1e-9 >= self.next_t
    }

    /// Queues the measurement taken now (`None`: dropped), schedules the next one `jitter`
    /// (a fraction of the period) off the nominal period, and returns the measurement due for
    /// delivery: `None` if none is yet (latency), `Some(None)` if it was dropped.
    pub(crate) fn take(&mut self, p: &LidarParams, jitter: f64, measurement: Option<T>) -> Option<Option<T>> {
        self.next_t += (1.0 + jitter) / p.rate_hz;
        self.queue.push_back(measurement);
        if self.queue.len() > p.latency_frames as usize { self.queue.pop_front() } else { None }
    }
}

/// The LiDAR: schedule, ray casting and impairments.
pub struct Lidar {
    params: LidarParams,
    /// Independent streams per impairment, so that enabling one never reshuffles another and a
    /// disabled one costs nothing.
    /// Range noise: one standard-normal draw per ray ([`crate::noise`]).
    rng_noise: NormalStream,
    rng_dropout: ChaCha8Rng,
    rng_scan: ChaCha8Rng,
    schedule: ScanSchedule<Scan>,
    /// Ray angles in the sensor frame, ascending, rad.
    angles: Vec<f64>,
    /// `(cos, sin)` of each ray's angle in the sensor frame.
    unit: Vec<[f64; 2]>,
    /// This scan's world-frame ray directions, in parry's f32.
    dirs: Vec<Vector>,
    /// Hit distance per ray ([`crate::world::NO_HIT`]: none or dropped), m.
    hits: Vec<f32>,
    /// This scan's range noise per ray (zero without noise), m.
    noise_draws: Vec<f64>,
}

impl Lidar {
    /// A LiDAR with its own random stream.
    pub fn new(params: LidarParams, seed: u64) -> Self {
        let n = params.rays();
        let half = params.fov_deg.to_radians() / 2.0;
        let step = if n > 1 { params.fov_deg.to_radians() / (n - 1) as f64 } else { 0.0 };
        let angles: Vec<f64> = (0..n).map(|i| -half + step * i as f64).collect();
        let unit = angles.iter().map(|a| [a.cos(), a.sin()]).collect();
        let stream = |k: u64| {
            let mut r = ChaCha8Rng::seed_from_u64(seed);
            r.set_stream(k);
            r
        };
        Self {
            params,
            rng_noise: NormalStream::new(stream(1).random()),
            rng_dropout: stream(2),
            rng_scan: stream(3),
            schedule: ScanSchedule::new(),
            angles,
            unit,
            dirs: Vec::with_capacity(n),
            hits: Vec::with_capacity(n),
            noise_draws: vec![0.0; n],
        }
    }

    /// The parameters.
    pub fn params(&self) -> &LidarParams {
        &self.params
    }

    /// Time of the next capture, s: [`Lidar::tick`] captures at the first call with
    /// `t >= next_scan_time()` and then advances it by one (jittered) frame interval.
    pub fn next_scan_time(&self) -> f64 {
        self.schedule.next_t()
    }

    /// Called every physics step at time `t`: captures a scan when one is due and returns the
    /// scan due for delivery now (after latency; `None` if none is due or it was dropped).
    pub fn tick(&mut self, t: f64, world: &World, ego: Body, pose: &VehicleState) -> Option<Scan> {
        if !self.schedule.due(t) {
            return None;
        }
        let j = if self.params.jitter > 0.0 { self.rng_scan.random_range(-self.params.jitter..=self.params.jitter) } else { 0.0 };
        let dropped = self.params.scan_drop_prob > 0.0 && self.rng_scan.random::<f64>() < self.params.scan_drop_prob;
        let scan = self.capture(t, world, ego, pose);
        self.schedule.take(&self.params, j, (!dropped).then_some(scan)).flatten()
    }

    /// Casts one scan now (no scheduling, no latency).
    pub fn capture(&mut self, t: f64, world: &World, ego: Body, pose: &VehicleState) -> Scan {
        let p = &self.params;
        let (c, s) = (pose.yaw.cos(), pose.yaw.sin());
        let origin = [pose.x + c * p.mount_x - s * p.mount_y, pose.y + s * p.mount_x + c * p.mount_y];
        let base = pose.yaw + p.mount_yaw_deg.to_radians();
        self.dirs.clear();
        let (cb, sb) = (base.cos(), base.sin());
        self.dirs.extend(self.unit.iter().map(|[c, s]| f32_dir(cb * c - sb * s, sb * c + cb * s)));
        world.cast_fan_f32(&RayFan { origin, base, angles: &self.angles, unit: &self.dirs }, p.max_range, ego, &mut self.hits);
        for fault in p.faults.iter().filter(|f| f.active(t)) {
            for (hit, &a) in self.hits.iter_mut().zip(&self.angles) {
                // Ranges are f32 like parry's hits; nothing returns from beyond `max_range`.
                let r = fault.apply(f64::from(*hit), a);
                *hit = if r <= p.max_range { r as f32 } else { NO_HIT };
            }
        }
        // One draw per ray and enabled impairment, hit or not: a ray's draws never depend on what
        // the other rays hit (and without range-dependent dropout the draws are exactly those of
        // `dropout_prob` alone). Each impairment is one pass over the rays.
        if p.dropout_prob > 0.0 || p.dropout_at_max_range > 0.0 {
            // Range-dependent dropout (`dropout_at_max_range > 0`): `p(r) = p0 + (p1 - p0) (r / R)^2`
            // at the true range `r`.
            let ranged = p.dropout_at_max_range > 0.0;
            let (p0, slope) = (p.dropout_prob, (p.dropout_at_max_range - p.dropout_prob) / (p.max_range * p.max_range));
            for hit in &mut self.hits {
                let u = self.rng_dropout.random::<f64>();
                let r = f64::from(*hit);
                if *hit != NO_HIT && u < if ranged { p0 + slope * r * r } else { p0 } {
                    *hit = NO_HIT;
                }
            }
        }
        if p.range_noise_std > 0.0 {
            self.rng_noise.fill(p.range_noise_std, &mut self.noise_draws);
        }
        // Every ray's point, then the rays without a return left out (`NO_HIT` is infinite, so
        // their points are not finite): two passes without a branch or a capacity check per ray.
        let mut points: Vec<[f64; 2]> = (self.unit.iter().zip(&self.hits).zip(&self.noise_draws))
            .map(|(([ca, sa], &hit), &n)| {
                let r = (f64::from(hit) + n).max(0.0);
                [r * ca, r * sa]
            })
            .collect();
        points.retain(|[x, y]| x.is_finite() && y.is_finite());
        Scan { t_captured: t, points }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::Track;
    use crate::vehicle::VehicleParams;

    fn scene(lead_x: f64) -> (World, Body) {
        let mut w = World::new(&Track::new("t", vec![[0.0, 0.0], [1000.0, 0.0]], 3.5, vec![]));
        let p = VehicleParams::default();
        let ego = w.add_vehicle(&p, &VehicleState::default());
        w.add_vehicle(&p, &VehicleState { x: lead_x, ..Default::default() });
        w.step(0.01);
        (w, ego)
    }

    #[test]
    fn default_has_the_reach_and_resolution_of_an_automotive_unit() {
        let p = LidarParams::default();
        assert!(p.max_range >= 200.0 && p.resolution_deg <= 0.1 && p.fov_deg >= 120.0, "{p:?}");
        assert_eq!(p.rays(), (p.fov_deg / p.resolution_deg).round() as usize + 1);
        assert!(p.validate().is_ok());
    }

    #[test]
    fn default_reaches_a_car_at_190_m() {
        // Rear face 190 m ahead of the sensor: lead centre at 190 + mount_x + half length.
        let d = 190.0;
        let half_length = VehicleParams::default().length / 2.0;
        let (w, ego) = scene(d + LidarParams::default().mount_x + half_length);
        let scan = Lidar::new(LidarParams::default(), 3).capture(0.0, &w, ego, &VehicleState::default());
        let std = LidarParams::default().range_noise_std;
        let on_face: Vec<_> = scan.points.iter().filter(|p| (p[0] - d).abs() < 4.0 * std + 1e-3).collect();
        // 1.9 m wide at 190 m is 0.57 deg: at least 5 rays at 0.1 deg.
        let width = VehicleParams::default().width;
        let expected = ((width / d).atan().to_degrees() / LidarParams::default().resolution_deg).floor() as usize;
        assert!(on_face.len() >= expected && expected >= 5, "{} returns on the face, expected {expected}", on_face.len());
        assert_eq!(on_face.len(), scan.points.len(), "nothing but the lead in view");
        // The old 100 m sensor saw nothing there (the test is not vacuous).
        let short = LidarParams { max_range: 100.0, ..Default::default() };
        assert!(Lidar::new(short, 3).capture(0.0, &w, ego, &VehicleState::default()).points.is_empty());
    }

    /// Straight track with guard rails (returns at every range up to `max_range`), ego at x = 300.
    fn rails() -> (World, Body, VehicleState) {
        let track = Track::straight(2000.0);
        let mut w = World::new(&track);
        let ego_state = VehicleState { x: 300.0, ..Default::default() };
        let ego = w.add_vehicle(&VehicleParams::default(), &ego_state);
        w.step(0.01);
        (w, ego, ego_state)
    }

    #[test]
    fn range_dependent_dropout_thins_returns_with_range_as_the_law_says() {
        let (w, ego, pose) = rails();
        let clean = LidarParams { range_noise_std: 0.0, ..Default::default() };
        let full = Lidar::new(clean.clone(), 1).capture(0.0, &w, ego, &pose);
        let (p0, p1) = (0.05, 0.8);
        let params = LidarParams { dropout_prob: p0, dropout_at_max_range: p1, ..clean.clone() };
        let law = |r: f64| p0 + (p1 - p0) * (r / params.max_range).powi(2);
        // Ranges of the rays that return without dropout (noise off: the exact hit distance),
        // keyed by their point's bits; a capture with dropout keeps a subset of these points.
        let range_of: std::collections::HashMap<[u64; 2], f64> =
            full.points.iter().map(|p| ([p[0].to_bits(), p[1].to_bits()], p[0].hypot(p[1]))).collect();
        let mut l = Lidar::new(params.clone(), 9);
        let scans = 200;
        // Per range bin (quarters of max_range): trials, observed drops, expected drops, variance.
        let mut bins = [(0.0f64, 0.0f64, 0.0f64, 0.0f64); 4];
        let bin = |r: f64| ((r / params.max_range * 4.0) as usize).min(3);
        for _ in 0..scans {
            let scan = l.capture(0.0, &w, ego, &pose);
            let kept: std::collections::HashSet<[u64; 2]> = scan.points.iter().map(|p| [p[0].to_bits(), p[1].to_bits()]).collect();
            assert!(kept.iter().all(|k| range_of.contains_key(k)), "a point that the clean scan does not have");
            for (k, &r) in &range_of {
                let b = &mut bins[bin(r)];
                let p = law(r);
                b.0 += 1.0;
                b.1 += f64::from(u8::from(!kept.contains(k)));
                b.2 += p;
                b.3 += p * (1.0 - p);
            }
        }
        let mut last = -1.0;
        for (i, (n, dropped, expected, var)) in bins.iter().enumerate() {
            assert!(*n > 1000.0, "bin {i}: only {n} trials");
            // 4 binomial standard deviations.
            assert!(
                (dropped - expected).abs() < 4.0 * var.sqrt(),
                "bin {i}: {dropped} dropped of {n}, expected {expected:.0} +- {:.0}",
                var.sqrt()
            );
            let fraction = dropped / n;
            assert!(fraction > last, "bin {i}: drop fraction {fraction} not above the nearer bin's {last}");
            last = fraction;
        }
    }

    /// The points of one capture computed here from the fan's hits and the documented draw order
    /// (a normal stream seeded by stream 1's first draw: one N(0, std^2) per ray; stream 2: one
    /// U[0, 1) per ray when `dropout_prob > 0`).
    fn reference_capture(p: &LidarParams, seed: u64, w: &World, ego: Body, pose: &VehicleState) -> Vec<[f64; 2]> {
        let stream = |k: u64| {
            let mut r = ChaCha8Rng::seed_from_u64(seed);
            r.set_stream(k);
            r
        };
        let (mut noise, mut dropout) = (NormalStream::new(stream(1).random()), stream(2));
        let l = Lidar::new(p.clone(), seed);
        let origin = [pose.x + p.mount_x, pose.y];
        let mut hits = Vec::new();
        let unit: Vec<Vector> = l.unit.iter().map(|&[c, s]| f32_dir(c, s)).collect();
        w.cast_fan(&RayFan { origin, base: 0.0, angles: &l.angles, unit: &unit }, p.max_range, ego, &mut hits);
        let mut out = Vec::new();
        for (a, hit) in l.angles.iter().zip(&hits) {
            let drop = p.dropout_prob > 0.0 && dropout.random::<f64>() < p.dropout_prob;
            let n = if p.range_noise_std > 0.0 { p.range_noise_std * noise.sample() } else { 0.0 };
            if let (Some(r), false) = (hit, drop) {
                let r = (r + n).max(0.0);
                out.push([r * a.cos(), r * a.sin()]);
            }
        }
        out
    }

    #[test]
    fn without_range_dependent_dropout_scans_are_those_of_before() {
        let (w, ego, pose) = rails();
        for p in [LidarParams::default(), LidarParams { dropout_prob: 0.3, ..Default::default() }] {
            let scan = Lidar::new(p.clone(), 4).capture(0.0, &w, ego, &pose);
            let reference = reference_capture(&p, 4, &w, ego, &pose);
            assert_eq!(scan.points.len(), reference.len());
            for (a, b) in scan.points.iter().zip(&reference) {
                assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9, "{a:?} vs {b:?}");
            }
        }
        // A flat law (dropout_at_max_range = dropout_prob) draws the same numbers: the same scan.
        let flat = LidarParams { dropout_prob: 0.3, dropout_at_max_range: 0.3, ..Default::default() };
        let constant = LidarParams { dropout_prob: 0.3, ..Default::default() };
        assert_eq!(Lidar::new(flat, 4).capture(0.0, &w, ego, &pose), Lidar::new(constant, 4).capture(0.0, &w, ego, &pose));
    }

    #[test]
    fn ranges_match_the_box_geometry_within_noise() {
        let (w, ego) = scene(25.0);
        let mut l = Lidar::new(LidarParams::default(), 7);
        let scan = l.capture(0.0, &w, ego, &VehicleState::default());
        // Rear face at x = 25 - 2.45 = 22.55 in the world, 20.55 m ahead of the sensor (mount 2 m).
        let face: Vec<_> = scan.points.iter().filter(|p| p[1].abs() < 0.9).collect();
        assert!(face.len() > 20, "{}", face.len());
        for p in &face {
            let analytic = 20.55 / p[1].atan2(p[0]).cos();
            let r = p[0].hypot(p[1]);
            assert!((r - analytic).abs() < 3.0 * 0.02 + 1e-3, "{r} vs {analytic}");
        }
        // No point closer than the lead: the ego body never appears in its own scan.
        assert!(scan.points.iter().all(|p| p[0].hypot(p[1]) > 20.0));
    }

    #[test]
    fn dropout_thins_returns_and_seed_repeats() {
        let (w, ego) = scene(15.0);
        let full =
            Lidar::new(LidarParams { range_noise_std: 0.0, ..Default::default() }, 1).capture(0.0, &w, ego, &VehicleState::default());
        let mut l = Lidar::new(LidarParams { range_noise_std: 0.0, dropout_prob: 0.5, ..Default::default() }, 1);
        let half = l.capture(0.0, &w, ego, &VehicleState::default());
        let ratio = half.points.len() as f64 / full.points.len() as f64;
        assert!((ratio - 0.5).abs() < 0.15, "{ratio}");
        let again = Lidar::new(LidarParams { range_noise_std: 0.0, dropout_prob: 0.5, ..Default::default() }, 1).capture(
            0.0,
            &w,
            ego,
            &VehicleState::default(),
        );
        assert_eq!(half, again);
    }

    #[test]
    fn schedule_latency_and_drops() {
        let (w, ego) = scene(15.0);
        let mut l = Lidar::new(LidarParams { latency_frames: 2, ..Default::default() }, 1);
        let mut delivered = Vec::new();
        for k in 0..100 {
            let t = k as f64 * 0.01;
            if let Some(s) = l.tick(t, &w, ego, &VehicleState::default()) {
                delivered.push((t, s.t_captured));
            }
        }
        // 20 Hz over 1 s: 20 captures, the first two held back by the 2-scan latency.
        assert_eq!(delivered.len(), 18);
        assert!(delivered.iter().all(|(t, c)| (t - c - 0.1).abs() < 1e-9));
        let mut l = Lidar::new(LidarParams { scan_drop_prob: 1.0, ..Default::default() }, 1);
        assert!((0..100).all(|k| l.tick(k as f64 * 0.01, &w, ego, &VehicleState::default()).is_none()));
    }

    #[test]
    fn jittered_intervals_stay_within_bounds_and_keep_the_mean_rate() {
        let (w, ego) = scene(15.0);
        let mut l = Lidar::new(LidarParams { jitter: 0.3, ..Default::default() }, 3);
        let dt = 0.001;
        let mut captures = Vec::new();
        for k in 0..100_000 {
            let t = k as f64 * dt;
            let due = l.next_scan_time();
            if let Some(s) = l.tick(t, &w, ego, &VehicleState::default()) {
                assert!(t >= due - 1e-9 && t < due + dt + 1e-9);
                captures.push(s.t_captured);
            }
        }
        // Intervals in [0.7, 1.3] / 20 Hz (+- one step of quantisation), mean 1 / 20 Hz.
        let iv: Vec<f64> = captures.windows(2).map(|c| c[1] - c[0]).collect();
        assert!(iv.iter().all(|&d| d > 0.035 - dt - 1e-9 && d < 0.065 + dt + 1e-9));
        let mean = iv.iter().sum::<f64>() / iv.len() as f64;
        assert!((mean - 0.05).abs() < 0.001, "{mean}");
        assert!(iv.iter().any(|&d| d < 0.04) && iv.iter().any(|&d| d > 0.06));
    }

    #[test]
    fn ego_box_around_the_sensor_gives_no_returns() {
        // The sensor sits inside the ego's own box (mount_x 2.0 < half length 2.45); with a
        // 360 deg field of view and nothing else around, every ray would hit the ego if it were
        // not excluded.
        let mut w = World::new(&Track::new("t", vec![[0.0, 0.0], [1000.0, 0.0]], 3.5, vec![]));
        let ego = w.add_vehicle(&VehicleParams::default(), &VehicleState::default());
        w.step(0.01);
        let params = LidarParams { fov_deg: 359.0, resolution_deg: 0.5, ..Default::default() };
        let scan = Lidar::new(params, 1).capture(0.0, &w, ego, &VehicleState::default());
        assert!(scan.points.is_empty(), "{:?}", &scan.points[..scan.points.len().min(5)]);
    }

    /// Micro-measurement of the ray-casting rate (not a timed test):
    /// `cargo test --release -p flc-sim --lib lidar::tests::ray_rate -- --ignored --nocapture`.
    #[test]
    #[ignore = "measurement; run in release with --nocapture"]
    fn ray_rate() {
        let track = Track::straight(2000.0);
        let mut w = World::new(&track);
        let p = VehicleParams::default();
        let ego_state = VehicleState { x: 280.0, ..Default::default() };
        let ego = w.add_vehicle(&p, &ego_state);
        w.add_vehicle(&p, &VehicleState { x: 300.0, ..Default::default() });
        w.step(0.01);
        let mut l = Lidar::new(LidarParams::default(), 1);
        let scans = 20_000;
        let start = std::time::Instant::now();
        let mut points = 0;
        for _ in 0..scans {
            points += l.capture(0.0, &w, ego, &ego_state).points.len();
        }
        let s = start.elapsed().as_secs_f64();
        let rays = (scans * l.params().rays()) as f64;
        println!(
            "{} scans x {} rays in {s:.3} s: {:.1} M rays/s, {:.1} us/scan, {} returns/scan; \
             default LiDAR budget: {:.0}x real time for the scans alone",
            scans,
            l.params().rays(),
            rays / s / 1e6,
            s / scans as f64 * 1e6,
            points / scans,
            scans as f64 / 20.0 / s
        );
        // For comparison: one BVH descent per ray through rapier's query pipeline.
        let start = std::time::Instant::now();
        let mut hits = 0usize;
        let origin = [ego_state.x + 2.0, ego_state.y];
        for _ in 0..scans / 10 {
            for [c, s] in &l.unit {
                hits += usize::from(w.cast_ray(origin, [*c, *s], l.params().max_range, ego).is_some());
            }
        }
        let s = start.elapsed().as_secs_f64();
        println!("per-ray query pipeline: {:.1} M rays/s ({} returns/scan)", rays / 10.0 / s / 1e6, hits / (scans / 10));
    }

    #[test]
    fn scripted_faults_blind_or_add_a_ghost_only_while_active_and_leave_the_draws_alone() {
        let (w, ego) = scene(25.0);
        let pose = VehicleState::default();
        let noisy = LidarParams { dropout_prob: 0.2, ..Default::default() };
        let clean_scan = |t: f64| Lidar::new(noisy.clone(), 5).capture(t, &w, ego, &pose);
        let blind = LidarFault::Blind { start: 1.0, duration: 0.5 };
        let ghost = LidarFault::Ghost { start: 1.0, duration: 0.05, range: 8.0, width: 1.0 };
        let with =
            |f: &LidarFault, t: f64| Lidar::new(LidarParams { faults: vec![f.clone()], ..noisy.clone() }, 5).capture(t, &w, ego, &pose);
        // Blind: no return at all, and only within [start, start + duration).
        assert!(with(&blind, 1.0).points.is_empty() && with(&blind, 1.49).points.is_empty());
        assert_eq!(with(&blind, 0.99), clean_scan(0.99));
        assert_eq!(with(&blind, 1.5), clean_scan(1.5));
        // Ghost: the rays crossing the 1 m face return at it (within noise); every other ray
        // returns exactly what it does without the fault (same draws).
        let g = with(&ghost, 1.0);
        let (near, far): (Vec<&[f64; 2]>, Vec<&[f64; 2]>) = g.points.iter().partition(|p| p[0] < 10.0);
        assert!(near.len() >= 8, "{} ghost points", near.len());
        assert!(near.iter().all(|p| (p[0] - 8.0).abs() < 0.1 && p[1].abs() <= 0.51), "{near:?}");
        let clean: Vec<_> = clean_scan(1.0).points.into_iter().filter(|p| p[1].atan2(p[0]).abs() > (0.5f64 / 8.0).atan() + 1e-3).collect();
        let far_outside: Vec<_> = far.into_iter().copied().filter(|p| p[1].atan2(p[0]).abs() > (0.5f64 / 8.0).atan() + 1e-3).collect();
        assert_eq!(far_outside, clean);
        assert_eq!(with(&ghost, 1.05), clean_scan(1.05));
    }

    #[test]
    fn validation_names_the_key() {
        let ghost = LidarFault::Ghost { start: 0.0, duration: 0.05, range: 300.0, width: 1.0 };
        assert_eq!(LidarParams { faults: vec![ghost], ..Default::default() }.validate().unwrap_err().key, "faults[0].range");
        let blind = LidarFault::Blind { start: 1.0, duration: 0.0 };
        assert_eq!(LidarParams { faults: vec![blind], ..Default::default() }.validate().unwrap_err().key, "faults[0].duration");
        assert_eq!(LidarParams { rate_hz: 0.0, ..Default::default() }.validate().unwrap_err().key, "rate_hz");
        for (p0, p1) in [(0.0, 1.5), (0.0, -0.1), (0.3, 0.1)] {
            let e = LidarParams { dropout_prob: p0, dropout_at_max_range: p1, ..Default::default() }.validate().unwrap_err();
            assert_eq!(e.key, "dropout_at_max_range", "{p0} {p1}: {e:?}");
        }
        for (p0, p1) in [(0.0, 0.0), (0.3, 0.0), (0.3, 0.3), (0.0, 1.0)] {
            assert!(LidarParams { dropout_prob: p0, dropout_at_max_range: p1, ..Default::default() }.validate().is_ok(), "{p0} {p1}");
        }
    }
}
