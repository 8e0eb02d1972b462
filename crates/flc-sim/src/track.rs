//! Tracks are data: a centreline polyline, a lane width and road-side objects (`docs/sim-model.md`).

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};

/// A road-side object; positions are given along the centreline (`s`, m) and across it (`offset`,
/// m, + left).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RoadsideObject {
    /// A guard rail (thin wall) at lateral `offset` from `from_s` to `to_s`.
    GuardRail {
        /// Lateral offset, m.
        offset: f64,
        /// Start, m along the centreline.
        from_s: f64,
        /// End, m along the centreline.
        to_s: f64,
    },
    /// A post (e.g. delineator, sign pole) of `radius` m.
    Post {
        /// Position along the centreline, m.
        s: f64,
        /// Lateral offset, m (or give `lane`).
        #[serde(default)]
        offset: f64,
        /// In the centre of this lane instead of at `offset` ([`Track::lane_offset`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lane: Option<u32>,
        /// Radius, m.
        radius: f64,
    },
    /// A parked (stationary) car, 4.7 m x 1.8 m.
    ParkedCar {
        /// Position along the centreline, m.
        s: f64,
        /// Lateral offset, m (or give `lane`).
        #[serde(default)]
        offset: f64,
        /// In the centre of this lane instead of at `offset` ([`Track::lane_offset`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lane: Option<u32>,
        /// Heading relative to the road, rad.
        #[serde(default)]
        heading_offset: f64,
    },
}

/// Nearest point on the centreline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Distance along the centreline, m.
    pub s: f64,
    /// Signed lateral offset (+ left of the direction of travel), m.
    pub lateral_offset: f64,
    /// Heading of the centreline there, rad.
    pub heading: f64,
    /// Index of the segment (a hint for the next, nearby query).
    pub segment: usize,
}

/// Most centreline points of a track (an imported road gives at most as many:
/// `openscenario::road::MAX_TRACK_POINTS` is this constant).
pub const MAX_CENTERLINE_POINTS: usize = 4_000_000;

/// Narrowest lane width a track accepts, m. OpenDRIVE allows any positive width; below 1 cm a
/// lane cannot be driven and the value is taken for an error.
pub const MIN_LANE_WIDTH: f64 = 0.01;

/// Widest lane width a track accepts, m (a test-track lane, as Euro NCAP's 28 m, is well inside).
pub const MAX_LANE_WIDTH: f64 = 100.0;

/// The usual range of road lane widths, m: a width outside it is accepted, and the OpenSCENARIO
/// importer says so in a warning.
pub const USUAL_LANE_WIDTH: (f64, f64) = (2.0, 6.0);

/// Most road-side objects of a track.
pub const MAX_OBJECTS: usize = 10_000;

/// A track: centreline polyline + lane width + road-side objects.
///
/// Deserialising (e.g. `[track] kind = "custom"` in a scenario file) computes the length table,
/// so a track read from a file is ready to use; [`Track::validate`] checks its geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, from = "TrackFile")]
pub struct Track {
    /// Name.
    #[serde(default)]
    pub name: String,
    /// Centreline of the lane driven in, as `[x, y]` points, m.
    pub centerline: Vec<[f64; 2]>,
    /// Lane width, m.
    #[serde(default = "default_lane_width")]
    pub lane_width: f64,
    /// Road-side clutter (guard rails, posts, parked cars).
    #[serde(default)]
    pub objects: Vec<RoadsideObject>,
    /// Number of lanes (all `lane_width` wide), numbered 0, 1, ... from the right. Default 1.
    #[serde(default = "one_lane", skip_serializing_if = "is_one_lane")]
    pub lanes: u32,
    /// The lane the ego (and the lead) start in; the centreline is its centre. Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub ego_lane: u32,
    /// Cumulative length at each point (computed).
    #[serde(skip)]
    cum: Vec<f64>,
    /// Bounding boxes `[min_x, min_y, max_x, max_y]` of [`CHUNK`] consecutive segments each
    /// (computed), so that [`Track::project`] only looks at the segments near the point.
    #[serde(skip)]
    chunks: Vec<[f64; 4]>,
}

/// Segments per bounding box of the projection index.
const CHUNK: usize = 16;

fn default_lane_width() -> f64 {
    3.5
}

fn one_lane() -> u32 {
    1
}

