//! One follower of the loop: its vehicle, sensors, links, pipeline and records.

use flc_core::detector::PROFILE_STATIONS;
use flc_core::{
    ActiveController, DepartureParams, Frame, LeadDeparture, LeadDetector, NeighbourTracker, OwnFix, Point2, PurePursuit, SwitchReason,
    V2vMessage,
};

use super::drive::{DriveCommand, Driven};
use super::geometry::{centreline_pursuit, centreline_steer, grid_points, wrap_angle};
use super::links::{follower_stream, sub_seed};
use super::path::nearest_lane_offset;
use crate::controllers::{BoxedLaw, ControllerKind};
use crate::error::SimError;
use crate::follower::{FollowerConfig, LostLeadSteering, Perception, Steering};
use crate::gnss::GnssError;
use crate::lidar::Lidar;
use crate::metrics::CollisionInfo;
use crate::platoon::V2vSource;
use crate::scenario::Scenario;
use crate::series::{Series, StepRecord};
use crate::track::Track;
use crate::v2v::V2vChannel;
use crate::vehicle::{SpeedController, Vehicle, VehicleState};
use crate::world::Body;

/// One follower: its vehicle, sensors, links, pipeline state and records.
pub(super) struct Follower {
    /// 1-based position in the string.
    pub(super) index: usize,
    pub(super) cfg: FollowerConfig,
    pub(super) body: Body,
    pub(super) vehicle: Vehicle,
    pub(super) speed_ctrl: SpeedController,
    pub(super) lidar: Lidar,
    /// The link its PID / supervisor listens to: from the predecessor (`predecessor`, `both`) or
    /// from the lead (`lead`; relayed by the predecessor with `relay`).
    pub(super) v2v: V2vChannel,
    /// `both`, followers 2..N: the link carrying the lead's speed (direct or relayed).
    pub(super) v2v_lead: Option<V2vChannel>,
    /// Its own GNSS error (the fix the association rule compares the sender's position with).
    pub(super) gnss: GnssError,
    pub(super) detector: Box<LeadDetector>,
    /// Objects beside the path, for the controllers that track them
    /// ([`crate::ControllerKind::tracks_neighbours`], issue 47): an intruding one is followed like
    /// a lead in the path when it is nearer (the robust FLCs: as their distance; the pipeline: as
    /// the frame's intruder, which its association rule and its FLC read).
    pub(super) neighbours: Option<NeighbourTracker>,
    /// An ego that keeps its lane watches its lead leave the path (`flc_core::LeadDeparture`):
    /// nothing in path after it is a clear road (`Frame::path_clear`), not a lost lead.
    pub(super) departure: LeadDeparture,
    pub(super) pursuit: PurePursuit,
    /// Lost-lead steering `hold_lane`: the lane keeper (pure pursuit of a point on the lane
    /// centre, with the follower's own wheelbase and steering limit).
    pub(super) lane_keeper: PurePursuit,
    /// `hold_lane` while no lead is detected: the offset of the lane held (chosen when the lead
    /// was lost; `None` while a lead is detected).
    pub(super) held_lane: Option<f64>,
    /// Forward distance from the sensor to the last lead detected, m (`None` before the first):
    /// where `hold_lane` puts the detector's corridor on the lane.
    pub(super) last_lead_x: Option<f64>,
    /// Its longitudinal law (the registry builds it from `cfg`).
    pub(super) longitudinal: BoxedLaw,
    pub(super) distance_offset: f64,
    /// The scan's points that can fall into the detector's grid (reused buffer).
    pub(super) grid_buf: Vec<[f64; 2]>,
    /// Lane keeping: the scan turned into the lane's frame at the sensor (reused buffer).
    pub(super) lane_buf: Vec<[f64; 2]>,
    pub(super) mailbox: Option<V2vMessage>,
    /// `both`: the lead's last speed and the control ticks since it arrived.
    pub(super) lead_info: Option<(f64, u32)>,
    /// Relay: a lead speed received and not yet forwarded to the follower behind.
    pub(super) relay_pending: Option<f64>,
    pub(super) speed_cmd: f64,
    pub(super) steer_cmd: f64,
    pub(super) path_curvature: f64,
    pub(super) last_tick_t: Option<f64>,
    pub(super) active: ActiveController,
    pub(super) reason: SwitchReason,
    pub(super) v2v_age: u32,
    pub(super) switches: u32,
    pub(super) detected: Option<f64>,
    pub(super) lookahead: (f64, f64),
    pub(super) accel_cmd: f64,
    pub(super) collision: Option<CollisionInfo>,
    pub(super) series: Series,
    /// Driven from outside ([`super::Simulation::drive`]): what its last scan gave, the command
    /// waiting; `None` for a follower its own law drives.
    pub(super) drive: Option<Box<Driven>>,
    /// An acceleration command from outside, m/s² (bypasses the low-level speed controller).
    pub(super) accel_override: Option<f64>,
}

