//! The sweep engine: a grid or a random sample over any scenario fields, run in parallel
//! (rayon), deterministic per run, streamed to CSV as runs finish, resumable.
//!
//! The pieces are public so that a distributed driver (`flc.sweep_file` on Dask,
//! `docs/distributed.md`) runs exactly this engine: [`SweepSpec::points`] expands the runs (ids,
//! seeds), [`SweepPoint`] crosses to a worker as JSON, [`run_point`] runs one and formats its
//! row (a run that fails becomes a row with its `error`), [`open_output`] prepares a CSV for
//! appending and says which ids it already holds.
//!
//! Resuming never serves rows of other inputs: [`inputs_digest`] is a digest of everything the
//! rows ran (the flc version, the columns, every point's id, values and whole scenario, seed
//! included), kept next to the CSV in `<out>.digest` ([`digest_path`]; the Parquet output of
//! `flc.sweep_file` keeps it in every part's metadata). An output whose digest differs from the
//! new sweep's, or that has finished rows but no digest, is refused ([`SimError::StaleOutput`]);
//! `restart` starts it over.
//!
//! A sweep file (TOML, `docs/safety-envelope.md`):
//!
//! ```toml
//! family = "paper"            # base = the paper experiment (or `base = "file.toml"`)
//! calibration = "realistic"
//! mode = "grid"               # or "random" with `samples = N`
//! seed = 1
//! [[axes]]
//! key = "speed_kmh"           # paper family: rebuilds the experiment at this speed
//! values = [30, 50, 70, 90]
//! [[axes]]
//! key = "lead_decel"          # every brake phase's deceleration, m/s²
//! from = 2.0
//! to = 9.0
//! steps = 8
//! [[axes]]
//! key = "lidar.latency_frames"   # any dotted scenario key, `[i]` for list items
//! values = [0, 1, 2]
//! ```

use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::error::{ConfigError, SimError};
use crate::metrics::Metrics;
use crate::paper::Calibration;
use crate::patch::Patch;
use crate::scenario::{ControllerKind, Scenario};

/// One axis of the sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// Dotted scenario key (`lidar.rate_hz`, `lead.phases[2].decel`) or one of the family keys
    /// `speed_kmh`, `lead_decel`, `controller`.
    pub key: String,
    /// Explicit values (numbers, or strings for `controller`).
    #[serde(default)]
    pub values: Option<Vec<Value>>,
    /// Grid: `steps` values from `from` to `to` inclusive. Random: uniform in `[from, to]`.
    #[serde(default)]
    pub from: Option<f64>,
    /// See `from`.
    #[serde(default)]
    pub to: Option<f64>,
    /// Number of grid values (grid mode with `from`/`to`).
    #[serde(default)]
    pub steps: Option<usize>,
}

/// Most axes of a sweep.
pub const MAX_AXES: usize = 32;

/// Most points of a sweep (grid points or random samples), and values of one axis.
pub const MAX_POINTS: usize = 100_000;

/// How points are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Every combination of the axes' values.
    Grid,
    /// `samples` points, each axis drawn independently (uniform or from `values`).
    Random,
}

/// A sweep definition.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// `"paper"`: the base is the paper experiment (enables `speed_kmh`, `lead_decel`, `controller`).
    #[serde(default)]
    pub family: Option<String>,
    /// Calibration of the paper family.
    #[serde(default = "default_calibration")]
    pub calibration: Calibration,
    /// A scenario file as the base (instead of a family), relative to the sweep file.
    #[serde(default)]
    pub base: Option<PathBuf>,
    /// Grid or random.
    #[serde(default = "default_mode")]
    pub mode: Mode,
    /// Number of random samples.
    #[serde(default)]
    pub samples: Option<usize>,
    /// Seed of the sampling and of the runs (run `i` gets a seed derived from it and `i`).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The axes.
    pub axes: Vec<Axis>,
}

fn default_calibration() -> Calibration {
    Calibration::Realistic
}
fn default_mode() -> Mode {
    Mode::Grid
}
fn default_seed() -> u64 {
    1
}

/// One point of a sweep: its index, the axis values and the scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepPoint {
    /// Index in the expanded sweep (stable: the row key for resuming).
    pub id: usize,
    /// `(key, value)` per axis.
    pub values: Vec<(String, Value)>,
    /// The scenario to run.
    pub scenario: Scenario,
}

