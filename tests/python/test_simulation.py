"""flc.Simulation: the simulator's loop stepped from Python (issue 26)."""
import math

import numpy as np
import pytest

import flc


def same_result(a: flc.RunResult, b: flc.RunResult) -> None:
    assert a.series.keys() == b.series.keys()
    for k in a.series:
        x, y = np.asarray(a.series[k]), np.asarray(b.series[k])
        assert x.shape == y.shape, k
        # Bit for bit (NaN where the other is NaN).
        assert np.array_equal(x.view(np.uint64), y.view(np.uint64)), k
    assert a.metrics == b.metrics or all(
        (a.metrics[k] == b.metrics[k]) or (isinstance(a.metrics[k], float) and math.isnan(a.metrics[k]) and math.isnan(b.metrics[k])) for k in a.metrics
    )
    assert a.collision == b.collision


@pytest.mark.parametrize("speed,preset", [(50, "realistic"), (70, "paper")])
def test_the_flc_binding_driving_the_ego_reproduces_flc_run_bit_for_bit(speed: float, preset: str) -> None:
    sc = flc.Scenario.paper(speed, "flc", preset)
    reference = flc.run(sc)
    law = flc.FallbackController(**sc["flc"])
    sim = flc.Simulation(sc)
    obs = sim.reset()
    scans = 0
    while not obs.done:
        assert obs.fresh
        cmd = law.step(obs.distance, obs.own_speed)
        obs = sim.step(cmd.speed)
        scans += 1
    assert scans > 20 * 30
    same_result(sim.result(), reference)


def test_none_is_the_scenario_controller_and_result_mid_run_is_the_run_so_far() -> None:
    sc = flc.Scenario.paper(50, "pipeline")
    reference = flc.run(sc)
    sim = flc.Simulation(sc)
    obs = sim.reset()
    for _ in range(100):
        obs = sim.step(None)
    partial = sim.result()
    n = len(partial.t)
    assert 0 < n < len(reference.t)
    assert np.array_equal(partial.gap, reference.gap[:n])
    while not obs.done:
        obs = sim.step()
    same_result(sim.result(), reference)
    with pytest.raises(flc.SimulationError, match="over"):
        sim.step()


def test_the_observation_separates_measurement_and_truth() -> None:
    sc = flc.Scenario.paper(50, "pipeline")
    sim = flc.Simulation(sc, lidar_points=True, beams=32)
    obs = sim.reset(seed=3)
    assert obs.t == 0.0 and obs.fresh and not obs.done
    assert abs(obs.truth.gap - sc["follower.initial_gap"]) < 1e-9
    # (The scan at t = 0 precedes the world's first step: it has no returns.)
    obs = sim.step(None)
    assert obs.t == pytest.approx(0.05)
    # Standstill, 7 m apart: the detector sees the lead about 7 m ahead, the truth is exactly 7 m.
    assert obs.distance is not None and abs(obs.distance - 7.0) < 0.5
    assert obs.points is not None and obs.points.shape[1] == 2 and len(obs.points) > 100
    assert obs.ranges is not None and obs.ranges.shape == (32,)
    # The beams straight ahead (sectors 15 and 16 of 32 over the field of view) see the lead's
    # rear face where the detector puts it (the guard rails are nearer, to the sides).
    assert min(obs.ranges[15], obs.ranges[16]) == pytest.approx(obs.detection["distance"], abs=0.3)
    assert obs.ranges.min() < obs.detection["distance"]
    # V2V (the pipeline listens to the lead): a message arrives within the first 0.2 s.
    while obs.t < 0.5:
        obs = sim.step(flc.SpeedCommand(0.0))
    assert obs.v2v_speed is not None and obs.v2v_seq is not None
    assert 0.0 <= obs.v2v_age < 0.2
    # The lead moves off; held at 0 m/s the ego falls behind: the truth shows the growing gap.
    assert obs.truth.speed == pytest.approx(0.0, abs=1e-6)
    assert obs.truth.gap > 7.0 and obs.truth.front_speed > 0.0


def test_an_acceleration_command_accelerates_the_ego() -> None:
    sc = flc.Scenario.paper(50, "flc", follower_initial_gap=200.0)
    sim = flc.Simulation(sc, command="accel")
    obs = sim.reset()
    while obs.t < 4.0:
        obs = sim.step(1.5)
    # The demand less the driving resistance (no speed controller compensates it).
    assert 1.3 < obs.truth.accel < 1.5
    assert np.isnan(sim.result().speed_command[-1])


def test_a_platoon_is_driven_follower_by_follower() -> None:
    sc = flc.Scenario.brakedemo(duration=25.0)
    reference = flc.run(sc)
    sim = flc.Simulation(sc, drive="all")
    assert sim.driven == list(range(1, 8))
    obs = sim.reset()
    assert set(obs) == set(range(1, 8))
    # Follower 3 holds its speed; the others keep their law (None).
    sent = []
    while not obs[1].done:
        if obs[3].fresh:
            sent.append(obs[3].own_speed)
        obs = sim.step({3: flc.SpeedCommand(obs[3].own_speed)} if obs[3].fresh else {})
    r = sim.result()
    assert r.platoon is not None and reference.platoon is not None
    # Followers 1-2 are unaffected bit for bit, follower 3 is not (it stops following) ...
    for k in (0, 1):
        assert np.array_equal(r.platoon.series["gap"][k], reference.platoon.series["gap"][k])
    assert not np.array_equal(r.platoon.series["gap"][2], reference.platoon.series["gap"][2])
    # ... because its speed commands are exactly the ones sent, one per fresh frame, in order.
    cmd = np.asarray(r.platoon.series["speed_command"][2])
    changes = [cmd[0]] + [cmd[i] for i in range(1, len(cmd)) if cmd[i] != cmd[i - 1]]
    assert len(sent) > 100 and np.array_equal(np.array(changes), np.array(sent))


def test_bad_use_is_an_error_naming_it() -> None:
    sc = flc.Scenario.paper(50, "flc")
    with pytest.raises(flc.ParameterError, match="follower 2"):
        flc.Simulation(sc, drive=2)
    with pytest.raises(flc.ParameterError, match="command"):
        flc.Simulation(sc, command="jerk")
    sim = flc.Simulation(sc)
    with pytest.raises(flc.SimulationError, match="reset"):
        sim.step(1.0)
    sim.reset()
    with pytest.raises(flc.ParameterError, match="command.speed"):
        sim.step(float("nan"))
    with pytest.raises(flc.ParameterError, match="command"):
        sim.step("fast")  # type: ignore[arg-type]
    with pytest.raises(flc.ParameterError, match="seed"):
        sim.reset(seed=-1)


def test_hold_until_is_the_same_command_at_every_scan_before_that_time() -> None:
    sc = flc.Scenario.paper(50, "flc")
    a, b = flc.Simulation(sc, command="accel"), flc.Simulation(sc, command="accel")
    oa, ob = a.reset(), b.reset()
    for k in range(40):
        cmd = 1.0 if k < 20 else -2.0
        until = oa.t + 0.25
        oa = a.step(cmd, hold_until=until)
        ob = b.step(cmd)
        while not ob.done and ob.t < until - 1e-9:
            ob = b.step(cmd)
        assert oa.t == ob.t and oa.truth == ob.truth
    same_result(a.result(), b.result())
