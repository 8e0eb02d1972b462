//! MCAP recordings of simulated runs, readable by Foxglove with no configuration
//! (`docs/foxglove.md`).
//!
//! A [`Recorder`] writes one `.mcap` file per run with the `mcap` crate: zstd-compressed chunks,
//! message and chunk indexes, a summary with statistics. Every channel but `/flc/state` uses one of
//! Foxglove's published well-known schemas, as the `foxglove` SDK provides them (protobuf
//! encoding, the SDK's file descriptor sets as schema data). Log times are simulation time in
//! nanoseconds, increasing on every channel, and every channel numbers its messages 0, 1, 2, ...
//!
//! | topic | schema | rate | content |
//! |---|---|---|---|
//! | [`TOPIC_SCAN`] `/lidar/points` | `foxglove.PointCloud` | each delivered scan | the hit points the detector saw (frame `lidar`, `x`, `y` as float32) |
//! | [`TOPIC_DETECTOR`] `/detector` | `foxglove.SceneUpdate` | each scan | the clusters as boxes, one entity per status (`clusters/<status>`, [`CLUSTER_STATUS`]), and the accepted lead box (`lead`), frame `lidar` |
//! | [`TOPIC_LOOKAHEAD`] `/pursuit/lookahead` | `foxglove.SceneUpdate` | each scan | the pure-pursuit lookahead point and the line to it, frame `follower` |
//! | [`TOPIC_TF`] `/tf` | `foxglove.FrameTransforms` | start + each physics step | `world -> lead`, `world -> follower`, `follower -> lidar` |
//! | [`TOPIC_TRACK`] `/track` | `foxglove.SceneUpdate` | once, t = 0 | centreline, lane edges, guard rails, posts, parked cars (frame `world`) |
//! | [`TOPIC_VEHICLES`] `/vehicles` | `foxglove.SceneUpdate` | once, t = 0 | the two vehicle bodies, locked to frames `lead` / `follower` |
//! | [`TOPIC_STATE`] `/flc/state` | `flc.State` (jsonschema, JSON) | each physics step | the run's [`StepRecord`] (NaN as `null`) plus `active_name`, `reason_name` |
//! | [`TOPIC_COLLISIONS`] `/collisions` | `foxglove.SceneUpdate` | at each first contact | a marker at the contact point (frame `world`): entity `collision/follower <k>` for a follower's collision, `contact/<a>/<b>` for a contact without a follower; sphere, normal, label, metadata |
//!
//! The file also carries two metadata records: `flc.scenario` (the scenario as JSON, at the start)
//! and `flc.metrics` (the run's metrics as JSON, written only when the run finished).
//!
//! The simulation thread encodes the messages and a writer thread per recording compresses and
//! writes them, so the compression runs alongside the simulation. The writer is finished on every
//! exit path: [`Recorder::finish`] at the end of a run, and [`Drop`] when the run stops early (an
//! error, a panic, a dropped [`crate::Simulation`]); a run stopped by `RunOptions::stop` (the
//! CLI's Ctrl-C handler) ends with a complete file.
//!
//! The recorder is one [`crate::Observer`] of the loop; the loop does not know it.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, Sender, SyncSender};
use std::thread::JoinHandle;

use flc_core::{ActiveController, ClusterInfo, SwitchReason};
use foxglove::Encode;
use foxglove::messages::{
    Color, CubePrimitive, CylinderPrimitive, FrameTransform, FrameTransforms, KeyValuePair, LinePrimitive, PackedElementField, Point3,
    PointCloud, Pose, Quaternion, SceneEntity, SceneEntityDeletion, SceneUpdate, SpherePrimitive, TextPrimitive, Timestamp, Vector3,
    line_primitive, packed_element_field::NumericType, scene_entity_deletion,
};
use serde::Serialize;

mod scene;
mod state;
mod writer;

pub use scene::CLUSTER_STATUS;
use scene::*;
pub use state::state_json_schema;
use state::*;
use writer::*;

