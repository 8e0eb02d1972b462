"""Reference trajectories from SUMO's own car-following models (issue 16; docs/baselines.md).

Runs SUMO's ``IDM``, ``ACC``, ``CACC`` and ``Krauss`` (sigma 0) with ``libsumo`` on a fixed set of
lead manoeuvres, with perfect information as SUMO gives it, and writes one CSV per model and
scenario into ``tests/data/sumo/`` (header comment: SUMO version, step, vehicle-type parameters):

* ``paper-<v>``: the paper experiment (lead from standstill to v km/h, 650 m, then 6 m/s² to a stop;
  follower 7 m behind), v = 30, 50, 70, 90, 110, 130;
* ``steady-accel`` / ``steady-decel``: following a lead at 15 m/s that then changes speed at
  +1 / -1 m/s² for 5 s;
* ``brake<d>-gap<g>``: a lead at 50 km/h braking at d = 2 or 6 m/s² to a stop with the follower at
  the same speed g = 12 or 40 m behind.

Usage (needs ``pip install eclipse-sumo libsumo``, both 1.28)::

    python tools/sumo_reference.py [--out tests/data/sumo] [--step 0.1]

Written for this project from SUMO's public documentation (vType attributes, TraCI/libsumo); no
SUMO file is copied. The network is a generated 5 km straight single-lane road.
"""
from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

#: SUMO models and their vType attributes. SUMO's defaults unless stated; the follower's decel
#: limit is the paper experiment's 8 m/s² (emergencyDecel 9 so that the model's own limit binds).
MODELS: dict[str, dict[str, str]] = {
    "IDM": {"carFollowModel": "IDM", "accel": "2.6", "decel": "4.5", "emergencyDecel": "9", "tau": "1.0", "minGap": "2.5", "delta": "4", "stepping": "0.25"},
    "ACC": {"carFollowModel": "ACC", "accel": "2.6", "decel": "8", "emergencyDecel": "9", "tau": "1.0", "minGap": "2.5"},
    "CACC": {"carFollowModel": "CACC", "accel": "2.6", "decel": "8", "emergencyDecel": "9", "tau": "1.0", "minGap": "2.5"},
    "Krauss": {"carFollowModel": "Krauss", "accel": "2.6", "decel": "4.5", "emergencyDecel": "9", "tau": "1.0", "minGap": "2.5", "sigma": "0"},
}
#: The lead: a scripted vehicle whose speed is set every step (limits high enough to follow the
#: script exactly).
LEAD_TYPE = {"carFollowModel": "Krauss", "accel": "10", "decel": "10", "emergencyDecel": "10", "sigma": "0", "minGap": "2.5"}
LENGTH = 5.0
ROAD = 5000.0


def lead_profile(kind: str, t: float, x: float, v: float, step: float, p: dict[str, float]) -> float:
    """The lead's speed for the next step: accelerate / hold / brake as the scenario says."""
    if kind == "paper":
        if p.get("braking") or x >= 650.0:
            p["braking"] = 1.0
            return max(0.0, v - 6.0 * step)
        return min(p["v_max"], v + 2.5 * step)
    if kind == "steady":
        if t < 30.0:
            return p["v0"]
        if t < 35.0:
            return max(0.0, v + p["a"] * step)
        return v
    if kind == "brake":
        if t < 5.0:
            return p["v0"]
        return max(0.0, v - p["d"] * step)
    raise ValueError(kind)


def scenarios() -> list[tuple[str, str, dict[str, float]]]:
    out = [(f"paper-{v}", "paper", {"v_max": v / 3.6, "v0": 0.0, "gap": 7.0, "duration": 160.0}) for v in (30, 50, 70, 90, 110, 130)]
    out += [
        ("steady-accel", "steady", {"v0": 15.0, "a": 1.0, "gap": 17.5, "duration": 60.0}),
        ("steady-decel", "steady", {"v0": 15.0, "a": -1.0, "gap": 17.5, "duration": 60.0}),
    ]
    for d in (2.0, 6.0):
        for g in (12.0, 40.0):
            out.append((f"brake{int(d)}-gap{int(g)}", "brake", {"v0": 50 / 3.6, "d": d, "gap": g, "duration": 30.0}))
    return out


