//! The rapier2d world: vehicles as kinematic bodies with cuboid colliders, road-side clutter as
//! fixed colliders. Motion comes from the vehicle models ([`crate::vehicle`]); rapier provides
//! contact detection (collisions) and ray casts (the LiDAR).

use rapier2d::prelude::*;

use crate::track::{RoadsideObject, Track};
use crate::vehicle::{VehicleParams, VehicleState};

/// A vehicle in the world.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Body {
    body: RigidBodyHandle,
    collider: ColliderHandle,
}

/// One side of a [`Contact`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Party {
    /// A vehicle added with [`World::add_vehicle`].
    Vehicle(Body),
    /// A road-side object: index into the track's `objects`.
    Static(usize),
}

/// Two colliders touching (penetration depth >= 0) after a step, as reported by rapier's narrow
/// phase. At least one side is a vehicle (`a` for vehicle-object contacts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// First side (always a vehicle).
    pub a: Party,
    /// Second side.
    pub b: Party,
    /// Penetration depth, m (>= 0).
    pub depth: f64,
    /// Contact normal, world frame, unit, pointing from `a` towards `b`.
    pub normal: [f64; 2],
    /// The deepest contact point on `a`'s surface, world frame, m.
    pub point: [f64; 2],
}

impl Contact {
    /// `true` if `body` is one of the two.
    pub fn involves(&self, body: Body) -> bool {
        self.a == Party::Vehicle(body) || self.b == Party::Vehicle(body)
    }

    /// The other side of a contact that involves `body`, with the normal pointing from `body`
    /// towards it (`None` if `body` is not in it).
    pub fn seen_from(&self, body: Body) -> Option<(Party, [f64; 2])> {
        let [nx, ny] = self.normal;
        if self.a == Party::Vehicle(body) {
            Some((self.b, self.normal))
        } else if self.b == Party::Vehicle(body) {
            Some((self.a, [-nx, -ny]))
        } else {
            None
        }
    }
}

/// What rapier's narrow phase knows about one touching pair, seen from `first`: depth, normal
/// (from `first` towards the other), deepest point on `first`.
struct Touch {
    depth: f64,
    normal: [f64; 2],
    point: [f64; 2],
}

/// Longest straight guard-rail piece, m (fewer, longer pieces make ray casts cheaper).
const RAIL_PIECE_MAX: f64 = 200.0;
/// Guard rails along curves are split at least every this many metres.
const RAIL_PIECE_CURVED: f64 = 6.0;

/// Splits `[from_s, to_s]` into pieces along which the centreline is straight (merged up to
/// [`RAIL_PIECE_MAX`]) or short enough to follow a curve ([`RAIL_PIECE_CURVED`]).
fn rail_pieces(track: &Track, from_s: f64, to_s: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut s0 = from_s;
    while s0 < to_s {
        let (_, _, h0) = track.pose_at(s0);
        let mut s1 = (s0 + RAIL_PIECE_CURVED).min(to_s);
        // Extend while the heading stays the same.
        while s1 < to_s && s1 - s0 < RAIL_PIECE_MAX {
            let next = (s1 + 1.0).min(to_s);
            let (_, _, h) = track.pose_at(next - 1e-6);
            if (crate::track::wrap(h - h0)).abs() > 1e-9 {
                break;
            }
            s1 = next;
        }
        out.push((s0, s1));
        s0 = s1;
    }
    out
}

fn pose(x: f64, y: f64, yaw: f64) -> Pose {
    Pose::new(Vector::new(x as f32, y as f32), yaw as f32)
}

/// A fan of rays from one origin (see [`World::cast_fan`]).
#[derive(Debug, Clone, Copy)]
pub struct RayFan<'a> {
    /// Origin, world frame, m.
    pub origin: [f64; 2],
    /// Angle the ray angles are relative to (world frame), rad.
    pub base: f64,
    /// Ray angles relative to `base`, ascending, rad.
    pub angles: &'a [f64],
    /// World-frame unit vector of each ray, in parry's f32.
    pub unit: &'a [Vector],
}

/// A ray's unit direction from its f64 components, in parry's f32 (as [`RayFan::unit`] holds it).
pub(crate) fn f32_dir(c: f64, s: f64) -> Vector {
    Vector::new(c as f32, s as f32)
}

/// The physics world.
pub struct World {
    pw: PhysicsWorld,
    vehicles: Vec<Body>,
}