impl Follower {
    pub(super) fn new(
        s: &Scenario,
        track: &Track,
        index: usize,
        cfg: FollowerConfig,
        body: Body,
        state: VehicleState,
        lead_link: bool,
    ) -> Result<Self, SimError> {
        let longitudinal = cfg.longitudinal()?;
        let detector_params = detector_params(&cfg, track.lane_width);
        let active = cfg.controller.initial_active();
        let distance_offset = cfg.follower.distance_offset.unwrap_or(cfg.follower.vehicle.length / 2.0 - cfg.lidar.mount_x);
        let v2v_lead = lead_link.then(|| V2vChannel::new(cfg.v2v.clone(), sub_seed(s.seed, follower_stream(index, 3))));
        Ok(Self {
            index,
            body,
            vehicle: Vehicle::new(cfg.follower.vehicle, state),
            speed_ctrl: SpeedController::new(cfg.follower.speed_controller),
            lidar: Lidar::new(cfg.lidar.clone(), sub_seed(s.seed, follower_stream(index, 1))),
            v2v: V2vChannel::new(cfg.v2v.clone(), sub_seed(s.seed, follower_stream(index, 2))),
            v2v_lead,
            gnss: GnssError::new(cfg.v2v.gnss, sub_seed(s.seed, follower_stream(index, 4))),
            detector: Box::new(<LeadDetector>::new(detector_params)?),
            neighbours: if cfg.controller.tracks_neighbours() { Some(NeighbourTracker::new(cfg.neighbours)?) } else { None },
            departure: LeadDeparture::new(departure_params(&detector_params, &cfg))?,
            pursuit: PurePursuit::new(cfg.pure_pursuit)?,
            lane_keeper: centreline_pursuit(&cfg.follower.vehicle)?,
            held_lane: None,
            last_lead_x: None,
            longitudinal,
            distance_offset,
            grid_buf: Vec::new(),
            lane_buf: Vec::new(),
            mailbox: None,
            lead_info: None,
            relay_pending: None,
            speed_cmd: cfg.follower.initial_speed,
            steer_cmd: 0.0,
            path_curvature: 0.0,
            last_tick_t: None,
            active,
            reason: SwitchReason::NoV2v,
            v2v_age: u32::MAX,
            switches: 0,
            detected: None,
            lookahead: (0.0, 0.0),
            accel_cmd: 0.0,
            collision: None,
            drive: None,
            accel_override: None,
            // Room for the whole run (up to 2^18 steps, 45 min at 10 ms; longer runs grow): no
            // reallocation while recording.
            series: Series::with_capacity(((s.duration / s.physics_dt).ceil() as usize + 2).min(1 << 18)),
            cfg,
        })
    }

    /// One delivered scan: the detector, the lateral control and the frame of the longitudinal
    /// law, which steps at once unless the follower is driven from outside ([`Follower::drive`]:
    /// the frame waits in `drive.pending` for [`Follower::resume`]).
    pub(super) fn control_tick(
        &mut self,
        t: f64,
        points: &[[f64; 2]],
        fs: &VehicleState,
        track: &Track,
        link: (V2vSource, f64),
        truth: Option<(f64, f64)>,
    ) {
        let (frame, det) = self.sense(t, points, fs, track, link, truth);
        match self.drive.as_mut() {
            None => self.apply_law(&frame),
            Some(d) => d.hold(t, frame, &det, points),
        }
    }

