//! The storyboard: OpenSCENARIO's `Storyboard` as scenario data (`[story]`), its runtime
//! ([`StoryState`]) and the kinematic motion its actions prescribe ([`Motion`]). Pure logic: no
//! simulator and no XML here (the `.xosc` importer translates into these types).
//!
//! # Model
//!
//! `[story]` holds **acts** (each with the name of the story it belongs to), each act holds
//! **maneuver groups** (with their actors), each group **maneuvers**, each maneuver **events**,
//! each event **actions**: OpenSCENARIO's `Story` / `Act` / `ManeuverGroup` / `Maneuver` /
//! `Event` / `Action` hierarchy with its state machine (standby -> running -> complete):
//!
//! - an act starts when its start trigger fires (at once without one) and ends when all its
//!   groups are complete or its stop trigger fires (its running actions are stopped);
//! - an event waits in standby while its maneuver runs and starts when its start trigger fires
//!   (at once without one); `priority` decides what happens to other running events of the same
//!   maneuver: `override` stops them, `skip` does not start the event while one runs, `parallel`
//!   runs alongside; an event is complete when all its actions are complete, and runs again
//!   (trigger re-armed) while it has executions left (`max_executions`);
//! - a maneuver, group and act are complete when all their children are complete.
//!
//! Actions act on every actor of their group ([`Action`]): longitudinal ones (speed,
//! longitudinal distance) replace the actor's running longitudinal action, lateral ones (lane
//! change, lane offset) its running lateral action; the two domains run side by side, as in
//! esmini.

mod engine;
mod motion;

pub use engine::{Started, StoryState, Transition as StoryTransition};
pub use motion::{Motion, MotionStep, spline_pose};

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};
use crate::trigger::Trigger;
pub use crate::trigger::VarValue;

/// How the story's scripted entities move (`[story] dynamics`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dynamics {
    /// Exactly as the actions prescribe (speed and lateral offset set every step; esmini's
    /// default controller). Default.
    #[default]
    Kinematic,
    /// Through each entity's vehicle model: a driver tracks the prescribed speed and lateral
    /// offset (actuator lag, dead time and limits apply).
    Vehicle,
}

/// Who drives the ego (`[story] ego`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EgoMode {
    /// flc's controller (the scenario's `controller`); the story's actions on the ego are
    /// ignored, but a `controller` action can hand the ego to the story and back. Default.
    #[default]
    Controller,
    /// The story: the ego follows its own actions kinematically (as esmini's default
    /// controller does); its sensors and pipeline still run and are recorded.
    Scripted,
}

/// One variable and its initial value (`[[story.variables]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variable {
    /// Name (unique).
    pub name: String,
    /// Initial value.
    pub value: VarValue,
}

/// OpenSCENARIO `Priority` of an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Priority {
    /// `override` (1.0: `overwrite`): stops the other running events of its maneuver. Default.
    #[default]
    Override,
    /// `skip`: does not start while another event of its maneuver runs.
    Skip,
    /// `parallel`: runs alongside the others.
    Parallel,
}

/// The transition shape of a speed or lateral change (OpenSCENARIO `DynamicsShape`), as a
/// function `f(p)` of the progress `p` in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// `step`: the target at once.
    Step,
    /// `linear`: `f = p`.
    Linear,
    /// `cubic`: `f = 3p² - 2p³`.
    Cubic,
    /// `sinusoidal`: `f = (1 - cos(pi p)) / 2`.
    Sinusoidal,
}

impl Shape {
    /// `f(p)` for `p` clamped to [0, 1].
    pub fn at(self, p: f64) -> f64 {
        let p = p.clamp(0.0, 1.0);
        match self {
            Shape::Step => 1.0,
            Shape::Linear => p,
            Shape::Cubic => p * p * (3.0 - 2.0 * p),
            Shape::Sinusoidal => 0.5 - 0.5 * (std::f64::consts::PI * p).cos(),
        }
    }

    /// The largest `df/dp` over [0, 1] (0 for a step): 1 linear, 1.5 cubic, pi/2 sinusoidal.
    pub fn peak_slope(self) -> f64 {
        match self {
            Shape::Step => 0.0,
            Shape::Linear => 1.0,
            Shape::Cubic => 1.5,
            Shape::Sinusoidal => 0.5 * std::f64::consts::PI,
        }
    }

