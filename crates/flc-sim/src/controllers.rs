//! The controller registry: **one row per longitudinal controller**, and everything the simulator
//! knows about controllers is generated from it — [`ControllerKind`] (names for scenario files,
//! the CLI, JSON and Python), the parameter section of each law in [`crate::Scenario`] and
//! [`crate::FollowerConfig`] (`[flc]`, `[idm]`, ...), their validation, and the construction of
//! the law behind `flc_core::LongitudinalController`. A law's own formulas (its step, its desired
//! gap) live with the law in `flc-core`.
//!
//! A row: `Kind = "name", section: ParamsType` (with `validate() -> Result<(), ParamError>`), build |cfg| expr, cruise |params, v| stmt, v2v,
//! truth, free_road, starts Active;` — the scenario-file name, the section (field and TOML table) holding the law's
//! parameters, how to build the law from a follower's configuration, how the paper experiment sets
//! a cruise controller's set speed (`docs/baselines.md`), whether the law listens to V2V, whether it
//! perceives the ground truth instead of the LiDAR (the R157 reference driver), whether it has a
//! free-road branch of its own (otherwise it cruises at the set speed until its first target,
//! [`crate::no_target`]), and which law the `active` column shows before the first control frame.

use flc_core::baselines::{AccController, CarlaBehaviorController, IdmController, RssController};
use flc_core::{ActiveController, FallbackController, LongitudinalController, PidController, RobustFallbackController, Supervisor};

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// A boxed longitudinal law, as the loop holds it.
pub type BoxedLaw = Box<dyn LongitudinalController + Send>;

/// Calls `$callback! { { $($prefix)* } rows... }` with the registry's rows.
macro_rules! for_each_controller {
    ($callback:ident! { $($prefix:tt)* }) => {
        $callback! { { $($prefix)* }
            /// The paper's FLC only (LiDAR distance + own speed; Sec. III-B, Eqs. (2)-(5)).
            Flc = "flc", flc: flc_core::FlcParams, build |c| FallbackController::new(c.flc), cruise |_p, _v| {}, v2v false, truth false, free_road false, starts Flc;
            /// The V2V PID only (holds the last received lead speed when V2V is lost; Sec. III-A.3).
            Pid = "pid", pid: flc_core::PidParams, build |c| PidController::new(c.pid), cruise |_p, _v| {}, v2v true, truth false, free_road false, starts Pid;
            /// The parallel longitudinal controller of Fig. 1 (PID while V2V is fresh, FLC
            /// otherwise), from `[supervisor]`, `[flc]` and `[pid]`.
            Pipeline = "pipeline", supervisor: $crate::controllers::SupervisorSpec, build |c| Supervisor::new(c.supervisor_params()), cruise |_p, _v| {}, v2v true, truth false, free_road false, starts Flc;
            /// Baseline under identical sensing: the Intelligent Driver Model (`[idm]`, `docs/baselines.md`).
            Idm = "idm", idm: flc_core::baselines::IdmParams, build |c| IdmController::new(c.idm), cruise |p, v| { p.desired_speed = v }, v2v false, truth false, free_road true, starts Flc;
            /// Baseline under identical sensing: Milanés & Shladover / SUMO ACC (`[acc]`).
            Acc = "acc", acc: flc_core::baselines::AccParams, build |c| AccController::new(c.acc), cruise |p, v| { p.desired_speed = v }, v2v false, truth false, free_road true, starts Flc;
            /// Baseline under identical sensing: RSS safe-distance controller (`[rss]`).
            Rss = "rss", rss: flc_core::baselines::RssParams, build |c| RssController::new(c.rss), cruise |p, v| { p.desired_speed = v }, v2v false, truth false, free_road true, starts Flc;
            /// Baseline under identical sensing: CARLA BehaviorAgent follower (`[carla_behavior]`).
            CarlaBehavior = "carla-behavior", carla_behavior: flc_core::baselines::CarlaBehaviorParams, build |c| CarlaBehaviorController::new(c.carla_behavior), cruise |p, v| { p.cruise_speed = v; p.speed_limit = v }, v2v false, truth false, free_road true, starts Flc;
            /// Beyond the paper: the robust FLC v2 (LiDAR distance + own speed, rate invariant, no
            /// braking for missed or spurious frames, a comfort layer timed by its own motion;
            /// `[flc_robust]`, `docs/robust-flc.md`).
            FlcRobust = "flc-robust", flc_robust: flc_core::RobustFlc2Params, build |c| flc_core::RobustFallbackController2::new(c.flc_robust), cruise |_p, _v| {}, v2v false, truth false, free_road false, starts Flc;
            /// Beyond the paper: v2 with wheel odometry (issue 24's separately named variant: v2
            /// with the closing speed per metre driven as its comfort layer's clock; v2's
            /// parameters `[flc_robust]`, its own `[flc_robust_odo]`).
            FlcRobustOdo = "flc-robust-odo", flc_robust_odo: flc_core::OdometryFlcParams, build |c| flc_core::OdometryFallbackController::new(c.flc_robust, c.flc_robust_odo), cruise |_p, _v| {}, v2v false, truth false, free_road false, starts Flc;
            /// The robust FLC v1, kept for comparison (`[flc_robust_v1]`, `docs/robust-flc.md`).
            FlcRobustV1 = "flc-robust-v1", flc_robust_v1: flc_core::RobustFlcParams, build |c| RobustFallbackController::new(c.flc_robust_v1), cruise |_p, _v| {}, v2v false, truth false, free_road false, starts Flc;
            /// Baseline under identical sensing: Gipps (1981) safe-speed car following (`[gipps]`).
            Gipps = "gipps", gipps: flc_core::baselines::GippsParams, build |c| flc_core::baselines::GippsController::new(c.gipps), cruise |p, v| { p.desired_speed = v }, v2v false, truth false, free_road true, starts Flc;
            /// Reference: the UN R157 careful and competent human driver (`[careful_driver]`,
            /// `docs/careful-driver.md`); it sees the scene as a human does (ground truth of the
            /// vehicle in front within its sight distance), not through the LiDAR.
            CarefulDriver = "careful-driver", careful_driver: flc_core::baselines::CarefulDriverParams, build |c| flc_core::baselines::CarefulDriver::new(c.careful_driver), cruise |p, v| { p.normal.desired_speed = v }, v2v false, truth true, free_road true, starts Flc;
        }
    };
}
pub(crate) use for_each_controller;

