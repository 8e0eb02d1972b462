//! C interface (feature `capi`): create / step / reset for the FLC, the PID, the supervisor, the
//! pure-pursuit lateral controller and the lead detector.
//!
//! Design (see `docs/firmware.md`):
//!
//! * **Caller-owned memory.** Every controller lives in a fixed-size, 8-byte aligned *storage
//!   struct* (`FlcFallback`, `FlcPid`, `FlcSupervisor`, `FlcPursuit`, `FlcDetector`) that the
//!   caller declares (static, stack or inside its own structs). Nothing is ever allocated and no
//!   pointer is kept across calls; a storage struct may be copied with `memcpy`.
//! * **Status codes, never panics.** Every function returns an [`FlcResult`]; every pointer is
//!   checked for NULL and alignment, every storage struct for a magic word written by `*_init` (so
//!   that zeroed or garbage storage is refused instead of used). Whether the *inputs* of a step
//!   were usable is reported in the output's `status`, exactly as in the Rust API. The release
//!   build is checked to contain no panic path (`tests/c_api.rs`).
//! * **`#[repr(C)]` mirrors** of the Rust parameter and output structs. Enumerations that the
//!   caller passes in are plain `uint8_t` fields validated by `*_init` (an out-of-range value from C
//!   can then never become an invalid Rust enum); `flc_*_params_default()` return the Rust defaults.
//!
//! The header `include/flc.h` is generated from this file by cbindgen (`cbindgen.toml`); a test
//! fails when it is out of date (`FLC_UPDATE_HEADER=1 cargo test -p flc-core --test c_header`
//! rewrites it).
//!
//! This is the only module of the crate with `unsafe` code: dereferencing the caller's pointers.
#![allow(unsafe_code)]

use core::ffi::{CStr, c_char};
use core::mem::{align_of, size_of};
use core::ptr::{self, addr_of, addr_of_mut};

use crate::command::{LongitudinalCommand, Status};
use crate::detector::{
    CLUSTER_CAPACITY, ClusterInfo, DetectorOutput, DetectorParams, DetectorStatus, LeadDetector, RUN_CAPACITY, Reprojection, Run,
};
use crate::flc::{DistOverride, FallbackController, FirstFrame, FlcParams, FlcTerms};
use crate::params::ParamError;
use crate::pid::{GainSet, PidCore, PidGains, PidParams, PidTerms};
use crate::pure_pursuit::{PurePursuit, PurePursuitParams, PursuitLaw, SteeringCommand};
use crate::supervisor::{ActiveController, Supervisor, SupervisorOutput, SupervisorParams, SwitchReason, V2vMessage};
use nalgebra::Point2;

// ---------------------------------------------------------------------------------------------
// Result codes and enumerations
// ---------------------------------------------------------------------------------------------

/// Result of every C API call. Anything but `FLC_RESULT_OK` means the call did nothing (no output
/// was written, the controller state is unchanged) except where a function says otherwise.
#[repr(i32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcResult {
    /// The call succeeded.
    Ok = 0,
    /// A required pointer was NULL.
    NullPointer = 1,
    /// A pointer was not aligned for its type.
    Misaligned = 2,
    /// The storage struct was not initialised by the matching `*_init` (or belongs to another
    /// controller type).
    NotInitialized = 3,
    /// `*_init`: a parameter was rejected; the optional `FlcParamError` names it.
    InvalidParams = 4,
    /// An argument other than a parameter struct is unusable (e.g. a point count so large that
    /// the point array cannot exist).
    InvalidArgument = 5,
}

/// Mirror of the Rust `Status`: whether a controller's inputs were usable. Anything but
/// `FLC_STATUS_OK` means the controller issued its safe command (brake / steer straight).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcStatus {
    /// Inputs valid, the control law was applied.
    Ok = 0,
    /// No lead this frame.
    NoLead = 1,
    /// The distance (or lead position) was NaN, infinite, negative or beyond the plausible range.
    InvalidDistance = 2,
    /// Own speed was NaN, infinite or outside the plausible range.
    InvalidSpeed = 3,
    /// The lead speed (V2V) was NaN, infinite or outside the plausible range.
    InvalidLeadSpeed = 4,
    /// The time step was NaN, infinite, zero or negative (PID only).
    InvalidDt = 5,
}

impl From<Status> for FlcStatus {
    fn from(s: Status) -> Self {
        match s {
            Status::Ok => FlcStatus::Ok,
            Status::NoLead => FlcStatus::NoLead,
            Status::InvalidDistance => FlcStatus::InvalidDistance,
            Status::InvalidSpeed => FlcStatus::InvalidSpeed,
            Status::InvalidLeadSpeed => FlcStatus::InvalidLeadSpeed,
            Status::InvalidDt => FlcStatus::InvalidDt,
        }
    }
}

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

/// Values of `FlcFallbackParams::dist_override` (Rust `DistOverride`).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcDistOverride {
    /// `dist_s = min(dist_s, override_dist)` (default).
    Min = 0,
    /// `dist_s = override_dist`.
    Replace = 1,
    /// No override.
    Off = 2,
}

/// Values of `FlcFallbackParams::first_frame` (Rust `FirstFrame`).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcFirstFrame {
    /// `Delta_d = 0` on a first frame (default).
    Steady = 0,
    /// Fast-braking branch until two frames are available.
    Braking = 1,
}

/// Values of `FlcPursuitParams::law` (Rust `PursuitLaw`).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcPursuitLaw {
    /// The paper's Eq. (1) (default).
    Paper = 0,
    /// Standard pure pursuit.
    Standard = 1,
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

/// Mirror of the Rust `ActiveController`.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcActiveController {
    /// The fallback longitudinal controller.
    Flc = 0,
    /// The V2V-based PID gap controller.
    Pid = 1,
}

