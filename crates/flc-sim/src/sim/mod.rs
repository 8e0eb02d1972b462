//! The closed loop: world, vehicles, LiDAR, V2V and the `flc-core` pipeline, stepped together.
//!
//! Per physics step (`physics_dt`, default 10 ms):
//! 1. the lead's driver turns its phases into an acceleration command, pure pursuit on the
//!    track's centreline (plus the phase's lateral offset) steers it;
//! 2. the V2V channel may deliver a message (kept in the follower's mailbox);
//! 3. the LiDAR may deliver a scan (its own rate, jitter, latency, drops); on each delivered scan
//!    the follower's pipeline runs once: detector -> pure pursuit + longitudinal controller
//!    (FLC, PID or the supervisor); the resulting speed command is held until the next scan;
//! 4. the follower's low-level speed controller turns the held speed command into an
//!    acceleration command; both vehicle models step; rapier moves the bodies and reports contacts.
//!
//! Collisions come from rapier's narrow phase: a follower's first contact with anything (the
//! vehicle in front, any other vehicle, a parked car, a guard rail, a post) is its collision; the
//! lead's contacts with road-side objects are listed in [`RunResult::other_contacts`].

mod contacts;
mod drive;
mod follower;
mod geometry;
mod links;
mod observer;
mod path;
mod story;
mod traffic;

pub use drive::{DriveCommand, DriveOptions, GroundTruth, Measurement, V2vSeen};
pub(crate) use links::sub_seed;
pub use observer::Observer;
pub(crate) use path::{CORRIDOR_MARGIN, lane_keeping_half_width};

use flc_core::PurePursuit;

use self::follower::Follower;
use self::geometry::{bumper_gap, centreline_pursuit, centreline_steer};
use self::links::relay_tick;
use self::path::{Object, human_front, nearest_in_path};
use self::story::{StepInput, StoryRun, pose_of};
use self::traffic::{Traffic, Triggers, Truth, truth};
use crate::error::{ConfigError, SimError};
use crate::lead::LeadDriver;
pub use crate::metrics::{CollisionInfo, FollowerRun};
use crate::metrics::{ContactRecord, HitObject, Metrics, PairContact};
use crate::platoon::V2vSource;
use crate::scenario::Scenario;
use crate::series::Series;
use crate::string_stability::{Signals, StringStability, reference_gap};
use crate::track::Track;
use crate::vehicle::{Vehicle, VehicleState};
use crate::world::{Body, World};

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The scenario that ran.
    pub scenario: Scenario,
    /// The metrics (of follower 1 in a platoon).
    pub metrics: Metrics,
    /// The per-step time series (of follower 1 and the lead in a platoon).
    pub series: Series,
    /// With `[platoon]`: every follower's series and metrics and the string-stability measures.
    pub platoon: Option<PlatoonResult>,
    /// Follower 1's first contact with anything (what [`RunResult::metrics`]' `collision` says).
    pub collision: Option<CollisionInfo>,
    /// The first contact of every pair of bodies that involves no follower (the lead touching a
    /// parked car, a guard rail, a post), in time order.
    pub other_contacts: Vec<ContactRecord>,
    /// `[story]` runs: every contact of every pair of bodies (followers included), one entry per
    /// episode (the step a pair starts touching), in time order; empty without a story.
    pub contacts: Vec<PairContact>,
    /// Why the run ended.
    pub end: RunEnd,
}

/// Why a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunEnd {
    /// It reached the scenario's `duration` (for an imported file: the `--max-duration` guard).
    #[default]
    Duration,
    /// A follower collided and `stop.on_collision` is set.
    Collision,
    /// The stop trigger (OpenSCENARIO's `StopTrigger`) fired.
    StopTrigger,
    /// The scripts were done and every vehicle stood still for `stop.standstill_time`.
    Standstill,
    /// It was stopped from outside ([`crate::RunOptions::stop`]) before its end.
    Interrupted,
}

impl RunEnd {
    /// The JSON word (`duration`, `collision`, `stop_trigger`, `standstill`, `interrupted`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Duration => "duration",
            Self::Collision => "collision",
            Self::StopTrigger => "stop_trigger",
            Self::Standstill => "standstill",
            Self::Interrupted => "interrupted",
        }
    }
}

/// Most entries of [`RunResult::contacts`] (a pair touching and parting on every step would
/// otherwise grow it with the run's length).
pub const MAX_CONTACTS: usize = 1000;

/// What a platoon run produced besides follower 1's [`RunResult::series`] / [`RunResult::metrics`].
#[derive(Debug, Clone)]
pub struct PlatoonResult {
    /// Followers 1..N (index 0 = follower 1).
    pub followers: Vec<FollowerRun>,
    /// The signals the string-stability measures are computed from (gap errors against each
    /// law's formation gap, speed errors, accelerations).
    pub signals: Signals,
    /// The string-stability measures of this run (time domain; `frequency_response` is filled
    /// by [`crate::frequency_response`]).
    pub string_stability: StringStability,
}

/// A running closed-loop simulation (step it, then [`Simulation::finish`]). A scenario without
/// `[platoon]` is the one-follower case of the same loop.
pub struct Simulation<O: Observer = ()> {
    /// Everything but the sink.
    state: State,
    /// The sink that sees follower 1's scans and steps ([`Observer`]).
    observer: O,
}

