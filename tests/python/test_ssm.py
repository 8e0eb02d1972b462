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

The trajectory and the comparison are :func:`flc.sumo.ssm_trajectory` / :func:`flc.sumo.ssm_comparison`;
the comparison table of docs/v2v-and-metrics.md renders the committed docs/figures/sumo-tables.json
(``python -m flc sumo-tables --out docs/figures``), which the last test compares with a fresh run.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

traci = pytest.importorskip("libsumo")

import flc  # noqa: E402
from flc import sumo as fs  # noqa: E402

STEP = fs.SSM_STEP
TOL = 1e-5


def test_min_ttc_max_drac_and_time_gap_agree_with_sumo(tmp_path):
    cols, ssm = fs.ssm_trajectory(tmp_path)
    m = flc.metrics_from_series(cols)
    sumo_ttc = fs.ssm_value(ssm, "conflict[@ego='foll']/minTTC")
    sumo_drac = fs.ssm_value(ssm, "conflict[@ego='foll']/maxDRAC")
    sumo_sgap = fs.ssm_value(ssm, "globalMeasures[@ego='foll']/minSGAP")
    sumo_tgap = fs.ssm_value(ssm, "globalMeasures[@ego='foll']/minTGAP")
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
    cols, ssm = fs.ssm_trajectory(tmp_path)
    m = flc.metrics_from_series(cols)
    ttc = [x for x in fs.ssm_span(ssm, "TTCSpan") if math.isfinite(x)]
    tet, tit = fs.tet_tit_from_ttc_span(ttc, STEP)
    assert (tet, tit) == (STEP * sum(1 for x in ttc if x <= 3.0), STEP * sum(3.0 - x for x in ttc if x <= 3.0))
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


def test_the_committed_comparison_table_is_this_run(tmp_path):
    c = fs.ssm_comparison(tmp_path)
    # The comparison's SUMO side is the log's (the values the first test compares) ...
    cols, ssm = fs.ssm_trajectory(tmp_path / "again")
    assert c.sumo["min_ttc"] == fs.ssm_value(ssm, "conflict[@ego='foll']/minTTC") and c.flc == flc.metrics_from_series(cols)
    assert all(abs(c.difference(k)) <= TOL for k in c.sumo)
    # ... and the documents' table (docs/figures/sumo-tables.json) is this run, number for number.
    stored = fs.read_tables()["ssm"]
    fresh = fs.ssm_record(c)
    assert set(fresh) == set(stored)
    for side in ("flc", "sumo"):
        assert set(fresh[side]) == set(stored[side])
        for k, v in stored[side].items():
            assert fresh[side][k] == pytest.approx(v, rel=1e-9, abs=1e-12), (side, k)
    assert (fresh["flc_pet"], fresh["sumo_pet"]) == (stored["flc_pet"], stored["sumo_pet"])
    assert fresh["min_ttc_leader_distance"] == pytest.approx(stored["min_ttc_leader_distance"], rel=1e-9)