impl SweepSpec {
    /// Reads a sweep file.
    pub fn from_file(path: &Path) -> Result<(Self, Option<PathBuf>), SimError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SimError::File { path: origin.clone(), message: e.to_string() })?;
        let de = toml::Deserializer::parse(&text)
            .map_err(|e| SimError::File { path: origin.clone(), message: crate::scenario::one_line(&e.to_string()) })?;
        let spec: SweepSpec = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = e.path().to_string();
            let inner = crate::scenario::one_line(&e.into_inner().to_string());
            let key = toml::from_str(&text).ok().and_then(|root| crate::patch::entry_path(&root, &key, &inner)).unwrap_or(key);
            SimError::File { path: origin.clone(), message: format!("`{key}`: {inner}") }
        })?;
        let dir = path.parent().map(Path::to_path_buf);
        Ok((spec, dir))
    }

    /// Number of points, checked before any is built: at most [`MAX_AXES`] axes, [`MAX_POINTS`]
    /// values per axis, samples and grid points.
    fn check_sizes(&self) -> Result<usize, ConfigError> {
        if self.axes.len() > MAX_AXES {
            return Err(ConfigError::new("axes", format!("at most {MAX_AXES} axes, got {}", self.axes.len())));
        }
        let mut grid = 1usize;
        for (i, a) in self.axes.iter().enumerate() {
            let n = match (&a.values, a.steps) {
                (Some(v), _) => (v.len(), "values"),
                (None, Some(n)) => (n, "steps"),
                (None, None) => (1, "steps"),
            };
            if n.0 > MAX_POINTS {
                return Err(ConfigError::new(format!("axes[{i}].{}", n.1), format!("at most {MAX_POINTS} values, got {}", n.0)));
            }
            grid = grid.saturating_mul(n.0);
        }
        match self.mode {
            Mode::Grid if grid > MAX_POINTS => {
                Err(ConfigError::new("axes", format!("the grid has {grid} points, more than the limit of {MAX_POINTS}")))
            }
            Mode::Grid => Ok(grid),
            Mode::Random => match self.samples {
                Some(n) if n > MAX_POINTS => Err(ConfigError::new("samples", format!("must be at most {MAX_POINTS}, got {n}"))),
                Some(n) => Ok(n),
                None => Ok(0),
            },
        }
    }

    fn axis_values(&self, i: usize, a: &Axis) -> Result<Vec<Value>, ConfigError> {
        let key = format!("axes[{i}]");
        if let Some(v) = &a.values {
            if v.is_empty() {
                return Err(ConfigError::new(format!("{key}.values"), "must not be empty"));
            }
            return Ok(v.clone());
        }
        match (a.from, a.to, a.steps) {
            (Some(lo), Some(hi), Some(n)) if n >= 1 && lo.is_finite() && hi.is_finite() => Ok((0..n)
                .map(|k| {
                    let x = if n == 1 { lo } else { lo + (hi - lo) * k as f64 / (n - 1) as f64 };
                    Value::from(x)
                })
                .collect()),
            _ => Err(ConfigError::new(key, "give `values = [...]`, or `from`, `to` and `steps >= 1`")),
        }
    }

    /// Expands the sweep into its points (validated scenarios).
    pub fn points(&self, base_dir: Option<&Path>) -> Result<Vec<SweepPoint>, SimError> {
        if self.axes.is_empty() {
            return Err(ConfigError::new("axes", "give at least one axis").into());
        }
        self.check_sizes()?;
        let base = match (&self.family, &self.base) {
            (Some(f), None) if f == "paper" => None,
            (Some(f), _) => return Err(ConfigError::new("family", format!("must be \"paper\", got `{f}`")).into()),
            (None, Some(p)) => {
                let path = base_dir.map_or(p.clone(), |d| d.join(p));
                Some(Scenario::from_file(&path)?)
            }
            (None, None) => return Err(ConfigError::new("family", "give `family = \"paper\"` or `base = \"scenario.toml\"`").into()),
        };
        let combos: Vec<Vec<(String, Value)>> = match self.mode {
            Mode::Grid => {
                let mut combos: Vec<Vec<(String, Value)>> = vec![Vec::new()];
                for (i, a) in self.axes.iter().enumerate() {
                    let vals = self.axis_values(i, a)?;
                    combos = combos
                        .into_iter()
                        .flat_map(|c| vals.iter().map(move |v| c.iter().cloned().chain([(a.key.clone(), v.clone())]).collect()))
                        .collect();
                }
                combos
            }
            Mode::Random => {
                use rand::{Rng, SeedableRng};
                let n = self.samples.ok_or_else(|| ConfigError::new("samples", "random mode needs `samples`"))?;
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(self.seed);
                let mut out = Vec::with_capacity(n);
                for _ in 0..n {
                    let mut c = Vec::new();
                    for (i, a) in self.axes.iter().enumerate() {
                        let v = match (&a.values, a.from, a.to) {
                            (Some(vals), _, _) if !vals.is_empty() => {
                                vals.get(rng.random_range(0..vals.len())).cloned().unwrap_or(Value::Null)
                            }
                            (_, Some(lo), Some(hi)) if lo <= hi => Value::from(rng.random_range(lo..=hi)),
                            _ => return Err(ConfigError::new(format!("axes[{i}]"), "random mode needs `values` or `from` <= `to`").into()),
                        };
                        c.push((a.key.clone(), v));
                    }
                    out.push(c);
                }
                out
            }
        };
        combos
            .into_iter()
            .enumerate()
            .map(|(id, values)| {
                let scenario = self.build(base.as_ref(), id, &values)?;
                Ok(SweepPoint { id, values, scenario })
            })
            .collect()
    }

    fn build(&self, base: Option<&Scenario>, id: usize, values: &[(String, Value)]) -> Result<Scenario, SimError> {
        let num = |k: &str, v: &Value| v.as_f64().ok_or_else(|| ConfigError::new(k, format!("must be a number, got {v}")));
        let mut s = match base {
            Some(b) => b.clone(),
            None => {
                let speed = values.iter().find(|(k, _)| k == "speed_kmh").map(|(k, v)| num(k, v)).transpose()?.unwrap_or(50.0);
                let controller = match values.iter().find(|(k, _)| k == "controller") {
                    Some((_, v)) => ControllerKind::parse(v.as_str().unwrap_or_default())?,
                    None => ControllerKind::Flc,
                };
                Scenario::paper_experiment(speed, controller, self.calibration)
            }
        };
        let mut patch = Patch::new();
        for (k, v) in values {
            if base.is_none() && (k == "speed_kmh" || k == "controller") {
                continue;
            }
            patch.set_json(k.as_str(), v)?;
        }
        s = s.patched(&patch)?;
        s.seed = run_seed(self.seed, id);
        s.validate()?;
        Ok(s)
    }
}