/// The world, the vehicles, their pipelines and the bookkeeping of a run.
struct State {
    scenario: Scenario,
    track: Track,
    world: World,
    lead_body: Body,
    lead: Vehicle,
    lead_driver: LeadDriver,
    lead_steer: PurePursuit,
    lead_x0: f64,
    followers: Vec<Follower>,
    /// The `[[vehicles]]` besides the lead.
    traffic: Vec<Traffic>,
    /// The vehicles in front of each follower ([`Simulation::fill_fronts`]), reused.
    fronts: Vec<Fronts>,
    /// For each follower whose controller sees the scene as a human does
    /// ([`crate::ControllerKind::perceives_truth`]): the vehicle in front as it sees it
    /// ([`path::human_front`]), reused.
    human_fronts: Vec<Option<(VehicleState, f64, f64)>>,
    /// Start and stop triggers.
    triggers: Triggers,
    /// `[story]`: its runtime and the motions of the entities it drives.
    story: Option<StoryRun>,
    /// How long each vehicle has stood still (0 = the lead, then the traffic, then the
    /// followers), s; negative while it moves.
    still: Vec<f64>,
    source: V2vSource,
    lead_weight: f64,
    relay: bool,
    /// Speeds of the vehicles at the start of the step (0 = lead), reused.
    speeds: Vec<f64>,
    /// This step's V2V senders' true kinematics (0: the lead, k: follower k).
    senders: Vec<flc_core::SenderState>,
    /// Bodies and states of the vehicles after a step with contacts (0 = lead), reused.
    bodies: Vec<(Body, VehicleState)>,
    /// First contacts of the pairs without a follower.
    other_contacts: Vec<ContactRecord>,
    /// `[story]`: every contact episode so far, and the pairs touching after the last step.
    contacts: Vec<PairContact>,
    touching: Vec<(HitObject, HitObject)>,
    /// Why the run ended (set when it does).
    end: RunEnd,
    t: f64,
    k: u64,
    standstill_since: Option<f64>,
    /// The lead's acceleration command and steering of the step being run (set while sensing).
    lead_cmd: (f64, f64),
    /// Some follower is driven from outside ([`Simulation::drive`]).
    any_driven: bool,
    /// The step's sensing ran and it waits for commands ([`Simulation::advance`]).
    paused: bool,
    /// The run is over.
    ended: bool,
    /// `[story]`: the storyboard was already evaluated at the current time (at t = 0, when the
    /// simulation is built), so the next step only advances the motions.
    story_evaluated: bool,
}

impl Simulation {
    /// Builds the world and every component from a validated scenario, with no sink.
    pub fn new(s: &Scenario) -> Result<Self, SimError> {
        let track = s.track.build()?;
        let configs = s.follower_configs()?;
        let platoon = s.platoon.clone().unwrap_or_default();
        let mut world = World::new(&track);
        // Every vehicle starts on the centreline, the last follower's rear bumper 1 m after the
        // track's start, each front bumper its initial gap behind the rear bumper in front
        // (one follower: its front bumper `initial_gap` behind the lead's rear bumper).
        let ll = &s.lead.vehicle;
        let n = configs.len();
        let mut s_pos = vec![0.0; n + 1];
        if let Some(last) = configs.last() {
            s_pos[n] = last.follower.start_s.unwrap_or(last.follower.vehicle.length / 2.0 + 1.0);
        }
        for k in (1..=n).rev() {
            let c = &configs[k - 1];
            let gap = if platoon.equilibrium_start {
                reference_gap(&*c.longitudinal()?, c.follower.initial_speed).unwrap_or(c.follower.initial_gap)
            } else {
                c.follower.initial_gap
            };
            let front_len = if k == 1 { ll.length } else { configs[k - 2].follower.vehicle.length };
            s_pos[k - 1] = s_pos[k] + c.follower.vehicle.length / 2.0 + gap + front_len / 2.0;
        }
        if let (Some(ls), 1) = (s.lead.s, n) {
            s_pos[0] = ls;
        }
        // The last follower may start off the centreline (`start_offset`, `start_heading`).
        let last_pose = configs.last().map_or((0.0, 0.0), |c| (c.follower.start_offset, c.follower.start_heading));
        let state_at = |k: usize, speed: f64| {
            let (off, head) = if k == n { last_pose } else { (0.0, 0.0) };
            let (x, y, yaw) = track.place(s_pos[k], off);
            VehicleState { x, y, yaw: yaw + head, speed, ..VehicleState::default() }
        };
        let lead_state = {
            let (x, y, yaw) = track.place(s_pos[0], s.lead.offset);
            VehicleState { x, y, yaw: yaw + s.lead.heading, speed: s.lead.initial_speed, ..VehicleState::default() }
        };
        // Bodies: follower 1, the lead, then followers 2..N.
        let mut bodies = Vec::with_capacity(n);
        let mut lead_body = None;
        for (k, c) in configs.iter().enumerate() {
            bodies.push(world.add_vehicle(&c.follower.vehicle, &state_at(k + 1, c.follower.initial_speed)));
            if k == 0 {
                lead_body = Some(world.add_vehicle(ll, &lead_state));
            }
        }
        let lead_body = lead_body.ok_or_else(|| ConfigError::new("platoon.followers", "at least one follower"))?;
        let mut followers = Vec::with_capacity(n);
        for (k, (mut c, body)) in configs.into_iter().zip(bodies).enumerate() {
            let state = state_at(k + 1, c.follower.initial_speed);
            let lead_link = platoon.v2v_source == V2vSource::Both && k >= 1;
            if platoon.v2v_source != V2vSource::Predecessor && k >= 1 {
                // The speed its PID takes is the lead's (`lead`) or a mix of the lead's and the
                // predecessor's (`both`): by design not that of the vehicle it detects, so there is
                // no sender to associate the detection with (docs/v2v-and-metrics.md 1.11).
                c.supervisor.association.enabled = false;
            }
            followers.push(Follower::new(s, &track, k + 1, c, body, state, lead_link)?);
        }
        // Scripted traffic: bodies after the string's.
        let traffic = s.vehicles.iter().map(|v| Traffic::new(v, &track, &mut world)).collect::<Result<Vec<_>, _>>()?;
        if s.lead.absent {
            // No lead: its slot stays, its body leaves the world (no sensor sees it, no contact).
            world.remove_vehicle(lead_body);
        }
        let per_phase =
            |phases: &[crate::lead::ScriptedPhase]| phases.iter().map(|_| crate::trigger::TriggerState::new()).collect::<Vec<_>>();
        let mut phase_triggers = vec![per_phase(&s.lead.phases)];
        phase_triggers.extend(s.vehicles.iter().map(|v| per_phase(&v.phases)));
        let any = s.stop.trigger.is_some()
            || s.lead.phases.iter().chain(s.vehicles.iter().flat_map(|v| v.phases.iter())).any(|p| p.start.is_some());
        let story = s.story.as_ref().map(|story| {
            let body = |name: &str, state: VehicleState, p: &crate::vehicle::VehicleParams| self::story::Body {
                state,
                length: p.length,
                reference: story.references.get(name).copied().unwrap_or_default(),
                pedestrian: p.body == crate::vehicle::BodyKind::Pedestrian,
                limits: story.limits.get(name).copied(),
            };
            let mut initial = vec![body("lead", lead_state, ll)];
            initial.extend(traffic.iter().map(|t| body(&t.name, *t.vehicle.state(), &t.params)));
            if let Some(f) = followers.first() {
                initial.push(body(crate::scenario::EGO, *f.vehicle.state(), &f.cfg.follower.vehicle));
            }
            StoryRun::new(story, &track, &initial)
        });
        let speeds0 = std::iter::once(lead_state.speed)
            .chain(traffic.iter().map(|t| t.vehicle.state().speed))
            .chain(followers.iter().map(|f| f.vehicle.state().speed));
        let still = speeds0.map(|v| if v < 1.0e-3 { 0.0 } else { -1.0 }).collect();
        let state = State {
            scenario: s.clone(),
            lead_x0: s_pos[0],
            world,
            lead_body,
            lead: Vehicle::new(*ll, lead_state),
            lead_driver: LeadDriver::new(*ll, &s.lead.phases, s.lead.initial_speed, s_pos[0], s.lead.offset, &|l| track.lane_offset(l)),
            lead_steer: centreline_pursuit(ll)?,
            followers,
            traffic,
            fronts: Vec::new(),
            human_fronts: Vec::new(),
            triggers: Triggers { phases: phase_triggers, stop: crate::trigger::TriggerState::new(), any, fired: Vec::new() },
            story,
            still,
            source: platoon.v2v_source,
            lead_weight: platoon.lead_weight,
            relay: platoon.relay,
            speeds: Vec::with_capacity(n + 1),
            senders: Vec::with_capacity(n + 1),
            bodies: Vec::new(),
            other_contacts: Vec::new(),
            contacts: Vec::new(),
            touching: Vec::new(),
            end: RunEnd::Duration,
            t: 0.0,
            k: 0,
            standstill_since: None,
            lead_cmd: (0.0, 0.0),
            any_driven: false,
            paused: false,
            ended: false,
            story_evaluated: false,
            track,
        };
        let mut sim = Self { state, observer: () };
        sim.evaluate_story_at_start();
        Ok(sim)
    }