/// Mirror of the Rust `SwitchReason`.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcSwitchReason {
    /// V2V is fresh and the PID drives.
    V2vFresh = 0,
    /// No valid V2V message has been received yet.
    NoV2v = 1,
    /// The last valid V2V message is older than `max_age_ticks`.
    V2vStale = 2,
    /// V2V is fresh again but fewer than `return_after` consecutive fresh messages arrived.
    Recovering = 3,
    /// The last message carried an unusable lead speed.
    InvalidV2v = 4,
}

/// Mirror of the Rust `GainSet`.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcGainSet {
    /// Far gains.
    Far = 0,
    /// Near gains.
    Near = 1,
}

// ---------------------------------------------------------------------------------------------
// Parameter structs
// ---------------------------------------------------------------------------------------------

/// Which parameter `*_init` rejected: NUL-terminated field name (as in the Rust struct, e.g.
/// `"time_gap"` or `"far.kp"`) and problem, truncated to fit.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct FlcParamError {
    /// The offending field, NUL-terminated.
    pub field: [c_char; 32],
    /// What is wrong with it, NUL-terminated.
    pub problem: [c_char; 64],
}

/// Mirror of the Rust `FlcParams` (the FLC). Fill with `flc_fallback_params_default()` and change
/// what you need; units and meaning as documented on the Rust struct.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcFallbackParams {
    /// `T_G`, s.
    pub time_gap: f64,
    /// `B_gap`, m.
    pub base_gap: f64,
    /// `C`, m/s.
    pub c: f64,
    /// Gain of `Scale_f`.
    pub scale_gain: f64,
    /// Cap of `Scale_f`.
    pub scale_cap: f64,
    /// `bound_t`, m.
    pub bound_t: f64,
    /// `Delta_d` threshold of the fast-braking branch, m per frame.
    pub brake_threshold: f64,
    /// Shift of the normal branch.
    pub shift_normal: f64,
    /// Shift of the fast-braking branch.
    pub shift_brake: f64,
    /// Override value of `dist_s`, m.
    pub override_dist: f64,
    /// Multiplier on negative `a`.
    pub negative_multiplier: f64,
    /// `v_cmd = S_F + command_gain * a`.
    pub command_gain: f64,
    /// Highest plausible own speed and highest command, m/s.
    pub max_speed: f64,
    /// Highest plausible distance, m.
    pub max_distance: f64,
    /// Safe command: `v_cmd = S_F - fault_brake_step`, m/s.
    pub fault_brake_step: f64,
    /// One of `FlcDistOverride`.
    pub dist_override: u8,
    /// One of `FlcFirstFrame`.
    pub first_frame: u8,
    /// Clip `dist_s` to `[-bound_t, bound_t]`.
    pub clip_dist_s: bool,
}

/// Mirror of the Rust `PidGains`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcPidGains {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain.
    pub ki: f64,
    /// Derivative gain.
    pub kd: f64,
}

/// Mirror of the Rust `PidParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcPidParams {
    /// Desired time gap, s.
    pub time_gap: f64,
    /// `B_gap`, m.
    pub base_gap: f64,
    /// `C`, m/s.
    pub c: f64,
    /// Gain of `Scale_f`.
    pub scale_gain: f64,
    /// Cap of `Scale_f`.
    pub scale_cap: f64,
    /// Far gains.
    pub far: FlcPidGains,
    /// Near gains.
    pub near: FlcPidGains,
    /// Switching margin above the desired distance, m.
    pub near_margin: f64,
    /// Clamp of the integral term, m/s.
    pub integral_limit: f64,
    /// `v_cmd = S_F + command_gain * u`.
    pub command_gain: f64,
    /// Highest plausible speed and highest command, m/s.
    pub max_speed: f64,
    /// Highest plausible distance, m.
    pub max_distance: f64,
    /// Safe command: `v_cmd = S_F - fault_brake_step`, m/s.
    pub fault_brake_step: f64,
}

/// Mirror of the Rust `SupervisorParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcSupervisorParams {
    /// The FLC's parameters.
    pub flc: FlcFallbackParams,
    /// The PID's parameters.
    pub pid: FlcPidParams,
    /// Highest V2V age, in control ticks, still counted as fresh.
    pub max_age_ticks: u32,
    /// Consecutive fresh messages needed before the PID drives again.
    pub return_after: u32,
    /// Bumpless FLC -> PID transfer.
    pub bumpless: bool,
}

/// Mirror of the Rust `PurePursuitParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcPursuitParams {
    /// Base lookahead, m.
    pub base_lookahead: f64,
    /// Speed scaling of the lookahead, s.
    pub lookahead_gain: f64,
    /// Wheelbase, m.
    pub wheelbase: f64,
    /// Steering saturation, rad.
    pub max_steer: f64,
    /// One of `FlcPursuitLaw`.
    pub law: u8,
}

/// Mirror of the Rust `DetectorParams` (the C API uses the default 350 x 60 grid).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcDetectorParams {
    /// Edge length of a grid cell, m.
    pub cell_size: f64,
    /// Forward distance to the near edge of the grid, m.
    pub x_min: f64,
    /// Smallest lateral extent of a vehicle, m.
    pub min_width: f64,
    /// Largest lateral extent of a vehicle, m.
    pub max_width: f64,
    /// Largest longitudinal extent of a vehicle, m.
    pub max_depth: f64,
    /// Lateral half width of the path corridor, m.
    pub path_half_width: f64,
    /// Fewest original points for a vehicle.
    pub min_cluster_points: u32,
    /// Most points used per scan.
    pub max_points: u32,
    /// Radius of the square dilation element, cells.
    pub dilation_radius: u8,
    /// One of `FlcReprojection`.
    pub reprojection: u8,
}

