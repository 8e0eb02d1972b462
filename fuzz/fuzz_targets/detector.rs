//! The lead detector on arbitrary point clouds, parameters and curvatures, through the Rust API
//! and the C API (which must agree bit for bit).
#![no_main]

#[path = "common.rs"]
mod common;

use arbitrary::Arbitrary;
use common::{Num, Param, same};
use flc_core::capi::{FlcDetector, FlcDetectorOutput, FlcResult, flc_detector_detect, flc_detector_init};
use flc_core::detector::CLUSTER_CAPACITY;
use flc_core::{DetectorParams, LeadDetector, Reprojection};
use libfuzzer_sys::fuzz_target;
use std::mem::MaybeUninit;
use std::sync::Mutex;

/// A point: anywhere (raw doubles), or on the grid (x in [-2, 205] m, y in [-7, 7] m).
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Pt {
    Raw(f64, f64),
    Grid(u16, i16),
    /// A short line of `n` points from a grid point, spaced by `step` cm along x or y.
    Line(u16, i16, u8, i8, bool),
}

#[derive(Arbitrary, Debug)]
struct Input {
    params: [Param; 6],
    far: [Param; 10],
    swept: Param,
    body: Param,
    join_beams: u8,
    dilation_radius: u8,
    max_dilation_radius: u8,
    bridge_beams: u8,
    min_cluster_points: u8,
    max_points: u16,
    cell_center: bool,
    curvature: Num,
    points: Vec<Pt>,
}

fn grid(x: u16, y: i16) -> [f64; 2] {
    [-2.0 + 207.0 * (f64::from(x) / 65535.0), 7.0 * (f64::from(y) / 32768.0)]
}

/// Detectors are large (46 KiB): keep one of each kind across runs.
static DETECTORS: Mutex<Option<(Box<LeadDetector>, Box<MaybeUninit<FlcDetector>>)>> = Mutex::new(None);

