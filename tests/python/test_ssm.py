"""flc's surrogate safety measures against SUMO's SSM device on the same trajectory (issue 22;
docs/v2v-and-metrics.md, "Surrogate safety measures and SUMO").

SUMO (``eclipse-sumo`` + ``libsumo`` 1.28, the ``flc[sumo]`` extra, installed by the ``test`` extra
and in CI) moves a follower that closes in on a slower lead and brakes late (both scripted with
``setSpeed``, speed mode 0; SUMO's own models brake early and never get below TTC 3 s here); its
SSM device logs TTC, DRAC, PET, SGAP and TGAP every step. The recorded trajectory (gap from the lane
positions: the lead's rear bumper minus the follower's front bumper, i.e. bumper to bumper
without SUMO's ``minGap``) goes through :func:`flc.metrics_from_series`, which is the
simulator's own Rust metrics code.

Tolerances. Both sides evaluate the same formulas (``TTC = g / (v_f - v_l)``,
``DRAC = (v_f - v_l)² / (2 g)``, ``TGAP = g / v_f``) on the same states: SUMO's SSM gap is the
bumper gap (the SGAP span starts at the depart positions' difference minus the lead's length, not
minus ``minGap``), and it logs the state after each step under the step's start time (its
``timeSpan`` is one step behind the time ``simulation.getTime()`` reports after the step), which
shifts labels, not values. What is left is the output rounding: ``--precision 6`` writes 6
decimals, so values agree to 5e-7 plus float noise; the asserted 1e-5 (s, m/s²) leaves room for
that and nothing else. Had flc used ``getLeader``'s distance (the gap minus ``minGap``, 2.5 m),
min TTC would be off by 2.5 m / closing speed, hundreds of times the tolerance; had it read the
state before the step, by one step's change (0.1 s of closing). TET and TIT are not SUMO
outputs; they are rebuilt from SUMO's per-step ``TTCSpan`` (``--device.ssm.trajectories``; each
value covers one step, as each of flc's samples does): the exposed samples are the same ones, so
TET agrees exactly (to float noise) and TIT to the rounding of the span's values (5e-7 s each,
times the 0.1 s step per exposed sample).

``python tests/python/test_ssm.py`` prints the comparison table of docs/v2v-and-metrics.md.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

traci = pytest.importorskip("libsumo")

import flc  # noqa: E402
from flc import sumo as fs  # noqa: E402

STEP = 0.1
LENGTH = 5.0
TOL = 1e-5


def _follower_speed(t: float, v: float) -> float:
    """A late-braking follower: 20 m/s until 4 s, then 4 m/s² down to the lead's 10 m/s."""
    return 20.0 if t < 4.0 else max(10.0, v - 4.0 * STEP)


