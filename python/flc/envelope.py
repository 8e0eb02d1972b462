"""Safety envelope: run or read sweeps, summarise them per controller and draw maps of minimum
gap / impact speed with the collision boundary (``docs/safety-envelope.md``).

Two sources, the same columns:

* :func:`run_grid` runs the paper scenario family over (max speed x one more axis) per controller
  from Python (parallel in Rust, or on any ``concurrent.futures`` executor);
* :func:`load_sweep` reads the CSV of ``scenario sweep FILE.toml --out CSV``.

:func:`make_all` is what ``python -m flc figures`` calls: both grids (speed x lead deceleration,
speed x LiDAR latency) for every controller, maps, bar charts and summary tables.
"""
from __future__ import annotations

import csv
import os
from pathlib import Path
from concurrent.futures import Executor
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _flc

PathLike = Union[str, "os.PathLike[str]"]
#: Sweep columns: text columns as string arrays, everything else as float arrays.
Columns = dict[str, np.ndarray]
Source = Union[PathLike, Mapping[str, np.ndarray]]

#: Controllers of the default maps: every controller of the Rust registry, in its order, except
#: the switching ``pipeline`` (the paper's FLC, the paper's PID with true V2V as the upper
#: reference, the baselines under identical sensing (``docs/baselines.md``), the robust FLC
#: (``docs/robust-flc.md``), ...).
CONTROLLERS: tuple[str, ...] = tuple(c for c in _flc.controller_names() if c != "pipeline")
#: Max speeds of the default maps, km/h.
SPEEDS_KMH = tuple(float(v) for v in range(30, 151, 10))
#: Lead decelerations of the speed x deceleration map, m/s².
LEAD_DECELS = tuple(float(v) for v in range(2, 10))
#: LiDAR latencies of the speed x latency map, frames (0-300 ms at 20 Hz).
LATENCY_FRAMES = tuple(float(v) for v in range(0, 7))


def _num(v: str) -> float:
    if v in ("", "null"):
        return float("nan")
    if v in ("true", "false"):
        return 1.0 if v == "true" else 0.0
    try:
        return float(v)
    except ValueError:
        return float("nan")


