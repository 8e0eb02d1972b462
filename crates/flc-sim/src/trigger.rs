//! Start and stop triggers with ASAM OpenSCENARIO 1.x semantics (pure logic: no simulator here).
//!
//! A [`Trigger`] is OpenSCENARIO's `Trigger` (`StartTrigger` / `StopTrigger`): a list of
//! `ConditionGroup`s that are ORed, each group a list of [`Condition`]s that are ANDed. A
//! [`Condition`] is OpenSCENARIO's `Condition`: a test ([`ConditionKind`]: `ByValueCondition` /
//! `ByEntityCondition` elements) plus its `delay` and `conditionEdge` ([`Edge`]).
//!
//! # TOML shapes
//!
//! A trigger is written as one of (`start` is the key of the field holding it):
//!
//! ```toml
//! # one condition: a table
//! start = { kind = "relative_distance", entity = "ego", of = "lead", distance = "longitudinal", freespace = true, rule = "less_than", value = 20.0 }
//! # OR of groups: an array; each element is one group, written either as one condition (a
//! # table) or as an array of conditions that are ANDed. This is (a AND b) OR c:
//! start = [[{ kind = "speed", entity = "ego", rule = "greater_than", value = 10.0 },
//!           { kind = "simulation_time", rule = "greater_or_equal", value = 2.0 }],
//!          { kind = "phase_state", entity = "lead", phase = 1, state = "ended", delay = 1.5 }]
//! ```
//!
//! Error keys follow the shape written: `start.entity` for a single condition, `start[1].entity`
//! for a group written as one table, `start[0][1].value` for condition 1 of group 0. The scenario
//! stop trigger is the same type ([`StopTrigger`]).
//!
//! # Evaluation and discretisation
//!
//! [`TriggerState::update`] is called once per physics step with the ground truth ([`WorldView`])
//! and the simulation time `t`. Per condition, at each evaluation:
//!
//! 1. the *level* is the test on the current ground truth (e.g. `gap < 20 m`); a value within
//!    `1e-9 * max(1, |value|)` of the threshold counts as equal (so `less_or_equal 20` holds at a
//!    gap of `20 + 1e-12`, `less_than 20` does not);
//! 2. the *edge* turns the level into the condition's raw result: `none` = the level; `rising` =
//!    the level was false at the previous evaluation and is true now; `falling` = true before,
//!    false now; `rising_or_falling` = changed. There is no previous evaluation at the first call,
//!    so an edge never holds there: a `rising` condition that is already true at the first
//!    evaluation does not fire until it has become false and true again (OpenSCENARIO: an edge is
//!    a transition between two evaluations);
//! 3. the *delay* `d` shifts the raw result in time: the result reported at time `t` is the raw
//!    result of the latest evaluation at time `<= t - d` (`1e-9` s slack), false before there was
//!    one. A condition that becomes true at the evaluation at `t0` is thus reported at the first
//!    evaluation at `t >= t0 + d`: exactly `d / dt` steps later when `d` is a multiple of `dt`.
//!
//! The trigger is the OR over groups of the AND of the reported results; it *fires* at the first
//! evaluation where it is true. [`TriggerState::update`] returns `true` at that evaluation and
//! never again (an OpenSCENARIO trigger starts its element once). A trigger with no group, or a
//! group with no condition, never holds ([`Trigger::validate`] rejects both).
//!
//! # Geometry
//!
//! Entities live on one road: `s` is the (unwrapped) distance along the road of the entity's
//! reference point, its centre; `lateral` the offset from the lane centre (+ left); bounding boxes
//! are `length` x `width` rectangles aligned with the road. See [`DistanceType`] and
//! [`ConditionKind`] for distances, headway and time to collision.
//!
//! # Phases and cycles
//!
//! A scripted entity has a list of phases run in order; phase `k > 0` implicitly waits for phase
//! `k - 1` to end, and a `phase_state` condition in its start trigger (OpenSCENARIO
//! `StoryboardElementStateCondition`) makes it wait for another phase too. [`check_phase_cycles`]
//! finds phases that can never start because they wait on each other (implicit edges included);
//! [`validate_scripts`] validates every start trigger and then checks the cycles.

use std::collections::{HashMap, HashSet, VecDeque};
use std::fmt;

use serde::de::{MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::{ConfigError, check_range};

/// Most condition groups of one trigger (as many as an imported trigger may expand to,
/// `openscenario::storyboard::MAX_GROUPS`).
pub const MAX_TRIGGER_GROUPS: usize = 64;

/// Most conditions of one trigger, all groups together (an imported trigger has up to
/// `openscenario::storyboard::MAX_CONDITIONS` as written; one expanded past this is rejected
/// when its twin is validated).
pub const MAX_TRIGGER_CONDITIONS: usize = 4096;

/// Float slack of comparisons and delays.
const EPS: f64 = 1e-9;

/// OpenSCENARIO `conditionEdge`. The default is `none` (OpenSCENARIO has no default: the
/// attribute is mandatory): with `none` a start condition such as "gap below 20 m" fires at the
/// first step it holds, including a scenario that starts inside the condition, which is what a
/// hand-written phase list means; `rising` would silently never fire there (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Edge {
    /// `rising`: the level changes from false to true between two evaluations.
    Rising,
    /// `falling`: the level changes from true to false between two evaluations.
    Falling,
    /// `risingOrFalling`: the level changes between two evaluations.
    RisingOrFalling,
    /// `none`: the level itself.
    #[default]
    None,
}

impl Edge {
    fn is_none(&self) -> bool {
        *self == Edge::None
    }
}

/// OpenSCENARIO `Rule` comparing the measured quantity `x` with the condition's `value`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rule {
    /// `greaterThan`: `x > value`.
    GreaterThan,
    /// `lessThan`: `x < value`.
    LessThan,
    /// `equalTo`: `|x - value| <= tolerance`.
    EqualTo,
    /// `greaterOrEqual`: `x >= value`.
    GreaterOrEqual,
    /// `lessOrEqual`: `x <= value`.
    LessOrEqual,
    /// `notEqualTo`: `|x - value| > tolerance`.
    NotEqualTo,
}

impl Rule {
    /// Whether `x` satisfies the rule against `value`; `tolerance` (default 0) widens
    /// `equal_to` / `not_equal_to`. Values within `1e-9 * max(1, |value|)` of `value` count as
    /// equal. A NaN `x` satisfies nothing.
    pub fn holds(self, x: f64, value: f64, tolerance: Option<f64>) -> bool {
        if x.is_nan() {
            return false;
        }
        let eps = EPS * value.abs().max(1.0);
        let tol = tolerance.unwrap_or(0.0) + eps;
        match self {
            Rule::GreaterThan => x > value + eps,
            Rule::LessThan => x < value - eps,
            Rule::GreaterOrEqual => x >= value - eps,
            Rule::LessOrEqual => x <= value + eps,
            Rule::EqualTo => (x - value).abs() <= tol,
            Rule::NotEqualTo => (x - value).abs() > tol,
        }
    }

    fn takes_tolerance(self) -> bool {
        matches!(self, Rule::EqualTo | Rule::NotEqualTo)
    }
}

/// OpenSCENARIO `relativeDistanceType`, with `freespace` (bool) choosing between bounding boxes
/// and reference points. With `da = |s_of - s_entity|`, `dl = |lat_of - lat_entity|`:
///
/// | type | `freespace = false` (reference points) | `freespace = true` (bounding boxes) |
/// |---|---|---|
/// | `longitudinal` | `da` | `gx = max(0, da - (len_a + len_b) / 2)` (bumper to bumper) |
/// | `lateral` | `dl` | `gy = max(0, dl - (w_a + w_b) / 2)` |
/// | `euclidean` (`cartesianDistance`) | `hypot(da, dl)` | `hypot(gx, gy)` (exact for road-aligned boxes) |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DistanceType {
    /// `longitudinal`: along the road (`s`).
    Longitudinal,
    /// `lateral`: across the road.
    Lateral,
    /// `cartesianDistance`: the Euclidean distance.
    Euclidean,
}

/// Which transition of a phase a `phase_state` condition waits for (OpenSCENARIO
/// `StoryboardElementState`): the condition holds from that transition on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhaseEvent {
    /// `startTransition`: the phase has started.
    Started,
    /// `endTransition`: the phase has ended.
    Ended,
}

/// A variable value (OpenSCENARIO `VariableDeclaration` / parameter types): number, boolean or
/// text.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum VarValue {
    /// `boolean`.
    Bool(bool),
    /// Any numeric type.
    Num(f64),
    /// `string` (and `dateTime`).
    Text(String),
}

/// OpenSCENARIO `StoryboardElementState` of an `element_state` condition. Transitions hold from
/// the moment they happen until the element's next transition (an event that runs again starts
/// The kind of a storyboard element (`storyboardElementType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ElementKind {
    /// A story.
    Story,
    /// An act.
    Act,
    /// A maneuver group.
    ManeuverGroup,
    /// A maneuver.
    Maneuver,
    /// An event.
    Event,
    /// An action.
    Action,
}

/// over); states hold while the element is in them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ElementEvent {
    /// `startTransition`.
    StartTransition,
    /// `endTransition`: it completed by itself.
    EndTransition,
    /// `stopTransition`: it was stopped (stop trigger, override).
    StopTransition,
    /// `skipTransition`: it was skipped (priority `skip`).
    SkipTransition,
    /// `completeState`.
    CompleteState,
    /// `runningState`.
    RunningState,
    /// `standbyState`.
    StandbyState,
}

/// The runtime state of a storyboard element, as a [`WorldView`] reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ElementStatus {
    /// In `runningState`.
    pub running: bool,
    /// In `completeState`.
    pub complete: bool,
    /// The last transition (`None`: none yet, standby), one of the transition variants.
    pub last: Option<ElementEvent>,
}

impl ElementStatus {
    /// Whether the element is in / has just had `e`.
    pub fn holds(&self, e: ElementEvent) -> bool {
        match e {
            ElementEvent::RunningState => self.running,
            ElementEvent::CompleteState => self.complete,
            ElementEvent::StandbyState => !self.running && !self.complete,
            t => self.last == Some(t),
        }
    }
}

