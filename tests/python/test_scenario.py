"""Scenarios and runs from Python."""
import json

import numpy as np
import pytest

import flc


def test_paper_preset_with_overrides():
    s = flc.Scenario.paper(speed_kmh=70, controller="pid", lidar_rate_hz=10)
    assert s.controller == "pid"
    assert s["lidar.rate_hz"] == 10
    assert s.speed_kmh == 70


@pytest.mark.parametrize(
    "kwargs, key",
    [({"lidar_rate_hz": 0}, "lidar.rate_hz"), ({"lidar_rate_hzz": 5}, "rate_hzz"), ({"duration": "long"}, "duration")],
)
def test_bad_scenarios_name_the_key(kwargs, key):
    with pytest.raises(flc.ScenarioError, match=key.replace(".", r"\.")):
        flc.Scenario.paper(speed_kmh=50, **kwargs)


def test_unknown_controller():
    with pytest.raises(flc.ScenarioError, match="controller"):
        flc.Scenario.paper(speed_kmh=50, controller="magic")


def test_run_returns_arrays_and_cli_metrics(tmp_path):
    r = flc.run(flc.Scenario.paper(speed_kmh=30, controller="flc"))
    for key in ["collision", "impact_speed", "min_gap", "final_clearance", "min_ttc", "max_decel", "max_jerk"]:
        assert key in r.metrics
    assert isinstance(r.t, np.ndarray) and r.t.shape == r.gap.shape
    assert np.all(np.diff(r.t) > 0)
    assert r.metrics["min_gap"] == pytest.approx(float(np.nanmin(r.gap)))


def test_sweep_is_deterministic_and_ordered():
    scs = [flc.Scenario.paper(speed_kmh=v, controller="flc", duration=20.0) for v in (30, 50)]
    a = flc.sweep(scs)
    b = flc.sweep(scs, threads=1)
    assert [x.metrics for x in a] == [y.metrics for y in b]
    assert a[0].scenario.speed_kmh == 30
    np.testing.assert_array_equal(a[1].gap, b[1].gap)


def test_load_toml(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('controller = "flc"\nduration = 5.0\n[lidar]\nrate_hz = 10.0\n')
    s = flc.Scenario.load(p)
    assert s["lidar.rate_hz"] == 10.0
    bad = tmp_path / "bad.toml"
    bad.write_text("[lidar]\nrate_hz = -3.0\n")
    with pytest.raises(flc.ScenarioError, match=r"lidar\.rate_hz"):
        flc.Scenario.load(bad)


def test_scenario_pickles():
    import pickle

    s = flc.Scenario.paper(speed_kmh=50)
    assert pickle.loads(pickle.dumps(s)) == s
