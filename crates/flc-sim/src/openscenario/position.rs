//! OpenSCENARIO `Position`s -> world poses of an entity's reference point, on the ego's road or
//! the roads of its route through a network ([`Geo`]).
//!
//! Supported: `WorldPosition`, `LanePosition`, `RoadPosition`, `RelativeLanePosition`,
//! `RelativeRoadPosition`, `RelativeObjectPosition`, `RelativeWorldPosition` (each with an
//! optional `Orientation`). Headings without an `Orientation` follow the driving direction of
//! the lane at the position (right-hand traffic: along the reference line for negative lane ids,
//! against it for positive ones); relative entity positions take the reference entity's
//! heading. `dsLane` of a `RelativeLanePosition` is taken as `ds` (equal on straight roads).

use super::error::ImportError;
use super::junction::Route;
use super::params::Params;
use super::road::{self, Road};
use super::xml;

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// The id of the road [`Geo::straight`] builds.
pub const STRAIGHT_ID: &str = "straight";

/// A world pose (of an entity's reference point): position (m) and heading (rad).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// Heading, rad.
    pub h: f64,
}

impl Pose {
    /// The point `(dx, dy)` of this pose's frame (x forward, y left), with this heading.
    pub fn offset(&self, dx: f64, dy: f64) -> Pose {
        let (sn, cs) = self.h.sin_cos();
        Pose { x: self.x + dx * cs - dy * sn, y: self.y + dx * sn + dy * cs, h: self.h }
    }
}

/// The road positions refer to.
#[derive(Debug, Clone)]
pub struct Geo {
    /// The road.
    pub road: Road,
    /// The road is the stand-in straight road (`--road straight` or no `LogicFile`): any
    /// `roadId` names it.
    pub any_road: bool,
    /// The ego's route through a network of several roads: `road` is its roads joined
    /// ([`super::junction::join`]) and a `roadId` of any of them is a position on it.
    pub route: Option<Route>,
}

impl Geo {
    /// A straight road along +x from (0, 0): `lanes` right lanes (ids -1 ..= -lanes) of `width`
    /// m, `length` m long.
    pub fn straight(lanes: u32, width: f64, length: f64) -> Result<Self, ImportError> {
        let lanes_xml: String = (1..=lanes)
            .map(|i| format!("<lane id=\"-{i}\" type=\"driving\"><width sOffset=\"0\" a=\"{width}\" b=\"0\" c=\"0\" d=\"0\"/></lane>"))
            .collect();
        let text = format!(
            "<OpenDRIVE><header revMajor=\"1\" revMinor=\"6\"/><road id=\"{STRAIGHT_ID}\" length=\"{length}\" junction=\"-1\">\
             <planView><geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"{length}\"><line/></geometry></planView>\
             <lanes><laneSection s=\"0\"><center><lane id=\"0\" type=\"none\"/></center><right>{lanes_xml}</right></laneSection></lanes>\
             </road></OpenDRIVE>"
        );
        let net = road::from_str(&text, "(straight road)")?;
        let road = net.roads.into_iter().next().ok_or_else(|| ImportError::file("(straight road)", "no road"))?;
        Ok(Self { road, any_road: true, route: None })
    }

    /// The position on [`Geo::road`] of `s` on road `id` (a `roadId` of `node`): the road
    /// itself, or a road of the ego's route; `s` must lie on that road.
    pub fn road_s(&self, file: &str, node: Node<'_, '_>, id: &str, s: f64) -> Result<f64, ImportError> {
        let id = id.trim();
        if self.any_road || (self.route.is_none() && id == self.road.id) {
            self.check_s(file, node, s)?;
            return Ok(s);
        }
        let Some(route) = &self.route else {
            return Err(ImportError::at(
                file,
                node,
                format!("road `{id}`: only one road is supported, the ego's road `{}` (give every entity a position on it)", self.road.id),
            ));
        };
        let Some(i) = route.roads.iter().position(|r| r == id) else {
            return Err(ImportError::at(
                file,
                node,
                format!(
                    "road `{id}` is not on the ego's route ({}): positions on roads the ego's route does not pass are not supported",
                    route.describe()
                ),
            ));
        };
        let start = route.starts.get(i).copied().unwrap_or(0.0);
        let len = route.starts.get(i + 1).copied().unwrap_or(self.road.length) - start;
        if s >= -1e-6 && s <= len + 1e-6 {
            Ok(start + s)
        } else {
            Err(ImportError::at(file, node, format!("s = {s} m is outside road `{id}` (0 to {len} m)")))
        }
    }

