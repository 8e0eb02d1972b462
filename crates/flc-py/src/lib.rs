//! `flc._flc`: thin pyo3 bindings over `flc-core` and `flc-sim`. The typed, documented Python API
//! is the `flc` package (`python/flc`); this module is private to it.
//!
//! Parameters, terms and scenarios cross the boundary as JSON text produced and read by `serde`
//! (the Python facade builds parameters from keyword arguments and parses what comes back), so
//! that the Rust definitions stay the single source of truth for names, defaults and validation.
//! The longitudinal laws share one binding (`laws`); controller and section names and keyword
//! overrides of scenarios come from `flc-sim` (`sim`).

use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::de::DeserializeOwned;

mod gym;
mod laws;
mod sim;
mod step;
mod sweep;

create_exception!(_flc, FlcError, PyException, "Base class of every error raised by flc.");
create_exception!(_flc, ParameterError, FlcError, "A parameter is out of range, of the wrong type or unknown; the message names it.");
create_exception!(_flc, ScenarioError, FlcError, "A scenario is malformed or out of range; the message names the key.");
create_exception!(_flc, SimulationError, FlcError, "A run failed.");

/// Deserialises parameters from JSON; errors name the dotted key.
pub(crate) fn from_json<T: DeserializeOwned>(json: &str, what: &str) -> PyResult<T> {
    let de = &mut serde_json::Deserializer::from_str(json);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        if path.is_empty() || path == "." {
            ParameterError::new_err(format!("{what}: {inner}"))
        } else {
            ParameterError::new_err(format!("{what}: `{path}`: {inner}"))
        }
    })
}

pub(crate) fn to_json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| FlcError::new_err(e.to_string()))
}

pub(crate) fn param_err(what: &str, e: flc_core::ParamError) -> PyErr {
    ParameterError::new_err(format!("{what}: invalid parameter `{}`: {}", e.field, e.problem))
}

/// The paper's default parameters of a component as JSON (`flc`, `flc_robust` (v2),
/// `flc_robust_v1`, `flc_robust_odo` (the odometry variant's own), `pid`, `pure_pursuit`,
/// `detector`, `supervisor`).
#[pyfunction]
fn default_params(kind: &str) -> PyResult<String> {
    match kind {
        "flc" => to_json(&flc_core::FlcParams::paper()),
        "flc_robust" => to_json(&flc_core::RobustFlc2Params::documented()),
        "flc_robust_v1" => to_json(&flc_core::RobustFlcParams::documented()),
        "flc_robust_odo" => to_json(&flc_core::OdometryFlcParams::documented()),
        "pid" => to_json(&flc_core::PidParams::paper()),
        "pure_pursuit" => to_json(&flc_core::PurePursuitParams::default()),
        "detector" => to_json(&flc_core::DetectorParams::default()),
        "supervisor" => to_json(&flc_core::SupervisorParams::default()),
        other => Err(ParameterError::new_err(format!("unknown component `{other}`"))),
    }
}

/// Pure pursuit, Eq. (1).
#[pyclass(module = "flc._flc")]
struct PurePursuit {
    inner: flc_core::PurePursuit,
}

#[pymethods]
impl PurePursuit {
    #[new]
    fn new(params_json: &str) -> PyResult<Self> {
        let p: flc_core::PurePursuitParams = from_json(params_json, "PurePursuit")?;
        Ok(Self { inner: flc_core::PurePursuit::new(p).map_err(|e| param_err("PurePursuit", e))? })
    }

    /// `(steer, lookahead, alpha, (x, y) of the lookahead point, status)`.
    fn step(&self, lead: Option<(f64, f64)>, own_speed: f64) -> (f64, f64, f64, (f64, f64), &'static str) {
        let c = self.inner.step(lead.map(|(x, y)| nalgebra_point(x, y)), own_speed);
        (c.steer, c.lookahead, c.alpha, (c.lookahead_point.x, c.lookahead_point.y), c.status.as_str())
    }

    fn params_json(&self) -> PyResult<String> {
        to_json(self.inner.params())
    }
}

fn nalgebra_point(x: f64, y: f64) -> flc_core::Point2<f64> {
    flc_core::Point2::new(x, y)
}

/// One supervisor tick as Python sees it (`flc.Supervisor.step`).
#[derive(serde::Serialize)]
struct SupervisorStep {
    speed: f64,
    accel: f64,
    status: &'static str,
    active: &'static str,
    reason: &'static str,
    switched: bool,
    /// `None` before any V2V message.
    v2v_age_ticks: Option<u32>,
    fresh_count: u32,
    /// `unknown`, `associated` or `not_associated` (is the detected object the V2V sender?).
    association: &'static str,
    flc_speed: f64,
    pid_speed: f64,
}