fn is_one_lane(n: &u32) -> bool {
    *n == 1
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// The serialised form of [`Track`] (everything but the computed length table).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TrackFile {
    #[serde(default)]
    name: String,
    centerline: Vec<[f64; 2]>,
    #[serde(default = "default_lane_width")]
    lane_width: f64,
    #[serde(default)]
    objects: Vec<RoadsideObject>,
    #[serde(default = "one_lane")]
    lanes: u32,
    #[serde(default)]
    ego_lane: u32,
}

impl From<TrackFile> for Track {
    fn from(f: TrackFile) -> Self {
        Track::new(&f.name, f.centerline, f.lane_width, f.objects).with_lanes(f.lanes, f.ego_lane)
    }
}

impl Track {
    /// Builds a track and its length table.
    pub fn new(name: &str, centerline: Vec<[f64; 2]>, lane_width: f64, objects: Vec<RoadsideObject>) -> Self {
        let mut t =
            Self { name: name.to_string(), centerline, lane_width, objects, lanes: 1, ego_lane: 0, cum: Vec::new(), chunks: Vec::new() };
        t.prepare();
        t
    }

    /// This track with `lanes` lanes, the ego starting in `ego_lane`; objects given by `lane`
    /// are placed at that lane's centre.
    pub fn with_lanes(mut self, lanes: u32, ego_lane: u32) -> Self {
        self.lanes = lanes;
        self.ego_lane = ego_lane;
        let offset = |l: u32| (f64::from(l) - f64::from(ego_lane)) * self.lane_width;
        for o in &mut self.objects {
            if let RoadsideObject::Post { offset: off, lane: Some(l), .. } | RoadsideObject::ParkedCar { offset: off, lane: Some(l), .. } =
                o
            {
                *off = offset(*l);
            }
        }
        self
    }

    /// Lateral offset of the centre of lane `lane` from the centreline (the ego lane's centre),
    /// m, + left: `(lane - ego_lane) * lane_width`.
    pub fn lane_offset(&self, lane: u32) -> f64 {
        (f64::from(lane) - f64::from(self.ego_lane)) * self.lane_width
    }

    /// Checks that `lane` exists; the error names `key`.
    pub fn check_lane(&self, key: &str, lane: u32) -> Result<(), ConfigError> {
        if lane < self.lanes {
            Ok(())
        } else {
            Err(ConfigError::new(key, format!("lane {lane} does not exist: the track has {} lane(s), 0-{}", self.lanes, self.lanes - 1)))
        }
    }

