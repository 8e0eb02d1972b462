"""The paper's figures, each one call (matplotlib, ``pip install 'flc[plot]'``).

* :func:`fig_following` — Fig. 4: trajectories, gap over time and lead speed per max speed, FLC vs PID;
* :func:`fig_truncated_cosine` — Fig. 2: the acceleration law of Eq. (5) for both Delta_d branches;
* :func:`fig_lyapunov` — Sec. III-C: phase portrait of Eq. (7) and the sign of dV/dt for Eq. (8);
* :func:`fig_robust_lyapunov` — Sec. III-C redone for the robust FLC (``docs/robust-flc.md``).
* :func:`fig_platoon_space_time`, :func:`fig_platoon_gap_errors`, :func:`fig_platoon_gamma` — the
  platoon brake demo (``docs/platoon.md``): space-time diagram of the string, gap errors per
  vehicle and the string-stability frequency response ``|Gamma(jw)|``.

Each returns a ``matplotlib.figure.Figure``. With ``out`` the figure is drawn on its own Agg canvas
(headless, pyplot's global state untouched) and saved there; without it, it is a pyplot figure
(``plt.show()``, notebooks). ``python -m flc figures --out DIR`` writes all of them as PNG; the data
behind each figure is available without matplotlib (``*_data`` / :func:`following_runs` /
:func:`platoon_runs`).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Callable, Optional, Sequence, Union

import numpy as np

from ._controllers import FallbackController
from ._params import defaults
from ._run import RunResult, frequency_response, sweep
from . import reproduction as rp
from ._scenario import Scenario

PathLike = Union[str, "os.PathLike[str]"]
DPI = 120


def _figure(save: bool, figsize: tuple[float, float]) -> Any:
    """A constrained-layout figure: on an Agg canvas when saving, else a pyplot figure."""
    try:
        if save:
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            fig = Figure(figsize=figsize, layout="constrained")
            FigureCanvasAgg(fig)
            return fig
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc.figures needs matplotlib: pip install 'flc[plot]'") from e
    return plt.figure(figsize=figsize, layout="constrained")


def _save(fig: Any, out: Optional[PathLike]) -> Any:
    if out is not None:
        fig.savefig(out, dpi=DPI)
    return fig


# ---------------------------------------------------------------------------------------------
# Fig. 2: the truncated cosine, Eq. (5)


def truncated_cosine_data(n: int = 221) -> dict[str, np.ndarray]:
    """Eq. (5) as computed by the Rust FLC, for ``dist_s`` over [-bound_t, bound_t].

    Own speed 0 makes ``D_d = B_gap`` and ``F_shift = 0`` (Eqs. (2)-(4)), so ``dist_s = LF_dist -
    B_gap``; ``B_gap`` is set to ``bound_t`` so that every ``dist_s`` is a valid (non-negative)
    distance. The branch is chosen by the previous frame: none (``Delta_d = 0`` -> shift 1) or a
    distance 1 m larger (``Delta_d = -1 <= -0.3`` -> shift 1.5). Keys: ``dist_s``;
    ``normal_law`` / ``normal`` (shift 1, before / after the negative multiplier);
    ``braking_law`` / ``braking`` (shift 1.5 with the default override ``min(dist_s, -3)``);
    ``braking_no_override`` (shift 1.5, override off: the bare law).
    """
    bound = float(defaults("flc")["bound_t"])
    dist_s = np.linspace(-bound, bound, n)
    cols: dict[str, list[float]] = {k: [] for k in ("normal_law", "normal", "braking_law", "braking", "braking_no_override")}
    runs = (("normal", "min", None), ("braking", "min", 1.0), ("braking_no_override", "off", 1.0))
    for ds in dist_s:
        d = float(ds) + bound
        for key, override, prev in runs:
            c = FallbackController(base_gap=bound, dist_override=override)
            if prev is not None:
                c.step(d + prev, 0.0)
            c.step(d, 0.0)
            t = c.terms()
            if abs(t["dist_s_raw"] - ds) > 1e-9 or t["braking_branch"] != (prev is not None):
                raise AssertionError(f"FLC terms do not match the intended input: {t}")
            if key == "braking_no_override":
                cols[key].append(t["a_law"])
            else:
                cols[key + "_law"].append(t["a_law"])
                cols[key].append(t["a"])
    data = {k: np.array(v) for k, v in cols.items()}
    data["dist_s"] = dist_s
    return data


def fig_truncated_cosine(out: Optional[PathLike] = None) -> Any:
    """The paper's Fig. 2: the truncated-cosine acceleration law of Eq. (5), both Delta_d branches,
    with the negative multiplier (dashed) and the override point ``dist_s = -3``. Lines carry a
    ``gid`` equal to their key in :func:`truncated_cosine_data`."""
    d = truncated_cosine_data()
    p = defaults("flc")
    bound, mult, ov = float(p["bound_t"]), float(p["negative_multiplier"]), float(p["override_dist"])
    fig = _figure(out is not None, (8, 5))
    ax = fig.subplots()
    x = d["dist_s"]
    ax.plot(x, d["normal_law"], "C0", lw=2, gid="normal_law", label=f"Δd > −0.3 m: dist_s·(1 − cos(π·dist_s/{bound:g}))  [Fig. 2]")
    ax.plot(x, d["normal"], "C0--", alpha=0.7, gid="normal", label=f"  … negative side × {mult:g} (multiplier)")
    ax.plot(x, d["braking_no_override"], "C1:", lw=1.5, gid="braking_no_override", label="Δd ≤ −0.3 m: dist_s·(1.5 − cos(…)), no override")
    ax.plot(x, d["braking_law"], "C1", lw=2, gid="braking_law", label=f"Δd ≤ −0.3 m with override dist_s → min(dist_s, {ov:g})")
    ax.plot(x, d["braking"], "C1--", alpha=0.7, gid="braking", label=f"  … × {mult:g} (multiplier)")
    a_ov = ov * (float(p["shift_brake"]) - math.cos(math.pi * ov / bound))
    ax.plot([ov, ov], [a_ov, mult * a_ov], "ko", ms=5)
    ax.annotate(f"override dist_s = {ov:g} m\na = {a_ov:.2f} (× {mult:g} = {mult * a_ov:.2f})", (ov, mult * a_ov), xytext=(ov + 1.5, -20),
                arrowprops={"arrowstyle": "->", "lw": 0.8}, fontsize=8)
    ax.axhline(0, color="grey", lw=0.5)
    ax.axvline(0, color="grey", lw=0.5)
    ax.set_xlim(-bound, bound)
    ax.set_xlabel(f"dist_s = LF_dist − D_d − F_shift (m), clipped to ±bound_t = ±{bound:g} m")
    ax.set_ylabel("a (m/s²); speed command = S_F + 1 s · a")
    ax.set_title("FLC truncated-cosine law, Eq. (5), computed by the Rust FallbackController")
    ax.legend(fontsize=8, loc="upper left")
    return _save(fig, out)


# ---------------------------------------------------------------------------------------------
# Sec. III-C: Lyapunov analysis, Eqs. (7)-(9)


def lyapunov_field(x1: np.ndarray, x2: np.ndarray, s_l: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. (7) with x1 = S_F − S_L, x2 = dist_s, Z = 0.1 / C (FLC defaults: T_G = 1, bound_t = 11,
    C = 5/3.6): returns (dx1/dt, dx2/dt, dV/dt) for V = (x1² + x2²) / 2 (Eq. (8))."""
    p = defaults("flc")
    bound, tg, z = float(p["bound_t"]), float(p["time_gap"]), float(p["scale_gain"]) / float(p["c"])
    g = x2 * (1.0 - np.cos(np.pi * x2 / bound))
    dx1 = g
    dx2 = -x1 - tg * g - 2.0 * z * g * (x1 + s_l)
    return dx1, dx2, x1 * dx1 + x2 * dx2


