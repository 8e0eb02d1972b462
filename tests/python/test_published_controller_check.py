"""tools/published_controller_check.py, CI-sized: its reading of a run (contacts, passed in-path
objects, far stops, closest approach) on synthetic trajectories, its esmini copy of a file with
the ALKS controller on the ego, and the whole tool in flc-only mode on the project's own fixtures
(CI has neither the published files nor esmini)."""

import json
import math
import pathlib
import sys
import xml.etree.ElementTree as ET

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
import published_controller_check as pcc  # noqa: E402

DATA = ROOT / "tests" / "data" / "openscenario"
SCENARIO = ROOT / "target" / "release" / "scenario"
CAR = (1.4, 4.5, 1.8)
BIKE = (0.4, 2.2, 0.8)
STEP = 0.01


def straight(ego_speed, t_end, others=(), stop_at=None):
    """The ego on the x axis from x = 0 at `ego_speed` (stopping with its rear axle at `stop_at`),
    and `others`: (name, x, y, heading, speed along x) standing or driving, every 10 ms."""
    rows = []
    for k in range(round(t_end / STEP) + 1):
        t = k * STEP
        x = ego_speed * t if stop_at is None else min(ego_speed * t, stop_at)
        v = ego_speed if stop_at is None or ego_speed * t < stop_at else 0.0
        rows.append((t, "Ego", x, 0.0, 0.0, v))
        for name, ox, oy, oh, ov in others:
            y = oy(t) if callable(oy) else oy
            rows.append((t, name, ox + ov * t, y, oh, ov))
    return rows


def test_a_standing_motorbike_on_the_marking_is_passed_a_wider_one_is_not():
    # The ego (1.8 m wide) at 15 m/s past a motorbike standing 1.6 m left of its path: its body
    # reaches 1.2 m from the path's centre, into the ego's lane (1.75 m): passed, 1.6 - 0.4 - 0.9 =
    # 0.3 m between the bodies.
    traj = straight(15.0, 8.0, [("Bike", 60.0, 1.6, 0.0, 0.0)])
    r = pcc.analyse(traj, {"Ego": CAR, "Bike": BIKE}, "Ego", [])
    assert [p["object"] for p in r["passed"]] == ["Bike"]
    assert abs(r["passed"][0]["clearance_m"] - 0.3) < 1e-6 and r["passed"][0]["ego_speed"] == 15.0
    # The ego's front reaches the motorbike's rear (60 + 0.4 - 1.1 = 59.3 m) at (59.3 - 1.4 - 2.25) / 15 s.
    assert abs(r["passed"][0]["time"] - (59.3 - 3.65) / 15.0) < 0.011
    assert r["closest_m"] < 0.2
    # 2.2 m left (its body from 1.8 m: out of the lane): not in the path, not passed, no closest approach.
    r = pcc.analyse(straight(15.0, 8.0, [("Bike", 60.0, 2.2, 0.0, 0.0)]), {"Ego": CAR, "Bike": BIKE}, "Ego", [])
    assert r["passed"] == [] and r["closest_m"] is None
    # A contact with it is a contact, not a pass.
    r = pcc.analyse(traj, {"Ego": CAR, "Bike": BIKE}, "Ego", [[3.7, "Bike", "Ego"]])
    assert r["passed"] == [] and r["contacts"][0]["pair"] == ["Bike", "Ego"] and r["contacts"][0]["speeds"]["Ego"] == 15.0


