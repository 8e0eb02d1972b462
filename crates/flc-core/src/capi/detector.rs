//! C interface of the lead detector ([`crate::detector`]): parameters, detection output, storage
//! `FlcDetector` (initialised in place), functions.

use core::mem::size_of;
use core::ptr::addr_of_mut;

use super::storage::{check_ptr, get_mut, init, param_error, report, storage, tri, write_out};
use super::{FlcParamError, FlcResult};
use crate::detector::{
    CLUSTER_CAPACITY, ClusterInfo, Detection, DetectorOutput, DetectorParams, DetectorStatus, LeadDetector, RUN_CAPACITY, Reprojection,
    Run, column_radii,
};
use crate::params::ParamError;

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

/// Mirror of the Rust `DetectorStatus`.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcDetectorStatus {
    /// The scan was processed completely ("no lead" is a valid result).
    Ok = 0,
    /// No finite point fell inside the grid.
    EmptyScan = 1,
    /// Some points were NaN or infinite; they were dropped.
    NonFinitePoints = 2,
    /// More than `max_points` points; only the first `max_points` were used.
    Truncated = 3,
    /// The run or cluster table overflowed; the nearest clusters were kept.
    TooManyClusters = 4,
    /// The path curvature was NaN or infinite; a straight path was used.
    InvalidCurvature = 5,
}

impl From<DetectorStatus> for FlcDetectorStatus {
    fn from(s: DetectorStatus) -> Self {
        match s {
            DetectorStatus::Ok => FlcDetectorStatus::Ok,
            DetectorStatus::EmptyScan => FlcDetectorStatus::EmptyScan,
            DetectorStatus::NonFinitePoints => FlcDetectorStatus::NonFinitePoints,
            DetectorStatus::Truncated => FlcDetectorStatus::Truncated,
            DetectorStatus::TooManyClusters => FlcDetectorStatus::TooManyClusters,
            DetectorStatus::InvalidCurvature => FlcDetectorStatus::InvalidCurvature,
        }
    }
}

/// Values of `FlcDetectorParams::reprojection` (Rust `Reprojection`).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcReprojection {
    /// Cell centres.
    CellCenter = 0,
    /// Raw points (default).
    PointRefined = 1,
}

/// Mirror of the Rust `DetectorParams` (the C API uses the default 520 x 60 grid).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcDetectorParams {
    /// Edge length of a grid cell, m.
    pub cell_size: f64,
    /// Forward distance to the near edge of the grid, m.
    pub x_min: f64,
    /// Where the far cells begin, m.
    pub far_start: f64,
    /// Length of a far cell, m.
    pub far_cell_size: f64,
    /// Horizontal angle between neighbouring LiDAR beams, degrees.
    pub beam_spacing_deg: f64,
    /// Largest lateral gap between joined fragments, m.
    pub join_gap: f64,
    /// Largest difference of joined fragments' rear-face x, m.
    pub join_depth: f64,
    /// Smallest lateral extent of a vehicle, m.
    pub min_width: f64,
    /// Largest lateral extent of a vehicle, m.
    pub max_width: f64,
    /// Largest longitudinal extent of a vehicle, m.
    pub max_depth: f64,
    /// Depth limit of narrow objects, m per m of width (plus 1 m).
    pub depth_per_width: f64,
    /// Lateral half width of the path corridor, m.
    pub path_half_width: f64,
    /// Objects narrower than this must lie wholly inside the corridor, m.
    pub narrow_width: f64,
    /// Half width of the swept path plus clearance, m: a body reaching within it is in path
    /// (replaces the two rules above when positive; 0 = off, the paper's corridor).
    pub swept_half_width: f64,
    /// Half width of the band the ego's body sweeps, m: a wide object whose body reaches within
    /// it is in path too, reported only when nothing else is (0 = off).
    pub body_half_width: f64,
    /// Solid-face test: a ray through the outline counts beyond this past its far edge, m.
    pub see_through_margin: f64,
    /// Solid-face test: rejected above this share of the cluster's point count.
    pub see_through_share: f64,
    /// Rear-face test of narrow candidates: depth of the rear face, m.
    pub rear_face_depth: f64,
    /// Fewest original points for a vehicle.
    pub min_cluster_points: u32,
    /// Most points used per scan.
    pub max_points: u32,
    /// Longitudinal radius of the dilation rectangle (columns) and its smallest lateral radius.
    pub dilation_radius: u8,
    /// Largest lateral radius of the dilation rectangle, cells.
    pub max_dilation_radius: u8,
    /// Missing neighbouring beams the lateral dilation bridges.
    pub bridge_beams: u8,
    /// Most consecutive missing beams between joined fragments.
    pub join_beams: u8,
    /// One of `FlcReprojection`.
    pub reprojection: u8,
}

