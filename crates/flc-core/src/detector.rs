//! The LiDAR lead-vehicle detector of Sec. III-A.1, with reach to 200 m.
//!
//! The paper (after Sabry et al., AutoNav 2024) only names the steps: "divides the area in front of
//! the follower vehicle into a 2D grid and identifies potential edge candidates. These edge
//! candidates are processed using the Dilation Morphological operation, followed by object
//! clustering [...]. The clustered objects that satisfy predefined geometric constraints are
//! classified as vehicles. The pixel coordinates of these vehicles are reprojected into meters".
//! This module implements exactly these steps on a fixed-size bird's-eye-view (BEV) grid laid
//! along the follower's predicted path (issue 23; `docs/detector.md` shows why, with measurements):
//!
//! ```text
//! (1) points   : drop non-finite points (counted); a point's grid coordinates are its forward
//!                distance x and its signed offset d from the predicted path (the arc of curvature
//!                kappa through the sensor, tangent to x), ignore points outside the grid
//! (2) grid     : occupancy bitmap, NX columns forward from x_min (cell_size long up to
//!                far_start, far_cell_size long beyond), NY cells of cell_size across the path
//! (3) edges    : occupied cells with at least one free 4-neighbour (outside the grid = free)
//! (4) dilation : a (2 r_x + 1) x (2 r_y + 1) rectangle: r_x = dilation_radius columns, r_y grows
//!                with range so that `bridge_beams` missing beams are bridged (at most
//!                max_dilation_radius cells)
//! (5) clusters : 8-connected components of the dilated map (run-based two-pass union-find)
//! (6) stats    : per cluster, extents and counts of the ORIGINAL points lying in its cells
//! (7) accept   : points >= the range's point threshold, width across the path in
//!                [min_width, max_width], depth <= max_depth, |centre offset| <= path_half_width
//!                (or, with swept_half_width > 0, the body reaching within it: issue 46;
//!                with body_half_width > 0 a wide body reaching within that too)
//! (8) select   : the accepted cluster with the smallest rear-face x (one in path by
//!                body_half_width alone only when there is no other)
//! (9) metres   : position = (rear-face x, lateral centre y); distance = rear-face x
//! ```
//!
//! Everything is fixed capacity (no allocation) and the result depends only on order-independent
//! aggregates (bitmaps, integer counts, minima and maxima), so it does not depend on the order of
//! the points. The thresholds and the grid resolution, which the paper leaves open, are the fields
//! of [`DetectorParams`]; see `docs/detector.md`.

use crate::command::clamp;
use crate::params::{ParamError, check_positive, check_range};
use nalgebra::Point2;

/// Capacity of the run table (maximal vertical runs of dilated cells per grid column) and of the
/// union-find parent table. When a scan produces more runs, the columns beyond the last stored run
/// (the far ones) are not clustered and the status is [`DetectorStatus::TooManyClusters`].
pub const RUN_CAPACITY: usize = 2048;

/// Capacity of the cluster table. When a scan has more clusters, the farthest ones (numbered by
/// their first grid column) are dropped and the status is [`DetectorStatus::TooManyClusters`].
pub const CLUSTER_CAPACITY: usize = 256;

/// Largest `|path_curvature|` the detector follows, 1/m (a 5 m radius); beyond it, and for NaN or
/// infinite curvatures, it uses a straight path ([`DetectorStatus::InvalidCurvature`]).
pub const MAX_CURVATURE: f64 = 0.2;

/// Most fragment candidates step 7b considers per scan (the nearest ones).
pub const JOIN_CAPACITY: usize = 32;

/// Points whose cell and path offset step 1 keeps for step 6 (the first ones of a scan), so that
/// step 6 does not compute them again; later points are computed twice (same result). 1280 covers
/// a whole scan of the default LiDAR (1201 rays) and takes 12.5 KiB.
pub const POINT_CACHE: usize = 1280;

/// Stations of a path profile ([`LeadDetector::set_path_profile`]).
pub const PROFILE_STATIONS: usize = 64;

/// A cached point outside the grid (or not finite).
pub(crate) const NO_CELL: u16 = u16::MAX;

const NO_CLUSTER: u16 = u16::MAX;

/// How the selected cluster's grid ("pixel") coordinates are reprojected into metres (step 9).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reprojection {
    /// Cell centres: rear face = centre of the nearest occupied cell column of the cluster,
    /// lateral position = centre of its occupied cell span (moved from the path frame into the
    /// sensor frame by the points' mean offset). Quantised to the cell size.
    CellCenter,
    /// Raw points: rear face = smallest x of the cluster's points, lateral position =
    /// `(min y + max y) / 2` of its points. Default.
    PointRefined,
}

/// Parameters of the detector. The paper gives none of these values; `Default` holds the
/// documented choices (see `docs/detector.md`).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorParams {
    /// Lateral size of a grid cell, and its length up to `far_start`, m. Default 0.2.
    pub cell_size: f64,
    /// Forward distance from the sensor to the near edge of the grid, m. Default 0.5 (drops
    /// returns from the follower's own body).
    pub x_min: f64,
    /// Where the long far cells begin, m (rounded to a whole number of near cells; at most `NX`
    /// near cells). Default 40.5: 200 cells of 0.2 m.
    pub far_start: f64,
    /// Length of a grid cell beyond `far_start`, m. Default 0.5: with `NX = 520` the grid ends at
    /// 200.5 m. (Beyond 40 m the beams of a 0.1 deg LiDAR are 7 cm or more apart; the raw points,
    /// not the cells, give the reported distance, so long cells cost no accuracy.)
    pub far_cell_size: f64,
    /// Longitudinal radius of the dilation rectangle, columns, and the smallest lateral radius,
    /// cells (0 = no dilation). Default 1: bridges gaps of up to two empty cells.
    pub dilation_radius: u8,
    /// Largest lateral radius the range-dependent growth reaches, cells (the radius is never below
    /// `dilation_radius`). Default 2:
    /// bridges lateral gaps up to 1.0 m, less than the 1.5-1.7 m between cars in adjacent lanes.
    pub max_dilation_radius: u8,
    /// Horizontal angle between neighbouring LiDAR beams, degrees (the sensor's resolution).
    /// Default 0.1 (the default simulated LiDAR; `docs/sim-model.md`).
    pub beam_spacing_deg: f64,
    /// Missing neighbouring beams (dropouts) the lateral dilation bridges at every range: the
    /// lateral radius at range x is the smallest r >= `dilation_radius` with
    /// `(2 r + 1) cell_size >= (bridge_beams + 1) x beam_spacing`, at most `max_dilation_radius`.
    /// Default 3.
    pub bridge_beams: u8,
    /// Largest lateral gap between fragments of one vehicle that step 7b joins, m (0 = no
    /// joining). Default 1.2: sparse returns (dropouts) can split a rear face into pieces that
    /// are each too narrow or too sparse; fragments whose rear faces lie within `join_depth` of
    /// each other and whose union fits a vehicle (width <= `max_width`, so never two cars in
    /// adjacent lanes) count as one, when the gap between them is at most `join_beams + 1` beam
    /// spacings at their range (that many missing beams) and at most `join_gap`.
    pub join_gap: f64,
    /// Most consecutive missing beams between joined fragments. Default 7 (at 0.1 deg: 0.14 m at
    /// 10 m, less than the dilation bridges, so no joining near the sensor; 0.84 m at 60 m).
    pub join_beams: u8,
    /// Largest difference of the fragments' rear-face x for joining, m. Default 1.0.
    pub join_depth: f64,
    /// Fewest original points for a vehicle near the sensor. Farther away the threshold is half
    /// the beams that the narrowest vehicle (`min_width`) returns at the cluster's range, but at
    /// least 2 (and never more than this). Default 3.
    pub min_cluster_points: usize,
    /// Smallest width across the path of a vehicle, m: the extent of its points plus one beam
    /// spacing at its range (an object w wide returns points between w and w minus one spacing
    /// apart) must reach it. Default 0.25: a pedestrian crossing the road, seen side-on (0.3 m
    /// deep in the ALKS scenarios' pedestrian catalogue, 0.27-0.30 m of returns; at 0.35 the
    /// detector never saw UN R157 4.2.3's pedestrian and `flc` hit it at 16.7 m/s), below half a
    /// 0.7 m motorcycle (the least of a target that counts as visible in the detection study); the
    /// solid-face tests of step 8 keep posts and rail fragments of that width out.
    pub min_width: f64,
    /// Largest extent across the path, m. Default 3.0 (trucks are ~2.55 m wide).
    pub max_width: f64,
    /// Largest longitudinal extent of a vehicle, m. Default 7.0 (rejects guard rails and walls).
    pub max_depth: f64,
    /// Narrow objects are short: the depth may not exceed `depth_per_width * width + 1 m` either
    /// (a 0.8 m motorcycle up to 3.4 m, a car 1.8 m wide up to 6.4 m). Default 3.0: a piece of
    /// guard rail seen at a grazing angle near the sensor (0.5 m across the path, 6 m long) is not
    /// a vehicle.
    pub depth_per_width: f64,
    /// Half width of the follower's path corridor, m: the centre of a vehicle's points must lie
    /// within it. Default 1.8 (half a 3.6 m lane).
    pub path_half_width: f64,
    /// Objects narrower than this must lie wholly inside the corridor, m. Default 1.2: a
    /// motorcycle rides inside the lane, while a post beside a guard rail at the corridor's edge
    /// (0.5 m wide, centred 1.8 m off the path) is not a vehicle; a car cutting in is wider and
    /// counts once its centre is inside.
    pub narrow_width: f64,
    /// Half width of the follower's swept path plus the clearance it keeps, m (issue 46): when
    /// positive, this replaces the narrow objects' rule above (wide ones keep the centre rule: a
    /// car cutting out leaves the path as with the paper's corridor). A narrow object whose body (its points'
    /// offsets from the predicted path, widened by one beam spacing at its range as in
    /// `min_width`) reaches within it is in path, whatever its width and
    /// centre: a motorbike standing on the lane marking, 1.35 m from the path, is in the path of
    /// a 1.9 m wide car keeping 0.5 m (1.45 m); a post beside a guard rail (1.55 m) and a car
    /// steady in the next lane (2.55 m) are not. Default 0 (off: the paper's corridor,
    /// `path_half_width` and `narrow_width`); the simulator's robust FLCs use the ego's half
    /// width plus 0.5 m (`docs/detector.md`).
    pub swept_half_width: f64,
    /// With this positive, a wide object (not below `narrow_width`) whose body (its returns'
    /// offsets from the path, widened by one beam spacing at its range) reaches within it of the
    /// path is in path too, whatever its centre: into the band the ego's own body sweeps, m
    /// (0 = off, the centre rule alone). Such an object is reported only when no object is in
    /// path by the other rules (a driver looks past a lead cutting out at what it reveals, but
    /// does not drive into a car on the lane marking). The simulator sets it to the ego's half
    /// width plus 0.5 m (the swept corridor's margin) for an ego that keeps its lane.
    pub body_half_width: f64,
    /// Step 8's solid-face test: a ray whose bearing lies strictly inside a cluster's bearing
    /// span and whose return is more than this beyond the cluster's far edge (x) passed through
    /// where the cluster would be a surface, m. Default 1.0. A vehicle's rear face and sides stop
    /// every ray inside its outline; a post and a piece of guard rail that fall into one cell
    /// do not (seen on the curvy route, 60-130 m ahead, where the arc to the lead crosses the rail).
    pub see_through_margin: f64,
    /// A candidate is rejected ([`RejectReason::SeeThrough`]) when more than this share of its
    /// point count passed through it. Default 0.25 (a 2-point cluster with one ray through it is
    /// not a surface; a car with 20 returns survives up to 5 stray rays).
    pub see_through_share: f64,
    /// A narrow candidate (narrower than `narrow_width`) needs a rear face: the returns within
    /// this of its nearest x must span at least half its bearing span, m. Default 1.0 (a
    /// motorcycle's rear face square to the path, or turned by 0.7 rad in a curve, lies within it;
    /// a guard rail seen at a grazing angle with a post behind it, seen on the curvy route, does
    /// not: [`RejectReason::NoRearFace`]).
    pub rear_face_depth: f64,
    /// Most points used per scan; later points are ignored ([`DetectorStatus::Truncated`]).
    /// Default 8192.
    pub max_points: usize,
    /// Reprojection of step 9. Default [`Reprojection::PointRefined`].
    pub reprojection: Reprojection,
}

impl Default for DetectorParams {
    fn default() -> Self {
        Self::defaults()
    }
}

