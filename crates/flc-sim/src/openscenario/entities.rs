//! `Entities`: `ScenarioObject`s with a `Vehicle`, a `Pedestrian`, a `MiscObject` or a
//! `CatalogReference` to one, their `ObjectController`; the choice of the ego and the lead and the names the
//! entities get in the scenario.

use super::Ctx;
use super::error::ImportError;
use super::xml;
use crate::controllers::ControllerKind;
use crate::vehicle::{BodyKind, PEDESTRIAN_BOX, PEDESTRIAN_MASS, VehicleParams};

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// Most entities in one scenario.
pub const MAX_ENTITIES: usize = 256;

/// What an entity is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A `Vehicle`: it may move.
    Vehicle,
    /// A `MiscObject`: it stands.
    Misc,
    /// A `Pedestrian`: a small box the story moves kinematically.
    Pedestrian,
}

/// One `ScenarioObject`, read.
#[derive(Debug, Clone, PartialEq)]
pub struct EntityDef {
    /// Its OpenSCENARIO name.
    pub osc_name: String,
    /// Vehicle or object.
    pub kind: Kind,
    /// Its vehicle parameters (bounding box length and width, performance, wheelbase, mass).
    pub vehicle: VehicleParams,
    /// `BoundingBox/Center` x, y: the box centre in the entity's frame, from its reference point.
    pub center: [f64; 2],
    /// Its `Performance` `[maxAcceleration, maxDeceleration]`, m/s², when both are given and
    /// used (they limit its speed changes).
    pub performance: Option<[f64; 2]>,
    /// The flc controller its `ObjectController` names, if any.
    pub controller: Option<ControllerKind>,
    /// Where it is declared.
    pub file: String,
    /// Its line.
    pub line: u32,
}

/// The flc controller called `name` (case-insensitive), if any.
pub fn flc_controller(name: &str) -> Option<ControllerKind> {
    ControllerKind::ALL.iter().copied().find(|k| k.as_str().eq_ignore_ascii_case(name.trim()))
}

impl Ctx<'_, '_> {
    /// Reads every `ScenarioObject` of `entities` (of `file`); more than [`MAX_ENTITIES`] is an
    /// error before any is read.
    pub(super) fn read_entities(&mut self, file: &str, entities: Node<'_, '_>) -> Result<Vec<EntityDef>, ImportError> {
        let n = xml::elements(entities).count();
        if n > MAX_ENTITIES {
            return Err(ImportError::at(file, entities, format!("{n} entities, more than the limit of {MAX_ENTITIES}")));
        }
        let mut out: Vec<EntityDef> = Vec::new();
        for so in xml::elements(entities) {
            if so.tag_name().name() != "ScenarioObject" {
                return Err(ImportError::unsupported(file, so));
            }
            let name = self.params.req_str(so, "name", file)?;
            if name.trim().is_empty() {
                return Err(ImportError::at(file, so, "an entity needs a name"));
            }
            if out.iter().any(|d| d.osc_name == name) {
                return Err(ImportError::at(file, so, format!("entity `{name}` declared twice")));
            }
            let mut object: Option<(Kind, VehicleParams, [f64; 2])> = None;
            let mut controller = None;
            for c in xml::elements(so) {
                match c.tag_name().name() {
                    "Vehicle" | "Pedestrian" | "MiscObject" | "CatalogReference" => {
                        if object.is_some() {
                            return Err(ImportError::at(file, c, "a ScenarioObject holds one entity object"));
                        }
                        self.performance = None;
                        object = Some(self.entity_object(file, c)?);
                    }
                    "ObjectController" => {
                        if let Some(k) = self.object_controller(file, c)? {
                            controller = Some(k);
                        }
                    }
                    _ => return Err(ImportError::unsupported(file, c)),
                }
            }
            let (kind, vehicle, center) =
                object.ok_or_else(|| ImportError::at(file, so, format!("entity `{name}` has no Vehicle, Pedestrian or MiscObject")))?;
            let performance = self.performance.take();
            out.push(EntityDef {
                osc_name: name,
                kind,
                vehicle,
                center,
                performance,
                controller,
                file: file.to_string(),
                line: xml::line(so),
            });
        }
        Ok(out)
    }