/// Generates [`ControllerKind`] and [`ControllerSections`] from the rows.
macro_rules! define_registry {
    ({} $( $(#[doc = $doc:literal])* $kind:ident = $name:literal, $field:ident : $params:ty,
        build |$c:ident| $build:expr, cruise |$p:ident, $v:ident| $cruise:block, v2v $v2v:literal, truth $truth:literal, free_road $free:literal, starts $active:ident; )*) => {
        /// Which longitudinal controller drives a follower (the registry's rows, in order).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        pub enum ControllerKind {
            $( $(#[doc = $doc])* #[serde(rename = $name)] $kind, )*
        }

        impl ControllerKind {
            /// Every controller, in the registry's order.
            pub const ALL: &'static [ControllerKind] = &[$( ControllerKind::$kind, )*];

            /// The name used in scenario files, the CLI, the JSON output and Python.
            pub fn as_str(self) -> &'static str {
                match self { $( ControllerKind::$kind => $name, )* }
            }

            /// Whether this controller uses V2V (the PID alone or inside the pipeline); the others
            /// see the lead only through the LiDAR detector.
            pub fn uses_v2v(self) -> bool {
                match self { $( ControllerKind::$kind => $v2v, )* }
            }

            /// Whether this controller perceives the ground truth of the vehicle in front (its true
            /// gap and speed, with lane keeping) instead of the LiDAR detector, whatever
            /// `follower.perception` says: the reference driver of R157, a human looking at the
            /// road (`docs/careful-driver.md`).
            pub fn perceives_truth(self) -> bool {
                match self { $( ControllerKind::$kind => $truth, )* }
            }

            /// Whether this law has a free-road branch of its own (drives towards its set speed when
            /// nothing is ahead: the baselines' and the careful driver's `NoLeadPolicy::Cruise`);
            /// the others are gap laws the simulator drives at the set speed until their first
            /// target ([`crate::no_target`]).
            pub fn free_road(self) -> bool {
                match self { $( ControllerKind::$kind => $free, )* }
            }

            /// The law shown in the `active` column before the first control frame.
            pub fn initial_active(self) -> ActiveController {
                match self { $( ControllerKind::$kind => ActiveController::$active, )* }
            }

            /// The parameter section (scenario table) this controller is configured by.
            pub fn section(self) -> &'static str {
                match self { $( ControllerKind::$kind => stringify!($field), )* }
            }

            /// Builds the law from a follower's parameter sections.
            pub fn build(self, cfg: &ControllerSections) -> Result<BoxedLaw, flc_core::ParamError> {
                match self { $( ControllerKind::$kind => { let $c = cfg; Ok(Box::new($build?)) } )* }
            }

            /// Sets a cruise controller's set speed `v` (m/s) in `sections` (the paper experiment's
            /// baselines); no-op for the FLC family and the PID.
            pub fn set_cruise_speed(self, sections: &mut ControllerSections, v: f64) {
                match self { $( ControllerKind::$kind => { let $p = &mut sections.$field; let $v = v; $cruise } )* }
            }
        }

        /// The parameter sections of every controller (`[flc]`, `[pid]`, `[supervisor]`,
        /// `[idm]`, ...): flattened into [`crate::Scenario`] and [`crate::FollowerConfig`] by
        /// `with_controller_sections!`. `Default`: each law's documented defaults.
        #[derive(Debug, Clone, Default, PartialEq)]
        pub struct ControllerSections {
            $( $(#[doc = $doc])* pub $field: $params, )*
        }
    };
}
for_each_controller!(define_registry! {});

/// Declares a struct with the fields given plus one field per controller section (`pub flc:
/// FlcParams`, ...), with `sections()` / `set_sections()` / `check_sections()` accessors: the
/// section fields of [`crate::Scenario`] and [`crate::FollowerConfig`] come from the registry.
macro_rules! with_controller_sections {
    ({ $(#[$meta:meta])* pub struct $name:ident { $( $(#[$fmeta:meta])* pub $fname:ident : $fty:ty, )* } }
     $( $(#[doc = $doc:literal])* $kind:ident = $cname:literal, $field:ident : $params:ty,
        build |$c:ident| $build:expr, cruise |$p:ident, $v:ident| $cruise:block, v2v $v2v:literal, truth $truth:literal, free_road $free:literal, starts $active:ident; )*) => {
        $(#[$meta])*
        pub struct $name {
            $( $(#[$fmeta])* pub $fname: $fty, )*
            $( $(#[doc = $doc])* pub $field: $params, )*
        }

        impl $name {
            /// Builds the struct from its own fields (in declaration order) and the controllers'
            /// parameter sections.
            #[allow(clippy::too_many_arguments)]
            pub(crate) fn assemble($( $fname: $fty, )* sections: $crate::controllers::ControllerSections) -> Self {
                Self { $( $fname, )* $( $field: sections.$field, )* }
            }

            /// The controllers' parameter sections.
            pub fn sections(&self) -> $crate::controllers::ControllerSections {
                $crate::controllers::ControllerSections { $( $field: self.$field.clone(), )* }
            }

            /// Replaces the controllers' parameter sections.
            pub fn set_sections(&mut self, sections: $crate::controllers::ControllerSections) {
                $( self.$field = sections.$field; )*
            }

            /// Checks every controller section; the error names `section.field` (`idm.delta`).
            pub fn check_sections(&self) -> Result<(), $crate::error::ConfigError> {
                $( self.$field.validate().map_err(|e| $crate::error::ConfigError::new(format!("{}.{}", stringify!($field), e.field), e.problem))?; )*
                Ok(())
            }
        }
    };
}
pub(crate) use with_controller_sections;

/// Supervisor settings (the FLC and PID parameters are the scenario's `[flc]` and `[pid]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SupervisorSpec {
    /// V2V age, in control ticks, still counted as fresh.
    pub max_age_ticks: u32,
    /// Consecutive fresh messages before the PID drives again.
    pub return_after: u32,
    /// Bumpless return to the PID.
    pub bumpless: bool,
    /// Is the detected object the V2V sender? (`[supervisor.association]`, issue 25).
    pub association: flc_core::AssociationParams,
}

impl SupervisorSpec {
    /// Checks the values (the error names the field, as the `flc-core` parameter structs do).
    pub fn validate(&self) -> Result<(), flc_core::ParamError> {
        if !(1..=1_000_000).contains(&self.return_after) {
            return Err(flc_core::ParamError { field: "return_after", problem: "must be in [1, 1000000] messages" });
        }
        self.association.validate()
    }
}

impl Default for SupervisorSpec {
    fn default() -> Self {
        let d = flc_core::SupervisorParams::default();
        Self { max_age_ticks: d.max_age_ticks, return_after: d.return_after, bumpless: d.bumpless, association: d.association }
    }
}

impl ControllerSections {
    /// The supervisor's parameters assembled from `[supervisor]`, `[flc]` and `[pid]`.
    pub fn supervisor_params(&self) -> flc_core::SupervisorParams {
        flc_core::SupervisorParams {
            max_age_ticks: self.supervisor.max_age_ticks,
            return_after: self.supervisor.return_after,
            bumpless: self.supervisor.bumpless,
            flc: self.flc,
            pid: self.pid,
            association: self.supervisor.association,
        }
    }
}

impl Default for ControllerKind {
    /// The paper's FLC.
    fn default() -> Self {
        ControllerKind::Flc
    }
}

impl ControllerKind {
    /// Whether this controller's LiDAR lead selection always uses the swept-path corridor (issue
    /// 46, `docs/detector.md`: `detector.swept_half_width`; the simulator fills in the ego's half
    /// width plus `sim/path.rs`'s `CORRIDOR_MARGIN` when the scenario leaves it at 0): the robust
    /// FLC and its odometry variant. The paper's `flc`, the pipeline and the baselines use it when
    /// the ego keeps its lane ([`crate::FollowerConfig::swept_corridor`]) and keep the paper's
    /// corridor when they steer after the lead (the paper experiment).
    pub fn swept_corridor(self) -> bool {
        matches!(self, ControllerKind::FlcRobust | ControllerKind::FlcRobustOdo)
    }

    /// Whether this controller runs the neighbour tracker after each detector scan
    /// (`flc_core::NeighbourTracker`: a car entering the ego's path seen before the detector
    /// finds it in the path): the robust FLC and its odometry variant, which follow the intruder
    /// like a lead in the path, and the pipeline, whose association rule hands the ego to its FLC
    /// when an intruder is nearer than the V2V sender (the FLC then follows it).
    pub fn tracks_neighbours(self) -> bool {
        self.swept_corridor() || self == ControllerKind::Pipeline
    }

    /// Parses the name used in scenario files and on the CLI.
    pub fn parse(s: &str) -> Result<Self, ConfigError> {
        Self::ALL.iter().copied().find(|k| k.as_str() == s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|k| k.as_str()).collect();
            ConfigError::new("controller", format!("must be one of {}, got `{s}`", names.join(", ")))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_are_unique() {
        let mut names: Vec<&str> = ControllerKind::ALL.iter().map(|k| k.as_str()).collect();
        for k in ControllerKind::ALL {
            assert_eq!(ControllerKind::parse(k.as_str()).ok(), Some(*k));
            let json = serde_json::to_string(k).unwrap_or_default();
            assert_eq!(json, format!("\"{}\"", k.as_str()));
        }
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), ControllerKind::ALL.len());
        assert!(ControllerKind::parse("frobnicate").is_err());
    }

    #[test]
    fn every_default_law_builds() {
        let cfg = ControllerSections::default();
        for k in ControllerKind::ALL {
            assert!(k.build(&cfg).is_ok(), "{}", k.as_str());
        }
    }
}
