//! `Storyboard` -> [`crate::story::Story`] and the scenario stop trigger: `Init` actions,
//! `Story` / `Act` / `ManeuverGroup` / `Maneuver` / `Event` / `Action`, start and stop
//! triggers and their conditions.

use std::collections::BTreeMap;

use super::Ctx;
use super::error::ImportError;
use super::expr::Value;
use super::position::{self, Geo};
use super::road::LaneMap;
use super::xml;
use crate::story::{
    Act, Action, ClothoidSegment, Dimension, EgoMode, Event, MAX_ELEMENTS, MAX_VERTICES, Maneuver, ManeuverGroup, Priority, Shape,
    StoryAction, Transition, Vertex,
};
use crate::track::Track;
use crate::trigger::{Condition, ConditionKind, DistanceType, Edge, ElementEvent, ElementKind, Rule, Trigger, VarValue};

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// Most conditions in one trigger (as written).
pub const MAX_CONDITIONS: usize = 1024;
/// Most condition groups one trigger may expand to (`TriggeringEntities` with `any` and several
/// entities distribute into OR groups).
pub const MAX_GROUPS: usize = 64;
/// The variable a skipped action (an environment change, a visual action) modifies by 0, so
/// that its storyboard element exists and ends at once as in the file.
pub const SKIPPED_VAR: &str = "osc:skipped";
/// Prefix of the story variable standing for an OpenSCENARIO parameter (`ParameterCondition`,
/// `ParameterAction`).
pub const PARAM_PREFIX: &str = "param:";

/// What the storyboard needs to know about an entity (by its scenario name).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Facts {
    /// `BoundingBox/Center` x, y (the box centre from the reference point), m.
    pub center: [f64; 2],
    /// Its reference point's initial `s` along the road, m.
    pub road_s: f64,
    /// A `MiscObject` (no action may move it).
    pub misc: bool,
    /// The ego.
    pub ego: bool,
}

/// The initial state `Init` gives an entity (before names and the track exist).
#[derive(Debug, Clone, Default)]
pub struct InitState<'a, 'i> {
    /// Its `TeleportAction/Position` and the file.
    pub position: Option<Node<'a, 'i>>,
    /// Its first Init `FollowTrajectoryAction`: without a `TeleportAction` the entity starts at
    /// the trajectory's first point (as esmini places it when the action starts at t = 0).
    pub trajectory: Option<Node<'a, 'i>>,
    /// Initial speed, m/s (a `SpeedAction` with a `step` shape or a time of 0).
    pub speed: Option<f64>,
    /// An initial speed relative to another entity (OpenSCENARIO name, delta or factor).
    pub relative_speed: Option<(String, bool, f64)>,
}

/// The storyboard translator.
pub struct Sb<'c, 'a, 't> {
    /// The import context.
    pub ctx: &'c mut Ctx<'a, 't>,
    /// OpenSCENARIO name -> scenario name.
    pub names: &'c BTreeMap<String, String>,
    /// Scenario name -> facts.
    pub facts: &'c BTreeMap<String, Facts>,
    /// The road.
    pub geo: &'c Geo,
    /// The track.
    pub track: &'c Track,
    /// Its lanes.
    pub lanes: &'c LaneMap,
    /// Who drives the ego.
    pub ego_mode: EgoMode,
    /// Declared variables and their initial values (in order).
    pub variables: Vec<(String, VarValue)>,
    /// `param:NAME` variables used (initial value = the parameter's value).
    pub param_vars: BTreeMap<String, VarValue>,
    /// An action was skipped ([`SKIPPED_VAR`] is needed).
    pub skipped_used: bool,
    /// Storyboard elements built so far.
    pub elements: usize,
    /// The action being read is the Init `FollowTrajectoryAction` an entity without a
    /// `TeleportAction` starts on ([`trajectory_start`]): its first segment's `PositionStart`
    /// is where the entity already is.
    pub start_trajectory: bool,
    /// The `initialDistanceOffset` of the `FollowTrajectoryAction` being read, m.
    pub start_offset: f64,
}

/// `dynamicsShape`.
fn shape_of(s: &str) -> Shape {
    match s {
        "linear" => Shape::Linear,
        "cubic" => Shape::Cubic,
        "sinusoidal" => Shape::Sinusoidal,
        _ => Shape::Step,
    }
}

const SHAPES: [&str; 4] = ["step", "linear", "cubic", "sinusoidal"];
const RULES: [&str; 6] = ["greaterThan", "lessThan", "equalTo", "greaterOrEqual", "lessOrEqual", "notEqualTo"];

fn rule_of(s: &str) -> Rule {
    match s {
        "greaterThan" => Rule::GreaterThan,
        "lessThan" => Rule::LessThan,
        "equalTo" => Rule::EqualTo,
        "greaterOrEqual" => Rule::GreaterOrEqual,
        "lessOrEqual" => Rule::LessOrEqual,
        _ => Rule::NotEqualTo,
    }
}

/// A parameter or expression value as a story variable value.
pub fn var_value(v: &Value) -> VarValue {
    match v {
        Value::Num(x) => VarValue::Num(*x),
        Value::Bool(b) => VarValue::Bool(*b),
        Value::Str(s) => VarValue::Text(s.clone()),
    }
}

/// `text` as a value of the kind of `like`.
fn typed(like: &VarValue, text: &str) -> Result<VarValue, String> {
    match like {
        VarValue::Num(_) => match text.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(VarValue::Num(x)),
            _ => Err(format!("`{text}` is not a number")),
        },
        // xsd:boolean: true, false, 1, 0.
        VarValue::Bool(_) => match text.trim() {
            "true" | "1" => Ok(VarValue::Bool(true)),
            "false" | "0" => Ok(VarValue::Bool(false)),
            _ => Err(format!("`{text}` is not a boolean")),
        },
        VarValue::Text(_) => Ok(VarValue::Text(text.to_string())),
    }
}

/// The one element child of `c`.
fn only_child<'a, 'i>(file: &str, c: Node<'a, 'i>) -> Result<Node<'a, 'i>, ImportError> {
    let mut it = xml::elements(c);
    match (it.next(), it.next()) {
        (Some(x), None) => Ok(x),
        _ => Err(ImportError::at(file, c, format!("a <{}> holds exactly one action", c.tag_name().name()))),
    }
}

/// Whether the `SpeedAction` `node` takes effect at once (a `step` shape or a time of 0).
pub fn immediate_speed(ctx: &Ctx<'_, '_>, file: &str, node: Node<'_, '_>) -> Result<bool, ImportError> {
    let d = xml::child(node, "SpeedActionDynamics").ok_or_else(|| ImportError::at(file, node, "<SpeedActionDynamics> is missing"))?;
    let shape = ctx.params.req_enum(d, "dynamicsShape", file, &SHAPES)?;
    let dim = ctx.params.enum_attr(d, "dynamicsDimension", file, &["time", "rate", "distance"])?;
    let value = ctx.params.num_attr(d, "value", file)?.unwrap_or(0.0);
    Ok(shape == "step" || (dim.as_deref() == Some("time") && value == 0.0))
}

/// The `SpeedAction` of a `PrivateAction` (`LongitudinalAction/SpeedAction`), if that is what it is.
pub fn speed_action<'a, 'i>(private: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
    let l = xml::child(private, "LongitudinalAction")?;
    xml::child(l, "SpeedAction")
}

/// Reads `Init`'s per-entity state: teleports and immediate speed actions (by OpenSCENARIO name;
/// `entities` are the names in order). The other init actions are [`Sb::init_act`]'s.
pub fn init_state<'a, 'i>(
    ctx: &mut Ctx<'_, '_>,
    file: &str,
    init: Node<'a, 'i>,
    entities: &[String],
) -> Result<Vec<InitState<'a, 'i>>, ImportError> {
    let mut out: Vec<InitState<'a, 'i>> = vec![InitState::default(); entities.len()];
    for actions in xml::elements(init) {
        if actions.tag_name().name() != "Actions" {
            return Err(ImportError::unsupported(file, actions));
        }
        for p in xml::children(actions, "Private") {
            let name = ctx.params.req_str(p, "entityRef", file)?;
            let i = entities.iter().position(|e| *e == name).ok_or_else(|| ImportError::at(file, p, format!("no entity `{name}`")))?;
            let Some(st) = out.get_mut(i) else { continue };
            for pa in xml::elements(p) {
                if pa.tag_name().name() != "PrivateAction" {
                    return Err(ImportError::unsupported(file, pa));
                }
                if let Some(t) = xml::child(pa, "TeleportAction") {
                    if st.position.is_some() {
                        return Err(ImportError::at(file, t, format!("a second TeleportAction for `{name}` in Init")));
                    }
                    st.position = Some(xml::child(t, "Position").ok_or_else(|| ImportError::at(file, t, "<Position> is missing"))?);
                } else if let Some(f) = xml::child(pa, "RoutingAction").and_then(|r| xml::child(r, "FollowTrajectoryAction")) {
                    st.trajectory = st.trajectory.or(Some(f));
                } else if let Some(sa) = speed_action(pa) {
                    if !immediate_speed(ctx, file, sa)? {
                        continue;
                    }
                    let target =
                        xml::child(sa, "SpeedActionTarget").ok_or_else(|| ImportError::at(file, sa, "<SpeedActionTarget> is missing"))?;
                    if let Some(a) = xml::child(target, "AbsoluteTargetSpeed") {
                        st.speed = Some(ctx.params.req_num(a, "value", file)?);
                        st.relative_speed = None;
                    } else if let Some(r) = xml::child(target, "RelativeTargetSpeed") {
                        let of = ctx.params.req_str(r, "entityRef", file)?;
                        let kind = ctx.params.req_enum(r, "speedTargetValueType", file, &["delta", "factor"])?;
                        st.relative_speed = Some((of, kind == "delta", ctx.params.req_num(r, "value", file)?));
                        st.speed = None;
                    } else {
                        return Err(ImportError::at(file, target, "expected AbsoluteTargetSpeed or RelativeTargetSpeed"));
                    }
                }
            }
        }
    }
    // Relative initial speeds, against the others' absolute ones (chains resolved in turn).
    for _ in 0..entities.len() {
        let mut progress = false;
        for i in 0..out.len() {
            let Some((of, delta, v)) = out.get(i).and_then(|s| s.relative_speed.clone()) else { continue };
            let Some(base) = entities.iter().position(|e| *e == of).and_then(|j| out.get(j)).and_then(|s| s.speed) else { continue };
            if let Some(s) = out.get_mut(i) {
                s.speed = Some(if delta { base + v } else { base * v });
                s.relative_speed = None;
                progress = true;
            }
        }
        if !progress {
            break;
        }
    }
    if let Some((i, s)) = out.iter().enumerate().find(|(_, s)| s.relative_speed.is_some()) {
        let of = s.relative_speed.as_ref().map(|r| r.0.clone()).unwrap_or_default();
        let e = entities.get(i).cloned().unwrap_or_default();
        return Err(ImportError::at(
            file,
            init,
            format!("the initial speed of `{e}` is relative to `{of}`, which has no absolute initial speed"),
        ));
    }
    Ok(out)
}

