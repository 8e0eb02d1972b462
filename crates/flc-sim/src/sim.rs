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

use crate::error::SimError;
use crate::lead::LeadDriver;
use crate::lidar::Lidar;
use crate::metrics::{CollisionInfo, Metrics, Series, StepRecord};
use crate::record::Recorder;
use crate::scenario::{ControllerKind, Scenario};
use crate::track::Track;
use crate::v2v::V2vChannel;
use crate::vehicle::{SpeedController, Vehicle, VehicleState};
use crate::world::{Body, World};

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The scenario that ran.
    pub scenario: Scenario,
    /// The metrics.
    pub metrics: Metrics,
    /// The per-step time series.
    pub series: Series,
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

enum Longitudinal {
    Flc(FallbackController),
    Pid(PidController),
    Pipeline(Box<Supervisor>),
    Baseline(Baseline),
    FlcRobust(RobustFallbackController),
}

/// A running closed-loop simulation (step it, then [`Simulation::finish`]).
pub struct Simulation {
    scenario: Scenario,
    track: Track,
    world: World,
    lead_body: Body,
    follower_body: Body,
    lead: Vehicle,
    follower: Vehicle,
    lead_driver: LeadDriver,
    lead_steer: PurePursuit,
    lead_x0: f64,
    speed_ctrl: SpeedController,
    lidar: Lidar,
    v2v: V2vChannel,
    detector: Box<LeadDetector>,
    pursuit: PurePursuit,
    longitudinal: Longitudinal,
    distance_offset: f64,
    // follower pipeline state
    mailbox: Option<V2vMessage>,
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
    // bookkeeping
    t: f64,
    k: u64,
    standstill_since: Option<f64>,
    collision: Option<CollisionInfo>,
    series: Series,
    /// MCAP recording (`crate::record`); finished by `finish_recording` or, on any early exit, by
    /// its `Drop`.
    recorder: Option<Box<Recorder>>,
}

impl Simulation {
    /// Builds the world and every component from a validated scenario.
    pub fn new(s: &Scenario) -> Result<Self, SimError> {
        let track = s.track.build()?;
        let mut world = World::new(&track);
        // Both vehicles start on the centreline: the follower's front bumper `initial_gap`
        // behind the lead's rear bumper.
        let lf = &s.follower.vehicle;
        let ll = &s.lead.vehicle;
        let follower_s = lf.length / 2.0 + 1.0;
        let lead_s = follower_s + lf.length / 2.0 + s.follower.initial_gap + ll.length / 2.0;
        let (fx, fy, fh) = track.pose_at(follower_s);
        let (lx, ly, lh) = track.pose_at(lead_s);
        let follower_state = VehicleState { x: fx, y: fy, yaw: fh, speed: s.follower.initial_speed, ..VehicleState::default() };
        let lead_state = VehicleState { x: lx, y: ly, yaw: lh, speed: s.lead.initial_speed, ..VehicleState::default() };
        let follower_body = world.add_vehicle(lf, &follower_state);
        let lead_body = world.add_vehicle(ll, &lead_state);
        let longitudinal = match s.controller {
            ControllerKind::Flc => Longitudinal::Flc(FallbackController::new(s.flc)?),
            ControllerKind::Pid => Longitudinal::Pid(PidController::new(s.pid)?),
            ControllerKind::Pipeline => Longitudinal::Pipeline(Box::new(Supervisor::new(s.supervisor_params())?)),
            ControllerKind::Idm => Longitudinal::Baseline(IdmController::new(s.idm)?.into()),
            ControllerKind::Acc => Longitudinal::Baseline(AccController::new(s.acc)?.into()),
            ControllerKind::Rss => Longitudinal::Baseline(RssController::new(s.rss)?.into()),
            ControllerKind::CarlaBehavior => Longitudinal::Baseline(CarlaBehaviorController::new(s.carla_behavior)?.into()),
            ControllerKind::FlcRobust => Longitudinal::FlcRobust(RobustFallbackController::new(s.flc_robust)?),
        };
        let distance_offset = s.follower.distance_offset.unwrap_or(lf.length / 2.0 - s.lidar.mount_x);
        let lead_pp = flc_core::PurePursuitParams {
            base_lookahead: 6.0,
            lookahead_gain: 0.8,
            law: flc_core::PursuitLaw::Standard,
            wheelbase: ll.wheelbase,
            max_steer: ll.max_steer,
        };
        let active = match s.controller {
            ControllerKind::Pid => ActiveController::Pid,
            _ => ActiveController::Flc,
        };
        Ok(Self {
            scenario: s.clone(),
            lead_x0: lead_s,
            world,
            lead_body,
            follower_body,
            lead: Vehicle::new(*ll, lead_state),
            follower: Vehicle::new(*lf, follower_state),
            lead_driver: LeadDriver::new(&s.lead.phases, s.lead.initial_speed),
            lead_steer: PurePursuit::new(lead_pp)?,
            speed_ctrl: SpeedController::new(s.follower.speed_controller),
            lidar: Lidar::new(s.lidar.clone(), sub_seed(s.seed, 1)),
            v2v: V2vChannel::new(s.v2v.clone(), sub_seed(s.seed, 2)),
            detector: Box::new(<LeadDetector>::new(s.detector)?),
            pursuit: PurePursuit::new(s.pure_pursuit)?,
            longitudinal,
            distance_offset,
            mailbox: None,
            last_lead_speed: None,
            speed_cmd: s.follower.initial_speed,
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
            t: 0.0,
            k: 0,
            standstill_since: None,
            collision: None,
            series: Series::default(),
            recorder: None,
            track,
        })
    }

