//! The kinematic motion a story prescribes for one entity ([`Motion`]): position along the
//! centreline, lateral offset, speed, and the running longitudinal and lateral actions.

use super::{Action, Dimension, Shape, Transition};
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
        }
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
        hit
    }

    /// The lane index (0 = the centreline's lane, + left) an offset lies in.
    fn lane_of(&self, offset: f64) -> f64 {
        if self.lane_width > 0.0 { (offset / self.lane_width).round() } else { 0.0 }
    }

    /// Starts action `i` (`action`) at time `t`, reading reference entities from `world`.
    /// Returns the action of the same domain it replaces (to be ended as stopped), and whether
    /// the action already ended (a step transition, a placement). Non-motion actions do nothing.
    pub fn start(&mut self, i: usize, action: &Action, t: f64, world: &dyn WorldView) -> (Option<usize>, bool) {
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
                    });
                    return (replaced, false);
                }
                (replaced, true)
            }
            _ => (None, true),
        }
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
        self.speed = r.speed.max(0.0);
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

    /// Advances from `t` to `t + dt` on a centreline of curvature `curvature` (1/m, + left)
    /// here; `world` answers the speeds of relative targets.
    pub fn step(&mut self, t: f64, dt: f64, curvature: f64, world: &dyn WorldView) -> MotionStep {
        let mut out = MotionStep::default();
        let t1 = t + dt;
        let v_prev = self.speed;
        let long_action = self.long.as_ref().map(|l| l.action);
        if let Some(k) = self.long.as_ref().and_then(|l| l.keep.clone()) {
            // A kept distance: placed from `of` at the start of the step, at its speed, then
            // moved on with that speed (esmini's order).
            if let Some(off) = self.reach(&k, world) {
                if !k.continuous && off < REACHED_M {
                    out.long_done = long_action;
                }
            } else if let Some(r) = world.entity(&k.of) {
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
            self.heading = crate::track::wrap(std::f64::consts::PI - lateral);
        } else {
            self.s += ds;
            self.heading = lateral;
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
