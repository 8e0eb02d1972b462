//! `flc.Simulation`: the simulator's loop stepped from Python (`flc_sim::Simulation::drive` /
//! `advance` / `command`), one control period (a scan of a driven follower) per `advance`.

use flc_sim::{DriveCommand, DriveOptions, Scenario};
use numpy::PyArrayMethods;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::sim::{RunTuple, parse_scenario, result_to_py, scenario_err};
use crate::{ParameterError, SimulationError, array};

/// A scenario's closed loop with followers `drive` (1-based) driven from Python.
#[pyclass(module = "flc._flc", unsendable)]
pub(crate) struct Simulation {
    scenario: Scenario,
    drive: Vec<usize>,
    opts: DriveOptions,
    /// Record each run as MCAP into this folder (`flc_sim::record`, as `flc.run(record=...)`).
    record: Option<std::path::PathBuf>,
    sim: Option<flc_sim::Simulation<Option<flc_sim::record::Recorder>>>,
}

fn parse_command(kind: &str, value: f64) -> PyResult<DriveCommand> {
    match kind {
        "law" => Ok(DriveCommand::Law),
        "speed" => Ok(DriveCommand::Speed(value)),
        "accel" => Ok(DriveCommand::Accel(value)),
        other => Err(ParameterError::new_err(format!("`command`: must be law, speed or accel, got `{other}`"))),
    }
}

impl Simulation {
    fn sim(&self) -> PyResult<&flc_sim::Simulation<Option<flc_sim::record::Recorder>>> {
        self.sim.as_ref().ok_or_else(|| SimulationError::new_err("Simulation: call reset() first"))
    }

    fn sim_mut(&mut self) -> PyResult<&mut flc_sim::Simulation<Option<flc_sim::record::Recorder>>> {
        self.sim.as_mut().ok_or_else(|| SimulationError::new_err("Simulation: call reset() first"))
    }
}

#[pymethods]
impl Simulation {
    /// `points`: copy each scan's raw points into the measurement; `beams`: reduce each scan to
    /// that many range beams (0: none); `record`: write each run as MCAP into this folder.
    #[new]
    #[pyo3(signature = (scenario_json, drive, points=false, beams=0, record=None))]
    fn new(scenario_json: &str, drive: Vec<usize>, points: bool, beams: usize, record: Option<std::path::PathBuf>) -> PyResult<Self> {
        let scenario = parse_scenario(scenario_json)?;
        if beams > 100_000 {
            return Err(ParameterError::new_err(format!("`beams`: at most 100000, got {beams}")));
        }
        let s = Self { scenario, drive, opts: DriveOptions { points, beams }, record, sim: None };
        // Check the driven followers now (the error names them).
        let mut probe = flc_sim::Simulation::new(&s.scenario).map_err(scenario_err)?;
        probe.drive(&s.drive, s.opts).map_err(|e| ParameterError::new_err(e.to_string()))?;
        Ok(s)
    }

    /// Starts the run anew: with `seed` (default: the scenario's), on `scenario_json` if given
    /// (validated; the driven followers must exist in it).
    #[pyo3(signature = (seed=None, scenario_json=None))]
    fn reset(&mut self, seed: Option<u64>, scenario_json: Option<&str>) -> PyResult<()> {
        if let Some(j) = scenario_json {
            self.scenario = parse_scenario(j)?;
        }
        if let Some(seed) = seed {
            self.scenario.seed = seed;
        }
        // Finish the previous run's recording first.
        self.sim = None;
        let base = flc_sim::Simulation::new(&self.scenario).map_err(scenario_err)?;
        let rec = match &self.record {
            Some(dir) => Some(flc_sim::record::Recorder::for_simulation(dir, &base).map_err(scenario_err)?),
            None => None,
        };
        let mut sim = base.with_observer(rec);
        sim.drive(&self.drive, self.opts).map_err(|e| ParameterError::new_err(e.to_string()))?;
        self.sim = Some(sim);
        Ok(())
    }

    /// Runs to the next scan of a driven follower (`True`) or the end of the run (`False`).
    fn advance(&mut self) -> PyResult<bool> {
        let sim = self.sim_mut()?;
        let paused = sim.advance().map_err(scenario_err)?;
        if !paused {
            sim.finish_observer(true).map_err(scenario_err)?;
        }
        Ok(paused)
    }

