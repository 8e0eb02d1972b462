//! The speed command shared by the longitudinal controllers and the status that comes with it.

/// What a longitudinal controller asks of the vehicle for one frame.
///
/// The paper "incorporates" the controller's acceleration into the current speed of the follower
/// and hands the resulting speed to the vehicle's own (low-level) speed controller (Sec. III-B).
/// Both the FLC and the PID produce this form so that the [`crate::supervisor`] can switch
/// between them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongitudinalCommand {
    /// Target speed for the low-level speed controller, m/s, always finite and `>= 0`.
    pub speed: f64,
    /// The control law's acceleration term that produced `speed` (after any multiplier), m/s².
    /// Always finite.
    pub accel: f64,
    /// Whether the inputs were usable; anything but [`Status::Ok`] means a safe command was issued.
    pub status: Status,
}

/// Outcome of one controller step. Anything other than [`Status::Ok`] means the controller
/// issued its *safe command* (brake, see the controller's parameters) instead of its law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Status {
    /// Inputs valid, the control law was applied.
    Ok = 0,
    /// No lead distance this frame (detector found nothing).
    NoLead = 1,
    /// The distance was NaN, infinite, negative or beyond the plausible range.
    InvalidDistance = 2,
    /// Own speed was NaN, infinite or outside the plausible range.
    InvalidSpeed = 3,
    /// The lead speed (V2V) was NaN, infinite or outside the plausible range.
    InvalidLeadSpeed = 4,
    /// The time step was NaN, infinite, zero or negative (PID only; the FLC takes no dt).
    InvalidDt = 5,
}

impl Status {
    /// `true` for [`Status::Ok`].
    pub const fn is_ok(self) -> bool {
        matches!(self, Status::Ok)
    }

    /// A short, stable, lower-case name (used by the simulator's JSON and the Python bindings).
    pub const fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::NoLead => "no_lead",
            Status::InvalidDistance => "invalid_distance",
            Status::InvalidSpeed => "invalid_speed",
            Status::InvalidLeadSpeed => "invalid_lead_speed",
            Status::InvalidDt => "invalid_dt",
        }
    }
}

impl core::fmt::Display for Status {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// `v` limited to `[lo, hi]`: the same result as `f64::clamp` for `lo <= hi` (NaN stays NaN), but
/// without `f64::clamp`'s panic on `lo > hi` or NaN bounds. The bounds come from parameters that the
/// compiler cannot see are validated, so `f64::clamp` would leave a panic path in every step
/// function; the release library is checked to contain none (`tests/c_api.rs`).
pub(crate) fn clamp(v: f64, lo: f64, hi: f64) -> f64 {
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

/// Checks a measured speed: finite and within `[-max_reverse, max]`.
pub(crate) fn valid_speed(v: f64, max: f64) -> bool {
    v.is_finite() && v >= -1.0 && v <= max
}

/// The braking command issued whenever inputs are unusable: slow down from the measured speed
/// (or from nothing, when the speed itself is unusable) by `step` m/s.
pub(crate) fn safe_brake(own_speed: f64, speed_ok: bool, step: f64, status: Status) -> LongitudinalCommand {
    let speed = if speed_ok { (own_speed - step).max(0.0) } else { 0.0 };
    LongitudinalCommand { speed, accel: -step, status }
}