    /// This simulation with `observer` as its sink (call it before the first step to observe the
    /// whole run).
    pub fn with_observer<P: Observer>(self, observer: P) -> Simulation<P> {
        Simulation { state: self.state, observer }
    }
}

impl<O: Observer> Simulation<O> {
    /// The scenario being run.
    pub fn scenario(&self) -> &Scenario {
        &self.state.scenario
    }

    /// Start and end times (s) of phase `k` of the scripted vehicle `name` (`lead` or a
    /// `[[vehicles]]` name); `None`: not (yet).
    pub fn phase_times(&self, name: &str, k: usize) -> (Option<f64>, Option<f64>) {
        use crate::trigger::WorldView;
        let p = self.truth().phase(name, k);
        (p.started, p.ended)
    }

    /// The status of the `[story]` element `name` now (`None`: no story or no such element).
    pub fn element(&self, name: &str) -> Option<crate::trigger::ElementStatus> {
        self.state.story.as_ref()?.state.element(name)
    }

    /// The value of `[story]` variable `name` now.
    pub fn variable(&self, name: &str) -> Option<crate::trigger::VarValue> {
        self.state.story.as_ref()?.state.variable(name).cloned()
    }

    /// Every start / end / stop / skip of a `[story]` event (`true`) or action (`false`) so far,
    /// with its name: `(time, is_event, name, transition)`.
    pub fn story_transitions(&self) -> Vec<(f64, bool, String, crate::trigger::ElementEvent)> {
        let (Some(run), Some(story)) = (self.state.story.as_ref(), self.state.scenario.story.as_ref()) else { return Vec::new() };
        run.state
            .transitions()
            .iter()
            .map(|tr| (tr.t, tr.event, run.state.name(story, tr.event, tr.index).unwrap_or_default().to_string(), tr.what))
            .collect()
    }

    /// `true` while the story drives the ego (`[story] ego = "scripted"` or after a
    /// `controller` action handed it over).
    pub fn ego_scripted(&self) -> bool {
        self.state.story.as_ref().is_some_and(|r| r.ego_scripted)
    }

    /// The state of the scripted vehicle `name` (`lead` or a `[[vehicles]]` name) now.
    pub fn scripted_state(&self, name: &str) -> Option<&VehicleState> {
        if name == "lead" {
            return Some(self.state.lead.state());
        }
        self.state.traffic.iter().find(|t| t.name == name).map(|t| t.vehicle.state())
    }

    /// The track.
    pub fn track(&self) -> &Track {
        &self.state.track
    }

    /// The lead's state now.
    pub fn lead_state(&self) -> &VehicleState {
        self.state.lead.state()
    }

    /// Follower `k`'s state now (`k = 0`: right behind the lead).
    pub fn follower_state(&self, k: usize) -> Option<&VehicleState> {
        self.state.followers.get(k).map(|f| f.vehicle.state())
    }

    /// The sink.
    pub fn observer(&self) -> &O {
        &self.observer
    }

    /// Simulation time, s.
    pub fn time(&self) -> f64 {
        self.state.t
    }

    /// Number of followers.
    pub fn n_followers(&self) -> usize {
        self.state.followers.len()
    }

    /// One physics step. Returns `Ok(false)` when the run is over. Driven followers
    /// ([`Simulation::drive`]) get the command set with [`Simulation::command`] (default: their
    /// law).
    pub fn step(&mut self) -> Result<bool, SimError> {
        if !self.state.paused {
            self.sense()?;
        }
        self.act()
    }

    /// Drives followers `followers` (1-based) from outside: from now on each scan delivered to
    /// one of them pauses [`Simulation::advance`] until its command is set. An index out of
    /// range is an error naming it.
    pub fn drive(&mut self, followers: &[usize], opts: DriveOptions) -> Result<(), ConfigError> {
        let n = self.state.followers.len();
        if let Some(&k) = followers.iter().find(|&&k| k == 0 || k > n) {
            return Err(ConfigError::new("drive", format!("follower {k} does not exist (the scenario has {n}, numbered from 1)")));
        }
        for &k in followers {
            let f = &mut self.state.followers[k - 1];
            f.drive = Some(Box::new(self::drive::Driven::new(opts, &f.cfg.lidar)));
        }
        self.state.any_driven |= !followers.is_empty();
        Ok(())
    }

