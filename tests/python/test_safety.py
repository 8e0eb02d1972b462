"""Safety evidence (docs/safety-evidence.md): STL robustness, falsification, replay."""
import numpy as np
import pytest

import flc
from flc import stl

# A scripted trajectory, 0.5 s steps, robustness computed by hand in the comments.
SCRIPT = dict(
    t=[k * 0.5 for k in range(9)],
    gap=[10, 8, 4, 3, 2.5, 2.5, 3, 5, 6],
    follower_speed=[10, 10, 9, 8, 6, 4, 3, 3, 3],
    lead_accel=[0, 0, -1, -1, -3, -3, 0, 0, 0],
    follower_accel=[0, -1, -2, -4, -4, -4, -2, 0, 0],
)
# Windows of 1 s = 3 samples; time gap 0.5 s.
PARAMS = dict(gentle_window=1.0, recover_within=1.0, tau=0.5)
HAND = {
    # min gap
    "no_contact": 2.5,
    # lead_accel + 2 = 2 2 1 1 -1 -1 2 2 2; its min over 3 samples = 2 2 1 1 -1 -1 -1 -1 2;
    # follower_accel + 3.5 = 3.5 2.5 1.5 -0.5 -0.5 -0.5 1.5 3.5 3.5; max(-hist, f) =
    # 3.5 2.5 1.5 -0.5 1 1 1.5 3.5 3.5 -> -0.5 (at 1.5 s the lead brakes 1 m/s², the follower 4)
    "comfort": -0.5,
    # gap - 0.5 v = 5 3 -0.5 -1 -0.5 0.5 1.5 3.5 4.5; its max over 3 samples =
    # 5 5 5 3 -0.5 0.5 1.5 3.5 4.5 -> -0.5 (1.0-2.0 s below the time gap throughout)
    "time_gap": -0.5,
}


@pytest.mark.parametrize("name", stl.REQUIREMENTS)
def test_stl_robustness_matches_hand_computation_and_rtamt(name):
    assert stl.robustness(SCRIPT, name, **PARAMS) == pytest.approx(HAND[name], abs=1e-12)
    assert stl.monitor(SCRIPT, name, **PARAMS) == pytest.approx(HAND[name], abs=1e-9)


def test_stl_time_gap_window_matters():
    # With 1.5 s (4 samples) the deficit 1.0-2.0 s is recovered in time: max over 0.5-2.0 s = 3,
    # over 1.0-2.5 s = 0.5, the smallest window maximum.
    p = dict(PARAMS, recover_within=1.5)
    assert stl.robustness(SCRIPT, "time_gap", **p) == pytest.approx(0.5)
    assert stl.monitor(SCRIPT, "time_gap", **p) == pytest.approx(0.5)


def test_stl_numpy_equals_rtamt_on_a_simulated_collision():
    r = flc.run(flc.Scenario.paper(90, "pid", preset="paper"))
    assert r.metrics["collision"]
    for name in stl.REQUIREMENTS:
        assert stl.robustness(r, name) == pytest.approx(stl.monitor(r, name), abs=1e-9), name
    assert stl.robustness(r, "no_contact") == pytest.approx(r.metrics["min_gap"]) and r.metrics["min_gap"] < 0


def test_stl_bad_input_names_the_problem():
    with pytest.raises(ValueError, match="unknown requirement 'nope'"):
        stl.robustness(SCRIPT, "nope")
    with pytest.raises(ValueError, match="unknown parameter"):
        stl.robustness(SCRIPT, "comfort", a_gentel=1.0)
    with pytest.raises(ValueError, match="column `gap`"):
        stl.robustness({"t": [0.0, 1.0]}, "no_contact")
    with pytest.raises(ValueError, match="uniformly sampled"):
        stl.robustness(dict(SCRIPT, t=[0, 1, 2, 3, 4, 5, 6, 7, 9]), "time_gap")
