//! Scripted traffic in the loop: the `[[vehicles]]` besides the lead, the start and stop
//! triggers evaluated on ground truth (which vehicle is in the ego's path: [`super::path`]).

use flc_core::PurePursuit;

use super::follower::Follower;
use super::geometry::{centreline_pursuit, centreline_steer};
use crate::error::SimError;
use crate::lead::{LeadDriver, ScriptedVehicle};
use crate::track::Track;
use crate::trigger::{EntityState, PhaseStatus, TriggerState, WorldView};
use crate::vehicle::{Vehicle, VehicleParams, VehicleState};
use crate::world::{Body, World};

/// One scripted vehicle besides the lead.
pub(super) struct Traffic {
    pub(super) name: String,
    pub(super) params: VehicleParams,
    pub(super) body: Body,
    pub(super) vehicle: Vehicle,
    pub(super) driver: LeadDriver,
    steer: PurePursuit,
    /// Centre position along the centreline at the start, m.
    pub(super) s0: f64,
    /// This step's acceleration and steering commands.
    cmd: (f64, f64),
}

impl Traffic {
    /// Places `spec` on `track` in `world`.
    pub(super) fn new(spec: &ScriptedVehicle, track: &Track, world: &mut World) -> Result<Self, SimError> {
        let offset = spec.offset.or(spec.lane.map(|l| track.lane_offset(l))).unwrap_or(0.0);
        let (x, y, h) = track.place(spec.s, offset);
        let state = VehicleState { x, y, yaw: h + spec.heading, speed: spec.initial_speed, ..VehicleState::default() };
        let lane_offset = |l: u32| track.lane_offset(l);
        Ok(Self {
            name: spec.name.clone(),
            params: spec.vehicle,
            body: world.add_vehicle(&spec.vehicle, &state),
            vehicle: Vehicle::new(spec.vehicle, state),
            driver: LeadDriver::new(spec.vehicle, &spec.phases, spec.initial_speed, spec.s, offset, &lane_offset),
            steer: centreline_pursuit(&spec.vehicle)?,
            s0: spec.s,
            cmd: (0.0, 0.0),
        })
    }

    /// Step 1 of the loop: the driver's command for this step (`over`: the acceleration demand
    /// and lateral offset of a story's motion, instead of the phases').
    pub(super) fn command(&mut self, t: f64, track: &Track, over: Option<(f64, f64)>) {
        let st = *self.vehicle.state();
        let proj = track.project(st.x, st.y);
        let c = self.driver.step(t, st.speed, proj.s - self.s0);
        let (accel, offset) = over.unwrap_or((c.accel, c.lateral_offset));
        self.cmd = (accel, centreline_steer(track, &self.steer, &st, proj.s, offset));
    }

    /// Step 4: dynamics.
    pub(super) fn advance(&mut self, dt: f64) {
        self.vehicle.step(self.cmd.0, self.cmd.1, dt);
    }
}

/// Trigger bookkeeping: one state per phase of each scripted entity (0 = the lead, then the
/// traffic) and the scenario's stop trigger.
pub(super) struct Triggers {
    pub(super) phases: Vec<Vec<TriggerState>>,
    pub(super) stop: TriggerState,
    /// `false`: no trigger anywhere (nothing to evaluate).
    pub(super) any: bool,
    /// `(entity, phase)` of the triggers that fired this step (reused buffer).
    pub(super) fired: Vec<(usize, usize)>,
}

/// The [`Truth`] of a loop state, borrowing only the fields it reads (so that the trigger
/// states can be updated meanwhile).
macro_rules! truth {
    ($st:expr) => {
        $crate::sim::traffic::Truth {
            track: &$st.track,
            lead: (&$st.lead, &$st.lead_driver),
            traffic: &$st.traffic,
            followers: &$st.followers,
            story: $st.story.as_ref().map(|r| &r.state),
            contacts: &$st.other_contacts,
            still: &$st.still,
        }
    };
}
pub(super) use truth;

/// The ground truth triggers see (`crate::trigger::WorldView`).
pub(super) struct Truth<'a> {
    pub(super) track: &'a Track,
    pub(super) lead: (&'a Vehicle, &'a LeadDriver),
    pub(super) traffic: &'a [Traffic],
    pub(super) followers: &'a [Follower],
    /// The story's runtime (element states, variables).
    pub(super) story: Option<&'a crate::story::StoryState>,
    /// Contacts without a follower.
    pub(super) contacts: &'a [crate::metrics::ContactRecord],
    /// Standstill times (0 = lead, traffic, followers).
    pub(super) still: &'a [f64],
}