// ---------------------------------------------------------------------------------------------
// Inputs and outputs
// ---------------------------------------------------------------------------------------------

/// Mirror of the Rust `LongitudinalCommand`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcLongitudinalCommand {
    /// Target speed for the low-level speed controller, m/s, finite and `>= 0`.
    pub speed: f64,
    /// The law's acceleration term, m/s², finite.
    pub accel: f64,
    /// Whether the inputs were usable.
    pub status: FlcStatus,
}

impl From<LongitudinalCommand> for FlcLongitudinalCommand {
    fn from(c: LongitudinalCommand) -> Self {
        Self { speed: c.speed, accel: c.accel, status: c.status.into() }
    }
}

/// Mirror of the Rust `FlcTerms` (the FLC's intermediate terms of the last step).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcFallbackTerms {
    /// `tau_D`, m.
    pub tau_d: f64,
    /// `D_d`, m.
    pub d_d: f64,
    /// `Scale_f`.
    pub scale_f: f64,
    /// `F_shift`, m.
    pub f_shift: f64,
    /// `Delta_d`, m per frame.
    pub delta_d: f64,
    /// `dist_s` before clipping and override, m.
    pub dist_s_raw: f64,
    /// `dist_s` as used, m.
    pub dist_s: f64,
    /// `a` before the negative multiplier.
    pub a_law: f64,
    /// `a` after the negative multiplier.
    pub a: f64,
    /// The fast-braking branch was taken.
    pub braking_branch: bool,
    /// The override changed `dist_s`.
    pub overridden: bool,
}

impl From<FlcTerms> for FlcFallbackTerms {
    fn from(t: FlcTerms) -> Self {
        Self {
            tau_d: t.tau_d,
            d_d: t.d_d,
            scale_f: t.scale_f,
            f_shift: t.f_shift,
            delta_d: t.delta_d,
            dist_s_raw: t.dist_s_raw,
            dist_s: t.dist_s,
            a_law: t.a_law,
            a: t.a,
            braking_branch: t.braking_branch,
            overridden: t.overridden,
        }
    }
}

/// Mirror of the Rust `PidTerms`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcPidTerms {
    /// Desired distance, m.
    pub desired: f64,
    /// Gap error, m.
    pub error: f64,
    /// Gap-error rate, m/s.
    pub error_rate: f64,
    /// Integral term, m/s.
    pub integral: f64,
    /// Output `u`, m/s.
    pub u: f64,
    /// Gain set used.
    pub gains: FlcGainSet,
}

impl From<PidTerms> for FlcPidTerms {
    fn from(t: PidTerms) -> Self {
        let gains = match t.gains {
            GainSet::Far => FlcGainSet::Far,
            GainSet::Near => FlcGainSet::Near,
        };
        Self { desired: t.desired, error: t.error, error_rate: t.error_rate, integral: t.integral, u: t.u, gains }
    }
}

/// Mirror of the Rust `V2vMessage`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcV2vMessage {
    /// The lead's speed as broadcast, m/s.
    pub lead_speed: f64,
    /// The sender's (wrapping) sequence number.
    pub seq: u32,
}

/// Mirror of the Rust `SupervisorOutput`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcSupervisorOutput {
    /// The command to apply.
    pub command: FlcLongitudinalCommand,
    /// What the FLC commanded this tick.
    pub flc: FlcLongitudinalCommand,
    /// What the PID commanded this tick.
    pub pid: FlcLongitudinalCommand,
    /// Ticks since the last accepted V2V message (`UINT32_MAX` if none yet).
    pub v2v_age_ticks: u32,
    /// Consecutive fresh messages counted so far.
    pub fresh_count: u32,
    /// Which controller produced `command`.
    pub active: FlcActiveController,
    /// Why.
    pub reason: FlcSwitchReason,
    /// `true` on the tick the active controller changed.
    pub switched: bool,
}

impl From<SupervisorOutput> for FlcSupervisorOutput {
    fn from(o: SupervisorOutput) -> Self {
        let active = match o.active {
            ActiveController::Flc => FlcActiveController::Flc,
            ActiveController::Pid => FlcActiveController::Pid,
        };
        let reason = match o.reason {
            SwitchReason::V2vFresh => FlcSwitchReason::V2vFresh,
            SwitchReason::NoV2v => FlcSwitchReason::NoV2v,
            SwitchReason::V2vStale => FlcSwitchReason::V2vStale,
            SwitchReason::Recovering => FlcSwitchReason::Recovering,
            SwitchReason::InvalidV2v => FlcSwitchReason::InvalidV2v,
        };
        Self {
            command: o.command.into(),
            flc: o.flc.into(),
            pid: o.pid.into(),
            v2v_age_ticks: o.v2v_age_ticks,
            fresh_count: o.fresh_count,
            active,
            reason,
            switched: o.switched,
        }
    }
}

/// Mirror of the Rust `SteeringCommand`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcSteeringCommand {
    /// Road-wheel steering angle, rad, left positive.
    pub steer: f64,
    /// `D_ahead`, m.
    pub lookahead: f64,
    /// Relative angle to the lead, rad.
    pub alpha: f64,
    /// Pursuit point x, follower frame, m.
    pub lookahead_x: f64,
    /// Pursuit point y, follower frame, m.
    pub lookahead_y: f64,
    /// `FLC_STATUS_OK`, or why the command is "straight ahead".
    pub status: FlcStatus,
}