use crate::error::SimError;
use crate::lidar::Scan;
use crate::metrics::{CollisionInfo, ContactRecord, Metrics, Series, StepRecord};
use crate::scenario::Scenario;
use crate::sim::{Observer, Simulation};
use crate::track::{RoadsideObject, Track};
use crate::vehicle::VehicleState;

/// LiDAR hit points, `foxglove.PointCloud` in frame [`FRAME_LIDAR`].
pub const TOPIC_SCAN: &str = "/lidar/points";
/// Detector clusters and the accepted lead box, `foxglove.SceneUpdate` in frame [`FRAME_LIDAR`].
pub const TOPIC_DETECTOR: &str = "/detector";
/// Pure-pursuit lookahead point, `foxglove.SceneUpdate` in frame [`FRAME_FOLLOWER`].
pub const TOPIC_LOOKAHEAD: &str = "/pursuit/lookahead";
/// Vehicle poses and the LiDAR mount, `foxglove.FrameTransforms`.
pub const TOPIC_TF: &str = "/tf";
/// Road outline and road-side objects, `foxglove.SceneUpdate` in frame [`FRAME_WORLD`], once.
pub const TOPIC_TRACK: &str = "/track";
/// Vehicle bodies, `foxglove.SceneUpdate` locked to the vehicle frames, once.
pub const TOPIC_VEHICLES: &str = "/vehicles";
/// Per-step state (the run's [`StepRecord`]), JSON with a JSON schema named [`STATE_SCHEMA`].
pub const TOPIC_STATE: &str = "/flc/state";
/// Contact markers (each follower's first contact, the other pairs' first contacts),
/// `foxglove.SceneUpdate` in frame [`FRAME_WORLD`], one message per contact.
pub const TOPIC_COLLISIONS: &str = "/collisions";
/// Name of the JSON schema of [`TOPIC_STATE`].
pub const STATE_SCHEMA: &str = "flc.State";
/// Fixed frame.
pub const FRAME_WORLD: &str = "world";
/// The lead's body centre (x forward, y left).
pub const FRAME_LEAD: &str = "lead";
/// The follower's body centre (x forward, y left); pure pursuit's frame.
pub const FRAME_FOLLOWER: &str = "follower";
/// The follower's LiDAR (the scan's and the detector's frame).
pub const FRAME_LIDAR: &str = "lidar";
/// Name of the metadata record holding the scenario (key `scenario`, JSON).
pub const METADATA_SCENARIO: &str = "flc.scenario";
/// Name of the metadata record holding the metrics (key `metrics`, JSON), written by
/// [`Recorder::finish`] only.
pub const METADATA_METRICS: &str = "flc.metrics";

/// File name of a run's recording: `<scenario>-<controller>[-<speed_kmh>kmh].mcap`, with
/// characters other than ASCII letters, digits, `.`, `_` and `-` replaced by `_`.
pub fn recording_file_name(scenario: &Scenario) -> String {
    let mut stem = scenario.run_file_stem();
    if let Some(v) = scenario.speed_kmh {
        let speed: String = format!("{v}").chars().map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' }).collect();
        stem.push_str(&format!("-{speed}kmh"));
    }
    format!("{stem}.mcap")
}

/// Simulation time, s, as MCAP log time, ns (negative and non-finite times clamp to 0).
pub fn time_ns(t: f64) -> u64 {
    if t.is_finite() && t > 0.0 { (t * 1e9).round() as u64 } else { 0 }
}

