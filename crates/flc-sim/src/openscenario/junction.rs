//! OpenDRIVE road links and junctions, and the route an entity drives through them.
//!
//! Read (by [`super::road`]): a road's `link` (`predecessor` / `successor` with `elementType`
//! `road` or `junction`, `elementId` and, for roads, `contactPoint`), its `junction` attribute
//! (the junction a connecting road belongs to), lane links (`lane/link/predecessor@id`,
//! `successor@id`) and `junction` elements with their `connection`s (`incomingRoad`,
//! `connectingRoad`, `contactPoint`, `laneLink from to`).
//!
//! The route ([`route`]): from the ego's road and lane, forwards through successors and
//! backwards through predecessors, as esmini 3.6.0's default controller drives without an
//! assigned route: at a junction it takes, of the connections from the road it comes from that
//! continue its lane, the one whose connecting road turns least (the heading change from its
//! start to its end nearest 0; the first in file order on a tie). The route's roads are joined
//! into one road ([`join`]) whose lanes keep their ids, so the one scenario model (a track along
//! the ego's lane) runs on it unchanged.
//!
//! Checked, each an error naming file, line and element: a link to a road or junction that is
//! not in the file, a junction connection whose incoming or connecting road is missing or whose
//! connecting road does not belong to the junction, a joint where the next road does not start
//! where the route's road ends (more than [`JOINT_TOLERANCE`]). A route that comes back to a road
//! it already passes (a loop) ends before it; its length is bounded by [`MAX_ROUTE_ROADS`].
//! A road the route would enter at its end (driven against its reference line) ends the route.

use std::collections::BTreeSet;

use super::error::ImportError;
use super::road::{Cubic, Network, Road};
use crate::track::wrap;

/// Most roads of one route.
pub const MAX_ROUTE_ROADS: usize = 1_000;
/// Largest distance between a road's end and the next road's start on a route, m.
pub const JOINT_TOLERANCE: f64 = 0.05;

/// `elementType` of a link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Element {
    /// A road.
    Road,
    /// A junction.
    Junction,
}

/// `contactPoint`: the end of the linked road that touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Contact {
    /// Its start (`s = 0`).
    Start,
    /// Its end (`s = length`).
    End,
}

/// A road's `predecessor` or `successor` link.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// What it links to.
    pub element: Element,
    /// The road's or junction's id.
    pub id: String,
    /// The linked road's end (roads only).
    pub contact: Option<Contact>,
    /// Line of the link element (for errors).
    pub line: u32,
}

/// A junction `connection`.
#[derive(Debug, Clone, PartialEq)]
pub struct Connection {
    /// The `id` attribute.
    pub id: String,
    /// `incomingRoad`.
    pub incoming: String,
    /// `connectingRoad`.
    pub connecting: String,
    /// `contactPoint` of the connecting road.
    pub contact: Contact,
    /// `laneLink from to` pairs (incoming road's lane, connecting road's lane).
    pub lane_links: Vec<(i32, i32)>,
    /// Line of the connection element.
    pub line: u32,
}

/// An OpenDRIVE `junction`.
#[derive(Debug, Clone, PartialEq)]
pub struct Junction {
    /// The `id` attribute.
    pub id: String,
    /// Its connections, in file order.
    pub connections: Vec<Connection>,
    /// Line of the junction element.
    pub line: u32,
}

/// The route of one lane through a network: its roads in driving order.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// The road ids, in driving order.
    pub roads: Vec<String>,
    /// Where each road starts along the joined road, m (same order).
    pub starts: Vec<f64>,
}

impl Route {
    /// Position along the joined road of road `id`'s `s` (`None`: `id` is not on the route).
    pub fn joined_s(&self, id: &str, s: f64) -> Option<f64> {
        self.roads.iter().position(|r| r == id).and_then(|i| self.starts.get(i)).map(|start| start + s)
    }

    /// The route as `a -> b -> c`.
    pub fn describe(&self) -> String {
        self.roads.join(" -> ")
    }
}

fn err_at(road: &Road, line: u32, element: &str, msg: String) -> ImportError {
    ImportError { file: road.file.clone(), line, element: element.into(), message: msg }
}

/// Heading change of `road` from its start to its end (wrapped to (-pi, pi]), rad.
fn turn(road: &Road) -> f64 {
    wrap(road.reference(road.length).2 - road.reference(0.0).2)
}

