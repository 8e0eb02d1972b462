"""The paper's figures, each one call (matplotlib, ``pip install 'flc[plot]'``).

* :func:`fig_following` — Fig. 4: trajectories, gap over time and lead speed per max speed, FLC vs PID;
* :func:`fig_truncated_cosine` — Fig. 2: the acceleration law of Eq. (5) for both Delta_d branches;
* :func:`fig_lyapunov` — Sec. III-C: phase portrait of Eq. (7) and the sign of dV/dt for Eq. (8).

``python -m flc figures --out DIR`` writes all three as PNG.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Optional, Sequence, Union

import numpy as np

from ._controllers import FallbackController
from ._params import defaults
from ._run import sweep
from ._scenario import Scenario

PathLike = Union[str, "os.PathLike[str]"]


def _plt(headless: bool) -> Any:
    try:
        import matplotlib

        if headless:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc figures need matplotlib: pip install 'flc[plot]'") from e
    return plt


def truncated_cosine_data(n: int = 201) -> dict[str, np.ndarray]:
    """Eq. (5) evaluated by the Rust FLC: ``dist_s`` over [-bound_t, bound_t] and ``a`` for the
    normal branch (Delta_d > -0.3, shift 1) and the braking branch (Delta_d <= -0.3, shift 1.5,
    override ``min(dist_s, -3)``), before (``*_law``) and after the negative multiplier."""
    p = defaults("flc")
    bound = float(p["bound_t"])
    # At own speed 10 m/s every dist_s in [-bound_t, bound_t] is a valid (positive) distance.
    v = 10.0
    base = float(p["time_gap"]) * v + float(p["base_gap"]) + v * min(float(p["scale_cap"]), float(p["scale_gain"]) * v / float(p["c"]))
    dist_s = np.linspace(-bound, bound, n)
    out: dict[str, list[float]] = {k: [] for k in ("normal_law", "normal", "braking_law", "braking")}
    for ds in dist_s:
        # LF_dist = dist_s + D_d + F_shift (Eqs. (2)-(4)).
        d = float(ds) + base
        c = FallbackController()
        c.step(d, v)  # first frame: Delta_d = 0 -> normal branch
        t = c.terms()
        out["normal_law"].append(t["a_law"])
        out["normal"].append(t["a"])
        c = FallbackController()
        c.step(d + 1.0, v)
        c.step(d, v)  # Delta_d = -1 <= -0.3 -> braking branch
        t = c.terms()
        out["braking_law"].append(t["a_law"])
        out["braking"].append(t["a"])
    data = {k: np.array(v) for k, v in out.items()}
    data["dist_s"] = dist_s
    return data


def fig_truncated_cosine(out: Optional[PathLike] = None) -> Any:
    """The paper's Fig. 2: the truncated-cosine acceleration law for both Delta_d branches."""
    plt = _plt(out is not None)
    d = truncated_cosine_data()
    p = defaults("flc")
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    ax.plot(d["dist_s"], d["normal_law"], label="Δd > −0.3 m: dist_s·(1 − cos(π dist_s / bound_t))")
    ax.plot(d["dist_s"], d["normal"], "--", color="C0", alpha=0.6, label=f"… with negative multiplier ×{p['negative_multiplier']:g}")
    ax.plot(d["dist_s"], d["braking_law"], label="Δd ≤ −0.3 m: shift 1.5, dist_s → min(dist_s, −3)")
    ax.plot(d["dist_s"], d["braking"], "--", color="C1", alpha=0.6, label="… with negative multiplier")
    ov = float(p["override_dist"])
    a_ov = ov * (float(p["shift_brake"]) - math.cos(math.pi * ov / float(p["bound_t"])))
    ax.plot([ov], [a_ov], "ko", label=f"override dist_s = {ov:g} m")
    ax.axhline(0, color="grey", lw=0.5)
    ax.axvline(0, color="grey", lw=0.5)
    ax.set_xlabel("dist_s (m)")
    ax.set_ylabel("a (m/s², added to the speed command over 1 s)")
    ax.set_title("FLC acceleration law, Eq. (5) (bound_t = 11 m)")
    ax.legend(fontsize=8)
    if out is not None:
        fig.savefig(out, dpi=120)
    return fig


