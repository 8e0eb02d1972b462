"""Running scenarios from Python: ``flc.run`` and ``flc.sweep`` (typed facade)."""
from __future__ import annotations

import json
from concurrent.futures import Executor
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _flc
from ._scenario import Scenario


class RunResult:
    """The outcome of one run.

    ``series`` maps column names (SI units, documented in ``docs/v2v-and-metrics.md``) to NumPy
    arrays, also reachable as attributes (``result.t``, ``result.gap``); ``metrics`` has the same
    keys as ``scenario --json`` (``collision``, ``min_gap``, ...).
    """

    def __init__(self, scenario: Scenario, metrics: Mapping[str, Any], series: Mapping[str, np.ndarray]) -> None:
        self.scenario = scenario
        self.metrics: dict[str, Any] = dict(metrics)
        self.series: dict[str, np.ndarray] = dict(series)

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

    def __repr__(self) -> str:
        m = self.metrics
        return f"RunResult({self.scenario.name!r}, controller={self.scenario.controller!r}, collision={m.get('collision')}, min_gap={m.get('min_gap'):.2f})"


def _result(scenario: Scenario, raw: tuple[str, dict[str, Any]]) -> RunResult:
    metrics_json, columns = raw
    return RunResult(scenario, json.loads(metrics_json), {k: np.asarray(v) for k, v in columns.items()})


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
