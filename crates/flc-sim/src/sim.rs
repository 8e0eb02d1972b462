//! The closed loop: world, vehicles, LiDAR, V2V and the `flc-core` pipeline, stepped together.
//!
//! Per physics step (`physics_dt`, default 10 ms):
//! 1. the lead's driver turns its phases into an acceleration command, pure pursuit on the
//!    track's centreline (plus the phase's lateral offset) steers it;
//! 2. the V2V channel may deliver a message (kept in the follower's mailbox);
//! 3. the LiDAR may deliver a scan (its own rate, jitter, latency, drops); on each delivered scan
//!    the follower's pipeline runs once: detector -> pure pursuit + longitudinal controller
//!    (FLC, PID or the supervisor); the resulting speed command is held until the next scan;
//! 4. the follower's low-level speed controller turns the held speed command into an
//!    acceleration command; both vehicle models step; rapier moves the bodies and reports contacts.
//!
//! Collisions come from rapier's contact events between the vehicle colliders.

use std::path::{Path, PathBuf};

use flc_core::baselines::{AccController, CarlaBehaviorController, IdmController, RssController};
use flc_core::{
    ActiveController, Baseline, FallbackController, LeadDetector, PidController, Point2, PurePursuit, RobustFallbackController, Supervisor,
    SwitchReason, V2vMessage,
};

use crate::error::{ConfigError, SimError};
use crate::lead::LeadDriver;
use crate::lidar::Lidar;
use crate::metrics::{CollisionInfo, Metrics, Series, StepRecord};
use crate::platoon::{FollowerConfig, V2vSource};
use crate::record::Recorder;
use crate::scenario::{ControllerKind, Scenario};
use crate::string_stability::StringStability;
use crate::track::Track;
use crate::v2v::V2vChannel;
use crate::vehicle::{SpeedController, Vehicle, VehicleState};
use crate::world::{Body, World};

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The scenario that ran.
    pub scenario: Scenario,
    /// The metrics (of follower 1 in a platoon).
    pub metrics: Metrics,
    /// The per-step time series (of follower 1 and the lead in a platoon).
    pub series: Series,
    /// With `[platoon]`: every follower's series and metrics and the string-stability measures.
    pub platoon: Option<PlatoonResult>,
}

/// One follower of a platoon run. Its series' `lead_*` columns are those of the vehicle in front
/// of it (the lead for follower 1), `gap` the gap to that vehicle.
#[derive(Debug, Clone)]
pub struct FollowerRun {
    /// Per-step time series.
    pub series: Series,
    /// Metrics against the vehicle in front.
    pub metrics: Metrics,
    /// Its first contact with the vehicle in front, if any.
    pub collision: Option<CollisionInfo>,
}

/// What a platoon run produced besides follower 1's [`RunResult::series`] / [`RunResult::metrics`].
#[derive(Debug, Clone)]
pub struct PlatoonResult {
    /// Followers 1..N (index 0 = follower 1).
    pub followers: Vec<FollowerRun>,
    /// The string-stability measures of this run (time domain; `frequency_response` is filled
    /// by [`crate::string_stability::frequency_response`]).
    pub string_stability: StringStability,
}

/// Runs a scenario without recording.
pub fn run(scenario: &Scenario) -> Result<RunResult, SimError> {
    run_with(scenario, None)
}

/// Runs a scenario; with `record`, also writes an MCAP recording into that directory.
pub fn run_with(scenario: &Scenario, record: Option<&Path>) -> Result<RunResult, SimError> {
    scenario.validate()?;
    let mut sim = Simulation::new(scenario)?;
    if let Some(dir) = record {
        sim.record_to(dir)?;
    }
    while sim.step()? {}
    sim.finish_recording(true)?;
    Ok(sim.finish())
}

/// Runs many scenarios in parallel (rayon) with an optional progress bar; results in input order.
pub fn run_batch(scenarios: &[Scenario], progress: bool) -> Vec<Result<RunResult, SimError>> {
    use rayon::prelude::*;
    let bar = if progress {
        let b = indicatif::ProgressBar::new(scenarios.len() as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed_precise} {msg}") {
            b.set_style(style);
        }
        Some(b)
    } else {
        None
    };
    let out = scenarios
        .par_iter()
        .map(|s| {
            let r = run(s);
            if let Some(b) = &bar {
                b.inc(1);
            }
            r
        })
        .collect();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    out
}

