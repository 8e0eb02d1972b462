"""MCAP recordings from Python: ``flc.run(..., record=DIR)`` writes them, ``flc.read_mcap`` and the
``mcap`` PyPI reader read them back."""
import json
from collections import Counter, defaultdict

import numpy as np
import pytest

import flc

mcap_reader = pytest.importorskip("mcap.reader")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    sc = flc.Scenario.paper(speed_kmh=50, controller="pipeline")
    r = flc.run(sc, record=str(d))
    files = sorted(d.glob("*.mcap"))
    assert [f.name for f in files] == ["paper-realistic-50-pipeline-50kmh.mcap"]
    return sc, r, files[0]


def test_read_mcap_returns_the_runs_series_scenario_and_metrics(recorded):
    sc, r, path = recorded
    back = flc.read_mcap(path)
    assert list(back.series) == list(r.series)
    for name, col in r.series.items():
        got = back.series[name]
        assert got.dtype == np.float64 and got.shape == col.shape, name
        # Bit for bit (NaN where the run has NaN).
        assert np.array_equal(got, col, equal_nan=True), name
    assert np.array_equal(back.gap.view(np.uint64), r.gap.view(np.uint64))
    assert back.scenario == sc
    assert back.metrics == r.metrics


def test_channels_have_foxglove_schemas_and_counts_follow_the_rates(recorded):
    sc, r, path = recorded
    counts: Counter = Counter()
    times = defaultdict(list)
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f)
        summary = reader.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        schemas = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values()}
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] += 1
            times[channel.topic].append(message.log_time)
    expected = {
        "/lidar/points": "foxglove.PointCloud",
        "/detector": "foxglove.SceneUpdate",
        "/pursuit/lookahead": "foxglove.SceneUpdate",
        "/tf": "foxglove.FrameTransforms",
        "/track": "foxglove.SceneUpdate",
        "/vehicles": "foxglove.SceneUpdate",
    }
    for topic, name in expected.items():
        assert (schemas[topic].name, schemas[topic].encoding, channels[topic].message_encoding) == (name, "protobuf", "protobuf")
    assert (schemas["/flc/state"].name, schemas["/flc/state"].encoding, channels["/flc/state"].message_encoding) == ("flc.State", "jsonschema", "json")
    assert set(json.loads(schemas["/flc/state"].data)["properties"]) >= set(r.series)

    steps = len(r.t)
    assert counts["/flc/state"] == steps and counts["/tf"] == steps + 1
    assert abs(counts["/lidar/points"] - r.t[-1] * sc["lidar.rate_hz"]) <= 1
    assert counts["/detector"] == counts["/pursuit/lookahead"] == counts["/lidar/points"]
    assert counts["/track"] == counts["/vehicles"] == 1
    for topic, ts in times.items():
        assert all(a < b for a, b in zip(ts, ts[1:])), topic
    assert times["/flc/state"] == [round(t * 1e9) for t in r.t]
    # Chunked with an index (an empty list would make the `all` below true for nothing).
    assert len(summary.chunk_indexes) > 0
    assert all(c.compression == "zstd" for c in summary.chunk_indexes)