impl DetectorParams {
    /// The documented default parameters (identical to `Default`).
    pub const fn defaults() -> Self {
        Self {
            cell_size: 0.2,
            x_min: 0.5,
            far_start: 40.5,
            far_cell_size: 0.5,
            dilation_radius: 1,
            max_dilation_radius: 2,
            beam_spacing_deg: 0.1,
            bridge_beams: 3,
            join_gap: 1.2,
            join_beams: 7,
            join_depth: 1.0,
            min_cluster_points: 3,
            min_width: 0.25,
            max_width: 3.0,
            max_depth: 7.0,
            depth_per_width: 3.0,
            path_half_width: 1.8,
            narrow_width: 1.2,
            swept_half_width: 0.0,
            body_half_width: 0.0,
            see_through_margin: 1.0,
            see_through_share: 0.25,
            rear_face_depth: 1.0,
            max_points: 8192,
            reprojection: Reprojection::PointRefined,
        }
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_positive("cell_size", self.cell_size, 10.0, "must be finite and in (0, 10] m")?;
        check_range("x_min", self.x_min, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        check_range("far_start", self.far_start, 0.0, 1000.0, "must be finite and in [0, 1000] m")?;
        if self.far_start < self.x_min {
            return Err(ParamError { field: "far_start", problem: "must be >= x_min" });
        }
        check_positive("far_cell_size", self.far_cell_size, 50.0, "must be finite and in (0, 50] m")?;
        if self.dilation_radius > 8 {
            return Err(ParamError { field: "dilation_radius", problem: "must be in [0, 8] cells" });
        }
        if self.max_dilation_radius > 8 {
            return Err(ParamError { field: "max_dilation_radius", problem: "must be in [0, 8] cells" });
        }
        check_positive("beam_spacing_deg", self.beam_spacing_deg, 10.0, "must be finite and in (0, 10] deg")?;
        if self.bridge_beams > 100 {
            return Err(ParamError { field: "bridge_beams", problem: "must be in [0, 100]" });
        }
        check_range("join_gap", self.join_gap, 0.0, 50.0, "must be finite and in [0, 50] m")?;
        check_range("join_depth", self.join_depth, 0.0, 100.0, "must be finite and in [0, 100] m")?;
        if !(1..=1_000_000).contains(&self.min_cluster_points) {
            return Err(ParamError { field: "min_cluster_points", problem: "must be in [1, 1e6]" });
        }
        check_range("min_width", self.min_width, 0.0, 50.0, "must be finite and in [0, 50] m")?;
        check_positive("max_width", self.max_width, 50.0, "must be finite and in (0, 50] m")?;
        if self.max_width < self.min_width {
            return Err(ParamError { field: "max_width", problem: "must be >= min_width" });
        }
        check_range("max_depth", self.max_depth, 0.0, 1000.0, "must be finite and in [0, 1000] m")?;
        check_range("depth_per_width", self.depth_per_width, 0.0, 1000.0, "must be finite and in [0, 1000]")?;
        check_positive("path_half_width", self.path_half_width, 100.0, "must be finite and in (0, 100] m")?;
        check_range("narrow_width", self.narrow_width, 0.0, 50.0, "must be finite and in [0, 50] m")?;
        check_range("swept_half_width", self.swept_half_width, 0.0, 100.0, "must be finite and in [0, 100] m (0 = off)")?;
        check_range("body_half_width", self.body_half_width, 0.0, 100.0, "must be finite and in [0, 100] m (0 = off)")?;
        check_range("see_through_margin", self.see_through_margin, 0.0, 1000.0, "must be finite and in [0, 1000] m")?;
        check_range("see_through_share", self.see_through_share, 0.0, 1e6, "must be finite and in [0, 1e6]")?;
        check_range("rear_face_depth", self.rear_face_depth, 0.0, 1000.0, "must be finite and in [0, 1000] m")?;
        if !(1..=1_000_000).contains(&self.max_points) {
            return Err(ParamError { field: "max_points", problem: "must be in [1, 1e6]" });
        }
        Ok(())
    }

    /// Beam spacing in radians.
    pub fn beam_spacing(&self) -> f64 {
        self.beam_spacing_deg * (core::f64::consts::PI / 180.0)
    }

    /// The fewest points a cluster whose rear face is at `x` (m) needs: `min_cluster_points` near
    /// the sensor; farther away half the beams the narrowest vehicle returns there, at least 2.
    pub fn min_points_at(&self, x: f64) -> usize {
        let beams = self.min_width / (x.max(1e-3) * self.beam_spacing());
        let half = 0.5 * beams;
        let n = if half >= self.min_cluster_points as f64 {
            self.min_cluster_points
        } else if half >= 2.0 {
            half as usize
        } else {
            2
        };
        n.min(self.min_cluster_points)
    }

    /// Lateral dilation radius (cells) at range `x` (m): see [`DetectorParams::bridge_beams`].
    pub fn lateral_radius_at(&self, x: f64) -> u8 {
        let gap = f64::from(self.bridge_beams) + 1.0;
        let need = (gap * x.max(0.0) * self.beam_spacing() / self.cell_size - 1.0) * 0.5;
        let mut r = self.dilation_radius;
        while r < self.max_dilation_radius && f64::from(r) < need {
            r += 1;
        }
        r
    }
}

/// Outcome of one [`LeadDetector::detect`] call. Only one status is reported; when several apply,
/// the first in this order wins: `InvalidCurvature`, `TooManyClusters`, `Truncated`, `EmptyScan`,
/// `NonFinitePoints`, `Ok`. Every status except `EmptyScan` may come with a detection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum DetectorStatus {
    /// The scan was processed completely ("no lead", `detection: None`, is a valid result).
    Ok = 0,
    /// No finite point fell inside the grid.
    EmptyScan = 1,
    /// Some points were NaN or infinite; they were dropped (see `points_rejected`).
    NonFinitePoints = 2,
    /// The scan had more than `max_points` points; only the first `max_points` were used.
    Truncated = 3,
    /// The run or cluster table overflowed; the nearest clusters were kept (best effort).
    TooManyClusters = 4,
    /// The path curvature was NaN, infinite or beyond [`MAX_CURVATURE`]; a straight path
    /// (curvature 0) was used.
    InvalidCurvature = 5,
}
impl DetectorStatus {
    /// `true` for [`DetectorStatus::Ok`].
    pub const fn is_ok(self) -> bool {
        matches!(self, DetectorStatus::Ok)
    }

    /// A short, stable, lower-case name (used by the simulator's JSON and the Python bindings).
    pub const fn as_str(self) -> &'static str {
        match self {
            DetectorStatus::Ok => "ok",
            DetectorStatus::EmptyScan => "empty_scan",
            DetectorStatus::NonFinitePoints => "non_finite_points",
            DetectorStatus::Truncated => "truncated",
            DetectorStatus::TooManyClusters => "too_many_clusters",
            DetectorStatus::InvalidCurvature => "invalid_curvature",
        }
    }
}

impl core::fmt::Display for DetectorStatus {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a cluster was not classified as a vehicle (step 7). Checked in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RejectReason {
    /// Fewer than `min_cluster_points` original points.
    TooFewPoints,
    /// Lateral extent of the points below `min_width`.
    TooNarrow,
    /// Lateral extent of the points above `max_width`.
    TooWide,
    /// Longitudinal extent of the points above `max_depth`.
    TooDeep,
    /// Not in the corridor: the lateral centre farther than `path_half_width` from the predicted
    /// path (or a narrow object not wholly inside), or with `swept_half_width` set, no point of
    /// the body within it.
    OffPath,
    /// A fragment joined into an earlier cluster to form one vehicle (step 7b); that cluster
    /// holds the joined statistics.
    Joined,
    /// Rays passed through the cluster's outline to returns beyond it (step 8): not a solid
    /// surface ([`DetectorParams::see_through_margin`]).
    SeeThrough,
    /// A narrow candidate whose nearest returns do not span half its bearing span (step 8):
    /// no rear face ([`DetectorParams::rear_face_depth`]).
    NoRearFace,
}

impl RejectReason {
    /// A short, stable, lower-case name.
    pub const fn as_str(self) -> &'static str {
        match self {
            RejectReason::TooFewPoints => "too_few_points",
            RejectReason::TooNarrow => "too_narrow",
            RejectReason::TooWide => "too_wide",
            RejectReason::TooDeep => "too_deep",
            RejectReason::OffPath => "off_path",
            RejectReason::Joined => "joined",
            RejectReason::SeeThrough => "see_through",
            RejectReason::NoRearFace => "no_rear_face",
        }
    }
}

/// One cluster of the last scan, for visualisation and diagnostics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterInfo {
    /// Smallest x of the cluster's original points (rear face), m.
    pub x_min: f64,
    /// Largest x of the cluster's original points, m.
    pub x_max: f64,
    /// Smallest y of the cluster's original points, m.
    pub y_min: f64,
    /// Largest y of the cluster's original points, m.
    pub y_max: f64,
    /// Smallest offset of the cluster's points from the predicted path (+ left), m.
    pub d_min: f64,
    /// Largest offset of the cluster's points from the predicted path (+ left), m.
    pub d_max: f64,
    /// Smallest bearing tangent `y / x` of the cluster's points.
    pub b_min: f64,
    /// Largest bearing tangent `y / x` of the cluster's points.
    pub b_max: f64,
    /// Smallest x index of the occupied cells holding the points.
    pub ix_min: u16,
    /// Largest x index of the occupied cells holding the points.
    pub ix_max: u16,
    /// Smallest y index of the occupied cells holding the points.
    pub iy_min: u16,
    /// Largest y index of the occupied cells holding the points.
    pub iy_max: u16,
    /// Number of original points in the cluster's cells.
    pub points: usize,
    /// Number of dilated cells forming the cluster.
    pub cells: usize,
    /// `None` when the cluster passed every geometric constraint (a vehicle).
    pub rejection: Option<RejectReason>,
    /// `true` for the cluster reported as the lead.
    pub selected: bool,
}

impl ClusterInfo {
    pub(crate) const EMPTY: Self = Self {
        x_min: f64::INFINITY,
        x_max: f64::NEG_INFINITY,
        y_min: f64::INFINITY,
        y_max: f64::NEG_INFINITY,
        d_min: f64::INFINITY,
        d_max: f64::NEG_INFINITY,
        b_min: f64::INFINITY,
        b_max: f64::NEG_INFINITY,
        ix_min: u16::MAX,
        ix_max: 0,
        iy_min: u16::MAX,
        iy_max: 0,
        points: 0,
        cells: 0,
        rejection: None,
        selected: false,
    };

    /// `true` when the cluster was classified as a vehicle.
    pub const fn accepted(&self) -> bool {
        self.rejection.is_none()
    }

    /// Extent of the points across the predicted path, m (on a straight path the lateral
    /// extent `y_max - y_min`; on a curved one the width of a rear face square to the path).
    pub fn width(&self) -> f64 {
        self.d_max - self.d_min
    }

    /// Offset of the cluster's centre from the predicted path, `(d_min + d_max) / 2`, m.
    pub fn center_offset(&self) -> f64 {
        0.5 * (self.d_min + self.d_max)
    }

    /// Longitudinal extent of the points, m.
    pub fn depth(&self) -> f64 {
        self.x_max - self.x_min
    }

    /// Lateral centre `(y_min + y_max) / 2` of the points, m.
    pub fn center_y(&self) -> f64 {
        0.5 * (self.y_min + self.y_max)
    }

    #[inline]
    fn add_point(&mut self, x: f64, y: f64, d: f64) {
        // Plain comparisons: the values are finite and -0.0 is normalised by the caller, so this is
        // `min` / `max` without their NaN handling.
        if d < self.d_min {
            self.d_min = d;
        }
        if d > self.d_max {
            self.d_max = d;
        }
        if x < self.x_min {
            self.x_min = x;
        }
        if x > self.x_max {
            self.x_max = x;
        }
        if y < self.y_min {
            self.y_min = y;
        }
        if y > self.y_max {
            self.y_max = y;
        }
        // x >= the grid's start (> 0) for every point in a cell.
        let b = y / x;
        if b < self.b_min {
            self.b_min = b;
        }
        if b > self.b_max {
            self.b_max = b;
        }
        self.points += 1;
    }
}

/// The lead vehicle found in a scan, in the sensor frame (x forward, y left), m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// `(rear-face x, lateral centre y)`, reprojected as set by [`DetectorParams::reprojection`].
    pub position: Point2<f64>,
    /// Longitudinal distance from the sensor to the lead's rear face (`= position.x`), m. This is
    /// the `LF_dist` the FLC uses.
    pub distance: f64,
    /// Extent of the cluster's points across the predicted path, m ([`ClusterInfo::width`]).
    pub width: f64,
    /// Longitudinal extent of the cluster's points, m.
    pub depth: f64,
    /// Number of original points in the cluster.
    pub points: usize,
    /// `min(1, points / (4 n_min)) * (1 - 0.5 min(1, |width - w_ref| / w_half))` with `n_min` the
    /// point threshold at its range ([`DetectorParams::min_points_at`]),
    /// `w_ref = (min_width + max_width) / 2` and `w_half = (max_width - min_width) / 2`; in [0, 1].
    pub confidence: f64,
}

/// Result of [`LeadDetector::detect`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorOutput {
    /// The nearest accepted cluster, if any.
    pub detection: Option<Detection>,
    /// See [`DetectorStatus`].
    pub status: DetectorStatus,
    /// Finite points (among the first `max_points`) that fell inside the grid.
    pub points_used: usize,
    /// Non-finite points (among the first `max_points`) that were dropped.
    pub points_rejected: usize,
    /// Clusters found (at most [`CLUSTER_CAPACITY`]); see [`LeadDetector::clusters`].
    pub clusters: usize,
}

/// A maximal vertical run of dilated cells in one grid column.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Run {
    y0: u8,
    y1: u8,
    cluster: u16,
}

impl Run {
    pub(crate) const EMPTY: Self = Self { y0: 0, y1: 0, cluster: NO_CLUSTER };
}

/// Grid geometry in metres, for one scan's path curvature.
#[derive(Debug, Clone, Copy)]
struct Geometry<'a> {
    x_lo: f64,
    cell: f64,
    /// Start of the far cells (`x_lo + n_near * cell`).
    x_far: f64,
    far_cell: f64,
    n_near: usize,
    nx: usize,
    ny: usize,
    /// Lateral (path-offset) edge of the grid, `-ny * cell / 2`.
    d_lo: f64,
    /// Path curvature, 1/m (finite, |kappa| <= MAX_CURVATURE).
    kappa: f64,
    /// The path's departure from the arc at stations `k / inv_spacing` ahead, m
    /// ([`LeadDetector::set_path_profile`]); unused while `inv_spacing` is 0.
    profile: &'a [f64; PROFILE_STATIONS],
    /// 1 / station spacing, 1/m; 0: no profile (the path is the arc).
    inv_spacing: f64,
    /// Largest `|profile|`, m.
    profile_reach: f64,
}

/// The profile of a path that is the arc.
static NO_PROFILE: [f64; PROFILE_STATIONS] = [0.0; PROFILE_STATIONS];

impl<'a> Geometry<'a> {
    fn new(p: &DetectorParams, nx: usize, ny: usize, kappa: f64) -> Self {
        let near = (p.far_start - p.x_min) / p.cell_size + 0.5;
        // Truncating cast of a finite non-negative value (validated), saturated to the grid.
        let n_near = if near >= 0.0 && near < nx as f64 { near as usize } else { nx };
        Self {
            x_lo: p.x_min,
            cell: p.cell_size,
            x_far: p.x_min + n_near as f64 * p.cell_size,
            far_cell: p.far_cell_size,
            n_near,
            nx,
            ny,
            d_lo: -0.5 * ny as f64 * p.cell_size,
            kappa,
            profile: &NO_PROFILE,
            inv_spacing: 0.0,
            profile_reach: 0.0,
        }
    }

    /// This geometry with the path profile `profile` at stations `spacing` m apart (`spacing` 0:
    /// none).
    fn with_profile(mut self, profile: &'a [f64; PROFILE_STATIONS], spacing: f64) -> Self {
        if spacing > 0.0 {
            self.profile = profile;
            self.inv_spacing = 1.0 / spacing;
            self.profile_reach = profile.iter().fold(0.0, |m: f64, &o| m.max(libm::fabs(o)));
        }
        self
    }

