"""Running scenarios from Python: ``flc.run`` and ``flc.sweep`` (typed facade)."""
from __future__ import annotations

import json
import os
from concurrent.futures import Executor
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _flc
from ._scenario import Scenario


class PlatoonResult:
    """Every follower of a platoon run.

    ``series`` maps the column names of :attr:`RunResult.series` to NumPy arrays shaped
    ``(n_followers, n_steps)`` (row ``k - 1`` = follower ``k``; its ``lead_*`` columns are the
    vehicle in front of it), plus ``gap_error`` (gap minus the follower's reference spacing policy)
    and ``speed_error`` (speed of the vehicle in front minus its own), also reachable as
    attributes (``platoon.gap``). ``metrics`` holds each follower's metrics (the keys of
    :attr:`RunResult.metrics`), ``string_stability`` the measures and verdict
    (``docs/platoon.md``), ``record`` the whole ``platoon`` object of ``scenario --json``.
    """

    def __init__(self, record: Mapping[str, Any], series: Mapping[str, np.ndarray]) -> None:
        self.record: dict[str, Any] = dict(record)
        self.series: dict[str, np.ndarray] = dict(series)
        self.metrics: list[dict[str, Any]] = [dict(m) for m in self.record.get("per_follower", [])]
        self.string_stability: dict[str, Any] = dict(self.record.get("string_stability", {}))
        #: Per follower (index ``k - 1``) its first contact with anything (see
        #: :attr:`RunResult.collision`), ``None`` without one.
        self.collisions: list[Optional[dict[str, Any]]] = [m.pop("collision_info", None) for m in self.metrics]

    @property
    def n_followers(self) -> int:
        return int(self.record.get("followers", 0))

    @property
    def t(self) -> np.ndarray:
        """Sample times, s (1-D, shared by all followers)."""
        return self.series["t"][0]

    def vehicle_speed(self) -> np.ndarray:
        """Speeds of all vehicles, shape ``(n_followers + 1, n_steps)``, row 0 = the lead, m/s."""
        return np.vstack([self.series["lead_speed"][:1], self.series["follower_speed"]])

    def vehicle_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """World positions ``(x, y)`` of all vehicles, each ``(n_followers + 1, n_steps)``, row 0 = lead."""
        x = np.vstack([self.series["lead_x"][:1], self.series["follower_x"]])
        y = np.vstack([self.series["lead_y"][:1], self.series["follower_y"]])
        return x, y

    def __getattr__(self, name: str) -> np.ndarray:
        series = self.__dict__.get("series", {})
        if name in series:
            return series[name]
        raise AttributeError(name)

    def __repr__(self) -> str:
        ss = self.string_stability
        return f"PlatoonResult(followers={self.n_followers}, any_collision={self.record.get('any_collision')}, string_stable={ss.get('string_stable')})"


