"""`RunResult.to_parquet` (issue 26, Parquet): the series round trip exactly, every column carries
the unit of the simulator's list of series columns, the metrics and scenario travel along."""
import json

import numpy as np
import pytest

import flc
from flc import _flc

pq = pytest.importorskip("pyarrow.parquet")
from flc import parquet  # noqa: E402


@pytest.fixture(scope="module")
def result():
    return flc.run(flc.Scenario.paper(speed_kmh=50, controller="pipeline", duration=20.0))


def test_run_result_round_trips_with_units(tmp_path, result):
    path = result.to_parquet(tmp_path / "run.parquet")
    series, units, metrics, scenario_json = parquet.read_series(path)
    cols = _flc.series_columns()
    assert list(series) == [n for n, _, _ in cols] and set(series) == set(result.series)
    for name, arr in result.series.items():
        assert np.array_equal(series[name], arr, equal_nan=True), name
    assert units == {n: u for n, _, u in cols}
    assert (units["t"], units["gap"], units["follower_speed"], units["follower_accel"]) == ("s", "m", "m/s", "m/s^2")
    assert metrics == result.metrics
    assert flc.Scenario.from_dict(json.loads(scenario_json)) == result.scenario


def test_types_follow_the_column_list_and_other_readers_see_the_units(tmp_path, result):
    path = result.to_parquet(tmp_path / "run.parquet")
    schema = pq.read_schema(path)
    for name, ty, unit in _flc.series_columns():
        f = schema.field(name)
        assert str(f.type) == {"f64": "double", "u8": "uint8"}[ty], name
        assert f.metadata[b"unit"] == unit.encode()
    assert any(ty == "u8" for _, ty, _ in _flc.series_columns())  # the codes really are integers
    # pandas through pyarrow reads the same numbers.
    pd = pytest.importorskip("pandas")
    df = pd.read_parquet(path)
    assert np.array_equal(df["gap"].to_numpy(), result.series["gap"], equal_nan=True)


def test_a_missing_column_is_named(tmp_path, result):
    s = dict(result.series)
    del s["gap"]
    with pytest.raises(flc.ParameterError, match="gap"):
        parquet.write_series(tmp_path / "x.parquet", s)


def test_sweep_parts_of_other_inputs_are_refused_and_restart_drops_them(tmp_path):
    """`SweepWriter` resumes only parts whose `flc.inputs_digest` is the new sweep's (issue 48)."""
    schema = [("run_id", "u64", ""), ("x", "f64", "m"), ("error", "str", "")]
    out = tmp_path / "s.parquet"
    w = parquet.SweepWriter(out, schema, digest="fnv1a128:" + "a" * 32)
    w.write(["0,1.5,", "1,2.5,"])
    w.close()
    assert parquet.SweepWriter(out, schema, digest="fnv1a128:" + "a" * 32).finished == {0, 1}
    with pytest.raises(flc.ParameterError, match=r"^out: .*2 finished rows ran other inputs.*restart=True"):
        parquet.SweepWriter(out, schema, digest="fnv1a128:" + "b" * 32)
    assert parquet.read_sweep(out).column("x").to_pylist() == [1.5, 2.5]
    w = parquet.SweepWriter(out, schema, digest="fnv1a128:" + "b" * 32, restart=True)
    assert w.finished == set() and not list(out.glob("part-*.parquet"))
