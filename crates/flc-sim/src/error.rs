//! Typed errors of the simulator.

use thiserror::Error;

/// A scenario or parameter value was rejected. `key` is the dotted TOML path
/// (e.g. `lidar.rate_hz`), `problem` says what is allowed.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("`{key}`: {problem}")]
pub struct ConfigError {
    /// Dotted path of the offending key, e.g. `lidar.rate_hz`.
    pub key: String,
    /// What is wrong and what is allowed, e.g. `must be in [1, 100] Hz, got 0`.
    pub problem: String,
}

impl ConfigError {
    /// Builds an error for `key`.
    pub fn new(key: impl Into<String>, problem: impl Into<String>) -> Self {
        Self { key: key.into(), problem: problem.into() }
    }

    /// Prefixes the key with a parent table name (`lidar` + `rate_hz` -> `lidar.rate_hz`).
    pub fn within(mut self, parent: &str) -> Self {
        self.key = if self.key.is_empty() { parent.to_string() } else { format!("{parent}.{}", self.key) };
        self
    }
}

/// Checks `lo <= v <= hi` (and finiteness) for key `key`; the error names the allowed range.
pub fn check_range(key: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<(), ConfigError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::new(key, format!("must be in [{lo}, {hi}] {unit}, got {v}")))
    }
}

/// Anything that can go wrong in the simulator.
#[derive(Debug, Error)]
pub enum SimError {
    /// A scenario value is out of range or unknown.
    #[error("invalid scenario value {0}")]
    Config(#[from] ConfigError),
    /// A scenario file could not be read or parsed.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong, naming the key where known.
        message: String,
    },
    /// A core parameter struct was rejected.
    #[error("invalid controller parameter: {0}")]
    Param(#[from] flc_core::ParamError),
    /// An input file was rejected; the message names the file, line or key (an OpenSCENARIO
    /// import error).
    #[error("{0}")]
    Input(String),
    /// A sweep output holds rows that may not be of the sweep being run (their inputs' digest
    /// differs or is missing): resuming would serve them, so it is refused; the caller says how
    /// to start over (`--restart`, `restart=True`).
    #[error("{path}: {reason}")]
    StaleOutput {
        /// The output.
        path: String,
        /// Why its rows cannot be resumed.
        reason: String,
    },
    /// An I/O error while writing results.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}
