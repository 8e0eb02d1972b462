"""Safety requirements as Signal Temporal Logic, robustness per run (``docs/safety-evidence.md``).

Three requirements over a run's series (:attr:`flc.RunResult.series`, SI units, one sample per
physics step). Each is an STL formula in discrete time; its *robustness* is the quantitative
semantics of Donze and Maler (``>=``: the difference, ``not``: minus, ``and``/``always``: min,
``or``/``implies``/``once``: max), in the signal's unit. Positive: satisfied with that margin;
negative: violated.

==================  =========================================================================  ====
name                formula (``rtamt`` syntax)                                                  unit
==================  =========================================================================  ====
``no_contact``      ``always (gap > 0)``                                                        m
``comfort``         ``always ((historically[0:H] (lead_accel >= -a_gentle))``                   m/s²
                    ``        implies (follower_accel >= -a_comfort))``
``time_gap``        ``always (once[0:T] (gap - tau * follower_speed >= 0))``                    m
``safe_distance``   ``always (gap - t_safe * follower_speed >= d_safe)``                        m
==================  =========================================================================  ====

* ``no_contact``: the bumper-to-bumper gap stays positive. Robustness = the smallest gap.
* ``comfort``: while the lead has braked no harder than ``a_gentle`` (2 m/s²) for the last ``H``
  (5 s), the follower brakes no harder than ``a_comfort`` (3.5 m/s², the metrics' hard-braking
  limit, ``docs/v2v-and-metrics.md``).
* ``time_gap``: no window of ``T`` (10 s) in which the time gap stays below ``tau`` (0.9 s, the
  German fine threshold "half the speedometer"): a time gap lost to a disturbance is recovered
  within ``T``.
* ``safe_distance``: the ARCH-COMP ACC benchmark's property ``D_rel >= D_default + T_gap v_ego``
  (10 m + 1.4 s), with ``D_rel`` read as the bumper-to-bumper gap.

:func:`robustness` computes them with NumPy (fast: the falsifier calls it per candidate);
:func:`monitor` evaluates the same formulas with the ``rtamt`` library (``pip install
'flc[safety]'``); ``tests/python/test_safety.py`` checks both against values computed by hand on
a scripted trajectory and against each other on simulated runs.
"""
from __future__ import annotations

from typing import Any, Mapping, Optional, Union

import numpy as np

#: Default parameters of the requirements (SI units).
DEFAULTS: dict[str, float] = {
    "a_gentle": 2.0,
    "gentle_window": 5.0,
    "a_comfort": 3.5,
    "tau": 0.9,
    "recover_within": 10.0,
    "d_safe": 10.0,
    "t_safe": 1.4,
}

#: The requirements, in order.
REQUIREMENTS: tuple[str, ...] = ("no_contact", "comfort", "time_gap", "safe_distance")


def _params(overrides: Mapping[str, float]) -> dict[str, float]:
    unknown = sorted(set(overrides) - set(DEFAULTS))
    if unknown:
        raise ValueError(f"stl: unknown parameter(s) {', '.join(unknown)} (known: {', '.join(DEFAULTS)})")
    p = dict(DEFAULTS)
    for k, v in overrides.items():
        v = float(v)
        if not np.isfinite(v) or v < 0:
            raise ValueError(f"stl: `{k}` must be a finite number >= 0, got {v}")
        p[k] = v
    return p


def formula(name: str, **params: float) -> str:
    """The requirement ``name`` as an ``rtamt`` formula, parameters substituted."""
    p = _params(params)
    if name == "no_contact":
        return "always (gap > 0)"
    if name == "comfort":
        return (
            f"always ((historically[0:{p['gentle_window']:g}] (lead_accel >= {-p['a_gentle']:g})) "
            f"implies (follower_accel >= {-p['a_comfort']:g}))"
        )
    if name == "time_gap":
        return f"always (once[0:{p['recover_within']:g}] (gap - {p['tau']:g} * follower_speed >= 0))"
    if name == "safe_distance":
        return f"always (gap - {p['t_safe']:g} * follower_speed >= {p['d_safe']:g})"
    raise ValueError(f"stl: unknown requirement {name!r} (known: {', '.join(REQUIREMENTS)})")


def _columns(series: Any) -> Mapping[str, np.ndarray]:
    s = getattr(series, "series", series)
    if not isinstance(s, Mapping):
        raise TypeError(f"stl: expected a RunResult or a mapping of series columns, got {type(series).__name__}")
    return s


