"""Sizes first (issue 29): a count far past its limit raises ScenarioError naming the key at once."""
import time

import pytest

import flc


@pytest.mark.parametrize(
    "data, key",
    [
        ({"platoon": {"followers": 7_000_000}}, "platoon.followers"),
        ({"vehicles": [{"name": f"car{i}"} for i in range(10_000)]}, "vehicles"),
        ({"lead": {"phases": [{"kind": "hold", "duration": 1.0}] * 10_000}}, "lead.phases"),
        ({"variants": [{"name": f"v{i}"} for i in range(10_000)]}, "variants"),
        ({"lidar": {"rate_hz": 7e6}}, "lidar.rate_hz"),
    ],
)
def test_huge_counts_raise_at_once(data, key):
    t = time.perf_counter()
    with pytest.raises(flc.ScenarioError, match=key.replace(".", r"\.").replace("[", r"\[")):
        flc.Scenario.from_dict(data)
    assert time.perf_counter() - t < 1.0


def test_huge_followers_via_overrides_raise_at_once():
    t = time.perf_counter()
    with pytest.raises(flc.ScenarioError, match=r"platoon\.followers"):
        flc.Scenario.from_dict({"platoon": {"followers": 2}}, **{"platoon.followers": 7_000_000})
    assert time.perf_counter() - t < 1.0