fuzz_target!(|inp: Input| {
    let d = DetectorParams::defaults();
    let [cell, x_min, min_w, max_w, max_depth, half] = inp.params;
    let [far_start, far_cell, spacing, join_gap, join_depth, depth_per_width, narrow, st_margin, st_share, rear_depth] = inp.far;
    let p = DetectorParams {
        cell_size: cell.get(d.cell_size, 0.0, 1.0),
        x_min: x_min.get(d.x_min, -1.0, 20.0),
        far_start: far_start.get(d.far_start, -1.0, 250.0),
        far_cell_size: far_cell.get(d.far_cell_size, 0.0, 3.0),
        dilation_radius: inp.dilation_radius % 10,
        max_dilation_radius: inp.max_dilation_radius % 10,
        beam_spacing_deg: spacing.get(d.beam_spacing_deg, 0.0, 2.0),
        bridge_beams: inp.bridge_beams % 120,
        join_gap: join_gap.get(d.join_gap, -0.5, 5.0),
        join_beams: inp.join_beams,
        join_depth: join_depth.get(d.join_depth, -0.5, 5.0),
        min_cluster_points: usize::from(inp.min_cluster_points % 12),
        min_width: min_w.get(d.min_width, -0.5, 5.0),
        max_width: max_w.get(d.max_width, 0.0, 6.0),
        max_depth: max_depth.get(d.max_depth, -0.5, 80.0),
        depth_per_width: depth_per_width.get(d.depth_per_width, -0.5, 10.0),
        path_half_width: half.get(d.path_half_width, 0.0, 8.0),
        narrow_width: narrow.get(d.narrow_width, -0.5, 5.0),
        swept_half_width: inp.swept.get(d.swept_half_width, -0.5, 5.0),
        body_half_width: inp.body.get(d.body_half_width, -0.5, 5.0),
        see_through_margin: st_margin.get(d.see_through_margin, -0.5, 5.0),
        see_through_share: st_share.get(d.see_through_share, -0.5, 2.0),
        rear_face_depth: rear_depth.get(d.rear_face_depth, -0.5, 5.0),
        max_points: if inp.max_points == 0 { d.max_points } else { usize::from(inp.max_points) },
        reprojection: if inp.cell_center { Reprojection::CellCenter } else { Reprojection::PointRefined },
    };
    let mut pts = Vec::new();
    for pt in inp.points.iter().take(4096) {
        match *pt {
            Pt::Raw(x, y) => pts.push([x, y]),
            Pt::Grid(x, y) => pts.push(grid(x, y)),
            Pt::Line(x, y, n, step, along_x) => {
                let [x0, y0] = grid(x, y);
                for i in 0..usize::from(n % 64) {
                    let o = f64::from(step) * 0.01 * i as f64;
                    pts.push(if along_x { [x0 + o, y0] } else { [x0, y0 + o] });
                }
            }
        }
    }
    let curvature = inp.curvature.get(-0.25, 0.25);

    let mut guard = DETECTORS.lock().unwrap();
    let (det, cdet) =
        guard.get_or_insert_with(|| (Box::new(<LeadDetector>::new(DetectorParams::defaults()).unwrap()), Box::new(MaybeUninit::uninit())));
    let cp = p.into();
    // SAFETY: valid pointers.
    let init = unsafe { flc_detector_init(cdet.as_mut_ptr(), &cp, std::ptr::null_mut()) };
    if det.reinit(p).is_err() {
        assert_eq!(init, FlcResult::InvalidParams);
        return;
    }
    assert_eq!(init, FlcResult::Ok);
    let out = det.detect(&pts, curvature);
    assert!(out.points_used + out.points_rejected <= pts.len().min(p.max_points));
    assert!(out.clusters <= CLUSTER_CAPACITY && out.clusters == det.clusters().len());
    assert_eq!(det.clusters().iter().filter(|c| c.selected).count(), usize::from(out.detection.is_some()));
    for c in det.clusters() {
        assert!(c.x_min.is_finite() && c.x_max.is_finite() && c.y_min.is_finite() && c.y_max.is_finite());
    }
    if let Some(found) = out.detection {
        let (x0, x1, y0, y1) = det.bounds(curvature);
        assert!(found.distance.is_finite() && found.position.y.is_finite());
        assert!(found.position.x >= x0 - 1e-9 && found.position.x <= x1 + 1e-9, "{found:?}");
        assert!(found.position.y >= y0 - 1e-9 && found.position.y <= y1 + 1e-9, "{found:?}");
        // The width test of step 7 uses the cluster's rear-face x (the cell centre that
        // `CellCenter` reports can lie up to half a cell nearer).
        let sel = det.clusters().iter().find(|c| c.selected).expect("the selected cluster");
        assert!(sel.width() + sel.x_min.max(0.0) * p.beam_spacing() >= p.min_width && found.width <= p.max_width, "{found:?} {sel:?}");
        assert!(found.depth >= 0.0 && found.depth <= p.max_depth && found.depth <= p.depth_per_width * found.width + 1.0);
        assert!(found.points >= p.min_points_at(found.distance) && found.points <= out.points_used);
        assert!((0.0..=1.0).contains(&found.confidence));
    }
    let mut co = MaybeUninit::<FlcDetectorOutput>::uninit();
    // SAFETY: initialised above; `pts` is a valid array of point pairs.
    let r = unsafe { flc_detector_detect(cdet.as_mut_ptr(), pts.as_ptr().cast(), pts.len(), curvature, co.as_mut_ptr()) };
    assert_eq!(r, FlcResult::Ok);
    // SAFETY: written on FlcResult::Ok.
    let co = unsafe { co.assume_init() };
    assert_eq!(co.has_detection, out.detection.is_some());
    assert_eq!(
        (co.points_used, co.points_rejected, co.clusters, co.status as u8),
        (out.points_used, out.points_rejected, out.clusters, out.status as u8)
    );
    if let Some(found) = out.detection {
        assert!(
            same(co.detection.distance, found.distance)
                && same(co.detection.y, found.position.y)
                && same(co.detection.confidence, found.confidence)
        );
    }
});
