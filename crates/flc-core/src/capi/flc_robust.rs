//! C interface of the robust FLC v1 ([`crate::flc_robust`]) and v2 ([`crate::flc_robust2`]):
//! parameters, terms, storage `FlcRobust` / `FlcRobust2`, functions. Same inputs as the FLC:
//! the LiDAR distance (or none) and the own speed, once per frame; no timestamp, no `dt`.

use core::ptr;

use super::storage::{check_ptr, get_mut, get_ref, init, param_error, storage, tri, write_out};
use super::{FlcLongitudinalCommand, FlcParamError, FlcResult};
use crate::comfort::ComfortParams;
use crate::flc_robust::{FirstObject, RobustFallbackController, RobustFlcParams, RobustFlcTerms};
use crate::flc_robust2::{RobustFallbackController2, RobustFlc2Params, RobustFlc2Terms};
use crate::params::ParamError;

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

/// Values of `FlcRobustParams::first_object` (Rust `FirstObject`).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcFirstObject {
    /// The first detection is the lead already followed (v1's default).
    Lead = 0,
    /// The first detection is an unknown, possibly standing object (v2's default).
    Unknown = 1,
}

/// Mirror of the Rust `RobustFlcParams` (laws (R1)-(R6)). Fill with
/// `flc_robust_params_default()`; units and meaning as documented on the Rust struct.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcRobustParams {
    /// `d_0`, m.
    pub standstill_gap: f64,
    /// `h`, s.
    pub time_gap: f64,
    /// `k_a`, 1/s.
    pub accel_gain: f64,
    /// `k_b`, 1/s.
    pub brake_gain: f64,
    /// `a_max`, m/s².
    pub max_accel: f64,
    /// `b_max`, m/s².
    pub max_decel: f64,
    /// `b_s`, m/s².
    pub envelope_decel: f64,
    /// `T_s`, s.
    pub envelope_reaction: f64,
    /// `d_s`, m.
    pub envelope_margin: f64,
    /// Distance jump that is a reveal, m.
    pub reveal_jump: f64,
    /// Growth of the distance that releases the latch, m.
    pub reveal_release: f64,
    /// `G`, s.
    pub command_gain: f64,
    /// Highest plausible own speed and highest command, m/s.
    pub max_speed: f64,
    /// Highest plausible distance, m.
    pub max_distance: f64,
    /// Safe command: `v_cmd = v - fault_brake_step`, m/s.
    pub fault_brake_step: f64,
    /// One of `FlcFirstObject`.
    pub first_object: u8,
}

/// Mirror of the Rust `RobustFlc2Params`: v1's laws plus v2's event rules.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcRobust2Params {
    /// (R1)-(R6), as in v1.
    pub law: FlcRobustParams,
    /// Distance within which a standing car on the path is detected, m.
    pub sight_distance: f64,
    /// Deceleration without a detection above `V_e(sight_distance)`, m/s².
    pub sight_decel: f64,
    /// Smallest own speed of the "not closing" release, m/s.
    pub release_speed: f64,
    /// Largest decrease of the distance that still counts as "not closing", m.
    pub release_closing: f64,
    /// (R7) time gap of the approach, s.
    pub approach_time_gap: f64,
    /// (R5') speed error braked for with `law.brake_gain`, m/s.
    pub firm_error: f64,
    /// (R5') gain on the negative speed error beyond `firm_error`, 1/s.
    pub firm_gain: f64,
    /// (C1)-(C2) the comfort layer.
    pub comfort: FlcComfortParams,
}