    /// A `Vehicle`, `Pedestrian`, `MiscObject` or `CatalogReference` to one.
    fn entity_object(&mut self, file: &str, node: Node<'_, '_>) -> Result<(Kind, VehicleParams, [f64; 2]), ImportError> {
        match node.tag_name().name() {
            "CatalogReference" => {
                self.catalog_entry(file, node, &["VehicleCatalog", "PedestrianCatalog", "MiscObjectCatalog"], |ctx, efile, entry| {
                    match entry.tag_name().name() {
                        "Vehicle" => ctx.vehicle(efile, entry),
                        "Pedestrian" => ctx.pedestrian(efile, entry),
                        "MiscObject" => ctx.misc_object(efile, entry),
                        _ => Err(ImportError::unsupported(efile, entry)),
                    }
                })
            }
            name => {
                // Inline objects may declare their own parameters.
                self.params.push_scope();
                let r = self.params.declare_in(node, file, &Default::default()).and_then(|()| match name {
                    "Vehicle" => self.vehicle(file, node),
                    "Pedestrian" => self.pedestrian(file, node),
                    _ => self.misc_object(file, node),
                });
                self.params.pop_scope();
                r
            }
        }
    }

    /// `BoundingBox`: the centre (x, y) and (length, width), within flc's ranges for a vehicle
    /// or object (`pedestrian` false) or a pedestrian.
    fn bounding_box(&mut self, file: &str, node: Node<'_, '_>, pedestrian: bool) -> Result<([f64; 2], f64, f64), ImportError> {
        let center = xml::child(node, "Center").ok_or_else(|| ImportError::at(file, node, "<Center> is missing"))?;
        let dims = xml::child(node, "Dimensions").ok_or_else(|| ImportError::at(file, node, "<Dimensions> is missing"))?;
        for c in xml::elements(node) {
            if !matches!(c.tag_name().name(), "Center" | "Dimensions") {
                self.other(file, c)?;
            }
        }
        let cx = self.params.req_num(center, "x", file)?;
        let cy = self.params.req_num(center, "y", file)?;
        // Not used in 2-D, but numbers (NaN and infinities are errors).
        self.params.req_num(center, "z", file)?;
        self.params.req_num(dims, "height", file)?;
        let length = self.params.req_num(dims, "length", file)?;
        let width = self.params.req_num(dims, "width", file)?;
        if pedestrian {
            let (lo, hi) = PEDESTRIAN_BOX;
            if !(lo..=hi).contains(&length) || !(lo..=hi).contains(&width) {
                return Err(ImportError::at(
                    file,
                    dims,
                    format!("a {length} x {width} m box is outside the simulator's pedestrian range (length and width {lo}-{hi} m)"),
                ));
            }
        } else if !(1.0..=25.0).contains(&length) || !(0.5..=3.0).contains(&width) {
            return Err(ImportError::at(
                file,
                dims,
                format!("a {length} x {width} m box is outside the simulator's vehicle range (length 1-25 m, width 0.5-3 m)"),
            ));
        }
        if cx.abs() > 50.0 || cy.abs() > 50.0 {
            return Err(ImportError::at(file, center, format!("the box centre ({cx}, {cy}) m is more than 50 m from the reference point")));
        }
        Ok(([cx, cy], length, width))
    }