/// Seeds of the random processes, derived from the scenario seed (SplitMix64 steps), so that each
/// process has its own stream and changing one impairment does not reshuffle another.
pub(crate) fn sub_seed(seed: u64, stream: u64) -> u64 {
    let mut z = seed.wrapping_add(stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The longitudinal controller of one follower: one arm per [`ControllerKind`].
enum Longitudinal {
    Flc(FallbackController),
    Pid(PidController),
    Pipeline(Box<Supervisor>),
    Baseline(Baseline),
    FlcRobust(RobustFallbackController),
}

impl Longitudinal {
    /// The controller of a follower configured by `c` (`s`: the whole scenario).
    fn new(_s: &Scenario, c: &FollowerConfig) -> Result<Self, SimError> {
        Ok(match c.controller {
            ControllerKind::Flc => Longitudinal::Flc(FallbackController::new(c.flc)?),
            ControllerKind::Pid => Longitudinal::Pid(PidController::new(c.pid)?),
            ControllerKind::Pipeline => Longitudinal::Pipeline(Box::new(Supervisor::new(c.supervisor_params())?)),
            ControllerKind::Idm => Longitudinal::Baseline(IdmController::new(c.idm)?.into()),
            ControllerKind::Acc => Longitudinal::Baseline(AccController::new(c.acc)?.into()),
            ControllerKind::Rss => Longitudinal::Baseline(RssController::new(c.rss)?.into()),
            ControllerKind::CarlaBehavior => Longitudinal::Baseline(CarlaBehaviorController::new(c.carla_behavior)?.into()),
            ControllerKind::FlcRobust => Longitudinal::FlcRobust(RobustFallbackController::new(c.flc_robust)?),
        })
    }
}

/// Random stream `j` of follower `k` (1-based): follower 1 keeps the single-follower streams
/// (1 = LiDAR, 2 = V2V link, 3 = second V2V link), follower `k` uses `j + 16 (k - 1)`.
fn follower_stream(k: usize, j: u64) -> u64 {
    j + 16 * (k as u64 - 1)
}

/// One follower: its vehicle, sensors, links, pipeline state and records.
struct Follower {
    /// 1-based position in the string.
    index: usize,
    cfg: FollowerConfig,
    body: Body,
    vehicle: Vehicle,
    speed_ctrl: SpeedController,
    lidar: Lidar,
    /// The link its PID / supervisor listens to: from the predecessor (`predecessor`, `both`) or
    /// from the lead (`lead`; relayed by the predecessor with `relay`).
    v2v: V2vChannel,
    /// `both`, followers 2..N: the link carrying the lead's speed (direct or relayed).
    v2v_lead: Option<V2vChannel>,
    detector: Box<LeadDetector>,
    pursuit: PurePursuit,
    longitudinal: Longitudinal,
    distance_offset: f64,
    /// The scan's points that can fall into the detector's grid (reused buffer).
    grid_buf: Vec<[f64; 2]>,
    mailbox: Option<V2vMessage>,
    /// `both`: the lead's last speed and the control ticks since it arrived.
    lead_info: Option<(f64, u32)>,
    /// Relay: a lead speed received and not yet forwarded to the follower behind.
    relay_pending: Option<f64>,
    last_lead_speed: Option<f64>,
    speed_cmd: f64,
    steer_cmd: f64,
    path_curvature: f64,
    last_tick_t: Option<f64>,
    active: ActiveController,
    reason: SwitchReason,
    v2v_age: u32,
    switches: u32,
    detected: Option<f64>,
    lookahead: (f64, f64),
    accel_cmd: f64,
    collision: Option<CollisionInfo>,
    series: Series,
}

impl Follower {
    fn new(s: &Scenario, index: usize, cfg: FollowerConfig, body: Body, state: VehicleState, lead_link: bool) -> Result<Self, SimError> {
        let longitudinal = Longitudinal::new(s, &cfg)?;
        let active = match cfg.controller {
            ControllerKind::Pid => ActiveController::Pid,
            _ => ActiveController::Flc,
        };
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
            detector: Box::new(<LeadDetector>::new(cfg.detector)?),
            pursuit: PurePursuit::new(cfg.pure_pursuit)?,
            longitudinal,
            distance_offset,
            grid_buf: Vec::new(),
            mailbox: None,
            lead_info: None,
            relay_pending: None,
            last_lead_speed: None,
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
            // Room for the whole run (up to 2^18 steps, 45 min at 10 ms; longer runs grow): no
            // reallocation while recording.
            series: Series::with_capacity(((s.duration / s.physics_dt).ceil() as usize + 2).min(1 << 18)),
            cfg,
        })
    }

    fn control_tick(&mut self, t: f64, points: &[[f64; 2]], fs: &VehicleState, road: &Road<'_>, source: V2vSource, lead_weight: f64) {
        let det = self.detector.detect(grid_points(&self.detector, &self.cfg.detector, points, &mut self.grid_buf), self.path_curvature);
        let detection = det.detection;
        let distance = detection.map(|d| d.distance - self.distance_offset);
        self.detected = distance;
        if self.cfg.follower.lane_keeping {
            // Lane keeping (lead-change scenarios): steer along the lane centre like the lead's
            // driver; the detector's corridor follows the lane.
            let s = road.track.project(fs.x, fs.y).s;
            self.steer_cmd = centreline_steer(road.track, road.steer, fs, s, 0.0);
            self.path_curvature = road.track.curvature_at(s);
        } else {
            // Pure pursuit in the vehicle frame (sensor offset added).
            let (mx, my) = (self.cfg.lidar.mount_x, self.cfg.lidar.mount_y);
            let lead_pos = detection.map(|d| Point2::new(d.position.x + mx, d.position.y + my));
            let steer = self.pursuit.step(lead_pos, fs.speed);
            self.steer_cmd = steer.steer;
            self.lookahead = (steer.lookahead_point.x, steer.lookahead_point.y);
            // Path for the detector's corridor on the next scan: the arc from the sensor through
            // the lead just detected, kappa = 2 y / (x² + y²) (pure-pursuit geometry); straight
            // without one.
            self.path_curvature = detection.map_or(0.0, |d| {
                let (x, y) = (d.position.x, d.position.y);
                let r2 = x * x + y * y;
                if r2 > 1.0 { 2.0 * y / r2 } else { 0.0 }
            });
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
        if let Some(m) = msg {
            self.last_lead_speed = Some(m.lead_speed);
        }
        let cmd = match &mut self.longitudinal {
            Longitudinal::Flc(c) => c.step(distance, fs.speed),
            Longitudinal::Pid(c) => {
                // PID only: the last received lead speed is held (own speed before any message).
                let sl = self.last_lead_speed.unwrap_or(fs.speed);
                c.step(sl, fs.speed, distance, dt)
            }
            Longitudinal::Pipeline(s) => {
                let out = s.step(msg, distance, fs.speed, dt);
                if out.switched {
                    self.switches += 1;
                }
                self.active = out.active;
                self.reason = out.reason;
                self.v2v_age = out.v2v_age_ticks;
                out.command
            }
            // The baselines get what the FLC gets plus the frame interval (their range-rate
            // estimator needs it).
            Longitudinal::Baseline(b) => b.step(distance, fs.speed, dt),
            // The robust FLC gets exactly what the FLC gets (no dt).
            Longitudinal::FlcRobust(c) => c.step(distance, fs.speed),
        };
        self.speed_cmd = cmd.speed;
    }

    fn record(&mut self, t: f64, track: &Track, gap: f64, ls: &VehicleState, fs: &VehicleState) {
        let proj = track.project(fs.x, fs.y);
        let heading_error = wrap_angle(fs.yaw - proj.heading);
        // The desired gap of the controller that drives.
        let desired = match (&self.longitudinal, self.active) {
            (Longitudinal::Baseline(_), _) => self.cfg.baseline_desired_gap(fs.speed),
            (Longitudinal::FlcRobust(c), _) => c.params().desired_gap(fs.speed),
            (_, ActiveController::Pid) => self.cfg.pid.desired_distance(fs.speed),
            (_, ActiveController::Flc) => self.cfg.flc.desired_distance(fs.speed) + self.cfg.flc.f_shift(fs.speed),
        };
        self.series.push(StepRecord {
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
        });
    }
}

/// The road a follower's pipeline may need: the track and the lead driver's pure pursuit (lane
/// keeping steers like the lead's driver).
struct Road<'a> {
    track: &'a Track,
    steer: &'a PurePursuit,
}