    /// The path's departure from the arc at forward distance `x`, m: linear between stations,
    /// the first station's value before it and the last's beyond (0 without a profile).
    #[inline]
    fn departure(&self, x: f64) -> f64 {
        let f = x * self.inv_spacing;
        if f.is_nan() || f <= 0.0 {
            return self.profile[0];
        }
        if f >= (PROFILE_STATIONS - 1) as f64 {
            return self.profile[PROFILE_STATIONS - 1];
        }
        // `f` is finite and in (0, PROFILE_STATIONS - 1): the cast is floor and in range.
        let i = f as usize;
        let (a, b) = (self.profile.get(i).copied().unwrap_or(0.0), self.profile.get(i + 1).copied().unwrap_or(0.0));
        a + (f - i as f64) * (b - a)
    }

    /// Forward end of the grid, m.
    fn x_hi(&self) -> f64 {
        self.x_far + (self.nx - self.n_near) as f64 * self.far_cell
    }

    /// Near edge and length of column `ix`, m.
    fn column(&self, ix: usize) -> (f64, f64) {
        if ix < self.n_near {
            (self.x_lo + ix as f64 * self.cell, self.cell)
        } else {
            (self.x_far + (ix - self.n_near) as f64 * self.far_cell, self.far_cell)
        }
    }

    /// Signed offset of `(x, y)` from the path, + left: for `kappa != 0` the distance to the circle
    /// of radius `1/kappa` through the sensor tangent to x,
    /// `(2 y - kappa (x^2 + y^2)) / (1 + sqrt((kappa x)^2 + (1 - kappa y)^2))` (no cancellation
    /// for small kappa; the root is at least 0, the denominator at least 1). `None` for points on the
    /// far half of that circle (`1 - kappa y <= 0`: more than a quarter turn along the path).
    ///
    /// With a path profile, less the path's departure from the arc at `x` ([`Geometry::departure`]).
    #[inline]
    fn offset(&self, x: f64, y: f64) -> Option<f64> {
        let d = self.arc_offset(x, y)?;
        Some(if self.inv_spacing > 0.0 { d - self.departure(x) } else { d })
    }

    /// The offset from the arc alone (see [`Geometry::offset`]).
    #[inline]
    fn arc_offset(&self, x: f64, y: f64) -> Option<f64> {
        let k = self.kappa;
        if k == 0.0 {
            return Some(y);
        }
        let c = 1.0 - k * y;
        if c.is_nan() || c <= 0.0 {
            return None;
        }
        let kx = k * x;
        Some((2.0 * y - k * (x * x + y * y)) / (1.0 + libm::sqrt(kx * kx + c * c)))
    }

    // Inlined into the detector's two per-point loops (also across crates, e.g. into the
    // simulator): about 10 % of a scan's instructions otherwise go to the calls.
    /// The cell `(ix, iy)` of the point `(x, y)` and its path offset `d`, if inside the grid.
    #[inline]
    fn cell_of(&self, x: f64, y: f64) -> Option<(usize, usize, f64)> {
        let ix = self.column_of(x)?;
        let d = self.offset(x, y)?;
        Some((ix, self.row_of(d)?, d))
    }

    /// The column holding forward distance `x`, if inside the grid; non-decreasing in `x` (so the
    /// column of a cluster's smallest x is its smallest column).
    #[inline]
    fn column_of(&self, x: f64) -> Option<usize> {
        // Written so that NaN falls through to `None`. For fx >= 0 the truncating cast is floor()
        // (and much cheaper than libm's software floor).
        let ix = if x < self.x_far {
            let fx = (x - self.x_lo) / self.cell;
            if fx.is_nan() || fx < 0.0 {
                return None;
            }
            // `fx` is finite and in [0, n_near + 1): the signed cast is exact (and one instruction,
            // where the unsigned one is several on x86-64).
            (fx as i64 as usize).min(self.n_near.saturating_sub(1))
        } else {
            let fx = (x - self.x_far) / self.far_cell;
            if !(fx >= 0.0 && fx < (self.nx - self.n_near) as f64) {
                return None;
            }
            self.n_near + fx as i64 as usize
        };
        (ix < self.nx).then_some(ix)
    }

    /// The lateral cell holding path offset `d`, if inside the grid; non-decreasing in `d`.
    #[inline]
    fn row_of(&self, d: f64) -> Option<usize> {
        let fy = (d - self.d_lo) / self.cell;
        (fy >= 0.0 && fy < self.ny as f64).then(|| (fy as i64 as usize).min(self.ny.saturating_sub(1)))
    }
}

/// The BEV-grid lead detector: `NX` columns forward starting at `x_min` (`cell_size` long up to
/// `far_start`, `far_cell_size` beyond), `NY` cells of `cell_size` across the predicted path
/// (`NY <= 64`, checked at compile time). The default `LeadDetector<520, 60>` covers x in
/// [0.5, 200.5] m (200 columns of 0.2 m, then 320 of 0.5 m) and 6 m either side of the path, and
/// takes 64 408 bytes = 62.9 KiB on 64-bit targets (a test checks
/// `size_of::<LeadDetector>() <= 64 KiB`).
///
/// Each grid column is one `u64` bitmap (bit `iy` = lateral cell `iy`), so occupancy, edges and
/// the dilated map take `3 * 8 * NX` bytes. Build with `<LeadDetector>::new(params)` (the
/// angle brackets select the default grid size).
#[derive(Debug, Clone)]
pub struct LeadDetector<const NX: usize = 520, const NY: usize = 60> {
    // The fields are crate-visible only so that the C interface (`capi`) can initialise a detector
    // in caller-owned memory field by field, without a whole-detector temporary on the stack.
    pub(crate) params: DetectorParams,
    /// Path curvature of the last scan (0 before the first), 1/m.
    pub(crate) curvature: f64,
    /// The path profile ([`LeadDetector::set_path_profile`]): the path's departure from the arc
    /// at stations `profile_spacing` m apart; `profile_spacing` 0: none.
    pub(crate) profile: [f64; PROFILE_STATIONS],
    pub(crate) profile_spacing: f64,
    pub(crate) occupied: [u64; NX],
    pub(crate) edges: [u64; NX],
    pub(crate) dilated: [u64; NX],
    /// Lateral dilation radius of each column ([`DetectorParams::lateral_radius_at`]).
    pub(crate) radius: [u8; NX],
    pub(crate) runs: [Run; RUN_CAPACITY],
    pub(crate) parent: [u16; RUN_CAPACITY],
    pub(crate) n_runs: usize,
    /// Index of the first run of each column and the number of runs in it (for O(1) lookups).
    pub(crate) col_first: [u16; NX],
    pub(crate) col_len: [u8; NX],
    pub(crate) clusters: [ClusterInfo; CLUSTER_CAPACITY],
    pub(crate) n_clusters: usize,
    /// Step 1's cell (`ix * NY + iy`, [`NO_CELL`] outside) and offset of the scan's first
    /// [`POINT_CACHE`] points, read back by step 6 of the same scan (never across scans).
    pub(crate) point_cell: [u16; POINT_CACHE],
    pub(crate) point_offset: [f64; POINT_CACHE],
}

/// Writes 0 into the columns of `columns` outside `span`: a pass that then writes every column in
/// `span` leaves the whole array as a clear-then-write would, without writing the span twice.
fn zero_outside(columns: &mut [u64], span: &core::ops::Range<usize>) {
    let n = columns.len();
    for c in columns.get_mut(..span.start.min(n)).unwrap_or(&mut []) {
        *c = 0;
    }
    for c in columns.get_mut(span.end.min(n)..).unwrap_or(&mut []) {
        *c = 0;
    }
}

/// Fills `radius` with the lateral dilation radius of each column of a grid with `params`.
pub(crate) fn column_radii<const NX: usize>(params: &DetectorParams, radius: &mut [u8; NX]) {
    let g = Geometry::new(params, NX, 1, 0.0);
    for (ix, r) in radius.iter_mut().enumerate() {
        let (x0, len) = g.column(ix);
        *r = params.lateral_radius_at(x0 + 0.5 * len);
    }
}

