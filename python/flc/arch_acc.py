"""The ARCH-COMP AINNCS adaptive-cruise-control benchmark as flc scenarios (``docs/safety-evidence.md``).

The benchmark: the lead at x in [90, 110] m and 32-32.2 m/s, the ego at x in [10, 11] m and
30-30.2 m/s, the lead braking at -2 m/s², control period 0.1 s, horizon 5 s; the property
``D_rel >= 10 + 1.4 v_ego`` (:func:`flc.stl.robustness` ``"safe_distance"``). Here flc's
controllers drive the ego in place of the benchmark's neural network, in flc's closed loop:
``D_rel`` is the bumper-to-bumper gap (so the initial gap is in [79, 100] m), the controllers run
on each LiDAR scan at 10 Hz (the control period), and both vehicles are flc's vehicle model (dead
time, lag, resistances; the benchmark's are a double integrator with a 2 s lag). This is
*simulation on samples*: the 27 points of a 3 x 3 x 3 grid over (gap, lead speed, ego speed), each
with the scenario's fixed seed. It proves nothing about the points between them.
"""
from __future__ import annotations

import itertools
from typing import Any

from . import stl
from ._run import sweep
from ._scenario import Scenario

#: The controllers compared (the PID with working V2V; the others on the LiDAR alone).
CONTROLLERS: tuple[str, ...] = ("flc", "flc-robust", "pid", "acc", "idm")

GAP = (79.0, 100.0)
LEAD_SPEED = (32.0, 32.2)
EGO_SPEED = (30.0, 30.2)


def scenario(controller: str, gap: float, lead_speed: float, ego_speed: float) -> Scenario:
    """One point of the benchmark's initial set as an flc scenario."""
    return Scenario.paper(
        90.0,
        controller,
        "realistic",
        **{
            "name": "arch-comp-acc",
            "duration": 5.0,
            "lidar.rate_hz": 10.0,
            "lead.initial_speed": lead_speed,
            "follower.initial_speed": ego_speed,
            "follower.initial_gap": gap,
            "lead.phases": [{"kind": "brake", "decel": 2.0, "speed": 0.0}],
        },
    )


def grid() -> list[tuple[float, float, float]]:
    """The 27 sample points (gap, lead speed, ego speed): each interval's ends and middle."""
    axes = [(lo, (lo + hi) / 2, hi) for lo, hi in (GAP, LEAD_SPEED, EGO_SPEED)]
    return [(g, vl, ve) for g, vl, ve in itertools.product(*axes)]


def evaluate(controllers: tuple[str, ...] = CONTROLLERS) -> list[dict[str, Any]]:
    """Per controller: samples, violations of the property, the least robustness and its point."""
    pts = grid()
    runs = sweep([scenario(c, *p) for c in controllers for p in pts])
    out = []
    for i, c in enumerate(controllers):
        rs = runs[i * len(pts) : (i + 1) * len(pts)]
        rob = [stl.robustness(r, "safe_distance") for r in rs]
        k = min(range(len(rob)), key=lambda j: rob[j])
        out.append({
            "controller": c,
            "samples": len(pts),
            "violations": sum(x < 0 for x in rob),
            "collisions": sum(bool(r.metrics["collision"]) for r in rs),
            "min_robustness": rob[k],
            "worst": pts[k],
        })
    return out
