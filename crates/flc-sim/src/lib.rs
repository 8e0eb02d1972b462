//! # flc-sim
//!
//! Closed-loop simulator for the flc pipeline: a rapier2d world with vehicles, road-side clutter,
//! a ray-cast LiDAR, a lossy V2V channel and scenario files.
pub mod error;

pub use error::{ConfigError, SimError};
pub mod v2v;
pub mod metrics;