/// The parallel longitudinal controller.
#[pyclass(module = "flc._flc")]
struct Supervisor {
    inner: flc_core::Supervisor,
}

#[pymethods]
impl Supervisor {
    #[new]
    fn new(params_json: &str) -> PyResult<Self> {
        let p: flc_core::SupervisorParams = from_json(params_json, "Supervisor")?;
        Ok(Self { inner: flc_core::Supervisor::new(p).map_err(|e| param_err("Supervisor", e))? })
    }

    /// One tick; returns the JSON of [`SupervisorStep`]: the command, the active controller and why.
    fn step(&mut self, v2v: Option<(f64, u32)>, distance: Option<f64>, own_speed: f64, dt: f64) -> PyResult<String> {
        let msg = v2v.map(|(lead_speed, seq)| flc_core::V2vMessage::speed_only(lead_speed, seq));
        let o = self.inner.step(msg, distance, own_speed, dt);
        to_json(&SupervisorStep {
            speed: o.command.speed,
            accel: o.command.accel,
            status: o.command.status.as_str(),
            active: o.active.as_str(),
            reason: o.reason.as_str(),
            switched: o.switched,
            v2v_age_ticks: (o.v2v_age_ticks != u32::MAX).then_some(o.v2v_age_ticks),
            fresh_count: o.fresh_count,
            association: o.association.as_str(),
            flc_speed: o.flc.speed,
            pid_speed: o.pid.speed,
        })
    }

    fn reset(&mut self) {
        self.inner.reset();
    }
}

/// The LiDAR lead detector (default 520 x 60 grid).
#[pyclass(module = "flc._flc")]
struct LeadDetector {
    inner: Box<flc_core::LeadDetector>,
}

#[pymethods]
impl LeadDetector {
    #[new]
    fn new(params_json: &str) -> PyResult<Self> {
        let p: flc_core::DetectorParams = from_json(params_json, "LeadDetector")?;
        let d = <flc_core::LeadDetector>::new(p).map_err(|e| param_err("LeadDetector", e))?;
        Ok(Self { inner: Box::new(d) })
    }

    /// Detects the lead in an (N, 2) array of points (sensor frame, m). Returns a dict.
    fn detect<'py>(&mut self, py: Python<'py>, points: PyReadonlyArray2<'py, f64>, path_curvature: f64) -> PyResult<Bound<'py, PyDict>> {
        let view = points.as_array();
        if view.ncols() != 2 {
            return Err(ParameterError::new_err(format!("points: expected shape (N, 2), got {:?}", view.shape())));
        }
        let pts: Vec<[f64; 2]> = view.rows().into_iter().map(|r| [r[0], r[1]]).collect();
        let out = self.inner.detect(&pts, path_curvature);
        let d = PyDict::new(py);
        d.set_item("status", out.status.as_str())?;
        d.set_item("points_used", out.points_used)?;
        d.set_item("points_rejected", out.points_rejected)?;
        d.set_item("clusters", out.clusters)?;
        d.set_item("detection", detection_dict(py, out.detection)?)?;
        let boxes: Vec<(f64, f64, f64, f64, usize, bool)> =
            self.inner.clusters().iter().map(|c| (c.x_min, c.x_max, c.y_min, c.y_max, c.points, c.accepted())).collect();
        d.set_item("cluster_boxes", boxes)?;
        Ok(d)
    }
}

/// Helper so the facade can build NumPy arrays without copying twice.
/// A detection as Python sees it (`x`, `y`, `distance`, `width`, `depth`, `points`,
/// `confidence`), or `None`: the detector binding's and the stepping observation's one shape.
pub(crate) fn detection_dict(py: Python<'_>, det: Option<flc_core::Detection>) -> PyResult<Py<PyAny>> {
    let Some(det) = det else { return Ok(py.None()) };
    let d = PyDict::new(py);
    d.set_item("x", det.position.x)?;
    d.set_item("y", det.position.y)?;
    d.set_item("distance", det.distance)?;
    d.set_item("width", det.width)?;
    d.set_item("depth", det.depth)?;
    d.set_item("points", det.points)?;
    d.set_item("confidence", det.confidence)?;
    Ok(d.into_any().unbind())
}

pub(crate) fn array<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, v)
}

#[pymodule]
fn _flc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("FlcError", py.get_type::<FlcError>())?;
    m.add("ParameterError", py.get_type::<ParameterError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add_function(wrap_pyfunction!(default_params, m)?)?;
    laws::register(m)?;
    m.add_class::<PurePursuit>()?;
    m.add_class::<Supervisor>()?;
    m.add_class::<LeadDetector>()?;
    sim::register(m)?;
    sweep::register(m)?;
    m.add_class::<step::Simulation>()?;
    m.add_class::<gym::GymEnvs>()?;
    m.add_class::<gym::ScenarioLaw>()?;
    Ok(())
}
