//! Bindings of the simulator: scenarios as JSON, `run` and `sweep` with the GIL released.

use std::path::PathBuf;

use flc_sim::Series;
use flc_sim::report::PlatoonRecord;
use flc_sim::{Calibration, ControllerKind, Scenario};
use flc_sim::{RunResult, SimError};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::{ScenarioError, SimulationError, array, from_json, to_json};

pub(crate) fn scenario_err(e: SimError) -> PyErr {
    match e {
        SimError::Config(_) | SimError::File { .. } | SimError::Param(_) | SimError::Input(_) => ScenarioError::new_err(e.to_string()),
        other => SimulationError::new_err(other.to_string()),
    }
}

pub(crate) fn parse_scenario(json: &str) -> PyResult<Scenario> {
    let s: Scenario = from_json(json, "scenario").map_err(|e| ScenarioError::new_err(e.to_string()))?;
    s.validate().map_err(|e| ScenarioError::new_err(format!("scenario: {e}")))?;
    Ok(s)
}

/// The paper experiment as scenario JSON.
#[pyfunction]
fn paper_scenario(speed_kmh: f64, controller: &str, preset: &str) -> PyResult<String> {
    flc_sim::paper::check_speed_kmh("speed_kmh", speed_kmh).map_err(|e| ScenarioError::new_err(e.to_string()))?;
    let (c, p) = controller_and_preset(controller, preset)?;
    to_json(&Scenario::paper_experiment(speed_kmh, c, p))
}

/// The curved-route run of the paper's tracking errors (`Scenario::paper_tracking`, what
/// `scenario` prints under its table) as scenario JSON.
#[pyfunction]
fn paper_tracking_scenario(controller: &str, preset: &str) -> PyResult<String> {
    let (c, p) = controller_and_preset(controller, preset)?;
    to_json(&Scenario::paper_tracking(c, p))
}

fn controller_and_preset(controller: &str, preset: &str) -> PyResult<(ControllerKind, Calibration)> {
    // The registry's error names the key already (`controller`: ...).
    let c = ControllerKind::parse(controller).map_err(|e| ScenarioError::new_err(e.to_string()))?;
    let p = match preset {
        "realistic" => Calibration::Realistic,
        "paper" => Calibration::Paper,
        other => return Err(ScenarioError::new_err(format!("`preset`: must be realistic or paper, got `{other}`"))),
    };
    Ok((c, p))
}

/// Reads a TOML scenario file and returns it as JSON.
#[pyfunction]
fn load_scenario(path: PathBuf) -> PyResult<String> {
    to_json(&Scenario::from_file(&path).map_err(scenario_err)?)
}

/// One imported run as Python gets it: the scenario's JSON and its parameter values as a JSON
/// list of `[name, value]` pairs, each value typed by its declaration (number, integer, boolean,
/// text; `flc_sim::openscenario::Imported::typed_params`).
type ImportedRun = (String, String);

/// Imports an OpenSCENARIO file (`flc_sim::openscenario::import`): one `(scenario JSON,
/// parameter values)` per run (a `ParameterValueDistribution` has one per combination). Bad
/// files and options raise `ScenarioError` naming the file, line and element, or the option.
#[pyfunction]
#[pyo3(signature = (path, params, ego, ego_mode, road, traffic_dynamics, controller, strict=false))]
#[allow(clippy::too_many_arguments)]
fn import_openscenario(
    path: PathBuf,
    params: Vec<(String, String)>,
    ego: Option<String>,
    ego_mode: &str,
    road: &str,
    traffic_dynamics: &str,
    controller: Option<&str>,
    strict: bool,
) -> PyResult<Vec<ImportedRun>> {
    let opts = flc_sim::openscenario::ImportOptions::from_words(params, ego, ego_mode, road, traffic_dynamics, controller)
        .map_err(|e| ScenarioError::new_err(e.to_string()))?;
    let opts = flc_sim::openscenario::ImportOptions { strict, ..opts };
    let import = flc_sim::openscenario::import(&path, &opts).map_err(|e| ScenarioError::new_err(e.to_string()))?;
    import.runs.into_iter().map(|r| Ok((to_json(&r.scenario)?, to_json(&r.typed_params)?))).collect()
}

