"""Gipps (1981) from Python: selected by name like every controller, parameterised by [gipps]."""
import pytest

import flc


def test_gipps_runs_the_paper_experiment_and_stops():
    r = flc.run(flc.Scenario.paper(speed_kmh=50, controller="gipps"))
    assert not r.metrics["collision"]
    assert r.metrics["final_clearance"] is not None and r.metrics["final_clearance"] > 0.5


def test_gipps_parameters_reach_the_law_and_bad_ones_name_the_key():
    s = flc.Scenario.paper(speed_kmh=50, controller="gipps", gipps_reaction_time=1.5)
    assert s["gipps.reaction_time"] == 1.5
    with pytest.raises(flc.ScenarioError, match=r"gipps\.decel"):
        flc.Scenario.paper(speed_kmh=50, controller="gipps", gipps_decel=-1.0)


def test_gipps_is_in_the_envelope_controllers():
    assert "gipps" in flc.envelope.CONTROLLERS