def lyapunov_data(s_l: float = 10.0, lim1: float = 6.0, lim2: float = 11.0, n: int = 241) -> dict[str, np.ndarray]:
    """The grid behind :func:`fig_lyapunov`: ``x1``, ``x2`` (n × n, x1 in ±lim1 m/s, x2 in ±lim2
    m), ``dx1``, ``dx2`` (Eq. (7)) and ``dv`` (dV/dt)."""
    x1, x2 = np.meshgrid(np.linspace(-lim1, lim1, n), np.linspace(-lim2, lim2, n))
    dx1, dx2, dv = lyapunov_field(x1, x2, s_l)
    return {"x1": x1, "x2": x2, "dx1": dx1, "dx2": dx2, "dv": dv}


def lyapunov_trajectory(start: tuple[float, float], s_l: float = 10.0, h: float = 0.02, steps: int = 3000) -> np.ndarray:
    """Eq. (7) integrated from ``start`` = (x1, x2) with classic RK4 (step ``h`` s); (k, 2) array."""

    def f(y: np.ndarray) -> np.ndarray:
        a, b, _ = lyapunov_field(y[0], y[1], s_l)
        return np.array([a, b], dtype=float)

    ys = [np.asarray(start, dtype=float)]
    for _ in range(steps):
        y = ys[-1]
        k1 = f(y)
        k2 = f(y + h / 2 * k1)
        k3 = f(y + h / 2 * k2)
        k4 = f(y + h * k3)
        nxt = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(nxt)) or np.max(np.abs(nxt)) > 100.0:
            break
        ys.append(nxt)
    return np.array(ys)