def _sumo_trajectory(tmp_path: Path) -> tuple[dict[str, np.ndarray], ET.Element]:
    """A follower at 20 m/s 60 m behind a lead at 10 m/s, both scripted in SUMO (speed mode 0):
    the follower brakes late (:func:`_follower_speed`), closing to 8.5 m. Returns flc's series
    columns (one row per SUMO state) and SUMO's SSM log."""
    net = fs.straight_road(tmp_path, 3000.0, speed=40.0)
    rou = tmp_path / "ssm.rou.xml"
    rou.write_text(
        "<routes>\n"
        f'<vType id="v" length="{LENGTH}" minGap="2.5" maxSpeed="40" accel="10" decel="10" emergencyDecel="10" sigma="0" speedFactor="1" speedDev="0"/>\n'
        '<route id="r" edges="e"/>\n'
        f'<vehicle id="lead" type="v" route="r" depart="0" departPos="{100.0 + 60.0 + LENGTH}" departSpeed="10" insertionChecks="none"/>\n'
        '<vehicle id="foll" type="v" route="r" depart="0" departPos="100" departSpeed="20" insertionChecks="none"/>\n'
        "</routes>\n"
    )
    ssm = tmp_path / "ssm.xml"
    traci.start(
        [fs.sumo_binary(), "-n", str(net), "-r", str(rou), "--step-length", str(STEP), "--step-method.ballistic", "true",
         "--no-step-log", "--no-warnings", "--precision", "6", "--collision.action", "warn",
         "--device.ssm.probability", "1", "--device.ssm.measures", "TTC DRAC PET SGAP TGAP",
         "--device.ssm.thresholds", "3.0 3.0 2.0 0.2 0.5", "--device.ssm.range", "100", "--device.ssm.trajectories", "true",
         "--device.ssm.file", str(ssm)]
    )
    rows: dict[str, list[float]] = {k: [] for k in ("t", "gap", "lead_speed", "follower_speed", "follower_accel", "lead_accel")}

    def record() -> None:
        rows["t"].append(float(traci.simulation.getTime()))
        rows["gap"].append(traci.vehicle.getLanePosition("lead") - LENGTH - traci.vehicle.getLanePosition("foll"))
        rows["lead_speed"].append(traci.vehicle.getSpeed("lead"))
        rows["follower_speed"].append(traci.vehicle.getSpeed("foll"))
        rows["follower_accel"].append(traci.vehicle.getAcceleration("foll"))
        rows["lead_accel"].append(traci.vehicle.getAcceleration("lead"))

    try:
        traci.simulationStep()
        for v in ("lead", "foll"):
            traci.vehicle.setSpeedMode(v, 0)
        record()
        while traci.simulation.getTime() < 20.0:
            t = float(traci.simulation.getTime())
            traci.vehicle.setSpeed("lead", 10.0)
            traci.vehicle.setSpeed("foll", _follower_speed(t, traci.vehicle.getSpeed("foll")))
            traci.simulationStep()
            record()
    finally:
        traci.close()
    return {k: np.asarray(v) for k, v in rows.items()}, ET.parse(ssm).getroot()


def _value(root: ET.Element, path: str) -> float:
    el = root.find(path)
    assert el is not None, path
    return float(el.get("value", "nan"))


def _spans(root: ET.Element, tag: str) -> list[float]:
    el = root.find(f"conflict[@ego='foll']/{tag}")
    assert el is not None, tag
    return [float("nan") if v == "NA" else float(v) for v in el.get("values", "").split()]


def test_min_ttc_max_drac_and_time_gap_agree_with_sumo(tmp_path):
    cols, ssm = _sumo_trajectory(tmp_path)
    m = flc.metrics_from_series(cols)
    sumo_ttc = _value(ssm, "conflict[@ego='foll']/minTTC")
    sumo_drac = _value(ssm, "conflict[@ego='foll']/maxDRAC")
    sumo_sgap = _value(ssm, "globalMeasures[@ego='foll']/minSGAP")
    sumo_tgap = _value(ssm, "globalMeasures[@ego='foll']/minTGAP")
    # A real conflict, not a trivial one: TTC well below the 3 s threshold, no collision.
    assert 0.5 < sumo_ttc < 2.5 and sumo_drac > 1.0 and np.all(cols["gap"] > 0.0)
    assert abs(m["min_ttc"] - sumo_ttc) <= TOL, (m["min_ttc"], sumo_ttc)
    assert abs(m["max_drac"] - sumo_drac) <= TOL, (m["max_drac"], sumo_drac)
    assert abs(m["min_gap"] - sumo_sgap) <= TOL, (m["min_gap"], sumo_sgap)
    assert abs(m["min_time_headway"] - sumo_tgap) <= TOL, (m["min_time_headway"], sumo_tgap)
    # Plain following: no cut-in, so no PET; SUMO (PET only for crossing and merging conflicts
    # at junctions) writes its PET element with value NA.
    pet = ssm.find("conflict[@ego='foll']/PET")
    assert m["pet"] is None and pet is not None and pet.get("value") == "NA"
    # The minGap-reduced gap (getLeader's distance) would not agree.
    closing = cols["follower_speed"] - cols["lead_speed"]
    k = int(np.argmin(np.where(closing > 1e-6, cols["gap"] / np.where(closing > 1e-6, closing, 1.0), np.inf)))
    assert abs((cols["gap"][k] - 2.5) / closing[k] - sumo_ttc) > 100 * TOL


