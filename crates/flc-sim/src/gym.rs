//! The reinforcement-learning environment of `flc.gym` (`flc/Following-v0`): one episode of the
//! closed loop with the ego's longitudinal command given by a policy ([`Env`]), and many of them
//! stepped in parallel ([`step_envs`]). The single Python environment and the vector one both
//! step this core, so they agree bit for bit.
//!
//! A policy step holds one command over the LiDAR scans of the policy period
//! (`1 / policy_frequency`; [`Simulation::advance`] pauses at each scan) and ends at the first scan
//! at or after the period's end. The reward ([`RewardWeights`]) integrates rates over the physics
//! steps of the policy step, so a run's return does not depend on the policy frequency.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, SimError};
use crate::record::Recorder;
use crate::scenario::Scenario;
use crate::series::Series;
use crate::sim::{DriveCommand, DriveOptions, Simulation};

/// Cap of the `v2v_age` feature of the kinematics observation, s (also its value before any message).
pub const MAX_V2V_AGE: f64 = 10.0;
/// A V2V message at most this old (s) is valid in the kinematics observation.
pub const V2V_FRESH: f64 = 0.5;
/// Cap of the detector observation's `points` feature.
pub const MAX_POINTS: f64 = 1.0e4;

/// What the policy observes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObservationKind {
    /// Detected gap (m; the LiDAR's `max_range` without a detection), its validity flag, own speed
    /// (m/s), the latest V2V lead speed (m/s; 0 before any), its age (s, capped at
    /// [`MAX_V2V_AGE`]) and its validity flag (at most [`V2V_FRESH`] old).
    Kinematics,
    /// `beams` range beams over the LiDAR's field of view, each divided by `max_range`, then own speed.
    Lidar,
    /// The detector's lead (distance, validity, x, y, width, depth, points, confidence) and own speed.
    Detector,
}

/// What the policy commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ActionKind {
    /// An acceleration demand, m/s² ([`DriveCommand::Accel`]).
    Acceleration,
    /// A speed command, m/s ([`DriveCommand::Speed`]).
    Speed,
}

/// The reward's weights. Every term but the collision is a rate (per simulated second),
/// integrated over the physics steps of a policy step, from the ground truth after each physics
/// step (gap `s`, m; own speed `v`, m/s; own acceleration `a`, m/s²; physics step `h`, s):
///
/// * `collision`: `-collision` once, on the policy step of the ego's first contact (an event, not a rate);
/// * `headway`: `-headway * max(0, time_gap - s / max(v, 1 m/s))` per s (per second of
///   headway shortfall);
/// * `comfort`: `-jerk * |j|` per s, with the jerk `j = (a_k - a_{k-1}) / h` (m/s³): integrated,
///   `-jerk * Σ|a_k - a_{k-1}|`, the total variation of the acceleration. The magnitude, not the
///   square: a held command changes the acceleration by a step `Δa` at each decision, and
///   `∫ j² dt` over a step is `Δa² / h` (it depends on the physics step and on how many physics
///   steps the change spreads over, and a finer policy pays it more or less often), while
///   `∫ |j| dt` is `|Δa|` however the change is spread, and the sum over a sampled smooth policy
///   tends to the total variation of the smooth one: the same at any policy frequency;
/// * `progress`: `progress * v / (10 m/s)` per s (`progress` per 10 m driven).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RewardWeights {
    /// Penalty of the first contact.
    pub collision: f64,
    /// Per second of headway shortfall, per second.
    pub headway: f64,
    /// The time gap below which the headway costs, s.
    pub time_gap: f64,
    /// Per m/s³ of jerk, per second (per m/s² of acceleration change).
    pub jerk: f64,
    /// Per 10 m driven.
    pub progress: f64,
}

/// The default comfort weight (per m/s² of acceleration change).
pub const JERK_WEIGHT: f64 = 0.01;

