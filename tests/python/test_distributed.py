"""`flc.sweep(..., executor=...)` with Dask's distributed LocalCluster on loopback gives the same
rows as the local (Rust, rayon) path."""
import pytest

import flc

distributed = pytest.importorskip("distributed")


def test_dask_local_cluster_matches_local_sweep():
    scs = [flc.Scenario.paper(speed_kmh=v, controller=c, duration=25.0) for v in (30, 70) for c in ("flc", "pid")]
    local = flc.sweep(scs)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            remote = flc.sweep(scs, executor=client.get_executor())
    assert [r.metrics for r in remote] == [r.metrics for r in local]
    assert [r.scenario for r in remote] == scs