pub(super) fn stamp(ns: u64) -> Timestamp {
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

/// Point coordinates as float32 on a grid of [`POINT_GRID`] m (2^-10 m, about 1 mm; the LiDAR's
/// range noise is 2 cm by default): exact in float32 with the low mantissa bits zero, which zstd
/// compresses well, unlike full-precision floats.
pub(super) fn quantize(v: f64) -> f32 {
    // Round to nearest by adding and removing 1.5 * 2^52 (|v| < 2^41 m); no libm call.
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    let scaled = v * (1.0 / POINT_GRID);
    (((scaled + MAGIC) - MAGIC) * POINT_GRID) as f32
}

/// Grid of the recorded point coordinates, m.
pub const POINT_GRID: f64 = 1.0 / 1024.0;

pub(super) fn io_err(path: &Path, e: impl std::fmt::Display) -> SimError {
    SimError::File { path: path.display().to_string(), message: format!("MCAP recording: {e}") }
}

/// Writes one run as an MCAP file. Created by [`Recorder::for_simulation`]
/// (`RunOptions::record`), fed by the closed loop as its [`Observer`], finished by [`Recorder::finish`]
/// or, if the run stops early, by [`Drop`].
///
/// The simulation thread encodes the messages; a writer thread of the recorder's own compresses
/// (zstd) and writes them, so that the compression overlaps the simulation.
pub struct Recorder {
    tx: Option<SyncSender<Batch>>,
    spare: Receiver<Batch>,
    batch: Batch,
    thread: Option<JoinHandle<mcap::McapResult<()>>>,
    path: PathBuf,
    channels: [Channel; N_CHANNELS],
    mount: (f64, f64, f64),
    fields: Vec<PackedElementField>,
    /// Frames of the scripted vehicles seen so far (`traffic/<name>`).
    traffic_frames: Vec<String>,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder").field("path", &self.path).field("open", &self.tx.is_some()).finish_non_exhaustive()
    }
}

impl Recorder {
    /// Creates `dir` if needed and starts `dir/`[`recording_file_name`]: writes the scenario
    /// metadata, the road and the vehicle bodies, and the vehicles' poses at simulation time `t`
    /// (0 before the first step).
    pub fn create(
        dir: &Path,
        scenario: &Scenario,
        track: &Track,
        t: f64,
        lead: &VehicleState,
        follower: &VehicleState,
    ) -> Result<Self, SimError> {
        std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
        Self::create_file(dir.join(recording_file_name(scenario)), scenario, track, t, lead, follower)
    }