    fn mass(&mut self, file: &str, node: Node<'_, '_>, v: &mut VehicleParams) -> Result<(), ImportError> {
        let (lo, hi) = match v.body {
            BodyKind::Vehicle => (100.0, 60_000.0),
            BodyKind::Pedestrian => PEDESTRIAN_MASS,
        };
        if let Some(m) = self.params.num_attr(node, "mass", file)? {
            if (lo..=hi).contains(&m) {
                v.mass = m;
            } else {
                self.warn.note("mass", file, node, format!("mass {m} kg outside [{lo}, {hi}] kg: the default {} kg is used", v.mass));
            }
        }
        Ok(())
    }

    /// The box centre and the vehicle parameters a `Vehicle` or `MiscObject` gets from its
    /// `BoundingBox` and `mass` (wheelbase 0.6 length until `Axles` say otherwise).
    fn boxed(&mut self, file: &str, node: Node<'_, '_>, body: BodyKind) -> Result<([f64; 2], VehicleParams), ImportError> {
        let bb = xml::child(node, "BoundingBox").ok_or_else(|| ImportError::at(file, node, "<BoundingBox> is missing"))?;
        let pedestrian = body == BodyKind::Pedestrian;
        let (center, length, width) = self.bounding_box(file, bb, pedestrian)?;
        let mut v = VehicleParams { body, length, width, ..VehicleParams::default() };
        if pedestrian {
            // Within the pedestrian mass range; a pedestrian moves kinematically (no vehicle model).
            v.mass = 75.0;
            v.wheelbase = 0.5 * length;
        } else {
            v.wheelbase = (0.6 * length).clamp(0.5, length);
        }
        self.mass(file, node, &mut v)?;
        Ok((center, v))
    }

