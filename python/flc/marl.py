"""``flc.marl``: a platoon as a PettingZoo ``ParallelEnv`` (extra ``flc[gym]``, with ``pettingzoo``).

Each follower of the scenario's ``[platoon]`` is an agent (``"follower_1"`` right behind the lead,
...): it observes what its own pipeline got (the observation types of :class:`flc.gym.FollowingEnv`),
commands its own acceleration or speed, and gets the reward of :class:`flc.gym.RewardWeights`
from its own ground truth. All agents act at every policy step (``policy_frequency``); the loop is
flc's (:class:`flc.Simulation` with ``drive="all"``). A collision ends the run (the scenario's
``stop.on_collision``, default on) and every agent is ``terminated``, as at the scenario's own end;
the time limit ``truncates`` every agent.
"""
from __future__ import annotations

import functools
from typing import Any, Mapping, Optional, Union

import numpy as np

try:
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("flc.marl needs gymnasium and pettingzoo: pip install 'flc[gym]'") from e

from ._flc import ParameterError
from ._scenario import Scenario
from ._simulation import AccelCommand, Observation, Simulation, SpeedCommand
from .gym import ACTIONS, OBSERVATIONS, RewardWeights, observe, reward_terms

__all__ = ["PlatoonEnv"]


class PlatoonEnv(ParallelEnv):  # type: ignore[misc]
    """Every follower of a platoon scenario an agent (see the module docs).

    ``scenario``: a platoon :class:`flc.Scenario` (default: the brake demo,
    :meth:`flc.Scenario.brakedemo`, 7 followers). ``observation``, ``action``,
    ``policy_frequency``, ``simulation_frequency``, ``beams``, ``time_limit``, ``max_speed`` and
    ``reward`` as in :class:`flc.gym.FollowingEnv`. ``reset(seed=...)`` seeds the run (LiDAR noise,
    V2V channels).
    """

    metadata = {"name": "flc_platoon_v0", "render_modes": []}

    def __init__(
        self,
        scenario: Union[None, Scenario, Mapping[str, Any]] = None,
        *,
        observation: str = "kinematics",
        action: str = "acceleration",
        policy_frequency: float = 10.0,
        simulation_frequency: float = 100.0,
        beams: int = 64,
        time_limit: float = 60.0,
        max_speed: float = 40.0,
        reward: RewardWeights = RewardWeights(),
    ) -> None:
        if observation not in OBSERVATIONS:
            raise ParameterError(f"`observation`: one of {OBSERVATIONS}, got {observation!r}")
        if action not in ACTIONS:
            raise ParameterError(f"`action`: one of {ACTIONS}, got {action!r}")
        base = Scenario.brakedemo() if scenario is None else scenario if isinstance(scenario, Scenario) else Scenario.from_dict(scenario)
        self.scenario = base.replace(duration=float(time_limit), physics_dt=1.0 / float(simulation_frequency))
        d = self.scenario.to_dict()
        n = int((d.get("platoon") or {}).get("followers", 1))
        self.possible_agents = [f"follower_{k}" for k in range(1, n + 1)]
        self.agents: list[str] = []
        self.observation_type, self.action_type = observation, action
        self.policy_frequency, self.simulation_frequency, self.time_limit = float(policy_frequency), float(simulation_frequency), float(time_limit)
        self.beams, self.weights = int(beams), reward
        self.max_range = float(d["lidar"]["max_range"])
        if self.policy_frequency > float(d["lidar"]["rate_hz"]) + 1e-9:
            raise ParameterError(f"`policy_frequency`: at most the LiDAR's rate ({d['lidar']['rate_hz']} Hz), got {policy_frequency}")
        veh = d["follower"]["vehicle"]
        if action == "acceleration":
            self._action_space = spaces.Box(np.float32(-veh["max_brake"]), np.float32(veh["max_accel"]), shape=(1,), dtype=np.float32)
        else:
            self._action_space = spaces.Box(np.float32(0.0), np.float32(max_speed), shape=(1,), dtype=np.float32)
        from .gym import FollowingEnv

        probe = FollowingEnv(self.scenario, observation=observation, action=action, beams=beams, policy_frequency=policy_frequency)
        self._observation_space = probe._obs_box
        self._sim = Simulation(self.scenario, drive="all", command="accel" if action == "acceleration" else "speed", beams=beams if observation == "lidar" else 0)
        self._obs: dict[int, Observation] = {}
        self._prev_accel: dict[int, float] = {}
        self._collided: dict[int, bool] = {}
        self._rng = np.random.default_rng()

    @functools.lru_cache(maxsize=None)  # noqa: B019 - the spaces are fixed per agent (PettingZoo's idiom)
    def observation_space(self, agent: str) -> spaces.Box:
        return self._observation_space

    @functools.lru_cache(maxsize=None)  # noqa: B019
    def action_space(self, agent: str) -> spaces.Box:
        return self._action_space

    @property
    def simulation(self) -> Simulation:
        """The :class:`flc.Simulation` of the episode."""
        return self._sim

    def _vec(self, o: Observation) -> np.ndarray:
        sp = self._observation_space
        return np.clip(observe(self.observation_type, o, self.max_range), sp.low, sp.high).astype(np.float32)

    def reset(self, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        obs = self._sim.reset(seed=int(self._rng.integers(2**63)))
        self._obs = dict(obs)
        self._prev_accel = {k: o.truth.accel for k, o in obs.items()}
        self._collided = {k: o.truth.collision is not None for k, o in obs.items()}
        self.agents = list(self.possible_agents)
        return {f"follower_{k}": self._vec(o) for k, o in obs.items()}, {f"follower_{k}": {"gap": o.truth.gap} for k, o in obs.items()}

    def step(self, actions: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict[str, Any]]]:
        cmds: dict[int, Any] = {}
        for name, a in actions.items():
            k = int(name.rsplit("_", 1)[1])
            box = self._action_space
            v = float(np.clip(np.asarray(a, dtype=np.float64).reshape(-1)[0], box.low[0], box.high[0]))
            cmds[k] = AccelCommand(v) if self.action_type == "acceleration" else SpeedCommand(v)
        obs = self._sim.step(cmds, hold_until=self._obs[1].t + 1.0 / self.policy_frequency)
        done = obs[1].done
        truncated_all = done and obs[1].truth.t >= self.time_limit - 0.5 / self.simulation_frequency
        out_obs, rewards, terms, truncs, infos = {}, {}, {}, {}, {}
        for name in self.agents:
            k = int(name.rsplit("_", 1)[1])
            o, prev = obs[k], self._obs[k]
            dt = max(o.truth.t - prev.truth.t, 1e-9)
            now = o.truth.collision is not None and not self._collided[k]
            self._collided[k] |= now
            r = reward_terms(self.weights, o.truth.gap, o.truth.speed, o.truth.accel, self._prev_accel[k], dt, now)
            self._prev_accel[k] = o.truth.accel
            out_obs[name] = self._vec(o)
            rewards[name] = float(sum(r.values()))
            terms[name] = bool(self._collided[k] or (done and not truncated_all))
            truncs[name] = bool(truncated_all and not self._collided[k])
            infos[name] = {"reward_terms": r, "gap": o.truth.gap, "speed": o.truth.speed, "collision": o.truth.collision is not None}
        self._obs = dict(obs)
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        return out_obs, rewards, terms, truncs, infos
