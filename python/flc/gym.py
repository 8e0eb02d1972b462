"""``flc.gym``: the simulator as a Gymnasium environment (extra ``flc[gym]``).

``FollowingEnv`` (registered as ``gymnasium.make("flc/Following-v0", ...)``) puts a policy in
place of the ego's longitudinal controller: lateral control, the lead, V2V, the LiDAR and the
actuators stay flc's (:class:`flc.Simulation`, the loop ``flc.run`` runs). See ``docs/python.md``
for the observation and action spaces, the reward and the episode ends.

>>> import gymnasium as gym, flc.gym
>>> env = gym.make("flc/Following-v0", observation="kinematics")
>>> obs, info = env.reset(seed=0)
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("flc.gym needs gymnasium: pip install 'flc[gym]'") from e

from ._flc import ParameterError
from ._scenario import Scenario
from ._simulation import AccelCommand, Observation, Simulation, SpeedCommand

__all__ = ["FollowingEnv", "RewardWeights", "ScenarioSampler", "OBSERVATIONS", "ACTIONS", "reward_terms", "observe"]

#: Observation types of :class:`FollowingEnv`.
OBSERVATIONS = ("kinematics", "lidar", "detector")
#: Action types of :class:`FollowingEnv`.
ACTIONS = ("acceleration", "speed")

#: Features of the ``"kinematics"`` observation, in order.
KINEMATICS = ("gap", "gap_valid", "own_speed", "v2v_speed", "v2v_age", "v2v_valid")
#: Features of the ``"detector"`` observation, in order.
DETECTOR = ("distance", "valid", "x", "y", "width", "depth", "points", "confidence", "own_speed")

#: Cap of the ``v2v_age`` feature, s (also its value before any message).
MAX_V2V_AGE = 10.0


@dataclass(frozen=True)
class RewardWeights:
    """The default reward, per environment step of length ``dt`` (s), from the ground truth at the
    end of the step (``docs/python.md``):

    * ``collision = -collision`` on the step the ego first touches anything (the episode ends);
    * ``headway = -headway * max(0, time_gap - gap / max(speed, 1 m/s))``: closer than
      ``time_gap`` seconds of headway costs, linearly in the shortfall (s);
    * ``comfort = -jerk * (Δaccel / dt)²``: the ego's jerk (m/s³) over the step, squared;
    * ``progress = progress * speed * dt / 10``: distance covered, per 10 m.

    The reward is their sum; ``info["reward_terms"]`` holds each term.
    """

    collision: float = 100.0
    headway: float = 1.0
    time_gap: float = 1.0
    jerk: float = 0.001
    progress: float = 1.0


def reward_terms(w: RewardWeights, gap: float, speed: float, accel: float, prev_accel: float, dt: float, collided_now: bool) -> dict[str, float]:
    """The terms of :class:`RewardWeights`' reward for one step (ground truth at its end)."""
    headway = gap / max(speed, 1.0)
    jerk = (accel - prev_accel) / dt
    return {
        "collision": -w.collision if collided_now else 0.0,
        "headway": -w.headway * max(0.0, w.time_gap - headway),
        "comfort": -w.jerk * jerk * jerk,
        "progress": w.progress * speed * dt / 10.0,
    }