impl<const NX: usize, const NY: usize> LeadDetector<NX, NY> {
    /// Validates `params` and builds the detector.
    pub fn new(params: DetectorParams) -> Result<Self, ParamError> {
        const {
            assert!(NX >= 1 && NX <= u16::MAX as usize, "LeadDetector: NX must be in [1, 65535]");
            assert!(NY >= 1 && NY <= 64, "LeadDetector: NY must be in [1, 64] (one u64 per column)");
        }
        params.validate()?;
        let mut radius = [0; NX];
        column_radii(&params, &mut radius);
        Ok(Self {
            params,
            curvature: 0.0,
            profile: [0.0; PROFILE_STATIONS],
            profile_spacing: 0.0,
            occupied: [0; NX],
            edges: [0; NX],
            dilated: [0; NX],
            radius,
            runs: [Run::EMPTY; RUN_CAPACITY],
            parent: [0; RUN_CAPACITY],
            n_runs: 0,
            col_first: [0; NX],
            col_len: [0; NX],
            clusters: [ClusterInfo::EMPTY; CLUSTER_CAPACITY],
            n_clusters: 0,
            point_cell: [NO_CELL; POINT_CACHE],
            point_offset: [0.0; POINT_CACHE],
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &DetectorParams {
        &self.params
    }

    /// Validates `params` and re-initialises this detector in place with them (the same state as
    /// [`LeadDetector::new`]). Unlike `new`, which returns the whole detector by value (tens of KiB
    /// that may pass through the stack), this needs only a few bytes of stack: use it on small
    /// stacks, e.g. on a detector kept in a `static`. On error nothing is changed.
    pub fn reinit(&mut self, params: DetectorParams) -> Result<(), ParamError> {
        params.validate()?;
        self.params = params;
        column_radii(&self.params, &mut self.radius);
        self.reset();
        Ok(())
    }

    /// Clears the grids, runs and clusters of the last scan, its curvature and the path profile
    /// (the parameters stay). Each [`LeadDetector::detect`] starts from scratch anyway, so this only clears what
    /// the diagnostic accessors ([`LeadDetector::clusters`], [`LeadDetector::is_occupied`], ...)
    /// show.
    pub fn reset(&mut self) {
        self.curvature = 0.0;
        self.profile = [0.0; PROFILE_STATIONS];
        self.profile_spacing = 0.0;
        self.occupied.fill(0);
        self.edges.fill(0);
        self.dilated.fill(0);
        self.runs.fill(Run::EMPTY);
        self.parent.fill(0);
        self.n_runs = 0;
        self.col_first.fill(0);
        self.col_len.fill(0);
        self.clusters.fill(ClusterInfo::EMPTY);
        self.n_clusters = 0;
        self.point_cell.fill(NO_CELL);
        self.point_offset.fill(0.0);
    }

    /// Grid size in cells, `(NX, NY)`.
    pub const fn grid_size() -> (usize, usize) {
        (NX, NY)
    }

    /// Forward extent of the grid `[x_min, end)`, m.
    pub fn x_range(&self) -> (f64, f64) {
        let g = self.geometry(0.0);
        (g.x_lo, g.x_hi())
    }

    /// Extent of the grid across the path, `[-NY * cell_size / 2, NY * cell_size / 2)`, m.
    pub fn y_range(&self) -> (f64, f64) {
        let g = self.geometry(0.0);
        (g.d_lo, g.d_lo + NY as f64 * g.cell)
    }

    /// A box `(x0, x1, y0, y1)` in the sensor frame that holds every point the grid can take for
    /// a scan with `path_curvature` (the whole grid bends along the path); for prefiltering scans.
    pub fn bounds(&self, path_curvature: f64) -> (f64, f64, f64, f64) {
        grid_box(&self.geometry(valid_curvature(path_curvature).unwrap_or(0.0)))
    }

    /// The cell `(ix, iy)` holding the point `(x, y)` on the last scan's path, if inside the grid.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        self.geometry(self.curvature).cell_of(x, y).map(|(ix, iy, _)| (ix, iy))
    }

    /// Centre of cell `(ix, iy)` in path coordinates: forward distance x and offset from the path
    /// (on a straight path the sensor frame), m. Not checked against the grid size.
    pub fn cell_center(&self, ix: usize, iy: usize) -> Point2<f64> {
        let g = self.geometry(self.curvature);
        let (x0, len) = g.column(ix);
        Point2::new(x0 + 0.5 * len, g.d_lo + (iy as f64 + 0.5) * g.cell)
    }

    /// Occupancy (step 2) of cell `(ix, iy)` in the last scan; `false` outside the grid.
    pub fn is_occupied(&self, ix: usize, iy: usize) -> bool {
        bit(&self.occupied, ix, iy)
    }

    /// Edge candidate (step 3) at cell `(ix, iy)` in the last scan; `false` outside the grid.
    pub fn is_edge(&self, ix: usize, iy: usize) -> bool {
        bit(&self.edges, ix, iy)
    }

    /// Dilated edge map (step 4) at cell `(ix, iy)` in the last scan; `false` outside the grid.
    pub fn is_dilated(&self, ix: usize, iy: usize) -> bool {
        bit(&self.dilated, ix, iy)
    }

    /// All clusters of the last scan, numbered by their nearest grid column.
    pub fn clusters(&self) -> &[ClusterInfo] {
        self.clusters.get(..self.n_clusters).unwrap_or(&[])
    }

    fn geometry(&self, kappa: f64) -> Geometry<'_> {
        Geometry::new(&self.params, NX, NY, kappa).with_profile(&self.profile, self.profile_spacing)
    }

    /// Sets the **path profile** for the scans that follow: where the predicted path leaves the
    /// arc of `path_curvature` ([`LeadDetector::detect`]), as lateral offsets (m, + left) at
    /// forward distances `0, spacing, 2 spacing, ...` (at most [`PROFILE_STATIONS`]; linear
    /// between, the last value beyond). A point's offset from the path is then its offset from
    /// the arc less the profile at its forward distance. The points stay as measured, so their
    /// bearings (step 8's see-through test) stay true.
    ///
    /// For a follower keeping its lane: the lane ahead as the arc of the curvature at the ego plus
    /// where the lane departs from it (an S-bend, the start of a curve: on R = 1000 m arcs
    /// reversing 40 m ahead the arc is 1.6 m off the lane at 80 m). `spacing` 0 (or an empty
    /// `offsets`) removes the profile: the path is the arc. Errors, leaving the profile as it
    /// was: `spacing` not finite or negative (`"spacing"`), an offset not finite or beyond
    /// 100 m, or more than [`PROFILE_STATIONS`] of them (`"offsets"`).
    ///
    /// ```
    /// use flc_core::{DetectorParams, LeadDetector};
    /// let mut d = <LeadDetector>::new(DetectorParams::default()).unwrap();
    /// // A car's rear face 40 m ahead, 1.8 m wide, centred 3 m to the left.
    /// let face: Vec<[f64; 2]> = (0..=12).map(|i| [40.0, 2.1 + 0.15 * f64::from(i)]).collect();
    /// assert!(d.detect(&face, 0.0).detection.is_none()); // off a straight path
    /// // The lane bends left: 3 m to the left at 40 m and beyond (stations 10 m apart).
    /// d.set_path_profile(10.0, &[0.0, 0.75, 1.5, 2.25, 3.0]).unwrap();
    /// let car = d.detect(&face, 0.0).detection.unwrap();
    /// assert_eq!(car.distance, 40.0);
    /// ```
    pub fn set_path_profile(&mut self, spacing: f64, offsets: &[f64]) -> Result<(), ParamError> {
        if !(spacing.is_finite() && spacing >= 0.0) {
            return Err(ParamError { field: "spacing", problem: "must be finite and >= 0 m" });
        }
        if offsets.len() > PROFILE_STATIONS || offsets.iter().any(|o| o.is_nan() || libm::fabs(*o) > 100.0) {
            return Err(ParamError { field: "offsets", problem: "at most 64 offsets, each finite and within 100 m" });
        }
        let last = offsets.last().copied().unwrap_or(0.0);
        for (k, o) in self.profile.iter_mut().enumerate() {
            *o = offsets.get(k).copied().unwrap_or(last);
        }
        self.profile_spacing = if offsets.is_empty() { 0.0 } else { spacing };
        if self.profile_spacing == 0.0 {
            self.profile = [0.0; PROFILE_STATIONS];
        }
        Ok(())
    }

    /// Runs the pipeline on one scan. `points` are `[x, y]` in the sensor frame (x forward, y left),
    /// m. `path_curvature` (1/m, positive = left, 0 = straight) predicts the follower's path as
    /// the arc through the sensor tangent to x; the grid lies along it. Never panics; see
    /// [`DetectorStatus`] for the outcomes.
    pub fn detect(&mut self, points: &[[f64; 2]], path_curvature: f64) -> DetectorOutput {
        let p = self.params;
        let curvature = valid_curvature(path_curvature);
        // The profile copied out (512 bytes of stack), as the passes below borrow `self` mutably.
        let profile = self.profile;
        let g = Geometry::new(&p, NX, NY, curvature.unwrap_or(0.0)).with_profile(&profile, self.profile_spacing);
        self.curvature = g.kappa;
        let truncated = points.len() > p.max_points;
        let scan = points.get(..p.max_points).unwrap_or(points);

        // (1)-(2): occupancy; the occupied columns span `lo..hi`.
        self.occupied = [0; NX];
        let (mut used, mut rejected) = (0usize, 0usize);
        let (mut lo, mut hi) = (NX, 0usize);
        // The cell index `ix * NY + iy` fits the cache's u16 for the grids this is built for;
        // larger grids compute every point twice.
        let cache = const { NX * NY < NO_CELL as usize };
        for (i, &[x, y]) in scan.iter().enumerate() {
            let mut cell = NO_CELL;
            if !(x.is_finite() && y.is_finite()) {
                rejected += 1;
            } else if let Some((ix, iy, d)) = g.cell_of(x, y) {
                used += 1;
                lo = lo.min(ix);
                hi = hi.max(ix + 1);
                if let Some(col) = self.occupied.get_mut(ix) {
                    *col |= 1u64.checked_shl(iy as u32).unwrap_or(0);
                }
                if let (true, Some(o)) = (cache, self.point_offset.get_mut(i)) {
                    *o = d;
                    cell = (ix * NY + iy) as u16;
                }
            }
            if let (true, Some(c)) = (cache, self.point_cell.get_mut(i)) {
                *c = cell;
            }
        }

        // (3)-(4): edges and dilation, on the columns that can hold a dilated cell.
        let reach = usize::from(p.dilation_radius);
        let span = lo.saturating_sub(reach)..(hi + reach).min(NX);
        self.find_edges(span.clone());
        self.dilate(span.clone());

        // (5): 8-connected components.
        let overflow = self.label(span);

        // (6): statistics of the original points. Neighbouring rays often fall into one cell: its
        // cluster is looked up once.
        let mut last: Option<((usize, usize), Option<usize>)> = None;
        for (i, &[x, y]) in scan.iter().enumerate() {
            let cached = if cache { self.point_cell.get(i).copied().zip(self.point_offset.get(i).copied()) } else { None };
            let cell = match cached {
                Some((NO_CELL, _)) => None,
                Some((c, d)) => Some((usize::from(c) / NY, usize::from(c) % NY, d)),
                None if x.is_finite() && y.is_finite() => g.cell_of(x, y),
                None => None,
            };
            let Some((ix, iy, d)) = cell else { continue };
            let owner = match last {
                Some((cell, owner)) if cell == (ix, iy) => owner,
                _ => {
                    let owner = self.cluster_at(ix, iy);
                    last = Some(((ix, iy), owner));
                    owner
                }
            };
            let Some(c) = owner else { continue };
            if let Some(info) = self.clusters.get_mut(c) {
                // `+ 0.0` maps -0.0 to +0.0, so that min/max cannot depend on the order of points.
                info.add_point(x + 0.0, y + 0.0, d + 0.0);
            }
        }

        // The cells' index extents, from the points' extents: a point's column depends only on its
        // x and its row only on its offset d, both monotonically.
        let n_clusters = self.n_clusters;
        for c in self.clusters.iter_mut().take(n_clusters).filter(|c| c.points > 0) {
            let index = |i: Option<usize>| i.map_or(0, |i| i as u16);
            (c.ix_min, c.ix_max) = (index(g.column_of(c.x_min)), index(g.column_of(c.x_max)));
            (c.iy_min, c.iy_max) = (index(g.row_of(c.d_min)), index(g.row_of(c.d_max)));
        }

        // (7): geometric constraints; (7b): fragments joined.
        for c in self.clusters.iter_mut().take(n_clusters) {
            if c.points == 0 {
                *c = ClusterInfo { x_min: 0.0, x_max: 0.0, y_min: 0.0, y_max: 0.0, d_min: 0.0, d_max: 0.0, b_min: 0.0, b_max: 0.0, ..*c };
            }
            c.rejection = judge(c, &p, g.kappa);
            c.selected = false;
        }
        self.join_fragments(&p, g.kappa);

        // (8): the nearest vehicle whose outline is solid. Each failed test rejects one candidate,
        // so this ends after at most `n_clusters` passes over the scan; in practice one.
        let bx = grid_box(&g);
        let best = loop {
            // The nearest, an object in path by its body alone only when there is no other.
            let mut best: Option<usize> = None;
            let mut best_key = (true, f64::INFINITY);
            for (i, c) in self.clusters.iter().take(n_clusters).enumerate() {
                let key = (by_body_alone(c, &p), c.x_min);
                if c.rejection.is_none() && key < best_key {
                    best_key = key;
                    best = Some(i);
                }
            }
            let Some(c) = best.and_then(|i| self.clusters.get_mut(i)) else { break None };
            match solid_face(c, scan, &p, bx) {
                Some(reason) => c.rejection = Some(reason),
                None => break best,
            }
        };

        // (9): reprojection.
        let detection = best.and_then(|i| self.clusters.get_mut(i)).map(|c| {
            c.selected = true;
            reproject(c, &p, &g)
        });

        let status = if curvature.is_none() {
            DetectorStatus::InvalidCurvature
        } else if overflow {
            DetectorStatus::TooManyClusters
        } else if truncated {
            DetectorStatus::Truncated
        } else if used == 0 {
            DetectorStatus::EmptyScan
        } else if rejected > 0 {
            DetectorStatus::NonFinitePoints
        } else {
            DetectorStatus::Ok
        };
        DetectorOutput { detection, status, points_used: used, points_rejected: rejected, clusters: n_clusters }
    }

    /// Step 7b: fragments of one vehicle. Among the first [`JOIN_CAPACITY`] clusters rejected only
    /// for too few points or too small a width, near the corridor, each (in cluster order) is
    /// joined with the later ones whose rear face lies within `join_depth` and whose lateral gap to
    /// the group is at most `join_gap`, while the union fits `max_width` and `max_depth`. A group
    /// of two or more that passes step 7 replaces its first member's statistics; the others are
    /// marked [`RejectReason::Joined`]. At most `JOIN_CAPACITY^2 / 2` pair checks per scan.
    fn join_fragments(&mut self, p: &DetectorParams, kappa: f64) {
        if p.join_gap.is_nan() || p.join_gap <= 0.0 {
            return;
        }
        let reach = p.path_half_width.max(p.swept_half_width).max(p.body_half_width) + p.max_width;
        let mut cand = [0u16; JOIN_CAPACITY];
        let mut n = 0;
        for (i, c) in self.clusters().iter().enumerate() {
            let fragment = matches!(c.rejection, Some(RejectReason::TooFewPoints | RejectReason::TooNarrow));
            if fragment && c.points > 0 && c.depth() <= p.max_depth && libm::fabs(c.center_offset()) <= reach {
                if let Some(slot) = cand.get_mut(n) {
                    *slot = i as u16;
                    n += 1;
                } else {
                    break;
                }
            }
        }
        let cand = cand.get(..n).unwrap_or(&[]);
        let mut used = [false; JOIN_CAPACITY];
        for (a, &ia) in cand.iter().enumerate() {
            if used.get(a).copied().unwrap_or(true) {
                continue;
            }
            let Some(mut group) = self.clusters.get(usize::from(ia)).copied() else { continue };
            let mut members = [false; JOIN_CAPACITY];
            let mut count = 1;
            for (b, &ib) in cand.iter().enumerate().skip(a + 1) {
                if used.get(b).copied().unwrap_or(true) {
                    continue;
                }
                let Some(c) = self.clusters.get(usize::from(ib)) else { continue };
                let dx = libm::fabs(c.x_min - group.x_min);
                if dx.is_nan() || dx > p.join_depth {
                    continue;
                }
                let gap = (c.d_min - group.d_max).max(group.d_min - c.d_max);
                let beams = (f64::from(p.join_beams) + 1.0) * c.x_min.min(group.x_min).max(0.0) * p.beam_spacing();
                if !(gap <= p.join_gap && gap <= beams) {
                    continue;
                }
                let union = union_of(&group, c);
                if union.width() <= p.max_width && union.depth() <= p.max_depth.min(p.depth_per_width * union.width() + 1.0) {
                    group = union;
                    count += 1;
                    if let Some(m) = members.get_mut(b) {
                        *m = true;
                    }
                }
            }
            if count < 2 || judge(&group, p, kappa).is_some() {
                continue;
            }
            group.rejection = None;
            if let Some(first) = self.clusters.get_mut(usize::from(ia)) {
                *first = group;
            }
            for (b, &ib) in cand.iter().enumerate() {
                if members.get(b).copied().unwrap_or(false) {
                    if let Some(u) = used.get_mut(b) {
                        *u = true;
                    }
                    if let Some(c) = self.clusters.get_mut(usize::from(ib)) {
                        c.rejection = Some(RejectReason::Joined);
                    }
                }
            }
        }
    }

    /// Step 3: occupied cells with at least one free 4-neighbour (cells outside the grid are free).
    /// Columns outside `span` have no occupied cell (so no edge): they are written 0 here, in the
    /// same pass, rather than cleared beforehand.
    fn find_edges(&mut self, span: core::ops::Range<usize>) {
        let mask = column_mask(NY);
        zero_outside(&mut self.edges, &span);
        for ix in span {
            let c = self.occupied.get(ix).copied().unwrap_or(0);
            let left = ix.checked_sub(1).and_then(|j| self.occupied.get(j)).copied().unwrap_or(0);
            let right = self.occupied.get(ix + 1).copied().unwrap_or(0);
            // Bit iy of `c << 1` is cell iy-1, of `c >> 1` cell iy+1; both shift in free cells.
            let interior = c & (c << 1) & (c >> 1) & left & right;
            if let Some(e) = self.edges.get_mut(ix) {
                *e = c & !interior & mask;
            }
        }
    }

    /// Step 4: dilation with a rectangle of `dilation_radius` columns either way and the column's
    /// lateral radius. Lateral dilation distributes over OR, so each dilated column is the lateral
    /// dilation of the OR of the neighbouring edge columns. Columns outside `span` are written 0.
    fn dilate(&mut self, span: core::ops::Range<usize>) {
        let r = usize::from(self.params.dilation_radius);
        let mask = column_mask(NY);
        zero_outside(&mut self.dilated, &span);
        for ix in span {
            let lo = ix.saturating_sub(r);
            let hi = (ix + r + 1).min(NX);
            let cols = self.edges.get(lo..hi).unwrap_or(&[]).iter().fold(0u64, |acc, &e| acc | e);
            let mut d = cols;
            for k in 1..=u32::from(self.radius.get(ix).copied().unwrap_or(0)) {
                d |= cols.checked_shl(k).unwrap_or(0) | cols.checked_shr(k).unwrap_or(0);
            }
            if let Some(out) = self.dilated.get_mut(ix) {
                *out = d & mask;
            }
        }
    }

    /// Step 5: two-pass labelling on runs. Pass 1 stores the runs column by column and unites each
    /// run with the 8-connected runs of the previous column; pass 2 gives every root a cluster
    /// number in run order (i.e. nearest column first). Returns `true` on table overflow. Columns
    /// outside `span` are empty.
    fn label(&mut self, span: core::ops::Range<usize>) -> bool {
        self.n_runs = 0;
        self.n_clusters = 0;
        self.col_len = [0; NX];
        let mut overflow = false;
        let mut prev = 0..0;
        'columns: for ix in span {
            let mut bits = self.dilated.get(ix).copied().unwrap_or(0);
            let start = self.n_runs;
            while bits != 0 {
                if self.n_runs >= RUN_CAPACITY {
                    overflow = true;
                    break 'columns;
                }
                let y0 = bits.trailing_zeros();
                let len = (!(bits >> y0)).trailing_zeros(); // >= 1: bit y0 is set
                let y1 = y0 + len.saturating_sub(1);
                bits &= !span_mask(y0, len);
                let idx = self.n_runs;
                if let Some(run) = self.runs.get_mut(idx) {
                    *run = Run { y0: y0 as u8, y1: y1 as u8, cluster: NO_CLUSTER };
                }
                if let Some(pa) = self.parent.get_mut(idx) {
                    *pa = idx as u16;
                }
                self.n_runs += 1;
                if let (Some(f), Some(l)) = (self.col_first.get_mut(ix), self.col_len.get_mut(ix)) {
                    if *l == 0 {
                        *f = idx as u16;
                    }
                    *l = l.saturating_add(1);
                }
                for j in prev.clone() {
                    let Some(a) = self.runs.get(j).copied() else { break };
                    if u32::from(a.y0) > y1 + 1 {
                        break;
                    }
                    if u32::from(a.y1) + 1 >= y0 {
                        union(&mut self.parent, j, idx);
                    }
                }
            }
            prev = start..self.n_runs;
        }

        for i in 0..self.n_runs {
            let root = find(&mut self.parent, i);
            let cluster = if root == i {
                if self.n_clusters < CLUSTER_CAPACITY {
                    let c = self.n_clusters;
                    self.n_clusters += 1;
                    if let Some(info) = self.clusters.get_mut(c) {
                        *info = ClusterInfo::EMPTY;
                    }
                    c as u16
                } else {
                    overflow = true;
                    NO_CLUSTER
                }
            } else {
                // The root is the smallest index of its set, so it already has its number.
                self.runs.get(root).map_or(NO_CLUSTER, |r| r.cluster)
            };
            let mut len = 0;
            if let Some(run) = self.runs.get_mut(i) {
                run.cluster = cluster;
                len = usize::from(run.y1.saturating_sub(run.y0)) + 1;
            }
            if let Some(info) = self.clusters.get_mut(usize::from(cluster)) {
                info.cells += len;
            }
        }
        overflow
    }

