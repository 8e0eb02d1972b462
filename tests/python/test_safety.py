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
# Windows of 1 s = 3 samples; time gap 0.5 s; safe distance 1 m + 0.2 s.
PARAMS = dict(gentle_window=1.0, recover_within=1.0, tau=0.5, d_safe=1.0, t_safe=0.2)
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
    # gap - 0.2 v - 1 = 7 5 1.2 0.4 0.3 0.7 1.4 3.4 4.4 -> 0.3
    "safe_distance": 0.3,
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


# --- falsification -----------------------------------------------------------------------------

import json  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

from flc import _falsify  # noqa: E402

SPECS = Path(__file__).resolve().parents[2] / "scenarios" / "falsify"


def test_falsifier_finds_the_paper_pid_collision_at_90_kmh_on_a_fixed_seed():
    # The box's centre is safe (the lead brakes at 4.5 m/s²): the search has to move to find it.
    plan = _falsify._Plan(_falsify.load_spec(SPECS / "paper-pid-90.toml"))
    centre = flc.run(plan.scenario(plan.point(np.full(len(plan.dims), 0.5))))
    assert stl.robustness(centre, "no_contact") > 0 and not centre.metrics["collision"]
    res = flc.falsify(SPECS / "paper-pid-90.toml", budget=48, seed=1)
    assert len(res.evaluations) == 48
    assert res.first_violation is not None and res.min_robustness < 0
    assert res.worst.collision and res.worst.point["lead.phases[2].decel"] > 4.5


def test_falsifier_is_deterministic_for_a_seed_on_any_thread_count():
    a = flc.falsify(SPECS / "robust-envelope.toml", budget=16, seed=3, threads=1)
    b = flc.falsify(SPECS / "robust-envelope.toml", budget=16, seed=3, threads=2)
    assert [e.robustness for e in a.evaluations] == [e.robustness for e in b.evaluations]
    assert [e.point for e in a.evaluations] == [e.point for e in b.evaluations]
    c = flc.falsify(SPECS / "robust-envelope.toml", budget=16, seed=4)
    assert [e.point for e in c.evaluations] != [e.point for e in a.evaluations]


def test_worst_case_file_replays_bit_for_bit(tmp_path):
    res = flc.falsify(SPECS / "robust-envelope.toml", budget=16, seed=1)
    w = res.worst
    # The lead profile, the faults and the start are in the scenario that ran.
    d = w.scenario.to_dict()
    assert len(d["lead"]["phases"]) >= 4 and d["lidar"].get("faults")
    path = _falsify.write_scenario(tmp_path / "worst.toml", w.scenario, "header")
    back = flc.Scenario.load(path)
    assert back == w.scenario
    again, replay = flc.run(w.scenario), flc.run(back)
    for k, v in again.series.items():
        assert np.array_equal(v, replay.series[k], equal_nan=True), k
    assert stl.robustness(replay, "no_contact") == w.robustness
    assert replay.metrics == again.metrics


def test_falsify_cli_writes_the_worst_case_and_refuses_a_bad_spec(tmp_path):
    env = dict(os.environ)
    r = subprocess.run(
        [sys.executable, "-m", "flc", "falsify", str(SPECS / "paper-flc-90.toml"), "--budget", "16", "--out", str(tmp_path), "-q"],
        capture_output=True, text=True, env=env, check=False,
    )
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["evaluations"] == 16 and s["min_robustness"] == json.loads((tmp_path / "falsify.json").read_text())["min_robustness"]
    back = flc.run(flc.Scenario.load(tmp_path / "worst.toml"))
    assert stl.robustness(back, "no_contact") == s["min_robustness"]
    bad = tmp_path / "bad.toml"
    bad.write_text('[base]\npaper = { speed_kmh = 90 }\n[search]\nbudjet = 3\n[[search.keys]]\nkey = "lead_decel"\nmin = 1.0\nmax = 2.0\n')
    r = subprocess.run([sys.executable, "-m", "flc", "falsify", str(bad)], capture_output=True, text=True, check=False)
    assert r.returncode == 2 and "search: unknown key(s) budjet" in r.stderr and r.stderr.count("\n") == 1


def test_falsify_spec_errors_name_the_key():
    base = {"base": {"paper": {"speed_kmh": 90}}}
    with pytest.raises(_falsify.SpecError, match=r"search.keys\[0\]: `min` and `max` must be finite numbers with min <= max, got 5.0, 1.0"):
        flc.falsify({**base, "search": {"keys": [{"key": "lead_decel", "min": 5.0, "max": 1.0}]}})
    with pytest.raises(_falsify.SpecError, match="lower corner is not a valid scenario.*lidar.rate_hz"):
        flc.falsify({**base, "search": {"keys": [{"key": "lidar.rate_hz", "min": 0.0, "max": 10.0}]}})
    with pytest.raises(_falsify.SpecError, match="search.requirement: unknown 'safe'"):
        flc.falsify({**base, "search": {"requirement": "safe", "keys": [{"key": "lead_decel", "min": 1.0, "max": 2.0}]}})


# --- the ARCH-COMP ACC benchmark on samples ---------------------------------------------------

from flc import arch_acc  # noqa: E402


def test_arch_acc_scenarios_are_the_benchmarks_initial_set():
    pts = arch_acc.grid()
    assert len(pts) == 27 and min(p[0] for p in pts) == 79.0 and max(p[0] for p in pts) == 100.0
    sc = arch_acc.scenario("flc", 79.0, 32.2, 30.0).to_dict()
    assert sc["duration"] == 5.0 and sc["lidar"]["rate_hz"] == 10.0
    assert sc["lead"]["initial_speed"] == 32.2 and sc["follower"]["initial_speed"] == 30.0 and sc["follower"]["initial_gap"] == 79.0
    [phase] = sc["lead"]["phases"]
    assert phase["kind"] == "brake" and phase["decel"] == 2.0 and phase["speed"] == 0.0
    r = flc.run(arch_acc.scenario("flc", 79.0, 32.2, 30.0))
    assert r.t[-1] == pytest.approx(5.0, abs=0.011)
    assert r.lead_speed[-1] == pytest.approx(32.2 - 2.0 * 5.0, abs=0.6)  # through the lead's lag


def test_arch_acc_property_holds_for_the_fallback_laws_on_every_sample():
    for row in arch_acc.evaluate(("flc", "flc-robust")):
        assert row["samples"] == 27 and row["violations"] == 0 and row["collisions"] == 0, row
        assert row["min_robustness"] > 0
