//! Scenario files: everything one closed-loop run needs, as TOML (schema in `docs/scenarios.md`).
//!
//! A scenario names the track, both vehicles, the lead's manoeuvre as a list of [`crate::lead::Phase`]s, the
//! controller, every sensor / V2V / actuator impairment, the rates, the seed and the stop
//! conditions. Unknown keys and out-of-range values are errors that name the dotted key and the
//! allowed range ([`ConfigError`]).

use std::path::Path;

use flc_core::{DetectorParams, NeighbourParams, PurePursuitParams};
use serde::{Deserialize, Serialize};

pub use crate::controllers::{ControllerKind, SupervisorSpec};
use crate::controllers::{for_each_controller, with_controller_sections};
use crate::error::{ConfigError, SimError, check_range};
use crate::follower::{FollowerConfig, FollowerSpec};
use crate::lead::{LeadSpec, Phase, ScriptedPhase, ScriptedVehicle};
use crate::lidar::LidarParams;
use crate::patch::Patch;
use crate::platoon::PlatoonSpec;
use crate::track::Track;
use crate::trigger::{ScriptedEntity, Trigger, validate_scripts};
use crate::v2v::V2vParams;

pub use crate::units::KMH;

/// Family key of [`Scenario::patched`]: the deceleration of every brake phase of the lead.
pub const LEAD_DECEL_KEY: &str = "lead_decel";

/// Which track to drive on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TrackSpec {
    /// The paper's straight run ([`Track::straight`]).
    Straight {
        /// Length of the straight, m.
        length: f64,
    },
    /// A route with curves like the paper's Fig. 3a ([`Track::curvy`]).
    Curvy,
    /// A track given in the file (polyline + width + road-side objects).
    Custom(Track),
}

impl Default for TrackSpec {
    fn default() -> Self {
        TrackSpec::Straight { length: 2000.0 }
    }
}

impl TrackSpec {
    /// Builds the track.
    pub fn build(&self) -> Result<Track, ConfigError> {
        match self {
            TrackSpec::Straight { length } => {
                check_range("length", *length, 50.0, 100_000.0, "m")?;
                Ok(Track::straight(*length))
            }
            TrackSpec::Curvy => Ok(Track::curvy()),
            TrackSpec::Custom(t) => {
                t.validate()?;
                Ok(t.clone())
            }
        }
    }
}

/// When a run ends (besides `duration`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StopSpec {
    /// End the run at the first collision between the vehicles.
    pub on_collision: bool,
    /// End the run once the lead has finished its phases and both vehicles have been at
    /// standstill (< 0.05 m/s) for this long, s.
    pub standstill_time: f64,
    /// Whether the standstill rule above ends the run (default true; an OpenSCENARIO file
    /// imported with `--ego-mode scripted` turns it off: its `StopTrigger` decides, as in
    /// esmini).
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub on_standstill: bool,
    /// End the run when this trigger fires (OpenSCENARIO's storyboard `StopTrigger`,
    /// [`crate::trigger`]), evaluated on ground truth after every physics step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trigger: Option<Trigger>,
}

impl Default for StopSpec {
    fn default() -> Self {
        Self { on_collision: true, standstill_time: 2.0, on_standstill: true, trigger: None }
    }
}

/// Longest `duration`, s.
pub const MAX_DURATION: f64 = 36_000.0;

fn yes() -> bool {
    true
}