/// Runs standard test suites (`flc_sim::suite`, GIL released): `name` is `ncap-ccr`, `r157`,
/// `all` or a folder with a `suite.toml`; `root` the folder of the named suites (`flc.run_suite`
/// passes the package's own; without it, `flc_sim::suite::default_root`). Returns one report per suite as JSON
/// (`flc_sim::suite::SuiteReport`). An unknown suite or controller raises `ScenarioError`.
#[pyfunction]
#[pyo3(signature = (name, controllers=None, root=None))]
fn run_suite(py: Python<'_>, name: &str, controllers: Option<Vec<String>>, root: Option<PathBuf>) -> PyResult<Vec<String>> {
    let kinds = match controllers {
        None => ControllerKind::ALL.to_vec(),
        Some(list) => list
            .iter()
            .map(|c| ControllerKind::parse(c))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ScenarioError::new_err(e.to_string()))?,
    };
    let root = match root {
        Some(r) => r,
        None => flc_sim::suite::default_root().map_err(scenario_err)?,
    };
    let suites = flc_sim::suite::Suite::find(&root, name).map_err(scenario_err)?;
    let reports = py.detach(|| suites.iter().map(|s| s.run(&kinds)).collect::<Result<Vec<_>, _>>()).map_err(scenario_err)?;
    Ok(reports.iter().map(flc_sim::suite::SuiteReport::to_json).collect())
}

/// Validates scenario JSON (defaults filled in) and returns the normalised JSON.
#[pyfunction]
fn check_scenario(json: &str) -> PyResult<String> {
    to_json(&parse_scenario(json)?)
}

/// The speeds (km/h) the paper experiment takes, inclusive (`flc_sim::paper::SPEED_RANGE_KMH`).
#[pyfunction]
fn paper_speed_range_kmh() -> (f64, f64) {
    flc_sim::paper::SPEED_RANGE_KMH
}

/// The controller names a scenario accepts (`controller = "..."`), in the registry's order
/// (`flc_sim::ControllerKind::ALL`).
#[pyfunction]
fn controller_names() -> Vec<&'static str> {
    ControllerKind::ALL.iter().map(|k| k.as_str()).collect()
}

/// The sections of a scenario (top-level tables: `follower`, `lidar`, `flc`, ...); a keyword
/// `<section>_<key>` overrides `[section] key` (`flc_sim::Scenario::section_names`).
#[pyfunction]
fn section_names() -> Vec<String> {
    Scenario::section_names()
}

/// The dotted key a keyword override names: `lidar_rate_hz` -> `lidar.rate_hz`; dotted keys and
/// the family key `lead_decel` unchanged (`flc_sim::Scenario::resolve_key`).
#[pyfunction]
fn resolve_key(name: &str) -> String {
    Scenario::resolve_key(name)
}

/// Scenario JSON with keyword overrides applied in order, validated, as normalised JSON.
/// `overrides_json` is a JSON list of `[name, value]` pairs (names as `resolve_key` takes them,
/// `lead_decel` = every brake phase's deceleration); errors are `ScenarioError`s naming the key
/// (`flc_sim::Scenario::with_overrides`), except a name that is no scenario key at all: a
/// `TypeError`, as Python raises for any unexpected keyword argument.
#[pyfunction]
fn apply_overrides(scenario_json: &str, overrides_json: &str) -> PyResult<String> {
    let bad = |e: PyErr| ScenarioError::new_err(e.to_string());
    let s: Scenario = from_json(scenario_json, "scenario").map_err(bad)?;
    let overrides: Vec<(String, serde_json::Value)> = from_json(overrides_json, "overrides").map_err(bad)?;
    let out = s.with_overrides(&overrides).map_err(|e| match Scenario::unknown_top_level_key(&e) {
        // A keyword that names nothing in a scenario is an unexpected keyword argument.
        Some(name) => PyTypeError::new_err(format!("unexpected keyword argument `{name}`: not a scenario key ({})", e.problem)),
        None => ScenarioError::new_err(e.to_string()),
    })?;
    to_json(&out)
}