    /// Everything of a control tick but the longitudinal law: the detector, the lateral control,
    /// and the frame the law gets.
    fn sense(
        &mut self,
        t: f64,
        points: &[[f64; 2]],
        fs: &VehicleState,
        track: &Track,
        (source, lead_weight): (V2vSource, f64),
        truth: Option<(f64, f64)>,
    ) -> (Frame, flc_core::DetectorOutput) {
        let steering = self.cfg.steering();
        let mount = (self.cfg.lidar.mount_x, self.cfg.lidar.mount_y);
        let points = if steering == Steering::LaneKeeping {
            let mut profile = [0.0; PROFILE_STATIONS];
            let turned = lane_frame(points, fs, track, mount, self.path_curvature, &mut self.lane_buf, &mut profile);
            // Finite and within 100 m for any road the simulator builds; a profile it refuses
            // leaves the arc alone (the detector's own fallback).
            if self.detector.set_path_profile(PROFILE_SPACING, &profile).is_err() {
                let _ = self.detector.set_path_profile(0.0, &[]);
            }
            turned
        } else {
            points
        };
        let det = self
            .detector
            .detect(grid_points(&self.detector, &self.cfg.detector, points, self.path_curvature, &mut self.grid_buf), self.path_curvature);
        // Ideal perception (validation only): the true gap and speed of the vehicle in front; a
        // controller that sees the scene as a human does (the R157 careful driver): those of the
        // vehicle in front as it sees it (`human_front`; `None` when there is none).
        let ideal = self.cfg.follower.perception == Perception::Ideal || self.cfg.controller.perceives_truth();
        let mut detection = det.detection;
        let intruder = self.neighbours.as_mut().and_then(|n| n.update(self.detector.clusters()));
        let path_clear = self.departure.update(self.detector.clusters()) && intruder.is_none();
        // The pipeline gets the intruder beside the detection (its supervisor decides); the robust
        // FLCs follow it as their lead when it is nearer.
        let separate = self.cfg.controller == ControllerKind::Pipeline;
        if let Some(i) = intruder.filter(|_| !separate) {
            if detection.is_none_or(|d| i.distance < d.distance) {
                detection = Some(i);
            }
        }
        let intruder = intruder.filter(|_| separate && !ideal).map(|i| i.distance - self.distance_offset);
        let (distance, lead_speed) =
            if ideal { (truth.map(|x| x.0), truth.map(|x| x.1)) } else { (detection.map(|d| d.distance - self.distance_offset), None) };
        self.detected = distance;
        if steering == Steering::LaneKeeping {
            // Lane keeping: steer along the lane centre with the follower's own lane keeper (its
            // wheelbase and steering limit, not the lead's: a lead's shorter wheelbase made the
            // ego steer too little and run 0.9 m wide at R = 250 m); the detector's corridor
            // follows the lane.
            let s = track.project(fs.x, fs.y).s;
            self.steer_cmd = centreline_steer(track, &self.lane_keeper, fs, s, 0.0);
            self.path_curvature = track.curvature_at(s);
        } else if det.detection.is_none() && steering == Steering::Pursuit(LostLeadSteering::HoldLane) {
            self.hold_lane(fs, track);
        } else {
            // Pure pursuit in the vehicle frame (sensor offset added).
            let (mx, my) = (self.cfg.lidar.mount_x, self.cfg.lidar.mount_y);
            // The in-path lead, never an intruding neighbour: a cut-in is braked for, not steered to.
            let lead_pos = det.detection.map(|d| Point2::new(d.position.x + mx, d.position.y + my));
            let steer = self.pursuit.step(lead_pos, fs.speed);
            self.steer_cmd = steer.steer;
            self.lookahead = (steer.lookahead_point.x, steer.lookahead_point.y);
            // Path for the detector's corridor on the next scan: the arc from the sensor through
            // the lead just detected, kappa = 2 y / (x² + y²) (pure-pursuit geometry); straight
            // without one (`lost_lead_steering = "straight"`).
            self.path_curvature = det.detection.map_or(0.0, |d| arc_curvature(d.position.x, d.position.y));
            if let Some(d) = det.detection {
                self.held_lane = None;
                self.last_lead_x = Some(d.position.x);
            }
        }
        let dt = self.last_tick_t.map_or(1.0 / self.cfg.lidar.rate_hz, |p| t - p);
        self.last_tick_t = Some(t);
        let mut msg = self.mailbox.take();
        if source == V2vSource::Both && self.index > 1 {
            // The predecessor's message carries the weighted speed while the lead's is fresh.
            let fresh_lead = self.lead_info.filter(|(_, age)| *age <= self.cfg.supervisor.max_age_ticks).map(|(v, _)| v);
            if let (Some(m), Some(vl)) = (msg.as_mut(), fresh_lead) {
                m.lead_speed = (1.0 - lead_weight) * m.lead_speed + lead_weight * vl;
            }
            if let Some((_, age)) = self.lead_info.as_mut() {
                *age = age.saturating_add(1);
            }
        }
        // The own GNSS fix at the CAM reference point (centre of the front of the bounding box).
        let (ex, ey) = self.gnss.sample(t);
        let half = self.cfg.follower.vehicle.length / 2.0;
        let own_fix = Some(OwnFix { x: fs.x + half * fs.yaw.cos() + ex, y: fs.y + half * fs.yaw.sin() + ey, heading: fs.yaw });
        (
            Frame {
                distance,
                own_speed: fs.speed,
                v2v: msg,
                dt,
                lead_speed,
                own_fix,
                travelled: Some(fs.odometer * self.cfg.follower.odometry_scale),
                intruder,
                path_clear: path_clear && distance.is_none(),
            },
            det,
        )
    }