fn is_default_neighbours(p: &NeighbourParams) -> bool {
    *p == NeighbourParams::default()
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's skip_serializing_if passes a reference
fn is_true(b: &bool) -> bool {
    *b
}

/// Most `[[vehicles]]` (as many as an imported file may have entities,
/// `openscenario::entities::MAX_ENTITIES`).
pub const MAX_VEHICLES: usize = 256;

/// Most phases of one scripted vehicle (the lead or one of `[[vehicles]]`).
pub const MAX_PHASES: usize = 1000;

/// Most `[[variants]]`.
pub const MAX_VARIANTS: usize = 1000;

/// Names a trigger may use for the followers: `ego` (= follower 1) and `follower <k>`.
pub const EGO: &str = "ego";

for_each_controller!(with_controller_sections! {
/// A complete scenario. `Default` is the paper's experiment at 50 km/h with the FLC, realistic
/// vehicle ([`crate::paper`]). The controllers' parameter sections (`[flc]`, `[pid]`,
/// `[supervisor]`, `[idm]`, ...) come from the registry ([`ControllerKind`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Name, used in output file names and the JSON's `scenario` field.
    pub name: String,
    /// Seed of every random process (LiDAR noise, dropouts, V2V loss, jitter).
    pub seed: u64,
    /// Which controller drives.
    pub controller: ControllerKind,
    /// Maximum simulated time, s.
    pub duration: f64,
    /// Physics (and low-level control) step, s. The pipeline runs on each delivered LiDAR scan.
    pub physics_dt: f64,
    /// The track.
    pub track: TrackSpec,
    /// The lead: the first scripted vehicle (entity `lead`).
    pub lead: LeadSpec,
    /// Other scripted vehicles (`[[vehicles]]`): traffic, cut-in cars, standing cars.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub vehicles: Vec<ScriptedVehicle>,
    /// The follower.
    pub follower: FollowerSpec,
    /// The follower's LiDAR.
    pub lidar: LidarParams,
    /// The V2V link lead -> follower.
    pub v2v: V2vParams,
    /// The lead detector.
    pub detector: DetectorParams,
    /// Objects beside the path (issue 47, `flc_core::NeighbourTracker`): used by the controllers
    /// that track them ([`ControllerKind::tracks_neighbours`]: `flc-robust`, `flc-robust-odo`,
    /// `pipeline`). Written out only when it differs from the defaults.
    #[serde(skip_serializing_if = "is_default_neighbours")]
    pub neighbours: NeighbourParams,
    /// The lateral controller (Eq. (1)).
    pub pure_pursuit: PurePursuitParams,
    /// Stop conditions.
    pub stop: StopSpec,
    /// The max speed (km/h) of the paper experiment this scenario was built from, if any (reported
    /// as `speed_kmh` in the JSON; informational).
    pub speed_kmh: Option<f64>,
    /// The storyboard (`[story]`, [`crate::story`]): acts, events and actions with OpenSCENARIO
    /// semantics driving the lead, the `[[vehicles]]` and optionally the ego (what `.xosc`
    /// files import to). With a story, the lead and the vehicles have no `phases`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub story: Option<crate::story::Story>,
    /// A platoon: N followers behind the lead (`crate::platoon`); `None`: one follower.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub platoon: Option<PlatoonSpec>,
    /// Named variants of this scenario (`[[variants]]`: `name` plus keys patched into the
    /// scenario); `scenario --config` runs each of them instead of the scenario itself.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub variants: Vec<Variant>,
    /// The variant this scenario was expanded from (set by [`Scenario::expand_variants`];
    /// reported as `variant` in the JSON).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variant: Option<String>,
}
});

/// One entry of `[[variants]]`: a name and the keys it changes (any scenario keys, tables merged
/// key by key).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Variant {
    /// Name of the variant (reported as `variant`, appended to output file names).
    pub name: String,
    /// The keys patched into the scenario.
    #[serde(flatten)]
    pub patch: toml::Table,
}