def _column(s: Mapping[str, Any], name: str) -> np.ndarray:
    if name not in s:
        raise ValueError(f"stl: the series has no column `{name}`")
    a = np.asarray(s[name], dtype=float).ravel()
    if a.size == 0:
        raise ValueError(f"stl: the column `{name}` is empty")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"stl: the column `{name}` has NaN or infinite samples")
    return a


def _dt(s: Mapping[str, Any]) -> float:
    t = _column(s, "t")
    if t.size < 2:
        return 1.0
    d = np.diff(t)
    dt = float(np.median(d))
    if dt <= 0 or np.max(np.abs(d - dt)) > 1e-6 * max(1.0, dt):
        raise ValueError("stl: the column `t` must be uniformly sampled (discrete-time STL)")
    return dt


def _window(dt: float, length: float) -> int:
    """Samples in a window ``[0, length]`` s (inclusive of both ends) at step ``dt``."""
    return int(np.floor(length / dt + 1e-9)) + 1


def _sliding(x: np.ndarray, n: int, op: Any) -> np.ndarray:
    """``op`` (np.min / np.max) over the past window of ``n`` samples ending at each sample,
    truncated at the start: the discrete ``historically[0:b]`` / ``once[0:b]``. Padding the
    front with ``x[0]`` leaves each truncated window's extremum unchanged."""
    n = max(1, min(n, x.size))
    padded = np.concatenate([np.full(n - 1, x[0]), x])
    return np.asarray(op(np.lib.stride_tricks.sliding_window_view(padded, n), axis=1))


def robustness(series: Any, name: str, **params: float) -> float:
    """The robustness of requirement ``name`` (:data:`REQUIREMENTS`) on a run (a
    :class:`flc.RunResult` or a mapping of its series columns), at time 0. ``params`` override
    :data:`DEFAULTS`."""
    p = _params(params)
    s = _columns(series)
    if name == "no_contact":
        return float(np.min(_column(s, "gap")))
    dt = _dt(s)
    if name == "comfort":
        lead = _column(s, "lead_accel") + p["a_gentle"]
        gentle = _sliding(lead, _window(dt, p["gentle_window"]), np.min)
        return float(np.min(np.maximum(-gentle, _column(s, "follower_accel") + p["a_comfort"])))
    if name == "time_gap":
        e = _column(s, "gap") - p["tau"] * _column(s, "follower_speed")
        return float(np.min(_sliding(e, _window(dt, p["recover_within"]), np.max)))
    if name == "safe_distance":
        return float(np.min(_column(s, "gap") - p["t_safe"] * _column(s, "follower_speed") - p["d_safe"]))
    raise ValueError(f"stl: unknown requirement {name!r} (known: {', '.join(REQUIREMENTS)})")


def robustness_all(series: Any, **params: float) -> dict[str, float]:
    """Every requirement's robustness on a run, by name."""
    return {n: robustness(series, n, **params) for n in REQUIREMENTS}


def monitor(series: Any, name: str, dt: Optional[float] = None, **params: float) -> float:
    """The robustness of requirement ``name`` computed by the ``rtamt`` library's offline
    discrete-time monitor (needs ``pip install 'flc[safety]'``). Same value as
    :func:`robustness` (to rounding)."""
    try:
        import rtamt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc.stl.monitor() needs rtamt: pip install 'flc[safety]'") from e
    s = _columns(series)
    step = _dt(s) if dt is None else float(dt)
    spec = rtamt.StlDiscreteTimeSpecification()
    names = {"no_contact": ["gap"], "comfort": ["lead_accel", "follower_accel"], "time_gap": ["gap", "follower_speed"], "safe_distance": ["gap", "follower_speed"]}
    if name not in names:
        raise ValueError(f"stl: unknown requirement {name!r} (known: {', '.join(REQUIREMENTS)})")
    for v in names[name]:
        spec.declare_var(v, "float")
    # rtamt counts the sampling period in integer units: microseconds.
    spec.set_sampling_period(int(round(step * 1e6)), "us", 0.01)
    spec.spec = formula(name, **params)
    spec.parse()
    n = len(_column(s, names[name][0]))
    data: dict[str, Union[list[float], list[int]]] = {"time": [k * step for k in range(n)]}
    for v in names[name]:
        data[v] = [float(x) for x in _column(s, v)]
    out = spec.evaluate(data)
    return float(out[0][1])
