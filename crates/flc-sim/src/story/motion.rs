//! The kinematic motion a story prescribes for one entity ([`Motion`]): position along the
//! centreline, lateral offset, speed, and the running longitudinal and lateral actions.

use super::{Action, Dimension, Shape, Transition, Vertex};
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
}

/// A continuous `LongitudinalDistanceAction`.
#[derive(Debug, Clone, PartialEq)]
struct Keep {
    of: String,
    distance: Option<f64>,
    time_gap: Option<f64>,
    freespace: bool,
    ahead: bool,
}

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
    long: Option<Long>,
    lat: Option<Lat>,
    traj: Option<Traj>,
    /// The heading is kept (after a trajectory, until a lateral action starts) instead of
    /// following the lateral motion.
    hold_heading: bool,
    /// It reached an end of the road ([`Motion::end_of_road`]).
    at_end: bool,
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
            long: None,
            lat: None,
            traj: None,
            hold_heading: false,
            at_end: false,
        }
    }

    /// Keeps the entity on a road `length` m long, as esmini's default controller does at a
    /// road's end: a step that would leave `[0, length]` stops it at the end; a step that
    /// starts there (`s_before`, within 1 µm) and would leave again marks the end reached (its
    /// speed still reported), and from the next step on it stands there (speed 0) whatever its
    /// actions. A running trajectory places the entity itself.
    pub fn end_of_road(&mut self, s_before: f64, length: f64, dt: f64) {
        const EPS: f64 = 1e-6;
        if self.traj.is_some() || length.is_nan() || length <= 0.0 {
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

    /// This motion for an entity `length` m long (freespace placements).
    pub fn with_length(mut self, length: f64) -> Self {
        self.own_len = Some(length);
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
        hit
    }

    /// The lane index (0 = the centreline's lane, + left) an offset lies in.
    fn lane_of(&self, offset: f64) -> f64 {
        if self.lane_width > 0.0 { (offset / self.lane_width).round() } else { 0.0 }
    }

    /// Starts action `i` (`action`) at time `t`, reading reference entities from `world`.
    /// Returns the action of the same domain it replaces (to be ended as stopped), and whether
    /// the action already ended (a step transition, a placement). Non-motion actions do nothing.
    pub fn start(&mut self, i: usize, action: &Action, t: f64, world: &dyn WorldView) -> (Vec<usize>, bool) {
        // A motion action ends a running trajectory (it holds both domains).
        let mut replaced: Vec<usize> = Vec::new();
        if action.is_longitudinal() || action.is_lateral() {
            replaced.extend(self.traj.take().map(|x| x.action).filter(|&a| a != i));
        }
        if action.is_lateral() {
            self.hold_heading = false;
        }
        if let Action::Trajectory { absolute, vertices } = action {
            replaced.extend(self.long.take().map(|l| l.action).filter(|&a| a != i));
            replaced.extend(self.lat.take().map(|l| l.action).filter(|&a| a != i));
            self.traj = Some(Traj { action: i, t0: if *absolute { 0.0 } else { t }, vertices: vertices.clone() });
            return (replaced, false);
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
                            v.max(0.0),
                            continuous
                                .then(|| (name.clone(), if factor.is_some() { 0.0 } else { d }, if factor.is_some() { f } else { 1.0 })),
                        )
                    }
                    (None, None) => (self.speed, None),
                };
                let duration = speed_duration(transition, self.speed, target);
                self.long =
                    Some(Long { action: i, v0: self.speed, v1: target, shape: transition.shape, duration, t0: t, track, keep: None });
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
                let centre = self.lane_of(self.offset) * self.lane_width;
                let base = match of {
                    Some(name) => world.entity(name).map_or(0.0, |e| e.lateral - self.lane_of(e.lateral) * self.lane_width),
                    None => 0.0,
                };
                let to = centre + base + offset;
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
                let keep = Keep { of: of.clone(), distance: *distance, time_gap: *time_gap, freespace: *freespace, ahead: *ahead };
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
                    });
                    return (replaced, false);
                }
                (replaced, true)
            }
            _ => (None, true),
        }
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
        if let Some(k) = self.long.as_ref().and_then(|l| l.keep.clone()) {
            // A kept distance: placed from `of` at the start of the step, at its speed, then
            // moved on with that speed (esmini's order).
            if let Some(r) = world.entity(&k.of) {
                self.keep_at(&k, &r, r.speed);
                self.speed = r.speed.max(0.0);
            }
        } else if let Some(l) = &self.long {
            let p = if l.duration > 0.0 { (t1 - l.t0) / l.duration } else { 1.0 };
            let mut v = l.v0 + (l.v1 - l.v0) * l.shape.at(p);
            if p >= 1.0 - 1e-12 {
                v = l.v1;
                match &l.track {
                    Some((name, d, f)) => {
                        if let Some(e) = world.entity(name) {
                            v = (e.speed * f + d).max(0.0);
                        }
                    }
                    None => out.long_done = Some(l.action),
                }
            }
            self.speed = v.max(0.0);
        }
        if out.long_done.is_some() {
            self.long = None;
        }
        self.accel = if dt > 0.0 { (self.speed - v_prev) / dt } else { 0.0 };
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
                (self.traveled + step_len - l.x0) / l.extent
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
                along = (step_len * step_len - d * d).max(0.0).sqrt();
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
        let lateral = if ds > 1e-9 { ((self.offset - offset_prev) / ds).atan() } else { 0.0 };
        self.traveled += along;
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