/// Steering along the track's centreline (plus `offset`, m, + left) with pure pursuit `pp`, for a
/// vehicle at `state` whose projection on the centreline is at `s`.
fn centreline_steer(track: &Track, pp: &PurePursuit, state: &VehicleState, s: f64, offset: f64) -> f64 {
    let d_ahead = pp.lookahead(state.speed);
    let (tx, ty, th) = track.pose_at(s + d_ahead);
    let (nx, ny) = (-th.sin(), th.cos());
    let (gx, gy) = (tx + offset * nx - state.x, ty + offset * ny - state.y);
    let (c, sn) = (state.yaw.cos(), state.yaw.sin());
    let local = Point2::new(c * gx + sn * gy, -sn * gx + c * gy);
    pp.step(Some(local), state.speed).steer
}

/// The points of a scan the detector can use: those within 1 cm of its grid (plus any
/// non-finite ones, which it counts). The detector ignores every other point (`cell_of` is
/// `None` for them), so its result is the same as on the whole scan, with less work: on a road
/// with guard rails about half the returns lie outside the grid. Scans longer than
/// `max_points` are passed whole (the detector truncates them).
fn grid_points<'a>(
    det: &LeadDetector,
    params: &flc_core::DetectorParams,
    points: &'a [[f64; 2]],
    buf: &'a mut Vec<[f64; 2]>,
) -> &'a [[f64; 2]] {
    if points.len() > params.max_points {
        return points;
    }
    let ((x0, x1), (y0, y1)) = (det.x_range(), det.y_range());
    let (x0, x1, y0, y1) = (x0 - 0.01, x1 + 0.01, y0 - 0.01, y1 + 0.01);
    buf.clear();
    buf.extend(points.iter().filter(|[x, y]| !(x.is_finite() && y.is_finite()) || (*x >= x0 && *x <= x1 && *y >= y0 && *y <= y1)));
    buf
}

