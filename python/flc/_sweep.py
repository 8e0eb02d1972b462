"""One sweep engine, local or distributed: :func:`sweep_file` (``docs/distributed.md``).

The Rust engine (``flc_sim::sweep``) expands the sweep (run ids, seeds), runs each point and
formats its row; this module only groups the points into chunks, hands them to an executor (a
Dask ``distributed.Client``, any ``concurrent.futures.Executor``, or threads in this process) and
writes the rows as the chunks come back.
"""
from __future__ import annotations

import concurrent.futures as cf
import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generator, Optional, Sequence, Union

import numpy as np

from . import _flc
from ._progress import ProgressArg, stderr_is_terminal
from ._progress import resolve as resolve_progress

PathLike = Union[str, "os.PathLike[str]"]

#: Automatic chunking: about this many tasks per worker thread (the last tasks balance the load)...
TASKS_PER_THREAD = 16
#: ...and never more runs per task than this (``docs/distributed.md``: chunk-size measurements).
MAX_AUTO_CHUNK = 32


@dataclass(frozen=True)
class SweepSummary:
    """What :func:`sweep_file` did: ``total`` runs in the sweep, ``skipped`` already in ``out``,
    ``done`` now, in ``tasks`` tasks of at most ``chunk_size`` runs (0 for the local CSV engine,
    which runs point by point)."""

    out: Path
    total: int
    skipped: int
    done: int
    tasks: int
    chunk_size: int
    seconds: float


def auto_chunk_size(runs: int, threads: int) -> int:
    """The automatic chunk size: ``runs / (TASKS_PER_THREAD * threads)`` rounded up, within
    ``[1, MAX_AUTO_CHUNK]``."""
    return max(1, min(MAX_AUTO_CHUNK, math.ceil(runs / (TASKS_PER_THREAD * max(1, threads)))))


def run_chunk(points_json: Sequence[str], series: bool = False) -> list[tuple[int, str, Optional[dict[str, np.ndarray]]]]:
    """The task of a distributed sweep: runs the points (JSON from the plan) one after the other
    in Rust with the GIL released and returns ``(run_id, CSV row, series or None)`` per point."""
    return _flc.sweep_run_chunk(list(points_json), series)


def _dask_client(executor: Any) -> Any:
    """The Dask client behind ``executor`` (a ``Client`` or its ``get_executor()``), else ``None``."""
    try:
        import distributed
    except ImportError:
        return None
    if isinstance(executor, distributed.Client):
        return executor
    inner = getattr(executor, "_client", None)
    return inner if isinstance(inner, distributed.Client) else None


def _threads(executor: Any, client: Any) -> int:
    if client is not None:
        return max(1, sum(client.nthreads().values()))
    return max(1, int(getattr(executor, "_max_workers", 0) or os.cpu_count() or 1))


def _series_dir(out: Path) -> Path:
    return out.with_name(out.stem + "-series")


def _completed(executor: Any, client: Any, chunks: list[list[str]], series: bool) -> Generator[Any, None, None]:
    """Submits one task per chunk and yields the results as tasks finish (cancels the rest if the
    caller stops early)."""
    if client is not None:
        import distributed

        futures = [client.submit(run_chunk, c, series, pure=False) for c in chunks]
        try:
            for f in distributed.as_completed(futures):
                yield f.result()
        finally:
            client.cancel([f for f in futures if not f.done()])
        return
    futs = [executor.submit(run_chunk, c, series) for c in chunks]
    try:
        for f in cf.as_completed(futs):
            yield f.result()
    finally:
        for f in futs:
            f.cancel()