class RunResult:
    """The outcome of one run.

    ``series`` maps column names (SI units, documented in ``docs/v2v-and-metrics.md``) to NumPy
    arrays, also reachable as attributes (``result.t``, ``result.gap``); ``metrics`` has the same
    keys as ``scenario --json`` (``collision``, ``min_gap``, ...). For a platoon these are follower
    1's, and ``platoon`` (a :class:`PlatoonResult`) holds every follower; ``None`` otherwise.

    ``collision`` is follower 1's first contact with anything (``None`` without one), the
    ``collision_info`` object of ``scenario --json``: ``time``, ``impact_speed``, ``lead_speed``,
    ``follower_speed``, ``object`` (``{"kind": "vehicle" | "parked_car" | "guard_rail" | "post",
    "name": "lead" | "follower k"}`` for a vehicle, ``{"kind", "index"}`` for a road-side object,
    the index into the track's ``objects``), ``other_speed``, ``impact_speed_normal``, ``point``
    and ``normal``. ``other_contacts`` lists the first contact of every pair without a follower
    (the lead touching a road-side object): ``time``, ``a``, ``b`` (objects as above), ``speed``,
    ``impact_speed_normal``, ``point``, ``normal``.
    """

    def __init__(
        self,
        scenario: Scenario,
        metrics: Mapping[str, Any],
        series: Mapping[str, np.ndarray],
        platoon: Optional[PlatoonResult] = None,
        collision: Optional[Mapping[str, Any]] = None,
        other_contacts: Optional[Sequence[Mapping[str, Any]]] = None,
    ) -> None:
        self.scenario = scenario
        self.metrics: dict[str, Any] = dict(metrics)
        self.series: dict[str, np.ndarray] = dict(series)
        self.platoon = platoon
        self.collision: Optional[dict[str, Any]] = None if collision is None else dict(collision)
        self.other_contacts: list[dict[str, Any]] = [dict(c) for c in other_contacts or []]

    @property
    def string_stability(self) -> Optional[dict[str, Any]]:
        """The platoon's string-stability measures and verdict (``None`` without a platoon)."""
        return None if self.platoon is None else self.platoon.string_stability

    def __getattr__(self, name: str) -> np.ndarray:
        series = self.__dict__.get("series", {})
        if name in series:
            return series[name]
        raise AttributeError(name)

    def to_pandas(self) -> Any:
        """The time series as a ``pandas.DataFrame`` (needs pandas)."""
        try:
            import pandas as pd
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("RunResult.to_pandas() needs pandas: pip install 'flc[pandas]'") from e
        return pd.DataFrame(self.series)

    def to_parquet(self, path: Union[str, "os.PathLike[str]"]) -> Any:
        """Writes the time series as one Parquet file (needs pyarrow: ``pip install
        'flc[parquet]'``): one column per series column, in the simulator's order, with its unit
        in the column metadata (``unit``), the metrics and the scenario in the file metadata
        (:func:`flc.parquet.write_series`; read back with :func:`flc.parquet.read_series`). For
        a platoon these are follower 1's series. Returns the path."""
        from .parquet import write_series

        return write_series(path, self.series, self.metrics, self.scenario.to_json())

    def __repr__(self) -> str:
        m = self.metrics
        extra = "" if self.platoon is None else f", followers={self.platoon.n_followers}"
        return f"RunResult({self.scenario.name!r}, controller={self.scenario.controller!r}, collision={m.get('collision')}, min_gap={m.get('min_gap'):.2f}{extra})"


def _result(scenario: Scenario, raw: tuple[str, dict[str, Any], Optional[tuple[str, dict[str, Any]]], str]) -> RunResult:
    metrics_json, columns, platoon, contacts_json = raw
    p = None
    if platoon is not None:
        record_json, arrays = platoon
        p = PlatoonResult(json.loads(record_json), {k: np.asarray(v) for k, v in arrays.items()})
    contacts = json.loads(contacts_json)
    series = {k: np.asarray(v) for k, v in columns.items()}
    return RunResult(scenario, json.loads(metrics_json), series, p, contacts.get("collision"), contacts.get("other_contacts"))


def run(scenario: Union[Scenario, Mapping[str, Any]], record: Optional[str] = None) -> RunResult:
    """Run one scenario in Rust (GIL released). With ``record`` (a directory), the run is also
    written there as an MCAP recording for Foxglove (``docs/foxglove.md``; read it back with
    :func:`flc.read_mcap`)."""
    sc = scenario if isinstance(scenario, Scenario) else Scenario.from_dict(scenario)
    return _result(sc, _flc.run(sc.to_json(), record))


def _run_one(scenario: Scenario) -> RunResult:
    return run(scenario)


def sweep(
    scenarios: Iterable[Union[Scenario, Mapping[str, Any]]],
    threads: Optional[int] = None,
    executor: Optional[Executor] = None,
) -> list[RunResult]:
    """Run many scenarios, in parallel on all cores in Rust with the GIL released (results in
    input order, each deterministic per its seed). With ``executor`` (any
    ``concurrent.futures.Executor``, e.g. a Dask ``distributed.Client.get_executor()``), each run is
    submitted there instead."""
    scs: Sequence[Scenario] = [s if isinstance(s, Scenario) else Scenario.from_dict(s) for s in scenarios]
    if executor is not None:
        futures = [executor.submit(_run_one, s) for s in scs]
        return [f.result() for f in futures]
    raws = _flc.sweep([s.to_json() for s in scs], threads)
    return [_result(s, r) for s, r in zip(scs, raws)]