    /// A `Vehicle` element (parameters already in scope).
    fn vehicle(&mut self, file: &str, node: Node<'_, '_>) -> Result<(Kind, VehicleParams, [f64; 2]), ImportError> {
        let (center, mut v) = self.boxed(file, node, BodyKind::Vehicle)?;
        let length = v.length;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "ParameterDeclarations" | "BoundingBox" => {}
                "Performance" => self.performance(file, c, &mut v)?,
                "Axles" => {
                    // Every axle's numbers are checked (finite), though only positionX is used.
                    for axle in xml::elements(c) {
                        if !matches!(axle.tag_name().name(), "FrontAxle" | "RearAxle" | "AdditionalAxle") {
                            return Err(ImportError::unsupported(file, axle));
                        }
                        for a in ["maxSteering", "wheelDiameter", "trackWidth", "positionX", "positionZ"] {
                            self.params.req_num(axle, a, file)?;
                        }
                    }
                    let x = |name: &str| -> Result<Option<f64>, ImportError> {
                        match xml::child(c, name) {
                            Some(a) => self.params.num_attr(a, "positionX", file),
                            None => Ok(None),
                        }
                    };
                    if let (Some(f), Some(r)) = (x("FrontAxle")?, x("RearAxle")?) {
                        let wb = f - r;
                        if wb >= 0.5 && wb <= length {
                            v.wheelbase = wb;
                        } else {
                            self.warn.note(
                                "Axles",
                                file,
                                c,
                                format!("wheelbase {wb} m outside [0.5, length] m: {} m is used", v.wheelbase),
                            );
                        }
                    }
                }
                "TrailerHitch" | "TrailerCoupler" => {
                    // Where a trailer would attach: nothing to attach without a trailer.
                    self.params.num_attr(c, "dx", file)?;
                    self.warn.note(c.tag_name().name(), file, c, "ignored (flc has no trailers; no trailer is attached)".into());
                }
                "Trailer" => self.trailer(file, c)?,
                _ => self.other(file, c)?,
            }
        }
        Ok((Kind::Vehicle, v, center))
    }

    /// `Trailer`: an empty `TrailerRef` (esmini's vehicle catalog: `$TrailerRef` = "") attaches
    /// nothing and is ignored with a warning; an actual trailer is not supported.
    fn trailer(&mut self, file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
        for c in xml::elements(node) {
            let empty =
                c.tag_name().name() == "TrailerRef" && self.params.str_attr(c, "entityRef", file)?.unwrap_or_default().trim().is_empty();
            if !empty {
                return Err(ImportError::at(file, c, "a trailer is not supported (only an empty TrailerRef)"));
            }
        }
        self.warn.note("Trailer", file, node, "an empty trailer reference: no trailer (ignored)".into());
        Ok(())
    }

    /// `Performance`: `maxDeceleration` -> `max_brake`, `maxAcceleration` -> `max_accel` when in
    /// their ranges (both used: they limit the story's speed changes, `story.limits`);
    /// `maxSpeed` is not used.
    fn performance(&mut self, file: &str, node: Node<'_, '_>, v: &mut VehicleParams) -> Result<(), ImportError> {
        let mut used = [None, None];
        if let Some(d) = self.params.num_attr(node, "maxDeceleration", file)? {
            if (0.5..=15.0).contains(&d) {
                v.max_brake = d;
                used[1] = Some(d);
            } else {
                self.warn.note(
                    "Performance@maxDeceleration",
                    file,
                    node,
                    format!("{d} m/s² outside [0.5, 15]: the default {} m/s² is used", v.max_brake),
                );
            }
        }
        if let Some(a) = self.params.num_attr(node, "maxAcceleration", file)? {
            if (0.1..=15.0).contains(&a) {
                v.max_accel = a;
                used[0] = Some(a);
            } else {
                self.warn.note(
                    "Performance@maxAcceleration",
                    file,
                    node,
                    format!("{a} m/s² outside [0.1, 15]: the default {} m/s² is used", v.max_accel),
                );
            }
        }
        if let [Some(a), Some(d)] = used {
            self.performance = Some([a, d]);
        }
        if node.attribute("maxSpeed").is_some() {
            self.params.num_attr(node, "maxSpeed", file)?;
            self.warn.note(
                "Performance@maxSpeed",
                file,
                node,
                "not used (speeds are the story's; flc's controllers have their own limits)".to_string(),
            );
        }
        Ok(())
    }

    /// A `Pedestrian` element (parameters already in scope): its box and mass; `model3d`,
    /// `pedestrianCategory`, `role` and `Properties` change neither motion nor sensing.
    fn pedestrian(&mut self, file: &str, node: Node<'_, '_>) -> Result<(Kind, VehicleParams, [f64; 2]), ImportError> {
        let (center, v) = self.boxed(file, node, BodyKind::Pedestrian)?;
        self.params.req_enum(node, "pedestrianCategory", file, &["pedestrian", "wheelchair", "animal"])?;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "ParameterDeclarations" | "BoundingBox" => {}
                _ => self.other(file, c)?,
            }
        }
        Ok((Kind::Pedestrian, v, center))
    }

    /// A `MiscObject` element (parameters already in scope): a standing object.
    fn misc_object(&mut self, file: &str, node: Node<'_, '_>) -> Result<(Kind, VehicleParams, [f64; 2]), ImportError> {
        let (center, v) = self.boxed(file, node, BodyKind::Vehicle)?;
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "ParameterDeclarations" | "BoundingBox" => {}
                _ => self.other(file, c)?,
            }
        }
        Ok((Kind::Misc, v, center))
    }

    /// An `ObjectController` (inline `Controller` or `CatalogReference`): the flc controller
    /// its name or one of its `Property` values names.
    fn object_controller(&mut self, file: &str, node: Node<'_, '_>) -> Result<Option<ControllerKind>, ImportError> {
        let mut found = None;
        for c in xml::elements(node) {
            let k = self.controller_element(file, c)?;
            found = found.or(k);
        }
        Ok(found)
    }

    /// A `Controller` or a `CatalogReference` to one: the flc controller it names, if any.
    pub(super) fn controller_element(&mut self, file: &str, c: Node<'_, '_>) -> Result<Option<ControllerKind>, ImportError> {
        match c.tag_name().name() {
            "Controller" => {
                self.params.push_scope();
                let r = self.params.declare_in(c, file, &Default::default()).and_then(|()| self.controller(file, c));
                self.params.pop_scope();
                r
            }
            "CatalogReference" => self.catalog_entry(file, c, &["ControllerCatalog"], |ctx, efile, entry| {
                if entry.tag_name().name() != "Controller" {
                    return Err(ImportError::at(efile, entry, "expected a <Controller> entry"));
                }
                ctx.controller(efile, entry)
            }),
            _ => Err(ImportError::unsupported(file, c)),
        }
    }

    /// A `Controller` element (parameters in scope).
    fn controller(&mut self, file: &str, node: Node<'_, '_>) -> Result<Option<ControllerKind>, ImportError> {
        let name = self.params.str_attr(node, "name", file)?.unwrap_or_default();
        let mut found = flc_controller(&name);
        for c in xml::elements(node) {
            match c.tag_name().name() {
                "ParameterDeclarations" => {}
                "Properties" => {
                    for p in xml::elements(c) {
                        match p.tag_name().name() {
                            "Property" => {
                                let value = self.params.req_str(p, "value", file)?;
                                if found.is_none() {
                                    found = flc_controller(&value);
                                }
                            }
                            _ => self.other(file, p)?,
                        }
                    }
                }
                _ => self.other(file, c)?,
            }
        }
        match found {
            Some(k) => {
                self.warn.note(
                    "Controller",
                    file,
                    node,
                    format!("`{name}` selects flc's `{}` controller; its other properties are not mapped", k.as_str()),
                );
            }
            None => {
                self.warn.note("Controller", file, node, format!("`{name}` names no flc controller: not used"));
            }
        }
        Ok(found)
    }
}

