//! C interface of the PID gap controller ([`crate::pid`], stored as [`PidCore`]): parameters,
//! terms, storage `FlcPid`, functions.

use core::ptr;

use super::storage::{check_ptr, get_mut, get_ref, init, storage, tri, write_out};
use super::{FlcLongitudinalCommand, FlcParamError, FlcResult};
use crate::pid::{GainSet, PidCore, PidGains, PidParams, PidTerms};

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

/// Mirror of the Rust `GainSet`.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcGainSet {
    /// Far gains.
    Far = 0,
    /// Near gains.
    Near = 1,
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

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcPid::storage`.
pub const FLC_PID_WORDS: usize = 24;

/// Caller-owned storage of one PID gap controller. Initialise with `flc_pid_init`.
#[repr(C)]
pub struct FlcPid {
    magic: u64,
    storage: [u64; FLC_PID_WORDS],
}

storage!(FlcPid, PidCore, 0x464C_435F_5049_4401); // "FLC_PID\x01"

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Functions
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
    // SAFETY: caller contract (that of `init`).
    unsafe { init(pid, params, error, |p: FlcPidParams| PidCore::new(p.into()), ptr::write) }
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
