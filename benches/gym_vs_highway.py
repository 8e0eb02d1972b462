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

The vector env (issue 49): ``gym.make_vec("flc/Following-v0", num_envs=N,
vectorization_mode="vector_entry_point")`` with the same observation, against the single env, both
with a constant speed action (``--speed``, default 20 m/s; no Python policy in the timing): env-steps per second
(``--vector-envs``, N steps of the vector env count N).

Run: python benches/gym_vs_highway.py [--policy-hz 1 5] [--beams 180] [--steps 300] [--vector-envs 2 4 8] [--no-highway]
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
    ap.add_argument("--vector-envs", type=int, nargs="+", default=[2, 4, 8])
    ap.add_argument("--speed", type=float, default=20.0,
                    help="the vector comparison's constant speed action, m/s (20: the ego hits the accelerating lead at 4.6 s, "
                         "an episode of 23 steps at 5 Hz; 5: no contact within the 150 s limit, resets rare)")
    ap.add_argument("--no-highway", action="store_true", help="skip highway-env (not installed)")
    args = ap.parse_args()

    import flc
    import flc.gym  # noqa: F401  (registers flc/Following-v0)
    import os

    from flc.gym import policies

    print(f"gymnasium {gym.__version__}; Python {platform.python_version()}; {platform.machine()} {platform.processor() or ''}; "
          f"{os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f}")
    vector_rates(args)
    if args.no_highway:
        return
    import highway_env  # noqa: F401  (registers highway-v0)

    print(f"highway-env {getattr(highway_env, '__version__', '?')}")
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
        flc_law = policies.FLC(fenv)
        f = rate(fenv, lambda: flc_law(None), args.steps, args.repeats)
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


def vector_rates(args: argparse.Namespace) -> None:
    import flc

    kw = dict(scenario=flc.Scenario.paper(70, "flc"), observation="lidar", action="speed", beams=args.beams, time_limit=150.0)
    print(f"{'policy Hz':>9} {'single env steps/s':>19} {'num_envs':>9} {'vector env-steps/s':>19} {'ratio':>7}")
    for hz in args.policy_hz:
        single = gym.make("flc/Following-v0", policy_frequency=hz, **kw)
        act = np.array([args.speed], dtype=np.float32)
        s = rate(single, lambda: act, args.steps, args.repeats)
        single.close()
        for n in args.vector_envs:
            venv = gym.make_vec("flc/Following-v0", num_envs=n, vectorization_mode="vector_entry_point", policy_frequency=hz, **kw)
            acts = np.full((n, 1), args.speed, dtype=np.float32)
            best = float("inf")
            steps = max(args.steps // n, 20)
            for r in range(args.repeats):
                venv.reset(seed=r)
                t0 = time.perf_counter()
                for _ in range(steps):
                    venv.step(acts)  # next-step autoreset
                best = min(best, time.perf_counter() - t0)
            v = steps * n / best
            venv.close()
            print(f"{hz:>9g} {s:>19.0f} {n:>9} {v:>19.0f} {v / s:>7.2f}")


if __name__ == "__main__":
    main()