/// What a run returns to Python: metrics JSON, `{column: 1-D array}` (follower 1), for a
/// platoon `(platoon JSON, {column: 2-D array (n_followers, n_steps)})`, and the contacts JSON
/// `{"collision": follower 1's first contact or null, "other_contacts": [...]}`.
pub(crate) type RunTuple<'py> = (String, Bound<'py, PyDict>, Option<(String, Bound<'py, PyDict>)>, String);

/// The contacts of a run as Python receives them (see `RunTuple`).
#[derive(serde::Serialize)]
struct Contacts<'a> {
    collision: Option<&'a flc_sim::CollisionInfo>,
    other_contacts: &'a [flc_sim::ContactRecord],
}

pub(crate) fn result_to_py<'py>(py: Python<'py>, r: RunResult) -> PyResult<RunTuple<'py>> {
    let metrics = to_json(&r.metrics)?;
    let contacts = to_json(&Contacts { collision: r.collision.as_ref(), other_contacts: &r.other_contacts })?;
    let d = PyDict::new(py);
    for (name, col) in r.series.columns() {
        d.set_item(name, array(py, col))?;
    }
    let platoon = match (PlatoonRecord::of(&r), r.platoon.as_ref()) {
        (Some(record), Some(p)) => {
            let pd = PyDict::new(py);
            let per_follower: Vec<Vec<(&'static str, Vec<f64>)>> = p.followers.iter().map(|f| f.series.columns()).collect();
            for (j, (name, _)) in Series::COLUMNS.iter().enumerate() {
                let rows: Vec<Vec<f64>> = per_follower.iter().map(|cols| cols.get(j).map(|c| c.1.clone()).unwrap_or_default()).collect();
                pd.set_item(*name, array2(py, &rows)?)?;
            }
            let sig = &p.signals;
            pd.set_item("gap_error", array2(py, &sig.gap_error)?)?;
            pd.set_item("speed_error", array2(py, &sig.speed_error)?)?;
            Some((to_json(&record)?, pd))
        }
        _ => None,
    };
    Ok((metrics, d, platoon, contacts))
}

fn array2<'py>(py: Python<'py>, rows: &[Vec<f64>]) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    numpy::PyArray2::from_vec2(py, rows).map_err(|e| SimulationError::new_err(e.to_string()))
}

/// The scenarios a file's `[[variants]]` expand to, as JSON (the scenario itself without any).
#[pyfunction]
fn expand_variants(scenario_json: &str) -> PyResult<Vec<String>> {
    let s = parse_scenario(scenario_json)?;
    let list = s.expand_variants().map_err(|e| ScenarioError::new_err(format!("scenario: {e}")))?;
    list.iter().map(to_json).collect()
}

/// The platoon brake demo (`scenarios/platoon-brakedemo.toml`) as scenario JSON.
#[pyfunction]
fn brakedemo_scenario() -> PyResult<String> {
    to_json(&flc_sim::presets::brakedemo())
}

/// `|Gamma(jw)|` of a platoon scenario at `freqs_hz` (default: its
/// `platoon.string_stability.frequencies_hz`): one sine run per frequency, in parallel, GIL
/// released. Returns the JSON list of points.
#[pyfunction]
#[pyo3(signature = (scenario_json, freqs_hz=None))]
fn frequency_response(py: Python<'_>, scenario_json: &str, freqs_hz: Option<Vec<f64>>) -> PyResult<String> {
    let s = parse_scenario(scenario_json)?;
    let freqs = freqs_hz.unwrap_or_else(|| s.platoon.as_ref().map(|p| p.string_stability.frequencies_hz.clone()).unwrap_or_default());
    let points = py.detach(|| flc_sim::frequency_response::frequency_response_at(&s, &freqs)).map_err(scenario_err)?;
    to_json(&points)
}

