"""The thin bindings: names, keyword overrides and terms come from Rust (issue "flc-py thin")."""
import json
import math
import re

import pytest

import flc
import flc.envelope
from flc import _flc, _scenario


# -- controller and section names ------------------------------------------------------------


def _accepted_controllers():
    """The names the Rust parser accepts, as its error message lists them."""
    with pytest.raises(flc.ScenarioError) as e:
        flc.Scenario.paper(controller="no-such-controller")
    m = re.search(r"must be one of (.*), got", str(e.value))
    assert m, str(e.value)
    return tuple(n.strip() for n in m.group(1).split(","))


def test_controller_names_are_rusts():
    names = tuple(_flc.controller_names())
    assert names and len(set(names)) == len(names)
    assert _scenario.CONTROLLERS == names
    assert _accepted_controllers() == names
    # The envelope maps: every controller but the switching pipeline, in the registry's order.
    assert flc.envelope.CONTROLLERS == tuple(n for n in names if n != "pipeline")
    for name in names:
        s = flc.Scenario.paper(speed_kmh=50, controller=name)
        assert s.controller == name
        assert flc.Scenario.from_dict(s.to_dict()).controller == name


def test_section_names_are_rusts():
    sections = tuple(_flc.section_names())
    assert _scenario.SECTIONS == sections
    for s in ("follower", "lead", "lidar", "v2v", "flc", "pid", "platoon"):
        assert s in sections
    # Every section is a table of the full scenario, and its keyword form overrides it.
    d = flc.Scenario.paper().to_dict()
    for s in sections:
        if s in d and isinstance(d[s], dict) and d[s]:
            assert _flc.resolve_key(f"{s}_x") == f"{s}.x"
    assert _flc.resolve_key("flc_robust_v1_time_gap") == "flc_robust_v1.time_gap"
    assert _flc.resolve_key("flc_robust_law_time_gap") == "flc_robust.law.time_gap"
    assert _flc.resolve_key("follower_vehicle_mass") == "follower.vehicle.mass"
    assert _flc.resolve_key("follower.vehicle.mass") == "follower.vehicle.mass"
    assert _flc.resolve_key("lead_decel") == "lead_decel"
    assert _flc.resolve_key("seed") == "seed"


def test_private_patch_helpers_are_gone():
    assert not hasattr(_scenario, "_set_path") and not hasattr(_scenario, "_override_path")


# -- keyword overrides through Rust's one patch mechanism ------------------------------------


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"lidar_rate_hz": 0}, "lidar.rate_hz"),
        ({"follower.vehicle.max_brake": -1.0}, "follower.vehicle.max_brake"),
        ({"flc_robust_law_time_gap": -1.0}, "flc_robust.law.time_gap"),
        ({"flc_robust_v1_time_gap": -1.0}, "flc_robust_v1.time_gap"),
        ({"flc_robust_time_gap": 1.0}, "flc_robust.time_gap"),
        ({"platoon_followers": 0}, "platoon.followers"),
        ({"lidar_rate_hzz": 3}, "rate_hzz"),
        ({"lead.phases[9].decel": 1.0}, "lead.phases[9].decel"),
        ({"lead_decel": -2.0}, "decel"),
        ({"seed": -1}, "seed"),
        ({"duration": "long"}, "duration"),
    ],
)
def test_keyword_override_errors_name_the_key(kwargs, key):
    base = flc.Scenario.paper(speed_kmh=50)
    for make in (
        lambda: flc.Scenario.paper(speed_kmh=50, **kwargs),
        lambda: flc.Scenario.from_dict(base.to_dict(), **kwargs),
        lambda: base.replace(**kwargs),
        lambda: flc.Scenario.brakedemo(**kwargs),
    ):
        with pytest.raises(flc.ScenarioError, match=re.escape(key)):
            make()


