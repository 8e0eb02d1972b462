//! ASAM OpenDRIVE (`.xodr`, 1.4-1.8) roads: the plan view (reference line) and the lanes, as far
//! as they shape 2-D motion, and their translation into the simulator's [`Track`].
//!
//! Read: `planView` geometries (`line`, `arc`, `spiral`, `poly3`, `paramPoly3`), `lanes` with
//! `laneOffset` records and `laneSection`s (`left`/`center`/`right` lanes with `id`, `type` and
//! `width` records). Skipped (they change neither the plan view nor lane widths; their tag names
//! are collected in [`Network::skipped`]): `elevationProfile`, `lateralProfile`, `objects`,
//! `signals`, `type`, `roadMark`, `speed`, `controller`, `userData`, ... and
//! any other element outside the plan view and the lane widths (the file's `header` is metadata
//! and not reported). Refused as unsupported: lane `border` records, `laneSection
//! singleSide="true"`, unknown geometry shapes. Road and lane links and `junction`s are read
//! for the route through a network ([`super::junction`]).
//!
//! Numerics (all deterministic, no randomness, fixed evaluation order):
//! - `line`, `arc`: closed forms (the arc through `sin(x)/x`, exact also for tiny curvatures);
//! - `spiral` (clothoid, curvature linear in `s`): the heading is exact (quadratic in `s`); the
//!   position is the integral of `(cos, sin)` of it by 8-point Gauss-Legendre quadrature over
//!   panels of at most 0.5 rad of turning, refined adaptively until two estimates agree to
//!   1e-11 relative; panel start points are tabulated, so a point costs one 8-point rule;
//! - `poly3` (`v(u) = a + b u + c u² + d u³`) and `paramPoly3`: positions are the polynomials;
//!   the arc length is tabulated the same way (adaptive Gauss-Legendre of the speed) and
//!   inverted by safeguarded Newton iteration, so `s` is true arc length along the curve. A
//!   `paramPoly3` whose true length differs from its `length` attribute is traversed in full,
//!   its arc length scaled to `length` (as esmini does).
//!
//! Beyond a geometry's end (a road longer than its plan view) the reference line continues
//! straight along the end tangent.

use std::collections::BTreeSet;
use std::path::Path;

use super::error::ImportError;
use super::junction::{Connection, Contact, Element, Junction, Link};
use super::xml;
use crate::track::{Track, wrap};

/// Most roads in one file.
pub const MAX_ROADS: usize = 10_000;
/// Most plan-view geometries in one file.
pub const MAX_GEOMETRIES: usize = 100_000;
/// Longest road or geometry, m.
pub const MAX_LENGTH: f64 = 1e6;
/// Largest `|x|`, `|y|` of a geometry's start, m.
pub const MAX_COORDINATE: f64 = 1e8;
/// Largest curvature of any geometry, 1/m (a 1 mm radius: anything beyond is not a road).
pub const MAX_CURVATURE: f64 = 1e3;
/// Most turning of one `spiral`, rad (a real one turns a few rad).
pub const MAX_SPIRAL_TURN: f64 = 1e4;
/// Most quadrature panels tabulated for one geometry.
pub const MAX_PANELS_PER_GEOMETRY: usize = 50_000;
/// Most quadrature panels tabulated for one file.
pub const MAX_PANELS: usize = 2_000_000;
/// Shortest road [`to_track`] accepts, m (as `[track] kind = "straight"`).
pub const MIN_TRACK_LENGTH: f64 = 50.0;
/// Longest step of [`to_track`]'s sampling along the road, m.
pub const TRACK_STEP: f64 = 0.5;
/// Largest distance between a track chord's midpoint and the lane centre curve's point midway (in road `s`), m.
pub const TRACK_CHORD_TOLERANCE: f64 = 0.0025;
/// Most points of a track built by [`to_track`]: the track's own limit.
pub const MAX_TRACK_POINTS: usize = crate::track::MAX_CENTERLINE_POINTS;
/// Lane widths that differ by at most this are "equal" for [`LaneMap::uniform`], m.
pub const WIDTH_TOLERANCE: f64 = 0.01;

/// Lane types counted as driving lanes by [`Road::driving_lanes`] and [`to_track`]: esmini's
/// "any driving" set (`driving`, `entry`, `exit`, `onRamp`, `offRamp`, `bidirectional`; compared
/// case-insensitively). Shoulders, parking, restricted, biking, sidewalk, border, median, ... are
/// not driving lanes.
pub const DRIVING_TYPES: [&str; 6] = ["driving", "entry", "exit", "onRamp", "offRamp", "bidirectional"];

/// Whether lane type `kind` is a driving lane ([`DRIVING_TYPES`]).
pub fn is_driving_type(kind: &str) -> bool {
    DRIVING_TYPES.iter().any(|t| t.eq_ignore_ascii_case(kind))
}

/// The roads of one OpenDRIVE file.
#[derive(Debug, Clone, PartialEq)]
pub struct Network {
    /// The roads, in file order (ids unique).
    pub roads: Vec<Road>,
    /// The junctions, in file order (ids unique).
    pub junctions: Vec<Junction>,
    /// Tag names of the elements that were skipped because they do not change 2-D motion
    /// (one warning per kind).
    pub skipped: BTreeSet<String>,
}

impl Network {
    /// The road with id `id`.
    pub fn road(&self, id: &str) -> Option<&Road> {
        self.roads.iter().find(|r| r.id == id)
    }

    /// The junction with id `id`.
    pub fn junction(&self, id: &str) -> Option<&Junction> {
        self.junctions.iter().find(|j| j.id == id)
    }
}

/// A cubic polynomial record starting at `s` (a `laneOffset`'s `s` or a `width`'s `sOffset`):
/// `a + b ds + c ds² + d ds³`, `ds` from `s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cubic {
    /// Start (m; a lane width's relative to its lane section).
    pub s: f64,
    /// Constant term, m.
    pub a: f64,
    /// Linear term, m/m.
    pub b: f64,
    /// Quadratic term, 1/m.
    pub c: f64,
    /// Cubic term, 1/m².
    pub d: f64,
}

impl Cubic {
    /// The value at `ds` from the record's start.
    pub fn eval(&self, ds: f64) -> f64 {
        ((self.d * ds + self.c) * ds + self.b) * ds + self.a
    }
}

/// The record of a sorted list in effect at `s` (the last one starting at or before it, else the
/// first) and `s` relative to its start (not below 0).
fn record_at(records: &[Cubic], s: f64) -> Option<(&Cubic, f64)> {
    let i = records.partition_point(|r| r.s <= s).saturating_sub(1);
    records.get(i).map(|r| (r, (s - r.s).max(0.0)))
}

/// The shape of a plan-view geometry, in its local frame (origin at the geometry's start `x`,
/// `y`, u axis along `hdg`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A straight line.
    Line,
    /// A circular arc of constant `curvature` (1/m, + left).
    Arc {
        /// Curvature, 1/m (+ left).
        curvature: f64,
    },
    /// An Euler spiral (clothoid): curvature linear in `s` from `curv_start` to `curv_end`.
    Spiral {
        /// Curvature at the start, 1/m.
        curv_start: f64,
        /// Curvature at the end, 1/m.
        curv_end: f64,
    },
    /// A cubic `v(u) = a + b u + c u² + d u³` over the local u axis.
    Poly3 {
        /// Coefficients `[a, b, c, d]`.
        coef: [f64; 4],
    },
    /// A parametric cubic `u(p)`, `v(p)`; `p` in `[0, length]` or, if `normalized`, `[0, 1]`.
    ParamPoly3 {
        /// `[aU, bU, cU, dU]`.
        u: [f64; 4],
        /// `[aV, bV, cV, dV]`.
        v: [f64; 4],
        /// `pRange="normalized"` (the default) rather than `"arcLength"`.
        normalized: bool,
    },
}

/// A plan-view geometry record.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// Start along the road, m.
    pub s: f64,
    /// Start x, m.
    pub x: f64,
    /// Start y, m.
    pub y: f64,
    /// Start heading, rad.
    pub hdg: f64,
    /// Length (along the curve), m.
    pub length: f64,
    /// The curve.
    pub shape: Shape,
    /// Quadrature table (spiral: positions; poly3/paramPoly3: arc length).
    table: Table,
}

/// Nodes of an adaptive quadrature: parameter values `q` and the integral from the first node to
/// each (`acc`: spiral `[x, y]`; polynomial curves `[arc length, 0]`).
#[derive(Debug, Clone, PartialEq, Default)]
struct Table {
    q: Vec<f64>,
    acc: Vec<[f64; 2]>,
    /// Largest curvature seen at the nodes (poly3/paramPoly3), 1/m: the projection's step.
    kmax: f64,
}

/// 8-point Gauss-Legendre abscissae (positive half) on [-1, 1].
const GL_X: [f64; 4] = [0.183_434_642_495_649_8, 0.525_532_409_916_329, 0.796_666_477_413_626_7, 0.960_289_856_497_536_3];
/// Their weights.
const GL_W: [f64; 4] = [0.362_683_783_378_362, 0.313_706_645_877_887_3, 0.222_381_034_453_374_5, 0.101_228_536_290_376_3];

/// 8-point Gauss-Legendre integral of the 2-vector function `f` over `[a, b]`.
fn gauss(a: f64, b: f64, f: &dyn Fn(f64) -> [f64; 2]) -> [f64; 2] {
    let (m, r) = (0.5 * (a + b), 0.5 * (b - a));
    let mut acc = [0.0, 0.0];
    for (x, w) in GL_X.iter().zip(GL_W) {
        for q in [m - r * x, m + r * x] {
            let v = f(q);
            acc[0] += w * v[0];
            acc[1] += w * v[1];
        }
    }
    [acc[0] * r, acc[1] * r]
}

/// Relative agreement of the two quadrature estimates that accepts a panel.
const QUAD_TOL: f64 = 1e-11;
/// Deepest bisection of one initial panel.
const QUAD_DEPTH: u32 = 48;

impl Table {
    /// Integrates `f` over `[q0, q1]` on `n0` equal panels, each bisected until the one-panel and
    /// the two-half-panel estimates agree to [`QUAD_TOL`] (relative, at least 1e-11 absolute).
    /// `budget`: panels left for the file.
    fn build(q0: f64, q1: f64, n0: usize, f: &dyn Fn(f64) -> [f64; 2], budget: &mut usize) -> Result<Table, String> {
        let n0 = n0.max(1);
        let h = (q1 - q0) / n0 as f64;
        let mut stack: Vec<(f64, f64, u32)> =
            (0..n0).rev().map(|i| (q0 + h * i as f64, if i + 1 == n0 { q1 } else { q0 + h * (i + 1) as f64 }, 0)).collect();
        let mut t = Table { q: vec![q0], acc: vec![[0.0, 0.0]], kmax: 0.0 };
        let mut last = [0.0, 0.0];
        while let Some((a, b, depth)) = stack.pop() {
            let whole = gauss(a, b, f);
            let m = 0.5 * (a + b);
            let (l, r) = (gauss(a, m, f), gauss(m, b, f));
            let split = [l[0] + r[0], l[1] + r[1]];
            if !(split[0].is_finite() && split[1].is_finite() && whole[0].is_finite() && whole[1].is_finite()) {
                return Err("the curve is not finite (coefficients too large)".into());
            }
            let err = (whole[0] - split[0]).hypot(whole[1] - split[1]);
            let tol = QUAD_TOL * split[0].hypot(split[1]).max(1.0);
            if err <= tol || depth >= QUAD_DEPTH || m <= a || m >= b {
                if t.q.len() > MAX_PANELS_PER_GEOMETRY || *budget == 0 {
                    return Err(format!(
                        "needs more than {} quadrature panels (at most {MAX_PANELS_PER_GEOMETRY} per geometry, {MAX_PANELS} per file)",
                        t.q.len()
                    ));
                }
                *budget -= 1;
                last = [last[0] + split[0], last[1] + split[1]];
                t.q.push(b);
                t.acc.push(last);
            } else {
                stack.push((m, b, depth + 1));
                stack.push((a, m, depth + 1));
            }
        }
        Ok(t)
    }