    /// Runs physics steps up to the next scan of a driven follower and pauses there (`Ok(true)`:
    /// read [`Simulation::measurement`] / [`Simulation::ground_truth`], set
    /// [`Simulation::command`], call again), or to the end of the run (`Ok(false)`; then
    /// [`Simulation::result`]). Commands not set are [`DriveCommand::Law`].
    pub fn advance(&mut self) -> Result<bool, SimError> {
        loop {
            if self.state.ended {
                return Ok(false);
            }
            if !self.state.paused {
                self.sense()?;
                if self.state.followers.iter().any(|f| f.drive.as_ref().is_some_and(|d| d.pending.is_some())) {
                    self.state.paused = true;
                    return Ok(true);
                }
            }
            self.act()?;
        }
    }

    /// Sets driven follower `k`'s (1-based) command for the step paused at. An error if `k` is
    /// not driven or a number is not finite.
    pub fn command(&mut self, k: usize, cmd: DriveCommand) -> Result<(), ConfigError> {
        let bad = match cmd {
            DriveCommand::Law => None,
            DriveCommand::Speed(v) => (!v.is_finite()).then_some(("speed", v)),
            DriveCommand::Accel(a) => (!a.is_finite()).then_some(("accel", a)),
        };
        if let Some((what, v)) = bad {
            return Err(ConfigError::new(format!("command.{what}"), format!("must be a finite number, got {v}")));
        }
        match self.state.followers.get_mut(k.wrapping_sub(1)).and_then(|f| f.drive.as_mut()) {
            Some(d) => {
                d.command = cmd;
                Ok(())
            }
            None => Err(ConfigError::new("command", format!("follower {k} is not driven from outside"))),
        }
    }

    /// What driven follower `k`'s (1-based) pipeline got at its last scan, whether that scan
    /// is the one paused at (`true`: its command is due), and the latest V2V message it received.
    pub fn measurement(&self, k: usize) -> Option<(&Measurement, bool, Option<V2vSeen>)> {
        let d = self.state.followers.get(k.wrapping_sub(1))?.drive.as_ref()?;
        Some((&d.last, d.pending.is_some(), d.v2v))
    }

    /// Driven follower `k`'s (1-based) last scan as [`DriveOptions::beams`] range beams, m (empty
    /// with `beams = 0`).
    pub fn beams(&self, k: usize) -> Option<Vec<f64>> {
        Some(self.state.followers.get(k.wrapping_sub(1))?.drive.as_ref()?.beams())
    }

    /// Follower `k`'s (1-based) series so far (one row per physics step, state after the step).
    pub fn series(&self, k: usize) -> Option<&Series> {
        Some(&self.state.followers.get(k.wrapping_sub(1))?.series)
    }

    /// The ground truth about follower `k` (1-based) now: the vehicle in front of it as the run's
    /// records take it, its own state, its collision.
    pub fn ground_truth(&self, k: usize) -> Option<GroundTruth> {
        let st = &self.state;
        let f = st.followers.get(k.wrapping_sub(1))?;
        let (front, front_len, front_width) = match (st.fronts.get(k - 1), k.checked_sub(2)) {
            (Some(fr), _) => fr.seen(),
            (None, None) => (*st.lead.state(), st.scenario.lead.vehicle.length, st.scenario.lead.vehicle.width),
            (None, Some(j)) => {
                let v = &st.followers[j].cfg.follower.vehicle;
                (*st.followers[j].vehicle.state(), v.length, v.width)
            }
        };
        let fs = f.vehicle.state();
        Some(GroundTruth {
            t: st.t,
            gap: bumper_gap(&front, (front_len, front_width), fs, f.cfg.follower.vehicle.length),
            front_speed: front.speed,
            front_accel: front.accel,
            speed: fs.speed,
            accel: fs.accel,
            pose: (fs.x, fs.y, fs.yaw),
            lateral_offset: st.track.project(fs.x, fs.y).lateral_offset,
            collision: f.collision.clone(),
        })
    }

