//! MCAP recordings (`flc_sim::record`): read back with the `mcap` crate, the channels carry
//! Foxglove's schemas, the counts follow the scan rate and the physics steps, log times increase,
//! the recorded series is the run's series bit for bit, and a run that stops early (panic, drop,
//! stop flag, SIGINT to the CLI) still leaves a complete file.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use flc_sim::record::{
    self, METADATA_METRICS, METADATA_SCENARIO, TOPIC_COLLISIONS, TOPIC_DETECTOR, TOPIC_LOOKAHEAD, TOPIC_SCAN, TOPIC_STATE, TOPIC_TF,
    TOPIC_TRACK, TOPIC_VEHICLES,
};
use flc_sim::{Calibration, ControllerKind, Scenario};
use flc_sim::{RunOptions, Simulation, run};

fn run_with(s: &Scenario, dir: Option<&Path>) -> Result<flc_sim::RunResult, flc_sim::SimError> {
    RunOptions { record: dir, ..RunOptions::default() }.run(s)
}

fn run_interruptible(s: &Scenario, dir: Option<&Path>, stop: &AtomicBool) -> Result<flc_sim::RunResult, flc_sim::SimError> {
    RunOptions { record: dir, stop: Some(stop), ..RunOptions::default() }.run(s)
}
use foxglove::Encode;
use foxglove::messages::{FrameTransforms, PointCloud, SceneUpdate};

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flc-record-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("mkdir");
    d
}

/// Short pipeline run with a V2V outage at brake onset: switches, NaN v2v ages, detections.
fn short_pipeline() -> Scenario {
    let mut s = Scenario::paper_experiment(30.0, ControllerKind::Pipeline, Calibration::Realistic);
    s.lead.phases[1] = flc_sim::Phase::Hold { until_x: Some(60.0), until_t: None, duration: None }.into();
    s.duration = 25.0;
    s
}

struct Msg {
    topic: String,
    sequence: u32,
    log_time: u64,
    data: Vec<u8>,
}

fn read_all(path: &Path) -> (Vec<Msg>, mcap::Summary) {
    let bytes = std::fs::read(path).expect("read recording");
    // Strict: both magics, every record well-formed.
    let msgs = mcap::MessageStream::new(&bytes)
        .expect("mcap header")
        .map(|m| {
            let m = m.expect("message");
            Msg { topic: m.channel.topic.clone(), sequence: m.sequence, log_time: m.log_time, data: m.data.into_owned() }
        })
        .collect();
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("file has a summary");
    (msgs, summary)
}

fn metadata(path: &Path) -> BTreeMap<String, BTreeMap<String, String>> {
    let bytes = std::fs::read(path).expect("read");
    let mut out = BTreeMap::new();
    for rec in mcap::read::LinearReader::new(&bytes).expect("reader") {
        if let mcap::records::Record::Metadata(m) = rec.expect("record") {
            out.insert(m.name, m.metadata);
        }
    }
    out
}

fn by_topic(msgs: &[Msg]) -> HashMap<&str, Vec<&Msg>> {
    let mut m: HashMap<&str, Vec<&Msg>> = HashMap::new();
    for msg in msgs {
        m.entry(msg.topic.as_str()).or_default().push(msg);
    }
    m
}

fn state_column(msgs: &[&Msg], key: &str) -> Vec<f64> {
    msgs.iter()
        .map(|m| {
            let v: serde_json::Value = serde_json::from_slice(&m.data).expect("json");
            match &v[key] {
                serde_json::Value::Null => f64::NAN,
                x => x.as_f64().unwrap_or_else(|| panic!("{key}: {x}")),
            }
        })
        .collect()
}

/// Equal column by column, bit for bit (NaN == NaN).
fn same_bits(a: &flc_sim::Series, b: &flc_sim::Series) -> bool {
    a.columns()
        .iter()
        .zip(b.columns())
        .all(|((na, ca), (nb, cb))| na == &nb && ca.len() == cb.len() && ca.iter().zip(&cb).all(|(x, y)| x.to_bits() == y.to_bits()))
}