fn csv_field(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The seed of run `run_id` of a sweep with seed `sweep_seed` (its own SplitMix64 stream), so
/// that any tool enumerating the same grid in the same order (e.g. `flc.envelope.run_grid`)
/// reproduces the sweep's rows exactly.
pub fn run_seed(sweep_seed: u64, run_id: usize) -> u64 {
    crate::sim::sub_seed(sweep_seed, run_id as u64 + 1000)
}

/// A CSV field: as it is, or quoted (RFC 4180) if it holds a comma or a quote; line breaks
/// become spaces (one row = one line, which resuming relies on).
fn csv_text(s: &str) -> String {
    let s = s.replace(['\n', '\r'], " ");
    if s.contains([',', '"']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s }
}

/// One finished row: `run_id, <axes...>, controller, seed, <metrics...>, error`. Without metrics
/// (a run that failed) the metric fields are empty and `error` holds the message.
fn row(point: &SweepPoint, metrics: Option<&Metrics>, error: Option<&str>) -> String {
    let m = metrics.map_or(Value::Null, |m| serde_json::to_value(m).unwrap_or(Value::Null));
    let mut f = vec![point.id.to_string()];
    f.extend(point.values.iter().map(|(_, v)| csv_text(&csv_field(v))));
    if !point.values.iter().any(|(k, _)| k == "controller") {
        f.push(point.scenario.controller.as_str().to_string());
    }
    f.push(point.scenario.seed.to_string());
    f.extend(Metrics::names().iter().map(|k| m.get(k.as_str()).map(csv_field).unwrap_or_default()));
    f.push(error.map(csv_text).unwrap_or_default());
    f.join(",")
}

/// Runs one point and returns its CSV row (no line break) and, if the run succeeded, its result.
/// A run that fails (an error, or a panic caught here) gives a row with empty metrics and the
/// message in `error`: the sweep goes on.
pub fn run_point(point: &SweepPoint) -> (String, Option<crate::RunResult>) {
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| crate::runner::run(&point.scenario)));
    match outcome {
        Ok(Ok(r)) => (row(point, Some(&r.metrics), None), Some(r)),
        Ok(Err(e)) => (row(point, None, Some(&e.to_string())), None),
        Err(panic) => {
            let msg = panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned());
            (row(point, None, Some(&format!("panic: {}", msg.unwrap_or_default()))), None)
        }
    }
}