    /// A V2V message on its link at `t`: into the mailbox (the next scan's frame).
    pub(super) fn deliver(&mut self, t: f64, m: V2vMessage) {
        self.mailbox = Some(m);
        if let Some(d) = self.drive.as_mut() {
            d.received(t, m);
        }
    }

    /// Steps the longitudinal law on `frame` and holds its speed command.
    fn apply_law(&mut self, frame: &Frame) {
        // Every law gets the same frame; only the PID family reads `v2v`, only the laws whose
        // `uses_dt()` is true read `dt` (the FLC family takes neither).
        let out = self.longitudinal.step(frame);
        if out.switched {
            self.switches += 1;
        }
        self.active = out.active;
        self.reason = out.reason;
        self.v2v_age = out.v2v_age_ticks;
        let cmd = out.command;
        self.speed_cmd = cmd.speed;
    }

    /// A follower driven from outside, after its command for this step was set: the law steps on
    /// the frame held ([`DriveCommand::Law`]) or the command given replaces the law's (a speed
    /// command, held like the law's; an acceleration command, which bypasses the low-level speed
    /// controller until the next command). Without a frame held (no scan this step) a speed or
    /// acceleration command replaces the held one at once and `Law` changes nothing.
    pub(super) fn resume(&mut self) {
        let Some(d) = self.drive.as_mut() else { return };
        let frame = d.pending.take();
        let cmd = std::mem::take(&mut d.command);
        match cmd {
            DriveCommand::Law => {
                if let Some(frame) = frame {
                    self.accel_override = None;
                    self.apply_law(&frame);
                }
            }
            DriveCommand::Speed(v) => {
                self.accel_override = None;
                self.speed_cmd = v;
            }
            DriveCommand::Accel(a) => {
                self.accel_override = Some(a);
                self.speed_cmd = f64::NAN;
            }
        }
    }

    /// The acceleration demand of this physics step: the low-level speed controller's on the
    /// held speed command, or the acceleration command given from outside.
    pub(super) fn accel_demand(&mut self, dt: f64) -> f64 {
        let v = self.vehicle.state().speed;
        match self.accel_override {
            None => self.speed_ctrl.step(self.speed_cmd, v, dt),
            Some(a) => a,
        }
    }

    /// Lost-lead steering `hold_lane` (no lead detected this scan): steer along the centre of the
    /// lane held, the one whose centre was nearest to the follower when the lead was lost (the
    /// simulator's stand-in for a camera lane keeper: it reads the track, no sensor model), and
    /// put the detector's corridor for the next scan on that lane: the arc from the sensor
    /// through the lane centre at the forward distance of the last lead detected (at least the
    /// lane keeper's lookahead), so a lead still in the lane is found again where it was lost.
    fn hold_lane(&mut self, fs: &VehicleState, track: &Track) {
        let proj = track.project(fs.x, fs.y);
        let lane = *self.held_lane.get_or_insert_with(|| nearest_lane_offset(track, proj.lateral_offset));
        self.steer_cmd = centreline_steer(track, &self.lane_keeper, fs, proj.s, lane);
        let (mx, my) = (self.cfg.lidar.mount_x, self.cfg.lidar.mount_y);
        let reach = self.last_lead_x.unwrap_or(0.0).max(self.lane_keeper.lookahead(fs.speed));
        // The lane centre `reach` m ahead of the sensor, in the sensor's frame.
        let (px, py, _) = track.place(proj.s + mx + reach, lane);
        let (gx, gy) = (px - fs.x, py - fs.y);
        let (c, sn) = (fs.yaw.cos(), fs.yaw.sin());
        let (x, y) = (c * gx + sn * gy - mx, -sn * gx + c * gy - my);
        self.lookahead = (x + mx, y + my);
        self.path_curvature = arc_curvature(x, y);
    }