    /// Sets follower `k`'s command for the period paused at: `kind` is `"law"` (the scenario's
    /// controller), `"speed"` (m/s) or `"accel"` (m/s²).
    fn command(&mut self, k: usize, kind: &str, value: f64) -> PyResult<()> {
        let cmd = parse_command(kind, value)?;
        self.sim_mut()?.command(k, cmd).map_err(|e| ParameterError::new_err(e.to_string()))
    }

    /// Sets `commands` (`(k, kind, value)`, as `command` takes them) and advances, again and
    /// again with the same commands while the simulation pauses before time `until` (s): one
    /// decision held over the scans of a policy period. Returns what the last `advance` did.
    fn hold(&mut self, commands: Vec<(usize, String, f64)>, until: f64) -> PyResult<bool> {
        let cmds = commands.iter().map(|(k, kind, v)| Ok((*k, parse_command(kind, *v)?))).collect::<PyResult<Vec<_>>>()?;
        let sim = self.sim_mut()?;
        loop {
            for &(k, c) in &cmds {
                sim.command(k, c).map_err(|e| ParameterError::new_err(e.to_string()))?;
            }
            let paused = sim.advance().map_err(scenario_err)?;
            if !paused {
                sim.finish_observer(true).map_err(scenario_err)?;
            }
            if !paused || sim.time() >= until - 1e-9 {
                return Ok(paused);
            }
        }
    }

    /// Follower `k`'s measurement (what its pipeline got at its last scan) as a dict.
    fn measurement<'py>(&self, py: Python<'py>, k: usize) -> PyResult<Bound<'py, PyDict>> {
        let (m, fresh, v2v) = self.sim()?.measurement(k).ok_or_else(|| ParameterError::new_err(format!("follower {k} is not driven")))?;
        let d = PyDict::new(py);
        d.set_item("t", m.t)?;
        d.set_item("fresh", fresh)?;
        d.set_item("distance", m.distance)?;
        d.set_item("own_speed", m.own_speed)?;
        d.set_item("dt", m.dt)?;
        d.set_item("lead_speed", m.lead_speed)?;
        d.set_item("v2v_new", m.v2v.map(|v| (v.lead_speed, v.seq)))?;
        match v2v {
            Some(v) => {
                d.set_item("v2v", (v.message.lead_speed, v.message.seq))?;
                d.set_item("v2v_age", self.sim()?.time() - v.received_at)?;
            }
            None => {
                d.set_item("v2v", py.None())?;
                d.set_item("v2v_age", py.None())?;
            }
        }
        d.set_item("status", m.status.map(|s| s.as_str()))?;
        d.set_item("clusters", m.clusters)?;
        d.set_item("detection", crate::detection_dict(py, m.detection)?)?;
        if self.opts.beams > 0 {
            d.set_item("ranges", array(py, self.sim()?.beams(k).unwrap_or_default()))?;
        }
        if self.opts.points {
            let flat: Vec<f64> = m.points.iter().flatten().copied().collect();
            let a = numpy::PyArray1::from_vec(py, flat).reshape([m.points.len(), 2])?;
            d.set_item("points", a)?;
        }
        Ok(d)
    }

    /// The ground truth about follower `k` now, as a dict.
    fn ground_truth<'py>(&self, py: Python<'py>, k: usize) -> PyResult<Bound<'py, PyDict>> {
        let g = self.sim()?.ground_truth(k).ok_or_else(|| ParameterError::new_err(format!("follower {k} does not exist")))?;
        let d = PyDict::new(py);
        d.set_item("t", g.t)?;
        d.set_item("gap", g.gap)?;
        d.set_item("front_speed", g.front_speed)?;
        d.set_item("front_accel", g.front_accel)?;
        d.set_item("speed", g.speed)?;
        d.set_item("accel", g.accel)?;
        d.set_item("x", g.pose.0)?;
        d.set_item("y", g.pose.1)?;
        d.set_item("yaw", g.pose.2)?;
        d.set_item("lateral_offset", g.lateral_offset)?;
        d.set_item("collision", g.collision.as_ref().map(crate::to_json).transpose()?)?;
        Ok(d)
    }

    /// Simulation time, s.
    fn time(&self) -> PyResult<f64> {
        Ok(self.sim()?.time())
    }

    /// Number of followers.
    fn n_followers(&self) -> PyResult<usize> {
        Ok(self.sim()?.n_followers())
    }

    /// The run's result so far (the tuple `run` returns).
    fn result<'py>(&self, py: Python<'py>) -> PyResult<RunTuple<'py>> {
        result_to_py(py, self.sim()?.result())
    }

    /// The scenario being run (JSON).
    fn scenario_json(&self) -> PyResult<String> {
        crate::to_json(&self.scenario)
    }
}