/// Bumper-to-bumper distance along the front vehicle's heading (the "gap").
fn bumper_gap(front: &VehicleState, front_length: f64, back: &VehicleState, back_length: f64) -> f64 {
    let (dx, dy) = (front.x - back.x, front.y - back.y);
    let centre = dx * front.yaw.cos() + dy * front.yaw.sin();
    centre - front_length / 2.0 - back_length / 2.0
}

/// A running closed-loop simulation (step it, then [`Simulation::finish`]). A scenario without
/// `[platoon]` is the one-follower case of the same loop.
pub struct Simulation {
    scenario: Scenario,
    track: Track,
    world: World,
    lead_body: Body,
    lead: Vehicle,
    lead_driver: LeadDriver,
    lead_steer: PurePursuit,
    lead_x0: f64,
    followers: Vec<Follower>,
    source: V2vSource,
    lead_weight: f64,
    relay: bool,
    /// Speeds of the vehicles at the start of the step (0 = lead), reused.
    speeds: Vec<f64>,
    // bookkeeping
    t: f64,
    k: u64,
    standstill_since: Option<f64>,
    /// MCAP recording (`crate::record`) of the lead and follower 1; finished by
    /// `finish_recording` or, on any early exit, by its `Drop`.
    recorder: Option<Box<Recorder>>,
}