    /// Steps 1-3 of a physics step: triggers, drivers, V2V, scans and the pipelines.
    fn sense(&mut self) -> Result<(), SimError> {
        let t = self.state.t;
        let dt = self.state.scenario.physics_dt;

        // 1. Start triggers (ground truth at the start of the step), then the drivers of the
        //    lead and the traffic and their lateral control along the centreline.
        if self.state.triggers.any {
            self.fire_start_triggers(t);
        }
        if self.state.story.is_some() {
            self.step_story(t, dt);
        }
        let ls = *self.state.lead.state();
        let lproj = self.state.track.project(ls.x, ls.y);
        let mut lcmd = self.state.lead_driver.step(t, ls.speed, lproj.s - self.state.lead_x0);
        let tracking =
            |st: &State, j: usize, p: &crate::vehicle::VehicleParams, v: f64| st.story.as_ref().and_then(|r| r.tracking(j, p, v));
        if let Some((accel, offset)) = tracking(&self.state, 0, &self.state.scenario.lead.vehicle, ls.speed) {
            (lcmd.accel, lcmd.lateral_offset) = (accel, offset);
        }
        let lead_steer = self.lead_centreline_steer(&ls, lproj.s, lcmd.lateral_offset);
        for i in 0..self.state.traffic.len() {
            let tr = &self.state.traffic[i];
            let over = tracking(&self.state, 1 + i, &tr.params, tr.vehicle.state().speed);
            self.state.traffic[i].command(t, &self.state.track, over);
        }
        if let Some(onset) = self.state.lead_driver.brake_onset() {
            for f in &mut self.state.followers {
                if f.cfg.v2v.outage_on_brake {
                    f.v2v.start_outage(onset);
                    if let Some(l) = f.v2v_lead.as_mut() {
                        l.start_outage(onset);
                    }
                }
            }
        }

        // 2. V2V: every link broadcasts its sender's speed at the start of the step.
        self.state.speeds.clear();
        self.state.speeds.push(ls.speed);
        self.state.speeds.extend(self.state.followers.iter().map(|f| f.vehicle.state().speed));
        self.state.senders.clear();
        self.state.senders.push(sender_truth(0, &ls, &self.state.scenario.lead.vehicle));
        for f in &self.state.followers {
            self.state.senders.push(sender_truth(f.index as u32, f.vehicle.state(), &f.cfg.follower.vehicle));
        }
        for k in 0..self.state.followers.len() {
            let pending = if self.state.relay && k >= 1 { self.state.followers[k - 1].relay_pending } else { None };
            let mut consumed = false;
            let f = &mut self.state.followers[k];
            match self.state.source {
                V2vSource::Predecessor => {
                    if let Some(m) = f.v2v.tick_state(t, self.state.speeds[k], &self.state.senders[k]) {
                        f.deliver(t, m);
                    }
                }
                V2vSource::Lead => {
                    let m = if self.state.relay && k >= 1 {
                        relay_tick(&mut f.v2v, t, pending, &mut consumed)
                    } else {
                        f.v2v.tick(t, ls.speed)
                    };
                    if let Some(m) = m {
                        f.deliver(t, m);
                        f.relay_pending = Some(m.lead_speed);
                    }
                }
                V2vSource::Both => {
                    let pred = f.v2v.tick(t, self.state.speeds[k]);
                    if let Some(m) = pred {
                        f.deliver(t, m);
                    }
                    let lead_msg = match f.v2v_lead.as_mut() {
                        // Follower 1: its predecessor is the lead.
                        None => pred,
                        Some(ch) if self.state.relay => relay_tick(ch, t, pending, &mut consumed),
                        Some(ch) => ch.tick(t, ls.speed),
                    };
                    if let Some(m) = lead_msg {
                        f.lead_info = Some((m.lead_speed, 0));
                        f.relay_pending = Some(m.lead_speed);
                    }
                }
            }
            if consumed {
                self.state.followers[k - 1].relay_pending = None;
            }
        }

        // 3. LiDAR scans -> pipelines (every follower sees the world as it is at the start of the step).
        // `front`: the vehicle in front of this follower (for ideal perception: its true gap and
        // speed); nothing moves during this loop.
        self.fill_fronts();
        self.fill_human_fronts();
        for (k, f) in self.state.followers.iter_mut().enumerate() {
            let fs = *f.vehicle.state();
            let len = f.cfg.follower.vehicle.length;
            let (front_state, front_len, front_width) = self.state.fronts[k].seen();
            if let Some(scan) = f.lidar.tick(t, &self.state.world, f.body, &fs) {
                // The ground truth ideal perception gets; a human-like reference only what is in
                // front of it (`None`: nothing).
                let truth = match self.state.human_fronts.get(k) {
                    Some(Some((hs, hl, hw))) => Some((bumper_gap(hs, (*hl, *hw), &fs, len), hs.speed)),
                    Some(None) => None,
                    // Nothing in front (an absent lead and nothing in path).
                    None if front_state.speed.is_nan() => None,
                    None => Some((bumper_gap(&front_state, (front_len, front_width), &fs, len), front_state.speed)),
                };
                f.control_tick(t, &scan.points, &fs, &self.state.track, (self.state.source, self.state.lead_weight), truth);
                if f.index == 1 {
                    self.observer.scan(t, &scan, f.detector.clusters(), f.detected, f.lookahead)?;
                }
            }
        }
        self.state.lead_cmd = (lcmd.accel, lead_steer);
        Ok(())
    }

    /// Steps 4-5 of a physics step (after [`Simulation::sense`] and the commands of driven
    /// followers): low-level control, dynamics, contacts, records, stop conditions.
    fn act(&mut self) -> Result<bool, SimError> {
        let dt = self.state.scenario.physics_dt;
        self.state.paused = false;
        if self.state.any_driven {
            for f in &mut self.state.followers {
                f.resume();
            }
        }
        let running = self.physics(dt)?;
        self.state.ended = !running;
        Ok(running)
    }

