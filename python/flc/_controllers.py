"""Step-wise controllers and the detector (typed facade over flc._flc)."""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Optional, Tuple

import numpy as np

from . import _flc
from ._params import params_json


def _terms(text: str) -> dict[str, Any]:
    """A law's terms: the JSON of ``flc_core::Terms`` (name -> value, in the law's order)."""
    terms: dict[str, Any] = json.loads(text)
    return terms


@dataclass(frozen=True)
class Command:
    """A longitudinal command: target speed (m/s), the law's acceleration term (m/s²) and status."""

    speed: float
    accel: float
    status: str


class _DistanceLaw:
    """A law on the LiDAR distance and the own speed only (no timestamp, no dt): built from the
    keyword arguments merged into the Rust defaults of ``_COMPONENT``, stepped once per frame."""

    _COMPONENT: str = ""
    _CLASS: Any = None

    def __init__(self, **params: Any) -> None:
        self._inner: Any = type(self)._CLASS(params_json(self._COMPONENT, params))

    def step(self, distance: Optional[float], own_speed: float) -> Command:
        """One LiDAR frame: ``distance`` in m (None: no lead), ``own_speed`` in m/s."""
        return Command(*self._inner.step(distance, own_speed))

    def terms(self) -> dict[str, Any]:
        """Terms of the last step: the Rust law's names, order and values (``flc_core::Terms``),
        flags as booleans (the class's docstring lists them)."""
        return _terms(self._inner.terms_json())

    def reset(self) -> None:
        """Back to the initial state (the next detection is a first detection)."""
        self._inner.reset()


class FallbackController(_DistanceLaw):
    """The paper's FLC, Eqs. (2)-(5): LiDAR distance + own speed in, speed command out.

    Keyword arguments are the fields of ``FlcParams`` (paper symbols in snake case, e.g.
    ``time_gap`` = T_G, ``base_gap`` = B_gap, ``bound_t``); defaults are the paper's.
    No timestamp and no dt. ``terms()``: tau_d, d_d, scale_f, f_shift, delta_d, dist_s, a, ...
    (``flc_core::FlcTerms``); flags ``braking_branch``, ``overridden``.
    """

    _COMPONENT = "flc"
    _CLASS = _flc.FallbackController


class RobustFallbackController(_DistanceLaw):
    """The robust FLC v1 (beyond the paper, ``docs/robust-flc.md``; ``controller="flc-robust-v1"``):
    the same inputs as the paper's FLC (LiDAR distance + own speed, no dt), a rate-invariant law.

    Keyword arguments are the fields of ``RobustFlcParams`` (``standstill_gap``, ``time_gap``,
    ``brake_gain``, ``envelope_decel``, ...); defaults are the documented design. ``terms()``:
    desired_gap, gap_error, gap_speed, envelope_speed, target_speed, revealed, latched,
    latch_min_distance, a; flags ``revealed``, ``latched``.
    """

    _COMPONENT = "flc_robust_v1"
    _CLASS = _flc.RobustFallbackController


class RobustFallbackController2(_DistanceLaw):
    """The robust FLC v2 (``docs/robust-flc.md``, "v2"; ``controller="flc-robust"``): v1's law
    with rules that do not brake for missed or spurious frames, an approach from far behind, a
    gentler small-error braking gain and a comfort layer that brakes for the closing speed it
    reads from its own motion. Same inputs (LiDAR distance + own speed, no dt).

    Keyword arguments are the fields of ``RobustFlc2Params``: ``law`` (a dict of v1's fields,
    merged into v2's defaults), ``sight_distance``, ``sight_decel``, ``release_speed``,
    ``release_closing``, ``approach_time_gap``, ``firm_error``, ``firm_gain``, ``comfort`` (a
    dict of the comfort layer's fields: ``memory``, ``response_time``, ``clock_accel``,
    ``accel``, ``decel``, ``fade_speed``, ``max_decel``).
    ``terms()``: distance, gap_speed, envelope_speed, approach_speed, target_speed, held,
    pending, revealed, latched, a_law, closing, closing_brake, comfort, a; flags ``held``,
    ``pending``, ``revealed``, ``latched``, ``comfort``.
    """

    _COMPONENT = "flc_robust"
    _CLASS = _flc.RobustFallbackController2


class PidController:
    """The V2V PID gap controller of Sec. III-A.3 (time gap 0.5 s, far / near gains)."""

    def __init__(self, **params: Any) -> None:
        self._inner = _flc.PidController(params_json("pid", params))

    def step(self, lead_speed: float, own_speed: float, distance: Optional[float], dt: float) -> Command:
        """One step (speeds in m/s, distance in m, dt in s)."""
        return Command(*self._inner.step(lead_speed, own_speed, distance, dt))

    def terms(self) -> dict[str, Any]:
        """Terms of the last step (desired, error, error_rate, integral, gains, u), as the Rust law
        names them (``flc_core::PidTerms``); ``gains`` is 0 for the far gains, 1 for the near ones."""
        return _terms(self._inner.terms_json())

    def reset(self) -> None:
        """Clear the integrator."""
        self._inner.reset()


@dataclass(frozen=True)
class Steering:
    """Output of the lateral controller."""

    steer: float
    lookahead: float
    alpha: float
    lookahead_point: Tuple[float, float]
    status: str


class PurePursuit:
    """Pure pursuit towards the lead, Eq. (1) (``law="paper"``) or the standard form."""

    def __init__(self, **params: Any) -> None:
        self._inner = _flc.PurePursuit(params_json("pure_pursuit", params))

    def step(self, lead: Optional[Tuple[float, float]], own_speed: float) -> Steering:
        """Steering (rad, + left) towards the lead at ``lead`` = (x, y) in the follower frame (m)."""
        return Steering(*self._inner.step(lead, own_speed))


class Supervisor:
    """The parallel longitudinal controller of Fig. 1 (PID while V2V is fresh, FLC otherwise)."""

    def __init__(self, **params: Any) -> None:
        self._inner = _flc.Supervisor(params_json("supervisor", params))

    def step(self, v2v: Optional[Tuple[float, int]], distance: Optional[float], own_speed: float, dt: float) -> dict[str, Any]:
        """One tick. ``v2v`` = (lead_speed m/s, sequence number) received this tick, or None."""
        out: dict[str, Any] = json.loads(self._inner.step(v2v, distance, own_speed, dt))
        return out

    def reset(self) -> None:
        """Back to the initial state (FLC, no V2V)."""
        self._inner.reset()


class LeadDetector:
    """The BEV-grid LiDAR lead detector of Sec. III-A.1."""

    def __init__(self, **params: Any) -> None:
        self._inner = _flc.LeadDetector(params_json("detector", params))

    def detect(self, points: Any, path_curvature: float = 0.0) -> dict[str, Any]:
        """Detect the lead in an (N, 2) array of points (sensor frame, x forward, m)."""
        arr = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 2))
        return dict(self._inner.detect(arr, path_curvature))