/// Mirror of the Rust `ComfortParams` (v2's comfort layer, (C1)-(C2)).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcComfortParams {
    /// (C1) memory of the closing-speed estimate, s.
    pub memory: f64,
    /// (C1) time constant of the modelled response to the commanded acceleration, s.
    pub response_time: f64,
    /// (C1) smallest modelled acceleration that counts as a clock, m/s².
    pub clock_accel: f64,
    /// (C2) IDM's maximum acceleration `a`, m/s².
    pub accel: f64,
    /// (C2) IDM's comfortable deceleration `b`, m/s².
    pub decel: f64,
    /// Own speed from which (C2) applies in full, m/s.
    pub fade_speed: f64,
    /// Largest deceleration the comfort layer commands, m/s².
    pub max_decel: f64,
}

/// Mirror of the Rust `RobustFlcTerms` (v1's terms of the last step).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcRobustTerms {
    /// (R1) desired gap, m.
    pub desired_gap: f64,
    /// `d - D_r(v)`, m.
    pub gap_error: f64,
    /// (R2) gap speed, m/s.
    pub gap_speed: f64,
    /// (R3) stop-envelope speed, m/s.
    pub envelope_speed: f64,
    /// (R4) target speed, m/s.
    pub target_speed: f64,
    /// Smallest distance since the latch was set, m (0 while not latched).
    pub latch_min_distance: f64,
    /// (R5) acceleration, m/s².
    pub a: f64,
    /// This frame set the latch.
    pub revealed: bool,
    /// The latch is set after this frame.
    pub latched: bool,
}

/// Mirror of the Rust `RobustFlc2Terms` (v2's terms of the last step).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcRobust2Terms {
    /// The accepted distance the law used, m (0 on a frame handled as missed).
    pub distance: f64,
    /// (R2) gap speed, m/s.
    pub gap_speed: f64,
    /// (R3) stop-envelope speed, m/s.
    pub envelope_speed: f64,
    /// (R7) approach speed, m/s.
    pub approach_speed: f64,
    /// (R4) target speed, m/s.
    pub target_speed: f64,
    /// (R5') the laws' acceleration before the comfort layer, m/s².
    pub a_law: f64,
    /// (C1) closing speed, m/s (0 without an estimate).
    pub closing: f64,
    /// (C2) the braking strategy's term, m/s² (0 without an estimate).
    pub closing_brake: f64,
    /// The commanded acceleration, m/s².
    pub a: f64,
    /// This frame was handled as missed.
    pub held: bool,
    /// A jump is pending confirmation after this frame.
    pub pending: bool,
    /// This frame set the latch.
    pub revealed: bool,
    /// The latch is set after this frame.
    pub latched: bool,
    /// (C1) an estimate was available on this frame.
    pub comfort: bool,
}

impl From<RobustFlcTerms> for FlcRobustTerms {
    fn from(t: RobustFlcTerms) -> Self {
        Self {
            desired_gap: t.desired_gap,
            gap_error: t.gap_error,
            gap_speed: t.gap_speed,
            envelope_speed: t.envelope_speed,
            target_speed: t.target_speed,
            latch_min_distance: t.latch_min_distance,
            a: t.a,
            revealed: t.revealed,
            latched: t.latched,
        }
    }
}