impl Simulation {
    /// Builds the world and every component from a validated scenario.
    pub fn new(s: &Scenario) -> Result<Self, SimError> {
        let track = s.track.build()?;
        let configs = s.follower_configs()?;
        let platoon = s.platoon.clone().unwrap_or_default();
        let mut world = World::new(&track);
        // Every vehicle starts on the centreline, the last follower's rear bumper 1 m after the
        // track's start, each front bumper its initial gap behind the rear bumper in front
        // (one follower: its front bumper `initial_gap` behind the lead's rear bumper).
        let ll = &s.lead.vehicle;
        let n = configs.len();
        let mut s_pos = vec![0.0; n + 1];
        if let Some(last) = configs.last() {
            s_pos[n] = last.follower.vehicle.length / 2.0 + 1.0;
        }
        for k in (1..=n).rev() {
            let c = &configs[k - 1];
            let gap = if platoon.equilibrium_start {
                c.reference_gap(c.follower.initial_speed).unwrap_or(c.follower.initial_gap)
            } else {
                c.follower.initial_gap
            };
            let front_len = if k == 1 { ll.length } else { configs[k - 2].follower.vehicle.length };
            s_pos[k - 1] = s_pos[k] + c.follower.vehicle.length / 2.0 + gap + front_len / 2.0;
        }
        let state_at = |sp: f64, speed: f64| {
            let (x, y, yaw) = track.pose_at(sp);
            VehicleState { x, y, yaw, speed, ..VehicleState::default() }
        };
        let lead_state = state_at(s_pos[0], s.lead.initial_speed);
        // Bodies: follower 1, the lead, then followers 2..N.
        let mut bodies = Vec::with_capacity(n);
        let mut lead_body = None;
        for (k, c) in configs.iter().enumerate() {
            bodies.push(world.add_vehicle(&c.follower.vehicle, &state_at(s_pos[k + 1], c.follower.initial_speed)));
            if k == 0 {
                lead_body = Some(world.add_vehicle(ll, &lead_state));
            }
        }
        let lead_body = lead_body.ok_or_else(|| ConfigError::new("platoon.followers", "at least one follower"))?;
        let mut followers = Vec::with_capacity(n);
        for (k, (c, body)) in configs.into_iter().zip(bodies).enumerate() {
            let state = state_at(s_pos[k + 1], c.follower.initial_speed);
            let lead_link = platoon.v2v_source == V2vSource::Both && k >= 1;
            followers.push(Follower::new(s, k + 1, c, body, state, lead_link)?);
        }
        let lead_pp = flc_core::PurePursuitParams {
            base_lookahead: 6.0,
            lookahead_gain: 0.8,
            law: flc_core::PursuitLaw::Standard,
            wheelbase: ll.wheelbase,
            max_steer: ll.max_steer,
        };
        Ok(Self {
            scenario: s.clone(),
            lead_x0: s_pos[0],
            world,
            lead_body,
            lead: Vehicle::new(*ll, lead_state),
            lead_driver: LeadDriver::new(&s.lead.phases, s.lead.initial_speed),
            lead_steer: PurePursuit::new(lead_pp)?,
            followers,
            source: platoon.v2v_source,
            lead_weight: platoon.lead_weight,
            relay: platoon.relay,
            speeds: Vec::with_capacity(n + 1),
            t: 0.0,
            k: 0,
            standstill_since: None,
            recorder: None,
            track,
        })
    }

    /// Simulation time, s.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Number of followers.
    pub fn n_followers(&self) -> usize {
        self.followers.len()
    }