    /// Index `i` of the panel `[q[i], q[i + 1]]` holding `x` in the sorted column `col`.
    fn panel(col: impl Fn(usize) -> f64, len: usize, x: f64) -> usize {
        // Binary search over the nodes: the last node <= x, at most len - 2.
        let (mut lo, mut hi) = (0usize, len);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if col(mid) <= x {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo.saturating_sub(1).min(len.saturating_sub(2))
    }

    /// The total integral (last node).
    fn total(&self) -> [f64; 2] {
        self.acc.last().copied().unwrap_or([0.0, 0.0])
    }

    /// Spiral: the integral from the start to parameter `q` (= arc length).
    fn integral_to(&self, q: f64, f: &dyn Fn(f64) -> [f64; 2]) -> [f64; 2] {
        let i = Self::panel(|k| self.q.get(k).copied().unwrap_or(f64::INFINITY), self.q.len(), q);
        let (Some(&q0), Some(&base)) = (self.q.get(i), self.acc.get(i)) else {
            return gauss(0.0, q, f);
        };
        let add = gauss(q0, q, f);
        [base[0] + add[0], base[1] + add[1]]
    }

    /// Polynomial curves: the parameter at arc length `sigma` (the inverse of the tabulated
    /// arc length of `speed`), by Newton iteration kept inside the panel's bracket.
    fn param_at(&self, sigma: f64, speed: &dyn Fn(f64) -> f64) -> f64 {
        let len = self.q.len();
        let i = Self::panel(|k| self.acc.get(k).map_or(f64::INFINITY, |a| a[0]), len, sigma);
        let (Some(&qa), Some(&qb), Some(a), Some(b)) = (self.q.get(i), self.q.get(i + 1), self.acc.get(i), self.acc.get(i + 1)) else {
            return self.q.first().copied().unwrap_or(0.0);
        };
        let (sa, sb) = (a[0], b[0]);
        if sigma >= sb {
            return qb;
        }
        if sigma <= sa {
            return qa;
        }
        let f = |p: f64| [speed(p), 0.0];
        let (mut lo, mut hi) = (qa, qb);
        let mut p = if sb > sa { qa + (sigma - sa) / (sb - sa) * (qb - qa) } else { 0.5 * (qa + qb) };
        let tol = 1e-12 * sigma.abs().max(1.0);
        for _ in 0..100 {
            let g = sa + gauss(qa, p, &f)[0] - sigma;
            if g.abs() <= tol {
                break;
            }
            if g > 0.0 {
                hi = p;
            } else {
                lo = p;
            }
            let v = speed(p);
            let newton = p - g / v;
            p = if v > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if hi - lo <= 1e-15 * hi.abs().max(lo.abs()).max(1.0) {
                break;
            }
        }
        p
    }
}

/// `a` in (-pi, pi] (unchanged, bit for bit, if it already is).
fn wrap_angle(a: f64) -> f64 {
    if a > -std::f64::consts::PI && a <= std::f64::consts::PI { a } else { wrap(a) }
}

/// `sin(z) / z`, accurate near 0.
fn sinc(z: f64) -> f64 {
    if z.abs() < 1e-4 { 1.0 - z * z / 6.0 } else { z.sin() / z }
}

/// Value and first and second derivatives of the cubic `c[0] + c[1] p + c[2] p² + c[3] p³`.
fn cubic3(c: &[f64; 4], p: f64) -> (f64, f64, f64) {
    (((c[3] * p + c[2]) * p + c[1]) * p + c[0], (3.0 * c[3] * p + 2.0 * c[2]) * p + c[1], 6.0 * c[3] * p + 2.0 * c[2])
}

impl Geometry {
    /// A geometry record starting at road position `s`, world `(x, y)`, heading `hdg`, of
    /// `length` m (as read from a `<geometry>`; the error's element is `geometry`).
    pub fn new(s: f64, x: f64, y: f64, hdg: f64, length: f64, shape: Shape) -> Result<Self, ImportError> {
        let err = |m: String| ImportError { file: String::new(), line: 0, element: "geometry".into(), message: m };
        if !(s.is_finite() && x.is_finite() && y.is_finite() && hdg.is_finite()) {
            return Err(err(format!("s, x, y and hdg must be finite, got {s}, {x}, {y}, {hdg}")));
        }
        if length.is_nan() || length <= 0.0 || length > MAX_LENGTH {
            return Err(err(format!("length must be in (0, {MAX_LENGTH}] m, got {length}")));
        }
        let mut budget = MAX_PANELS_PER_GEOMETRY;
        Geometry { s, x, y, hdg, length, shape, table: Table::default() }.tabulate(&mut budget).map_err(err)
    }

    /// Tabulates the quadrature the shape needs; the error says what is wrong with the values.
    /// `budget`: quadrature panels left for the file ([`MAX_PANELS`]).
    fn tabulate(mut self, budget: &mut usize) -> Result<Self, String> {
        let g = &self;
        let length = g.length;
        let too_curved = |k: f64| {
            if k.is_nan() || k.abs() > MAX_CURVATURE {
                Err(format!("curvature {k:e} 1/m is beyond the limit of {MAX_CURVATURE} 1/m (a {} mm radius)", 1e3 / MAX_CURVATURE))
            } else {
                Ok(())
            }
        };
        let table = match g.shape {
            Shape::Line => Table::default(),
            Shape::Arc { curvature } => {
                too_curved(curvature)?;
                Table::default()
            }
            Shape::Spiral { curv_start, curv_end } => {
                too_curved(curv_start)?;
                too_curved(curv_end)?;
                // An upper bound of the turning (exact if the curvature keeps its sign).
                let turn = 0.5 * (curv_start.abs() + curv_end.abs()) * length;
                if turn.is_nan() || turn > MAX_SPIRAL_TURN {
                    return Err(format!("the spiral turns by about {turn:.0} rad, more than {MAX_SPIRAL_TURN} rad"));
                }
                let n0 = (turn / 0.5).ceil().max(1.0) as usize;
                let f = |q: f64| {
                    let th = g.spiral_heading(q);
                    [th.cos(), th.sin()]
                };
                Table::build(0.0, length, n0, &f, budget)?
            }
            Shape::Poly3 { coef } => {
                // s is arc length: u_end <= length, since the arc length is at least u.
                let speed = |u: f64| [cubic3(&coef, u).1.hypot(1.0), 0.0];
                let mut t = Table::build(0.0, length, 4, &speed, budget)?;
                // Largest curvature at the nodes up to the geometry's end.
                let reach = t.acc.iter().position(|a| a[0] >= length).unwrap_or(t.q.len());
                t.kmax = t.q.iter().take(reach + 1).map(|&u| g.local_curvature_at(u).abs()).fold(0.0, f64::max);
                too_curved(t.kmax)?;
                t
            }
            Shape::ParamPoly3 { normalized, .. } => {
                let pmax = if normalized { 1.0 } else { length };
                let speed = |p: f64| [g.pp3_speed(p), 0.0];
                let mut t = Table::build(0.0, pmax, 4, &speed, budget)?;
                if t.total()[0].is_nan() || t.total()[0] <= 1e-9 {
                    return Err("the paramPoly3 has zero length (u and v constant)".into());
                }
                t.kmax = t.q.iter().map(|&p| g.local_curvature_at(p).abs()).fold(0.0, f64::max);
                too_curved(t.kmax)?;
                t
            }
        };
        self.table = table;
        Ok(self)
    }

    /// Spiral heading change from the start at arc length `q`.
    fn spiral_heading(&self, q: f64) -> f64 {
        match self.shape {
            Shape::Spiral { curv_start, curv_end } => {
                let rate = (curv_end - curv_start) / self.length;
                q * (curv_start + 0.5 * rate * q)
            }
            _ => 0.0,
        }
    }

    /// paramPoly3 speed `|(u'(p), v'(p))|`.
    fn pp3_speed(&self, p: f64) -> f64 {
        match self.shape {
            Shape::ParamPoly3 { u, v, .. } => cubic3(&u, p).1.hypot(cubic3(&v, p).1),
            _ => 1.0,
        }
    }

    /// Curvature at the polynomial curves' parameter (u or p).
    fn local_curvature_at(&self, p: f64) -> f64 {
        match self.shape {
            Shape::Poly3 { coef } => {
                let (_, d1, d2) = cubic3(&coef, p);
                let n = d1.hypot(1.0);
                d2 / (n * n * n)
            }
            Shape::ParamPoly3 { u, v, .. } => {
                let (_, u1, u2) = cubic3(&u, p);
                let (_, v1, v2) = cubic3(&v, p);
                let n = u1.hypot(v1);
                if n < 1e-12 { 0.0 } else { (u1 * v2 - v1 * u2) / (n * n * n) }
            }
            _ => 0.0,
        }
    }

    /// The polynomial curves' parameter at distance `ds` (in `[0, length]`) along the geometry.
    fn param(&self, ds: f64) -> f64 {
        match self.shape {
            Shape::Poly3 { coef } => self.table.param_at(ds, &|u| cubic3(&coef, u).1.hypot(1.0)),
            Shape::ParamPoly3 { .. } => {
                let sigma = ds * self.table.total()[0] / self.length;
                self.table.param_at(sigma, &|p| self.pp3_speed(p))
            }
            _ => ds,
        }
    }

    /// Local `(u, v, heading)` at `ds` in `[0, length]`.
    fn local(&self, ds: f64) -> (f64, f64, f64) {
        match self.shape {
            Shape::Line => (ds, 0.0, 0.0),
            Shape::Arc { curvature } => {
                let half = 0.5 * curvature * ds;
                let chord = ds * sinc(half);
                (chord * half.cos(), chord * half.sin(), 2.0 * half)
            }
            Shape::Spiral { .. } => {
                let f = |q: f64| {
                    let th = self.spiral_heading(q);
                    [th.cos(), th.sin()]
                };
                let [u, v] = self.table.integral_to(ds, &f);
                (u, v, self.spiral_heading(ds))
            }
            Shape::Poly3 { coef } => {
                let u = self.param(ds);
                let (v, d1, _) = cubic3(&coef, u);
                (u, v, d1.atan())
            }
            Shape::ParamPoly3 { u, v, .. } => {
                let p = self.param(ds);
                let (pu, u1, u2) = cubic3(&u, p);
                let (pv, v1, v2) = cubic3(&v, p);
                let h = if u1.hypot(v1) > 1e-12 { v1.atan2(u1) } else { v2.atan2(u2) };
                (pu, pv, h)
            }
        }
    }

    /// World `(x, y, heading)` at `ds` from the start; outside `[0, length]` straight along the
    /// end tangent.
    pub fn eval(&self, ds: f64) -> (f64, f64, f64) {
        let d = ds.clamp(0.0, self.length);
        let (u, v, h) = self.local(d);
        let (sn, cs) = self.hdg.sin_cos();
        let heading = self.hdg + h;
        let extra = ds - d;
        let (x, y) = (self.x + u * cs - v * sn, self.y + u * sn + v * cs);
        (x + extra * heading.cos(), y + extra * heading.sin(), wrap_angle(heading))
    }

    /// Curvature at `ds` (1/m, + left; 0 outside `[0, length]`).
    pub fn curvature(&self, ds: f64) -> f64 {
        if !(0.0..=self.length).contains(&ds) {
            return 0.0;
        }
        match self.shape {
            Shape::Line => 0.0,
            Shape::Arc { curvature } => curvature,
            Shape::Spiral { curv_start, curv_end } => curv_start + (curv_end - curv_start) * ds / self.length,
            Shape::Poly3 { .. } | Shape::ParamPoly3 { .. } => self.local_curvature_at(self.param(ds)),
        }
    }