def network(dirpath: Path) -> Path:
    from sumo import SUMO_HOME  # noqa: F401  (the eclipse-sumo package)

    nod, edg, net = dirpath / "road.nod.xml", dirpath / "road.edg.xml", dirpath / "road.net.xml"
    nod.write_text(f'<nodes><node id="a" x="0" y="0"/><node id="b" x="{ROAD}" y="0"/></nodes>\n')
    edg.write_text('<edges><edge id="e" from="a" to="b" numLanes="1" speed="50"/></edges>\n')
    netconvert = Path(sys.executable).parent / "netconvert"
    subprocess.run([str(netconvert if netconvert.exists() else "netconvert"), "-n", str(nod), "-e", str(edg), "-o", str(net), "--no-warnings"], check=True)
    return net


def vtype(name: str, attrs: dict[str, str]) -> str:
    a = " ".join(f'{k}="{v}"' for k, v in attrs.items())
    # speedFactor 1 and speedDev 0: the desired speed is exactly maxSpeed (SUMO draws a random
    # speed factor per vehicle by default).
    return f'<vType id="{name}" length="{LENGTH}" maxSpeed="50" speedFactor="1" speedDev="0" {a}/>'


def run_one(net: Path, dirpath: Path, model: str, kind: str, p: dict[str, float], step: float) -> list[dict[str, float]]:
    import libsumo as traci

    rou = dirpath / "route.rou.xml"
    lead_pos = 100.0 + p["gap"] + LENGTH
    rou.write_text(
        "<routes>\n"
        + vtype("leadT", LEAD_TYPE)
        + "\n"
        + vtype("follT", MODELS[model])
        + '\n<route id="r" edges="e"/>\n'
        + f'<vehicle id="lead" type="leadT" route="r" depart="0" departPos="{lead_pos}" departSpeed="{p["v0"]}" insertionChecks="none"/>\n'
        + f'<vehicle id="foll" type="follT" route="r" depart="0" departPos="100" departSpeed="{p["v0"]}" insertionChecks="none"/>\n'
        + "</routes>\n"
    )
    traci.start(["sumo", "-n", str(net), "-r", str(rou), "--step-length", str(step), "--no-step-log", "--no-warnings", "--collision.action", "warn"])
    try:
        traci.simulationStep()
        traci.vehicle.setSpeedMode("lead", 0)
        rows = []
        state: dict[str, float] = dict(p)
        t = 0.0
        if "foll" not in traci.vehicle.getIDList():
            raise RuntimeError("the follower was not inserted")
        while t < p["duration"]:
            vl, xl = traci.vehicle.getSpeed("lead"), traci.vehicle.getLanePosition("lead")
            traci.vehicle.setSpeed("lead", lead_profile(kind, t, xl - lead_pos, vl, step, state))
            traci.simulationStep()
            t = traci.simulation.getTime()
            xl, vl = traci.vehicle.getLanePosition("lead"), traci.vehicle.getSpeed("lead")
            xf, vf = traci.vehicle.getLanePosition("foll"), traci.vehicle.getSpeed("foll")
            rows.append({"t": t, "lead_x": xl, "lead_speed": vl, "follower_x": xf, "follower_speed": vf, "gap": xl - LENGTH - xf})
            if kind != "steady" and vl == 0.0 and vf == 0.0 and t > 10.0:
                break
        return rows
    finally:
        traci.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="tests/data/sumo")
    ap.add_argument("--step", type=float, default=0.1)
    args = ap.parse_args(argv)
    import libsumo

    version = libsumo.__version__ if hasattr(libsumo, "__version__") else "?"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        net = network(d)
        for model in MODELS:
            for name, kind, p in scenarios():
                rows = run_one(net, d, model, kind, p, args.step)
                path = out / f"{model.lower()}-{name}.csv"
                with open(path, "w", newline="") as f:
                    attrs = " ".join(f"{k}={v}" for k, v in MODELS[model].items())
                    f.write(f"# SUMO {version} (libsumo), step {args.step} s, follower vType: length={LENGTH} speedFactor=1 speedDev=0 {attrs}; lead scripted by setSpeed ({kind})\n")
                    w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
                    w.writeheader()
                    for r in rows:
                        w.writerow({k: repr(v) for k, v in r.items()})
                print(path, len(rows), "rows", f"min gap {min(r['gap'] for r in rows):.2f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