    /// [`Recorder::create`] into the file `path` (its folder must exist).
    pub fn create_file(
        path: PathBuf,
        scenario: &Scenario,
        track: &Track,
        t: f64,
        lead: &VehicleState,
        follower: &VehicleState,
    ) -> Result<Self, SimError> {
        let file = File::create(&path).map_err(|e| io_err(&path, e))?;
        // mcap's defaults (zstd, 1 MiB chunks, message and chunk indexes, statistics, summary
        // offsets, CRCs) but zstd level 2 instead of 3 (the same size on these files, faster),
        // compressing on the writer thread itself (no zstd worker pool).
        let opts = mcap::WriteOptions::new()
            .library(format!("flc-sim {} (mcap-rs)", env!("CARGO_PKG_VERSION")))
            .compression_threads(0)
            .compression_level(2);
        let mut w = opts.create(BufWriter::with_capacity(1 << 16, file)).map_err(|e| io_err(&path, e))?;
        let mut open = || -> mcap::McapResult<[Channel; N_CHANNELS]> {
            let scan = add_channel::<PointCloud>(&mut w, TOPIC_SCAN)?;
            let detector = add_channel::<SceneUpdate>(&mut w, TOPIC_DETECTOR)?;
            let lookahead = add_channel::<SceneUpdate>(&mut w, TOPIC_LOOKAHEAD)?;
            let tf = add_channel::<FrameTransforms>(&mut w, TOPIC_TF)?;
            let track = add_channel::<SceneUpdate>(&mut w, TOPIC_TRACK)?;
            let vehicles = add_channel::<SceneUpdate>(&mut w, TOPIC_VEHICLES)?;
            let schema = w.add_schema(STATE_SCHEMA, "jsonschema", state_json_schema().as_bytes())?;
            let state = Channel { id: w.add_channel(schema, TOPIC_STATE, "json", &BTreeMap::new())?, sequence: 0 };
            let scenario_json = serde_json::to_string(scenario).unwrap_or_default();
            let meta = BTreeMap::from([
                ("scenario".to_string(), scenario_json),
                ("flc_sim_version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
            ]);
            w.write_metadata(&mcap::records::Metadata { name: METADATA_SCENARIO.into(), metadata: meta })?;
            let collisions = add_channel::<SceneUpdate>(&mut w, TOPIC_COLLISIONS)?;
            Ok([scan, detector, lookahead, tf, track, vehicles, state, collisions])
        };
        let channels = open().map_err(|e| io_err(&path, e))?;
        let l = &scenario.lidar;
        let fields = ["x", "y"]
            .iter()
            .zip([0u32, 4])
            .map(|(n, o)| PackedElementField { name: (*n).to_string(), offset: o, r#type: NumericType::Float32 as i32 })
            .collect();
        let (tx, rx) = std::sync::mpsc::sync_channel(QUEUE);
        let (spare_tx, spare) = std::sync::mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("flc-record".into())
            .spawn(move || writer_loop(w, rx, spare_tx))
            .map_err(|e| io_err(&path, e))?;
        let mut rec = Self {
            tx: Some(tx),
            spare,
            batch: Batch::default(),
            thread: Some(thread),
            path,
            channels,
            mount: (l.mount_x, l.mount_y, l.mount_yaw_deg.to_radians()),
            fields,
            traffic_frames: Vec::new(),
        };
        let ns = time_ns(t);
        rec.write(Ch::Track, ns, &SceneUpdate { deletions: vec![], entities: vec![track_entity(ns, track)] })?;
        let (lv, fv) = (&scenario.lead.vehicle, &scenario.follower.vehicle);
        let vehicles = vec![
            vehicle_entity(ns, FRAME_LEAD, lv.length, lv.width, LEAD_COLOR),
            vehicle_entity(ns, FRAME_FOLLOWER, fv.length, fv.width, FOLLOWER_COLOR),
        ];
        rec.write(Ch::Vehicles, ns, &SceneUpdate { deletions: vec![], entities: vehicles })?;
        rec.poses(ns, lead, follower)?;
        Ok(rec)
    }

    /// Starts the recording of `sim` (before its first step, to record the whole run) in `dir`;
    /// a platoon's recording holds the lead and follower 1.
    pub fn for_simulation<O: Observer>(dir: &Path, sim: &Simulation<O>) -> Result<Self, SimError> {
        let follower = sim.follower_state(0).ok_or_else(|| crate::error::ConfigError::new("platoon.followers", "at least one follower"))?;
        Self::create(dir, sim.scenario(), sim.track(), sim.time(), sim.lead_state(), follower)
    }

    /// [`Recorder::for_simulation`] into the file `path` (its folder must exist).
    pub fn for_simulation_file<O: Observer>(path: PathBuf, sim: &Simulation<O>) -> Result<Self, SimError> {
        let follower = sim.follower_state(0).ok_or_else(|| crate::error::ConfigError::new("platoon.followers", "at least one follower"))?;
        Self::create_file(path, sim.scenario(), sim.track(), sim.time(), sim.lead_state(), follower)
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write<T: Encode>(&mut self, ch: Ch, log_ns: u64, msg: &T) -> Result<(), SimError> {
        let start = self.batch.data.len();
        if let Err(e) = msg.encode(&mut self.batch.data) {
            self.batch.data.truncate(start);
            return Err(io_err(&self.path, e));
        }
        self.push_message(ch, log_ns, start)
    }

    /// Queues the message encoded in `batch.data[start..]`.
    fn push_message(&mut self, ch: Ch, log_ns: u64, start: usize) -> Result<(), SimError> {
        let c = &mut self.channels[ch as usize];
        let header = mcap::records::MessageHeader { channel_id: c.id, sequence: c.sequence, log_time: log_ns, publish_time: log_ns };
        c.sequence += 1;
        let end = self.batch.data.len();
        self.push(Item::Message(header, start..end))
    }

    fn push(&mut self, item: Item) -> Result<(), SimError> {
        if self.tx.is_none() {
            return Err(io_err(&self.path, "the recording was already closed"));
        }
        self.batch.items.push(item);
        if self.batch.items.len() >= BATCH_ITEMS || self.batch.data.len() >= BATCH_BYTES { self.flush_batch() } else { Ok(()) }
    }

    fn flush_batch(&mut self) -> Result<(), SimError> {
        let next = self
            .spare
            .try_recv()
            .unwrap_or_else(|_| Batch { data: Vec::with_capacity(BATCH_BYTES + (64 << 10)), items: Vec::with_capacity(BATCH_ITEMS) });
        let batch = std::mem::replace(&mut self.batch, next);
        match &self.tx {
            Some(tx) if tx.send(batch).is_ok() => Ok(()),
            // The writer thread stopped: report why.
            _ => Err(self.close().err().unwrap_or_else(|| io_err(&self.path, "the recording was already closed"))),
        }
    }

    /// Hands over what is batched, closes the queue and waits for the writer thread to finish the
    /// file.
    fn close(&mut self) -> Result<(), SimError> {
        if let Some(tx) = &self.tx {
            if !self.batch.items.is_empty() {
                let _ = tx.send(std::mem::take(&mut self.batch));
            }
        }
        drop(self.tx.take());
        match self.thread.take().map(JoinHandle::join) {
            None | Some(Ok(Ok(()))) => Ok(()),
            Some(Ok(Err(e))) => Err(io_err(&self.path, e)),
            Some(Err(_)) => Err(io_err(&self.path, "the writer thread panicked")),
        }
    }

    fn poses(&mut self, ns: u64, lead: &VehicleState, follower: &VehicleState) -> Result<(), SimError> {
        let (mx, my, myaw) = self.mount;
        let msg = FrameTransforms {
            transforms: vec![
                transform(ns, FRAME_WORLD, FRAME_LEAD, lead.x, lead.y, lead.yaw),
                transform(ns, FRAME_WORLD, FRAME_FOLLOWER, follower.x, follower.y, follower.yaw),
                transform(ns, FRAME_FOLLOWER, FRAME_LIDAR, mx, my, myaw),
            ],
        };
        self.write(Ch::Tf, ns, &msg)
    }

    /// Writes the metrics (if given), the summary and the index, and closes the file.
    pub fn finish(mut self, metrics: Option<&Metrics>) -> Result<PathBuf, SimError> {
        self.finish_in_place(metrics)
    }

    /// [`Recorder::finish`] through a reference (the [`Observer`] end of a run); a second call
    /// is an error.
    fn finish_in_place(&mut self, metrics: Option<&Metrics>) -> Result<PathBuf, SimError> {
        if let Some(m) = metrics {
            let meta = BTreeMap::from([("metrics".to_string(), serde_json::to_string(m).unwrap_or_default())]);
            self.push(Item::Metadata(mcap::records::Metadata { name: METADATA_METRICS.into(), metadata: meta }))?;
        }
        self.close()?;
        Ok(self.path.clone())
    }
}

impl Drop for Recorder {
    /// A run that stopped early still leaves a complete, indexed file (without `flc.metrics`):
    /// the writer thread writes what was queued and finishes the file; errors are ignored here.
    fn drop(&mut self) {
        let _ = self.close();
    }
}

/// The recorder as the loop's sink: follower 1's scans on [`TOPIC_SCAN`], [`TOPIC_DETECTOR`],
/// [`TOPIC_LOOKAHEAD`]; every step on [`TOPIC_TF`] and [`TOPIC_STATE`]; the end as metadata.
impl Observer for Recorder {
    /// One delivered scan at simulation time `t`: the points, the detector's clusters
    /// (`clusters[i].selected` marks the accepted lead; `detected` is the distance the controller
    /// got, m) and the pure-pursuit lookahead point `(x, y)` in the follower's frame, m.
    fn scan(
        &mut self,
        t: f64,
        scan: &Scan,
        clusters: &[ClusterInfo],
        detected: Option<f64>,
        lookahead: (f64, f64),
    ) -> Result<(), SimError> {
        let ns = time_ns(t);
        let captured = stamp(time_ns(scan.t_captured));
        // Points: x, y as float32, 8 bytes each.
        let mut data = vec![0u8; scan.points.len() * 8];
        for (p, out) in scan.points.iter().zip(data.chunks_exact_mut(8)) {
            out[..4].copy_from_slice(&quantize(p[0]).to_le_bytes());
            out[4..].copy_from_slice(&quantize(p[1]).to_le_bytes());
        }
        let cloud = PointCloud {
            timestamp: Some(captured),
            frame_id: FRAME_LIDAR.to_string(),
            pose: Some(pose(0.0, 0.0, 0.0, 0.0)),
            point_stride: 8,
            fields: self.fields.clone(),
            data: data.into(),
        };
        self.write(Ch::Scan, ns, &cloud)?;

        // Clusters (replacing the previous scan's), one entity per status, and the accepted lead.
        let mut groups: [Vec<CubePrimitive>; CLUSTER_STATUS.len()] = Default::default();
        let mut entities = Vec::with_capacity(CLUSTER_STATUS.len() + 1);
        for c in clusters {
            if !(c.x_min.is_finite() && c.x_max.is_finite() && c.y_min.is_finite() && c.y_max.is_finite()) {
                continue;
            }
            let (cx, cy) = (0.5 * (c.x_min + c.x_max), 0.5 * (c.y_min + c.y_max));
            let size = v3((c.x_max - c.x_min).max(0.1), (c.y_max - c.y_min).max(0.1), 1.0);
            let status = match (c.selected, c.rejection) {
                (true, _) => 0,
                (false, None) => 1,
                (false, Some(r)) => CLUSTER_STATUS.iter().position(|(n, _)| *n == r.as_str()).unwrap_or(CLUSTER_STATUS.len() - 1),
            };
            let (_, color) = CLUSTER_STATUS[status];
            groups[status].push(CubePrimitive { pose: Some(pose(cx, cy, 0.0, 0.0)), size: Some(size), color: Some(color) });
            if c.selected {
                let mut lead = entity(ns, FRAME_LIDAR, "lead");
                lead.timestamp = Some(captured);
                let d = detected.unwrap_or(f64::NAN);
                lead.metadata = vec![kv("distance_m", format!("{d:.3}")), kv("points", c.points.to_string())];
                let corners =
                    [[c.x_min, c.y_min], [c.x_max, c.y_min], [c.x_max, c.y_max], [c.x_min, c.y_max]].map(|[x, y]| Point3 { x, y, z: 0.55 });
                lead.lines.push(line(line_primitive::Type::LineLoop, corners.to_vec(), 0.12, rgba(0.1, 1.0, 0.2, 1.0)));
                lead.texts.push(TextPrimitive {
                    pose: Some(pose(c.x_min, cy, 1.8, 0.0)),
                    billboard: true,
                    font_size: 14.0,
                    scale_invariant: true,
                    color: Some(rgba(0.1, 1.0, 0.2, 1.0)),
                    text: format!("lead {d:.2} m"),
                });
                entities.push(lead);
            }
        }
        for ((name, _), cubes) in CLUSTER_STATUS.iter().zip(groups) {
            if !cubes.is_empty() {
                let mut e = entity(ns, FRAME_LIDAR, &format!("clusters/{name}"));
                e.timestamp = Some(captured);
                e.metadata = vec![kv("clusters", cubes.len().to_string())];
                e.cubes = cubes;
                entities.push(e);
            }
        }
        let all = SceneEntityDeletion { timestamp: Some(captured), r#type: scene_entity_deletion::Type::All as i32, id: String::new() };
        self.write(Ch::Detector, ns, &SceneUpdate { deletions: vec![all], entities })?;

        // Lookahead point in the follower frame.
        let (lx, ly) = lookahead;
        let mut e = entity(ns, FRAME_FOLLOWER, "lookahead");
        e.metadata = vec![kv("x_m", format!("{lx:.3}")), kv("y_m", format!("{ly:.3}"))];
        e.spheres.push(SpherePrimitive { pose: Some(pose(lx, ly, 0.3, 0.0)), size: Some(v3(0.6, 0.6, 0.6)), color: Some(LOOKAHEAD_COLOR) });
        e.lines.push(line(
            line_primitive::Type::LineStrip,
            vec![Point3 { x: 0.0, y: 0.0, z: 0.3 }, Point3 { x: lx, y: ly, z: 0.3 }],
            0.05,
            LOOKAHEAD_COLOR,
        ));
        self.write(Ch::Lookahead, ns, &SceneUpdate { deletions: vec![], entities: vec![e] })
    }

    /// One physics step: the vehicles' poses on [`TOPIC_TF`] and the step's record on
    /// [`TOPIC_STATE`], both at `rec.t`.
    fn step(&mut self, rec: &StepRecord, lead: &VehicleState, follower: &VehicleState) -> Result<(), SimError> {
        let ns = time_ns(rec.t);
        self.poses(ns, lead, follower)?;
        let start = self.batch.data.len();
        let msg = StateMessage { step: rec, active_name: active_name(rec.active), reason_name: reason_name(rec.reason) };
        if let Err(e) = serde_json::to_writer(&mut self.batch.data, &msg) {
            self.batch.data.truncate(start);
            return Err(io_err(&self.path, e));
        }
        self.push_message(Ch::State, ns, start)
    }

    /// A scripted vehicle's pose on [`TOPIC_TF`] (frame `traffic/<name>`); the first time, its
    /// body on [`TOPIC_VEHICLES`].
    fn traffic(&mut self, t: f64, index: usize, name: &str, state: &VehicleState, (length, width): (f64, f64)) -> Result<(), SimError> {
        let ns = time_ns(t);
        if index >= self.traffic_frames.len() {
            let frame = format!("traffic/{name}");
            let body = vehicle_entity(ns, &frame, length, width, TRAFFIC_COLOR);
            self.write(Ch::Vehicles, ns, &SceneUpdate { deletions: vec![], entities: vec![body] })?;
            self.traffic_frames.push(frame);
        }
        let frame = self.traffic_frames.get(index).cloned().unwrap_or_default();
        let msg = FrameTransforms { transforms: vec![transform(ns, FRAME_WORLD, &frame, state.x, state.y, state.yaw)] };
        self.write(Ch::Tf, ns, &msg)
    }

    /// A follower's first contact: a marker on [`TOPIC_COLLISIONS`].
    fn collision(&mut self, follower: usize, c: &CollisionInfo) -> Result<(), SimError> {
        let ns = time_ns(c.time);
        let id = format!("collision/follower {follower}");
        let text = format!("follower {follower} hit {} at {:.2} m/s", c.object.label(), c.impact_speed);
        let mut e = contact_entity(ns, &id, c.point, c.normal, text);
        e.metadata.extend([
            kv("object", c.object.label()),
            kv("impact_speed_mps", format!("{:.3}", c.impact_speed)),
            kv("impact_speed_normal_mps", format!("{:.3}", c.impact_speed_normal)),
            kv("follower_speed_mps", format!("{:.3}", c.follower_speed)),
            kv("other_speed_mps", format!("{:.3}", c.other_speed)),
        ]);
        self.write(Ch::Collisions, ns, &SceneUpdate { deletions: vec![], entities: vec![e] })
    }

    /// A contact without a follower: a marker on [`TOPIC_COLLISIONS`].
    fn other_contact(&mut self, c: &ContactRecord) -> Result<(), SimError> {
        let ns = time_ns(c.time);
        let (a, b) = (c.a.label(), c.b.label());
        let id = format!("contact/{a}/{b}");
        let mut e = contact_entity(ns, &id, c.point, c.normal, format!("{a} touched {b} at {:.2} m/s", c.speed));
        e.metadata.push(kv("impact_speed_normal_mps", format!("{:.3}", c.impact_speed_normal)));
        self.write(Ch::Collisions, ns, &SceneUpdate { deletions: vec![], entities: vec![e] })
    }

    fn finish(&mut self, metrics: Option<&Metrics>) -> Result<(), SimError> {
        self.finish_in_place(metrics).map(|_| ())
    }
}