/// Runs one scenario (GIL released). Returns `(metrics_json, {column: ndarray}, platoon,
/// contacts_json)` with `platoon = (platoon_json, {column: 2-D ndarray})` or `None` (see `RunTuple`).
#[pyfunction]
#[pyo3(signature = (scenario_json, record=None))]
fn run<'py>(py: Python<'py>, scenario_json: &str, record: Option<PathBuf>) -> PyResult<RunTuple<'py>> {
    let s = parse_scenario(scenario_json)?;
    let r =
        py.detach(|| flc_sim::RunOptions { record: record.as_deref(), ..flc_sim::RunOptions::default() }.run(&s)).map_err(scenario_err)?;
    result_to_py(py, r)
}

/// Runs many scenarios in parallel in Rust (GIL released); results in input order.
#[pyfunction]
#[pyo3(signature = (scenarios_json, threads=None))]
fn sweep<'py>(py: Python<'py>, scenarios_json: Vec<String>, threads: Option<usize>) -> PyResult<Vec<RunTuple<'py>>> {
    let scenarios = scenarios_json.iter().map(|j| parse_scenario(j)).collect::<PyResult<Vec<_>>>()?;
    let results: Vec<Result<RunResult, SimError>> = py.detach(|| {
        let go = || scenarios.par_iter().map(flc_sim::run).collect::<Vec<_>>();
        match threads {
            Some(n) if n > 0 => match rayon::ThreadPoolBuilder::new().num_threads(n).build() {
                Ok(pool) => pool.install(go),
                Err(_) => go(),
            },
            _ => go(),
        }
    });
    results.into_iter().map(|r| result_to_py(py, r.map_err(scenario_err)?)).collect()
}

/// Benchmark helper: the best wall time (s) of `repeats` runs of the scenario in Rust alone (no
/// conversion to Python objects), to compare with `flc.run` (docs/benchmarks.md).
#[pyfunction]
fn bench_rust_run(py: Python<'_>, scenario_json: &str, repeats: usize) -> PyResult<f64> {
    let s = parse_scenario(scenario_json)?;
    py.detach(|| {
        let mut best = f64::INFINITY;
        for _ in 0..repeats.max(1) {
            let t0 = std::time::Instant::now();
            let r = flc_sim::run(&s);
            let dt = t0.elapsed().as_secs_f64();
            std::hint::black_box(r).map_err(scenario_err)?;
            best = best.min(dt);
        }
        Ok(best)
    })
}

/// flc's metrics (JSON, the keys of `scenario --json`) of a series given as columns, e.g. one
/// recorded by another simulator: `flc_sim::Series::from_columns` (known names, equal lengths;
/// a column not given is NaN, a code column "no controller") and `flc_sim::Metrics::compute_with`
/// with `params_json` (`flc_sim::MetricsParams`, defaults for keys not given). No collision is
/// known, so `collision` is false. Bad columns or parameters raise `ParameterError`.
#[pyfunction]
#[pyo3(signature = (columns, params_json=None))]
fn metrics_from_series(columns: std::collections::BTreeMap<String, Vec<f64>>, params_json: Option<&str>) -> PyResult<String> {
    let params: flc_sim::MetricsParams = match params_json {
        Some(j) => from_json(j, "metrics params")?,
        None => flc_sim::MetricsParams::default(),
    };
    let cols: Vec<(&str, &[f64])> = columns.iter().map(|(k, v)| (k.as_str(), v.as_slice())).collect();
    let series = Series::from_columns(&cols).map_err(|e| crate::ParameterError::new_err(format!("metrics_from_series: {e}")))?;
    to_json(&flc_sim::Metrics::compute_with(&series, None, &params))
}