    /// Steps 4-5 proper; `Ok(false)` when the run is over.
    fn physics(&mut self, dt: f64) -> Result<bool, SimError> {
        let (lead_accel, lead_steer) = self.state.lead_cmd;
        // 4. Low-level control and dynamics (the story's kinematic entities are put where their
        //    motion is).
        let ego_slot = 1 + self.state.traffic.len();
        for (k, f) in self.state.followers.iter_mut().enumerate() {
            let v = f.vehicle.state().speed;
            f.accel_cmd = f.accel_demand(dt);
            match self.state.story.as_ref().filter(|r| k == 0 && r.ego_scripted) {
                Some(r) if r.kinematic(ego_slot) => {
                    if let Some(m) = r.motions.get(ego_slot) {
                        f.accel_cmd = m.accel;
                        f.vehicle.set_state(pose_of(&self.state.track, m, f.steer_cmd));
                    }
                }
                Some(r) => {
                    if let Some((accel, _)) = r.tracking(ego_slot, &f.cfg.follower.vehicle, v) {
                        f.accel_cmd = accel;
                    }
                    f.vehicle.step(f.accel_cmd, f.steer_cmd, dt);
                }
                None => f.vehicle.step(f.accel_cmd, f.steer_cmd, dt),
            }
        }
        match self.state.story.as_ref().filter(|r| r.kinematic(0)).and_then(|r| r.motions.first()) {
            Some(m) => self.state.lead.set_state(pose_of(&self.state.track, m, 0.0)),
            None => self.state.lead.step(lead_accel, lead_steer, dt),
        }
        for (i, f) in self.state.followers.iter().enumerate() {
            self.state.world.set_pose(f.body, f.vehicle.state());
            if i == 0 {
                self.state.world.set_pose(self.state.lead_body, self.state.lead.state());
            }
        }
        for (i, tr) in self.state.traffic.iter_mut().enumerate() {
            match self.state.story.as_ref().filter(|r| r.kinematic(1 + i)).and_then(|r| r.motions.get(1 + i)) {
                Some(m) => tr.vehicle.set_state(pose_of(&self.state.track, m, 0.0)),
                None => tr.advance(dt),
            }
            self.state.world.set_pose(tr.body, tr.vehicle.state());
        }
        {
            let st = &mut self.state;
            let speeds = std::iter::once(st.lead.state().speed)
                .chain(st.traffic.iter().map(|t| t.vehicle.state().speed))
                .chain(st.followers.iter().map(|f| f.vehicle.state().speed));
            // Negative while moving; 0 at the first step at standstill (esmini counts from the
            // first evaluation that sees it standing).
            for (still, v) in st.still.iter_mut().zip(speeds) {
                *still = if v >= 1.0e-3 {
                    -1.0
                } else if *still < 0.0 {
                    0.0
                } else {
                    *still + dt
                };
            }
        }
        let contacts = self.state.world.step(dt);
        self.state.t += dt;
        self.state.k += 1;

        // 5. Contacts, then records: each follower against the vehicle in front of it.
        if !contacts.is_empty() {
            self.record_contacts(&contacts)?;
        }
        if self.state.story.is_some() && !(contacts.is_empty() && self.state.touching.is_empty()) {
            self.record_episodes(&contacts);
        }
        let ls = *self.state.lead.state();
        self.fill_fronts();
        let mut all_still = ls.speed < 0.05;
        let mut collided = false;
        for (k, f) in self.state.followers.iter_mut().enumerate() {
            let fs = *f.vehicle.state();
            let len = f.cfg.follower.vehicle.length;
            let fronts = self.state.fronts[k];
            let (front, _, _) = fronts.seen();
            // The gap to the vehicle in path (none: NaN), and to the one followed in the string.
            let gap = fronts.in_path.map_or(f64::NAN, |(st, l, w)| bumper_gap(&st, (l, w), &fs, len));
            let lead_gap = bumper_gap(&fronts.string.0, (fronts.string.1, fronts.string.2), &fs, len);
            collided |= f.collision.is_some();
            all_still &= fs.speed < 0.05;
            let rec = f.record(self.state.t, &self.state.track, (gap, lead_gap), &front, &fs);
            if f.index == 1 {
                self.observer.step(&rec, &ls, &fs)?;
            }
        }
        for (i, tr) in self.state.traffic.iter().enumerate() {
            self.observer.traffic(self.state.t, i, &tr.name, tr.vehicle.state(), (tr.params.length, tr.params.width))?;
        }

        // Stop conditions.
        if collided && self.state.scenario.stop.on_collision {
            self.state.end = RunEnd::Collision;
            return Ok(false);
        }
        if self.state.triggers.any && self.stop_trigger_fired() {
            self.state.end = RunEnd::StopTrigger;
            return Ok(false);
        }
        let scripts_done = match &self.state.story {
            Some(r) => r.state.complete(),
            None => self.state.lead_driver.finished(),
        };
        if scripts_done && all_still && self.state.scenario.stop.on_standstill {
            let since = *self.state.standstill_since.get_or_insert(self.state.t);
            if self.state.t - since >= self.state.scenario.stop.standstill_time {
                self.state.end = RunEnd::Standstill;
                return Ok(false);
            }
        } else {
            self.state.standstill_since = None;
        }
        Ok(self.state.t < self.state.scenario.duration - 0.5 * dt)
    }

    /// Turns a step's contacts into records: each follower's first contact (its collision, also
    /// told to the observer) and the first contact of each pair without a follower.
    fn record_contacts(&mut self, contacts: &[crate::world::Contact]) -> Result<(), SimError> {
        let st = &mut self.state;
        st.refresh_bodies();
        let names: Vec<&str> = st.traffic.iter().map(|t| t.name.as_str()).collect();
        let pedestrians = pedestrian_flags(st);
        let bodies = contacts::Bodies {
            vehicles: &st.bodies,
            followers: st.followers.len(),
            traffic: &names,
            pedestrians: &pedestrians,
            track: &st.track,
        };
        for (i, f) in st.followers.iter_mut().enumerate() {
            if f.collision.is_none() {
                f.collision = contacts::first_collision(contacts, &bodies, i + 1, st.t);
                if let Some(c) = &f.collision {
                    self.observer.collision(f.index, c)?;
                }
            }
        }
        let seen = st.other_contacts.len();
        contacts::record_other_contacts(contacts, &bodies, st.t, &mut st.other_contacts);
        for c in &st.other_contacts[seen..] {
            self.observer.other_contact(c)?;
        }
        Ok(())
    }

    /// `[story]` runs: appends to `contacts` every pair of this step's `contacts` that was not
    /// touching after the step before (a new contact episode), and remembers the pairs touching.
    fn record_episodes(&mut self, contacts: &[crate::world::Contact]) {
        let st = &mut self.state;
        st.refresh_bodies();
        let names: Vec<&str> = st.traffic.iter().map(|t| t.name.as_str()).collect();
        let pedestrians = pedestrian_flags(st);
        let bodies = contacts::Bodies {
            vehicles: &st.bodies,
            followers: st.followers.len(),
            traffic: &names,
            pedestrians: &pedestrians,
            track: &st.track,
        };
        let now = contacts::pair_contacts(contacts, &bodies, st.t);
        let mut touching = Vec::with_capacity(now.len());
        for c in now {
            let pair = (c.a.clone(), c.b.clone());
            let seen = |p: &(HitObject, HitObject)| (p.0 == pair.0 && p.1 == pair.1) || (p.0 == pair.1 && p.1 == pair.0);
            if touching.iter().any(seen) {
                continue;
            }
            if !st.touching.iter().any(seen) && st.contacts.len() < MAX_CONTACTS {
                st.contacts.push(c);
            }
            touching.push(pair);
        }
        st.touching = touching;
    }

    /// `fronts`: for each follower the nearest vehicle in its path ([`path::nearest_in_path`])
    /// among the lead, the traffic and the followers ahead of it, and the one it follows in the
    /// string (the lead for the first follower).
    fn fill_fronts(&mut self) {
        let st = &mut self.state;
        st.fronts.clear();
        let ll = &st.scenario.lead.vehicle;
        let lead = Object { state: *st.lead.state(), length: ll.length, width: ll.width };
        // An absent lead is no vehicle in front: followed in the string, it is "nothing" (NaN).
        let (lead_there, lead_string) = match st.scenario.lead.absent {
            false => (Some(lead), lead),
            true => (None, Object { state: NOTHING, length: f64::NAN, width: f64::NAN }),
        };
        let object =
            |g: &Follower| Object { state: *g.vehicle.state(), length: g.cfg.follower.vehicle.length, width: g.cfg.follower.vehicle.width };
        for k in 0..st.followers.len() {
            let ego = object(&st.followers[k]);
            let ahead = st.followers[..k].iter().map(object);
            let traffic = st.traffic.iter().map(|t| Object { state: *t.vehicle.state(), length: t.params.length, width: t.params.width });
            let string = k.checked_sub(1).map_or(lead_string, |j| object(&st.followers[j]));
            let in_path = nearest_in_path(&st.track, &ego, lead_there.into_iter().chain(traffic).chain(ahead));
            st.fronts.push(Fronts { in_path, string: (string.state, string.length, string.width) });
        }
    }