impl From<SteeringCommand> for FlcSteeringCommand {
    fn from(s: SteeringCommand) -> Self {
        Self {
            steer: s.steer,
            lookahead: s.lookahead,
            alpha: s.alpha,
            lookahead_x: s.lookahead_point.x,
            lookahead_y: s.lookahead_point.y,
            status: s.status.into(),
        }
    }
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

impl From<DetectorOutput> for FlcDetectorOutput {
    fn from(o: DetectorOutput) -> Self {
        let detection =
            o.detection.map_or(FlcDetection { x: 0.0, y: 0.0, distance: 0.0, width: 0.0, depth: 0.0, confidence: 0.0, points: 0 }, |d| {
                FlcDetection {
                    x: d.position.x,
                    y: d.position.y,
                    distance: d.distance,
                    width: d.width,
                    depth: d.depth,
                    confidence: d.confidence,
                    points: d.points,
                }
            });
        Self {
            detection,
            points_used: o.points_used,
            points_rejected: o.points_rejected,
            clusters: o.clusters,
            status: o.status.into(),
            has_detection: o.detection.is_some(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Storage structs
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcFallback::storage`.
pub const FLC_FALLBACK_WORDS: usize = 28;
/// Words (8 bytes each) of `FlcPid::storage`.
pub const FLC_PID_WORDS: usize = 24;
/// Words (8 bytes each) of `FlcSupervisor::storage`.
pub const FLC_SUPERVISOR_WORDS: usize = 94;
/// Words (8 bytes each) of `FlcPursuit::storage`.
pub const FLC_PURSUIT_WORDS: usize = 5;
/// Words (8 bytes each) of `FlcDetector::storage` (37.3 KiB).
pub const FLC_DETECTOR_WORDS: usize = 4777;

/// Caller-owned storage of one FLC. Initialise with `flc_fallback_init`; the fields are private.
#[repr(C)]
pub struct FlcFallback {
    magic: u64,
    storage: [u64; FLC_FALLBACK_WORDS],
}

/// Caller-owned storage of one PID gap controller. Initialise with `flc_pid_init`.
#[repr(C)]
pub struct FlcPid {
    magic: u64,
    storage: [u64; FLC_PID_WORDS],
}

/// Caller-owned storage of one supervisor (FLC + PID + switching). Initialise with
/// `flc_supervisor_init`.
#[repr(C)]
pub struct FlcSupervisor {
    magic: u64,
    storage: [u64; FLC_SUPERVISOR_WORDS],
}

/// Caller-owned storage of one pure-pursuit lateral controller. Initialise with
/// `flc_pursuit_init`.
#[repr(C)]
pub struct FlcPursuit {
    magic: u64,
    storage: [u64; FLC_PURSUIT_WORDS],
}

/// Caller-owned storage of one lead detector (default 350 x 60 grid). Initialise with
/// `flc_detector_init`. About 37 KiB: prefer static storage on small stacks.
#[repr(C)]
pub struct FlcDetector {
    magic: u64,
    storage: [u64; FLC_DETECTOR_WORDS],
}

/// Ties a storage struct to the Rust type it holds.
trait Storage {
    type Inner;
    const MAGIC: u64;
}

macro_rules! storage {
    ($storage:ty, $inner:ty, $magic:expr) => {
        impl Storage for $storage {
            type Inner = $inner;
            const MAGIC: u64 = $magic;
        }
        const _: () = {
            assert!(size_of::<$inner>() <= size_of::<$storage>() - 8, "storage struct too small: raise its *_WORDS");
            assert!(align_of::<$inner>() <= align_of::<$storage>(), "storage struct under-aligned");
        };
    };
}

storage!(FlcFallback, FallbackController, 0x464C_435F_464C_4301); // "FLC_FLC\x01"
storage!(FlcPid, PidCore, 0x464C_435F_5049_4401); // "FLC_PID\x01"
storage!(FlcSupervisor, Supervisor, 0x464C_435F_5355_5001); // "FLC_SUP\x01"
storage!(FlcPursuit, PurePursuit, 0x464C_435F_5050_5501); // "FLC_PPU\x01"
storage!(FlcDetector, LeadDetector, 0x464C_435F_4445_5401); // "FLC_DET\x01"

/// The initialised controller in `s`, or why there is none.
///
/// # Safety
/// `s` is NULL or points to memory valid for reads and writes of `S` (any contents).
unsafe fn get_mut<'a, S: Storage>(s: *mut S) -> Result<&'a mut S::Inner, FlcResult> {
    check_ptr(s.cast_const())?;
    // SAFETY: `s` is non-null and aligned (checked) and valid for reads (caller contract); the
    // magic word is a plain u64, any bit pattern is valid.
    let magic = unsafe { ptr::read(addr_of!((*s.cast::<Layout>()).magic)) };
    if magic != S::MAGIC {
        return Err(FlcResult::NotInitialized);
    }
    // SAFETY: the magic word is only written by `*_init` after a valid `S::Inner` has been written
    // to the storage, which is aligned for it (const-asserted above) and big enough.
    Ok(unsafe { &mut *storage_ptr(s) })
}

/// As [`get_mut`], shared.
///
/// # Safety
/// `s` is NULL or points to memory valid for reads of `S` (any contents).
unsafe fn get_ref<'a, S: Storage>(s: *const S) -> Result<&'a S::Inner, FlcResult> {
    check_ptr(s)?;
    // SAFETY: as in `get_mut`.
    let magic = unsafe { ptr::read(addr_of!((*s.cast::<Layout>()).magic)) };
    if magic != S::MAGIC {
        return Err(FlcResult::NotInitialized);
    }
    // SAFETY: as in `get_mut`.
    Ok(unsafe { &*storage_ptr(s.cast_mut()).cast_const() })
}

/// The common layout of every storage struct: the magic word, then the storage words.
#[repr(C)]
struct Layout {
    magic: u64,
    storage: [u64; 0],
}

/// Pointer to the storage words of `s`, typed as the controller.
///
/// # Safety
/// `s` is non-null, aligned and points to an `S`.
unsafe fn storage_ptr<S: Storage>(s: *mut S) -> *mut S::Inner {
    // SAFETY: every storage struct is `#[repr(C)] { u64, [u64; N] }`, so the storage words start
    // right after the magic word, as in `Layout`.
    unsafe { addr_of_mut!((*s.cast::<Layout>()).storage).cast::<S::Inner>() }
}

/// Writes a fully initialised controller into `s` and marks it initialised.
///
/// # Safety
/// `s` is non-null, aligned and valid for writes of `S`.
unsafe fn put<S: Storage>(s: *mut S, inner: S::Inner) {
    // SAFETY: caller contract; the storage is big enough and aligned for `S::Inner` (const-asserted).
    // The old contents (if any) are plain data without destructors, so overwriting is fine.
    unsafe {
        ptr::write(storage_ptr(s), inner);
        ptr::write(addr_of_mut!((*s.cast::<Layout>()).magic), S::MAGIC);
    }
}

/// NULL and alignment check of a pointer argument.
fn check_ptr<T>(p: *const T) -> Result<(), FlcResult> {
    if p.is_null() {
        Err(FlcResult::NullPointer)
    } else if !p.is_aligned() {
        Err(FlcResult::Misaligned)
    } else {
        Ok(())
    }
}

/// Reads a caller's input struct.
///
/// # Safety
/// `p` is NULL or points to a valid `T`.
unsafe fn read_in<T: Copy>(p: *const T) -> Result<T, FlcResult> {
    check_ptr(p)?;
    // SAFETY: non-null and aligned (checked), valid (caller contract).
    Ok(unsafe { ptr::read(p) })
}

/// Writes an output for the caller.
///
/// # Safety
/// `p` is non-null, aligned and valid for writes of `T` (checked by the caller of this function).
unsafe fn write_out<T>(p: *mut T, value: T) {
    // SAFETY: caller contract.
    unsafe { ptr::write(p, value) }
}

/// Stores `e` in `*out` when `out` is non-null and aligned (truncated, NUL-terminated).
///
/// # Safety
/// `out` is NULL or valid for writes of `FlcParamError`.
unsafe fn report(out: *mut FlcParamError, e: ParamError) -> FlcResult {
    if check_ptr(out.cast_const()).is_ok() {
        let mut r = FlcParamError { field: [0; 32], problem: [0; 64] };
        copy_c_str(&mut r.field, e.field);
        copy_c_str(&mut r.problem, e.problem);
        // SAFETY: checked non-null and aligned; valid for writes (caller contract).
        unsafe { write_out(out, r) };
    }
    FlcResult::InvalidParams
}

fn copy_c_str(dst: &mut [c_char], src: &str) {
    let n = dst.len().saturating_sub(1);
    for (d, &b) in dst.iter_mut().zip(src.as_bytes().iter().take(n)) {
        *d = b as c_char;
    }
}

const fn param_error(field: &'static str, problem: &'static str) -> ParamError {
    ParamError { field, problem }
}

macro_rules! tri {
    ($e:expr) => {
        match $e {
            Ok(v) => v,
            Err(e) => return e,
        }
    };
}

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

impl From<FlcParams> for FlcFallbackParams {
    fn from(p: FlcParams) -> Self {
        Self {
            time_gap: p.time_gap,
            base_gap: p.base_gap,
            c: p.c,
            scale_gain: p.scale_gain,
            scale_cap: p.scale_cap,
            bound_t: p.bound_t,
            brake_threshold: p.brake_threshold,
            shift_normal: p.shift_normal,
            shift_brake: p.shift_brake,
            override_dist: p.override_dist,
            negative_multiplier: p.negative_multiplier,
            command_gain: p.command_gain,
            max_speed: p.max_speed,
            max_distance: p.max_distance,
            fault_brake_step: p.fault_brake_step,
            dist_override: match p.dist_override {
                DistOverride::Min => FlcDistOverride::Min as u8,
                DistOverride::Replace => FlcDistOverride::Replace as u8,
                DistOverride::Off => FlcDistOverride::Off as u8,
            },
            first_frame: match p.first_frame {
                FirstFrame::Steady => FlcFirstFrame::Steady as u8,
                FirstFrame::Braking => FlcFirstFrame::Braking as u8,
            },
            clip_dist_s: p.clip_dist_s,
        }
    }
}

impl TryFrom<FlcFallbackParams> for FlcParams {
    type Error = ParamError;
    fn try_from(p: FlcFallbackParams) -> Result<Self, ParamError> {
        let dist_override = match p.dist_override {
            0 => DistOverride::Min,
            1 => DistOverride::Replace,
            2 => DistOverride::Off,
            _ => return Err(param_error("dist_override", "must be one of FLC_DIST_OVERRIDE_*")),
        };
        let first_frame = match p.first_frame {
            0 => FirstFrame::Steady,
            1 => FirstFrame::Braking,
            _ => return Err(param_error("first_frame", "must be one of FLC_FIRST_FRAME_*")),
        };
        Ok(FlcParams {
            time_gap: p.time_gap,
            base_gap: p.base_gap,
            c: p.c,
            scale_gain: p.scale_gain,
            scale_cap: p.scale_cap,
            bound_t: p.bound_t,
            brake_threshold: p.brake_threshold,
            shift_normal: p.shift_normal,
            shift_brake: p.shift_brake,
            override_dist: p.override_dist,
            dist_override,
            negative_multiplier: p.negative_multiplier,
            clip_dist_s: p.clip_dist_s,
            command_gain: p.command_gain,
            first_frame,
            max_speed: p.max_speed,
            max_distance: p.max_distance,
            fault_brake_step: p.fault_brake_step,
        })
    }
}

impl From<PidGains> for FlcPidGains {
    fn from(g: PidGains) -> Self {
        Self { kp: g.kp, ki: g.ki, kd: g.kd }
    }
}

impl From<FlcPidGains> for PidGains {
    fn from(g: FlcPidGains) -> Self {
        Self { kp: g.kp, ki: g.ki, kd: g.kd }
    }
}

impl From<PidParams> for FlcPidParams {
    fn from(p: PidParams) -> Self {
        Self {
            time_gap: p.time_gap,
            base_gap: p.base_gap,
            c: p.c,
            scale_gain: p.scale_gain,
            scale_cap: p.scale_cap,
            far: p.far.into(),
            near: p.near.into(),
            near_margin: p.near_margin,
            integral_limit: p.integral_limit,
            command_gain: p.command_gain,
            max_speed: p.max_speed,
            max_distance: p.max_distance,
            fault_brake_step: p.fault_brake_step,
        }
    }
}

impl From<FlcPidParams> for PidParams {
    fn from(p: FlcPidParams) -> Self {
        Self {
            time_gap: p.time_gap,
            base_gap: p.base_gap,
            c: p.c,
            scale_gain: p.scale_gain,
            scale_cap: p.scale_cap,
            far: p.far.into(),
            near: p.near.into(),
            near_margin: p.near_margin,
            integral_limit: p.integral_limit,
            command_gain: p.command_gain,
            max_speed: p.max_speed,
            max_distance: p.max_distance,
            fault_brake_step: p.fault_brake_step,
        }
    }
}

impl From<SupervisorParams> for FlcSupervisorParams {
    fn from(p: SupervisorParams) -> Self {
        Self { flc: p.flc.into(), pid: p.pid.into(), max_age_ticks: p.max_age_ticks, return_after: p.return_after, bumpless: p.bumpless }
    }
}

impl TryFrom<FlcSupervisorParams> for SupervisorParams {
    type Error = ParamError;
    fn try_from(p: FlcSupervisorParams) -> Result<Self, ParamError> {
        Ok(SupervisorParams {
            max_age_ticks: p.max_age_ticks,
            return_after: p.return_after,
            bumpless: p.bumpless,
            flc: p.flc.try_into()?,
            pid: p.pid.into(),
        })
    }
}

impl From<PurePursuitParams> for FlcPursuitParams {
    fn from(p: PurePursuitParams) -> Self {
        let law = match p.law {
            PursuitLaw::Paper => FlcPursuitLaw::Paper as u8,
            PursuitLaw::Standard => FlcPursuitLaw::Standard as u8,
        };
        Self { base_lookahead: p.base_lookahead, lookahead_gain: p.lookahead_gain, wheelbase: p.wheelbase, max_steer: p.max_steer, law }
    }
}

impl TryFrom<FlcPursuitParams> for PurePursuitParams {
    type Error = ParamError;
    fn try_from(p: FlcPursuitParams) -> Result<Self, ParamError> {
        let law = match p.law {
            0 => PursuitLaw::Paper,
            1 => PursuitLaw::Standard,
            _ => return Err(param_error("law", "must be one of FLC_PURSUIT_LAW_*")),
        };
        Ok(PurePursuitParams {
            base_lookahead: p.base_lookahead,
            lookahead_gain: p.lookahead_gain,
            law,
            wheelbase: p.wheelbase,
            max_steer: p.max_steer,
        })
    }
}

impl From<DetectorParams> for FlcDetectorParams {
    fn from(p: DetectorParams) -> Self {
        let reprojection = match p.reprojection {
            Reprojection::CellCenter => FlcReprojection::CellCenter as u8,
            Reprojection::PointRefined => FlcReprojection::PointRefined as u8,
        };
        Self {
            cell_size: p.cell_size,
            x_min: p.x_min,
            min_width: p.min_width,
            max_width: p.max_width,
            max_depth: p.max_depth,
            path_half_width: p.path_half_width,
            min_cluster_points: u32::try_from(p.min_cluster_points).unwrap_or(u32::MAX),
            max_points: u32::try_from(p.max_points).unwrap_or(u32::MAX),
            dilation_radius: p.dilation_radius,
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
            dilation_radius: p.dilation_radius,
            min_cluster_points,
            min_width: p.min_width,
            max_width: p.max_width,
            max_depth: p.max_depth,
            path_half_width: p.path_half_width,
            max_points,
            reprojection,
        };
        params.validate()?;
        Ok(params)
    }
}

// ---------------------------------------------------------------------------------------------
// Library information
// ---------------------------------------------------------------------------------------------

/// The crate version, e.g. `"0.1.0"` (static, NUL-terminated).
#[unsafe(no_mangle)]
pub extern "C" fn flc_version() -> *const c_char {
    const VERSION: &CStr = match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
        Ok(v) => v,
        Err(_) => c"unknown",
    };
    VERSION.as_ptr()
}

/// Stable lower-case name of an `FlcResult` (static, NUL-terminated; `"unknown"` if out of range).
#[unsafe(no_mangle)]
pub extern "C" fn flc_result_name(result: i32) -> *const c_char {
    let s: &CStr = match result {
        0 => c"ok",
        1 => c"null_pointer",
        2 => c"misaligned",
        3 => c"not_initialized",
        4 => c"invalid_params",
        5 => c"invalid_argument",
        _ => c"unknown",
    };
    s.as_ptr()
}

/// Stable lower-case name of an `FlcStatus` (as the Rust `Status::as_str`).
#[unsafe(no_mangle)]
pub extern "C" fn flc_status_name(status: u8) -> *const c_char {
    let s: &CStr = match status {
        0 => c"ok",
        1 => c"no_lead",
        2 => c"invalid_distance",
        3 => c"invalid_speed",
        4 => c"invalid_lead_speed",
        5 => c"invalid_dt",
        _ => c"unknown",
    };
    s.as_ptr()
}

/// Stable lower-case name of an `FlcDetectorStatus` (as the Rust `DetectorStatus::as_str`).
#[unsafe(no_mangle)]
pub extern "C" fn flc_detector_status_name(status: u8) -> *const c_char {
    let s: &CStr = match status {
        0 => c"ok",
        1 => c"empty_scan",
        2 => c"non_finite_points",
        3 => c"truncated",
        4 => c"too_many_clusters",
        5 => c"invalid_curvature",
        _ => c"unknown",
    };
    s.as_ptr()
}

// ---------------------------------------------------------------------------------------------
// FLC
// ---------------------------------------------------------------------------------------------

/// The FLC's default (paper) parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_fallback_params_default() -> FlcFallbackParams {
    FlcParams::paper().into()
}

/// Validates `*params` and initialises `*flc` (the first frame after init is a first frame).
/// On `FLC_RESULT_INVALID_PARAMS`, `*error` (may be NULL) names the field and `*flc` is unchanged.
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`flc`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_fallback_init(
    flc: *mut FlcFallback,
    params: *const FlcFallbackParams,
    error: *mut FlcParamError,
) -> FlcResult {
    tri!(check_ptr(flc.cast_const()));
    // SAFETY: caller contract.
    let p = tri!(unsafe { read_in(params) });
    match FlcParams::try_from(p).and_then(FallbackController::new) {
        // SAFETY: `flc` checked non-null and aligned, valid for writes (caller contract).
        Ok(c) => unsafe { put(flc, c) },
        // SAFETY: caller contract.
        Err(e) => return unsafe { report(error, e) },
    }
    FlcResult::Ok
}

/// One FLC frame: `distance` is `LF_dist` in m (ignored unless `has_distance`), `own_speed` `S_F`
/// in m/s. Writes the command to `*out`.
///
/// # Safety
/// `flc` is NULL or points to an `FlcFallback` (initialised or not); `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_fallback_step(
    flc: *mut FlcFallback,
    has_distance: bool,
    distance: f64,
    own_speed: f64,
    out: *mut FlcLongitudinalCommand,
) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_mut(flc) });
    let cmd = c.step(has_distance.then_some(distance), own_speed);
    // SAFETY: `out` checked non-null and aligned, valid for writes (caller contract).
    unsafe { write_out(out, cmd.into()) };
    FlcResult::Ok
}