impl World {
    /// A world with the track's road-side objects as fixed colliders.
    pub fn new(track: &Track) -> Self {
        let mut pw = PhysicsWorld::new();
        pw.gravity = Vector::ZERO;
        // Exact contact state every step: no reuse of manifolds while poses drift slightly.
        pw.integration_parameters.contact_recycling = false;
        // No incremental re-balancing of the broad-phase tree: with many moving vehicles (a
        // platoon) rapier would re-optimise it at every step (about 4 % of a 16-vehicle run); the
        // queries here are one sector box per scan and one pair search per step, and contacts and
        // ray hits do not depend on the tree's shape (same results, `fan_casting_*` tests).
        pw.broad_phase = BroadPhaseBvh::with_optimization_strategy(BvhOptimizationStrategy::None);
        let place = |s: f64, offset: f64| track.place(s, offset);
        for (index, o) in track.objects.iter().enumerate() {
            // The object's index travels with its colliders (reported in contacts).
            let tag = index as u128;
            match *o {
                RoadsideObject::GuardRail { offset, from_s, to_s } => {
                    for (s0, s1) in rail_pieces(track, from_s, to_s) {
                        let (x0, y0, _) = place(s0, offset);
                        let (x1, y1, _) = place(s1, offset);
                        let len = (x1 - x0).hypot(y1 - y0);
                        if len > 1e-3 {
                            let c = ColliderBuilder::cuboid((len / 2.0 + 0.05) as f32, 0.1)
                                .position(pose((x0 + x1) / 2.0, (y0 + y1) / 2.0, (y1 - y0).atan2(x1 - x0)))
                                .user_data(tag);
                            pw.insert_collider(c, None);
                        }
                    }
                }
                RoadsideObject::Post { s, offset, radius, .. } => {
                    let (x, y, _) = place(s, offset);
                    pw.insert_collider(ColliderBuilder::ball(radius as f32).position(pose(x, y, 0.0)).user_data(tag), None);
                }
                RoadsideObject::ParkedCar { s, offset, heading_offset, .. } => {
                    let (x, y, h) = place(s, offset);
                    pw.insert_collider(ColliderBuilder::cuboid(2.35, 0.9).position(pose(x, y, h + heading_offset)).user_data(tag), None);
                }
            }
        }
        Self { pw, vehicles: Vec::new() }
    }

    /// Adds a vehicle (kinematic body, cuboid collider `length x width`) at `state`.
    pub fn add_vehicle(&mut self, params: &VehicleParams, state: &VehicleState) -> Body {
        let rb = RigidBodyBuilder::kinematic_position_based().pose(pose(state.x, state.y, state.yaw));
        let col = ColliderBuilder::cuboid((params.length / 2.0) as f32, (params.width / 2.0) as f32)
            .active_collision_types(
                ActiveCollisionTypes::default() | ActiveCollisionTypes::KINEMATIC_KINEMATIC | ActiveCollisionTypes::KINEMATIC_FIXED,
            )
            .active_events(ActiveEvents::COLLISION_EVENTS);
        let (body, collider) = self.pw.insert(rb, col);
        let b = Body { body, collider };
        self.vehicles.push(b);
        b
    }

    /// Takes a vehicle out of the scene: its collider is removed (no ray hits it, it touches
    /// nothing); its handle stays valid for [`World::set_pose`], which then moves nothing seen.
    pub fn remove_vehicle(&mut self, body: Body) {
        self.pw.remove_collider(body.collider);
        self.vehicles.retain(|v| *v != body);
    }

    /// Moves a vehicle's body to `state` (takes effect for contacts at the next [`World::step`]).
    pub fn set_pose(&mut self, body: Body, state: &VehicleState) {
        if let Some(rb) = self.pw.bodies.get_mut(body.body) {
            rb.set_position(pose(state.x, state.y, state.yaw), true);
        }
    }