    fn prepare(&mut self) {
        let mut cum = Vec::with_capacity(self.centerline.len());
        let mut acc = 0.0;
        for (i, p) in self.centerline.iter().enumerate() {
            if i > 0 {
                let q = self.centerline[i - 1];
                acc += (p[0] - q[0]).hypot(p[1] - q[1]);
            }
            cum.push(acc);
        }
        self.cum = cum;
        let nseg = self.centerline.len().saturating_sub(1);
        self.chunks = (0..nseg.div_ceil(CHUNK))
            .map(|c| {
                let pts = &self.centerline[c * CHUNK..=((c + 1) * CHUNK).min(nseg)];
                pts.iter().fold([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY], |b, p| {
                    [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])]
                })
            })
            .collect();
    }

    /// A copy with the length table recomputed (deserialised tracks already have it).
    pub fn prepared(&self) -> Self {
        let mut t = self.clone();
        t.prepare();
        t
    }

    /// Checks the geometry; errors name the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.centerline.len() < 2 {
            return Err(ConfigError::new("centerline", "needs at least 2 points"));
        }
        if self.centerline.len() > MAX_CENTERLINE_POINTS {
            return Err(ConfigError::new("centerline", format!("at most {MAX_CENTERLINE_POINTS} points, got {}", self.centerline.len())));
        }
        if self.objects.len() > MAX_OBJECTS {
            return Err(ConfigError::new("objects", format!("at most {MAX_OBJECTS} road-side objects, got {}", self.objects.len())));
        }
        for (i, w) in self.centerline.windows(2).enumerate() {
            let (p, q) = (w[0], w[1]);
            if !(p[0].is_finite() && p[1].is_finite() && q[0].is_finite() && q[1].is_finite()) {
                let bad = if p[0].is_finite() && p[1].is_finite() { i + 1 } else { i };
                return Err(ConfigError::new(format!("centerline[{bad}]"), "coordinates must be finite"));
            }
            if (q[0] - p[0]).hypot(q[1] - p[1]) < 1e-6 {
                return Err(ConfigError::new(format!("centerline[{}]", i + 1), "repeats the previous point (zero-length segment)"));
            }
        }
        check_range("lane_width", self.lane_width, MIN_LANE_WIDTH, MAX_LANE_WIDTH, "m")?;
        if !(1..=8).contains(&self.lanes) {
            return Err(ConfigError::new("lanes", format!("must be 1-8, got {}", self.lanes)));
        }
        self.check_lane("ego_lane", self.ego_lane)?;
        for (i, o) in self.objects.iter().enumerate() {
            let key = |k: &str| format!("objects[{i}].{k}");
            match o {
                RoadsideObject::GuardRail { offset, from_s, to_s } => {
                    check_range(&key("offset"), *offset, -50.0, 50.0, "m")?;
                    check_range(&key("from_s"), *from_s, 0.0, 1e6, "m")?;
                    check_range(&key("to_s"), *to_s, *from_s, 1e6, "m (>= from_s)")?;
                }
                RoadsideObject::Post { s, offset, radius, lane } => {
                    if let Some(l) = lane {
                        self.check_lane(&key("lane"), *l)?;
                    }
                    check_range(&key("s"), *s, 0.0, 1e6, "m")?;
                    check_range(&key("offset"), *offset, -50.0, 50.0, "m")?;
                    check_range(&key("radius"), *radius, 0.01, 2.0, "m")?;
                }
                RoadsideObject::ParkedCar { s, offset, heading_offset, lane } => {
                    if let Some(l) = lane {
                        self.check_lane(&key("lane"), *l)?;
                    }
                    check_range(&key("s"), *s, 0.0, 1e6, "m")?;
                    check_range(&key("offset"), *offset, -50.0, 50.0, "m")?;
                    check_range(&key("heading_offset"), *heading_offset, -3.2, 3.2, "rad")?;
                }
            }
        }
        Ok(())
    }

    /// Total length, m.
    pub fn length(&self) -> f64 {
        self.cum.last().copied().unwrap_or(0.0)
    }

    fn segment_of(&self, s: f64) -> usize {
        let n = self.centerline.len();
        if n < 2 {
            return 0;
        }
        let i = self.cum.partition_point(|&c| c <= s);
        i.saturating_sub(1).min(n - 2)
    }

    /// Pose `(x, y, heading)` at distance `s` along the centreline (extrapolated beyond the ends).
    pub fn pose_at(&self, s: f64) -> (f64, f64, f64) {
        if self.centerline.len() < 2 {
            return (0.0, 0.0, 0.0);
        }
        let i = self.segment_of(s);
        let (p, q) = (self.centerline[i], self.centerline[i + 1]);
        let len = (q[0] - p[0]).hypot(q[1] - p[1]).max(1e-12);
        let h = (q[1] - p[1]).atan2(q[0] - p[0]);
        let u = s - self.cum[i];
        (p[0] + u * (q[0] - p[0]) / len, p[1] + u * (q[1] - p[1]) / len, h)
    }

    /// The point `offset` m to the left of the centreline at `s` (+ left) and the road's heading
    /// there: where objects and vehicles given by `(s, offset)` stand.
    pub fn place(&self, s: f64, offset: f64) -> (f64, f64, f64) {
        let (x, y, h) = self.pose_at(s);
        (x - offset * h.sin(), y + offset * h.cos(), h)
    }

    /// Signed curvature at `s`, 1/m (+ left), from the heading change over the neighbouring segments.
    pub fn curvature_at(&self, s: f64) -> f64 {
        // Over +-10 m, so that the polyline's piecewise-constant heading averages out.
        let (_, _, h0) = self.pose_at(s - 10.0);
        let (_, _, h1) = self.pose_at(s + 10.0);
        wrap(h1 - h0) / 20.0
    }

    /// Squared distance from `(x, y)` to segment `i` and the parameter `u` of the nearest point
    /// (the first and last segments are extended beyond the ends).
    fn segment_d2(&self, i: usize, x: f64, y: f64) -> (f64, f64) {
        let (p, q) = (self.centerline[i], self.centerline[i + 1]);
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let len2 = (dx * dx + dy * dy).max(1e-12);
        let n = self.centerline.len();
        let lo = if i == 0 { f64::NEG_INFINITY } else { 0.0 };
        let hi = if i + 2 == n { f64::INFINITY } else { 1.0 };
        let u = (((x - p[0]) * dx + (y - p[1]) * dy) / len2).clamp(lo, hi);
        let (cx, cy) = (p[0] + u * dx, p[1] + u * dy);
        ((x - cx).powi(2) + (y - cy).powi(2), u)
    }

    /// The projection of `(x, y)` onto segment `i` at parameter `u`.
    fn projection_on(&self, i: usize, u: f64, x: f64, y: f64) -> Projection {
        let (p, q) = (self.centerline[i], self.centerline[i + 1]);
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let len = (dx * dx + dy * dy).max(1e-12).sqrt();
        let lateral = (dx * (y - p[1]) - dy * (x - p[0])) / len;
        Projection { s: self.cum[i] + u * len, lateral_offset: lateral, heading: dy.atan2(dx), segment: i }
    }

    /// Nearest point on the centreline to `(x, y)`: the same result as checking every segment
    /// (ties go to the lower segment index), but only the segments whose bounding box can
    /// contain a nearer point are checked.
    pub fn project(&self, x: f64, y: f64) -> Projection {
        let nseg = self.centerline.len().saturating_sub(1);
        if self.chunks.len() <= 2 || !(x.is_finite() && y.is_finite()) {
            return self.project_range(x, y, 0, nseg);
        }
        // (d2, segment, u) of the best so far.
        let mut best = (f64::INFINITY, usize::MAX, 0.0);
        let consider = |i: usize, best: &mut (f64, usize, f64)| {
            let (d2, u) = self.segment_d2(i, x, y);
            if d2 < best.0 || (d2 == best.0 && i < best.1) {
                *best = (d2, i, u);
            }
        };
        // The extended end segments are not bounded by their boxes: always checked.
        consider(0, &mut best);
        consider(nseg - 1, &mut best);
        let lower_bound = |b: &[f64; 4]| {
            let dx = (b[0] - x).max(x - b[2]).max(0.0);
            let dy = (b[1] - y).max(y - b[3]).max(0.0);
            dx * dx + dy * dy
        };
        let segments = |c: usize| c * CHUNK..((c + 1) * CHUNK).min(nseg);
        // Nearest box first, then every box that may still hold a nearer (or tied) segment; the
        // margin covers rounding in the distances.
        let first =
            (0..self.chunks.len()).min_by(|&a, &b| lower_bound(&self.chunks[a]).total_cmp(&lower_bound(&self.chunks[b]))).unwrap_or(0);
        for i in segments(first) {
            consider(i, &mut best);
        }
        for (c, b) in self.chunks.iter().enumerate() {
            if c != first && lower_bound(b) <= best.0 * (1.0 + 1e-9) + 1e-12 {
                for i in segments(c) {
                    consider(i, &mut best);
                }
            }
        }
        if best.1 == usize::MAX {
            return self.project_range(x, y, 0, nseg);
        }
        self.projection_on(best.1, best.2, x, y)
    }

    /// Nearest point searching only the segments within `window` of `hint` (for tracking a vehicle
    /// step by step; falls back to a full search when the result is at the window's edge).
    pub fn project_near(&self, x: f64, y: f64, hint: usize, window: usize) -> Projection {
        let nseg = self.centerline.len().saturating_sub(1);
        let lo = hint.saturating_sub(window);
        let hi = (hint + window + 1).min(nseg);
        let p = self.project_range(x, y, lo, hi);
        if (p.segment == lo && lo > 0) || (p.segment + 1 == hi && hi < nseg) { self.project(x, y) } else { p }
    }

    /// Nearest point among segments `lo..hi`, checking each (first of equals wins).
    fn project_range(&self, x: f64, y: f64, lo: usize, hi: usize) -> Projection {
        let mut best: Option<(f64, usize, f64)> = None;
        for i in lo..hi {
            let (d2, u) = self.segment_d2(i, x, y);
            if best.is_none_or(|(b, _, _)| d2 < b) {
                best = Some((d2, i, u));
            }
        }
        best.map_or(Projection { s: 0.0, lateral_offset: 0.0, heading: 0.0, segment: 0 }, |(_, i, u)| self.projection_on(i, u, x, y))
    }

    /// The paper's straight run: one lane of `length` m along +x, a second lane to the left,
    /// guard rails on both sides, posts every 50 m and parked cars in the left lane.
    pub fn straight(length: f64) -> Self {
        let lw = default_lane_width();
        let mut objects = vec![
            RoadsideObject::GuardRail { offset: -(lw / 2.0 + 1.5), from_s: 0.0, to_s: length },
            RoadsideObject::GuardRail { offset: 1.5 * lw + 1.5, from_s: 0.0, to_s: length },
        ];
        let mut s = 25.0;
        while s < length {
            objects.push(RoadsideObject::Post { s, offset: -(lw / 2.0 + 1.0), radius: 0.08, lane: None });
            s += 50.0;
        }
        let mut s = 300.0;
        while s < length {
            objects.push(RoadsideObject::ParkedCar { s, offset: lw, heading_offset: 0.0, lane: None });
            s += 600.0;
        }
        // Two lanes: the ego's (0) and the one to its left (1), where the cars are parked.
        Self::new("straight", vec![[0.0, 0.0], [length, 0.0]], lw, objects).with_lanes(2, 0)
    }

    /// A route with curves like the paper's Fig. 3a: straights joined by arcs of radius 120-250 m
    /// (rural-road radii for 50-90 km/h), sampled every 2 m, guard rails on both sides.
    pub fn curvy() -> Self {
        // (straight length m, arc radius m, arc angle rad, + left)
        let plan: [(f64, f64, f64); 5] = [
            (200.0, 200.0, std::f64::consts::FRAC_PI_2),
            (150.0, 150.0, -std::f64::consts::FRAC_PI_2),
            (200.0, 250.0, std::f64::consts::FRAC_PI_3),
            (100.0, 120.0, -std::f64::consts::FRAC_PI_3),
            (400.0, 1.0, 0.0),
        ];
        let mut t = Self::from_plan("curvy", &plan, 2.0);
        let len = t.length();
        let lw = t.lane_width;
        t.objects = vec![
            RoadsideObject::GuardRail { offset: -(lw / 2.0 + 1.5), from_s: 0.0, to_s: len },
            RoadsideObject::GuardRail { offset: lw / 2.0 + 1.5, from_s: 0.0, to_s: len },
        ];
        let mut s = 30.0;
        while s < len {
            t.objects.push(RoadsideObject::Post { s, offset: -(lw / 2.0 + 1.0), radius: 0.08, lane: None });
            s += 60.0;
        }
        t
    }

    /// One lane (3.5 m) along a plan of `(straight length m, arc radius m, arc angle rad, + left)`
    /// legs from the origin heading along +x, sampled every `step` m (each sub-arc a chord),
    /// without road-side objects: the curved roads of [`Track::curvy`] and of the fixtures.
    pub fn from_plan(name: &str, plan: &[(f64, f64, f64)], step: f64) -> Self {
        let (mut x, mut y, mut h) = (0.0_f64, 0.0_f64, 0.0_f64);
        let mut pts = vec![[x, y]];
        for &(straight, radius, angle) in plan {
            let n = (straight / step).round() as usize;
            for _ in 0..n {
                x += step * h.cos();
                y += step * h.sin();
                pts.push([x, y]);
            }
            if angle != 0.0 {
                let arc = radius * angle.abs();
                let n = (arc / step).ceil() as usize;
                let dh = angle / n as f64;
                let ds = arc / n as f64;
                for _ in 0..n {
                    // Chord of the sub-arc: heading at its middle.
                    let hm = h + dh / 2.0;
                    x += ds * hm.cos();
                    y += ds * hm.sin();
                    h += dh;
                    pts.push([x, y]);
                }
            }
        }
        Self::new(name, pts, default_lane_width(), Vec::new())
    }

    /// One lane (3.5 m) along pieces of `(length m, curvature at its start, at its end, 1/m, +
    /// left)` whose curvature changes linearly along them (a clothoid where the two differ, an
    /// arc or a straight where they are equal), from the origin heading along +x: legs of about
    /// `step` m, each an arc of the curvature at its middle (the heading at every leg's end is the
    /// clothoid's), sampled as [`Track::from_plan`] samples them.
    pub fn from_curvature(name: &str, pieces: &[(f64, f64, f64)], step: f64) -> Self {
        let mut plan = Vec::new();
        for &(len, k0, k1) in pieces {
            let n = (len / step).round().max(1.0) as usize;
            let ds = len / n as f64;
            for i in 0..n {
                let k = k0 + (k1 - k0) * (i as f64 + 0.5) / n as f64;
                plan.push(if k == 0.0 { (ds, 1.0, 0.0) } else { (0.0, 1.0 / k.abs(), k * ds) });
            }
        }
        Self::from_plan(name, &plan, step)
    }
}

