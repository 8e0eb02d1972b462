"""A sweep file on a 2-worker Dask LocalCluster (loopback, worker processes, 1 thread each)
against the local engine (`flc.sweep_file` without executor = `scenario sweep`, rayon on the same
2 cores), measured alternately (the machine may be shared), plus the bytes a task sends back per
run and the bytes of a point sent to a worker (issue 27, docs/benchmarks.md).

Run: target/ci-venv/bin/python benches/distributed_sweep.py [SWEEP] [--chunks 1,8,auto] [--repeats 2]
"""
from __future__ import annotations

import argparse
import pickle
import resource
import statistics
import tempfile
import time
from pathlib import Path

import distributed

import flc
from flc import _flc
from flc._sweep import run_chunk


def _own_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _cpu(client: distributed.Client) -> float:
    """CPU seconds used so far by this process (client, LocalCluster scheduler, nannies, the
    local engine's threads) and by the worker processes: the cost, whatever the machine's load."""
    return _own_cpu() + sum(client.run(_own_cpu).values())


def _rows(path: Path) -> list[str]:
    return sorted(path.read_text().splitlines()[1:], key=lambda r: int(r.split(",")[0]))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("sweep", nargs="?", default="sweeps/bench-1k.toml")
    ap.add_argument("--chunks", default="1,8,auto")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    chunks = [None if c == "auto" else int(c) for c in args.chunks.split(",")]
    _, _, points, _ = _flc.sweep_plan(args.sweep)
    sample = [j for _, j in points[:20]]
    back = len(pickle.dumps(run_chunk(sample), protocol=pickle.HIGHEST_PROTOCOL)) / len(sample)
    sent = sum(len(j.encode()) for j in sample) / len(sample)
    times: dict[str, list[float]] = {"local": []}
    cpus: dict[str, list[float]] = {"local": []}
    info: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp, distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0"
    ) as cluster, distributed.Client(cluster) as client:
        reference = None
        for rep in range(args.repeats):
            for c in [0, *chunks]:  # 0 = the local engine; alternate local and Dask runs
                out = Path(tmp) / f"r{rep}-{c}.csv"
                c0 = _cpu(client)
                t0 = time.perf_counter()
                if c == 0:
                    s = flc.sweep_file(args.sweep, out=out, threads=2)
                    name = "local"
                else:
                    s = flc.sweep_file(args.sweep, executor=client, out=out, chunk_size=c)
                    name = f"dask chunk {'auto' if c is None else c}"
                    info[name] = f"{s.chunk_size} runs x {s.tasks} tasks"
                dt = time.perf_counter() - t0
                cpu = _cpu(client) - c0
                times.setdefault(name, []).append(dt)
                cpus.setdefault(name, []).append(cpu)
                rows = _rows(out)
                reference = reference or rows
                assert rows == reference, f"{name}: rows differ from the local engine's"
                print(f"# rep {rep} {name}: {dt:.2f} s wall, {cpu:.2f} s CPU", flush=True)
    local = statistics.median(times["local"])
    local_cpu = statistics.median(cpus["local"])
    print(f"\n{len(points)} runs ({args.sweep}); each {args.repeats} times, alternately; medians\n")
    print("| engine | chunking | wall time | all wall times | wall vs local | CPU time (all processes) | CPU vs local |")
    print("|---|---|---:|---|---:|---:|---:|")
    for name, ts in times.items():
        m, cm = statistics.median(ts), statistics.median(cpus[name])
        print(
            f"| {name} | {info.get(name, 'rayon, 2 threads')} | {m:.2f} s | {', '.join(f'{t:.2f}' for t in ts)} | {m / local - 1:+.1%} "
            f"| {cm:.2f} s | {cm / local_cpu - 1:+.1%} |"
        )
    print(f"\nrows identical to the local engine's (sorted) in every run; sent back per run: {back:.0f} B "
          f"(pickled rows of a 20-run chunk); sent to a worker per run: {sent:.0f} B (point JSON)")


if __name__ == "__main__":
    main()