def test_tet_and_tit_from_sumos_ttc_span(tmp_path):
    cols, ssm = _sumo_trajectory(tmp_path)
    m = flc.metrics_from_series(cols)
    ttc = [x for x in _spans(ssm, "TTCSpan") if math.isfinite(x)]
    tet = STEP * sum(1 for x in ttc if x <= 3.0)
    tit = STEP * sum(3.0 - x for x in ttc if x <= 3.0)
    exposed = sum(1 for x in ttc if x <= 3.0)
    assert tet > 1.0 and tit > 0.5  # exposed for a while
    assert abs(m["tet"] - tet) <= 1e-9, (m["tet"], tet)
    assert abs(m["tit"] - tit) <= exposed * 5e-7 * STEP + 1e-9, (m["tit"], tit)
    # A lower threshold through the keyword parameters: fewer samples, the same agreement.
    low = flc.metrics_from_series(cols, ttc_threshold=2.2)
    tet_low = STEP * sum(1 for x in ttc if x <= 2.2)
    assert 0.0 < low["tet"] < m["tet"] and abs(low["tet"] - tet_low) <= 1e-9, (low["tet"], tet_low)


def test_metrics_from_series_has_the_run_metric_names_and_checks_its_input():
    r = flc.run(flc.Scenario.paper(speed_kmh=30, controller="flc"))
    m = flc.metrics_from_series({k: r.series[k] for k in ("t", "gap", "lead_speed", "follower_speed", "follower_accel")})
    assert list(m) == list(r.metrics)
    assert [k for k in m if k in ("max_drac", "tet", "tit", "min_time_headway", "pet")] == ["max_drac", "tet", "tit", "min_time_headway", "pet"]
    # The same series gives the same TTC-based metrics as the run itself.
    for key in ("min_gap", "min_ttc", "max_drac", "tet", "tit", "min_time_headway", "pet", "max_decel", "duration"):
        assert m[key] == r.metrics[key], key
    # No `active` column: nobody drove.
    assert (m["time_flc"], m["time_pid"]) == (0.0, 0.0)
    with pytest.raises(flc.ParameterError, match="unknown column `gpa`"):
        flc.metrics_from_series({"t": [0.0, 0.1], "gpa": [1.0, 2.0]})
    with pytest.raises(flc.ParameterError, match="column `t` has 2 samples, `gap` 1"):
        flc.metrics_from_series({"t": [0.0, 0.1], "gap": [1.0]})
    with pytest.raises(flc.ParameterError, match="ttc_treshold"):
        flc.metrics_from_series({"t": [0.0, 0.1]}, ttc_treshold=2.0)


def main() -> None:
    """Prints the comparison table of docs/v2v-and-metrics.md (``python tests/python/test_ssm.py``)."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        cols, ssm = _sumo_trajectory(Path(d))
    m = flc.metrics_from_series(cols)
    ttc = [x for x in _spans(ssm, "TTCSpan") if math.isfinite(x)]
    sumo = {
        "min_ttc": _value(ssm, "conflict[@ego='foll']/minTTC"),
        "max_drac": _value(ssm, "conflict[@ego='foll']/maxDRAC"),
        "min_gap": _value(ssm, "globalMeasures[@ego='foll']/minSGAP"),
        "min_time_headway": _value(ssm, "globalMeasures[@ego='foll']/minTGAP"),
        "tet": STEP * sum(1 for x in ttc if x <= 3.0),
        "tit": STEP * sum(3.0 - x for x in ttc if x <= 3.0),
    }
    print("| flc | flc value | SUMO value | difference |")
    print("|---|---|---|---|")
    for k, v in sumo.items():
        print(f"| `{k}` | {m[k]:.6f} | {v:.6f} | {abs(m[k] - v):.1e} |")
    pet = ssm.find("conflict[@ego='foll']/PET")
    print(f"| `pet` | {m['pet']} | {None if pet is None else pet.get('value')} | — |")
    closing = cols["follower_speed"] - cols["lead_speed"]
    ok = closing > 1e-6
    print(f"min TTC with getLeader's distance (the gap minus minGap 2.5 m): {float(np.min((cols['gap'][ok] - 2.5) / closing[ok])):.6f} s")


if __name__ == "__main__":
    main()
