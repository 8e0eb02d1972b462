//! One follower's configuration: its vehicle and initial state ([`FollowerSpec`], the
//! `[follower]` section) and everything its pipeline needs ([`FollowerConfig`]: the scenario's
//! single-follower sections, patched per follower by `[[platoon.overrides]]`).

use flc_core::{DetectorParams, NeighbourParams, PurePursuitParams};
use serde::{Deserialize, Serialize};

use crate::controllers::{BoxedLaw, ControllerKind, for_each_controller, with_controller_sections};
use crate::error::{ConfigError, check_range};
use crate::lidar::LidarParams;
use crate::no_target::NoTargetCruise;
use crate::patch::Patch;
use crate::v2v::V2vParams;
use crate::vehicle::{SpeedControllerParams, VehicleParams};

/// The follower vehicle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FollowerSpec {
    /// Initial speed, m/s.
    pub initial_speed: f64,
    /// The set speed, m/s, of the gap laws without a free-road branch of their own (the FLC
    /// family, the PID, the pipeline): they drive at it while nothing has ever been in their
    /// path ([`crate::no_target`], `docs/sim-model.md`). `None` (default): the initial speed (an
    /// ACC's set speed is the speed it is engaged at, ISO 15622). The baselines and the careful
    /// driver cruise at their own `desired_speed`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub set_speed: Option<f64>,
    /// Initial bumper-to-bumper gap to the lead, m. The paper: 7 m at standstill.
    pub initial_gap: f64,
    /// Initial position of the (last) follower's centre along the centreline, m (`None`,
    /// default: half its length + 1 m, just after the track's start).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_s: Option<f64>,
    /// Initial lateral offset of the (last) follower's centre from the centreline, m (+ left).
    /// Default 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub start_offset: f64,
    /// Initial heading of the (last) follower relative to the road, rad (+ left). Default 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub start_heading: f64,
    /// Vehicle model.
    pub vehicle: VehicleParams,
    /// Low-level speed controller (turns the pipeline's speed command into drive / brake).
    pub speed_controller: SpeedControllerParams,
    /// What the controllers get as `LF_dist`: the detector's distance (from the LiDAR origin to the
    /// lead's rear face) minus this offset, m. `None` (default) = the LiDAR's distance behind the
    /// front bumper, so the controllers see the bumper-to-bumper gap.
    pub distance_offset: Option<f64>,
    /// Steer along the lane centre instead of pursuing the detected lead (the paper's pipeline
    /// pursues the lead): a lead that leaves the lane is not followed (a cut-out reveals what is
    /// ahead to an ego that stays in its lane), and the detector's corridor follows the lane.
    /// The default depends on where the scenario comes from, decided in one place
    /// ([`FollowerSpec::default_lane_keeping`]): `false` for the paper experiment and TOML files,
    /// `true` for imported OpenSCENARIO files and the suites (ALKS is lane keeping). How the
    /// follower then steers: [`FollowerConfig::steering`].
    pub lane_keeping: bool,
    /// How the follower steers while its detector sees no lead (pursuit of the lead only; not
    /// with `lane_keeping` or ideal perception, which always steer along the lane):
    /// `"hold_lane"` (default) or `"straight"` (steering 0, the pipeline as first built). See
    /// [`LostLeadSteering`] and `docs/sim-model.md`.
    #[serde(skip_serializing_if = "is_hold_lane")]
    pub lost_lead_steering: LostLeadSteering,
    /// What the controllers see: the LiDAR detector (`"lidar"`, default), or `"ideal"`: the true
    /// bumper gap to the vehicle in front and, for the laws that use it, its true speed, with
    /// lane keeping instead of pursuit. **For validation only** (checking a baseline against its
    /// source model, `docs/baselines.md`); never used for the paper's or the envelope's results,
    /// and reported in the JSON (`perception`) and the table (`[ideal]`) when on.
    pub perception: Perception,
    /// Wheel odometry: the travelled distance the controllers get (`Frame::travelled`) is the
    /// true path length times this factor (a tyre radius off by 1 % is 1.01 or 0.99). Read only by
    /// the odometry variant of the robust FLC. Default 1.
    #[serde(skip_serializing_if = "is_one")]
    pub odometry_scale: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