    /// The driving direction at road position `(s, t)`: the reference line's heading, turned
    /// by pi in a lane with a positive id (right-hand traffic).
    pub fn lane_heading(&self, s: f64, t: f64) -> f64 {
        let (_, _, h) = self.road.reference(s);
        match self.road.lane_at(s, t) {
            Some(id) if id > 0 => h + std::f64::consts::PI,
            _ => h,
        }
    }

    fn check_s(&self, file: &str, node: Node<'_, '_>, s: f64) -> Result<(), ImportError> {
        if s >= -1e-6 && s <= self.road.length + 1e-6 {
            Ok(())
        } else {
            Err(ImportError::at(file, node, format!("s = {s} m is outside road `{}` (0 to {} m)", self.road.id, self.road.length)))
        }
    }
}

/// `dLane` lanes from lane `id`, skipping the centre lane 0 (+ towards positive ids).
pub fn shift_lane(id: i32, d: i32) -> i32 {
    let r = id.saturating_add(d);
    if id < 0 && r >= 0 {
        r.saturating_add(1)
    } else if id > 0 && r <= 0 {
        r.saturating_sub(1)
    } else {
        r
    }
}

/// The element inside a `Position`.
pub fn inner<'a, 'i>(file: &str, position: Node<'a, 'i>) -> Result<Node<'a, 'i>, ImportError> {
    let mut it = xml::elements(position);
    match (it.next(), it.next()) {
        (Some(p), None) => Ok(p),
        _ => Err(ImportError::at(file, position, "a <Position> holds exactly one position element")),
    }
}

/// The entity a relative position refers to (`entityRef`), `None` for absolute positions.
pub fn reference(params: &Params, file: &str, position: Node<'_, '_>) -> Result<Option<String>, ImportError> {
    let p = inner(file, position)?;
    match p.tag_name().name() {
        "RelativeLanePosition" | "RelativeRoadPosition" | "RelativeObjectPosition" | "RelativeWorldPosition" => {
            Ok(Some(params.req_str(p, "entityRef", file)?))
        }
        _ => Ok(None),
    }
}

/// The `roadId` of an absolute lane or road position (`None` otherwise).
pub fn road_id(params: &Params, file: &str, position: Node<'_, '_>) -> Result<Option<String>, ImportError> {
    let p = inner(file, position)?;
    match p.tag_name().name() {
        "LanePosition" | "RoadPosition" => Ok(Some(params.req_str(p, "roadId", file)?)),
        _ => Ok(None),
    }
}

