"""Reading MCAP recordings of runs (``flc.run(scenario, record=DIR)``, ``scenario --record DIR``)."""
from __future__ import annotations

import json
import math
import os
from typing import Any, Union

import numpy as np

from ._run import RunResult
from ._scenario import Scenario

#: Topic of the per-step state (JSON, one message per physics step; see docs/foxglove.md).
STATE_TOPIC = "/flc/state"
#: Metadata records written by the simulator.
SCENARIO_METADATA = "flc.scenario"
METRICS_METADATA = "flc.metrics"


def read_mcap(path: Union[str, "os.PathLike[str]"]) -> RunResult:
    """Read a run back from its MCAP recording (needs the ``mcap`` package: ``pip install 'flc[mcap]'``).

    Returns a :class:`RunResult`: ``series`` maps the same column names as ``flc.run`` to float64
    arrays decoded from the ``/flc/state`` channel (``null`` -> NaN), equal to the run's series;
    ``scenario`` comes from the file's ``flc.scenario`` metadata; ``metrics`` from ``flc.metrics``,
    which only a finished run has (``{}`` for a run that was interrupted).
    """
    try:
        from mcap.reader import make_reader
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc.read_mcap needs the mcap package: pip install 'flc[mcap]'") from e

    metadata: dict[str, dict[str, str]] = {}
    rows: list[dict[str, Any]] = []
    with open(os.fspath(path), "rb") as f:
        reader = make_reader(f)
        for record in reader.iter_metadata():
            metadata[record.name] = dict(record.metadata)
        for _schema, _channel, message in reader.iter_messages(topics=[STATE_TOPIC], log_time_order=True):
            rows.append(json.loads(message.data))

    if SCENARIO_METADATA not in metadata:
        raise ValueError(f"{os.fspath(path)}: not an flc recording (no `{SCENARIO_METADATA}` metadata)")
    scenario = Scenario(json.loads(metadata[SCENARIO_METADATA]["scenario"]))
    metrics = json.loads(metadata[METRICS_METADATA]["metrics"]) if METRICS_METADATA in metadata else {}

    # Numeric fields, in the order the simulator writes them (the names `*_name` are labels).
    columns = [k for k, v in rows[0].items() if not isinstance(v, str)] if rows else []
    series = {k: np.array([_number(r.get(k)) for r in rows], dtype=np.float64) for k in columns}
    return RunResult(scenario, metrics, series)


def _number(v: Any) -> float:
    return math.nan if v is None else float(v)
