"""The committed reproduction map (sweeps/paper-reproduction-*.csv) is what the code computes,
and the paper preset is the point the map chooses (docs/paper-reproduction.md)."""
import random

import numpy as np

import flc
from flc import reproduction as rp
from flc import figures


def _as_written(r):
    """A row as ``rp.write_csv`` writes it (floats in repr, so equal text = equal bits)."""
    return {k: (repr(v) if isinstance(v, float) else str(v)) for k, v in r.items()}


def _recompute(spec, rows):
    """Recomputes committed rows (their point and seed) and compares every column: the matches, and
    per cell the collision, the clearance and the impact speed, bit for bit."""
    names = [c["name"] for c in spec["constants"]]
    points = [{n: float(r[n]) for n in names} for r in rows]
    seeds = {int(r["seed"]) for r in rows}
    assert seeds == {1}, seeds  # the map and the random sample are computed at seed 1
    for r, p, cells in zip(rows, points, rp.evaluate(spec, points, (1,))):
        again = _as_written(rp.row(p, 1, cells))
        committed = {k: r[k] for k in again}
        assert again == committed, {k: (committed[k], again[k]) for k in again if again[k] != committed[k]}


def test_every_all_8_row_of_the_map_and_its_grid_neighbours_are_reproduced():
    # The region the docs quote (all 8 cells) rests on these rows and its edge on their
    # neighbours (one grid step in x and y, diagonals included): every one recomputed.
    spec = rp.load_spec()
    m = spec["map"]
    xs, ys = [float(v) for v in m["x_values"]], [float(v) for v in m["y_values"]]
    rows = rp.read_csv(rp.ROOT / "sweeps" / "paper-reproduction-map.csv")
    assert len(rows) == len(xs) * len(ys)
    at = {(xs.index(float(r[m["x"]])), ys.index(float(r[m["y"]]))): r for r in rows}
    eight = [ij for ij, r in at.items() if int(r["matches"]) == 8]
    assert eight, "no all-8 row in the map"
    near = sorted({(i + a, j + b) for (i, j) in eight for a in (-1, 0, 1) for b in (-1, 0, 1) if (i + a, j + b) in at})
    _recompute(spec, [at[ij] for ij in near])
    # The share the docs quote is that of the committed rows.
    assert abs(100.0 * rp.region_share(rows) - 100.0 * len(eight) / len(rows)) < 1e-12


def test_every_all_8_row_of_the_random_sample_and_three_others_are_reproduced():
    spec = rp.load_spec()
    rows = rp.read_csv(rp.ROOT / "sweeps" / "paper-reproduction-random.csv")
    eight = [r for r in rows if int(r["matches"]) == 8]
    assert eight, "no all-8 row in the random sample"
    others = random.Random(3).sample([r for r in rows if int(r["matches"]) != 8], 3)
    _recompute(spec, eight + others)


def test_the_paper_preset_is_the_point_the_map_chooses():
    spec = rp.load_spec()
    chosen = rp.choose(spec, rp.read_csv(rp.ROOT / "sweeps" / "paper-reproduction-map.csv"))
    d = flc.Scenario.paper(speed_kmh=50, controller="pid", preset="paper").to_dict()
    r = flc.Scenario.paper(speed_kmh=50, controller="pid", preset="realistic").to_dict()
    assert d["follower"]["speed_controller"]["max_decel"] == chosen["brake_authority"]
    veh = d["follower"]["vehicle"]
    assert abs(veh["dead_time"] + veh["lag"] - chosen["actuator_response"]) < 1e-12
    # The same constants for both controllers, no controller gain changed by the preset.
    assert d["pid"] == r["pid"] and d["flc"] == r["flc"]
    assert chosen["matches"] == 8 and chosen["worst_neighbour"] == 7


def test_choose_prefers_the_most_robust_point():
    spec = {"map": {"x": "a", "y": "b", "x_values": [1, 2, 3], "y_values": [1, 2, 3]}}
    grid = {(1, 1): 8, (2, 1): 8, (3, 1): 5, (1, 2): 8, (2, 2): 8, (3, 2): 8, (1, 3): 8, (2, 3): 8, (3, 3): 8}
    rows = [{"a": x, "b": y, "matches": m} for (x, y), m in grid.items()]
    c = rp.choose(spec, rows)
    # (1, 3), (2, 3) and (3, 3) have all-8 neighbourhoods; (2, 3) has the most neighbours (the sum breaks the tie).
    assert (c["a"], c["b"], c["worst_neighbour"]) == (2.0, 3.0, 8)


def test_reproduction_figure_data():
    d = figures.reproduction_data(rp.ROOT / "sweeps")
    assert d["matches"].shape == (len(d["y"]), len(d["x"]))
    assert np.nanmax(d["matches"]) == 8 and np.nanmin(d["matches"]) >= 0
    assert set(d["lines"]) >= {"negative_multiplier", "speed_kp", "lidar_rate", "lidar_latency", "pid_kd", "seed"}
    xs, ms = d["lines"]["seed"]
    assert list(xs) == [1, 2, 3, 4, 5] and all(m == 8 for m in ms)


def test_the_module_that_computes_does_not_import_the_one_that_draws() -> None:
    import ast
    import subprocess
    import sys
    from pathlib import Path

    src = Path(rp.__file__).read_text(encoding="utf-8")
    imported = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.ImportFrom):
            imported |= {f"{node.module or ''}.{a.name}".strip(".") for a in node.names}
        elif isinstance(node, ast.Import):
            imported |= {a.name for a in node.names}
    assert not [m for m in imported if "figures" in m or "matplotlib" in m], imported
    # Importing it loads neither flc.figures nor matplotlib.
    code = "import sys, flc.reproduction; print('flc.figures' in sys.modules, 'matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False"]