/// The world pose of the `Position` element `position` of `file`. `refs` gives the pose of the
/// reference point of an entity named by a relative position (its OpenSCENARIO name); `None`
/// there is an error (unknown, or not placed).
pub fn resolve(
    params: &Params,
    geo: &Geo,
    file: &str,
    position: Node<'_, '_>,
    refs: &dyn Fn(&str) -> Option<Pose>,
) -> Result<Pose, ImportError> {
    let p = inner(file, position)?;
    let num = |attr: &str| params.num_attr(p, attr, file);
    let req = |attr: &str| params.req_num(p, attr, file);
    let orientation = orientation(params, file, p)?;
    let reference = |p: Node<'_, '_>| -> Result<Pose, ImportError> {
        let name = params.req_str(p, "entityRef", file)?;
        refs(&name).ok_or_else(|| ImportError::at(file, p, format!("entity `{name}` has no position to refer to (unknown, or not placed)")))
    };
    // Heading: `base` without an Orientation, `relative_to + h` for a relative one, `h` for an
    // absolute one.
    let heading = |base: f64, relative_to: f64| match orientation {
        None => base,
        Some((true, h)) => h,
        Some((false, h)) => relative_to + h,
    };
    let on_road = |s: f64, t: f64, own_heading: Option<f64>| -> Pose {
        let (x, y, _) = geo.road.world(s, t);
        let lane_h = geo.lane_heading(s, t);
        Pose { x, y, h: own_heading.unwrap_or_else(|| heading(lane_h, lane_h)) }
    };
    match p.tag_name().name() {
        "WorldPosition" => {
            let h = num("h")?.unwrap_or(0.0);
            Ok(Pose { x: req("x")?, y: req("y")?, h })
        }
        "LanePosition" => {
            let lane = lane_id(params, file, p, "laneId")?;
            let s = geo.road_s(file, p, &params.req_str(p, "roadId", file)?, req("s")?)?;
            let offset = num("offset")?.unwrap_or(0.0);
            let centre = geo
                .road
                .lane_center_t(lane, s)
                .ok_or_else(|| ImportError::at(file, p, format!("lane {lane} does not exist at s = {s} m of road `{}`", geo.road.id)))?;
            // The offset is along the road's t (left of the reference line) on either side, as
            // esmini places it (lane 4 at t = 8 m with offset -5: t = 3 m). The heading follows
            // lane `laneId`'s driving direction even where the offset puts the point in another
            // lane (esmini: Euro NCAP CCFhol's target, lane -1 offset 3.5 m, `h = pi` relative,
            // faces -s).
            let lane_h = geo.lane_heading(s, centre);
            Ok(on_road(s, centre + offset, Some(heading(lane_h, lane_h))))
        }
        "RoadPosition" => {
            let s = geo.road_s(file, p, &params.req_str(p, "roadId", file)?, req("s")?)?;
            let t = req("t")?;
            // The heading (and a relative Orientation) is the reference line's, whatever lane `t`
            // falls in (esmini 3.6.0: `t` = 1.75 in lane 1 faces +s; `h = -pi` faces -s).
            let road_h = geo.road.world(s, t).2;
            Ok(on_road(s, t, Some(heading(road_h, road_h))))
        }
        "RelativeRoadPosition" => {
            let r = reference(p)?;
            let (s0, t0) = geo.road.to_local(r.x, r.y);
            let s = s0 + req("ds")?;
            geo.check_s(file, p, s)?;
            let t = t0 + req("dt")?;
            // A relative Orientation turns from the reference line's direction (esmini: `h = pi`
            // in a left-hand lane of a right-hand road faces -s, as in lane -1), not the lane's.
            let own = match orientation {
                Some((false, h)) => Some(geo.road.world(s, t).2 + h),
                _ => None,
            };
            Ok(on_road(s, t, own))
        }
        "RelativeLanePosition" => {
            let r = reference(p)?;
            let (s0, t0) = geo.road.to_local(r.x, r.y);
            let from = geo.road.lane_at(s0, t0).ok_or_else(|| {
                ImportError::at(
                    file,
                    p,
                    format!("the reference entity is not in a lane (road `{}`, s = {s0:.2} m, t = {t0:.2} m)", geo.road.id),
                )
            })?;
            let d = params.req_int(p, "dLane", file)?;
            let d = i32::try_from(d.clamp(-1000, 1000)).unwrap_or(0);
            let to = shift_lane(from, d);
            let ds = match (num("ds")?, num("dsLane")?) {
                (Some(_), Some(_)) => return Err(ImportError::at(file, p, "give `ds` or `dsLane`, not both")),
                (Some(v), None) | (None, Some(v)) => v,
                (None, None) => 0.0,
            };
            let s = s0 + if from > 0 { -ds } else { ds };
            geo.check_s(file, p, s)?;
            let centre = geo.road.lane_center_t(to, s).ok_or_else(|| {
                ImportError::at(file, p, format!("lane {to} ({from} + {d}) does not exist at s = {s} m of road `{}`", geo.road.id))
            })?;
            let sign = if to > 0 { -1.0 } else { 1.0 };
            Ok(on_road(s, centre + sign * num("offset")?.unwrap_or(0.0), None))
        }
        "RelativeObjectPosition" => {
            let r = reference(p)?;
            let q = r.offset(req("dx")?, req("dy")?);
            Ok(Pose { h: heading(r.h, r.h), ..q })
        }
        "RelativeWorldPosition" => {
            let r = reference(p)?;
            Ok(Pose { x: r.x + req("dx")?, y: r.y + req("dy")?, h: heading(r.h, r.h) })
        }
        _ => Err(ImportError::unsupported(file, p)),
    }
}