    /// The cluster owning dilated cell `(ix, iy)`, if any. Runs are sorted by `(ix, y0)` and, being
    /// disjoint within a column, also by `(ix, y1)`.
    fn cluster_at(&self, ix: usize, iy: usize) -> Option<usize> {
        let first = usize::from(*self.col_first.get(ix)?);
        let len = usize::from(*self.col_len.get(ix)?);
        let runs = self.runs.get(first..first + len)?;
        let r = runs.iter().find(|r| usize::from(r.y0) <= iy && iy <= usize::from(r.y1))?;
        (r.cluster != NO_CLUSTER).then_some(usize::from(r.cluster))
    }
}

/// The statistics of two clusters together.
fn union_of(a: &ClusterInfo, b: &ClusterInfo) -> ClusterInfo {
    ClusterInfo {
        x_min: a.x_min.min(b.x_min),
        x_max: a.x_max.max(b.x_max),
        y_min: a.y_min.min(b.y_min),
        y_max: a.y_max.max(b.y_max),
        d_min: a.d_min.min(b.d_min),
        d_max: a.d_max.max(b.d_max),
        b_min: a.b_min.min(b.b_min),
        b_max: a.b_max.max(b.b_max),
        ix_min: a.ix_min.min(b.ix_min),
        ix_max: a.ix_max.max(b.ix_max),
        iy_min: a.iy_min.min(b.iy_min),
        iy_max: a.iy_max.max(b.iy_max),
        points: a.points + b.points,
        cells: a.cells + b.cells,
        rejection: a.rejection,
        selected: false,
    }
}

/// The curvature the detector follows: `None` for NaN, infinite or beyond [`MAX_CURVATURE`].
fn valid_curvature(k: f64) -> Option<f64> {
    // `+ 0.0` maps -0.0 to +0.0.
    (libm::fabs(k) <= MAX_CURVATURE).then_some(k + 0.0)
}

fn bit(cols: &[u64], ix: usize, iy: usize) -> bool {
    let b = cols.get(ix).copied().unwrap_or(0);
    u32::try_from(iy).ok().and_then(|s| b.checked_shr(s)).is_some_and(|v| v & 1 == 1)
}

/// The low `ny` bits set.
fn column_mask(ny: usize) -> u64 {
    if ny >= 64 { u64::MAX } else { (1u64 << ny) - 1 }
}

/// `len` bits set starting at bit `y0` (`y0 + len <= 64`).
fn span_mask(y0: u32, len: u32) -> u64 {
    let ones = if len >= 64 { u64::MAX } else { (1u64 << len) - 1 };
    ones.checked_shl(y0).unwrap_or(0)
}

/// Union-find root with path halving. Invariant: `parent[i] <= i`, so the loop terminates.
fn find(parent: &mut [u16], mut i: usize) -> usize {
    loop {
        let Some(p) = parent.get(i).map(|&p| usize::from(p)) else { return i };
        if p >= i {
            return i;
        }
        let gp = parent.get(p).map_or(p, |&g| usize::from(g));
        if let Some(slot) = parent.get_mut(i) {
            *slot = gp as u16;
        }
        i = gp;
    }
}

/// Unites the sets of `a` and `b`; the smaller root index becomes the root.
fn union(parent: &mut [u16], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (root, child) = if ra <= rb { (ra, rb) } else { (rb, ra) };
    if root != child {
        if let Some(slot) = parent.get_mut(child) {
            *slot = root as u16;
        }
    }
}

/// Step 7.
fn judge(c: &ClusterInfo, p: &DetectorParams, kappa: f64) -> Option<RejectReason> {
    let width = c.width();
    // A sparse narrow cluster must be a face square to the path: its x extent at most its width
    // times (tan of the path's heading at its range + 1), plus 0.2 m of noise. Two returns of a
    // guard rail crossing the corridor far ahead are 0.3 m apart across and 1.7 m along it.
    let kx = libm::fabs(kappa * c.x_min);
    let tan_heading = if kx < 0.99 { kx / libm::sqrt(1.0 - kx * kx) } else { 7.0 };
    let sparse = c.points < 2 * p.min_cluster_points && width < p.narrow_width;
    if c.points < p.min_points_at(c.x_min) {
        Some(RejectReason::TooFewPoints)
    } else if width + c.x_min.max(0.0) * p.beam_spacing() < p.min_width {
        // The points of an object w wide lie between w and w minus one beam spacing apart.
        Some(RejectReason::TooNarrow)
    } else if width > p.max_width {
        Some(RejectReason::TooWide)
    } else if c.depth() > p.max_depth
        || c.depth() > p.depth_per_width * width + 1.0
        || (sparse && c.depth() > width * (tan_heading + 1.0) + 0.2)
    {
        Some(RejectReason::TooDeep)
    } else if in_corridor(c, p) {
        None
    } else {
        Some(RejectReason::OffPath)
    }
}

/// Step 7's corridor: with `swept_half_width > 0`, a narrow object (below `narrow_width`) is in
/// it when its body reaches within it (its nearest offset from the path, 0 when it straddles the
/// path, less one beam spacing at its range, is below it); otherwise the paper's rule, the centre
/// within `path_half_width` and narrow objects wholly inside, or with `body_half_width > 0` a
/// wide object whose body reaches within that ([`by_body_alone`]). Written so that a non-finite
/// offset is rejected.
fn in_corridor(c: &ClusterInfo, p: &DetectorParams) -> bool {
    if p.swept_half_width > 0.0 && c.width() < p.narrow_width {
        // The body reaches up to one beam spacing beyond its outermost return (as in step 7's
        // width): a motorbike on the marking 70 m ahead returns its first beam 0.1 m inside its
        // edge with 0.2 deg beams.
        body_offset(c, p) < p.swept_half_width
    } else {
        by_centre(c, p) || by_body_alone(c, p)
    }
}

/// The paper's rule: the centre within `path_half_width`, a narrow object wholly inside.
fn by_centre(c: &ClusterInfo, p: &DetectorParams) -> bool {
    let off = libm::fabs(c.center_offset());
    off <= p.path_half_width && (c.width() >= p.narrow_width || off + 0.5 * c.width() <= p.path_half_width)
}

/// A wide object in the corridor by its body alone: outside the centre rule, its body reaching
/// within `body_half_width` (the band the ego's body sweeps plus a margin; a car driving on the lane marking,
/// its centre 1.75 m off, which the centre rule finds on its edge at 1.8 m). Reported only when
/// no other object is in path (step 8).
fn by_body_alone(c: &ClusterInfo, p: &DetectorParams) -> bool {
    p.body_half_width > 0.0 && c.width() >= p.narrow_width && !by_centre(c, p) && body_offset(c, p) < p.body_half_width
}

/// The nearest offset of a cluster's body from the path, widened by one beam spacing at its
/// range, m: 0 when it straddles the path; NaN when its offsets are not finite.
fn body_offset(c: &ClusterInfo, p: &DetectorParams) -> f64 {
    let near = if c.d_min > 0.0 {
        c.d_min
    } else if c.d_max < 0.0 {
        -c.d_max
    } else if c.d_min <= 0.0 && c.d_max >= 0.0 {
        0.0
    } else {
        f64::NAN
    };
    near - c.x_min.max(0.0) * p.beam_spacing()
}

/// The box holding the grid of `g` (see [`LeadDetector::bounds`]).
fn grid_box(g: &Geometry) -> (f64, f64, f64, f64) {
    let (x0, x1) = (g.x_lo, g.x_hi());
    // A point in the grid is within `-d_lo` of the path, so within that plus the profile's
    // largest departure of the arc.
    let half = -g.d_lo + g.profile_reach;
    if g.kappa == 0.0 {
        return (x0, x1, -half, half);
    }
    // Points within `half` of the near half of the circle of radius R: on the inside of the
    // bend up to the inner circle at x1 (or the circle's centre line), on the outside down to
    // `half` beyond the sensor's lateral position.
    // With R = 1/|kappa| and the inner radius R - half: `R - sqrt((R - half)^2 - x1^2)`,
    // written without cancellation or overflow for small kappa; 1 um of margin for rounding.
    let k = libm::fabs(g.kappa);
    let inner = 1.0 - k * half;
    let reach = if inner > k * x1 {
        (half * (2.0 - k * half) + k * x1 * x1) / (1.0 + libm::sqrt(inner * inner - k * k * x1 * x1))
    } else {
        1.0 / k
    };
    let (half, reach) = (half + 1e-6, reach + 1e-6);
    if g.kappa > 0.0 { (x0, x1, -half, reach) } else { (x0, x1, -reach, half) }
}

/// Step 8's solid-face tests, in one pass over the scan: [`RejectReason::SeeThrough`] when more
/// than `see_through_share` of the cluster's point count are rays with a bearing strictly inside
/// its span that return beyond its far edge; for a narrow cluster, [`RejectReason::NoRearFace`]
/// when the returns inside its bearing span within `rear_face_depth` of its nearest x span less
/// than half its bearing span. Only points inside the grid's box `bx` ([`LeadDetector::bounds`])
/// count, so that a scan prefiltered to the box gives the same result.
fn solid_face(c: &ClusterInfo, scan: &[[f64; 2]], p: &DetectorParams, bx: (f64, f64, f64, f64)) -> Option<RejectReason> {
    let (_, x1, y0, y1) = bx;
    let far = c.x_max + p.see_through_margin;
    let rear = c.x_min + p.rear_face_depth;
    let limit = p.see_through_share * c.points as f64;
    let (mut through, mut lo, mut hi) = (0usize, f64::INFINITY, f64::NEG_INFINITY);
    for &[x, y] in scan {
        // Also false for NaN.
        if !(x >= c.x_min && x <= x1 && y >= y0 && y <= y1) {
            continue;
        }
        let b = y / x;
        if x > far {
            if b > c.b_min && b < c.b_max {
                through += 1;
            }
        } else if x <= rear && b >= c.b_min && b <= c.b_max {
            lo = lo.min(b);
            hi = hi.max(b);
        }
    }
    if through as f64 > limit {
        Some(RejectReason::SeeThrough)
    } else if c.width() < p.narrow_width && hi - lo < 0.5 * (c.b_max - c.b_min) {
        Some(RejectReason::NoRearFace)
    } else {
        None
    }
}