/// The test of a [`Condition`] (TOML `kind = "..."`). `entity` is OpenSCENARIO's triggering
/// entity (`TriggeringEntities` with one `EntityRef`), `of` the reference entity (`entityRef`).
/// `value` / `rule` / `tolerance` compare the measured quantity ([`Rule`]); `tolerance` is only
/// allowed with `equal_to` / `not_equal_to`. `freespace` and `distance` are mandatory, as in
/// OpenSCENARIO.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ConditionKind {
    /// `ByValueCondition/SimulationTimeCondition`: the simulation time `t` (s).
    SimulationTime {
        /// Threshold, s.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/RelativeDistanceCondition`: the distance from `entity` to `of` (m),
    /// see [`DistanceType`].
    RelativeDistance {
        /// Triggering entity.
        entity: String,
        /// Reference entity.
        of: String,
        /// `relativeDistanceType`.
        distance: DistanceType,
        /// `true`: between bounding boxes; `false`: between reference points (centres).
        freespace: bool,
        /// Threshold, m.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, m.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/TimeHeadwayCondition`: the distance (bumper to bumper with
    /// `freespace`, else centre to centre) from `entity` to `of` ahead of it, divided by the
    /// speed of `entity` (s). Infinite when `of` is behind `entity` or `entity` does not move
    /// forward. `distance = "euclidean"` with `freespace`: the shortest distance between the two
    /// (rotated) boxes, as esmini measures it.
    TimeHeadway {
        /// Triggering entity (the follower).
        entity: String,
        /// Reference entity (ahead).
        of: String,
        /// Bounding boxes (`true`) or reference points (`false`).
        freespace: bool,
        /// What is measured (default `longitudinal`).
        #[serde(default = "longitudinal", skip_serializing_if = "is_longitudinal")]
        distance: DistanceType,
        /// Threshold, s.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/TimeToCollisionCondition` (target = an `EntityRef`): the longitudinal
    /// distance between `entity` and `of` (as in `time_headway`) divided by the closing speed,
    /// s, accelerations ignored. `of` may be ahead (closing speed `v_entity - v_of`) or behind
    /// (`v_of - v_entity`); infinite when not closing. Lateral offsets are ignored: AND it with
    /// a lateral `relative_distance` condition to require the same lane.
    Ttc {
        /// Triggering entity.
        entity: String,
        /// Reference entity, ahead or behind.
        of: String,
        /// Bounding boxes (`true`) or reference points (`false`).
        freespace: bool,
        /// Threshold, s.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/SpeedCondition`: the speed of `entity`, m/s.
    Speed {
        /// Triggering entity.
        entity: String,
        /// Threshold, m/s.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, m/s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/ReachPositionCondition`: the reference point of `entity` is within
    /// `tolerance` (m) of the road position `s` (and of the lateral offset `lateral` if given,
    /// Euclidean). An entity moving more than `2 tolerance` per step can jump over the position.
    ReachPosition {
        /// Triggering entity.
        entity: String,
        /// Position along the road, m.
        s: f64,
        /// Lateral offset, m (`None`: any).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lateral: Option<f64>,
        /// Radius, m.
        tolerance: f64,
    },
    /// `ByEntityCondition/TraveledDistanceCondition`: the distance travelled by `entity` since
    /// the start is at least `value` (m).
    TraveledDistance {
        /// Triggering entity.
        entity: String,
        /// Distance, m.
        value: f64,
    },
    /// `ByEntityCondition/AccelerationCondition`: the longitudinal acceleration of `entity`, m/s².
    Acceleration {
        /// Triggering entity.
        entity: String,
        /// Threshold, m/s².
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, m/s².
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/StandStillCondition`: `entity` has been at standstill (speed below
    /// 1e-3 m/s) for more than `duration` s, counted from the first evaluation that saw it
    /// standing.
    StandStill {
        /// Triggering entity.
        entity: String,
        /// Duration, s.
        duration: f64,
    },
    /// `ByEntityCondition/RelativeSpeedCondition`: the speed of `entity` minus that of `of`, m/s.
    RelativeSpeed {
        /// Triggering entity.
        entity: String,
        /// Reference entity.
        of: String,
        /// Threshold, m/s.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, m/s.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/DistanceCondition`: the distance from `entity` to the road position
    /// `s`, `lateral` (m along / across the centreline), see [`DistanceType`] (`freespace`: from
    /// the entity's bounding box).
    Distance {
        /// Triggering entity.
        entity: String,
        /// Position along the centreline, m.
        s: f64,
        /// Lateral offset of the position, m (+ left).
        #[serde(default)]
        lateral: f64,
        /// `relativeDistanceType`.
        distance: DistanceType,
        /// From the bounding box (`true`) or the reference point.
        freespace: bool,
        /// Threshold, m.
        value: f64,
        /// Comparison.
        rule: Rule,
        /// Half width of `equal_to`, m.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        tolerance: Option<f64>,
    },
    /// `ByEntityCondition/CollisionCondition`: `entity` has touched `with` (an entity name), or
    /// anything when `with` is not given.
    Collision {
        /// Triggering entity.
        entity: String,
        /// The other entity (`None`: anything).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        with: Option<String>,
    },
    /// `ByValueCondition/VariableCondition` (and `ParameterCondition`, parameters being
    /// variables set once): story variable `variable` compared with `value` (numbers with the
    /// rule; booleans and text only `equal_to` / `not_equal_to`).
    Variable {
        /// The variable (`[[story.variables]]`).
        variable: String,
        /// Compared value.
        value: VarValue,
        /// Comparison.
        rule: Rule,
    },
    /// `ByValueCondition/StoryboardElementStateCondition` on a storyboard element of `[story]`
    /// (story, act, maneuver group, maneuver, event or action, by name).
    ElementState {
        /// The element's name.
        element: String,
        /// The state or transition waited for.
        state: ElementEvent,
        /// Its kind (`storyboardElementType`): among elements of the same name, the one of
        /// this kind (default: the first of that name, outermost first).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        element_type: Option<ElementKind>,
    },
    /// `ByValueCondition/StoryboardElementStateCondition` on a phase: phase `phase` (index in
    /// the entity's phase list, from 0) of `entity` has started / ended.
    PhaseState {
        /// The entity owning the phase.
        entity: String,
        /// Phase index, from 0.
        phase: usize,
        /// The transition waited for.
        state: PhaseEvent,
    },
}

/// One OpenSCENARIO `Condition`: a test with its `delay` (s, default 0) and `conditionEdge`
/// (`edge`, default `none`, see [`Edge`]). In TOML the three are one table:
/// `{ kind = "speed", entity = "ego", rule = "less_than", value = 5.0, edge = "falling", delay = 0.5 }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Condition {
    /// `delay`: the result is reported this long after it holds, s (>= 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub delay: f64,
    /// `conditionEdge`.
    #[serde(default, skip_serializing_if = "Edge::is_none")]
    pub edge: Edge,
    /// The test (unknown keys are rejected by it).
    #[serde(flatten)]
    pub kind: ConditionKind,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Condition {
    /// A condition without delay, edge `none`.
    pub fn new(kind: ConditionKind) -> Self {
        Self { delay: 0.0, edge: Edge::None, kind }
    }

    /// With `delay` (s).
    pub fn delayed(mut self, delay: f64) -> Self {
        self.delay = delay;
        self
    }

    /// With `edge`.
    pub fn on(mut self, edge: Edge) -> Self {
        self.edge = edge;
        self
    }
}

/// Ground truth of one entity, as a [`WorldView`] gives it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EntityState {
    /// Position along the road of the reference point (centre), m, unwrapped.
    pub s: f64,
    /// Lateral offset of the reference point from the lane centre, m, + left.
    pub lateral: f64,
    /// Speed (along the road), m/s.
    pub speed: f64,
    /// Bounding box length, m.
    pub length: f64,
    /// Bounding box width, m.
    pub width: f64,
    /// Distance travelled since the start, m.
    pub traveled: f64,
    /// Longitudinal acceleration, m/s².
    pub accel: f64,
    /// Time it has been at standstill (speed < 1e-3 m/s) without interruption, s (0 while moving).
    pub still_for: f64,
}

/// Start / end times of one phase (`None`: not yet).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PhaseStatus {
    /// Simulation time the phase started, s.
    pub started: Option<f64>,
    /// Simulation time the phase ended, s.
    pub ended: Option<f64>,
}

/// The ground truth triggers are evaluated on. The simulation time is the `t` passed to
/// [`TriggerState::update`] (one source of truth for delays and `simulation_time`).
pub trait WorldView {
    /// The state of entity `name` (`None`: no such entity; its conditions do not hold).
    fn entity(&self, name: &str) -> Option<EntityState>;
    /// The status of phase `phase` of entity `name` (default: not started).
    fn phase(&self, name: &str, phase: usize) -> PhaseStatus;
    /// The status of storyboard element `name` (default: none; its conditions do not hold).
    fn element(&self, _name: &str) -> Option<ElementStatus> {
        None
    }
    /// The status of storyboard element `name` of kind `kind` (default: [`WorldView::element`]).
    fn element_of(&self, name: &str, kind: Option<ElementKind>) -> Option<ElementStatus> {
        let _ = kind;
        self.element(name)
    }
    /// The value of story variable `name` (default: none).
    fn variable(&self, _name: &str) -> Option<VarValue> {
        None
    }
    /// Whether entity `a` has touched `b` (`None`: anything) so far (default: no).
    fn collided(&self, _a: &str, _b: Option<&str>) -> bool {
        false
    }
    /// The world pose `[x, y, yaw]` of entity `name`'s box centre (default: none; distances
    /// are then measured along the centreline).
    fn pose(&self, _name: &str) -> Option<[f64; 3]> {
        None
    }
    /// The world point `offset` m (+ left) from the centreline at `s`: `[x, y, road heading,
    /// curvature]` (default: none).
    fn place(&self, _s: f64, _offset: f64) -> Option<[f64; 4]> {
        None
    }
}

fn longitudinal() -> DistanceType {
    DistanceType::Longitudinal
}

fn is_longitudinal(d: &DistanceType) -> bool {
    *d == DistanceType::Longitudinal
}

/// The shortest distance between two boxes (`[x, y, yaw]` of the centre, length, width), 0 when
/// they overlap, and whether the second is ahead of the first along the first's heading (their
/// projections on it apart, or overlapping: esmini's `Object::FreeSpaceDistance` and the sign it
/// gives a distance).
pub fn box_distance(a: ([f64; 3], f64, f64), b: ([f64; 3], f64, f64)) -> (f64, bool) {
    let corners = |([x, y, h], l, w): ([f64; 3], f64, f64)| {
        let (c, s) = (h.cos(), h.sin());
        [(0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)].map(|(u, v)| [x + c * u * l - s * v * w, y + s * u * l + c * v * w])
    };
    let (ca, cb) = (corners(a), corners(b));
    let project = |pts: &[[f64; 2]; 4], n: [f64; 2]| {
        pts.iter().map(|p| p[0] * n[0] + p[1] * n[1]).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)))
    };
    let axis = |h: f64| [[h.cos(), h.sin()], [-h.sin(), h.cos()]];
    // Separating axes: the sides of both boxes.
    let separated = axis(a.0[2]).into_iter().chain(axis(b.0[2])).any(|n| {
        let ((la, ha), (lb, hb)) = (project(&ca, n), project(&cb, n));
        ha < lb || hb < la
    });
    let ((la, _), (_, hb)) = (project(&ca, axis(a.0[2])[0]), project(&cb, axis(a.0[2])[0]));
    let ahead = la <= hb;
    if !separated {
        return (0.0, ahead);
    }
    let edge = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        let (dx, dy) = (r[0] - q[0], r[1] - q[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 { (((p[0] - q[0]) * dx + (p[1] - q[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
        (p[0] - q[0] - t * dx).hypot(p[1] - q[1] - t * dy)
    };
    let mut d = f64::INFINITY;
    for (pts, other) in [(&ca, &cb), (&cb, &ca)] {
        for p in pts {
            for (k, q) in other.iter().enumerate() {
                d = d.min(edge(*p, *q, other[(k + 1) % 4]));
            }
        }
    }
    (d, ahead)
}

/// Longitudinal / lateral distance from `a` to `b` (reference points or box gaps).
fn gaps(a: &EntityState, b: &EntityState, freespace: bool) -> (f64, f64) {
    let da = (b.s - a.s).abs();
    let dl = (b.lateral - a.lateral).abs();
    if freespace { ((da - 0.5 * (a.length + b.length)).max(0.0), (dl - 0.5 * (a.width + b.width)).max(0.0)) } else { (da, dl) }
}

/// `a` compared with `b` by `rule`: numbers by value (`Rule::holds`), booleans and text equal or
/// not (a number compared with text parses the text; anything else does not hold).
fn compare_values(a: &VarValue, b: &VarValue, rule: Rule) -> bool {
    use VarValue as V;
    let num = |v: &V| match v {
        V::Num(x) => Some(*x),
        V::Text(t) => t.trim().parse::<f64>().ok(),
        V::Bool(_) => None,
    };
    match (a, b) {
        (V::Bool(x), V::Bool(y)) => match rule {
            Rule::EqualTo => x == y,
            Rule::NotEqualTo => x != y,
            _ => false,
        },
        (V::Text(x), V::Text(y)) if num(a).is_none() || num(b).is_none() => match rule {
            Rule::EqualTo => x == y,
            Rule::NotEqualTo => x != y,
            _ => false,
        },
        _ => match (num(a), num(b)) {
            (Some(x), Some(y)) => rule.holds(x, y, None),
            _ => false,
        },
    }
}

impl ConditionKind {
    /// The measured quantity compared by the rule (distance m, time s, speed m/s; for
    /// `reach_position` the distance to the position, for `traveled_distance` the distance
    /// travelled) at time `t`; `None` for `phase_state` or an unknown entity.
    pub fn measure(&self, world: &dyn WorldView, t: f64) -> Option<f64> {
        let pair = |a: &str, b: &str| Some((world.entity(a)?, world.entity(b)?));
        match self {
            ConditionKind::SimulationTime { .. } => Some(t),
            ConditionKind::RelativeDistance { entity, of, distance, freespace, .. } => {
                let (a, b) = pair(entity, of)?;
                let (dx, dy) = gaps(&a, &b, *freespace);
                Some(match distance {
                    DistanceType::Longitudinal => dx,
                    DistanceType::Lateral => dy,
                    DistanceType::Euclidean => dx.hypot(dy),
                })
            }
            ConditionKind::TimeHeadway { entity, of, freespace, distance, .. } => {
                let (a, b) = pair(entity, of)?;
                let (dx, dy) = gaps(&a, &b, *freespace);
                let boxes = match (distance, *freespace, world.pose(entity), world.pose(of)) {
                    (DistanceType::Euclidean, true, Some(pa), Some(pb)) => {
                        Some(box_distance((pa, a.length, a.width), (pb, b.length, b.width)))
                    }
                    _ => None,
                };
                let (gap, behind) = match (boxes, distance) {
                    (Some((d, ahead)), _) => (d, !ahead),
                    (None, DistanceType::Euclidean) => (dx.hypot(dy), b.s < a.s),
                    (None, DistanceType::Lateral) => (dy, b.s < a.s),
                    (None, DistanceType::Longitudinal) => (dx, b.s < a.s),
                };
                Some(if behind || a.speed <= 0.0 { f64::INFINITY } else { gap / a.speed })
            }
            ConditionKind::Ttc { entity, of, freespace, .. } => {
                let (a, b) = pair(entity, of)?;
                let gap = gaps(&a, &b, *freespace).0;
                let closing = if b.s >= a.s { a.speed - b.speed } else { b.speed - a.speed };
                Some(if closing > 0.0 { gap / closing } else { f64::INFINITY })
            }
            ConditionKind::Speed { entity, .. } => Some(world.entity(entity)?.speed),
            ConditionKind::ReachPosition { entity, s, lateral, .. } => {
                let e = world.entity(entity)?;
                let dl = lateral.map_or(0.0, |l| e.lateral - l);
                Some((e.s - s).hypot(dl))
            }
            ConditionKind::TraveledDistance { entity, .. } => Some(world.entity(entity)?.traveled),
            ConditionKind::Acceleration { entity, .. } => Some(world.entity(entity)?.accel),
            ConditionKind::StandStill { entity, .. } => Some(world.entity(entity)?.still_for),
            ConditionKind::RelativeSpeed { entity, of, .. } => {
                let (a, b) = pair(entity, of)?;
                Some(a.speed - b.speed)
            }
            ConditionKind::Distance { entity, s, lateral, distance, freespace, .. } => {
                let e = world.entity(entity)?;
                let point = EntityState { s: *s, lateral: *lateral, length: 0.0, width: 0.0, ..e };
                let (dx, dy) = gaps(&e, &point, *freespace);
                Some(match distance {
                    DistanceType::Longitudinal => dx,
                    DistanceType::Lateral => dy,
                    DistanceType::Euclidean => dx.hypot(dy),
                })
            }
            ConditionKind::PhaseState { .. }
            | ConditionKind::Collision { .. }
            | ConditionKind::Variable { .. }
            | ConditionKind::ElementState { .. } => None,
        }
    }

    /// The level of the test at time `t` (before edge and delay).
    pub fn holds(&self, world: &dyn WorldView, t: f64) -> bool {
        match self {
            ConditionKind::SimulationTime { value, rule, tolerance }
            | ConditionKind::RelativeDistance { value, rule, tolerance, .. }
            | ConditionKind::TimeHeadway { value, rule, tolerance, .. }
            | ConditionKind::Ttc { value, rule, tolerance, .. }
            | ConditionKind::Speed { value, rule, tolerance, .. }
            | ConditionKind::Acceleration { value, rule, tolerance, .. }
            | ConditionKind::RelativeSpeed { value, rule, tolerance, .. }
            | ConditionKind::Distance { value, rule, tolerance, .. } => {
                self.measure(world, t).is_some_and(|x| rule.holds(x, *value, *tolerance))
            }
            // Counted from the first evaluation that sees the entity standing, and held once
            // that time *exceeds* `duration` (as esmini 3.6.0 does: a 1 s standstill seen first
            // at t0 holds at t0 + 1.01 s with 10 ms steps).
            ConditionKind::StandStill { duration, .. } => {
                self.measure(world, t).is_some_and(|d| Rule::GreaterThan.holds(d, *duration, None))
            }
            ConditionKind::Collision { entity, with } => world.collided(entity, with.as_deref()),
            ConditionKind::Variable { variable, value, rule } => world.variable(variable).is_some_and(|v| compare_values(&v, value, *rule)),
            ConditionKind::ElementState { element, state, element_type } => {
                world.element_of(element, *element_type).is_some_and(|e| e.holds(*state))
            }
            ConditionKind::ReachPosition { tolerance, .. } => {
                self.measure(world, t).is_some_and(|d| Rule::LessOrEqual.holds(d, *tolerance, None))
            }
            ConditionKind::TraveledDistance { value, .. } => {
                self.measure(world, t).is_some_and(|d| Rule::GreaterOrEqual.holds(d, *value, None))
            }
            ConditionKind::PhaseState { entity, phase, state } => {
                let p = world.phase(entity, *phase);
                match state {
                    PhaseEvent::Started => p.started.is_some(),
                    PhaseEvent::Ended => p.ended.is_some(),
                }
            }
        }
    }

    /// The entities the test names, with their keys (`entity`, `of`).
    fn entity_refs(&self) -> Vec<(&'static str, &str)> {
        match self {
            ConditionKind::SimulationTime { .. } | ConditionKind::Variable { .. } | ConditionKind::ElementState { .. } => vec![],
            ConditionKind::RelativeDistance { entity, of, .. }
            | ConditionKind::TimeHeadway { entity, of, .. }
            | ConditionKind::RelativeSpeed { entity, of, .. }
            | ConditionKind::Ttc { entity, of, .. } => vec![("entity", entity), ("of", of)],
            ConditionKind::Collision { entity, with } => {
                let mut v = vec![("entity", entity.as_str())];
                if let Some(w) = with {
                    v.push(("with", w.as_str()));
                }
                v
            }
            ConditionKind::Acceleration { entity, .. }
            | ConditionKind::StandStill { entity, .. }
            | ConditionKind::Distance { entity, .. }
            | ConditionKind::Speed { entity, .. }
            | ConditionKind::ReachPosition { entity, .. }
            | ConditionKind::TraveledDistance { entity, .. }
            | ConditionKind::PhaseState { entity, .. } => vec![("entity", entity)],
        }
    }
}

/// One `ConditionGroup` (ANDed conditions). `bare`: written in TOML as one condition table.
#[derive(Debug, Clone, PartialEq)]
struct Group {
    conditions: Vec<Condition>,
    bare: bool,
}

/// An OpenSCENARIO `Trigger`: condition groups ORed, conditions in a group ANDed. See the
/// module doc for the TOML shapes and the evaluation ([`TriggerState`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Trigger {
    groups: Vec<Group>,
    /// Written as one condition table.
    single: bool,
}

/// The scenario-level stop trigger: the same type (OpenSCENARIO `StopTrigger`).
pub type StopTrigger = Trigger;

/// A phase's start trigger (OpenSCENARIO `StartTrigger`).
pub type StartTrigger = Trigger;

impl Trigger {
    /// A trigger of one condition (TOML: a table).
    pub fn when(condition: Condition) -> Self {
        Self { groups: vec![Group { conditions: vec![condition], bare: true }], single: true }
    }

    /// OR of AND groups (TOML: an array; a group of one condition is written as a table).
    pub fn any_of(groups: Vec<Vec<Condition>>) -> Self {
        let groups = groups.into_iter().map(|c| Group { bare: c.len() == 1, conditions: c }).collect();
        Self { groups, single: false }
    }

    /// The condition groups (ORed), each a slice of ANDed conditions.
    pub fn groups(&self) -> impl Iterator<Item = &[Condition]> {
        self.groups.iter().map(|g| g.conditions.as_slice())
    }

    /// All conditions, group by group.
    pub fn conditions(&self) -> impl Iterator<Item = &Condition> {
        self.groups.iter().flat_map(|g| g.conditions.iter())
    }

    /// The dotted key of group `g` as written (`key`, `key[g]`).
    fn group_key(&self, key: &str, g: usize) -> String {
        if self.single { key.to_string() } else { format!("{key}[{g}]") }
    }

    /// The dotted key of condition `c` of group `g` as written (`key`, `key[g]`, `key[g][c]`).
    pub fn condition_key(&self, key: &str, g: usize, c: usize) -> String {
        match self.groups.get(g) {
            Some(grp) if grp.bare => self.group_key(key, g),
            _ => format!("{key}[{g}][{c}]"),
        }
    }

    /// The phases this trigger waits for: `(group, entity, phase, state)` of every
    /// `phase_state` condition.
    pub fn phase_refs(&self) -> impl Iterator<Item = (usize, &str, usize, PhaseEvent)> {
        self.groups.iter().enumerate().flat_map(|(g, grp)| {
            grp.conditions.iter().filter_map(move |c| match &c.kind {
                ConditionKind::PhaseState { entity, phase, state } => Some((g, entity.as_str(), *phase, *state)),
                _ => None,
            })
        })
    }

    /// Checks the trigger's sizes only (at most [`MAX_TRIGGER_GROUPS`] groups and
    /// [`MAX_TRIGGER_CONDITIONS`] conditions), without allocating: run before anything is built
    /// from it.
    pub fn check_size(&self, key: &str) -> Result<(), ConfigError> {
        if self.groups.len() > MAX_TRIGGER_GROUPS {
            return Err(ConfigError::new(key, format!("at most {MAX_TRIGGER_GROUPS} condition groups, got {}", self.groups.len())));
        }
        let n = self.groups.iter().fold(0usize, |n, g| n.saturating_add(g.conditions.len()));
        if n > MAX_TRIGGER_CONDITIONS {
            return Err(ConfigError::new(key, format!("at most {MAX_TRIGGER_CONDITIONS} conditions, got {n}")));
        }
        Ok(())
    }

    /// Checks the trigger written at dotted key `key` against `entities` (`(name, number of
    /// phases)` of every entity that conditions may name): at least one group and one condition
    /// per group, known entities (`of` different from `entity`), existing phase indices, ranges
    /// (delay in [0, 1e5] s, finite values, tolerances >= 0 and only with `equal_to` /
    /// `not_equal_to`). The error names the full key, e.g.
    /// `vehicles[1].phases[2].start[0][1].entity: unknown entity "leed" (known: ego, lead)`.
    pub fn validate(&self, key: &str, entities: &[(&str, usize)]) -> Result<(), ConfigError> {
        self.check_size(key)?;
        if self.groups.is_empty() {
            return Err(ConfigError::new(key, "a trigger needs at least one condition group"));
        }
        for (g, grp) in self.groups.iter().enumerate() {
            if grp.conditions.is_empty() {
                return Err(ConfigError::new(self.group_key(key, g), "a condition group needs at least one condition"));
            }
            for (c, cond) in grp.conditions.iter().enumerate() {
                validate_condition(cond, entities).map_err(|e| e.within(&self.condition_key(key, g, c)))?;
            }
        }
        Ok(())
    }
}

fn known_list(entities: &[(&str, usize)]) -> String {
    entities.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// Validates one condition; keys relative to the condition.
fn validate_condition(cond: &Condition, entities: &[(&str, usize)]) -> Result<(), ConfigError> {
    check_range("delay", cond.delay, 0.0, 1.0e5, "s")?;
    for (k, name) in cond.kind.entity_refs() {
        if !entities.iter().any(|(n, _)| *n == name) {
            return Err(ConfigError::new(k, format!("unknown entity \"{name}\" (known: {})", known_list(entities))));
        }
    }
    let compare = |value: f64, lo: f64, hi: f64, unit: &str, rule: Rule, tol: Option<f64>| -> Result<(), ConfigError> {
        check_range("value", value, lo, hi, unit)?;
        if let Some(t) = tol {
            if !rule.takes_tolerance() {
                return Err(ConfigError::new("tolerance", "only applies to rule = \"equal_to\" / \"not_equal_to\""));
            }
            check_range("tolerance", t, 0.0, hi, unit)?;
        }
        Ok(())
    };
    match &cond.kind {
        ConditionKind::SimulationTime { value, rule, tolerance } => compare(*value, 0.0, 1.0e6, "s", *rule, *tolerance),
        ConditionKind::RelativeDistance { entity, of, value, rule, tolerance, .. } => {
            differ(entity, of)?;
            compare(*value, 0.0, 1.0e6, "m", *rule, *tolerance)
        }
        ConditionKind::TimeHeadway { entity, of, value, rule, tolerance, .. }
        | ConditionKind::Ttc { entity, of, value, rule, tolerance, .. } => {
            differ(entity, of)?;
            compare(*value, 0.0, 1.0e5, "s", *rule, *tolerance)
        }
        ConditionKind::Speed { value, rule, tolerance, .. } => compare(*value, -100.0, 100.0, "m/s", *rule, *tolerance),
        ConditionKind::ReachPosition { s, lateral, tolerance, .. } => {
            check_range("s", *s, -1.0e7, 1.0e7, "m")?;
            if let Some(l) = lateral {
                check_range("lateral", *l, -100.0, 100.0, "m")?;
            }
            check_range("tolerance", *tolerance, 0.0, 1.0e4, "m")
        }
        ConditionKind::TraveledDistance { value, .. } => check_range("value", *value, 0.0, 1.0e7, "m"),
        ConditionKind::Acceleration { value, rule, tolerance, .. } => compare(*value, -100.0, 100.0, "m/s²", *rule, *tolerance),
        ConditionKind::RelativeSpeed { entity, of, value, rule, tolerance } => {
            differ(entity, of)?;
            compare(*value, -200.0, 200.0, "m/s", *rule, *tolerance)
        }
        ConditionKind::StandStill { duration, .. } => check_range("duration", *duration, 0.0, 1.0e5, "s"),
        ConditionKind::Distance { s, lateral, value, rule, tolerance, .. } => {
            check_range("s", *s, -1.0e7, 1.0e7, "m")?;
            check_range("lateral", *lateral, -1.0e4, 1.0e4, "m")?;
            compare(*value, 0.0, 1.0e7, "m", *rule, *tolerance)
        }
        ConditionKind::Collision { entity, with } => match with {
            Some(w) => differ(entity, w),
            None => Ok(()),
        },
        ConditionKind::Variable { value, rule, .. } => match value {
            VarValue::Num(v) => check_range("value", *v, -1.0e300, 1.0e300, ""),
            _ if rule.takes_tolerance() => Ok(()),
            _ => Err(ConfigError::new("rule", "booleans and text compare only with `equal_to` / `not_equal_to`")),
        },
        ConditionKind::ElementState { element, .. } => {
            if element.is_empty() {
                return Err(ConfigError::new("element", "must name a storyboard element"));
            }
            Ok(())
        }
        ConditionKind::PhaseState { entity, phase, .. } => {
            let count = entities.iter().find(|(n, _)| n == entity).map_or(0, |(_, c)| *c);
            if *phase >= count {
                let has = match count {
                    0 => "has no phases".to_string(),
                    1 => "has 1 phase (index 0)".to_string(),
                    n => format!("has {n} phases (indices 0-{})", n - 1),
                };
                return Err(ConfigError::new("phase", format!("entity \"{entity}\" {has}, got {phase}")));
            }
            Ok(())
        }
    }
}

fn differ(entity: &str, of: &str) -> Result<(), ConfigError> {
    if entity == of {
        return Err(ConfigError::new("of", format!("must name another entity than `entity` (\"{entity}\")")));
    }
    Ok(())
}

// ---- serde: a condition table, or an array of groups (a table or an array of tables) ----

impl Serialize for Group {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.conditions.as_slice() {
            [c] if self.bare => c.serialize(s),
            cs => cs.serialize(s),
        }
    }
}

/// The two TOML shapes of a group and of a trigger: one condition table, or an array of `T`s
/// (conditions for a group, groups for a trigger).
enum TableOrArray<T> {
    Table(Condition),
    Array(Vec<T>),
}

/// What an array of `Self` is, for serde's "expected ..." message.
trait Element {
    const EXPECTING: &'static str;
}

impl Element for Condition {
    const EXPECTING: &'static str = "a condition group: a condition table or an array of condition tables";
}

impl Element for Group {
    const EXPECTING: &'static str = "a trigger: a condition table, or an array of condition groups (ORed)";
}

impl<'de, T: Deserialize<'de> + Element> Deserialize<'de> for TableOrArray<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de> + Element> Visitor<'de> for V<T> {
            type Value = TableOrArray<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(T::EXPECTING)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                Ok(TableOrArray::Table(Condition::deserialize(serde::de::value::MapAccessDeserializer::new(map))?))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut items = Vec::new();
                while let Some(x) = seq.next_element::<T>()? {
                    items.push(x);
                }
                Ok(TableOrArray::Array(items))
            }
        }
        d.deserialize_any(V(std::marker::PhantomData))
    }
}

impl<'de> Deserialize<'de> for Group {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(match TableOrArray::<Condition>::deserialize(d)? {
            TableOrArray::Table(c) => Group { conditions: vec![c], bare: true },
            TableOrArray::Array(conditions) => Group { conditions, bare: false },
        })
    }
}

impl Serialize for Trigger {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.groups.as_slice() {
            [g] if self.single && g.conditions.len() == 1 => g.serialize(s),
            gs => gs.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Trigger {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(match TableOrArray::<Group>::deserialize(d)? {
            TableOrArray::Table(c) => Trigger::when(c),
            TableOrArray::Array(groups) => Trigger { groups, single: false },
        })
    }
}

// ---- evaluation ----

/// Edge memory and delay line of one condition.
#[derive(Debug, Clone, Default)]
struct ConditionMemory {
    /// The level at the previous evaluation.
    prev: Option<bool>,
    /// `(t, raw result)` of recent evaluations, oldest first: the latest one at or before
    /// `t - delay` and the ones after it.
    history: VecDeque<(f64, bool)>,
}

impl ConditionMemory {
    fn step(&mut self, edge: Edge, delay: f64, level: bool, t: f64) -> bool {
        let raw = match edge {
            Edge::None => level,
            Edge::Rising => self.prev == Some(false) && level,
            Edge::Falling => self.prev == Some(true) && !level,
            Edge::RisingOrFalling => self.prev.is_some_and(|p| p != level),
        };
        self.prev = Some(level);
        if delay.is_nan() || delay <= 0.0 {
            return raw;
        }
        self.history.push_back((t, raw));
        let cutoff = t - delay + EPS;
        while self.history.get(1).is_some_and(|&(ts, _)| ts <= cutoff) {
            self.history.pop_front();
        }
        matches!(self.history.front(), Some(&(ts, v)) if ts <= cutoff && v)
    }
}

/// The run-time state of one [`Trigger`]: edge memory and delay timers per condition, and
/// whether (when) it fired. Start from `TriggerState::default()`; call [`update`](Self::update)
/// at every physics step.
#[derive(Debug, Clone, Default)]
pub struct TriggerState {
    memory: Vec<ConditionMemory>,
    fired_at: Option<f64>,
}

impl TriggerState {
    /// A fresh state (nothing evaluated, not fired).
    pub fn new() -> Self {
        Self::default()
    }

    /// Evaluates `trigger` on `world` at simulation time `t` (non-decreasing from call to call):
    /// `true` exactly once, at the evaluation where the trigger fires (module doc). After that it
    /// returns `false` without evaluating.
    pub fn update(&mut self, trigger: &Trigger, world: &dyn WorldView, t: f64) -> bool {
        if self.fired_at.is_some() {
            return false;
        }
        let n = trigger.conditions().count();
        if self.memory.len() != n {
            self.memory.resize_with(n, ConditionMemory::default);
        }
        let mut memory = self.memory.iter_mut();
        let mut any = false;
        for grp in &trigger.groups {
            // Every condition is evaluated (edges need their memory), no short circuit.
            let mut all = !grp.conditions.is_empty();
            for c in &grp.conditions {
                let level = c.kind.holds(world, t);
                let reported = memory.next().is_some_and(|m| m.step(c.edge, c.delay, level, t));
                all &= reported;
            }
            any |= all;
        }
        if any {
            self.fired_at = Some(t);
        }
        any
    }

    /// Whether the trigger has fired.
    pub fn fired(&self) -> bool {
        self.fired_at.is_some()
    }

    /// The time it fired, s.
    pub fn fired_at(&self) -> Option<f64> {
        self.fired_at
    }
}

// ---- phase dependencies ----

/// A scripted entity as [`check_phase_cycles`] / [`validate_scripts`] see it.
#[derive(Debug, Clone)]
pub struct ScriptedEntity<'a> {
    /// The entity name conditions refer to.
    pub name: &'a str,
    /// Dotted key of its phase list, e.g. `vehicles[1].phases`; phase `k` is `{key}[{k}]` and
    /// its start trigger `{key}[{k}].start`.
    pub key: &'a str,
    /// The start trigger of each phase (`None`: starts when the previous phase ends). Empty for
    /// an entity without phases that conditions may still name.
    pub starts: Vec<Option<&'a Trigger>>,
}

/// Why a phase waits for another.
#[derive(Debug, Clone, Copy)]
enum Wait {
    Previous,
    Ref(PhaseEvent),
}

/// Finds phases that can never start because they wait on each other: phase `k > 0` waits for
/// phase `k - 1` (implicit), and for the phases named by `phase_state` conditions of its start
/// trigger. OR groups are honoured: a phase is startable if its previous phase is and some
/// group of its trigger names only startable phases (other conditions are assumed satisfiable).
/// The error (key `{phase}.start` of a phase in the cycle) lists the cycle, e.g.
/// `` `a.phases[1]` (a, phase 1) waits for `b.phases[0]` (b, phase 0) to start, which waits for ...``.
/// References to unknown entities or phases are ignored here ([`Trigger::validate`] reports them).
pub fn check_phase_cycles(entities: &[ScriptedEntity<'_>]) -> Result<(), ConfigError> {
    // Node index of (entity, phase).
    let mut offsets = Vec::with_capacity(entities.len());
    let mut nodes: Vec<(usize, usize)> = Vec::new();
    for (e, ent) in entities.iter().enumerate() {
        offsets.push(nodes.len());
        nodes.extend((0..ent.starts.len()).map(|k| (e, k)));
    }
    // The first entity of each name (names are distinct once `validate_scripts` passed).
    let mut index: HashMap<&str, usize> = HashMap::with_capacity(entities.len());
    for (e, ent) in entities.iter().enumerate() {
        index.entry(ent.name).or_insert(e);
    }
    let node_of = |name: &str, phase: usize| -> Option<usize> {
        let e = *index.get(name)?;
        (phase < entities[e].starts.len()).then(|| offsets[e] + phase)
    };
    // Per node: the groups of (node waited for, why).
    let groups: Vec<Vec<Vec<(usize, PhaseEvent)>>> = nodes
        .iter()
        .map(|&(e, k)| match entities[e].starts.get(k).copied().flatten() {
            Some(trig) if !trig.groups.is_empty() => {
                let mut gs = vec![Vec::new(); trig.groups.len()];
                for (g, name, phase, state) in trig.phase_refs() {
                    if let (Some(u), Some(list)) = (node_of(name, phase), gs.get_mut(g)) {
                        list.push((u, state));
                    }
                }
                gs
            }
            _ => vec![Vec::new()],
        })
        .collect();
    let prev = |v: usize| -> Option<usize> { (nodes[v].1 > 0).then(|| v - 1) };
    // The startable nodes (least fixpoint of "previous startable and some group of startable
    // nodes"), by a worklist in time linear in nodes + references: per group the number of its
    // references not yet startable, per node the (node, group) references to it.
    let mut pending: Vec<Vec<usize>> = groups.iter().map(|gs| gs.iter().map(Vec::len).collect()).collect();
    let mut waiting: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nodes.len()];
    for (v, gs) in groups.iter().enumerate() {
        for (g, list) in gs.iter().enumerate() {
            for &(u, _) in list {
                waiting[u].push((v, g));
            }
        }
    }
    let mut ready: Vec<bool> = pending.iter().map(|p| p.contains(&0)).collect();
    let mut ok = vec![false; nodes.len()];
    let mut queue: Vec<usize> = (0..nodes.len()).filter(|&v| ready[v] && prev(v).is_none()).collect();
    for &v in &queue {
        ok[v] = true;
    }
    while let Some(u) = queue.pop() {
        let next = u + 1;
        let mut candidates: Vec<usize> = Vec::new();
        if next < nodes.len() && nodes[next].0 == nodes[u].0 {
            candidates.push(next);
        }
        for &(v, g) in &waiting[u] {
            pending[v][g] -= 1;
            if pending[v][g] == 0 && !ready[v] {
                ready[v] = true;
                candidates.push(v);
            }
        }
        for v in candidates {
            if !ok[v] && ready[v] && prev(v).is_none_or(|p| ok[p]) {
                ok[v] = true;
                queue.push(v);
            }
        }
    }
    let Some(start) = ok.iter().position(|&b| !b) else { return Ok(()) };
    // Every blocked node waits for a blocked node: follow one such wait until a node repeats.
    let blocking = |v: usize| -> Option<(usize, Wait)> {
        if let Some(p) = prev(v).filter(|&p| !ok[p]) {
            return Some((p, Wait::Previous));
        }
        groups[v].iter().flatten().find(|&&(u, _)| !ok[u]).map(|&(u, s)| (u, Wait::Ref(s)))
    };
    let mut path: Vec<(usize, Wait)> = Vec::new();
    let mut on_path: Vec<Option<usize>> = vec![None; nodes.len()];
    let mut v = start;
    let cycle = loop {
        if let Some(i) = on_path[v] {
            break path.split_off(i);
        }
        on_path[v] = Some(path.len());
        let Some((u, why)) = blocking(v) else { break Vec::new() };
        if path.len() > nodes.len() {
            break Vec::new();
        }
        path.push((v, why));
        v = u;
    };
    let phase_key = |v: usize| {
        let (e, k) = nodes[v];
        format!("{}[{k}]", entities[e].key)
    };
    if cycle.is_empty() {
        return Err(ConfigError::new(phase_key(start), "this phase can never start"));
    }
    // Start the report at a phase whose trigger names the next one (there is one: implicit
    // waits only go back within an entity).
    let first = cycle.iter().position(|(_, w)| matches!(w, Wait::Ref(_))).unwrap_or(0);
    let mut cycle = cycle;
    cycle.rotate_left(first);
    let label = |v: usize| {
        let (e, k) = nodes[v];
        format!("`{}` ({}, phase {k})", phase_key(v), entities[e].name)
    };
    let mut text = String::from("start triggers wait on each other in a cycle: ");
    for (i, (v, why)) in cycle.iter().enumerate() {
        let next = cycle.get(i + 1).or(cycle.first()).map_or(*v, |(u, _)| *u);
        if i == 0 {
            text.push_str(&label(*v));
        }
        let how = match why {
            Wait::Previous => " (the previous phase) to end".to_string(),
            Wait::Ref(PhaseEvent::Started) => " to start".to_string(),
            Wait::Ref(PhaseEvent::Ended) => " to end".to_string(),
        };
        text.push_str(&format!("{} waits for {}{how}", if i == 0 { "" } else { ", which" }, label(next)));
    }
    let key = cycle.first().map_or_else(|| phase_key(start), |(v, _)| format!("{}.start", phase_key(*v)));
    Err(ConfigError::new(key, text))
}

/// Validates every start trigger of `entities` (names must be distinct; keys
/// `{key}[{k}].start...`), then [`check_phase_cycles`].
pub fn validate_scripts(entities: &[ScriptedEntity<'_>]) -> Result<(), ConfigError> {
    let table: Vec<(&str, usize)> = entities.iter().map(|e| (e.name, e.starts.len())).collect();
    let mut seen = HashSet::with_capacity(entities.len());
    for e in entities {
        if !seen.insert(e.name) {
            return Err(ConfigError::new(e.key, format!("entity name \"{}\" is used twice", e.name)));
        }
        for (k, start) in e.starts.iter().enumerate() {
            if let Some(trig) = start {
                trig.validate(&format!("{}[{k}].start", e.key), &table)?;
            }
        }
    }
    check_phase_cycles(entities)
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    /// Ground truth as plain data.
    #[derive(Default)]
    struct Fake {
        cars: Vec<(&'static str, EntityState)>,
        phases: Vec<(&'static str, usize, PhaseStatus)>,
    }

    impl WorldView for Fake {
        fn entity(&self, name: &str) -> Option<EntityState> {
            self.cars.iter().find(|(n, _)| *n == name).map(|(_, e)| *e)
        }
        fn phase(&self, name: &str, phase: usize) -> PhaseStatus {
            self.phases.iter().find(|(n, k, _)| *n == name && *k == phase).map(|(_, _, p)| *p).unwrap_or_default()
        }
    }

    fn car(s: f64, speed: f64, traveled: f64) -> EntityState {
        EntityState { s, lateral: 0.0, speed, length: 4.5, width: 1.8, traveled, ..EntityState::default() }
    }

    /// Ego at 20 m/s behind the lead at 15 m/s; bumper-to-bumper gap 40 - 5 t.
    fn closing(t: f64) -> Fake {
        Fake {
            cars: vec![("ego", car(10.0 + 20.0 * t, 20.0, 20.0 * t)), ("lead", car(54.5 + 15.0 * t, 15.0, 15.0 * t))],
            ..Fake::default()
        }
    }

    /// Ego's speed 10 + 5 cos(pi t / 2): below 10 in (1, 3), above in (3, 5), ...
    fn oscillating(t: f64) -> Fake {
        let v = 10.0 + 5.0 * (std::f64::consts::FRAC_PI_2 * t).cos();
        Fake { cars: vec![("ego", car(0.0, v, 0.0))], ..Fake::default() }
    }

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct W {
        start: Trigger,
    }

    fn trig(toml_value: &str) -> Trigger {
        toml::from_str::<W>(&format!("start = {toml_value}")).unwrap_or_else(|e| panic!("{toml_value}: {e}")).start
    }

    /// Steps (k, t = k dt, k = 0..=t_end/dt) at which `update` returned true.
    fn fires(trigger: &Trigger, world: impl Fn(f64) -> Fake, t_end: f64) -> Vec<usize> {
        let mut state = TriggerState::new();
        let n = (t_end / DT).round() as usize;
        let out: Vec<usize> = (0..=n).filter(|&k| state.update(trigger, &world(k as f64 * DT), k as f64 * DT)).collect();
        assert!(out.len() <= 1, "fired more than once: {out:?}");
        assert_eq!(state.fired(), !out.is_empty());
        out
    }

    fn fire_time(trigger: &Trigger, world: impl Fn(f64) -> Fake, t_end: f64) -> Option<f64> {
        fires(trigger, world, t_end).first().map(|&k| k as f64 * DT)
    }

    fn near(t: Option<f64>, expected: f64) {
        let t = t.unwrap_or_else(|| panic!("did not fire (expected {expected})"));
        assert!((t - expected).abs() <= DT + 1e-9, "fired at {t}, expected {expected} +- one step");
    }

    const GAP: &str =
        r#"{ kind = "relative_distance", entity = "ego", of = "lead", distance = "longitudinal", freespace = true, value = 20.0"#;

    #[test]
    fn freespace_gap_fires_at_the_analytic_time() {
        let lt = trig(&format!("{GAP}, rule = \"less_than\" }}"));
        near(fire_time(&lt, closing, 10.0), 4.0);
        // At t = 4 the gap is 20 (within 1e-9): `less_or_equal` fires exactly there.
        let le = trig(&format!("{GAP}, rule = \"less_or_equal\" }}"));
        assert_eq!(fires(&le, closing, 10.0), [400]);
        let gap0 = lt.conditions().next().and_then(|c| c.kind.measure(&closing(0.0), 0.0));
        assert_eq!(gap0, Some(40.0));
    }

    #[test]
    fn delay_adds_exactly_on_the_step_grid() {
        let plain = fires(&trig(&format!("{GAP}, rule = \"less_than\" }}")), closing, 10.0);
        let delayed = fires(&trig(&format!("{GAP}, rule = \"less_than\", delay = 1.5 }}")), closing, 10.0);
        assert_eq!(delayed[0], plain[0] + 150);
        near(Some(delayed[0] as f64 * DT), 5.5);
        // The delay shifts the result: a condition true for one step only is still reported.
        let pulse = trig(r#"{ kind = "simulation_time", rule = "equal_to", value = 1.0, tolerance = 0.001, delay = 0.5 }"#);
        assert_eq!(fires(&pulse, closing, 3.0), [150]);
        // A delay that is not a multiple of dt: the first step at or after t0 + d.
        let odd = trig(r#"{ kind = "simulation_time", rule = "greater_or_equal", value = 1.0, delay = 0.255 }"#);
        assert_eq!(fires(&odd, closing, 3.0), [126]);
    }

    const FAST: &str = r#"kind = "speed", entity = "ego", rule = "greater_than", value = 10.0"#;

    #[test]
    fn falling_edge_fires_once_and_needs_a_true_to_false_transition() {
        // Above 10 at the start, below from t = 1, above from t = 3, below again from t = 5.
        near(fire_time(&trig(&format!("{{ {FAST}, edge = \"falling\" }}")), oscillating, 8.0), 1.0);
        // Never true: no falling edge.
        let never = trig(r#"{ kind = "speed", entity = "ego", rule = "greater_than", value = 20.0, edge = "falling" }"#);
        assert_eq!(fires(&never, oscillating, 8.0), Vec::<usize>::new());
        // Starts false (v = 15 > 12), true in (0.74, 3.26): fires at the end of it, not at t = 0.
        let slow = trig(r#"{ kind = "speed", entity = "ego", rule = "less_than", value = 12.0, edge = "falling" }"#);
        let t = 2.0 / std::f64::consts::PI * (0.4f64).acos();
        near(fire_time(&slow, oscillating, 8.0), 4.0 - t);
    }

    #[test]
    fn rising_edge_needs_a_transition_and_none_is_the_level() {
        let always = r#"kind = "speed", entity = "ego", rule = "greater_than", value = 1.0"#;
        assert_eq!(fires(&trig(&format!("{{ {always}, edge = \"rising\" }}")), oscillating, 8.0), Vec::<usize>::new());
        assert_eq!(fires(&trig(&format!("{{ {always} }}")), oscillating, 8.0), [0]);
        // Below 10 from t = 1 (level false at the start) ... rising at t = 1 of `< 10`.
        let below = r#"{ kind = "speed", entity = "ego", rule = "less_than", value = 10.0, edge = "rising" }"#;
        near(fire_time(&trig(below), oscillating, 8.0), 1.0);
        // Either change: the first one (t = 1) of `> 10`, true at the start.
        near(fire_time(&trig(&format!("{{ {FAST}, edge = \"rising_or_falling\" }}")), oscillating, 8.0), 1.0);
    }

    #[test]
    fn groups_are_ored_and_conditions_anded() {
        let on = |name: &str| format!(r#"{{ kind = "speed", entity = "{name}", rule = "greater_than", value = 0.5 }}"#);
        // (a AND b) OR c
        let t = trig(&format!("[[{}, {}], {}]", on("a"), on("b"), on("c")));
        assert_eq!(t.groups().map(<[Condition]>::len).collect::<Vec<_>>(), [2, 1]);
        for bits in 0..8u8 {
            let (a, b, c) = (bits & 1 != 0, bits & 2 != 0, bits & 4 != 0);
            let v = |x: bool| if x { 1.0 } else { 0.0 };
            let w =
                Fake { cars: vec![("a", car(0.0, v(a), 0.0)), ("b", car(0.0, v(b), 0.0)), ("c", car(0.0, v(c), 0.0))], ..Fake::default() };
            let mut s = TriggerState::new();
            assert_eq!(s.update(&t, &w, 0.0), (a && b) || c, "a={a} b={b} c={c}");
            assert!(!s.update(&t, &w, DT), "fires once");
        }
        // An unknown entity never holds (validation reports it); nothing panics.
        let ghost = trig(&on("ghost"));
        assert!(!TriggerState::new().update(&ghost, &closing(0.0), 0.0));
    }

    #[test]
    fn box_distance_is_the_shortest_between_rotated_boxes() {
        // Aligned 4 x 2 m boxes, centres 10 m apart along x: 6 m, the second ahead.
        let (d, ahead) = box_distance(([0.0, 0.0, 0.0], 4.0, 2.0), ([10.0, 0.0, 0.0], 4.0, 2.0));
        assert!((d - 6.0).abs() < 1e-12 && ahead, "{d} {ahead}");
        // Seen from the second: the first is behind.
        assert!(!box_distance(([10.0, 0.0, 0.0], 4.0, 2.0), ([0.0, 0.0, 0.0], 4.0, 2.0)).1);
        // Diagonally apart (3 m along, 4 m across between the near corners): 5 m, not 3.
        let (d, _) = box_distance(([0.0, 0.0, 0.0], 4.0, 2.0), ([7.0, 6.0, 0.0], 4.0, 2.0));
        assert!((d - 5.0).abs() < 1e-12, "{d}");
        // The second turned by 30 degrees: its rear corner comes nearer than its centre line.
        let h = 30f64.to_radians();
        let (d, _) = box_distance(([0.0, 0.0, 0.0], 4.0, 2.0), ([10.0, 0.0, h], 4.0, 2.0));
        let corner = 10.0 - 2.0 * h.cos() - 1.0 * h.sin() - 2.0;
        assert!((d - corner).abs() < 1e-12, "{d} vs {corner}");
        // Overlapping: 0.
        assert_eq!(box_distance(([0.0, 0.0, 0.0], 4.0, 2.0), ([3.0, 0.5, 0.2], 4.0, 2.0)).0, 0.0);
    }

    #[test]
    fn headway_and_ttc_fire_at_analytic_times() {
        let hw = |extra: &str| trig(&format!(r#"{{ kind = "time_headway", rule = "less_or_equal", value = 1.5, {extra} }}"#));
        // (40 - 5 t) / 20 <= 1.5 from t = 2; centre to centre (44.5 - 5 t) / 20 from t = 2.9.
        near(fire_time(&hw(r#"entity = "ego", of = "lead", freespace = true"#), closing, 10.0), 2.0);
        near(fire_time(&hw(r#"entity = "ego", of = "lead", freespace = false"#), closing, 10.0), 2.9);
        // The lead has nobody ahead (until the fake ego drives through it at t = 8.9): infinite headway.
        assert!(fires(&hw(r#"entity = "lead", of = "ego", freespace = true"#), closing, 8.5).is_empty());
        let ttc = |extra: &str| trig(&format!(r#"{{ kind = "ttc", rule = "less_than", value = 3.0, {extra} }}"#));
        // (40 - 5 t) / 5 < 3 after t = 5, from either side; centre distance (44.5 - 5 t) / 5 after 5.9.
        near(fire_time(&ttc(r#"entity = "ego", of = "lead", freespace = true"#), closing, 10.0), 5.0);
        near(fire_time(&ttc(r#"entity = "lead", of = "ego", freespace = true"#), closing, 10.0), 5.0);
        near(fire_time(&ttc(r#"entity = "ego", of = "lead", freespace = false"#), closing, 10.0), 5.9);
        // Opening gap: infinite.
        let opening =
            |t: f64| Fake { cars: vec![("ego", car(0.0, 10.0, 0.0)), ("lead", car(20.0 + 5.0 * t, 15.0, 0.0))], ..Fake::default() };
        assert!(fires(&ttc(r#"entity = "ego", of = "lead", freespace = true"#), opening, 5.0).is_empty());
        let standing = Fake { cars: vec![("ego", car(0.0, 0.0, 0.0)), ("lead", car(20.0, 0.0, 0.0))], ..Fake::default() };
        let c = hw(r#"entity = "ego", of = "lead", freespace = true"#);
        assert_eq!(c.conditions().next().and_then(|c| c.kind.measure(&standing, 0.0)), Some(f64::INFINITY));
    }

    #[test]
    fn distance_types_and_freespace() {
        let a = EntityState { s: 0.0, lateral: 0.0, speed: 0.0, length: 4.0, width: 2.0, traveled: 0.0, ..EntityState::default() };
        let b = EntityState { s: 10.0, lateral: 3.5, ..a };
        let w = Fake { cars: vec![("a", a), ("b", b)], ..Fake::default() };
        let m = |distance: &str, freespace: bool| {
            trig(&format!(r#"{{ kind = "relative_distance", entity = "a", of = "b", distance = "{distance}", freespace = {freespace}, rule = "less_than", value = 1.0 }}"#))
                .conditions()
                .next()
                .and_then(|c| c.kind.measure(&w, 0.0))
        };
        assert_eq!(m("longitudinal", false), Some(10.0));
        assert_eq!(m("lateral", false), Some(3.5));
        assert_eq!(m("euclidean", false), Some(10.0f64.hypot(3.5)));
        assert_eq!(m("longitudinal", true), Some(6.0));
        assert_eq!(m("lateral", true), Some(1.5));
        assert_eq!(m("euclidean", true), Some(6.0f64.hypot(1.5)));
        // Overlapping boxes: zero, not negative.
        let (gx, gy) = gaps(&a, &EntityState { s: 2.0, lateral: 1.0, ..a }, true);
        assert_eq!((gx, gy), (0.0, 0.0));
    }

    #[test]
    fn position_travel_speed_and_time() {
        // Ego s = 10 + 20 t: within 0.5 m of s = 100 from t = 4.475, first step 4.48.
        let reach = trig(r#"{ kind = "reach_position", entity = "ego", s = 100.0, tolerance = 0.5 }"#);
        assert_eq!(fires(&reach, closing, 10.0), [448]);
        // With a lateral target 1 m off the ego's lane: never within 0.5 m.
        let off = trig(r#"{ kind = "reach_position", entity = "ego", s = 100.0, lateral = 1.0, tolerance = 0.5 }"#);
        assert!(fires(&off, closing, 10.0).is_empty());
        let travel = trig(r#"{ kind = "traveled_distance", entity = "ego", value = 50.0 }"#);
        assert_eq!(fires(&travel, closing, 10.0), [250]);
        let speed = trig(r#"{ kind = "speed", entity = "ego", rule = "less_than", value = 7.5 }"#);
        // 10 + 5 cos(pi t / 2) < 7.5 when cos < -1/2: after t = 4/3.
        near(fire_time(&speed, oscillating, 8.0), 4.0 / 3.0);
        let ge = trig(r#"{ kind = "simulation_time", rule = "greater_or_equal", value = 3.0 }"#);
        assert_eq!(fires(&ge, closing, 10.0), [300]);
        let gt = trig(r#"{ kind = "simulation_time", rule = "greater_than", value = 3.0 }"#);
        assert_eq!(fires(&gt, closing, 10.0), [301]);
    }

    #[test]
    fn phase_state_started_and_ended() {
        // Lead phase 1 runs from t = 2 to t = 5.
        let world = |t: f64| Fake {
            phases: vec![("lead", 1, PhaseStatus { started: (t >= 2.0 - 1e-12).then_some(2.0), ended: (t >= 5.0 - 1e-12).then_some(5.0) })],
            ..Fake::default()
        };
        let started = trig(r#"{ kind = "phase_state", entity = "lead", phase = 1, state = "started" }"#);
        assert_eq!(fires(&started, world, 10.0), [200]);
        let ended = trig(r#"{ kind = "phase_state", entity = "lead", phase = 1, state = "ended", delay = 1.0 }"#);
        assert_eq!(fires(&ended, world, 10.0), [600]);
        let other = trig(r#"{ kind = "phase_state", entity = "lead", phase = 0, state = "started" }"#);
        assert!(fires(&other, world, 10.0).is_empty());
    }

    const ENTITIES: &[(&str, usize)] = &[("ego", 2), ("lead", 3), ("cutin", 1)];
    const KEY: &str = "vehicles[1].phases[2].start";

    fn err(toml_value: &str) -> ConfigError {
        trig(toml_value).validate(KEY, ENTITIES).expect_err(toml_value)
    }

    #[test]
    fn validation_names_the_dotted_key() {
        let ok = r#"{ kind = "speed", entity = "ego", rule = "less_than", value = 5.0 }"#;
        assert_eq!(trig(ok).validate(KEY, ENTITIES), Ok(()));
        let e = err(r#"{ kind = "speed", entity = "leed", rule = "less_than", value = 5.0 }"#);
        assert_eq!(e.key, "vehicles[1].phases[2].start.entity");
        assert_eq!(e.problem, r#"unknown entity "leed" (known: ego, lead, cutin)"#);
        let e = err(&format!(r#"[[{ok}, {GAP}, rule = "less_than", of = "leed" }}]]"#).replace(r#"of = "lead", "#, ""));
        assert_eq!(e.key, "vehicles[1].phases[2].start[0][1].of");
        let e = err(&format!(r#"[{ok}, {{ kind = "simulation_time", rule = "less_than", value = 1.0, delay = -0.5 }}]"#));
        assert_eq!(e.key, "vehicles[1].phases[2].start[1].delay");
        assert!(e.problem.contains("[0, 100000]"), "{}", e.problem);
        let e = err(r#"{ kind = "speed", entity = "ego", rule = "less_than", value = nan }"#);
        assert_eq!((e.key.as_str(), e.problem.as_str()), ("vehicles[1].phases[2].start.value", "must be in [-100, 100] m/s, got NaN"));
        let e = err(r#"{ kind = "speed", entity = "ego", rule = "less_than", value = 5.0, tolerance = 0.1 }"#);
        assert_eq!(e.key, "vehicles[1].phases[2].start.tolerance");
        let e = err(r#"{ kind = "speed", entity = "ego", rule = "equal_to", value = 5.0, tolerance = -0.1 }"#);
        assert_eq!(e.key, "vehicles[1].phases[2].start.tolerance");
        let e = err(r#"{ kind = "reach_position", entity = "ego", s = 5.0, tolerance = -1.0 }"#);
        assert_eq!(e.key, "vehicles[1].phases[2].start.tolerance");
        let e = err(r#"{ kind = "phase_state", entity = "lead", phase = 3, state = "ended" }"#);
        assert_eq!(
            (e.key.as_str(), e.problem.as_str()),
            ("vehicles[1].phases[2].start.phase", r#"entity "lead" has 3 phases (indices 0-2), got 3"#)
        );
        let e = err(r#"{ kind = "phase_state", entity = "cutin", phase = 1, state = "ended" }"#);
        assert_eq!(e.problem, r#"entity "cutin" has 1 phase (index 0), got 1"#);
        let e = err(r#"{ kind = "ttc", entity = "ego", of = "ego", freespace = true, rule = "less_than", value = 2.0 }"#);
        assert_eq!(e.key, "vehicles[1].phases[2].start.of");
        let e = err("[]");
        assert_eq!(e.key, KEY);
        let e = err(&format!("[{ok}, []]"));
        assert_eq!(e.key, "vehicles[1].phases[2].start[1]");
        assert_eq!(e.to_string(), "`vehicles[1].phases[2].start[1]`: a condition group needs at least one condition");
    }

    fn phase_ref(entity: &str, phase: usize, state: &str) -> Trigger {
        trig(&format!(r#"{{ kind = "phase_state", entity = "{entity}", phase = {phase}, state = "{state}" }}"#))
    }

    #[test]
    fn phase_cycles_are_found() {
        // ego[1] waits for lead[2] to start; lead[2] for lead[1] (previous); lead[1] for ego[1] to end.
        let ego1 = phase_ref("lead", 2, "started");
        let lead1 = phase_ref("ego", 1, "ended");
        let ents = [
            ScriptedEntity { name: "ego", key: "vehicles[0].phases", starts: vec![None, Some(&ego1)] },
            ScriptedEntity { name: "lead", key: "vehicles[1].phases", starts: vec![None, Some(&lead1), None] },
        ];
        let e = check_phase_cycles(&ents).expect_err("cycle");
        assert_eq!(e.key, "vehicles[0].phases[1].start");
        assert_eq!(
            e.problem,
            "start triggers wait on each other in a cycle: `vehicles[0].phases[1]` (ego, phase 1) waits for `vehicles[1].phases[2]` \
             (lead, phase 2) to start, which waits for `vehicles[1].phases[1]` (lead, phase 1) (the previous phase) to end, which \
             waits for `vehicles[0].phases[1]` (ego, phase 1) to end"
        );
        assert_eq!(validate_scripts(&ents), Err(e));
        // Waiting for a later phase of the same entity, or for itself.
        let later = phase_ref("ego", 1, "started");
        let ents = [ScriptedEntity { name: "ego", key: "ego.phases", starts: vec![Some(&later), None] }];
        assert_eq!(check_phase_cycles(&ents).map_err(|e| e.key), Err("ego.phases[0].start".to_string()));
        let own = phase_ref("ego", 0, "ended");
        let ents = [ScriptedEntity { name: "ego", key: "ego.phases", starts: vec![Some(&own)] }];
        let e = check_phase_cycles(&ents).expect_err("self");
        assert!(e.problem.ends_with("`ego.phases[0]` (ego, phase 0) waits for `ego.phases[0]` (ego, phase 0) to end"), "{}", e.problem);
    }

    #[test]
    fn phase_cycles_are_not_falsely_found() {
        // Cross references in both directions without a cycle, and an earlier own phase.
        let ego1 = phase_ref("lead", 0, "ended");
        let lead2 = phase_ref("ego", 0, "ended");
        let ego2 = phase_ref("ego", 0, "started");
        let ents = [
            ScriptedEntity { name: "ego", key: "vehicles[0].phases", starts: vec![None, Some(&ego1), Some(&ego2)] },
            ScriptedEntity { name: "lead", key: "vehicles[1].phases", starts: vec![None, None, Some(&lead2)] },
            ScriptedEntity { name: "follower", key: "vehicles[2].phases", starts: vec![] },
        ];
        assert_eq!(check_phase_cycles(&ents), Ok(()));
        assert_eq!(validate_scripts(&ents), Ok(()));
        // The cycle of `phase_cycles_are_found`, with an OR group that does not wait: no deadlock.
        let ego1 = phase_ref("lead", 2, "started");
        let lead1 = trig(
            r#"[{ kind = "phase_state", entity = "ego", phase = 1, state = "ended" }, { kind = "simulation_time", rule = "greater_than", value = 5.0 }]"#,
        );
        let ents = [
            ScriptedEntity { name: "ego", key: "vehicles[0].phases", starts: vec![None, Some(&ego1)] },
            ScriptedEntity { name: "lead", key: "vehicles[1].phases", starts: vec![None, Some(&lead1), None] },
        ];
        assert_eq!(check_phase_cycles(&ents), Ok(()));
        // But an AND with the waiting condition is still a cycle.
        let lead1 = trig(
            r#"[[{ kind = "phase_state", entity = "ego", phase = 1, state = "ended" }, { kind = "simulation_time", rule = "greater_than", value = 5.0 }]]"#,
        );
        let ents = [
            ScriptedEntity { name: "ego", key: "vehicles[0].phases", starts: vec![None, Some(&ego1)] },
            ScriptedEntity { name: "lead", key: "vehicles[1].phases", starts: vec![None, Some(&lead1), None] },
        ];
        assert!(check_phase_cycles(&ents).is_err());
    }

    #[test]
    fn validate_scripts_checks_each_trigger_and_names() {
        let bad = phase_ref("leed", 0, "started");
        let ents = [
            ScriptedEntity { name: "ego", key: "vehicles[0].phases", starts: vec![None, Some(&bad)] },
            ScriptedEntity { name: "lead", key: "vehicles[1].phases", starts: vec![None] },
        ];
        let e = validate_scripts(&ents).expect_err("unknown");
        assert_eq!(e.key, "vehicles[0].phases[1].start.entity");
        assert_eq!(e.problem, r#"unknown entity "leed" (known: ego, lead)"#);
        let ents = [
            ScriptedEntity { name: "ego", key: "vehicles[0].phases", starts: vec![] },
            ScriptedEntity { name: "ego", key: "vehicles[1].phases", starts: vec![] },
        ];
        assert_eq!(validate_scripts(&ents).map_err(|e| e.key), Err("vehicles[1].phases".to_string()));
    }

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Example {
        start: StartTrigger,
        cut_in: StartTrigger,
        stop: StopTrigger,
    }

    const EXAMPLE: &str = r#"
start = { kind = "relative_distance", entity = "ego", of = "lead", value = 20, rule = "less_than", freespace = true, distance = "longitudinal" }
cut_in = [[{ kind = "speed", entity = "ego", rule = "greater_than", value = 10.0 },
           { kind = "simulation_time", rule = "greater_or_equal", value = 2.0, edge = "rising" }],
          { kind = "phase_state", entity = "lead", phase = 1, state = "ended", delay = 1.5 }]
stop = [{ kind = "ttc", entity = "ego", of = "lead", freespace = false, rule = "equal_to", value = 1.0, tolerance = 0.05 }]
"#;

    #[test]
    fn toml_round_trip_and_unknown_fields() {
        let ex: Example = toml::from_str(EXAMPLE).expect("example parses");
        assert_eq!(ex.start.conditions().next().map(|c| (c.delay, c.edge)), Some((0.0, Edge::None)));
        assert_eq!(ex.cut_in.groups().map(<[Condition]>::len).collect::<Vec<_>>(), [2, 1]);
        assert_eq!(ex.cut_in.conditions().nth(2).map(|c| c.delay), Some(1.5));
        assert_eq!(ex.cut_in.phase_refs().collect::<Vec<_>>(), [(1, "lead", 1, PhaseEvent::Ended)]);
        assert_eq!(ex.cut_in.condition_key("k", 0, 1), "k[0][1]");
        assert_eq!(ex.cut_in.condition_key("k", 1, 0), "k[1]");
        assert_eq!(ex.start.condition_key("k", 0, 0), "k");
        let text = toml::to_string(&ex).expect("serialises");
        let back: Example = toml::from_str(&text).unwrap_or_else(|e| panic!("{text}\n{e}"));
        assert_eq!(back, ex, "{text}");
        let json = serde_json::to_string(&ex).expect("json");
        assert_eq!(serde_json::from_str::<Example>(&json).ok(), Some(ex));
        // The constructors give the shapes TOML gives.
        let c = Condition::new(ConditionKind::Speed { entity: "ego".into(), value: 1.0, rule: Rule::LessThan, tolerance: None });
        assert_eq!(trig(r#"{ kind = "speed", entity = "ego", value = 1.0, rule = "less_than" }"#), Trigger::when(c.clone()));
        let c2 = c.clone().delayed(0.5).on(Edge::Rising);
        assert_eq!(
            trig(
                r#"[[{ kind = "speed", entity = "ego", value = 1.0, rule = "less_than" }, { kind = "speed", entity = "ego", value = 1.0, rule = "less_than", delay = 0.5, edge = "rising" }], { kind = "speed", entity = "ego", value = 1.0, rule = "less_than" }]"#
            ),
            Trigger::any_of(vec![vec![c.clone(), c2], vec![c]])
        );
        // Unknown keys, kinds and missing mandatory keys are errors.
        for bad in [
            r#"{ kind = "speed", entity = "ego", rule = "less_than", value = 1.0, speeed = 2.0 }"#,
            r#"{ kind = "sped", entity = "ego", rule = "less_than", value = 1.0 }"#,
            r#"{ kind = "relative_distance", entity = "ego", of = "lead", rule = "less_than", value = 1.0, distance = "longitudinal" }"#,
            r#"{ kind = "speed", entity = "ego", rule = "smaller", value = 1.0 }"#,
            r#"[[{ kind = "speed", entity = "ego", rule = "less_than", value = 1.0, edge = "up" }]]"#,
            "3",
        ] {
            assert!(toml::from_str::<W>(&format!("start = {bad}")).is_err(), "accepted {bad}");
        }
        let e = toml::from_str::<W>(r#"start = { kind = "speed", entity = "ego", rule = "less_than", value = 1.0, speeed = 2.0 }"#)
            .expect_err("unknown");
        assert!(e.to_string().contains("speeed"), "{e}");
    }
}