/// A lane id attribute (`laneId` is a string in OpenSCENARIO: `-2`).
pub fn lane_id(params: &Params, file: &str, node: Node<'_, '_>, attr: &str) -> Result<i32, ImportError> {
    let raw = params.req_str(node, attr, file)?;
    let v: f64 = raw.trim().parse().map_err(|_| ImportError::at(file, node, format!("`{attr}` = `{raw}` is not a lane id")))?;
    if v.fract() != 0.0 || v.abs() > 1000.0 {
        return Err(ImportError::at(file, node, format!("`{attr}` = `{raw}` is not a lane id")));
    }
    Ok(v as i32)
}

/// The `Orientation` child of a position: `(absolute, h)`. Without `type`: absolute in a file
/// of OpenSCENARIO 1.0-1.2 (its `FileHeader`), relative otherwise, as esmini 3.6.0 reads it
/// ("No orientation type specified - using absolute (default for OSC version <= 1.2)").
fn orientation(params: &Params, file: &str, p: Node<'_, '_>) -> Result<Option<(bool, f64)>, ImportError> {
    for c in xml::elements(p) {
        if c.tag_name().name() != "Orientation" {
            return Err(ImportError::unsupported(file, c));
        }
    }
    let Some(o) = xml::child(p, "Orientation") else { return Ok(None) };
    let absolute = match params.enum_attr(o, "type", file, &["relative", "absolute"])? {
        Some(t) => t == "absolute",
        None => up_to_1_2(p),
    };
    Ok(Some((absolute, params.num_attr(o, "h", file)?.unwrap_or(0.0))))
}