def load_sweep(path: PathLike) -> dict[str, np.ndarray]:
    """Columns of a sweep CSV: numbers as float arrays (``collision`` as 0/1, empty as NaN),
    text columns (``controller``, ``error``: empty or the message of a run that failed) as string
    arrays; rows sorted by ``run_id``."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    rows.sort(key=lambda r: int(r["run_id"]))
    cols: dict[str, np.ndarray] = {}
    for k in rows[0].keys() if rows else []:
        vals = [r[k] for r in rows]
        if k in ("controller", "error"):
            cols[k] = np.array(vals, dtype=str)
        else:
            cols[k] = np.array([_num(v) for v in vals])
    return cols


#: Axis / colour-bar labels with units.
LABELS = {
    "speed_kmh": "max speed (km/h)",
    "lead_decel": "lead deceleration (m/s²)",
    "lidar.latency_frames": "LiDAR latency (frames, 50 ms each at 20 Hz)",
    "min_gap": "min gap (m)",
    "impact_speed": "impact speed (m/s)",
}


def _label(key: str) -> str:
    return LABELS.get(key, key)


def _scenario_with(speed_kmh: float, controller: str, preset: str, seed: int, key: str, value: float) -> Any:
    from ._scenario import Scenario

    sc = Scenario.paper(speed_kmh=speed_kmh, controller=controller, preset=preset, seed=seed)
    if key == "speed_kmh":
        return sc
    if key == "lead_decel":
        # The family key of the one patch mechanism (Rust): every brake phase's deceleration.
        return sc.replace(lead_decel=float(value))
    return sc.replace(**{key: int(value) if float(value).is_integer() else value})


#: Runs per batch of :func:`run_grid` when it reports progress.
PROGRESS_BATCH = 64


def run_grid(
    y: str = "lead_decel",
    y_values: Sequence[float] = LEAD_DECELS,
    controllers: Sequence[str] = CONTROLLERS,
    speeds_kmh: Sequence[float] = SPEEDS_KMH,
    preset: str = "realistic",
    seed: int = 1,
    threads: Optional[int] = None,
    executor: Optional[Executor] = None,
    progress: Optional[Callable[[int, int], None]] = None,
) -> Columns:
    """Runs the paper scenario family (``flc.Scenario.paper``) for every controller x max speed x
    ``y`` value and returns the same columns as :func:`load_sweep` (``controller``, ``speed_kmh``,
    ``y`` and every metric of ``scenario --json``). ``y`` is ``"lead_decel"`` (the brake phase's
    deceleration, m/s²) or any dotted scenario key (e.g. ``"lidar.latency_frames"``). Run ``i``
    (controller-major, ``y`` fastest) gets the seed ``scenario sweep`` gives its run ``i`` for the
    sweep seed ``seed``, so ``sweeps/envelope-decel.toml`` gives the same rows. With
    ``progress``, ``progress(done, total)`` is called as the runs finish (they then run in batches
    of :data:`PROGRESS_BATCH`; the results do not change)."""
    from ._run import sweep

    keys = [(c, float(v), float(w)) for c in controllers for v in speeds_kmh for w in y_values]
    # Run i gets the seed `scenario sweep` gives run i, so a sweep file with the axes controller,
    # speed_kmh, y (in that order) and the same seed has exactly these rows.
    scs = [_scenario_with(v, c, preset, _flc.sweep_run_seed(seed, i), y, w) for i, (c, v, w) in enumerate(keys)]
    if progress is None:
        results = sweep(scs, threads=threads, executor=executor)
    else:
        results = []
        for start in range(0, len(scs), PROGRESS_BATCH):
            results += sweep(scs[start : start + PROGRESS_BATCH], threads=threads, executor=executor)
            progress(len(results), len(scs))
    cols: Columns = {"controller": np.array([c for c, _, _ in keys], dtype=str)}
    cols["speed_kmh"] = np.array([v for _, v, _ in keys])
    cols[y] = np.array([w for _, _, w in keys])
    names = [k for k, val in results[0].metrics.items() if isinstance(val, (bool, int, float)) or val is None] if results else []
    for k in names:
        if k in cols:
            continue
        vals = [r.metrics.get(k) for r in results]
        cols[k] = np.array([float("nan") if x is None else float(x) for x in vals])
    return cols


def _cols(source: Source) -> Columns:
    if isinstance(source, Mapping):
        return {k: np.asarray(v) for k, v in source.items()}
    return load_sweep(source)


def highest_safe(speeds: np.ndarray, collided: np.ndarray) -> float:
    """Highest speed such that no run at that speed or below collided (NaN if the lowest collided)."""
    order = np.argsort(speeds)
    best = float("nan")
    for s, c in zip(speeds[order], collided[order]):
        if c:
            break
        best = float(s)
    return best


def summary(cols: dict[str, np.ndarray], group: str = "lead_decel") -> list[dict[str, Any]]:
    """One row per (controller, ``group`` value): highest collision-free speed, min TTC and max
    DRAC over the group (and the median over its runs of each run's min TTC / max DRAC), comfort (max decel, max jerk, time above 3.5 m/s²) and gap keeping."""
    out: list[dict[str, Any]] = []
    ctrls = cols["controller"]
    gvals = cols[group] if group in cols else np.zeros(len(ctrls))
    for c in _ordered(ctrls):
        for g in sorted(set(gvals[ctrls == c].tolist())):
            m = (ctrls == c) & (gvals == g)

            def agg(name: str, fn: Any) -> float:
                v = cols[name][m] if name in cols else np.array([np.nan])
                v = v[np.isfinite(v)]
                return float(fn(v)) if v.size else float("nan")

            out.append(
                {
                    "controller": c,
                    group: g,
                    "runs": int(m.sum()),
                    "collisions": int(np.nansum(cols["collision"][m])),
                    "highest_safe_speed_kmh": highest_safe(cols["speed_kmh"][m], cols["collision"][m] > 0.5),
                    "min_ttc": agg("min_ttc", np.min),
                    "median_min_ttc": agg("min_ttc", np.median),
                    "max_drac": agg("max_drac", np.max),
                    "median_max_drac": agg("max_drac", np.median),
                    "max_decel": agg("max_decel", np.max),
                    "max_jerk": agg("max_jerk", np.max),
                    "time_hard_braking": agg("time_hard_braking", np.max),
                    "gap_error_rms": agg("gap_error_rms", np.mean),
                }
            )
    return out


def _grid(cols: dict[str, np.ndarray], mask: np.ndarray, x: str, y: str, value: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    xs = np.unique(cols[x][mask])
    ys = np.unique(cols[y][mask])
    z = np.full((ys.size, xs.size), np.nan)
    col = np.full((ys.size, xs.size), np.nan)
    for xi, yi, vi, ci in zip(cols[x][mask], cols[y][mask], cols[value][mask], cols["collision"][mask]):
        i, j = int(np.searchsorted(ys, yi)), int(np.searchsorted(xs, xi))
        z[i, j] = vi
        col[i, j] = ci
    return xs, ys, z, col


def fig_maps(
    path: Source,
    x: str = "speed_kmh",
    y: str = "lead_decel",
    value: str = "min_gap",
    out: Optional[PathLike] = None,
) -> Any:
    """Heatmaps of ``value`` over (``x``, ``y``), one panel per controller; collisions are marked
    and the collision boundary (collision = 0.5) is drawn. ``path``: a sweep CSV or columns."""
    try:
        import matplotlib

        if out is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc.envelope figures need matplotlib: pip install 'flc[plot]'") from e
    cols = _cols(path)
    ctrls = _ordered(cols["controller"])
    ncol = min(3, len(ctrls))
    nrow = (len(ctrls) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.0 * ncol, 4.2 * nrow), squeeze=False, constrained_layout=True)
    for ax in axes.flat[len(ctrls):]:
        ax.set_visible(False)
    for ax, c in zip(axes.flat, ctrls):
        xs, ys, z, col = _grid(cols, cols["controller"] == c, x, y, value)
        im = ax.pcolormesh(xs, ys, z, shading="nearest", cmap="viridis")
        fig.colorbar(im, ax=ax, label=_label(value))
        if xs.size >= 2 and ys.size >= 2 and np.nanmax(col) > 0.5 > np.nanmin(col):
            ax.contour(xs, ys, col, levels=[0.5], colors="red", linewidths=2)
        ii, jj = np.nonzero(col > 0.5)
        ax.scatter(xs[jj], ys[ii], marker="x", color="red", label="collision" if ii.size else None)
        ax.set_title(f"{c}: {value}")
        ax.set_xlabel(_label(x))
        ax.set_ylabel(_label(y))
        if ii.size:
            ax.legend(loc="upper left")
    if out is not None:
        fig.savefig(out, dpi=110)
    return fig


def _ordered(ctrls: np.ndarray) -> list[str]:
    """Controllers present, in the order of :data:`CONTROLLERS` (others after, sorted)."""
    present = set(ctrls.tolist())
    return [c for c in CONTROLLERS if c in present] + sorted(present - set(CONTROLLERS))


def fig_highest_speed(path: Source, group: str = "lead_decel", out: Optional[PathLike] = None) -> Any:
    """Bar chart of the highest collision-free speed per controller (and ``group`` value)."""
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = summary(_cols(path), group)
    ctrls = _ordered(np.array([r["controller"] for r in rows], dtype=str))
    groups = sorted({r[group] for r in rows})
    fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
    width = 0.8 / max(1, len(ctrls))
    for k, c in enumerate(ctrls):
        vals = [next((r["highest_safe_speed_kmh"] for r in rows if r["controller"] == c and r[group] == g), np.nan) for g in groups]
        ax.bar(np.arange(len(groups)) + k * width, np.nan_to_num(vals), width, label=c)
    ax.set_xticks(np.arange(len(groups)) + width * (len(ctrls) - 1) / 2, [f"{g:g}" for g in groups])
    ax.set_xlabel(_label(group))
    ax.set_ylabel("highest collision-free speed (km/h)")
    ax.legend()
    if out is not None:
        fig.savefig(out, dpi=110)
    return fig


def write_table(rows: Sequence[dict[str, Any]]) -> str:
    """The summary as a Markdown table."""
    if not rows:
        return ""
    keys = list(rows[0].keys())
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + " |")
    return "\n".join(lines) + "\n"