fn is_hold_lane(v: &LostLeadSteering) -> bool {
    *v == LostLeadSteering::HoldLane
}

/// How a lead-pursuing follower steers while no lead is detected
/// ([`FollowerSpec::lost_lead_steering`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LostLeadSteering {
    /// Hold the lane: steer along the centre of the lane the follower is in when the lead is lost
    /// (the lane whose centre is nearest to its lateral offset, kept until a lead is detected
    /// again), and keep the detector's corridor on that lane. The simulator's stand-in for a
    /// camera lane keeper: it reads the track's geometry, no sensor model. Default.
    #[default]
    HoldLane,
    /// Steering 0 (straight ahead) and a straight corridor: the pipeline as first built, which
    /// leaves the road in a curve.
    Straight,
}

impl LostLeadSteering {
    /// `"hold_lane"` or `"straight"`.
    pub fn as_str(self) -> &'static str {
        match self {
            LostLeadSteering::HoldLane => "hold_lane",
            LostLeadSteering::Straight => "straight",
        }
    }
}

/// What the follower's controllers see ([`FollowerSpec::perception`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Perception {
    /// The ray-cast LiDAR and the lead detector (with their noise, latency and range).
    #[default]
    Lidar,
    /// Ground truth: the bumper gap and the speed of the vehicle in front (validation only).
    Ideal,
}

impl Perception {
    /// `"lidar"` or `"ideal"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Perception::Lidar => "lidar",
            Perception::Ideal => "ideal",
        }
    }
}

/// Where a scenario comes from: the one input of the steering default
/// ([`FollowerSpec::default_lane_keeping`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScenarioOrigin {
    /// Written for flc: the paper experiment, the TOML files, the presets.
    Native,
    /// Imported from OpenSCENARIO (the published files, the suites).
    OpenScenario,
}

/// How a follower steers ([`FollowerConfig::steering`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Steering {
    /// Along the centre of its lane (the simulator's stand-in for a camera lane keeper).
    LaneKeeping,
    /// Pure pursuit of the detected lead (the paper's pipeline); without a detection as
    /// [`LostLeadSteering`] says.
    Pursuit(LostLeadSteering),
}

impl FollowerSpec {
    /// The default of [`FollowerSpec::lane_keeping`] for a scenario of `origin`: the paper
    /// experiment and flc's own files pursue the lead (the paper's lateral control, Sec. III-C);
    /// an imported OpenSCENARIO file keeps its lane (its ego is a driver or an ALKS that keeps its
    /// lane and does not follow a lead that leaves it; the suites import their files).
    pub fn default_lane_keeping(origin: ScenarioOrigin) -> bool {
        match origin {
            ScenarioOrigin::Native => false,
            ScenarioOrigin::OpenScenario => true,
        }
    }
}

impl Default for FollowerSpec {
    fn default() -> Self {
        Self {
            initial_speed: 0.0,
            set_speed: None,
            initial_gap: 7.0,
            start_s: None,
            start_offset: 0.0,
            start_heading: 0.0,
            vehicle: VehicleParams::default(),
            speed_controller: SpeedControllerParams::default(),
            distance_offset: None,
            lane_keeping: Self::default_lane_keeping(ScenarioOrigin::Native),
            lost_lead_steering: LostLeadSteering::HoldLane,
            perception: Perception::Lidar,
            odometry_scale: 1.0,
        }
    }
}

for_each_controller!(with_controller_sections! {
/// Everything one follower's pipeline needs: the scenario's single-follower sections, patched per
/// follower by `[[platoon.overrides]]`; the controllers' sections come from the registry
/// ([`crate::ControllerKind`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FollowerConfig {
    /// Which controller drives.
    pub controller: ControllerKind,
    /// Vehicle, low-level controller, initial state.
    pub follower: FollowerSpec,
    /// Its LiDAR.
    pub lidar: LidarParams,
    /// Its incoming V2V link(s).
    pub v2v: V2vParams,
    /// Its lead detector.
    pub detector: DetectorParams,
    /// Its tracker of objects beside the path (the controllers with the swept-path corridor).
    #[serde(default)]
    pub neighbours: NeighbourParams,
    /// Its lateral controller.
    pub pure_pursuit: PurePursuitParams,
}
});

