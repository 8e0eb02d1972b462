"""The UN R157 careful and competent human driver from Python (docs/careful-driver.md): selected by
name like every controller, parameterised by [careful_driver], stopping short of a standing car
exactly when the hand-computed stopping distance says it can."""
import math

import numpy as np

import flc
import flc.envelope
from flc import _scenario

A = 0.774 * 9.81  # 0.774 g, m/s²
T = 0.6  # build-up time, s


def by_hand(v: float) -> float:
    """v 1.15 + (v T - A T² / 6) + (v - A T / 2)² / (2 A), m."""
    return v * 1.15 + (v * T - A * T * T / 6.0) + (v - A * T / 2.0) ** 2 / (2.0 * A)


def standing_car(sight: float) -> flc.Scenario:
    """A car standing on a straight road, the driver cruising at 80 km/h from 120 m; it sees the
    car from ``sight`` m on, and ``risk_decel = 2`` makes that sudden appearance a disturbance."""
    return flc.Scenario.from_dict(
        {
            "name": "careful-driver-standing-car",
            "controller": "careful-driver",
            "duration": 20.0,
            "lead": {"initial_speed": 0.0, "phases": [{"kind": "hold", "duration": 100.0}]},
            "follower": {"initial_speed": 22.2222, "initial_gap": 120.0},
            "v2v": {"enabled": False},
            "careful_driver": {"sight_distance": sight, "risk_decel": 2.0, "normal": {"desired_speed": 22.2222}},
        }
    )


def test_the_careful_driver_is_a_controller():
    assert "careful-driver" in _scenario.CONTROLLERS
    assert "careful-driver" in flc.envelope.CONTROLLERS


def test_it_stops_short_of_a_car_seen_80_m_ahead():
    # 64.63 m from 80 km/h by hand (docs/careful-driver.md): a car seen 80 m ahead can be avoided.
    assert math.isclose(by_hand(80 / 3.6), 64.627, abs_tol=1e-3)
    r = flc.run(standing_car(80.0))
    assert not r.metrics["collision"]
    seen = np.nonzero(r.detected_distance <= 80.0)[0][0]
    stopped = seen + np.nonzero(r.follower_speed[seen:] <= 0.0)[0][0]
    v = r.follower_speed[seen]
    travelled = r.follower_x[stopped] - r.follower_x[seen]
    # The hand computation at the speed it had, plus at most what the actuators add (0.3 s of
    # dead time and lag, 3.8 m of the speed interface's slow final stop; crates/flc-sim/tests/careful_driver.rs).
    assert by_hand(v) < travelled < by_hand(v) + 0.3 * v + A / 2.0
    assert r.gap[stopped] > 5.0


def test_it_hits_a_car_seen_60_m_ahead():
    # 60 m < 64.63 m: too late for the careful driver.
    r = flc.run(standing_car(60.0))
    assert r.metrics["collision"]