/// The seed `scenario sweep` gives run `run_id` of a sweep with seed `sweep_seed`.
#[pyfunction]
fn sweep_run_seed(sweep_seed: u64, run_id: usize) -> u64 {
    flc_sim::sweep::run_seed(sweep_seed, run_id)
}

/// One flc follower driven by a host simulator (`flc.sumo`): the scenario's follower pipeline
/// (controller, `[lidar]` as the gap sensor, `[v2v]`, vehicle and low-level controller;
/// `flc_sim::ExternalFollower`).
#[pyclass(module = "flc._flc", unsendable)]
struct ExternalFollower {
    inner: flc_sim::ExternalFollower,
}

#[pymethods]
impl ExternalFollower {
    /// `actuation`: `"vehicle"` (flc's low-level controller and vehicle model) or `"direct"` (the
    /// law's speed command as it is).
    #[new]
    #[pyo3(signature = (scenario_json, seed, actuation="vehicle"))]
    fn new(scenario_json: &str, seed: u64, actuation: &str) -> PyResult<Self> {
        let s = parse_scenario(scenario_json)?;
        let a: flc_sim::Actuation = from_json(&format!("\"{actuation}\""), "actuation")?;
        let inner = flc_sim::ExternalFollower::new(s.base_follower_config(), seed).map_err(scenario_err)?.with_actuation(a);
        Ok(Self { inner })
    }

    /// One host step; returns the JSON of `flc_sim::ExternalOutput`. Bad input raises
    /// `ParameterError` naming the argument.
    #[pyo3(signature = (t, dt, gap, front_speed, own_speed))]
    fn step(&mut self, t: f64, dt: f64, gap: Option<f64>, front_speed: Option<f64>, own_speed: f64) -> PyResult<String> {
        let input = flc_sim::ExternalInput { t, dt, gap, front_speed, own_speed };
        let out = self.inner.step(&input).map_err(|e| match e {
            SimError::Config(c) => crate::ParameterError::new_err(format!("ExternalFollower.step: {c}")),
            other => SimulationError::new_err(other.to_string()),
        })?;
        to_json(&out)
    }

    /// Starts a V2V outage at `t` (until `end_outage`).
    fn start_outage(&mut self, t: f64) {
        self.inner.v2v_mut().start_outage(t);
    }

    /// Ends a V2V outage started with `start_outage` at `t`.
    fn end_outage(&mut self, t: f64) {
        self.inner.v2v_mut().end_outage(t);
    }

    /// The V2V link's statistics as JSON (`flc_sim::V2vStats`).
    fn v2v_stats(&mut self) -> PyResult<String> {
        to_json(&self.inner.v2v_mut().stats())
    }
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<ExternalFollower>()?;
    m.add_function(wrap_pyfunction!(sweep_run_seed, m)?)?;
    m.add_function(wrap_pyfunction!(metrics_from_series, m)?)?;
    m.add_function(wrap_pyfunction!(paper_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(paper_tracking_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(load_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(import_openscenario, m)?)?;
    m.add_function(wrap_pyfunction!(run_suite, m)?)?;
    m.add_function(wrap_pyfunction!(check_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(bench_rust_run, m)?)?;
    m.add_function(wrap_pyfunction!(expand_variants, m)?)?;
    m.add_function(wrap_pyfunction!(brakedemo_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(frequency_response, m)?)?;
    m.add_function(wrap_pyfunction!(controller_names, m)?)?;
    m.add_function(wrap_pyfunction!(paper_speed_range_kmh, m)?)?;
    m.add_function(wrap_pyfunction!(section_names, m)?)?;
    m.add_function(wrap_pyfunction!(resolve_key, m)?)?;
    m.add_function(wrap_pyfunction!(apply_overrides, m)?)?;
    Ok(())
}
