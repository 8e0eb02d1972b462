//! The lead vehicle's driver: runs the scenario's [`Phase`]s in order and produces an
//! acceleration command and a lateral offset target for every physics step.

mod phase;

pub use phase::Phase;

use serde::{Deserialize, Serialize};

use crate::vehicle::VehicleParams;

/// The lead vehicle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LeadSpec {
    /// Initial speed, m/s.
    pub initial_speed: f64,
    /// Vehicle model.
    pub vehicle: VehicleParams,
    /// The manoeuvre.
    pub phases: Vec<Phase>,
}

impl Default for LeadSpec {
    fn default() -> Self {
        Self { initial_speed: 0.0, vehicle: VehicleParams::default(), phases: Vec::new() }
    }
}

/// Gain of the speed-holding loop (hold phases, end of accelerate / brake), 1/s.
const HOLD_GAIN: f64 = 3.0;
/// The accelerate phase blends into its target over the last `1 / ACCEL_BLEND` m/s.
const ACCEL_BLEND: f64 = 10.0;

/// Output of the lead driver for one physics step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeadCommand {
    /// Acceleration demand for the lead's actuators, m/s² (the scripted acceleration plus the
    /// resistance feed-forward).
    pub accel: f64,
    /// Lateral offset from the lane centre to steer to, m (+ left).
    pub lateral_offset: f64,
    /// Index of the running phase (`phases.len()` when all are done).
    pub phase: usize,
}

/// Phase state machine of the lead. The driver realises the script: its acceleration demand is
/// the phase's acceleration plus a feed-forward of the vehicle's own driving resistance
/// ([`VehicleParams::resistance`]), so a `brake` phase of 6 m/s² decelerates the lead at 6 m/s²
/// at any speed (within its brake authority, after the actuator's dead time and lag).
#[derive(Debug, Clone)]
pub struct LeadDriver {
    vehicle: VehicleParams,
    phases: Vec<Phase>,
    targets: Vec<Option<f64>>,
    index: usize,
    phase_start_t: f64,
    hold_speed: f64,
    offset_from: f64,
    offset: f64,
    brake_onset: Option<f64>,
    started: bool,
}

impl LeadDriver {
    /// Builds the driver; `phases` must have been validated ([`crate::Scenario::validate`]).
    pub fn new(vehicle: VehicleParams, phases: &[Phase], initial_speed: f64) -> Self {
        let targets = phases.iter().map(|p| p.speed_target().ok().flatten()).collect();
        Self {
            vehicle,
            phases: phases.to_vec(),
            targets,
            index: 0,
            phase_start_t: 0.0,
            hold_speed: initial_speed,
            offset_from: 0.0,
            offset: 0.0,
            brake_onset: None,
            started: false,
        }
    }

    /// Time of the first brake phase's onset, if it has started.
    pub fn brake_onset(&self) -> Option<f64> {
        self.brake_onset
    }

    /// `true` once every phase has finished.
    pub fn finished(&self) -> bool {
        self.index >= self.phases.len()
    }

    /// One step at time `t` with the lead's current `speed` (m/s) and travelled distance `x` (m).
    pub fn step(&mut self, t: f64, speed: f64, x: f64) -> LeadCommand {
        // Advance through finished phases (several may finish on the same step).
        while let Some(phase) = self.phases.get(self.index) {
            let target = self.targets.get(self.index).copied().flatten();
            let elapsed = t - self.phase_start_t;
            let done = match phase {
                Phase::Accelerate { .. } => target.is_none_or(|v| speed >= v - 0.05),
                Phase::Brake { .. } => target.is_none_or(|v| speed <= v + 0.01),
                Phase::Hold { until_x, until_t, duration } => {
                    until_x.is_some_and(|ux| x >= ux) || until_t.is_some_and(|ut| t >= ut) || duration.is_some_and(|d| elapsed >= d)
                }
                Phase::LaneChange { duration, .. } | Phase::Sine { duration, .. } => elapsed >= *duration,
            };
            if !done {
                break;
            }
            self.finish_phase(t, speed);
        }
        self.on_phase_start(t);
        let target = self.targets.get(self.index).copied().flatten();
        let hold = |v: f64| (HOLD_GAIN * (v - speed)).clamp(-3.0, 2.0);
        let accel = match self.phases.get(self.index) {
            Some(Phase::Accelerate { accel, .. }) => {
                let v = target.unwrap_or(speed);
                // Full acceleration until 1/ACCEL_BLEND m/s below the target, then exponential approach.
                accel.min(ACCEL_BLEND * accel * (v - speed)).max(0.0)
            }
            Some(Phase::Brake { decel, .. }) => -decel,
            Some(Phase::LaneChange { offset, duration }) => {
                let s = ((t - self.phase_start_t) / duration).clamp(0.0, 1.0);
                // Smooth (cosine) lateral profile.
                let w = 0.5 - 0.5 * (std::f64::consts::PI * s).cos();
                self.offset = self.offset_from + (offset - self.offset_from) * w;
                hold(self.hold_speed)
            }
            Some(Phase::Sine { amplitude, freq_hz, .. }) => {
                // Speed reference v0 + A sin(w (t - t0)) around the speed held before: its
                // derivative as feed-forward plus the hold loop on the reference.
                let w = std::f64::consts::TAU * freq_hz;
                let phase = w * (t - self.phase_start_t);
                let reference = self.hold_speed + amplitude * phase.sin();
                (amplitude * w * phase.cos() + HOLD_GAIN * (reference - speed)).clamp(-8.0, 3.5)
            }
            Some(Phase::Hold { .. }) | None => hold(self.hold_speed),
        };
        // Realise the net acceleration: add what drag and rolling resistance take away.
        let accel = accel + self.vehicle.resistance(speed);
        LeadCommand { accel, lateral_offset: self.offset, phase: self.index }
    }

    fn finish_phase(&mut self, t: f64, speed: f64) {
        self.hold_speed = match (self.phases.get(self.index), self.targets.get(self.index).copied().flatten()) {
            (Some(Phase::Accelerate { .. } | Phase::Brake { .. }), Some(v)) => v,
            // After a sine the lead returns to the speed it oscillated around.
            (Some(Phase::Sine { .. }), _) => self.hold_speed,
            _ => speed.max(0.0),
        };
        if let Some(Phase::LaneChange { offset, .. }) = self.phases.get(self.index) {
            self.offset = *offset;
        }
        self.index += 1;
        self.phase_start_t = t;
        self.offset_from = self.offset;
        self.started = false;
    }

    fn on_phase_start(&mut self, t: f64) {
        if self.started {
            return;
        }
        self.started = true;
        self.phase_start_t = t;
        self.offset_from = self.offset;
        if matches!(self.phases.get(self.index), Some(Phase::Brake { .. })) && self.brake_onset.is_none() {
            self.brake_onset = Some(t);
        }
    }
}
