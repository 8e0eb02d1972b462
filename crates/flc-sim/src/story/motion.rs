//! The kinematic motion a story prescribes for one entity ([`Motion`]): position along the
//! centreline, lateral offset, speed, and the running longitudinal and lateral actions.

use super::{Action, ClothoidSegment, Dimension, Shape, Transition, Vertex};
use crate::trigger::WorldView;

/// A running longitudinal action.
#[derive(Debug, Clone, PartialEq)]
struct Long {
    action: usize,
    v0: f64,
    v1: f64,
    shape: Shape,
    /// Duration of the transition, s (0: step).
    duration: f64,
    t0: f64,
    /// Relative target tracked after the transition: `(entity, delta, factor)`.
    track: Option<(String, f64, f64)>,
    /// A continuous longitudinal distance kept to another entity.
    keep: Option<Keep>,
    /// A running `SynchronizeAction`.
    sync: Option<Sync>,
}

/// esmini's synchronisation modes.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SyncMode {
    None,
    NonLinear,
    Linear,
    Stopped,
    StopNow,
    Waiting,
    Steady,
}

/// A running `SynchronizeAction` and its state (esmini's `SynchronizeAction::Step`).
#[derive(Debug, Clone, PartialEq)]
struct Sync {
    master: String,
    master_target: f64,
    master_point: Option<[f64; 2]>,
    /// How far ahead along its trajectory the master's target is this step
    /// ([`Motion::set_master_ahead`]).
    master_ahead: Option<f64>,
    target: f64,
    final_speed: Option<f64>,
    steady: Option<f64>,
    tolerance: f64,
    tolerance_master: f64,
    mode: SyncMode,
    convex: bool,
    last: f64,
    last_master: f64,
}

const SMALL: f64 = 1.0e-6;
const LARGE: f64 = 1.0e10;
/// esmini's `MAX_DECELERATION` of a synchronisation that must stop at once, m/s².
const SYNC_STOP_DECEL: f64 = -8.0;

/// A running `LongitudinalDistanceAction`: kept every step (`continuous`), or until within
/// [`REACHED_M`] of the distance.
#[derive(Debug, Clone, PartialEq)]
struct Keep {
    of: String,
    distance: Option<f64>,
    time_gap: Option<f64>,
    freespace: bool,
    ahead: bool,
    continuous: bool,
}

/// A non-continuous `LongitudinalDistanceAction` ends in the step its distance is off by less
/// than this, m (esmini 3.6.0's `LONGITUDINAL_DISTANCE_THRESHOLD`).
pub const REACHED_M: f64 = 0.1;

/// A running lateral action.
#[derive(Debug, Clone, PartialEq)]
struct Lat {
    action: usize,
    from: f64,
    to: f64,
    shape: Shape,
    /// `true`: `extent` is a distance along the road, else a time.
    by_distance: bool,
    extent: f64,
    t0: f64,
    x0: f64,
    /// A lane change: the entity moves at its speed along its heading, so the lateral motion
    /// takes from its progress along the road (esmini); a lane offset does not.
    along_heading: bool,
}

/// A running `FollowTrajectoryAction` along a spline: esmini's polyline of the spline (a vertex every metre
/// and one at the end), laid in the road's frame from where the action started.
#[derive(Debug, Clone, PartialEq)]
struct Spline {
    action: usize,
    /// Vertices `(s, offset, heading relative to the road)`; vertex `k` sits at `k` m along the
    /// polyline's parameter (the last at its whole number of metres, esmini's).
    pts: Vec<[f64; 3]>,
    /// The spline's length (the segments' sum), m.
    length: f64,
    /// Distance moved along it, m.
    u: f64,
}

impl Spline {
    /// The parameter (m along the polyline) of the point of it nearest to `p` (`[s, offset]`).
    fn project(&self, p: [f64; 2]) -> Option<f64> {
        let n = self.pts.len();
        let param = |k: usize| if k + 1 == n { self.length } else { k as f64 };
        let mut best: Option<(f64, f64)> = None;
        for k in 0..n.saturating_sub(1) {
            let (a, b) = (self.pts[k], self.pts[k + 1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len2 = dx * dx + dy * dy;
            let f = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let d = (p[0] - a[0] - f * dx).hypot(p[1] - a[1] - f * dy);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, param(k) + f * (param(k + 1) - param(k))));
            }
        }
        best.map(|(_, u)| u)
    }

    /// The spline of `segments` from `(s, offset)` facing `heading` (relative to the road),
    /// sampled as esmini's `ClothoidSplineShape::CalculatePolyLine`.
    fn new(action: usize, segments: &[ClothoidSegment], s: f64, offset: f64, heading: f64) -> Self {
        let length: f64 = segments.iter().map(|g| g.length).sum();
        // Segment start poses in the local frame (x ahead, y left, theta).
        let mut starts = Vec::with_capacity(segments.len());
        let mut pose = [0.0, 0.0, 0.0];
        for g in segments {
            starts.push(pose);
            pose = clothoid_at(pose, g, g.length);
        }
        let local = |u: f64, j: usize| clothoid_at(starts[j], &segments[j], u);
        let steps = (length + 1.0e-9).floor() as usize;
        let (c, sn) = (heading.cos(), heading.sin());
        let mut pts = Vec::with_capacity(steps + 1);
        let (mut j, mut sum) = (0usize, 0.0);
        for k in 0..=steps {
            let p = if k < steps {
                let u = k as f64;
                while j + 1 < segments.len() && u > sum + segments[j].length - 1.0e-9 {
                    sum += segments[j].length;
                    j += 1;
                }
                local(u - sum, j)
            } else {
                let last = segments.len() - 1;
                let before: f64 = segments[..last].iter().map(|g| g.length).sum();
                local(length - before, last)
            };
            pts.push([s + p[0] * c - p[1] * sn, offset + p[0] * sn + p[1] * c, heading + p[2]]);
        }
        Self { action, pts, length, u: 0.0 }
    }

    /// The pose at `u` m along the polyline (positions linear between vertices, the heading
    /// turned over 0.5 m either side of a vertex, esmini's corner interpolation).
    fn at(&self, u: f64) -> [f64; 3] {
        let n = self.pts.len();
        let last = (n - 1) as f64;
        if n == 1 || u > last - 1.0e-9 {
            return self.pts[n - 1];
        }
        let u = u.max(0.0);
        let i = (u.floor() as usize).min(n - 2);
        let a = u - i as f64;
        let (p0, p1) = (self.pts[i], self.pts[i + 1]);
        let mut h = p0[2];
        if a < 0.5 && i > 0 {
            h = self.pts[i - 1][2] + (0.5 + a) * crate::track::wrap(p0[2] - self.pts[i - 1][2]);
        } else if a > 0.5 {
            let w = if i + 2 < n { a - 0.5 } else { (a - 0.5) / 0.5 };
            h = p0[2] + w * crate::track::wrap(p1[2] - p0[2]);
        }
        [(1.0 - a) * p0[0] + a * p1[0], (1.0 - a) * p0[1] + a * p1[1], h]
    }
}

