"""OpenSCENARIO files from Python: ``flc.Scenario.load("FILE.xosc", params=...)`` and ``load_all``
(docs/openscenario.md)."""

import pathlib

import pytest

import flc

DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "openscenario"


def test_load_xosc_with_params_and_run_it():
    s = flc.Scenario.load(DATA / "target_brakes.xosc", params={"Decel": 2.0}, controller="flc-robust")
    assert s.controller == "flc-robust"
    # The lead's brake action carries the parameter: 2 m/s² instead of the file's 6.
    actions = [
        a
        for act in s.to_dict()["story"]["acts"]
        for g in act["groups"]
        for m in g["maneuvers"]
        for e in m["events"]
        for a in e["actions"]
        if a["kind"] == "speed" and a.get("dimension") == "rate"
    ]
    assert [a["value"] for a in actions] == [2.0]
    r = flc.run(s)
    assert not r.metrics["collision"]
    # The lead brakes kinematically at exactly the parameter's 2 m/s².
    assert abs(r.lead_accel.min() + 2.0) < 1e-9


def test_scripted_ego_follows_its_storyboard():
    s = flc.Scenario.load(DATA / "speed_linear_rate.xosc", ego_mode="scripted")
    r = flc.run(s)
    # The ego holds the file's 13.888889 m/s (its storyboard has no action on it), whatever the
    # controller commands.
    assert r.follower_speed.min() == r.follower_speed.max() == 13.888889
    assert r.speed_command.max() != 13.888889


def test_distribution_runs_carry_their_parameters():
    runs = flc.Scenario.load_all(DATA / "distribution_2x2.xosc", ego_mode="scripted")
    assert [(float(r.params["EgoSpeed_kmh"]), float(r.params["TargetSpeed_kmh"])) for r in runs] == [
        (40, 10),
        (40, 20),
        (60, 10),
        (60, 20),
    ]
    with pytest.raises(flc.ScenarioError, match="load_all"):
        flc.Scenario.load(DATA / "distribution_2x2.xosc")


def test_one_permutation_of_a_distribution():
    runs = flc.Scenario.load_all(DATA / "distribution_2x2.xosc", ego_mode="scripted")
    third = flc.Scenario.load(DATA / "distribution_2x2.xosc", ego_mode="scripted", permutation=2)
    assert third.params == runs[2].params
    assert third.to_dict() == runs[2].to_dict()
    for bad in (4, -1):
        with pytest.raises(ValueError, match=r"`permutation`.*4 run\(s\)"):
            flc.Scenario.load(DATA / "distribution_2x2.xosc", permutation=bad)


def test_bad_files_and_options_name_the_problem(tmp_path):
    bad = tmp_path / "bad.xosc"
    bad.write_text('<?xml version="1.0"?>\n<OpenSCENARIO>\n  <FileHeader>\n</OpenSCENARIO>\n')
    with pytest.raises(flc.ScenarioError, match=r"bad\.xosc:\d+"):
        flc.Scenario.load(bad)
    with pytest.raises(flc.ScenarioError, match="ego_mode"):
        flc.Scenario.load(DATA / "target_brakes.xosc", ego_mode="autopilot")
    with pytest.raises(flc.ScenarioError, match="Nope"):
        flc.Scenario.load(DATA / "target_brakes.xosc", params={"Nope": 1})
    with pytest.raises(flc.ScenarioError, match="params"):
        flc.Scenario.load(pathlib.Path(__file__).resolve().parents[2] / "scenarios" / "cut-in.toml", params={"a": 1})
