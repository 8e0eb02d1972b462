//! Followers driven from outside the loop (Python's `flc.Simulation` and `flc.gym`): the loop
//! stays the one of [`super::Simulation`]; for a driven follower each delivered scan runs the
//! detector, the lateral control and builds the law's [`Frame`], then the loop pauses
//! ([`super::Simulation::advance`]) so that the caller reads what the pipeline got
//! ([`Measurement`]) and the ground truth ([`GroundTruth`]), and sets the longitudinal command
//! ([`DriveCommand`]) before the rest of the physics step runs.

use flc_core::{Detection, DetectorOutput, DetectorStatus, Frame, V2vMessage};

use crate::lidar::LidarParams;
use crate::metrics::CollisionInfo;

/// The longitudinal command of a driven follower for one control period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum DriveCommand {
    /// The scenario's own law steps on the frame of this scan (what `flc.run` does).
    #[default]
    Law,
    /// A speed command, m/s, held until the next command like the law's (the low-level speed
    /// controller and the vehicle model turn it into motion).
    Speed(f64),
    /// An acceleration demand, m/s², held until the next command: it replaces the low-level
    /// speed controller's output (drive / brake demand), so the vehicle model's dead time, lag,
    /// limits and driving resistance still apply.
    Accel(f64),
}

/// What the observation of a driven follower carries besides its pipeline's frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriveOptions {
    /// Copy the raw LiDAR points of each scan (sensor frame, m) into [`Measurement::points`].
    pub points: bool,
    /// Reduce a scan to this many range beams on request ([`super::Simulation::beams`]; 0:
    /// none): the LiDAR's field of view cut into equal angular sectors, each the nearest return in
    /// it (the LiDAR's `max_range` when it has none), as highway-env's `LidarObservation` does.
    pub beams: usize,
}

/// What a driven follower's pipeline got at its last delivered scan.
#[derive(Debug, Clone, Default)]
pub struct Measurement {
    /// Simulation time of the scan's delivery, s.
    pub t: f64,
    /// The distance the longitudinal law gets (`LF_dist`: the detector's distance minus the
    /// follower's `distance_offset`, the bumper gap), m; `None`: no lead detected.
    pub distance: Option<f64>,
    /// Own speed as the law gets it, m/s.
    pub own_speed: f64,
    /// Time since the previous scan, s (the law's `dt`).
    pub dt: f64,
    /// The front vehicle's speed, m/s: only with ideal perception (validation), else `None`.
    pub lead_speed: Option<f64>,
    /// The V2V message received since the previous scan (what the PID family gets), if any.
    pub v2v: Option<V2vMessage>,
    /// The detector's lead (sensor frame), if any.
    pub detection: Option<Detection>,
    /// The detector's status.
    pub status: Option<DetectorStatus>,
    /// Clusters the detector found.
    pub clusters: usize,
    /// Raw points of the scan (with [`DriveOptions::points`] or [`DriveOptions::beams`]),
    /// sensor frame, m.
    pub points: Vec<[f64; 2]>,
}

/// The latest V2V message a driven follower received and when.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct V2vSeen {
    /// The message.
    pub message: V2vMessage,
    /// Simulation time of its arrival, s.
    pub received_at: f64,
}

/// The ground truth about a follower now (for evaluation and rewards, never for control).
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTruth {
    /// Simulation time, s.
    pub t: f64,
    /// Bumper-to-bumper gap to the vehicle in front, m.
    pub gap: f64,
    /// Speed of the vehicle in front, m/s.
    pub front_speed: f64,
    /// Acceleration of the vehicle in front, m/s².
    pub front_accel: f64,
    /// Own speed, m/s.
    pub speed: f64,
    /// Own acceleration, m/s².
    pub accel: f64,
    /// World position `(x, y)`, m, and yaw, rad.
    pub pose: (f64, f64, f64),
    /// Lateral offset from the track's centreline, m (+ left).
    pub lateral_offset: f64,
    /// Its first contact with anything, if any so far.
    pub collision: Option<CollisionInfo>,
}

/// A driven follower's state between scans.
#[derive(Debug, Clone)]
pub(crate) struct Driven {
    opts: DriveOptions,
    fov: f64,
    max_range: f64,
    /// The frame of a scan delivered this step, waiting for the command.
    pub(super) pending: Option<Frame>,
    /// The command set for this step (taken by `Follower::resume`).
    pub(super) command: DriveCommand,
    /// What the last scan gave.
    pub(super) last: Measurement,
    /// The latest V2V message and its arrival.
    pub(super) v2v: Option<V2vSeen>,
}

impl Driven {
    pub(super) fn new(opts: DriveOptions, lidar: &LidarParams) -> Self {
        Self {
            opts,
            fov: lidar.fov_deg.to_radians(),
            max_range: lidar.max_range,
            pending: None,
            command: DriveCommand::Law,
            last: Measurement::default(),
            v2v: None,
        }
    }

    /// A V2V message arrived at `t`.
    pub(super) fn received(&mut self, t: f64, message: V2vMessage) {
        self.v2v = Some(V2vSeen { message, received_at: t });
    }

    /// A scan delivered at `t`: keeps the frame for the command and what the pipeline got.
    pub(super) fn hold(&mut self, t: f64, frame: Frame, det: &DetectorOutput, points: &[[f64; 2]]) {
        let m = &mut self.last;
        (m.t, m.distance, m.own_speed, m.dt, m.lead_speed, m.v2v) =
            (t, frame.distance, frame.own_speed, frame.dt, frame.lead_speed, frame.v2v);
        (m.detection, m.status, m.clusters) = (det.detection, Some(det.status), det.clusters);
        m.points.clear();
        if self.opts.points || self.opts.beams > 0 {
            m.points.extend_from_slice(points);
        }
        self.pending = Some(frame);
    }

    /// The last scan as [`DriveOptions::beams`] range beams (computed now: a decision held over
    /// several scans pays for the beams of the scans it reads only).
    pub(super) fn beams(&self) -> Vec<f64> {
        let mut out = Vec::new();
        if self.opts.beams > 0 {
            beams(&self.last.points, self.opts.beams, self.fov, self.max_range, &mut out);
        }
        out
    }
}

/// `n` range beams of a scan (sensor frame points): the field of view `fov` (rad, centred on
/// the x axis) cut into `n` equal sectors, each the nearest return in it, `max_range` without.
pub(crate) fn beams(points: &[[f64; 2]], n: usize, fov: f64, max_range: f64, out: &mut Vec<f64>) {
    out.clear();
    out.resize(n, max_range);
    let half = fov / 2.0;
    let width = fov / n as f64;
    for &[x, y] in points {
        let a = y.atan2(x);
        if !(a >= -half && a <= half) {
            continue;
        }
        let i = (((a + half) / width) as usize).min(n - 1);
        let r = x.hypot(y);
        if r < out[i] {
            out[i] = r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beams_take_the_nearest_return_per_sector() {
        let fov = 90f64.to_radians();
        // Four sectors of 22.5 deg from -45 deg: a point straight ahead falls into sector 2.
        let pts = [[10.0, 0.0], [5.0, 0.0], [10.0, -9.0], [1.0, 100.0]];
        let mut out = Vec::new();
        beams(&pts, 4, fov, 200.0, &mut out);
        assert_eq!(out.len(), 4);
        assert_eq!(out[2], 5.0);
        assert!((out[0] - 10f64.hypot(9.0)).abs() < 1e-12, "{out:?}");
        assert_eq!(out[1], 200.0);
        assert_eq!(out[3], 200.0, "a point outside the field of view is no return");
    }
}
