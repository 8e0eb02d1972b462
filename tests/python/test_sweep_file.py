"""`flc.sweep_file` (issue 27): one sweep engine, local or on Dask. On a loopback LocalCluster of 2
worker processes the rows equal the local engine's (the function `scenario sweep` runs) byte for
byte after sorting, for several chunk sizes and as Parquet; an interrupted sweep resumes without
redoing finished ids; a worker killed mid-sweep still gives every row exactly once; a failing run
is a row with its error."""
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import flc
from flc import _flc
from flc._sweep import run_chunk

distributed = pytest.importorskip("distributed")

SWEEP = """
family = "paper"
calibration = "realistic"
mode = "random"
samples = {n}
seed = 11
[[axes]]
key = "controller"
values = ["flc", "pid", "pipeline"]
[[axes]]
key = "speed_kmh"
from = 30.0
to = 90.0
[[axes]]
key = "lead_decel"
from = 3.0
to = 9.0
[[axes]]
key = "lidar.latency_frames"
values = [0, 1, 2]
"""


def _sweep_file(tmp_path, n=16, name="s.toml"):
    f = tmp_path / name
    f.write_text(SWEEP.format(n=n))
    return f


def _lines(path):
    text = path.read_text(encoding="utf-8")
    assert text.endswith("\n")
    header, *rows = text.splitlines()
    return header, sorted(rows, key=lambda r: int(r.split(",")[0]))


def _cluster():
    return distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0")


@pytest.fixture(scope="module")
def client():
    with _cluster() as cluster, distributed.Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def local_rows(tmp_path_factory):
    d = tmp_path_factory.mktemp("local")
    f = _sweep_file(d)
    s = flc.sweep_file(f, out=d / "local.csv")
    assert (s.total, s.done, s.skipped) == (16, 16, 0)
    return _lines(d / "local.csv")