impl Default for RewardWeights {
    fn default() -> Self {
        Self { collision: 100.0, headway: 1.0, time_gap: 1.0, jerk: JERK_WEIGHT, progress: 1.0 }
    }
}

impl RewardWeights {
    /// Every weight finite and non-negative.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (k, v) in [
            ("collision", self.collision),
            ("headway", self.headway),
            ("time_gap", self.time_gap),
            ("jerk", self.jerk),
            ("progress", self.progress),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError::new(format!("reward.{k}"), format!("must be a finite number >= 0, got {v}")));
            }
        }
        Ok(())
    }

    /// The rate terms integrated over rows `from..` of `series` (physics step `h`, s), the row
    /// before `from` having acceleration `prev_accel`.
    pub fn integrate(&self, series: &Series, from: usize, mut prev_accel: f64, h: f64) -> RewardTerms {
        let mut t = RewardTerms::default();
        for i in from..series.len() {
            let (gap, v, a) = (series.gap[i], series.follower_speed[i], series.follower_accel[i]);
            let jerk = (a - prev_accel) / h;
            t.headway -= self.headway * (self.time_gap - gap / v.max(1.0)).max(0.0) * h;
            t.comfort -= self.jerk * jerk.abs() * h;
            t.progress += self.progress * v / 10.0 * h;
            prev_accel = a;
        }
        t
    }
}

/// One policy step's reward, term by term.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RewardTerms {
    /// See [`RewardWeights`].
    pub collision: f64,
    /// See [`RewardWeights`].
    pub headway: f64,
    /// See [`RewardWeights`].
    pub comfort: f64,
    /// See [`RewardWeights`].
    pub progress: f64,
}

impl RewardTerms {
    /// The reward: the sum of the terms.
    pub fn total(&self) -> f64 {
        self.collision + self.headway + self.comfort + self.progress
    }
}

/// The environment's configuration (`flc.gym.FollowingEnv`'s arguments that reach Rust).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvConfig {
    /// The observation.
    pub observation: ObservationKind,
    /// The action.
    pub action: ActionKind,
    /// Decisions per simulated second, Hz.
    pub policy_frequency: f64,
    /// Range beams of [`ObservationKind::Lidar`].
    #[serde(default)]
    pub beams: usize,
    /// The reward.
    #[serde(default)]
    pub reward: RewardWeights,
    /// The action's bounds (actions are clipped into them).
    pub action_low: f32,
    /// See `action_low`.
    pub action_high: f32,
    /// Keep each scan's points (for pictures).
    #[serde(default)]
    pub points: bool,
    /// Record each episode as MCAP into this folder (`<scenario stem>-<episode>.mcap`).
    #[serde(default)]
    pub record: Option<PathBuf>,
}

impl EnvConfig {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.policy_frequency.is_finite() && self.policy_frequency > 0.0) {
            return Err(ConfigError::new("policy_frequency", format!("must be a positive number, got {}", self.policy_frequency)));
        }
        if self.observation == ObservationKind::Lidar && !(1..=100_000).contains(&self.beams) {
            return Err(ConfigError::new("beams", format!("must be in 1..=100000, got {}", self.beams)));
        }
        if !(self.action_low.is_finite() && self.action_high.is_finite() && self.action_low <= self.action_high) {
            return Err(ConfigError::new(
                "action",
                format!("bounds must be finite and ordered, got [{}, {}]", self.action_low, self.action_high),
            ));
        }
        self.reward.validate()
    }

    /// Length of the observation vector.
    pub fn observation_len(&self) -> usize {
        match self.observation {
            ObservationKind::Kinematics => 6,
            ObservationKind::Lidar => self.beams + 1,
            ObservationKind::Detector => 9,
        }
    }

    /// The observation's bounds `(low, high)` (observations are clipped into them).
    pub fn observation_bounds(&self) -> (Vec<f32>, Vec<f32>) {
        let inf = f32::INFINITY;
        match self.observation {
            ObservationKind::Kinematics => (vec![0.0; 6], vec![inf, 1.0, inf, inf, MAX_V2V_AGE as f32, 1.0]),
            ObservationKind::Lidar => {
                let mut high = vec![1.0; self.beams];
                high.push(inf);
                (vec![0.0; self.beams + 1], high)
            }
            ObservationKind::Detector => {
                (vec![-inf, 0.0, -inf, -inf, 0.0, 0.0, 0.0, 0.0, 0.0], vec![inf, 1.0, inf, inf, inf, inf, MAX_POINTS as f32, 1.0, inf])
            }
        }
    }
}

