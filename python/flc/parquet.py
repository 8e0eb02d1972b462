"""Parquet output (needs ``pyarrow``: ``pip install 'flc[parquet]'``).

* :func:`write_series` / :meth:`flc.RunResult.to_parquet` write a run's per-step series, one
  column per entry of the simulator's list of series columns (``flc_sim::Series::COLUMNS``) with
  its unit in the column metadata (``unit``), the metrics and the scenario in the file metadata;
  :func:`read_series` reads it back.
* :class:`SweepWriter` streams sweep rows (the CSV rows of the Rust engine) into a directory of
  Parquet parts, typed by the engine's schema (``flc_sim::sweep::schema_of``: metrics with the
  units of ``flc_sim::Metrics::COLUMNS``); :func:`read_sweep` reads it back sorted by ``run_id``.

Units live in each field's metadata under ``b"unit"`` (empty for flags, counts and text).
"""
from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

from . import _flc

PathLike = Union[str, "os.PathLike[str]"]

#: Field metadata key of a column's unit.
UNIT_KEY = b"unit"
#: File metadata key of a sweep part's inputs digest (``flc_sim::sweep::inputs_digest``).
DIGEST_KEY = "flc.inputs_digest"


def _pa() -> Any:
    try:
        import pyarrow as pa
        import pyarrow.parquet  # noqa: F401  (registers pa.parquet)
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("Parquet output needs pyarrow: pip install 'flc[parquet]'") from e
    return pa


def _arrow_type(pa: Any, name: str) -> Any:
    types = {
        "f64": pa.float64(),
        "u8": pa.uint8(),
        "u32": pa.uint32(),
        "u64": pa.uint64(),
        "i64": pa.int64(),
        "bool": pa.bool_(),
        "str": pa.string(),
    }
    return types[name]


def _schema(columns: Sequence[tuple[str, str, str]], metadata: Optional[Mapping[str, str]] = None) -> Any:
    pa = _pa()
    fields = [pa.field(n, _arrow_type(pa, t), nullable=True, metadata={UNIT_KEY: u.encode()}) for n, t, u in columns]
    return pa.schema(fields, metadata={k.encode(): v.encode() for k, v in (metadata or {}).items()})


def units(schema: Any) -> dict[str, str]:
    """``{column: unit}`` of a pyarrow schema written by this module."""
    return {f.name: (f.metadata or {}).get(UNIT_KEY, b"").decode() for f in schema}


def write_series(
    path: PathLike,
    series: Mapping[str, Any],
    metrics: Optional[Mapping[str, Any]] = None,
    scenario_json: Optional[str] = None,
) -> Path:
    """Writes per-step series (``{column: 1-D array}``, the columns of
    :attr:`flc.RunResult.series`) as one Parquet file: every series column in the simulator's
    order, typed (``f64``; codes such as ``active`` as ``uint8``) and with its unit; ``metrics``
    and the scenario's JSON in the file metadata (``flc.metrics``, ``flc.scenario``). A column
    missing from ``series`` raises :class:`flc.ParameterError` naming it."""
    import numpy as np

    pa = _pa()
    cols = _flc.series_columns()
    missing = [n for n, _, _ in cols if n not in series]
    if missing:
        raise _flc.ParameterError(f"write_series: `series` lacks the column(s) {', '.join(missing)}")
    meta = {"flc.kind": "series"}
    if metrics is not None:
        meta["flc.metrics"] = json.dumps(dict(metrics))
    if scenario_json is not None:
        meta["flc.scenario"] = scenario_json
    schema = _schema(cols, meta)
    arrays = [pa.array(np.asarray(series[n]).astype({"u8": np.uint8}.get(t, np.float64)), type=_arrow_type(pa, t)) for n, t, _ in cols]
    path = Path(path)
    pa.parquet.write_table(pa.Table.from_arrays(arrays, schema=schema), path)
    return path


def read_series(path: PathLike) -> tuple[dict[str, Any], dict[str, str], Optional[dict[str, Any]], Optional[str]]:
    """Reads a file of :func:`write_series`: ``(series, units, metrics, scenario_json)`` with
    ``series`` as ``{column: float64 NumPy array}`` (as :attr:`flc.RunResult.series`)."""
    import numpy as np

    pa = _pa()
    table = pa.parquet.read_table(path)
    meta = table.schema.metadata or {}
    series = {n: np.asarray(table.column(n).to_numpy(), dtype=float) for n in table.column_names}
    metrics = json.loads(meta[b"flc.metrics"]) if b"flc.metrics" in meta else None
    scenario = meta[b"flc.scenario"].decode() if b"flc.scenario" in meta else None
    return series, units(table.schema), metrics, scenario


def _value(text: str, ty: str) -> Any:
    if text == "":
        return None
    if ty in ("u64", "i64", "u32"):
        return int(text)
    if ty == "f64":
        return float(text)
    if ty == "bool":
        return text == "true"
    return text