def lyapunov_field(x1: np.ndarray, x2: np.ndarray, s_l: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. (7) with x1 = S_F − S_L, x2 = dist_s, Z = 0.1 / C: returns (dx1/dt, dx2/dt, dV/dt) for
    V = (x1² + x2²) / 2 (Eq. (8))."""
    p = defaults("flc")
    bound, tg, z = float(p["bound_t"]), float(p["time_gap"]), float(p["scale_gain"]) / float(p["c"])
    g = x2 * (1.0 - np.cos(np.pi * x2 / bound))
    dx1 = g
    dx2 = -x1 - tg * g - 2.0 * z * g * (x1 + s_l)
    return dx1, dx2, x1 * dx1 + x2 * dx2


def fig_lyapunov(s_l: float = 10.0, out: Optional[PathLike] = None) -> Any:
    """Phase portrait of Eq. (7) in (x1, x2) with the sign regions of dV/dt (Eq. (8))."""
    plt = _plt(out is not None)
    lim1, lim2 = 6.0, 11.0
    x1, x2 = np.meshgrid(np.linspace(-lim1, lim1, 241), np.linspace(-lim2, lim2, 241))
    dx1, dx2, dv = lyapunov_field(x1, x2, s_l)
    fig, ax = plt.subplots(figsize=(7, 5.5), constrained_layout=True)
    ax.contourf(x1, x2, np.sign(dv), levels=[-1.5, 0, 1.5], colors=["#cfe8cf", "#f4cccc"], alpha=0.8)
    ax.contour(x1, x2, dv, levels=[0], colors="k", linewidths=0.8)
    ax.streamplot(x1, x2, dx1, dx2, density=1.1, color="grey", linewidth=0.6)
    # A few trajectories (RK4).
    for start in [(-4.0, 8.0), (4.0, -8.0), (-5.0, -4.0), (5.0, 6.0), (2.0, 2.0)]:
        xs = [np.array(start)]
        h = 0.02
        for _ in range(3000):
            def f(v: np.ndarray) -> np.ndarray:
                a, b, _ = lyapunov_field(np.array(v[0]), np.array(v[1]), s_l)
                return np.array([float(a), float(b)])

            y = xs[-1]
            k1 = f(y)
            k2 = f(y + h / 2 * k1)
            k3 = f(y + h / 2 * k2)
            k4 = f(y + h * k3)
            nxt = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if not np.all(np.isfinite(nxt)) or abs(nxt[0]) > 3 * lim1 or abs(nxt[1]) > 3 * lim2:
                break
            xs.append(nxt)
        tr = np.array(xs)
        ax.plot(tr[:, 0], tr[:, 1], lw=1.5)
        ax.plot(*start, "o", ms=4)
    ax.set_xlim(-lim1, lim1)
    ax.set_ylim(-lim2, lim2)
    ax.set_xlabel("x1 = S_F − S_L (m/s)")
    ax.set_ylabel("x2 = dist_s (m)")
    ax.set_title(f"Eq. (7) phase portrait, S_L = {s_l:g} m/s; green: dV/dt < 0, red: dV/dt > 0")
    if out is not None:
        fig.savefig(out, dpi=120)
    return fig


def following_runs(speeds_kmh: Sequence[float] = (30, 50, 70, 90), preset: str = "paper") -> dict[tuple[float, str], Any]:
    """The runs behind Fig. 4: for each speed, the FLC and the PID (``flc.sweep``)."""
    scs = [Scenario.paper(speed_kmh=v, controller=c, preset=preset) for v in speeds_kmh for c in ("flc", "pid")]
    return {(float(s.speed_kmh or 0.0), s.controller): r for s, r in zip(scs, sweep(scs))}


def fig_following(speeds_kmh: Sequence[float] = (30, 50, 70, 90), preset: str = "paper", out: Optional[PathLike] = None) -> Any:
    """The paper's Fig. 4: per speed, trajectories (lead, FLC and PID followers), gap over time per
    controller (collisions marked) and the lead's speed profile."""
    plt = _plt(out is not None)
    runs = following_runs(speeds_kmh, preset)
    fig, axes = plt.subplots(len(speeds_kmh), 3, figsize=(14, 3.0 * len(speeds_kmh)), squeeze=False, constrained_layout=True)
    for row, v in zip(axes, speeds_kmh):
        flc_r, pid_r = runs[(float(v), "flc")], runs[(float(v), "pid")]
        ax = row[0]
        ax.plot(flc_r.lead_x, flc_r.lead_y, "k-", lw=2, label="lead")
        ax.plot(flc_r.follower_x, flc_r.follower_y, "C0--", label="follower (FLC)")
        ax.plot(pid_r.follower_x, pid_r.follower_y, "C1:", label="follower (PID)")
        ax.set_ylim(-2, 2)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"{v:g} km/h: trajectories")
        ax.legend(fontsize=7)
        ax = row[1]
        for r, name, color in ((flc_r, "FLC", "C0"), (pid_r, "PID", "C1")):
            m = r.metrics
            lab = f"{name}: collision {m['impact_speed']:.1f} m/s" if m["collision"] else f"{name}: stop, {m['final_clearance'] or m['min_gap']:.1f} m"
            ax.plot(r.t, r.gap, color=color, label=lab)
            if m["collision"]:
                ax.plot([m["collision_time"]], [0.0], "x", color="red", ms=10, mew=2)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("gap (m)")
        ax.set_title("gap distance")
        ax.legend(fontsize=7)
        ax = row[2]
        ax.plot(flc_r.t, flc_r.lead_speed * 3.6, "k-", label="lead (FLC run)")
        ax.plot(pid_r.t, pid_r.lead_speed * 3.6, "k:", label="lead (PID run)")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("lead speed (km/h)")
        ax.set_title("lead speed profile")
        ax.legend(fontsize=7)
    fig.suptitle(f"Paper experiment, {preset} preset: lead brakes at −6 m/s² after ~650 m")
    if out is not None:
        fig.savefig(out, dpi=100)
    return fig


def make_all(out_dir: PathLike, speeds_kmh: Sequence[float] = (30, 50, 70, 90), preset: str = "paper") -> list[Path]:
    """Writes ``following.png``, ``truncated_cosine.png`` and ``lyapunov.png`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "following.png", out / "truncated_cosine.png", out / "lyapunov.png"]
    fig_following(speeds_kmh, preset, paths[0])
    fig_truncated_cosine(paths[1])
    fig_lyapunov(out=paths[2])
    return paths