/// Mirror of the Rust `Detection`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcDetection {
    /// Rear-face x (sensor frame), m.
    pub x: f64,
    /// Lateral centre y (sensor frame), m.
    pub y: f64,
    /// `LF_dist` for the FLC (= `x`), m.
    pub distance: f64,
    /// Lateral extent, m.
    pub width: f64,
    /// Longitudinal extent, m.
    pub depth: f64,
    /// Confidence in [0, 1].
    pub confidence: f64,
    /// Number of points in the cluster.
    pub points: usize,
}

/// Mirror of the Rust `DetectorOutput`. `detection` is all zero when `has_detection` is false.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcDetectorOutput {
    /// The nearest accepted cluster (valid when `has_detection`).
    pub detection: FlcDetection,
    /// Finite points (among the first `max_points`) inside the grid.
    pub points_used: usize,
    /// Non-finite points (among the first `max_points`) dropped.
    pub points_rejected: usize,
    /// Clusters found.
    pub clusters: usize,
    /// Outcome of the scan.
    pub status: FlcDetectorStatus,
    /// Whether a lead was found.
    pub has_detection: bool,
}

impl FlcDetection {
    /// The mirror of `d`, all zero for `None` (the outputs' `has_detection` says which).
    pub(super) fn from_option(d: Option<Detection>) -> Self {
        d.map_or(FlcDetection { x: 0.0, y: 0.0, distance: 0.0, width: 0.0, depth: 0.0, confidence: 0.0, points: 0 }, |d| FlcDetection {
            x: d.position.x,
            y: d.position.y,
            distance: d.distance,
            width: d.width,
            depth: d.depth,
            confidence: d.confidence,
            points: d.points,
        })
    }
}