#[test]
fn recording_has_foxglove_schemas_rates_monotonic_times_and_the_run_series() {
    let dir = tmpdir("full");
    let s = short_pipeline();
    let r = run_with(&s, Some(&dir)).expect("run");
    // Recording does not change the run.
    assert!(same_bits(&r.series, &run(&s).expect("run").series), "recording changed the run");
    let path = dir.join(record::recording_file_name(&s));
    assert_eq!(path.file_name().and_then(|n| n.to_str()), Some("paper-realistic-30-pipeline-30kmh.mcap"));
    let (msgs, summary) = read_all(&path);

    // Channels: Foxglove's well-known schemas as the SDK publishes them.
    let proto = |s: Option<foxglove::Schema>| s.expect("schema");
    let expected: [(&str, foxglove::Schema); 7] = [
        (TOPIC_SCAN, proto(PointCloud::get_schema())),
        (TOPIC_DETECTOR, proto(SceneUpdate::get_schema())),
        (TOPIC_LOOKAHEAD, proto(SceneUpdate::get_schema())),
        (TOPIC_TF, proto(FrameTransforms::get_schema())),
        (TOPIC_TRACK, proto(SceneUpdate::get_schema())),
        (TOPIC_VEHICLES, proto(SceneUpdate::get_schema())),
        (TOPIC_COLLISIONS, proto(SceneUpdate::get_schema())),
    ];
    let channels: HashMap<&str, &mcap::Channel> = summary.channels.values().map(|c| (c.topic.as_str(), c.as_ref())).collect();
    assert_eq!(channels.len(), 8, "{:?}", channels.keys());
    for (topic, schema) in &expected {
        let c = channels[topic];
        let got = c.schema.as_ref().expect("channel has a schema");
        assert_eq!(
            (got.name.as_str(), got.encoding.as_str(), c.message_encoding.as_str()),
            (schema.name.as_str(), "protobuf", "protobuf"),
            "{topic}"
        );
        assert_eq!(&got.data[..], &schema.data[..], "{topic}: schema data differs from the SDK's");
    }
    assert_eq!(channels[TOPIC_SCAN].schema.as_ref().map(|s| s.name.as_str()), Some("foxglove.PointCloud"));
    let state = channels[TOPIC_STATE];
    let st = state.schema.as_ref().expect("state schema");
    assert_eq!((st.name.as_str(), st.encoding.as_str(), state.message_encoding.as_str()), ("flc.State", "jsonschema", "json"));
    let js: serde_json::Value = serde_json::from_slice(&st.data).expect("json schema");
    for (name, _) in flc_sim::Series::COLUMNS {
        assert!(js["properties"].get(name).is_some(), "schema lacks {name}");
    }

    // Counts: one state and one /tf per physics step (+ the initial poses), one scan, detector and
    // lookahead update per delivered scan (20 Hz), the static scene once.
    let t = by_topic(&msgs);
    let steps = r.series.len();
    let run_time = r.series.t[steps - 1];
    assert!(steps > 1000, "{steps}");
    assert_eq!(t[TOPIC_STATE].len(), steps);
    assert_eq!(t[TOPIC_TF].len(), steps + 1);
    assert_eq!((t[TOPIC_TRACK].len(), t[TOPIC_VEHICLES].len()), (1, 1));
    let scans = t[TOPIC_SCAN].len();
    assert!((scans as f64 - run_time * s.lidar.rate_hz).abs() <= 1.0, "{scans} scans in {run_time} s");
    assert_eq!(t[TOPIC_DETECTOR].len(), scans);
    assert_eq!(t[TOPIC_LOOKAHEAD].len(), scans);
    let stats = summary.stats.as_ref().expect("statistics");
    assert_eq!(stats.message_count as usize, msgs.len());
    assert!(!summary.chunk_indexes.is_empty(), "chunked with an index");
    assert!(summary.chunk_indexes.iter().all(|c| c.compression == "zstd"), "zstd chunks");

    // Log times increase and sequences count up on every channel; state at the series' times.
    for (topic, list) in &t {
        assert!(list.windows(2).all(|w| w[0].log_time < w[1].log_time), "{topic}: log times not increasing");
        assert!(list.iter().enumerate().all(|(i, m)| m.sequence as usize == i), "{topic}: sequence numbers");
    }
    let times: Vec<u64> = t[TOPIC_STATE].iter().map(|m| m.log_time).collect();
    assert_eq!(times, r.series.t.iter().map(|&x| record::time_ns(x)).collect::<Vec<_>>());

    // The recorded series is the run's series, bit for bit (NaN recorded as null).
    for (name, col) in r.series.columns() {
        let rec = state_column(&t[TOPIC_STATE], name);
        assert_eq!(rec.len(), col.len(), "{name}");
        for (i, (a, b)) in rec.iter().zip(&col).enumerate() {
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{name}[{i}]: recorded {a} vs run {b}");
        }
    }
    assert!(r.series.active.contains(&0) && r.series.active.contains(&1), "the pipeline switched");

    // Scans decode as Foxglove point clouds in the LiDAR frame; the detector saw the lead.
    let clouds: Vec<PointCloud> = t[TOPIC_SCAN].iter().map(|m| foxglove::Decode::decode(&m.data[..]).expect("point cloud")).collect();
    for c in &clouds {
        assert_eq!((c.frame_id.as_str(), c.point_stride, c.fields.len(), c.data.len() % 8), ("lidar", 8, 2, 0));
    }
    assert!(clouds.iter().filter(|c| c.data.len() > 100 * 8).count() > scans / 2, "scans with points");
    let leads = t[TOPIC_DETECTOR]
        .iter()
        .filter(|m| {
            let u: SceneUpdate = foxglove::Decode::decode(&m.data[..]).expect("scene update");
            u.entities.iter().any(|e| e.id == "lead")
        })
        .count();
    assert!(leads > scans / 2, "lead box in {leads} of {scans} scans");
    let tf: FrameTransforms = foxglove::Decode::decode(&t[TOPIC_TF][1].data[..]).expect("tf");
    let pairs: Vec<(&str, &str)> = tf.transforms.iter().map(|x| (x.parent_frame_id.as_str(), x.child_frame_id.as_str())).collect();
    assert_eq!(pairs, [("world", "lead"), ("world", "follower"), ("follower", "lidar")]);
    let x = tf.transforms[1].translation.expect("translation").x;
    assert_eq!(x.to_bits(), r.series.follower_x[0].to_bits());

    // Metadata: the scenario and the metrics of the run.
    let meta = metadata(&path);
    let sc: Scenario = serde_json::from_str(&meta[METADATA_SCENARIO]["scenario"]).expect("scenario json");
    assert_eq!(sc, s);
    let m: serde_json::Value = serde_json::from_str(&meta[METADATA_METRICS]["metrics"]).expect("metrics json");
    assert_eq!(m, serde_json::to_value(&r.metrics).expect("json"));
}

