//! `flc.gym`'s environments: N episodes of `flc_sim::gym::Env` stepped in one call (GIL
//! released, in parallel), observations and outcomes written into NumPy arrays the caller owns.

use flc_sim::gym::{Env, EnvConfig, Outcome, step_envs};
use numpy::{PyReadonlyArray1, PyReadwriteArray2};
use pyo3::prelude::*;

use crate::sim::{RunTuple, parse_scenario, result_to_py, scenario_err};
use crate::{ParameterError, from_json};

/// A scan as a law gets it: `(t, distance, own_speed, v2v = (lead_speed, seq))`.
type LawFrame = (f64, Option<f64>, f64, Option<(f64, u32)>);
/// A pose `(x, y, yaw)`, m and rad.
type Pose = (f64, f64, f64);

/// `n` environments of one configuration (`flc_sim::gym::EnvConfig` as JSON).
#[pyclass(module = "flc._flc", unsendable)]
pub(crate) struct GymEnvs {
    envs: Vec<Env>,
    cfg: EnvConfig,
}

impl GymEnvs {
    fn env(&self, i: usize) -> PyResult<&Env> {
        self.envs.get(i).ok_or_else(|| ParameterError::new_err(format!("environment {i}: there are {}", self.envs.len())))
    }
}

#[pymethods]
impl GymEnvs {
    #[new]
    fn new(n: usize, config_json: &str) -> PyResult<Self> {
        let cfg: EnvConfig = from_json(config_json, "FollowingEnv")?;
        let envs = (0..n)
            .map(|_| Env::new(cfg.clone()))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ParameterError::new_err(format!("FollowingEnv: `{}`: {}", e.key, e.problem)))?;
        Ok(Self { envs, cfg })
    }

    /// The observation's `(low, high)` bounds.
    fn observation_bounds(&self) -> (Vec<f32>, Vec<f32>) {
        self.cfg.observation_bounds()
    }

    /// The names of the columns of `out` (`flc_sim::gym::Outcome::FIELDS`).
    #[staticmethod]
    fn fields() -> Vec<&'static str> {
        Outcome::FIELDS.to_vec()
    }

    /// Resets environment `i` (the scenario JSON given) or steps it with `actions[i]`, all in
    /// parallel with the GIL released; writes `obs[i]` and `out[i]` (`fields()`).
    fn step(
        &mut self,
        py: Python<'_>,
        actions: PyReadonlyArray1<'_, f32>,
        resets: Vec<Option<String>>,
        mut obs: PyReadwriteArray2<'_, f32>,
        mut out: PyReadwriteArray2<'_, f64>,
    ) -> PyResult<()> {
        let n = self.envs.len();
        let d = self.cfg.observation_len();
        let nf = Outcome::FIELDS.len();
        if resets.len() != n || obs.as_array().shape() != [n, d].as_slice() || out.as_array().shape() != [n, nf].as_slice() {
            return Err(ParameterError::new_err(format!("step: {n} resets, obs of shape ({n}, {d}) and out of ({n}, {nf}) expected")));
        }
        let actions = actions.as_slice().map_err(|e| ParameterError::new_err(format!("actions: {e}")))?.to_vec();
        if actions.len() != n {
            return Err(ParameterError::new_err(format!("actions: {n} expected, got {}", actions.len())));
        }
        let resets = resets.iter().map(|j| j.as_deref().map(parse_scenario).transpose()).collect::<PyResult<Vec<_>>>()?;
        let obs = obs.as_slice_mut().map_err(|e| ParameterError::new_err(format!("obs: {e}")))?;
        let rows = out.as_slice_mut().map_err(|e| ParameterError::new_err(format!("out: {e}")))?;
        let envs = &mut self.envs;
        let mut outcomes = vec![Outcome::default(); n];
        py.detach(|| step_envs(envs, &actions, resets, obs, &mut outcomes)).map_err(scenario_err)?;
        for (o, row) in outcomes.iter().zip(rows.chunks_mut(nf)) {
            o.to_row(row);
        }
        Ok(())
    }

    /// Environment `i`'s last scan as a law gets it: `(t, distance, own_speed, v2v)` with
    /// `v2v = (lead_speed, seq)` of the latest message received, or `None`.
    fn frame(&self, i: usize) -> PyResult<LawFrame> {
        let sim = self.env(i)?.simulation().ok_or_else(|| ParameterError::new_err("reset first"))?;
        let (m, _, v2v) = sim.measurement(1).ok_or_else(|| ParameterError::new_err("follower 1 is not driven"))?;
        Ok((m.t, m.distance, m.own_speed, v2v.map(|v| (v.message.lead_speed, v.message.seq))))
    }

    /// Environment `i`'s last scan's points (sensor frame, m) and the ego's and the lead's poses
    /// `(x, y, yaw)` now.
    fn scene(&self, i: usize) -> PyResult<(Vec<[f64; 2]>, Pose, Pose)> {
        let sim = self.env(i)?.simulation().ok_or_else(|| ParameterError::new_err("reset first"))?;
        let (m, _, _) = sim.measurement(1).ok_or_else(|| ParameterError::new_err("follower 1 is not driven"))?;
        let e = sim.follower_state(0).ok_or_else(|| ParameterError::new_err("no follower"))?;
        let l = sim.lead_state();
        Ok((m.points.clone(), (e.x, e.y, e.yaw), (l.x, l.y, l.yaw)))
    }

    /// Environment `i`'s run so far (the tuple `run` returns).
    fn result<'py>(&self, py: Python<'py>, i: usize) -> PyResult<RunTuple<'py>> {
        let sim = self.env(i)?.simulation().ok_or_else(|| ParameterError::new_err("reset first"))?;
        result_to_py(py, sim.result())
    }

    /// Environment `i`'s scenario (JSON).
    fn scenario_json(&self, i: usize) -> PyResult<String> {
        let sim = self.env(i)?.simulation().ok_or_else(|| ParameterError::new_err("reset first"))?;
        crate::to_json(sim.scenario())
    }
}