    /// `df/dp` at `p` (0 outside [0, 1]).
    pub fn slope(self, p: f64) -> f64 {
        if !(0.0..=1.0).contains(&p) {
            return 0.0;
        }
        match self {
            Shape::Step => 0.0,
            Shape::Linear => 1.0,
            Shape::Cubic => 6.0 * p * (1.0 - p),
            Shape::Sinusoidal => 0.5 * std::f64::consts::PI * (std::f64::consts::PI * p).sin(),
        }
    }
}

/// What `value` of a transition measures (OpenSCENARIO `DynamicsDimension`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dimension {
    /// `time`: the duration, s.
    Time,
    /// `rate`: for a speed change the rate of change, m/s² (the duration is `|change| / rate`);
    /// for a lane change the peak lateral speed, m/s, as esmini reads it (the duration is
    /// `k |change| / rate` with `k` = 1 linear, 1.5 cubic, pi/2 sinusoidal: the shape's
    /// peak slope [`Shape::peak_slope`]).
    Rate,
    /// `distance`: the distance travelled during the transition, m.
    Distance,
}

/// A transition: shape and its extent (`shape`, `dimension`, `value` of an action's table).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transition {
    /// Shape.
    pub shape: Shape,
    /// What `value` is.
    pub dimension: Dimension,
    /// Duration (s), rate or distance (m); ignored for `step`.
    pub value: f64,
}

/// One `ClothoidSplineSegment`: curvature changing linearly over `length`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClothoidSegment {
    /// Curvature at its start, 1/m (+ left).
    pub curvature_start: f64,
    /// Curvature at its end, 1/m (+ left).
    pub curvature_end: f64,
    /// Length, m.
    pub length: f64,
}

impl Transition {
    fn validate(&self) -> Result<(), ConfigError> {
        if self.shape == Shape::Step {
            return check_range("value", self.value, 0.0, 1.0e6, "");
        }
        self.validate_moving()
    }

    /// A speed change may have a rate of 0 (as esmini: the speed stays at its start value).
    fn validate_speed(&self) -> Result<(), ConfigError> {
        if self.shape == Shape::Step || self.dimension == Dimension::Rate {
            return check_range("value", self.value, 0.0, 1.0e6, "");
        }
        self.validate_moving()
    }

    fn validate_moving(&self) -> Result<(), ConfigError> {
        check_range("value", self.value, 1.0e-6, 1.0e6, "(s, rate or m: positive)")
    }
}

