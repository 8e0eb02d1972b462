//! C interface (feature `capi`): create / step / reset for the FLC, the robust FLC v1 and v2, the
//! PID, the supervisor, the pure-pursuit lateral controller, the lead detector and the neighbour
//! tracker.
//!
//! Design (see `docs/firmware.md`):
//!
//! * **Caller-owned memory.** Every controller lives in a fixed-size, 8-byte aligned *storage
//!   struct* (`FlcFallback`, `FlcRobust`, `FlcRobust2`, `FlcPid`, `FlcSupervisor`, `FlcPursuit`,
//!   `FlcDetector`, `FlcNeighbours`) that the caller declares (static, stack or inside its own
//!   structs). Nothing is ever allocated and no
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
//! One file per controller ([`flc`], [`flc_robust`] (v1 and v2), [`pid`], [`supervisor`], [`pure_pursuit`], [`detector`], [`neighbours`]: its
//! `#[repr(C)]` mirrors, storage struct, conversions and functions); this file holds what they
//! share (result codes, status, the parameter error, the command, library information) and
//! [`storage`] the caller-owned-storage machinery, including the one `init` helper behind every
//! `*_init` function.
//!
//! The header `include/flc.h` is generated from this folder by cbindgen (`cbindgen.toml`); a test
//! fails when it is out of date (`FLC_UPDATE_HEADER=1 cargo test -p flc-core --test c_header`
//! rewrites it).
//!
//! This is the only module (folder) of the crate with `unsafe` code: dereferencing the caller's pointers.
#![allow(unsafe_code)]

use core::ffi::{CStr, c_char};

use crate::command::{LongitudinalCommand, Status};

mod storage;

// cbindgen reads the modules in this order, which is the order of the header's functions and
// constants: keep it (blank lines keep rustfmt from sorting them).
pub mod flc;

pub mod flc_robust;

pub mod pid;

pub mod supervisor;

pub mod pure_pursuit;

pub mod detector;

pub mod neighbours;

pub use detector::*;
pub use flc::*;
pub use flc_robust::*;
pub use neighbours::*;
pub use pid::*;
pub use pure_pursuit::*;
pub use supervisor::*;

// ---------------------------------------------------------------------------------------------
// Result codes, status, shared inputs and outputs
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
