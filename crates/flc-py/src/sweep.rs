//! Bindings of the sweep engine (`flc_sim::sweep`) for `flc.sweep_file`: the expansion of a sweep
//! file or OpenSCENARIO distribution into points (run ids, seeds), one chunk of points run in
//! Rust with the GIL released (rows only, series on request), the CSV output's resume logic, and
//! the column schema. Python only distributes the chunks and writes what comes back.

use std::path::{Path, PathBuf};

use flc_sim::SimError;
use flc_sim::sweep::{self, SweepPoint, SweepSpec};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::sim::scenario_err;
use crate::{ParameterError, ScenarioError, SimulationError, array, from_json, to_json};

/// What a plan gives Python: the value keys, the column schema `(name, type, unit)`, the points
/// as JSON and the digest of their inputs (`flc_sim::sweep::inputs_digest`).
type Plan = (Vec<String>, Vec<(String, &'static str, &'static str)>, Vec<(usize, String)>, String);

/// How Python and `python -m flc sweep` start an output over.
const RESTART_HINT: &str = "start over with `restart=True` (`python -m flc sweep --restart`), or give another `out`";

/// A sweep output error: `ParameterError` naming `out` with how to start over for a stale output,
/// `SimulationError` otherwise.
fn output_err(e: SimError) -> PyErr {
    match e {
        SimError::StaleOutput { .. } => ParameterError::new_err(format!("out: {e}; {RESTART_HINT}")),
        other => SimulationError::new_err(other.to_string()),
    }
}

fn is_xosc(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("xosc"))
}

/// The keys and points of a sweep file (TOML, `flc_sim::sweep::SweepSpec`) or an OpenSCENARIO
/// file (`.xosc`, a `ParameterValueDistribution` gives one point per combination; default import
/// options), exactly as `scenario sweep FILE` expands them.
fn points_of(path: &Path) -> PyResult<(Vec<String>, Vec<SweepPoint>)> {
    if is_xosc(path) {
        let opts = flc_sim::openscenario::ImportOptions::from_words(Vec::new(), None, "controller", "file", "kinematic", None)
            .map_err(|e| ScenarioError::new_err(e.to_string()))?;
        let import = flc_sim::openscenario::import(path, &opts).map_err(|e| ScenarioError::new_err(e.to_string()))?;
        return Ok(sweep::distribution_points(import.runs));
    }
    let (spec, dir) = SweepSpec::from_file(path).map_err(scenario_err)?;
    let points = spec.points(dir.as_deref()).map_err(|e| ScenarioError::new_err(format!("{}: {e}", path.display())))?;
    Ok((spec.axes.iter().map(|a| a.key.clone()).collect(), points))
}

/// Expands a sweep file or OpenSCENARIO distribution: `(keys, schema, [(run_id, point JSON)],
/// digest)`, the schema one `(column, type, unit)` per CSV column (`flc_sim::sweep::schema_of`),
/// the digest that of the points' inputs (`flc_sim::sweep::inputs_digest`, what `scenario sweep`
/// keeps with its CSV). Bad files raise `ScenarioError` naming the file and key.
#[pyfunction]
fn sweep_plan(py: Python<'_>, path: PathBuf) -> PyResult<Plan> {
    let (keys, points) = py.detach(|| points_of(&path))?;
    let schema = sweep::schema_of(&keys, &points);
    let digest = sweep::inputs_digest(&keys, &points);
    let json = points.iter().map(|p| Ok((p.id, to_json(p)?))).collect::<PyResult<Vec<_>>>()?;
    Ok((keys, schema, json, digest))
}

/// Why a sweep output's `rows` finished rows cannot be resumed, and how to start over: `stored`
/// is the digest kept with them (`None`: none), `digest` the new sweep's; `None` if they match
/// (`flc_sim::sweep::stale_reason`: the words of the CSV's refusal, for the Parquet output).
#[pyfunction]
#[pyo3(signature = (rows, stored, digest))]
fn sweep_stale_reason(rows: usize, stored: Option<&str>, digest: &str) -> Option<String> {
    sweep::stale_reason(rows, stored, digest).map(|r| format!("{r}; {RESTART_HINT}"))
}