/// Forgets the previous distance (the next frame is a first frame).
///
/// # Safety
/// `flc` is NULL or points to an `FlcFallback`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_fallback_reset(flc: *mut FlcFallback) -> FlcResult {
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_mut(flc) });
    c.reset();
    FlcResult::Ok
}

/// The FLC's terms of the last step (all zero before the first step or after a fault).
///
/// # Safety
/// `flc` is NULL or points to an `FlcFallback`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_fallback_terms(flc: *const FlcFallback, out: *mut FlcFallbackTerms) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_ref(flc) });
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, (*c.terms()).into()) };
    FlcResult::Ok
}

// ---------------------------------------------------------------------------------------------
// PID
// ---------------------------------------------------------------------------------------------

/// The PID's default parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_pid_params_default() -> FlcPidParams {
    PidParams::paper().into()
}

/// Validates `*params` and initialises `*pid` (integrator cleared).
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`pid`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_pid_init(pid: *mut FlcPid, params: *const FlcPidParams, error: *mut FlcParamError) -> FlcResult {
    tri!(check_ptr(pid.cast_const()));
    // SAFETY: caller contract.
    let p = tri!(unsafe { read_in(params) });
    match PidCore::new(p.into()) {
        // SAFETY: checked, caller contract.
        Ok(c) => unsafe { put(pid, c) },
        // SAFETY: caller contract.
        Err(e) => return unsafe { report(error, e) },
    }
    FlcResult::Ok
}