impl From<RobustFlc2Terms> for FlcRobust2Terms {
    fn from(t: RobustFlc2Terms) -> Self {
        Self {
            distance: t.distance,
            gap_speed: t.gap_speed,
            envelope_speed: t.envelope_speed,
            approach_speed: t.approach_speed,
            target_speed: t.target_speed,
            a_law: t.a_law,
            closing: t.closing,
            closing_brake: t.closing_brake,
            a: t.a,
            held: t.held,
            pending: t.pending,
            revealed: t.revealed,
            latched: t.latched,
            comfort: t.comfort,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcRobust::storage`.
pub const FLC_ROBUST_WORDS: usize = 29;

/// Words (8 bytes each) of `FlcRobust2::storage`.
pub const FLC_ROBUST2_WORDS: usize = 64;

/// Caller-owned storage of one robust FLC v1. Initialise with `flc_robust_init`.
#[repr(C)]
pub struct FlcRobust {
    magic: u64,
    storage: [u64; FLC_ROBUST_WORDS],
}

/// Caller-owned storage of one robust FLC v2. Initialise with `flc_robust2_init`.
#[repr(C)]
pub struct FlcRobust2 {
    magic: u64,
    storage: [u64; FLC_ROBUST2_WORDS],
}

storage!(FlcRobust, RobustFallbackController, 0x464C_435F_5242_5301); // "FLC_RBS\x01"
storage!(FlcRobust2, RobustFallbackController2, 0x464C_435F_5242_5302); // "FLC_RBS\x02"

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

impl From<RobustFlcParams> for FlcRobustParams {
    fn from(p: RobustFlcParams) -> Self {
        Self {
            standstill_gap: p.standstill_gap,
            time_gap: p.time_gap,
            accel_gain: p.accel_gain,
            brake_gain: p.brake_gain,
            max_accel: p.max_accel,
            max_decel: p.max_decel,
            envelope_decel: p.envelope_decel,
            envelope_reaction: p.envelope_reaction,
            envelope_margin: p.envelope_margin,
            reveal_jump: p.reveal_jump,
            reveal_release: p.reveal_release,
            command_gain: p.command_gain,
            max_speed: p.max_speed,
            max_distance: p.max_distance,
            fault_brake_step: p.fault_brake_step,
            first_object: match p.first_object {
                FirstObject::Lead => FlcFirstObject::Lead as u8,
                FirstObject::Unknown => FlcFirstObject::Unknown as u8,
            },
        }
    }
}

impl TryFrom<FlcRobustParams> for RobustFlcParams {
    type Error = ParamError;
    fn try_from(p: FlcRobustParams) -> Result<Self, ParamError> {
        let first_object = match p.first_object {
            0 => FirstObject::Lead,
            1 => FirstObject::Unknown,
            _ => return Err(param_error("first_object", "must be one of FLC_FIRST_OBJECT_*")),
        };
        Ok(RobustFlcParams {
            standstill_gap: p.standstill_gap,
            time_gap: p.time_gap,
            accel_gain: p.accel_gain,
            brake_gain: p.brake_gain,
            max_accel: p.max_accel,
            max_decel: p.max_decel,
            envelope_decel: p.envelope_decel,
            envelope_reaction: p.envelope_reaction,
            envelope_margin: p.envelope_margin,
            reveal_jump: p.reveal_jump,
            reveal_release: p.reveal_release,
            first_object,
            command_gain: p.command_gain,
            max_speed: p.max_speed,
            max_distance: p.max_distance,
            fault_brake_step: p.fault_brake_step,
        })
    }
}

impl From<RobustFlc2Params> for FlcRobust2Params {
    fn from(p: RobustFlc2Params) -> Self {
        Self {
            law: p.law.into(),
            sight_distance: p.sight_distance,
            sight_decel: p.sight_decel,
            release_speed: p.release_speed,
            release_closing: p.release_closing,
            approach_time_gap: p.approach_time_gap,
            firm_error: p.firm_error,
            firm_gain: p.firm_gain,
            comfort: p.comfort.into(),
        }
    }
}

impl From<ComfortParams> for FlcComfortParams {
    fn from(p: ComfortParams) -> Self {
        Self {
            memory: p.memory,
            response_time: p.response_time,
            clock_accel: p.clock_accel,
            accel: p.accel,
            decel: p.decel,
            fade_speed: p.fade_speed,
            max_decel: p.max_decel,
        }
    }
}

impl From<FlcComfortParams> for ComfortParams {
    fn from(p: FlcComfortParams) -> Self {
        Self {
            memory: p.memory,
            response_time: p.response_time,
            clock_accel: p.clock_accel,
            accel: p.accel,
            decel: p.decel,
            fade_speed: p.fade_speed,
            max_decel: p.max_decel,
        }
    }
}

impl TryFrom<FlcRobust2Params> for RobustFlc2Params {
    type Error = ParamError;
    fn try_from(p: FlcRobust2Params) -> Result<Self, ParamError> {
        Ok(RobustFlc2Params {
            law: p.law.try_into()?,
            sight_distance: p.sight_distance,
            sight_decel: p.sight_decel,
            release_speed: p.release_speed,
            release_closing: p.release_closing,
            approach_time_gap: p.approach_time_gap,
            firm_error: p.firm_error,
            firm_gain: p.firm_gain,
            comfort: p.comfort.into(),
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Functions: v1
// ---------------------------------------------------------------------------------------------

/// The robust FLC v1's documented parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_robust_params_default() -> FlcRobustParams {
    RobustFlcParams::documented().into()
}

/// Validates `*params` and initialises `*flc`. On `FLC_RESULT_INVALID_PARAMS`, `*error` (may be
/// NULL) names the field and `*flc` is unchanged.
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`flc`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust_init(flc: *mut FlcRobust, params: *const FlcRobustParams, error: *mut FlcParamError) -> FlcResult {
    // SAFETY: caller contract (that of `init`).
    unsafe { init(flc, params, error, |p| RobustFlcParams::try_from(p).and_then(RobustFallbackController::new), ptr::write) }
}

/// One frame: `distance` in m (ignored unless `has_distance`), `own_speed` in m/s.
///
/// # Safety
/// `flc` is NULL or points to an `FlcRobust` (initialised or not); `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust_step(
    flc: *mut FlcRobust,
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

/// Forgets everything (the next detection is a first detection).
///
/// # Safety
/// `flc` is NULL or points to an `FlcRobust`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust_reset(flc: *mut FlcRobust) -> FlcResult {
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_mut(flc) });
    c.reset();
    FlcResult::Ok
}

/// v1's terms of the last step.
///
/// # Safety
/// `flc` is NULL or points to an `FlcRobust`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust_terms(flc: *const FlcRobust, out: *mut FlcRobustTerms) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_ref(flc) });
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, (*c.terms()).into()) };
    FlcResult::Ok
}

