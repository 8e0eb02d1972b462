//! Three-lane traffic beside a followed lead, for counting false cut-ins: segments of one minute,
//! each built from a seed (deterministic, no random generator state outside the seed).
//!
//! A segment: three 3.5 m lanes (0 right, 1 the ego's, 2 left), the ego (a controller keeping its
//! lane) following a lead in its lane at the same speed (60-130 km/h); on a straight road, an arc
//! of R = 1000 m (left or right), or an S-bend (curves of 0.4 rad at R = 1000 m alternating left
//! and right), every change of curvature a clothoid of 120 m (motorway design);
//! guard rails beside the outer lanes (0.5-1.5 m beyond their edges) or delineator posts every
//! 50 m instead. Each neighbouring lane has one speed for all its vehicles (no two of them meet):
//! the left lane from 5 km/h slower to 30 km/h faster than the ego (cars overtaking), the right
//! one from the ego's speed to 25 km/h slower (trucks and cars the ego passes); its vehicles,
//! 35-80 m apart, are cars keeping the lane centre, cars weaving +-0.3 m within it (sinusoidal
//! lane changes of 1.5-3 s to each side) and trucks (12-16.5 m x 2.55 m). Nobody leaves its
//! lane: every change of the ego's target away from its lead is a false cut-in.
//!
//! [`cut_in_segment`] is the control: the same road with a car from the left lane cutting in
//! between the ego and its lead, which must be counted.

use crate::lead::{Phase, ScriptedVehicle};
use crate::scenario::{ControllerKind, Scenario, TrackSpec};
use crate::track::{RoadsideObject, Track};
use crate::units::KMH;
use crate::vehicle::VehicleParams;

/// Lane width, m.
pub const LANE_WIDTH: f64 = 3.5;
/// Where the ego's centre starts, m along the centreline.
pub const EGO_S: f64 = 200.0;
/// Length of a segment, s.
pub const SEGMENT_S: f64 = 60.0;

/// The road of a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RoadShape {
    /// Straight.
    Straight,
    /// One arc of R = 1000 m, turning left (`true`) or right.
    Arc(bool),
    /// Curves of 0.4 rad at R = 1000 m alternating left and right (the first turning left when
    /// `true`), joined by clothoids.
    SBend(bool),
}

impl std::fmt::Display for RoadShape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RoadShape::Straight => write!(f, "straight"),
            RoadShape::Arc(l) => write!(f, "R = 1000 m {}", if *l { "left" } else { "right" }),
            RoadShape::SBend(l) => write!(f, "S-bend (R = 1000 m, first {})", if *l { "left" } else { "right" }),
        }
    }
}

/// SplitMix64: a deterministic stream from a seed.
#[derive(Debug, Clone)]
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// Uniform in 0..n.
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// The road of `shape` with three lanes (the ego's the middle one) and the road side, from `draw`.
/// Length of a clothoid transition, m: A = sqrt(R L) = 346 m >= R / 3 for R = 1000 m, the
/// motorway design rule (RAA 2008 / AASHTO spirals: curvature changes gradually, so that a driver
/// can follow the lane). Without transitions the S-bend's curvature reversed in one step and the
/// traffic's lane keeper drifted 0.1-0.14 m off its lane centre there (`tests/false_cut_ins.rs`).
const TRANSITION: f64 = 120.0;

fn road(shape: RoadShape, draw: &mut Draw) -> Track {
    let k = 1.0 / 1000.0;
    let l = TRANSITION;
    // Each curve turns by its arc plus half of each transition (k L / 2 each end).
    let plan = match shape {
        RoadShape::Straight => vec![(3200.0, 0.0, 0.0)],
        RoadShape::Arc(left) => {
            let k = if left { k } else { -k };
            vec![(150.0, 0.0, 0.0), (l, 0.0, k), (2900.0 - l, k, k), (l, k, 0.0), (100.0, 0.0, 0.0)]
        }
        RoadShape::SBend(left) => {
            // Eight curves of 0.4 rad (400 m of R = 1000 m), alternating, each reversal a
            // transition through a point of inflection.
            let k = if left { k } else { -k };
            let mut p = vec![(150.0, 0.0, 0.0), (l, 0.0, k)];
            for c in 0..8 {
                let kc = if c % 2 == 0 { k } else { -k };
                p.push((400.0 - l, kc, kc));
                p.push(if c < 7 { (2.0 * l, kc, -kc) } else { (l, kc, 0.0) });
            }
            p.push((100.0, 0.0, 0.0));
            p
        }
    };
    let mut t = Track::from_curvature(&shape.to_string(), &plan, 2.0);
    let len = t.length();
    let edge = 1.5 * LANE_WIDTH;
    for side in [1.0, -1.0] {
        let beyond = draw.uniform(0.5, 1.5);
        if draw.below(4) == 0 {
            // Delineator posts every 50 m instead of a rail.
            let mut s = draw.uniform(0.0, 50.0);
            while s < len {
                t.objects.push(RoadsideObject::Post { s, offset: side * (edge + beyond), lane: None, radius: 0.1 });
                s += 50.0;
            }
        } else {
            t.objects.push(RoadsideObject::GuardRail { offset: side * (edge + beyond), from_s: 0.0, to_s: len });
        }
    }
    t.with_lanes(3, 1)
}