fn entity_state(track: &Track, v: &Vehicle, still_for: f64) -> EntityState {
    let st = v.state();
    let p = track.project(st.x, st.y);
    let par = v.params();
    EntityState {
        s: p.s,
        lateral: p.lateral_offset,
        speed: st.speed,
        length: par.length,
        width: par.width,
        // The path its reference point travelled (esmini's odometer), not the distance along
        // the road: a turn off the road travels on while `s` hardly grows.
        traveled: st.odometer,
        accel: st.accel,
        still_for,
    }
}

/// Follower index (0-based) of a trigger name: `ego` or `follower <k>`.
fn follower_index(name: &str) -> Option<usize> {
    if name == crate::scenario::EGO {
        return Some(0);
    }
    name.strip_prefix("follower ").and_then(|k| k.parse::<usize>().ok()).and_then(|k| k.checked_sub(1))
}

impl WorldView for Truth<'_> {
    fn pose(&self, name: &str) -> Option<[f64; 3]> {
        let st = if name == "lead" {
            self.lead.0.state()
        } else if let Some(k) = follower_index(name) {
            self.followers.get(k)?.vehicle.state()
        } else {
            self.traffic.iter().find(|t| t.name == name)?.vehicle.state()
        };
        Some([st.x, st.y, st.yaw])
    }

    fn place(&self, s: f64, offset: f64) -> Option<[f64; 4]> {
        let (x, y, h) = self.track.place(s, offset);
        Some([x, y, h, self.track.curvature_at(s)])
    }

    fn entity(&self, name: &str) -> Option<EntityState> {
        let still = |i: usize| self.still.get(i).copied().unwrap_or(0.0).max(0.0);
        if name == "lead" {
            return Some(entity_state(self.track, self.lead.0, still(0)));
        }
        if let Some(k) = follower_index(name) {
            let f = self.followers.get(k)?;
            return Some(entity_state(self.track, &f.vehicle, still(1 + self.traffic.len() + k)));
        }
        let i = self.traffic.iter().position(|t| t.name == name)?;
        self.traffic.get(i).map(|t| entity_state(self.track, &t.vehicle, still(1 + i)))
    }

    fn element(&self, name: &str) -> Option<crate::trigger::ElementStatus> {
        self.story?.element(name)
    }

    fn variable(&self, name: &str) -> Option<crate::trigger::VarValue> {
        self.story?.variable(name).cloned()
    }

    fn collided(&self, a: &str, b: Option<&str>) -> bool {
        // A follower's first contact, under its trigger names (`ego` = `follower 1`).
        let follower_hit = |k: usize, other: &str| {
            self.followers.get(k).and_then(|f| f.collision.as_ref()).is_some_and(|c| {
                let name = c.object.name();
                other.is_empty()
                    || name.as_deref() == Some(other)
                    || (other == crate::scenario::EGO && name.as_deref() == Some("follower 1"))
            })
        };
        let is = |n: &str, who: &str| n == who || (who == crate::scenario::EGO && n == "follower 1");
        if let Some(k) = follower_index(a) {
            return follower_hit(k, b.unwrap_or(""));
        }
        if let Some(k) = b.and_then(follower_index) {
            return follower_hit(k, a);
        }
        self.contacts.iter().any(|c| {
            let (na, nb) = (c.a.name().unwrap_or_default(), c.b.name().unwrap_or_default());
            match b {
                None => is(&na, a) || is(&nb, a),
                Some(b) => (is(&na, a) && is(&nb, b)) || (is(&na, b) && is(&nb, a)),
            }
        }) || (b.is_none() && (0..self.followers.len()).any(|k| follower_hit(k, a)))
    }

    fn phase(&self, name: &str, phase: usize) -> PhaseStatus {
        let driver = if name == "lead" { Some(self.lead.1) } else { self.traffic.iter().find(|t| t.name == name).map(|t| &t.driver) };
        let (started, ended) = driver.map_or((None, None), |d| d.phase_times(phase));
        PhaseStatus { started, ended }
    }
}