/// One PID step: `lead_speed` (V2V) and `own_speed` in m/s, `distance` in m (ignored unless
/// `has_distance`), `dt` in s.
///
/// # Safety
/// `pid` is NULL or points to an `FlcPid`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_pid_step(
    pid: *mut FlcPid,
    lead_speed: f64,
    own_speed: f64,
    has_distance: bool,
    distance: f64,
    dt: f64,
    out: *mut FlcLongitudinalCommand,
) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_mut(pid) });
    let cmd = c.step(lead_speed, own_speed, has_distance.then_some(distance), dt);
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, cmd.into()) };
    FlcResult::Ok
}

/// Clears the integrator.
///
/// # Safety
/// `pid` is NULL or points to an `FlcPid`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_pid_reset(pid: *mut FlcPid) -> FlcResult {
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_mut(pid) });
    c.reset();
    FlcResult::Ok
}

/// The PID's terms of the last step.
///
/// # Safety
/// `pid` is NULL or points to an `FlcPid`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_pid_terms(pid: *const FlcPid, out: *mut FlcPidTerms) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_ref(pid) });
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, (*c.terms()).into()) };
    FlcResult::Ok
}

// ---------------------------------------------------------------------------------------------
// Supervisor
// ---------------------------------------------------------------------------------------------

