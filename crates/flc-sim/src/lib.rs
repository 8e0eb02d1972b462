//! # flc-sim
//!
//! Closed-loop simulator for the flc pipeline (the paper's CARLA experiment, Secs. III-IV). The
//! layers, lowest first (a module uses only its own layer and the ones below; `docs/architecture.md`,
//! checked by `tests/layers.rs`):
//!
//! 0. **base**: errors naming dotted keys (`error`), km/h at the interface only ([`KMH`]);
//! 1. **components**: tracks as data ([`Track`]), the rapier2d world (`world`), vehicle dynamics
//!    ([`Vehicle`]), the ray-cast LiDAR ([`Lidar`]) and its distance-only form ([`GapSensor`]),
//!    start / stop triggers with OpenSCENARIO semantics ([`trigger`]), the V2V channel
//!    ([`V2vChannel`]), the drivers and [`Phase`]s of the lead and the `[[vehicles]]` (`lead`);
//!    each owns its parameter struct;
//! 2. **data**: the per-step [`Series`] (columns declared once), [`Metrics`];
//! 3. **configuration**: the one key-patch mechanism ([`Patch`]), the controller registry
//!    ([`ControllerKind`]), followers and platoons ([`FollowerConfig`], [`PlatoonSpec`]),
//!    [`Scenario`], the paper's Sec. IV ([`paper`]), other built-in scenarios ([`presets`]),
//!    the string-stability measures ([`string_stability`]);
//! 4. **the loop**: [`Simulation`], talking to sinks only through [`Observer`]; the same follower
//!    pipeline driven by another simulator ([`ExternalFollower`], `flc.sumo`);
//! 5. **sinks**: MCAP recordings ([`record`]), JSON records, tables and CSV ([`report`]), the
//!    main job's verdict against the paper ([`paper_verdict`]), the SVG
//!    writer of the generated figures (`svg`);
//! 6. **the runner**: [`run`] / [`RunOptions`] (recording, stop flag, progress, batches);
//! 7. **experiments**: [`sweep`], the standard test suites ([`suite`]), the frequency response
//!    ([`frequency_response`]), the detector study ([`detection_study`]), the cut-in grid
//!    ([`cut_in_grid`]) and the `scenario` binary.
mod controllers;
pub mod cut_in_grid;
pub mod detection_study;
mod error;
mod external;
mod follower;
pub mod frequency_response;
mod gap_sensor;
pub mod gnss;
pub mod gym;
mod lead;
mod lidar;
mod metrics;
pub mod neighbour_traffic;
pub mod no_target;
mod noise;
pub mod openscenario;
pub mod paper;
pub mod paper_verdict;
mod patch;
mod platoon;
pub mod presets;
pub mod record;
pub mod report;
mod runner;
mod scenario;
mod series;
mod sim;
pub mod story;
pub mod stream;
pub mod string_stability;
pub mod suite;
mod svg;
pub mod sweep;
mod track;
pub mod trajectory;
pub mod trigger;
mod units;
mod v2v;
mod vehicle;
mod world;

pub use controllers::{BoxedLaw, ControllerSections};
pub use error::{ConfigError, SimError, check_range};
pub use external::{Actuation, ExternalFollower, ExternalInput, ExternalOutput};
pub use follower::{FollowerConfig, FollowerSpec, LostLeadSteering, Perception, ScenarioOrigin, Steering};
pub use gap_sensor::GapSensor;
pub use lead::{LeadCommand, LeadDriver, LeadSpec, Phase, STOP_AT_DECEL, ScriptedPhase, ScriptedVehicle};
pub use lidar::{Lidar, LidarFault, LidarParams, Scan};
pub use metrics::{CollisionInfo, ContactRecord, HARD_BRAKING, HitObject, Metrics, MetricsParams, ObjectKind, PairContact};
pub use paper::{Calibration, PAPER_SPEEDS_KMH};
pub use patch::Patch;
pub use platoon::{FollowerOverride, MAX_FOLLOWERS, PlatoonSpec, StringStabilitySpec, V2vSource};
pub use runner::{RunOptions, run};
pub use scenario::{ControllerKind, EGO, LEAD_DECEL_KEY, Scenario, StopSpec, SupervisorSpec, TrackSpec, Variant};
pub use series::{ACTIVE_FLC, ACTIVE_PID, MISSING_CODE, Series, StepRecord};
pub use sim::{
    DriveCommand, DriveOptions, FollowerRun, GroundTruth, Measurement, Observer, PlatoonResult, RunEnd, RunResult, Simulation, V2vSeen,
};
pub use track::{Projection, RoadsideObject, Track};
pub use units::KMH;
pub use v2v::{GilbertElliott, Outage, V2vChannel, V2vPacket, V2vParams, V2vStats};
pub use vehicle::{BodyKind, SpeedController, SpeedControllerParams, Vehicle, VehicleParams, VehicleState};