/// A scenario's follower law (any controller of the registry, `flc_sim::ControllerKind`, with
/// the scenario's parameter sections) and its low-level speed controller, as a policy steps
/// them: the law on each decision's frame, the speed controller to turn the law's speed command
/// into an acceleration demand (`flc.gym.policies`).
#[pyclass(module = "flc._flc", unsendable)]
pub(crate) struct ScenarioLaw {
    law: flc_sim::BoxedLaw,
    speed: flc_sim::SpeedController,
}

#[pymethods]
impl ScenarioLaw {
    #[new]
    fn new(scenario_json: &str) -> PyResult<Self> {
        let s = parse_scenario(scenario_json)?;
        let cfg = s.base_follower_config();
        let law = cfg.longitudinal().map_err(|e| ParameterError::new_err(format!("`{}`: {}", e.key, e.problem)))?;
        Ok(Self { law, speed: flc_sim::SpeedController::new(cfg.follower.speed_controller) })
    }

    /// One frame (`dt` s since the previous one; `v2v = (lead_speed, seq)` of a message received
    /// since): returns `(speed_command, accel_demand)`, the demand from the speed controller
    /// stepped over `dt` from `own_speed`.
    #[pyo3(signature = (distance, own_speed, dt, v2v=None))]
    fn step(&mut self, distance: Option<f64>, own_speed: f64, dt: f64, v2v: Option<(f64, u32)>) -> (f64, f64) {
        let mut frame = flc_core::Frame::new(distance, own_speed, dt);
        frame.v2v = v2v.map(|(v, seq)| flc_core::V2vMessage::speed_only(v, seq));
        let v = self.law.step(&frame).command.speed;
        (v, self.speed.step(v, own_speed, dt))
    }

    /// Back to the initial state.
    fn reset(&mut self, scenario_json: &str) -> PyResult<()> {
        *self = Self::new(scenario_json)?;
        Ok(())
    }
}