/// One action (`kind = "..."`). Speeds in m/s, offsets in m (+ left) from the centreline (the
/// ego lane's centre at the start, [`crate::Track`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Action {
    /// `SpeedAction`: to `speed` (absolute), or to the speed of entity `of` plus `delta` or times
    /// `factor` (`RelativeTargetSpeed`; `continuous`: keep tracking it after the transition).
    Speed {
        /// Absolute target, m/s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        speed: Option<f64>,
        /// Reference entity of a relative target.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        of: Option<String>,
        /// Relative target: `v_of + delta`, m/s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        delta: Option<f64>,
        /// Relative target: `v_of * factor`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        factor: Option<f64>,
        /// Relative target: track it after the transition (the action never ends by itself).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        continuous: bool,
        /// The transition.
        #[serde(flatten)]
        transition: Transition,
    },
    /// `LaneChangeAction`: to the lateral offset `offset` (absolute target lane: the lane centre,
    /// m from the centreline), or `lanes` lanes left (+) of the current lane of entity `of`
    /// (`RelativeTargetLane`, lanes of the track's `lane_width`), plus `lane_offset`
    /// (`targetLaneOffset`, m). `dimension` is `time`, `distance` or `rate` (peak lateral
    /// speed, m/s).
    LaneChange {
        /// Absolute target offset, m.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        offset: Option<f64>,
        /// Reference entity of a relative target.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        of: Option<String>,
        /// Relative target: lanes to the left (+) of `of`'s lane.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lanes: Option<i32>,
        /// `targetLaneOffset`, m (+ left).
        #[serde(default, skip_serializing_if = "is_zero")]
        lane_offset: f64,
        /// The transition.
        #[serde(flatten)]
        transition: Transition,
    },
    /// `LaneOffsetAction` (non-continuous): to `offset` (m, + left) from the centre of the lane
    /// the actor is in when it starts; with `of`, to `offset` from that entity's lateral
    /// position, whatever lanes the two are in (as esmini).
    LaneOffset {
        /// Target offset from the lane centre, m.
        offset: f64,
        /// `RelativeTargetLaneOffset`: relative to this entity's lateral position.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        of: Option<String>,
        /// Shape of the change.
        shape: Shape,
        /// `maxLateralAcc`, m/s² (sets the duration: `sqrt(k |change| / a)` with `k` of the shape).
        max_lateral_acc: f64,
    },
    /// `LongitudinalDistanceAction`: puts the actor at `distance` (m) or `time_gap` (s, times
    /// the actor's speed) behind (`ahead = false`) or ahead of entity `of` in the actor's driving
    /// direction, between bounding boxes with `freespace`, between centres without. `continuous`
    /// (esmini without `DynamicConstraints`): every step it is put there again from `of`'s
    /// position at the start of the step, takes `of`'s speed and moves on with it (a time gap
    /// then times `of`'s speed); the action never ends by itself.
    LongitudinalDistance {
        /// Reference entity.
        of: String,
        /// Distance, m.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        distance: Option<f64>,
        /// Time gap, s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        time_gap: Option<f64>,
        /// Bounding boxes (`true`) or centres.
        freespace: bool,
        /// The actor ahead of `of` (`true`) or behind it (`false`, default).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        ahead: bool,
        /// Kept every step (`true`), or reached once (default).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        continuous: bool,
    },
    /// `SynchronizeAction`, as esmini plays it: the actor's speed is shaped so that it reaches
    /// `target` (track `s` of its reference point) when entity `master` reaches
    /// `master_target` (track `s` of its box centre), arriving at `final_speed` (m/s; held
    /// constant over the last `steady_time` s or `steady_distance` m); without a final speed a
    /// linear profile. Ends when either arrives (within `tolerance` / `tolerance_master`, m),
    /// passes its target or the master would arrive within the step.
    Synchronize {
        /// The master entity.
        master: String,
        /// The master's target, track `s` of its box centre, m.
        master_target: f64,
        /// The master's target as a point `[s, offset]` (track, of its reference point) when the
        /// file gives it on a trajectory (`TrajectoryPosition`): while the master follows a
        /// trajectory, its distance is measured along that trajectory to where the point projects
        /// onto it (esmini's trajectory coordinates), not along the road.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        master_point: Option<[f64; 2]>,
        /// The actor's target, track `s` of its reference point, m.
        target: f64,
        /// Final speed, m/s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        final_speed: Option<f64>,
        /// Steady state before the target, s at the final speed.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        steady_time: Option<f64>,
        /// Steady state before the target, m.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        steady_distance: Option<f64>,
        /// `targetTolerance`, m.
        #[serde(default, skip_serializing_if = "is_zero")]
        tolerance: f64,
        /// `targetToleranceMaster`, m.
        #[serde(default, skip_serializing_if = "is_zero")]
        tolerance_master: f64,
    },
    /// `FollowTrajectoryAction` along a `ClothoidSpline` that starts where the actor is
    /// (no `PositionStart`), as esmini plays it with `TimeReference/None` and `followingMode
    /// position`: the spline is laid from the actor's position and heading when the action
    /// starts, sampled every metre (esmini's polyline), and the actor's reference point moves
    /// along it at the actor's speed; past its end the rest of the step continues straight
    /// and the action ends. It holds the lateral domain only (esmini without a time
    /// reference): a speed action runs beside it and sets the speed it moves at, a lateral
    /// action replaces it. On a straight road only (the spline is laid in the road's frame).
    FollowTrajectory {
        /// The spline's segments, in order.
        segments: Vec<ClothoidSegment>,
    },
    /// `RoutingAction/FollowTrajectoryAction` with a polyline in `position` following mode
    /// (esmini's default controller): the actor is put on the polyline at each step, linearly
    /// between its vertices in time, in centreline coordinates (exact for vertices at one `s`,
    /// as a crossing pedestrian's, and on straight roads); its speed is the segment's length
    /// over its time, its heading (relative to the road) interpolated between the vertices'.
    /// After the last vertex it keeps that speed and heading and moves on along the road, in
    /// the direction its heading faces (esmini's default controller). Replaces both the
    /// running longitudinal and lateral actions.
    Trajectory {
        /// `time`: vertex times are simulation times (`absolute`) or from the action's start.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        absolute: bool,
        /// The vertices, times non-decreasing.
        vertices: Vec<Vertex>,
    },
    /// `VariableSetAction`.
    VariableSet {
        /// The variable.
        variable: String,
        /// Its new value.
        value: VarValue,
    },
    /// `VariableModifyAction`: `value = value * multiply + add` (one of them).
    VariableModify {
        /// The variable.
        variable: String,
        /// Added.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        add: Option<f64>,
        /// Multiplied.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        multiply: Option<f64>,
    },
    /// `ActivateControllerAction` / `ControllerAction` on the ego: `true` hands it to flc's
    /// controller, `false` to the story (lateral is accepted and ignored: pure pursuit always
    /// steers).
    Controller {
        /// flc's longitudinal controller on (`true`) or the story's actions (`false`).
        longitudinal: bool,
    },
}