/// The pose `[x, y, theta]` `u` m along the spline of `segments` laid from the origin along +x,
/// on esmini's polyline of it (as a running `FollowTrajectoryAction` moves).
pub fn spline_pose(segments: &[ClothoidSegment], u: f64) -> [f64; 3] {
    if segments.is_empty() {
        return [0.0; 3];
    }
    Spline::new(0, segments, 0.0, 0.0, 0.0).at(u)
}

/// The pose `u` m along a clothoid segment `g` from `start` (`[x, y, theta]`, local frame):
/// theta integrates the linear curvature exactly, x and y by Gauss-Legendre quadrature over
/// pieces of at most 0.25 m.
fn clothoid_at(start: [f64; 3], g: &ClothoidSegment, u: f64) -> [f64; 3] {
    let rate = (g.curvature_end - g.curvature_start) / g.length;
    let theta = |v: f64| start[2] + g.curvature_start * v + 0.5 * rate * v * v;
    let n = ((u / 0.25).ceil() as usize).max(1);
    let h = u / n as f64;
    // 3-point Gauss-Legendre nodes and weights on [-1, 1].
    const X: [f64; 3] = [-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4];
    const W: [f64; 3] = [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0];
    let (mut x, mut y) = (start[0], start[1]);
    for k in 0..n {
        let mid = (k as f64 + 0.5) * h;
        for q in 0..3 {
            let th = theta(mid + 0.5 * h * X[q]);
            x += 0.5 * h * W[q] * th.cos();
            y += 0.5 * h * W[q] * th.sin();
        }
    }
    [x, y, theta(u)]
}

/// A running trajectory ([`Action::Trajectory`]).
#[derive(Debug, Clone, PartialEq)]
struct Traj {
    action: usize,
    /// Time of vertex times' zero, s (0 for absolute times).
    t0: f64,
    vertices: Vec<Vertex>,
}

impl Traj {
    /// `(s, offset, heading, speed, ended)` at time `t`: linear between the vertices, the
    /// first before it, the last after it; the speed of the segment in effect (its length in
    /// centreline coordinates over its time).
    fn at(&self, t: f64) -> (f64, f64, f64, f64, bool) {
        // Within a nanosecond of a vertex counts as reached (sums of steps are inexact).
        let tau = t - self.t0 + 1e-9;
        let seg_speed = |a: &Vertex, b: &Vertex| {
            let dt = b.t - a.t;
            if dt > 0.0 { (b.s - a.s).hypot(b.offset - a.offset) / dt } else { 0.0 }
        };
        let n = self.vertices.len();
        let k = self.vertices.partition_point(|v| v.t <= tau);
        match (k.checked_sub(1).and_then(|i| self.vertices.get(i)), self.vertices.get(k)) {
            (Some(a), Some(b)) => {
                let p = if b.t > a.t { ((tau - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 1.0 };
                let lerp = |x: f64, y: f64| x + (y - x) * p;
                (lerp(a.s, b.s), lerp(a.offset, b.offset), lerp(a.heading, b.heading), seg_speed(a, b), false)
            }
            (None, Some(b)) => (b.s, b.offset, b.heading, 0.0, false),
            (Some(a), None) => {
                let v = match (n.checked_sub(2).and_then(|i| self.vertices.get(i)), self.vertices.last()) {
                    (Some(x), Some(y)) => seg_speed(x, y),
                    _ => 0.0,
                };
                (a.s, a.offset, a.heading, v, true)
            }
            (None, None) => (0.0, 0.0, 0.0, 0.0, true),
        }
    }
}

/// What one step of a [`Motion`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionStep {
    /// The longitudinal action that ended this step.
    pub long_done: Option<usize>,
    /// The lateral action that ended this step.
    pub lat_done: Option<usize>,
}

/// An entity moved by its story actions: at `s` (m along the centreline, its centre) and
/// `offset` (m from the centreline, + left) with `speed` (m/s); `heading` relative to the road
/// (rad, + left) follows the lateral motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// Centre position along the centreline, m.
    pub s: f64,
    /// Lateral offset of the centre from the centreline, m (+ left).
    pub offset: f64,
    /// Speed, m/s.
    pub speed: f64,
    /// Acceleration over the last step, m/s².
    pub accel: f64,
    /// Heading relative to the road, rad.
    pub heading: f64,
    /// Distance travelled, m.
    pub traveled: f64,
    /// Drives against the centreline's direction (`s` decreasing): an oncoming entity, one that
    /// starts facing more than 90° away from the road's direction (`heading` near pi).
    pub reversed: bool,
    lane_width: f64,
    /// The entity's own length (freespace placements), m.
    own_len: Option<f64>,
    /// Its box centre from the reference point (`s`, `offset`), entity frame, m.
    reference: [f64; 2],
    /// `[max acceleration, max deceleration]` its speed changes keep to, m/s² (`None`: none).
    limits: Option<[f64; 2]>,
    long: Option<Long>,
    lat: Option<Lat>,
    traj: Option<Traj>,
    spline: Option<Spline>,
    /// The heading is kept (after a trajectory, until a lateral action starts) instead of
    /// following the lateral motion.
    hold_heading: bool,
    /// It reached an end of the road ([`Motion::end_of_road`]).
    at_end: bool,
    /// Its velocity along the road over its last step (`ds / dt`; `None` before its first
    /// step): what esmini's ground truth reports as the velocity (from the displacement), m/s.
    vel_s: Option<f64>,
}