/// Wraps an angle to (-pi, pi].
pub fn wrap(a: f64) -> f64 {
    let r = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if r <= -std::f64::consts::PI { r + std::f64::consts::TAU } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_projection_and_pose() {
        let t = Track::straight(1000.0);
        assert_eq!(t.length(), 1000.0);
        let p = t.project(250.0, 1.2);
        assert!((p.s - 250.0).abs() < 1e-9 && (p.lateral_offset - 1.2).abs() < 1e-9);
        assert_eq!(t.pose_at(400.0), (400.0, 0.0, 0.0));
        assert!(t.validate().is_ok());
    }

    #[test]
    fn curvy_track_geometry() {
        let t = Track::curvy();
        assert!(t.validate().is_ok());
        // Length: straights 1050 m + arcs 200 pi/2 + 150 pi/2 + 250 pi/3 + 120 pi/3.
        let expected = 1050.0 + 350.0 * std::f64::consts::FRAC_PI_2 + 370.0 * std::f64::consts::FRAC_PI_3;
        assert!((t.length() - expected).abs() < 0.1, "{}", t.length());
        // In the middle of the first arc (radius 200 m, left) the curvature is 1/200.
        let s_mid = 200.0 + 200.0 * std::f64::consts::FRAC_PI_4;
        assert!((t.curvature_at(s_mid) - 0.005).abs() < 6e-4, "{}", t.curvature_at(s_mid));
        // Points on the centreline project onto themselves.
        for s in [10.0, 250.0, 700.0, 1200.0, 1700.0] {
            let (x, y, h) = t.pose_at(s);
            let p = t.project(x, y);
            assert!((p.s - s).abs() < 1e-6 && p.lateral_offset.abs() < 1e-6);
            // A point 1 m to the left has offset +1.
            let q = t.project_near(x - h.sin(), y + h.cos(), p.segment, 5);
            assert!((q.lateral_offset - 1.0).abs() < 0.01, "{}", q.lateral_offset);
        }
    }

    #[test]
    fn pose_on_an_arc_matches_the_circle() {
        // The curvy track's first arc: radius 200 m to the left, starting at (200, 0) heading +x,
        // centre (200, 200).
        let t = Track::curvy();
        let r = 200.0;
        for phi in [0.1, 0.5, 1.0, 1.5] {
            let (x, y, h) = t.pose_at(200.0 + r * phi);
            let (ex, ey) = (200.0 + r * f64::sin(phi), r * (1.0 - f64::cos(phi)));
            // Chords of <= 2 m deviate from the circle by at most 2²/(8 r) = 2.5 mm.
            assert!((x - ex).hypot(y - ey) < 0.01, "phi {phi}: ({x}, {y}) vs ({ex}, {ey})");
            // Heading of the chord: within half a sub-arc angle (2 m / 200 m / 2) of the tangent.
            assert!(wrap(h - phi).abs() < 0.006, "phi {phi}: heading {h}");
            // And back: the point projects onto itself.
            let p = t.project(x, y);
            assert!((p.s - (200.0 + r * phi)).abs() < 1e-6 && p.lateral_offset.abs() < 1e-6);
        }
    }

    #[test]
    fn indexed_projection_equals_checking_every_segment() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        // A random walk with sharp turns (the nearest segment is often far along the polyline).
        let mut pts = vec![[0.0, 0.0]];
        let mut h = 0.0f64;
        for _ in 0..700 {
            h += rng.random_range(-0.6..0.6);
            let [x, y] = *pts.last().expect("point");
            let step = rng.random_range(0.5..5.0);
            pts.push([x + step * h.cos(), y + step * h.sin()]);
        }
        let walk = Track::new("walk", pts, 3.5, vec![]);
        for t in [Track::curvy(), walk] {
            let nseg = t.centerline.len() - 1;
            let (min, max) = t
                .chunks
                .iter()
                .fold(([f64::MAX; 2], [f64::MIN; 2]), |(a, b), c| ([a[0].min(c[0]), a[1].min(c[1])], [b[0].max(c[2]), b[1].max(c[3])]));
            for _ in 0..5000 {
                let x = rng.random_range(min[0] - 100.0..max[0] + 100.0);
                let y = rng.random_range(min[1] - 100.0..max[1] + 100.0);
                assert_eq!(t.project(x, y), t.project_range(x, y, 0, nseg), "({x}, {y}) on {}", t.name);
            }
            // Vertices: exact ties between neighbouring segments.
            for p in t.centerline.iter().step_by(7) {
                assert_eq!(t.project(p[0], p[1]), t.project_range(p[0], p[1], 0, nseg));
            }
        }
    }

    #[test]
    fn toml_round_trip_computes_the_length_table() {
        let src = r#"
            name = "l"
            centerline = [[0.0, 0.0], [100.0, 0.0], [100.0, 50.0]]
            objects = [
                { kind = "guard_rail", offset = -3.0, from_s = 0.0, to_s = 150.0 },
                { kind = "post", s = 20.0, offset = 3.0, radius = 0.1 },
                { kind = "parked_car", s = 120.0, offset = 3.5 },
            ]
        "#;
        let t: Track = toml::from_str(src).expect("parse");
        assert!(t.validate().is_ok());
        assert_eq!(t.lane_width, 3.5);
        assert_eq!(t.length(), 150.0);
        assert_eq!(t.pose_at(125.0), (100.0, 25.0, std::f64::consts::FRAC_PI_2));
        let again: Track = toml::from_str(&toml::to_string(&t).expect("serialise")).expect("parse");
        assert_eq!(again, t);
        // Unknown keys are rejected.
        assert!(toml::from_str::<Track>("centerline = [[0.0, 0.0], [1.0, 0.0]]\nlane_widht = 3.0").is_err());
        // As a scenario's `[track]` table.
        let spec: crate::scenario::TrackSpec = toml::from_str(&format!("kind = \"custom\"\n{src}")).expect("track spec");
        let built = spec.build().expect("valid");
        assert_eq!(built, t);
        assert!(toml::from_str::<crate::scenario::TrackSpec>("kind = \"custom\"\ncenterline = [[0.0, 0.0], [1.0, 0.0]]\nfoo = 1").is_err());
    }

    #[test]
    fn validation_names_the_key() {
        let t = Track::new("bad", vec![[0.0, 0.0], [0.0, 0.0]], 3.5, vec![]);
        assert_eq!(t.validate().unwrap_err().key, "centerline[1]");
        let t = Track::new(
            "bad",
            vec![[0.0, 0.0], [10.0, 0.0]],
            3.5,
            vec![RoadsideObject::Post { s: 5.0, offset: 2.0, radius: 0.0, lane: None }],
        );
        assert_eq!(t.validate().unwrap_err().key, "objects[0].radius");
        let t = Track::new("bad", vec![[0.0, 0.0]], 3.5, vec![]);
        assert_eq!(t.validate().unwrap_err().key, "centerline");
        let t = Track::new("bad", vec![[0.0, 0.0], [f64::NAN, 0.0]], 3.5, vec![]);
        assert_eq!(t.validate().unwrap_err().key, "centerline[1]");
        let t = Track::new("bad", vec![[f64::INFINITY, 0.0], [1.0, 0.0]], 3.5, vec![]);
        assert_eq!(t.validate().unwrap_err().key, "centerline[0]");
        // Any positive width up to 100 m (a 28 m test-track lane); zero, negative, absurd: errors.
        for ok in [0.5, 9.0, 28.0, 100.0] {
            assert!(Track::new("w", vec![[0.0, 0.0], [10.0, 0.0]], ok, vec![]).validate().is_ok(), "{ok}");
        }
        for bad in [0.0, -3.5, 0.001, 100.5, f64::NAN, f64::INFINITY] {
            let t = Track::new("bad", vec![[0.0, 0.0], [10.0, 0.0]], bad, vec![]);
            assert_eq!(t.validate().unwrap_err().key, "lane_width", "{bad}");
        }
    }
}