/// Lane of `road` that lane `lane` of the previous road continues in, by the lane's
/// `predecessor` links (`None` if the road's lanes name none: the same id).
fn entered_lane(road: &Road, lane: i32) -> Option<i32> {
    let first = road.lane_sections.first()?;
    let side = first.right.iter().chain(&first.left);
    let linked: Vec<i32> = side.clone().filter(|l| l.predecessor == Some(lane)).map(|l| l.id).collect();
    if let Some(&id) = linked.first() {
        return Some(id);
    }
    if side.clone().any(|l| l.predecessor.is_some()) { None } else { first.lane(lane).map(|l| l.id) }
}

/// The road after `road` (driven along its reference line in lane `lane`) on the route, with its
/// lane: `Ok(None)` where the route ends.
fn next<'n>(net: &'n Network, road: &'n Road, lane: i32) -> Result<Option<(&'n Road, i32)>, ImportError> {
    let Some(link) = &road.successor else { return Ok(None) };
    match link.element {
        Element::Road => {
            let next = net.road(&link.id).ok_or_else(|| {
                err_at(road, link.line, "successor", format!("road `{}` links to road `{}`, which is not in the file", road.id, link.id))
            })?;
            if link.contact != Some(Contact::Start) {
                return Ok(None);
            }
            Ok(entered_lane(next, lane).map(|l| (next, l)))
        }
        Element::Junction => {
            let j = net.junction(&link.id).ok_or_else(|| {
                err_at(
                    road,
                    link.line,
                    "successor",
                    format!("road `{}` links to junction `{}`, which is not in the file", road.id, link.id),
                )
            })?;
            let mut best: Option<(&Road, i32, f64)> = None;
            for c in j.connections.iter().filter(|c| c.incoming == road.id) {
                let conn = net.road(&c.connecting).ok_or_else(|| {
                    err_at(
                        road,
                        c.line,
                        "connection",
                        format!("junction `{}`: connecting road `{}` is not in the file", j.id, c.connecting),
                    )
                })?;
                if conn.junction != j.id {
                    return Err(err_at(
                        conn,
                        conn.line,
                        "road",
                        format!("road `{}` connects in junction `{}` but its `junction` attribute is `{}`", conn.id, j.id, conn.junction),
                    ));
                }
                if c.contact != Contact::Start {
                    continue;
                }
                let to = if c.lane_links.is_empty() {
                    entered_lane(conn, lane)
                } else {
                    c.lane_links.iter().find(|(from, _)| *from == lane).map(|(_, to)| *to)
                };
                let Some(to) = to.filter(|&to| conn.lane_sections.first().is_some_and(|s| s.lane(to).is_some())) else { continue };
                let a = turn(conn).abs();
                if best.is_none_or(|(_, _, b)| a < b) {
                    best = Some((conn, to, a));
                }
            }
            Ok(best.map(|(r, l, _)| (r, l)))
        }
    }
}

/// The road before `road` (lane `lane`) on the route, with its lane: `Ok(None)` where the route
/// starts. A junction before it: the connecting road (driven along its reference line) that
/// ends at `road`'s start, the one that turns least.
fn previous<'n>(net: &'n Network, road: &'n Road, lane: i32) -> Result<Option<(&'n Road, i32)>, ImportError> {
    let Some(link) = &road.predecessor else { return Ok(None) };
    let lane_before = |r: &Road| -> Option<i32> {
        // The lane of `road` names its predecessor lane; else the same id.
        let first = road.lane_sections.first()?;
        let own = first.lane(lane)?;
        let id = own.predecessor.unwrap_or(lane);
        r.lane_sections.last().and_then(|s| s.lane(id)).map(|l| l.id)
    };
    match link.element {
        Element::Road => {
            let prev = net.road(&link.id).ok_or_else(|| {
                err_at(road, link.line, "predecessor", format!("road `{}` links to road `{}`, which is not in the file", road.id, link.id))
            })?;
            if link.contact != Some(Contact::End) {
                return Ok(None);
            }
            Ok(lane_before(prev).map(|l| (prev, l)))
        }
        Element::Junction => {
            let j = net.junction(&link.id).ok_or_else(|| {
                err_at(
                    road,
                    link.line,
                    "predecessor",
                    format!("road `{}` links to junction `{}`, which is not in the file", road.id, link.id),
                )
            })?;
            let mut best: Option<(&Road, i32, f64)> = None;
            for c in &j.connections {
                let Some(conn) = net.road(&c.connecting) else {
                    return Err(err_at(
                        road,
                        c.line,
                        "connection",
                        format!("junction `{}`: connecting road `{}` is not in the file", j.id, c.connecting),
                    ));
                };
                let ends_here = conn
                    .successor
                    .as_ref()
                    .is_some_and(|s| s.element == Element::Road && s.id == road.id && s.contact == Some(Contact::Start));
                if c.contact != Contact::Start || !ends_here {
                    continue;
                }
                let Some(l) = lane_before(conn) else { continue };
                let a = turn(conn).abs();
                if best.is_none_or(|(_, _, b)| a < b) {
                    best = Some((conn, l, a));
                }
            }
            Ok(best.map(|(r, l, _)| (r, l)))
        }
    }
}

