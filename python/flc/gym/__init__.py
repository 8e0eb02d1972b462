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

import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional, Sequence, Union, cast

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
    from gymnasium.vector import AutoresetMode
    from gymnasium.vector.utils import batch_space
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("flc.gym needs gymnasium: pip install 'flc[gym]'") from e

from .. import _flc
from .._flc import ParameterError
from .._scenario import Scenario
from .._simulation import AccelCommand, Observation, Simulation, SpeedCommand

__all__ = ["FollowingEnv", "FollowingVectorEnv", "RewardWeights", "ScenarioSampler", "OBSERVATIONS", "ACTIONS", "reward_terms", "observe"]

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
    """The default reward (``flc_sim::gym::RewardWeights``; ``docs/python.md``). Every term but
    the collision is a *rate*, per simulated second, integrated over the physics steps of the
    policy step from the ground truth after each physics step, so that a run's return does not
    depend on the policy frequency:

    * ``collision``: ``-collision`` once, on the step of the ego's first contact (an event);
    * ``headway``: ``-headway * max(0, time_gap - gap / max(speed, 1 m/s))`` per s (per second of
      headway shortfall, per second);
    * ``comfort``: ``-jerk * |j|`` per s, ``j`` the ego's jerk, m/s³ (per m/s³, per second):
      integrated, ``-jerk`` per m/s² of acceleration change (the magnitude, not the square, so a
      change costs the same however many physics or policy steps it spreads over);
    * ``progress``: ``progress * speed / (10 m/s)`` per s (``progress`` per 10 m driven).

    The reward is their sum; ``info["reward_terms"]`` holds each term.
    """

    collision: float = 100.0
    headway: float = 1.0
    time_gap: float = 1.0
    jerk: float = 0.01
    progress: float = 1.0


