//! Contacts reported by the world, turned into records: each follower's first contact with
//! anything ([`CollisionInfo`]) and the first contact of every other pair ([`ContactRecord`]).

use crate::metrics::{CollisionInfo, ContactRecord, HitObject, ObjectKind, PairContact};
use crate::track::{RoadsideObject, Track};
use crate::vehicle::VehicleState;
use crate::world::{Body, Contact, Party};

/// The bodies of the vehicles with their states after the step: index 0 = the lead, `k` =
/// follower `k` (`1..=followers`), then the scripted traffic in `traffic` order.
pub(super) struct Bodies<'a> {
    /// `(body, state)` of every vehicle, lead first.
    pub(super) vehicles: &'a [(Body, VehicleState)],
    /// Number of followers.
    pub(super) followers: usize,
    /// Names of the scripted vehicles after the string.
    pub(super) traffic: &'a [&'a str],
    /// Which of `vehicles` are pedestrians (same order).
    pub(super) pedestrians: &'a [bool],
    /// The track (kinds of its road-side objects).
    pub(super) track: &'a Track,
}

impl Bodies<'_> {
    /// What `party` is.
    fn object(&self, party: Party) -> HitObject {
        match party {
            Party::Vehicle(b) => {
                let k = self.vehicles.iter().position(|(v, _)| *v == b).unwrap_or(usize::MAX);
                let mut o = match k.checked_sub(self.followers + 1).and_then(|i| self.traffic.get(i)) {
                    Some(name) => HitObject::named((*name).to_string()),
                    None => HitObject::vehicle(k),
                };
                if self.pedestrians.get(k).copied().unwrap_or(false) {
                    o.kind = ObjectKind::Pedestrian;
                }
                o
            }
            Party::Static(i) => {
                // The world tags every collider of object `i` with `i`; an unknown index (none
                // is ever reported) is named a post.
                let kind = match self.track.objects.get(i) {
                    Some(RoadsideObject::GuardRail { .. }) => ObjectKind::GuardRail,
                    Some(RoadsideObject::ParkedCar { .. }) => ObjectKind::ParkedCar,
                    Some(RoadsideObject::Post { .. }) | None => ObjectKind::Post,
                };
                HitObject::object(kind, i)
            }
        }
    }

    /// The state of vehicle `party` (`None` for a road-side object: it stands still).
    fn state(&self, party: Party) -> Option<&VehicleState> {
        match party {
            Party::Vehicle(b) => self.vehicles.iter().find(|(v, _)| *v == b).map(|(_, s)| s),
            Party::Static(_) => None,
        }
    }
}

/// World-frame velocity of a vehicle (along its heading; the models have no side slip), m/s.
fn velocity(s: Option<&VehicleState>) -> [f64; 2] {
    s.map_or([0.0, 0.0], |s| [s.speed * s.yaw.cos(), s.speed * s.yaw.sin()])
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// Closing speed of `ego` towards `other` along the unit `normal` (from `ego` to `other`), >= 0.
fn normal_speed(ego: Option<&VehicleState>, other: Option<&VehicleState>, normal: [f64; 2]) -> f64 {
    let (ve, vo) = (velocity(ego), velocity(other));
    dot([ve[0] - vo[0], ve[1] - vo[1]], normal).max(0.0)
}

/// Follower `k`'s first contact among this step's `contacts`, if it touched anything: the
/// vehicle in front if it is among them, else the deepest.
pub(super) fn first_collision(contacts: &[Contact], bodies: &Bodies<'_>, k: usize, time: f64) -> Option<CollisionInfo> {
    let (body, fs) = bodies.vehicles.get(k).copied()?;
    let (front_body, front) = bodies.vehicles.get(k.checked_sub(1)?).copied()?;
    let mut best: Option<(&Contact, Party, [f64; 2])> = None;
    for c in contacts {
        let Some((other, normal)) = c.seen_from(body) else { continue };
        let better = match best {
            None => true,
            Some((b, o, _)) => o != Party::Vehicle(front_body) && (other == Party::Vehicle(front_body) || c.depth > b.depth),
        };
        if better {
            best = Some((c, other, normal));
        }
    }
    let (c, other, normal) = best?;
    let other_state = bodies.state(other);
    let impact_speed = if other == Party::Vehicle(front_body) {
        (fs.speed - front.speed).max(0.0)
    } else {
        // Closing speed along the heading, towards the side (front or rear) of the contact.
        let heading = [fs.yaw.cos(), fs.yaw.sin()];
        let side = if dot([c.point[0] - fs.x, c.point[1] - fs.y], heading) >= 0.0 { 1.0 } else { -1.0 };
        let (ve, vo) = (velocity(Some(&fs)), velocity(other_state));
        (side * dot([ve[0] - vo[0], ve[1] - vo[1]], heading)).max(0.0)
    };
    Some(CollisionInfo {
        time,
        impact_speed,
        lead_speed: front.speed,
        follower_speed: fs.speed,
        object: bodies.object(other),
        other_speed: other_state.map_or(0.0, |s| s.speed),
        impact_speed_normal: normal_speed(Some(&fs), other_state, normal),
        point: c.point,
        normal,
    })
}

/// Adds to `out` the first contact of every pair in `contacts` that involves no follower (the
/// lead or a scripted vehicle with a road-side object or with each other); `out` holds the pairs
/// already seen.
pub(super) fn record_other_contacts(contacts: &[Contact], bodies: &Bodies<'_>, time: f64, out: &mut Vec<ContactRecord>) {
    let is_follower = |p: Party| match p {
        Party::Vehicle(b) => bodies.vehicles.iter().position(|(v, _)| *v == b).is_some_and(|k| (1..=bodies.followers).contains(&k)),
        Party::Static(_) => false,
    };
    for c in contacts {
        if is_follower(c.a) || is_follower(c.b) {
            // A follower's contact: its collision.
            continue;
        }
        let Party::Vehicle(first) = c.a else { continue };
        let Some((other, normal)) = c.seen_from(first) else { continue };
        let (a, b) = (bodies.object(Party::Vehicle(first)), bodies.object(other));
        if out.iter().any(|r| (r.a == a && r.b == b) || (r.a == b && r.b == a)) {
            continue;
        }
        let (sa, sb) = (bodies.state(Party::Vehicle(first)), bodies.state(other));
        out.push(ContactRecord {
            time,
            a,
            b,
            speed: sa.map_or(0.0, |s| s.speed),
            impact_speed_normal: normal_speed(sa, sb, normal),
            point: c.point,
            normal,
        });
    }
}

/// Every pair touching in `contacts` (followers included), as [`PairContact`]s from the first
/// vehicle's side; a pair reported twice (several manifolds) is listed once by the caller.
pub(super) fn pair_contacts(contacts: &[Contact], bodies: &Bodies<'_>, time: f64) -> Vec<PairContact> {
    let mut out = Vec::with_capacity(contacts.len());
    for c in contacts {
        let Party::Vehicle(first) = c.a else { continue };
        let Some((other, normal)) = c.seen_from(first) else { continue };
        let (sa, sb) = (bodies.state(Party::Vehicle(first)), bodies.state(other));
        let (va, vb) = (velocity(sa), velocity(sb));
        out.push(PairContact {
            time,
            a: bodies.object(Party::Vehicle(first)),
            b: bodies.object(other),
            relative_speed: (va[0] - vb[0]).hypot(va[1] - vb[1]),
            impact_speed_normal: normal_speed(sa, sb, normal),
            point: c.point,
        });
    }
    out
}