def fig_lyapunov(s_l: float = 10.0, out: Optional[PathLike] = None) -> Any:
    """Phase portrait of Eq. (7) in (x1, x2) = (S_F − S_L, dist_s) with RK4 trajectories, the sign
    of dV/dt (V of Eq. (8)) shaded, the contour dV/dt = 0, and the quadrants the paper calls stable."""
    lim1, lim2 = 6.0, 11.0
    g = lyapunov_data(s_l, lim1, lim2)
    fig = _figure(out is not None, (8, 6.5))
    ax = fig.subplots()
    ax.contourf(g["x1"], g["x2"], np.sign(g["dv"]), levels=[-1.5, 0, 1.5], colors=["#cfe8cf", "#f4cccc"], alpha=0.8)
    ax.contour(g["x1"], g["x2"], g["dv"], levels=[0], colors="k", linewidths=0.8)
    ax.streamplot(g["x1"], g["x2"], g["dx1"], g["dx2"], density=1.0, color="grey", linewidth=0.5, arrowsize=0.8)
    for i, start in enumerate([(-4.0, 8.0), (4.0, -8.0), (-5.0, -4.0), (5.0, 6.0), (2.0, 2.0)]):
        tr = lyapunov_trajectory(start, s_l)
        ax.plot(tr[:, 0], tr[:, 1], color=f"C{i}", lw=1.6)
        ax.plot(*start, "o", color=f"C{i}", ms=5)
    box = {"boxstyle": "round", "fc": "white", "alpha": 0.85, "lw": 0.5}
    ax.text(3.0, 8.5, "x1 > 0, x2 > 0: faster than the lead,\nfarther than desired: stable (paper)\n"
            "−x1·x2 < 0", ha="center", fontsize=8, bbox=box)
    ax.text(-3.0, -9.5, "x1 < 0, x2 < 0: slower than the lead,\ncloser than desired: stable (paper)\n"
            "−x1·x2 < 0", ha="center", fontsize=8, bbox=box)
    ax.text(-3.0, 1.0, "dV/dt ≈ −x1·x2 > 0\n(x1 < 0, x2 > 0)", ha="center", fontsize=8, bbox=box)
    ax.text(3.0, -1.8, "dV/dt ≈ −x1·x2 > 0\n(x1 > 0, x2 < 0)", ha="center", fontsize=8, bbox=box)
    ax.set_xlim(-lim1, lim1)
    ax.set_ylim(-lim2, lim2)
    ax.set_xlabel("x1 = S_F − S_L (m/s)")
    ax.set_ylabel("x2 = dist_s (m)")
    ax.set_title(f"Eq. (7), S_L = {s_l:g} m/s, V = (x1² + x2²)/2: green dV/dt < 0, red dV/dt > 0,\n"
                 "black dV/dt = 0; grey streamlines, coloured RK4 trajectories from the dots", fontsize=10)
    return _save(fig, out)


# ---------------------------------------------------------------------------------------------
# Sec. III-C redone for the robust FLC (docs/robust-flc.md, "Stability")