/// What a reset or a step returns besides the observation (the ground truth at its end).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Outcome {
    /// The reward ([`RewardTerms::total`]; 0 after a reset).
    pub reward: f64,
    /// Its terms.
    pub terms: RewardTerms,
    /// A collision, or the scenario's own end (standstill after the lead's script, a stop trigger).
    pub terminated: bool,
    /// The time limit (the scenario's `duration`).
    pub truncated: bool,
    /// Simulation time, s.
    pub t: f64,
    /// Simulated time of the step, s (0 after a reset).
    pub dt: f64,
    /// Bumper gap to the vehicle in front, m.
    pub gap: f64,
    /// Own speed, m/s.
    pub speed: f64,
    /// Own acceleration, m/s².
    pub accel: f64,
    /// Speed of the vehicle in front, m/s.
    pub front_speed: f64,
    /// The ego has touched something (this step or before).
    pub collision: bool,
    /// The detected distance the law would get, m (NaN: no lead detected).
    pub distance: f64,
}

impl Outcome {
    /// Names of [`Outcome::to_row`]'s values, in order.
    pub const FIELDS: [&'static str; 15] = [
        "reward",
        "terminated",
        "truncated",
        "t",
        "dt",
        "gap",
        "speed",
        "accel",
        "front_speed",
        "collision",
        "distance",
        "reward_collision",
        "reward_headway",
        "reward_comfort",
        "reward_progress",
    ];

    /// The outcome as numbers (flags 0 / 1), in [`Outcome::FIELDS`] order.
    pub fn to_row(&self, out: &mut [f64]) {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let v = [
            self.reward,
            flag(self.terminated),
            flag(self.truncated),
            self.t,
            self.dt,
            self.gap,
            self.speed,
            self.accel,
            self.front_speed,
            flag(self.collision),
            self.distance,
            self.terms.collision,
            self.terms.headway,
            self.terms.comfort,
            self.terms.progress,
        ];
        for (o, x) in out.iter_mut().zip(v) {
            *o = x;
        }
    }
}

/// One environment: an episode of the closed loop with follower 1 (the ego) driven by the policy.
pub struct Env {
    cfg: EnvConfig,
    /// [`EnvConfig::observation_bounds`], computed once.
    bounds: (Vec<f32>, Vec<f32>),
    sim: Option<Simulation<Option<Recorder>>>,
    /// Series rows already rewarded.
    rows: usize,
    /// The ego's acceleration at the last rewarded row.
    prev_accel: f64,
    collided: bool,
    /// Time of the scan the policy decides on, s.
    scan_t: f64,
    /// The run is over.
    done: bool,
    /// Episodes started (names the recordings).
    episodes: u64,
}

impl std::fmt::Debug for Env {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Env").field("cfg", &self.cfg).field("episodes", &self.episodes).finish_non_exhaustive()
    }
}

impl Env {
    /// An environment (call [`Env::reset`] before stepping).
    pub fn new(cfg: EnvConfig) -> Result<Self, ConfigError> {
        cfg.validate()?;
        let bounds = cfg.observation_bounds();
        Ok(Self { cfg, bounds, sim: None, rows: 0, prev_accel: 0.0, collided: false, scan_t: 0.0, done: true, episodes: 0 })
    }

    /// The configuration.
    pub fn config(&self) -> &EnvConfig {
        &self.cfg
    }