    /// One physics step. Returns `Ok(false)` when the run is over.
    pub fn step(&mut self) -> Result<bool, SimError> {
        let dt = self.scenario.physics_dt;
        let t = self.t;

        // 1. Lead driver and lateral control along the centreline.
        let ls = *self.lead.state();
        let lproj = self.track.project(ls.x, ls.y);
        let lcmd = self.lead_driver.step(t, ls.speed, lproj.s - self.lead_x0);
        let lead_steer = self.lead_centreline_steer(&ls, lproj.s, lcmd.lateral_offset);
        if let Some(onset) = self.lead_driver.brake_onset() {
            for f in &mut self.followers {
                if f.cfg.v2v.outage_on_brake {
                    f.v2v.start_outage(onset);
                    if let Some(l) = f.v2v_lead.as_mut() {
                        l.start_outage(onset);
                    }
                }
            }
        }

        // 2. V2V: every link broadcasts its sender's speed at the start of the step.
        self.speeds.clear();
        self.speeds.push(ls.speed);
        self.speeds.extend(self.followers.iter().map(|f| f.vehicle.state().speed));
        for k in 0..self.followers.len() {
            let pending = if self.relay && k >= 1 { self.followers[k - 1].relay_pending } else { None };
            let mut consumed = false;
            let f = &mut self.followers[k];
            match self.source {
                V2vSource::Predecessor => {
                    if let Some(m) = f.v2v.tick(t, self.speeds[k]) {
                        f.mailbox = Some(m);
                    }
                }
                V2vSource::Lead => {
                    let m = if self.relay && k >= 1 { relay_tick(&mut f.v2v, t, pending, &mut consumed) } else { f.v2v.tick(t, ls.speed) };
                    if let Some(m) = m {
                        f.mailbox = Some(m);
                        f.relay_pending = Some(m.lead_speed);
                    }
                }
                V2vSource::Both => {
                    let pred = f.v2v.tick(t, self.speeds[k]);
                    if let Some(m) = pred {
                        f.mailbox = Some(m);
                    }
                    let lead_msg = match f.v2v_lead.as_mut() {
                        // Follower 1: its predecessor is the lead.
                        None => pred,
                        Some(ch) if self.relay => relay_tick(ch, t, pending, &mut consumed),
                        Some(ch) => ch.tick(t, ls.speed),
                    };
                    if let Some(m) = lead_msg {
                        f.lead_info = Some((m.lead_speed, 0));
                        f.relay_pending = Some(m.lead_speed);
                    }
                }
            }
            if consumed {
                self.followers[k - 1].relay_pending = None;
            }
        }

        // 3. LiDAR scans -> pipelines (every follower sees the world as it is at the start of the step).
        for f in &mut self.followers {
            let fs = *f.vehicle.state();
            if let Some(scan) = f.lidar.tick(t, &self.world, f.body, &fs) {
                f.control_tick(t, &scan.points, &fs, &Road { track: &self.track, steer: &self.lead_steer }, self.source, self.lead_weight);
                if f.index == 1 {
                    if let Some(rec) = self.recorder.as_deref_mut() {
                        rec.scan(t, &scan, f.detector.clusters(), f.detected, f.lookahead)?;
                    }
                }
            }
        }

        // 4. Low-level control and dynamics.
        for f in &mut self.followers {
            let v = f.vehicle.state().speed;
            f.accel_cmd = f.speed_ctrl.step(f.speed_cmd, v, dt);
            f.vehicle.step(f.accel_cmd, f.steer_cmd, dt);
        }
        self.lead.step(lcmd.accel, lead_steer, dt);
        for (i, f) in self.followers.iter().enumerate() {
            self.world.set_pose(f.body, f.vehicle.state());
            if i == 0 {
                self.world.set_pose(self.lead_body, self.lead.state());
            }
        }
        let contacts = self.world.step(dt);
        self.t += dt;
        self.k += 1;

        // 5. Records: each follower against the vehicle in front of it.
        let ls = *self.lead.state();
        let (mut front, mut front_len, mut front_body) = (ls, self.scenario.lead.vehicle.length, self.lead_body);
        let mut all_still = ls.speed < 0.05;
        let mut collided = false;
        for f in &mut self.followers {
            let fs = *f.vehicle.state();
            let len = f.cfg.follower.vehicle.length;
            let gap = bumper_gap(&front, front_len, &fs, len);
            if f.collision.is_none() && contacts.iter().any(|c| c.involves(front_body) && c.involves(f.body)) {
                f.collision = Some(CollisionInfo {
                    time: self.t,
                    impact_speed: (fs.speed - front.speed).max(0.0),
                    lead_speed: front.speed,
                    follower_speed: fs.speed,
                });
            }
            collided |= f.collision.is_some();
            all_still &= fs.speed < 0.05;
            f.record(self.t, &self.track, gap, &front, &fs);
            (front, front_len, front_body) = (fs, len, f.body);
        }
        if let (Some(rec), Some(f)) = (self.recorder.as_deref_mut(), self.followers.first()) {
            if let Some(r) = f.series.len().checked_sub(1).and_then(|last| f.series.get(last)) {
                rec.step(&r, &ls, f.vehicle.state())?;
            }
        }

        // Stop conditions.
        if collided && self.scenario.stop.on_collision {
            return Ok(false);
        }
        if self.lead_driver.finished() && all_still {
            let since = *self.standstill_since.get_or_insert(self.t);
            if self.t - since >= self.scenario.stop.standstill_time {
                return Ok(false);
            }
        } else {
            self.standstill_since = None;
        }
        Ok(self.t < self.scenario.duration - 0.5 * dt)
    }

    fn lead_centreline_steer(&self, ls: &VehicleState, s: f64, offset: f64) -> f64 {
        centreline_steer(&self.track, &self.lead_steer, ls, s, offset)
    }

    /// Starts an MCAP recording of this run in `dir` (see [`crate::record`]; call it before the
    /// first step to record the whole run). Returns the file's path. A platoon's recording holds
    /// the lead and follower 1.
    pub fn record_to(&mut self, dir: &Path) -> Result<PathBuf, SimError> {
        let Some(f) = self.followers.first() else { return Err(ConfigError::new("platoon.followers", "at least one follower").into()) };
        let rec = Recorder::create(dir, &self.scenario, &self.track, self.t, self.lead.state(), f.vehicle.state())?;
        let path = rec.path().to_path_buf();
        self.recorder = Some(Box::new(rec));
        Ok(path)
    }

