//! The lead's manoeuvre: a list of [`Phase`]s run in order (scenario key `lead.phases`).

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};
use crate::units::KMH;

/// One phase of the lead's manoeuvre. Phases run in order; after the last one the lead holds its
/// speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Phase {
    /// Accelerate at `accel` (m/s², > 0) until `speed` (m/s) or `speed_kmh` (km/h) is reached.
    Accelerate {
        /// Acceleration, m/s².
        accel: f64,
        /// Target speed, m/s (give this or `speed_kmh`).
        #[serde(default)]
        speed: Option<f64>,
        /// Target speed, km/h (give this or `speed`).
        #[serde(default)]
        speed_kmh: Option<f64>,
    },
    /// Hold the current speed until the lead's travelled distance reaches `until_x` (m), the
    /// simulation time reaches `until_t` (s), or for `duration` (s); exactly one of them.
    Hold {
        /// Distance travelled by the lead since the start, m.
        #[serde(default)]
        until_x: Option<f64>,
        /// Simulation time, s.
        #[serde(default)]
        until_t: Option<f64>,
        /// Duration of the phase, s.
        #[serde(default)]
        duration: Option<f64>,
    },
    /// Brake at `decel` (m/s², > 0) to `speed` / `speed_kmh` (default: to a stop). Its onset is
    /// the "brake onset" event (V2V `outage_on_brake`, metrics).
    Brake {
        /// Deceleration, m/s² (positive number).
        decel: f64,
        /// Final speed, m/s (default 0).
        #[serde(default)]
        speed: Option<f64>,
        /// Final speed, km/h.
        #[serde(default)]
        speed_kmh: Option<f64>,
    },
    /// Move laterally to `offset` (m, + left, relative to the lane centre) over `duration` (s):
    /// a cut out (lead leaves the lane) or a cut back in. Speed is held.
    LaneChange {
        /// Final lateral offset from the lane centre, m.
        offset: f64,
        /// Duration of the manoeuvre, s.
        duration: f64,
    },
    /// Drive a sinusoidal speed `v0 + amplitude sin(2 pi freq_hz (t - t_start))` around the speed
    /// held before (`v0`) for `duration` (s), then hold `v0` again (string-stability frequency
    /// response).
    Sine {
        /// Speed amplitude, m/s.
        amplitude: f64,
        /// Frequency, Hz.
        freq_hz: f64,
        /// Duration of the phase, s.
        duration: f64,
    },
}

impl Phase {
    fn target_speed(key: &str, speed: Option<f64>, speed_kmh: Option<f64>, default: Option<f64>) -> Result<f64, ConfigError> {
        let v = match (speed, speed_kmh) {
            (Some(v), None) => v,
            (None, Some(k)) => k * KMH,
            (None, None) => default.ok_or_else(|| ConfigError::new(key, "give `speed` (m/s) or `speed_kmh` (km/h)"))?,
            (Some(_), Some(_)) => return Err(ConfigError::new(key, "give either `speed` (m/s) or `speed_kmh` (km/h), not both")),
        };
        check_range(if speed_kmh.is_some() { "speed_kmh" } else { "speed" }, v, 0.0, 70.0, "m/s (0-252 km/h)")?;
        Ok(v)
    }

    /// The phase's target speed in m/s (accelerate / brake), validated.
    pub fn speed_target(&self) -> Result<Option<f64>, ConfigError> {
        match self {
            Phase::Accelerate { speed, speed_kmh, .. } => Self::target_speed("speed", *speed, *speed_kmh, None).map(Some),
            Phase::Brake { speed, speed_kmh, .. } => Self::target_speed("speed", *speed, *speed_kmh, Some(0.0)).map(Some),
            _ => Ok(None),
        }
    }

    pub(crate) fn validate(&self) -> Result<(), ConfigError> {
        self.speed_target()?;
        match self {
            Phase::Accelerate { accel, .. } => check_range("accel", *accel, 0.01, 15.0, "m/s²"),
            Phase::Brake { decel, .. } => check_range("decel", *decel, 0.01, 15.0, "m/s² (positive number)"),
            Phase::Hold { until_x, until_t, duration } => {
                let given = [until_x, until_t, duration].iter().filter(|o| o.is_some()).count();
                if given != 1 {
                    return Err(ConfigError::new("until_x", "give exactly one of `until_x` (m), `until_t` (s), `duration` (s)"));
                }
                if let Some(x) = until_x {
                    check_range("until_x", *x, 0.0, 1.0e6, "m")?;
                }
                if let Some(t) = until_t {
                    check_range("until_t", *t, 0.0, 1.0e5, "s")?;
                }
                if let Some(d) = duration {
                    check_range("duration", *d, 0.0, 1.0e5, "s")?;
                }
                Ok(())
            }
            Phase::LaneChange { offset, duration } => {
                check_range("offset", *offset, -10.0, 10.0, "m")?;
                check_range("duration", *duration, 0.1, 60.0, "s")
            }
            Phase::Sine { amplitude, freq_hz, duration } => {
                check_range("amplitude", *amplitude, 0.0, 20.0, "m/s")?;
                check_range("freq_hz", *freq_hz, 0.001, 5.0, "Hz")?;
                check_range("duration", *duration, 0.0, 1.0e5, "s")
            }
        }
    }
}
