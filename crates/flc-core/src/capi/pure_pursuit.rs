//! C interface of pure pursuit ([`crate::pure_pursuit`]): parameters, steering command, storage
//! `FlcPursuit`, functions.

use core::ptr;

use nalgebra::Point2;

use super::storage::{check_ptr, get_ref, init, param_error, storage, tri, write_out};
use super::{FlcParamError, FlcResult, FlcStatus};
use crate::params::ParamError;
use crate::pure_pursuit::{PurePursuit, PurePursuitParams, PursuitLaw, SteeringCommand};

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

/// Values of `FlcPursuitParams::law` (Rust `PursuitLaw`).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlcPursuitLaw {
    /// The paper's Eq. (1) (default).
    Paper = 0,
    /// Standard pure pursuit.
    Standard = 1,
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

// ---------------------------------------------------------------------------------------------
// Storage
// ---------------------------------------------------------------------------------------------

/// Words (8 bytes each) of `FlcPursuit::storage`.
pub const FLC_PURSUIT_WORDS: usize = 5;

/// Caller-owned storage of one pure-pursuit lateral controller. Initialise with
/// `flc_pursuit_init`.
#[repr(C)]
pub struct FlcPursuit {
    magic: u64,
    storage: [u64; FLC_PURSUIT_WORDS],
}

storage!(FlcPursuit, PurePursuit, 0x464C_435F_5050_5501); // "FLC_PPU\x01"

// ---------------------------------------------------------------------------------------------
// Parameter conversions
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Functions
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
    // SAFETY: caller contract (that of `init`).
    unsafe { init(pp, params, error, |p| PurePursuitParams::try_from(p).and_then(PurePursuit::new), ptr::write) }
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
