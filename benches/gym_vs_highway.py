"""Environment steps per second: flc's FollowingEnv against highway-env's highway-v0, side by side
in one process, both with a LiDAR-like observation (issue 26; results in docs/benchmarks.md).

* ``flc/Following-v0``: the paper experiment at 70 km/h (fixed scenario), observation ``"lidar"``
  (``--beams`` range beams from flc's 1201-ray ray-cast LiDAR at 20 Hz, 100 Hz physics, the
  detector, V2V and actuator models), speed actions from the paper's FLC (``flc.FallbackController``);
* ``highway-v0`` (highway-env, installed for the benchmark only: ``pip install highway-env``):
  ``LidarObservation`` with ``--beams`` cells, its default 15 Hz simulation, random actions,
  ``vehicles_count`` from ``--highway-vehicles`` (its default 50, and 1 as in flc's scenario).

Both at the same policy frequency (``--policy-hz``, default 1 Hz: highway-v0's default; an env
step is then the same simulated time in both), each reset when its episode ends, best of
``--repeats`` timings of ``--steps`` steps.

Run: python benches/gym_vs_highway.py [--policy-hz 1 5] [--beams 180] [--steps 300]
"""
from __future__ import annotations

import argparse
import platform
import time
from typing import Any, Callable

import gymnasium as gym
import numpy as np


def rate(env: Any, act: Callable[[], Any], steps: int, repeats: int, seed: int = 0) -> float:
    best = float("inf")
    for r in range(repeats):
        env.reset(seed=seed + r)
        t0 = time.perf_counter()
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(act())
            if term or trunc:
                env.reset()
        best = min(best, time.perf_counter() - t0)
    return steps / best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policy-hz", type=float, nargs="+", default=[1.0, 5.0])
    ap.add_argument("--beams", type=int, default=180)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--highway-vehicles", type=int, nargs="+", default=[50, 1],
                    help="highway-v0's vehicles_count (50: its default; 1: one other car, as flc's scenario)")
    args = ap.parse_args()

    import flc
    import flc.gym  # noqa: F401  (registers flc/Following-v0)
    import highway_env  # noqa: F401  (registers highway-v0)

    print(f"flc {flc.__name__}; highway-env {getattr(highway_env, '__version__', '?')}; gymnasium {gym.__version__}; "
          f"Python {platform.python_version()}; {platform.machine()} {platform.processor() or ''}")
    print(f"{'policy Hz':>9} {'flc steps/s':>12} {'highway vehicles':>17} {'highway steps/s':>16} {'ratio':>7}")
    for hz in args.policy_hz:
        fenv = gym.make(
            "flc/Following-v0",
            scenario=flc.Scenario.paper(70, "flc"),
            observation="lidar",
            action="speed",
            beams=args.beams,
            policy_frequency=hz,
            time_limit=150.0,
        )
        # The policy: the paper's FLC on the detected gap (the simulation's measurement), so that
        # the ego follows the lead as in the paper's run.
        law = flc.FallbackController()
        sim = fenv.unwrapped

        def flc_policy() -> np.ndarray:
            o = sim._obs
            return np.array([law.step(o.distance, o.own_speed).speed], dtype=np.float32)

        f = rate(fenv, flc_policy, args.steps, args.repeats)
        for n in args.highway_vehicles:
            henv = gym.make(
                "highway-v0",
                config={
                    "observation": {"type": "LidarObservation", "cells": args.beams, "maximum_range": 200},
                    "policy_frequency": hz,
                    "duration": 10_000,
                    "vehicles_count": n,
                },
            )
            henv.action_space.seed(0)
            h = rate(henv, henv.action_space.sample, args.steps, args.repeats)
            henv.close()
            print(f"{hz:>9g} {f:>12.0f} {n:>17} {h:>16.1f} {f / h:>7.1f}")


if __name__ == "__main__":
    main()
