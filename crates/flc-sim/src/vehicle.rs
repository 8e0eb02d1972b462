//! Vehicle model: kinematic bicycle (lateral) + longitudinal dynamics with actuator dead time,
//! first-order lag, drive / brake / friction limits, aerodynamic drag and rolling resistance; and
//! the low-level speed controller that turns a speed command into an acceleration demand.
//! Constants and their sources: `docs/sim-model.md`.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};

/// Gravity, m/s².
const G: f64 = 9.81;
/// A pedestrian's box length and width range, m.
pub const PEDESTRIAN_BOX: (f64, f64) = (0.1, 3.0);
/// A pedestrian's mass range, kg.
pub const PEDESTRIAN_MASS: (f64, f64) = (10.0, 500.0);

/// What a body is: a vehicle (default) or a pedestrian (`body = "pedestrian"`: a small box,
/// only ever moved kinematically by a story's actions; see `docs/scenarios.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyKind {
    /// A road vehicle. Default.
    #[default]
    Vehicle,
    /// A pedestrian: box 0.1-3 m, mass 10-500 kg; a scripted entity of a `[story]` only.
    Pedestrian,
}

impl BodyKind {
    /// `true` for [`BodyKind::Vehicle`] (the default, not written to TOML).
    pub fn is_vehicle(&self) -> bool {
        *self == BodyKind::Vehicle
    }
}

/// Vehicle parameters. `Default`: a mid-size sedan on dry asphalt.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VehicleParams {
    /// What the body is (default: a vehicle; not written when it is one).
    #[serde(skip_serializing_if = "BodyKind::is_vehicle")]
    pub body: BodyKind,
    /// Body length (collider), m.
    pub length: f64,
    /// Body width (collider), m.
    pub width: f64,
    /// Wheelbase, m.
    pub wheelbase: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Highest braking deceleration the tyres transmit (friction limit, ~mu g), m/s².
    pub max_brake: f64,
    /// Highest drive acceleration at low speed (traction / torque limit), m/s².
    pub max_accel: f64,
    /// Drive power limit, W (acceleration <= P / (m v) at speed).
    pub max_power: f64,
    /// Aerodynamic drag coefficient.
    pub drag_cd: f64,
    /// Frontal area, m².
    pub frontal_area: f64,
    /// Air density, kg/m³.
    pub air_density: f64,
    /// Rolling-resistance coefficient.
    pub rolling_resistance: f64,
    /// Actuator dead time (command to first response), s.
    pub dead_time: f64,
    /// Actuator first-order lag time constant, s.
    pub lag: f64,
    /// Steering (road-wheel) limit, rad.
    pub max_steer: f64,
    /// Steering rate limit, rad/s.
    pub max_steer_rate: f64,
}

impl Default for VehicleParams {
    fn default() -> Self {
        Self {
            body: BodyKind::Vehicle,
            length: 4.9,
            width: 1.9,
            wheelbase: 2.9,
            mass: 1800.0,
            max_brake: 8.0,
            max_accel: 3.5,
            max_power: 150_000.0,
            drag_cd: 0.30,
            frontal_area: 2.3,
            air_density: 1.2,
            rolling_resistance: 0.012,
            dead_time: 0.1,
            lag: 0.2,
            max_steer: 0.6,
            max_steer_rate: 0.8,
        }
    }
}

impl VehicleParams {
    /// Driving resistance at speed `v` (m/s) as a deceleration, m/s²: aerodynamic drag
    /// `rho c_d A v² / (2 m)` plus rolling resistance `c_rr g` (0 at standstill).
    pub fn resistance(&self, v: f64) -> f64 {
        if v > 0.0 {
            (0.5 * self.air_density * self.drag_cd * self.frontal_area * v * v) / self.mass + self.rolling_resistance * G
        } else {
            0.0
        }
    }

