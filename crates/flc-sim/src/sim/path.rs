//! What is in the ego's path, in road coordinates: `s` along the ego's lane (the track's
//! centreline, [`Track::project`]) and `t` across it (m, + left, from the centre of the ego's
//! lane). One definition for everyone who asks: the ground-truth "vehicle in front" of the
//! records and metrics ([`nearest_in_path`]) and the careful driver's perception
//! ([`human_front`]).
//!
//! Two regions, both measured on the road, not along the ego's heading (on a curve of radius `R`
//! the heading line leaves the lane by `d² / 2R` at distance `d`: 1.8 m at 30 m on R = 250 m, so
//! every vehicle ahead in the lane would be "off the line"):
//! * the **swept-path corridor**: the band the ego's body sweeps if it holds its lateral position
//!   in its lane, widened by [`PathParams::corridor_margin`] on each side, and at least its lane
//!   (half the lane width each side of its path, [`lane_keeping_half_width`]; the detector of an
//!   ego that keeps its lane uses the same). An object whose body reaches into it is in the path
//!   (a motorbike on the lane marking is, and so is a car poking 0.25 m into the lane).
//! * the **lane as a careful driver reads it** (UN R157 Annex 3): the lateral movement a driver
//!   does not read as a lane change is the wandering zone [`PathParams::wandering`] (0.375 m)
//!   *relative to the lane*. A vehicle of the next lane is perceived as cutting in once its centre
//!   has come more than the wandering zone towards the ego's lane; a vehicle of the ego's lane is
//!   perceived as cutting out once it is more than the wandering zone off the lane centre and
//!   moving away from it faster than [`PathParams::leaving_speed`] (a lead weaving within ±0.3 m
//!   stays the vehicle in front, and so does one at the turning point of a weave a few
//!   centimetres wider, or a vehicle standing on the marking).

use super::geometry::bumper_gap;
use crate::track::{Track, wrap};
use crate::vehicle::VehicleState;

/// The lateral wandering of a vehicle inside its lane that a careful driver does not read as a
/// lane change, m (UN R157's performance model of a careful and competent human driver: the risk
/// of a cut-in is perceived once the vehicle's lateral movement exceeds it;
/// `docs/careful-driver.md`).
pub const WANDERING: f64 = 0.375;

/// Margin of the swept-path corridor on each side of the ego's body, m: an object whose body
/// comes within this of the band the ego's body sweeps is in its path (the least lateral
/// clearance to pass an object with).
pub const CORRIDOR_MARGIN: f64 = 0.5;

/// Half width of the detector's corridor for an ego `ego_width` m wide that keeps its lane on
/// lanes `lane_width` m wide, m: its swept band plus [`CORRIDOR_MARGIN`], and at least its lane
/// (an object poking into the ego's lane is in its path: ALKS 4.2_2's target 2 m off the lane's
/// centre, 0.57 m clear of a 2 m wide ego's body, which the swept band plus margin alone let
/// `flc-robust` pass at 10.4 m/s). The band is measured about the ego's path (its lateral place
/// in the lane), as the outside check measures its lane band.
pub fn lane_keeping_half_width(ego_width: f64, lane_width: f64) -> f64 {
    corridor_half_width(0.5 * ego_width, CORRIDOR_MARGIN, lane_width)
}

/// The corridor's half width about the ego's path: its body's half extent plus `margin`, at least
/// half the lane. The one formula of [`lane_keeping_half_width`] and [`EgoPath`].
fn corridor_half_width(half_width: f64, margin: f64, lane_width: f64) -> f64 {
    f64::max(half_width + margin, 0.5 * lane_width)
}

/// Lateral speed away from the lane's centre above which a vehicle beyond the wandering zone is
/// read as leaving the lane (a cut-out), m/s: well below a lane change's (a 3.5 m change in 5 s
/// crosses the wandering zone at about 0.7 m/s), above the lateral speed at the turning point of
/// a weave and of a standing vehicle (0).
pub const LEAVING_SPEED: f64 = 0.2;

/// The parameters of the path: the wandering zone and the corridor's margin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathParams {
    /// Lateral movement within the lane not read as a lane change, m ([`WANDERING`]).
    pub wandering: f64,
    /// Margin of the swept-path corridor on each side of the ego's body, m ([`CORRIDOR_MARGIN`]).
    pub corridor_margin: f64,
    /// Lateral speed away from the lane's centre that makes a vehicle beyond the wandering zone
    /// a cut-out, m/s ([`LEAVING_SPEED`]).
    pub leaving_speed: f64,
}