def test_a_lead_that_cuts_out_before_the_ego_arrives_is_not_passed():
    # A car 40 m ahead at 5 m/s moves 3.5 m left within 2 s from t = 1 s; the ego at 15 m/s
    # overtakes it at about t = 4 s in the next lane.
    def lateral(t):
        return 3.5 * min(1.0, max(0.0, (t - 1.0) / 2.0))

    traj = straight(15.0, 8.0, [("Lead", 40.0, lateral, 0.0, 5.0)])
    r = pcc.analyse(traj, {"Ego": CAR, "Lead": CAR}, "Ego", [])
    assert r["passed"] == []
    # The closest approach while it was in the path: the gap 35.5 - 10 t when its body leaves the
    # ego's lane band, 2.65 m to the side (half a 3.5 m lane + its half width) at t = 1 + 2 * 2.65 / 3.5 s.
    t_out = 1.0 + 2.0 * 2.65 / 3.5
    assert abs(r["closest_m"] - (35.5 - 10.0 * t_out)) < 0.15, r["closest_m"]
    # Staying in the lane instead, it is hit or passed: here passed (no contact recorded).
    r = pcc.analyse(straight(15.0, 8.0, [("Lead", 40.0, 0.0, 0.0, 5.0)]), {"Ego": CAR, "Lead": CAR}, "Ego", [])
    assert [p["object"] for p in r["passed"]] == ["Lead"]


def test_far_stops_are_stops_with_nothing_in_path_within_50_m():
    # The ego stops at x = 100 m, the standing car's rear 40 m + ... ahead of its front.
    dims = {"Ego": CAR, "Car": CAR}
    for car_x, far in [(200.0, True), (120.0, False)]:
        traj = straight(10.0, 15.0, [("Car", car_x, 0.0, 0.0, 0.0)], stop_at=100.0)
        r = pcc.analyse(traj, dims, "Ego", [])
        gap = car_x + 1.4 - 2.25 - (100.0 + 1.4 + 2.25)
        if far:
            assert len(r["far_stops"]) == 1 and abs(r["far_stops"][0]["gap_m"] - gap) < 0.01
            assert abs(r["far_stops"][0]["time"] - 10.0) < 0.11 and r["far_stops"][0]["duration"] > 4.5
        else:
            assert r["far_stops"] == [] and abs(r["closest_m"] - gap) < 0.01
    # Nothing on the road at all: a stop is a far stop (gap None).
    r = pcc.analyse(straight(10.0, 15.0, stop_at=100.0), dims, "Ego", [])
    assert len(r["far_stops"]) == 1 and r["far_stops"][0]["gap_m"] is None
    # flc's own series: the same rule on the in-path gap (NaN: nothing in path).
    series = [(k * 0.01, math.nan if k > 50 else 10.0, 0.0 if k > 50 else 5.0) for k in range(500)]
    assert pcc.series_far_stops(series) == [{"time": 0.51, "duration": 4.48, "gap_m": None}]
    assert pcc.series_far_stops([(k * 0.01, 30.0, 0.0) for k in range(500)]) == []
    # Standing less than 3 s (setting off again once the way is clear) is no far stop.
    assert pcc.series_far_stops(series[:340]) == []


def test_on_a_curve_the_next_lane_is_not_in_path():
    # The ego on an arc of R = 250 m (left) stops after 20 m; a car stands in the next lane (3.5 m
    # further in) 21.4 m beyond: beyond the ego's trajectory, which the path continues with its
    # curvature; 3.5 m across the road, not in the path (no closest approach, the stop a far
    # one); the same car in the ego's lane is in the path.
    R, v = 250.0, 15.0

    def on_arc(s, off):
        a = s / R
        return (R - off) * math.sin(a), R - (R - off) * math.cos(a), a

    for off, in_path in [(3.5, False), (0.0, True)]:
        rows = []
        cx, cy, ch = on_arc(40.0 + 1.4, off)
        for k in range(round(5.0 / STEP) + 1):
            t = k * STEP
            s = min(v * t, 20.0)
            x, y, h = on_arc(s, 0.0)
            rows.append((t, "Ego", x - 1.4 * math.cos(h), y - 1.4 * math.sin(h), h, v if v * t < 20.0 else 0.0))
            rows.append((t, "Car", cx - 1.4 * math.cos(ch), cy - 1.4 * math.sin(ch), ch, 0.0))
        r = pcc.analyse(rows, {"Ego": CAR, "Car": CAR}, "Ego", [])
        if in_path:
            # The ego's box centre stops at s = 20 m, the car's is at 41.4 m.
            assert r["closest_m"] is not None and abs(r["closest_m"] - (41.4 - 20.0 - 4.5)) < 0.05, r["closest_m"]
            assert r["far_stops"] == []
        else:
            assert r["closest_m"] is None and len(r["far_stops"]) == 1