impl Motion {
    /// An entity at rest in its motion (no action running) at `s`, `offset`, `speed`, on a track
    /// of lanes `lane_width` wide.
    pub fn new(s: f64, offset: f64, speed: f64, lane_width: f64) -> Self {
        Self {
            s,
            offset,
            speed,
            accel: 0.0,
            heading: 0.0,
            traveled: 0.0,
            reversed: false,
            lane_width,
            own_len: None,
            reference: [0.0, 0.0],
            limits: None,
            long: None,
            lat: None,
            traj: None,
            spline: None,
            hold_heading: false,
            at_end: false,
            vel_s: None,
        }
    }

    /// Keeps the entity on a road `length` m long, as esmini's default controller does at a
    /// road's end: a step that would leave `[0, length]` stops it at the end; a step that
    /// starts there (`s_before`, within 1 µm) and would leave again marks the end reached (its
    /// speed still reported), and from the next step on it stands there (speed 0) whatever its
    /// actions. A running trajectory places the entity itself.
    pub fn end_of_road(&mut self, s_before: f64, length: f64, dt: f64) {
        const EPS: f64 = 1e-6;
        if self.traj.is_some() || self.spline.is_some() || length.is_nan() || length <= 0.0 {
            return;
        }
        if self.at_end {
            let v = self.speed;
            self.speed = 0.0;
            self.accel = if dt > 0.0 { -v / dt } else { 0.0 };
        }
        if self.s > length {
            self.s = length;
            self.at_end |= s_before >= length - EPS;
        } else if self.s < 0.0 {
            self.s = 0.0;
            self.at_end |= s_before <= EPS;
        }
    }

    /// Tells a running synchronisation how far ahead along its master's trajectory the master's
    /// target is this step (`None`: the master follows no trajectory; measured along the road).
    pub fn set_master_ahead(&mut self, ahead: Option<f64>) {
        if let Some(y) = self.long.as_mut().and_then(|l| l.sync.as_mut()) {
            y.master_ahead = ahead;
        }
    }

    /// The master and its target point of a running synchronisation that measures the master
    /// along its trajectory (`Action::Synchronize::master_point`).
    pub fn sync_master_point(&self) -> Option<(&str, [f64; 2])> {
        let y = self.long.as_ref()?.sync.as_ref()?;
        Some((y.master.as_str(), y.master_point?))
    }

    /// How far ahead along the trajectory this entity follows (a running spline) the point
    /// `[s, offset]` projects onto it, from where the entity is now, m; `None` when it follows
    /// none. The spline is laid on a straight road: `(s, offset)` is a Cartesian frame.
    pub fn ahead_on_trajectory(&self, point: [f64; 2]) -> Option<f64> {
        let tr = self.spline.as_ref()?;
        Some(tr.project(point)? - tr.u.min(tr.length))
    }

    /// Records the step's velocity along the road from `s_before` to where the step (and the
    /// road's end) left it (esmini's ground-truth velocity, which a synchronisation reads).
    pub fn record_velocity(&mut self, s_before: f64, dt: f64) {
        if dt > 0.0 {
            self.vel_s = Some((self.s - s_before) / dt);
        }
    }

    /// `true` while this entity follows a trajectory (a running spline).
    pub fn follows_trajectory(&self) -> bool {
        self.spline.is_some()
    }

    /// This motion for an entity `length` m long (freespace placements).
    pub fn with_length(mut self, length: f64) -> Self {
        self.own_len = Some(length);
        self
    }

    /// This motion for an entity whose speed changes keep to `limits` (`[max acceleration, max
    /// deceleration]`, m/s²): a transition whose peak rate would exceed them takes longer.
    pub fn with_limits(mut self, limits: Option<[f64; 2]>) -> Self {
        self.limits = limits;
        self
    }

    /// This motion for an entity whose box centre is at `reference` from the point it moves
    /// (entity frame, m).
    pub fn with_reference(mut self, reference: [f64; 2]) -> Self {
        self.reference = reference;
        self
    }

    /// This motion facing `heading` relative to the road (rad): beyond 90° it drives against the
    /// centreline's direction ([`Motion::reversed`]).
    pub fn with_heading(mut self, heading: f64) -> Self {
        self.heading = heading;
        self.reversed = heading.abs() > std::f64::consts::FRAC_PI_2;
        self
    }

    /// This motion keeping its heading relative to the road while no lateral action runs (a
    /// pedestrian: esmini turns neither its box nor its walking direction with the road).
    pub fn holding_heading(mut self) -> Self {
        self.hold_heading = true;
        self
    }

    /// The box centre's position from the moved point, entity frame, m.
    pub fn reference(&self) -> [f64; 2] {
        self.reference
    }

    /// Stops action `i` if it runs here (`true` if it did).
    pub fn stop(&mut self, i: usize) -> bool {
        let mut hit = false;
        if self.long.as_ref().is_some_and(|l| l.action == i) {
            self.long = None;
            hit = true;
        }
        if self.lat.as_ref().is_some_and(|l| l.action == i) {
            self.lat = None;
            hit = true;
        }
        if self.traj.as_ref().is_some_and(|l| l.action == i) {
            self.traj = None;
            hit = true;
        }
        if self.spline.as_ref().is_some_and(|l| l.action == i) {
            self.spline = None;
            hit = true;
        }
        hit
    }

