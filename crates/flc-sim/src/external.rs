//! One flc follower inside another simulator (SUMO through `flc.sumo`, or any host loop): the
//! host owns the world and tells the follower, every step, the true gap to the vehicle in front,
//! that vehicle's speed and the follower's own speed; the follower answers with the speed it will
//! have at the end of the step.
//!
//! Inside, the pipeline is the simulator's own ([`crate::Simulation`]'s follower), minus the
//! ray-cast world:
//!
//! 1. **V2V**: the vehicle in front broadcasts its speed through flc's channel model
//!    ([`V2vChannel`]: rate, latency, jitter, loss, bursts, outages) from the `[v2v]` section;
//! 2. **sensing**: the [`GapSensor`] (the LiDAR's schedule, range, noise, drops and latency from
//!    `[lidar]`); with `follower.perception = "ideal"` the controller gets the true gap and the
//!    front vehicle's true speed at the sensor's rate instead (validation only; always for the
//!    R157 reference driver, [`crate::ControllerKind::perceives_truth`]);
//! 3. **control**: the configured longitudinal law ([`crate::ControllerKind`], any of them: FLC,
//!    robust FLC, PID, the supervisor pipeline, the baselines), fed the same [`Frame`] as in the
//!    simulator at each measurement;
//! 4. **actuation** ([`Actuation`]): by default every step the low-level [`SpeedController`] and
//!    the longitudinal part of the [`Vehicle`] model (dead time, lag, limits, resistance) turn the
//!    speed command into the speed the host should set; [`Actuation::Direct`] hands the law's
//!    speed command to the host as it is, the way SUMO's own car-following models act (the
//!    closed-loop check of the baselines against SUMO's models, `docs/sumo.md`).
//!
//! No clock is read: time comes from the host's `t`. The first call is the sensor's first scan.

use flc_core::{ActiveController, Frame, SwitchReason, V2vMessage};
use serde::{Deserialize, Serialize};

use crate::controllers::BoxedLaw;
use crate::error::SimError;
use crate::follower::{FollowerConfig, Perception};
use crate::gap_sensor::GapSensor;
use crate::v2v::V2vChannel;
use crate::vehicle::{SpeedController, Vehicle, VehicleState};

/// What the host knows at the start of a step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExternalInput {
    /// Host simulation time, s.
    pub t: f64,
    /// Step length until the next call, s (> 0).
    pub dt: f64,
    /// True bumper-to-bumper gap to the vehicle in front, m (`None`: nothing in front).
    pub gap: Option<f64>,
    /// Speed of the vehicle in front, m/s (`None`: nothing in front); it is what that vehicle
    /// broadcasts over V2V.
    pub front_speed: Option<f64>,
    /// The follower's own speed, m/s.
    pub own_speed: f64,
}

/// The follower's answer for one step (serialised with the law and reason as their names).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ExternalOutput {
    /// The speed to set for the end of the step, m/s (>= 0).
    pub speed: f64,
    /// The acceleration demand of the low-level controller, m/s².
    pub accel_command: f64,
    /// The longitudinal law's speed command, m/s.
    pub speed_command: f64,
    /// `true` if the law ran this step (a measurement was delivered).
    pub control_tick: bool,
    /// The distance the law saw at its last tick, m (`None`: nothing seen).
    pub distance: Option<f64>,
    /// Which law drives (the supervisor's choice; fixed for single laws).
    #[serde(serialize_with = "active_name")]
    pub active: ActiveController,
    /// Why.
    #[serde(serialize_with = "reason_name")]
    pub reason: SwitchReason,
    /// Hand-overs so far.
    pub switches: u32,
    /// Control ticks since the last V2V message (`None`: none yet).
    pub v2v_age_ticks: Option<u32>,
}

/// How the law's speed command becomes the speed the host sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Actuation {
    /// flc's low-level speed controller and longitudinal vehicle model (default).
    #[default]
    Vehicle,
    /// The law's speed command itself (held between the law's ticks), clamped at 0.
    Direct,
}

/// One flc follower in a host simulator (see the module docs).
pub struct ExternalFollower {
    actuation: Actuation,
    cfg: FollowerConfig,
    sensor: GapSensor,
    v2v: V2vChannel,
    mailbox: Option<V2vMessage>,
    longitudinal: BoxedLaw,
    vehicle: Vehicle,
    speed_ctrl: SpeedController,
    speed_cmd: Option<f64>,
    last_tick_t: Option<f64>,
    /// Wheel odometry from the host's speeds: `Σ own_speed dt` over the past steps, m.
    odometer: f64,
    out: ExternalOutput,
}

