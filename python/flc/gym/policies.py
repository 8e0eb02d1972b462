"""``flc.gym.policies``: flc's controllers as policies of :class:`flc.gym.FollowingEnv`, and
:func:`evaluate` to compare any agent with them.

A policy is a callable ``policy(observation) -> action``. The expert policies read the LiDAR
measurement the env's last scan gave (:meth:`FollowingEnv.frame`: the detected distance, own
speed and the latest V2V message: what the scenario's law gets, never the ground truth) and step
the Rust law of the scenario's registry (``flc_sim::ControllerKind``, with the scenario's
parameter sections) once per decision, with ``dt`` the time since the previous decision. With
``action="speed"`` the action is the law's speed command; with ``action="acceleration"`` it is
the demand of the ego's own low-level speed controller (``follower.speed_controller``) for that
command, stepped once per decision.

>>> import gymnasium as gym, flc.gym
>>> from flc.gym import policies
>>> env = gym.make("flc/Following-v0")
>>> stats = policies.evaluate(policies.FLC(env), env, episodes=2, seed=0)
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Callable, Optional

import numpy as np

from .. import _flc

__all__ = ["LawPolicy", "FLC", "RobustFLC", "Pipeline", "IDM", "RandomPolicy", "evaluate", "Evaluation"]


class LawPolicy:
    """The law of registry controller ``controller`` (``flc.controller_names()``) as a policy of
    ``env`` (a :class:`FollowingEnv` or a wrapper of one). ``overrides``: keyword overrides of
    the episode's scenario (``flc_t_g=1.2``, as :meth:`flc.Scenario.replace` takes them).
    """

    def __init__(self, env: Any, controller: str, **overrides: Any) -> None:
        self.env = env.unwrapped
        self.controller = controller
        self.overrides = overrides
        self._law: Optional[Any] = None
        self._scenario = ""
        self._t: Optional[float] = None
        self._seq: Optional[int] = None

    def _start(self) -> None:
        from .._scenario import Scenario

        sc = Scenario(json.loads(self.env._core.scenario_json(0))).replace(controller=self.controller, **self.overrides)
        self._law = _flc.ScenarioLaw(sc.to_json())
        self._t, self._seq = None, None

    def __call__(self, observation: Any = None) -> np.ndarray:
        t, distance, own_speed, v2v = self.env.frame()
        scenario = self.env._core.scenario_json(0)
        if self._law is None or scenario != self._scenario or (self._t is not None and t < self._t):
            self._scenario = scenario
            self._start()
        dt = 1.0 / self.env.policy_frequency if self._t is None else max(t - self._t, 1e-6)
        self._t = t
        msg = None
        if v2v is not None and v2v[1] != self._seq:
            msg, self._seq = v2v, v2v[1]
        assert self._law is not None
        speed, accel = self._law.step(distance, own_speed, dt, msg)
        a = speed if self.env.action_type == "speed" else accel
        return np.array([a], dtype=np.float32)


def FLC(env: Any, **overrides: Any) -> LawPolicy:
    """The paper's FLC (Eqs. 2-5; ``controller="flc"``): LiDAR distance and own speed only."""
    return LawPolicy(env, "flc", **overrides)


def RobustFLC(env: Any, **overrides: Any) -> LawPolicy:
    """The robust FLC (``controller="flc-robust"``, ``docs/robust-flc.md``)."""
    return LawPolicy(env, "flc-robust", **overrides)


def Pipeline(env: Any, **overrides: Any) -> LawPolicy:
    """The paper's pipeline (``controller="pipeline"``): the PID gap controller on fresh V2V,
    the FLC otherwise, switched by the supervisor."""
    return LawPolicy(env, "pipeline", **overrides)


def IDM(env: Any, **overrides: Any) -> LawPolicy:
    """The Intelligent Driver Model on the LiDAR (``controller="idm"``, Treiber et al. 2000)."""
    return LawPolicy(env, "idm", **overrides)


class RandomPolicy:
    """Uniform random actions from the env's action space (seeded)."""

    def __init__(self, env: Any, seed: int = 0) -> None:
        self.space = env.action_space
        self.space.seed(seed)

    def __call__(self, observation: Any = None) -> np.ndarray:
        return np.asarray(self.space.sample(), dtype=np.float32)


@dataclass(frozen=True)
class Evaluation:
    """What :func:`evaluate` returns: per-episode ``returns``, ``lengths`` (steps),
    ``collisions`` and the summed reward ``terms``."""

    returns: np.ndarray
    lengths: np.ndarray
    collisions: np.ndarray
    terms: dict[str, np.ndarray]

    @property
    def mean_return(self) -> float:
        return float(np.mean(self.returns))


def evaluate(policy: Callable[[Any], Any], env: Any, episodes: int = 10, seed: int = 0) -> Evaluation:
    """Runs ``episodes`` episodes of ``env`` (reset with seeds ``seed``, ``seed + 1``, ...) with
    ``policy(observation) -> action``."""
    returns, lengths, collisions = [], [], []
    terms: dict[str, list[float]] = {}
    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        total, n = 0.0, 0
        sums: dict[str, float] = {}
        while True:
            obs, r, term, trunc, info = env.step(policy(obs))
            total += r
            n += 1
            for name, v in info["reward_terms"].items():
                sums[name] = sums.get(name, 0.0) + v
            if term or trunc:
                break
        returns.append(total)
        lengths.append(n)
        collisions.append(bool(info["collision"]))
        for name, v in sums.items():
            terms.setdefault(name, []).append(v)
    return Evaluation(np.array(returns), np.array(lengths), np.array(collisions), {k: np.array(v) for k, v in terms.items()})
