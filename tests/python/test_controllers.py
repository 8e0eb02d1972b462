"""The Python facade of the core controllers: same numbers as the paper's equations, clear errors."""
import math

import numpy as np
import pytest

import flc


def test_flc_matches_eq5_by_hand():
    c = flc.FallbackController()
    # S_F = 10 m/s, LF_dist = 25 m: dist_s = 25 - (1.0 * 10 + 6) - 10 * 0.4 = 5.
    out = c.step(25.0, 10.0)
    assert out.status == "ok"
    assert out.accel == pytest.approx(5 * (1 - math.cos(math.pi * 5 / 11)), abs=1e-12)
    assert c.terms()["dist_s"] == pytest.approx(5.0)
    # Delta_d = -0.5 <= -0.3: braking branch, dist_s overridden to -3, multiplier 2.
    out = c.step(24.5, 10.0)
    assert out.accel == pytest.approx(2 * -3 * (1.5 - math.cos(math.pi * 3 / 11)), abs=1e-12)


def test_keyword_parameters_use_paper_names():
    c = flc.FallbackController(time_gap=2.0, base_gap=4.0)
    c.step(30.0, 10.0)
    assert c.terms()["d_d"] == pytest.approx(2.0 * 10 + 4.0)


@pytest.mark.parametrize(
    "kwargs, name",
    [({"time_gap": float("nan")}, "time_gap"), ({"bound_t": "11"}, "bound_t"), ({"tme_gap": 1.0}, "tme_gap"), ({"bound_t": -1.0}, "bound_t")],
)
def test_bad_parameters_name_the_field(kwargs, name):
    with pytest.raises(flc.ParameterError, match=name):
        flc.FallbackController(**kwargs)


def test_errors_share_one_base():
    assert issubclass(flc.ParameterError, flc.FlcError)
    assert issubclass(flc.ScenarioError, flc.FlcError)


def test_bad_input_gives_safe_command():
    c = flc.FallbackController()
    out = c.step(float("nan"), 10.0)
    assert out.status == "invalid_distance" and out.speed == 7.0
    assert c.step(None, 10.0).status == "no_lead"


def test_pid_far_gains_by_hand():
    p = flc.PidController()
    out = p.step(12.0, 10.0, 30.0, 0.05)
    assert out.accel == pytest.approx(0.2 * 15 + 0.01 * 15 * 0.05 + 0.6 * 2)


def test_pure_pursuit_eq1():
    pp = flc.PurePursuit()
    s = pp.step((20.0, 2.0), 10.0)
    assert s.steer == pytest.approx(math.atan(2.9 * 2 * 2.0 / (9.0**2 + 20.0**2)))


def test_supervisor_falls_back_and_returns():
    s = flc.Supervisor(max_age_ticks=2, return_after=3)
    outs = [s.step((10.0, k), 20.0, 10.0, 0.05) for k in range(3)]
    assert outs[-1]["active"] == "pid"
    outs = [s.step(None, 20.0, 10.0, 0.05) for _ in range(3)]
    assert [o["active"] for o in outs] == ["pid", "pid", "flc"]
    assert outs[-1]["reason"] == "v2v_stale"


def test_supervisor_reports_association_and_falls_back_on_a_cut_in():
    # Issue 25: a distance jump the V2V sender's speed does not explain is a new object.
    s = flc.Supervisor(return_after=3)
    outs = [s.step((10.0, k), 25.0, 10.0, 0.05) for k in range(3)]
    assert outs[-1]["active"] == "pid" and outs[-1]["association"] == "associated"
    out = s.step((10.0, 3), 12.0, 10.0, 0.05)
    assert (out["active"], out["reason"], out["association"], out["switched"]) == ("flc", "not_associated", "not_associated", True)
    # The car leaves: the sender is where it was, and the PID drives again after 3 messages.
    outs = [s.step((10.0, k), 25.0, 10.0, 0.05) for k in range(4, 7)]
    assert [o["association"] for o in outs] == ["associated"] * 3
    assert [o["active"] for o in outs] == ["flc", "flc", "pid"]


def test_detector_finds_a_rear_face():
    d = flc.LeadDetector()
    ys = np.linspace(-0.95, 0.95, 40)
    pts = np.column_stack([np.full_like(ys, 20.0), ys])
    out = d.detect(pts)
    assert out["status"] == "ok"
    assert out["detection"]["distance"] == pytest.approx(20.0, abs=0.2)
    assert d.detect(np.zeros((0, 2)))["detection"] is None


def test_robust_flc_by_hand():
    # docs/robust-flc.md (R1)-(R6), defaults d_0 = 3, h = 1.5, k_a = 1, k_b = 4, a_max = 2.
    c = flc.RobustFallbackController()
    # v = 20, d = 33 = D_r(20): no action.
    out = c.step(33.0, 20.0)
    assert (out.speed, out.accel, out.status) == (pytest.approx(20.0), pytest.approx(0.0), "ok")
    # v = 20, d = 30: V_g = 18, a = 4 * (18 - 20) = -8, v_cmd = 12.
    out = c.step(30.0, 20.0)
    assert out.accel == pytest.approx(-8.0) and out.speed == pytest.approx(12.0)
    assert c.terms()["gap_error"] == pytest.approx(-3.0)
    # A jump up by more than 3 m reveals another object: the stop envelope (R3) caps the target.
    c.step(80.0, 30.0)
    t = c.terms()
    ve = 7.0 * (math.sqrt(0.25 + 2 * 78 / 7) - 0.5)
    assert t["revealed"] and t["latched"] and t["target_speed"] == pytest.approx(ve)
    # No lead: brake by fault_brake_step.
    assert c.step(None, 10.0) == flc.Command(7.0, -3.0, "no_lead")