    /// Runs rapier's collision pipeline (broad + narrow phase) on the current poses; there is
    /// nothing to integrate, since motion comes from the vehicle models. Returns every touching
    /// pair that involves a vehicle.
    pub fn step(&mut self, dt: f64) -> Vec<Contact> {
        self.pw.integration_parameters.dt = dt as f32;
        self.pw.detect_collisions(&(), &());
        let mut out = Vec::new();
        for (i, v) in self.vehicles.iter().enumerate() {
            // Vehicle-vehicle pairs (each once) ...
            for w in self.vehicles.iter().skip(i + 1) {
                if let Some(t) = self.touch(v.collider, w.collider) {
                    out.push(Contact { a: Party::Vehicle(*v), b: Party::Vehicle(*w), depth: t.depth, normal: t.normal, point: t.point });
                }
            }
        }
        // ... and vehicle-clutter pairs.
        let vehicle = |h: ColliderHandle| self.vehicles.iter().find(|v| v.collider == h).copied();
        for pair in self.pw.narrow_phase.contact_pairs() {
            let (a, b) = (pair.collider1, pair.collider2);
            let (v, other) = match (vehicle(a), vehicle(b)) {
                (Some(v), None) => (v, b),
                (None, Some(v)) => (v, a),
                _ => continue,
            };
            if let Some(t) = self.touch_of(pair, v.collider) {
                // The object's index in `track.objects` (every piece of a guard rail carries it).
                let object = self.pw.colliders.get(other).map_or(usize::MAX, |co| co.user_data as usize);
                out.push(Contact { a: Party::Vehicle(v), b: Party::Static(object), depth: t.depth, normal: t.normal, point: t.point });
            }
        }
        out
    }

    /// The contact of two colliders seen from `a`, if rapier's narrow phase has them touching.
    fn touch(&self, a: ColliderHandle, b: ColliderHandle) -> Option<Touch> {
        self.touch_of(self.pw.narrow_phase.contact_pair(a, b)?, a)
    }

    /// The deepest contact of `pair` seen from its collider `first` (depth >= 0), world frame:
    /// rapier keeps the normal and points in the frames of the pair's colliders.
    fn touch_of(&self, pair: &ContactPair, first: ColliderHandle) -> Option<Touch> {
        let (m, c) = pair.find_deepest_contact()?;
        if c.dist > 0.0 {
            return None;
        }
        let co1 = self.pw.colliders.get(pair.collider1)?;
        let n = co1.position().rotation * m.local_n1;
        let (sign, p) = if first == pair.collider1 {
            (1.0, co1.position().transform_point(c.local_p1))
        } else {
            (-1.0, self.pw.colliders.get(pair.collider2)?.position().transform_point(c.local_p2))
        };
        let (n, p) = ([sign * f64::from(n.x), sign * f64::from(n.y)], [f64::from(p.x), f64::from(p.y)]);
        Some(Touch { depth: -f64::from(c.dist), normal: n, point: p })
    }

    /// Casts a ray from `origin` along the unit vector `dir` (world frame) up to `max_range`,
    /// ignoring `exclude` (the ego vehicle). Returns the hit distance.
    pub fn cast_ray(&self, origin: [f64; 2], dir: [f64; 2], max_range: f64, exclude: Body) -> Option<f64> {
        let ray = Ray::new(Vector::new(origin[0] as f32, origin[1] as f32), Vector::new(dir[0] as f32, dir[1] as f32));
        let filter = QueryFilter::default().exclude_rigid_body(exclude.body);
        self.pw.cast_ray(&ray, max_range as f32, true, filter).map(|(_, toi)| f64::from(toi))
    }

    /// Casts a fan of rays from one origin: ray `i` points at `base + angles[i]` (world frame,
    /// `angles` ascending within [-pi, pi], `unit[i]` its world-frame unit vector); `hits[i]`
    /// receives the nearest hit distance or `None`. Same result as [`World::cast_ray`] per ray.
    ///
    /// Rapier's query pipeline (BVH) gathers the colliders whose boxes meet the fan's sector (ego
    /// excluded); each is then ray-cast by parry only for the rays inside its angular extent (exact
    /// for cuboids and balls), which makes a scan cost about one shape test per ray instead of a
    /// BVH descent per ray.
    pub fn cast_fan(&self, fan: &RayFan<'_>, max_range: f64, exclude: Body, hits: &mut Vec<Option<f64>>) {
        let mut best = Vec::new();
        self.cast_fan_f32(fan, max_range, exclude, &mut best);
        hits.clear();
        hits.extend(best.iter().map(|&b| (b != NO_HIT).then_some(f64::from(b))));
    }