/// The ego: the entity named `want` (`--ego`), else one named `Ego` or `ego`, else the first.
pub fn choose_ego(defs: &[EntityDef], want: Option<&str>) -> Result<usize, String> {
    let names = || defs.iter().map(|d| d.osc_name.as_str()).collect::<Vec<_>>().join(", ");
    let i = match want {
        Some(w) => {
            defs.iter().position(|d| d.osc_name == w).ok_or_else(|| format!("no entity `{w}` to be the ego (entities: {})", names()))?
        }
        None => defs
            .iter()
            .position(|d| d.osc_name == "Ego")
            .or_else(|| defs.iter().position(|d| d.osc_name == "ego"))
            .ok_or_else(|| "the scenario has no entities".to_string())
            .or_else(|e| if defs.is_empty() { Err(e) } else { Ok(0) })?,
    };
    match defs.get(i) {
        Some(d) if d.kind == Kind::Vehicle => Ok(i),
        Some(d) => Err(format!(
            "the ego `{}` is a {}: the ego must be a Vehicle",
            d.osc_name,
            if d.kind == Kind::Pedestrian { "Pedestrian" } else { "MiscObject" }
        )),
        None => Err("the scenario has no entities".into()),
    }
}

/// Where an entity starts on the track: its box centre's `s` and lateral offset from the
/// centreline (m) and its heading relative to the road (rad).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Placement {
    /// Along the centreline, m.
    pub s: f64,
    /// From the centreline, m, + left.
    pub lateral: f64,
    /// Relative to the road, rad.
    pub heading: f64,
}