def sweep_file(
    path: PathLike,
    executor: Any = None,
    out: Optional[PathLike] = None,
    chunk_size: Optional[int] = None,
    series: bool = False,
    threads: Optional[int] = None,
    partition_rows: int = 1000,
    progress: ProgressArg = None,
    restart: bool = False,
) -> SweepSummary:
    """Runs a sweep file (TOML, ``docs/safety-envelope.md``) or an OpenSCENARIO distribution
    (``.xosc``) with the Rust sweep engine, locally or on a cluster; the rows are those of
    ``scenario sweep FILE`` (same run ids, seeds and values; sorted by ``run_id`` the same bytes).

    ``out``: ``*.csv`` (default: the sweep file with ``.csv``) or ``*.parquet`` (a directory of
    Parquet parts with units in the column metadata, :mod:`flc.parquet`, needs pyarrow). Runs
    already in ``out`` are skipped (resume) only if they ran exactly this sweep's inputs: the
    digest of the inputs (``flc_sim::sweep::inputs_digest``: the flc version and every
    run's scenario) is kept with the output (``<out>.digest`` next to a CSV, as ``scenario
    sweep`` writes it; each Parquet part's metadata ``flc.inputs_digest``), and an output of
    other inputs, or with rows but no digest, raises :class:`flc.ParameterError` naming ``out``.
    ``restart=True`` starts ``out`` over (its rows, Parquet parts and series files are dropped).
    A run that fails is a row with its ``error``.

    ``executor``: ``None`` runs here on ``threads`` (default all cores); a Dask
    ``distributed.Client`` (or its ``get_executor()``) or any ``concurrent.futures.Executor``
    gets one task per chunk of ``chunk_size`` runs (default :func:`auto_chunk_size`); each task
    runs its chunk in Rust with the GIL released and sends back its rows only, written as tasks
    finish. A worker lost mid-task costs its chunk, which Dask runs again elsewhere. With
    ``series=True`` each task also sends the runs' series, written as
    ``<out stem>-series/<run_id>.parquet`` (:func:`flc.parquet.write_series`).

    Rows end in ``run_id`` order in a CSV (sorted when the sweep ends; a Parquet output is read
    sorted by :func:`flc.parquet.read_sweep`). ``progress``: ``None`` (default) draws a progress
    bar on stderr when stderr is a terminal, ``False`` none, ``True`` always; a callable
    ``progress(done, todo)`` is called after each task instead (with ``True`` or a callable the
    sweep runs in tasks even locally; the rows are the same). Bad files raise
    :class:`flc.ScenarioError` naming the file and key; a bad argument :class:`flc.ParameterError`.
    """
    t0 = time.perf_counter()
    src = Path(path)
    out_path = Path(out) if out is not None else src.with_suffix(".csv")
    parquet = out_path.suffix.lower() == ".parquet"
    if chunk_size is not None and (not isinstance(chunk_size, int) or chunk_size < 1):
        raise _flc.ParameterError(f"chunk_size: expected a positive integer, got {chunk_size!r}")
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise _flc.ParameterError(f"threads: expected a positive integer, got {threads!r}")
    # A callable, or a bar forced on a stream that is no terminal, is drawn from here (tasks).
    custom = progress is True or (callable(progress) and not isinstance(progress, bool))
    if executor is None and not parquet and not series and not custom:
        draw = progress is None and stderr_is_terminal()
        done, total = _flc.sweep_local_csv(str(src), str(out_path), threads, bool(restart), draw)
        return SweepSummary(out_path, total, total - done, done, 0, 0, time.perf_counter() - t0)

    keys, schema, points, digest = _flc.sweep_plan(str(src))
    if parquet:
        from .parquet import SweepWriter

        meta = {"flc.source": str(src), "flc.keys": json.dumps(keys)}
        sink: Any = SweepWriter(out_path, schema, partition_rows=partition_rows, metadata=meta, digest=digest, restart=bool(restart))
        finished: set[int] = sink.finished
    else:
        finished = set(_flc.sweep_open_csv(str(out_path), keys, digest, bool(restart)))
        sink = _CsvSink(out_path)
    if restart and _series_dir(out_path).is_dir():
        for old in _series_dir(out_path).glob("*.parquet"):
            old.unlink()
    if series:
        from .parquet import write_series

        _series_dir(out_path).mkdir(parents=True, exist_ok=True)
    todo = [j for i, j in points if i not in finished]
    report, bar = resolve_progress(progress, len(todo))
    own = None
    if executor is None:
        own = cf.ThreadPoolExecutor(max_workers=threads or os.cpu_count() or 1)
        executor = own
    client = _dask_client(executor)
    chunk = chunk_size or auto_chunk_size(len(todo), _threads(executor, client))
    chunks = [todo[k : k + chunk] for k in range(0, len(todo), chunk)]
    written = 0
    results = _completed(executor, client, chunks, series)
    try:
        for rows in results:
            sink.write([r for _, r, _ in rows])
            if series:
                for run_id, _, cols in rows:
                    if cols is not None:
                        write_series(_series_dir(out_path) / f"{run_id}.parquet", cols)
            written += len(rows)
            if report is not None:
                report(written, len(todo))
    finally:
        results.close()
        sink.close()
        if bar is not None:
            bar.close()
        if own is not None:
            own.shutdown(wait=True, cancel_futures=True)
    return SweepSummary(out_path, len(points), len(points) - len(todo), written, len(chunks), chunk, time.perf_counter() - t0)


class _CsvSink:
    """Appends rows to a CSV prepared by the engine (``_flc.sweep_open_csv``), flushed per task."""

    def __init__(self, out: Path) -> None:
        self._path = out
        self._f = open(out, "a", encoding="utf-8", newline="")

    def write(self, rows: Sequence[str]) -> None:
        self._f.write("".join(r + "\n" for r in rows))
        self._f.flush()

    def close(self) -> None:
        self._f.close()
        # Rows were appended as tasks finished: put them in run_id order (resume reads ids).
        _flc.sweep_sort_csv(str(self._path))
