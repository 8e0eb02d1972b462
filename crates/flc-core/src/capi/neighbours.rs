//! C interface of the neighbour tracker ([`crate::neighbours`], issue 47): parameters, output,
//! storage `FlcNeighbours`, functions. The update reads the clusters of the last scan of an
//! initialised `FlcDetector` (`LeadDetector::clusters`), as the Rust tracker does.

use core::ptr;

use super::storage::{check_ptr, get_mut, get_ref, init, storage, tri, write_out};
use super::{FlcDetection, FlcDetector, FlcParamError, FlcResult};
use crate::neighbours::{NeighbourParams, NeighbourTracker};
use crate::params::ParamError;

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

/// Mirror of the Rust `NeighbourParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcNeighbourParams {
    /// Largest offset of a neighbour's near edge from the path, m.
    pub band: f64,
    /// Smallest width across the path of a tracked neighbour, m.
    pub min_width: f64,
    /// Farthest a tracked neighbour is ahead (its rear face), m; 0 tracks nothing.
    pub max_range: f64,
    /// Lateral movement towards the path not read as a cut-in, m (UN R157's wandering zone).
    pub wandering: f64,
    /// Association gate along the path (change of the rear-face x between two scans), m.
    pub gate_x: f64,
    /// Association gate across the path (change of the near edge), m.
    pub gate_d: f64,
    /// Smallest width of a view that measures the band a track occupies (a full view), m.
    pub full_width: f64,
    /// Farthest a full view is taken, m.
    pub full_range: f64,
    /// Widest (and deepest) cluster tracked, m.
    pub max_width: f64,
    /// Width of the lanes, m; 0 turns the lane rule off.
    pub lane_width: f64,
    /// Scans a track is kept without being seen.
    pub max_misses: u8,
}

/// Output of `flc_neighbours_update`. `detection` is all zero when `has_detection` is false.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcNeighbourOutput {
    /// The nearest intruding neighbour (valid when `has_detection`): its rear face and lateral
    /// centre (sensor frame), `distance` = its rear-face x, for the fallback to follow.
    pub detection: FlcDetection,
    /// Tracks held after the update (at most 8).
    pub tracks: usize,
    /// Whether a neighbour intrudes.
    pub has_detection: bool,
}

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcNeighbours::storage` (736 bytes).
pub const FLC_NEIGHBOURS_WORDS: usize = 92;

/// Caller-owned storage of one neighbour tracker (at most 8 tracks). Initialise with
/// `flc_neighbours_init`.
#[repr(C)]
pub struct FlcNeighbours {
    magic: u64,
    storage: [u64; FLC_NEIGHBOURS_WORDS],
}

storage!(FlcNeighbours, NeighbourTracker, 0x464C_435F_4E42_5201); // "FLC_NBR\x01"

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

impl From<NeighbourParams> for FlcNeighbourParams {
    fn from(p: NeighbourParams) -> Self {
        Self {
            band: p.band,
            min_width: p.min_width,
            max_range: p.max_range,
            wandering: p.wandering,
            gate_x: p.gate_x,
            gate_d: p.gate_d,
            full_width: p.full_width,
            full_range: p.full_range,
            max_width: p.max_width,
            lane_width: p.lane_width,
            max_misses: p.max_misses,
        }
    }
}

impl TryFrom<FlcNeighbourParams> for NeighbourParams {
    type Error = ParamError;
    fn try_from(p: FlcNeighbourParams) -> Result<Self, ParamError> {
        let params = NeighbourParams {
            band: p.band,
            min_width: p.min_width,
            max_range: p.max_range,
            wandering: p.wandering,
            gate_x: p.gate_x,
            gate_d: p.gate_d,
            max_misses: p.max_misses,
            full_width: p.full_width,
            full_range: p.full_range,
            max_width: p.max_width,
            lane_width: p.lane_width,
        };
        params.validate()?;
        Ok(params)
    }
}

// ---------------------------------------------------------------------------------------------
// Functions
// ---------------------------------------------------------------------------------------------

/// The neighbour tracker's default parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_neighbours_params_default() -> FlcNeighbourParams {
    NeighbourParams::defaults().into()
}

/// Validates `*params` and initialises `*nb` (no track).
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`nb`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_neighbours_init(
    nb: *mut FlcNeighbours,
    params: *const FlcNeighbourParams,
    error: *mut FlcParamError,
) -> FlcResult {
    // SAFETY: caller contract (that of `init`).
    unsafe { init(nb, params, error, |p| NeighbourParams::try_from(p).and_then(NeighbourTracker::new), ptr::write) }
}

/// One scan: call once after each `flc_detector_detect` on `det` (the tracker reads the clusters
/// of its last scan; `det` is not modified). Updates the tracks and writes the nearest intruding
/// neighbour, if any, to `*out`. A reset detector has no clusters: every track misses a scan.
///
/// # Safety
/// `nb` is NULL or points to an `FlcNeighbours`; `det` is NULL or points to an `FlcDetector`;
/// `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_neighbours_update(nb: *mut FlcNeighbours, det: *const FlcDetector, out: *mut FlcNeighbourOutput) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let d = tri!(unsafe { get_ref(det) });
    // SAFETY: caller contract.
    let n = tri!(unsafe { get_mut(nb) });
    let detection = n.update(d.clusters());
    let o = FlcNeighbourOutput {
        detection: FlcDetection::from_option(detection),
        tracks: n.tracks().count(),
        has_detection: detection.is_some(),
    };
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, o) };
    FlcResult::Ok
}

/// Forgets every track.
///
/// # Safety
/// `nb` is NULL or points to an `FlcNeighbours`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_neighbours_reset(nb: *mut FlcNeighbours) -> FlcResult {
    // SAFETY: caller contract.
    let n = tri!(unsafe { get_mut(nb) });
    n.reset();
    FlcResult::Ok
}