    /// The nearest point to `(x, y)` with `ds` in `[0, span]` (`span` may pass the geometry's
    /// end: straight extension): `(ds, squared distance)`.
    fn project(&self, x: f64, y: f64, span: f64) -> (f64, f64) {
        let d2 = |ds: f64| {
            let (px, py, _) = self.eval(ds);
            (px - x).powi(2) + (py - y).powi(2)
        };
        let best_of = |cands: &[f64]| {
            cands.iter().fold((0.0, f64::INFINITY), |b, &ds| {
                let d = d2(ds);
                if d < b.1 { (ds, d) } else { b }
            })
        };
        let straight = || {
            let (sn, cs) = self.hdg.sin_cos();
            let ds = ((x - self.x) * cs + (y - self.y) * sn).clamp(0.0, span);
            (ds, d2(ds))
        };
        match self.shape {
            Shape::Line => straight(),
            Shape::Arc { curvature: 0.0 } => straight(),
            Shape::Arc { curvature } => {
                let end = self.length.min(span);
                let mut cands = vec![0.0, end];
                let (sn, cs) = self.hdg.sin_cos();
                let r = 1.0 / curvature;
                let (cx, cy) = (self.x - r * sn, self.y + r * cs);
                let (r0x, r0y) = (self.x - cx, self.y - cy);
                let (rpx, rpy) = (x - cx, y - cy);
                if rpx.hypot(rpy) > 0.0 {
                    let alpha = (r0x * rpy - r0y * rpx).atan2(r0x * rpx + r0y * rpy);
                    let turn = if curvature > 0.0 { alpha } else { -alpha };
                    let ds = turn.rem_euclid(std::f64::consts::TAU) / curvature.abs();
                    if ds <= end {
                        cands.push(ds);
                    }
                }
                if span > self.length {
                    // The straight tail.
                    let (ex, ey, eh) = self.eval(self.length);
                    let along = ((x - ex) * eh.cos() + (y - ey) * eh.sin()).clamp(0.0, span - self.length);
                    cands.push(self.length + along);
                }
                best_of(&cands)
            }
            _ => {
                let kmax = match self.shape {
                    Shape::Spiral { curv_start, curv_end } => curv_start.abs().max(curv_end.abs()),
                    _ => self.table.kmax,
                };
                let step = (0.2 / kmax.max(1e-9)).min(1.0);
                let n = ((span / step).ceil() as usize).clamp(1, 4_000_000);
                let h = span / n as f64;
                let mut best = (0usize, f64::INFINITY);
                for i in 0..=n {
                    let d = d2(h * i as f64);
                    if d < best.1 {
                        best = (i, d);
                    }
                }
                // The foot of the perpendicular near the best sample: (P - X) . T changes sign.
                let foot = |ds: f64| {
                    let (px, py, ph) = self.eval(ds);
                    (px - x) * ph.cos() + (py - y) * ph.sin()
                };
                let mut cands = vec![h * best.0 as f64];
                for (a, b) in [(best.0.saturating_sub(1), best.0), (best.0, (best.0 + 1).min(n))] {
                    let (mut lo, mut hi) = (h * a as f64, h * b as f64);
                    if !(hi > lo && foot(lo) < 0.0 && foot(hi) > 0.0) {
                        continue;
                    }
                    for _ in 0..80 {
                        let mid = 0.5 * (lo + hi);
                        if mid <= lo || mid >= hi {
                            break;
                        }
                        if foot(mid) < 0.0 {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    cands.push(0.5 * (lo + hi));
                }
                best_of(&cands)
            }
        }
    }
}

/// A lane of a lane section.
#[derive(Debug, Clone, PartialEq)]
pub struct Lane {
    /// OpenDRIVE id: 0 the centre lane, > 0 left of the reference line, < 0 right of it.
    pub id: i32,
    /// The `type` attribute (`driving`, `shoulder`, ...).
    pub kind: String,
    /// `width` records, `s` = `sOffset` from the section start, sorted.
    pub widths: Vec<Cubic>,
    /// `link/predecessor@id`: the lane of the previous road or section it continues.
    pub predecessor: Option<i32>,
    /// `link/successor@id`.
    pub successor: Option<i32>,
}

impl Lane {
    /// Width at `ds` from the section start, m (0 without width records; never negative).
    pub fn width_at(&self, ds: f64) -> f64 {
        record_at(&self.widths, ds).map_or(0.0, |(w, d)| w.eval(d)).max(0.0)
    }

    /// Whether the lane is a driving lane ([`DRIVING_TYPES`]).
    pub fn is_driving(&self) -> bool {
        is_driving_type(&self.kind)
    }
}

/// A lane section: the lanes from `s` to the next section's start.
#[derive(Debug, Clone, PartialEq)]
pub struct LaneSection {
    /// Start along the road, m.
    pub s: f64,
    /// Left lanes, ids 1, 2, ... outwards.
    pub left: Vec<Lane>,
    /// Right lanes, ids -1, -2, ... outwards.
    pub right: Vec<Lane>,
}

impl LaneSection {
    /// The lane with id `id` (not the centre lane).
    pub fn lane(&self, id: i32) -> Option<&Lane> {
        let side = if id > 0 { &self.left } else { &self.right };
        side.iter().find(|l| l.id == id && id != 0)
    }
}

/// An OpenDRIVE road: its reference line and lanes.
#[derive(Debug, Clone, PartialEq)]
pub struct Road {
    /// The `id` attribute.
    pub id: String,
    /// Length of the reference line, m.
    pub length: f64,
    /// Plan-view geometries, sorted by `s`.
    pub geometries: Vec<Geometry>,
    /// `laneOffset` records (shift of the centre lane from the reference line, + left), sorted.
    pub lane_offsets: Vec<Cubic>,
    /// Lane sections, sorted by `s`.
    pub lane_sections: Vec<LaneSection>,
    /// `rule="LHT"`: left-hand traffic (lanes with positive ids run along the reference line).
    pub left_hand_traffic: bool,
    /// The `junction` attribute: the junction a connecting road belongs to, `-1` for none.
    pub junction: String,
    /// `link/predecessor`.
    pub predecessor: Option<Link>,
    /// `link/successor`.
    pub successor: Option<Link>,
    /// The file the road was read from (for errors).
    pub file: String,
    /// Line of its `<road>` element (for errors).
    pub line: u32,
}

/// `s` clamped to `[0, length]` (NaN -> 0).
fn clamp_s(s: f64, length: f64) -> f64 {
    if s.is_nan() { 0.0 } else { s.clamp(0.0, length.max(0.0)) }
}

impl Road {
    /// The geometry in effect at `s` (already clamped) and `s` relative to its start.
    fn piece(&self, s: f64) -> Option<(&Geometry, f64)> {
        let i = self.geometries.partition_point(|g| g.s <= s).saturating_sub(1);
        self.geometries.get(i).map(|g| (g, s - g.s))
    }

    /// Point `(x, y, heading)` of the reference line at `s` (clamped to `[0, length]`).
    pub fn reference(&self, s: f64) -> (f64, f64, f64) {
        let s = clamp_s(s, self.length);
        self.piece(s).map_or((0.0, 0.0, 0.0), |(g, ds)| g.eval(ds))
    }

    /// Curvature of the reference line at `s`, 1/m (+ left).
    pub fn curvature(&self, s: f64) -> f64 {
        let s = clamp_s(s, self.length);
        self.piece(s).map_or(0.0, |(g, ds)| g.curvature(ds))
    }

    /// The `laneOffset` at `s`: lateral shift of the centre lane from the reference line, m.
    pub fn lane_offset(&self, s: f64) -> f64 {
        let s = clamp_s(s, self.length);
        if self.lane_offsets.first().is_some_and(|r| s < r.s) {
            return 0.0;
        }
        record_at(&self.lane_offsets, s).map_or(0.0, |(r, d)| r.eval(d))
    }

    /// The lane section in effect at `s` (clamped) and `s` relative to its start.
    pub fn section_at(&self, s: f64) -> Option<(&LaneSection, f64)> {
        let s = clamp_s(s, self.length);
        let i = self.lane_sections.partition_point(|l| l.s <= s).saturating_sub(1);
        self.lane_sections.get(i).map(|l| (l, (s - l.s).max(0.0)))
    }

    /// Offset of lane `lane_id`'s inner border from the centre lane (unsigned) and its width, at
    /// `ds` into `sec`.
    fn inner_and_width(sec: &LaneSection, lane_id: i32, ds: f64) -> Option<(f64, f64)> {
        let own = sec.lane(lane_id)?;
        let side = if lane_id > 0 { &sec.left } else { &sec.right };
        let inner: f64 = side
            .iter()
            .filter(|l| l.id.signum() == lane_id.signum() && l.id.unsigned_abs() < lane_id.unsigned_abs())
            .map(|l| l.width_at(ds))
            .sum();
        Some((inner, own.width_at(ds)))
    }

    /// Lateral coordinate `t` (m, + left) of the centre of lane `lane_id` at `s`: `laneOffset` +
    /// the widths of the lanes between the centre lane and it + half its own width (negative
    /// ids: to the right). Lane 0: the centre lane (`laneOffset`). `None` if there is no such
    /// lane at `s`.
    pub fn lane_center_t(&self, lane_id: i32, s: f64) -> Option<f64> {
        let (sec, ds) = self.section_at(s)?;
        let off = self.lane_offset(s);
        if lane_id == 0 {
            return Some(off);
        }
        let (inner, w) = Self::inner_and_width(sec, lane_id, ds)?;
        let t = inner + 0.5 * w;
        Some(if lane_id > 0 { off + t } else { off - t })
    }

    /// Width of lane `lane_id` at `s`, m (the centre lane: 0).
    pub fn lane_width(&self, lane_id: i32, s: f64) -> Option<f64> {
        let (sec, ds) = self.section_at(s)?;
        if lane_id == 0 {
            return Some(0.0);
        }
        sec.lane(lane_id).map(|l| l.width_at(ds))
    }

    /// The lane containing lateral coordinate `t` at `s`. A lane spans `(inner, outer]` from the
    /// centre lane outwards (a border belongs to the lane nearer the centre lane); `t` on the
    /// centre lane itself belongs to lane -1 (else 1) if it has a positive width. `None` beyond
    /// the outermost lane.
    pub fn lane_at(&self, s: f64, t: f64) -> Option<i32> {
        let (sec, ds) = self.section_at(s)?;
        let d = t - self.lane_offset(s);
        if !d.is_finite() {
            return None;
        }
        if d == 0.0 {
            return [-1, 1].into_iter().find(|&id| sec.lane(id).is_some_and(|l| l.width_at(ds) > 0.0));
        }
        let (side, sign) = if d > 0.0 { (&sec.left, 1) } else { (&sec.right, -1) };
        let mut ids: Vec<i32> = side.iter().map(|l| l.id).filter(|id| id.signum() == sign).collect();
        ids.sort_by_key(|id| id.unsigned_abs());
        let mut outer = 0.0;
        for id in ids {
            let inner = outer;
            outer += sec.lane(id).map_or(0.0, |l| l.width_at(ds));
            if d.abs() > inner && d.abs() <= outer {
                return Some(id);
            }
        }
        None
    }

    /// World pose at road coordinates `(s, t)`: the reference point plus `t` along its left
    /// normal; the heading is the reference line's.
    pub fn world(&self, s: f64, t: f64) -> (f64, f64, f64) {
        let (x, y, h) = self.reference(s);
        let (sn, cs) = h.sin_cos();
        (x - t * sn, y + t * cs, h)
    }

    /// Ids of the driving lanes ([`DRIVING_TYPES`], whatever their width) at `s`, right to left.
    pub fn driving_lanes(&self, s: f64) -> Vec<i32> {
        let Some((sec, _)) = self.section_at(s) else { return Vec::new() };
        let mut ids: Vec<i32> = sec.right.iter().chain(&sec.left).filter(|l| l.is_driving() && l.id != 0).map(|l| l.id).collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// Road coordinates `(s, t)` of the world point `(x, y)`: its projection onto the nearest
    /// point of the reference line (`s` in `[0, length]`; `t` + left, measured along the normal
    /// there). Ties go to the earlier geometry.
    pub fn to_local(&self, x: f64, y: f64) -> (f64, f64) {
        if !(x.is_finite() && y.is_finite()) {
            return (0.0, 0.0);
        }
        let mut best = (0.0, f64::INFINITY);
        for (i, g) in self.geometries.iter().enumerate() {
            let end = self.geometries.get(i + 1).map_or(self.length, |n| n.s);
            let span = (end - g.s).max(0.0);
            let (ds, d2) = g.project(x, y, span);
            if d2 < best.1 {
                best = (clamp_s(g.s + ds, self.length), d2);
            }
        }
        let s = best.0;
        let (px, py, h) = self.reference(s);
        (s, (y - py) * h.cos() - (x - px) * h.sin())
    }
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads the OpenDRIVE file `path` ([`from_str`]).
pub fn load(path: &Path) -> Result<Network, ImportError> {
    let text = xml::read(path)?;
    from_str(&text, &path.display().to_string())
}

/// Parses OpenDRIVE text; `origin` names the file in errors.
pub fn from_str(text: &str, origin: &str) -> Result<Network, ImportError> {
    let doc = xml::parse(text, origin)?;
    let root = doc.root_element();
    if root.tag_name().name() != "OpenDRIVE" {
        return Err(ImportError::at(origin, root, "not an OpenDRIVE file: the root element must be <OpenDRIVE>"));
    }
    let mut p = Reader { file: origin, skipped: BTreeSet::new(), geometries: 0, panels: MAX_PANELS };
    let mut roads: Vec<Road> = Vec::new();
    let mut junctions: Vec<Junction> = Vec::new();
    let mut ids = BTreeSet::new();
    for el in xml::elements(root) {
        match el.tag_name().name() {
            "road" => {
                if roads.len() >= MAX_ROADS {
                    return Err(ImportError::at(origin, el, format!("more than {MAX_ROADS} roads")));
                }
                let road = p.road(el)?;
                if !ids.insert(road.id.clone()) {
                    return Err(p.attr_err(el, "id", format!("road id \"{}\" is used twice", road.id)));
                }
                roads.push(road);
            }
            "junction" => {
                if junctions.len() >= MAX_ROADS {
                    return Err(ImportError::at(origin, el, format!("more than {MAX_ROADS} junctions")));
                }
                let j = p.junction(el)?;
                if junctions.iter().any(|o| o.id == j.id) {
                    return Err(p.attr_err(el, "id", format!("junction id \"{}\" is used twice", j.id)));
                }
                junctions.push(j);
            }
            // Metadata only (name, version, geo reference): its numbers must still be numbers.
            "header" => p.unused_numbers(el, &["revMajor", "revMinor", "north", "south", "east", "west", "version"])?,
            other => p.skip(other),
        }
    }
    Ok(Network { roads, junctions, skipped: p.skipped })
}

/// Parsing state: the file, the skipped kinds and the file-wide limits.
struct Reader<'f> {
    file: &'f str,
    skipped: BTreeSet<String>,
    geometries: usize,
    /// Quadrature panels left ([`MAX_PANELS`]).
    panels: usize,
}

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

impl Reader<'_> {
    fn skip(&mut self, tag: &str) {
        if !self.skipped.contains(tag) {
            self.skipped.insert(tag.to_string());
        }
    }

    fn err(&self, node: Node<'_, '_>, msg: impl Into<String>) -> ImportError {
        ImportError::at(self.file, node, msg)
    }

    /// An error about attribute `attr` of `node` (element `tag@attr`).
    fn attr_err(&self, node: Node<'_, '_>, attr: &str, msg: impl Into<String>) -> ImportError {
        let mut e = ImportError::at(self.file, node, msg);
        e.element = format!("{}@{attr}", e.element);
        e
    }

    fn attr_str<'a>(&self, node: Node<'a, '_>, attr: &str) -> Result<&'a str, ImportError> {
        node.attribute(attr).ok_or_else(|| self.attr_err(node, attr, format!("missing attribute `{attr}`")))
    }

    /// Attributes flc does not use that OpenDRIVE types as numbers: each present one must be a
    /// finite number (`NaN`, `inf` or text is an error naming the attribute).
    fn unused_numbers(&self, node: Node<'_, '_>, attrs: &[&str]) -> Result<(), ImportError> {
        for a in attrs {
            if node.attribute(*a).is_some() {
                self.num(node, a)?;
            }
        }
        Ok(())
    }

    /// A required finite number.
    fn num(&self, node: Node<'_, '_>, attr: &str) -> Result<f64, ImportError> {
        let raw = self.attr_str(node, attr)?;
        let v: f64 = raw.trim().parse().map_err(|_| self.attr_err(node, attr, format!("`{attr}` is not a number: \"{raw}\"")))?;
        if v.is_finite() { Ok(v) } else { Err(self.attr_err(node, attr, format!("`{attr}` must be finite, got {raw}"))) }
    }

    /// A required number in `[lo, hi]` (`lo_open`: `(lo, hi]`).
    fn num_in(&self, node: Node<'_, '_>, attr: &str, lo: f64, lo_open: bool, hi: f64) -> Result<f64, ImportError> {
        let v = self.num(node, attr)?;
        let ok = if lo_open { v > lo } else { v >= lo } && v <= hi;
        if ok {
            Ok(v)
        } else {
            let range = if lo_open { format!("({lo}, {hi}]") } else { format!("[{lo}, {hi}]") };
            Err(self.attr_err(node, attr, format!("`{attr}` must be in {range} m, got {v}")))
        }
    }

    /// The four coefficients `names` of a cubic.
    fn coef(&self, node: Node<'_, '_>, names: [&str; 4]) -> Result<[f64; 4], ImportError> {
        Ok([self.num(node, names[0])?, self.num(node, names[1])?, self.num(node, names[2])?, self.num(node, names[3])?])
    }

    fn cubic(&self, node: Node<'_, '_>, start: &str) -> Result<Cubic, ImportError> {
        let s = self.num_in(node, start, 0.0, false, MAX_LENGTH)?;
        let [a, b, c, d] = self.coef(node, ["a", "b", "c", "d"])?;
        Ok(Cubic { s, a, b, c, d })
    }

    fn road(&mut self, el: Node<'_, '_>) -> Result<Road, ImportError> {
        let id = self.attr_str(el, "id")?.to_string();
        let length = self.num_in(el, "length", 0.0, true, MAX_LENGTH)?;
        let left_hand_traffic = match el.attribute("rule") {
            None | Some("RHT") => false,
            Some("LHT") => true,
            Some(other) => return Err(self.attr_err(el, "rule", format!("`rule` must be RHT or LHT, got \"{other}\""))),
        };
        let junction = el.attribute("junction").unwrap_or("-1").trim().to_string();
        let mut plan = None;
        let mut lanes = None;
        let (mut predecessor, mut successor) = (None, None);
        for c in xml::elements(el) {
            match c.tag_name().name() {
                "link" => {
                    for l in xml::elements(c) {
                        match l.tag_name().name() {
                            "predecessor" => predecessor = Some(self.link(l)?),
                            "successor" => successor = Some(self.link(l)?),
                            other => self.skip(other),
                        }
                    }
                }
                "planView" => {
                    if plan.replace(c).is_some() {
                        return Err(self.err(c, "a road has one <planView>"));
                    }
                }
                "lanes" => {
                    if lanes.replace(c).is_some() {
                        return Err(self.err(c, "a road has one <lanes>"));
                    }
                }
                other => self.skip(other),
            }
        }
        let plan = plan.ok_or_else(|| self.err(el, format!("road \"{id}\" has no <planView>")))?;
        let geometries = self.plan_view(plan)?;
        let (lane_offsets, lane_sections) = match lanes {
            Some(l) => self.lanes(l)?,
            None => (Vec::new(), Vec::new()),
        };
        Ok(Road {
            id,
            length,
            geometries,
            lane_offsets,
            lane_sections,
            left_hand_traffic,
            junction,
            predecessor,
            successor,
            file: self.file.to_string(),
            line: xml::line(el),
        })
    }

    fn plan_view(&mut self, plan: Node<'_, '_>) -> Result<Vec<Geometry>, ImportError> {
        let mut out: Vec<Geometry> = Vec::new();
        for g in xml::elements(plan) {
            if g.tag_name().name() != "geometry" {
                self.skip(g.tag_name().name());
                continue;
            }
            self.geometries += 1;
            if self.geometries > MAX_GEOMETRIES {
                return Err(self.err(g, format!("more than {MAX_GEOMETRIES} geometries in the file")));
            }
            let s = self.num_in(g, "s", 0.0, false, MAX_LENGTH)?;
            if out.last().is_some_and(|p| s < p.s) {
                return Err(self.attr_err(g, "s", "geometries must be sorted by `s`"));
            }
            let x = self.num_in(g, "x", -MAX_COORDINATE, false, MAX_COORDINATE)?;
            let y = self.num_in(g, "y", -MAX_COORDINATE, false, MAX_COORDINATE)?;
            let hdg = self.num(g, "hdg")?;
            let length = self.num_in(g, "length", 0.0, true, MAX_LENGTH)?;
            let mut shape = None;
            for c in xml::elements(g) {
                let kind = match c.tag_name().name() {
                    "line" => Shape::Line,
                    "arc" => Shape::Arc { curvature: self.num(c, "curvature")? },
                    "spiral" => Shape::Spiral { curv_start: self.num(c, "curvStart")?, curv_end: self.num(c, "curvEnd")? },
                    "poly3" => Shape::Poly3 { coef: self.coef(c, ["a", "b", "c", "d"])? },
                    "paramPoly3" => {
                        let normalized = match c.attribute("pRange") {
                            None | Some("normalized") => true,
                            Some("arcLength") => false,
                            Some(other) => {
                                return Err(self.attr_err(
                                    c,
                                    "pRange",
                                    format!("`pRange` must be arcLength or normalized, got \"{other}\""),
                                ));
                            }
                        };
                        Shape::ParamPoly3 {
                            u: self.coef(c, ["aU", "bU", "cU", "dU"])?,
                            v: self.coef(c, ["aV", "bV", "cV", "dV"])?,
                            normalized,
                        }
                    }
                    "userData" => {
                        self.skip("userData");
                        continue;
                    }
                    _ => return Err(ImportError::unsupported(self.file, c)),
                };
                if shape.replace((kind, c)).is_some() {
                    return Err(self.err(c, "a <geometry> has exactly one shape (line, arc, spiral, poly3 or paramPoly3)"));
                }
            }
            let (shape, node) =
                shape.ok_or_else(|| self.err(g, "a <geometry> needs a shape: <line>, <arc>, <spiral>, <poly3> or <paramPoly3>"))?;
            let geometry = Geometry { s, x, y, hdg, length, shape, table: Table::default() }
                .tabulate(&mut self.panels)
                .map_err(|m| self.err(node, m))?;
            out.push(geometry);
        }
        if out.is_empty() {
            return Err(self.err(plan, "the <planView> has no <geometry>"));
        }
        Ok(out)
    }

    fn lanes(&mut self, el: Node<'_, '_>) -> Result<(Vec<Cubic>, Vec<LaneSection>), ImportError> {
        let mut offsets: Vec<Cubic> = Vec::new();
        let mut sections: Vec<LaneSection> = Vec::new();
        for c in xml::elements(el) {
            match c.tag_name().name() {
                "laneOffset" => {
                    let r = self.cubic(c, "s")?;
                    if offsets.last().is_some_and(|p| r.s < p.s) {
                        return Err(self.attr_err(c, "s", "laneOffset records must be sorted by `s`"));
                    }
                    offsets.push(r);
                }
                "laneSection" => {
                    let sec = self.section(c)?;
                    if sections.last().is_some_and(|p| sec.s < p.s) {
                        return Err(self.attr_err(c, "s", "lane sections must be sorted by `s`"));
                    }
                    sections.push(sec);
                }
                other => self.skip(other),
            }
        }
        Ok((offsets, sections))
    }

    fn section(&mut self, el: Node<'_, '_>) -> Result<LaneSection, ImportError> {
        let s = self.num_in(el, "s", 0.0, false, MAX_LENGTH)?;
        if el.attribute("singleSide").is_some_and(|v| v == "true" || v == "1") {
            return Err(self.attr_err(el, "singleSide", "unsupported: lane sections for one side only (singleSide=\"true\")"));
        }
        let mut sec = LaneSection { s, left: Vec::new(), right: Vec::new() };
        let mut seen = [false; 3];
        for c in xml::elements(el) {
            let (slot, sign) = match c.tag_name().name() {
                "left" => (0, 1),
                "center" => (1, 0),
                "right" => (2, -1),
                other => {
                    self.skip(other);
                    continue;
                }
            };
            if seen.get_mut(slot).is_some_and(|seen| std::mem::replace(seen, true)) {
                return Err(self.err(c, format!("a <laneSection> has one <{}>", c.tag_name().name())));
            }
            let mut lanes = Vec::new();
            for l in xml::elements(c) {
                if l.tag_name().name() != "lane" {
                    self.skip(l.tag_name().name());
                    continue;
                }
                let lane = self.lane(l)?;
                if lane.id.signum() != sign {
                    let side = c.tag_name().name();
                    return Err(self.attr_err(
                        l,
                        "id",
                        format!("lane id {} cannot be in <{side}> (left > 0, center 0, right < 0)", lane.id),
                    ));
                }
                if lanes.iter().any(|o: &Lane| o.id == lane.id) {
                    return Err(self.attr_err(l, "id", format!("lane id {} is used twice in this lane section", lane.id)));
                }
                lanes.push(lane);
            }
            lanes.sort_by_key(|l| l.id.unsigned_abs());
            let gap = lanes.iter().enumerate().find(|(k, l)| l.id.unsigned_abs() as usize != k + 1);
            if let (Some((k, l)), true) = (gap, sign != 0) {
                let expected = sign * (k as i32 + 1);
                return Err(
                    self.err(c, format!("lane ids must run 1, 2, ... outwards without gaps: lane {} found, {expected} missing", l.id))
                );
            }
            match sign {
                1 => sec.left = lanes,
                -1 => sec.right = lanes,
                _ => {}
            }
        }
        Ok(sec)
    }

    fn lane(&mut self, el: Node<'_, '_>) -> Result<Lane, ImportError> {
        let raw = self.attr_str(el, "id")?;
        let id: i32 = raw
            .trim()
            .parse()
            .ok()
            .filter(|v: &i32| v.unsigned_abs() <= 1000)
            .ok_or_else(|| self.attr_err(el, "id", format!("`id` must be an integer in [-1000, 1000], got \"{raw}\"")))?;
        let kind = self.attr_str(el, "type")?.to_string();
        let mut widths: Vec<Cubic> = Vec::new();
        let (mut predecessor, mut successor) = (None, None);
        for c in xml::elements(el) {
            match c.tag_name().name() {
                "link" => {
                    for l in xml::elements(c) {
                        match l.tag_name().name() {
                            "predecessor" => predecessor = Some(self.lane_id(l, "id")?),
                            "successor" => successor = Some(self.lane_id(l, "id")?),
                            other => self.skip(other),
                        }
                    }
                }
                "width" => {
                    let w = self.cubic(c, "sOffset")?;
                    if widths.last().is_some_and(|p| w.s < p.s) {
                        return Err(self.attr_err(c, "sOffset", "width records must be sorted by `sOffset`"));
                    }
                    widths.push(w);
                }
                "border" => return Err(ImportError::unsupported(self.file, c)),
                other => {
                    // Not used for motion, but a number where OpenDRIVE wants one (docs/openscenario.md).
                    if other == "roadMark" {
                        self.unused_numbers(c, &["sOffset", "width", "height"])?;
                    }
                    self.skip(other)
                }
            }
        }
        Ok(Lane { id, kind, widths, predecessor, successor })
    }

    /// A lane id attribute: an integer in [-1000, 1000].
    fn lane_id(&self, el: Node<'_, '_>, attr: &str) -> Result<i32, ImportError> {
        let raw = self.attr_str(el, attr)?;
        raw.trim()
            .parse()
            .ok()
            .filter(|v: &i32| v.unsigned_abs() <= 1000)
            .ok_or_else(|| self.attr_err(el, attr, format!("`{attr}` must be an integer in [-1000, 1000], got \"{raw}\"")))
    }

    /// A `contactPoint` attribute (`start` / `end`).
    fn contact(&self, el: Node<'_, '_>) -> Result<Option<Contact>, ImportError> {
        match el.attribute("contactPoint") {
            None => Ok(None),
            Some("start") => Ok(Some(Contact::Start)),
            Some("end") => Ok(Some(Contact::End)),
            Some(other) => Err(self.attr_err(el, "contactPoint", format!("`contactPoint` must be start or end, got \"{other}\""))),
        }
    }

    /// A road's `predecessor` / `successor` link.
    fn link(&self, el: Node<'_, '_>) -> Result<Link, ImportError> {
        let element = match el.attribute("elementType").unwrap_or("road") {
            "road" => Element::Road,
            "junction" => Element::Junction,
            other => return Err(self.attr_err(el, "elementType", format!("`elementType` must be road or junction, got \"{other}\""))),
        };
        let id = self.attr_str(el, "elementId")?.trim().to_string();
        let contact = self.contact(el)?;
        Ok(Link { element, id, contact, line: xml::line(el) })
    }

    /// A `junction` with its `connection`s (other children: skipped).
    fn junction(&mut self, el: Node<'_, '_>) -> Result<Junction, ImportError> {
        let id = self.attr_str(el, "id")?.trim().to_string();
        let mut connections = Vec::new();
        for c in xml::elements(el) {
            if c.tag_name().name() != "connection" {
                self.skip(c.tag_name().name());
                continue;
            }
            let incoming = self.attr_str(c, "incomingRoad")?.trim().to_string();
            let connecting = self.attr_str(c, "connectingRoad")?.trim().to_string();
            let contact = self.contact(c)?.ok_or_else(|| self.attr_err(c, "contactPoint", "missing attribute `contactPoint`"))?;
            let mut lane_links = Vec::new();
            for l in xml::elements(c) {
                if l.tag_name().name() == "laneLink" {
                    lane_links.push((self.lane_id(l, "from")?, self.lane_id(l, "to")?));
                } else {
                    self.skip(l.tag_name().name());
                }
            }
            let cid = c.attribute("id").unwrap_or("").to_string();
            connections.push(Connection { id: cid, incoming, connecting, contact, lane_links, line: xml::line(c) });
        }
        Ok(Junction { id, connections, line: xml::line(el) })
    }
}

// ---------------------------------------------------------------------------------------------
// Road -> Track

/// How the OpenDRIVE lanes of a road map onto a [`Track`] built by [`to_track`].
#[derive(Debug, Clone, PartialEq)]
pub struct LaneMap {
    /// The road's id.
    pub road_id: String,
    /// The OpenDRIVE id of the lane the track follows.
    pub ego_lane: i32,
    /// OpenDRIVE ids of the track's lanes: `lane_ids[i]` is track lane `i` (0 the rightmost
    /// driving lane on the ego's side, then leftwards).
    pub lane_ids: Vec<i32>,
    /// The track's lane width: the median width of the ego lane along the road, m.
    pub lane_width: f64,
    /// Narrowest and widest width of the track's lanes anywhere along the road, m.
    pub width_range: (f64, f64),
    /// Whether the track's equal-width lane model is exact: all its lanes exist in every lane
    /// section, are adjacent and are `lane_width` wide everywhere (within [`WIDTH_TOLERANCE`]).
    /// If not, only [`Track::lane_offset`] is approximate; [`LaneMap::offset_of`] is exact.
    pub uniform: bool,
    /// Why the lanes are not uniform (for a warning), if they are not.
    pub note: Option<String>,
    /// Road positions (m) where the ego lane's centre jumps sideways (by more than
    /// [`TRACK_CHORD_TOLERANCE`] within 1 mm of road: the file's widths or offsets are
    /// discontinuous there); the track keeps the jump.
    pub discontinuities: Vec<f64>,
    /// The track runs against the road's reference line (`s` decreasing): the ego drives a lane
    /// with a positive id of a right-hand traffic road.
    pub reversed: bool,
    /// The road (for exact lane offsets).
    road: Road,
    /// `(distance from the track's start along the road, s along the track)` at the track's
    /// points: the road's `s`, or `length - s` when [`LaneMap::reversed`].
    s_table: Vec<(f64, f64)>,
}

impl LaneMap {
    /// Lateral offset (m, + left) of the centre of lane `lane_id` from the ego lane's centre at
    /// road position `s_road`; `None` if either lane does not exist there.
    pub fn offset_of(&self, lane_id: i32, s_road: f64) -> Option<f64> {
        let d = self.road.lane_center_t(lane_id, s_road)? - self.road.lane_center_t(self.ego_lane, s_road)?;
        Some(if self.reversed { -d } else { d })
    }

    /// The track lane number of OpenDRIVE lane `lane_id` (`None`: not one of the track's lanes).
    pub fn lane_index(&self, lane_id: i32) -> Option<u32> {
        self.lane_ids.iter().position(|&l| l == lane_id).and_then(|i| u32::try_from(i).ok())
    }

    /// Distance along the track (the ego lane's centre curve) at road position `s_road`
    /// (linear between the track's points).
    pub fn track_s(&self, s_road: f64) -> f64 {
        if s_road.is_nan() {
            return 0.0;
        }
        let s_road = if self.reversed { self.road.length - s_road } else { s_road };
        let i = self.s_table.partition_point(|p| p.0 <= s_road).saturating_sub(1);
        match (self.s_table.get(i), self.s_table.get(i + 1)) {
            (Some(a), Some(b)) if b.0 > a.0 => a.1 + (b.1 - a.1) * ((s_road - a.0) / (b.0 - a.0)).clamp(0.0, 1.0),
            (Some(a), _) => a.1,
            _ => 0.0,
        }
    }

    /// The road the track was built from.
    pub fn road(&self) -> &Road {
        &self.road
    }
}

/// The simulator's [`Track`] for driving `road` in lane `ego_lane`, named `name`: the centre
/// curve of that lane over the whole road in its driving direction (right-hand traffic: along
/// the reference line for a negative id, against it for a positive one, the track then
/// starting at the road's end), sampled every [`TRACK_STEP`] m of road and more finely where
/// needed to keep every chord within [`TRACK_CHORD_TOLERANCE`] of the curve; `lanes`/`ego_lane`
/// number the driving lanes on the ego's side of the road (its direction's lanes) from the
/// rightmost in its driving direction (plus the ego lane if it is of another type); the lane
/// width is the ego lane's median width. The [`LaneMap`] relates OpenDRIVE lanes to it.
pub fn to_track(road: &Road, ego_lane: i32, name: &str) -> Result<(Track, LaneMap), ImportError> {
    let err = |msg: String| ImportError { file: road.file.clone(), line: road.line, element: "road".into(), message: msg };
    let rid = &road.id;
    if ego_lane == 0 {
        return Err(err(format!("lane 0 of road \"{rid}\" is the centre lane (no width): give a lane with a non-zero id")));
    }
    // Right-hand traffic: a positive lane runs against the reference line.
    let reversed = ego_lane > 0;
    let dir = if reversed { -1.0 } else { 1.0 };
    if road.left_hand_traffic {
        return Err(err(format!("road \"{rid}\" has rule=\"LHT\": left-hand traffic roads are not supported")));
    }
    if road.length.is_nan() || road.length < MIN_TRACK_LENGTH {
        return Err(err(format!("road \"{rid}\" is {} m long; the simulator needs a road of at least {MIN_TRACK_LENGTH} m", road.length)));
    }
    if road.lane_sections.is_empty() {
        return Err(err(format!("road \"{rid}\" has no lane sections")));
    }
    if let Some(sec) = road.lane_sections.iter().find(|sec| sec.lane(ego_lane).is_none()) {
        return Err(err(format!("lane {ego_lane} does not exist in road \"{rid}\"'s lane section at s = {} m", sec.s)));
    }
    // The track's lanes: driving lanes on the ego's side in any section, and the ego lane, from
    // the rightmost in the driving direction (the outermost of a reversed track).
    let mut lane_ids: Vec<i32> = road
        .lane_sections
        .iter()
        .flat_map(|sec| {
            let side = if reversed { &sec.left } else { &sec.right };
            side.iter().filter(|l| l.is_driving() && l.id.signum() == ego_lane.signum()).map(|l| l.id)
        })
        .collect();
    lane_ids.push(ego_lane);
    lane_ids.sort_unstable();
    lane_ids.dedup();
    if reversed {
        lane_ids.reverse();
    }

    // Sample the ego lane's centre curve, by `u`: the distance from the track's start along
    // the road (the road's `s`, or `length - s` reversed).
    let road_s = |u: f64| if reversed { road.length - u } else { u };
    let centre = |u: f64| -> Result<(f64, f64, f64, f64), ImportError> {
        let s = road_s(u);
        let t = road.lane_center_t(ego_lane, s).ok_or_else(|| err(format!("lane {ego_lane} does not exist at s = {s} m")))?;
        let (x, y, h) = road.world(s, t);
        Ok((x, y, h, t))
    };
    let (x0, y0, _, _) = centre(0.0)?;
    let mut pts = vec![[x0, y0]];
    let mut s_table = vec![(0.0, 0.0)];
    let mut widths = vec![road.lane_width(ego_lane, road_s(0.0)).unwrap_or(0.0)];
    let mut s = 0.0;
    let mut track_len = 0.0;
    let max_points = MAX_TRACK_POINTS;
    let mut discontinuities = Vec::new();
    while s < road.length {
        let [px, py] = pts.last().copied().unwrap_or([x0, y0]);
        let mut h = TRACK_STEP.min(road.length - s);
        let (s1, p1) = loop {
            let s1 = if h >= road.length - s { road.length } else { s + h };
            let (x1, y1, _, _) = centre(s1)?;
            let (xm, ym, _, _) = centre(0.5 * (s + s1))?;
            // The curve's midpoint against the chord's (at least its distance from the chord;
            // also catches sideways jumps, whose midpoint lies on the chord's line).
            let dev = (xm - 0.5 * (px + x1)).hypot(ym - 0.5 * (py + y1));
            if dev <= TRACK_CHORD_TOLERANCE {
                break (s1, [x1, y1]);
            }
            if h <= 1e-3 {
                if discontinuities.last().is_none_or(|&d: &f64| s - d > 0.01) {
                    discontinuities.push(s);
                }
                break (s1, [x1, y1]);
            }
            h *= 0.5;
        };
        // The lane centre must move forwards: 1 - curvature * t > 0.
        let sm = 0.5 * (s + s1);
        let (_, _, hm, tm) = centre(sm)?;
        let (dx, dy) = (p1[0] - px, p1[1] - py);
        let stretch = 1.0 - road.curvature(road_s(sm)) * tm;
        if stretch < 0.01 || dir * (dx * hm.cos() + dy * hm.sin()) <= 0.0 {
            return Err(err(format!(
                "the centre of lane {ego_lane} folds back near s = {:.2} m (it lies {:.2} m from the reference line, beyond the curve's centre)",
                road_s(sm),
                tm.abs()
            )));
        }
        let step = dx.hypot(dy);
        if step >= 1e-3 || s1 >= road.length {
            if step < 1e-3 && pts.len() > 1 {
                // The end point, too close to the previous one: replace it.
                pts.pop();
                s_table.pop();
                widths.pop();
                let [qx, qy] = pts.last().copied().unwrap_or([x0, y0]);
                track_len = s_table.last().map_or(0.0, |p| p.1) + (p1[0] - qx).hypot(p1[1] - qy);
            } else {
                track_len += step;
            }
            pts.push(p1);
            s_table.push((s1, track_len));
            widths.push(road.lane_width(ego_lane, road_s(s1)).unwrap_or(0.0));
            if pts.len() > max_points {
                return Err(err(format!("road \"{rid}\" needs more than {max_points} track points")));
            }
        }
        s = s1;
    }
    let lane_width = median(&mut widths);

    // Uniformity of the equal-width lane model.
    let mut note = None;
    let mut width_range = (f64::INFINITY, f64::NEG_INFINITY);
    if lane_ids.windows(2).any(|w| matches!(w, [a, b] if (i64::from(*b) - i64::from(*a)).abs() != 1)) {
        note = Some(format!("the track's lanes {lane_ids:?} are not adjacent (other lane types lie between them)"));
    }
    for &(u, _) in &s_table {
        let sr = road_s(u);
        for &id in &lane_ids {
            match road.lane_width(id, sr) {
                Some(w) => {
                    width_range = (width_range.0.min(w), width_range.1.max(w));
                    if note.is_none() && (w - lane_width).abs() > WIDTH_TOLERANCE {
                        note = Some(format!("lane {id} is {w:.3} m wide at s = {sr:.1} m, the track's lanes {lane_width:.3} m"));
                    }
                }
                None => {
                    if note.is_none() {
                        note = Some(format!("lane {id} does not exist at s = {sr:.1} m"));
                    }
                }
            }
        }
    }
    if !width_range.0.is_finite() {
        width_range = (lane_width, lane_width);
    }
    let ego_index = lane_ids.iter().position(|&l| l == ego_lane).and_then(|i| u32::try_from(i).ok()).unwrap_or(0);
    let nlanes = u32::try_from(lane_ids.len()).unwrap_or(u32::MAX);
    let track = Track::new(name, without_collinear(pts), lane_width, Vec::new()).with_lanes(nlanes, ego_index);
    track.validate().map_err(|e| err(format!("road \"{rid}\", lane {ego_lane}: the track is not valid: {e}")))?;
    let map = LaneMap {
        road_id: road.id.clone(),
        ego_lane,
        lane_ids,
        lane_width,
        width_range,
        uniform: note.is_none(),
        note,
        discontinuities: discontinuities.into_iter().map(road_s).collect(),
        reversed,
        road: road.clone(),
        s_table,
    };
    Ok((track, map))
}

/// The median of `v` (0 if empty).
/// `pts` without the points that lie within 1 µm of the chord between their kept neighbours
/// (straight stretches become one segment; on any real curve the sagitta of two samples is far
/// larger, so curves keep every sample). The track's lengths are unchanged.
fn without_collinear(pts: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    const TOL: f64 = 1e-6;
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(pts.len());
    for (i, &p) in pts.iter().enumerate() {
        if let (Some(&a), Some(&c)) = (out.last(), pts.get(i + 1)) {
            let (dx, dy) = (c[0] - a[0], c[1] - a[1]);
            let len = dx.hypot(dy);
            let along = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len.max(1e-12);
            let off = ((p[0] - a[0]) * dy - (p[1] - a[1]) * dx).abs() / len.max(1e-12);
            if len > 0.0 && off < TOL && along > 0.0 && along < len {
                continue;
            }
        }
        out.push(p);
    }
    out
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => 0.0,
        n if n % 2 == 1 => v.get(n / 2).copied().unwrap_or(0.0),
        n => 0.5 * (v.get(n / 2 - 1).copied().unwrap_or(0.0) + v.get(n / 2).copied().unwrap_or(0.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LANES_2X2: &str = r#"
    <laneSection s="0">
      <left>
        <lane id="2" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
        <lane id="1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/><roadMark sOffset="0" type="solid"/></lane>
      </left>
      <center><lane id="0" type="none"><roadMark sOffset="0" type="broken"/></lane></center>
      <right>
        <lane id="-1" type="driving"><link><predecessor id="-1"/></link><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
        <lane id="-2" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
        <lane id="-3" type="shoulder"><width sOffset="0" a="1.0" b="0" c="0" d="0"/></lane>
      </right>
    </laneSection>"#;

    /// An OpenDRIVE file with one road of `length` m.
    fn xodr(length: f64, geoms: &str, lanes: &str) -> String {
        format!(
            r#"<?xml version="1.0" encoding="UTF-8"?>
<OpenDRIVE>
  <header revMajor="1" revMinor="6" name="test"/>
  <road id="r1" length="{length}" junction="-1">
    <link><successor elementType="road" elementId="r2"/></link>
    <type s="0" type="motorway"><speed max="130" unit="km/h"/></type>
    <planView>
{geoms}
    </planView>
    <elevationProfile><elevation s="0" a="0" b="0" c="0" d="0"/></elevationProfile>
    <lateralProfile/>
    <lanes>
{lanes}
    </lanes>
    <objects/>
    <signals/>
  </road>
  <junction id="7" name="j"/>
</OpenDRIVE>
"#
        )
    }

    fn road_of(text: &str) -> Road {
        let mut n = from_str(text, "t.xodr").expect("valid OpenDRIVE");
        n.roads.remove(0)
    }

    fn one(length: f64, shape: &str) -> Road {
        road_of(&xodr(length, &format!(r#"<geometry s="0" x="0" y="0" hdg="0" length="{length}">{shape}</geometry>"#), LANES_2X2))
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn gauss_legendre_rule_is_exact_to_degree_15() {
        for k in 0..16 {
            let f = |x: f64| [x.powi(k), 0.0];
            let got = gauss(0.0, 2.0, &f)[0];
            let exact = 2f64.powi(k + 1) / f64::from(k + 1);
            assert!(((got - exact) / exact).abs() < 1e-14, "x^{k}: {got} vs {exact}");
        }
    }

    #[test]
    fn line_points_heading_and_clamping() {
        let r = road_of(&xodr(100.0, r#"<geometry s="0" x="10" y="5" hdg="0.3" length="100"><line/></geometry>"#, LANES_2X2));
        assert_eq!(r.id, "r1");
        for s in [0.0, 37.5, 100.0] {
            let (x, y, h) = r.reference(s);
            assert!(close(x, 10.0 + s * 0.3f64.cos(), 1e-12) && close(y, 5.0 + s * 0.3f64.sin(), 1e-12) && close(h, 0.3, 1e-15));
            assert_eq!(r.curvature(s), 0.0);
        }
        assert_eq!(r.reference(150.0), r.reference(100.0));
        assert_eq!(r.reference(-3.0), r.reference(0.0));
        assert_eq!(r.reference(f64::NAN), r.reference(0.0));
        // world(): t along the left normal.
        let (x, y, h) = r.world(20.0, 2.0);
        let (rx, ry, _) = r.reference(20.0);
        assert!(close(x, rx - 2.0 * 0.3f64.sin(), 1e-12) && close(y, ry + 2.0 * 0.3f64.cos(), 1e-12) && h == 0.3);
        let (s, t) = r.to_local(x, y);
        assert!(close(s, 20.0, 1e-9) && close(t, 2.0, 1e-9), "{s} {t}");
    }

    #[test]
    fn arc_has_radius_curvature_and_heading_change() {
        let radius = 200.0;
        for sign in [1.0, -1.0] {
            let k = sign / radius;
            let r = one(300.0, &format!(r#"<arc curvature="{k}"/>"#));
            let (cx, cy) = (0.0, sign * radius);
            for s in [0.0, 10.0, 123.4, 299.0, 300.0] {
                let (x, y, h) = r.reference(s);
                assert!(close((x - cx).hypot(y - cy), radius, 1e-9), "s {s}");
                assert!(close(h, k * s, 1e-12), "s {s}: heading {h}");
                assert_eq!(r.curvature(s), k);
            }
            // The track along lane -1 (t = -1.75): radius 1/k - t.
            let (track, map) = to_track(&r, -1, "arc").expect("track");
            let t = r.lane_center_t(-1, 100.0).expect("lane -1");
            assert_eq!(t, -1.75);
            let lane_r = 1.0 / k - t;
            // Track::curvature_at counts whole 0.5 m segments over +-10 m: within 2.5 %.
            let kt = track.curvature_at(150.0 * (1.0 - k * t));
            assert!(close(kt, 1.0 / lane_r, 0.03 / lane_r.abs()), "track curvature {kt} vs {}", 1.0 / lane_r);
            assert!(close(track.length(), 300.0 * (1.0 - k * t), 1e-3), "{}", track.length());
            assert_eq!(map.lane_ids, vec![-2, -1]);
            assert_eq!((track.lanes, track.ego_lane, track.lane_width), (2, 1, 3.5));
            assert!(map.uniform, "{:?}", map.note);
            assert_eq!(map.lane_index(-2), Some(0));
            assert_eq!(map.lane_index(-3), None);
            assert!(close(map.offset_of(-2, 50.0).expect("-2"), -3.5, 1e-12));
            assert!(close(map.offset_of(1, 50.0).expect("1"), 3.5, 1e-12));
            assert!(close(track.lane_offset(0), -3.5, 1e-12));
            assert!(close(map.track_s(300.0), track.length(), 1e-9));
            assert!(close(map.track_s(150.0), 150.0 * (1.0 - k * t), 1e-3));
        }
    }

    #[test]
    fn track_chords_stay_within_a_centimetre_in_tight_curves() {
        // Radius 15 m to the right; lane -1 (inside, radius 13.25 m) and lane -2 (9.75 m).
        let r = one(60.0, r#"<arc curvature="-0.0666666666666666667"/>"#);
        for (lane, lane_r) in [(-1, 13.25), (-2, 9.75)] {
            let (track, _) = to_track(&r, lane, "tight").expect("track");
            let (cx, cy) = (0.0, -15.0);
            let mut worst: f64 = 0.0;
            for w in track.centerline.windows(2) {
                let (p, q) = (w[0], w[1]);
                for p in [p, q] {
                    assert!(close((p[0] - cx).hypot(p[1] - cy), lane_r, 1e-9));
                }
                let (mx, my) = (0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]));
                worst = worst.max(lane_r - (mx - cx).hypot(my - cy));
            }
            eprintln!("lane {lane}: {} points, worst chord deviation {worst:.2e} m", track.centerline.len());
            assert!(worst < 0.01 && worst > 0.0, "{worst}");
            let kt = track.curvature_at(20.0);
            assert!(close(kt, -1.0 / lane_r, 0.03 / lane_r), "{kt}");
        }
        // Radius 5 m to the left: lane -1 at 6.75 m needs chords shorter than 0.5 m of road.
        let r = one(60.0, r#"<arc curvature="0.2"/>"#);
        let (track, map) = to_track(&r, -1, "hairpin").expect("track");
        let (cx, cy, lane_r) = (0.0, 5.0, 6.75);
        let mut worst: f64 = 0.0;
        for w in track.centerline.windows(2) {
            let (mx, my) = (0.5 * (w[0][0] + w[1][0]), 0.5 * (w[0][1] + w[1][1]));
            worst = worst.max(lane_r - (mx - cx).hypot(my - cy));
        }
        eprintln!("hairpin: {} points, worst chord deviation {worst:.2e} m", track.centerline.len());
        assert!(worst < TRACK_CHORD_TOLERANCE && track.centerline.len() > 200, "{worst}");
        assert!(close(track.length(), 60.0 * lane_r / 5.0, 0.01) && close(map.track_s(60.0), track.length(), 1e-9));
        assert_eq!(map.track_s(f64::NAN), 0.0);
        // A lane centre beyond the curve's centre is an error.
        let r = one(60.0, r#"<arc curvature="-0.25"/>"#);
        let e = to_track(&r, -2, "folded").expect_err("folds back");
        assert!(e.message.contains("folds back"), "{e}");
    }

    /// Independent reference: composite Simpson rule with `n` intervals of the spiral's exact heading.
    fn spiral_by_simpson((x0, y0, h0): (f64, f64, f64), (k0, k1, len): (f64, f64, f64), s: f64, n: usize) -> (f64, f64) {
        let th = |q: f64| h0 + k0 * q + 0.5 * (k1 - k0) / len * q * q;
        let h = s / n as f64;
        let (mut sx, mut sy) = (0.0, 0.0);
        for i in 0..=n {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let t = th(h * i as f64);
            sx += w * t.cos();
            sy += w * t.sin();
        }
        (x0 + sx * h / 3.0, y0 + sy * h / 3.0)
    }

    #[test]
    fn spiral_curvature_is_linear_and_points_match_numeric_integration() {
        for (k0, k1, len) in [(0.0, 0.02, 250.0), (-0.01, 0.015, 400.0), (0.004, 0.004, 100.0), (0.05, -0.002, 1000.0)] {
            let text = xodr(
                len,
                &format!(r#"<geometry s="0" x="3" y="-4" hdg="0.2" length="{len}"><spiral curvStart="{k0}" curvEnd="{k1}"/></geometry>"#),
                LANES_2X2,
            );
            let r = road_of(&text);
            let mut worst: f64 = 0.0;
            for f in [0.0, 0.1, 0.25, 0.5, 0.77, 1.0] {
                let s = f * len;
                assert!(close(r.curvature(s), k0 + (k1 - k0) * f, 1e-15), "curvature at {s}");
                let (x, y, h) = r.reference(s);
                let expect_h = wrap_angle(0.2 + k0 * s + 0.5 * (k1 - k0) / len * s * s);
                assert!(close(h, expect_h, 1e-12), "heading at {s}: {h} vs {expect_h}");
                let (ex, ey) = spiral_by_simpson((3.0, -4.0, 0.2), (k0, k1, len), s, 400_000);
                worst = worst.max((x - ex).hypot(y - ey));
            }
            eprintln!("spiral {k0} -> {k1} over {len} m: largest difference to Simpson (400k intervals) {worst:.2e} m");
            assert!(worst < 1e-6, "{worst}");
        }
    }

    /// Arc length of `v = c u²` from 0 to `u`.
    fn parabola_len(c: f64, u: f64) -> f64 {
        let z = 2.0 * c * u;
        0.5 * u * z.hypot(1.0) + z.asinh() / (4.0 * c)
    }

    /// `u` at arc length `s` along `v = c u²` (bisection).
    fn parabola_u(c: f64, s: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, s);
        for _ in 0..200 {
            let m = 0.5 * (lo + hi);
            if parabola_len(c, m) < s {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    }

    #[test]
    fn poly3_is_parametrised_by_arc_length() {
        let c = 0.004;
        let (x0, y0, h0, a): (f64, f64, f64, f64) = (7.0, 2.0, 0.4, 0.3);
        let text = xodr(
            120.0,
            &format!(r#"<geometry s="0" x="{x0}" y="{y0}" hdg="{h0}" length="120"><poly3 a="{a}" b="0" c="{c}" d="0"/></geometry>"#),
            LANES_2X2,
        );
        let r = road_of(&text);
        let mut worst: f64 = 0.0;
        for s in [0.0, 1.0, 30.0, 60.0, 119.0, 120.0] {
            let u = parabola_u(c, s);
            let v = a + c * u * u;
            let (ex, ey) = (x0 + u * h0.cos() - v * h0.sin(), y0 + u * h0.sin() + v * h0.cos());
            let (x, y, h) = r.reference(s);
            worst = worst.max((x - ex).hypot(y - ey));
            assert!(close(h, h0 + (2.0 * c * u).atan(), 1e-9), "heading at {s}");
            let k = 2.0 * c / (1.0 + 4.0 * c * c * u * u).powf(1.5);
            assert!(close(r.curvature(s), k, 1e-9), "curvature at {s}");
        }
        eprintln!("poly3 parabola: largest position error {worst:.2e} m");
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn param_poly3_straight_equals_a_line_and_parabola_matches() {
        let line = road_of(&xodr(80.0, r#"<geometry s="0" x="1" y="2" hdg="0.7" length="80"><line/></geometry>"#, LANES_2X2));
        for pp in [
            r#"<paramPoly3 aU="0" bU="1" cU="0" dU="0" aV="0" bV="0" cV="0" dV="0" pRange="arcLength"/>"#,
            r#"<paramPoly3 aU="0" bU="80" cU="0" dU="0" aV="0" bV="0" cV="0" dV="0" pRange="normalized"/>"#,
            r#"<paramPoly3 aU="0" bU="80" cU="0" dU="0" aV="0" bV="0" cV="0" dV="0"/>"#,
        ] {
            let r = road_of(&xodr(80.0, &format!(r#"<geometry s="0" x="1" y="2" hdg="0.7" length="80">{pp}</geometry>"#), LANES_2X2));
            for s in [0.0, 12.5, 40.0, 80.0] {
                let (a, b) = (r.reference(s), line.reference(s));
                assert!(close(a.0, b.0, 1e-9) && close(a.1, b.1, 1e-9) && close(a.2, b.2, 1e-12), "{pp} at {s}: {a:?} vs {b:?}");
                assert!(r.curvature(s).abs() < 1e-15);
            }
        }
        // The parabola v = c u² for u in [0, L]: its true length A differs from `length` = L, so
        // s in [0, L] covers the whole curve with arc length s A / L.
        let (c, l) = (0.005, 100.0);
        let total = parabola_len(c, l);
        for pp in [
            format!(r#"<paramPoly3 aU="0" bU="1" cU="0" dU="0" aV="0" bV="0" cV="{c}" dV="0" pRange="arcLength"/>"#),
            format!(r#"<paramPoly3 aU="0" bU="{l}" cU="0" dU="0" aV="0" bV="0" cV="{}" dV="0" pRange="normalized"/>"#, c * l * l),
        ] {
            let r = road_of(&xodr(l, &format!(r#"<geometry s="0" x="0" y="0" hdg="0" length="{l}">{pp}</geometry>"#), LANES_2X2));
            let mut worst: f64 = 0.0;
            for s in [0.0, 10.0, 50.0, 99.0, 100.0] {
                let u = parabola_u(c, s * total / l);
                let (x, y, h) = r.reference(s);
                worst = worst.max((x - u).hypot(y - c * u * u));
                assert!(close(h, (2.0 * c * u).atan(), 1e-9));
                assert!(close(r.curvature(s), 2.0 * c / (1.0 + 4.0 * c * c * u * u).powf(1.5), 1e-9));
            }
            eprintln!("paramPoly3 parabola: largest position error {worst:.2e} m");
            assert!(worst < 1e-6, "{pp}: {worst}");
        }
    }

    const LANES_VARYING: &str = r#"
    <laneOffset s="0" a="0.5" b="0.01" c="0" d="0"/>
    <laneOffset s="100" a="1.5" b="0" c="-0.0001" d="0"/>
    <laneSection s="0">
      <left><lane id="1" type="driving"><width sOffset="0" a="3.25" b="0" c="0" d="0"/></lane></left>
      <center><lane id="0" type="none"/></center>
      <right>
        <lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
        <lane id="-2" type="driving">
          <width sOffset="0" a="3.0" b="0" c="0" d="0"/>
          <width sOffset="40" a="3.0" b="0.01" c="0" d="0"/>
        </lane>
        <lane id="-3" type="shoulder"><width sOffset="0" a="1.0" b="0" c="0" d="0"/></lane>
      </right>
    </laneSection>
    <laneSection s="120">
      <left><lane id="1" type="driving"><width sOffset="0" a="3.25" b="0" c="0" d="0"/></lane></left>
      <center><lane id="0" type="none"/></center>
      <right>
        <lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
        <lane id="-2" type="driving"><width sOffset="0" a="3.6" b="0" c="0" d="0"/></lane>
      </right>
    </laneSection>"#;

    #[test]
    fn lane_centres_with_lane_offset_and_width_records() {
        let r = road_of(&xodr(200.0, r#"<geometry s="0" x="0" y="0" hdg="0" length="200"><line/></geometry>"#, LANES_VARYING));
        let off = |s: f64| if s < 100.0 { 0.5 + 0.01 * s } else { 1.5 - 1e-4 * (s - 100.0).powi(2) };
        let w2 = |s: f64| {
            if s < 40.0 {
                3.0
            } else if s < 120.0 {
                3.0 + 0.01 * (s - 40.0)
            } else {
                3.6
            }
        };
        for s in [0.0, 20.0, 60.0, 110.0, 120.0, 150.0, 200.0] {
            assert!(close(r.lane_offset(s), off(s), 1e-12), "offset at {s}");
            assert!(close(r.lane_center_t(0, s).expect("0"), off(s), 1e-12));
            assert!(close(r.lane_center_t(-1, s).expect("-1"), off(s) - 1.75, 1e-12));
            assert!(close(r.lane_center_t(-2, s).expect("-2"), off(s) - 3.5 - 0.5 * w2(s), 1e-12), "lane -2 at {s}");
            assert!(close(r.lane_center_t(1, s).expect("1"), off(s) + 1.625, 1e-12));
            assert!(close(r.lane_width(-2, s).expect("-2"), w2(s), 1e-12));
            assert_eq!(r.lane_width(0, s), Some(0.0));
            // -3 only exists in the first section.
            assert_eq!(r.lane_center_t(-3, s).is_some(), s < 120.0);
            assert_eq!(r.lane_center_t(2, s), None);
            assert_eq!(r.driving_lanes(s), vec![-2, -1, 1]);
            // lane_at round trip at every lane centre, and the borders.
            for id in [-3, -2, -1, 1] {
                if let Some(t) = r.lane_center_t(id, s) {
                    assert_eq!(r.lane_at(s, t), Some(id), "lane {id} at {s}");
                    let (x, y, _) = r.world(s, t);
                    assert_eq!(r.lane_at(s, r.to_local(x, y).1), Some(id));
                }
            }
            let o = off(s);
            assert_eq!(r.lane_at(s, o), Some(-1));
            assert_eq!(r.lane_at(s, o - 3.5), Some(-1), "a border belongs to the inner lane");
            assert_eq!(r.lane_at(s, o - 3.5 - 1e-9), Some(-2));
            assert_eq!(r.lane_at(s, o + 1e-9), Some(1));
            assert_eq!(r.lane_at(s, o + 3.25 + 1e-9), None);
            assert_eq!(r.lane_at(s, o - 50.0), None);
            assert_eq!(r.lane_at(s, f64::NAN), None);
        }
        let (track, map) = to_track(&r, -1, "varying").expect("track");
        assert_eq!(map.lane_ids, vec![-2, -1]);
        assert_eq!((track.lanes, track.ego_lane, track.lane_width), (2, 1, 3.5));
        assert!(!map.uniform);
        assert!(map.note.as_deref().is_some_and(|n| n.contains("lane -2")), "{:?}", map.note);
        // Lane -2 widens to 3.8 m just before the second section (last sample at 119.5 m).
        assert!(close(map.width_range.0, 3.0, 1e-12) && close(map.width_range.1, 3.795, 1e-9), "{:?}", map.width_range);
        assert!(close(map.offset_of(-2, 60.0).expect("-2"), -1.75 - 0.5 * w2(60.0), 1e-12));
        assert!(close(map.offset_of(-3, 60.0).expect("-3"), -1.75 - w2(60.0) - 0.5, 1e-12));
        assert_eq!(map.offset_of(-3, 150.0), None);
        assert!(map.discontinuities.is_empty(), "{:?}", map.discontinuities);
        // Lane -2 narrows from 3.8 to 3.6 m at the second section: its centre jumps by 0.1 m.
        let (_, map2) = to_track(&r, -2, "jump").expect("track");
        assert!(map2.discontinuities.len() == 1 && close(map2.discontinuities[0], 120.0, 0.002), "{:?}", map2.discontinuities);
        // The track is the ego lane's centre: y = offset - 1.75 on this straight road.
        for p in &track.centerline {
            assert!(close(p[1], off(p[0]) - 1.75, 1e-9), "{p:?}");
        }
    }

    /// Start poses chained so that the geometries join without gaps.
    fn chained(shapes: &[(f64, Shape, &str)]) -> (String, f64) {
        let (mut s, mut x, mut y, mut h) = (0.0, 0.0, 0.0, 0.1);
        let mut out = String::new();
        let mut budget = MAX_PANELS;
        assert!(Geometry::new(0.0, 0.0, 0.0, 0.0, -1.0, Shape::Line).is_err());
        assert!(Geometry::new(0.0, f64::NAN, 0.0, 0.0, 1.0, Shape::Line).is_err());
        for (len, shape, xml) in shapes {
            out += &format!(r#"<geometry s="{s}" x="{x}" y="{y}" hdg="{h}" length="{len}">{xml}</geometry>"#);
            let g =
                Geometry { s, x, y, hdg: h, length: *len, shape: *shape, table: Table::default() }.tabulate(&mut budget).expect("valid");
            assert_eq!(Geometry::new(s, x, y, h, *len, *shape).as_ref(), Ok(&g));
            (x, y, h) = g.eval(*len);
            s += len;
        }
        (out, s)
    }

    fn mixed_road() -> Road {
        let (geoms, len) = chained(&[
            (100.0, Shape::Line, "<line/>"),
            (80.0, Shape::Spiral { curv_start: 0.0, curv_end: 0.01 }, r#"<spiral curvStart="0" curvEnd="0.01"/>"#),
            (100.0, Shape::Arc { curvature: 0.01 }, r#"<arc curvature="0.01"/>"#),
            (80.0, Shape::Spiral { curv_start: 0.01, curv_end: -0.008 }, r#"<spiral curvStart="0.01" curvEnd="-0.008"/>"#),
            (60.0, Shape::Arc { curvature: -0.008 }, r#"<arc curvature="-0.008"/>"#),
            (
                90.0,
                Shape::ParamPoly3 { u: [0.0, 90.0, 0.0, 0.0], v: [0.0, 0.0, -0.008 * 90.0 * 90.0 / 2.0, 8.0], normalized: true },
                r#"<paramPoly3 aU="0" bU="90" cU="0" dU="0" aV="0" bV="0" cV="-32.4" dV="8" pRange="normalized"/>"#,
            ),
            (70.0, Shape::Poly3 { coef: [0.0, 0.0, 0.0005, -1e-5] }, r#"<poly3 a="0" b="0" c="0.0005" d="-0.00001"/>"#),
        ]);
        road_of(&xodr(len, &geoms, LANES_2X2))
    }

    #[test]
    fn to_local_inverts_world() {
        let r = mixed_road();
        let mut worst: f64 = 0.0;
        let mut s = 0.0;
        while s <= r.length {
            for t in [-5.0, -1.75, 0.0, 2.5, 5.0] {
                let (x, y, _) = r.world(s, t);
                let (ls, lt) = r.to_local(x, y);
                worst = worst.max((ls - s).abs()).max((lt - t).abs());
                assert!(close(ls, s, 1e-6) && close(lt, t, 1e-6), "({s}, {t}) -> ({ls}, {lt})");
            }
            s += 3.7;
        }
        eprintln!("to_local(world(s, t)): largest error {worst:.2e} m");
        // The joints are continuous (the chained fixture) and the track builds and validates.
        let (track, map) = to_track(&r, -2, "mixed").expect("track");
        assert!(map.uniform);
        assert_eq!(track.ego_lane, 0);
        let p = track.project(r.world(250.0, -5.25).0, r.world(250.0, -5.25).1);
        assert!(p.lateral_offset.abs() < 0.01 && close(p.s, map.track_s(250.0), 0.01), "{p:?}");
        // Off the ends: s is clamped.
        let (x, y, _) = r.world(r.length, 1.0);
        let (hx, hy) = (r.reference(r.length).2.cos(), r.reference(r.length).2.sin());
        let (ls, lt) = r.to_local(x + 20.0 * hx, y + 20.0 * hy);
        assert!(close(ls, r.length, 1e-9) && close(lt, 1.0, 1e-6), "{ls} {lt}");
        assert_eq!(from_str(&xodr(r.length, "", ""), "x").map(|_| ()).unwrap_err().element, "planView");
    }

    #[test]
    fn skipped_elements_are_collected_and_parsing_is_deterministic() {
        let text = xodr(100.0, r#"<geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry>"#, LANES_2X2);
        let n = from_str(&text, "t.xodr").expect("parse");
        let skipped: Vec<&str> = n.skipped.iter().map(String::as_str).collect();
        assert_eq!(skipped, ["elevationProfile", "lateralProfile", "objects", "roadMark", "signals", "type"]);
        assert_eq!(from_str(&text, "t.xodr").expect("again"), n);
        assert_eq!(n.road("r1").map(|r| r.line), Some(4));
        assert!(n.road("nope").is_none());
        let path = std::env::temp_dir().join(format!("flc-road-test-{}.xodr", std::process::id()));
        std::fs::write(&path, &text).expect("write");
        let loaded = load(&path);
        let _ = std::fs::remove_file(&path);
        let loaded = loaded.expect("load");
        assert_eq!(loaded.roads[0].file, path.display().to_string());
        assert_eq!(loaded.roads[0].geometries, n.roads[0].geometries);
    }

    /// The error of `text`.
    fn bad(text: &str) -> ImportError {
        from_str(text, "bad.xodr").expect_err("must be rejected")
    }

    #[test]
    fn bad_inputs_name_file_line_and_element() {
        let line = |g: &str| xodr(100.0, g, LANES_2X2);
        // The geometry is on line 8 of the fixture.
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="-5"><line/></geometry>"#));
        assert_eq!((e.file.as_str(), e.line, e.element.as_str()), ("bad.xodr", 8, "geometry@length"), "{e}");
        assert!(e.to_string().starts_with("bad.xodr:8: <geometry@length>:"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="NaN" y="0" hdg="0" length="5"><line/></geometry>"#));
        assert_eq!((e.line, e.element.as_str()), (8, "geometry@x"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" length="5"><line/></geometry>"#));
        assert!(e.element == "geometry@hdg" && e.message.contains("missing"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="x1" length="5"><line/></geometry>"#));
        assert!(e.element == "geometry@hdg" && e.message.contains("not a number"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><arc/></geometry>"#));
        assert_eq!(e.element, "arc@curvature", "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><spiral curvStart="0" curvEnd="inf"/></geometry>"#));
        assert_eq!(e.element, "spiral@curvEnd", "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><clothoid/></geometry>"#));
        assert!(e.element == "clothoid" && e.message.contains("unsupported"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"/>"#));
        assert!(e.element == "geometry" && e.message.contains("shape"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><line/><arc curvature="0.1"/></geometry>"#));
        assert_eq!(e.element, "arc", "{e}");
        let e = bad(&line(
            r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><paramPoly3 aU="0" bU="1" cU="0" dU="0" aV="0" bV="0" cV="0" dV="0" pRange="p"/></geometry>"#,
        ));
        assert_eq!(e.element, "paramPoly3@pRange", "{e}");
        let e = bad(&line(
            r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><paramPoly3 aU="1" bU="0" cU="0" dU="0" aV="0" bV="0" cV="0" dV="0"/></geometry>"#,
        ));
        assert!(e.element == "paramPoly3" && e.message.contains("zero length"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="100000"><spiral curvStart="0" curvEnd="1"/></geometry>"#));
        assert!(e.element == "spiral" && e.message.contains("turns"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><poly3 a="0" b="0" c="1e300" d="0"/></geometry>"#));
        assert!(e.element == "poly3" && e.message.contains("curvature"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="1e5"><poly3 a="0" b="0" c="0" d="1e300"/></geometry>"#));
        assert!(e.element == "poly3" && e.message.contains("finite"), "{e}");
        let e = bad(&line(r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><arc curvature="-2e3"/></geometry>"#));
        assert!(e.element == "arc" && e.message.contains("curvature"), "{e}");
        let e = bad(&line(
            r#"<geometry s="10" x="0" y="0" hdg="0" length="5"><line/></geometry>
               <geometry s="5" x="0" y="0" hdg="0" length="5"><line/></geometry>"#,
        ));
        assert!(e.element == "geometry@s" && e.line == 9 && e.message.contains("sorted"), "{e}");
        let e = bad(&xodr(0.0, r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><line/></geometry>"#, LANES_2X2));
        assert_eq!((e.line, e.element.as_str()), (4, "road@length"), "{e}");
        let e = bad(&xodr(2e6, r#"<geometry s="0" x="0" y="0" hdg="0" length="5"><line/></geometry>"#, LANES_2X2));
        assert_eq!(e.element, "road@length", "{e}");
        // Lanes.
        let g = r#"<geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry>"#;
        let border = LANES_2X2.replace(
            r#"<lane id="-2" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>"#,
            "<lane id=\"-2\" type=\"driving\">\n<border sOffset=\"0\" a=\"3.5\" b=\"0\" c=\"0\" d=\"0\"/></lane>",
        );
        let e = bad(&xodr(100.0, g, &border));
        assert!(e.element == "border" && e.message.contains("unsupported") && e.line == 23, "{e}");
        let gap = LANES_2X2.replace(r#"<lane id="-2" type="driving">"#, r#"<lane id="-4" type="driving">"#);
        let e = bad(&xodr(100.0, g, &gap));
        assert!(e.element == "right" && e.message.contains("-2 missing"), "{e}");
        let wrong_side = LANES_2X2.replace(r#"<lane id="2" type="driving">"#, r#"<lane id="-5" type="driving">"#);
        assert_eq!(bad(&xodr(100.0, g, &wrong_side)).element, "lane@id");
        let no_type = LANES_2X2.replace(r#"<lane id="-1" type="driving">"#, r#"<lane id="-1">"#);
        assert_eq!(bad(&xodr(100.0, g, &no_type)).element, "lane@type");
        let nan_width = LANES_2X2.replace(r#"<width sOffset="0" a="1.0""#, r#"<width sOffset="0" a="nan""#);
        assert_eq!(bad(&xodr(100.0, g, &nan_width)).element, "width@a");
        let single = LANES_2X2.replace(r#"<laneSection s="0">"#, r#"<laneSection s="0" singleSide="true">"#);
        assert_eq!(bad(&xodr(100.0, g, &single)).element, "laneSection@singleSide");
        // Files.
        let e = bad("<OpenSCENARIO/>");
        assert!(e.element == "OpenSCENARIO" && e.message.contains("OpenDRIVE"), "{e}");
        let e = bad("<OpenDRIVE>\n<road id=\"1\" length=\"5\">\n</OpenDRIVE>");
        assert_eq!(e.element, "xml", "{e}");
        let twice = xodr(100.0, g, LANES_2X2)
            .replace("<junction id=\"7\" name=\"j\"/>", &format!("<road id=\"r1\" length=\"100\"><planView>{g}</planView></road>"));
        assert!(bad(&twice).message.contains("twice"));
    }

    #[test]
    fn hand_built_roads_never_panic() {
        let lane = |id: i32, w: f64| Lane {
            id,
            kind: "driving".into(),
            widths: vec![Cubic { s: 0.0, a: w, b: 0.0, c: 0.0, d: 0.0 }],
            predecessor: None,
            successor: None,
        };
        let weird = LaneSection {
            s: f64::NAN,
            left: vec![lane(i32::MIN, f64::NAN), lane(3, 1e308)],
            right: vec![lane(i32::MAX, -1.0), lane(-1, 1e308)],
        };
        let empty = Road {
            id: "h".into(),
            length: f64::NAN,
            geometries: vec![],
            lane_offsets: vec![Cubic { s: f64::INFINITY, a: 1.0, b: 0.0, c: 0.0, d: 0.0 }],
            lane_sections: vec![weird.clone(), LaneSection { s: 0.0, left: vec![], right: vec![] }],
            left_hand_traffic: false,
            junction: "-1".into(),
            predecessor: None,
            successor: None,
            file: String::new(),
            line: 0,
        };
        let mut with_geometry = empty.clone();
        with_geometry.length = 80.0;
        with_geometry.geometries =
            vec![Geometry::new(0.0, 0.0, 0.0, 0.0, 80.0, Shape::Spiral { curv_start: 0.0, curv_end: 0.01 }).expect("ok")];
        for r in [&empty, &with_geometry] {
            for s in [f64::NAN, f64::NEG_INFINITY, -1.0, 0.0, 10.0, 1e9, f64::INFINITY] {
                for id in [i32::MIN, -1, 0, 1, 3, i32::MAX] {
                    let _ = (r.lane_center_t(id, s), r.lane_width(id, s));
                    for t in [f64::NAN, -1e308, 0.0, 1.0, f64::INFINITY] {
                        let _ = (r.lane_at(s, t), r.world(s, t));
                    }
                }
                let _ = (r.reference(s), r.curvature(s), r.lane_offset(s), r.driving_lanes(s), r.to_local(s, s), r.to_local(s, 0.0));
            }
            for id in [i32::MIN, -1, 0, 1, i32::MAX] {
                assert!(to_track(r, id, "h").is_err());
            }
        }
    }

    #[test]
    fn a_lane_with_a_positive_id_is_driven_against_the_reference_line() {
        let r = road_of(&xodr(100.0, r#"<geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry>"#, LANES_2X2));
        let (track, map) = to_track(&r, 1, "t").expect("lane 1");
        // From the road's end to its start, along lane 1's centre (t = 1.75).
        assert_eq!(track.centerline, vec![[100.0, 1.75], [0.0, 1.75]]);
        assert!(map.reversed && close(track.length(), 100.0, 1e-9));
        // The left driving lanes, rightmost first in the driving direction: 2 (outer), then 1.
        assert_eq!((map.lane_ids.clone(), track.lanes, track.ego_lane), (vec![2, 1], 2, 1));
        // Offsets + left of the driving direction: lane 2 to the right, lane -1 to the left.
        assert!(close(map.offset_of(2, 30.0).expect("2"), -3.5, 1e-12) && close(map.offset_of(-1, 30.0).expect("-1"), 3.5, 1e-12));
        assert!(close(map.track_s(30.0), 70.0, 1e-9) && close(map.track_s(100.0), 0.0, 1e-9));
        // A negative lane: unchanged, along the reference line.
        let (fwd, m) = to_track(&r, -1, "t").expect("lane -1");
        assert_eq!(fwd.centerline, vec![[0.0, -1.75], [100.0, -1.75]]);
        assert!(!m.reversed && close(m.track_s(30.0), 30.0, 1e-9) && close(m.offset_of(-2, 30.0).expect("-2"), -3.5, 1e-12));
    }

    #[test]
    fn to_track_refuses_what_it_cannot_model() {
        let straight =
            |len: f64| road_of(&xodr(len, &format!(r#"<geometry s="0" x="0" y="0" hdg="0" length="{len}"><line/></geometry>"#), LANES_2X2));
        let r = straight(100.0);
        let e = to_track(&r, 0, "t").expect_err("centre");
        assert!(e.message.contains("centre lane"), "{e}");
        assert_eq!((e.file.as_str(), e.line, e.element.as_str()), ("t.xodr", 4, "road"));
        assert!(to_track(&r, -7, "t").expect_err("missing").message.contains("does not exist"));
        // The shoulder is 1 m wide: unusual, but a positive width (the importer warns).
        assert_eq!(to_track(&r, -3, "t").expect("narrow").0.lane_width, 1.0);
        let e = to_track(&straight(40.0), -1, "t").expect_err("short");
        assert!(e.message.contains("at least 50 m"), "{e}");
        let (track, map) = to_track(&straight(50.0), -1, "t").expect("50 m is enough");
        assert!(track.validate().is_ok() && close(track.length(), 50.0, 1e-9));
        assert_eq!(track.name, "t");
        assert_eq!(map.road().id, "r1");
        let lht = road_of(
            &xodr(100.0, r#"<geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry>"#, LANES_2X2)
                .replace("junction=\"-1\"", "rule=\"LHT\""),
        );
        assert!(to_track(&lht, -1, "t").expect_err("lht").message.contains("LHT"));
    }
}