@dataclass
class ScenarioSampler:
    """Domain randomisation: a scenario per episode, drawn from the generator
    :meth:`FollowingEnv.reset` seeds (same seed, same scenario; the scenario's own ``seed``, which
    drives the LiDAR noise and the V2V channel, is drawn too).

    ``families``: lead manoeuvres to draw from, after the standard suites (``docs/standard-suites.md``):
    ``"paper"`` (both at standstill 7 m apart, the lead accelerates to the speed, cruises to
    650 m and brakes to a stop: Sec. IV), ``"ccrs"`` (a standing lead, the ego approaches at the
    speed), ``"ccrm"`` (a lead at ``ccrm_lead_kmh`` ahead of a faster ego), ``"ccrb"`` (both at
    the speed, the lead brakes to a stop after ``hold_s``). Ranges are ``(low, high)``, drawn
    uniformly: ``speed_kmh``, ``gap`` (initial gap of the moving families, m; ``ccrs`` starts at
    ``ccrs_gap``), ``decel`` (the lead's braking, m/s²), ``hold_s``; V2V: ``v2v_loss`` (loss
    probability), ``v2v_outage_prob`` (chance of an outage at the brake onset; V2V is on in
    every episode); LiDAR: ``range_noise_std`` (m), ``dropout_prob``, ``scan_drop_prob``.
    ``base`` overrides apply to every scenario first (keyword overrides as
    :meth:`flc.Scenario.from_dict` takes them).
    """

    families: Sequence[str] = ("paper", "ccrs", "ccrm", "ccrb")
    speed_kmh: tuple[float, float] = (30.0, 90.0)
    gap: tuple[float, float] = (12.0, 60.0)
    ccrs_gap: tuple[float, float] = (60.0, 150.0)
    ccrm_lead_kmh: float = 20.0
    decel: tuple[float, float] = (2.0, 8.0)
    hold_s: tuple[float, float] = (2.0, 8.0)
    v2v_loss: tuple[float, float] = (0.0, 0.5)
    v2v_outage_prob: float = 0.5
    range_noise_std: tuple[float, float] = (0.0, 0.05)
    dropout_prob: tuple[float, float] = (0.0, 0.2)
    scan_drop_prob: tuple[float, float] = (0.0, 0.1)
    base: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        unknown = [f for f in self.families if f not in ("paper", "ccrs", "ccrm", "ccrb")]
        if unknown or not self.families:
            raise ParameterError(f"ScenarioSampler.families: paper, ccrs, ccrm or ccrb, got {list(self.families)}")

    def __call__(self, rng: np.random.Generator) -> Scenario:
        u = lambda r: float(rng.uniform(r[0], r[1]))  # noqa: E731
        family = str(self.families[int(rng.integers(len(self.families)))])
        v_kmh = u(self.speed_kmh)
        v = v_kmh / 3.6
        decel = u(self.decel)
        hold = {"kind": "hold", "duration": u(self.hold_s)}
        brake = {"kind": "brake", "decel": decel}
        s = Scenario.paper(v_kmh, "flc").to_dict()
        s["name"] = f"gym-{family}"
        if family == "ccrs":
            s["lead"].update(initial_speed=0.0, phases=[])
            s["follower"].update(initial_speed=v, initial_gap=u(self.ccrs_gap))
        elif family == "ccrm":
            vl = min(self.ccrm_lead_kmh / 3.6, v)
            s["lead"].update(initial_speed=vl, phases=[hold, brake])
            s["follower"].update(initial_speed=v, initial_gap=u(self.gap) + 20.0)
        elif family == "ccrb":
            s["lead"].update(initial_speed=v, phases=[hold, brake])
            s["follower"].update(initial_speed=v, initial_gap=u(self.gap))
        else:
            s["lead"]["phases"][-1]["decel"] = decel
        s["seed"] = int(rng.integers(2**31))
        s["v2v"].update(enabled=True, loss_prob=u(self.v2v_loss), outage_on_brake=bool(rng.random() < self.v2v_outage_prob))
        s["lidar"].update(range_noise_std=u(self.range_noise_std), dropout_prob=u(self.dropout_prob), scan_drop_prob=u(self.scan_drop_prob))
        return Scenario.from_dict(s, **dict(self.base))


def observe(kind: str, o: Observation, max_range: float) -> np.ndarray:
    """The observation vector of type ``kind`` from a :class:`flc.Observation` (float32)."""
    if kind == "kinematics":
        gap = o.distance
        fresh_v2v = o.v2v_speed is not None and o.v2v_age is not None and o.v2v_age <= 0.5
        age = MAX_V2V_AGE if o.v2v_age is None else min(o.v2v_age, MAX_V2V_AGE)
        return np.array(
            [max_range if gap is None else gap, 0.0 if gap is None else 1.0, o.own_speed, o.v2v_speed or 0.0, age, 1.0 if fresh_v2v else 0.0],
            dtype=np.float32,
        )
    if kind == "lidar":
        assert o.ranges is not None
        return np.append(np.asarray(o.ranges, dtype=np.float32) / np.float32(max_range), np.float32(o.own_speed)).astype(np.float32)
    d = o.detection
    if d is None or o.distance is None:
        return np.array([max_range, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, o.own_speed], dtype=np.float32)
    return np.array(
        [o.distance, 1.0, d["x"], d["y"], d["width"], d["depth"], min(float(d["points"]), 1.0e4), d["confidence"], o.own_speed], dtype=np.float32
    )


