"""Any contact of a follower is its collision; ``result.collision`` names what was hit."""
from pathlib import Path

import pytest

import flc

ROOT = Path(__file__).resolve().parents[2]


def _scenario(target: dict, lead_gap: float = 500.0, duration: float = 20.0) -> flc.Scenario:
    """A straight road, rails at +-5 m (objects 0, 1), ``target`` as object 2, the follower at
    20 m/s with a speed controller that can hardly brake, the lead far ahead."""
    return flc.Scenario.from_dict(
        {
            "name": "collide",
            "controller": "flc",
            "duration": duration,
            "track": {
                "kind": "custom",
                "centerline": [[0.0, 0.0], [3000.0, 0.0]],
                "lane_width": 3.5,
                "objects": [
                    {"kind": "guard_rail", "offset": 5.0, "from_s": 0.0, "to_s": 1000.0},
                    {"kind": "guard_rail", "offset": -5.0, "from_s": 0.0, "to_s": 1000.0},
                    target,
                ],
            },
            "lead": {"initial_speed": 20.0, "phases": [{"kind": "hold", "duration": 60.0}]},
            "follower": {
                "initial_speed": 20.0,
                "initial_gap": lead_gap,
                "lane_keeping": True,
                "speed_controller": {"max_accel": 0.1, "max_decel": 0.1},
            },
            "v2v": {"enabled": False},
        }
    )


def test_a_post_in_the_lane_is_the_followers_collision():
    r = flc.run(_scenario({"kind": "post", "s": 110.0, "offset": 0.0, "radius": 0.3}))
    c = r.collision
    assert c is not None and r.metrics["collision"] is True
    assert c["object"] == {"kind": "post", "index": 2}
    # Front bumper from 5.9 m to the post's face at 109.7 m at about 20 m/s.
    assert 103.8 / 20.0 < c["time"] < 1.1 * 103.8 / 20.0
    assert c["time"] == r.metrics["collision_time"] and c["impact_speed"] == r.metrics["impact_speed"]
    assert c["impact_speed"] == pytest.approx(c["follower_speed"], rel=1e-3)
    assert c["other_speed"] == 0.0 and c["normal"][0] > 0.9
    assert r.other_contacts == []


def test_the_lead_touching_a_parked_car_is_listed_not_a_collision():
    # The lead's front at 5.9 + 30 + 4.9 m, the parked car's rear face 60 m further: 3 s.
    s = _scenario({"kind": "parked_car", "s": 40.8 + 60.0 + 2.35, "offset": 0.0}, lead_gap=30.0, duration=3.5)
    r = flc.run(s)
    assert r.collision is None and r.metrics["collision"] is False
    assert len(r.other_contacts) == 1
    c = r.other_contacts[0]
    assert c["a"] == {"kind": "vehicle", "name": "lead"} and c["b"] == {"kind": "parked_car", "index": 2}
    assert c["time"] == pytest.approx(3.0, abs=0.05)


#: A follower that cannot brake (demand limited to 0.1 m/s², friction to 0.5 m/s²): it reaches
#: whatever stands in its lane, whatever its controller does (controller outcomes are tested with
#: the controllers).
NO_BRAKES = {"follower.speed_controller.max_decel": 0.1, "follower.vehicle.max_brake": 0.5}


def test_a_follower_without_brakes_hits_the_car_revealed_by_the_cut_out():
    r = flc.run(flc.Scenario.load(ROOT / "scenarios" / "robust-cut-out.toml", **NO_BRAKES))
    assert r.collision is not None and r.collision["object"] == {"kind": "vehicle", "name": "stopped"}
    assert r.collision["impact_speed"] > 15.0 and r.metrics["collision"] is True


def test_platoon_followers_name_what_they_hit():
    s = _scenario({"kind": "post", "s": 2900.0, "offset": 0.0, "radius": 0.3}, lead_gap=30.0)
    s = s.replace(platoon_followers=2, **{"platoon.overrides": [{"followers": [2], "follower": {"initial_speed": 25.0, "initial_gap": 20.0}}]})
    r = flc.run(s)
    assert r.platoon is not None
    c1, c2 = r.platoon.collisions
    assert c1 is not None and c2 is not None
    assert c1["object"]["name"] == "follower 2" and c2["object"]["name"] == "follower 1"
    assert "collision_info" not in r.platoon.metrics[0]
    assert r.collision == c1