    /// Records the step (and returns its record): `gap` to the vehicle in path, `lead_gap` to the
    /// one followed in the string, `ls` the state of the vehicle in front.
    pub(super) fn record(
        &mut self,
        t: f64,
        track: &Track,
        (gap, lead_gap): (f64, f64),
        ls: &VehicleState,
        fs: &VehicleState,
    ) -> StepRecord {
        let proj = track.project(fs.x, fs.y);
        let heading_error = wrap_angle(fs.yaw - proj.heading);
        // The desired gap of the law that drives (the law's own formula).
        let desired = self.longitudinal.desired_gap(fs.speed);
        let rec = StepRecord {
            t,
            lead_x: ls.x,
            lead_y: ls.y,
            lead_speed: ls.speed,
            lead_accel: ls.accel,
            follower_x: fs.x,
            follower_y: fs.y,
            follower_yaw: fs.yaw,
            follower_speed: fs.speed,
            follower_accel: fs.accel,
            gap,
            desired_gap: desired,
            detected_distance: self.detected.unwrap_or(f64::NAN),
            speed_command: self.speed_cmd,
            accel_command: self.accel_cmd,
            steer_command: self.steer_cmd,
            active: self.active as u8,
            reason: self.reason as u8,
            v2v_age: if self.v2v_age == u32::MAX { f64::NAN } else { f64::from(self.v2v_age) },
            lateral_offset: proj.lateral_offset,
            heading_error,
            lead_gap,
        };
        self.series.push(rec);
        rec
    }
}

/// Lane keeping: the scan `points` (sensor frame of a LiDAR mounted at `(mx, my)` on a vehicle at
/// `fs`) turned into the lane's frame, and the lane's departure from the detector's arc as a path
/// profile ([`LeadDetector::set_path_profile`]), so that the detector's corridor runs along the
/// lane at the ego's lateral position: the ego's swept path if it keeps its lane.
///
/// 1. **Turned** by the lane's heading at the sensor relative to the vehicle's. Without the turn
///    the corridor left the lane on a curve: the sensor sits `mount_x` ahead of the body centre
///    (its lane tangent turned by `mount_x / R`) and the body of the kinematic bicycle is turned
///    out of the curve by its slip angle (together about 0.014 rad on R = 250 m: 0.7 m at 50 m),
///    and flc-robust passed a motorbike standing on the inner marking with 0.27 m of clearance
///    (`tests/in_path.rs`). The lane's heading is that of the chord over +-5 m of the sensor's
///    projection (the centreline is a polyline). The distances ahead change by less than
///    1 - cos of the turn (1e-4 at 0.015 rad).
/// 2. **The profile** (`profile`, stations [`PROFILE_SPACING`] m apart in the turned frame): the
///    lateral distance between the line parallel to the lane's centre through the sensor and the
///    arc of curvature `kappa` (the lane's at the ego, which the detector is given). Where the
///    curvature changes ahead (an S-bend, a curve's start) that arc leaves the lane: on
///    R = 1000 m arcs reversing 40 m ahead it is 1.6 m off at 80 m, and steady neighbours in the
///    next lane read as cut-ins (`tests/false_cut_ins.rs`). On an arc or a straight the profile
///    is about 0. The points are not moved, so their bearings stay true.
fn lane_frame<'a>(
    points: &'a [[f64; 2]],
    fs: &VehicleState,
    track: &Track,
    (mx, my): (f64, f64),
    kappa: f64,
    buf: &'a mut Vec<[f64; 2]>,
    profile: &mut [f64; PROFILE_STATIONS],
) -> &'a [[f64; 2]] {
    let (c, sn) = (fs.yaw.cos(), fs.yaw.sin());
    let (sx, sy) = (fs.x + c * mx - sn * my, fs.y + sn * mx + c * my);
    let proj = track.project(sx, sy);
    let s = proj.s;
    let ((x0, y0, _), (x1, y1, _)) = (track.place(s - 5.0, 0.0), track.place(s + 5.0, 0.0));
    let lane_heading = (y1 - y0).atan2(x1 - x0);
    let turn = wrap_angle(lane_heading - fs.yaw);
    // The parallel line sampled along the lane, in the turned frame, resampled at the stations'
    // forward distances (linear between samples; the last sample's departure beyond it, or from
    // where the lane turns back towards the sensor).
    let (cl, sl) = (lane_heading.cos(), lane_heading.sin());
    let departure = |x: f64, y: f64| y - kappa * x * x / (1.0 + (1.0 - kappa * kappa * x * x).max(0.0).sqrt());
    let mut prev = (0.0, departure(0.0, 0.0));
    let mut k = 0;
    let mut j = 0;
    while k < PROFILE_STATIONS && j < LANE_SAMPLES {
        j += 1;
        let (px, py, _) = track.place(s + j as f64 * LANE_SAMPLE, proj.lateral_offset);
        let (gx, gy) = (px - sx, py - sy);
        let (x, y) = (cl * gx + sl * gy, -sl * gx + cl * gy);
        if x <= prev.0 {
            break;
        }
        let d = departure(x, y);
        while k < PROFILE_STATIONS && k as f64 * PROFILE_SPACING <= x {
            let w = (k as f64 * PROFILE_SPACING - prev.0) / (x - prev.0);
            profile[k] = prev.1 + w.max(0.0) * (d - prev.1);
            k += 1;
        }
        prev = (x, d);
    }
    for o in profile.iter_mut().skip(k) {
        *o = prev.1;
    }
    if turn == 0.0 {
        return points;
    }
    let (ct, st) = (turn.cos(), turn.sin());
    buf.clear();
    buf.extend(points.iter().map(|&[x, y]| [x * ct + y * st, -x * st + y * ct]));
    buf
}