/// Runs a sweep file locally exactly as `scenario sweep FILE --out CSV [--restart]` does (the
/// same engine, rayon on `threads` or all cores, GIL released): rows streamed into `out`,
/// finished ids of the same inputs skipped, rows in `run_id` order at the end; an output of
/// other inputs raises `ParameterError` unless `restart`; with `progress` the CLI's progress bar
/// on stderr (drawn only on a terminal). Returns `(runs done now, runs in the sweep)`.
#[pyfunction]
#[pyo3(signature = (path, out, threads=None, restart=false, progress=false))]
fn sweep_local_csv(
    py: Python<'_>,
    path: PathBuf,
    out: PathBuf,
    threads: Option<usize>,
    restart: bool,
    progress: bool,
) -> PyResult<(usize, usize)> {
    let (keys, points) = py.detach(|| points_of(&path))?;
    let go = || sweep::run_points(&keys, &points, &out, progress, restart);
    let done = py
        .detach(|| match threads {
            Some(n) if n > 0 => match rayon::ThreadPoolBuilder::new().num_threads(n).build() {
                Ok(pool) => pool.install(go),
                Err(_) => go(),
            },
            _ => go(),
        })
        .map_err(output_err)?;
    Ok((done, points.len()))
}

/// One finished point as Python gets it: run id, CSV row (no line break) and, on request, the
/// run's series (`{column: 1-D array}`; `None` for a run that failed).
type ChunkRow<'py> = (usize, String, Option<Bound<'py, PyDict>>);

/// Runs a chunk of points (JSON from `sweep_plan`) one after the other in Rust with the GIL
/// released (`flc_sim::sweep::run_point`: a failing run is a row with its error). Returns one
/// `ChunkRow` per point, in input order; series only with `series=True`.
#[pyfunction]
#[pyo3(signature = (points_json, series=false))]
fn sweep_run_chunk<'py>(py: Python<'py>, points_json: Vec<String>, series: bool) -> PyResult<Vec<ChunkRow<'py>>> {
    let points = points_json.iter().map(|j| from_json::<SweepPoint>(j, "sweep point")).collect::<PyResult<Vec<_>>>()?;
    let done = py.detach(|| points.iter().map(sweep::run_point).collect::<Vec<_>>());
    points
        .iter()
        .zip(done)
        .map(|(p, (row, result))| {
            let cols = match (series, result) {
                (true, Some(r)) => {
                    let d = PyDict::new(py);
                    for (name, col) in r.series.columns() {
                        d.set_item(name, array(py, col))?;
                    }
                    Some(d)
                }
                _ => None,
            };
            Ok((p.id, row, cols))
        })
        .collect()
}

/// Prepares a sweep CSV for appending rows of points named `keys` whose inputs have `digest`
/// (`flc_sim::sweep::open_output`: header and digest written if there are no finished rows or
/// with `restart`, a cut last line dropped; an output of other inputs raises `ParameterError`)
/// and returns the run ids it already holds, sorted.
#[pyfunction]
#[pyo3(signature = (out, keys, digest, restart=false))]
fn sweep_open_csv(out: PathBuf, keys: Vec<String>, digest: &str, restart: bool) -> PyResult<Vec<usize>> {
    let (_, done) = sweep::open_output(&out, &keys, digest, restart).map_err(|e| match e {
        SimError::StaleOutput { .. } => output_err(e),
        other => SimulationError::new_err(format!("{}: {other}", out.display())),
    })?;
    let mut ids: Vec<usize> = done.into_iter().collect();
    ids.sort_unstable();
    Ok(ids)
}

/// Puts the rows of a sweep CSV in `run_id` order (`flc_sim::sweep::sort_output`).
#[pyfunction]
fn sweep_sort_csv(out: PathBuf) -> PyResult<()> {
    sweep::sort_output(&out).map_err(|e| SimulationError::new_err(format!("{}: {e}", out.display())))
}

/// The per-step series columns `(name, type, unit)` (`flc_sim::Series::COLUMNS`, types `f64` or
/// `u8` for codes): the one list of series columns.
#[pyfunction]
fn series_columns() -> Vec<(&'static str, &'static str, &'static str)> {
    flc_sim::Series::COLUMNS.iter().zip(flc_sim::Series::COLUMN_TYPES).map(|((n, u), t)| (*n, *t, *u)).collect()
}

/// The metrics `(name, type, unit)` (`flc_sim::Metrics::COLUMNS`).
#[pyfunction]
fn metric_columns() -> Vec<(&'static str, &'static str, &'static str)> {
    flc_sim::Metrics::COLUMNS.to_vec()
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(sweep_plan, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_local_csv, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_run_chunk, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_open_csv, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_stale_reason, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_sort_csv, m)?)?;
    m.add_function(wrap_pyfunction!(series_columns, m)?)?;
    m.add_function(wrap_pyfunction!(metric_columns, m)?)?;
    Ok(())
}
