//! Scripted vehicles: the lead (`[lead]`) and any other traffic (`[[vehicles]]`), each driven by
//! a [`LeadDriver`] that runs its [`Phase`]s (in order, or when their start triggers fire) and
//! produces an acceleration command and a lateral offset target for every physics step.

mod phase;

pub use phase::{Phase, STOP_AT_DECEL, ScriptedPhase};

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};
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
    pub phases: Vec<ScriptedPhase>,
    /// Initial position of its centre along the centreline, m (`None`, default: `initial_gap`
    /// ahead of the follower; one follower only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub s: Option<f64>,
    /// Initial lateral offset of its centre from the centreline, m (+ left). Default 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub offset: f64,
    /// Initial heading relative to the road, rad (+ left). Default 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub heading: f64,
    /// `true`: there is no lead (an OpenSCENARIO file with the ego alone). Its slot stays in the
    /// simulation, at `s`, but out of the world: no sensor sees it, it touches nothing, it is
    /// no vehicle in front (the series' `lead_*` columns are NaN while nothing is in path) and
    /// it sends no V2V (`v2v.enabled` must be `false`). Default `false`.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub absent: bool,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// A scripted vehicle besides the lead (TOML `[[vehicles]]`): other traffic, a cut-in car, a
/// standing car. The ego's detector sees it like any other body; its phases are the lead's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScriptedVehicle {
    /// Its name (unique; not `ego`, `lead` or `follower<k>`): what triggers and collision
    /// records call it.
    pub name: String,
    /// Vehicle model (default: the default car).
    #[serde(default)]
    pub vehicle: VehicleParams,
    /// Initial position of its centre along the centreline, m.
    pub s: f64,
    /// Initial lane (index, [`crate::Track::lane_offset`]); give `lane` or `offset` (default:
    /// the ego's lane).
    #[serde(default)]
    pub lane: Option<u32>,
    /// Initial lateral offset from the ego lane's centre, m (+ left).
    #[serde(default)]
    pub offset: Option<f64>,
    /// Initial heading relative to the road, rad (+ left).
    #[serde(default)]
    pub heading: f64,
    /// Initial speed, m/s (negative only in a story, an imported file: it drives backwards along
    /// its path, facing `heading`, as esmini plays an OpenSCENARIO entity with a negative speed).
    #[serde(default)]
    pub initial_speed: f64,
    /// Its manoeuvre (empty: it holds its initial speed; with speed 0 it stands).
    #[serde(default)]
    pub phases: Vec<ScriptedPhase>,
}

impl ScriptedVehicle {
    /// Checks its values (keys relative to the vehicle's table); lanes and triggers are checked
    /// by the scenario, which knows the track and the other entities.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_moved_by(false)
    }

    /// [`ScriptedVehicle::validate`] for a vehicle moved by a story (`story`: an imported
    /// OpenSCENARIO file), which may start backwards; its phases' driver starts forwards.
    pub fn validate_moved_by(&self, story: bool) -> Result<(), ConfigError> {
        check_range("s", self.s, -1.0e6, 1.0e6, "m")?;
        check_range("heading", self.heading, -3.2, 3.2, "rad")?;
        check_range("initial_speed", self.initial_speed, if story { -70.0 } else { 0.0 }, 70.0, "m/s")?;
        if let Some(o) = self.offset {
            check_range("offset", o, -50.0, 50.0, "m")?;
        }
        if self.lane.is_some() && self.offset.is_some() {
            return Err(ConfigError::new("offset", "give either `lane` or `offset`"));
        }
        self.vehicle.validate().map_err(|e| e.within("vehicle"))?;
        for (i, p) in self.phases.iter().enumerate() {
            p.validate().map_err(|e| e.within(&format!("phases[{i}]")))?;
        }
        Ok(())
    }
}