    /// The lane index (0 = the centreline's lane, + left) an offset lies in.
    fn lane_of(&self, offset: f64) -> f64 {
        if self.lane_width > 0.0 { (offset / self.lane_width).round() } else { 0.0 }
    }

    /// Starts action `i` (`action`) at time `t`, reading reference entities from `world`.
    /// Returns the actions of the same domains it replaces (to be ended as stopped), and whether
    /// the action already ended (a step transition, a placement). Non-motion actions do nothing.
    /// A timed trajectory holds both domains (esmini): any motion action replaces it, and it
    /// replaces both the longitudinal and the lateral action. A trajectory without time
    /// reference (a spline, [`Action::FollowTrajectory`]) holds the lateral domain only, as
    /// esmini reads it (`ScenarioReader.cpp`: `DOMAIN_MASK_LAT` for `TimingDomain::NONE`): a
    /// lateral action replaces it, a speed action runs beside it and sets the speed it moves at.
    pub fn start(&mut self, i: usize, action: &Action, t: f64, world: &dyn WorldView) -> (Vec<usize>, bool) {
        let mut replaced: Vec<usize> = Vec::new();
        if action.is_longitudinal() || action.is_lateral() {
            replaced.extend(self.traj.take().map(|x| x.action).filter(|&a| a != i));
        }
        if action.is_lateral() {
            replaced.extend(self.spline.take().map(|x| x.action).filter(|&a| a != i));
            self.hold_heading = false;
        }
        match action {
            Action::FollowTrajectory { segments } => {
                replaced.extend(self.lat.take().map(|l| l.action).filter(|&a| a != i));
                self.spline = Some(Spline::new(i, segments, self.s, self.offset, self.heading));
                return (replaced, false);
            }
            Action::Trajectory { absolute, vertices } => {
                replaced.extend(self.long.take().map(|l| l.action).filter(|&a| a != i));
                replaced.extend(self.lat.take().map(|l| l.action).filter(|&a| a != i));
                self.traj = Some(Traj { action: i, t0: if *absolute { 0.0 } else { t }, vertices: vertices.clone() });
                return (replaced, false);
            }
            _ => {}
        }
        let (other, done) = self.start_one(i, action, t, world);
        replaced.extend(other);
        (replaced, done)
    }

