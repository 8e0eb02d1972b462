//! A scripted vehicle's manoeuvre: a list of [`Phase`]s run in order (scenario keys
//! `lead.phases`, `vehicles[i].phases`), each optionally started by a trigger ([`ScriptedPhase`]).

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};
use crate::trigger::Trigger;
use crate::units::KMH;

/// A [`Phase`] with an optional start trigger (OpenSCENARIO `StartTrigger`, [`crate::trigger`]).
/// In TOML it is the phase's table with a `start` key:
/// `{ kind = "brake", decel = 6.0, start = { kind = "relative_distance", ... } }`.
///
/// Without `start` the phase begins when the one before it ends. With `start` it begins when its
/// trigger fires, once every phase before it has begun: the running phase is cut short
/// (OpenSCENARIO's `priority = "override"`), and if the previous phase ended before the trigger
/// fired the vehicle holds its speed and lateral offset until then. The trigger is watched from
/// the moment the phase before it begins (from t = 0 for the first phase).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScriptedPhase {
    /// The manoeuvre.
    #[serde(flatten)]
    pub phase: Phase,
    /// When it starts (default: when the previous phase ends).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<Trigger>,
}

impl From<Phase> for ScriptedPhase {
    fn from(phase: Phase) -> Self {
        Self { phase, start: None }
    }
}

impl std::ops::Deref for ScriptedPhase {
    type Target = Phase;
    fn deref(&self) -> &Phase {
        &self.phase
    }
}

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
    /// Move laterally to `offset` (m, + left, from the ego lane's centre) or to the centre of
    /// `lane` (the track's lane index) over `duration` (s): a cut out (the lead leaves the lane),
    /// a cut in, a lane change. Speed is held. Give `offset` or `lane`.
    LaneChange {
        /// Final lateral offset from the ego lane's centre, m.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        offset: Option<f64>,
        /// Final lane (index, [`crate::Track::lane_offset`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        lane: Option<u32>,
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
    /// Brake uniformly to a standstill with the front bumper at `s` (m along the centreline):
    /// the deceleration `v² / (2 d)` to the remaining distance `d` is recomputed every step, up
    /// to `max_decel` (m/s², default 8). Ends at standstill.
    StopAt {
        /// Where the front bumper stops, m along the centreline.
        s: f64,
        /// Deceleration limit, m/s² (default 8).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_decel: Option<f64>,
    },
    /// Stand still (brake to a stop and hold) for `duration` (s), or to the end of the run.
    Stand {
        /// Duration, s (`None`: to the end of the run).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        duration: Option<f64>,
    },
}

/// Default deceleration limit of [`Phase::StopAt`], m/s².
pub const STOP_AT_DECEL: f64 = 8.0;

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
            Phase::LaneChange { offset, lane, duration } => {
                match (offset, lane) {
                    (Some(o), None) => check_range("offset", *o, -20.0, 20.0, "m")?,
                    (None, Some(_)) => {}
                    _ => return Err(ConfigError::new("offset", "give either `offset` (m) or `lane` (index)")),
                }
                check_range("duration", *duration, 0.1, 60.0, "s")
            }
            Phase::StopAt { s, max_decel } => {
                check_range("s", *s, 0.0, 1.0e6, "m")?;
                check_range("max_decel", max_decel.unwrap_or(STOP_AT_DECEL), 0.1, 15.0, "m/s²")
            }
            Phase::Stand { duration } => match duration {
                Some(d) => check_range("duration", *d, 0.0, 1.0e5, "s"),
                None => Ok(()),
            },
            Phase::Sine { amplitude, freq_hz, duration } => {
                check_range("amplitude", *amplitude, 0.0, 20.0, "m/s")?;
                check_range("freq_hz", *freq_hz, 0.001, 5.0, "Hz")?;
                check_range("duration", *duration, 0.0, 1.0e5, "s")
            }
        }
    }
}