def robust_lyapunov_field(x1: np.ndarray, x2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The robust FLC's closed loop behind a lead at constant speed, in x1 = v − v_L (m/s) and
    x2 = d − D_r(v) (m), with the law's clamps and the actuator taken as ideal (as the paper's
    analysis does): a = clamp(k x2 / h, −b_max, a_max), k = k_a for x2 >= 0 and k_b otherwise;
    x1' = a, x2' = −x1 − h a. Returns (dx1/dt, dx2/dt, V, dV/dt) for
    V = x1² / 2 + k x2² / (2 h) (``RobustFlcParams`` defaults)."""
    p = defaults("flc_robust_v1")
    h, ka, kb = float(p["time_gap"]), float(p["accel_gain"]), float(p["brake_gain"])
    amax, bmax = float(p["max_accel"]), float(p["max_decel"])
    x1, x2 = np.asarray(x1, dtype=float), np.asarray(x2, dtype=float)
    k = np.where(x2 >= 0.0, ka, kb)
    a = np.clip(k * x2 / h, -bmax, amax)
    dx1 = a
    dx2 = -x1 - h * a
    v = 0.5 * x1**2 + 0.5 * k * x2**2 / h
    dv = x1 * dx1 + (k / h) * x2 * dx2
    return dx1, dx2, v, dv


def robust_lyapunov_data(lim1: float = 10.0, lim2: float = 12.0, n: int = 241) -> dict[str, np.ndarray]:
    """The grid behind :func:`fig_robust_lyapunov`: ``x1``, ``x2`` (n × n, x1 in ±lim1 m/s, x2 in
    ±lim2 m), ``dx1``, ``dx2``, ``v`` and ``dv`` (dV/dt)."""
    x1, x2 = np.meshgrid(np.linspace(-lim1, lim1, n), np.linspace(-lim2, lim2, n))
    dx1, dx2, v, dv = robust_lyapunov_field(x1, x2)
    return {"x1": x1, "x2": x2, "dx1": dx1, "dx2": dx2, "v": v, "dv": dv}


def robust_lyapunov_trajectory(start: tuple[float, float], h: float = 0.01, steps: int = 3000) -> np.ndarray:
    """The robust closed loop integrated from ``start`` = (x1, x2) with classic RK4 (step ``h``
    s); (k, 2) array."""

    def f(y: np.ndarray) -> np.ndarray:
        a, b, _, _ = robust_lyapunov_field(y[0], y[1])
        return np.array([a, b], dtype=float)

    ys = [np.asarray(start, dtype=float)]
    for _ in range(steps):
        y = ys[-1]
        k1 = f(y)
        k2 = f(y + h / 2 * k1)
        k3 = f(y + h / 2 * k2)
        k4 = f(y + h * k3)
        ys.append(y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
    return np.array(ys)


def fig_robust_lyapunov(out: Optional[PathLike] = None) -> Any:
    """Phase portrait of the robust FLC in (x1, x2) = (v − v_L, d − D_r(v)) with RK4 trajectories,
    the sign of dV/dt for V = x1²/2 + k x2²/(2h) shaded (green < 0; dV/dt = −(k²/h) x2² wherever
    the law is not clamped) and the clamp boundaries dashed."""
    lim1, lim2 = 10.0, 12.0
    p = defaults("flc_robust_v1")
    h, ka, kb = float(p["time_gap"]), float(p["accel_gain"]), float(p["brake_gain"])
    amax, bmax = float(p["max_accel"]), float(p["max_decel"])
    g = robust_lyapunov_data(lim1, lim2)
    fig = _figure(out is not None, (8, 6.5))
    ax = fig.subplots()
    tol = 1e-9
    sign = np.where(g["dv"] > tol, 1.0, np.where(g["dv"] < -tol, -1.0, 0.0))
    ax.contourf(g["x1"], g["x2"], sign, levels=[-1.5, -0.5, 0.5, 1.5], colors=["#cfe8cf", "#ffffff", "#f4cccc"], alpha=0.8)
    ax.streamplot(g["x1"], g["x2"], g["dx1"], g["dx2"], density=1.0, color="grey", linewidth=0.5, arrowsize=0.8)
    for y, label in ((h * amax / ka, "a = a_max"), (-h * bmax / kb, "a = −b_max")):
        ax.axhline(y, color="k", ls="--", lw=0.8)
        ax.text(lim1 * 0.97, y + 0.25, label, ha="right", fontsize=8)
    ax.axhline(0.0, color="k", lw=0.6)
    starts = [(-8.0, 10.0), (8.0, -10.0), (6.0, 4.0), (-6.0, -6.0), (9.0, 0.0), (-9.0, 2.0)]
    for i, start in enumerate(starts):
        tr = robust_lyapunov_trajectory(start)
        ax.plot(tr[:, 0], tr[:, 1], color=f"C{i}", lw=1.6)
        ax.plot(*start, "o", color=f"C{i}", ms=5)
    box = {"boxstyle": "round", "fc": "white", "alpha": 0.85, "lw": 0.5}
    ax.text(-5.0, -2.2, "not clamped (between the dashed lines):\ndV/dt = −(k²/h)·x2² ≤ 0", ha="center", fontsize=8, bbox=box)
    ax.text(-5.0, 10.5, "a = a_max: the lead pulls away\nfaster than the follower may speed up", ha="center", fontsize=8, bbox=box)
    ax.text(5.0, -11.0, "a = −b_max: braking as hard as the law allows", ha="center", fontsize=8, bbox=box)
    ax.set_xlim(-lim1, lim1)
    ax.set_ylim(-lim2, lim2)
    ax.set_xlabel("x1 = v − v_L (m/s)")
    ax.set_ylabel("x2 = d − D_r(v) (m)")
    ax.set_title(f"Robust FLC (h = {h:g} s, k_a = {ka:g}, k_b = {kb:g} 1/s), V = x1²/2 + k·x2²/(2h):\n"
                 "green dV/dt < 0, red dV/dt > 0 (clamped law only); RK4 trajectories from the dots", fontsize=10)
    return _save(fig, out)


# ---------------------------------------------------------------------------------------------
# Fig. 4: the following experiment


def following_runs(speeds_kmh: Sequence[float] = (30, 50, 70, 90), preset: str = "paper") -> dict[tuple[float, str], RunResult]:
    """The runs behind Fig. 4, keyed (speed km/h, "flc" | "pid"), run in parallel by ``flc.sweep``."""
    keys = [(float(v), c) for v in speeds_kmh for c in ("flc", "pid")]
    results = sweep([Scenario.paper(speed_kmh=v, controller=c, preset=preset) for v, c in keys])
    return dict(zip(keys, results))


def outcome(r: RunResult) -> str:
    """'collision at X m/s' or 'stopped, clearance X m' for a run."""
    m = r.metrics
    if m["collision"]:
        return f"collision at {m['impact_speed']:.1f} m/s"
    clear = m["final_clearance"] if m["final_clearance"] is not None else m["min_gap"]
    return f"stopped, clearance {clear:.1f} m"


def fig_following(speeds_kmh: Sequence[float] = (30, 50, 70, 90), preset: str = "paper", out: Optional[PathLike] = None) -> Any:
    """The paper's Fig. 4, one row per max speed: (a) x-y trajectories of the lead and the FLC and PID
    followers, (b) gap over time per controller (collisions marked ×, outcome in the legend),
    (c) the lead's speed profile in km/h."""
    runs = following_runs(speeds_kmh, preset)
    fig = _figure(out is not None, (15, 2.9 * len(speeds_kmh) + 0.6))
    axes = fig.subplots(len(speeds_kmh), 3, squeeze=False)
    ctrl = (("flc", "FLC", "C0", "--"), ("pid", "PID", "C1", ":"))
    for row, v in zip(axes, speeds_kmh):
        rs = {c: runs[(float(v), c)] for c, *_ in ctrl}
        ax = row[0]
        lead = rs["flc"]
        ax.plot(lead.lead_x, lead.lead_y, "k-", lw=3, alpha=0.5, label="lead")
        ymax = 0.05
        for c, name, color, ls in ctrl:
            r = rs[c]
            ax.plot(r.follower_x, r.follower_y, color=color, ls=ls, lw=1.5, label=f"follower ({name})")
            ax.plot(r.follower_x[-1], r.follower_y[-1], "x" if r.metrics["collision"] else "o", color=color, ms=8, mew=2)
            ymax = max(ymax, 1.3 * float(np.max(np.abs(r.follower_y))))
        ax.plot(lead.lead_x[-1], lead.lead_y[-1], "ks", ms=6)
        ax.set_ylim(-ymax, ymax)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"(a) {v:g} km/h: trajectories, y exaggerated (end: ■ lead, ● stop, × collision)", fontsize=9)
        ax.legend(fontsize=7, loc="lower left")
        ax = row[1]
        for c, name, color, _ in ctrl:
            r = rs[c]
            ax.plot(r.t, r.gap, color=color, label=f"{name}: {outcome(r)}")
            if r.metrics["collision"]:
                tc = float(r.metrics["collision_time"])
                ax.plot([tc], [float(np.interp(tc, r.t, r.gap))], "x", color="red", ms=11, mew=2.5)
        ax.axhline(0, color="grey", lw=0.5)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("gap (m)")
        ax.set_title(f"(b) {v:g} km/h: gap distance (separate runs)", fontsize=9)
        ax.legend(fontsize=8, loc="lower center")
        ax = row[2]
        for c, name, color, ls in ctrl:
            ax.plot(rs[c].t, rs[c].lead_speed * 3.6, color="k" if c == "flc" else color, ls="-" if c == "flc" else ls, label=f"lead, {name} run")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("lead speed (km/h)")
        ax.set_title(f"(c) {v:g} km/h: lead vehicle speed profile", fontsize=9)
        ax.legend(fontsize=7, loc="lower center")
    fig.suptitle(f"Fig. 4 reproduction ({preset} preset): lead accelerates, cruises ~650 m, brakes at −6 m/s²; FLC vs V2V PID")
    return _save(fig, out)


