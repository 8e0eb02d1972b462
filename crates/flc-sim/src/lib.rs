//! # flc-sim
//!
//! Closed-loop simulator for the flc pipeline (the paper's CARLA experiment, Secs. III-IV): a
//! rapier2d world with vehicles and road-side clutter ([`world`]), a ray-cast LiDAR ([`lidar`]), a
//! lossy V2V channel ([`v2v`]), vehicle dynamics ([`vehicle`]), tracks as data ([`track`]),
//! scenario files ([`scenario`]), the closed loop ([`sim`]) with platoons ([`platoon`]), metrics
//! ([`metrics`]), string-stability measures ([`string_stability`]), reports ([`report`]) and MCAP
//! recordings for Foxglove ([`record`]).
pub mod error;
pub mod lead;
pub mod lidar;
pub mod metrics;
pub mod paper;
pub mod platoon;
pub mod presets;
pub mod record;
pub mod report;
pub mod scenario;
pub mod series;
pub mod sim;
pub mod string_stability;
pub mod sweep;
pub mod track;
pub mod units;
pub mod v2v;
pub mod vehicle;
pub mod world;

pub use error::{ConfigError, SimError};
pub use scenario::Scenario;
pub use sim::{FollowerRun, PlatoonResult, RunResult, Simulation, run, run_batch, run_with};