def parse_rows(lines: Iterable[str], schema: Sequence[tuple[str, str, str]]) -> list[list[Any]]:
    """Sweep CSV rows (the engine's, without line breaks) as typed values by the engine's schema:
    numbers exactly (the rows hold shortest round-trip floats), empty fields as ``None``."""
    types = [t for _, t, _ in schema]
    out = []
    for fields in csv.reader(lines):
        if len(fields) != len(types):
            raise _flc.SimulationError(f"a sweep row has {len(fields)} fields, the schema {len(types)}: {fields[:2]}")
        out.append([_value(x, t) for x, t in zip(fields, types)])
    return out


class SweepWriter:
    """Streams sweep rows into the directory ``out`` as Parquet parts ``part-NNNNN.parquet``
    (each written to a temporary name and renamed, so a part is whole or absent), a part whenever
    ``partition_rows`` rows are buffered and at :meth:`close`. :attr:`finished` holds the run
    ids of the parts already there (for resuming). ``schema``: ``(column, type, unit)`` per CSV
    column (``flc._flc.sweep_plan``).

    ``digest``: the digest of the sweep's inputs (``flc._flc.sweep_plan``), written into every
    part's metadata (``flc.inputs_digest``); parts already there are resumed only if each carries
    this digest, else :class:`flc.ParameterError` naming ``out`` (the words of ``scenario sweep``'s
    refusal). ``restart=True`` deletes the parts first."""

    def __init__(
        self,
        out: PathLike,
        schema: Sequence[tuple[str, str, str]],
        partition_rows: int = 1000,
        metadata: Optional[Mapping[str, str]] = None,
        digest: Optional[str] = None,
        restart: bool = False,
    ) -> None:
        pa = _pa()
        self.dir = Path(out)
        if self.dir.exists() and not self.dir.is_dir():
            raise _flc.ParameterError(f"out: {self.dir} exists and is not a directory (a Parquet sweep is a directory of parts)")
        self.dir.mkdir(parents=True, exist_ok=True)
        if restart:
            for old in [*self.dir.glob("part-*.parquet"), *self.dir.glob(".part-*.parquet.tmp")]:
                old.unlink()
        self.columns = list(schema)
        digest_meta = {} if digest is None else {DIGEST_KEY: digest}
        self.schema = _schema(self.columns, {"flc.kind": "sweep", **(metadata or {}), **digest_meta})
        self.partition_rows = max(1, int(partition_rows))
        self._buf: list[str] = []
        parts = sorted(self.dir.glob("part-*.parquet"))
        self.finished: set[int] = set()
        stored: set[Optional[str]] = set()
        for p in parts:
            self.finished.update(int(i) for i in pa.parquet.read_table(p, columns=["run_id"]).column("run_id").to_pylist())
            meta = pa.parquet.read_schema(p).metadata or {}
            stored.add(meta[DIGEST_KEY.encode()].decode() if DIGEST_KEY.encode() in meta else None)
        if digest is not None and parts:
            # One digest for all the parts, and it is this sweep's; a part without one is old.
            kept = None if None in stored else (next(iter(stored)) if len(stored) == 1 else ",".join(sorted(str(d) for d in stored)))
            reason = _flc.sweep_stale_reason(len(self.finished), kept, digest)
            if reason is not None:
                raise _flc.ParameterError(f"out: {self.dir}: {reason}")
        self._next = 1 + max((int(p.stem.split("-")[1]) for p in parts), default=-1)

    def write(self, rows: Iterable[str]) -> None:
        """Buffers CSV rows (no line breaks); writes a part once ``partition_rows`` are buffered."""
        self._buf.extend(rows)
        if len(self._buf) >= self.partition_rows:
            self.flush()

    def flush(self) -> None:
        """Writes the buffered rows as one part (nothing if none)."""
        if not self._buf:
            return
        pa = _pa()
        values = parse_rows(self._buf, self.columns)
        arrays = [pa.array([r[k] for r in values], type=f.type) for k, f in enumerate(self.schema)]
        final = self.dir / f"part-{self._next:05d}.parquet"
        tmp = self.dir / f".{final.name}.tmp"
        pa.parquet.write_table(pa.Table.from_arrays(arrays, schema=self.schema), tmp)
        os.replace(tmp, final)
        self._next += 1
        self._buf = []

    def close(self) -> None:
        """Writes what is buffered."""
        self.flush()


def read_sweep(path: PathLike) -> Any:
    """A Parquet sweep (directory of :class:`SweepWriter`) as one ``pyarrow.Table``, rows sorted
    by ``run_id``; the units are in the field metadata (:func:`units`)."""
    pa = _pa()
    parts = sorted(Path(path).glob("part-*.parquet"))
    if not parts:
        raise _flc.ParameterError(f"read_sweep: no part-*.parquet in {path}")
    tables = [pa.parquet.read_table(p) for p in parts]
    table = pa.concat_tables(tables)
    return table.sort_by("run_id")
