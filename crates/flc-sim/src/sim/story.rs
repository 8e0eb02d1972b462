//! `[story]` in the loop: the storyboard's runtime ([`StoryState`]) evaluated on ground truth at
//! the start of every step, and the motion ([`Motion`]) of every entity it drives: the lead, the
//! `[[vehicles]]` and, while the story has it, the ego.

use crate::story::{Action, Dynamics, EgoMode, Motion, Started, Story, StoryState};
use crate::track::Track;
use crate::trigger::WorldView;
use crate::vehicle::{VehicleParams, VehicleState};

/// Gain of the driver that tracks a story's speed in `dynamics = "vehicle"`, 1/s.
const TRACK_GAIN: f64 = 3.0;

/// The story's runtime and the motions of its entities (slot 0 = the lead, `1..=n` = the
/// traffic, `n + 1` = the ego).
pub(super) struct StoryRun {
    pub(super) state: StoryState,
    pub(super) motions: Vec<Motion>,
    /// The story drives the ego now (`ego = "scripted"`, or a `controller` action handed it over).
    pub(super) ego_scripted: bool,
    pub(super) dynamics: Dynamics,
    /// Slots that always move kinematically (pedestrians), whatever `dynamics`.
    always_kinematic: Vec<bool>,
    started: Vec<Started>,
    stopped: Vec<usize>,
    /// Slots that moved before the others this step ([`StoryRun::advance`]; kept to reuse).
    moved_first: Vec<bool>,
}

/// An entity as the story moves it: its state, length and reference point (the box centre's
/// position from it, in the entity's frame).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Body {
    pub(super) state: VehicleState,
    pub(super) length: f64,
    pub(super) reference: [f64; 2],
    /// A pedestrian: moved kinematically whatever the story's `dynamics`.
    pub(super) pedestrian: bool,
    /// The limits of its speed changes (`story.limits`).
    pub(super) limits: Option<[f64; 2]>,
}

/// The motion of the reference point of `b` on `track`.
pub(super) fn motion_of(track: &Track, b: &Body) -> Motion {
    let st = &b.state;
    let (c, s) = (st.yaw.cos(), st.yaw.sin());
    let [rx, ry] = b.reference;
    let p = track.project(st.x - c * rx + s * ry, st.y - s * rx - c * ry);
    let mut m = Motion::new(p.s, p.lateral_offset, st.speed, track.lane_width)
        .with_length(b.length)
        .with_reference(b.reference)
        .with_limits(b.limits)
        .with_heading(crate::track::wrap(st.yaw - p.heading));
    m.traveled = st.odometer;
    if b.pedestrian { m.holding_heading() } else { m }
}

/// The pose a motion puts its vehicle's box centre in, with the path its reference point has
/// travelled as the odometer (esmini's, which a teleport does not advance).
pub(super) fn pose_of(track: &Track, m: &Motion, steer: f64) -> VehicleState {
    let (x, y, h) = track.place(m.s, m.offset);
    let yaw = h + m.heading;
    let [rx, ry] = m.reference();
    let (c, s) = (yaw.cos(), yaw.sin());
    VehicleState { x: x + c * rx - s * ry, y: y + s * rx + c * ry, yaw, speed: m.speed, accel: m.accel, steer, odometer: m.traveled }
}

/// What [`StoryRun::step`] reads of the loop: the story, the ground truth at the start of the
/// step, the entity slots by name, the track and the ego (from which its motion restarts when
/// the story takes it over).
pub(super) struct StepInput<'a> {
    pub(super) story: &'a Story,
    pub(super) world: &'a dyn WorldView,
    pub(super) slot: &'a dyn Fn(&str) -> Option<usize>,
    pub(super) track: &'a Track,
    pub(super) ego: Body,
}

impl StoryRun {
    /// The runtime of `story` for entities `initial` (lead, traffic..., ego).
    pub(super) fn new(story: &Story, track: &Track, initial: &[Body]) -> Self {
        Self {
            state: StoryState::new(story),
            motions: initial.iter().map(|b| motion_of(track, b)).collect(),
            ego_scripted: story.ego == EgoMode::Scripted,
            dynamics: story.dynamics,
            always_kinematic: initial.iter().map(|b| b.pedestrian).collect(),
            started: Vec::new(),
            stopped: Vec::new(),
            moved_first: Vec::new(),
        }
    }

    /// The ego's slot.
    fn ego(&self) -> usize {
        self.motions.len().saturating_sub(1)
    }

    /// One evaluation at `t`: starts / stops actions, then advances every motion to `t + dt`.
    pub(super) fn step(&mut self, input: &StepInput<'_>, t: f64, dt: f64) {
        self.evaluate(input, t);
        self.advance(input, t, dt);
    }

