//! C interface of the FLC ([`crate::flc`]): parameters, terms, storage `FlcFallback`, functions.

use core::ptr;

use super::storage::{check_ptr, get_mut, get_ref, init, param_error, storage, tri, write_out};
use super::{FlcLongitudinalCommand, FlcParamError, FlcResult};
use crate::flc::{DistOverride, FallbackController, FirstFrame, FlcParams, FlcTerms};
use crate::params::ParamError;

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcFallback::storage`.
pub const FLC_FALLBACK_WORDS: usize = 28;

/// Caller-owned storage of one FLC. Initialise with `flc_fallback_init`; the fields are private.
#[repr(C)]
pub struct FlcFallback {
    magic: u64,
    storage: [u64; FLC_FALLBACK_WORDS],
}

storage!(FlcFallback, FallbackController, 0x464C_435F_464C_4301); // "FLC_FLC\x01"

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

// ---------------------------------------------------------------------------------------------
// Functions
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
    // SAFETY: caller contract (that of `init`).
    unsafe { init(flc, params, error, |p| FlcParams::try_from(p).and_then(FallbackController::new), ptr::write) }
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