    /// [`World::cast_fan`] into an `f32` buffer (parry's precision), [`NO_HIT`] for no return: the
    /// LiDAR's hot loop, without an `Option` and an `f64 -> f32` conversion per ray and collider.
    pub(crate) fn cast_fan_f32(&self, fan: &RayFan<'_>, max_range: f64, exclude: Body, hits: &mut Vec<f32>) {
        use rapier2d::parry::bounding_volume::Aabb;
        use std::f64::consts::{FRAC_PI_2, TAU};
        let RayFan { origin, base, angles, unit } = *fan;
        hits.clear();
        hits.resize(angles.len(), NO_HIT);
        let (Some(&a_first), Some(&a_last)) = (angles.first(), angles.last()) else { return };
        let filter = QueryFilter::default().exclude_rigid_body(exclude.body);
        let qp = self.pw.query_pipeline_with_filter(filter);
        let o = Vector::new(origin[0] as f32, origin[1] as f32);
        let r = max_range as f32;
        // Bounding box of the sector: origin, both edge rays' ends and the axis directions inside.
        let (mut lo, mut hi) = (o, o);
        let mut include = |a: f64| {
            let p = o + Vector::new((a.cos() * max_range) as f32, (a.sin() * max_range) as f32);
            lo = lo.min(p);
            hi = hi.max(p);
        };
        include(base + a_first);
        include(base + a_last);
        for k in 0..4 {
            let axis = f64::from(k) * FRAC_PI_2;
            let rel = crate::track::wrap(axis - base);
            if [rel - TAU, rel, rel + TAU].iter().any(|a| (a_first..=a_last).contains(a)) {
                include(axis);
            }
        }
        let region = Aabb::new(lo - Vector::splat(0.01), hi + Vector::splat(0.01));
        for (_, co) in qp.intersect_aabb_conservative(region) {
            let (lo, hi) = angular_extent(co, origin, base);
            // Cuboids (vehicles, rails, parked cars): parry's `cast_ray` is `cast_local_ray` on the
            // ray moved into the shape's frame; the origin's image is the same for every ray of
            // the fan, so it is computed once (same operations, same result).
            let pos = co.position();
            let local = co.shape().as_cuboid().map(|c| {
                let lo_origin = pos.inverse_transform_point(o);
                LocalBox { near: -c.half_extents - lo_origin, far: c.half_extents - lo_origin, inv_rot: pos.rotation.inverse() }
            });
            for shift in [-TAU, 0.0, TAU] {
                let (l, h) = (lo + shift - ANGLE_SLACK, hi + shift + ANGLE_SLACK);
                if h < a_first || l > a_last {
                    continue;
                }
                let first = angles.partition_point(|&a| a < l);
                let last = angles.partition_point(|&a| a <= h);
                let (Some(dirs), Some(slots)) = (unit.get(first..last), hits.get_mut(first..last)) else { continue };
                let rays = dirs.iter().copied().zip(slots);
                // The cast's `max_toi` is the nearest hit so far, `r` before the first (`NO_HIT` is
                // infinite, every hit is <= r: `min(slot, r)`, written as a compare).
                match &local {
                    Some(b) => {
                        for (dir, slot) in rays {
                            if let Some(toi) = b.cast(b.inv_rot * dir, if *slot < r { *slot } else { r }) {
                                *slot = toi;
                            }
                        }
                    }
                    None => {
                        for (dir, slot) in rays {
                            if let Some(toi) = co.shape().cast_ray(pos, &Ray::new(o, dir), if *slot < r { *slot } else { r }, true) {
                                *slot = toi;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// A cuboid seen from a fan's origin, in the cuboid's frame: the slab offsets `mins - origin` and
/// `maxs - origin` are the same for every ray of the fan.
struct LocalBox {
    near: Vector,
    far: Vector,
    inv_rot: rapier2d::parry::math::Rotation,
}

impl LocalBox {
    /// parry's `Aabb::cast_local_ray(ray, max_toi, solid = true)` (slab test, `parry2d` 0.31,
    /// `query/ray/ray_aabb.rs`) for the fan's ray along the local direction `dir`, with the
    /// per-fan terms precomputed: the same f32 operations in the same order, so the same result
    /// bit for bit (tested against parry in `fan_casting_equals_one_ray_cast_per_ray*`).
    #[inline]
    fn cast(&self, dir: Vector, max_toi: f32) -> Option<f32> {
        let (mut tmin, mut tmax) = (0.0f32, max_toi);
        for (d, near, far) in [(dir.x, self.near.x, self.far.x), (dir.y, self.near.y, self.far.y)] {
            if d == 0.0 {
                // Parallel to this slab: no hit unless inside it (`o < mins` iff `mins - o > 0`).
                if near > 0.0 || far < 0.0 {
                    return None;
                }
            } else {
                let denom = 1.0 / d;
                let (mut a, mut b) = (near * denom, far * denom);
                if a > b {
                    std::mem::swap(&mut a, &mut b);
                }
                // `tmin.max(a)` and `tmax.min(b)` as parry writes them, as compares: the same value
                // for every input that can occur (`tmin`, `tmax` are never NaN; a NaN `a` or `b`
                // keeps the other, as `max` / `min` do), one instruction each instead of the
                // NaN-aware sequence. Equal values differ at most in the sign of a zero, which
                // no consumer distinguishes (a range of -0 and +0 give the same point).
                if a > tmin {
                    tmin = a;
                }
                if b < tmax {
                    tmax = b;
                }
                if tmin > tmax {
                    return None;
                }
            }
        }
        Some(tmin)
    }
}

/// "No return" in [`World::cast_fan_f32`]'s buffer.
pub(crate) const NO_HIT: f32 = f32::INFINITY;

/// Angular margin added to each collider's extent in [`World::cast_fan`], rad: covers f32
/// rounding of the shapes (1e-4 m at 1 km from the origin is 1e-7 rad at 1 m range).
const ANGLE_SLACK: f64 = 2e-4;

/// Directions (relative to `base`, rad, `lo <= hi`, `hi - lo < pi` unless the whole circle) under
/// which a collider is seen from `origin`: exact for cuboids and balls, the bounding box's for
/// other shapes, the whole circle when the origin is inside or within 1 cm of the shape.
fn angular_extent(co: &Collider, origin: [f64; 2], base: f64) -> (f64, f64) {
    use std::f64::consts::PI;
    let pos = co.position();
    let shape = co.shape();
    let o = Vector::new(origin[0] as f32, origin[1] as f32);
    if shape.distance_to_point(pos, o, true) < 0.01 {
        return (-PI, PI);
    }
    let rel = |x: f32, y: f32| crate::track::wrap((f64::from(y) - origin[1]).atan2(f64::from(x) - origin[0]) - base);
    if let Some(ball) = shape.as_ball() {
        let c = pos.translation;
        let d = (f64::from(c.x) - origin[0]).hypot(f64::from(c.y) - origin[1]);
        let half = (f64::from(ball.radius) / d).min(1.0).asin();
        let a = rel(c.x, c.y);
        return (a - half, a + half);
    }
    let corners = if let Some(cuboid) = shape.as_cuboid() {
        let h = cuboid.half_extents;
        [(-h.x, -h.y), (h.x, -h.y), (h.x, h.y), (-h.x, h.y)].map(|(x, y)| pos.transform_point(Vector::new(x, y)))
    } else {
        let bb = co.compute_aabb();
        [bb.mins, Vector::new(bb.maxs.x, bb.mins.y), bb.maxs, Vector::new(bb.mins.x, bb.maxs.y)]
    };
    // A convex shape seen from outside spans less than pi: unwrap around the first corner.
    let a0 = rel(corners[0].x, corners[0].y);
    corners.iter().map(|c| a0 + crate::track::wrap(rel(c.x, c.y) - a0)).fold((a0, a0), |(l, h), a| (l.min(a), h.max(a)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn empty() -> World {
        World::new(&Track::new("t", vec![[0.0, 0.0], [1000.0, 0.0]], 3.5, vec![]))
    }

    #[test]
    fn vehicles_driven_into_each_other_collide_at_the_right_step() {
        let mut w = empty();
        let p = VehicleParams::default();
        let a_state = VehicleState { x: 0.0, ..Default::default() };
        let b_state = VehicleState { x: 10.0, ..Default::default() };
        let a = w.add_vehicle(&p, &a_state);
        let b = w.add_vehicle(&p, &b_state);
        // Gap 10 - 4.9 = 5.1 m closed by 1 cm per step: contact at step 510 (f32 rounding: +-1).
        let mut first = None;
        for k in 1..=600 {
            let s = VehicleState { x: 0.01 * k as f64, ..Default::default() };
            w.set_pose(a, &s);
            w.set_pose(b, &b_state);
            let contacts = w.step(0.01);
            if let Some(c) = contacts.iter().find(|c| c.involves(a) && c.involves(b)) {
                // Normal from a towards b (+x), the point on the faces at x = 0.01 k + 2.45.
                let (other, n) = c.seen_from(a).expect("involves a");
                assert_eq!(other, Party::Vehicle(b));
                assert!((n[0] - 1.0).abs() < 1e-4 && n[1].abs() < 1e-4, "{n:?}");
                assert_eq!(c.seen_from(b).map(|(_, m)| m), Some([-n[0], -n[1]]));
                assert!((c.point[0] - (0.01 * k as f64 + 2.45)).abs() < 0.02 && c.point[1].abs() <= 0.951, "{:?}", c.point);
                first = Some(k);
                break;
            }
        }
        let k = first.expect("no collision reported");
        assert!((509..=511).contains(&k), "collision at step {k}");
    }

    #[test]
    fn vehicle_driven_into_the_guard_rail_touches_it_at_the_right_step() {
        // Straight track: objects[0] is the right guard rail at -3.25 m (0.1 m half thickness,
        // face at y = -3.15); posts at x = 25, 75, ...; the body (half width 0.95 m) at x = 50
        // moves right by 1 cm per step: contact when y <= -2.2, at step 220.
        let track = Track::straight(500.0);
        let mut w = World::new(&track);
        let p = VehicleParams::default();
        let v = w.add_vehicle(&p, &VehicleState { x: 50.0, ..Default::default() });
        let mut first = None;
        for k in 1..=300 {
            w.set_pose(v, &VehicleState { x: 50.0, y: -0.01 * k as f64, ..Default::default() });
            let contacts = w.step(0.01);
            if let Some(c) = contacts.first() {
                assert!(c.involves(v));
                assert_eq!(c.b, Party::Static(0));
                // Normal from the vehicle to the rail (-y), the point on the rail's face.
                assert!(c.normal[0].abs() < 1e-4 && (c.normal[1] + 1.0).abs() < 1e-4, "{:?}", c.normal);
                assert!((c.point[1] + 3.15).abs() < 0.02 && (c.point[0] - 50.0).abs() <= 2.46, "{:?}", c.point);
                assert!(matches!(track.objects[0], RoadsideObject::GuardRail { offset, .. } if offset < 0.0));
                first = Some(k);
                break;
            }
        }
        let k = first.expect("no contact with the guard rail");
        assert!((219..=221).contains(&k), "contact at step {k}");
    }

    #[test]
    fn rays_hit_roadside_objects_where_the_track_places_them() {
        let track = Track::straight(1000.0);
        let mut w = World::new(&track);
        let ego = w.add_vehicle(&VehicleParams::default(), &VehicleState { x: 280.0, y: 3.5, ..Default::default() });
        w.step(0.01);
        // Parked car at s = 300 in the left lane (offset 3.5 m), 4.7 m long: rear face at 297.65.
        let r = w.cast_ray([290.0, 3.5], [1.0, 0.0], 100.0, ego).expect("parked car");
        assert!((r - 7.65).abs() < 1e-3, "{r}");
        // Straight down from the lane centre: the right guard rail's face at y = -3.15.
        let r = w.cast_ray([290.0, 0.0], [0.0, -1.0], 100.0, ego).expect("guard rail");
        assert!((r - 3.15).abs() < 1e-3, "{r}");
        // Nothing along the road within 100 m from x = 500 in the right lane (next parked car at
        // s = 900 is in the left lane).
        assert_eq!(w.cast_ray([500.0, 0.0], [1.0, 0.0], 100.0, ego), None);
    }

    #[test]
    fn fan_casting_equals_one_ray_cast_per_ray() {
        // Curvy track (rails in short pieces along the arcs, posts) plus a lead and the ego, at
        // several poses, forward fans and a full circle: the fan must give exactly what casting
        // each ray through the query pipeline gives.
        let track = Track::curvy();
        let mut w = World::new(&track);
        let p = VehicleParams::default();
        let ego_state = VehicleState::default();
        let ego = w.add_vehicle(&p, &ego_state);
        let lead = w.add_vehicle(&p, &ego_state);
        let mut hits = Vec::new();
        for s in [5.0, 230.0, 420.0, 700.0, 1100.0, 1500.0] {
            let (x, y, h) = track.pose_at(s);
            let (lx, ly, lh) = track.pose_at(s + 25.0);
            w.set_pose(ego, &VehicleState { x, y, yaw: h, ..Default::default() });
            w.set_pose(lead, &VehicleState { x: lx, y: ly, yaw: lh, ..Default::default() });
            w.step(0.01);
            for (fov, n) in [(120f64.to_radians(), 961), (std::f64::consts::TAU - 1e-3, 2001)] {
                let angles: Vec<f64> = (0..n).map(|i| -fov / 2.0 + fov * i as f64 / (n - 1) as f64).collect();
                let unit: Vec<[f64; 2]> = angles.iter().map(|a| [(h + a).cos(), (h + a).sin()]).collect();
                let unit32: Vec<Vector> = unit.iter().map(|d| f32_dir(d[0], d[1])).collect();
                let origin = [x + 2.0 * h.cos(), y + 2.0 * h.sin()];
                w.cast_fan(&RayFan { origin, base: h, angles: &angles, unit: &unit32 }, 100.0, ego, &mut hits);
                assert_eq!(hits.len(), n);
                let mut seen = 0;
                for (d, hit) in unit.iter().zip(&hits) {
                    let single = w.cast_ray(origin, *d, 100.0, ego);
                    match (hit, single) {
                        (Some(a), Some(b)) => assert!((a - b).abs() < 1e-4, "s {s}: {a} vs {b}"),
                        (None, None) => {}
                        other => panic!("s {s}: fan {:?} vs single {:?}", other.0, other.1),
                    }
                    seen += usize::from(hit.is_some());
                }
                assert!(seen > 0, "s {s}: nothing in view");
            }
        }
    }

    #[test]
    fn fan_casting_equals_one_ray_cast_per_ray_at_random_poses() {
        // Random origins on and beside both preset tracks (also just behind rails, next to posts
        // and parked cars), random headings and fields of view.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for track in [Track::straight(2000.0), Track::curvy()] {
            let mut w = World::new(&track);
            let p = VehicleParams::default();
            let ego = w.add_vehicle(&p, &VehicleState::default());
            let lead = w.add_vehicle(&p, &VehicleState::default());
            let mut hits = Vec::new();
            for _ in 0..150 {
                let s = rng.random_range(0.0..track.length());
                let (x, y, h) = track.pose_at(s);
                let off = rng.random_range(-8.0..8.0);
                let (ox, oy) = (x - off * h.sin(), y + off * h.cos());
                let (lx, ly, lh) = track.pose_at(s + rng.random_range(3.0..60.0));
                w.set_pose(ego, &VehicleState { x: ox, y: oy, yaw: h, ..Default::default() });
                w.set_pose(lead, &VehicleState { x: lx, y: ly, yaw: lh, ..Default::default() });
                w.step(0.01);
                let base = h + rng.random_range(-3.0..3.0);
                let fov: f64 = rng.random_range(0.1..std::f64::consts::TAU);
                let n = 721;
                let angles: Vec<f64> = (0..n).map(|i| -fov / 2.0 + fov * i as f64 / (n - 1) as f64).collect();
                let unit: Vec<[f64; 2]> = angles.iter().map(|a| [(base + a).cos(), (base + a).sin()]).collect();
                let unit32: Vec<Vector> = unit.iter().map(|d| f32_dir(d[0], d[1])).collect();
                w.cast_fan(&RayFan { origin: [ox, oy], base, angles: &angles, unit: &unit32 }, 100.0, ego, &mut hits);
                for (d, hit) in unit.iter().zip(&hits) {
                    let single = w.cast_ray([ox, oy], *d, 100.0, ego);
                    match (hit, single) {
                        (Some(a), Some(b)) => assert!((a - b).abs() < 1e-4, "s {s} off {off}: {a} vs {b}"),
                        (None, None) => {}
                        other => panic!("s {s} off {off}: fan {:?} vs single {:?}", other.0, other.1),
                    }
                }
            }
        }
    }

    /// The fan's ray casts before the per-fan cuboid terms: parry's `cast_ray` per ray and
    /// collider, nearest hit kept (reference for `fan_casting_is_bit_identical_to_parry`).
    fn cast_fan_reference(w: &World, fan: &RayFan<'_>, max_range: f64, exclude: Body) -> Vec<Option<f64>> {
        let filter = QueryFilter::default().exclude_rigid_body(exclude.body);
        let qp = w.pw.query_pipeline_with_filter(filter);
        let o = Vector::new(fan.origin[0] as f32, fan.origin[1] as f32);
        let mut hits = vec![None; fan.angles.len()];
        let everything = rapier2d::parry::bounding_volume::Aabb::new(Vector::splat(-1e6), Vector::splat(1e6));
        for (_, co) in qp.intersect_aabb_conservative(everything) {
            for (d, slot) in fan.unit.iter().zip(hits.iter_mut()) {
                let ray = Ray::new(o, *d);
                let best = slot.map_or(max_range as f32, |b: f64| b as f32);
                if let Some(toi) = co.shape().cast_ray(co.position(), &ray, best, true) {
                    *slot = Some(f64::from(toi));
                }
            }
        }
        hits
    }

    #[test]
    fn fan_casting_is_bit_identical_to_parry() {
        // The fan's own slab test for cuboids must give exactly parry's numbers (the closed loop's
        // results depend on every bit of them).
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for track in [Track::straight(2000.0), Track::curvy()] {
            let mut w = World::new(&track);
            let p = VehicleParams::default();
            let ego = w.add_vehicle(&p, &VehicleState::default());
            let others: Vec<Body> = (0..3).map(|_| w.add_vehicle(&p, &VehicleState::default())).collect();
            let mut hits = Vec::new();
            for _ in 0..60 {
                let s = rng.random_range(0.0..track.length() - 100.0);
                let (x, y, h) = track.pose_at(s);
                w.set_pose(ego, &VehicleState { x, y, yaw: h + rng.random_range(-0.2..0.2), ..Default::default() });
                for (k, b) in others.iter().enumerate() {
                    let (lx, ly, lh) = track.pose_at(s + 8.0 + 25.0 * k as f64 + rng.random_range(0.0..10.0));
                    let yaw = lh + rng.random_range(-0.3..0.3);
                    w.set_pose(*b, &VehicleState { x: lx + rng.random_range(-1.0..1.0), y: ly, yaw, ..Default::default() });
                }
                w.step(0.01);
                let n = 961;
                let fov = 120f64.to_radians();
                let angles: Vec<f64> = (0..n).map(|i| -fov / 2.0 + fov * i as f64 / (n - 1) as f64).collect();
                let unit: Vec<Vector> = angles.iter().map(|a| f32_dir((h + a).cos(), (h + a).sin())).collect();
                let fan = RayFan { origin: [x + 2.0 * h.cos(), y + 2.0 * h.sin()], base: h, angles: &angles, unit: &unit };
                w.cast_fan(&fan, 100.0, ego, &mut hits);
                let reference = cast_fan_reference(&w, &fan, 100.0, ego);
                assert!(hits.iter().any(Option::is_some));
                for (i, (a, b)) in hits.iter().zip(&reference).enumerate() {
                    assert!(a.map(f64::to_bits) == b.map(f64::to_bits), "s {s} ray {i}: {a:?} vs {b:?}");
                }
            }
        }
    }

    #[test]
    fn separate_vehicles_do_not_collide() {
        let mut w = empty();
        let p = VehicleParams::default();
        let a = w.add_vehicle(&p, &VehicleState::default());
        let b = w.add_vehicle(&p, &VehicleState { x: 5.0, ..Default::default() });
        for _ in 0..10 {
            w.set_pose(a, &VehicleState::default());
            w.set_pose(b, &VehicleState { x: 5.0, ..Default::default() });
            assert!(w.step(0.01).is_empty());
        }
    }

    #[test]
    fn ray_hits_a_box_at_the_analytic_range_and_ignores_the_ego() {
        let mut w = empty();
        let p = VehicleParams::default();
        let ego = w.add_vehicle(&p, &VehicleState::default());
        let lead = w.add_vehicle(&p, &VehicleState { x: 30.0, y: 0.5, ..Default::default() });
        w.step(0.01);
        // From the ego centre along +x: the lead's rear face is at 30 - 2.45 = 27.55 m.
        let r = w.cast_ray([0.0, 0.0], [1.0, 0.0], 100.0, ego).expect("hit");
        assert!((r - 27.55).abs() < 1e-3, "{r}");
        // Excluding the lead instead, the ray from inside the ego hits the ego itself at once.
        let r = w.cast_ray([0.0, 0.0], [1.0, 0.0], 100.0, lead).expect("hit");
        assert!(r < 1e-3);
        // Angled ray: hits the rear face plane x = 27.55 at y = 27.55 tan(1 deg).
        let a = 1f64.to_radians();
        let r = w.cast_ray([0.0, 0.0], [a.cos(), a.sin()], 100.0, ego).expect("hit");
        assert!((r - 27.55 / a.cos()).abs() < 2e-3, "{r}");
    }
}