    /// Checks every field; the error names it and the allowed range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        match self.body {
            BodyKind::Vehicle => {
                check_range("length", self.length, 1.0, 25.0, "m")?;
                check_range("width", self.width, 0.5, 3.0, "m")?;
                check_range("wheelbase", self.wheelbase, 0.5, self.length, "m (<= length)")?;
                check_range("mass", self.mass, 100.0, 60_000.0, "kg")?;
            }
            BodyKind::Pedestrian => {
                check_range("length", self.length, PEDESTRIAN_BOX.0, PEDESTRIAN_BOX.1, "m (a pedestrian)")?;
                check_range("width", self.width, PEDESTRIAN_BOX.0, PEDESTRIAN_BOX.1, "m (a pedestrian)")?;
                check_range("wheelbase", self.wheelbase, 0.05, self.length, "m (<= length)")?;
                check_range("mass", self.mass, PEDESTRIAN_MASS.0, PEDESTRIAN_MASS.1, "kg (a pedestrian)")?;
            }
        }
        check_range("max_brake", self.max_brake, 0.5, 15.0, "m/s²")?;
        check_range("max_accel", self.max_accel, 0.1, 15.0, "m/s²")?;
        check_range("max_power", self.max_power, 1_000.0, 2.0e6, "W")?;
        check_range("drag_cd", self.drag_cd, 0.0, 2.0, "")?;
        check_range("frontal_area", self.frontal_area, 0.0, 20.0, "m²")?;
        check_range("air_density", self.air_density, 0.0, 2.0, "kg/m³")?;
        check_range("rolling_resistance", self.rolling_resistance, 0.0, 0.1, "")?;
        check_range("dead_time", self.dead_time, 0.0, 2.0, "s")?;
        check_range("lag", self.lag, 0.0, 5.0, "s")?;
        check_range("max_steer", self.max_steer, 0.05, 1.2, "rad")?;
        check_range("max_steer_rate", self.max_steer_rate, 0.05, 10.0, "rad/s")
    }
}

/// State of a vehicle; `(x, y)` is the body centre, `yaw` its heading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VehicleState {
    /// Position of the body centre, m.
    pub x: f64,
    /// Position of the body centre, m.
    pub y: f64,
    /// Heading, rad.
    pub yaw: f64,
    /// Speed, m/s (>= 0).
    pub speed: f64,
    /// Longitudinal acceleration over the last step, m/s².
    pub accel: f64,
    /// Road-wheel steering angle, rad.
    pub steer: f64,
    /// Wheel odometry: the path length travelled since the start, m (the `travelled` signal of
    /// the controllers' frame).
    pub odometer: f64,
}

/// A vehicle: state + actuator pipeline.
#[derive(Debug, Clone)]
pub struct Vehicle {
    params: VehicleParams,
    state: VehicleState,
    delay: VecDeque<f64>,
    actuator: f64,
}

impl Vehicle {
    /// A vehicle at `state` with idle actuators.
    pub fn new(params: VehicleParams, state: VehicleState) -> Self {
        Self { params, state, delay: VecDeque::new(), actuator: 0.0 }
    }

    /// The state.
    pub fn state(&self) -> &VehicleState {
        &self.state
    }

    /// Sets the speed (a host simulator that owns the motion, [`crate::ExternalFollower`]);
    /// actuator states are kept. Non-finite or negative speeds become 0.
    pub fn set_speed(&mut self, speed: f64) {
        self.state.speed = if speed.is_finite() { speed.max(0.0) } else { 0.0 };
    }

    /// Puts the vehicle at `state` (a story moving it kinematically, [`crate::story::Motion`]),
    /// its odometer included (the story counts the path it moves it along); actuator states are
    /// kept.
    pub fn set_state(&mut self, state: VehicleState) {
        self.state = state;
    }

    /// The parameters.
    pub fn params(&self) -> &VehicleParams {
        &self.params
    }