/// Spacing of the path profile's stations ([`lane_frame`]), m: 64 of them reach 252 m (the
/// default grid ends at 200.5 m).
const PROFILE_SPACING: f64 = 4.0;
/// Spacing of the samples of the lane the profile is resampled from, m.
const LANE_SAMPLE: f64 = 2.0;
/// Samples of the lane: up to 300 m along it.
const LANE_SAMPLES: usize = 150;

/// Curvature of the arc from the sensor (heading along x) through `(x, y)`, kappa = 2 y / (x² +
/// y²) (pure-pursuit geometry); 0 for a point within 1 m.
fn arc_curvature(x: f64, y: f64) -> f64 {
    let r2 = x * x + y * y;
    if r2 > 1.0 { 2.0 * y / r2 } else { 0.0 }
}

/// The detector's parameters this follower runs on lanes `lane_width` m wide: `[detector]`, with
/// the swept-path corridor of the followers that use it ([`crate::FollowerConfig::swept_corridor`])
/// set to the ego's half width plus the corridor margin (`sim/path.rs`, 0.5 m) when the scenario
/// leaves `detector.swept_half_width` at 0; a value the scenario sets is used as given.
///
/// An ego that keeps its lane also counts a wide object whose body reaches into the band its own
/// body sweeps plus the same margin (`detector.body_half_width`, left at 0), after everything else
/// in path; one steering after its lead does not (its path bends towards the lead). For such an
/// ego both half widths are at least half its lane ([`super::lane_keeping_half_width`]): an object
/// poking into its lane is in its path.
fn detector_params(cfg: &FollowerConfig, lane_width: f64) -> flc_core::DetectorParams {
    let mut p = cfg.detector;
    let lane_keeping = cfg.steering() == Steering::LaneKeeping;
    let swept = 0.5 * cfg.follower.vehicle.width + super::CORRIDOR_MARGIN;
    let in_lane = super::lane_keeping_half_width(cfg.follower.vehicle.width, lane_width);
    if cfg.swept_corridor() && p.swept_half_width == 0.0 {
        p.swept_half_width = if lane_keeping { in_lane } else { swept };
    }
    if lane_keeping && p.body_half_width == 0.0 {
        p.body_half_width = in_lane;
    }
    p
}

/// The departure watch of a follower: an ego that keeps its lane clears its path once the body
/// of the lead it lost lies beyond the detector's corridor (the larger of its two half widths);
/// one steering after its lead does not watch (its path bends towards where the lead was).
fn departure_params(detector: &flc_core::DetectorParams, cfg: &FollowerConfig) -> DepartureParams {
    let clear_half_width =
        if cfg.steering() == Steering::LaneKeeping { detector.swept_half_width.max(detector.body_half_width) } else { 0.0 };
    DepartureParams { clear_half_width, ..DepartureParams::default() }
}