/// The CSV header for a sweep.
pub fn header(spec: &SweepSpec) -> String {
    let keys: Vec<String> = spec.axes.iter().map(|a| a.key.clone()).collect();
    header_of(&keys)
}

/// The CSV columns for points whose values are named `keys`: `run_id`, the keys, `controller`
/// (unless a key), `seed`, the metrics ([`Metrics::names`]) and `error`.
pub fn columns_of(keys: &[String]) -> Vec<String> {
    let mut h = vec!["run_id".to_string()];
    h.extend(keys.iter().cloned());
    if !keys.iter().any(|k| k == "controller") {
        h.push("controller".into());
    }
    h.push("seed".into());
    h.extend(Metrics::names().iter().cloned());
    h.push("error".into());
    h
}

/// The CSV header for points whose values are named `keys` ([`columns_of`]).
pub fn header_of(keys: &[String]) -> String {
    columns_of(keys).join(",")
}

/// The type (`"u64"`, `"i64"`, `"f64"`, `"bool"`, `"str"`) and unit of every column of
/// [`columns_of`]`(keys)`, in order: an axis is `i64`, `f64` or `bool` if every point's value is
/// one, else `str` (units: km/h for `speed_kmh`, m/s^2 for `lead_decel`, else none); the
/// metrics as [`Metrics::COLUMNS`].
pub fn schema_of(keys: &[String], points: &[SweepPoint]) -> Vec<(String, &'static str, &'static str)> {
    let axis_type = |key: &str| {
        let vals = || points.iter().filter_map(|p| p.values.iter().find(|(k, _)| k == key).map(|(_, v)| v));
        if vals().all(|v| v.is_i64()) {
            "i64"
        } else if vals().all(Value::is_number) {
            "f64"
        } else if vals().all(Value::is_boolean) {
            "bool"
        } else {
            "str"
        }
    };
    columns_of(keys)
        .into_iter()
        .map(|name| {
            let (ty, unit) = match name.as_str() {
                "run_id" | "seed" => ("u64", ""),
                "controller" | "error" if !keys.contains(&name) => ("str", ""),
                k if keys.iter().any(|x| x == k) => {
                    let unit = match k {
                        "speed_kmh" => "km/h",
                        crate::scenario::LEAD_DECEL_KEY => "m/s^2",
                        _ => "",
                    };
                    (axis_type(k), unit)
                }
                k => Metrics::COLUMNS.iter().find(|(n, _, _)| *n == k).map_or(("str", ""), |(_, t, u)| (*t, *u)),
            };
            (name, ty, unit)
        })
        .collect()
}

/// The points of an OpenSCENARIO distribution's runs: ids in file order, the parameter values as
/// strings. Returns the keys (the first run's parameter names) and the points.
pub fn distribution_points(runs: Vec<crate::openscenario::Imported>) -> (Vec<String>, Vec<SweepPoint>) {
    let keys: Vec<String> = runs.first().map(|r| r.params.iter().map(|(k, _)| k.clone()).collect()).unwrap_or_default();
    let points = runs
        .into_iter()
        .enumerate()
        .map(|(id, r)| SweepPoint { id, values: r.params.into_iter().map(|(k, v)| (k, Value::String(v))).collect(), scenario: r.scenario })
        .collect();
    (keys, points)
}

/// The version of flc whose engine writes the rows: part of [`inputs_digest`].
pub const FLC_VERSION: &str = env!("CARGO_PKG_VERSION");

/// The format tag of [`inputs_digest`] (changes if what it covers changes).
const DIGEST_FORMAT: &str = "flc-sweep-inputs/1";