/// A vertex of a [`Action::Trajectory`] (`[[...actions.vertices]]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vertex {
    /// When it is reached, s from the action's start (or simulation time): the file's
    /// `(time - offset) / scale`.
    pub t: f64,
    /// Position of the reference point along the centreline, m.
    pub s: f64,
    /// Its lateral offset from the centreline, m (+ left).
    pub offset: f64,
    /// Heading relative to the road, rad.
    pub heading: f64,
}

/// At most this many vertices in a trajectory.
pub const MAX_VERTICES: usize = 10_000;

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Action {
    /// `true` for speed and longitudinal-distance actions.
    pub fn is_longitudinal(&self) -> bool {
        matches!(self, Action::Speed { .. } | Action::LongitudinalDistance { .. } | Action::Synchronize { .. } | Action::Trajectory { .. })
    }

    /// `true` for lane change and lane offset actions.
    pub fn is_lateral(&self) -> bool {
        matches!(self, Action::LaneChange { .. } | Action::LaneOffset { .. } | Action::FollowTrajectory { .. } | Action::Trajectory { .. })
    }

    /// The entities it names (`of`).
    fn entity_ref(&self) -> Option<&str> {
        match self {
            Action::Speed { of, .. } | Action::LaneChange { of, .. } | Action::LaneOffset { of, .. } => of.as_deref(),
            Action::LongitudinalDistance { of, .. } => Some(of),
            Action::Synchronize { master, .. } => Some(master),
            _ => None,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), ConfigError> {
        match self {
            Action::Speed { speed, of, delta, factor, transition, .. } => {
                transition.validate_speed()?;
                match (speed, of, delta, factor) {
                    (Some(v), None, None, None) => check_range("speed", *v, 0.0, 100.0, "m/s"),
                    (None, Some(_), Some(d), None) => check_range("delta", *d, -100.0, 100.0, "m/s"),
                    (None, Some(_), None, Some(f)) => check_range("factor", *f, 0.0, 100.0, ""),
                    _ => Err(ConfigError::new("speed", "give `speed` (m/s), or `of` with `delta` (m/s) or `factor`")),
                }
            }
            Action::LaneChange { offset, of, lanes, lane_offset, transition } => {
                transition.validate()?;
                check_range("lane_offset", *lane_offset, -50.0, 50.0, "m")?;
                match (offset, of, lanes) {
                    (Some(o), None, None) => check_range("offset", *o, -100.0, 100.0, "m"),
                    (None, Some(_), Some(l)) if l.unsigned_abs() <= 20 => Ok(()),
                    _ => Err(ConfigError::new("offset", "give `offset` (m), or `of` with `lanes` (at most 20)")),
                }
            }
            Action::LaneOffset { offset, max_lateral_acc, .. } => {
                check_range("offset", *offset, -50.0, 50.0, "m")?;
                check_range("max_lateral_acc", *max_lateral_acc, 1.0e-3, 50.0, "m/s²")
            }
            Action::LongitudinalDistance { distance, time_gap, .. } => match (distance, time_gap) {
                (Some(d), None) => check_range("distance", *d, 0.0, 1.0e5, "m"),
                (None, Some(g)) => check_range("time_gap", *g, 0.0, 1.0e3, "s"),
                _ => Err(ConfigError::new("distance", "give `distance` (m) or `time_gap` (s)")),
            },
            Action::Synchronize {
                master_target, target, final_speed, steady_time, steady_distance, tolerance, tolerance_master, ..
            } => {
                check_range("master_target", *master_target, -1.0e7, 1.0e7, "m")?;
                check_range("target", *target, -1.0e7, 1.0e7, "m")?;
                check_range("tolerance", *tolerance, 0.0, 1.0e4, "m")?;
                check_range("tolerance_master", *tolerance_master, 0.0, 1.0e4, "m")?;
                if let Some(v) = final_speed {
                    check_range("final_speed", *v, 1.0e-3, 100.0, "m/s")?;
                }
                if let Some(t) = steady_time {
                    check_range("steady_time", *t, 0.0, 1.0e4, "s")?;
                }
                if let Some(d) = steady_distance {
                    check_range("steady_distance", *d, 0.0, 1.0e6, "m")?;
                }
                if (steady_time.is_some() || steady_distance.is_some())
                    && (final_speed.is_none() || steady_time.is_some() == steady_distance.is_some())
                {
                    return Err(ConfigError::new(
                        "steady_time",
                        "a steady state needs `final_speed` and one of `steady_time`, `steady_distance`",
                    ));
                }
                Ok(())
            }
            Action::FollowTrajectory { segments } => {
                if segments.is_empty() || segments.len() > 1000 {
                    return Err(ConfigError::new("segments", "give 1 to 1000 segments"));
                }
                let mut total = 0.0;
                for (i, g) in segments.iter().enumerate() {
                    check_range(&format!("segments[{i}].curvature_start"), g.curvature_start, -10.0, 10.0, "1/m")?;
                    check_range(&format!("segments[{i}].curvature_end"), g.curvature_end, -10.0, 10.0, "1/m")?;
                    check_range(&format!("segments[{i}].length"), g.length, 1.0e-3, 1.0e5, "m")?;
                    total += g.length;
                }
                check_range("segments", total, 1.0e-3, 1.0e5, "m (total length)")
            }
            Action::VariableSet { value, .. } => match value {
                VarValue::Num(v) if !v.is_finite() => Err(ConfigError::new("value", "must be finite")),
                _ => Ok(()),
            },
            Action::VariableModify { add, multiply, .. } => match (add, multiply) {
                (Some(a), None) => check_range("add", *a, -1.0e12, 1.0e12, ""),
                (None, Some(m)) => check_range("multiply", *m, -1.0e12, 1.0e12, ""),
                _ => Err(ConfigError::new("add", "give `add` or `multiply`")),
            },
            Action::Controller { .. } => Ok(()),
            Action::Trajectory { vertices, .. } => {
                if vertices.is_empty() || vertices.len() > MAX_VERTICES {
                    return Err(ConfigError::new("vertices", format!("give 1 to {MAX_VERTICES} vertices")));
                }
                let mut prev = f64::NEG_INFINITY;
                for (i, v) in vertices.iter().enumerate() {
                    let at = |k: &str| format!("vertices[{i}].{k}");
                    check_range(&at("t"), v.t, -1.0e6, 1.0e6, "s")?;
                    check_range(&at("s"), v.s, -1.0e6, 1.0e6, "m")?;
                    check_range(&at("offset"), v.offset, -100.0, 100.0, "m")?;
                    check_range(&at("heading"), v.heading, -10.0, 10.0, "rad")?;
                    if v.t < prev {
                        return Err(ConfigError::new(at("t"), "vertex times must not decrease"));
                    }
                    prev = v.t;
                }
                Ok(())
            }
        }
    }
}

/// A named action (`[[...events.actions]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StoryAction {
    /// Name (for `element_state` conditions).
    pub name: String,
    /// The action.
    #[serde(flatten)]
    pub action: Action,
}