impl Default for PathParams {
    fn default() -> Self {
        Self { wandering: WANDERING, corridor_margin: CORRIDOR_MARGIN, leaving_speed: LEAVING_SPEED }
    }
}

/// A vehicle as the path sees it: its state and the length and width of its body, m.
#[derive(Debug, Clone, Copy)]
pub(super) struct Object {
    pub(super) state: VehicleState,
    pub(super) length: f64,
    pub(super) width: f64,
}

/// An object located relative to the ego's path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Located {
    /// Distance of its centre ahead of the ego's centre along the road, m.
    pub(super) ds: f64,
    /// Lateral position of its centre from the centre of the ego's lane, m (+ left).
    pub(super) t: f64,
    /// Its lateral speed across the road, m/s (+ left): its speed times the sine of its heading
    /// relative to the road.
    pub(super) t_speed: f64,
    /// Its speed along the road, m/s: its speed times the cosine of its heading relative to the
    /// road.
    pub(super) s_speed: f64,
    /// It faces more than 45° away from the road's direction: it is crossing the road (a
    /// pedestrian walking across, a car at a junction), not driving along it.
    pub(super) crossing: bool,
    /// Half its extent across the road, m: `(L |sin h| + W cos h) / 2` for its body `L` x `W`
    /// turned by `h` from the road (half its width when it is parallel to the road).
    pub(super) half_width: f64,
}

/// The ego's path on a track: where the ego is in road coordinates, its lane and its body.
#[derive(Debug, Clone, Copy)]
pub(super) struct EgoPath<'a> {
    track: &'a Track,
    /// The ego's position along the centreline, m.
    s: f64,
    /// The centre of the ego's lane (offset from the centreline, m, + left).
    lane_centre: f64,
    /// The ego's lateral position from its lane's centre, m.
    t: f64,
    /// Half the ego's width, m.
    half_width: f64,
    /// The ego's speed along the road, m/s.
    speed: f64,
    params: PathParams,
}

impl<'a> EgoPath<'a> {
    /// The path of an ego of `width` m at `ego` on `track`: its lane is the track's lane whose
    /// centre is nearest to it ([`nearest_lane_offset`]).
    pub(super) fn new(track: &'a Track, ego: &VehicleState, width: f64, params: PathParams) -> Self {
        let p = track.project(ego.x, ego.y);
        let lane_centre = nearest_lane_offset(track, p.lateral_offset);
        let speed = ego.speed * wrap(ego.yaw - p.heading).cos();
        Self { track, s: p.s, lane_centre, t: p.lateral_offset - lane_centre, half_width: width / 2.0, speed, params }
    }

    /// The same path, its body's extent across the road that of a box `length` m long turned by
    /// its heading relative to the road.
    fn with_length(mut self, ego: &VehicleState, length: f64) -> Self {
        let h = wrap(ego.yaw - self.track.project(ego.x, ego.y).heading);
        self.half_width = half_extent(length, 2.0 * self.half_width, h);
        self
    }

    /// Where `o` is relative to this path.
    pub(super) fn locate(&self, o: &Object) -> Located {
        let p = self.track.project(o.state.x, o.state.y);
        let h = wrap(o.state.yaw - p.heading);
        Located {
            ds: p.s - self.s,
            t: p.lateral_offset - self.lane_centre,
            t_speed: o.state.speed * h.sin(),
            s_speed: o.state.speed * h.cos(),
            crossing: h.cos().abs() < std::f64::consts::FRAC_1_SQRT_2,
            half_width: half_extent(o.length, o.width, h),
        }
    }

    /// Half width of the corridor about the ego's path, m: the band its body sweeps plus the
    /// corridor's margin, at least half the lane ([`lane_keeping_half_width`], the detector's).
    fn corridor(&self) -> f64 {
        corridor_half_width(self.half_width, self.params.corridor_margin, self.track.lane_width)
    }

    /// Whether an object at `l` reaches into the corridor: its body comes within
    /// [`Self::corridor`] of the ego's path (within the margin of the ego's body, or into its
    /// lane).
    pub(super) fn in_corridor(&self, l: &Located) -> bool {
        (l.t - self.t).abs() - l.half_width < self.corridor()
    }