impl Default for LeadSpec {
    fn default() -> Self {
        Self {
            initial_speed: 0.0,
            vehicle: VehicleParams::default(),
            phases: Vec::new(),
            s: None,
            offset: 0.0,
            heading: 0.0,
            absent: false,
        }
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

/// Phase state machine of a scripted vehicle. The driver realises the script: its acceleration
/// demand is the phase's acceleration plus a feed-forward of the vehicle's own driving resistance
/// ([`VehicleParams::resistance`]), so a `brake` phase of 6 m/s² decelerates the vehicle at 6 m/s²
/// at any speed (within its brake authority, after the actuator's dead time and lag).
///
/// Start triggers ([`ScriptedPhase::start`]) are evaluated by the simulation on ground truth: it
/// asks [`LeadDriver::armed`] which phase's trigger to watch and calls [`LeadDriver::fire`] when it
/// fires.
#[derive(Debug, Clone)]
pub struct LeadDriver {
    vehicle: VehicleParams,
    phases: Vec<Phase>,
    has_trigger: Vec<bool>,
    fired: Vec<bool>,
    targets: Vec<Option<f64>>,
    /// Lane changes: the final offset of each phase (lanes resolved on the track).
    offsets: Vec<Option<f64>>,
    index: usize,
    phase_start_t: f64,
    hold_speed: f64,
    offset_from: f64,
    offset: f64,
    brake_onset: Option<f64>,
    started: bool,
    /// Start / end time of every phase.
    times: Vec<(Option<f64>, Option<f64>)>,
    /// Position along the centreline where the travelled distance is 0, plus half the length:
    /// `front = front0 + x`.
    front0: f64,
}

impl LeadDriver {
    /// The driver of a vehicle that starts with its centre at `s0` along the centreline and
    /// lateral `offset0`; `phases` must have been validated ([`crate::Scenario::validate`]);
    /// lane indices go through `lane_offset` ([`crate::Track::lane_offset`]).
    pub fn new(
        vehicle: VehicleParams,
        phases: &[ScriptedPhase],
        initial_speed: f64,
        s0: f64,
        offset0: f64,
        lane_offset: &dyn Fn(u32) -> f64,
    ) -> Self {
        let targets = phases.iter().map(|p| p.speed_target().ok().flatten()).collect();
        let offsets = phases
            .iter()
            .map(|p| match &p.phase {
                Phase::LaneChange { offset, lane, .. } => offset.or(lane.map(lane_offset)),
                _ => None,
            })
            .collect();
        Self {
            vehicle,
            phases: phases.iter().map(|p| p.phase.clone()).collect(),
            has_trigger: phases.iter().map(|p| p.start.is_some()).collect(),
            fired: vec![false; phases.len()],
            targets,
            offsets,
            index: 0,
            phase_start_t: 0.0,
            hold_speed: initial_speed,
            offset_from: offset0,
            offset: offset0,
            brake_onset: None,
            started: false,
            times: vec![(None, None); phases.len()],
            front0: s0 + vehicle.length / 2.0,
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

    /// Start and end times of phase `k` (`None`: not yet).
    pub fn phase_times(&self, k: usize) -> (Option<f64>, Option<f64>) {
        self.times.get(k).copied().unwrap_or((None, None))
    }

    /// The phase whose start trigger is watched now: the current phase while it waits for its
    /// trigger, else the next one if it has a trigger.
    pub fn armed(&self) -> Option<usize> {
        let waiting = self.index < self.phases.len() && self.has_trigger[self.index] && !self.fired[self.index];
        if waiting {
            return Some(self.index);
        }
        let next = self.index + 1;
        (next < self.phases.len() && self.has_trigger[next] && !self.fired[next]).then_some(next)
    }

    /// Phase `k`'s trigger fired at `t` (the vehicle's speed `speed`): it starts now, cutting
    /// the running phase short if there is one.
    pub fn fire(&mut self, k: usize, t: f64, speed: f64) {
        if k >= self.phases.len() || self.fired[k] {
            return;
        }
        self.fired[k] = true;
        if k == self.index + 1 {
            self.finish_phase(t, speed);
        }
    }

    fn waiting(&self) -> bool {
        self.index < self.phases.len() && self.has_trigger[self.index] && !self.fired[self.index]
    }

    /// One step at time `t` with the vehicle's current `speed` (m/s) and travelled distance `x` (m).
    pub fn step(&mut self, t: f64, speed: f64, x: f64) -> LeadCommand {
        // Advance through finished phases (several may finish on the same step).
        while !self.waiting() {
            let Some(phase) = self.phases.get(self.index) else { break };
            let target = self.targets.get(self.index).copied().flatten();
            let elapsed = t - self.phase_start_t;
            let done = match phase {
                Phase::Accelerate { .. } => target.is_none_or(|v| speed >= v - 0.05),
                Phase::Brake { .. } => target.is_none_or(|v| speed <= v + 0.01),
                Phase::Hold { until_x, until_t, duration } => {
                    until_x.is_some_and(|ux| x >= ux) || until_t.is_some_and(|ut| t >= ut) || duration.is_some_and(|d| elapsed >= d)
                }
                Phase::LaneChange { duration, .. } | Phase::Sine { duration, .. } => elapsed >= *duration,
                Phase::StopAt { .. } => self.started && speed <= 0.01,
                Phase::Stand { duration } => duration.is_some_and(|d| elapsed >= d),
            };
            if !done {
                break;
            }
            self.finish_phase(t, speed);
        }
        let hold = |v: f64| (HOLD_GAIN * (v - speed)).clamp(-3.0, 2.0);
        if self.waiting() {
            // Waiting for the phase's trigger: keep speed and lane.
            let accel = hold(self.hold_speed) + self.vehicle.resistance(speed);
            return LeadCommand { accel, lateral_offset: self.offset, phase: self.index };
        }
        self.on_phase_start(t);
        let target = self.targets.get(self.index).copied().flatten();
        let accel = match self.phases.get(self.index) {
            Some(Phase::Accelerate { accel, .. }) => {
                let v = target.unwrap_or(speed);
                // Full acceleration until 1/ACCEL_BLEND m/s below the target, then exponential approach.
                accel.min(ACCEL_BLEND * accel * (v - speed)).max(0.0)
            }
            Some(Phase::Brake { decel, .. }) => -decel,
            Some(Phase::LaneChange { duration, .. }) => {
                let offset = self.offsets.get(self.index).copied().flatten().unwrap_or(self.offset_from);
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
            Some(Phase::StopAt { s, max_decel }) => {
                let limit = max_decel.unwrap_or(STOP_AT_DECEL);
                let d = s - (self.front0 + x);
                if d > 0.01 { (-(speed * speed) / (2.0 * d)).max(-limit) } else { -limit.min(3.0 + 3.0 * speed) }
            }
            Some(Phase::Stand { .. }) => hold(0.0),
            Some(Phase::Hold { .. }) | None => hold(self.hold_speed),
        };
        // Realise the net acceleration: add what drag and rolling resistance take away.
        let accel = accel + self.vehicle.resistance(speed);
        LeadCommand { accel, lateral_offset: self.offset, phase: self.index }
    }

    fn finish_phase(&mut self, t: f64, speed: f64) {
        self.hold_speed = match (self.phases.get(self.index), self.targets.get(self.index).copied().flatten()) {
            (Some(Phase::Accelerate { .. } | Phase::Brake { .. }), Some(v)) => v,
            // After a sine the vehicle returns to the speed it oscillated around.
            (Some(Phase::Sine { .. }), _) => self.hold_speed,
            (Some(Phase::StopAt { .. } | Phase::Stand { .. }), _) => 0.0,
            _ => speed.max(0.0),
        };
        if let Some(Some(offset)) = self.offsets.get(self.index) {
            self.offset = *offset;
        }
        if let Some(tm) = self.times.get_mut(self.index) {
            // A phase cut short before it began still counts as started and ended now.
            tm.0.get_or_insert(t);
            tm.1 = Some(t);
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
        if let Some(tm) = self.times.get_mut(self.index) {
            tm.0 = Some(t);
        }
        if matches!(self.phases.get(self.index), Some(Phase::Brake { .. })) && self.brake_onset.is_none() {
            self.brake_onset = Some(t);
        }
    }
}