impl From<DetectorOutput> for FlcDetectorOutput {
    fn from(o: DetectorOutput) -> Self {
        Self {
            detection: FlcDetection::from_option(o.detection),
            points_used: o.points_used,
            points_rejected: o.points_rejected,
            clusters: o.clusters,
            status: o.status.into(),
            has_detection: o.detection.is_some(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcDetector::storage` (63.4 KiB).
pub const FLC_DETECTOR_WORDS: usize = 8117;

/// Most offsets of a path profile (`flc_detector_set_path_profile`).
pub const FLC_PROFILE_STATIONS: usize = 64;
const _: () = assert!(FLC_PROFILE_STATIONS == crate::detector::PROFILE_STATIONS);

/// Caller-owned storage of one lead detector (default 520 x 60 grid). Initialise with
/// `flc_detector_init`. About 63 KiB: prefer static storage on small stacks.
#[repr(C)]
pub struct FlcDetector {
    magic: u64,
    storage: [u64; FLC_DETECTOR_WORDS],
}

storage!(FlcDetector, LeadDetector, 0x464C_435F_4445_5401); // "FLC_DET\x01"

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

impl From<DetectorParams> for FlcDetectorParams {
    fn from(p: DetectorParams) -> Self {
        let reprojection = match p.reprojection {
            Reprojection::CellCenter => FlcReprojection::CellCenter as u8,
            Reprojection::PointRefined => FlcReprojection::PointRefined as u8,
        };
        Self {
            cell_size: p.cell_size,
            x_min: p.x_min,
            far_start: p.far_start,
            far_cell_size: p.far_cell_size,
            beam_spacing_deg: p.beam_spacing_deg,
            join_gap: p.join_gap,
            join_depth: p.join_depth,
            min_width: p.min_width,
            max_width: p.max_width,
            max_depth: p.max_depth,
            depth_per_width: p.depth_per_width,
            path_half_width: p.path_half_width,
            narrow_width: p.narrow_width,
            swept_half_width: p.swept_half_width,
            body_half_width: p.body_half_width,
            see_through_margin: p.see_through_margin,
            see_through_share: p.see_through_share,
            rear_face_depth: p.rear_face_depth,
            min_cluster_points: u32::try_from(p.min_cluster_points).unwrap_or(u32::MAX),
            max_points: u32::try_from(p.max_points).unwrap_or(u32::MAX),
            dilation_radius: p.dilation_radius,
            max_dilation_radius: p.max_dilation_radius,
            bridge_beams: p.bridge_beams,
            join_beams: p.join_beams,
            reprojection,
        }
    }
}

impl TryFrom<FlcDetectorParams> for DetectorParams {
    type Error = ParamError;
    fn try_from(p: FlcDetectorParams) -> Result<Self, ParamError> {
        let reprojection = match p.reprojection {
            0 => Reprojection::CellCenter,
            1 => Reprojection::PointRefined,
            _ => return Err(param_error("reprojection", "must be one of FLC_REPROJECTION_*")),
        };
        // u32 -> usize is lossless on 32- and 64-bit targets; saturate elsewhere (then rejected).
        let min_cluster_points = usize::try_from(p.min_cluster_points).unwrap_or(usize::MAX);
        let max_points = usize::try_from(p.max_points).unwrap_or(usize::MAX);
        let params = DetectorParams {
            cell_size: p.cell_size,
            x_min: p.x_min,
            far_start: p.far_start,
            far_cell_size: p.far_cell_size,
            dilation_radius: p.dilation_radius,
            max_dilation_radius: p.max_dilation_radius,
            beam_spacing_deg: p.beam_spacing_deg,
            bridge_beams: p.bridge_beams,
            join_gap: p.join_gap,
            join_beams: p.join_beams,
            join_depth: p.join_depth,
            min_cluster_points,
            min_width: p.min_width,
            max_width: p.max_width,
            max_depth: p.max_depth,
            depth_per_width: p.depth_per_width,
            path_half_width: p.path_half_width,
            narrow_width: p.narrow_width,
            swept_half_width: p.swept_half_width,
            body_half_width: p.body_half_width,
            see_through_margin: p.see_through_margin,
            see_through_share: p.see_through_share,
            rear_face_depth: p.rear_face_depth,
            max_points,
            reprojection,
        };
        params.validate()?;
        Ok(params)
    }
}

// ---------------------------------------------------------------------------------------------
// Functions
// ---------------------------------------------------------------------------------------------

/// The detector's default parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_detector_params_default() -> FlcDetectorParams {
    DetectorParams::defaults().into()
}

/// Validates `*params` and initialises `*det` in place (a few hundred bytes of stack, whatever the
/// detector's size).
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`det`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_detector_init(
    det: *mut FlcDetector,
    params: *const FlcDetectorParams,
    error: *mut FlcParamError,
) -> FlcResult {
    // SAFETY: caller contract (that of `init`). `init` hands `init_detector_in_place` the storage
    // words, non-null, aligned and valid for writes of a `LeadDetector` (const-asserted size and
    // alignment); every field is written there before the magic word marks the detector
    // initialised.
    unsafe { init(det, params, error, DetectorParams::try_from, init_detector_in_place) }
}

/// Writes every field of a `LeadDetector` (the same state as `LeadDetector::new(params)`) without
/// a whole-detector temporary.
///
/// # Safety
/// `d` is non-null, aligned and valid for writes of `LeadDetector`.
unsafe fn init_detector_in_place(d: *mut LeadDetector, params: DetectorParams) {
    /// Fails to compile when a field is added to `LeadDetector` and not initialised here.
    #[allow(dead_code)]
    fn every_field_is_written(d: LeadDetector) {
        let LeadDetector {
            params: _,
            curvature: _,
            profile: _,
            profile_spacing: _,
            occupied: _,
            edges: _,
            dilated: _,
            radius: _,
            runs: _,
            parent: _,
            n_runs: _,
            col_first: _,
            col_len: _,
            clusters: _,
            n_clusters: _,
            point_cell: _,
            point_offset: _,
        } = d;
    }
    // SAFETY: caller contract; each `addr_of_mut!` projects to a field of `*d` without creating a
    // reference to uninitialised memory, and each write covers the whole field with valid values
    // (all-zero is a valid `[u64]`, `[u16]`, `[u8]`; runs and clusters get their EMPTY value; the
    // radius table is zeroed, so valid, before a reference to it is taken and it is filled).
    unsafe {
        addr_of_mut!((*d).params).write(params);
        addr_of_mut!((*d).curvature).write(0.0);
        addr_of_mut!((*d).profile).write_bytes(0, 1);
        addr_of_mut!((*d).profile_spacing).write(0.0);
        addr_of_mut!((*d).occupied).write_bytes(0, 1);
        addr_of_mut!((*d).edges).write_bytes(0, 1);
        addr_of_mut!((*d).dilated).write_bytes(0, 1);
        addr_of_mut!((*d).radius).write_bytes(0, 1);
        column_radii(&params, &mut *addr_of_mut!((*d).radius));
        let runs = addr_of_mut!((*d).runs).cast::<Run>();
        for i in 0..RUN_CAPACITY {
            runs.add(i).write(Run::EMPTY);
        }
        addr_of_mut!((*d).parent).write_bytes(0, 1);
        addr_of_mut!((*d).n_runs).write(0);
        addr_of_mut!((*d).col_first).write_bytes(0, 1);
        addr_of_mut!((*d).col_len).write_bytes(0, 1);
        let clusters = addr_of_mut!((*d).clusters).cast::<ClusterInfo>();
        for i in 0..CLUSTER_CAPACITY {
            clusters.add(i).write(ClusterInfo::EMPTY);
        }
        addr_of_mut!((*d).n_clusters).write(0);
        let cells = addr_of_mut!((*d).point_cell).cast::<u16>();
        for i in 0..crate::detector::POINT_CACHE {
            cells.add(i).write(crate::detector::NO_CELL);
        }
        addr_of_mut!((*d).point_offset).write_bytes(0, 1);
    }
}

/// Runs the detector on one scan: `points` is an array of `n_points` `[x, y]` pairs (sensor frame,
/// x forward, y left, m; may be NULL when `n_points` is 0), `path_curvature` in 1/m (0 =
/// straight). Never reads beyond `n_points` pairs, nor beyond `max_points`.
///
/// # Safety
/// `det` is NULL or points to an `FlcDetector`; `points` is NULL or valid for reads of
/// `2 * n_points` doubles; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_detector_detect(
    det: *mut FlcDetector,
    points: *const f64,
    n_points: usize,
    path_curvature: f64,
    out: *mut FlcDetectorOutput,
) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    let scan: &[[f64; 2]] = if n_points == 0 {
        &[]
    } else {
        let pts = points.cast::<[f64; 2]>();
        tri!(check_ptr(pts));
        if n_points > isize::MAX as usize / size_of::<[f64; 2]>() {
            return FlcResult::InvalidArgument;
        }
        // SAFETY: non-null and aligned (checked), the byte length fits in isize (checked), valid for
        // reads of `n_points` pairs (caller contract); `[f64; 2]` has the layout of two doubles.
        unsafe { core::slice::from_raw_parts(pts, n_points) }
    };
    // SAFETY: caller contract.
    let d = tri!(unsafe { get_mut(det) });
    let o = d.detect(scan, path_curvature);
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, o.into()) };
    FlcResult::Ok
}

/// Sets the path profile for the scans that follow (Rust `LeadDetector::set_path_profile`): where
/// the predicted path leaves the arc of `path_curvature`, `n_offsets` lateral offsets (m, + left;
/// at most `FLC_PROFILE_STATIONS`) at forward distances `0, spacing, 2 spacing, ...`; linear
/// between, the last value beyond. `spacing` 0 or `n_offsets` 0 removes it. A rejected profile
/// returns `FLC_RESULT_INVALID_PARAMS`, names the field in the optional `error` and leaves the
/// profile as it was. Cleared by `flc_detector_reset`.
///
/// # Safety
/// `det` is NULL or points to an `FlcDetector`; `offsets` is NULL or valid for reads of
/// `n_offsets` doubles; `error` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_detector_set_path_profile(
    det: *mut FlcDetector,
    spacing: f64,
    offsets: *const f64,
    n_offsets: usize,
    error: *mut FlcParamError,
) -> FlcResult {
    let offsets: &[f64] = if n_offsets == 0 {
        &[]
    } else {
        tri!(check_ptr(offsets));
        if n_offsets > FLC_PROFILE_STATIONS {
            // SAFETY: caller contract.
            return unsafe { report(error, param_error("offsets", "at most 64 offsets, each finite and within 100 m")) };
        }
        // SAFETY: non-null and aligned (checked), at most PROFILE_STATIONS doubles (checked),
        // valid for reads of `n_offsets` doubles (caller contract).
        unsafe { core::slice::from_raw_parts(offsets, n_offsets) }
    };
    // SAFETY: caller contract.
    let d = tri!(unsafe { get_mut(det) });
    match d.set_path_profile(spacing, offsets) {
        Ok(()) => FlcResult::Ok,
        // SAFETY: caller contract.
        Err(e) => unsafe { report(error, e) },
    }
}

/// Clears the last scan's grids and clusters (each detect starts from scratch anyway).
///
/// # Safety
/// `det` is NULL or points to an `FlcDetector`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_detector_reset(det: *mut FlcDetector) -> FlcResult {
    // SAFETY: caller contract.
    let d = tri!(unsafe { get_mut(det) });
    d.reset();
    FlcResult::Ok
}