fn assert_partial(path: &Path, steps_at_least: usize) -> usize {
    let (msgs, summary) = read_all(path);
    let t = by_topic(&msgs);
    let n = t.get(TOPIC_STATE).map_or(0, Vec::len);
    assert!(n >= steps_at_least, "{n} steps recorded");
    assert_eq!(t[TOPIC_TF].len(), n + 1);
    assert!(summary.stats.is_some_and(|s| s.message_count as usize == msgs.len()));
    assert!(!metadata(path).contains_key(METADATA_METRICS), "an unfinished run has no metrics");
    n
}

#[test]
fn a_dropped_or_panicking_run_leaves_a_complete_file() {
    // Dropped without finish().
    let dir = tmpdir("drop");
    let s = short_pipeline();
    let sim = Simulation::new(&s).expect("sim");
    let rec = record::Recorder::for_simulation(&dir, &sim).expect("record");
    let path = rec.path().to_path_buf();
    let mut sim = sim.with_observer(rec);
    for _ in 0..300 {
        assert!(sim.step().expect("step"));
    }
    drop(sim);
    assert_eq!(assert_partial(&path, 300), 300);

    // A panic in the middle of the run (unwinding drops the simulation).
    let dir = tmpdir("panic");
    let path = dir.join(record::recording_file_name(&s));
    let d = dir.clone();
    let joined = std::thread::spawn(move || {
        let sim = Simulation::new(&s).expect("sim");
        let rec = record::Recorder::for_simulation(&d, &sim).expect("record");
        let mut sim = sim.with_observer(rec);
        for _ in 0..250 {
            let _ = sim.step();
        }
        panic!("injected failure");
    })
    .join();
    assert!(joined.is_err());
    assert_eq!(assert_partial(&path, 250), 250);
}