/// The route of lane `lane` of road `start` through `net` (module docs).
pub fn route(net: &Network, start: &Road, lane: i32) -> Result<Route, ImportError> {
    let mut seen: BTreeSet<&str> = BTreeSet::from([start.id.as_str()]);
    let mut after: Vec<&Road> = Vec::new();
    let (mut road, mut l) = (start, lane);
    while seen.len() < MAX_ROUTE_ROADS {
        match next(net, road, l)? {
            Some((r, rl)) if seen.insert(r.id.as_str()) => {
                check_joint(road, r)?;
                after.push(r);
                (road, l) = (r, rl);
            }
            _ => break,
        }
    }
    let mut before: Vec<&Road> = Vec::new();
    let (mut road, mut l) = (start, lane);
    while seen.len() < MAX_ROUTE_ROADS {
        match previous(net, road, l)? {
            Some((r, rl)) if seen.insert(r.id.as_str()) => {
                check_joint(r, road)?;
                before.push(r);
                (road, l) = (r, rl);
            }
            _ => break,
        }
    }
    let roads: Vec<&Road> = before.into_iter().rev().chain(std::iter::once(start)).chain(after).collect();
    let mut starts = Vec::with_capacity(roads.len());
    let mut s = 0.0;
    for r in &roads {
        starts.push(s);
        s += r.length;
    }
    Ok(Route { roads: roads.iter().map(|r| r.id.clone()).collect(), starts })
}

/// `b` must start where `a` ends.
fn check_joint(a: &Road, b: &Road) -> Result<(), ImportError> {
    let (ax, ay, _) = a.reference(a.length);
    let (bx, by, _) = b.reference(0.0);
    let gap = (bx - ax).hypot(by - ay);
    if gap.is_finite() && gap <= JOINT_TOLERANCE {
        Ok(())
    } else {
        Err(err_at(
            b,
            b.line,
            "road",
            format!(
                "road `{}` follows road `{}` on the route but starts {gap:.3} m from its end (at most {JOINT_TOLERANCE} m): the links or the geometry are wrong",
                b.id, a.id
            ),
        ))
    }
}