    /// `human_fronts`: for each follower whose controller perceives the scene as a human
    /// ([`crate::ControllerKind::perceives_truth`]) the vehicle in front as it sees it; empty when no
    /// follower does.
    fn fill_human_fronts(&mut self) {
        let st = &mut self.state;
        st.human_fronts.clear();
        if !st.followers.iter().any(|f| f.cfg.controller.perceives_truth()) {
            return;
        }
        let ll = &st.scenario.lead.vehicle;
        let lead = (!st.scenario.lead.absent).then_some(Object { state: *st.lead.state(), length: ll.length, width: ll.width });
        for k in 0..st.followers.len() {
            let f = &st.followers[k];
            let ahead = st.followers[..k].iter().map(|g| Object {
                state: *g.vehicle.state(),
                length: g.cfg.follower.vehicle.length,
                width: g.cfg.follower.vehicle.width,
            });
            let traffic = st.traffic.iter().map(|t| Object { state: *t.vehicle.state(), length: t.params.length, width: t.params.width });
            let ego = Object { state: *f.vehicle.state(), length: f.cfg.follower.vehicle.length, width: f.cfg.follower.vehicle.width };
            let seen = human_front(&st.track, &ego, lead.into_iter().chain(traffic).chain(ahead));
            st.human_fronts.push(seen);
        }
    }

    fn truth(&self) -> Truth<'_> {
        truth!(self.state)
    }

    /// `[story]` at `t`: its triggers on the ground truth at the start of the step, then the
    /// motions of its entities to `t + dt`.
    fn step_story(&mut self, t: f64, dt: f64) {
        let evaluated = std::mem::take(&mut self.state.story_evaluated);
        self.story_pass(t, if evaluated { StoryPass::Advance(dt) } else { StoryPass::Step(dt) });
    }

    /// The storyboard evaluated at t = 0 before the first step, as esmini does: what its actions
    /// do at once (a teleport, a step change of speed) is in the state at t = 0 (the first
    /// trajectory row, the first scan); the first step then only advances the motions.
    fn evaluate_story_at_start(&mut self) {
        if self.state.story.is_none() {
            return;
        }
        let moved = self.story_pass(0.0, StoryPass::Evaluate);
        self.state.story_evaluated = true;
        let st = &mut self.state;
        let Some(run) = st.story.as_ref() else { return };
        let ego_slot = 1 + st.traffic.len();
        for j in moved {
            let Some(m) = run.motions.get(j).filter(|_| run.kinematic(j)) else { continue };
            if j == 0 {
                st.lead.set_state(pose_of(&st.track, m, 0.0));
                st.world.set_pose(st.lead_body, st.lead.state());
            } else if j == ego_slot {
                if let Some(f) = st.followers.first_mut() {
                    f.vehicle.set_state(pose_of(&st.track, m, f.steer_cmd));
                    st.world.set_pose(f.body, f.vehicle.state());
                }
            } else if let Some(tr) = st.traffic.get_mut(j - 1) {
                tr.vehicle.set_state(pose_of(&st.track, m, 0.0));
                st.world.set_pose(tr.body, tr.vehicle.state());
            }
        }
    }

    /// One pass of the story at `t`; returns the slots an action started on (when evaluated).
    fn story_pass(&mut self, t: f64, pass: StoryPass) -> Vec<usize> {
        let st = &mut self.state;
        let Some(story) = st.scenario.story.as_ref() else { return Vec::new() };
        let Some(mut run) = st.story.take() else { return Vec::new() };
        let traffic = &st.traffic;
        let slot = |name: &str| -> Option<usize> {
            match name {
                "lead" => Some(0),
                crate::scenario::EGO => Some(traffic.len() + 1),
                _ => traffic.iter().position(|t| t.name == name).map(|i| i + 1),
            }
        };
        let ego = self::story::Body {
            state: st.followers.first().map(|f| *f.vehicle.state()).unwrap_or_default(),
            length: st.followers.first().map_or(0.0, |f| f.cfg.follower.vehicle.length),
            reference: story.references.get(crate::scenario::EGO).copied().unwrap_or_default(),
            pedestrian: false,
            limits: story.limits.get(crate::scenario::EGO).copied(),
        };
        let mut moved = Vec::new();
        {
            let truth = truth!(st);
            let input = StepInput { story, world: &truth, slot: &slot, track: &st.track, ego };
            match pass {
                StoryPass::Evaluate => moved = run.evaluate(&input, t),
                StoryPass::Advance(dt) => run.advance(&input, t, dt),
                StoryPass::Step(dt) => run.step(&input, t, dt),
            }
        }
        st.story = Some(run);
        moved
    }

    /// Evaluates every armed start trigger at `t` and starts the phases whose trigger fires.
    fn fire_start_triggers(&mut self, t: f64) {
        let st = &mut self.state;
        let truth = truth!(st);
        let Triggers { phases, fired, .. } = &mut st.triggers;
        fired.clear();
        for (e, states) in phases.iter_mut().enumerate() {
            let (driver, script) = match e.checked_sub(1) {
                None => (&st.lead_driver, &st.scenario.lead.phases),
                Some(i) => match (st.traffic.get(i), st.scenario.vehicles.get(i)) {
                    (Some(tr), Some(v)) => (&tr.driver, &v.phases),
                    _ => continue,
                },
            };
            let Some(k) = driver.armed() else { continue };
            if let (Some(trig), Some(ts)) = (script.get(k).and_then(|p| p.start.as_ref()), states.get_mut(k)) {
                if ts.update(trig, &truth, t) {
                    fired.push((e, k));
                }
            }
        }
        for &(e, k) in &st.triggers.fired {
            match e.checked_sub(1) {
                None => st.lead_driver.fire(k, t, st.lead.state().speed),
                Some(i) => {
                    if let Some(tr) = st.traffic.get_mut(i) {
                        tr.driver.fire(k, t, tr.vehicle.state().speed);
                    }
                }
            }
        }
    }

    /// `true` when the scenario's stop trigger fires (ground truth after the step).
    fn stop_trigger_fired(&mut self) -> bool {
        let st = &mut self.state;
        let Some(trig) = &st.scenario.stop.trigger else { return false };
        st.triggers.stop.update(trig, &truth!(st), st.t)
    }

    fn lead_centreline_steer(&self, ls: &VehicleState, s: f64, offset: f64) -> f64 {
        centreline_steer(&self.state.track, &self.state.lead_steer, ls, s, offset)
    }

    /// Tells the observer that the run ended: with follower 1's metrics so far if `completed`
    /// (the run reached its end), without if it was stopped early.
    pub fn finish_observer(&mut self, completed: bool) -> Result<(), SimError> {
        let metrics = match (completed, self.state.followers.first()) {
            (true, Some(f)) => Some(Metrics::compute(&f.series, f.collision.clone())),
            _ => None,
        };
        self.observer.finish(metrics.as_ref())
    }

    /// Ends the run and computes the metrics (follower 1's as [`RunResult::metrics`]; with
    /// `[platoon]` every follower's and the string-stability measures in [`RunResult::platoon`]).
    pub fn finish(self) -> RunResult {
        let State { scenario, followers, lead_driver, other_contacts, contacts, end, .. } = self.state;
        let mut laws = Vec::with_capacity(followers.len());
        let runs: Vec<FollowerRun> = followers
            .into_iter()
            .map(|f| {
                laws.push(f.longitudinal);
                FollowerRun { metrics: Metrics::compute(&f.series, f.collision.clone()), series: f.series, collision: f.collision }
            })
            .collect();
        let laws: Vec<&dyn flc_core::LongitudinalController> = laws.iter().map(|l| &**l as &dyn flc_core::LongitudinalController).collect();
        assemble(scenario, runs, &laws, &lead_driver, (other_contacts, contacts, end))
    }

    /// The result of the run so far, as [`Simulation::finish`] gives it at the end (the run goes
    /// on; `flc.Simulation.result()`).
    pub fn result(&self) -> RunResult {
        let st = &self.state;
        let runs: Vec<FollowerRun> = st
            .followers
            .iter()
            .map(|f| FollowerRun {
                metrics: Metrics::compute(&f.series, f.collision.clone()),
                series: f.series.clone(),
                collision: f.collision.clone(),
            })
            .collect();
        let laws: Vec<&dyn flc_core::LongitudinalController> =
            st.followers.iter().map(|f| &*f.longitudinal as &dyn flc_core::LongitudinalController).collect();
        assemble(st.scenario.clone(), runs, &laws, &st.lead_driver, (st.other_contacts.clone(), st.contacts.clone(), st.end))
    }
}

