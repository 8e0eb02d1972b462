//! # flc-core
//!
//! The on-board algorithms of *"A LiDAR-Driven Fallback Longitudinal Controller for Safer
//! Following in Sudden Braking Scenarios"* (Sabry et al., ICVES 2025) as an embeddable,
//! `no_std`, allocation-free and panic-free library:
//!
//! | module | paper | what it does |
//! |---|---|---|
//! | [`flc`] | Sec. III-B, Eqs. (2)-(5) | the fallback longitudinal controller (LiDAR distance + own speed only) |
//! | [`flc_robust`] | beyond the paper (issue 7) | a rate-invariant, collision-free-to-130-km/h variant with the same inputs |
//! | [`flc_robust2`] | beyond the paper (issue 24; the simulator's `flc-robust`) | v1's laws with event rules that do not brake for missed or spurious frames |
//! | [`comfort`] | beyond the paper (issue 24) | v2's comfort layer: a closing speed timed by the law's own motion, IDM's braking strategy |
//! | [`flc_robust_odo`] | beyond the paper (issue 24's variant; `flc-robust-odo`) | v2 with the wheel odometry as the comfort layer's clock |
//! | [`pid`] | Sec. III-A.3 | the V2V-based PID gap controller (the baseline) |
//! | [`pure_pursuit`] | Sec. III-A.2, Eq. (1) | lateral control towards the lead |
//! | [`supervisor`] | Fig. 1 | the parallel longitudinal controller: PID while V2V is fresh, FLC otherwise |
//! | [`longitudinal`] | - | [`LongitudinalController`], the one interface of every longitudinal law (FLC, robust FLC, PID, supervisor, baselines) |
//! | [`detector`] | Sec. III-A.1 | the BEV-grid LiDAR lead-vehicle detector |
//!
//! Units are SI everywhere (m, m/s, m/s², s, rad). Every step function returns a defined command
//! together with a [`Status`]; invalid input never panics and never makes a controller accelerate.
//! Parameter structs implement `Default` with the paper's values; constructors validate them and
//! return a [`ParamError`] naming the offending field.
#![no_std]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::unreachable,
        clippy::todo,
        clippy::unimplemented
    )
)]

#[cfg(any(feature = "std", test))]
extern crate std;

pub mod association;
pub mod baselines;
#[cfg(feature = "capi")]
pub mod capi;
pub mod comfort;
pub mod command;
pub mod departure;
pub mod detector;
pub mod flc;
pub mod flc_robust;
pub mod flc_robust2;
pub mod flc_robust_odo;
pub mod longitudinal;
pub mod neighbours;
pub mod params;
pub mod pid;
pub mod pure_pursuit;
pub mod supervisor;

pub use association::{Association, AssociationParams, AssociationState, OwnFix, SenderState};
pub use baselines::{Baseline, BaselineKind, NoLeadPolicy};
pub use comfort::ComfortParams;
pub use command::{LongitudinalCommand, Status};
pub use departure::{DepartureParams, LeadDeparture};
pub use detector::{ClusterInfo, Detection, DetectorOutput, DetectorParams, DetectorStatus, LeadDetector, RejectReason, Reprojection};
pub use flc::{DistOverride, FallbackController, FirstFrame, FlcParams, FlcTerms};
pub use flc_robust::{FirstObject, RobustFallbackController, RobustFlcParams, RobustFlcTerms};
pub use flc_robust_odo::{OdometryFallbackController, OdometryFlcParams};
pub use flc_robust2::{RobustFallbackController2, RobustFlc2Params, RobustFlc2Terms};
pub use longitudinal::{ControlOutput, Frame, LongitudinalController, MAX_TERMS, Terms};
pub use nalgebra::Point2;
pub use neighbours::{NEIGHBOUR_CAPACITY, NeighbourParams, NeighbourTrack, NeighbourTracker};
pub use params::ParamError;
pub use pid::{GainSet, PidController, PidCore, PidGains, PidParams, PidTerms};
pub use pure_pursuit::{PurePursuit, PurePursuitParams, PursuitLaw, SteeringCommand};
pub use supervisor::{ActiveController, Supervisor, SupervisorOutput, SupervisorParams, SwitchReason, V2vMessage};