class FollowingEnv(gymnasium.Env):  # type: ignore[misc]
    """Vehicle following with flc's simulator: the policy commands the ego's longitudinal motion.

    ``scenario``: a fixed :class:`flc.Scenario` (or dict) for every episode, or ``None`` (default)
    for the :class:`ScenarioSampler` ``sampler`` (domain randomisation; default
    ``ScenarioSampler()``), or a callable ``rng -> Scenario``. ``observation``: ``"kinematics"``
    (Box(6): :data:`KINEMATICS`: detected gap m — ``max_range`` without a detection —, its
    validity flag, own speed m/s, the latest V2V lead speed m/s, its age s (capped at 10), and
    its validity flag: a message at most 0.5 s old), ``"lidar"`` (Box(``beams`` + 1): the scan as
    ``beams`` range beams over the LiDAR's field of view, each the nearest return divided by the
    LiDAR's ``max_range`` (1: none), as highway-env's ``LidarObservation``; then own speed m/s) or
    ``"detector"`` (Box(9): :data:`DETECTOR`: the detector's lead in the sensor frame).
    ``action``: ``"acceleration"`` (Box(1) in ``[-max_brake, max_accel]`` of the ego's vehicle, m/s²;
    default ``[-8, 3.5]``) or ``"speed"`` (Box(1) in ``[0, max_speed]``, m/s; default ``[0, 40]``).
    ``policy_frequency`` (Hz, default 10): decisions per simulated second, at most the LiDAR's
    rate (a decision is held over the scans until the next); ``simulation_frequency`` (Hz, default
    100): the physics rate. ``time_limit``: episode length, s (default 60; ``truncated``).
    ``reward``: :class:`RewardWeights`. ``terminated``: a collision, or the scenario's own end
    (standstill after the lead's script, a stop trigger); ``truncated``: the time limit.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: Union[None, Scenario, Mapping[str, Any], Callable[[np.random.Generator], Scenario]] = None,
        *,
        observation: str = "kinematics",
        action: str = "acceleration",
        policy_frequency: float = 10.0,
        simulation_frequency: float = 100.0,
        beams: int = 64,
        time_limit: float = 60.0,
        max_speed: float = 40.0,
        sampler: Optional[ScenarioSampler] = None,
        reward: RewardWeights = RewardWeights(),
        render_mode: Optional[str] = None,
    ) -> None:
        if observation not in OBSERVATIONS:
            raise ParameterError(f"`observation`: one of {OBSERVATIONS}, got {observation!r}")
        if action not in ACTIONS:
            raise ParameterError(f"`action`: one of {ACTIONS}, got {action!r}")
        if render_mode is not None:
            raise ParameterError("`render_mode`: FollowingEnv does not render (use flc.run(..., record=dir) and Foxglove)")
        for name, value in (("policy_frequency", policy_frequency), ("simulation_frequency", simulation_frequency), ("time_limit", time_limit)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ParameterError(f"`{name}`: a positive number, got {value!r}")
        if simulation_frequency < policy_frequency:
            raise ParameterError("`simulation_frequency`: must be at least `policy_frequency`")
        self._fixed: Optional[Scenario] = None
        self._sample: Callable[[np.random.Generator], Scenario]
        if scenario is None:
            self._sample = sampler if sampler is not None else ScenarioSampler()
        elif callable(scenario) and not isinstance(scenario, (Scenario, Mapping)):
            self._sample = scenario
        else:
            self._fixed = scenario if isinstance(scenario, Scenario) else Scenario.from_dict(scenario)
            self._sample = lambda rng: self._fixed  # type: ignore[assignment,return-value]
        self.observation_type = observation
        self.action_type = action
        self.policy_frequency = float(policy_frequency)
        self.simulation_frequency = float(simulation_frequency)
        self.time_limit = float(time_limit)
        self.weights = reward
        self.beams = int(beams)
        self.render_mode = render_mode
        probe = self._episode_scenario(self._sample(np.random.default_rng(0)))
        d = probe.to_dict()
        self.max_range = float(d["lidar"]["max_range"])
        lidar_rate = float(d["lidar"]["rate_hz"])
        if self.policy_frequency > lidar_rate + 1e-9:
            raise ParameterError(f"`policy_frequency`: at most the LiDAR's rate ({lidar_rate} Hz), got {policy_frequency}")
        veh = d["follower"]["vehicle"]
        if action == "acceleration":
            self._act_box = spaces.Box(np.float32(-veh["max_brake"]), np.float32(veh["max_accel"]), shape=(1,), dtype=np.float32)
        else:
            self._act_box = spaces.Box(np.float32(0.0), np.float32(max_speed), shape=(1,), dtype=np.float32)
        self.action_space = self._act_box
        inf = np.float32(np.inf)
        if observation == "kinematics":
            low = np.array([0, 0, 0, 0, 0, 0], dtype=np.float32)
            high = np.array([inf, 1, inf, inf, MAX_V2V_AGE, 1], dtype=np.float32)
        elif observation == "lidar":
            if self.beams < 1:
                raise ParameterError(f"`beams`: at least 1, got {beams}")
            low = np.zeros(self.beams + 1, dtype=np.float32)
            high = np.append(np.ones(self.beams, dtype=np.float32), inf).astype(np.float32)
        else:
            low = np.array([-inf, 0, -inf, -inf, 0, 0, 0, 0, 0], dtype=np.float32)
            high = np.array([inf, 1, inf, inf, inf, inf, 1.0e4, 1, inf], dtype=np.float32)
        self._obs_box = spaces.Box(low, high, dtype=np.float32)
        self.observation_space = self._obs_box
        self._sim: Optional[Simulation] = None
        self._obs: Optional[Observation] = None
        self._prev_accel = 0.0
        self._collided = False

    def _episode_scenario(self, s: Scenario) -> Scenario:
        return s.replace(duration=self.time_limit, physics_dt=1.0 / self.simulation_frequency)

    @property
    def simulation(self) -> Optional[Simulation]:
        """The :class:`flc.Simulation` of the current episode (its :meth:`~flc.Simulation.result`
        is the episode's :class:`flc.RunResult`)."""
        return self._sim

    def _vector(self, o: Observation) -> np.ndarray:
        v = observe(self.observation_type, o, self.max_range)
        return np.clip(v, self._obs_box.low, self._obs_box.high).astype(np.float32)

    def _info(self, o: Observation) -> dict[str, Any]:
        t = o.truth
        return {
            "t": t.t,
            "gap": t.gap,
            "speed": t.speed,
            "accel": t.accel,
            "front_speed": t.front_speed,
            "collision": t.collision is not None,
            "distance": o.distance,
            "scenario": self._sim.scenario.name if self._sim is not None else "",
        }

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        scenario = self._episode_scenario(self._sample(self.np_random))
        if self._sim is None:
            self._sim = Simulation(scenario, drive=1, command="accel" if self.action_type == "acceleration" else "speed", beams=self.beams if self.observation_type == "lidar" else 0)
        # A fixed scenario gets a run seed (LiDAR noise, V2V channel) from the episode's generator.
        run_seed = int(self.np_random.integers(2**63)) if self._fixed is not None else None
        obs = self._sim.reset(seed=run_seed, scenario=scenario)
        self._obs = obs
        self._prev_accel = obs.truth.accel
        self._collided = obs.truth.collision is not None
        return self._vector(obs), self._info(obs)

    def _action_value(self, action: Any) -> float:
        """The one number of an action (a number or anything array-like holding exactly one);
        anything else raises ``TypeError`` / ``ValueError`` saying what an action must be."""
        unit = "m/s²" if self.action_type == "acceleration" else "m/s"
        what = (
            f"FollowingEnv.step: `action` must be one number or an array of shape (1,): the {self.action_type} "
            f"in [{float(self._act_box.low[0]):g}, {float(self._act_box.high[0]):g}] {unit} (values outside are clipped)"
        )
        if action is None or isinstance(action, (str, bytes, dict)):
            raise TypeError(f"{what}, got {type(action).__name__} {action!r:.60}")
        try:
            arr = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{what}, got {type(action).__name__} {action!r:.60}") from None
        if arr.size != 1:
            raise ValueError(f"{what}, got shape {arr.shape}")
        x = float(arr.reshape(-1)[0])
        if not np.isfinite(x):
            raise ValueError(f"{what}, got {x}")
        return x

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._sim is None or self._obs is None:
            raise RuntimeError("FollowingEnv.step: call reset() first")
        a = float(np.clip(self._action_value(action), self._act_box.low[0], self._act_box.high[0]))
        cmd: Union[SpeedCommand, AccelCommand] = AccelCommand(a) if self.action_type == "acceleration" else SpeedCommand(a)
        # The decision is held over the scans of the policy period (in Rust).
        obs = self._sim.step(cmd, hold_until=self._obs.t + 1.0 / self.policy_frequency)
        dt = max(obs.truth.t - self._obs.truth.t, 1e-9)
        collided_now = obs.truth.collision is not None and not self._collided
        self._collided |= collided_now
        terms = reward_terms(self.weights, obs.truth.gap, obs.truth.speed, obs.truth.accel, self._prev_accel, dt, collided_now)
        self._prev_accel = obs.truth.accel
        self._obs = obs
        truncated = obs.done and not self._collided and obs.truth.t >= self.time_limit - 0.5 / self.simulation_frequency
        terminated = self._collided or (obs.done and not truncated)
        info = self._info(obs)
        info["reward_terms"] = terms
        info["dt"] = dt
        return self._vector(obs), float(sum(terms.values())), bool(terminated), bool(truncated), info


def _register() -> None:
    if "flc/Following-v0" not in gymnasium.registry:
        gymnasium.register(id="flc/Following-v0", entry_point="flc.gym:FollowingEnv")


_register()