def test_the_esmini_copy_puts_the_alks_controller_on_the_ego(tmp_path):
    out = tmp_path / "standing_car.xosc"
    done = pcc.with_alks_controller(DATA / "standing_car.xosc", out, "ReferenceDriver")
    assert done == "added, activated in the Init"
    root = ET.parse(out).getroot()
    ego = next(o for o in root.iter("ScenarioObject") if o.get("name") == "Ego")
    ctrl = ego.find("ObjectController/Controller")
    assert ctrl.get("name") == "ALKS_R157SM_Controller"
    assert {p.get("name"): p.get("value") for p in ctrl.iter("Property")}["model"] == "ReferenceDriver"
    init = next(p for p in root.find("Storyboard/Init/Actions").findall("Private") if p.get("entityRef") == "Ego")
    act = init.find("PrivateAction/ControllerAction/ActivateControllerAction")
    assert act.get("longitudinal") == "true" and act.get("lateral") == "false"
    # Catalog folders made absolute (the copy lives elsewhere).
    assert all(pathlib.Path(d.get("path")).is_absolute() for d in root.iter("Directory"))
    # The other entities keep no ALKS controller.
    others = [o for o in root.iter("ScenarioObject") if o.get("name") != "Ego"]
    assert all(o.find("ObjectController") is None for o in others)
    # A file whose ego has a controller of flc's: replaced.
    done = pcc.with_alks_controller(DATA / "from_catalogs.xosc", tmp_path / "c.xosc", "Regulation")
    assert done.startswith("replaced its controller")


@pytest.mark.skipif(not SCENARIO.is_file(), reason="needs `cargo build --release --bin scenario` (tests/run_all.sh builds it first)")
def test_the_tool_on_the_projects_fixtures(tmp_path):
    data = tmp_path / "check.json"
    files = [DATA / "standing_car.xosc", DATA / "lane_leave_reveal.xosc", DATA / "distribution_2x2.xosc"]
    code = pcc.main([*map(str, files), "--no-esmini", "--flc", str(SCENARIO), "--controllers", "careful-driver,flc-robust",
                     "--work", str(tmp_path / "work"), "--data", str(data), "-j", "2"])
    assert code == 0
    d = json.loads(data.read_text())
    runs = {(f["path"].split("/")[-1], r["permutation"]): r for f in d["files"] for r in f["runs"]}
    # distribution_2x2 has 4 runs: permutations 0, 1, 2, 3 (0, N/3, 2N/3, N-1).
    assert sorted(runs) == [("distribution_2x2.xosc", 0), ("distribution_2x2.xosc", 1), ("distribution_2x2.xosc", 2),
                            ("distribution_2x2.xosc", 3), ("lane_leave_reveal.xosc", None), ("standing_car.xosc", None)]
    for key, r in runs.items():
        for who in ("careful-driver", "flc-robust"):
            p = r["players"][who]
            assert p["status"] == "ok", (key, who, p)
            # Both competent drivers stop for the standing car and the revealed box: no contact,
            # nothing passed, no stop far short of it.
            assert p["contacts"] == [] and p["passed"] == [] and p["far_stops"] == [], (key, who, p)
            # The tool's closest approach (its geometry on the ego's swept path) is flc's own
            # min_gap (the in-path module's ground truth) within a few centimetres.
            assert abs(p["closest_m"] - p["min_gap"]) < 0.05, (key, who, p["closest_m"], p["min_gap"])
    # The careful driver stops 2 m or more short of the standing car (R157's model, its own docs).
    assert runs[("standing_car.xosc", None)]["players"]["careful-driver"]["closest_m"] > 2.0
    # Resumable: the second call serves the cached runs, equal.
    assert pcc.main([*map(str, files), "--no-esmini", "--flc", str(SCENARIO), "--controllers", "careful-driver,flc-robust",
                     "--work", str(tmp_path / "work"), "--data", str(tmp_path / "again.json"), "-j", "1"]) == 0
    again = json.loads((tmp_path / "again.json").read_text())
    assert again["files"] == d["files"]