/// Runs `f` on the start of the trajectory of the Init `FollowTrajectoryAction` `fta`, with the
/// trajectory's parameters in scope (a `TrajectoryCatalog` entry's declarations and the
/// reference's assignments): `f` gets the points to resolve and the distance along them
/// (`initialDistanceOffset`). A `ClothoidSpline` gives its first segment's `PositionStart`
/// (offset 0 only); a `Polyline` its vertices' positions. esmini starts the action at t = 0 and
/// places the entity there, which flc takes as the entity's initial position.
pub fn trajectory_start<'a, 't, R>(
    ctx: &mut Ctx<'a, 't>,
    file: &str,
    fta: Node<'_, '_>,
    f: impl FnOnce(&mut Ctx<'a, 't>, &str, &[Node<'_, '_>], f64) -> Result<R, ImportError>,
) -> Result<R, ImportError> {
    let offset = ctx.params.num_attr(fta, "initialDistanceOffset", file)?.unwrap_or(0.0);
    if !offset.is_finite() || offset < 0.0 {
        return Err(ImportError::at(file, fta, format!("initialDistanceOffset = {offset}: expected a finite distance >= 0")));
    }
    let traj = match xml::child(fta, "TrajectoryRef") {
        Some(r) => only_child(file, r)?,
        None => xml::elements(fta)
            .find(|c| matches!(c.tag_name().name(), "Trajectory" | "CatalogReference"))
            .ok_or_else(|| ImportError::at(file, fta, "<TrajectoryRef> is missing"))?,
    };
    let first_point = move |ctx: &mut Ctx<'a, 't>, file: &str, traj: Node<'_, '_>| -> Result<R, ImportError> {
        if traj.tag_name().name() != "Trajectory" {
            return Err(ImportError::at(file, traj, "expected a <Trajectory>"));
        }
        let shape = xml::child(traj, "Shape").ok_or_else(|| ImportError::at(file, traj, "<Shape> is missing"))?;
        let shape = only_child(file, shape)?;
        let points: Vec<Node<'_, '_>> = match shape.tag_name().name() {
            "ClothoidSpline" => {
                if offset != 0.0 {
                    return Err(ImportError::at(
                        file,
                        fta,
                        "a start on a <ClothoidSpline> with an initialDistanceOffset other than 0 is not supported",
                    ));
                }
                let seg = xml::elements(shape).next().ok_or_else(|| ImportError::at(file, shape, "no <ClothoidSplineSegment>"))?;
                vec![xml::child(seg, "PositionStart").ok_or_else(|| {
                    ImportError::at(
                        file,
                        seg,
                        "the first segment has no <PositionStart> and the entity no TeleportAction (no initial position)",
                    )
                })?]
            }
            "Polyline" => {
                let mut v = Vec::new();
                for x in xml::elements(shape) {
                    if v.len() == 10_000 {
                        return Err(ImportError::at(file, x, "more than 10000 vertices"));
                    }
                    v.push(xml::child(x, "Position").ok_or_else(|| ImportError::at(file, x, "<Position> is missing"))?);
                }
                if v.is_empty() {
                    return Err(ImportError::at(file, shape, "no <Vertex>"));
                }
                v
            }
            other => {
                return Err(ImportError::at(
                    file,
                    shape,
                    format!("<{other}>: an entity without a TeleportAction may start only on a <ClothoidSpline> or <Polyline>"),
                ));
            }
        };
        for p in &points {
            if super::position::reference(&ctx.params, file, *p)?.is_some() {
                return Err(ImportError::at(file, *p, "a trajectory start relative to an entity is not supported"));
            }
        }
        f(ctx, file, &points, offset)
    };
    match traj.tag_name().name() {
        "CatalogReference" => ctx.catalog_entry(file, traj, &["TrajectoryCatalog"], |ctx, efile, node| first_point(ctx, efile, node)),
        _ => {
            ctx.params.push_scope();
            let r = ctx.params.declare_in(traj, file, &BTreeMap::new()).and_then(|()| first_point(ctx, file, traj));
            ctx.params.pop_scope();
            r
        }
    }
}

/// The pose `offset` metres along the polyline through `points` (world poses): the heading of
/// the segment it lies on (a single point: its own pose). `None` past the end.
pub fn along_polyline(points: &[position::Pose], offset: f64) -> Option<position::Pose> {
    let first = *points.first()?;
    if points.len() == 1 {
        return (offset == 0.0).then_some(first);
    }
    let mut left = offset;
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let len = dx.hypot(dy);
        if left <= len && len > 0.0 {
            let k = left / len;
            return Some(position::Pose { x: a.x + k * dx, y: a.y + k * dy, h: dy.atan2(dx) });
        }
        left -= len;
    }
    None
}