    /// Whether the body of an object at `l` overlaps, across the road, the band the ego's body
    /// sweeps (no margin: the ego would touch it).
    pub(super) fn overlaps_body(&self, l: &Located) -> bool {
        (l.t - self.t).abs() - l.half_width - self.half_width < 0.0
    }

    /// Whether a careful driver reads an object at `l` (ahead) as in its lane: in the corridor,
    /// or its centre within the lane width less the wandering zone of the lane's centre (a
    /// vehicle of the next lane has moved more than the wandering zone towards it), and not
    /// cutting out (more than the wandering zone off the lane's centre and moving away from it
    /// faster than the leaving speed).
    pub(super) fn seen_in_lane(&self, l: &Located) -> bool {
        let w = self.params.wandering;
        let leaving = l.t.abs() > w && l.t.signum() * l.t_speed > self.params.leaving_speed;
        !leaving && (l.t.abs() < self.track.lane_width - w || self.in_corridor(l))
    }

    /// Whether a careful driver reads an object at `l` (ahead) as crossing into its path: it is
    /// crossing the road ([`Located::crossing`]), walking or driving towards the ego's lane
    /// faster than the leaving speed, and it reaches the swept-path corridor no later than the
    /// ego reaches it (its lateral gap to the corridor over its lateral speed, against the
    /// distance over the closing speed along the road). The lane rule reads lateral movement
    /// of traffic along the road; a pedestrian stepping onto the road from the kerb is seen
    /// as soon as it walks on a course into the path, as a driver watching it would.
    pub(super) fn crossing_into(&self, l: &Located) -> bool {
        let side = l.t - self.t;
        let towards = -side.signum() * l.t_speed;
        let closing = self.speed - l.s_speed;
        if !l.crossing || towards <= self.params.leaving_speed || closing <= 0.0 {
            return false;
        }
        let gap = (side.abs() - l.half_width - self.corridor()).max(0.0);
        gap / towards <= l.ds / closing
    }
}

/// The vehicle in the ego's path among `candidates` (ground truth: the nearest whose centre is
/// ahead along the road and whose body reaches into the ego's swept-path corridor) and its
/// length; `None` if there is none. An object beside the ego (bumper gap <= 0) whose body does
/// not overlap the ego's across the road is being passed, not in front: so the gap to the vehicle
/// in path is negative only when the bodies overlap both ways (a contact).
pub(super) fn nearest_in_path(track: &Track, ego: &Object, candidates: impl Iterator<Item = Object>) -> Option<(VehicleState, f64, f64)> {
    let path = EgoPath::new(track, &ego.state, ego.width, PathParams::default()).with_length(&ego.state, ego.length);
    let mut best: Option<(f64, VehicleState, f64, f64)> = None;
    for o in candidates {
        let l = path.locate(&o);
        if l.ds > 0.0
            && path.in_corridor(&l)
            && best.is_none_or(|b| l.ds < b.0)
            && ((l.t - path.t).abs() < l.half_width + path.half_width + CONTACT_TOLERANCE
                || bumper_gap(&o.state, (o.length, o.width), &ego.state, ego.length) > 0.0)
        {
            best = Some((l.ds, o.state, o.length, o.width));
        }
    }
    best.map(|(_, st, len, w)| (st, len, w))
}

/// The vehicle in front of `ego` as a careful human driver sees it, and its length: the nearest
/// vehicle ahead along the road that it reads as in its lane ([`EgoPath::seen_in_lane`]) or as
/// crossing into its path ([`EgoPath::crossing_into`]); with
/// none, the nearest read as leaving the lane whose body still overlaps the band the ego's body
/// sweeps (a driver looks past a cut-out at what it reveals, but does not drive into a vehicle
/// still in its way: a lead swerving wide at walking pace, ALKS 4.1_2). `None`: nothing in front.
pub(super) fn human_front(track: &Track, ego: &Object, candidates: impl Iterator<Item = Object>) -> Option<(VehicleState, f64, f64)> {
    let path = EgoPath::new(track, &ego.state, ego.width, PathParams::default());
    let mut best: Option<(f64, VehicleState, f64, f64)> = None;
    let mut in_the_way: Option<(f64, VehicleState, f64, f64)> = None;
    for o in candidates {
        let l = path.locate(&o);
        if l.ds <= 0.0 {
            continue;
        }
        if path.seen_in_lane(&l) || path.crossing_into(&l) {
            if best.is_none_or(|b| l.ds < b.0) {
                best = Some((l.ds, o.state, o.length, o.width));
            }
        } else if path.overlaps_body(&l) && in_the_way.is_none_or(|b| l.ds < b.0) {
            in_the_way = Some((l.ds, o.state, o.length, o.width));
        }
    }
    best.or(in_the_way).map(|(_, st, len, w)| (st, len, w))
}