# ---------------------------------------------------------------------------------------------
# Platoons: the brake demo (docs/platoon.md)


def platoon_runs(scenario: Optional[Scenario] = None) -> dict[str, RunResult]:
    """The runs behind the platoon figures, keyed by variant name (``pid-v2v``, ``flc``,
    ``pipeline-outage`` for the default :meth:`Scenario.brakedemo`), run in parallel."""
    sc = scenario if scenario is not None else Scenario.brakedemo()
    variants = sc.variants()
    results = sweep(variants)
    return {(v.variant or v.controller): r for v, r in zip(variants, results)}


def _platoon(r: RunResult) -> Any:
    if r.platoon is None:
        raise ValueError(f"{r.scenario.name!r} is not a platoon run (no [platoon] section)")
    return r.platoon


def space_time_data(r: RunResult) -> dict[str, np.ndarray]:
    """The space-time diagram of a platoon run: ``t`` (s), ``position`` (m, shape
    ``(n_followers + 1, n_steps)``, row 0 = the lead): each vehicle's distance travelled along its
    path, offset so that the lead starts at 0 and each follower at minus its straight-line distance
    to the lead's start; ``speed`` (m/s, same shape)."""
    p = _platoon(r)
    x, y = p.vehicle_xy()
    x0, y0 = x[0, 0], y[0, 0]
    start = -np.hypot(x[:, 0] - x0, y[:, 0] - y0)
    steps = np.hypot(np.diff(x, axis=1), np.diff(y, axis=1))
    position = start[:, None] + np.concatenate([np.zeros((x.shape[0], 1)), np.cumsum(steps, axis=1)], axis=1)
    return {"t": np.asarray(p.t), "position": position, "speed": p.vehicle_speed()}


def gap_error_data(r: RunResult) -> dict[str, np.ndarray]:
    """Gap errors of a platoon run: ``t`` (s), ``gap_error`` (m, ``(n_followers, n_steps)``: gap
    minus each follower's reference spacing policy, as in the string-stability measures) and
    ``window_start`` (s, start of the measures' window: the lead's brake onset)."""
    p = _platoon(r)
    return {"t": np.asarray(p.t), "gap_error": np.asarray(p.gap_error), "window_start": np.asarray(float(p.string_stability["window_start"]))}