impl Sb<'_, '_, '_> {
    fn count(&mut self, file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
        self.elements += 1;
        if self.elements > MAX_ELEMENTS {
            return Err(ImportError::at(file, node, format!("more than {MAX_ELEMENTS} storyboard elements")));
        }
        Ok(())
    }

    /// The scenario name of the entity named by attribute `attr` of `node`.
    fn entity(&self, file: &str, node: Node<'_, '_>, attr: &str) -> Result<String, ImportError> {
        let n = self.ctx.params.req_str(node, attr, file)?;
        self.names.get(&n).cloned().ok_or_else(|| ImportError::at(file, node, format!("no entity `{n}`")))
    }

    fn facts(&self, name: &str) -> Facts {
        self.facts.get(name).copied().unwrap_or(Facts { center: [0.0, 0.0], road_s: 0.0, misc: false, ego: false })
    }

    /// The init act's events: the `Init` actions other than teleports and immediate speeds, one
    /// event per entity (its actions start together at t = 0). Init `VariableAction` /
    /// `ParameterAction` set the initial values instead.
    pub fn init_act(&mut self, file: &str, init: Node<'_, '_>) -> Result<Option<Act>, ImportError> {
        let mut groups: Vec<ManeuverGroup> = Vec::new();
        for actions in xml::elements(init) {
            for a in xml::elements(actions) {
                match a.tag_name().name() {
                    "Private" => {
                        let who = self.entity(file, a, "entityRef")?;
                        let mut acts = Vec::new();
                        let mut start_on_trajectory = !xml::elements(a).any(|pa| xml::child(pa, "TeleportAction").is_some());
                        for pa in xml::elements(a) {
                            if xml::child(pa, "TeleportAction").is_some() {
                                continue;
                            }
                            if let Some(sa) = speed_action(pa) {
                                if immediate_speed(self.ctx, file, sa)? {
                                    continue;
                                }
                            }
                            if let Some(c) = xml::child(pa, "ControllerAction") {
                                // AssignControllerAction in Init selects the controller (read
                                // by the caller); an activation is an action.
                                // In Init only a hand-over to the story has an effect (flc's
                                // controller drives the ego from the start; a scripted ego
                                // ignores activations).
                                if let Some(act) = xml::child(c, "ActivateControllerAction") {
                                    let action = self.activate_controller(file, act, std::slice::from_ref(&who))?;
                                    if self.ego_mode == EgoMode::Controller && action == (Action::Controller { longitudinal: false }) {
                                        acts.push((pa, action));
                                    } else {
                                        self.ctx.warn.note(
                                            "Init/ActivateControllerAction",
                                            file,
                                            act,
                                            "no effect at t = 0 (flc's controller or the story already drives the ego)".into(),
                                        );
                                    }
                                }
                                for x in xml::elements(c) {
                                    match x.tag_name().name() {
                                        "ActivateControllerAction" => {}
                                        "AssignControllerAction" => self.assign_controller_in_init(file, x, &who)?,
                                        _ => return Err(ImportError::unsupported(file, x)),
                                    }
                                }
                                continue;
                            }
                            let fta = xml::child(pa, "RoutingAction").and_then(|r| xml::child(r, "FollowTrajectoryAction"));
                            self.start_trajectory = start_on_trajectory && fta.is_some();
                            start_on_trajectory &= fta.is_none();
                            let action = self.private_action(file, pa, std::slice::from_ref(&who));
                            self.start_trajectory = false;
                            if let (Some(f), true) = (fta, self.ego_mode == EgoMode::Controller && self.facts(&who).ego) {
                                self.ctx.warn.note(
                                    "FollowTrajectoryAction",
                                    file,
                                    f,
                                    "the ego starts at the trajectory's start, then flc's controller drives it along its lane (the path is not followed; --ego-mode scripted follows it)".into(),
                                );
                            }
                            if let Some(action) = action? {
                                acts.push((pa, action));
                            }
                        }
                        if acts.is_empty() {
                            continue;
                        }
                        let event = format!("init/{who}");
                        let mut actions = Vec::new();
                        for (k, (node, action)) in acts.into_iter().enumerate() {
                            self.count(file, node)?;
                            actions.push(StoryAction { name: format!("{event}/{k}"), action });
                        }
                        self.elements += 3;
                        groups.push(ManeuverGroup {
                            name: format!("init/{who}"),
                            actors: vec![who.clone()],
                            maneuvers: vec![Maneuver {
                                name: format!("init/{who}"),
                                events: vec![Event { name: event, priority: Priority::Parallel, max_executions: 1, start: None, actions }],
                            }],
                        });
                    }
                    "GlobalAction" => self.init_global(file, a)?,
                    _ => return Err(ImportError::unsupported(file, a)),
                }
            }
        }
        if groups.is_empty() {
            return Ok(None);
        }
        self.elements += 1;
        Ok(Some(Act { name: "init".into(), story: String::new(), start: None, stop: None, groups }))
    }

    /// An `AssignControllerAction` in Init: on the ego it was read as the controller choice; on
    /// another entity it is skipped unless it activates the controller.
    fn assign_controller_in_init(&mut self, file: &str, node: Node<'_, '_>, who: &str) -> Result<(), ImportError> {
        if self.facts(who).ego {
            return Ok(());
        }
        for attr in ["activateLongitudinal", "activateLateral"] {
            if self.ctx.params.bool_attr(node, attr, file)? == Some(true) {
                self.ctx.warn.note(
                    "ActivateControllerAction@other",
                    file,
                    node,
                    format!("a controller activated on `{who}` (not the ego): flc has no controller for it; it stays scripted (its story moves it)"),
                );
                return Ok(());
            }
        }
        self.ctx.warn.skip(file, node, "a controller assigned to an entity other than the ego (never activated)");
        Ok(())
    }

    /// A `GlobalAction` in Init: variable and parameter actions set initial values; environment
    /// and infrastructure actions are skipped; anything else is an error.
    fn init_global(&mut self, file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
        for g in xml::elements(node) {
            match g.tag_name().name() {
                "VariableAction" | "ParameterAction" => {
                    let action = self.variable_action(file, g)?;
                    let variable = match &action {
                        Action::VariableSet { variable, .. } | Action::VariableModify { variable, .. } => variable.clone(),
                        _ => continue,
                    };
                    let slot = match self.variables.iter_mut().find(|(n, _)| *n == variable) {
                        Some((_, v)) => Some(v),
                        None => self.param_vars.get_mut(&variable),
                    };
                    match (slot, action) {
                        (Some(VarValue::Num(x)), Action::VariableModify { add, multiply, .. }) => {
                            *x = *x * multiply.unwrap_or(1.0) + add.unwrap_or(0.0);
                        }
                        (Some(v), Action::VariableSet { value, .. }) => *v = value,
                        _ => {}
                    }
                }
                "EnvironmentAction" | "InfrastructureAction" => self.ctx.warn.skip(file, g, "changes neither motion nor sensing in flc"),
                _ => return Err(ImportError::unsupported(file, g)),
            }
        }
        Ok(())
    }

    /// The acts of every `Story` and the scenario stop trigger of `Storyboard` `node`.
    pub fn storyboard(&mut self, file: &str, node: Node<'_, '_>) -> Result<(Vec<Act>, Option<Trigger>), ImportError> {
        let mut acts = Vec::new();
        let mut stop = None;
        for (i, c) in xml::elements(node).enumerate() {
            match c.tag_name().name() {
                "Init" => {}
                "Story" => {
                    self.ctx.params.push_scope();
                    let r = self.ctx.params.declare_in(c, file, &BTreeMap::new()).and_then(|()| self.story(file, c, i));
                    self.ctx.params.pop_scope();
                    acts.extend(r?);
                }
                "StopTrigger" => stop = self.trigger(file, c)?,
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        Ok((acts, stop))
    }

    fn story(&mut self, file: &str, node: Node<'_, '_>, i: usize) -> Result<Vec<Act>, ImportError> {
        let name = self.ctx.params.str_attr(node, "name", file)?.unwrap_or_else(|| format!("story{i}"));
        let mut acts = Vec::new();
        for (k, c) in xml::elements(node).enumerate() {
            match c.tag_name().name() {
                "ParameterDeclarations" => {}
                "Act" => acts.push(self.act(file, c, &name, k)?),
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        Ok(acts)
    }

    fn act(&mut self, file: &str, node: Node<'_, '_>, story: &str, i: usize) -> Result<Act, ImportError> {
        self.count(file, node)?;
        let name = self.ctx.params.str_attr(node, "name", file)?.unwrap_or_else(|| format!("{story}/act{i}"));
        let mut act = Act { name, story: story.to_string(), start: None, stop: None, groups: Vec::new() };
        for (k, c) in xml::elements(node).enumerate() {
            match c.tag_name().name() {
                "ManeuverGroup" => {
                    let g = self.group(file, c, &act.name, k)?;
                    act.groups.push(g);
                }
                "StartTrigger" => act.start = self.trigger(file, c)?,
                "StopTrigger" => act.stop = self.trigger(file, c)?,
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        Ok(act)
    }

    fn group(&mut self, file: &str, node: Node<'_, '_>, act: &str, i: usize) -> Result<ManeuverGroup, ImportError> {
        self.count(file, node)?;
        let name = self.ctx.params.str_attr(node, "name", file)?.unwrap_or_else(|| format!("{act}/group{i}"));
        if let Some(n) = self.ctx.params.int_attr(node, "maximumExecutionCount", file)? {
            if n != 1 {
                return Err(ImportError::at(
                    file,
                    node,
                    format!("maximumExecutionCount = {n} of a ManeuverGroup is not supported (only 1)"),
                ));
            }
        }
        let mut g = ManeuverGroup { name, actors: Vec::new(), maneuvers: Vec::new() };
        for c in xml::elements(node) {
            if c.tag_name().name() == "Actors" {
                for e in xml::elements(c) {
                    if e.tag_name().name() != "EntityRef" {
                        return Err(ImportError::unsupported(file, e));
                    }
                    let who = self.entity(file, e, "entityRef")?;
                    if !g.actors.contains(&who) {
                        g.actors.push(who);
                    }
                }
                if g.actors.is_empty() && self.ctx.params.bool_attr(c, "selectTriggeringEntities", file)? == Some(true) {
                    return Err(ImportError::at(
                        file,
                        c,
                        "actors chosen by selectTriggeringEntities are not supported: name them with EntityRef",
                    ));
                }
            }
        }
        for (k, c) in xml::elements(node).enumerate() {
            match c.tag_name().name() {
                "Actors" => {}
                "Maneuver" => {
                    let m = self.maneuver(file, c, &g.name, k, &g.actors)?;
                    g.maneuvers.push(m);
                }
                "CatalogReference" => {
                    let actors = g.actors.clone();
                    let gname = g.name.clone();
                    let m = self.catalog_maneuver(file, c, &gname, k, &actors)?;
                    g.maneuvers.push(m);
                }
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        Ok(g)
    }

    fn catalog_maneuver(
        &mut self,
        file: &str,
        node: Node<'_, '_>,
        group: &str,
        k: usize,
        actors: &[String],
    ) -> Result<Maneuver, ImportError> {
        // The entry is read inside the reference's parameter scope.
        let cats = self.ctx.cats;
        let catalog = self.ctx.params.req_str(node, "catalogName", file)?;
        let entry = self.ctx.params.req_str(node, "entryName", file)?;
        let (efile, enode) = match cats.find(&["ManeuverCatalog"], &catalog, &entry)? {
            Some(x) => x,
            None => return Err(ImportError::at(file, node, cats.not_found(&catalog, &entry))),
        };
        if enode.tag_name().name() != "Maneuver" {
            return Err(ImportError::at(&efile, enode, "expected a <Maneuver> entry"));
        }
        self.ctx.enter_catalog(file, node, &catalog, &entry)?;
        let overrides = super::catalog::assignments(&self.ctx.params, node, file);
        let r = overrides.and_then(|o| {
            self.ctx.params.push_scope();
            let r = self.ctx.params.declare_in(enode, &efile, &o).and_then(|()| self.maneuver_body(&efile, enode, group, k, actors));
            self.ctx.params.pop_scope();
            r
        });
        self.ctx.leave_catalog();
        r
    }

    fn maneuver(&mut self, file: &str, node: Node<'_, '_>, group: &str, k: usize, actors: &[String]) -> Result<Maneuver, ImportError> {
        self.ctx.params.push_scope();
        let r = self.ctx.params.declare_in(node, file, &BTreeMap::new()).and_then(|()| self.maneuver_body(file, node, group, k, actors));
        self.ctx.params.pop_scope();
        r
    }

    fn maneuver_body(&mut self, file: &str, node: Node<'_, '_>, group: &str, i: usize, actors: &[String]) -> Result<Maneuver, ImportError> {
        self.count(file, node)?;
        let name = self.ctx.params.str_attr(node, "name", file)?.unwrap_or_else(|| format!("{group}/maneuver{i}"));
        let mut m = Maneuver { name, events: Vec::new() };
        for (k, c) in xml::elements(node).enumerate() {
            match c.tag_name().name() {
                "ParameterDeclarations" => {}
                "Event" => {
                    let e = self.event(file, c, &m.name, k, actors)?;
                    m.events.push(e);
                }
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        Ok(m)
    }

    fn event(&mut self, file: &str, node: Node<'_, '_>, maneuver: &str, i: usize, actors: &[String]) -> Result<Event, ImportError> {
        self.count(file, node)?;
        let name = self.ctx.params.str_attr(node, "name", file)?.unwrap_or_else(|| format!("{maneuver}/event{i}"));
        let priority = match self.ctx.params.enum_attr(node, "priority", file, &["overwrite", "override", "skip", "parallel"])?.as_deref() {
            Some("skip") => Priority::Skip,
            Some("parallel") => Priority::Parallel,
            _ => Priority::Override,
        };
        let max_executions = match self.ctx.params.int_attr(node, "maximumExecutionCount", file)? {
            None => 1,
            Some(n) if (1..=1_000_000).contains(&n) => u32::try_from(n).unwrap_or(1),
            Some(n) => return Err(ImportError::at(file, node, format!("maximumExecutionCount = {n}: must be 1 to 1000000"))),
        };
        let mut e = Event { name, priority, max_executions, start: None, actions: Vec::new() };
        let mut k = 0usize;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "Action" => {
                    self.count(file, c)?;
                    let aname = self.ctx.params.str_attr(c, "name", file)?.unwrap_or_else(|| format!("{}/{k}", e.name));
                    let action = self.action(file, c, actors)?;
                    e.actions.push(StoryAction { name: aname, action });
                    k += 1;
                }
                "StartTrigger" => e.start = self.trigger(file, c)?,
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        if e.actions.is_empty() {
            return Err(ImportError::at(file, node, "an event needs at least one action"));
        }
        Ok(e)
    }

    /// A no-op standing for a skipped action.
    fn skipped(&mut self) -> Action {
        self.skipped_used = true;
        Action::VariableModify { variable: SKIPPED_VAR.into(), add: Some(0.0), multiply: None }
    }

    /// An `Action`: `PrivateAction`, `GlobalAction` or (error) `UserDefinedAction`.
    fn action(&mut self, file: &str, node: Node<'_, '_>, actors: &[String]) -> Result<Action, ImportError> {
        let mut it = xml::elements(node);
        let (Some(c), None) = (it.next(), it.next()) else {
            return Err(ImportError::at(file, node, "an <Action> holds exactly one action"));
        };
        match c.tag_name().name() {
            "PrivateAction" => match self.private_action(file, c, actors)? {
                Some(a) => Ok(a),
                None => Ok(self.skipped()),
            },
            "GlobalAction" => {
                let mut it = xml::elements(c);
                let (Some(g), None) = (it.next(), it.next()) else {
                    return Err(ImportError::at(file, c, "a <GlobalAction> holds exactly one action"));
                };
                match g.tag_name().name() {
                    "VariableAction" | "ParameterAction" => self.variable_action(file, g),
                    "EnvironmentAction" | "InfrastructureAction" => {
                        self.ctx.warn.skip(file, g, "changes neither motion nor sensing in flc");
                        Ok(self.skipped())
                    }
                    _ => Err(ImportError::unsupported(file, g)),
                }
            }
            _ => Err(ImportError::unsupported(file, c)),
        }
    }

    /// A `PrivateAction` on `actors`; `None`: skipped (visual only).
    fn private_action(&mut self, file: &str, node: Node<'_, '_>, actors: &[String]) -> Result<Option<Action>, ImportError> {
        let mut it = xml::elements(node);
        let (Some(c), None) = (it.next(), it.next()) else {
            return Err(ImportError::at(file, node, "a <PrivateAction> holds exactly one action"));
        };
        let one = |c| only_child(file, c);
        let moves = |sb: &Self, x: Node<'_, '_>| -> Result<(), ImportError> {
            if let Some(m) = actors.iter().find(|a| sb.facts(a).misc) {
                return Err(ImportError::at(file, x, format!("an action on `{m}`, a MiscObject (it cannot move)")));
            }
            Ok(())
        };
        match c.tag_name().name() {
            "LongitudinalAction" => {
                let x = one(c)?;
                moves(self, x)?;
                match x.tag_name().name() {
                    "SpeedAction" => self.speed(file, x).map(Some),
                    "LongitudinalDistanceAction" => self.longitudinal_distance(file, x).map(Some),
                    _ => Err(ImportError::unsupported(file, x)),
                }
            }
            "LateralAction" => {
                let x = one(c)?;
                moves(self, x)?;
                match x.tag_name().name() {
                    "LaneChangeAction" => self.lane_change(file, x, actors).map(Some),
                    "LaneOffsetAction" => self.lane_offset(file, x).map(Some),
                    _ => Err(ImportError::unsupported(file, x)),
                }
            }
            "ActivateControllerAction" => self.activate_controller(file, c, actors).map(Some),
            "RoutingAction" => {
                let x = one(c)?;
                moves(self, x)?;
                match x.tag_name().name() {
                    "FollowTrajectoryAction" => self.follow_trajectory(file, x).map(Some),
                    _ => Err(ImportError::unsupported(file, x)),
                }
            }
            "SynchronizeAction" => {
                moves(self, c)?;
                self.synchronize(file, c).map(Some)
            }
            "ControllerAction" => {
                let mut found = None;
                for x in xml::elements(c) {
                    match x.tag_name().name() {
                        "ActivateControllerAction" => found = Some(self.activate_controller(file, x, actors)?),
                        _ => return Err(ImportError::unsupported(file, x)),
                    }
                }
                found.map(Some).ok_or_else(|| ImportError::at(file, c, "an empty ControllerAction"))
            }
            "VisibilityAction" | "AppearanceAction" => {
                self.ctx.warn.skip(file, c, "visual only");
                Ok(None)
            }
            _ => Err(ImportError::unsupported(file, c)),
        }
    }

    /// `ActivateControllerAction` on the ego: flc's controller on (`longitudinal`, default
    /// true) or off. With `--ego-mode scripted` it is kept as an element but hands nothing over.
    /// On another entity (esmini's acc-test activates an ACC on a target) flc has no
    /// controller to hand it to: the entity stays scripted (its storyboard moves it, as esmini
    /// with `--disable_controllers`), with a warning.
    fn activate_controller(&mut self, file: &str, node: Node<'_, '_>, actors: &[String]) -> Result<Action, ImportError> {
        if let Some(a) = actors.iter().find(|a| !self.facts(a).ego) {
            self.ctx.warn.note(
                "ActivateControllerAction@other",
                file,
                node,
                format!(
                    "a controller activated on `{a}` (not the ego): flc has no controller for it; it stays scripted (its story moves it)"
                ),
            );
            return Ok(self.skipped());
        }
        let longitudinal = self.ctx.params.bool_attr(node, "longitudinal", file)?.unwrap_or(true);
        if self.ego_mode == EgoMode::Scripted {
            self.ctx.warn.note(
                "ActivateControllerAction",
                file,
                node,
                "--ego-mode scripted: the ego follows the story; controller activations hand nothing over".into(),
            );
            return Ok(Action::Controller { longitudinal: false });
        }
        Ok(Action::Controller { longitudinal })
    }

    /// The `(dynamics, target)` children of a speed or lane change action, the transition the
    /// dynamics give, and the target's one child.
    fn dynamics_and_target<'a, 'i>(
        &mut self,
        file: &str,
        node: Node<'a, 'i>,
        (dyn_tag, target_tag): (&str, &str),
    ) -> Result<(Transition, Node<'a, 'i>), ImportError> {
        let mut dynamics = None;
        let mut target = None;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                n if n == dyn_tag => dynamics = Some(c),
                n if n == target_tag => target = Some(c),
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let d = dynamics.ok_or_else(|| ImportError::at(file, node, format!("<{dyn_tag}> is missing")))?;
        let t = target.ok_or_else(|| ImportError::at(file, node, format!("<{target_tag}> is missing")))?;
        let p = &self.ctx.params;
        let shape = shape_of(&p.req_enum(d, "dynamicsShape", file, &SHAPES)?);
        let dimension = match p.req_enum(d, "dynamicsDimension", file, &["time", "rate", "distance"])?.as_str() {
            "rate" => Dimension::Rate,
            "distance" => Dimension::Distance,
            _ => Dimension::Time,
        };
        let mut value = p.req_num(d, "value", file)?;
        if value < 0.0 {
            // esmini uses the magnitude (cut-in_simple.xosc: `value="-5"`).
            self.ctx.esmini_extension(
                &format!("{dyn_tag}@value<0"),
                file,
                d,
                &format!("a negative {dyn_tag} value ({value})"),
                "its magnitude is used",
            )?;
            value = value.abs();
        }
        if shape != Shape::Step && value == 0.0 && dimension == Dimension::Rate && dyn_tag == "SpeedActionDynamics" {
            // esmini: a speed rate of 0 never moves the speed off its start value; the action
            // ends at once if that is the target, else never (ALKS 4_4_x templates' default).
            self.ctx.esmini_extension(
                "SpeedActionDynamics@rate=0",
                file,
                d,
                "a speed change at rate 0",
                "the speed stays at its start value (the action ends only if that is the target)",
            )?;
        } else if shape != Shape::Step && value <= 0.0 {
            return Err(ImportError::at(file, d, format!("value = {value}: must be positive")));
        }
        let mut it = xml::elements(t);
        let (Some(x), None) = (it.next(), it.next()) else {
            return Err(ImportError::at(file, t, format!("a <{target_tag}> holds one target")));
        };
        Ok((Transition { shape, dimension, value }, x))
    }

    fn speed(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let (transition, x) = self.dynamics_and_target(file, node, ("SpeedActionDynamics", "SpeedActionTarget"))?;
        let p = &self.ctx.params;
        match x.tag_name().name() {
            "AbsoluteTargetSpeed" => Ok(Action::Speed {
                speed: Some(p.req_num(x, "value", file)?),
                of: None,
                delta: None,
                factor: None,
                continuous: false,
                transition,
            }),
            "RelativeTargetSpeed" => {
                let of = self.entity(file, x, "entityRef")?;
                let p = &self.ctx.params;
                let v = p.req_num(x, "value", file)?;
                let delta = p.req_enum(x, "speedTargetValueType", file, &["delta", "factor"])? == "delta";
                let continuous = p.bool_attr(x, "continuous", file)?.unwrap_or(false);
                Ok(Action::Speed {
                    speed: None,
                    of: Some(of),
                    delta: delta.then_some(v),
                    factor: (!delta).then_some(v),
                    continuous,
                    transition,
                })
            }
            _ => Err(ImportError::unsupported(file, x)),
        }
    }

    fn longitudinal_distance(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        if let Some(c) = xml::elements(node).next() {
            return Err(ImportError::unsupported(file, c));
        }
        let of = self.entity(file, node, "entityRef")?;
        let p = &self.ctx.params;
        let continuous = p.bool_attr(node, "continuous", file)?.unwrap_or(false);
        let distance = p.num_attr(node, "distance", file)?;
        let time_gap = p.num_attr(node, "timeGap", file)?;
        let freespace = p.req_bool(node, "freespace", file)?;
        let ahead =
            match p.enum_attr(node, "displacement", file, &["trailingReferencedEntity", "leadingReferencedEntity", "any"])?.as_deref() {
                Some("leadingReferencedEntity") => true,
                Some("any") => return Err(ImportError::at(file, node, "displacement=\"any\" is not supported")),
                _ => false,
            };
        self.coordinate_system(file, node, false)?;
        if distance.is_some() == time_gap.is_some() {
            return Err(ImportError::at(file, node, "give `distance` or `timeGap`"));
        }
        Ok(Action::LongitudinalDistance { of, distance, time_gap, freespace, ahead, continuous })
    }

    /// `coordinateSystem`: entity, road or lane (measured along the track either way); `warn`:
    /// say it is approximated.
    fn coordinate_system(&mut self, file: &str, node: Node<'_, '_>, warn: bool) -> Result<(), ImportError> {
        if let Some(cs) = self.ctx.params.enum_attr(node, "coordinateSystem", file, &["entity", "road", "lane", "trajectory", "world"])? {
            if !matches!(cs.as_str(), "entity" | "road" | "lane") {
                return Err(ImportError::at(file, node, format!("coordinateSystem=\"{cs}\" is not supported (entity, road, lane)")));
            }
            if warn {
                let key = format!("{}@coordinateSystem", node.tag_name().name());
                self.ctx.warn.note(&key, file, node, "ignored: distances are measured along the track".into());
            }
        }
        Ok(())
    }

    fn lane_change(&mut self, file: &str, node: Node<'_, '_>, actors: &[String]) -> Result<Action, ImportError> {
        let lane_offset = self.ctx.params.num_attr(node, "targetLaneOffset", file)?.unwrap_or(0.0);
        let (transition, x) = self.dynamics_and_target(file, node, ("LaneChangeActionDynamics", "LaneChangeTarget"))?;
        match x.tag_name().name() {
            "AbsoluteTargetLane" => {
                let lane = position::lane_id(&self.ctx.params, file, x, "value")?;
                let first = actors.first().ok_or_else(|| ImportError::at(file, x, "a lane change needs an actor"))?;
                let s = self.facts(first).road_s;
                let offset = self.lanes.offset_of(lane, s).ok_or_else(|| {
                    ImportError::at(file, x, format!("lane {lane} does not exist at s = {s:.1} m of road `{}`", self.geo.road.id))
                })?;
                Ok(Action::LaneChange { offset: Some(offset), of: None, lanes: None, lane_offset, transition })
            }
            "RelativeTargetLane" => {
                let of = self.entity(file, x, "entityRef")?;
                let n = self.ctx.params.req_int(x, "value", file)?;
                let lanes = i32::try_from(n).map_err(|_| ImportError::at(file, x, format!("value = {n} lanes")))?;
                Ok(Action::LaneChange { offset: None, of: Some(of), lanes: Some(lanes), lane_offset, transition })
            }
            _ => Err(ImportError::unsupported(file, x)),
        }
    }

    fn lane_offset(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let p = &self.ctx.params;
        if p.bool_attr(node, "continuous", file)? == Some(true) {
            return Err(ImportError::at(file, node, "continuous=\"true\" is not supported (only an offset reached once)"));
        }
        let mut dynamics = None;
        let mut target = None;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "LaneOffsetActionDynamics" => dynamics = Some(c),
                "LaneOffsetTarget" => target = Some(c),
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let d = dynamics.ok_or_else(|| ImportError::at(file, node, "<LaneOffsetActionDynamics> is missing"))?;
        let t = target.ok_or_else(|| ImportError::at(file, node, "<LaneOffsetTarget> is missing"))?;
        let shape = shape_of(&p.req_enum(d, "dynamicsShape", file, &SHAPES)?);
        let max_lateral_acc = p
            .num_attr(d, "maxLateralAcc", file)?
            .ok_or_else(|| ImportError::at(file, d, "maxLateralAcc is needed (flc times the offset change by it)"))?;
        let mut it = xml::elements(t);
        let (Some(x), None) = (it.next(), it.next()) else {
            return Err(ImportError::at(file, t, "a <LaneOffsetTarget> holds one target"));
        };
        match x.tag_name().name() {
            "AbsoluteTargetLaneOffset" => Ok(Action::LaneOffset { offset: p.req_num(x, "value", file)?, of: None, shape, max_lateral_acc }),
            "RelativeTargetLaneOffset" => {
                let of = self.entity(file, x, "entityRef")?;
                let offset = self.ctx.params.req_num(x, "value", file)?;
                Ok(Action::LaneOffset { offset, of: Some(of), shape, max_lateral_acc })
            }
            _ => Err(ImportError::unsupported(file, x)),
        }
    }

    /// `FollowTrajectoryAction`: a `ClothoidSpline` trajectory ([`Self::follow_spline`]), else
    /// an inline `Polyline` ([`Self::follow_polyline`], which names any other shape).
    fn follow_trajectory(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let inline = xml::elements(node).find_map(|c| match c.tag_name().name() {
            "Trajectory" => Some(c),
            "TrajectoryRef" => xml::elements(c).find(|t| t.tag_name().name() == "Trajectory"),
            _ => None,
        });
        let catalog = xml::elements(node).any(|c| {
            c.tag_name().name() == "CatalogReference"
                || (c.tag_name().name() == "TrajectoryRef" && xml::elements(c).any(|t| t.tag_name().name() == "CatalogReference"))
        });
        let first_shape = inline
            .and_then(|t| xml::elements(t).find(|c| c.tag_name().name() == "Shape"))
            .and_then(|sh| xml::elements(sh).next())
            .map(|x| x.tag_name().name());
        let untimed = xml::elements(node)
            .find(|c| c.tag_name().name() == "TimeReference")
            .and_then(|t| xml::elements(t).next())
            .is_some_and(|t| t.tag_name().name() == "None");
        let untimed_start = self.start_trajectory && untimed && first_shape == Some("Polyline");
        if catalog || first_shape == Some("ClothoidSpline") || untimed_start {
            self.follow_spline(file, node)
        } else {
            self.follow_polyline(file, node)
        }
    }

    /// `FollowTrajectoryAction` with an inline `Polyline` trajectory (in `TrajectoryRef`, or
    /// directly as in 1.0), `position` following mode and a `TimeReference/Timing`: the
    /// vertices' positions (absolute ones) on the track, each reached `(time - offset) / scale`
    /// after the action's start (`absolute`: at that simulation time), as esmini plays it.
    fn follow_polyline(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let p = &self.ctx.params;
        if p.num_attr(node, "initialDistanceOffset", file)?.is_some_and(|d| d != 0.0) {
            return Err(ImportError::at(file, node, "initialDistanceOffset other than 0 is not supported"));
        }
        let (mut trajectory, mut timing, mut mode) = (None, None, None);
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "Trajectory" => trajectory = Some(c),
                "TrajectoryRef" => {
                    let t = only_child(file, c)?;
                    if t.tag_name().name() != "Trajectory" {
                        return Err(ImportError::unsupported(file, t));
                    }
                    trajectory = Some(t);
                }
                "CatalogReference" => return Err(ImportError::unsupported(file, c)),
                "TimeReference" => {
                    let t = only_child(file, c)?;
                    match t.tag_name().name() {
                        "Timing" => timing = Some(t),
                        _ => {
                            return Err(ImportError::at(
                                file,
                                t,
                                "a trajectory without timing is not supported (give <Timing>: flc moves the entity by the vertices' times)",
                            ));
                        }
                    }
                }
                "TrajectoryFollowingMode" => mode = Some(c),
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let traj = trajectory.ok_or_else(|| ImportError::at(file, node, "<TrajectoryRef> is missing"))?;
        let timing = timing.ok_or_else(|| ImportError::at(file, node, "<TimeReference> is missing"))?;
        let mode = mode.ok_or_else(|| ImportError::at(file, node, "<TrajectoryFollowingMode> is missing"))?;
        if p.req_enum(mode, "followingMode", file, &["position", "follow"])? != "position" {
            return Err(ImportError::at(
                file,
                mode,
                "followingMode=\"follow\" is not supported (only \"position\", as esmini's default controller plays it)",
            ));
        }
        let absolute = p.req_enum(timing, "domainAbsoluteRelative", file, &["absolute", "relative"])? == "absolute";
        let scale = p.req_num(timing, "scale", file)?;
        let offset = p.req_num(timing, "offset", file)?;
        if !(scale > 0.0 && scale.is_finite() && offset.is_finite()) {
            return Err(ImportError::at(
                file,
                timing,
                format!("scale = {scale}, offset = {offset}: the scale must be positive, both finite"),
            ));
        }
        if p.bool_attr(traj, "closed", file)? == Some(true) {
            return Err(ImportError::at(file, traj, "closed=\"true\" is not supported"));
        }
        let mut polyline = None;
        for c in xml::elements(traj) {
            match c.tag_name().name() {
                "Shape" => {
                    let sh = only_child(file, c)?;
                    if sh.tag_name().name() != "Polyline" {
                        return Err(ImportError::unsupported(file, sh));
                    }
                    polyline = Some(sh);
                }
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let polyline = polyline.ok_or_else(|| ImportError::at(file, traj, "<Shape> is missing"))?;
        let mut vertices = Vec::new();
        for v in xml::elements(polyline) {
            if v.tag_name().name() != "Vertex" {
                return Err(ImportError::unsupported(file, v));
            }
            if vertices.len() >= MAX_VERTICES {
                return Err(ImportError::at(file, v, format!("more than {MAX_VERTICES} vertices")));
            }
            self.count(file, v)?;
            let time = self.ctx.params.num_attr(v, "time", file)?.ok_or_else(|| {
                ImportError::at(file, v, "a vertex without `time` is not supported (flc moves the entity by the vertices' times)")
            })?;
            // esmini's reading: the trajectory's clock reads `offset + scale * t` at time `t`
            // into the action (absolute: simulation time).
            let t = (time - offset) / scale;
            if !t.is_finite() || vertices.last().is_some_and(|w: &Vertex| t < w.t) {
                return Err(ImportError::at(file, v, format!("time = {time}: vertex times must be finite and must not decrease")));
            }
            let pos = only_child(file, v)?;
            if pos.tag_name().name() != "Position" {
                return Err(ImportError::unsupported(file, pos));
            }
            let (s, lateral, heading) = self.track_pose(file, pos)?;
            vertices.push(Vertex { t, s, offset: lateral, heading });
        }
        if vertices.is_empty() {
            return Err(ImportError::at(file, polyline, "a polyline needs at least one vertex"));
        }
        Ok(Action::Trajectory { absolute, vertices })
    }

    /// The story variable of an OpenSCENARIO parameter (registered with its value).
    fn param_var(&mut self, file: &str, node: Node<'_, '_>, name: &str) -> Result<(String, VarValue), ImportError> {
        let name = name.trim().trim_start_matches('$');
        let v = self.ctx.params.value(name).ok_or_else(|| ImportError::at(file, node, format!("no parameter `{name}`")))?;
        let v = var_value(v);
        let key = format!("{PARAM_PREFIX}{name}");
        let init = self.param_vars.entry(key.clone()).or_insert(v).clone();
        Ok((key, init))
    }

    /// The variable named by `node`'s `variableRef` (a `VariableAction`/`VariableCondition`) or
    /// `parameterRef` (`ParameterAction`/`ParameterCondition`) and its (initial) value.
    fn variable_of(&mut self, file: &str, node: Node<'_, '_>) -> Result<(String, VarValue), ImportError> {
        if node.attribute("parameterRef").is_some() {
            let name = self.ctx.params.req_str(node, "parameterRef", file)?;
            return self.param_var(file, node, &name);
        }
        let name = self.ctx.params.req_str(node, "variableRef", file)?;
        let v = self.variables.iter().find(|(n, _)| *n == name).map(|(_, v)| v.clone());
        v.map(|v| (name.clone(), v)).ok_or_else(|| ImportError::at(file, node, format!("no variable `{name}` (VariableDeclarations)")))
    }

    /// `VariableAction` (1.2) / `ParameterAction` (1.0-1.1): `SetAction` (`VariableSetAction`)
    /// or `ModifyAction` (`VariableModifyAction`) with `Rule/AddValue` or `Rule/MultiplyByValue`.
    fn variable_action(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let (variable, like) = self.variable_of(file, node)?;
        let mut it = xml::elements(node);
        let (Some(x), None) = (it.next(), it.next()) else {
            return Err(ImportError::at(file, node, format!("a <{}> holds one action", node.tag_name().name())));
        };
        match x.tag_name().name() {
            "SetAction" | "VariableSetAction" | "ParameterSetAction" => {
                let text = self.ctx.params.req_str(x, "value", file)?;
                let value = typed(&like, &text).map_err(|m| ImportError::at(file, x, format!("`{variable}`: {m}")))?;
                Ok(Action::VariableSet { variable, value })
            }
            "ModifyAction" | "VariableModifyAction" | "ParameterModifyAction" => {
                if !matches!(like, VarValue::Num(_)) {
                    return Err(ImportError::at(file, x, format!("`{variable}` is not a number: it cannot be modified")));
                }
                let rule = xml::child(x, "Rule").ok_or_else(|| ImportError::at(file, x, "<Rule> is missing"))?;
                let mut it = xml::elements(rule);
                let (Some(r), None) = (it.next(), it.next()) else {
                    return Err(ImportError::at(file, rule, "a <Rule> holds AddValue or MultiplyByValue"));
                };
                let v = self.ctx.params.req_num(r, "value", file)?;
                match r.tag_name().name() {
                    "AddValue" => Ok(Action::VariableModify { variable, add: Some(v), multiply: None }),
                    "MultiplyByValue" => Ok(Action::VariableModify { variable, add: None, multiply: Some(v) }),
                    _ => Err(ImportError::unsupported(file, r)),
                }
            }
            _ => Err(ImportError::unsupported(file, x)),
        }
    }

    // ---- triggers ----

    /// A `StartTrigger` / `StopTrigger`: groups ORed, conditions ANDed; `None` without groups.
    pub fn trigger(&mut self, file: &str, node: Node<'_, '_>) -> Result<Option<Trigger>, ImportError> {
        let n = node.descendants().filter(|d| d.is_element() && d.tag_name().name() == "Condition").count();
        if n > MAX_CONDITIONS {
            return Err(ImportError::at(file, node, format!("{n} conditions, more than the limit of {MAX_CONDITIONS} per trigger")));
        }
        let mut groups: Vec<Vec<Condition>> = Vec::new();
        for g in xml::elements(node) {
            if g.tag_name().name() != "ConditionGroup" {
                return Err(ImportError::unsupported(file, g));
            }
            let mut alts: Vec<Vec<Condition>> = vec![Vec::new()];
            let mut any = false;
            for c in xml::elements(g) {
                if c.tag_name().name() != "Condition" {
                    return Err(ImportError::unsupported(file, c));
                }
                any = true;
                let options = self.condition(file, c)?;
                let total = alts.len().saturating_mul(options.len());
                if total.saturating_add(groups.len()) > MAX_GROUPS {
                    return Err(ImportError::at(file, c, format!("the trigger expands to more than {MAX_GROUPS} condition groups")));
                }
                let mut next = Vec::with_capacity(total);
                for a in &alts {
                    for o in &options {
                        let mut x = a.clone();
                        x.extend(o.iter().cloned());
                        next.push(x);
                    }
                }
                alts = next;
            }
            if !any {
                return Err(ImportError::at(file, g, "an empty ConditionGroup"));
            }
            groups.extend(alts);
        }
        Ok(match groups.len() {
            0 => None,
            1 if groups.first().is_some_and(|g| g.len() == 1) => groups.pop().and_then(|mut g| g.pop()).map(Trigger::when),
            _ => Some(Trigger::any_of(groups)),
        })
    }

    /// A `Condition`: its alternatives (ORed), each a list of conditions (ANDed).
    fn condition(&mut self, file: &str, node: Node<'_, '_>) -> Result<Vec<Vec<Condition>>, ImportError> {
        let p = &self.ctx.params;
        let delay = p.num_attr(node, "delay", file)?.unwrap_or(0.0);
        if delay < 0.0 {
            return Err(ImportError::at(file, node, format!("delay = {delay} s: must not be negative")));
        }
        let edge = match p.enum_attr(node, "conditionEdge", file, &["rising", "falling", "risingOrFalling", "none"])?.as_deref() {
            Some("rising") => Edge::Rising,
            Some("falling") => Edge::Falling,
            Some("risingOrFalling") => Edge::RisingOrFalling,
            _ => Edge::None,
        };
        let mut it = xml::elements(node);
        let (Some(c), None) = (it.next(), it.next()) else {
            return Err(ImportError::at(file, node, "a <Condition> holds ByValueCondition or ByEntityCondition"));
        };
        let wrap = |k: ConditionKind| Condition::new(k).delayed(delay).on(edge);
        match c.tag_name().name() {
            "ByValueCondition" => {
                let mut it = xml::elements(c);
                let (Some(v), None) = (it.next(), it.next()) else {
                    return Err(ImportError::at(file, c, "a <ByValueCondition> holds one condition"));
                };
                Ok(vec![vec![wrap(self.value_condition(file, v)?)]])
            }
            "ByEntityCondition" => {
                let te = xml::child(c, "TriggeringEntities").ok_or_else(|| ImportError::at(file, c, "<TriggeringEntities> is missing"))?;
                let ec = xml::child(c, "EntityCondition").ok_or_else(|| ImportError::at(file, c, "<EntityCondition> is missing"))?;
                for x in xml::elements(c) {
                    if !matches!(x.tag_name().name(), "TriggeringEntities" | "EntityCondition") {
                        return Err(ImportError::unsupported(file, x));
                    }
                }
                let all = self.ctx.params.req_enum(te, "triggeringEntitiesRule", file, &["any", "all"])? == "all";
                let mut who = Vec::new();
                for e in xml::elements(te) {
                    if e.tag_name().name() != "EntityRef" {
                        return Err(ImportError::unsupported(file, e));
                    }
                    who.push(self.entity(file, e, "entityRef")?);
                }
                if who.is_empty() {
                    return Err(ImportError::at(file, te, "no triggering entity"));
                }
                if !all && who.len() > MAX_GROUPS {
                    return Err(ImportError::at(file, te, format!("more than {MAX_GROUPS} triggering entities with rule `any`")));
                }
                let mut it = xml::elements(ec);
                let (Some(x), None) = (it.next(), it.next()) else {
                    return Err(ImportError::at(file, ec, "an <EntityCondition> holds one condition"));
                };
                let mut conds = Vec::with_capacity(who.len());
                for w in &who {
                    conds.push(wrap(self.entity_condition(file, x, w)?));
                }
                Ok(if all { vec![conds] } else { conds.into_iter().map(|c| vec![c]).collect() })
            }
            _ => Err(ImportError::unsupported(file, c)),
        }
    }

    fn rule(&self, file: &str, node: Node<'_, '_>) -> Result<Rule, ImportError> {
        Ok(rule_of(&self.ctx.params.req_enum(node, "rule", file, &RULES)?))
    }

    fn value_condition(&mut self, file: &str, node: Node<'_, '_>) -> Result<ConditionKind, ImportError> {
        match node.tag_name().name() {
            "SimulationTimeCondition" => {
                let value = self.ctx.params.req_num(node, "value", file)?;
                Ok(ConditionKind::SimulationTime { value, rule: self.rule(file, node)?, tolerance: None })
            }
            "StoryboardElementStateCondition" => {
                let p = &self.ctx.params;
                let kind = match p
                    .req_enum(node, "storyboardElementType", file, &["story", "act", "maneuver", "maneuverGroup", "event", "action"])?
                    .as_str()
                {
                    "story" => ElementKind::Story,
                    "act" => ElementKind::Act,
                    "maneuverGroup" => ElementKind::ManeuverGroup,
                    "maneuver" => ElementKind::Maneuver,
                    "event" => ElementKind::Event,
                    _ => ElementKind::Action,
                };
                let raw = p.req_str(node, "storyboardElementRef", file)?;
                let element = raw.rsplit("::").next().unwrap_or(&raw).to_string();
                let state = match p
                    .req_enum(
                        node,
                        "state",
                        file,
                        &[
                            "startTransition",
                            "endTransition",
                            "stopTransition",
                            "skipTransition",
                            "completeState",
                            "runningState",
                            "standbyState",
                        ],
                    )?
                    .as_str()
                {
                    "startTransition" => ElementEvent::StartTransition,
                    "endTransition" => ElementEvent::EndTransition,
                    "stopTransition" => ElementEvent::StopTransition,
                    "skipTransition" => ElementEvent::SkipTransition,
                    "completeState" => ElementEvent::CompleteState,
                    "runningState" => ElementEvent::RunningState,
                    _ => ElementEvent::StandbyState,
                };
                Ok(ConditionKind::ElementState { element, state, element_type: Some(kind) })
            }
            "ParameterCondition" | "VariableCondition" => {
                let (variable, like) = self.variable_of(file, node)?;
                let text = self.ctx.params.req_str(node, "value", file)?;
                let value = typed(&like, &text).map_err(|m| ImportError::at(file, node, format!("`{variable}`: {m}")))?;
                let rule = self.rule(file, node)?;
                if !matches!(value, VarValue::Num(_)) && !matches!(rule, Rule::EqualTo | Rule::NotEqualTo) {
                    return Err(ImportError::at(file, node, "booleans and text compare only with equalTo / notEqualTo"));
                }
                Ok(ConditionKind::Variable { variable, value, rule })
            }
            _ => Err(ImportError::unsupported(file, node)),
        }
    }

    /// `direction` of a speed or acceleration condition (1.2): longitudinal only.
    fn longitudinal_only(&self, file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
        match self.ctx.params.enum_attr(node, "direction", file, &["longitudinal", "lateral", "vertical"])?.as_deref() {
            None | Some("longitudinal") => Ok(()),
            Some(d) => Err(ImportError::at(file, node, format!("direction=\"{d}\" is not supported (longitudinal)"))),
        }
    }

    fn distance_type(&self, file: &str, node: Node<'_, '_>, default: Option<DistanceType>) -> Result<DistanceType, ImportError> {
        let v = self.ctx.params.enum_attr(
            node,
            "relativeDistanceType",
            file,
            &["longitudinal", "lateral", "cartesianDistance", "euclidianDistance"],
        )?;
        match v.as_deref() {
            Some("longitudinal") => Ok(DistanceType::Longitudinal),
            Some("lateral") => Ok(DistanceType::Lateral),
            Some(_) => Ok(DistanceType::Euclidean),
            None => default.ok_or_else(|| ImportError::at(file, node, "relativeDistanceType is missing")),
        }
    }

    /// `alongRoute` (1.0, deprecated): ignored with a warning.
    fn along_route(&mut self, file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
        if self.ctx.params.bool_attr(node, "alongRoute", file)?.is_some() {
            let key = format!("{}@alongRoute", node.tag_name().name());
            self.ctx.warn.note(&key, file, node, "ignored: distances are measured along the track".into());
        }
        Ok(())
    }

    /// The common part of `TimeHeadwayCondition` and `TimeToCollisionCondition` (`what` names it
    /// in errors): longitudinal only, `alongRoute` and the coordinate system checked, then
    /// `(freespace, value, rule)`.
    fn longitudinal_time(
        &mut self,
        file: &str,
        node: Node<'_, '_>,
        (entity, of): (&str, &str),
        what: &str,
    ) -> Result<(bool, f64, Rule), ImportError> {
        let distance = self.distance_type(file, node, Some(DistanceType::Longitudinal))?;
        self.time_measure(file, node, (entity, of), what, distance)
    }

    /// [`Self::longitudinal_time`] for a given measure: longitudinal, or (a time headway)
    /// Euclidean.
    fn time_measure(
        &mut self,
        file: &str,
        node: Node<'_, '_>,
        (entity, of): (&str, &str),
        what: &str,
        distance: DistanceType,
    ) -> Result<(bool, f64, Rule), ImportError> {
        self.along_route(file, node)?;
        self.coordinate_system(file, node, true)?;
        let ok = distance == DistanceType::Longitudinal || (distance == DistanceType::Euclidean && what == "a time headway");
        if !ok {
            return Err(ImportError::at(file, node, format!("{what} measured other than longitudinally is not supported")));
        }
        let freespace = self.ctx.params.req_bool(node, "freespace", file)?;
        if !freespace {
            self.centre_note(file, node, entity, of);
        }
        let value = self.ctx.params.req_num(node, "value", file)?;
        Ok((freespace, value, self.rule(file, node)?))
    }

    /// A warning when reference points and box centres differ between `a` and `b` along the
    /// measured direction (flc measures `freespace = false` distances between box centres).
    fn centre_note(&mut self, file: &str, node: Node<'_, '_>, a: &str, b: &str) {
        let (fa, fb) = (self.facts(a), self.facts(b));
        if (fa.center[0] - fb.center[0]).abs() > 1e-9 || (fa.center[1] - fb.center[1]).abs() > 1e-9 {
            let key = format!("{}@freespace", node.tag_name().name());
            self.ctx.warn.note(
                &key,
                file,
                node,
                format!("freespace=\"false\" between `{a}` and `{b}` is measured between box centres (their reference points sit differently in their boxes)"),
            );
        }
    }

    /// `FollowTrajectoryAction` with `TimeReference/None`, `followingMode="position"` and a
    /// `ClothoidSpline` that starts at the actor (story::Action::FollowTrajectory), given inline
    /// or from a `TrajectoryCatalog`; on a straight road.
    fn follow_spline(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let p = &self.ctx.params;
        let offset = p.num_attr(node, "initialDistanceOffset", file)?.unwrap_or(0.0);
        if offset != 0.0 && !self.start_trajectory {
            return Err(ImportError::at(file, node, "initialDistanceOffset other than 0 is not supported (but on an entity's start)"));
        }
        self.start_offset = offset;
        let (mut traj, mut timing, mut mode) = (None, None, None);
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "TrajectoryRef" => traj = Some(only_child(file, c)?),
                "Trajectory" | "CatalogReference" => traj = Some(c),
                "TimeReference" => timing = Some(only_child(file, c)?),
                "TrajectoryFollowingMode" => mode = Some(c),
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let traj = traj.ok_or_else(|| ImportError::at(file, node, "<TrajectoryRef> is missing"))?;
        let timing = timing.ok_or_else(|| ImportError::at(file, node, "<TimeReference> is missing"))?;
        if timing.tag_name().name() != "None" {
            return Err(ImportError::at(file, timing, "only <TimeReference><None/> is supported (the actor keeps its own speed)"));
        }
        let mode = mode.ok_or_else(|| ImportError::at(file, node, "<TrajectoryFollowingMode> is missing"))?;
        let m = self.ctx.params.req_enum(mode, "followingMode", file, &["position", "follow"])?;
        // A clothoid spline is smooth: "follow" moves the actor as "position" does.
        let _ = m;
        if !self.straight_track() {
            return Err(ImportError::at(file, node, "a trajectory on a curved road is not supported (flc lays it in the road's frame)"));
        }
        match traj.tag_name().name() {
            "Trajectory" => {
                self.ctx.params.push_scope();
                let r = self.ctx.params.declare_in(traj, file, &BTreeMap::new()).and_then(|()| self.trajectory(file, traj));
                self.ctx.params.pop_scope();
                r
            }
            "CatalogReference" => {
                let cats = self.ctx.cats;
                let catalog = self.ctx.params.req_str(traj, "catalogName", file)?;
                let entry = self.ctx.params.req_str(traj, "entryName", file)?;
                let (efile, enode) = match cats.find(&["TrajectoryCatalog"], &catalog, &entry)? {
                    Some(x) => x,
                    None => return Err(ImportError::at(file, traj, cats.not_found(&catalog, &entry))),
                };
                if enode.tag_name().name() != "Trajectory" {
                    return Err(ImportError::at(&efile, enode, "expected a <Trajectory> entry"));
                }
                self.ctx.enter_catalog(file, traj, &catalog, &entry)?;
                let overrides = super::catalog::assignments(&self.ctx.params, traj, file);
                let r = overrides.and_then(|o| {
                    self.ctx.params.push_scope();
                    let r = self.ctx.params.declare_in(enode, &efile, &o).and_then(|()| self.trajectory(&efile, enode));
                    self.ctx.params.pop_scope();
                    r
                });
                self.ctx.leave_catalog();
                r
            }
            _ => Err(ImportError::unsupported(file, traj)),
        }
    }

    /// `true` when the track has no curvature anywhere (a trajectory is laid in its frame).
    fn straight_track(&self) -> bool {
        let len = self.track.length();
        let n = (len / 0.5).ceil().clamp(1.0, 1.0e6) as usize;
        (0..=n).all(|k| self.track.curvature_at(len * k as f64 / n as f64).abs() < 1.0e-9)
    }

    /// A `Trajectory` element: an open `ClothoidSpline` whose first segment starts at the actor.
    fn trajectory(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let p = &self.ctx.params;
        if p.req_bool(node, "closed", file)? {
            return Err(ImportError::at(file, node, "closed=\"true\" is not supported"));
        }
        let mut shape = None;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "ParameterDeclarations" => {}
                "Shape" => shape = Some(only_child(file, c)?),
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let shape = shape.ok_or_else(|| ImportError::at(file, node, "<Shape> is missing"))?;
        if shape.tag_name().name() == "Polyline" && self.start_trajectory {
            return self.straight_polyline(file, shape);
        }
        if self.start_offset != 0.0 {
            return Err(ImportError::at(file, shape, "initialDistanceOffset other than 0 is not supported on a <ClothoidSpline>"));
        }
        if shape.tag_name().name() != "ClothoidSpline" {
            return Err(ImportError::at(
                file,
                shape,
                format!("<{}>: only a <ClothoidSpline> trajectory is supported", shape.tag_name().name()),
            ));
        }
        let mut segments = Vec::new();
        for g in xml::elements(shape) {
            if g.tag_name().name() != "ClothoidSplineSegment" {
                return Err(ImportError::unsupported(file, g));
            }
            if let Some(c) = xml::elements(g).next() {
                // esmini starts a segment there; flc lays the spline from the actor only: the
                // first segment's start is accepted where the entity was placed at it.
                if segments.is_empty() && self.start_trajectory && c.tag_name().name() == "PositionStart" && xml::elements(g).count() == 1 {
                    // fall through: the entity starts there.
                } else {
                    return Err(ImportError::at(file, c, "a segment's <PositionStart> is not supported (the spline starts at the actor)"));
                }
            }
            if p.num_attr(g, "hOffset", file)?.is_some_and(|h| h != 0.0) {
                return Err(ImportError::at(file, g, "hOffset other than 0 is not supported"));
            }
            p.num_attr(g, "timeStart", file)?;
            let seg = ClothoidSegment {
                curvature_start: p.req_num(g, "curvatureStart", file)?,
                curvature_end: p.req_num(g, "curvatureEnd", file)?,
                length: p.req_num(g, "length", file)?,
            };
            if segments.len() == 1000 {
                return Err(ImportError::at(file, g, "more than 1000 segments"));
            }
            segments.push(seg);
        }
        p.num_attr(shape, "timeEnd", file)?;
        let a = Action::FollowTrajectory { segments };
        a.validate().map_err(|e| ImportError::at(file, shape, e.to_string()))?;
        Ok(a)
    }

    /// An untimed `Polyline` an entity starts on (placed `initialDistanceOffset` along it,
    /// facing along it): on a straight polyline (its vertices in one line, one direction) the
    /// actor moves on along it at its own speed, a straight spline of the rest of its length.
    /// A polyline with corners: error.
    fn straight_polyline(&mut self, file: &str, shape: Node<'_, '_>) -> Result<Action, ImportError> {
        let mut poses = Vec::new();
        for v in xml::elements(shape) {
            if poses.len() == 10_000 {
                return Err(ImportError::at(file, v, "more than 10000 vertices"));
            }
            if self.ctx.params.num_attr(v, "time", file)?.is_some() {
                return Err(ImportError::at(file, v, "a vertex time without <Timing> is not supported"));
            }
            let p = xml::child(v, "Position").ok_or_else(|| ImportError::at(file, v, "<Position> is missing"))?;
            poses.push(position::resolve(&self.ctx.params, self.geo, file, p, &|_| None)?);
        }
        let mut length = 0.0;
        let mut heading: Option<f64> = None;
        for w in poses.windows(2) {
            let (dx, dy) = (w[1].x - w[0].x, w[1].y - w[0].y);
            let len = dx.hypot(dy);
            if len == 0.0 {
                continue;
            }
            let h = dy.atan2(dx);
            if heading.is_some_and(|h0| crate::track::wrap(h - h0).abs() > 1.0e-9) {
                return Err(ImportError::at(file, shape, "an untimed <Polyline> with corners is not supported (only a straight one)"));
            }
            heading = Some(h);
            length += len;
        }
        let rest = length - self.start_offset;
        if heading.is_none() || rest <= 0.0 {
            return Err(ImportError::at(file, shape, format!("nothing of the polyline ({length} m) is left past initialDistanceOffset")));
        }
        let a = Action::FollowTrajectory { segments: vec![ClothoidSegment { curvature_start: 0.0, curvature_end: 0.0, length: rest }] };
        a.validate().map_err(|e| ImportError::at(file, shape, e.to_string()))?;
        Ok(a)
    }

    /// `SynchronizeAction` (esmini's algorithm, `story::Action::Synchronize`): absolute target
    /// positions, an `AbsoluteSpeed` final speed with an optional steady state, tolerances.
    fn synchronize(&mut self, file: &str, node: Node<'_, '_>) -> Result<Action, ImportError> {
        let master = self.entity(file, node, "masterEntityRef")?;
        let p = &self.ctx.params;
        let tolerance = p.num_attr(node, "targetTolerance", file)?.unwrap_or(0.0);
        let tolerance_master = p.num_attr(node, "targetToleranceMaster", file)?.unwrap_or(0.0);
        let (mut master_target, mut target, mut final_speed, mut steady_time, mut steady_distance) = (None, None, None, None, None);
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "TargetPositionMaster" => master_target = Some(self.target_s(file, c)?),
                "TargetPosition" => target = Some(self.target_s(file, c)?),
                "FinalSpeed" => {
                    let a = only_child(file, c)?;
                    if a.tag_name().name() != "AbsoluteSpeed" {
                        return Err(ImportError::unsupported(file, a));
                    }
                    final_speed = Some(self.ctx.params.req_num(a, "value", file)?);
                    for ss in xml::elements(a) {
                        match ss.tag_name().name() {
                            "TargetTimeSteadyState" => steady_time = Some(self.ctx.params.req_num(ss, "time", file)?),
                            "TargetDistanceSteadyState" => steady_distance = Some(self.ctx.params.req_num(ss, "distance", file)?),
                            _ => return Err(ImportError::unsupported(file, ss)),
                        }
                    }
                }
                _ => return Err(ImportError::unsupported(file, c)),
            }
        }
        let (Some((ms, mdir, master_point)), Some((ts, _, _))) = (master_target, target) else {
            return Err(ImportError::at(file, node, "give <TargetPositionMaster> and <TargetPosition>"));
        };
        // The master is measured by its box centre (`s` of the world view): its target moves by
        // the centre's offset along the direction the target faces.
        let master_target = ms + mdir * self.facts(&master).center[0];
        Ok(Action::Synchronize {
            master,
            master_target,
            master_point,
            target: ts,
            final_speed,
            steady_time,
            steady_distance,
            tolerance,
            tolerance_master,
        })
    }

    /// The track `s` of an absolute target position (a `TargetPosition...` element holding one
    /// position), the direction it faces along the track (+1 or -1), and for a position on a
    /// trajectory (`TrajectoryPosition`) the point `[s, offset]` itself.
    fn target_s(&mut self, file: &str, holder: Node<'_, '_>) -> Result<(f64, f64, Option<[f64; 2]>), ImportError> {
        if let Some(tp) = xml::child(holder, "TrajectoryPosition") {
            let pose = self.trajectory_position(file, tp)?;
            let pr = self.track.project(pose.x, pose.y);
            return Ok((pr.s, if (pose.h - pr.heading).cos() < 0.0 { -1.0 } else { 1.0 }, Some([pr.s, pr.lateral_offset])));
        }
        if position::reference(&self.ctx.params, file, holder)?.is_some() {
            return Err(ImportError::at(
                file,
                holder,
                "a target position relative to an entity is not supported (it moves with the entity)",
            ));
        }
        let pose = position::resolve(&self.ctx.params, self.geo, file, holder, &|_| None)?;
        let pr = self.track.project(pose.x, pose.y);
        Ok((pr.s, if (pose.h - pr.heading).cos() < 0.0 { -1.0 } else { 1.0 }, None))
    }

    /// The world pose of a `TrajectoryPosition` (`s` m along its trajectory, `t` 0): on a
    /// `Polyline` through its vertices, on a `ClothoidSpline` from its first segment's
    /// `PositionStart` (esmini's polyline of the spline, as the actor moves along it).
    fn trajectory_position(&mut self, file: &str, node: Node<'_, '_>) -> Result<position::Pose, ImportError> {
        let s = self.ctx.params.req_num(node, "s", file)?;
        if !s.is_finite() || s < 0.0 {
            return Err(ImportError::at(file, node, format!("s = {s}: expected a finite distance >= 0")));
        }
        if self.ctx.params.num_attr(node, "t", file)?.is_some_and(|t| t != 0.0) {
            return Err(ImportError::at(file, node, "t other than 0 is not supported"));
        }
        let r = xml::child(node, "TrajectoryRef").ok_or_else(|| ImportError::at(file, node, "<TrajectoryRef> is missing"))?;
        let traj = only_child(file, r)?;
        let geo = self.geo;
        let run = |sb: &mut Self, file: &str, traj: Node<'_, '_>| -> Result<position::Pose, ImportError> {
            let shape = xml::child(traj, "Shape").and_then(|x| xml::elements(x).next());
            let shape = shape.ok_or_else(|| ImportError::at(file, traj, "<Shape> is missing"))?;
            let points: Vec<Node<'_, '_>> = match shape.tag_name().name() {
                "Polyline" => xml::elements(shape).filter_map(|v| xml::child(v, "Position")).take(10_001).collect(),
                "ClothoidSpline" => xml::elements(shape).next().and_then(|g| xml::child(g, "PositionStart")).into_iter().collect(),
                _ => Vec::new(),
            };
            if points.is_empty() || points.len() > 10_000 {
                return Err(ImportError::at(
                    file,
                    shape,
                    "a TrajectoryPosition needs a <Polyline> of 1 to 10000 vertices or a <ClothoidSpline> whose first segment has a <PositionStart>",
                ));
            }
            let mut poses = Vec::with_capacity(points.len());
            for p in &points {
                if position::reference(&sb.ctx.params, file, *p)?.is_some() {
                    return Err(ImportError::at(file, *p, "a trajectory relative to an entity is not supported here"));
                }
                poses.push(position::resolve(&sb.ctx.params, geo, file, *p, &|_| None)?);
            }
            let beyond = || ImportError::at(file, node, format!("s = {s} m is beyond the trajectory's end"));
            if shape.tag_name().name() == "Polyline" {
                return along_polyline(&poses, s).ok_or_else(beyond);
            }
            let was = (sb.start_trajectory, sb.start_offset);
            (sb.start_trajectory, sb.start_offset) = (true, 0.0);
            let a = sb.trajectory(file, traj);
            (sb.start_trajectory, sb.start_offset) = was;
            let Action::FollowTrajectory { segments } = a? else { return Err(ImportError::at(file, traj, "expected a <ClothoidSpline>")) };
            if s > segments.iter().map(|g| g.length).sum::<f64>() + 1.0e-9 {
                return Err(beyond());
            }
            let [x, y, h] = crate::story::spline_pose(&segments, s);
            let o = poses[0];
            let (c, sn) = (o.h.cos(), o.h.sin());
            Ok(position::Pose { x: o.x + x * c - y * sn, y: o.y + x * sn + y * c, h: o.h + h })
        };
        match traj.tag_name().name() {
            "Trajectory" => {
                self.ctx.params.push_scope();
                let r = self.ctx.params.declare_in(traj, file, &BTreeMap::new()).and_then(|()| run(self, file, traj));
                self.ctx.params.pop_scope();
                r
            }
            "CatalogReference" => {
                let cats = self.ctx.cats;
                let catalog = self.ctx.params.req_str(traj, "catalogName", file)?;
                let entry = self.ctx.params.req_str(traj, "entryName", file)?;
                let (efile, enode) = match cats.find(&["TrajectoryCatalog"], &catalog, &entry)? {
                    Some(x) => x,
                    None => return Err(ImportError::at(file, traj, cats.not_found(&catalog, &entry))),
                };
                if enode.tag_name().name() != "Trajectory" {
                    return Err(ImportError::at(&efile, enode, "expected a <Trajectory> entry"));
                }
                self.ctx.enter_catalog(file, traj, &catalog, &entry)?;
                let overrides = super::catalog::assignments(&self.ctx.params, traj, file);
                let r = overrides.and_then(|o| {
                    self.ctx.params.push_scope();
                    let r = self.ctx.params.declare_in(enode, &efile, &o).and_then(|()| run(self, &efile, enode));
                    self.ctx.params.pop_scope();
                    r
                });
                self.ctx.leave_catalog();
                r
            }
            _ => Err(ImportError::unsupported(file, traj)),
        }
    }

    /// The track position `(s, lateral)` of an absolute `Position` (a relative one is an error:
    /// its reference moves).
    fn track_position(&mut self, file: &str, position: Node<'_, '_>) -> Result<(f64, f64), ImportError> {
        if position::reference(&self.ctx.params, file, position)?.is_some() {
            let inner = position::inner(file, position)?;
            return Err(ImportError::at(
                file,
                inner,
                "a position relative to an entity is not supported in a condition (it moves with the entity)",
            ));
        }
        let pose = position::resolve(&self.ctx.params, self.geo, file, position, &|_| None)?;
        let pr = self.track.project(pose.x, pose.y);
        Ok((pr.s, pr.lateral_offset))
    }

    /// The track position and heading relative to the track `(s, lateral, heading)` of an
    /// absolute `Position` (a relative one is an error: its reference moves).
    fn track_pose(&mut self, file: &str, position: Node<'_, '_>) -> Result<(f64, f64, f64), ImportError> {
        let (s, lateral) = self.track_position(file, position)?;
        let pose = position::resolve(&self.ctx.params, self.geo, file, position, &|_| None)?;
        let pr = self.track.project(pose.x, pose.y);
        Ok((s, lateral, crate::track::wrap(pose.h - pr.heading)))
    }

    fn entity_condition(&mut self, file: &str, node: Node<'_, '_>, entity: &str) -> Result<ConditionKind, ImportError> {
        let entity = entity.to_string();
        let position = |sb: &mut Self| -> Result<(f64, f64), ImportError> {
            let pos = xml::child(node, "Position").ok_or_else(|| ImportError::at(file, node, "<Position> is missing"))?;
            for c in xml::elements(node) {
                if c.tag_name().name() != "Position" {
                    return Err(ImportError::unsupported(file, c));
                }
            }
            sb.track_position(file, pos)
        };
        match node.tag_name().name() {
            "SpeedCondition" => {
                self.longitudinal_only(file, node)?;
                let value = self.ctx.params.req_num(node, "value", file)?;
                Ok(ConditionKind::Speed { entity, value, rule: self.rule(file, node)?, tolerance: None })
            }
            "AccelerationCondition" => {
                self.longitudinal_only(file, node)?;
                let value = self.ctx.params.req_num(node, "value", file)?;
                Ok(ConditionKind::Acceleration { entity, value, rule: self.rule(file, node)?, tolerance: None })
            }
            "RelativeSpeedCondition" => {
                self.longitudinal_only(file, node)?;
                let of = self.entity(file, node, "entityRef")?;
                let value = self.ctx.params.req_num(node, "value", file)?;
                Ok(ConditionKind::RelativeSpeed { entity, of, value, rule: self.rule(file, node)?, tolerance: None })
            }
            "StandStillCondition" => Ok(ConditionKind::StandStill { entity, duration: self.ctx.params.req_num(node, "duration", file)? }),
            "TraveledDistanceCondition" => {
                Ok(ConditionKind::TraveledDistance { entity, value: self.ctx.params.req_num(node, "value", file)? })
            }
            "RelativeDistanceCondition" => {
                let of = self.entity(file, node, "entityRef")?;
                let distance = self.distance_type(file, node, None)?;
                self.coordinate_system(file, node, false)?;
                let freespace = self.ctx.params.req_bool(node, "freespace", file)?;
                if !freespace {
                    self.centre_note(file, node, &entity, &of);
                }
                let value = self.ctx.params.req_num(node, "value", file)?;
                Ok(ConditionKind::RelativeDistance {
                    entity,
                    of,
                    distance,
                    freespace,
                    value,
                    rule: self.rule(file, node)?,
                    tolerance: None,
                })
            }
            "TimeHeadwayCondition" => {
                let of = self.entity(file, node, "entityRef")?;
                // esmini's default measure: the (box) Euclidean distance.
                let distance = self.distance_type(file, node, Some(DistanceType::Euclidean))?;
                let (freespace, value, rule) = self.time_measure(file, node, (&entity, &of), "a time headway", distance)?;
                Ok(ConditionKind::TimeHeadway { entity, of, freespace, distance, value, rule, tolerance: None })
            }
            "TimeToCollisionCondition" => {
                let target = xml::child(node, "TimeToCollisionConditionTarget")
                    .ok_or_else(|| ImportError::at(file, node, "<TimeToCollisionConditionTarget> is missing"))?;
                let mut it = xml::elements(target);
                let (Some(x), None) = (it.next(), it.next()) else {
                    return Err(ImportError::at(file, target, "a <TimeToCollisionConditionTarget> holds one target"));
                };
                if x.tag_name().name() != "EntityRef" {
                    return Err(ImportError::unsupported(file, x));
                }
                let of = self.entity(file, x, "entityRef")?;
                let (freespace, value, rule) = self.longitudinal_time(file, node, (&entity, &of), "a time to collision")?;
                Ok(ConditionKind::Ttc { entity, of, freespace, value, rule, tolerance: None })
            }
            "ReachPositionCondition" => {
                let tolerance = self.ctx.params.req_num(node, "tolerance", file)?;
                let (s, lateral) = position(self)?;
                // The condition is on the reference point; flc measures the box centre.
                let c = self.facts(&entity).center;
                Ok(ConditionKind::ReachPosition { entity, s: s + c[0], lateral: Some(lateral + c[1]), tolerance })
            }
            "DistanceCondition" => {
                self.along_route(file, node)?;
                self.coordinate_system(file, node, false)?;
                let distance = self.distance_type(file, node, Some(DistanceType::Euclidean))?;
                let freespace = self.ctx.params.req_bool(node, "freespace", file)?;
                let value = self.ctx.params.req_num(node, "value", file)?;
                let rule = self.rule(file, node)?;
                let (mut s, mut lateral) = position(self)?;
                if !freespace {
                    let c = self.facts(&entity).center;
                    s += c[0];
                    lateral += c[1];
                }
                Ok(ConditionKind::Distance { entity, s, lateral, distance, freespace, value, rule, tolerance: None })
            }
            "CollisionCondition" => {
                let mut it = xml::elements(node);
                let (Some(x), None) = (it.next(), it.next()) else {
                    return Err(ImportError::at(file, node, "a <CollisionCondition> holds EntityRef or ByType"));
                };
                match x.tag_name().name() {
                    "EntityRef" => Ok(ConditionKind::Collision { entity, with: Some(self.entity(file, x, "entityRef")?) }),
                    "ByType" => {
                        let key = "ByType".to_string();
                        self.ctx.warn.note(&key, file, x, "a collision with an object of a type: with anything".into());
                        Ok(ConditionKind::Collision { entity, with: None })
                    }
                    _ => Err(ImportError::unsupported(file, x)),
                }
            }
            _ => Err(ImportError::unsupported(file, node)),
        }
    }
}