    /// Advances by `dt` with the acceleration demand `accel_cmd` (m/s²) and steering demand
    /// `steer_cmd` (rad).
    pub fn step(&mut self, accel_cmd: f64, steer_cmd: f64, dt: f64) {
        let p = self.params;
        let accel_cmd = if accel_cmd.is_finite() { accel_cmd } else { -p.max_brake };
        let steer_cmd = if steer_cmd.is_finite() { steer_cmd } else { 0.0 };
        // Dead time: a FIFO of round(dead_time / dt) steps.
        let n = (p.dead_time / dt).round() as usize;
        if self.delay.len() != n {
            self.delay = std::iter::repeat_n(self.actuator, n).collect();
        }
        self.delay.push_back(accel_cmd);
        let delayed = self.delay.pop_front().unwrap_or(accel_cmd);
        // First-order lag (exact discretisation).
        let alpha = if p.lag > 0.0 { 1.0 - (-dt / p.lag).exp() } else { 1.0 };
        self.actuator += alpha * (delayed - self.actuator);
        let v = self.state.speed;
        // Drive limited by traction and power, brake by friction.
        let a_act = if self.actuator >= 0.0 {
            self.actuator.min(p.max_accel).min(p.max_power / (p.mass * v.max(1.0)))
        } else {
            self.actuator.max(-p.max_brake)
        };
        let resist = p.resistance(v);
        let v_new = (v + (a_act - resist) * dt).max(0.0);
        let v_mid = 0.5 * (v + v_new);
        // Kinematic bicycle about the body centre (slip angle beta, rear axle at L/2 behind).
        let max_dsteer = p.max_steer_rate * dt;
        let steer = (self.state.steer + (steer_cmd.clamp(-p.max_steer, p.max_steer) - self.state.steer).clamp(-max_dsteer, max_dsteer))
            .clamp(-p.max_steer, p.max_steer);
        let lr = p.wheelbase / 2.0;
        let beta = (lr / p.wheelbase * steer.tan()).atan();
        let s = &mut self.state;
        s.x += v_mid * (s.yaw + beta).cos() * dt;
        s.y += v_mid * (s.yaw + beta).sin() * dt;
        s.yaw += v_mid / lr * beta.sin() * dt;
        s.odometer += v_mid * dt;
        s.accel = (v_new - v) / dt;
        s.speed = v_new;
        s.steer = steer;
    }
}

/// Parameters of the low-level speed controller (PI on the speed error, like CARLA's default
/// longitudinal vehicle controller the paper feeds its speed command into).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpeedControllerParams {
    /// Proportional gain, (m/s²)/(m/s).
    pub kp: f64,
    /// Integral gain, (m/s²)/m.
    pub ki: f64,
    /// Clamp of the integral term, m/s².
    pub integral_limit: f64,
    /// Highest acceleration demand, m/s².
    pub max_accel: f64,
    /// Highest deceleration demand (positive), m/s².
    pub max_decel: f64,
}

impl Default for SpeedControllerParams {
    fn default() -> Self {
        Self { kp: 1.0, ki: 0.1, integral_limit: 1.0, max_accel: 3.5, max_decel: 8.0 }
    }
}

impl SpeedControllerParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_range("kp", self.kp, 0.01, 50.0, "1/s")?;
        check_range("ki", self.ki, 0.0, 50.0, "1/s²")?;
        check_range("integral_limit", self.integral_limit, 0.0, 10.0, "m/s²")?;
        check_range("max_accel", self.max_accel, 0.1, 15.0, "m/s²")?;
        check_range("max_decel", self.max_decel, 0.1, 15.0, "m/s²")
    }
}

/// The low-level speed controller: speed command -> acceleration demand.
#[derive(Debug, Clone)]
pub struct SpeedController {
    params: SpeedControllerParams,
    integral: f64,
}

impl SpeedController {
    /// A controller with an empty integrator.
    pub fn new(params: SpeedControllerParams) -> Self {
        Self { params, integral: 0.0 }
    }