/// A truck: 12-16.5 m long, 2.55 m wide, powered to hold motorway speeds.
fn truck(draw: &mut Draw) -> VehicleParams {
    let length = draw.uniform(12.0, 16.5);
    VehicleParams {
        length,
        width: 2.55,
        wheelbase: 0.6 * length,
        mass: 12_000.0,
        max_power: 400_000.0,
        frontal_area: 8.0,
        ..VehicleParams::default()
    }
}

/// Segment `seed`: its road, the ego (`controller`) following its lead, and the neighbours unless
/// `neighbours` is false (the same segment with the lead alone: the reference for the braking
/// a neighbour causes).
pub fn segment(seed: u64, controller: ControllerKind, neighbours: bool) -> Scenario {
    let mut draw = Draw(seed.wrapping_mul(0xD1B5_4A32_D192_ED69) ^ 0x47);
    let shape = match draw.below(5) {
        0 | 1 => RoadShape::Straight,
        2 => RoadShape::Arc(draw.below(2) == 0),
        _ => RoadShape::SBend(draw.below(2) == 0),
    };
    let track = road(shape, &mut draw);
    let v = draw.uniform(60.0, 130.0) * KMH;
    let len = VehicleParams::default().length;
    let mut s = Scenario { name: format!("neighbours-{seed}"), controller, duration: SEGMENT_S, seed, ..Default::default() };
    s.track = TrackSpec::Custom(track);
    s.v2v.enabled = false;
    s.follower.start_s = Some(EGO_S);
    s.follower.initial_speed = v;
    s.follower.lane_keeping = true;
    s.careful_driver.normal.desired_speed = v;
    // The lead 1.5-2.5 s ahead (bumper to bumper), holding its speed.
    s.lead.s = Some(EGO_S + len + v * draw.uniform(1.5, 2.5));
    s.lead.offset = 0.0;
    s.lead.initial_speed = v;
    s.lead.phases = Vec::new();
    s.name = format!("neighbours-{seed} ({shape}, {:.0} km/h)", v / KMH);
    if !neighbours {
        return s;
    }
    for (lane, dv) in [(2u32, draw.uniform(-5.0, 30.0)), (0u32, -draw.uniform(0.0, 25.0))] {
        let speed = (v + dv * KMH).max(10.0);
        let centre = if lane == 2 { LANE_WIDTH } else { -LANE_WIDTH };
        // From 150 m behind the ego to 250 m ahead, 35-80 m between rear and front.
        let mut at = EGO_S - 150.0 + draw.uniform(0.0, 40.0);
        let mut k = 0;
        while at < EGO_S + 250.0 {
            let kind = draw.below(3);
            let vehicle = if kind == 2 { truck(&mut draw) } else { VehicleParams::default() };
            let centre_s = at + 0.5 * vehicle.length;
            let phases = if kind == 1 {
                // Weaving +-0.3 m: sinusoidal lane changes to either side of the lane's centre.
                let first = if draw.below(2) == 0 { 1.0 } else { -1.0 };
                let mut p = Vec::new();
                let mut t = 0.0;
                let mut side = first;
                while t < SEGMENT_S {
                    let d = draw.uniform(1.5, 3.0);
                    p.push(Phase::LaneChange { offset: Some(centre + 0.3 * side), lane: None, duration: d }.into());
                    side = -side;
                    t += d;
                }
                p
            } else {
                Vec::new()
            };
            s.vehicles.push(ScriptedVehicle {
                name: format!("n{lane}-{k}"),
                vehicle,
                s: centre_s,
                lane: None,
                offset: Some(centre),
                heading: 0.0,
                initial_speed: speed,
                phases,
            });
            at = centre_s + 0.5 * vehicle.length + draw.uniform(35.0, 80.0);
            k += 1;
        }
    }
    s
}

/// The control: segment `seed` without neighbours but with a car from the left lane, at the
/// ego's speed, cutting in (a 3 s sinusoidal lane change starting at 10 s) half way between the
/// ego and its lead. It must count as a change of target.
pub fn cut_in_segment(seed: u64, controller: ControllerKind) -> Scenario {
    let mut s = segment(seed, controller, false);
    let v = s.lead.initial_speed;
    let lead_s = s.lead.s.unwrap_or(EGO_S);
    s.vehicles.push(ScriptedVehicle {
        name: "cut-in".into(),
        vehicle: VehicleParams::default(),
        s: 0.5 * (EGO_S + lead_s),
        lane: None,
        offset: Some(LANE_WIDTH),
        heading: 0.0,
        initial_speed: v,
        phases: vec![
            Phase::Hold { until_x: None, until_t: Some(10.0), duration: None }.into(),
            Phase::LaneChange { offset: Some(0.0), lane: None, duration: 3.0 }.into(),
        ],
    });
    s.name = format!("cut-in {}", s.name);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_are_deterministic_and_valid() {
        for seed in 0..20 {
            let a = segment(seed, ControllerKind::FlcRobust, true);
            assert_eq!(a, segment(seed, ControllerKind::FlcRobust, true));
            a.validate().expect("valid");
            assert!(!a.vehicles.is_empty());
            cut_in_segment(seed, ControllerKind::FlcRobust).validate().expect("valid");
        }
    }
}