/// An event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Event {
    /// Name.
    pub name: String,
    /// Priority among the maneuver's events.
    #[serde(default)]
    pub priority: Priority,
    /// How often it may run (`maximumExecutionCount`, default 1).
    #[serde(default = "one")]
    pub max_executions: u32,
    /// Start trigger (none: starts with its maneuver).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<Trigger>,
    /// Its actions (at least one).
    pub actions: Vec<StoryAction>,
}

fn one() -> u32 {
    1
}

/// A maneuver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Maneuver {
    /// Name.
    pub name: String,
    /// Its events.
    pub events: Vec<Event>,
}

/// A maneuver group.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManeuverGroup {
    /// Name.
    pub name: String,
    /// The entities its actions act on.
    pub actors: Vec<String>,
    /// Its maneuvers.
    pub maneuvers: Vec<Maneuver>,
}

/// An act.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Act {
    /// Name.
    pub name: String,
    /// The story it belongs to (for `element_state` conditions on stories).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub story: String,
    /// Start trigger (none: starts at once).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<Trigger>,
    /// Stop trigger.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop: Option<Trigger>,
    /// Its maneuver groups.
    pub groups: Vec<ManeuverGroup>,
}

/// The storyboard (`[story]`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Story {
    /// How the scripted entities move.
    pub dynamics: Dynamics,
    /// Who drives the ego.
    pub ego: EgoMode,
    /// Variables and their initial values.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub variables: Vec<Variable>,
    /// Each entity's reference point (OpenSCENARIO's: the position its actions and placements
    /// move, a vehicle's rear axle), as the position of its bounding-box centre in the entity's
    /// frame from that point, m (`lead = [1.4, 0.0]`: the centre is 1.4 m ahead of it). Entities
    /// not named move their box centre.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub references: std::collections::BTreeMap<String, [f64; 2]>,
    /// Each entity's `[max acceleration, max deceleration]` (m/s², OpenSCENARIO's vehicle
    /// `Performance`): a speed change whose peak rate exceeds them is stretched in time until it
    /// does not (as esmini). Entities not named change speed as their actions say.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub limits: std::collections::BTreeMap<String, [f64; 2]>,
    /// The acts.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub acts: Vec<Act>,
}