impl Scenario {
    /// Checks every value; the error names the dotted key and the allowed range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.check_sizes()?;
        check_range("duration", self.duration, 0.01, MAX_DURATION, "s")?;
        check_range("physics_dt", self.physics_dt, 0.0005, 0.05, "s")?;
        self.track.build().map_err(|e| e.within("track"))?;
        // A lead moved by a story may start backwards (an imported file's negative speed, as
        // esmini plays it); the lead's own speed profile starts forwards.
        let slowest = if self.story.is_some() { -70.0 } else { 0.0 };
        check_range("lead.initial_speed", self.lead.initial_speed, slowest, 70.0, "m/s")?;
        if self.lead.absent {
            let bad = if !self.lead.phases.is_empty() {
                Some("an absent lead has no phases")
            } else if self.v2v.enabled {
                Some("an absent lead sends no V2V: set `v2v.enabled = false`")
            } else if self.platoon.is_some() {
                Some("a platoon follows a lead: it cannot be absent")
            } else {
                None
            };
            if let Some(m) = bad {
                return Err(ConfigError::new("lead.absent", m));
            }
        }
        self.lead.vehicle.validate().map_err(|e| e.within("lead.vehicle"))?;
        for (i, p) in self.lead.phases.iter().enumerate() {
            p.validate().map_err(|e| e.within(&format!("lead.phases[{i}]")))?;
        }
        self.validate_traffic()?;
        self.validate_pedestrians()?;
        self.base_follower_config().validate()?;
        check_range("stop.standstill_time", self.stop.standstill_time, 0.0, 3600.0, "s")?;
        if let Some(s) = self.speed_kmh {
            check_speed_kmh("speed_kmh", s)?;
        }
        if let Some(p) = &self.platoon {
            p.validate().map_err(|e| e.within("platoon"))?;
            self.follower_configs()?;
        }
        for i in 0..self.variants.len() {
            let key = format!("variants[{i}]");
            self.expand_variant(i)?.validate().map_err(|e| e.within(&key))?;
        }
        Ok(())
    }

    /// Every count the file controls, checked before anything is built from it (each check
    /// constant time or linear in what was parsed): followers, overrides, V2V outages, vehicles, phases,
    /// trigger groups and conditions, centreline points, road-side objects, storyboard
    /// elements, variants.
    fn check_sizes(&self) -> Result<(), ConfigError> {
        if let Some(p) = &self.platoon {
            p.validate().map_err(|e| e.within("platoon"))?;
        }
        if let TrackSpec::Custom(t) = &self.track {
            if t.centerline.len() > crate::track::MAX_CENTERLINE_POINTS || t.objects.len() > crate::track::MAX_OBJECTS {
                t.validate().map_err(|e| e.within("track"))?;
            }
        }
        if self.v2v.outages.len() > crate::v2v::MAX_OUTAGES {
            self.v2v.validate().map_err(|e| e.within("v2v"))?;
        }
        if self.vehicles.len() > MAX_VEHICLES {
            return Err(ConfigError::new("vehicles", format!("at most {MAX_VEHICLES} scripted vehicles, got {}", self.vehicles.len())));
        }
        let phases = |key: &str, phases: &[ScriptedPhase]| -> Result<(), ConfigError> {
            if phases.len() > MAX_PHASES {
                return Err(ConfigError::new(key, format!("at most {MAX_PHASES} phases, got {}", phases.len())));
            }
            for (k, p) in phases.iter().enumerate() {
                if let Some(t) = &p.start {
                    t.check_size(&format!("{key}[{k}].start"))?;
                }
            }
            Ok(())
        };
        phases("lead.phases", &self.lead.phases)?;
        for (i, v) in self.vehicles.iter().enumerate() {
            phases(&format!("vehicles[{i}].phases"), &v.phases)?;
        }
        if let Some(t) = &self.stop.trigger {
            t.check_size("stop.trigger")?;
        }
        if let Some(story) = &self.story {
            let n = story.size();
            if n > crate::story::MAX_ELEMENTS {
                return Err(ConfigError::new(
                    "story.acts",
                    format!("{n} storyboard elements, more than the limit of {}", crate::story::MAX_ELEMENTS),
                ));
            }
            for (key, t) in story.triggers() {
                t.check_size(&key)?;
            }
        }
        if self.variants.len() > MAX_VARIANTS {
            return Err(ConfigError::new("variants", format!("at most {MAX_VARIANTS} variants, got {}", self.variants.len())));
        }
        Ok(())
    }

    /// `[[vehicles]]`, lanes and every trigger: names unique and not reserved, lanes on the
    /// track, triggers naming existing entities and phases, no cycle of phases waiting on each
    /// other; errors name the dotted key.
    /// A pedestrian (`vehicle.body = "pedestrian"`) is a scripted entity that the story moves
    /// kinematically: never the ego or a follower, never without `[story]`.
    fn validate_pedestrians(&self) -> Result<(), ConfigError> {
        use crate::vehicle::BodyKind;
        if self.follower.vehicle.body == BodyKind::Pedestrian {
            return Err(ConfigError::new("follower.vehicle.body", "the ego is a vehicle (a pedestrian cannot be driven by a controller)"));
        }
        let scripted = std::iter::once(("lead.vehicle.body".to_string(), &self.lead.vehicle))
            .chain(self.vehicles.iter().enumerate().map(|(i, v)| (format!("vehicles[{i}].vehicle.body"), &v.vehicle)));
        for (key, v) in scripted {
            if v.body == BodyKind::Pedestrian && self.story.is_none() {
                return Err(ConfigError::new(&key, "a pedestrian moves by a story's actions only: it needs a [story]"));
            }
        }
        Ok(())
    }

    fn validate_traffic(&self) -> Result<(), ConfigError> {
        let track = self.track.build().map_err(|e| e.within("track"))?;
        let lane_change = |key: &str, phases: &[ScriptedPhase]| -> Result<(), ConfigError> {
            for (k, p) in phases.iter().enumerate() {
                if let Phase::LaneChange { lane: Some(l), .. } = &p.phase {
                    track.check_lane(&format!("{key}[{k}].lane"), *l)?;
                }
            }
            Ok(())
        };
        lane_change("lead.phases", &self.lead.phases)?;
        for (i, v) in self.vehicles.iter().enumerate() {
            let key = format!("vehicles[{i}]");
            v.validate_moved_by(self.story.is_some()).map_err(|e| e.within(&key))?;
            let reserved = v.name == "lead" || v.name == EGO || v.name.starts_with("follower");
            if v.name.trim().is_empty() || reserved {
                return Err(ConfigError::new(
                    format!("{key}.name"),
                    format!("`{}` is not a name a scripted vehicle can have (empty, `lead`, `ego` and `follower...` are taken)", v.name),
                ));
            }
            if let Some(l) = v.lane {
                track.check_lane(&format!("{key}.lane"), l)?;
            }
            lane_change(&format!("{key}.phases"), &v.phases)?;
        }
        // Every entity a trigger may name, as the trigger checks see it: the scripted vehicles
        // with their phases, then the followers (no phases).
        let keys: Vec<String> = (0..self.vehicles.len()).map(|i| format!("vehicles[{i}].phases")).collect();
        let followers: Vec<String> = (1..=self.n_followers()).map(|k| format!("follower {k}")).collect();
        fn starts(phases: &[ScriptedPhase]) -> Vec<Option<&Trigger>> {
            phases.iter().map(|p| p.start.as_ref()).collect()
        }
        let mut entities = vec![ScriptedEntity { name: "lead", key: "lead.phases", starts: starts(&self.lead.phases) }];
        entities.extend(self.vehicles.iter().zip(&keys).map(|(v, key)| ScriptedEntity { name: &v.name, key, starts: starts(&v.phases) }));
        entities.extend(std::iter::once(EGO).chain(followers.iter().map(String::as_str)).map(|name| ScriptedEntity {
            name,
            key: "follower",
            starts: Vec::new(),
        }));
        validate_scripts(&entities)?;
        let table: Vec<(&str, usize)> = entities.iter().map(|e| (e.name, e.starts.len())).collect();
        if let Some(t) = &self.stop.trigger {
            t.validate("stop.trigger", &table)?;
        }
        if let Some(ls) = self.lead.s {
            check_range("lead.s", ls, -1.0e6, 1.0e6, "m")?;
            if self.n_followers() > 1 {
                return Err(ConfigError::new("lead.s", "a platoon places the lead by the followers' gaps: leave `lead.s` out"));
            }
        }
        check_range("lead.offset", self.lead.offset, -50.0, 50.0, "m")?;
        check_range("lead.heading", self.lead.heading, -3.2, 3.2, "rad")?;
        if let Some(fs) = self.follower.start_s {
            check_range("follower.start_s", fs, -1.0e6, 1.0e6, "m")?;
        }
        check_range("follower.start_offset", self.follower.start_offset, -50.0, 50.0, "m")?;
        check_range("follower.start_heading", self.follower.start_heading, -3.2, 3.2, "rad")?;
        if let Some(story) = &self.story {
            self.validate_story(story, &table)?;
        }
        Ok(())
    }

    /// `[story]`: no phases beside it, sizes, names, actors, actions, and every trigger (element
    /// names included).
    fn validate_story(&self, story: &crate::story::Story, table: &[(&str, usize)]) -> Result<(), ConfigError> {
        if !self.lead.phases.is_empty() {
            return Err(ConfigError::new("lead.phases", "with [story] the story moves the lead: give it no phases"));
        }
        if let Some(i) = self.vehicles.iter().position(|v| !v.phases.is_empty()) {
            return Err(ConfigError::new(
                format!("vehicles[{i}].phases"),
                "with [story] the story moves the vehicles: give them no phases",
            ));
        }
        let names: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
        story.validate(&names)?;
        let elements = story.element_names();
        let mut sorted = elements.clone();
        sorted.sort_unstable();
        let known = |e: &str| sorted.binary_search(&e).is_ok();
        let mut variables: Vec<&str> = story.variables.iter().map(|v| v.name.as_str()).collect();
        variables.sort_unstable();
        let mut all = story.triggers();
        if let Some(t) = &self.stop.trigger {
            all.push(("stop.trigger".to_string(), t));
        }
        for (key, trig) in all {
            trig.validate(&key, table)?;
            for (g, grp) in trig.groups().enumerate() {
                for (c, cond) in grp.iter().enumerate() {
                    if let crate::trigger::ConditionKind::ElementState { element, .. } = &cond.kind {
                        if !known(element) {
                            return Err(ConfigError::new(
                                format!("{}.element", trig.condition_key(&key, g, c)),
                                format!("no storyboard element `{element}`"),
                            ));
                        }
                    }
                    if let crate::trigger::ConditionKind::Variable { variable, .. } = &cond.kind {
                        if variables.binary_search(&variable.as_str()).is_err() {
                            return Err(ConfigError::new(
                                format!("{}.variable", trig.condition_key(&key, g, c)),
                                format!("no variable `{variable}` in story.variables"),
                            ));
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The settings of a single follower (or of every follower of a platoon before
    /// `[[platoon.overrides]]`): the scenario's `controller`, `[follower]`, `[lidar]`, `[v2v]`,
    /// `[detector]`, `[flc]`, `[pid]`, `[pure_pursuit]`, `[supervisor]` and the baselines' and robust
    /// FLC's sections.
    pub fn base_follower_config(&self) -> FollowerConfig {
        FollowerConfig::assemble(
            self.controller,
            self.follower.clone(),
            self.lidar.clone(),
            self.v2v.clone(),
            self.detector,
            self.neighbours,
            self.pure_pursuit,
            self.sections(),
        )
    }

    /// Number of followers (1 without `[platoon]`).
    pub fn n_followers(&self) -> usize {
        self.platoon.as_ref().map_or(1, |p| p.followers as usize)
    }

    /// The settings of every follower (index 0 = follower 1, right behind the lead), with
    /// `[[platoon.overrides]]` applied in order; each is validated. Errors name the override
    /// (`platoon.overrides[1].v2v.loss_prob`).
    pub fn follower_configs(&self) -> Result<Vec<FollowerConfig>, ConfigError> {
        let base = self.base_follower_config();
        let mut out = vec![base; self.n_followers()];
        if let Some(p) = &self.platoon {
            for (i, o) in p.overrides.iter().enumerate() {
                let key = format!("platoon.overrides[{i}]");
                for &k in &o.followers {
                    let slot = out.get_mut((k as usize).wrapping_sub(1)).ok_or_else(|| {
                        ConfigError::new(format!("{key}.followers"), format!("no follower {k} (platoon.followers = {})", p.followers))
                    })?;
                    let patched = slot.patched(&o.patch).map_err(|e| e.within(&key))?;
                    patched.validate().map_err(|e| e.within(&key))?;
                    *slot = patched;
                }
            }
        }
        Ok(out)
    }

    /// Variant `i` of `[[variants]]`: this scenario (without its variants) with the variant's
    /// keys patched in, `variant` set to its name.
    pub fn expand_variant(&self, i: usize) -> Result<Scenario, ConfigError> {
        let key = format!("variants[{i}]");
        let v = self.variants.get(i).ok_or_else(|| ConfigError::new(key.clone(), "no such variant"))?;
        if v.patch.contains_key("variants") || v.patch.contains_key("variant") {
            return Err(ConfigError::new(format!("{key}.variants"), "a variant cannot define variants"));
        }
        if v.name.is_empty() {
            return Err(ConfigError::new(format!("{key}.name"), "must not be empty"));
        }
        let base = Scenario { variants: Vec::new(), ..self.clone() };
        let mut out = base.patched(&Patch::from_table(&v.patch)).map_err(|e| e.within(&key))?;
        out.variant = Some(v.name.clone());
        Ok(out)
    }

    /// This scenario with `patch` applied ([`crate::Patch`]), plus the family key `lead_decel`
    /// (m/s², positive): the deceleration of **every** brake phase of the lead (sweeps, Python
    /// envelopes). Errors name the dotted key; the result is not validated.
    pub fn patched(&self, patch: &Patch) -> Result<Scenario, ConfigError> {
        // TOML integers are i64 and the seed is a u64: it goes around the patch (a patch that
        // sets `seed` sets it).
        let base = Scenario { seed: 0, ..self.clone() };
        let sets_seed = patch.keys().any(|k| k == "seed");
        let mut resolved = Patch::new();
        for (key, value) in patch.entries() {
            if key == LEAD_DECEL_KEY {
                let brakes: Vec<usize> = self
                    .lead
                    .phases
                    .iter()
                    .enumerate()
                    .filter(|(_, p)| matches!(p.phase, crate::lead::Phase::Brake { .. }))
                    .map(|(i, _)| i)
                    .collect();
                if brakes.is_empty() {
                    return Err(ConfigError::new(key, "the scenario's lead has no brake phase"));
                }
                for i in brakes {
                    resolved.set(format!("lead.phases[{i}].decel"), value.clone());
                }
            } else {
                resolved.set(key, value.clone());
            }
        }
        let mut out = resolved.apply(&base).map_err(with_family_key)?;
        if !sets_seed {
            out.seed = self.seed;
        }
        Ok(out)
    }

    /// The unknown top-level key an error of [`Scenario::patched`] / [`Scenario::with_overrides`]
    /// reports (a key that names nothing in a scenario, `speed`), or `None` for any other error
    /// (an unknown key inside a section, a bad value). Python raises `TypeError` for such a
    /// keyword, as for any unexpected keyword argument.
    pub fn unknown_top_level_key(e: &ConfigError) -> Option<&str> {
        let name = e.problem.strip_prefix("unknown field `")?.split('`').next()?;
        (e.key.is_empty() || e.key == name).then_some(name)
    }

    /// The scenario's sections (top-level tables: `follower`, `lidar`, `flc`, `platoon`, ...),
    /// derived from the struct itself.
    pub fn section_names() -> Vec<String> {
        table_paths().iter().filter(|(flat, dotted)| flat == dotted).map(|(flat, _)| flat.clone()).collect()
    }

    /// The dotted key of a keyword override: `lidar_rate_hz` -> `lidar.rate_hz` (the longest
    /// table name followed by `_`, nested tables included: `flc_robust_law_time_gap` ->
    /// `flc_robust.law.time_gap`), a dotted key and the family key `lead_decel` unchanged,
    /// anything else as is (`seed`).
    pub fn resolve_key(name: &str) -> String {
        if name.contains('.') || name == LEAD_DECEL_KEY {
            return name.to_string();
        }
        let mut tables: Vec<&(String, String)> = table_paths().iter().collect();
        tables.sort_by_key(|(flat, _)| std::cmp::Reverse(flat.len()));
        for (flat, dotted) in tables {
            if let Some(rest) = name.strip_prefix(flat.as_str()).and_then(|r| r.strip_prefix('_')) {
                if !rest.is_empty() {
                    return format!("{dotted}.{rest}");
                }
            }
        }
        name.to_string()
    }

    /// This scenario with keyword overrides (`lidar_rate_hz = 10`, `"follower.vehicle.mass"`,
    /// `lead_decel`) applied in order through [`Scenario::patched`]; validated. Errors name the key.
    pub fn with_overrides(&self, overrides: &[(String, serde_json::Value)]) -> Result<Scenario, ConfigError> {
        let mut patch = Patch::new();
        let mut seed = None;
        for (name, value) in overrides {
            let key = Self::resolve_key(name);
            if key == "seed" {
                // Any u64 (the sweep's run seeds use the whole range; TOML's integers do not).
                seed =
                    Some(value.as_u64().ok_or_else(|| ConfigError::new("seed", format!("must be an integer in [0, 2^64), got {value}")))?);
            } else {
                patch.set_json(key, value)?;
            }
        }
        let mut s = self.patched(&patch)?;
        if let Some(seed) = seed {
            s.seed = seed;
        }
        s.validate()?;
        Ok(s)
    }

    /// One `KEY=VALUE` of `scenario --set`, as [`Scenario::with_overrides`] takes it: the key as
    /// Python's keyword overrides name it (`lidar_rate_hz`, `lidar.rate_hz`, `lead_decel`,
    /// `seed`), the value read as a TOML value (`10`, `6.5`, `true`, `"x"`, `[1, 2]`,
    /// `{ loss_prob = 0.5 }`), else taken as a bare string (`controller=pid`). Errors are keyed
    /// `--set`.
    pub fn override_pair(arg: &str) -> Result<(String, serde_json::Value), ConfigError> {
        let Some((key, text)) = arg.split_once('=') else {
            return Err(ConfigError::new("--set", format!("expected KEY=VALUE, got `{arg}`")));
        };
        let key = key.trim();
        if key.is_empty() {
            return Err(ConfigError::new("--set", format!("empty key in `{arg}`")));
        }
        let text = text.trim();
        if text.is_empty() {
            return Err(ConfigError::new("--set", format!("`{key}`: empty value")));
        }
        let value = match toml::from_str::<toml::Table>(&format!("v = {text}")) {
            Ok(mut t) => t.remove("v").unwrap_or_else(|| toml::Value::String(text.to_string())),
            Err(_) => toml::Value::String(text.to_string()),
        };
        // TOML has `inf` and `nan`; no scenario key takes them (JSON would turn them into null).
        fn finite(v: &toml::Value) -> bool {
            match v {
                toml::Value::Float(f) => f.is_finite(),
                toml::Value::Array(a) => a.iter().all(finite),
                toml::Value::Table(t) => t.values().all(finite),
                _ => true,
            }
        }
        if !finite(&value) {
            return Err(ConfigError::new(key, format!("must be a finite number, got `{text}` (`--set`)")));
        }
        let json = serde_json::to_value(&value).map_err(|e| ConfigError::new("--set", format!("`{key}`: {e}")))?;
        Ok((key.to_string(), json))
    }

    /// The scenarios to run for this one: each variant if it has `[[variants]]`, else itself.
    pub fn expand_variants(&self) -> Result<Vec<Scenario>, ConfigError> {
        if self.variants.is_empty() {
            return Ok(vec![self.clone()]);
        }
        (0..self.variants.len()).map(|i| self.expand_variant(i)).collect()
    }

    /// Lets `kind` drive the follower, with what the controller implies: V2V on for the laws that
    /// listen to it (the PID, the pipeline), off for the others.
    pub fn set_controller(&mut self, kind: ControllerKind) {
        self.controller = kind;
        self.v2v.enabled = kind.uses_v2v();
    }

    /// File name of a run's outputs: `<scenario>[-<variant>]-<controller>` with anything but
    /// `[A-Za-z0-9._-]` replaced by `_`; longer than 160 bytes, its first 143 bytes, `-` and a
    /// 16-digit hash of the whole.
    pub fn run_file_stem(&self) -> String {
        /// Longest stem, bytes (room for the longest suffix, `-trajectory.csv`, ... in 255).
        const MAX_STEM: usize = 160;
        let raw = match &self.variant {
            Some(v) => format!("{}-{v}-{}", self.name, self.controller.as_str()),
            None => format!("{}-{}", self.name, self.controller.as_str()),
        };
        let stem: String = raw.chars().map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' }).collect();
        if stem.len() <= MAX_STEM {
            return stem;
        }
        // A file name has at most 255 bytes: a long stem (a distribution's many parameters) is
        // cut and told apart from other cut stems by the FNV-1a hash of the whole.
        let hash = stem.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
        format!("{}-{hash:016x}", &stem[..MAX_STEM - 17])
    }

    /// Parses TOML text. Errors name the dotted key (`lidar.rate_hz`) and the problem; `origin`
    /// (a file name) prefixes the message.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, SimError> {
        let file_err = |message: String| SimError::File { path: origin.to_string(), message };
        let de = toml::Deserializer::parse(text).map_err(|e| file_err(one_line(&e.to_string())))?;
        let scenario: Scenario = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = one_line(&e.into_inner().to_string());
            let path = toml::from_str(text).ok().and_then(|root| crate::patch::entry_path(&root, &path, &inner)).unwrap_or(path);
            file_err(if path.is_empty() || path == "." { inner } else { format!("`{path}`: {inner}") })
        })?;
        scenario.validate().map_err(|e| file_err(e.to_string()))?;
        Ok(scenario)
    }

    /// Reads and validates a scenario file.
    pub fn from_file(path: &Path) -> Result<Self, SimError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SimError::File { path: origin.clone(), message: e.to_string() })?;
        let mut s = Self::from_toml_str(&text, &origin)?;
        if s.name.is_empty() {
            s.name = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        }
        Ok(s)
    }

    /// The scenario as TOML (round-trips through [`Scenario::from_toml_str`]).
    pub fn to_toml(&self) -> Result<String, SimError> {
        toml::to_string(self).map_err(|e| SimError::File { path: self.name.clone(), message: e.to_string() })
    }
}

/// toml's messages span several lines (with a source excerpt); keep the first meaningful line.
pub(crate) fn one_line(msg: &str) -> String {
    let lines: Vec<&str> = msg.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    // toml 1 puts "TOML parse error at line L, column C" first and the problem last.
    match (lines.first(), lines.last()) {
        (Some(first), Some(last)) if first.starts_with("TOML parse error") && first != last => {
            format!(
                "{} ({})",
                last.trim_start_matches(['|', '^', ' ']),
                first.trim_start_matches("TOML parse error at ").trim_end_matches(':')
            )
        }
        (Some(first), _) => (*first).to_string(),
        _ => msg.to_string(),
    }
}

/// Every table of the full scenario (a platoon included) as (`a_b_c`, `a.b.c`), nested ones
/// included, top-level ones in the struct's order; computed once.
fn table_paths() -> &'static [(String, String)] {
    static PATHS: std::sync::OnceLock<Vec<(String, String)>> = std::sync::OnceLock::new();
    PATHS.get_or_init(|| {
        fn walk(t: &toml::map::Map<String, toml::Value>, flat: &str, dotted: &str, out: &mut Vec<(String, String)>) {
            for (k, v) in t {
                if let toml::Value::Table(inner) = v {
                    let (f, d) = if flat.is_empty() { (k.clone(), k.clone()) } else { (format!("{flat}_{k}"), format!("{dotted}.{k}")) };
                    out.push((f.clone(), d.clone()));
                    walk(inner, &f, &d, out);
                }
            }
        }
        let full = Scenario { platoon: Some(PlatoonSpec::default()), ..Scenario::default() };
        let mut out = Vec::new();
        if let Ok(toml::Value::Table(t)) = toml::Value::try_from(&full) {
            walk(&t, "", "", &mut out);
        }
        out
    })
}