    /// The storyboard evaluated at `t`: starts and stops actions (a teleport, a step change of
    /// speed take effect in the motions at once). Returns the slots an action started on.
    pub(super) fn evaluate(&mut self, input: &StepInput<'_>, t: f64) -> Vec<usize> {
        let StepInput { story, world, slot, track, ego: ego_now } = *input;
        let mut moved = Vec::new();
        self.started.clear();
        self.stopped.clear();
        self.state.step(story, world, t, &mut self.started, &mut self.stopped);
        for &x in &self.stopped {
            for m in &mut self.motions {
                m.stop(x);
            }
        }
        let ego = self.ego();
        for k in 0..self.started.len() {
            let i = self.started[k].action;
            let Some((action, actors)) = self.state.action(story, i) else { continue };
            if let Action::Controller { longitudinal } = action {
                if actors.iter().any(|a| slot(a) == Some(ego)) {
                    let scripted = !*longitudinal;
                    if scripted && !self.ego_scripted {
                        self.motions[ego] = motion_of(track, &ego_now);
                    }
                    self.ego_scripted = scripted;
                }
                continue;
            }
            if !(action.is_longitudinal() || action.is_lateral()) {
                continue;
            }
            for a in actors {
                let Some(j) = slot(a) else {
                    self.state.end_action(i, true);
                    continue;
                };
                if j == ego && !self.ego_scripted {
                    // flc's controller drives the ego: its story actions do not run.
                    self.state.end_action(i, true);
                    continue;
                }
                let Some(m) = self.motions.get_mut(j) else { continue };
                moved.push(j);
                let (replaced, done) = m.start(i, action, t, world);
                for r in replaced {
                    self.state.end_action(r, true);
                }
                if done {
                    self.state.end_action(i, false);
                }
            }
        }
        moved
    }

    /// Every motion the story drives advanced from `t` to `t + dt`.
    ///
    /// In esmini's order: a `FollowTrajectoryAction` moves its entity while the actions step, an
    /// Init action before the story's, so a synchronisation measures a master that follows a
    /// trajectory where it is after this step's move along it (esmini 3.6.0
    /// `StoryBoard::Step`: Init private actions, then the story; `SynchronizeAction::Step`
    /// reads `master_object_->pos_`). Those masters step first, then the distances are told,
    /// then every other motion steps (each once).
    pub(super) fn advance(&mut self, input: &StepInput<'_>, t: f64, dt: f64) {
        let StepInput { slot, .. } = *input;
        let n = self.motions.len();
        // The masters of synchronisations that measure them along their trajectory, not
        // synchronised themselves.
        self.moved_first.clear();
        self.moved_first.resize(n, false);
        for j in 0..n {
            let Some(k) = self.motions[j].sync_master_point().and_then(|(name, _)| slot(name)) else { continue };
            if let Some(mk) = self.motions.get(k) {
                self.moved_first[k] = mk.follows_trajectory() && mk.sync_master_point().is_none();
            }
        }
        for k in 0..n {
            if self.moved_first[k] {
                self.advance_one(k, input, t, dt);
            }
        }
        for j in 0..n {
            let Some((name, point)) = self.motions[j].sync_master_point() else { continue };
            let ahead = slot(name).and_then(|k| self.motions.get(k)).and_then(|mm| mm.ahead_on_trajectory(point));
            self.motions[j].set_master_ahead(ahead);
        }
        for k in 0..n {
            if !self.moved_first[k] {
                self.advance_one(k, input, t, dt);
            }
        }
    }

    /// Slot `j`'s motion advanced from `t` to `t + dt` (not the ego while flc drives it).
    fn advance_one(&mut self, j: usize, input: &StepInput<'_>, t: f64, dt: f64) {
        let StepInput { world, track, .. } = *input;
        if j == self.ego() && !self.ego_scripted {
            return;
        }
        let m = &mut self.motions[j];
        let kappa = track.curvature_at(m.s);
        let s_before = m.s;
        let out = m.step(t, dt, kappa, world);
        m.end_of_road(s_before, track.length(), dt);
        m.record_velocity(s_before, dt);
        if let Some(i) = out.long_done {
            self.state.end_action(i, false);
        }
        if let Some(i) = out.lat_done {
            self.state.end_action(i, false);
        }
    }

    /// `true` when slot `j` moves kinematically (its pose is set from its motion).
    pub(super) fn kinematic(&self, j: usize) -> bool {
        // An oncoming entity moves kinematically in either dynamics (the traffic driver tracks
        // the road's direction only); so does a pedestrian.
        // So does one driving backwards (a negative speed; the vehicle model drives forwards only).
        let reversed = j != self.ego() && self.motions.get(j).is_some_and(|m| m.reversed || m.speed < 0.0);
        let always = self.always_kinematic.get(j).copied().unwrap_or(false);
        (self.dynamics == Dynamics::Kinematic || reversed || always) && (j != self.ego() || self.ego_scripted)
    }

    /// `dynamics = "vehicle"`: the acceleration demand (with the resistance feed-forward) and
    /// the lateral offset that track slot `j`'s motion with a vehicle `p` at speed `speed`.
    pub(super) fn tracking(&self, j: usize, p: &VehicleParams, speed: f64) -> Option<(f64, f64)> {
        let m = self.motions.get(j)?;
        Some((m.accel + TRACK_GAIN * (m.speed - speed) + p.resistance(speed), m.offset))
    }
}