    fn start_one(&mut self, i: usize, action: &Action, t: f64, world: &dyn WorldView) -> (Option<usize>, bool) {
        match action {
            Action::Speed { speed, of, delta, factor, continuous, transition } => {
                let replaced = self.long.take().map(|l| l.action).filter(|&a| a != i);
                let (target, track) = match (speed, of) {
                    (Some(v), _) => (*v, None),
                    (None, Some(name)) => {
                        let v_of = world.entity(name).map_or(self.speed, |e| e.speed);
                        let (d, f) = (delta.unwrap_or(0.0), factor.unwrap_or(1.0));
                        let v = if factor.is_some() { v_of * f } else { v_of + d };
                        (
                            v,
                            continuous
                                .then(|| (name.clone(), if factor.is_some() { 0.0 } else { d }, if factor.is_some() { f } else { 1.0 })),
                        )
                    }
                    (None, None) => (self.speed, None),
                };
                let mut duration = speed_duration(transition, self.speed, target);
                if let Some([up, down]) = self.limits {
                    // esmini (`TransitionDynamics::SetMaxRate`): the transition slowed to the
                    // entity's performance, its shape kept.
                    let change = (target - self.speed).abs();
                    let limit = if target > self.speed { up } else { down };
                    if duration.is_finite() && duration > 0.0 && limit > 0.0 {
                        duration = duration.max(transition.shape.peak_slope() * change / limit);
                    }
                }
                self.long = Some(Long {
                    action: i,
                    v0: self.speed,
                    v1: target,
                    shape: transition.shape,
                    duration,
                    t0: t,
                    track,
                    keep: None,
                    sync: None,
                });
                (replaced, false)
            }
            Action::LaneChange { offset, of, lanes, lane_offset, transition } => {
                let replaced = self.lat.take().map(|l| l.action).filter(|&a| a != i);
                let to = match (offset, of, lanes) {
                    (Some(o), _, _) => *o + lane_offset,
                    (None, Some(name), Some(n)) => {
                        let ref_offset = world.entity(name).map_or(self.offset, |e| e.lateral);
                        (self.lane_of(ref_offset) + f64::from(*n)) * self.lane_width + lane_offset
                    }
                    _ => self.offset,
                };
                self.start_lateral(i, to, transition, true, t);
                (replaced, false)
            }
            Action::LaneOffset { offset, of, shape, max_lateral_acc } => {
                let replaced = self.lat.take().map(|l| l.action).filter(|&a| a != i);
                // Absolute: from the centre of the lane the entity is in. Relative to an entity:
                // that entity's lateral position plus `offset`, whatever lane either is in
                // (esmini keeps the actor's lane and offsets within it, even by a lane or more).
                let to = match of.as_deref().and_then(|name| world.entity(name)) {
                    Some(e) => e.lateral + offset,
                    None => self.lane_of(self.offset) * self.lane_width + offset,
                };
                let change = (to - self.offset).abs();
                // Peak lateral acceleration of the shape over a change `c` in time `T`: linear has
                // none inside (taken as cubic), cubic 6 c / T², sinusoidal pi² c / (2 T²).
                let k = match shape {
                    Shape::Sinusoidal => std::f64::consts::PI * std::f64::consts::PI / 2.0,
                    _ => 6.0,
                };
                let duration = if *shape == Shape::Step || change == 0.0 { 0.0 } else { (k * change / max_lateral_acc).sqrt() };
                let tr = Transition { shape: *shape, dimension: Dimension::Time, value: duration };
                self.start_lateral(i, to, &tr, false, t);
                (replaced, false)
            }
            Action::LongitudinalDistance { of, distance, time_gap, freespace, ahead, continuous } => {
                let replaced = self.long.take().map(|l| l.action).filter(|&a| a != i);
                let keep = Keep {
                    of: of.clone(),
                    distance: *distance,
                    time_gap: *time_gap,
                    freespace: *freespace,
                    ahead: *ahead,
                    continuous: *continuous,
                };
                // With the world's geometry, esmini's way: one correction now (the first one
                // of an Init action is in the state at t = 0), one at the start of every step
                // after, until within `REACHED_M` (non-continuous).
                if let Some(off) = self.reach(&keep, world) {
                    if *continuous || off >= REACHED_M {
                        self.long = Some(Long {
                            action: i,
                            v0: self.speed,
                            v1: self.speed,
                            shape: Shape::Step,
                            duration: 0.0,
                            t0: t,
                            track: None,
                            keep: Some(keep),
                            sync: None,
                        });
                        return (replaced, false);
                    }
                    return (replaced, true);
                }
                if let Some(r) = world.entity(of) {
                    // A reached-once time gap is the actor's own speed times the gap (as before);
                    // a kept one `of`'s (esmini).
                    let v = if *continuous { r.speed } else { self.speed };
                    self.keep_at(&keep, &r, v);
                    if *continuous {
                        self.speed = r.speed;
                    }
                }
                if *continuous {
                    self.long = Some(Long {
                        action: i,
                        v0: self.speed,
                        v1: self.speed,
                        shape: Shape::Step,
                        duration: 0.0,
                        t0: t,
                        track: None,
                        keep: Some(keep),
                        sync: None,
                    });
                    return (replaced, false);
                }
                (replaced, true)
            }
            Action::Synchronize {
                master,
                master_target,
                master_point,
                target,
                final_speed,
                steady_time,
                steady_distance,
                tolerance,
                tolerance_master,
            } => {
                let replaced = self.long.take().map(|l| l.action).filter(|&a| a != i);
                // A steady state by time is a distance at the final speed (esmini's Start).
                let steady = steady_distance.or_else(|| steady_time.zip(*final_speed).map(|(t, v)| t * v));
                let mut sync = Sync {
                    master: master.clone(),
                    master_target: *master_target,
                    master_point: *master_point,
                    master_ahead: None,
                    target: *target,
                    final_speed: *final_speed,
                    steady,
                    tolerance: *tolerance,
                    tolerance_master: *tolerance_master,
                    mode: SyncMode::None,
                    convex: false,
                    last: LARGE,
                    last_master: LARGE,
                };
                // An action started with the storyboard (t = 0) gets esmini's first frame, a
                // step of 0 s in which the master has no velocity yet: it waits, at speed 0.
                let mut done = false;
                if t <= 0.0 {
                    done = self.sync_step(&mut sync, 0.0, world, true);
                }
                if done {
                    return (replaced, true);
                }
                self.long = Some(Long {
                    action: i,
                    v0: self.speed,
                    v1: self.speed,
                    shape: Shape::Step,
                    duration: 0.0,
                    t0: t,
                    track: None,
                    keep: None,
                    sync: Some(sync),
                });
                (replaced, false)
            }
            _ => (None, true),
        }
    }

