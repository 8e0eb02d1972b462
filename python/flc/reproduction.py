"""The paper's outcome pattern over the constants it leaves open (``docs/paper-reproduction.md``).

The paper's Sec. IV has eight cells: the FLC stops at 30 / 50 / 70 km/h (3.8 / 4.0 / 2.3 m) and
collides at 90; the V2V PID stops at 30 / 50 (7.9 / 1.2 m) and collides at 70 / 90. A *point* is
one set of values for the constants of ``sweeps/paper-reproduction.toml`` (brake authority,
actuator response, FLC negative multiplier, speed-controller gain, LiDAR rate and latency, PID
gain), applied alike to both controllers on top of the realistic preset; it *matches* a cell when
the simulated outcome (stop / collision) is the paper's.

:func:`make_all` (``python -m flc reproduction``) computes

* the 2-D map brake authority x actuator response (matching cells per point),
* one-at-a-time lines through the chosen point for every constant and the seeds,
* a random sample over all constants (the size of the all-8 region),

writes them as ``sweeps/paper-reproduction-{map,lines,random}.csv`` (the figures are
:func:`flc.figures.make_reproduction`'s; this module imports no plotting code).
"""
from __future__ import annotations

import csv
import os
import random
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, Union

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib  # type: ignore[no-redef]

from . import _flc
from ._run import sweep
from ._paths import REPRODUCTION, source_root
from ._scenario import Scenario

PathLike = Union[str, "os.PathLike[str]"]


#: The source tree (the documents; ``flc._paths.source_root``), else the working directory: only
#: the developer commands that check for it first use it (``python -m flc docs``).
ROOT = source_root() or Path.cwd()
#: The reproduction data that ships with the package (``flc/data/reproduction``, linked from
#: ``sweeps/``): the spec and the committed CSVs.
DATA_DIR = REPRODUCTION
SPEC_PATH = DATA_DIR / "paper-reproduction.toml"

#: The paper's cells: (controller, km/h) -> clearance at standstill (m), ``None`` = collision.
PAPER: dict[tuple[str, float], Optional[float]] = {
    ("flc", 30.0): 3.8, ("flc", 50.0): 4.0, ("flc", 70.0): 2.3, ("flc", 90.0): None,
    ("pid", 30.0): 7.9, ("pid", 50.0): 1.2, ("pid", 70.0): None, ("pid", 90.0): None,
}
CELLS = list(PAPER)


def load_spec(path: PathLike = SPEC_PATH) -> dict[str, Any]:
    with open(path, "rb") as f:
        return tomllib.load(f)


def constants(spec: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    return {c["name"]: c for c in spec["constants"]}


def base_point(spec: Mapping[str, Any]) -> dict[str, float]:
    return {c["name"]: float(c["base"]) for c in spec["constants"]}


def overrides(spec: Mapping[str, Any], point: Mapping[str, float]) -> dict[str, Any]:
    """The scenario keys of a point (the rate is needed to turn a latency into whole frames)."""
    cs = constants(spec)
    out: dict[str, Any] = {}
    rate = float(point.get("lidar_rate", cs["lidar_rate"]["base"]))
    for name, value in point.items():
        c = cs[name]
        if c.get("latency_ms"):
            out["lidar.latency_frames"] = int(round(value / 1000.0 * rate))
        else:
            for key, share in c["keys"].items():
                out[key] = value * share
    return out


def scenarios(spec: Mapping[str, Any], point: Mapping[str, float], seed: int = 1) -> list[Scenario]:
    ov = overrides(spec, point)
    return [Scenario.paper(speed_kmh=v, controller=c, preset="realistic", seed=seed, **ov) for (c, v) in CELLS]


def outcomes(results: Sequence[Any]) -> list[dict[str, Any]]:
    """Per cell: collision, clearance (m), impact speed (m/s), matches the paper."""
    out = []
    for cell, r in zip(CELLS, results):
        m = r.metrics
        collided = bool(m["collision"])
        out.append(
            {
                "collision": collided,
                "clearance": m["final_clearance"] if not collided else None,
                "impact_speed": m["impact_speed"],
                "match": collided == (PAPER[cell] is None),
            }
        )
    return out


def evaluate(spec: Mapping[str, Any], points: Sequence[Mapping[str, float]], seeds: Sequence[int] = (1,),
             threads: Optional[int] = None) -> list[list[dict[str, Any]]]:
    """Each point at each seed: the 8 cells (all runs in parallel in Rust)."""
    jobs = [(p, s) for p in points for s in seeds]
    scs = [sc for (p, s) in jobs for sc in scenarios(spec, p, s)]
    res = sweep(scs, threads=threads)
    n = len(CELLS)
    return [outcomes(res[i * n:(i + 1) * n]) for i in range(len(jobs))]


def row(point: Mapping[str, float], seed: int, cells: Sequence[Mapping[str, Any]], **extra: Any) -> dict[str, Any]:
    r: dict[str, Any] = dict(extra)
    r.update(point)
    r["seed"] = seed
    r["matches"] = sum(1 for c in cells if c["match"])
    for (ctrl, v), c in zip(CELLS, cells):
        tag = f"{ctrl}{int(v)}"
        r[f"{tag}_collision"] = int(c["collision"])
        r[f"{tag}_clearance"] = "" if c["clearance"] is None else c["clearance"]
        r[f"{tag}_impact"] = c["impact_speed"]
    return r


def write_csv(path: PathLike, rows: Sequence[Mapping[str, Any]]) -> None:
    keys: list[str] = []
    for r in rows:
        keys.extend(k for k in r if k not in keys)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})