/// The lead: the nearest Vehicle ahead of the ego whose centre is within half a lane width of
/// the ego lane's centre, else the first other Vehicle, else the first other entity (a
/// Pedestrian or a MiscObject).
pub fn choose_lead(defs: &[EntityDef], placed: &[Placement], ego: usize, lane_width: f64) -> Option<usize> {
    let ego_s = placed.get(ego)?.s;
    let others = || (0..defs.len()).filter(move |&i| i != ego);
    let vehicle = |i: &usize| defs.get(*i).is_some_and(|d| d.kind == Kind::Vehicle);
    others()
        .filter(vehicle)
        .filter_map(|i| placed.get(i).map(|p| (i, p)))
        .filter(|(_, p)| p.s > ego_s && p.lateral.abs() < 0.5 * lane_width)
        .min_by(|a, b| a.1.s.total_cmp(&b.1.s).then(a.0.cmp(&b.0)))
        .map(|(i, _)| i)
        .or_else(|| others().find(vehicle))
        .or_else(|| others().next())
}

/// Whether a scripted vehicle may not be called `name` in the scenario.
pub fn reserved(name: &str) -> bool {
    name.trim().is_empty() || name == "lead" || name == crate::scenario::EGO || name.starts_with("follower")
}

/// The scenario names of the entities: `ego`, `lead`, and the OpenSCENARIO name for the others
/// (a reserved or taken name gets a `_osc` suffix, a `follower...` name an `osc_` prefix).
pub fn flc_names(defs: &[EntityDef], ego: usize, lead: usize) -> Vec<String> {
    let mut used: Vec<String> = vec![crate::scenario::EGO.to_string(), "lead".to_string()];
    let mut out = Vec::with_capacity(defs.len());
    for (i, d) in defs.iter().enumerate() {
        let name = if i == ego {
            crate::scenario::EGO.to_string()
        } else if i == lead {
            "lead".to_string()
        } else {
            let mut n = d.osc_name.clone();
            if n.starts_with("follower") {
                n = format!("osc_{n}");
            }
            while reserved(&n) || used.contains(&n) {
                n.push_str("_osc");
            }
            used.push(n.clone());
            n
        };
        out.push(name);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn def(name: &str, kind: Kind) -> EntityDef {
        EntityDef {
            osc_name: name.into(),
            kind,
            vehicle: VehicleParams::default(),
            center: [1.4, 0.0],
            performance: None,
            controller: None,
            file: String::new(),
            line: 0,
        }
    }

    #[test]
    fn ego_lead_and_names() {
        let defs = vec![
            def("A", Kind::Vehicle),
            def("Ego", Kind::Vehicle),
            def("lead", Kind::Vehicle),
            def("Obj", Kind::Misc),
            def("follower2", Kind::Vehicle),
        ];
        assert_eq!(choose_ego(&defs, None), Ok(1));
        assert_eq!(choose_ego(&defs, Some("A")), Ok(0));
        assert!(choose_ego(&defs, Some("Obj")).is_err());
        assert!(choose_ego(&defs, Some("zz")).err().unwrap_or_default().contains("zz"));
        let p = |s: f64, lateral: f64| Placement { s, lateral, heading: 0.0 };
        // A is ahead in the ego lane but `lead` is nearer; the object is nearest but not a vehicle.
        let placed = vec![p(80.0, 0.3), p(20.0, 0.0), p(60.0, -1.0), p(30.0, 0.0), p(40.0, 3.5)];
        assert_eq!(choose_lead(&defs, &placed, 1, 3.5), Some(2));
        // Nobody ahead in the lane: the first other vehicle.
        let placed = vec![p(10.0, 0.0), p(20.0, 0.0), p(60.0, -3.5), p(30.0, 0.0), p(40.0, 3.5)];
        assert_eq!(choose_lead(&defs, &placed, 1, 3.5), Some(0));
        let only = vec![def("Ego", Kind::Vehicle), def("Obj", Kind::Misc)];
        assert_eq!(choose_lead(&only, &[p(0.0, 0.0), p(10.0, 0.0)], 0, 3.5), Some(1));
        assert_eq!(choose_lead(&only[..1], &[p(0.0, 0.0)], 0, 3.5), None);
        let names = flc_names(&defs, 1, 0);
        assert_eq!(names, vec!["lead", "ego", "lead_osc", "Obj", "osc_follower2"]);
    }
}
