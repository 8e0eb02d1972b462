//! C interface of the supervisor ([`crate::supervisor`]): parameters, V2V message, output, storage
//! `FlcSupervisor`, functions.

use core::ptr;

use super::storage::{check_ptr, get_mut, init, storage, tri, write_out};
use super::{FlcFallbackParams, FlcLongitudinalCommand, FlcParamError, FlcPidParams, FlcResult};
use crate::association::{AssociationParams, AssociationState};
use crate::longitudinal::Frame;
use crate::params::ParamError;
use crate::supervisor::{ActiveController, Supervisor, SupervisorOutput, SupervisorParams, SwitchReason, V2vMessage};

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

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
    /// V2V is fresh but the detected object is not its sender.
    NotAssociated = 5,
}

/// Mirror of the Rust `AssociationState`.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcAssociationState {
    /// No fresh V2V or no detection yet.
    Unknown = 0,
    /// The detected object is the V2V sender.
    Associated = 1,
    /// The detected object is not the V2V sender.
    NotAssociated = 2,
}

/// Mirror of the Rust `AssociationParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcAssociationParams {
    /// Largest unexplained change of the distance between two ticks, m.
    pub jump_m: f64,
    /// Time constant with which the tracked gap follows the detections, s.
    pub track_tau_s: f64,
    /// Growth of the dead-reckoned gap's tolerance, m/s.
    pub speed_error_mps: f64,
    /// 1-sigma GNSS position error assumed for each vehicle, m.
    pub gnss_sigma_m: f64,
    /// Width of the position gate in sigmas of the gap's GNSS error.
    pub gate_sigmas: f64,
    /// Largest V2V air latency the gate allows for, s.
    pub max_latency_s: f64,
    /// `false`: every detection counts as the sender.
    pub enabled: bool,
}

impl From<AssociationParams> for FlcAssociationParams {
    fn from(p: AssociationParams) -> Self {
        Self {
            jump_m: p.jump_m,
            track_tau_s: p.track_tau_s,
            speed_error_mps: p.speed_error_mps,
            gnss_sigma_m: p.gnss_sigma_m,
            gate_sigmas: p.gate_sigmas,
            max_latency_s: p.max_latency_s,
            enabled: p.enabled,
        }
    }
}

impl From<FlcAssociationParams> for AssociationParams {
    fn from(p: FlcAssociationParams) -> Self {
        Self {
            enabled: p.enabled,
            jump_m: p.jump_m,
            track_tau_s: p.track_tau_s,
            speed_error_mps: p.speed_error_mps,
            gnss_sigma_m: p.gnss_sigma_m,
            gate_sigmas: p.gate_sigmas,
            max_latency_s: p.max_latency_s,
        }
    }
}

/// Mirror of the Rust `SupervisorParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlcSupervisorParams {
    /// The FLC's parameters.
    pub flc: FlcFallbackParams,
    /// The PID's parameters.
    pub pid: FlcPidParams,
    /// The association rule's parameters.
    pub association: FlcAssociationParams,
    /// Highest V2V age, in control ticks, still counted as fresh.
    pub max_age_ticks: u32,
    /// Consecutive fresh messages needed before the PID drives again.
    pub return_after: u32,
    /// Bumpless FLC -> PID transfer.
    pub bumpless: bool,
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
    /// Is the detected object the V2V sender?
    pub association: FlcAssociationState,
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
            SwitchReason::NotAssociated => FlcSwitchReason::NotAssociated,
        };
        let association = match o.association {
            AssociationState::Unknown => FlcAssociationState::Unknown,
            AssociationState::Associated => FlcAssociationState::Associated,
            AssociationState::NotAssociated => FlcAssociationState::NotAssociated,
        };
        Self {
            command: o.command.into(),
            flc: o.flc.into(),
            pid: o.pid.into(),
            v2v_age_ticks: o.v2v_age_ticks,
            fresh_count: o.fresh_count,
            active,
            reason,
            association,
            switched: o.switched,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcSupervisor::storage`.
pub const FLC_SUPERVISOR_WORDS: usize = 122;

/// Caller-owned storage of one supervisor (FLC + PID + switching). Initialise with
/// `flc_supervisor_init`.
#[repr(C)]
pub struct FlcSupervisor {
    magic: u64,
    storage: [u64; FLC_SUPERVISOR_WORDS],
}

storage!(FlcSupervisor, Supervisor, 0x464C_435F_5355_5001); // "FLC_SUP\x01"

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

impl From<SupervisorParams> for FlcSupervisorParams {
    fn from(p: SupervisorParams) -> Self {
        Self {
            flc: p.flc.into(),
            pid: p.pid.into(),
            association: p.association.into(),
            max_age_ticks: p.max_age_ticks,
            return_after: p.return_after,
            bumpless: p.bumpless,
        }
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
            association: p.association.into(),
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Functions
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
    // SAFETY: caller contract (that of `init`).
    unsafe { init(sup, params, error, |p| SupervisorParams::try_from(p).and_then(Supervisor::new), ptr::write) }
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
    // SAFETY: caller contract (that of `flc_supervisor_step_intruder`), without an intruder.
    unsafe { flc_supervisor_step_intruder(sup, has_v2v, v2v, has_distance, distance, own_speed, dt, false, f64::NAN, out) }
}

/// `flc_supervisor_step` with the distance to a neighbour entering the path (the intruder of
/// `flc_neighbours_update`, bumper-to-bumper like `distance`, in m; ignored unless
/// `has_intruder`): an intruder nearer than the V2V sender breaks the association and the FLC,
/// driving at once, follows it (Rust `Supervisor::step_frame`).
///
/// # Safety
/// `sup` is NULL or points to an `FlcSupervisor`; `out` is NULL or valid for writes.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn flc_supervisor_step_intruder(
    sup: *mut FlcSupervisor,
    has_v2v: bool,
    v2v: FlcV2vMessage,
    has_distance: bool,
    distance: f64,
    own_speed: f64,
    dt: f64,
    has_intruder: bool,
    intruder: f64,
    out: *mut FlcSupervisorOutput,
) -> FlcResult {
    tri!(check_ptr(out.cast_const()));
    // SAFETY: caller contract.
    let s = tri!(unsafe { get_mut(sup) });
    let frame = Frame {
        v2v: has_v2v.then_some(V2vMessage::speed_only(v2v.lead_speed, v2v.seq)),
        intruder: has_intruder.then_some(intruder),
        ..Frame::new(has_distance.then_some(distance), own_speed, dt)
    };
    let o = s.step_frame(&frame);
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