def read_csv(path: PathLike) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def run_map(spec: Mapping[str, Any], threads: Optional[int] = None) -> list[dict[str, Any]]:
    m = spec["map"]
    base = base_point(spec)
    points = [dict(base, **{m["x"]: float(x), m["y"]: float(y)}) for y in m["y_values"] for x in m["x_values"]]
    return [row(p, 1, cells) for p, cells in zip(points, evaluate(spec, points, (1,), threads))]


def choose(spec: Mapping[str, Any], map_rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The preset point of the map: the point whose worst neighbour (one grid step in x and y,
    diagonals included) matches the most cells; ties go to more matches at the point itself,
    then to more matches summed over the neighbourhood, then to the larger brake authority."""
    m = spec["map"]
    xs, ys = [float(v) for v in m["x_values"]], [float(v) for v in m["y_values"]]
    grid = {(float(r[m["x"]]), float(r[m["y"]])): int(r["matches"]) for r in map_rows}
    best: Optional[tuple[Any, ...]] = None
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            nb = [grid[(xs[a], ys[b])] for a in range(max(0, i - 1), min(len(xs), i + 2)) for b in range(max(0, j - 1), min(len(ys), j + 2))]
            key = (min(nb), grid[(x, y)], sum(nb), x)
            if best is None or key > best[0]:
                best = (key, x, y, min(nb), grid[(x, y)])
    assert best is not None
    _, x, y, worst, own = best
    return {m["x"]: x, m["y"]: y, "worst_neighbour": worst, "matches": own}


def line_values(c: Mapping[str, Any], n: int = 9) -> list[float]:
    if "values" in c:
        return [float(v) for v in c["values"]]
    lo, hi = (float(v) for v in c["range"])
    return [lo + (hi - lo) * k / (n - 1) for k in range(n)]


def run_lines(spec: Mapping[str, Any], center: Mapping[str, float], threads: Optional[int] = None) -> list[dict[str, Any]]:
    points, tags = [], []
    for c in spec["constants"]:
        for v in sorted(set(line_values(c)) | {float(center[c["name"]])}):
            points.append(dict(center, **{c["name"]: v}))
            tags.append(c["name"])
    rows = [row(p, 1, cells, varied=t) for p, t, cells in zip(points, tags, evaluate(spec, points, (1,), threads))]
    seeds = [int(s) for s in spec["seeds"]]
    for s, cells in zip(seeds, evaluate(spec, [center], seeds, threads)):
        rows.append(row(center, s, cells, varied="seed"))
    return rows


def run_random(spec: Mapping[str, Any], threads: Optional[int] = None) -> list[dict[str, Any]]:
    rng = random.Random(int(spec["random_seed"]))
    points = []
    for _ in range(int(spec["random_samples"])):
        p = {}
        for c in spec["constants"]:
            p[c["name"]] = float(rng.choice(c["values"])) if "values" in c else rng.uniform(*[float(v) for v in c["range"]])
        points.append(p)
    return [row(p, 1, cells) for p, cells in zip(points, evaluate(spec, points, (1,), threads))]


def region_share(rows: Sequence[Mapping[str, Any]]) -> float:
    """Share of the rows that match all 8 cells."""
    return sum(1 for r in rows if int(r["matches"]) == 8) / max(1, len(rows))


def compute(data_dir: PathLike = DATA_DIR, threads: Optional[int] = None) -> dict[str, Any]:
    """Computes the map, the lines through the chosen point and the random sample and writes the
    CSVs into ``data_dir``. Returns the chosen point and the region sizes. (This module computes;
    :func:`flc.figures.make_reproduction` computes and draws the figures.)"""
    spec = load_spec()
    data = Path(data_dir)
    data.mkdir(parents=True, exist_ok=True)
    map_rows = run_map(spec, threads)
    write_csv(data / "paper-reproduction-map.csv", map_rows)
    chosen = choose(spec, map_rows)
    m = spec["map"]
    center = dict(base_point(spec), **{m["x"]: chosen[m["x"]], m["y"]: chosen[m["y"]]})
    lines = run_lines(spec, center, threads)
    write_csv(data / "paper-reproduction-lines.csv", lines)
    rnd = run_random(spec, threads)
    write_csv(data / "paper-reproduction-random.csv", rnd)
    return {
        "chosen": chosen,
        "map_share_8": region_share(map_rows),
        "random_share_8": region_share(rnd),
        "random_share_7": sum(1 for r in rnd if int(r["matches"]) >= 7) / len(rnd),
    }