def gamma_data(scenario: Optional[Scenario] = None, freqs_hz: Optional[Sequence[float]] = None) -> dict[str, dict[str, np.ndarray]]:
    """``|Gamma(jw)|`` per variant of a platoon scenario (default: the brake demo at its
    ``frequencies_hz``): ``freq_hz`` (Hz), ``gamma`` (``(n_freqs, n_followers)``, follower over the
    vehicle in front), ``counted`` (same shape; amplitude above the floor), ``max_gamma`` (max of the
    counted ones per frequency, NaN if none)."""
    sc = scenario if scenario is not None else Scenario.brakedemo()
    out: dict[str, dict[str, np.ndarray]] = {}
    for v in sc.variants():
        pts = frequency_response(v, freqs_hz)
        out[v.variant or v.controller] = {
            "freq_hz": np.array([p["freq_hz"] for p in pts], dtype=float),
            "gamma": np.array([[np.nan if g is None else g for g in p["gamma"]] for p in pts], dtype=float),
            "counted": np.array([p["counted"] for p in pts], dtype=bool),
            "max_gamma": np.array([np.nan if p["max_gamma"] is None else p["max_gamma"] for p in pts], dtype=float),
        }
    return out


def _variant_axes(fig: Any, n: int) -> Any:
    return fig.subplots(1, n, squeeze=False)[0]


def fig_platoon_space_time(runs: Optional[dict[str, RunResult]] = None, out: Optional[PathLike] = None) -> Any:
    """Space-time diagram of the brake demo (one panel per variant): every vehicle's position along
    the road over time, the lead in black; × marks a collision."""
    runs = runs if runs is not None else platoon_runs()
    fig = _figure(out is not None, (5.2 * len(runs), 4.2))
    for ax, (name, r) in zip(_variant_axes(fig, len(runs)), runs.items()):
        d = space_time_data(r)
        n = d["position"].shape[0]
        colors = _follower_colors(n - 1)
        for k in range(n):
            color = "k" if k == 0 else colors[k - 1]
            ax.plot(d["t"], d["position"][k], color=color, lw=1.6 if k == 0 else 1.1, gid=f"{name}/vehicle{k}", label="lead" if k == 0 else (f"follower {k}" if k in (1, n - 1) else None))
        for k, m in enumerate(_platoon(r).metrics, start=1):
            if m["collision"]:
                tc = float(m["collision_time"])
                ax.plot([tc], [float(np.interp(tc, d["t"], d["position"][k]))], "x", color="red", ms=10, mew=2.5)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("position along the road (m)")
        ss = _platoon(r).string_stability
        ax.set_title(f"{name}: {'string stable' if ss['string_stable'] else 'not string stable'}", fontsize=10)
        ax.legend(fontsize=8, loc="upper left")
    fig.suptitle(f"Platoon brake demo: space-time diagram ({len(runs)} variants)")
    return _save(fig, out)