/// The roads of `route` joined into one road (id: the first road's), each road's geometries,
/// lane offsets and lane sections shifted by its start; lanes keep their ids, so lane `lane`
/// must keep its id along the route (else an error).
pub fn join(net: &Network, route: &Route, lane: i32) -> Result<Road, ImportError> {
    let mut roads = route.roads.iter().filter_map(|id| net.road(id));
    let Some(first) = roads.next() else { return Err(ImportError::file("(route)", "an empty route")) };
    let mut out = first.clone();
    if route.roads.len() == 1 {
        return Ok(out);
    }
    out.successor = None;
    out.predecessor = None;
    let any_offsets = route.roads.iter().filter_map(|id| net.road(id)).any(|r| !r.lane_offsets.is_empty());
    for (r, &start) in roads.zip(route.starts.iter().skip(1)) {
        if r.left_hand_traffic != out.left_hand_traffic {
            return Err(err_at(r, r.line, "road", format!("road `{}` on the route has another traffic rule than road `{}`", r.id, out.id)));
        }
        if r.lane_sections.iter().any(|sec| sec.lane(lane).is_none()) {
            return Err(err_at(
                r,
                r.line,
                "road",
                format!("lane {lane} does not continue with the same id on road `{}` of the route {}", r.id, route.describe()),
            ));
        }
        out.geometries.extend(r.geometries.iter().map(|g| {
            let mut g = g.clone();
            g.s += start;
            g
        }));
        if any_offsets {
            if r.lane_offsets.first().is_none_or(|o| o.s > 0.0) {
                out.lane_offsets.push(Cubic { s: start, a: 0.0, b: 0.0, c: 0.0, d: 0.0 });
            }
            out.lane_offsets.extend(r.lane_offsets.iter().map(|o| Cubic { s: o.s + start, ..*o }));
        }
        out.lane_sections.extend(r.lane_sections.iter().map(|sec| {
            let mut sec = sec.clone();
            sec.s += start;
            sec
        }));
        out.length = start + r.length;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::openscenario::road;

    fn lanes(ids: &[i32], links: &str) -> String {
        let lane = |i: i32| {
            format!("<lane id=\"{i}\" type=\"driving\"><link>{links}</link><width sOffset=\"0\" a=\"3.5\" b=\"0\" c=\"0\" d=\"0\"/></lane>")
        };
        let left: String = ids.iter().filter(|&&i| i > 0).map(|&i| lane(i)).collect();
        let right: String = ids.iter().filter(|&&i| i < 0).map(|&i| lane(i)).collect();
        format!(
            "<lanes><laneSection s=\"0\"><left>{left}</left><center><lane id=\"0\" type=\"none\"/></center><right>{right}</right></laneSection></lanes>"
        )
    }

    fn road_xml(id: &str, junction: &str, len: f64, [x, y, hdg]: [f64; 3], shape: &str, link: &str, ids: &[i32]) -> String {
        format!(
            "<road id=\"{id}\" junction=\"{junction}\" length=\"{len}\"><link>{link}</link><planView><geometry s=\"0\" x=\"{x}\" y=\"{y}\" hdg=\"{hdg}\" length=\"{len}\">{shape}</geometry></planView>{}</road>",
            lanes(ids, "")
        )
    }

    /// A T: road 1 (west, ends at junction 9), road 2 (east, starts at it), road 3 (north, starts
    /// at it); connecting roads 10 (straight 1 -> 2) and 11 (left 1 -> 3, listed first).
    fn t_junction(extra: &str, conn_extra: &str) -> String {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let arc_len = half_pi * 10.0;
        let j = "<successor elementType=\"junction\" elementId=\"9\"/>";
        let jp = "<predecessor elementType=\"junction\" elementId=\"9\"/>";
        format!(
            "<OpenDRIVE><header revMajor=\"1\" revMinor=\"6\"/>{}{}{}{}{}{extra}<junction id=\"9\">\
             <connection id=\"0\" incomingRoad=\"1\" connectingRoad=\"11\" contactPoint=\"start\"><laneLink from=\"-1\" to=\"-1\"/></connection>\
             <connection id=\"1\" incomingRoad=\"1\" connectingRoad=\"10\" contactPoint=\"start\"><laneLink from=\"-1\" to=\"-1\"/></connection>{conn_extra}\
             </junction></OpenDRIVE>",
            road_xml("1", "-1", 100.0, [0.0, 0.0, 0.0], "<line/>", j, &[1, -1]),
            road_xml("2", "-1", 100.0, [120.0, 0.0, 0.0], "<line/>", jp, &[1, -1]),
            road_xml("3", "-1", 100.0, [110.0, 10.0, half_pi], "<line/>", jp, &[1, -1]),
            road_xml(
                "10",
                "9",
                20.0,
                [100.0, 0.0, 0.0],
                "<line/>",
                "<predecessor elementType=\"road\" elementId=\"1\" contactPoint=\"end\"/><successor elementType=\"road\" elementId=\"2\" contactPoint=\"start\"/>",
                &[1, -1]
            ),
            road_xml(
                "11",
                "9",
                arc_len,
                [100.0, 0.0, 0.0],
                "<arc curvature=\"0.1\"/>",
                "<predecessor elementType=\"road\" elementId=\"1\" contactPoint=\"end\"/><successor elementType=\"road\" elementId=\"3\" contactPoint=\"start\"/>",
                &[-1]
            ),
        )
    }

    fn route_of(text: &str, start: &str) -> Result<Route, ImportError> {
        let net = road::from_str(text, "t.xodr")?;
        let r = net.road(start).expect("road");
        route(&net, r, -1)
    }

    #[test]
    fn straightest_connection_forwards_and_backwards() {
        let text = t_junction("", "");
        let r = route_of(&text, "1").expect("route");
        assert_eq!(r.roads, ["1", "10", "2"]);
        assert_eq!(r.starts, [0.0, 100.0, 120.0]);
        assert_eq!(r.joined_s("2", 5.0), Some(125.0));
        assert_eq!(r.joined_s("3", 5.0), None);
        // From road 2 backwards: the connecting road that ends at its start.
        assert_eq!(route_of(&text, "2").expect("route").roads, ["1", "10", "2"]);
        // From road 3 backwards: through the left turn.
        assert_eq!(route_of(&text, "3").expect("route").roads, ["1", "11", "3"]);
        let net = road::from_str(&text, "t.xodr").expect("net");
        let joined = join(&net, &r, -1).expect("join");
        assert_eq!(joined.length, 220.0);
        let (x, y, h) = joined.world(170.0, -1.75);
        assert!((x - 170.0).abs() < 1e-9 && (y + 1.75).abs() < 1e-9 && h.abs() < 1e-12);
        assert_eq!(joined.lane_sections.len(), 3);
    }

    #[test]
    fn bad_links_are_errors() {
        // A link to a road that is not there.
        let text = t_junction("", "").replace("elementId=\"2\" contactPoint=\"start\"", "elementId=\"22\" contactPoint=\"start\"");
        // (road 10's successor; the route reaches it from road 1.)
        let e = route_of(&text, "1").expect_err("missing road");
        assert!(e.message.contains("road `22`") && e.message.contains("not in the file"), "{e}");
        // A junction that is not there.
        let text = t_junction("", "").replacen("elementId=\"9\"", "elementId=\"99\"", 1);
        let e = route_of(&text, "1").expect_err("missing junction");
        assert!(e.message.contains("junction `99`"), "{e}");
        // A missing connecting road.
        let text = t_junction("", "<connection id=\"2\" incomingRoad=\"1\" connectingRoad=\"77\" contactPoint=\"start\"/>");
        let e = route_of(&text, "1").expect_err("missing connecting road");
        assert!(e.message.contains("connecting road `77`") && e.element == "connection", "{e}");
        // A connecting road that does not say it belongs to the junction.
        let text = t_junction("", "").replace("<road id=\"10\" junction=\"9\"", "<road id=\"10\" junction=\"-1\"");
        let e = route_of(&text, "1").expect_err("not in the junction");
        assert!(e.message.contains("`junction` attribute"), "{e}");
        // A joint with a gap.
        let text = t_junction("", "").replace("x=\"120\" y=\"0\"", "x=\"121\" y=\"0\"");
        let e = route_of(&text, "1").expect_err("gap");
        assert!(e.message.contains("starts 1.000 m from its end"), "{e}");
    }

    #[test]
    fn loops_end_the_route() {
        // Two roads linked into a ring: 1 -> 2 -> 1.
        let a = road_xml(
            "1",
            "-1",
            100.0,
            [0.0, 0.0, 0.0],
            "<line/>",
            "<predecessor elementType=\"road\" elementId=\"2\" contactPoint=\"end\"/><successor elementType=\"road\" elementId=\"2\" contactPoint=\"start\"/>",
            &[-1],
        );
        let b = road_xml(
            "2",
            "-1",
            100.0,
            [100.0, 0.0, 0.0],
            "<line/>",
            "<predecessor elementType=\"road\" elementId=\"1\" contactPoint=\"end\"/><successor elementType=\"road\" elementId=\"1\" contactPoint=\"start\"/>",
            &[-1],
        );
        let text = format!("<OpenDRIVE><header revMajor=\"1\" revMinor=\"6\"/>{a}{b}</OpenDRIVE>");
        // Road 2 does not end where road 1 starts, but the route stops before closing the loop.
        let r = route_of(&text, "1").expect("route");
        assert_eq!(r.roads, ["1", "2"]);
    }

    #[test]
    fn malformed_links_are_errors() {
        for (bad, what) in [
            ("elementType=\"road\" elementId=\"2\" contactPoint=\"middle\"", "contactPoint"),
            ("elementType=\"bridge\" elementId=\"2\"", "elementType"),
            ("elementType=\"road\" contactPoint=\"start\"", "elementId"),
        ] {
            let text = t_junction("", "")
                .replace("<successor elementType=\"road\" elementId=\"2\" contactPoint=\"start\"/>", &format!("<successor {bad}/>"));
            let e = road::from_str(&text, "t.xodr").expect_err(what);
            assert!(e.to_string().contains(what), "{what}: {e}");
        }
        let text = t_junction(
            "",
            "<connection id=\"5\" incomingRoad=\"1\" connectingRoad=\"10\" contactPoint=\"start\"><laneLink from=\"x\" to=\"1\"/></connection>",
        );
        assert!(road::from_str(&text, "t.xodr").expect_err("laneLink").to_string().contains("laneLink@from"));
        let text = t_junction("", "<connection id=\"5\" connectingRoad=\"10\" contactPoint=\"start\"/>");
        assert!(road::from_str(&text, "t.xodr").expect_err("incoming").to_string().contains("incomingRoad"));
        let text = t_junction("<junction id=\"9\"/>", "");
        assert!(road::from_str(&text, "t.xodr").expect_err("twice").to_string().contains("junction id \"9\" is used twice"));
    }
}
