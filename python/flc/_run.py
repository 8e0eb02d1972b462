"""Running scenarios from Python: ``flc.run`` and ``flc.sweep`` (typed facade)."""
from __future__ import annotations

import json
import os
from concurrent.futures import Executor
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _flc
from ._scenario import Scenario
from ._suite import SuiteResults, controller_list


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
        raise AttributeError(f"{type(self).__name__} has no attribute or series column {name!r}")

    def __dir__(self) -> Iterable[str]:
        # The series columns are attributes too (tab completion in IPython / Jupyter).
        return sorted(set(super().__dir__()) | set(self.__dict__.get("series", {})))

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

    # The series columns, served from ``series`` by ``__getattr__`` and listed by ``__dir__``;
    # declared here (annotations only, no class attributes) for IDEs and type checkers. The
    # simulator's one column table is ``flc_sim::Series::COLUMNS``; tests/python/test_bindings.py
    # keeps this list equal to it.
    t: np.ndarray
    lead_x: np.ndarray
    lead_y: np.ndarray
    lead_speed: np.ndarray
    lead_accel: np.ndarray
    follower_x: np.ndarray
    follower_y: np.ndarray
    follower_yaw: np.ndarray
    follower_speed: np.ndarray
    follower_accel: np.ndarray
    gap: np.ndarray
    desired_gap: np.ndarray
    detected_distance: np.ndarray
    speed_command: np.ndarray
    accel_command: np.ndarray
    steer_command: np.ndarray
    active: np.ndarray
    reason: np.ndarray
    v2v_age: np.ndarray
    lateral_offset: np.ndarray
    heading_error: np.ndarray
    lead_gap: np.ndarray

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
        raise AttributeError(f"{type(self).__name__} has no attribute or series column {name!r}")

    def __dir__(self) -> Iterable[str]:
        # The series columns are attributes too (tab completion in IPython / Jupyter).
        return sorted(set(super().__dir__()) | set(self.__dict__.get("series", {})))

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


def _as_scenario(scenario: Any, where: str) -> Scenario:
    """``scenario`` as a :class:`Scenario` (a mapping is built with :meth:`Scenario.from_dict`);
    anything else raises ``TypeError`` naming the parameter and what to pass."""
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, Mapping):
        return Scenario.from_dict(scenario)
    hint = ""
    if isinstance(scenario, (str, os.PathLike)):
        hint = " (a file: flc.Scenario.load(path); the paper's experiment: flc.Scenario.paper(speed_kmh=...))"
    raise TypeError(f"{where}: expected a flc.Scenario or a dict shaped like a scenario file, got {type(scenario).__name__} {scenario!r:.60}{hint}")


def run(scenario: Union[Scenario, Mapping[str, Any]], record: Optional[str] = None) -> RunResult:
    """Run one scenario in Rust (GIL released). With ``record`` (a directory), the run is also
    written there as an MCAP recording for Foxglove (``docs/foxglove.md``; read it back with
    :func:`flc.read_mcap`). ``scenario`` of another type (a file name, a preset name) raises
    ``TypeError``."""
    sc = _as_scenario(scenario, "run(): `scenario`")
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
    if isinstance(scenarios, (str, bytes, Mapping, Scenario)):
        raise TypeError(f"sweep(): `scenarios` must be a list of scenarios, got {type(scenarios).__name__}")
    scs: Sequence[Scenario] = [_as_scenario(s, f"sweep(): `scenarios[{i}]`") for i, s in enumerate(scenarios)]
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
    sc = _as_scenario(scenario, "frequency_response(): `scenario`")
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


def run_suite(
    name: str,
    controllers: Optional[Union[str, Sequence[str]]] = None,
    root: Optional[Union[str, os.PathLike[str]]] = None,
) -> SuiteResults:
    """Runs a standard test suite (``docs/standard-suites.md``): ``"ncap-ccr"`` (Euro NCAP AEB
    Car-to-Car Rear), ``"r157"`` (UN R157 ALKS), ``"all"``, or a folder holding a ``suite.toml``;
    every case for each of ``controllers`` (a name, ``"flc"``, a comma-separated list as on the
    command line, or a list of names; default: every controller) next to the R157 careful driver,
    in parallel in Rust. Returns a :class:`flc.SuiteResults`: a list with one
    :class:`flc.SuiteReport` per suite, the JSON of ``flc_sim::suite::SuiteReport`` as a dict
    whose keys are also attributes: ``summary`` (one entry per controller: ``passed``, ``runs``,
    ``collisions``, ``below_reference``, ``ncap_score``) and ``results`` (one per run: ``case``,
    ``run``, ``controller``, ``outcome``, ``score``, ``below_reference``, ``metrics``).
    ``.to_pandas()`` gives the runs as a table (one row per run, metrics as columns),
    ``.summary_to_pandas()`` the summary. ``root``: the folder of the named suites (default: the suites that ship with the package,
    ``flc/data/suites``, the same files as the source tree's ``scenarios/suites``; never the
    working directory). An unknown suite or controller raises
    :class:`flc.ScenarioError`; ``controllers`` of another type a ``TypeError``."""
    if not isinstance(name, (str, os.PathLike)):
        raise TypeError(f"run_suite(): `name` must be a suite name or a folder, got {type(name).__name__}")
    from ._paths import SUITES

    names = controller_list(controllers)
    texts = _flc.run_suite(os.fspath(name), names, str(SUITES if root is None else root))
    return SuiteResults(json.loads(t) for t in texts)