impl FollowerConfig {
    /// Checks every value; the error names the dotted key (`lidar.rate_hz`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let f = &self.follower;
        check_range("follower.initial_speed", f.initial_speed, 0.0, 70.0, "m/s")?;
        check_range("follower.initial_gap", f.initial_gap, 0.5, 500.0, "m")?;
        if let Some(v) = f.set_speed {
            check_range("follower.set_speed", v, 0.0, 70.0, "m/s")?;
        }
        check_range("follower.odometry_scale", f.odometry_scale, 0.5, 2.0, "(ratio)")?;
        if let Some(o) = f.distance_offset {
            check_range("follower.distance_offset", o, -10.0, 10.0, "m")?;
        }
        f.vehicle.validate().map_err(|e| e.within("follower.vehicle"))?;
        f.speed_controller.validate().map_err(|e| e.within("follower.speed_controller"))?;
        self.lidar.validate().map_err(|e| e.within("lidar"))?;
        self.v2v.validate().map_err(|e| e.within("v2v"))?;
        let core = |section: &str, r: Result<(), flc_core::ParamError>| {
            r.map_err(|e| ConfigError::new(format!("{section}.{}", e.field), e.problem))
        };
        core("detector", self.detector.validate())?;
        core("neighbours", self.neighbours.validate())?;
        core("pure_pursuit", self.pure_pursuit.validate())?;
        self.check_sections()
    }

    /// Builds this follower's longitudinal law (the registry's [`ControllerKind::build`]); a law
    /// without a free-road branch of its own cruises at [`FollowerConfig::set_speed`] until its
    /// first target ([`NoTargetCruise`]).
    pub fn longitudinal(&self) -> Result<BoxedLaw, ConfigError> {
        let law = self
            .controller
            .build(&self.sections())
            .map_err(|e| ConfigError::new(format!("{}.{}", self.controller.section(), e.field), e.problem))?;
        Ok(if self.controller.free_road() { law } else { Box::new(NoTargetCruise::new(law, self.set_speed())) })
    }

    /// How this follower steers: along its lane with `lane_keeping`, and always for a controller
    /// that perceives the scene as a human does or with ideal perception (both see the vehicle in
    /// front in road coordinates, not a LiDAR lead to pursue); otherwise pure pursuit of the
    /// detected lead.
    pub fn steering(&self) -> Steering {
        let f = &self.follower;
        if f.lane_keeping || f.perception == Perception::Ideal || self.controller.perceives_truth() {
            Steering::LaneKeeping
        } else {
            Steering::Pursuit(f.lost_lead_steering)
        }
    }

    /// Whether the LiDAR lead selection uses the ego's swept path plus margin as its corridor
    /// (issue 46): always for the controllers that ask for it
    /// ([`ControllerKind::swept_corridor`]), and for every controller of an ego that keeps its
    /// lane (imported files and the suites): "in my path" is then the lane the ego keeps, and a
    /// motorbike on the marking reaches into it. An ego steering after its lead (the paper
    /// experiment) keeps the paper's corridor around the pursuit arc.
    pub fn swept_corridor(&self) -> bool {
        self.controller.swept_corridor() || self.steering() == Steering::LaneKeeping
    }

    /// The set speed of the gap laws with no target, m/s: `follower.set_speed`, or the initial
    /// speed.
    pub fn set_speed(&self) -> f64 {
        self.follower.set_speed.unwrap_or(self.follower.initial_speed)
    }

    /// This configuration with `patch` (a table shaped like the scenario's sections) merged in:
    /// tables merge key by key, anything else is replaced. Errors name the key within the patch.
    pub fn patched(&self, patch: &toml::Table) -> Result<Self, ConfigError> {
        Patch::from_table(patch).apply(self)
    }
}