/// Whether the document of `node` declares OpenSCENARIO 1.0-1.2 in its `FileHeader` (a file
/// without a readable header: no).
fn up_to_1_2(node: Node<'_, '_>) -> bool {
    let root = node.document().root_element();
    let Some(h) = xml::child(root, "FileHeader") else { return false };
    let num = |a: &str| h.attribute(a).and_then(|v| v.trim().parse::<u32>().ok());
    matches!((num("revMajor"), num("revMinor")), (Some(1), Some(m)) if m <= 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(geo: &Geo, xml_text: &str, refs: &dyn Fn(&str) -> Option<Pose>) -> Result<Pose, ImportError> {
        let doc = xml::parse(xml_text, "t.xosc")?;
        resolve(&Params::new(), geo, "t.xosc", doc.root_element(), refs)
    }

    fn close(a: Pose, x: f64, y: f64, h: f64) {
        assert!((a.x - x).abs() < 1e-9 && (a.y - y).abs() < 1e-9 && (a.h - h).abs() < 1e-9, "{a:?} vs ({x}, {y}, {h})");
    }

    #[test]
    fn every_position_kind() {
        let geo = Geo::straight(3, 3.5, 2000.0).expect("road");
        let none = |_: &str| None;
        close(at(&geo, "<Position><WorldPosition x=\"3\" y=\"-1\" h=\"0.1\"/></Position>", &none).expect("world"), 3.0, -1.0, 0.1);
        close(
            at(&geo, "<Position><LanePosition roadId=\"1\" laneId=\"-2\" s=\"100\" offset=\"0.5\"/></Position>", &none).expect("lane"),
            100.0,
            -4.75,
            0.0,
        );
        close(at(&geo, "<Position><RoadPosition roadId=\"1\" s=\"160\" t=\"-8.75\"/></Position>", &none).expect("road"), 160.0, -8.75, 0.0);
        let ego = Pose { x: 100.0, y: -5.25, h: 0.0 };
        let refs = move |n: &str| (n == "Ego").then_some(ego);
        close(
            at(&geo, "<Position><RelativeRoadPosition entityRef=\"Ego\" ds=\"30\" dt=\"0\"/></Position>", &refs).expect("rr"),
            130.0,
            -5.25,
            0.0,
        );
        close(
            at(&geo, "<Position><RelativeObjectPosition entityRef=\"Ego\" dx=\"60\" dy=\"3.5\"/></Position>", &refs).expect("ro"),
            160.0,
            -1.75,
            0.0,
        );
        close(
            at(&geo, "<Position><RelativeLanePosition entityRef=\"Ego\" dLane=\"1\" ds=\"80\" offset=\"0.3\"/></Position>", &refs)
                .expect("rl"),
            180.0,
            -1.45,
            0.0,
        );
        close(
            at(&geo, "<Position><RelativeLanePosition entityRef=\"Ego\" dLane=\"-1\" dsLane=\"-40\" offset=\"-0.2\"/></Position>", &refs)
                .expect("rl2"),
            60.0,
            -8.95,
            0.0,
        );
        close(
            at(&geo, "<Position><RelativeWorldPosition entityRef=\"Ego\" dx=\"80\" dy=\"0\"/></Position>", &refs).expect("rw"),
            180.0,
            -5.25,
            0.0,
        );
        // Orientation: relative to the lane, or absolute.
        close(
            at(&geo, "<Position><LanePosition roadId=\"1\" laneId=\"-1\" s=\"10\"><Orientation type=\"relative\" h=\"0.2\"/></LanePosition></Position>", &none)
                .expect("or"),
            10.0,
            -1.75,
            0.2,
        );
        let e = at(&geo, "<Position>\n<GeoPosition latitude=\"1\" longitude=\"2\"/></Position>", &none).expect_err("geo");
        assert!(e.to_string().starts_with("t.xosc:2: <GeoPosition>:"), "{e}");
        let e = at(&geo, "<Position><RelativeRoadPosition entityRef=\"X\" ds=\"1\" dt=\"0\"/></Position>", &refs).expect_err("unknown");
        assert!(e.to_string().contains("`X`"), "{e}");
        let e = at(&geo, "<Position><LanePosition roadId=\"1\" laneId=\"-7\" s=\"10\"/></Position>", &none).expect_err("lane");
        assert!(e.to_string().contains("lane -7"), "{e}");
        assert_eq!(shift_lane(-1, 1), 1);
        assert_eq!(shift_lane(1, -1), -1);
        assert_eq!(shift_lane(-2, 1), -1);
        assert_eq!(shift_lane(-1, -2), -3);
    }

    #[test]
    fn one_road_only() {
        let mut geo = Geo::straight(3, 3.5, 2000.0).expect("road");
        geo.any_road = false;
        let none = |_: &str| None;
        let e = at(&geo, "<Position><LanePosition roadId=\"7\" laneId=\"-1\" s=\"10\"/></Position>", &none).expect_err("road");
        assert!(e.to_string().contains("only one road"), "{e}");
        assert!(at(&geo, "<Position><LanePosition roadId=\"straight\" laneId=\"-1\" s=\"10\"/></Position>", &none).is_ok());
    }

    #[test]
    fn road_position_heading_is_the_reference_lines() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/openscenario/roads/two_way.xodr");
        let net = road::load(&path).expect("two-way road");
        let geo = Geo { road: net.roads[0].clone(), any_road: false, route: None };
        let none = |_: &str| None;
        // t = 1.75 is lane 1 (driven in -s): a RoadPosition still faces +s, and a relative
        // Orientation turns from +s (esmini 3.6.0); a LanePosition in lane 1 faces -s.
        close(at(&geo, "<Position><RoadPosition roadId=\"1\" s=\"160\" t=\"1.75\"/></Position>", &none).expect("road"), 160.0, 1.75, 0.0);
        let h = at(
            &geo,
            "<Position><RoadPosition roadId=\"1\" s=\"160\" t=\"1.75\"><Orientation type=\"relative\" h=\"-3\"/></RoadPosition></Position>",
            &none,
        );
        close(h.expect("road+h"), 160.0, 1.75, -3.0);
        let lane = at(&geo, "<Position><LanePosition roadId=\"1\" laneId=\"1\" s=\"160\"/></Position>", &none).expect("lane");
        close(lane, 160.0, 1.75, std::f64::consts::PI);
    }
}