    /// The episode's simulation (`None` before the first reset).
    pub fn simulation(&self) -> Option<&Simulation<Option<Recorder>>> {
        self.sim.as_ref()
    }

    /// The run is over (or not started).
    pub fn done(&self) -> bool {
        self.done
    }

    /// Starts an episode of `scenario` (validated; its `seed`, `duration` and `physics_dt` as
    /// given) and runs to the first scan that sees the world: the scan at t = 0 comes before the
    /// first physics step and has no returns, so the ego holds its initial speed over that first
    /// scan period. Writes the observation into `obs`.
    pub fn reset(&mut self, scenario: &Scenario, obs: &mut [f32]) -> Result<Outcome, SimError> {
        scenario.validate()?;
        let lidar_rate = scenario.lidar.rate_hz;
        if self.cfg.policy_frequency > lidar_rate + 1e-9 {
            return Err(ConfigError::new(
                "policy_frequency",
                format!("at most the LiDAR's rate ({lidar_rate} Hz), got {}", self.cfg.policy_frequency),
            )
            .into());
        }
        // Finish the previous episode's recording first.
        self.sim = None;
        let base = Simulation::new(scenario)?;
        let rec = match &self.cfg.record {
            None => None,
            Some(dir) => {
                std::fs::create_dir_all(dir).map_err(|e| SimError::File { path: dir.display().to_string(), message: e.to_string() })?;
                let path = dir.join(format!("{}-{:05}.mcap", scenario.run_file_stem(), self.episodes));
                Some(Recorder::for_simulation_file(path, &base)?)
            }
        };
        self.episodes += 1;
        let mut sim = base.with_observer(rec);
        let beams = if self.cfg.observation == ObservationKind::Lidar { self.cfg.beams } else { 0 };
        sim.drive(&[1], DriveOptions { points: self.cfg.points, beams })?;
        let mut paused = sim.advance()?;
        if paused && sim.time() <= 0.0 {
            let v = sim.ground_truth(1).map_or(0.0, |g| g.speed);
            sim.command(1, DriveCommand::Speed(v))?;
            paused = sim.advance()?;
        }
        if !paused {
            sim.finish_observer(true)?;
        }
        let series = sim.series(1).ok_or_else(|| ConfigError::new("drive", "no follower 1"))?;
        self.rows = series.len();
        self.prev_accel = series.follower_accel.last().copied().unwrap_or(0.0);
        self.sim = Some(sim);
        self.done = !paused;
        let mut out = self.outcome(0.0)?;
        self.collided = out.collision;
        out.terminated = false;
        out.truncated = false;
        self.observe(obs)?;
        Ok(out)
    }

    /// Applies `action` (clipped into the action's bounds) over one policy period and writes the
    /// observation at its end into `obs`.
    pub fn step(&mut self, action: f32, obs: &mut [f32]) -> Result<Outcome, SimError> {
        if self.done {
            return Err(ConfigError::new("step", "the episode is over (or not started): reset first").into());
        }
        let sim = self.sim.as_mut().ok_or_else(|| ConfigError::new("step", "reset first"))?;
        let a = f64::from(action.clamp(self.cfg.action_low, self.cfg.action_high));
        let cmd = match self.cfg.action {
            ActionKind::Acceleration => DriveCommand::Accel(a),
            ActionKind::Speed => DriveCommand::Speed(a),
        };
        let until = self.scan_t + 1.0 / self.cfg.policy_frequency;
        let t0 = sim.time();
        let paused = loop {
            sim.command(1, cmd)?;
            let paused = sim.advance()?;
            if !paused || sim.time() >= until - 1e-9 {
                break paused;
            }
        };
        if !paused {
            sim.finish_observer(true)?;
        }
        self.done = !paused;
        let h = sim.scenario().physics_dt;
        let series = sim.series(1).ok_or_else(|| ConfigError::new("drive", "no follower 1"))?;
        let mut terms = self.cfg.reward.integrate(series, self.rows, self.prev_accel, h);
        self.rows = series.len();
        self.prev_accel = series.follower_accel.last().copied().unwrap_or(self.prev_accel);
        let dt = (sim.time() - t0).max(1e-9);
        let duration = sim.scenario().duration;
        let mut out = self.outcome(dt)?;
        let collided_now = out.collision && !self.collided;
        self.collided |= collided_now;
        if collided_now {
            terms.collision = -self.cfg.reward.collision;
        }
        out.terms = terms;
        out.reward = terms.total();
        out.truncated = self.done && !self.collided && out.t >= duration - 0.5 * h;
        out.terminated = self.collided || (self.done && !out.truncated);
        self.observe(obs)?;
        Ok(out)
    }