/// The supervisor's default parameters (paper FLC and PID).
#[unsafe(no_mangle)]
pub extern "C" fn flc_supervisor_params_default() -> FlcSupervisorParams {
    SupervisorParams::default().into()
}

/// Validates `*params` (FLC and PID included) and initialises `*sup` (FLC driving, no V2V).
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`sup`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_supervisor_init(
    sup: *mut FlcSupervisor,
    params: *const FlcSupervisorParams,
    error: *mut FlcParamError,
) -> FlcResult {
    tri!(check_ptr(sup.cast_const()));
    // SAFETY: caller contract.
    let p = tri!(unsafe { read_in(params) });
    match SupervisorParams::try_from(p).and_then(Supervisor::new) {
        // SAFETY: checked, caller contract.
        Ok(s) => unsafe { put(sup, s) },
        // SAFETY: caller contract.
        Err(e) => return unsafe { report(error, e) },
    }
    FlcResult::Ok
}

/// One control tick: `v2v` is the message received since the previous tick (ignored unless
/// `has_v2v`), `distance` the LiDAR distance in m (ignored unless `has_distance`), `own_speed` in
/// m/s, `dt` the PID's time step in s.
///
/// # Safety
/// `sup` is NULL or points to an `FlcSupervisor`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_supervisor_step(
    sup: *mut FlcSupervisor,
    has_v2v: bool,
    v2v: FlcV2vMessage,
    has_distance: bool,
    distance: f64,
    own_speed: f64,
    dt: f64,
    out: *mut FlcSupervisorOutput,
) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let s = tri!(unsafe { get_mut(sup) });
    let msg = has_v2v.then_some(V2vMessage { lead_speed: v2v.lead_speed, seq: v2v.seq });
    let o = s.step(msg, has_distance.then_some(distance), own_speed, dt);
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, o.into()) };
    FlcResult::Ok
}