def test_overrides_apply_in_order_and_keep_the_rest():
    base = flc.Scenario.paper(speed_kmh=50)
    s = base.replace(lidar_rate_hz=10, **{"lidar.rate_hz": 15.0})
    assert s["lidar.rate_hz"] == 15.0 and s["lidar_rate_hz"] == 15.0
    d = base.to_dict()
    d["lidar"]["rate_hz"] = 15.0
    assert s.to_dict() == flc.Scenario.from_dict(d).to_dict()
    # A missing table is created (platoon), an unset optional value can be set.
    p = base.replace(platoon_followers=3)
    assert p["platoon.followers"] == 3
    assert base.replace() == base


def test_seed_override_keeps_every_u64():
    big = 2**64 - 1
    s = flc.Scenario.paper(seed=big)
    assert s.seed == big
    assert s.replace(lidar_rate_hz=10).seed == big
    assert s.replace(seed=5).seed == 5


def _two_brakes():
    d = flc.Scenario.paper(speed_kmh=50).to_dict()
    d["lead"]["phases"] = [
        {"kind": "accelerate", "accel": 2.5, "speed_kmh": 50.0},
        {"kind": "brake", "decel": 3.0, "speed_kmh": 20.0},
        {"kind": "hold", "duration": 2.0},
        {"kind": "brake", "decel": 5.0},
    ]
    return flc.Scenario.from_dict(d)


def test_lead_decel_patches_every_brake_phase():
    s = _two_brakes()
    before = s["lead.phases"]
    t = s.replace(lead_decel=7.5)
    after = t["lead.phases"]
    assert [p["kind"] for p in after] == [p["kind"] for p in before]
    for i, (b, a) in enumerate(zip(before, after)):
        if b["kind"] == "brake":
            assert a["decel"] == 7.5 and t[f"lead.phases[{i}].decel"] == 7.5
            assert {k: v for k, v in a.items() if k != "decel"} == {k: v for k, v in b.items() if k != "decel"}
        else:
            assert a == b
    # The envelope's lead deceleration axis goes through the same family key.
    e = flc.envelope._scenario_with(50.0, "flc", "realistic", 3, "lead_decel", 4.0)
    assert e == flc.Scenario.paper(speed_kmh=50.0, seed=3, lead_decel=4.0)
    assert [p["decel"] for p in e["lead.phases"] if p["kind"] == "brake"] == [4.0]


def test_lead_decel_without_a_brake_phase_is_an_error():
    d = flc.Scenario.paper().to_dict()
    d["lead"]["phases"] = [{"kind": "hold", "duration": 5.0}]
    with pytest.raises(flc.ScenarioError, match="lead_decel"):
        flc.Scenario.from_dict(d, lead_decel=3.0)


# -- the shared longitudinal binding: terms are Rust's --------------------------------------


def test_flc_terms_are_the_rust_terms_by_hand():
    # tests/python/test_controllers.py: S_F = 10 m/s, LF_dist = 25 m (paper parameters).
    c = flc.FallbackController()
    out = c.step(25.0, 10.0)
    a = 5 * (1 - math.cos(math.pi * 5 / 11))
    t = c.terms()
    assert list(t) == ["tau_d", "d_d", "scale_f", "f_shift", "delta_d", "dist_s_raw", "dist_s", "braking_branch", "overridden", "a_law", "a"]
    expect = {"tau_d": 10.0, "d_d": 16.0, "scale_f": 0.4, "f_shift": 4.0, "delta_d": 0.0, "dist_s_raw": 5.0, "dist_s": 5.0, "a_law": a, "a": a}
    for k, v in expect.items():
        assert t[k] == pytest.approx(v, abs=1e-12), k
    assert t["braking_branch"] is False and t["overridden"] is False
    assert out.accel == t["a"]
    # Braking branch: Delta_d = -0.5, dist_s overridden to -3, multiplier 2.
    c.step(24.5, 10.0)
    t = c.terms()
    assert t["braking_branch"] is True and t["overridden"] is True
    assert t["dist_s"] == -3.0 and t["a"] == pytest.approx(2 * -3 * (1.5 - math.cos(math.pi * 3 / 11)), abs=1e-12)
    # The facade is the binding's JSON, nothing added.
    assert t == json.loads(c._inner.terms_json())