    /// One step of a synchronisation (esmini's `SynchronizeAction::Step` on one road: distances
    /// along the track, speeds along it); `true` when it ends.
    /// `still`: the master's velocity is taken as 0 (esmini's first frame, at t = 0 with a
    /// step of 0: no entity has moved yet, so none has a velocity).
    fn sync_step(&mut self, y: &mut Sync, dt: f64, world: &dyn WorldView, still: bool) -> bool {
        let Some(m) = world.entity(&y.master) else { return false };
        // A master following a trajectory is measured along it (esmini: `CS_TRAJECTORY`).
        let md = y.master_point.and(y.master_ahead).unwrap_or(y.master_target - m.s);
        let dir_master = if md < 0.0 { -1.0 } else { 1.0 };
        let (mut master_dist, mut dist) = (md.abs(), (y.target - self.s).abs());
        let mut done =
            dist < y.tolerance + SMALL || master_dist < y.tolerance_master + SMALL || dist > y.last || master_dist > y.last_master;
        y.last = dist;
        y.last_master = master_dist;
        dist = (dist - y.tolerance).max(SMALL);
        master_dist = (master_dist - y.tolerance_master).max(SMALL);
        let mut t_master = LARGE;
        // esmini projects the master's velocity on the road's s axis (`GetVelS`): a master
        // turning off the road's direction closes in on its target more slowly along `s`.
        let along_road = match (world.pose(&y.master), world.place(m.s, m.lateral)) {
            (Some([_, _, yaw]), Some([_, _, road, _])) => (yaw - road).cos().abs(),
            _ => 1.0,
        };
        let master_speed = if still { 0.0 } else { dir_master * m.speed * along_road };
        if master_speed > SMALL {
            t_master = master_dist / master_speed;
            if t_master < dt {
                done = true;
            }
        } else if y.mode != SyncMode::Waiting {
            y.mode = SyncMode::Waiting;
            self.speed = 0.0;
        }
        if done {
            if let Some(v1) = y.final_speed {
                self.speed = v1;
            }
            return true;
        }
        let average = dist / t_master;
        let mut acc = 0.0;
        match y.final_speed {
            Some(v1) => {
                if let Some(ss) = y.steady.filter(|_| y.mode != SyncMode::Steady) {
                    let time_to_ss = ss / v1;
                    if dist - ss < SMALL || t_master - time_to_ss < SMALL {
                        y.mode = SyncMode::Steady;
                    } else {
                        dist -= ss;
                        t_master -= time_to_ss;
                    }
                }
                match y.mode {
                    SyncMode::Steady => {
                        self.speed = v1;
                        return false;
                    }
                    SyncMode::Waiting => {
                        if t_master >= LARGE {
                            return false;
                        }
                        y.mode = SyncMode::None;
                    }
                    SyncMode::StopNow => {
                        self.speed += SYNC_STOP_DECEL * dt;
                        if self.speed < 0.0 {
                            self.speed = 0.0;
                            y.mode = SyncMode::Waiting;
                        }
                        return false;
                    }
                    SyncMode::Stopped => {
                        if t_master < 2.0 * dist / v1 {
                            y.mode = SyncMode::Linear;
                        } else {
                            self.speed = 0.0;
                            return false;
                        }
                    }
                    _ => {}
                }
                if y.mode == SyncMode::Linear {
                    self.speed = if t_master > LARGE - 1.0 { 0.0 } else { linear_profile_speed(v1.max(0.0), t_master, dist).max(0.0) };
                    return false;
                }
                if y.mode == SyncMode::NonLinear && t_master < LARGE && (self.speed - (2.0 * dist / t_master - v1)).abs() < 0.1 {
                    // Passed the apex: constant acceleration to the end, this step at the speed.
                    y.mode = SyncMode::Linear;
                    return false;
                }
                if y.mode == SyncMode::None {
                    y.mode = SyncMode::NonLinear;
                    y.convex = (v1 + self.speed) / 2.0 < dist / t_master;
                }
                // esmini takes the current speed from the ground truth's velocity projected on
                // the road (`SIGN(speed) * |GetVelS()|`): the displacement of the last step, which
                // lags the speed an action set by a step where a trajectory moves first.
                let v_now = self.vel_s.map_or(self.speed, |v| v.abs().copysign(self.speed));
                let (sd, t, v0) = (dist, t_master, v_now);
                let mut vx = 0.0;
                if (v1 - v0).abs() < SMALL {
                    vx = (sd - (t / 2.0) * v0) / (t / 2.0);
                    acc = (vx - v0) / (t / 2.0);
                } else {
                    let root = 2.0_f64.sqrt() * (2.0 * sd * sd - 2.0 * (v1 + v0) * t * sd + (v1 * v1 + v0 * v0) * t * t).sqrt();
                    let x1 = -(root + 2.0 * sd - 2.0 * v1 * t) / (2.0 * (v1 - v0));
                    let x2 = -(-root + 2.0 * sd - 2.0 * v1 * t) / (2.0 * (v1 - v0));
                    if x1 > 0.0 && x1 < t {
                        vx = (2.0 * sd - root) / (2.0 * t);
                        acc = (vx - v0) / x1;
                    } else if x2 > 0.0 && x2 < t {
                        vx = (2.0 * sd + root) / (2.0 * t);
                        acc = (vx - v0) / x2;
                    }
                }
                if y.mode == SyncMode::NonLinear && ((!y.convex && acc > 0.0) || (y.convex && acc < 0.0)) {
                    y.mode = SyncMode::Linear;
                    acc = 0.0;
                }
                if y.mode == SyncMode::NonLinear && vx < 0.0 {
                    let t1 = 2.0 * v0 * sd / (v0 * v0 + v1 * v1);
                    acc = if t1.abs() > SMALL { -v0 / t1 } else { 0.0 };
                    if t1 * v0 / 2.0 > sd / 2.0 {
                        acc = SYNC_STOP_DECEL;
                        y.mode = SyncMode::StopNow;
                    }
                    if v0 + acc * dt < 0.0 {
                        self.speed = 0.0;
                        y.mode = SyncMode::Stopped;
                        return false;
                    }
                }
            }
            None => {
                if master_speed > SMALL {
                    y.mode = SyncMode::Linear;
                    let v_final = 2.0 * average - self.speed;
                    acc = (v_final - self.speed) / t_master;
                }
            }
        }
        self.speed += acc * dt;
        false
    }

    /// One correction of a distance action as esmini 3.6.0 makes it (`LongDistanceAction::Step`):
    /// the distance to `k.of` measured along this entity's heading (between the rotated boxes
    /// with `freespace`: 0 when their projections overlap; else between box centres), the
    /// wanted one (a time gap times `k.of`'s speed), and the entity moved along its path by
    /// the difference, at `k.of`'s speed. Returns the difference's size before the move, m
    /// (`None` when the world gives no geometry: the caller measures along the centreline).
    fn reach(&mut self, k: &Keep, world: &dyn WorldView) -> Option<f64> {
        let r = world.entity(&k.of)?;
        let [xr, yr, hr] = world.pose(&k.of)?;
        let [x0, y0, h0, kappa] = world.place(self.s, self.offset)?;
        let yaw = h0 + self.heading;
        let (c, sn) = (yaw.cos(), yaw.sin());
        let [rx, ry] = self.reference;
        let (xa, ya) = (x0 + c * rx - sn * ry, y0 + sn * rx + c * ry);
        // > 0: `of` is ahead along this entity's heading.
        let along = c * (xr - xa) + sn * (yr - ya);
        let distance = if k.freespace {
            let d = hr - yaw;
            let half = 0.5 * self.own_len.unwrap_or(r.length) + 0.5 * r.length * d.cos().abs() + 0.5 * r.width * d.sin().abs();
            (along.abs() - half).max(0.0).copysign(along)
        } else {
            along
        };
        let want = k.distance.unwrap_or_else(|| k.time_gap.unwrap_or(0.0) * r.speed).abs();
        let diff = distance - if k.ahead { -want } else { want };
        let scale = 1.0 - kappa * self.offset;
        let dir = if self.reversed { -1.0 } else { 1.0 };
        self.s += dir * if scale > 0.1 { diff / scale } else { diff };
        self.speed = r.speed;
        Some(diff.abs())
    }