def _follower_colors(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    return [cmap(0.9 * i / max(n - 1, 1)) for i in range(n)]


def fig_platoon_gap_errors(runs: Optional[dict[str, RunResult]] = None, out: Optional[PathLike] = None) -> Any:
    """Gap error of every follower over time (one panel per variant), the window of the
    string-stability measures shaded."""
    runs = runs if runs is not None else platoon_runs()
    fig = _figure(out is not None, (5.2 * len(runs), 4.2))
    for ax, (name, r) in zip(_variant_axes(fig, len(runs)), runs.items()):
        d = gap_error_data(r)
        colors = _follower_colors(d["gap_error"].shape[0])
        for k, e in enumerate(d["gap_error"], start=1):
            ax.plot(d["t"], e, color=colors[k - 1], lw=1.1, gid=f"{name}/follower{k}", label=f"follower {k}")
        ax.axvspan(float(d["window_start"]), float(d["t"][-1]), color="grey", alpha=0.12, lw=0)
        ax.axhline(0, color="grey", lw=0.5)
        ss = _platoon(r).string_stability
        ratio = ss.get("max_ratio")
        ax.set_title(f"{name}: max error ratio {ratio:.2f}" if ratio is not None else name, fontsize=10)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("gap − reference gap (m)")
        ax.legend(fontsize=7, ncol=2, loc="lower left")
    fig.suptitle("Platoon brake demo: gap errors per follower (shaded: window of the measures)")
    return _save(fig, out)


def fig_platoon_gamma(gamma: Optional[dict[str, dict[str, np.ndarray]]] = None, out: Optional[PathLike] = None, tolerance: float = 0.02) -> Any:
    """``|Gamma(jw)|`` per variant: the largest counted ratio over the followers (line) and every
    follower's (dots), against the drive frequency; string stable below 1 (+ tolerance)."""
    gamma = gamma if gamma is not None else gamma_data()
    fig = _figure(out is not None, (7.5, 4.8))
    ax = fig.subplots()
    for i, (name, g) in enumerate(gamma.items()):
        color = f"C{i}"
        ax.plot(g["freq_hz"], g["max_gamma"], "o-", color=color, lw=1.8, gid=f"{name}/max", label=f"{name}: max over followers")
        f = np.repeat(g["freq_hz"][:, None], g["gamma"].shape[1], axis=1)
        ax.plot(f[g["counted"]], g["gamma"][g["counted"]], ".", color=color, alpha=0.45, ms=6, gid=f"{name}/followers")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(1.0 + tolerance, color="k", lw=0.6, ls=":")
    ax.set_xscale("log")
    freqs = sorted({float(f) for g in gamma.values() for f in g["freq_hz"]})
    ax.set_xticks(freqs)
    ax.set_xticks([], minor=True)
    ax.set_xticklabels([f"{f:g}" for f in freqs])
    ax.set_xlabel("frequency of the lead's speed (Hz)")
    ax.set_ylabel("|Γ(jω)| = |V_k| / |V_k−1|")
    ax.set_title("String stability: frequency response (dots: every follower)", fontsize=10)
    ax.legend(fontsize=8)
    return _save(fig, out)


def make_all(
    out_dir: PathLike,
    speeds_kmh: Sequence[float] = (30, 50, 70, 90),
    preset: str = "paper",
    platoon_freqs_hz: Optional[Sequence[float]] = None,
    progress: Optional[Callable[[int, int, str], None]] = None,
) -> list[Path]:
    """Writes ``following.png``, ``truncated_cosine.png``, ``lyapunov.png`` and the platoon
    figures ``platoon_space_time.png``, ``platoon_gap_errors.png``, ``platoon_gamma.png`` (the
    brake demo; ``|Gamma|`` at ``platoon_freqs_hz``, default its own frequencies) and the paper
    reproduction map from its committed data (``paper_reproduction*.png``) into ``out_dir``
    (created if needed); returns their paths. ``progress(done, total, name)`` is called after each
    figure."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    runs: dict[str, RunResult] = {}

    def platoon() -> dict[str, RunResult]:
        if not runs:
            runs.update(platoon_runs())
        return runs

    jobs: list[tuple[str, Callable[[Path], Any]]] = [
        ("following.png", lambda p: fig_following(speeds_kmh, preset, p)),
        ("truncated_cosine.png", lambda p: fig_truncated_cosine(p)),
        ("lyapunov.png", lambda p: fig_lyapunov(out=p)),
        ("platoon_space_time.png", lambda p: fig_platoon_space_time(platoon(), p)),
        ("platoon_gap_errors.png", lambda p: fig_platoon_gap_errors(platoon(), p)),
        ("platoon_gamma.png", lambda p: fig_platoon_gamma(gamma_data(None, platoon_freqs_hz), p)),
    ]
    # The paper reproduction map, drawn from its committed data, which ships with the package
    # (`python -m flc reproduction` recomputes the data; a missing file raises, never skips).
    data = rp.DATA_DIR
    missing = [n for n in ("paper-reproduction-map.csv", "paper-reproduction-lines.csv", "paper-reproduction-random.csv") if not (data / n).is_file()]
    if missing:
        raise FileNotFoundError(f"the paper reproduction data {data / missing[0]} is missing (it ships with the package; `python -m flc reproduction` recomputes it)")
    jobs += [
        ("paper_reproduction.png", lambda p: fig_reproduction(data, p)),
        ("paper_reproduction_clearances.png", lambda p: fig_reproduction_clearances(data, p)),
    ]
    for k, (name, make) in enumerate(jobs):
        make(out / name)
        if progress is not None:
            progress(k + 1, len(jobs), name)
    return [out / name for name, _ in jobs]


# ---------------------------------------------------------------- paper reproduction map


def reproduction_data(data_dir: PathLike) -> dict[str, Any]:
    """The committed reproduction data (``sweeps/paper-reproduction-*.csv``) as arrays: the map
    (``x``, ``y``, ``matches`` grid), the lines (per varied constant: values, matches) and the random
    sample (per constant: values, matches)."""
    spec = rp.load_spec()
    d = Path(data_dir)
    m = spec["map"]
    rows = rp.read_csv(d / "paper-reproduction-map.csv")
    xs, ys = [float(v) for v in m["x_values"]], [float(v) for v in m["y_values"]]
    grid = np.full((len(ys), len(xs)), np.nan)
    for r in rows:
        grid[ys.index(float(r[m["y"]])), xs.index(float(r[m["x"]]))] = float(r["matches"])
    lines: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for r in rp.read_csv(d / "paper-reproduction-lines.csv"):
        name = r["varied"]
        v = float(r["seed"]) if name == "seed" else float(r[name])
        xs_, ms_ = lines.get(name, (np.array([]), np.array([])))
        lines[name] = (np.append(xs_, v), np.append(ms_, float(r["matches"])))
    rnd = rp.read_csv(d / "paper-reproduction-random.csv")
    random_ = {c["name"]: (np.array([float(r[c["name"]]) for r in rnd]), np.array([float(r["matches"]) for r in rnd])) for c in spec["constants"]}
    return {"x": np.array(xs), "y": np.array(ys), "matches": grid, "x_name": m["x"], "y_name": m["y"], "lines": lines, "random": random_, "spec": spec}


def fig_reproduction(data_dir: PathLike, out: Optional[PathLike] = None) -> Any:
    """Where the paper's 8-cell outcome pattern holds: (a) matching cells over brake authority x
    actuator response (other constants at the base values), the chosen preset marked; (b) matching
    cells along each constant through the preset; (c) the share of random points (all constants
    drawn over their ranges) that match all 8, per decile of each constant."""
    d = reproduction_data(data_dir)
    spec = d["spec"]
    labels = {c["name"]: c["label"] for c in spec["constants"]}
    fig = _figure(out is not None, (15.0, 11.0))
    gs = fig.add_gridspec(3, 4)
    ax = fig.add_subplot(gs[:, :2])
    im = ax.pcolormesh(d["x"], d["y"], d["matches"], shading="nearest", cmap="viridis", vmin=0, vmax=8)
    ax.contour(d["x"], d["y"], d["matches"], levels=[7.5], colors="white", linewidths=1.5)
    rows = rp.read_csv(Path(data_dir) / "paper-reproduction-map.csv")
    chosen = rp.choose(spec, rows)
    ax.plot([chosen[d["x_name"]]], [chosen[d["y_name"]]], marker="*", markersize=16, color="red", label="paper preset")
    ax.set_xlabel(labels[d["x_name"]])
    ax.set_ylabel(labels[d["y_name"]])
    ax.set_title(f"(a) cells matching the paper (of 8); white: all 8 ({100 * rp.region_share(rows):.1f} % of the map)")
    ax.legend(loc="upper right")
    fig.colorbar(im, ax=ax, label="matching cells")
    names = [c["name"] for c in spec["constants"] if c["name"] not in (d["x_name"], d["y_name"])] + ["seed"]
    for k, name in enumerate(names[:6]):
        a = fig.add_subplot(gs[k // 2, 2 + k % 2])
        xs, ms = d["lines"].get(name, (np.array([]), np.array([])))
        a.plot(xs, ms, "o-")
        a.set_ylim(-0.3, 8.3)
        a.axhline(8, color="grey", lw=0.8, ls=":")
        a.set_xlabel(labels.get(name, "seed"))
        a.set_ylabel("matching cells")
        a.set_title(f"(b) through the preset: {name}", fontsize=10)
    fig.suptitle(
        f"Paper reproduction map (sweeps/paper-reproduction.toml); random sample over all {len(spec['constants'])} constants: "
        f"{100 * rp.region_share(rp.read_csv(Path(data_dir) / 'paper-reproduction-random.csv')):.1f} % match all 8 cells"
    )
    fig.subplots_adjust(left=0.05, right=0.98, bottom=0.07, top=0.9, wspace=0.35, hspace=0.4)
    return _save(fig, out)


def fig_reproduction_clearances(data_dir: PathLike, out: Optional[PathLike] = None) -> Any:
    """Clearances at standstill of the stopping cells against the paper's (3.8 / 4.0 / 2.3 m FLC,
    7.9 / 1.2 m PID): along the brake-authority line through the preset, and the remaining lines
    (one panel per constant), paper values dashed."""
    spec = rp.load_spec()
    rows = rp.read_csv(Path(data_dir) / "paper-reproduction-lines.csv")
    names = [c["name"] for c in spec["constants"]]
    fig = _figure(out is not None, (16.0, 7.5))
    axes = fig.subplots(2, 4).ravel()
    stops = [(c, v) for (c, v), p in rp.PAPER.items() if p is not None]
    for ax, name in zip(axes, names):
        rs = [r for r in rows if r["varied"] == name]
        xs = [float(r[name]) for r in rs]
        for (c, v) in stops:
            tag = f"{c}{int(v)}"
            ys = [float(r[f"{tag}_clearance"]) if r[f"{tag}_clearance"] else np.nan for r in rs]
            line = ax.plot(xs, ys, "o-", ms=3, label=f"{c.upper()} {int(v)} km/h")[0]
            ax.axhline(rp.PAPER[(c, v)] or 0.0, color=line.get_color(), ls="--", lw=0.8)
        ax.set_xlabel(next(c["label"] for c in spec["constants"] if c["name"] == name))
        ax.set_ylabel("clearance at standstill (m)")
    axes[0].legend(fontsize=7)
    axes[-1].axis("off")
    fig.suptitle("Clearances of the stopping cells through the paper preset (dashed: the paper's values); gaps = collision")
    fig.tight_layout()
    return _save(fig, out)


def make_reproduction(out_dir: PathLike, data_dir: PathLike = rp.DATA_DIR, threads: Optional[int] = None) -> dict[str, Any]:
    """Computes the paper reproduction map (:func:`flc.reproduction.compute`: the CSVs into
    ``data_dir``) and draws ``paper_reproduction.png`` and ``paper_reproduction_clearances.png``
    into ``out_dir``. Returns the chosen point and the region sizes."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = rp.compute(data_dir, threads)
    fig_reproduction(data_dir, out / "paper_reproduction.png")
    fig_reproduction_clearances(data_dir, out / "paper_reproduction_clearances.png")
    return summary