    /// The ground truth now as an outcome without reward.
    fn outcome(&mut self, dt: f64) -> Result<Outcome, SimError> {
        let sim = self.sim.as_ref().ok_or_else(|| ConfigError::new("step", "reset first"))?;
        let g = sim.ground_truth(1).ok_or_else(|| ConfigError::new("drive", "no follower 1"))?;
        let (m, _, _) = sim.measurement(1).ok_or_else(|| ConfigError::new("drive", "follower 1 is not driven"))?;
        self.scan_t = m.t;
        Ok(Outcome {
            t: g.t,
            dt,
            gap: g.gap,
            speed: g.speed,
            accel: g.accel,
            front_speed: g.front_speed,
            collision: g.collision.is_some(),
            distance: m.distance.unwrap_or(f64::NAN),
            ..Outcome::default()
        })
    }

    /// Writes the observation of the last scan into `obs` ([`EnvConfig::observation_len`] values).
    pub fn observe(&self, obs: &mut [f32]) -> Result<(), SimError> {
        let sim = self.sim.as_ref().ok_or_else(|| ConfigError::new("observe", "reset first"))?;
        let n = self.cfg.observation_len();
        if obs.len() != n {
            return Err(ConfigError::new("observation", format!("buffer of {} values, the observation has {n}", obs.len())).into());
        }
        let (m, _, v2v) = sim.measurement(1).ok_or_else(|| ConfigError::new("drive", "follower 1 is not driven"))?;
        let max_range = sim.scenario().lidar.max_range;
        let own = m.own_speed;
        match self.cfg.observation {
            ObservationKind::Kinematics => {
                let age = v2v.map(|v| sim.time() - v.received_at);
                let fresh = age.is_some_and(|a| a <= V2V_FRESH);
                let v = [
                    m.distance.unwrap_or(max_range),
                    if m.distance.is_some() { 1.0 } else { 0.0 },
                    own,
                    v2v.map_or(0.0, |v| v.message.lead_speed),
                    age.map_or(MAX_V2V_AGE, |a| a.min(MAX_V2V_AGE)),
                    if fresh { 1.0 } else { 0.0 },
                ];
                for (o, x) in obs.iter_mut().zip(v) {
                    *o = x as f32;
                }
            }
            ObservationKind::Lidar => {
                let beams = sim.beams(1).unwrap_or_default();
                let r = max_range as f32;
                for (o, b) in obs.iter_mut().zip(beams.iter().chain(std::iter::repeat(&max_range))) {
                    *o = (*b as f32) / r;
                }
                obs[n - 1] = own as f32;
            }
            ObservationKind::Detector => {
                let v = match (m.detection, m.distance) {
                    (Some(d), Some(dist)) => {
                        [dist, 1.0, d.position.x, d.position.y, d.width, d.depth, (d.points as f64).min(MAX_POINTS), d.confidence, own]
                    }
                    _ => [max_range, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, own],
                };
                for (o, x) in obs.iter_mut().zip(v) {
                    *o = x as f32;
                }
            }
        }
        let (low, high) = &self.bounds;
        for ((o, l), h) in obs.iter_mut().zip(low).zip(high) {
            *o = o.max(*l).min(*h);
        }
        Ok(())
    }
}