def test_robust_and_pid_terms_by_hand():
    r = flc.RobustFallbackController()
    r.step(30.0, 20.0)
    t = r.terms()
    assert list(t)[:3] == ["desired_gap", "gap_error", "gap_speed"]
    assert (t["desired_gap"], t["gap_error"], t["gap_speed"], t["a"]) == (pytest.approx(33.0), pytest.approx(-3.0), pytest.approx(18.0), pytest.approx(-8.0))
    assert t["revealed"] is False and t["latched"] is False
    p = flc.PidController()
    out = p.step(12.0, 10.0, 30.0, 0.05)
    t = p.terms()
    assert list(t) == ["desired", "error", "error_rate", "integral", "gains", "u"]
    # desired = 0.5 * 10 + 6 + 10 * 0.4 = 15; far gains (0): u = 0.2 * 15 + 0.01 * 15 * 0.05 + 0.6 * 2.
    assert t["desired"] == pytest.approx(15.0) and t["error"] == pytest.approx(15.0) and t["error_rate"] == pytest.approx(2.0)
    assert t["integral"] == pytest.approx(0.01 * 15 * 0.05) and t["gains"] == 0
    assert t["u"] == pytest.approx(0.2 * 15 + 0.01 * 15 * 0.05 + 0.6 * 2) == out.accel


def test_one_binding_for_every_law():
    laws = [
        (_flc.FallbackController, "flc", lambda c: c.step(25.0, 10.0)),
        (_flc.RobustFallbackController, "flc_robust_v1", lambda c: c.step(30.0, 20.0)),
        (_flc.RobustFallbackController2, "flc_robust", lambda c: c.step(30.0, 20.0)),
        (_flc.PidController, "pid", lambda c: c.step(12.0, 10.0, 30.0, 0.05)),
    ]
    for cls, kind, step in laws:
        c = cls(_flc.default_params(kind))
        zero = json.loads(c.terms_json())
        assert zero and all(v == 0 for v in zero.values())
        assert json.loads(c.params_json()) == json.loads(_flc.default_params(kind))
        step(c)
        stepped = json.loads(c.terms_json())
        assert list(stepped) == list(zero) and stepped != zero
        c.reset()
        assert json.loads(c.terms_json()) == zero
        with pytest.raises(flc.ParameterError, match=cls.__name__):
            cls('{"no_such_parameter": 1}')


@pytest.mark.parametrize("cls", [flc.FallbackController, flc.RobustFallbackController])
def test_terms_stay_finite_numbers_on_bad_input(cls):
    # Terms cross as JSON (no NaN in JSON): the core keeps every term finite, even on bad input.
    bad = [None, float("nan"), float("inf"), -1.0, 0.0, 1e300, 20.0]
    for d1 in bad:
        for v in (float("nan"), float("inf"), -1.0, 0.0, 10.0, 1e300):
            for d2 in bad:
                c = cls()
                c.step(d1, v)
                c.step(d2, 10.0)
                for k, x in c.terms().items():
                    assert isinstance(x, (bool, float)) and math.isfinite(x), (d1, v, d2, k, x)


def test_supervisor_step_keys_and_types():
    s = flc.Supervisor()
    out = s.step(None, 20.0, 10.0, 0.05)
    assert list(out) == ["speed", "accel", "status", "active", "reason", "switched", "v2v_age_ticks", "fresh_count", "association", "flc_speed", "pid_speed"]
    assert out["v2v_age_ticks"] is None and out["switched"] is False and out["fresh_count"] == 0
    assert out["association"] == "unknown"
    assert (out["active"], out["reason"]) == ("flc", "no_v2v")
    # No V2V: the FLC drives, as the FLC alone would.
    alone = flc.FallbackController().step(20.0, 10.0)
    assert (out["speed"], out["accel"], out["status"]) == (alone.speed, alone.accel, alone.status)
    out = s.step((10.0, 1), 20.0, 10.0, 0.05)
    assert out["v2v_age_ticks"] == 0 and out["fresh_count"] == 1 and isinstance(out["fresh_count"], int)