def test_robust_flc_parameters_and_scenario():
    with pytest.raises(flc.ParameterError, match="brake_gain"):
        flc.RobustFallbackController(brake_gain=0.0)
    c = flc.RobustFallbackController(time_gap=2.0)
    c.step(30.0, 10.0)
    assert c.terms()["desired_gap"] == pytest.approx(3.0 + 2.0 * 10)
    s = flc.Scenario.paper(speed_kmh=50, controller="flc-robust-v1", flc_robust_v1_time_gap=1.8)
    assert s.controller == "flc-robust-v1"
    r = flc.run(s)
    assert r.metrics["collision"] is False
    with pytest.raises(flc.ScenarioError, match="flc_robust_v1.time_gap"):
        flc.Scenario.paper(controller="flc-robust-v1", flc_robust_v1_time_gap=-1.0)


def test_robust_flc_v2_parameters_and_scenario():
    # v2 is `controller="flc-robust"`; v1's law sits in `law` (`[flc_robust.law]`).
    with pytest.raises(flc.ParameterError, match="firm_gain"):
        flc.RobustFallbackController2(firm_gain=0.0)
    with pytest.raises(flc.ParameterError, match="brake_gain"):
        flc.RobustFallbackController2(law={"brake_gain": 0.0})
    c = flc.RobustFallbackController2(law={"time_gap": 2.0})
    for _ in range(3):
        c.step(30.0, 10.0)
    t = c.terms()
    assert t["distance"] == 30.0 and t["held"] is False
    # The first detection is a possible standing object; its distance stays: not closing, so the
    # target is the gap speed v + (d - 3 - 2 v) / h = 10 + (30 - 23) / 2 (R2) once released.
    assert t["gap_speed"] == pytest.approx(10.0 + (30.0 - 3.0 - 2.0 * 10.0) / 2.0)
    # A missed frame holds the object where it was and never accelerates.
    out = c.step(None, 10.0)
    assert c.terms()["held"] is True and out.accel <= 0.0
    s = flc.Scenario.paper(speed_kmh=50, controller="flc-robust", flc_robust_law_time_gap=1.8)
    assert s.controller == "flc-robust" and s.to_dict()["flc_robust"]["law"]["time_gap"] == 1.8
    assert flc.run(s).metrics["collision"] is False
    with pytest.raises(flc.ScenarioError, match="flc_robust.law.time_gap"):
        flc.Scenario.paper(controller="flc-robust", flc_robust_law_time_gap=-1.0)
    # The comfort layer (`[flc_robust.comfort]`): its errors name the nested key.
    with pytest.raises(flc.ParameterError, match="comfort.decel"):
        flc.RobustFallbackController2(comfort={"decel": 0.0})
    with pytest.raises(flc.ScenarioError, match="flc_robust.comfort.memory"):
        flc.Scenario.paper(controller="flc-robust", flc_robust_comfort_memory=-1.0)
    # Closing at 4 m/s per its own motion: accelerating at 1 m/s² (as commanded once the estimate
    # exists), the speed rises 0.05 m/s per frame while the gap falls 0.2 m: Δτ = Δv / â.
    c = flc.RobustFallbackController2()
    d, v = 60.0, 20.0
    c.step(d, v)
    c.step(d, v)
    for _ in range(60):
        out = c.step(d, v)
        d, v = d - 0.2, v + 0.05 * (1.0 if out.accel > 0.3 else 0.0)
    t = c.terms()
    assert t["comfort"] is True and t["closing_brake"] < 0.0 and t["a"] <= t["a_law"]


def test_robust_flc_odometry_variant_scenario():
    # v2 with the wheels as its comfort layer's clock: its parameters are v2's `[flc_robust]`
    # (the comfort layer in `[flc_robust.comfort]`), its own `[flc_robust_odo]`.
    from flc import _params, _scenario

    assert "flc-robust-odo" in _scenario.CONTROLLERS
    assert _params.defaults("flc_robust_odo") == {"min_speed": 0.5}
    assert _params.defaults("flc_robust")["comfort"]["accel"] == 0.85
    s = flc.Scenario.paper(speed_kmh=50, controller="flc-robust-odo", flc_robust_comfort_accel=1.0, flc_robust_law_time_gap=1.8)
    d = s.to_dict()
    assert d["flc_robust"]["comfort"]["accel"] == 1.0 and d["flc_robust"]["law"]["time_gap"] == 1.8
    r = flc.run(s)
    assert r.metrics["collision"] is False
    # Timed by the wheels or by its own motion, the same comfort layer: in the paper's experiment
    # the two smallest gaps agree within 0.5 m.
    v2 = flc.run(flc.Scenario.paper(speed_kmh=50, controller="flc-robust", flc_robust_comfort_accel=1.0, flc_robust_law_time_gap=1.8))
    assert abs(r.metrics["min_gap"] - v2.metrics["min_gap"]) < 0.5
    with pytest.raises(flc.ScenarioError, match="flc_robust_odo.min_speed"):
        flc.Scenario.paper(controller="flc-robust-odo", flc_robust_odo_min_speed=0.0)