    /// Puts the reference point where `k` wants it from `r` (distances between box centres,
    /// reference points taken to sit alike in both entities; between boxes with `freespace`),
    /// along the actor's driving direction; a time gap is taken times `v`.
    fn keep_at(&mut self, k: &Keep, r: &crate::trigger::EntityState, v: f64) {
        let mut d = k.distance.unwrap_or_else(|| k.time_gap.unwrap_or(0.0) * v);
        if k.freespace {
            d += 0.5 * r.length + 0.5 * self.own_len.unwrap_or(r.length);
        }
        let dir = if self.reversed { -1.0 } else { 1.0 };
        let centre = if k.ahead { r.s + dir * d } else { r.s - dir * d };
        self.s = centre - dir * self.reference[0];
    }

    fn start_lateral(&mut self, i: usize, to: f64, tr: &Transition, along_heading: bool, t0: f64) {
        let (by_distance, extent) = match tr.dimension {
            Dimension::Distance => (true, tr.value),
            // The peak lateral speed (esmini): the duration whose peak slope is `value`.
            Dimension::Rate => (false, tr.shape.peak_slope() * (to - self.offset).abs() / tr.value),
            Dimension::Time => (false, tr.value),
        };
        self.lat =
            Some(Lat { action: i, from: self.offset, to, shape: tr.shape, by_distance, extent, t0, x0: self.traveled, along_heading });
    }

    /// `step_len` m along the running spline (esmini's `MoveTrajectoryDS`); past its end the rest
    /// straight on along its last heading, and the action ends (`out.lat_done`).
    fn move_on_spline(&mut self, step_len: f64, out: &mut MotionStep) {
        let Some(tr) = self.spline.as_mut() else { return };
        let u_prev = tr.u.min(tr.length);
        tr.u += step_len;
        let mut p = tr.at(tr.u);
        if tr.u > tr.length - 1.0e-9 {
            let rest = (step_len - (tr.length - u_prev)).max(0.0);
            p[0] += rest * p[2].cos();
            p[1] += rest * p[2].sin();
            out.lat_done = Some(tr.action);
        }
        self.s = p[0];
        self.offset = p[1];
        self.heading = crate::track::wrap(p[2]);
        self.traveled += step_len;
        if out.lat_done.is_some() {
            self.spline = None;
            self.reversed = self.heading.abs() > std::f64::consts::FRAC_PI_2;
        }
    }

    /// Advances from `t` to `t + dt` on a centreline of curvature `curvature` (1/m, + left)
    /// here; `world` answers the speeds of relative targets.
    pub fn step(&mut self, t: f64, dt: f64, curvature: f64, world: &dyn WorldView) -> MotionStep {
        let mut out = MotionStep::default();
        let t1 = t + dt;
        let v_prev = self.speed;
        if let Some(tr) = &self.traj {
            let (s, offset, heading, seg_speed, ended) = tr.at(t1);
            // The speed is the step's displacement over the step (esmini: also a jump to where a
            // time offset puts the entity at the start), the segment's speed once it ends.
            let moved = (s - self.s).hypot(offset - self.offset);
            self.traveled += moved;
            let speed = if ended || dt <= 0.0 { seg_speed } else { moved / dt };
            (self.s, self.offset, self.heading, self.speed) = (s, offset, heading, speed);
            self.accel = if dt > 0.0 { (self.speed - v_prev) / dt } else { 0.0 };
            if ended {
                // esmini's default controller takes over: on along the road at that speed, in
                // the direction the heading faces, the heading kept.
                out.long_done = Some(tr.action);
                self.traj = None;
                self.hold_heading = true;
                self.reversed = crate::track::wrap(heading).abs() > std::f64::consts::FRAC_PI_2;
            }
            return out;
        }
        let long_action = self.long.as_ref().map(|l| l.action);
        // esmini steps actions in storyboard order: a trajectory before the speed action in that
        // order (an Init trajectory under a story's synchronisation) moves the entity first, at
        // the speed of the step before; the speed action then sees where it moved to.
        let spline_first = self.spline.as_ref().is_some_and(|tr| long_action.is_some_and(|a| tr.action < a));
        if spline_first {
            self.move_on_spline(v_prev * dt, &mut out);
        }
        if let Some(k) = self.long.as_ref().and_then(|l| l.keep.clone()) {
            // A kept distance: placed from `of` at the start of the step, at its speed, then
            // moved on with that speed (esmini's order).
            if let Some(off) = self.reach(&k, world) {
                if !k.continuous && off < REACHED_M {
                    out.long_done = long_action;
                }
            } else if let Some(r) = world.entity(&k.of) {
                self.keep_at(&k, &r, r.speed);
                self.speed = r.speed;
            }
        } else if let Some(mut y) = self.long.as_ref().and_then(|l| l.sync.clone()) {
            let done = self.sync_step(&mut y, dt, world, false);
            if let Some(l) = self.long.as_mut() {
                if done {
                    out.long_done = Some(l.action);
                } else {
                    l.sync = Some(y);
                }
            }
        } else if let Some(l) = &self.long {
            let p = if l.duration > 0.0 { (t1 - l.t0) / l.duration } else { 1.0 };
            let mut v = l.v0 + (l.v1 - l.v0) * l.shape.at(p);
            if p >= 1.0 - 1e-12 {
                v = l.v1;
                match &l.track {
                    Some((name, d, f)) => {
                        if let Some(e) = world.entity(name) {
                            v = e.speed * f + d;
                        }
                    }
                    None => out.long_done = Some(l.action),
                }
            }
            // A negative speed drives the entity backwards along its path, facing as it
            // faces (esmini 3.6.0; OpenSCENARIO's target speeds are any `Double`).
            self.speed = v;
        }
        if out.long_done.is_some() {
            self.long = None;
        }
        self.accel = if dt > 0.0 { (self.speed - v_prev) / dt } else { 0.0 };
        if spline_first {
            return out;
        }
        if self.spline.is_some() {
            self.move_on_spline(self.speed * dt, &mut out);
            return out;
        }
        let mut step_len = self.speed * dt;
        let offset_prev = self.offset;
        if let Some(l) = &self.lat {
            // esmini steps actions in storyboard order and a lane change moves the entity: a
            // lane change before the speed action in that order moves it at the speed of the
            // step before (the speed action sets the new one after it).
            if l.along_heading && long_action.is_some_and(|a| l.action < a) {
                step_len = v_prev * dt;
            }
        }
        let mut along = step_len;
        if let Some(l) = &self.lat {
            let p = if l.extent <= 0.0 || l.shape == Shape::Step {
                1.0
            } else if l.by_distance {
                (self.traveled + step_len.abs() - l.x0) / l.extent
            } else {
                (t1 - l.t0) / l.extent
            };
            self.offset = l.from + (l.to - l.from) * l.shape.at(p);
            if p >= 1.0 - 1e-12 {
                self.offset = l.to;
                out.lat_done = Some(l.action);
            }
            if l.along_heading {
                let d = self.offset - offset_prev;
                along = (step_len * step_len - d * d).max(0.0).sqrt().copysign(step_len);
            }
        }
        if out.lat_done.is_some() {
            self.lat = None;
        }
        // Along a curve the centreline moves `1 - kappa offset` times as fast as a point at
        // `offset`: the entity covers `along` on its own path.
        // A reversed entity runs the other way: `s` decreases, and its heading is pi less the
        // angle of its lateral motion.
        let scale = 1.0 - curvature * self.offset;
        let ds = if scale > 0.1 { along / scale } else { along };
        // Backwards (a negative speed) the entity still faces forward: the angle of its lateral
        // motion is taken against the distance covered, whichever way.
        let lateral = if ds.abs() > 1e-9 { ((self.offset - offset_prev) / ds.abs()).atan() } else { 0.0 };
        self.traveled += along.abs();
        if self.reversed {
            self.s -= ds;
            if !self.hold_heading {
                self.heading = crate::track::wrap(std::f64::consts::PI - lateral);
            }
        } else {
            self.s += ds;
            if !self.hold_heading {
                self.heading = lateral;
            }
        }
        out
    }
}