/// Half the extent across the road of a `length` x `width` box turned by `h` from it, m.
fn half_extent(length: f64, width: f64, h: f64) -> f64 {
    0.5 * (length * h.sin().abs() + width * h.cos().abs())
}

/// How close across the road (m) the extents of two bodies side by side may be for a negative
/// bumper gap to count as a contact (the vehicle in path) rather than a pass: a side-swipe
/// touches at the extents' sum, within the boxes' corners.
const CONTACT_TOLERANCE: f64 = 0.1;

/// The offset (m, + left of the centreline) of the track's lane whose centre is nearest to
/// `lateral_offset`.
pub(super) fn nearest_lane_offset(track: &Track, lateral_offset: f64) -> f64 {
    (0..track.lanes.max(1))
        .map(|l| track.lane_offset(l))
        .min_by(|a, b| (a - lateral_offset).abs().total_cmp(&(b - lateral_offset).abs()))
        .unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two lanes (the ego's, 0, and one to its left), a 100 m straight then an arc of `radius` m
    /// turning left (`left`) or right over 90°, sampled every 2 m.
    fn curve(radius: f64, left: bool) -> Track {
        let angle = if left { std::f64::consts::FRAC_PI_2 } else { -std::f64::consts::FRAC_PI_2 };
        Track::from_plan("arc", &[(100.0, radius, angle)], 2.0).with_lanes(2, 0)
    }

    /// A vehicle on `track` at `s`, `offset` m left of the centreline, heading along the road
    /// (+ `heading`) at 20 m/s (standing if `heading` is NaN).
    fn at(track: &Track, s: f64, offset: f64, heading: f64, (length, width): (f64, f64)) -> Object {
        let (x, y, h) = track.place(s, offset);
        let (yaw, speed) = if heading.is_nan() { (h + 0.05, 0.0) } else { (h + heading, 20.0) };
        Object { state: VehicleState { x, y, yaw, speed, ..VehicleState::default() }, length, width }
    }

    /// Standing (`at`), turned 0.05 rad to the left.
    const STANDING: f64 = f64::NAN;

    const CAR: (f64, f64) = (4.7, 1.8);
    const BIKE: (f64, f64) = (2.2, 0.8);

    #[test]
    fn on_curves_the_lane_ahead_is_in_path_and_the_next_lane_is_not() {
        for radius in [250.0, 1000.0] {
            for left in [true, false] {
                let track = curve(radius, left);
                // The ego 20 m into the arc, 0.2 m off its lane's centre, heading along the road.
                let ego = at(&track, 120.0, 0.2, 0.0, CAR);
                let path = EgoPath::new(&track, &ego.state, CAR.1, PathParams::default());
                let lw = track.lane_width;
                // (what, s ahead, offset, heading, size, in corridor, seen by a careful driver)
                let cases = [
                    ("car on the lane centre", 60.0, 0.0, 0.0, CAR, true, true),
                    ("motorbike on the lane centre", 90.0, 0.0, 0.0, BIKE, true, true),
                    ("motorbike on the marking", 40.0, lw / 2.0, 0.0, BIKE, true, true),
                    ("motorbike standing on the marking, turned away", 40.0, lw / 2.0, STANDING, BIKE, true, true),
                    ("car standing across both lanes", 40.0, lw / 2.0, STANDING, CAR, true, true),
                    ("lead at the turning point of a wider weave", 30.0, 0.4, 0.005, CAR, true, true),
                    ("lead weaving 0.3 m left, heading away", 30.0, 0.3, 0.05, CAR, true, true),
                    ("lead weaving 0.3 m right, heading away", 30.0, -0.3, -0.05, CAR, true, true),
                    ("car in the next lane", 30.0, lw, 0.0, CAR, false, false),
                    ("car in the next lane weaving 0.3 m towards", 30.0, lw - 0.3, -0.05, CAR, false, false),
                    ("car cutting in, 0.5 m towards", 30.0, lw - 0.5, -0.05, CAR, false, true),
                    ("lead cutting out, 0.5 m away", 30.0, 0.5, 0.05, CAR, true, false),
                ];
                for (what, ds, offset, heading, size, corridor, seen) in cases {
                    let o = at(&track, 120.0 + ds, offset, heading, size);
                    let l = path.locate(&o);
                    let tag = format!("R = {radius} m, left = {left}: {what}");
                    assert!((l.ds - ds).abs() < 0.05, "{tag}: ds {}", l.ds);
                    assert!((l.t - offset).abs() < 0.01, "{tag}: t {}", l.t);
                    assert_eq!(path.in_corridor(&l), corridor, "{tag}: {l:?}");
                    assert_eq!(path.seen_in_lane(&l), seen, "{tag}: {l:?}");
                    // Alone, a vehicle read as leaving stays in front while its body is in the way.
                    let front = human_front(&track, &ego, std::iter::once(o));
                    assert_eq!(front.is_some(), seen || path.overlaps_body(&l), "{tag}");
                    assert_eq!(nearest_in_path(&track, &ego, std::iter::once(o)).is_some(), corridor, "{tag}");
                }
                // Behind the ego: never in front.
                let behind = at(&track, 100.0, 0.0, 0.0, CAR);
                assert!(human_front(&track, &ego, std::iter::once(behind)).is_none());
            }
        }
    }

    #[test]
    fn a_pedestrian_walking_into_the_path_is_seen_before_it_reaches_the_lane() {
        // UN R157 4.2.3: a pedestrian 5 m right of the ego lane's centre walks across at 5 km/h
        // and reaches it when the ego, at 60 km/h, does (3.6 s). Straight part of the track.
        let track = curve(1000.0, true);
        let ego = Object {
            state: {
                let (x, y, h) = track.place(20.0, 0.0);
                VehicleState { x, y, yaw: h, speed: 60.0 / 3.6, ..VehicleState::default() }
            },
            length: CAR.0,
            width: CAR.1,
        };
        let path = EgoPath::new(&track, &ego.state, CAR.1, PathParams::default());
        let walker = |ds: f64, t: f64, heading: f64, speed: f64| {
            let (x, y, h) = track.place(20.0 + ds, t);
            Object { state: VehicleState { x, y, yaw: h + heading, speed, ..VehicleState::default() }, length: 0.3, width: 0.5 }
        };
        let half_pi = std::f64::consts::FRAC_PI_2;
        // (what, ds, t, heading, speed, crossing into the path)
        let cases = [
            ("walking towards the lane, arriving with the ego", 60.0, -5.0, half_pi, 5.0 / 3.6, true),
            ("the same from the left", 60.0, 5.0, -half_pi, 5.0 / 3.6, true),
            ("walking away from the lane", 60.0, -5.0, -half_pi, 5.0 / 3.6, false),
            ("standing at the kerb", 60.0, -5.0, half_pi, 0.0, false),
            ("walking towards, too far aside to arrive before the ego passes", 20.0, -5.0, half_pi, 5.0 / 3.6, false),
        ];
        for (what, ds, t, heading, speed, into) in cases {
            let o = walker(ds, t, heading, speed);
            let l = path.locate(&o);
            assert_eq!(path.crossing_into(&l), into, "{what}: {l:?}");
            assert_eq!(human_front(&track, &ego, std::iter::once(o)).is_some(), into, "{what}");
            // Not in the lane by the lane rule (that one reads traffic along the road).
            assert!(!path.seen_in_lane(&l), "{what}");
        }
        // A car drifting towards the lane along the road is left to the lane rule (R157's
        // wandering zone), however fast it closes in.
        let drifting = at(&track, 50.0, track.lane_width - 0.2, -0.05, CAR);
        let l = path.locate(&drifting);
        assert!(!l.crossing && !path.crossing_into(&l), "{l:?}");
    }

    #[test]
    fn a_lead_swerving_wide_is_dropped_only_once_out_of_the_way_or_when_something_is_revealed() {
        for radius in [250.0, 1000.0] {
            for left in [true, false] {
                let track = curve(radius, left);
                let ego = at(&track, 120.0, 0.0, 0.0, CAR);
                let tag = format!("R = {radius} m, left = {left}");
                // 0.8 m off the lane's centre and moving away (0.2 rad at 20 m/s: 4 m/s across):
                // read as leaving, but its body (turned 0.2 rad: 1.35 m half extent across the
                // road) still overlaps the ego's.
                let swerving = at(&track, 140.0, 0.8, 0.2, CAR);
                let path = EgoPath::new(&track, &ego.state, CAR.1, PathParams::default());
                let l = path.locate(&swerving);
                assert!(!path.seen_in_lane(&l) && path.overlaps_body(&l), "{tag}: {l:?}");
                assert!(human_front(&track, &ego, std::iter::once(swerving)).is_some(), "{tag}");
                // 2.6 m off: its body clear of the ego's band (2.6 - 1.35 - 0.9 = 0.35 m): dropped.
                let out = at(&track, 140.0, 2.6, 0.2, CAR);
                assert!(human_front(&track, &ego, std::iter::once(out)).is_none(), "{tag}");
                // A car revealed behind the swerving lead is what the driver looks at.
                let revealed = at(&track, 180.0, 0.0, STANDING, CAR);
                let front = human_front(&track, &ego, [swerving, revealed].into_iter()).expect("in front");
                assert!((front.0.x - revealed.state.x).abs() < 1e-9, "{tag}");
            }
        }
    }

    #[test]
    fn the_heading_line_would_miss_the_lane_ahead_on_a_curve() {
        // What the road coordinates fix: on R = 250 m the car 60 m ahead in the lane is about
        // 60² / 500 = 7.2 m off the ego's heading line (6.9 m on the polyline).
        let track = curve(250.0, true);
        let ego = at(&track, 120.0, 0.0, 0.0, CAR);
        let o = at(&track, 180.0, 0.0, 0.0, CAR);
        let (e, c) = (ego.state, o.state);
        let across = -(c.x - e.x) * e.yaw.sin() + (c.y - e.y) * e.yaw.cos();
        assert!(across > 6.5, "{across}");
        assert!(human_front(&track, &ego, std::iter::once(o)).is_some());
    }

    #[test]
    fn the_nearest_in_path_wins_and_the_corridor_follows_the_ego() {
        let track = curve(1000.0, false);
        let ego = at(&track, 120.0, 0.0, 0.0, CAR);
        let near = at(&track, 150.0, track.lane_width / 2.0, 0.0, BIKE);
        let far = at(&track, 170.0, 0.0, 0.0, CAR);
        let next_lane = at(&track, 130.0, track.lane_width, 0.0, CAR);
        let got = nearest_in_path(&track, &ego, [far, next_lane, near].into_iter()).expect("in path");
        assert_eq!(got.1, BIKE.0);
        // The ego 1 m to the right of its lane's centre: the motorbike on the left marking is
        // 1.75 + 1 - 0.4 - 0.9 = 1.45 m from its body, out of the 0.5 m margin.
        let ego_right = at(&track, 120.0, -1.0, 0.0, CAR);
        let got = nearest_in_path(&track, &ego_right, [far, next_lane, near].into_iter()).expect("in path");
        assert_eq!(got.1, CAR.0);
        // The ego's lane is the nearest lane: in the left lane, the car there is in path.
        let ego_left = at(&track, 120.0, track.lane_width - 0.2, 0.0, CAR);
        let got = nearest_in_path(&track, &ego_left, [far, next_lane].into_iter()).expect("in path");
        assert!((got.0.x - next_lane.state.x).abs() < 1e-9);
    }

    #[test]
    fn an_object_being_passed_is_not_in_front_unless_the_bodies_overlap() {
        let track = curve(250.0, true);
        let ego = at(&track, 120.0, 0.0, 0.0, CAR);
        // A motorbike on the marking, its centre 1 m ahead of the ego's: bumper gap < 0, in the
        // corridor (0.45 m from the ego's body), not overlapping across the road: being passed.
        let beside = at(&track, 121.0, track.lane_width / 2.0, STANDING, BIKE);
        assert!(bumper_gap(&beside.state, BIKE, &ego.state, CAR.0) < 0.0);
        assert!(nearest_in_path(&track, &ego, std::iter::once(beside)).is_none());
        // 5 m ahead it is in front (gap 1.55 m).
        let ahead = at(&track, 125.0, track.lane_width / 2.0, STANDING, BIKE);
        assert!(nearest_in_path(&track, &ego, std::iter::once(ahead)).is_some());
        // Overlapping across the road and along it: a contact, still the vehicle in path.
        let hit = at(&track, 123.0, 1.0, STANDING, BIKE);
        assert!(bumper_gap(&hit.state, BIKE, &ego.state, CAR.0) < 0.0);
        assert!(nearest_in_path(&track, &ego, std::iter::once(hit)).is_some());
    }
}