/// One call of a vector environment: environment `i` is reset on `resets[i]` if given (its
/// outcome that of the reset: reward 0, neither terminated nor truncated), else stepped with
/// `actions[i]`; observations go into row `i` of `obs` (`envs.len()` rows of
/// [`EnvConfig::observation_len`]), outcomes into `out[i]`. The environments run in parallel on
/// rayon's current pool; each is independent of the others and of the number of threads.
pub fn step_envs(
    envs: &mut [Env],
    actions: &[f32],
    resets: Vec<Option<Scenario>>,
    obs: &mut [f32],
    out: &mut [Outcome],
) -> Result<(), SimError> {
    use rayon::prelude::*;
    let n = envs.len();
    let d = envs.first().map_or(0, |e| e.cfg.observation_len());
    if actions.len() != n || resets.len() != n || out.len() != n || obs.len() != n * d {
        return Err(ConfigError::new("actions", format!("{n} environments: one action, reset and observation row each")).into());
    }
    if n == 1 {
        // One environment: on the calling thread (no hand-over to the pool and back).
        out[0] = match resets.into_iter().next().flatten() {
            Some(s) => envs[0].reset(&s, obs)?,
            None => envs[0].step(actions[0], obs)?,
        };
        return Ok(());
    }
    envs.par_iter_mut()
        .zip(obs.par_chunks_mut(d.max(1)))
        .zip(out.par_iter_mut())
        .zip(resets.into_par_iter())
        .zip(actions.par_iter())
        .map(|((((env, o), r), reset), &a)| {
            *r = match reset {
                Some(s) => env.reset(&s, o)?,
                None => env.step(a, o)?,
            };
            Ok(())
        })
        .collect::<Result<Vec<()>, SimError>>()
        .map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::series::StepRecord;

    #[test]
    fn rates_are_integrated_over_the_rows() {
        // Two physics steps of 0.01 s at 10 m/s, 5 m gap (0.5 s headway), accel 0 then 1 m/s².
        let mut s = Series::default();
        for (t, a) in [(0.01, 0.0), (0.02, 1.0)] {
            s.push(StepRecord { t, gap: 5.0, follower_speed: 10.0, follower_accel: a, ..StepRecord::default() });
        }
        let w = RewardWeights::default();
        let t = w.integrate(&s, 0, 0.0, 0.01);
        assert!((t.progress - 2.0 * 10.0 / 10.0 * 0.01).abs() < 1e-12, "{t:?}");
        assert!((t.headway + 2.0 * 0.5 * 0.01).abs() < 1e-12, "{t:?}");
        // One jerk of 100 m/s³ over 0.01 s: a change of 1 m/s².
        assert!((t.comfort + JERK_WEIGHT * 1.0).abs() < 1e-12, "{t:?}");
        // The same change spread over four physics steps costs the same.
        let mut s4 = Series::default();
        for (k, a) in [0.25, 0.5, 0.75, 1.0].into_iter().enumerate() {
            s4.push(StepRecord { t: 0.01 * (k + 1) as f64, gap: 5.0, follower_speed: 10.0, follower_accel: a, ..StepRecord::default() });
        }
        assert!((w.integrate(&s4, 0, 0.0, 0.01).comfort + JERK_WEIGHT).abs() < 1e-12);
        assert_eq!(t.collision, 0.0);
    }

    #[test]
    fn bad_weights_and_configs_name_the_field() {
        let w = RewardWeights { jerk: -1.0, ..RewardWeights::default() };
        assert_eq!(w.validate().unwrap_err().key, "reward.jerk");
        let cfg = EnvConfig {
            observation: ObservationKind::Lidar,
            action: ActionKind::Speed,
            policy_frequency: 10.0,
            beams: 0,
            reward: RewardWeights::default(),
            action_low: 0.0,
            action_high: 40.0,
            points: false,
            record: None,
        };
        assert_eq!(Env::new(cfg).unwrap_err().key, "beams");
    }
}
