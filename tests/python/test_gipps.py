"""Gipps (1981) from Python: selected by name like every controller, parameterised by [gipps]."""
import pytest

import flc


def test_gipps_runs_the_paper_experiment_and_stops():
    r = flc.run(flc.Scenario.paper(speed_kmh=50, controller="gipps"))
    assert not r.metrics["collision"]
    assert r.metrics["final_clearance"] is not None and r.metrics["final_clearance"] > 0.5


#: The law regulates the detector's distance, a few cm short of the bumper gap, so the true gap
#: settles that much long (measured +0.041 m at tau 1 s, +0.035 m at 1.5 s; difference 14.994 m).
GAP_TOL = 0.1


def _steady(reaction_time):
    """Gipps behind a lead that accelerates at 0.5 m/s² to 20 m/s and holds it for 120 s."""
    return flc.Scenario.paper(
        speed_kmh=50, controller="gipps", gipps_reaction_time=reaction_time, gipps_desired_speed=25.0, duration=120.0,
        **{"v2v.enabled": False, "lead.phases": [{"kind": "accelerate", "accel": 0.5, "speed": 20.0}, {"kind": "hold", "until_t": 1000.0}]},
    )


def test_gipps_parameters_reach_the_law_and_bad_ones_name_the_key():
    s = _steady(1.5)
    assert s["gipps.reaction_time"] == 1.5
    # Run the law: its equilibrium gap at 20 m/s is min_gap + 1.5 tau v + v²/2 (1/decel - 1/lead_decel),
    # so 0.5 s more reaction time means 1.5 * 0.5 s * 20 m/s = 15 m more gap (23.61 -> 38.61 m).
    gaps = {}
    for tau in (1.0, 1.5):
        r = flc.run(_steady(tau))
        assert not r.metrics["collision"]
        assert abs(r.follower_speed[-1] - 20.0) < 0.3
        gaps[tau] = float(r.gap[-1])
        assert gaps[tau] == pytest.approx(2.5 + 1.5 * tau * 20.0 + 200.0 * (1 / 4.5 - 1 / 3.75), abs=GAP_TOL), tau
    assert gaps[1.5] - gaps[1.0] == pytest.approx(15.0, abs=GAP_TOL)
    with pytest.raises(flc.ScenarioError, match=r"gipps\.decel"):
        flc.Scenario.paper(speed_kmh=50, controller="gipps", gipps_decel=-1.0)


def test_gipps_is_in_the_envelope_controllers():
    from flc import envelope  # a submodule: `flc.envelope` is bound only once something imports it

    assert "gipps" in envelope.CONTROLLERS