    /// Finishes the recording, if any (with the metrics of the steps so far if `with_metrics`),
    /// and returns its path. Without this call the recording is finished when the simulation is
    /// dropped or finished, errors ignored.
    pub fn finish_recording(&mut self, with_metrics: bool) -> Result<Option<PathBuf>, SimError> {
        let Some(rec) = self.recorder.take() else { return Ok(None) };
        let metrics = match (with_metrics, self.followers.first()) {
            (true, Some(f)) => Some(Metrics::compute(&f.series, f.collision)),
            _ => None,
        };
        rec.finish(metrics.as_ref()).map(Some)
    }

    /// Ends the run and computes the metrics (follower 1's as [`RunResult::metrics`]; with
    /// `[platoon]` every follower's and the string-stability measures in [`RunResult::platoon`]).
    pub fn finish(self) -> RunResult {
        let configs: Vec<FollowerConfig> = self.followers.iter().map(|f| f.cfg.clone()).collect();
        let mut runs: Vec<FollowerRun> = self
            .followers
            .into_iter()
            .map(|f| FollowerRun { metrics: Metrics::compute(&f.series, f.collision), series: f.series, collision: f.collision })
            .collect();
        let platoon = self.scenario.platoon.as_ref().map(|p| {
            let string_stability = StringStability::measure(&p.string_stability, &runs, &configs, self.lead_driver.brake_onset());
            PlatoonResult { followers: runs.clone(), string_stability }
        });
        let first = runs.swap_remove(0);
        RunResult { scenario: self.scenario, metrics: first.metrics, series: first.series, platoon }
    }
}

/// Relay link: forwards `pending` (a lead speed the sender received and has not forwarded yet)
/// on the first due broadcast slot (`consumed` tells), then delivers what has arrived.
fn relay_tick(ch: &mut V2vChannel, t: f64, pending: Option<f64>, consumed: &mut bool) -> Option<V2vMessage> {
    if let Some(v) = pending {
        if ch.broadcast_due(t) {
            ch.send(t, v);
            *consumed = true;
        }
    }
    ch.receive(t)
}

fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn follower_one_keeps_the_single_follower_streams() {
        assert_eq!([1, 2, 3].map(|j| follower_stream(1, j)), [1, 2, 3]);
        assert_eq!(follower_stream(2, 1), 17);
        // Distinct streams for every follower and process.
        let mut all: Vec<u64> = (1..=64).flat_map(|k| (1..=3).map(move |j| follower_stream(k, j))).collect();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), 64 * 3);
    }

    #[test]
    fn grid_prefilter_does_not_change_the_detection() {
        // Random scans with points inside, outside and within a few mm of the detector's grid:
        // the detector sees the same scan whether or not the points outside are dropped.
        let params = flc_core::DetectorParams::default();
        let mut a = <LeadDetector>::new(params).unwrap();
        let mut b = <LeadDetector>::new(params).unwrap();
        let ((x0, x1), (y0, y1)) = (a.x_range(), a.y_range());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut buf = Vec::new();
        for _ in 0..300 {
            let mut pts: Vec<[f64; 2]> = Vec::new();
            // A car somewhere ahead, rails, clutter, edge points.
            let (cx, cy) = (rng.random_range(3.0..80.0), rng.random_range(-5.0..5.0));
            for i in 0..30 {
                pts.push([cx + rng.random_range(-0.02..0.02), cy - 0.9 + 1.8 * f64::from(i) / 29.0]);
            }
            for _ in 0..300 {
                let x: f64 = rng.random_range(-2.0..110.0);
                pts.push([x, if rng.random_bool(0.5) { -3.15 } else { 6.65 } + rng.random_range(-0.03..0.03)]);
            }
            for _ in 0..40 {
                let e = rng.random_range(-0.005..0.005);
                pts.push(match rng.random_range(0..4) {
                    0 => [x0 + e, rng.random_range(y0..y1)],
                    1 => [x1 + e, rng.random_range(y0..y1)],
                    2 => [rng.random_range(x0..x1), y0 + e],
                    _ => [rng.random_range(x0..x1), y1 + e],
                });
            }
            let kappa = rng.random_range(-0.01..0.01);
            let full = a.detect(&pts, kappa);
            let filtered = b.detect(grid_points(&b, &params, &pts, &mut buf), kappa);
            assert_eq!(full.detection, filtered.detection);
            assert_eq!(a.clusters(), b.clusters());
            assert!(buf.len() < pts.len());
        }
    }
}