impl ExternalFollower {
    /// A follower with `cfg` (validated here) whose random streams derive from `seed` (sensor
    /// stream 1, V2V stream 2, as the simulator's follower 1).
    pub fn new(cfg: FollowerConfig, seed: u64) -> Result<Self, SimError> {
        cfg.validate()?;
        let longitudinal = cfg.longitudinal()?;
        let out = ExternalOutput {
            speed: 0.0,
            accel_command: 0.0,
            speed_command: 0.0,
            control_tick: false,
            distance: None,
            active: cfg.controller.initial_active(),
            reason: SwitchReason::NoV2v,
            switches: 0,
            v2v_age_ticks: None,
        };
        Ok(Self {
            actuation: Actuation::Vehicle,
            sensor: GapSensor::new(cfg.lidar.clone(), crate::sim::sub_seed(seed, 1)),
            v2v: V2vChannel::new(cfg.v2v.clone(), crate::sim::sub_seed(seed, 2)),
            mailbox: None,
            longitudinal,
            vehicle: Vehicle::new(cfg.follower.vehicle, VehicleState::default()),
            speed_ctrl: SpeedController::new(cfg.follower.speed_controller),
            speed_cmd: None,
            last_tick_t: None,
            odometer: 0.0,
            out,
            cfg,
        })
    }

    /// This follower with `actuation` instead of the default [`Actuation::Vehicle`].
    pub fn with_actuation(mut self, actuation: Actuation) -> Self {
        self.actuation = actuation;
        self
    }

    /// Its configuration.
    pub fn config(&self) -> &FollowerConfig {
        &self.cfg
    }

    /// The V2V link (statistics, outages started by the host).
    pub fn v2v_mut(&mut self) -> &mut V2vChannel {
        &mut self.v2v
    }

    /// One host step. Bad input (non-finite or negative speeds, `dt <= 0`) is an error naming the
    /// field; the follower's state is then unchanged.
    pub fn step(&mut self, input: &ExternalInput) -> Result<ExternalOutput, SimError> {
        check_input(input)?;
        let t = input.t;
        // 1. V2V: the vehicle in front broadcasts at the start of the step.
        let msg = match (self.cfg.v2v.enabled, input.front_speed) {
            (true, Some(v)) => self.v2v.tick(t, v),
            _ => self.v2v.receive(t),
        };
        if msg.is_some() {
            self.mailbox = msg;
        }
        // 2.-3. A measurement -> the law.
        // Ideal perception, or the R157 careful driver (always the host's true gap and speed).
        let ideal = self.cfg.follower.perception == Perception::Ideal || self.cfg.controller.perceives_truth();
        let measured = self.sensor.tick(t, input.gap);
        self.out.control_tick = measured.is_some();
        if let Some(seen) = measured {
            let (distance, lead_speed) = if ideal { (input.gap, input.front_speed) } else { (seen, None) };
            let dt = self.last_tick_t.map_or(1.0 / self.cfg.lidar.rate_hz, |p| t - p);
            self.last_tick_t = Some(t);
            let o = self.longitudinal.step(&Frame {
                distance,
                own_speed: input.own_speed,
                v2v: self.mailbox.take(),
                dt,
                lead_speed,
                own_fix: None,
                travelled: Some(self.odometer * self.cfg.follower.odometry_scale),
                intruder: None,
                path_clear: false,
            });
            self.speed_cmd = Some(o.command.speed);
            self.out.switches += u32::from(o.switched);
            self.out.active = o.active;
            self.out.reason = o.reason;
            self.out.v2v_age_ticks = (o.v2v_age_ticks != u32::MAX).then_some(o.v2v_age_ticks);
            self.out.distance = distance;
        }
        // 4. Low-level control and the vehicle's longitudinal dynamics, from the host's speed.
        let cmd = *self.speed_cmd.get_or_insert(input.own_speed);
        let (speed, accel) = match self.actuation {
            Actuation::Vehicle => {
                self.vehicle.set_speed(input.own_speed);
                let accel = self.speed_ctrl.step(cmd, input.own_speed, input.dt);
                self.vehicle.step(accel, 0.0, input.dt);
                (self.vehicle.state().speed, accel)
            }
            Actuation::Direct => {
                let v = if cmd.is_finite() { cmd.max(0.0) } else { 0.0 };
                (v, (v - input.own_speed) / input.dt)
            }
        };
        self.out.speed = speed;
        self.out.accel_command = accel;
        self.out.speed_command = cmd;
        self.odometer += 0.5 * (input.own_speed + speed) * input.dt;
        Ok(self.out)
    }
}

fn active_name<S: serde::Serializer>(a: &ActiveController, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(a.as_str())
}

fn reason_name<S: serde::Serializer>(r: &SwitchReason, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(r.as_str())
}

fn check_input(i: &ExternalInput) -> Result<(), SimError> {
    let bad = |field: &str, v: f64| SimError::Config(crate::ConfigError::new(field, format!("must be a finite number >= 0, got {v}")));
    if !(i.t.is_finite() && i.t >= 0.0) {
        return Err(bad("t", i.t));
    }
    if !(i.dt.is_finite() && i.dt > 0.0) {
        return Err(SimError::Config(crate::ConfigError::new("dt", format!("must be a finite number > 0, got {}", i.dt))));
    }
    if !(i.own_speed.is_finite() && i.own_speed >= 0.0) {
        return Err(bad("own_speed", i.own_speed));
    }
    if let Some(g) = i.gap.filter(|g| g.is_nan()) {
        return Err(SimError::Config(crate::ConfigError::new("gap", format!("must be a number, got {g}"))));
    }
    if let Some(v) = i.front_speed.filter(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(bad("front_speed", v));
    }
    Ok(())
}