/// Step 9 and the confidence.
fn reproject(c: &ClusterInfo, p: &DetectorParams, g: &Geometry) -> Detection {
    let (x, y) = match p.reprojection {
        Reprojection::PointRefined => (c.x_min, c.center_y()),
        Reprojection::CellCenter => {
            let (x0, len) = g.column(usize::from(c.ix_min));
            let d_cells = g.d_lo + 0.5 * (f64::from(c.iy_min) + f64::from(c.iy_max) + 1.0) * g.cell;
            // From the path frame to the sensor frame by the points' own shift.
            (x0 + 0.5 * len, d_cells + (c.center_y() - c.center_offset()))
        }
    };
    let width = c.width();
    let point_term = (c.points as f64 / (4.0 * p.min_points_at(c.x_min) as f64)).min(1.0);
    let w_ref = 0.5 * (p.min_width + p.max_width);
    let w_half = 0.5 * (p.max_width - p.min_width);
    let width_term = if w_half > 0.0 { 1.0 - 0.5 * (libm::fabs(width - w_ref) / w_half).min(1.0) } else { 1.0 };
    Detection {
        position: Point2::new(x, y),
        distance: x,
        width,
        depth: c.depth(),
        points: c.points,
        confidence: clamp(point_term * width_term, 0.0, 1.0),
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    /// Angular resolution of the simulated LiDAR, rad (0.2 deg).
    const RES: f64 = 0.2 * core::f64::consts::PI / 180.0;

    fn det() -> LeadDetector {
        <LeadDetector>::new(DetectorParams::default()).unwrap()
    }

    /// A vehicle's rear face centred at `(d, yc)`, `width` wide, as seen by a LiDAR at the origin
    /// with beams at multiples of 0.2 deg. The face bulges 0.1 m towards the sensor at its edges
    /// (bumper corners) and carries a deterministic +-2 cm range noise; its nearest point is at
    /// `d - 0.02` at worst.
    fn rear_face(d: f64, yc: f64, width: f64) -> Vec<[f64; 2]> {
        rear_face_res(d, yc, width, RES)
    }

    /// [`rear_face`] with beams every `res` rad.
    fn rear_face_res(d: f64, yc: f64, width: f64, res: f64) -> Vec<[f64; 2]> {
        let a0 = libm::atan2(yc - 0.5 * width, d);
        let a1 = libm::atan2(yc + 0.5 * width, d);
        let mut k = libm::ceil(a0 / res) as i64;
        let mut pts = Vec::new();
        while k as f64 * res <= a1 {
            let y = d * libm::tan(k as f64 * res);
            let u = (y - yc) / (0.5 * width);
            let x = d + 0.1 * u * u + 0.02 * libm::sin(k as f64 * 12.9898);
            pts.push([x, y]);
            k += 1;
        }
        pts
    }

    /// A line of points at lateral offset `y` from `x0` to `x1`, every `step` m.
    fn rail(y: f64, x0: f64, x1: f64, step: f64) -> Vec<[f64; 2]> {
        let n = libm::floor((x1 - x0) / step) as usize;
        (0..=n).map(|i| [x0 + i as f64 * step, y]).collect()
    }

    #[test]
    fn status_names() {
        assert_eq!(DetectorStatus::Ok.as_str(), "ok");
        assert_eq!(DetectorStatus::EmptyScan.as_str(), "empty_scan");
        assert_eq!(DetectorStatus::NonFinitePoints.as_str(), "non_finite_points");
        assert_eq!(DetectorStatus::Truncated.as_str(), "truncated");
        assert_eq!(DetectorStatus::TooManyClusters.as_str(), "too_many_clusters");
        assert_eq!(DetectorStatus::InvalidCurvature.as_str(), "invalid_curvature");
        assert_eq!(RejectReason::OffPath.as_str(), "off_path");
    }

    /// Step 6 reads the cell and offset of the first [`POINT_CACHE`] points back from step 1 and
    /// computes those of later points again: a scan longer than the cache gives the same result
    /// whichever side of the cache's end the car's points lie on, and a detector that has just
    /// seen a long scan reads nothing of it on a shorter one.
    #[test]
    fn point_cache_changes_no_result() {
        // Clutter inside the grid (a guard rail 5 m left) and outside it (far to the right).
        let rail: Vec<[f64; 2]> = (0..400).map(|i| [5.0 + 0.4 * f64::from(i), 5.0]).collect();
        let outside: Vec<[f64; 2]> = (0..1000).map(|i| [10.0 + 0.1 * f64::from(i), -40.0]).collect();
        let car = rear_face(62.0, 0.3, 1.9);
        let late: Vec<[f64; 2]> = rail.iter().chain(&outside).chain(&car).copied().collect();
        let early: Vec<[f64; 2]> = car.iter().chain(&rail).chain(&outside).copied().collect();
        assert!(late.len() > POINT_CACHE + car.len());
        // Straight, and a gentle curve (the car 0.96 m off its arc, inside the corridor).
        for curvature in [0.0, 0.0005] {
            let (mut a, mut b) = (det(), det());
            let (out_late, out_early) = (a.detect(&late, curvature), b.detect(&early, curvature));
            assert!(out_late.detection.is_some(), "{out_late:?}");
            assert_eq!(out_late, out_early);
            assert_eq!(a.clusters(), b.clusters());
            let (x, y) = (out_late.detection.unwrap(), out_early.detection.unwrap());
            assert_eq!(x.distance.to_bits(), y.distance.to_bits());
            // After the long scan, a short one: as on a fresh detector.
            let short: Vec<[f64; 2]> = car.iter().chain(rail.iter().take(50)).copied().collect();
            let mut fresh = det();
            assert_eq!(a.detect(&short, curvature), fresh.detect(&short, curvature));
            assert_eq!(a.clusters(), fresh.clusters());
        }
    }

    #[test]
    fn memory_fits_in_64_kib() {
        let size = core::mem::size_of::<LeadDetector>();
        assert!(size <= 65536, "LeadDetector takes {size} bytes");
        // The figure quoted in the docs (63.4 KiB on 64-bit targets).
        #[cfg(target_pointer_width = "64")]
        assert_eq!(size, 64936);
    }

    #[test]
    fn default_grid_geometry() {
        let d = det();
        assert_eq!(LeadDetector::<520, 60>::grid_size(), (520, 60));
        let (x0, x1) = d.x_range();
        let (y0, y1) = d.y_range();
        assert!((x0 - 0.5).abs() < 1e-12 && (x1 - 200.5).abs() < 1e-9);
        assert!((y0 + 6.0).abs() < 1e-12 && (y1 - 6.0).abs() < 1e-9);
        assert_eq!(d.cell_of(0.5, -6.0), Some((0, 0)));
        assert_eq!(d.cell_of(0.49, 0.0), None);
        assert_eq!(d.cell_of(200.6, 0.0), None);
        assert_eq!(d.cell_of(10.0, 6.1), None);
        // 200 near columns of 0.2 m, then 0.5 m ones.
        assert_eq!(d.cell_of(40.45, 0.0).map(|c| c.0), Some(199));
        assert_eq!(d.cell_of(40.55, 0.0).map(|c| c.0), Some(200));
        assert_eq!(d.cell_of(200.4, 0.0).map(|c| c.0), Some(519));
        let c = d.cell_center(0, 0);
        assert!((c.x - 0.6).abs() < 1e-12 && (c.y + 5.9).abs() < 1e-12);
        let c = d.cell_center(200, 30);
        assert!((c.x - 40.75).abs() < 1e-12 && (c.y - 0.1).abs() < 1e-12);
        // The lateral dilation radius grows with range: 1 cell up to 63 m, then 2.
        assert_eq!(d.params().lateral_radius_at(60.0), 1);
        assert_eq!(d.params().lateral_radius_at(100.0), 2);
        assert_eq!(d.params().lateral_radius_at(200.0), 2);
        // The point threshold: 3 near, 2 from 23.9 m (where 0.25 m spans fewer than 6 beams).
        assert_eq!(d.params().min_points_at(10.0), 3);
        assert_eq!(d.params().min_points_at(23.0), 3);
        assert_eq!(d.params().min_points_at(24.0), 2);
        assert_eq!(d.params().min_points_at(190.0), 2);
    }

    #[test]
    fn rear_face_distance_within_one_cell() {
        for reprojection in [Reprojection::PointRefined, Reprojection::CellCenter] {
            let mut d = <LeadDetector>::new(DetectorParams { reprojection, ..Default::default() }).unwrap();
            for dist in [5.0, 20.0, 45.0, 65.0] {
                let scan = rear_face(dist, 0.0, 1.9);
                assert!(scan.len() >= 8, "{} points at {dist} m", scan.len());
                let out = d.detect(&scan, 0.0);
                assert_eq!(out.status, DetectorStatus::Ok);
                let det = out.detection.unwrap_or_else(|| panic!("no detection at {dist} m ({reprojection:?})"));
                // Within the cell's length (0.2 m near, 0.5 m beyond 40.5 m).
                let cell = if dist < 40.0 { 0.2 } else { 0.5 };
                assert!((det.distance - dist).abs() <= cell, "{reprojection:?} at {dist}: {}", det.distance);
                assert_eq!(det.distance, det.position.x);
                assert!(det.position.y.abs() <= 0.2, "{reprojection:?} at {dist}: y {}", det.position.y);
                assert!(det.width > 1.6 && det.width <= 1.9, "width {}", det.width);
                assert!(det.depth <= 0.2, "depth {}", det.depth);
                assert_eq!(det.points, scan.len());
                assert!(det.confidence > 0.5 && det.confidence <= 1.0);
                if reprojection == Reprojection::PointRefined {
                    // The raw rear face is within the simulated noise of the truth.
                    assert!((det.distance - dist).abs() <= 0.021, "at {dist}: {}", det.distance);
                }
            }
        }
    }

    #[test]
    fn empty_scan() {
        let mut d = det();
        let out = d.detect(&[], 0.0);
        assert_eq!(out.status, DetectorStatus::EmptyScan);
        assert_eq!(out.detection, None);
        assert_eq!((out.points_used, out.points_rejected, out.clusters), (0, 0, 0));
        // Points only outside the grid are an empty scan as well.
        let out = d.detect(&[[-3.0, 0.0], [250.0, 0.0], [10.0, 40.0]], 0.0);
        assert_eq!(out.status, DetectorStatus::EmptyScan);
        assert_eq!(out.detection, None);
        assert!(d.clusters().is_empty());
    }

    #[test]
    fn no_lead_is_ok() {
        let mut d = det();
        let out = d.detect(&rear_face(20.0, 5.0, 1.9), 0.0);
        assert_eq!(out.status, DetectorStatus::Ok);
        assert_eq!(out.detection, None);
        assert_eq!(out.clusters, 1);
    }

    #[test]
    fn non_finite_points_are_counted_and_dropped() {
        let mut d = det();
        let mut scan = rear_face(20.0, 0.0, 1.9);
        let n = scan.len();
        scan.insert(3, [f64::NAN, 0.0]);
        scan.push([20.0, f64::INFINITY]);
        scan.push([f64::NEG_INFINITY, f64::NAN]);
        let out = d.detect(&scan, 0.0);
        assert_eq!(out.status, DetectorStatus::NonFinitePoints);
        assert_eq!(out.points_rejected, 3);
        assert_eq!(out.points_used, n);
        let det = out.detection.unwrap();
        assert!((det.distance - 20.0).abs() <= 0.2);
        assert_eq!(det.points, n);
    }

    #[test]
    fn guard_rails_rejected_car_accepted() {
        let mut d = det();
        let mut scan = rear_face(30.0, 0.0, 1.9);
        scan.extend(rail(5.0, 1.0, 70.0, 0.1));
        scan.extend(rail(-5.0, 1.0, 70.0, 0.1));
        let out = d.detect(&scan, 0.0);
        let det = out.detection.unwrap();
        assert!((det.distance - 30.0).abs() <= 0.2);
        assert!(det.position.y.abs() <= 0.2);
        assert_eq!(out.clusters, 3);
        let rails: Vec<_> = d.clusters().iter().filter(|c| c.y_min.abs() > 4.0).collect();
        assert_eq!(rails.len(), 2);
        for r in rails {
            assert_eq!(r.rejection, Some(RejectReason::TooNarrow));
            assert!(!r.selected && r.depth() > 60.0);
        }
        let car: Vec<_> = d.clusters().iter().filter(|c| c.accepted()).collect();
        assert_eq!(car.len(), 1);
        assert!(car.first().unwrap().selected);
        // A wall-like cluster (deep and wide enough) is rejected by depth.
        let mut wall = rail(1.0, 10.0, 30.0, 0.1);
        wall.extend(rail(-0.5, 10.0, 30.0, 0.1));
        wall.extend((0..16).map(|i| [10.0, -0.5 + 0.1 * f64::from(i)]));
        let out = d.detect(&wall, 0.0);
        assert_eq!(out.detection, None);
        assert_eq!(d.clusters().first().unwrap().rejection, Some(RejectReason::TooDeep));
    }

    #[test]
    fn next_lane_car_needs_curved_path() {
        let mut d = det();
        let scan = rear_face(20.0, 3.7, 1.9);
        let out = d.detect(&scan, 0.0);
        assert_eq!(out.detection, None);
        assert_eq!(d.clusters().first().unwrap().rejection, Some(RejectReason::OffPath));
        // y_path(20) = 0.5 * k * 400 = 3.7 for k = 0.0185 1/m (a 54 m radius left curve).
        let out = d.detect(&scan, 0.0185);
        let det = out.detection.unwrap();
        assert!((det.position.y - 3.7).abs() <= 0.2 && (det.distance - 20.0).abs() <= 0.2);
        // Bending the other way does not help.
        assert_eq!(d.detect(&scan, -0.0185).detection, None);
    }

    /// The path profile: a car in the next lane 60 m ahead where the lane bends towards it
    /// (an S-bend's reversal) is in path with the lane's profile and off it without, at its
    /// measured distance; a car on the lane ahead of the ego is out of path where the profile
    /// says the lane has moved away; a zero profile, and clearing it, give what no profile gives.
    #[test]
    fn the_path_profile_moves_the_corridor_not_the_points() {
        let mut d = det();
        let bent: Vec<f64> = (0..PROFILE_STATIONS).map(|k| (k as f64 * 5.0 - 30.0).clamp(0.0, 30.0) * 0.12).collect();
        let next_lane = rear_face(60.0, 3.5, 1.9);
        assert_eq!(d.detect(&next_lane, 0.0).detection, None);
        d.set_path_profile(5.0, &bent).unwrap();
        let car = d.detect(&next_lane, 0.0).detection.expect("in the bent lane");
        assert!((car.distance - 60.0).abs() <= 0.2 && (car.position.y - 3.5).abs() <= 0.2, "{car:?}");
        // Where the lane has moved 3.6 m left, a car straight ahead is beside it.
        assert_eq!(d.detect(&rear_face(60.0, 0.0, 1.9), 0.0).detection, None);
        // Zero, cleared and reset profiles are the arc.
        let scan: Vec<[f64; 2]> = rear_face(30.0, 0.4, 1.9).into_iter().chain(rail(-4.0, 2.0, 150.0, 0.5)).collect();
        let mut plain = det();
        let want = plain.detect(&scan, 0.004);
        d.set_path_profile(4.0, &[0.0; PROFILE_STATIONS]).unwrap();
        assert_eq!(d.detect(&scan, 0.004), want);
        assert_eq!(d.clusters(), plain.clusters());
        d.set_path_profile(5.0, &bent).unwrap();
        d.set_path_profile(0.0, &[]).unwrap();
        assert_eq!(d.detect(&scan, 0.004), want);
        d.set_path_profile(5.0, &bent).unwrap();
        d.reset();
        assert_eq!(d.detect(&scan, 0.004), want);
    }

    /// A refused profile names its field and leaves the profile as it was.
    #[test]
    fn a_bad_path_profile_names_its_field() {
        let mut d = det();
        d.set_path_profile(10.0, &[0.0, 1.0, 2.0]).unwrap();
        let before = (d.profile, d.profile_spacing);
        for (spacing, offsets, field) in [
            (f64::NAN, std::vec![0.0], "spacing"),
            (-1.0, std::vec![0.0], "spacing"),
            (f64::INFINITY, std::vec![0.0], "spacing"),
            (4.0, std::vec![0.0, f64::NAN], "offsets"),
            (4.0, std::vec![100.5], "offsets"),
            (4.0, std::vec![0.0; PROFILE_STATIONS + 1], "offsets"),
        ] {
            assert_eq!(d.set_path_profile(spacing, &offsets).unwrap_err().field, field);
            assert_eq!((d.profile, d.profile_spacing), before);
        }
    }

    /// Issue 46: the swept-path corridor. A 1.9 m wide ego keeping 0.5 m: 1.45 m.
    const SWEPT: DetectorParams = DetectorParams { swept_half_width: 1.45, ..DetectorParams::defaults() };

    /// `body_half_width` (an ego keeping its lane, 1.9 m wide): a car driving on the lane marking
    /// (centre 1.75-1.95 m off, 1.9 m wide: its body 0.8-1.0 m from the path) is in path by its
    /// body, where the centre rule (1.8 m) loses it at 1.85 m; one half a lane over (2.4 m: 1.45 m)
    /// and a car in the next lane are not. An object in path by its body alone comes second: with
    /// a car on the lane centre farther ahead (a lead cutting out and the car it reveals), the
    /// farther car is reported.
    #[test]
    fn a_car_on_the_marking_is_in_path_by_its_body_after_everything_else() {
        let body = DetectorParams { body_half_width: 0.95, ..SWEPT };
        let mut d = <LeadDetector>::new(body).unwrap();
        let mut centre = <LeadDetector>::new(SWEPT).unwrap();
        for side in [1.0, -1.0] {
            // (what, centre offset, in path by the body rule)
            for (what, yc, inside) in [
                ("on the marking", 1.75, true),
                ("on the marking, 0.1 m further out", 1.85, true),
                ("half a lane over", 2.4, false),
                ("in the next lane", 3.5, false),
            ] {
                let scan = rear_face(25.0, side * yc, 1.9);
                let tag = std::format!("{what} (side {side})");
                let out = d.detect(&scan, 0.0);
                assert_eq!(out.detection.is_some(), inside, "{tag}: {:?}", d.clusters());
                if (yc - 1.85).abs() < 1e-9 {
                    assert!(centre.detect(&scan, 0.0).detection.is_none(), "{tag}: the centre rule");
                }
            }
            // A car on the marking 20 m ahead and a car on the lane centre 40 m ahead.
            let mut scan = rear_face(20.0, side * 1.85, 1.9);
            scan.extend(rear_face(40.0, 0.0, 1.9));
            let out = d.detect(&scan, 0.0).detection.expect("a car in path");
            assert!((out.distance - 40.0).abs() <= 0.2, "side {side}: {}", out.distance);
        }
    }

    /// A motorbike standing on the lane marking (0.8 m wide, centre 1.75 m off the path: its
    /// body reaches to 1.35 m) is in the swept path, on either side and on a curved path; the
    /// paper's corridor lets it through (narrow, not wholly inside 1.8 m). A post beside a
    /// guard rail (0.5 m wide, centred 1.8 m off: 1.55 m) and a car steady in the next lane,
    /// weaving 0.3 m towards the ego (centre 3.2 m: 2.25 m) are not; a car straddling the lane
    /// marking is, as it is in the paper's corridor.
    #[test]
    fn swept_corridor_takes_what_reaches_into_the_path() {
        let mut paper = det();
        let mut swept = <LeadDetector>::new(SWEPT).unwrap();
        for side in [1.0, -1.0] {
            // (what, distance, centre, width, in the paper's corridor, in the swept path)
            let cases = [
                ("motorbike on the marking", 25.0, 1.75, 0.8, false, true),
                ("motorbike on the marking, far", 70.0, 1.75, 0.8, false, true),
                ("motorbike on the lane centre", 25.0, 0.0, 0.8, true, true),
                ("post beside a guard rail", 20.0, 1.8, 0.5, false, false),
                ("car in the next lane", 20.0, 3.5, 1.9, false, false),
                ("car in the next lane weaving 0.3 m towards", 20.0, 3.2, 1.9, false, false),
                ("car straddling the marking", 20.0, 1.7, 1.9, true, true),
                ("car half a lane over the marking (wide: the centre rule)", 20.0, 2.4, 1.9, false, false),
            ];
            for (what, x, yc, w, in_paper, in_swept) in cases {
                let scan = rear_face(x, side * yc, w);
                let tag = std::format!("{what} (side {side})");
                let p = paper.detect(&scan, 0.0);
                assert_eq!(p.detection.is_some(), in_paper, "{tag}: paper corridor");
                let out = swept.detect(&scan, 0.0);
                assert_eq!(out.detection.is_some(), in_swept, "{tag}: swept path, {:?}", swept.clusters());
                if let Some(d) = out.detection {
                    assert!((d.distance - x).abs() <= 0.2, "{tag}: {}", d.distance);
                } else {
                    assert_eq!(swept.clusters().first().unwrap().rejection, Some(RejectReason::OffPath), "{tag}");
                }
            }
        }
        // On a curved path (R = 250 m, left), in path coordinates: the motorbike on the marking
        // 30 m ahead lies 30² / 500 + 1.75 = 3.55 m to the left of the heading line.
        let k = 1.0 / 250.0;
        let bend = |x: f64| 0.5 * k * x * x;
        for (yc, expect) in [(1.75, true), (-1.75, true), (3.5, false), (-3.5, false)] {
            let scan = rear_face(30.0, bend(30.0) + yc, 0.8);
            assert_eq!(swept.detect(&scan, k).detection.is_some(), expect, "curved, offset {yc}");
            assert!(paper.detect(&scan, k).detection.is_none(), "curved, offset {yc}: paper");
        }
        // The nearest of a motorbike on the marking and a car further in the lane.
        let mut scan = rear_face(20.0, 1.75, 0.8);
        scan.extend(rear_face(40.0, 0.0, 1.9));
        assert!((swept.detect(&scan, 0.0).detection.unwrap().distance - 20.0).abs() <= 0.2);
        assert!((paper.detect(&scan, 0.0).detection.unwrap().distance - 40.0).abs() <= 0.2);
    }

    /// The paper's corridor is what `swept_half_width = 0` gives: every cluster judged the same
    /// as with the field absent (the field only ever takes effect when positive).
    #[test]
    fn swept_corridor_off_is_the_paper_corridor() {
        assert_eq!(DetectorParams::defaults().swept_half_width, 0.0);
        let bad = DetectorParams { swept_half_width: -0.1, ..DetectorParams::defaults() };
        assert_eq!(bad.validate().unwrap_err().field, "swept_half_width");
        let nan = DetectorParams { swept_half_width: f64::NAN, ..DetectorParams::defaults() };
        assert_eq!(nan.validate().unwrap_err().field, "swept_half_width");
    }

    #[test]
    fn invalid_curvature_treated_as_straight() {
        let mut d = det();
        for k in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let out = d.detect(&rear_face(20.0, 0.0, 1.9), k);
            assert_eq!(out.status, DetectorStatus::InvalidCurvature);
            assert!((out.detection.unwrap().distance - 20.0).abs() <= 0.2);
            let out = d.detect(&rear_face(20.0, 3.7, 1.9), k);
            assert_eq!(out.detection, None);
        }
    }

    #[test]
    fn pole_rejected() {
        let mut d = det();
        // A 15 cm pole on the path: several points but far too narrow.
        let pole = rear_face(15.0, 0.0, 0.15);
        assert!(pole.len() >= 3);
        let out = d.detect(&pole, 0.0);
        assert_eq!(out.detection, None);
        assert_eq!(out.clusters, 1);
        assert_eq!(d.clusters().first().unwrap().rejection, Some(RejectReason::TooNarrow));
        // Two stray returns: too few points.
        let out = d.detect(&[[15.0, 0.0], [15.05, 0.9]], 0.0);
        assert_eq!(out.detection, None);
        assert_eq!(d.clusters().first().unwrap().rejection, Some(RejectReason::TooFewPoints));
        // A wide object (a 4 m barrier) is rejected too.
        let out = d.detect(&rear_face(15.0, 0.0, 4.0), 0.0);
        assert_eq!(out.detection, None);
        assert_eq!(d.clusters().first().unwrap().rejection, Some(RejectReason::TooWide));
    }

    #[test]
    fn partially_seen_car_accepted_if_wide_enough() {
        let mut d = det();
        let out = d.detect(&rear_face(12.0, 0.6, 1.0), 0.0);
        let det = out.detection.unwrap();
        assert!((det.distance - 12.0).abs() <= 0.2);
        // Wider than nothing, narrower than a full car: lower confidence than a full rear face.
        let full = d.detect(&rear_face(12.0, 0.0, 1.9), 0.0).detection.unwrap();
        assert!(det.confidence < full.confidence);
    }

    #[test]
    fn a_cluster_that_rays_pass_through_is_not_a_vehicle() {
        // A guard-rail return and a post return 0.4 m apart across the path at 59 m (seen on the
        // curvy route): two points, narrow and flat enough for a sparse vehicle face.
        let pair = [[59.16, -0.31], [59.29, 0.10]];
        let mut d = det();
        let alone = d.detect(&pair, 0.0).detection.expect("accepted without evidence against it");
        assert!((alone.distance - 59.16).abs() < 1e-9);
        // A ray between them returns from the rail 2 m farther: nothing solid stands there.
        let through = [pair[0], pair[1], [61.07, -0.21]];
        let out = d.detect(&through, 0.0);
        assert_eq!(out.detection, None);
        assert!(d.clusters().iter().any(|c| c.rejection == Some(RejectReason::SeeThrough)));
        // Returns beyond a car but outside its bearing span do not reject it.
        let mut scan = rear_face(30.0, 0.0, 1.8);
        scan.extend([[45.0, 3.0], [45.0, -3.0]]);
        assert!(d.detect(&scan, 0.0).detection.is_some());
        // A share of stray rays at most `see_through_share` of the points is tolerated.
        // (The stray returns 2 m apart in depth: single points, not a surface of their own.)
        let face = rear_face(30.0, 0.0, 1.8);
        let n = face.len();
        let stray = |k: usize| (0..k).map(|i| [40.0 + 2.0 * i as f64, -0.5 + i as f64 * 0.05]);
        let mut scan = face.clone();
        scan.extend(stray(n / 4));
        assert!(d.detect(&scan, 0.0).detection.is_some(), "{n} points");
        let mut scan = face;
        scan.extend(stray(n / 4 + 1));
        assert_eq!(d.detect(&scan, 0.0).detection, None);
    }

    #[test]
    fn nearest_of_two_cars() {
        let mut d = det();
        // Side by side in bearing (a real scan has no returns behind the nearer car).
        let mut scan = rear_face(35.0, 1.6, 1.9);
        scan.extend(rear_face(20.0, -0.6, 1.8));
        let out = d.detect(&scan, 0.0);
        assert_eq!(out.clusters, 2);
        let det = out.detection.unwrap();
        assert!((det.distance - 20.0).abs() <= 0.2);
        assert_eq!(d.clusters().iter().filter(|c| c.accepted()).count(), 2);
        assert_eq!(d.clusters().iter().filter(|c| c.selected).count(), 1);
        // The nearer one in the next lane does not count.
        let mut scan = rear_face(35.0, 0.3, 1.9);
        scan.extend(rear_face(20.0, -3.7, 1.8));
        let det = d.detect(&scan, 0.0).detection.unwrap();
        assert!((det.distance - 35.0).abs() <= 0.2);
    }

    #[test]
    fn oversized_scan_truncated() {
        let p = DetectorParams { max_points: 200, ..Default::default() };
        let mut d = <LeadDetector>::new(p).unwrap();
        let mut scan = rear_face(20.0, 0.0, 1.9);
        let n = scan.len();
        assert!(n < 200);
        scan.resize(200, [-1.0, 0.0]); // outside the grid
        scan.extend(core::iter::repeat_n([f64::NAN, 0.0], 50));
        scan.extend(rear_face(10.0, 0.0, 1.9));
        let out = d.detect(&scan, 0.0);
        assert_eq!(out.status, DetectorStatus::Truncated);
        assert_eq!(out.points_used, n);
        assert_eq!(out.points_rejected, 0);
        // The nearer car lies beyond max_points and is not seen.
        assert!((out.detection.unwrap().distance - 20.0).abs() <= 0.2);
    }

    #[test]
    fn too_many_clusters_keeps_the_nearest() {
        let mut scan = rear_face(5.0, 0.0, 1.9);
        // Isolated single points every 8 cells (1.6 m, too far apart to be joined) from x ~ 10 m:
        // ~300 clusters. Many lie behind the car, where a real scan has no returns: the
        // solid-face test is switched off (margin beyond every point) to test the overflow alone.
        let mut d = <LeadDetector>::new(DetectorParams { see_through_margin: 1000.0, ..Default::default() }).unwrap();
        for ix in (48..350).step_by(8) {
            for iy in (0..60).step_by(8) {
                let c = d.cell_center(ix, iy);
                scan.push([c.x, c.y]);
            }
        }
        let out = d.detect(&scan, 0.0);
        assert_eq!(out.status, DetectorStatus::TooManyClusters);
        assert_eq!(out.clusters, CLUSTER_CAPACITY);
        let det = out.detection.unwrap();
        assert!((det.distance - 5.0).abs() <= 0.2);
        assert!(d.clusters().first().unwrap().selected);
        assert!(d.clusters().iter().skip(1).all(|c| c.rejection == Some(RejectReason::TooFewPoints)));
    }

    #[test]
    fn grid_maps_follow_the_paper_steps() {
        let mut d = det();
        // A solid 5 x 5 block of occupied cells: 16 edge cells, 9 interior ones.
        let mut scan = Vec::new();
        for ix in 100..105 {
            for iy in 20..25 {
                let c = d.cell_center(ix, iy);
                scan.push([c.x, c.y]);
            }
        }
        d.detect(&scan, 0.0);
        let count = |f: &dyn Fn(usize, usize) -> bool| {
            (0..350).flat_map(|ix| (0..60).map(move |iy| (ix, iy))).filter(|&(ix, iy)| f(ix, iy)).count()
        };
        assert_eq!(count(&|ix, iy| d.is_occupied(ix, iy)), 25);
        assert_eq!(count(&|ix, iy| d.is_edge(ix, iy)), 16);
        assert!(!d.is_edge(102, 22) && d.is_edge(100, 22) && d.is_edge(102, 24));
        // Radius-1 dilation of the ring covers the 7 x 7 square except the centre, which is two
        // cells from every edge cell.
        assert_eq!(count(&|ix, iy| d.is_dilated(ix, iy)), 48);
        assert!(d.is_dilated(99, 19) && d.is_dilated(105, 25) && !d.is_dilated(106, 22));
        assert!(d.is_dilated(101, 22) && !d.is_dilated(102, 22));
        assert_eq!(d.clusters().len(), 1);
        assert_eq!(d.clusters().first().unwrap().cells, 48);
        // The point in the undilated centre cell belongs to no cluster (documented limitation).
        assert_eq!(d.clusters().first().unwrap().points, 24);
        // Cells on the grid border count their outside neighbour as free.
        let c = d.cell_center(0, 0);
        let c2 = d.cell_center(1, 0);
        d.detect(&[[c.x, c.y], [c2.x, c2.y]], 0.0);
        assert!(d.is_edge(0, 0) && d.is_edge(1, 0));
        assert!(!d.is_occupied(350, 0) && !d.is_occupied(0, 60));
    }

    #[test]
    fn dilation_bridges_sparse_far_returns() {
        // At 65 m the 0.2 deg beams are 0.227 m apart, more than a cell: without dilation the rear
        // face breaks into single-cell clusters, each too narrow.
        let scan = rear_face(65.0, 0.0, 1.9);
        let mut no_dil = <LeadDetector>::new(DetectorParams { dilation_radius: 0, max_dilation_radius: 0, ..Default::default() }).unwrap();
        let out = no_dil.detect(&scan, 0.0);
        assert!(out.clusters > 1);
        // At best a fragment survives the width check.
        assert!(out.detection.is_none_or(|det| det.points < scan.len() && det.width < 1.5));
        let out = det().detect(&scan, 0.0);
        assert_eq!(out.clusters, 1);
        let det = out.detection.unwrap();
        assert_eq!(det.points, scan.len());
        assert!(det.width > 1.6);
    }

    #[test]
    fn invalid_params_name_the_field() {
        let d = DetectorParams::default();
        let cases: [(DetectorParams, &str); 12] = [
            (DetectorParams { cell_size: 0.0, ..d }, "cell_size"),
            (DetectorParams { cell_size: f64::NAN, ..d }, "cell_size"),
            (DetectorParams { x_min: -1.0, ..d }, "x_min"),
            (DetectorParams { dilation_radius: 9, ..d }, "dilation_radius"),
            (DetectorParams { min_cluster_points: 0, ..d }, "min_cluster_points"),
            (DetectorParams { min_width: f64::INFINITY, ..d }, "min_width"),
            (DetectorParams { max_width: f64::NAN, ..d }, "max_width"),
            (DetectorParams { min_width: 2.0, max_width: 1.0, ..d }, "max_width"),
            (DetectorParams { max_depth: -0.1, ..d }, "max_depth"),
            (DetectorParams { path_half_width: 0.0, ..d }, "path_half_width"),
            (DetectorParams { max_points: 0, ..d }, "max_points"),
            (DetectorParams { max_points: 2_000_000, ..d }, "max_points"),
        ];
        for (p, field) in cases {
            assert_eq!(p.validate().unwrap_err().field, field);
            assert_eq!(<LeadDetector>::new(p).unwrap_err().field, field);
        }
        assert!(d.validate().is_ok());
    }

    #[test]
    fn small_grid_compiles_and_works() {
        let mut d = LeadDetector::<100, 64>::new(DetectorParams::default()).unwrap();
        let out = d.detect(&rear_face(12.0, 0.0, 1.9), 0.0);
        assert!((out.detection.unwrap().distance - 12.0).abs() <= 0.2);
        assert!(d.y_range().1 > 6.3);
    }

    /// Beams of the default LiDAR (0.1 deg).
    const RES_DEFAULT: f64 = 0.1 * core::f64::consts::PI / 180.0;

    #[test]
    fn long_range_car_and_motorcycle() {
        let mut d = det();
        for dist in [80.0, 120.0, 150.0, 190.0] {
            let scan = rear_face_res(dist, 0.0, 1.8, RES_DEFAULT);
            let det = d.detect(&scan, 0.0).detection.unwrap_or_else(|| panic!("car at {dist} m"));
            assert!((det.distance - dist).abs() <= 0.021, "{dist}: {}", det.distance);
            assert_eq!(det.points, scan.len());
        }
        // A 0.8 m wide motorcycle up to 80 m (4.6 beams at 0.1 deg, 0.14 m apart).
        for dist in [10.0, 40.0, 80.0] {
            let scan = rear_face_res(dist, 0.3, 0.8, RES_DEFAULT);
            let det = d.detect(&scan, 0.0).detection.unwrap_or_else(|| panic!("motorcycle at {dist} m"));
            assert!((det.distance - dist).abs() <= 0.021);
        }
        // A 15 cm post stays too narrow at every range.
        for dist in [10.0, 60.0, 150.0] {
            assert_eq!(d.detect(&rear_face_res(dist, 0.0, 0.15, RES_DEFAULT), 0.0).detection, None);
        }
    }

    #[test]
    fn sparse_returns_still_one_cluster() {
        // Every other beam missing at 100 m (0.35 m between returns): bridged by the wider lateral
        // dilation, one cluster of the whole face.
        let mut d = det();
        let scan: Vec<_> = rear_face_res(100.0, 0.0, 1.8, RES_DEFAULT).into_iter().step_by(2).collect();
        let out = d.detect(&scan, 0.0);
        assert_eq!(out.clusters, 1);
        let det = out.detection.unwrap();
        assert_eq!(det.points, scan.len());
        // Two returns 0.6 m apart at 150 m are still a vehicle (the far point threshold is 2).
        let out = d.detect(&[[150.0, -0.3], [150.02, 0.3]], 0.0);
        assert!(out.detection.is_some());
        // Near the sensor they are not.
        assert_eq!(d.detect(&[[20.0, -0.3], [20.02, 0.3]], 0.0).detection, None);
    }

    #[test]
    fn adjacent_lane_cars_do_not_merge_at_range() {
        // Cars 3.5 m apart centre to centre (1.7 m gap) at 200 m: the lead stays 1.8 m wide.
        let mut d = det();
        for dist in [100.0, 150.0, 199.0] {
            let mut scan = rear_face_res(dist, 0.0, 1.8, RES_DEFAULT);
            scan.extend(rear_face_res(dist, 3.5, 1.8, RES_DEFAULT));
            scan.extend(rear_face_res(dist, -3.5, 1.8, RES_DEFAULT));
            let out = d.detect(&scan, 0.0);
            assert_eq!(out.clusters, 3, "at {dist} m");
            let det = out.detection.unwrap();
            assert!(det.width < 1.9 && det.position.y.abs() < 0.1, "at {dist} m: {det:?}");
        }
    }

    /// Points of a rear face `width` wide, square to a circular path of curvature `k` through the
    /// sensor, `s` m along it (exact geometry, no noise).
    fn face_on_arc(k: f64, s: f64, width: f64, n: usize) -> Vec<[f64; 2]> {
        let (r, a) = (1.0 / k, s * k);
        (0..n)
            .map(|i| {
                let off = -0.5 * width + width * i as f64 / (n - 1) as f64; // + left of the path
                let rho = r - off;
                [rho * libm::sin(a), r - rho * libm::cos(a)]
            })
            .collect()
    }

    #[test]
    fn grid_follows_a_curved_path() {
        let mut d = det();
        for (k, s) in [(1.0 / 250.0, 120.0), (-1.0 / 250.0, 150.0), (1.0 / 120.0, 80.0)] {
            let face = face_on_arc(k, s, 1.8, 12);
            // The offsets across the path are exact: the rear face is 1.8 m wide across it.
            let det = d.detect(&face, k).detection.unwrap_or_else(|| panic!("k {k}, s {s}"));
            assert!((det.width - 1.8).abs() < 1e-6, "width {}", det.width);
            let c = d.clusters().iter().find(|c| c.selected).unwrap();
            assert!(c.center_offset().abs() < 1e-6);
            let x_true = face.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
            assert_eq!(det.distance, x_true);
            // Off the straight corridor: not the lead when the path is taken as straight.
            assert_eq!(d.detect(&face, 0.0).detection, None);
            // The prefilter box holds it.
            let (x0, x1, y0, y1) = d.bounds(k);
            assert!(face.iter().all(|p| p[0] >= x0 && p[0] < x1 && p[1] >= y0 && p[1] <= y1));
        }
        // A point more than a quarter turn along the path is outside the grid.
        let mut d = det();
        d.detect(&[], 0.1);
        assert_eq!(d.cell_of(5.0, 15.0), None);
        assert!(d.cell_of(5.0, 1.2).is_some());
        // Curvatures beyond 0.2 1/m are invalid (treated as straight).
        assert_eq!(d.detect(&rear_face(20.0, 0.0, 1.9), 0.25).status, DetectorStatus::InvalidCurvature);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn path_offset_is_the_distance_to_the_arc(
            k in prop_oneof![-0.05f64..0.05, Just(0.0), -1e-9f64..1e-9],
            x in 0.5f64..200.0,
            y in -60.0f64..60.0,
        ) {
            let g = Geometry::new(&DetectorParams::default(), 520, 60, k);
            match g.offset(x, y) {
                None => prop_assert!(k * y >= 1.0),
                Some(d) => {
                    if k == 0.0 {
                        prop_assert_eq!(d, y);
                    } else if k.abs() < 1e-5 {
                        // The reference below cancels badly here; the offset tends to y.
                        prop_assert!((d - y).abs() <= k.abs() * (x * x + y * y));
                    } else {
                        // |distance to the centre (0, 1/k)| - radius, + on the left.
                        let r = 1.0 / k;
                        let rho = libm::hypot(x, y - r);
                        let exact = if k > 0.0 { r - rho } else { rho + r };
                        prop_assert!((d - exact).abs() <= 1e-9 * (1.0 + 1.0 / k.abs()));
                    }
                }
            }
        }

        #[test]
        fn bounds_hold_every_grid_point(
            k in prop_oneof![-0.2f64..0.2, -0.01f64..0.01, Just(0.0)],
            pts in proptest::collection::vec((0.0f64..210.0, -220.0f64..220.0), 1..200),
            profile in proptest::option::of((1.0f64..20.0, proptest::collection::vec(-5.0f64..5.0, 1..=PROFILE_STATIONS))),
        ) {
            let mut d = det();
            if let Some((spacing, offsets)) = &profile {
                d.set_path_profile(*spacing, offsets).unwrap();
            }
            d.detect(&[], k);
            let (x0, x1, y0, y1) = d.bounds(k);
            for (x, y) in pts {
                if d.cell_of(x, y).is_some() {
                    prop_assert!(x >= x0 && x < x1 && y >= y0 && y <= y1, "({x}, {y}) outside {:?}", (x0, x1, y0, y1));
                }
            }
        }
    }

    /// A car somewhere ahead, clutter, a few NaNs and signed zeros.
    fn scene() -> impl Strategy<Value = Vec<[f64; 2]>> {
        (3.0f64..68.0, -2.5f64..2.5, 0.5f64..2.8, proptest::collection::vec((-2.0f64..75.0, -7.0f64..7.0), 0..150), 0usize..4).prop_map(
            |(dist, yc, w, clutter, nans)| {
                let mut pts = rear_face(dist, yc, w);
                pts.extend(clutter.into_iter().map(|(x, y)| [x, y]));
                pts.extend(core::iter::repeat_n([f64::NAN, 1.0], nans));
                pts.push([10.0, 0.0]);
                pts.push([10.05, -0.0]);
                pts
            },
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn output_independent_of_point_order(
            (pts, shuffled) in scene().prop_flat_map(|pts| (Just(pts.clone()), Just(pts).prop_shuffle())),
            curvature in -0.03f64..0.03,
            refined in any::<bool>(),
        ) {
            let reprojection = if refined { Reprojection::PointRefined } else { Reprojection::CellCenter };
            let p = DetectorParams { reprojection, ..Default::default() };
            let mut a = <LeadDetector>::new(p).unwrap();
            let mut b = <LeadDetector>::new(p).unwrap();
            let out_a = a.detect(&pts, curvature);
            let out_b = b.detect(&shuffled, curvature);
            prop_assert_eq!(out_a, out_b);
            prop_assert_eq!(a.clusters(), b.clusters());
            // Bit-identical, not just equal.
            if let (Some(x), Some(y)) = (out_a.detection, out_b.detection) {
                prop_assert_eq!(x.distance.to_bits(), y.distance.to_bits());
                prop_assert_eq!(x.position.y.to_bits(), y.position.y.to_bits());
            }
        }

        #[test]
        fn arbitrary_points_never_panic(
            pts in proptest::collection::vec(
                (prop_oneof![proptest::num::f64::ANY, -5.0f64..80.0, Just(f64::NAN)],
                 prop_oneof![proptest::num::f64::ANY, -8.0f64..8.0]), 0..600),
            curvature in prop_oneof![proptest::num::f64::ANY, -0.05f64..0.05],
            refined in any::<bool>(),
            max_points in 1usize..700,
            car in proptest::option::of((3.0f64..68.0, -2.0f64..2.0)),
        ) {
            let reprojection = if refined { Reprojection::PointRefined } else { Reprojection::CellCenter };
            let p = DetectorParams { reprojection, max_points, ..Default::default() };
            let mut d = <LeadDetector>::new(p).unwrap();
            // An optional car first, so that detections (not only rejections) are exercised.
            let mut scan: Vec<[f64; 2]> = car.map_or_else(Vec::new, |(dist, yc)| rear_face(dist, yc, 1.9));
            scan.extend(pts.into_iter().map(|(x, y)| [x, y]));
            let out = d.detect(&scan, curvature);
            prop_assert!(out.points_used + out.points_rejected <= scan.len().min(max_points));
            prop_assert!(out.clusters <= CLUSTER_CAPACITY && out.clusters == d.clusters().len());
            if !curvature.is_finite() {
                prop_assert_eq!(out.status, DetectorStatus::InvalidCurvature);
            }
            if out.points_used == 0 {
                prop_assert_eq!(out.detection, None);
            }
            let (x0, x1, y0, y1) = d.bounds(curvature);
            for c in d.clusters() {
                prop_assert!(c.x_min.is_finite() && c.x_max.is_finite() && c.y_min.is_finite() && c.y_max.is_finite());
            }
            prop_assert!(d.clusters().iter().filter(|c| c.selected).count() == usize::from(out.detection.is_some()));
            if let Some(det) = out.detection {
                prop_assert!(det.position.x.is_finite() && det.position.y.is_finite());
                prop_assert!(det.distance.is_finite() && det.width.is_finite() && det.depth.is_finite());
                prop_assert!(det.position.x >= x0 && det.position.x <= x1 + 1e-9);
                prop_assert!(det.position.y >= y0 - 1e-9 && det.position.y <= y1 + 1e-9);
                prop_assert_eq!(det.distance, det.position.x);
                prop_assert!(det.width + det.distance.max(0.0) * p.beam_spacing() >= p.min_width && det.width <= p.max_width);
                prop_assert!(det.depth >= 0.0 && det.depth <= p.max_depth && det.depth <= p.depth_per_width * det.width + 1.0);
                prop_assert!(det.points >= p.min_points_at(det.distance) && det.points <= out.points_used);
                prop_assert!(det.points >= 2.min(p.min_cluster_points));
                prop_assert!((0.0..=1.0).contains(&det.confidence));
            }
        }
    }
}