/// An unknown top-level key of a patch: serde's list of the scenario's keys, plus the family key
/// [`LEAD_DECEL_KEY`] that a patch also takes (a sweep axis, a Python keyword), so that the list
/// holds every valid key.
fn with_family_key(mut e: ConfigError) -> ConfigError {
    if let Some(name) = Scenario::unknown_top_level_key(&e) {
        let name = name.to_string();
        e.problem = format!("{}, or `{LEAD_DECEL_KEY}` (every brake phase's deceleration, m/s²)", e.problem);
        e.key = name;
    }
    e
}

/// The speeds (km/h) the paper experiment takes, inclusive: the one limit of every entry point
/// (`scenario --speeds`, a scenario's `speed_kmh`, `flc.Scenario.paper`, `python -m flc figures
/// --speeds`; checked by [`check_speed_kmh`]). The lead must move (1 km/h) and stay below the
/// lead's speed limit of 70 m/s (252 km/h).
pub const SPEED_RANGE_KMH: (f64, f64) = (1.0, 250.0);

/// Checks a paper-experiment speed against [`SPEED_RANGE_KMH`]; the error names `key`.
pub fn check_speed_kmh(key: &str, speed_kmh: f64) -> Result<(), crate::ConfigError> {
    crate::check_range(key, speed_kmh, SPEED_RANGE_KMH.0, SPEED_RANGE_KMH.1, "km/h")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_top_level_key_lists_every_valid_key_with_the_family_key() {
        // A sweep axis is a dotted key as written (no keyword resolution).
        let mut patch = Patch::new();
        patch.set("lead_decl", toml::Value::Float(4.0));
        let e = Scenario::default().patched(&patch).expect_err("typo");
        assert_eq!(Scenario::unknown_top_level_key(&e), Some("lead_decl"));
        let text = e.to_string();
        assert!(text.starts_with("`lead_decl`: unknown field `lead_decl`"), "{text}");
        for key in ["`lead_decel`", "`speed_kmh`", "`controller`", "`lidar`", "`seed`"] {
            assert!(text.contains(key), "{key} in {text}");
        }
        let e = Scenario::default().with_overrides(&[("speed".into(), serde_json::json!(70.0))]).expect_err("not a key");
        assert_eq!(Scenario::unknown_top_level_key(&e), Some("speed"));
        // Inside a section the list is the section's keys, and it is not a top-level key.
        let e = Scenario::default().with_overrides(&[("lidar.rate_hzz".into(), serde_json::json!(4.0))]).expect_err("typo");
        assert_eq!(Scenario::unknown_top_level_key(&e), None);
        assert!(!e.to_string().contains("lead_decel"), "{e}");
    }

    #[test]
    fn sections_keys_and_overrides() {
        let names = Scenario::section_names();
        for s in
            ["follower", "lead", "lidar", "v2v", "detector", "pure_pursuit", "stop", "track", "platoon", "flc", "pid", "supervisor", "idm"]
        {
            assert!(names.iter().any(|n| n == s), "{s} in {names:?}");
        }
        assert!(!names.iter().any(|n| n == "name" || n == "seed"));
        assert_eq!(Scenario::resolve_key("lidar_rate_hz"), "lidar.rate_hz");
        assert_eq!(Scenario::resolve_key("flc_robust_v1_brake_gain"), "flc_robust_v1.brake_gain");
        assert_eq!(Scenario::resolve_key("flc_robust_law_brake_gain"), "flc_robust.law.brake_gain");
        assert_eq!(Scenario::resolve_key("flc_robust_firm_gain"), "flc_robust.firm_gain");
        assert_eq!(Scenario::resolve_key("follower_vehicle_mass"), "follower.vehicle.mass");
        assert_eq!(Scenario::resolve_key("follower.vehicle.mass"), "follower.vehicle.mass");
        assert_eq!(Scenario::resolve_key("seed"), "seed");
        let s = Scenario::default()
            .with_overrides(&[("lidar_rate_hz".into(), serde_json::json!(10.0)), ("lead_decel".into(), serde_json::json!(4.0))])
            .expect("overrides");
        assert_eq!(s.lidar.rate_hz, 10.0);
        assert!(matches!(s.lead.phases[2].phase, crate::lead::Phase::Brake { decel, .. } if decel == 4.0));
        let e = Scenario::default().with_overrides(&[("lidar_rate_hz".into(), serde_json::json!(0.0))]).expect_err("range");
        assert!(e.to_string().contains("lidar.rate_hz"), "{e}");
        // Seeds anywhere in the u64 range survive patches and overrides.
        let big = Scenario { seed: u64::MAX - 7, ..Scenario::default() };
        assert_eq!(big.with_overrides(&[("lidar_rate_hz".into(), serde_json::json!(10.0))]).expect("patch").seed, u64::MAX - 7);
        assert_eq!(Scenario::default().with_overrides(&[("seed".into(), serde_json::json!(u64::MAX))]).expect("seed").seed, u64::MAX);
        assert!(
            Scenario::default().with_overrides(&[("seed".into(), serde_json::json!(-1))]).expect_err("seed").to_string().contains("seed")
        );
        let e = Scenario::default().with_overrides(&[("lidar_frobnicate".into(), serde_json::json!(1))]).expect_err("unknown");
        assert!(e.to_string().contains("frobnicate"), "{e}");
    }
}