def reward_terms(w: RewardWeights, gap: float, speed: float, accel: float, prev_accel: float, dt: float, collided_now: bool) -> dict[str, float]:
    """The terms of :class:`RewardWeights`' reward for one step of length ``dt`` (s), its rates
    taken from the ground truth at its end (the rectangle rule over the step; :class:`FollowingEnv`
    integrates over the physics steps in Rust)."""
    headway = gap / max(speed, 1.0)
    return {
        "collision": -w.collision if collided_now else 0.0,
        "headway": -w.headway * max(0.0, w.time_gap - headway) * dt,
        "comfort": -w.jerk * abs(accel - prev_accel),
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


def _config(
    observation: str, action: str, policy_frequency: float, beams: int, reward: RewardWeights, act: Any, record: Optional[str], points: bool = False
) -> str:
    """The JSON of ``flc_sim::gym::EnvConfig``."""
    from dataclasses import asdict

    return json.dumps(
        {
            "observation": observation,
            "action": action,
            "policy_frequency": float(policy_frequency),
            "beams": int(beams),
            "reward": asdict(reward),
            "action_low": float(act.low[0]),
            "action_high": float(act.high[0]),
            "points": bool(points),
            "record": None if record is None else str(record),
        }
    )


_FIELDS = tuple(_flc.GymEnvs.fields())
_COL = {name: i for i, name in enumerate(_FIELDS)}
_TERMS = ("collision", "headway", "comfort", "progress")


def _info(row: np.ndarray, scenario: str) -> dict[str, Any]:
    distance = float(row[_COL["distance"]])
    return {
        "t": float(row[_COL["t"]]),
        "gap": float(row[_COL["gap"]]),
        "speed": float(row[_COL["speed"]]),
        "accel": float(row[_COL["accel"]]),
        "front_speed": float(row[_COL["front_speed"]]),
        "collision": bool(row[_COL["collision"]]),
        "distance": None if math.isnan(distance) else distance,
        "scenario": scenario,
        "dt": float(row[_COL["dt"]]),
        "reward_terms": {k: float(row[_COL["reward_" + k]]) for k in _TERMS},
    }


#: Size of :func:`render_frame`'s picture, pixels, and its scale, m per pixel.
FRAME_HEIGHT, FRAME_WIDTH, FRAME_SCALE = 160, 640, 0.25


def render_frame(
    scenario: Mapping[str, Any],
    points: np.ndarray,
    ego: tuple[float, float, float],
    lead: tuple[float, float, float],
    distance: Optional[float],
) -> np.ndarray:
    """A top-down picture in the ego's frame (x forward to the right, the ego at a fifth of the
    width, :data:`FRAME_SCALE` m per pixel): grass, the ego's lane (the track's ``lane_width``,
    drawn straight along the ego's heading), its edge and neighbouring lane markings, the lead
    (red) and the ego (blue), the LiDAR returns of the last scan (white) and the detected lead
    (yellow bar at the detected gap; none without a detection). Pure NumPy rasterisation."""
    h, w, m = FRAME_HEIGHT, FRAME_WIDTH, FRAME_SCALE
    img = np.empty((h, w, 3), dtype=np.uint8)
    img[:] = (58, 110, 52)
    x0, y0 = w // 5, h // 2
    ex, ey, eyaw = ego
    c, s_ = math.cos(-eyaw), math.sin(-eyaw)

    def to_px(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (x0 + x / m).astype(np.int64), (y0 - y / m).astype(np.int64)

    lane = float(scenario.get("track", {}).get("lane_width", 3.5)) if isinstance(scenario.get("track"), Mapping) else 3.5
    half = lane / 2.0
    road = (slice(max(0, int(y0 - 1.5 * lane / m)), min(h, int(y0 + 1.5 * lane / m))), slice(0, w))
    img[road] = (90, 90, 90)
    for k, solid in ((-1.5, True), (-0.5, False), (0.5, False), (1.5, True)):
        row = int(round(y0 - k * lane / m))
        if 0 <= row < h:
            cols = np.arange(w) if solid else np.arange(w)[(np.arange(w) // 12) % 2 == 0]
            img[row, cols] = (235, 235, 235)

    def box(cx: float, cy: float, yaw: float, length: float, width: float, color: tuple[int, int, int]) -> None:
        u = np.linspace(-length / 2, length / 2, max(2, int(length / m * 2)))
        v = np.linspace(-width / 2, width / 2, max(2, int(width / m * 2)))
        uu, vv = np.meshgrid(u, v)
        x = cx + uu * math.cos(yaw) - vv * math.sin(yaw)
        y = cy + uu * math.sin(yaw) + vv * math.cos(yaw)
        px, py = to_px(x.ravel(), y.ravel())
        ok = (px >= 0) & (px < w) & (py >= 0) & (py < h)
        img[py[ok], px[ok]] = color

    lv = scenario["lead"]["vehicle"]
    fv = scenario["follower"]["vehicle"]
    lx, ly, lyaw = lead
    dx, dy = lx - ex, ly - ey
    box(dx * c - dy * s_, dx * s_ + dy * c, lyaw - eyaw, float(lv["length"]), float(lv["width"]), (200, 40, 40))
    box(0.0, 0.0, 0.0, float(fv["length"]), float(fv["width"]), (40, 90, 220))
    lidar = scenario["lidar"]
    if len(points):
        a = math.radians(float(lidar.get("mount_yaw_deg", 0.0)))
        px_ = float(lidar.get("mount_x", 0.0)) + points[:, 0] * math.cos(a) - points[:, 1] * math.sin(a)
        py_ = float(lidar.get("mount_y", 0.0)) + points[:, 0] * math.sin(a) + points[:, 1] * math.cos(a)
        u, v = to_px(px_, py_)
        ok = (u >= 0) & (u < w - 1) & (v >= 0) & (v < h - 1)
        for du in (0, 1):
            for dv in (0, 1):
                img[v[ok] + dv, u[ok] + du] = (255, 255, 255)
    if distance is not None:
        col = int(x0 + (float(fv["length"]) / 2 + distance) / m)
        rows = slice(max(0, int(y0 - half / m)), min(h, int(y0 + half / m)))
        if 0 <= col < w - 2:
            img[rows, col : col + 3] = (250, 210, 30)
    return img


class _EpisodeSpec:
    """What :class:`FollowingEnv` and :class:`FollowingVectorEnv` share: argument checks, the
    spaces and the scenario of an episode drawn from a generator."""

    def __init__(
        self,
        scenario: Any,
        observation: str,
        action: str,
        policy_frequency: float,
        simulation_frequency: float,
        beams: int,
        time_limit: float,
        max_speed: float,
        sampler: Optional[ScenarioSampler],
        render_mode: Optional[str],
    ) -> None:
        if observation not in OBSERVATIONS:
            raise ParameterError(f"`observation`: one of {OBSERVATIONS}, got {observation!r}")
        if action not in ACTIONS:
            raise ParameterError(f"`action`: one of {ACTIONS}, got {action!r}")
        if render_mode not in (None, "rgb_array", "human"):
            raise ParameterError(f"`render_mode`: None, 'rgb_array' or 'human', got {render_mode!r}")
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
        self.beams = int(beams)
        if observation == "lidar" and self.beams < 1:
            raise ParameterError(f"`beams`: at least 1, got {beams}")
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
        cfg = _config(observation, action, policy_frequency, self.beams, RewardWeights(), self._act_box, None)
        low, high = _flc.GymEnvs(0, cfg).observation_bounds()
        self._obs_box = spaces.Box(np.array(low, dtype=np.float32), np.array(high, dtype=np.float32), dtype=np.float32)

    def _episode_scenario(self, s: Scenario) -> Scenario:
        return s.replace(duration=self.time_limit, physics_dt=1.0 / self.simulation_frequency)

    def _draw(self, rng: np.random.Generator) -> tuple[str, str]:
        """The next episode's scenario JSON and name, drawn from ``rng`` (a fixed scenario gets a
        run seed, for the LiDAR noise and the V2V channel, from it)."""
        if self._fixed is not None:
            seed = int(rng.integers(2**63))
            if not hasattr(self, "_seed_template"):
                self._seed_template = _seed_template(self._episode_scenario(self._fixed))
            if self._seed_template is not None:
                # The same text `replace(seed=...).to_json()` gives (checked by _seed_template),
                # without two patches through the scenario's JSON per episode.
                head, tail, name = self._seed_template
                return f"{head}{seed}{tail}", name
            scenario = self._episode_scenario(self._fixed).replace(seed=seed)
            return scenario.to_json(), scenario.name
        scenario = self._episode_scenario(self._sample(rng))
        return scenario.to_json(), scenario.name


def _seed_template(scenario: Scenario) -> Optional[tuple[str, str, str]]:
    """``(head, tail, name)`` such that ``head + str(seed) + tail`` is
    ``scenario.replace(seed=seed).to_json()`` for every seed: the JSON with two seeds of different
    lengths differs only in the one ``"seed"`` value (``None`` if not: then every draw patches)."""
    probes = (7, 123456789012345, 2**63 - 1)
    texts = [scenario.replace(seed=p).to_json() for p in probes]
    key = f'"seed":{probes[0]}'
    if texts[0].count(key) != 1:
        return None
    head, tail = texts[0].split(key)
    head += '"seed":'
    if any(t != f"{head}{p}{tail}" for p, t in zip(probes, texts)):
        return None
    return head, tail, scenario.name


class FollowingEnv(_EpisodeSpec, gymnasium.Env):  # type: ignore[misc]
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
    ``reward``: :class:`RewardWeights` (rates integrated over the step). ``record``: a folder;
    each episode is written there as MCAP (``<scenario>-<controller>-<episode>.mcap``, Foxglove).
    ``terminated``: a collision, or the scenario's own end (standstill after the lead's script, a
    stop trigger); ``truncated``: the time limit. The episode is stepped by the Rust core
    ``flc_sim::gym`` (the one :class:`FollowingVectorEnv` steps N of).
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 10}

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
        record: Optional[str] = None,
    ) -> None:
        _EpisodeSpec.__init__(self, scenario, observation, action, policy_frequency, simulation_frequency, beams, time_limit, max_speed, sampler, render_mode)
        self.weights = reward
        self.render_mode = render_mode
        self.action_space = self._act_box
        self.observation_space = self._obs_box
        self._core = _flc.GymEnvs(1, _config(observation, action, policy_frequency, self.beams, reward, self._act_box, record, render_mode is not None))
        self.metadata = {"render_modes": ["rgb_array", "human"], "render_fps": self.policy_frequency}
        self._figure: Any = None
        self._obs_buf = np.zeros((1, self._obs_box.shape[0]), dtype=np.float32)
        self._out = np.zeros((1, len(_FIELDS)), dtype=np.float64)
        self._scenario_name = ""
        self._started = False

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        js, self._scenario_name = self._draw(self.np_random)
        self._core.step(np.zeros(1, dtype=np.float32), [js], self._obs_buf, self._out)
        self._started = True
        return self._obs_buf[0].copy(), _info(self._out[0], self._scenario_name)

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
        if not self._started:
            raise RuntimeError("FollowingEnv.step: call reset() first")
        a = np.array([self._action_value(action)], dtype=np.float32)
        self._core.step(a, [None], self._obs_buf, self._out)
        row = self._out[0]
        return (
            self._obs_buf[0].copy(),
            float(row[_COL["reward"]]),
            bool(row[_COL["terminated"]]),
            bool(row[_COL["truncated"]]),
            _info(row, self._scenario_name),
        )

    def render(self) -> Optional[np.ndarray]:
        """``"rgb_array"``: a top-down picture of the ego's surroundings now as an
        ``(H, W, 3)`` uint8 array (:func:`render_frame`); ``"human"``: shows it in a matplotlib
        window (an error naming the problem without matplotlib or a display)."""
        if self.render_mode is None:
            gymnasium.logger.warn("FollowingEnv.render: no render_mode given")
            return None
        if not self._started:
            raise RuntimeError("FollowingEnv.render: call reset() first")
        sc = json.loads(self._core.scenario_json(0))
        points, ego, lead = self._core.scene(0)
        distance = self._core.frame(0)[1]
        img = render_frame(sc, np.asarray(points, dtype=np.float64).reshape(-1, 2), ego, lead, distance)
        if self.render_mode == "rgb_array":
            return img
        self._show(img)
        return None

    def _show(self, img: np.ndarray) -> None:
        try:
            import matplotlib
            import matplotlib.pyplot as plt
        except ImportError as e:
            raise ImportError("render_mode='human' needs matplotlib: pip install 'flc[plot]'") from e
        if matplotlib.get_backend().lower() in ("agg", "pdf", "svg", "ps", "cairo", "template"):
            raise RuntimeError(f"render_mode='human': no display (matplotlib backend {matplotlib.get_backend()!r}); use render_mode='rgb_array'")
        if self._figure is None:
            plt.ion()
            self._figure = plt.figure("flc/Following-v0")
            self._image = self._figure.gca().imshow(img)
            self._figure.gca().set_axis_off()
        else:
            self._image.set_data(img)
        plt.pause(1.0 / self.policy_frequency)

    def close(self) -> None:
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None
        super().close()

    def frame(self) -> tuple[float, Optional[float], float, Optional[tuple[float, int]]]:
        """The last scan as a longitudinal law gets it: ``(t, distance, own_speed, v2v)``,
        ``distance`` in m (``None``: no lead detected), ``v2v = (lead_speed, seq)`` of the latest
        V2V message received (``None`` before any). What :mod:`flc.gym.policies` read."""
        return self._core.frame(0)

    def result(self) -> Any:
        """The episode's :class:`flc.RunResult` so far (at its end, the one ``flc.run`` returns
        for the same commands)."""
        from .._run import _result

        return _result(Scenario(json.loads(self._core.scenario_json(0))), self._core.result(0))


class FollowingVectorEnv(gymnasium.vector.VectorEnv):  # type: ignore[misc]
    """``num_envs`` :class:`FollowingEnv` episodes stepped together inside Rust: one call steps
    every environment in parallel (rayon threads, GIL released) and writes the observations into
    one ``(num_envs, n)`` float32 array. ``gymnasium.make_vec("flc/Following-v0", num_envs=N,
    vectorization_mode="vector_entry_point", ...)`` returns it; the keyword arguments are
    :class:`FollowingEnv`'s (``record`` writes every environment's episodes, numbered per
    environment, into the same folder only with ``num_envs=1``).

    Environment ``i`` reset with seed ``s`` runs exactly the episode of a :class:`FollowingEnv`
    reset with ``s`` (``reset(seed=s)``: ``s + i``; a list: one each), bit for bit. Autoreset:
    Gymnasium 1.x's default ``AutoresetMode.NEXT_STEP``: the step after a ``terminated`` or
    ``truncated`` one resets that environment (its action is ignored; reward 0, neither flag,
    the first observation of the new episode). ``info`` holds, as arrays with ``_name`` masks,
    ``t``, ``dt``, ``gap``, ``speed``, ``accel``, ``front_speed``, ``collision``, ``distance``
    (NaN: no lead detected) and the reward terms ``reward_collision``, ``reward_headway``,
    ``reward_comfort``, ``reward_progress``.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
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
        record: Optional[str] = None,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ParameterError(f"`num_envs`: a positive integer, got {num_envs!r}")
        if record is not None and num_envs > 1:
            raise ParameterError("`record`: only with num_envs=1 (the episodes of several environments would share names)")
        self._spec = _EpisodeSpec(scenario, observation, action, policy_frequency, simulation_frequency, beams, time_limit, max_speed, sampler, render_mode)
        self.num_envs = num_envs
        self.render_mode = render_mode
        self.weights = reward
        self.single_action_space = self._spec._act_box
        self.single_observation_space = self._spec._obs_box
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self._core = _flc.GymEnvs(num_envs, _config(observation, action, policy_frequency, self._spec.beams, reward, self._spec._act_box, record))
        self._obs = np.zeros((num_envs, self._spec._obs_box.shape[0]), dtype=np.float32)
        self._out = np.zeros((num_envs, len(_FIELDS)), dtype=np.float64)
        self._rngs: list[np.random.Generator] = []
        self._needs_reset = np.zeros(num_envs, dtype=bool)
        self._names = [""] * num_envs

    def reset(self, *, seed: Union[None, int, Sequence[Optional[int]]] = None, options: Optional[dict[str, Any]] = None) -> tuple[np.ndarray, dict[str, Any]]:
        n = self.num_envs
        if seed is None:
            seeds: list[Optional[int]] = [None] * n
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ParameterError(f"`seed`: {n} seeds, got {len(seeds)}")
        if not self._rngs or seed is not None:
            self._rngs = [gymnasium.utils.seeding.np_random(s)[0] for s in seeds]
        draws = [self._spec._draw(rng) for rng in self._rngs]
        self._names = [name for _, name in draws]
        self._core.step(np.zeros(n, dtype=np.float32), [js for js, _ in draws], self._obs, self._out)
        self._needs_reset[:] = False
        return self._obs.copy(), self._infos()

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._rngs:
            raise RuntimeError("FollowingVectorEnv.step: call reset() first")
        n = self.num_envs
        a = self._action_values(actions)
        resets: list[Optional[str]] = [None] * n
        for i in np.flatnonzero(self._needs_reset):
            resets[i], self._names[i] = self._spec._draw(self._rngs[i])
        self._core.step(a, resets, self._obs, self._out)
        terminated = self._out[:, _COL["terminated"]] != 0
        truncated = self._out[:, _COL["truncated"]] != 0
        self._needs_reset = terminated | truncated
        return self._obs.copy(), self._out[:, _COL["reward"]].copy(), terminated, truncated, self._infos()

    def _action_values(self, actions: Any) -> np.ndarray:
        """The ``num_envs`` actions as one contiguous float32 array (shape ``(n,)`` or ``(n, 1)``
        accepted); anything else raises ``TypeError`` / ``ValueError`` saying what they must be."""
        n = self.num_envs
        box = cast(spaces.Box, self.single_action_space)
        what = (
            f"FollowingVectorEnv.step: `actions` must be an array of shape ({n}, 1) or ({n},): one {self._spec.action_type} "
            f"per environment in [{float(box.low[0]):g}, {float(box.high[0]):g}] (values outside are clipped)"
        )
        if actions is None or isinstance(actions, (str, bytes, dict)):
            raise TypeError(f"{what}, got {type(actions).__name__} {actions!r:.60}")
        try:
            arr = np.asarray(actions, dtype=np.float32)
        except (TypeError, ValueError):
            raise TypeError(f"{what}, got {type(actions).__name__} {actions!r:.60}") from None
        if arr.shape not in ((n,), (n, 1)):
            raise ValueError(f"{what}, got shape {arr.shape}")
        a = np.ascontiguousarray(arr.reshape(n))
        if not np.isfinite(a).all():
            raise ValueError(f"{what}, got {a[~np.isfinite(a)][0]} for environment {int(np.flatnonzero(~np.isfinite(a))[0])}")
        return a

    def _infos(self) -> dict[str, Any]:
        info: dict[str, Any] = {}
        mask = np.ones(self.num_envs, dtype=bool)
        for name in _FIELDS[3:]:
            col = self._out[:, _COL[name]].copy()
            info[name] = col.astype(bool) if name == "collision" else col
            info["_" + name] = mask
        info["scenario"] = np.array(self._names, dtype=object)
        info["_scenario"] = mask
        return info


def _register() -> None:
    if "flc/Following-v0" not in gymnasium.registry:
        gymnasium.register(id="flc/Following-v0", entry_point="flc.gym:FollowingEnv", vector_entry_point="flc.gym:FollowingVectorEnv")


_register()
from . import policies  # noqa: E402,F401