/// Largest number of storyboard elements (acts + groups + maneuvers + events + actions).
pub const MAX_ELEMENTS: usize = 10_000;

impl Story {
    /// Every element name with its kind, in document order.
    pub fn element_names(&self) -> Vec<&str> {
        let mut out = Vec::new();
        let mut stories: Vec<&str> = Vec::new();
        for a in &self.acts {
            if !a.story.is_empty() && !stories.contains(&a.story.as_str()) {
                stories.push(&a.story);
            }
        }
        out.extend(stories);
        for a in &self.acts {
            out.push(a.name.as_str());
            for g in &a.groups {
                out.push(g.name.as_str());
                for m in &g.maneuvers {
                    out.push(m.name.as_str());
                    for e in &m.events {
                        out.push(e.name.as_str());
                        out.extend(e.actions.iter().map(|x| x.name.as_str()));
                    }
                }
            }
        }
        out
    }

    /// Number of elements (acts + groups + maneuvers + events + actions), counted without
    /// allocating.
    pub fn size(&self) -> usize {
        let mut n = 0usize;
        for a in &self.acts {
            n = n.saturating_add(1);
            for g in &a.groups {
                n = n.saturating_add(1);
                for m in &g.maneuvers {
                    n = n.saturating_add(1);
                    for e in &m.events {
                        n = n.saturating_add(1).saturating_add(e.actions.len());
                    }
                }
            }
        }
        n
    }

    /// Every trigger with its dotted key.
    pub fn triggers(&self) -> Vec<(String, &Trigger)> {
        let mut out = Vec::new();
        for (i, a) in self.acts.iter().enumerate() {
            if let Some(t) = &a.start {
                out.push((format!("story.acts[{i}].start"), t));
            }
            if let Some(t) = &a.stop {
                out.push((format!("story.acts[{i}].stop"), t));
            }
            for (j, g) in a.groups.iter().enumerate() {
                for (k, m) in g.maneuvers.iter().enumerate() {
                    for (l, e) in m.events.iter().enumerate() {
                        if let Some(t) = &e.start {
                            out.push((format!("story.acts[{i}].groups[{j}].maneuvers[{k}].events[{l}].start"), t));
                        }
                    }
                }
            }
        }
        out
    }