/// The vehicles in front of one follower (ground truth), each with its length.
/// The state of "nothing" (an absent lead followed in the string): NaN throughout.
const NOTHING: VehicleState =
    VehicleState { x: f64::NAN, y: f64::NAN, yaw: f64::NAN, speed: f64::NAN, accel: f64::NAN, steer: f64::NAN, odometer: f64::NAN };

#[derive(Debug, Clone, Copy)]

struct Fronts {
    /// The vehicle in its path ([`path::nearest_in_path`]); `None`: nothing is.
    in_path: Option<(VehicleState, f64, f64)>,
    /// The vehicle it follows in the string (the lead for the first follower), wherever it is.
    string: (VehicleState, f64, f64),
}

impl Fronts {
    /// The vehicle in front as ideal perception and the records' front columns take it: the one
    /// in path, else the one followed in the string.
    fn seen(&self) -> (VehicleState, f64, f64) {
        self.in_path.unwrap_or(self.string)
    }
}

/// A run's [`RunResult`] from its parts.
fn assemble(
    scenario: Scenario,
    mut runs: Vec<FollowerRun>,
    laws: &[&dyn flc_core::LongitudinalController],
    lead_driver: &LeadDriver,
    (other_contacts, contacts, end): (Vec<ContactRecord>, Vec<PairContact>, RunEnd),
) -> RunResult {
    let platoon = scenario.platoon.as_ref().map(|p| {
        let signals = Signals::of(&runs, laws);
        let string_stability = StringStability::measure(&p.string_stability, &signals, &runs, lead_driver.brake_onset());
        PlatoonResult { followers: runs.clone(), signals, string_stability }
    });
    let first = runs.swap_remove(0);
    RunResult { scenario, metrics: first.metrics, series: first.series, platoon, collision: first.collision, other_contacts, contacts, end }
}

impl State {
    /// This step's bodies and states in `bodies` (lead, followers, traffic: the order
    /// `contacts::Bodies` indexes), reusing its allocation.
    fn refresh_bodies(&mut self) {
        self.bodies.clear();
        self.bodies.push((self.lead_body, *self.lead.state()));
        self.bodies.extend(self.followers.iter().map(|f| (f.body, *f.vehicle.state())));
        self.bodies.extend(self.traffic.iter().map(|t| (t.body, *t.vehicle.state())));
    }
}

/// Which bodies are pedestrians, in the order of `State::bodies` (the lead, the followers, the
/// traffic).
fn pedestrian_flags(st: &State) -> Vec<bool> {
    let ped = |p: &crate::vehicle::VehicleParams| p.body == crate::vehicle::BodyKind::Pedestrian;
    std::iter::once(ped(&st.scenario.lead.vehicle))
        .chain(st.followers.iter().map(|_| false))
        .chain(st.traffic.iter().map(|t| ped(&t.params)))
        .collect()
}

/// What one pass of the story does: evaluate the storyboard, advance the motions by `dt`, or both.
#[derive(Debug, Clone, Copy)]
enum StoryPass {
    Evaluate,
    Advance(f64),
    Step(f64),
}

/// The true CAM / BSM kinematics of a V2V sender: its reference point is the centre of the front
/// of its bounding box (CAM `ReferencePosition`), `id` its station id.
fn sender_truth(id: u32, st: &VehicleState, v: &crate::vehicle::VehicleParams) -> flc_core::SenderState {
    let half = v.length / 2.0;
    flc_core::SenderState {
        station_id: id,
        x: st.x + half * st.yaw.cos(),
        y: st.y + half * st.yaw.sin(),
        heading: st.yaw,
        accel: st.accel,
        length: v.length,
    }
}