#[test]
fn a_stop_flag_ends_the_run_and_finishes_the_file() {
    let dir = tmpdir("stop");
    let s = short_pipeline();
    let stop = AtomicBool::new(false);
    let full = run(&s).expect("run").series.len();
    let r = std::thread::scope(|scope| {
        let h = scope.spawn(|| run_interruptible(&s, Some(&dir), &stop));
        // Stop once the first chunk is on disk (the file grows chunk by chunk), mid-run.
        let path = dir.join(record::recording_file_name(&s));
        while !h.is_finished() && std::fs::metadata(&path).map_or(true, |m| m.len() < 200_000) {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        stop.store(true, Ordering::Relaxed);
        h.join().expect("no panic").expect("run")
    });
    let path = dir.join(record::recording_file_name(&s));
    if r.series.len() < full {
        assert_eq!(assert_partial(&path, 0), r.series.len());
    } else {
        // The machine finished first: a complete recording.
        assert!(metadata(&path).contains_key(METADATA_METRICS));
    }
    // Already set: nothing runs, the file holds the static scene.
    let dir = tmpdir("stop-set");
    let r = run_interruptible(&s, Some(&dir), &AtomicBool::new(true)).expect("run");
    assert!(r.series.is_empty());
    assert_eq!(assert_partial(&dir.join(record::recording_file_name(&s)), 0), 0);
}

#[test]
fn recording_into_an_unwritable_place_is_an_error() {
    let dir = tmpdir("bad");
    let file = dir.join("not-a-dir");
    std::fs::write(&file, "x").expect("write");
    let err = run_with(&short_pipeline(), Some(&file)).expect_err("not a directory");
    assert!(err.to_string().contains("not-a-dir"), "{err}");
}

#[cfg(unix)]
#[test]
fn sigint_to_the_cli_finishes_the_recording() {
    use std::process::{Command, Stdio};
    let dir = tmpdir("sigint");
    // A long steady-following run: minutes of simulated time, several seconds of wall time.
    let cfg = dir.join("long.toml");
    std::fs::write(
        &cfg,
        "name = \"long\"\ncontroller = \"flc\"\nduration = 3000.0\n[track]\nkind = \"straight\"\nlength = 100000.0\n[follower]\ninitial_speed = 20.0\ninitial_gap = 30.0\n[lead]\ninitial_speed = 20.0\n[[lead.phases]]\nkind = \"hold\"\nuntil_t = 3000.0\n[v2v]\nenabled = false\n",
    )
    .expect("write");
    let out = dir.join("rec");
    let mut child = Command::new(env!("CARGO_BIN_EXE_scenario"))
        .arg("--config")
        .arg(&cfg)
        .arg("--record")
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let path = out.join("long-flc.mcap");
    let t0 = std::time::Instant::now();
    while std::fs::metadata(&path).map_or(true, |m| m.len() < 200_000) {
        assert!(t0.elapsed().as_secs() < 120, "no recording data after 120 s");
        assert!(child.try_wait().expect("wait").is_none(), "the run ended before the interrupt");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let killed = Command::new("kill").arg("-INT").arg(child.id().to_string()).status().expect("kill");
    assert!(killed.success());
    let out = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    let n = assert_partial(&path, 100);
    assert!(n < 300_000, "the run went to the end: {n} steps");
}

#[test]
fn a_recording_shows_the_scripted_traffic() {
    // scenarios/cut-in.toml: one scripted car; its body on /vehicles once, its pose every step.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/cut-in.toml");
    let mut s = Scenario::from_file(&path).expect("scenario");
    s.duration = 8.0;
    let dir = tmpdir("traffic");
    let r = run_with(&s, Some(&dir)).expect("run");
    let file = std::fs::read_dir(&dir)
        .expect("dir")
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "mcap"))
        .expect("mcap");
    let (msgs, _) = read_all(&file);
    let t = by_topic(&msgs);
    let bodies: Vec<String> = t[TOPIC_VEHICLES]
        .iter()
        .flat_map(|m| {
            let u: SceneUpdate = foxglove::Decode::decode(&m.data[..]).expect("scene update");
            u.entities.into_iter().map(|e| e.id)
        })
        .collect();
    assert_eq!(bodies, ["lead", "follower", "traffic/cutin"]);
    let poses: Vec<f64> = t[TOPIC_TF]
        .iter()
        .filter_map(|m| {
            let tf: FrameTransforms = foxglove::Decode::decode(&m.data[..]).expect("tf");
            tf.transforms.iter().find(|x| x.child_frame_id == "traffic/cutin").and_then(|x| x.translation.map(|p| p.y))
        })
        .collect();
    assert_eq!(poses.len(), r.series.len());
    // It starts in lane 1 (3.5 m left) and ends in the ego's lane.
    assert!((poses[0] - 3.5).abs() < 0.05 && poses.last().is_some_and(|y| y.abs() < 0.2), "{} -> {:?}", poses[0], poses.last());
}
