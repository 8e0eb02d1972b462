//! Foxglove scene primitives: poses, colours, the road, the vehicle bodies, transforms.

use super::*;

pub(super) fn v3(x: f64, y: f64, z: f64) -> Vector3 {
    Vector3 { x, y, z }
}

pub(super) fn yaw_quat(yaw: f64) -> Quaternion {
    let h = 0.5 * yaw;
    Quaternion { x: 0.0, y: 0.0, z: h.sin(), w: h.cos() }
}

pub(super) fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Pose {
    Pose { position: Some(v3(x, y, z)), orientation: Some(yaw_quat(yaw)) }
}

pub(super) const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

pub(super) const LEAD_COLOR: Color = rgba(0.95, 0.35, 0.2, 0.9);
pub(super) const FOLLOWER_COLOR: Color = rgba(0.2, 0.55, 0.95, 0.9);
/// Scripted vehicles besides the lead.
pub(super) const TRAFFIC_COLOR: Color = rgba(0.65, 0.65, 0.7, 0.9);
pub(super) const LOOKAHEAD_COLOR: Color = rgba(1.0, 0.2, 0.9, 1.0);

/// Entity names (`clusters/<name>` on [`TOPIC_DETECTOR`]) and colours of the detector's clusters:
/// the accepted lead, the other vehicle-like clusters, then one per `flc_core::RejectReason`
/// (named by its `as_str`).
pub const CLUSTER_STATUS: [(&str, Color); 7] = [
    ("lead", rgba(0.1, 0.9, 0.2, 0.6)),
    ("candidate", rgba(0.95, 0.85, 0.1, 0.5)),
    ("too_few_points", rgba(0.5, 0.5, 0.5, 0.25)),
    ("too_narrow", rgba(0.3, 0.6, 0.9, 0.35)),
    ("too_wide", rgba(0.9, 0.5, 0.2, 0.35)),
    ("too_deep", rgba(0.7, 0.3, 0.8, 0.35)),
    ("off_path", rgba(0.75, 0.75, 0.75, 0.35)),
];

pub(super) fn line(kind: line_primitive::Type, points: Vec<Point3>, thickness: f64, color: Color) -> LinePrimitive {
    LinePrimitive {
        r#type: kind as i32,
        pose: Some(pose(0.0, 0.0, 0.0, 0.0)),
        thickness,
        scale_invariant: false,
        points,
        color: Some(color),
        ..Default::default()
    }
}

pub(super) fn entity(ns: u64, frame: &str, id: &str) -> SceneEntity {
    SceneEntity { timestamp: Some(stamp(ns)), frame_id: frame.to_string(), id: id.to_string(), ..Default::default() }
}

pub(super) fn kv(key: &str, value: impl Into<String>) -> KeyValuePair {
    KeyValuePair { key: key.to_string(), value: value.into() }
}

/// Centreline shifted sideways by `offset` (+ left), one point per centreline point.
pub(super) fn offset_polyline(c: &[[f64; 2]], offset: f64, z: f64) -> Vec<Point3> {
    let n = c.len();
    (0..n)
        .map(|i| {
            let (a, b) = (c[i.saturating_sub(1)], c[(i + 1).min(n - 1)]);
            let h = (b[1] - a[1]).atan2(b[0] - a[0]);
            Point3 { x: c[i][0] - offset * h.sin(), y: c[i][1] + offset * h.cos(), z }
        })
        .collect()
}