def make_maps(path: Source, out_dir: PathLike, x: str, y: str, stem: str) -> list[Path]:
    """Writes ``<stem>-min_gap.png``, ``<stem>-impact_speed.png``, ``<stem>-highest-speed.png`` and
    the summary table ``<stem>-summary.md`` (``path``: a sweep CSV or columns)."""
    path = _cols(path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for value in ("min_gap", "impact_speed"):
        p = out / f"{stem}-{value}.png"
        fig_maps(path, x, y, value, p)
        written.append(p)
    p = out / f"{stem}-highest-speed.png"
    fig_highest_speed(path, y, p)
    written.append(p)
    p = out / f"{stem}-summary.md"
    p.write_text(write_table(summary(path, y)))
    written.append(p)
    return written


def make_all(
    out_dir: PathLike,
    controllers: Sequence[str] = CONTROLLERS,
    speeds_kmh: Sequence[float] = SPEEDS_KMH,
    preset: str = "realistic",
    threads: Optional[int] = None,
    progress: Optional[Callable[[int, int, str], None]] = None,
) -> list[Path]:
    """Both default maps for ``controllers``: ``envelope-decel-*`` (speed x lead deceleration,
    :data:`LEAD_DECELS`) and ``envelope-latency-*`` (speed x LiDAR latency, lead at -6 m/s²,
    :data:`LATENCY_FRAMES`), with ``preset`` (``"realistic"`` or ``"paper"``; the paper preset's
    files get a ``-paper`` suffix). ``progress(done, total, map)`` is called as runs finish.
    Returns the written paths."""
    suffix = "" if preset == "realistic" else f"-{preset}"
    written: list[Path] = []
    for stem, y, values in (("envelope-decel", "lead_decel", LEAD_DECELS), ("envelope-latency", "lidar.latency_frames", LATENCY_FRAMES)):
        report = None if progress is None else (lambda d, n, s=stem: progress(d, n, s))
        cols = run_grid(y, values, controllers, speeds_kmh, preset, threads=threads, progress=report)
        written += make_maps(cols, out_dir, "speed_kmh", y, stem + suffix)
    return written


#: The robust FLC's own sweep files (``docs/robust-flc.md``, "Safety-envelope maps"): the paper's
#: FLC and the robust FLC behind a lead able to brake at -9 m/s².
ROBUST_SWEEPS = ("envelope-robust", "envelope-robust-paper")


def robust_summaries(out_dir: PathLike, threads: Optional[int] = None) -> list[Path]:
    """Runs ``sweeps/<stem>.toml`` for each of :data:`ROBUST_SWEEPS` and writes its metrics table
    ``<stem>-summary.md`` into ``out_dir`` (``docs/figures``; ``docs/robust-flc.md`` includes them)."""
    import tempfile

    from ._paths import require_source_tree
    from ._sweep import sweep_file

    sweeps = require_source_tree("flc.envelope.robust_summaries (it runs sweeps/envelope-robust*.toml)") / "sweeps"

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for stem in ROBUST_SWEEPS:
        with tempfile.TemporaryDirectory() as tmp:
            csv_path = Path(tmp) / f"{stem}.csv"
            sweep_file(sweeps / f"{stem}.toml", out=csv_path, threads=threads)
            p = out / f"{stem}-summary.md"
            p.write_text(write_table(summary(load_sweep(csv_path), "lead_decel")))
        written.append(p)
    return written