/// Back to the initial state (FLC driving, no V2V).
///
/// # Safety
/// `sup` is NULL or points to an `FlcSupervisor`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_supervisor_reset(sup: *mut FlcSupervisor) -> FlcResult {
    // SAFETY: caller contract.
    let s = tri!(unsafe { get_mut(sup) });
    s.reset();
    FlcResult::Ok
}

// ---------------------------------------------------------------------------------------------
// Pure pursuit
// ---------------------------------------------------------------------------------------------

/// The lateral controller's default parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_pursuit_params_default() -> FlcPursuitParams {
    PurePursuitParams::default().into()
}

/// Validates `*params` and initialises `*pp`.
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`pp`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_pursuit_init(pp: *mut FlcPursuit, params: *const FlcPursuitParams, error: *mut FlcParamError) -> FlcResult {
    tri!(check_ptr(pp.cast_const()));
    // SAFETY: caller contract.
    let p = tri!(unsafe { read_in(params) });
    match PurePursuitParams::try_from(p).and_then(PurePursuit::new) {
        // SAFETY: checked, caller contract.
        Ok(c) => unsafe { put(pp, c) },
        // SAFETY: caller contract.
        Err(e) => return unsafe { report(error, e) },
    }
    FlcResult::Ok
}

/// Steering towards the lead at `(lead_x, lead_y)` (follower frame, m; ignored unless `has_lead`)
/// at own speed `own_speed` m/s. Stateless (no reset).
///
/// # Safety
/// `pp` is NULL or points to an `FlcPursuit`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_pursuit_step(
    pp: *const FlcPursuit,
    has_lead: bool,
    lead_x: f64,
    lead_y: f64,
    own_speed: f64,
    out: *mut FlcSteeringCommand,
) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_ref(pp) });
    let cmd = c.step(has_lead.then(|| Point2::new(lead_x, lead_y)), own_speed);
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, cmd.into()) };
    FlcResult::Ok
}

// ---------------------------------------------------------------------------------------------
// Detector
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
    tri!(check_ptr(det.cast_const()));
    // SAFETY: caller contract.
    let p = tri!(unsafe { read_in(params) });
    let params = match DetectorParams::try_from(p) {
        Ok(p) => p,
        // SAFETY: caller contract.
        Err(e) => return unsafe { report(error, e) },
    };
    // SAFETY: `det` is non-null and aligned (checked) and valid for writes (caller contract); the
    // storage is big enough and aligned for a `LeadDetector` (const-asserted). Every field is
    // written below before the magic word marks the detector initialised.
    unsafe {
        init_detector_in_place(storage_ptr(det), params);
        ptr::write(addr_of_mut!((*det.cast::<Layout>()).magic), FlcDetector::MAGIC);
    }
    FlcResult::Ok
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
            occupied: _,
            edges: _,
            dilated: _,
            runs: _,
            parent: _,
            n_runs: _,
            col_first: _,
            col_len: _,
            clusters: _,
            n_clusters: _,
        } = d;
    }
    // SAFETY: caller contract; each `addr_of_mut!` projects to a field of `*d` without creating a
    // reference to uninitialised memory, and each write covers the whole field with valid values
    // (all-zero is a valid `[u64]`, `[u16]`, `[u8]`; runs and clusters get their EMPTY value).
    unsafe {
        addr_of_mut!((*d).params).write(params);
        addr_of_mut!((*d).occupied).write_bytes(0, 1);
        addr_of_mut!((*d).edges).write_bytes(0, 1);
        addr_of_mut!((*d).dilated).write_bytes(0, 1);
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

// ---------------------------------------------------------------------------------------------
// Panic handler for no_std static libraries
// ---------------------------------------------------------------------------------------------

/// Needed only to link a `no_std` static library (feature `panic-handler`, without `std`). The
/// release library is checked to contain no call to it (`tests/c_api.rs`), so this never runs.
#[cfg(all(feature = "panic-handler", not(feature = "std"), not(test)))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        core::hint::spin_loop();
    }
}

/// The precompiled `core` of hosted targets carries unwind tables that name this symbol; with
/// `panic = "abort"` nothing ever unwinds, so it is never called. Defining it lets a `no_std`
/// static library link even without `--gc-sections`.
#[cfg(all(feature = "panic-handler", not(feature = "std"), not(test)))]
#[unsafe(no_mangle)]
pub extern "C" fn rust_eh_personality() {}