    /// Simulation time, s.
    pub fn time(&self) -> f64 {
        self.t
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
        if self.scenario.v2v.outage_on_brake {
            if let Some(onset) = self.lead_driver.brake_onset() {
                self.v2v.start_outage(onset);
            }
        }

        // 2. V2V.
        if let Some(m) = self.v2v.tick(t, ls.speed) {
            self.mailbox = Some(m);
        }

        // 3. LiDAR scan -> pipeline.
        let fs = *self.follower.state();
        if let Some(scan) = self.lidar.tick(t, &self.world, self.follower_body, &fs) {
            self.control_tick(t, &scan.points, &fs);
            if let Some(rec) = self.recorder.as_deref_mut() {
                rec.scan(t, &scan, self.detector.clusters(), self.detected, self.lookahead)?;
            }
        }

        // 4. Low-level control and dynamics.
        self.accel_cmd = self.speed_ctrl.step(self.speed_cmd, fs.speed, dt);
        self.follower.step(self.accel_cmd, self.steer_cmd, dt);
        self.lead.step(lcmd.accel, lead_steer, dt);
        self.world.set_pose(self.follower_body, self.follower.state());
        self.world.set_pose(self.lead_body, self.lead.state());
        let contacts = self.world.step(dt);
        self.t += dt;
        self.k += 1;

        let (ls, fs) = (*self.lead.state(), *self.follower.state());
        let gap = self.bumper_gap(&ls, &fs);
        if self.collision.is_none() && contacts.iter().any(|c| c.involves(self.lead_body) && c.involves(self.follower_body)) {
            self.collision = Some(CollisionInfo { time: self.t, impact_speed: (fs.speed - ls.speed).max(0.0), lead_speed: ls.speed, follower_speed: fs.speed });
        }
        self.record(gap, &ls, &fs);
        if let (Some(rec), Some(last)) = (self.recorder.as_deref_mut(), self.series.len().checked_sub(1)) {
            if let Some(r) = self.series.get(last) {
                rec.step(&r, &ls, &fs)?;
            }
        }

        // Stop conditions.
        if self.collision.is_some() && self.scenario.stop.on_collision {
            return Ok(false);
        }
        let still = ls.speed < 0.05 && fs.speed < 0.05;
        if self.lead_driver.finished() && still {
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
        let d_ahead = self.lead_steer.lookahead(ls.speed);
        let (tx, ty, th) = self.track.pose_at(s + d_ahead);
        let (nx, ny) = (-th.sin(), th.cos());
        let (gx, gy) = (tx + offset * nx - ls.x, ty + offset * ny - ls.y);
        let (c, sn) = (ls.yaw.cos(), ls.yaw.sin());
        let local = Point2::new(c * gx + sn * gy, -sn * gx + c * gy);
        self.lead_steer.step(Some(local), ls.speed).steer
    }

    /// Bumper-to-bumper distance along the lead's heading (the "gap").
    fn bumper_gap(&self, ls: &VehicleState, fs: &VehicleState) -> f64 {
        let (dx, dy) = (ls.x - fs.x, ls.y - fs.y);
        let centre = dx * ls.yaw.cos() + dy * ls.yaw.sin();
        centre - self.scenario.lead.vehicle.length / 2.0 - self.scenario.follower.vehicle.length / 2.0
    }

    fn control_tick(&mut self, t: f64, points: &[[f64; 2]], fs: &VehicleState) {
        let det = self.detector.detect(points, self.path_curvature);
        let detection = det.detection;
        let distance = detection.map(|d| d.distance - self.distance_offset);
        self.detected = distance;
        if self.scenario.follower.lane_keeping {
            // Lane keeping (lead-change scenarios): steer along the lane centre like the lead's
            // driver; the detector's corridor follows the lane.
            let s = self.track.project(fs.x, fs.y).s;
            self.steer_cmd = self.lead_centreline_steer(fs, s, 0.0);
            self.path_curvature = self.track.curvature_at(s);
        } else {
            // Pure pursuit in the vehicle frame (sensor offset added).
            let (mx, my) = (self.scenario.lidar.mount_x, self.scenario.lidar.mount_y);
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
        let dt = self.last_tick_t.map_or(1.0 / self.scenario.lidar.rate_hz, |p| t - p);
        self.last_tick_t = Some(t);
        let msg = self.mailbox.take();
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

    fn record(&mut self, gap: f64, ls: &VehicleState, fs: &VehicleState) {
        let proj = self.track.project(fs.x, fs.y);
        let heading_error = wrap_angle(fs.yaw - proj.heading);
        // The desired gap of the controller that drives.
        let desired = match (&self.longitudinal, self.active) {
            (Longitudinal::Baseline(_), _) => self.scenario.baseline_desired_gap(fs.speed),
            (Longitudinal::FlcRobust(c), _) => c.params().desired_gap(fs.speed),
            (_, ActiveController::Pid) => self.scenario.pid.desired_distance(fs.speed),
            (_, ActiveController::Flc) => self.scenario.flc.desired_distance(fs.speed) + self.scenario.flc.f_shift(fs.speed),
        };
        self.series.push(StepRecord {
            t: self.t,
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

    /// Starts an MCAP recording of this run in `dir` (see [`crate::record`]; call it before the
    /// first step to record the whole run). Returns the file's path.
    pub fn record_to(&mut self, dir: &Path) -> Result<PathBuf, SimError> {
        let rec = Recorder::create(dir, &self.scenario, &self.track, self.t, self.lead.state(), self.follower.state())?;
        let path = rec.path().to_path_buf();
        self.recorder = Some(Box::new(rec));
        Ok(path)
    }

    /// Finishes the recording, if any (with the metrics of the steps so far if `with_metrics`),
    /// and returns its path. Without this call the recording is finished when the simulation is
    /// dropped or finished, errors ignored.
    pub fn finish_recording(&mut self, with_metrics: bool) -> Result<Option<PathBuf>, SimError> {
        let Some(rec) = self.recorder.take() else { return Ok(None) };
        let metrics = with_metrics.then(|| Metrics::compute(&self.series, self.collision));
        rec.finish(metrics.as_ref()).map(Some)
    }

    /// Ends the run and computes the metrics.
    pub fn finish(self) -> RunResult {
        let metrics = Metrics::compute(&self.series, self.collision);
        RunResult { scenario: self.scenario, metrics, series: self.series }
    }
}

fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI
}