/// esmini's `CalcSpeedForLinearProfile`: the speed now that reaches `v_final` after `time` s
/// and `dist` m at constant acceleration (0 for a vanishing time or distance).
fn linear_profile_speed(v_final: f64, time: f64, dist: f64) -> f64 {
    if time < 0.001 || dist < 0.001 { 0.0 } else { 2.0 * dist / time - v_final }
}

/// Duration of a speed transition from `v0` to `v1`: `time` as given, `rate` = `|v1 - v0| /
/// rate` (infinite for a rate of 0 and a change), `distance` = the time that covers the distance at the mean speed `(v0 + v1) / 2`
/// (every shape is symmetric); 0 for a step.
fn speed_duration(tr: &Transition, v0: f64, v1: f64) -> f64 {
    if tr.shape == Shape::Step {
        return 0.0;
    }
    match tr.dimension {
        Dimension::Time => tr.value,
        // A rate of 0 (esmini): the speed never leaves `v0` (done at once if that is `v1`).
        Dimension::Rate if tr.value == 0.0 => {
            if v1 == v0 {
                0.0
            } else {
                f64::INFINITY
            }
        }
        Dimension::Rate => (v1 - v0).abs() / tr.value,
        Dimension::Distance => {
            let mean = 0.5 * (v0 + v1);
            if mean > 1e-9 { tr.value / mean } else { 0.0 }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(k0: f64, k1: f64, length: f64) -> ClothoidSegment {
        ClothoidSegment { curvature_start: k0, curvature_end: k1, length }
    }

    #[test]
    fn a_clothoid_segment_of_constant_curvature_is_a_circular_arc() {
        // A quarter circle of radius 100 m from the origin facing +x ends at (100, 100), facing +y.
        let r = 100.0;
        let p = clothoid_at([0.0, 0.0, 0.0], &seg(1.0 / r, 1.0 / r, r * std::f64::consts::FRAC_PI_2), r * std::f64::consts::FRAC_PI_2);
        assert!((p[0] - r).abs() < 1e-9 && (p[1] - r).abs() < 1e-9, "{p:?}");
        assert!((p[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-12, "{p:?}");
        // A clothoid from 0 to k over L turns by k L / 2.
        let q = clothoid_at([0.0, 0.0, 0.0], &seg(0.0, 0.02, 50.0), 50.0);
        assert!((q[2] - 0.5).abs() < 1e-12, "{q:?}");
    }

    #[test]
    fn a_trajectory_is_laid_from_the_actor_and_sampled_every_metre() {
        // An oncoming actor (heading pi) at s = 100, offset 1.75 turning left (curvature +) moves to
        // -s and to smaller offsets; the polyline has a vertex per metre and one at the end.
        let tr = Spline::new(0, &[seg(0.01, 0.01, 10.5)], 100.0, 1.75, std::f64::consts::PI);
        assert_eq!(tr.pts.len(), 11);
        let end = tr.pts[10];
        let (dx, dy) = (100.0 * (0.105f64).sin(), 100.0 * (1.0 - (0.105f64).cos()));
        assert!((end[0] - (100.0 - dx)).abs() < 1e-9 && (end[1] - (1.75 - dy)).abs() < 1e-9, "{end:?}");
        // Between vertices: linear; past the last vertex's parameter: the end.
        let mid = tr.at(2.5);
        let (a, b) = (tr.pts[2], tr.pts[3]);
        assert!((mid[0] - 0.5 * (a[0] + b[0])).abs() < 1e-12 && (mid[1] - 0.5 * (a[1] + b[1])).abs() < 1e-12);
        assert_eq!(tr.at(10.2), end);
    }
}