    /// Checks sizes first, then names, actors and actions (`entities`: every entity name an
    /// actor or reference may use). Keys are dotted (`story.acts[0].groups[1].actors`).
    pub fn validate(&self, entities: &[&str]) -> Result<(), ConfigError> {
        let n = self.size();
        if n > MAX_ELEMENTS {
            return Err(ConfigError::new("story.acts", format!("{n} storyboard elements, more than the limit of {MAX_ELEMENTS}")));
        }
        if self.variables.len() > MAX_ELEMENTS {
            return Err(ConfigError::new("story.variables", format!("more than {MAX_ELEMENTS} variables")));
        }
        let mut vars: Vec<&str> = self.variables.iter().map(|v| v.name.as_str()).collect();
        vars.sort_unstable();
        if let Some(w) = vars.windows(2).find(|w| w[0] == w[1]) {
            return Err(ConfigError::new("story.variables", format!("variable `{}` declared twice", w[0])));
        }
        for (i, v) in self.variables.iter().enumerate() {
            if let VarValue::Num(x) = v.value {
                check_range(&format!("story.variables[{i}].value"), x, -1.0e300, 1.0e300, "")?;
            }
        }
        let entity_set: std::collections::HashSet<&str> = entities.iter().copied().collect();
        let known = |name: &str| entity_set.contains(name);
        for (name, r) in &self.references {
            if !known(name) {
                return Err(ConfigError::new(format!("story.references.{name}"), format!("no entity `{name}`")));
            }
            check_range(&format!("story.references.{name}[0]"), r[0], -50.0, 50.0, "m")?;
            check_range(&format!("story.references.{name}[1]"), r[1], -50.0, 50.0, "m")?;
        }
        for (name, l) in &self.limits {
            if !known(name) {
                return Err(ConfigError::new(format!("story.limits.{name}"), format!("no entity `{name}`")));
            }
            check_range(&format!("story.limits.{name}[0]"), l[0], 0.01, 1.0e3, "m/s²")?;
            check_range(&format!("story.limits.{name}[1]"), l[1], 0.01, 1.0e3, "m/s²")?;
        }
        for (i, a) in self.acts.iter().enumerate() {
            let ak = format!("story.acts[{i}]");
            for (j, g) in a.groups.iter().enumerate() {
                let gk = format!("{ak}.groups[{j}]");
                for (x, actor) in g.actors.iter().enumerate() {
                    if !known(actor) {
                        return Err(ConfigError::new(
                            format!("{gk}.actors[{x}]"),
                            format!("no entity `{actor}` (entities: {})", entities.join(", ")),
                        ));
                    }
                }
                for (k, m) in g.maneuvers.iter().enumerate() {
                    for (l, e) in m.events.iter().enumerate() {
                        let ek = format!("{gk}.maneuvers[{k}].events[{l}]");
                        if e.actions.is_empty() {
                            return Err(ConfigError::new(format!("{ek}.actions"), "an event needs at least one action"));
                        }
                        if e.max_executions == 0 {
                            return Err(ConfigError::new(format!("{ek}.max_executions"), "must be at least 1"));
                        }
                        for (y, act) in e.actions.iter().enumerate() {
                            let key = format!("{ek}.actions[{y}]");
                            act.action.validate().map_err(|err| err.within(&key))?;
                            if let Some(of) = act.action.entity_ref().filter(|o| !known(o)) {
                                return Err(ConfigError::new(format!("{key}.of"), format!("no entity `{of}`")));
                            }
                            if let Action::VariableSet { variable, .. } | Action::VariableModify { variable, .. } = &act.action {
                                if vars.binary_search(&variable.as_str()).is_err() {
                                    return Err(ConfigError::new(
                                        format!("{key}.variable"),
                                        format!("no variable `{variable}` in story.variables"),
                                    ));
                                }
                            }
                            if (act.action.is_longitudinal() || act.action.is_lateral()) && g.actors.is_empty() {
                                return Err(ConfigError::new(format!("{gk}.actors"), "a motion action needs at least one actor"));
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
