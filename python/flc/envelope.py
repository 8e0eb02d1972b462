"""Safety envelope: read sweep results (``scenario sweep`` CSV), summarise them per controller and
draw maps of minimum gap / impact speed with the collision boundary.

    scenario sweep sweeps/envelope-decel.toml --out decel.csv
    python -m flc envelope decel.csv --x speed_kmh --y lead_decel --out docs/figures
"""
from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Any, Optional, Sequence, Union

import numpy as np

PathLike = Union[str, "os.PathLike[str]"]


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
    text columns (``controller``) as string arrays; rows sorted by ``run_id``."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    rows.sort(key=lambda r: int(r["run_id"]))
    cols: dict[str, np.ndarray] = {}
    for k in rows[0].keys() if rows else []:
        vals = [r[k] for r in rows]
        if k == "controller":
            cols[k] = np.array(vals, dtype=str)
        else:
            cols[k] = np.array([_num(v) for v in vals])
    return cols


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
    DRAC over the group, comfort (max decel, max jerk, time above 3.5 m/s²) and gap keeping."""
    out: list[dict[str, Any]] = []
    ctrls = cols["controller"]
    gvals = cols[group] if group in cols else np.zeros(len(ctrls))
    for c in sorted(set(ctrls.tolist())):
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
                    "max_drac": agg("max_drac", np.max),
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
    path: PathLike,
    x: str = "speed_kmh",
    y: str = "lead_decel",
    value: str = "min_gap",
    out: Optional[PathLike] = None,
) -> Any:
    """Heatmaps of ``value`` over (``x``, ``y``), one panel per controller; collisions are marked
    and the collision boundary (collision = 0.5) is drawn."""
    try:
        import matplotlib

        if out is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc.envelope figures need matplotlib: pip install 'flc[plot]'") from e
    cols = load_sweep(path)
    ctrls = sorted(set(cols["controller"].tolist()))
    fig, axes = plt.subplots(1, len(ctrls), figsize=(5.0 * len(ctrls), 4.2), squeeze=False, constrained_layout=True)
    for ax, c in zip(axes[0], ctrls):
        xs, ys, z, col = _grid(cols, cols["controller"] == c, x, y, value)
        im = ax.pcolormesh(xs, ys, z, shading="nearest", cmap="viridis")
        fig.colorbar(im, ax=ax, label=value)
        if xs.size >= 2 and ys.size >= 2 and np.nanmax(col) > 0.5 > np.nanmin(col):
            ax.contour(xs, ys, col, levels=[0.5], colors="red", linewidths=2)
        ii, jj = np.nonzero(col > 0.5)
        ax.scatter(xs[jj], ys[ii], marker="x", color="red", label="collision" if ii.size else None)
        ax.set_title(f"{c}: {value}")
        ax.set_xlabel(x)
        ax.set_ylabel(y)
        if ii.size:
            ax.legend(loc="upper left")
    if out is not None:
        fig.savefig(out, dpi=110)
    return fig


def fig_highest_speed(path: PathLike, group: str = "lead_decel", out: Optional[PathLike] = None) -> Any:
    """Bar chart of the highest collision-free speed per controller (and ``group`` value)."""
    import matplotlib

    if out is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = summary(load_sweep(path), group)
    ctrls = sorted({r["controller"] for r in rows})
    groups = sorted({r[group] for r in rows})
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    width = 0.8 / max(1, len(ctrls))
    for k, c in enumerate(ctrls):
        vals = [next((r["highest_safe_speed_kmh"] for r in rows if r["controller"] == c and r[group] == g), np.nan) for g in groups]
        ax.bar(np.arange(len(groups)) + k * width, np.nan_to_num(vals), width, label=c)
    ax.set_xticks(np.arange(len(groups)) + width * (len(ctrls) - 1) / 2, [f"{g:g}" for g in groups])
    ax.set_xlabel(group)
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


def make_maps(path: PathLike, out_dir: PathLike, x: str, y: str, stem: str) -> list[Path]:
    """Writes ``<stem>-min_gap.png``, ``<stem>-impact_speed.png`` and ``<stem>-highest-speed.png``."""
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
    return written