    /// Acceleration demand to track `speed_cmd` from `speed` (m/s) over `dt` (s).
    pub fn step(&mut self, speed_cmd: f64, speed: f64, dt: f64) -> f64 {
        let p = self.params;
        if !(speed_cmd.is_finite() && speed.is_finite()) {
            return -p.max_decel;
        }
        let e = speed_cmd - speed;
        // A stop request at standstill holds the brake (no creeping, no integrator windup).
        if speed_cmd <= 0.0 && speed < 0.1 {
            self.integral = 0.0;
            return -p.max_decel.min(2.0);
        }
        let candidate = (self.integral + p.ki * e * dt).clamp(-p.integral_limit, p.integral_limit);
        let raw = p.kp * e + candidate;
        if raw < p.max_accel && raw > -p.max_decel {
            self.integral = candidate;
        }
        (p.kp * e + self.integral).clamp(-p.max_decel, p.max_accel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    /// Stopping distance from `v0` under a full brake demand `cmd` (< -max_brake) for dead time
    /// `td`, lag `tau` and friction limit `a`, without drag: travel at `v0` for `td`; then the lag
    /// ramps the deceleration `|cmd| (1 - exp(-t / tau))` up to `a` at
    /// `t1 = -tau ln(1 - a / |cmd|)`; then constant `a` to standstill.
    fn analytic_stopping_distance(v0: f64, cmd: f64, td: f64, tau: f64, a: f64) -> f64 {
        let c = cmd.abs();
        let t1 = -tau * (1.0 - a / c).ln();
        let e = (-t1 / tau).exp();
        // Speed lost and distance covered during the ramp (integrals of the ramp deceleration).
        let dv = c * (t1 - tau * (1.0 - e));
        let dx = v0 * t1 - c * (t1 * t1 / 2.0 - tau * (t1 - tau * (1.0 - e)));
        let v1 = v0 - dv;
        v0 * td + dx + v1 * v1 / (2.0 * a)
    }

    fn stopping_distance(p: VehicleParams, v0: f64, cmd: f64) -> f64 {
        let mut v = Vehicle::new(p, VehicleState { speed: v0, ..Default::default() });
        let mut steps = 0;
        while v.state().speed > 0.0 && steps < 100_000 {
            v.step(cmd, 0.0, DT);
            steps += 1;
        }
        assert_eq!(v.state().speed, 0.0);
        v.state().x
    }

    #[test]
    fn full_braking_distance_matches_friction_limit_plus_actuator_delay() {
        // Without resistances: the analytic value (25 m of v²/(2a) from 20 m/s at 8 m/s², + 2 m
        // of dead time, + ~0.9 m while the lag builds up the deceleration), within the error
        // of the 10 ms discretisation (about v0 dt = 0.2 m).
        let ideal = VehicleParams { drag_cd: 0.0, rolling_resistance: 0.0, ..Default::default() };
        for (v0, cmd) in [(20.0, -20.0), (30.0, -12.0), (10.0, -9.0)] {
            let expected = analytic_stopping_distance(v0, cmd, ideal.dead_time, ideal.lag, ideal.max_brake);
            let x = stopping_distance(ideal, v0, cmd);
            assert!((x - expected).abs() < v0 * DT, "v0 {v0}, cmd {cmd}: {x} m vs analytic {expected} m");
        }
        let expected = analytic_stopping_distance(20.0, -20.0, 0.1, 0.2, 8.0);
        assert!((expected - 27.93).abs() < 0.01, "{expected}");
        // Drag and rolling resistance add to the brakes: a little shorter, by at most their share
        // (<= 0.33 m/s² of 8.3 at 20 m/s).
        let x = stopping_distance(VehicleParams::default(), 20.0, -20.0);
        assert!(x < expected && x > expected * (1.0 - 0.33 / 8.33) - 0.2, "{x}");
    }

    #[test]
    fn speed_never_negative_and_coasting_slows_down() {
        let mut v = Vehicle::new(VehicleParams::default(), VehicleState { speed: 30.0, ..Default::default() });
        for _ in 0..100 {
            v.step(0.0, 0.0, DT);
        }
        // Drag at 30 m/s: 0.5*1.2*0.3*2.3*900/1800 = 0.207 m/s² plus rolling 0.118 m/s².
        assert!((v.state().speed - (30.0 - 0.325)).abs() < 0.02, "{}", v.state().speed);
        let mut v = Vehicle::new(VehicleParams::default(), VehicleState { speed: 0.5, ..Default::default() });
        for _ in 0..500 {
            v.step(-8.0, 0.0, DT);
            assert!(v.state().speed >= 0.0);
        }
    }

    #[test]
    fn lag_step_response() {
        let p = VehicleParams { drag_cd: 0.0, rolling_resistance: 0.0, ..Default::default() };
        let mut v = Vehicle::new(p, VehicleState { speed: 10.0, ..Default::default() });
        // After dead time + one time constant the response reaches 1 - 1/e = 63 % of the -4 step.
        for _ in 0..30 {
            v.step(-4.0, 0.0, DT);
        }
        assert!((v.state().accel + 4.0 * (1.0 - (-1.0f64).exp())).abs() < 0.15, "{}", v.state().accel);
    }

    #[test]
    fn straight_line_and_turning() {
        let mut v = Vehicle::new(VehicleParams::default(), VehicleState { speed: 10.0, ..Default::default() });
        for _ in 0..100 {
            v.step(0.0, 0.0, DT);
        }
        assert_eq!(v.state().y, 0.0);
        let mut v = Vehicle::new(VehicleParams::default(), VehicleState { speed: 10.0, ..Default::default() });
        for _ in 0..100 {
            v.step(0.0, 0.2, DT);
        }
        assert!(v.state().y > 0.0 && v.state().yaw > 0.0);
    }

    #[test]
    fn constant_steer_drives_the_bicycle_circle() {
        // Body-centre kinematic bicycle, l_r = L/2: slip beta = atan(tan(delta)/2), the centre
        // moves on a circle of radius l_r / sin(beta) at yaw rate v sin(beta) / l_r.
        let p = VehicleParams { drag_cd: 0.0, rolling_resistance: 0.0, ..Default::default() };
        let delta: f64 = 0.1;
        let mut v = Vehicle::new(p, VehicleState { speed: 10.0, steer: delta, ..Default::default() });
        let beta = (delta.tan() / 2.0).atan();
        let radius = p.wheelbase / 2.0 / beta.sin();
        // Initial velocity direction is yaw + beta = beta: the centre is to its left.
        let (cx, cy) = (-radius * beta.sin(), radius * beta.cos());
        for _ in 0..1000 {
            v.step(0.0, delta, DT);
            let s = v.state();
            assert!(((s.x - cx).hypot(s.y - cy) - radius).abs() < 0.01 * radius);
        }
        let expected_yaw = 10.0 * beta.sin() / (p.wheelbase / 2.0) * 10.0;
        assert!((v.state().yaw - expected_yaw).abs() < 1e-6 * expected_yaw.abs().max(1.0), "{} vs {expected_yaw}", v.state().yaw);
    }

    #[test]
    fn speed_controller_tracks() {
        let mut v = Vehicle::new(VehicleParams::default(), VehicleState::default());
        let mut c = SpeedController::new(SpeedControllerParams::default());
        for _ in 0..3000 {
            let a = c.step(15.0, v.state().speed, DT);
            v.step(a, 0.0, DT);
        }
        assert!((v.state().speed - 15.0).abs() < 0.1, "{}", v.state().speed);
    }

    #[test]
    fn validation_names_the_key() {
        let p = VehicleParams { max_brake: 0.0, ..Default::default() };
        assert_eq!(p.validate().unwrap_err().key, "max_brake");
    }
}