/// FNV-1a with 128 bits, over bytes written into it: a digest that is the same on every
/// platform and Rust version (std's hashers promise neither). For detecting changed inputs,
/// not against an adversary.
struct Fnv1a128(u128);

impl Write for Fnv1a128 {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        const PRIME: u128 = 0x0000_0000_0100_0000_0000_0000_0000_013B;
        for &b in buf {
            self.0 ^= u128::from(b);
            self.0 = self.0.wrapping_mul(PRIME);
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The digest of what a sweep's rows run: the flc version ([`FLC_VERSION`]), the value keys
/// (the columns) and every point in order, id, axis values and whole scenario (seed included) as
/// their JSON. Two sweeps with the same digest write the same rows; any change to the sweep
/// file, a base scenario it reads, an import option or the flc version changes it. The same
/// function serves `scenario sweep` and `flc.sweep_file`: `fnv1a128:` and 32 hex digits.
pub fn inputs_digest(keys: &[String], points: &[SweepPoint]) -> String {
    let mut h = Fnv1a128(0x6c62_272e_07bb_0142_62b8_2175_6295_c58d);
    // Serializing plain data into a writer that never fails cannot fail; were it to, the
    // digest would still be deterministic (the error is the same every time).
    let _ = serde_json::to_writer(&mut h, &(DIGEST_FORMAT, FLC_VERSION, keys, points));
    format!("fnv1a128:{:032x}", h.0)
}

/// Where a sweep CSV keeps the digest of its rows' inputs: `<out>.digest` (a small JSON file:
/// `format`, `flc_version`, `inputs_digest`).
pub fn digest_path(out: &Path) -> PathBuf {
    let mut name = out.file_name().map(std::ffi::OsStr::to_os_string).unwrap_or_default();
    name.push(".digest");
    out.with_file_name(name)
}

/// The record of [`digest_path`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct DigestRecord {
    format: String,
    flc_version: String,
    inputs_digest: String,
}

/// The refusal of an output whose `rows` finished rows may not be this sweep's: `stored` is the
/// digest kept with them (`None`: none), `digest` the new sweep's. `None` if they match. The
/// same words for the CSV and (`flc.sweep_file`) the Parquet output.
pub fn stale_reason(rows: usize, stored: Option<&str>, digest: &str) -> Option<String> {
    match stored {
        Some(s) if s == digest => None,
        Some(s) => Some(format!(
            "its {rows} finished rows ran other inputs than this sweep (the sweep file, a base scenario, an option or the flc version changed: digest {s}, now {digest})"
        )),
        None => Some(format!(
            "it holds {rows} finished rows but no digest of their inputs (written by an older flc, or the digest was removed), so they may not be this sweep's"
        )),
    }
}

/// Ids already present in an existing output file (for resuming): the rows that end with a line
/// break and hold every field (a row cut by an interrupted write is redone).
pub fn finished_ids(out: &Path) -> HashSet<usize> {
    let Ok(text) = std::fs::read_to_string(out) else { return HashSet::new() };
    text.split_inclusive('\n')
        .skip(1)
        .filter_map(|l| l.strip_suffix('\n'))
        .filter(|l| l.split(',').count() >= 2 + Metrics::names().len())
        .filter_map(|l| l.split(',').next().and_then(|id| id.parse().ok()))
        .collect()
}

/// Prepares `out` for appending the rows of points named `keys`, whose inputs have the digest
/// `digest` ([`inputs_digest`]), and returns the ids it already holds ([`finished_ids`]).
///
/// A missing file, one without finished rows, or any file with `restart`, is written anew with
/// the header, and its digest into [`digest_path`]. A file with finished rows resumes only if
/// its digest is `digest`: otherwise, or without a digest, it is refused
/// ([`SimError::StaleOutput`], nothing written). A cut last line (an interrupted write) is
/// dropped. The file is not locked: one writer per output.
pub fn open_output(out: &Path, keys: &[String], digest: &str, restart: bool) -> Result<(std::fs::File, HashSet<usize>), SimError> {
    let done = if restart { HashSet::new() } else { finished_ids(out) };
    let record_path = digest_path(out);
    if done.is_empty() {
        let mut file = std::fs::File::create(out)?;
        writeln!(file, "{}", header_of(keys))?;
        let record = DigestRecord { format: DIGEST_FORMAT.into(), flc_version: FLC_VERSION.into(), inputs_digest: digest.into() };
        let text = serde_json::to_string(&record)
            .map_err(|e| SimError::File { path: record_path.display().to_string(), message: e.to_string() })?;
        std::fs::write(&record_path, text + "\n")?;
        return Ok((file, done));
    }
    let stored = std::fs::read_to_string(&record_path).ok().and_then(|t| serde_json::from_str::<DigestRecord>(&t).ok());
    if let Some(reason) = stale_reason(done.len(), stored.as_ref().map(|r| r.inputs_digest.as_str()), digest) {
        return Err(SimError::StaleOutput { path: out.display().to_string(), reason });
    }
    let text = std::fs::read(out)?;
    let keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let file = std::fs::OpenOptions::new().append(true).open(out)?;
    if keep < text.len() {
        file.set_len(keep as u64)?;
    }
    Ok((file, done))
}

/// Runs the points not yet in `out`, appending one CSV row per finished run (flushed as it
/// finishes). Resumes only an output of the same inputs ([`open_output`]); `restart` starts it
/// over. Returns the number of runs done now.
pub fn run_sweep(spec: &SweepSpec, points: &[SweepPoint], out: &Path, progress: bool, restart: bool) -> Result<usize, SimError> {
    let keys: Vec<String> = spec.axes.iter().map(|a| a.key.clone()).collect();
    run_points(&keys, points, out, progress, restart)
}

/// Runs `points` (their values named `keys`, the CSV's columns after `run_id`) in parallel,
/// streaming one row per finished run into `out` and skipping the ids already there, as
/// [`run_sweep`] does; also the engine of OpenSCENARIO `ParameterValueDistribution` files
/// (the keys are their parameters). A run that fails is a row with its `error`. An output of
/// other inputs is refused unless `restart` ([`open_output`]). Returns the number of runs done.
pub fn run_points(keys: &[String], points: &[SweepPoint], out: &Path, progress: bool, restart: bool) -> Result<usize, SimError> {
    use rayon::prelude::*;
    let digest = inputs_digest(keys, points);
    let (file, done) = open_output(out, keys, &digest, restart)?;
    let todo: Vec<&SweepPoint> = points.iter().filter(|p| !done.contains(&p.id)).collect();
    let writer = Mutex::new(std::io::BufWriter::new(file));
    let bar = progress.then(|| crate::runner::progress_bar(todo.len(), "runs"));
    let results: Vec<Result<(), SimError>> = todo
        .par_iter()
        .map(|p| {
            let (line, _) = run_point(p);
            let mut w = writer.lock().map_err(|_| SimError::File { path: out.display().to_string(), message: "writer poisoned".into() })?;
            writeln!(w, "{line}")?;
            w.flush()?;
            if let Some(b) = &bar {
                b.inc(1);
            }
            Ok(())
        })
        .collect();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    results.into_iter().collect::<Result<Vec<_>, _>>()?;
    sort_output(out)?;
    Ok(todo.len())
}

/// Puts the rows of a finished sweep CSV in `run_id` order (rows are appended as runs finish, in
/// any order): the header and any lines before the first row stay first, the rows follow sorted
/// by id (stable), lines without an id after them. Written to a temporary file beside `out` and
/// renamed over it; a file already in order is not touched. Resuming reads ids, not positions,
/// so a sorted file resumes as before.
pub fn sort_output(out: &Path) -> Result<(), SimError> {
    let text = std::fs::read_to_string(out)?;
    let id = |l: &str| l.split(',').next().and_then(|f| f.parse::<usize>().ok());
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    let first = lines.iter().skip(1).position(|l| id(l).is_some()).map_or(lines.len(), |i| i + 1);
    let (head, body) = lines.split_at(first);
    let mut rows: Vec<(usize, &str)> = body.iter().filter_map(|l| id(l).map(|i| (i, *l))).collect();
    if rows.windows(2).all(|w| w[0].0 <= w[1].0) {
        return Ok(());
    }
    rows.sort_by_key(|(i, _)| *i);
    let tmp = out.with_extension("sorting.tmp");
    {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        for l in head.iter().copied().chain(rows.iter().map(|(_, l)| *l)).chain(body.iter().copied().filter(|l| id(l).is_none())) {
            w.write_all(l.as_bytes())?;
        }
        w.flush()?;
    }
    std::fs::rename(&tmp, out)?;
    Ok(())
}