/// The road as a scene entity: centreline, lane edges and the road-side objects.
pub(super) fn track_entity(ns: u64, track: &Track) -> SceneEntity {
    let mut e = entity(ns, FRAME_WORLD, "road");
    e.metadata = vec![kv("track", track.name.clone()), kv("lane_width_m", format!("{}", track.lane_width))];
    let c = &track.centerline;
    if c.len() >= 2 {
        let half = track.lane_width / 2.0;
        e.lines.push(line(line_primitive::Type::LineStrip, offset_polyline(c, 0.0, 0.0), 0.08, rgba(0.9, 0.9, 0.9, 0.5)));
        e.lines.push(line(line_primitive::Type::LineStrip, offset_polyline(c, half, 0.0), 0.15, rgba(1.0, 1.0, 1.0, 0.9)));
        e.lines.push(line(line_primitive::Type::LineStrip, offset_polyline(c, -half, 0.0), 0.15, rgba(1.0, 1.0, 1.0, 0.9)));
    }
    for o in &track.objects {
        match *o {
            RoadsideObject::GuardRail { offset, from_s, to_s } => {
                let n = (((to_s - from_s) / 2.0).ceil() as usize).clamp(1, 100_000);
                let pts = (0..=n)
                    .map(|k| {
                        let s = from_s + (to_s - from_s) * k as f64 / n as f64;
                        let (x, y, _) = track.place(s, offset);
                        Point3 { x, y, z: 0.5 }
                    })
                    .collect();
                e.lines.push(line(line_primitive::Type::LineStrip, pts, 0.2, rgba(0.75, 0.75, 0.8, 1.0)));
            }
            RoadsideObject::Post { s, offset, radius, .. } => {
                let (x, y, _) = track.place(s, offset);
                e.cylinders.push(CylinderPrimitive {
                    pose: Some(pose(x, y, 0.6, 0.0)),
                    size: Some(v3(2.0 * radius, 2.0 * radius, 1.2)),
                    bottom_scale: 1.0,
                    top_scale: 1.0,
                    color: Some(rgba(0.9, 0.9, 0.3, 1.0)),
                });
            }
            RoadsideObject::ParkedCar { s, offset, heading_offset, .. } => {
                let (x, y, h) = track.place(s, offset);
                e.cubes.push(CubePrimitive {
                    pose: Some(pose(x, y, 0.75, h + heading_offset)),
                    size: Some(v3(4.7, 1.8, 1.5)),
                    color: Some(rgba(0.55, 0.55, 0.6, 1.0)),
                });
            }
        }
    }
    e
}

pub(super) fn vehicle_entity(ns: u64, frame: &str, length: f64, width: f64, color: Color) -> SceneEntity {
    let mut e = entity(ns, frame, frame);
    e.frame_locked = true;
    e.cubes.push(CubePrimitive { pose: Some(pose(0.0, 0.0, 0.75, 0.0)), size: Some(v3(length, width, 1.5)), color: Some(color) });
    e.texts.push(TextPrimitive {
        pose: Some(pose(0.0, 0.0, 2.2, 0.0)),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Some(rgba(1.0, 1.0, 1.0, 1.0)),
        text: frame.to_string(),
    });
    e
}

pub(super) fn transform(ns: u64, parent: &str, child: &str, x: f64, y: f64, yaw: f64) -> FrameTransform {
    FrameTransform {
        timestamp: Some(stamp(ns)),
        parent_frame_id: parent.to_string(),
        child_frame_id: child.to_string(),
        translation: Some(v3(x, y, 0.0)),
        rotation: Some(yaw_quat(yaw)),
    }
}

pub(super) const CONTACT_COLOR: Color = rgba(1.0, 0.1, 0.1, 1.0);

/// A contact marker in frame [`FRAME_WORLD`]: a sphere at `point`, a 1.5 m line along the
/// `normal` and a label.
pub(super) fn contact_entity(ns: u64, id: &str, point: [f64; 2], normal: [f64; 2], text: String) -> SceneEntity {
    let [x, y] = point;
    let mut e = entity(ns, FRAME_WORLD, id);
    e.metadata = vec![kv("x_m", format!("{x:.3}")), kv("y_m", format!("{y:.3}"))];
    e.spheres.push(SpherePrimitive { pose: Some(pose(x, y, 0.8, 0.0)), size: Some(v3(0.7, 0.7, 0.7)), color: Some(CONTACT_COLOR) });
    e.lines.push(line(
        line_primitive::Type::LineStrip,
        vec![Point3 { x, y, z: 0.8 }, Point3 { x: x + 1.5 * normal[0], y: y + 1.5 * normal[1], z: 0.8 }],
        0.08,
        CONTACT_COLOR,
    ));
    e.texts.push(TextPrimitive {
        pose: Some(pose(x, y, 2.4, 0.0)),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Some(CONTACT_COLOR),
        text,
    });
    e
}