def frequency_response(scenario: Union[Scenario, Mapping[str, Any]], freqs_hz: Optional[Sequence[float]] = None) -> list[dict[str, Any]]:
    """``|Gamma(jw)|`` of a platoon scenario: for each frequency (Hz; default the scenario's
    ``platoon.string_stability.frequencies_hz``) the lead drives ``v + A sin(w t)`` and every
    vehicle's speed is fitted at ``w``. Runs in parallel in Rust (GIL released). Each point has
    ``freq_hz``, ``amplitude`` (per vehicle, lead first), ``gamma`` and ``phase_deg`` (per
    follower), ``counted``, ``max_gamma`` and ``collision`` (``docs/platoon.md``)."""
    sc = scenario if isinstance(scenario, Scenario) else Scenario.from_dict(scenario)
    freqs = None if freqs_hz is None else [float(f) for f in freqs_hz]
    points: list[dict[str, Any]] = json.loads(_flc.frequency_response(sc.to_json(), freqs))
    return points


def metrics_from_series(series: Mapping[str, Any], **params: float) -> dict[str, Any]:
    """flc's metrics (the keys of :attr:`RunResult.metrics`) of a series given as columns, e.g. a
    trajectory recorded by another simulator: ``series`` maps column names of
    :attr:`RunResult.series` (``t``, ``gap``, ``lead_speed``, ``follower_speed``,
    ``follower_accel``, ...) to equally long 1-D arrays (SI units). A column not given is NaN
    (codes such as ``active``: no controller), so the metrics that need it are empty. ``params``
    override the thresholds of ``flc_sim::MetricsParams`` (``ttc_threshold=1.5``,
    ``headway_min_speed=...``; ``docs/v2v-and-metrics.md``). No collision is known: ``collision``
    is ``False``. Unknown or unequal columns and unknown parameters raise
    :class:`flc.ParameterError` naming them. The computation is the simulator's own (Rust)."""
    columns = {str(k): np.asarray(v, dtype=float).ravel().tolist() for k, v in series.items()}
    metrics: dict[str, Any] = json.loads(_flc.metrics_from_series(columns, json.dumps(params) if params else None))
    return metrics


def run_suite(name: str, controllers: Optional[Sequence[str]] = None, root: Optional[Union[str, os.PathLike[str]]] = None) -> list[dict[str, Any]]:
    """Runs a standard test suite (``docs/standard-suites.md``): ``"ncap-ccr"`` (Euro NCAP AEB
    Car-to-Car Rear), ``"r157"`` (UN R157 ALKS), ``"all"``, or a folder holding a ``suite.toml``;
    every case for each of ``controllers`` (default: every controller) next to the R157 careful
    driver, in parallel in Rust. Returns one report per suite, the JSON of
    ``flc_sim::suite::SuiteReport`` as a dict: ``summary`` (one entry per controller: ``passed``,
    ``runs``, ``collisions``, ``below_reference``, ``ncap_score``) and ``results`` (one per run:
    ``case``, ``run``, ``controller``, ``outcome``, ``score``, ``below_reference``, ``metrics``).
    ``pandas.json_normalize(report["results"])`` gives a table. ``root``: the folder of the named
    suites (default: the suites that ship with the package, ``flc/data/suites``, the same files as
    the source tree's ``scenarios/suites``; never the working directory). An unknown suite or
    controller raises :class:`flc.ScenarioError`."""
    from ._paths import SUITES

    texts = _flc.run_suite(name, None if controllers is None else list(controllers), str(SUITES if root is None else root))
    return [json.loads(t) for t in texts]