def test_distributed_rows_equal_the_local_engine_byte_for_byte(tmp_path, client, local_rows):
    f = _sweep_file(tmp_path)
    header, rows = local_rows
    assert len(rows) == 16 and header.startswith("run_id,controller,speed_kmh,lead_decel,lidar.latency_frames,seed,collision,")
    assert header.endswith(",error") and all(r.endswith(",") for r in rows)  # no run failed
    for chunk in (1, 3, 16, None):
        out = tmp_path / f"dask-{chunk}.csv"
        s = flc.sweep_file(f, executor=client, out=out, chunk_size=chunk)
        assert (s.total, s.done, s.skipped) == (16, 16, 0)
        assert s.tasks == -(-16 // s.chunk_size)
        assert _lines(out) == (header, rows), chunk
    # The same through a concurrent.futures executor and the client's executor facade.
    out = tmp_path / "executor.csv"
    flc.sweep_file(f, executor=client.get_executor(), out=out, chunk_size=5)
    assert _lines(out) == (header, rows)


def test_parquet_output_holds_the_local_rows_with_units(tmp_path, client, local_rows):
    from flc import parquet

    f = _sweep_file(tmp_path)
    header, rows = local_rows
    keys, schema, _, _ = _flc.sweep_plan(str(f))
    expected = parquet.parse_rows(rows, schema)
    for executor in (client, None):
        out = tmp_path / f"rows-{executor is None}.parquet"
        flc.sweep_file(f, executor=executor, out=out, chunk_size=4, partition_rows=5)
        assert len(list(out.glob("part-*.parquet"))) >= 2
        table = parquet.read_sweep(out)
        assert table.column_names == header.split(",")
        assert [list(r.values()) for r in table.to_pylist()] == expected
        u = parquet.units(table.schema)
        assert (u["min_gap"], u["max_decel"], u["tit"], u["max_jerk"], u["speed_kmh"], u["lead_decel"]) == ("m", "m/s^2", "s^2", "m/s^3", "km/h", "m/s^2")
        assert u["collision"] == u["controller"] == u["switches"] == ""
        types = {fld.name: str(fld.type) for fld in table.schema}
        assert (types["run_id"], types["collision"], types["switches"], types["lidar.latency_frames"], types["error"]) == ("uint64", "bool", "uint32", "int64", "string")
        assert json.loads(table.schema.metadata[b"flc.keys"]) == keys


class Stop(Exception):
    pass


def test_resume_after_an_interrupted_sweep_skips_finished_ids(tmp_path, client, local_rows):
    f = _sweep_file(tmp_path)
    out = tmp_path / "resume.csv"

    def stop_after_first(done, todo):
        raise Stop

    with pytest.raises(Stop):
        flc.sweep_file(f, executor=client, out=out, chunk_size=4, progress=stop_after_first)
    _, partial = _lines(out)
    assert len(partial) == 4
    # A cut last line, as a kill during a write leaves it, is redone, not kept.
    with open(out, "a", encoding="utf-8") as fh:
        fh.write("15,pid,47.1")
    s = flc.sweep_file(f, executor=client, out=out, chunk_size=4)
    assert (s.skipped, s.done) == (4, 12)
    assert _lines(out) == local_rows
    # Finished: nothing left to do.
    s = flc.sweep_file(f, executor=client, out=out)
    assert (s.skipped, s.done, s.tasks) == (16, 0, 0)
    assert _lines(out) == local_rows

    # The same for Parquet: the parts written before the interruption are kept.
    from flc import parquet

    pq_out = tmp_path / "resume.parquet"
    with pytest.raises(Stop):
        flc.sweep_file(f, executor=client, out=pq_out, chunk_size=4, partition_rows=1, progress=stop_after_first)
    assert parquet.read_sweep(pq_out).num_rows == 4
    s = flc.sweep_file(f, executor=client, out=pq_out, chunk_size=4)
    assert (s.skipped, s.done) == (4, 12)
    ids = parquet.read_sweep(pq_out).column("run_id").to_pylist()
    assert ids == list(range(16))


def test_a_killed_worker_still_gives_every_row_exactly_once(tmp_path, local_rows):
    n = 16
    f = _sweep_file(tmp_path)
    out = tmp_path / "killed.csv"
    killed = []
    with _cluster() as cluster, distributed.Client(cluster) as client:
        pids = client.run(os.getpid)

        def kill_a_busy_worker():
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and not killed:
                busy = [w for w, tasks in client.processing().items() if tasks]
                rows = out.read_text().count("\n") - 1 if out.exists() else 0
                if busy and rows >= 1:
                    os.kill(pids[busy[0]], 9)
                    killed.append(pids[busy[0]])
                    return
                time.sleep(0.005)

        killer = threading.Thread(target=kill_a_busy_worker)
        killer.start()
        s = flc.sweep_file(f, executor=client, out=out, chunk_size=1)
        killer.join()
        assert s.done == n
        assert killed, "no worker was killed: the sweep ended first"
        assert killed[0] not in client.run(os.getpid).values()
    header, rows = _lines(out)
    ids = [int(r.split(",")[0]) for r in rows]
    assert sorted(ids) == list(range(n))  # every row, exactly once
    assert (header, rows) == local_rows


def test_a_failing_run_is_a_row_with_its_error(tmp_path):
    from flc import parquet

    f = _sweep_file(tmp_path, n=3)
    _, schema, points, _ = _flc.sweep_plan(str(f))
    bad = json.loads(points[1][1])
    bad["scenario"]["lidar"]["rate_hz"] = 0.0
    rows = run_chunk([points[0][1], json.dumps(bad), points[2][1]])
    assert [r[0] for r in rows] == [0, 1, 2]
    typed = parquet.parse_rows([r[1] for r in rows], schema)
    names = [c for c, _, _ in schema]
    err, gap = names.index("error"), names.index("min_gap")
    assert typed[0][err] is None and typed[2][err] is None and typed[0][gap] > 0
    assert "lidar.rate_hz" in typed[1][err] and typed[1][gap] is None


def test_series_on_request(tmp_path, client):
    from flc import parquet

    f = _sweep_file(tmp_path, n=3)
    out = tmp_path / "with-series.csv"
    flc.sweep_file(f, executor=client, out=out, series=True, chunk_size=2)
    _, _, points, _ = _flc.sweep_plan(str(f))
    for run_id, point in points:
        series, units, _, _ = parquet.read_series(tmp_path / "with-series-series" / f"{run_id}.parquet")
        direct = flc.run(flc.Scenario.from_dict(json.loads(point)["scenario"]))
        assert set(series) == set(direct.series) and units["gap"] == "m"
        for k, v in direct.series.items():
            assert np.array_equal(series[k], v, equal_nan=True), k


def test_command_line(tmp_path):
    f = _sweep_file(tmp_path, n=2)
    out = tmp_path / "cli.csv"
    p = subprocess.run([sys.executable, "-m", "flc", "sweep", str(f), "--out", str(out)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "2 runs done" in p.stderr and len(_lines(out)[1]) == 2
    bad = tmp_path / "bad.toml"
    bad.write_text('family = "paper"\n[[axes]]\nkey = "lidar.rate_hzz"\nvalues = [10.0]\n')
    p = subprocess.run([sys.executable, "-m", "flc", "sweep", str(bad)], capture_output=True, text=True)
    assert p.returncode == 2 and "lidar.rate_hzz" in p.stderr, p.stderr


def test_an_openscenario_distribution_runs_the_same_way(tmp_path, client):
    from pathlib import Path

    xosc = Path(__file__).resolve().parents[1] / "data" / "openscenario" / "distribution_2x2.xosc"
    local = tmp_path / "local.csv"
    s = flc.sweep_file(xosc, out=local)
    assert (s.total, s.done) == (4, 4)
    header, rows = _lines(local)
    assert header.startswith("run_id,EgoSpeed_kmh,TargetSpeed_kmh,controller,seed,")
    dask = tmp_path / "dask.csv"
    flc.sweep_file(xosc, executor=client, out=dask, chunk_size=3)
    assert _lines(dask) == (header, rows)


DECEL = """
family = "paper"
seed = 4
[[axes]]
key = "speed_kmh"
values = [30.0]
[[axes]]
key = "lead_decel"
values = [4.0, 8.0]
"""


def _decels(out):
    """The `lead_decel` values of a CSV or Parquet sweep output, sorted."""
    if out.suffix == ".parquet":
        from flc import parquet

        return sorted(parquet.read_sweep(out).column("lead_decel").to_pylist())
    header, rows = _lines(out)
    col = header.split(",").index("lead_decel")
    return sorted(float(r.split(",")[col]) for r in rows)


def _snapshot(out):
    if out.suffix == ".parquet":
        return sorted((p.name, p.read_bytes()) for p in out.glob("part-*.parquet"))
    return out.read_bytes()


@pytest.mark.parametrize("engine", ["local", "dask"])
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_changed_sweep_is_refused_never_served_and_restart_starts_over(tmp_path, client, engine, suffix):
    executor = client if engine == "dask" else None
    f = tmp_path / "s.toml"
    f.write_text(DECEL)
    out = tmp_path / f"out{suffix}"
    s = flc.sweep_file(f, executor=executor, out=out)
    assert (s.total, s.done, s.skipped) == (2, 2, 0)
    before = _snapshot(out)
    # The same sweep: resumed, nothing to do.
    s = flc.sweep_file(f, executor=executor, out=out)
    assert (s.done, s.skipped) == (0, 2)
    # The case: lead_decel [4, 8] -> [2, 9] (the same run ids). Refused, output untouched.
    f.write_text(DECEL.replace("[4.0, 8.0]", "[2.0, 9.0]"))
    with pytest.raises(flc.ParameterError, match=r"^out: .*other inputs.*restart=True"):
        flc.sweep_file(f, executor=executor, out=out)
    assert _snapshot(out) == before and _decels(out) == [4.0, 8.0]
    # restart=True: the new sweep's rows only.
    s = flc.sweep_file(f, executor=executor, out=out, restart=True)
    assert (s.done, s.skipped) == (2, 0)
    assert _decels(out) == [2.0, 9.0]
    s = flc.sweep_file(f, executor=executor, out=out)
    assert (s.done, s.skipped) == (0, 2)


def test_the_csv_digest_is_the_same_for_the_rust_engine_and_the_python_path(tmp_path, client, local_rows):
    f = _sweep_file(tmp_path)
    out = tmp_path / "mixed.csv"

    def stop_after_first(done, todo):
        raise Stop

    # Started on Dask (Python writes the rows, the digest from the plan)...
    with pytest.raises(Stop):
        flc.sweep_file(f, executor=client, out=out, chunk_size=4, progress=stop_after_first)
    digest = json.loads((tmp_path / "mixed.csv.digest").read_text())["inputs_digest"]
    assert digest == _flc.sweep_plan(str(f))[3]
    # ...finished by the Rust engine (`scenario sweep`'s function), which accepts the digest.
    s = flc.sweep_file(f, out=out)
    assert (s.skipped, s.done) == (4, 12)
    assert _lines(out) == local_rows


def test_an_output_without_a_digest_is_refused(tmp_path):
    from flc import parquet

    f = tmp_path / "s.toml"
    f.write_text(DECEL)
    csv = tmp_path / "old.csv"
    flc.sweep_file(f, out=csv)
    (tmp_path / "old.csv.digest").unlink()  # as an flc from before the digests left it
    with pytest.raises(flc.ParameterError, match="no digest"):
        flc.sweep_file(f, out=csv)
    assert flc.sweep_file(f, out=csv, restart=True).done == 2
    # Parquet parts without `flc.inputs_digest` in their metadata (written before the digests).
    pq = tmp_path / "old.parquet"
    keys, schema, points, digest = _flc.sweep_plan(str(f))
    old = parquet.SweepWriter(pq, schema)
    old.write([r for _, r, _ in run_chunk([p for _, p in points])])
    old.close()
    before = sorted(p.read_bytes() for p in pq.glob("part-*.parquet"))
    with pytest.raises(flc.ParameterError, match="no digest"):
        flc.sweep_file(f, out=pq)
    assert sorted(p.read_bytes() for p in pq.glob("part-*.parquet")) == before
    s = flc.sweep_file(f, out=pq, restart=True)
    assert (s.done, s.skipped) == (2, 0)
    assert parquet.read_sweep(pq).schema.metadata[b"flc.inputs_digest"].decode() == digest


def test_command_line_refuses_a_changed_sweep_and_restarts(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(DECEL)
    out = tmp_path / "cli.csv"
    cmd = [sys.executable, "-m", "flc", "sweep", str(f), "--out", str(out)]
    assert subprocess.run(cmd, capture_output=True, text=True).returncode == 0
    f.write_text(DECEL.replace("[4.0, 8.0]", "[2.0, 9.0]"))
    p = subprocess.run(cmd, capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "cli.csv" in p.stderr and "--restart" in p.stderr, p.stderr
    p = subprocess.run(cmd + ["--restart"], capture_output=True, text=True)
    assert p.returncode == 0 and "2 runs done" in p.stderr, p.stderr
    assert _decels(out) == [2.0, 9.0]