// ---------------------------------------------------------------------------------------------
// Functions: v2
// ---------------------------------------------------------------------------------------------

/// The robust FLC v2's documented parameters.
#[unsafe(no_mangle)]
pub extern "C" fn flc_robust2_params_default() -> FlcRobust2Params {
    RobustFlc2Params::documented().into()
}

/// Validates `*params` and initialises `*flc`. On `FLC_RESULT_INVALID_PARAMS`, `*error` (may be
/// NULL) names the field and `*flc` is unchanged.
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`flc`, `error`) of its type.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust2_init(flc: *mut FlcRobust2, params: *const FlcRobust2Params, error: *mut FlcParamError) -> FlcResult {
    // SAFETY: caller contract (that of `init`).
    unsafe { init(flc, params, error, |p| RobustFlc2Params::try_from(p).and_then(RobustFallbackController2::new), ptr::write) }
}

/// One frame: `distance` in m (ignored unless `has_distance`), `own_speed` in m/s.
///
/// # Safety
/// `flc` is NULL or points to an `FlcRobust2` (initialised or not); `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust2_step(
    flc: *mut FlcRobust2,
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

/// Forgets everything (the next detection is a first detection).
///
/// # Safety
/// `flc` is NULL or points to an `FlcRobust2`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust2_reset(flc: *mut FlcRobust2) -> FlcResult {
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_mut(flc) });
    c.reset();
    FlcResult::Ok
}

/// v2's terms of the last step.
///
/// # Safety
/// `flc` is NULL or points to an `FlcRobust2`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn flc_robust2_terms(flc: *const FlcRobust2, out: *mut FlcRobust2Terms) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let c = tri!(unsafe { get_ref(flc) });
    // SAFETY: checked, caller contract.
    unsafe { write_out(out, (*c.terms()).into()) };
    FlcResult::Ok
}
