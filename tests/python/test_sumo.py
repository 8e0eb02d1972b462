"""flc's controllers driving SUMO vehicles (``flc.sumo``, issue 16; docs/sumo.md).

Needs ``eclipse-sumo`` and ``libsumo`` (the ``flc[sumo]`` extra, installed by tests/run_all.sh).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import libsumo  # noqa: F401  (SUMO is a test dependency, the `test` extra: a missing one fails, no skip)
import numpy as np
import pytest

import flc
from flc import sumo as fs

#: The committed SUMO tables the documents render (docs/figures/sumo-tables.json, written by
#: `python -m flc sumo-tables --out docs/figures`); each test below that computes one of their rows
#: compares it with the file, so the documents' numbers cannot drift from the code silently.
TABLES = fs.read_tables()


def _same(fresh: Any, stored: Any, where: str = "") -> None:
    """``fresh`` equals the committed ``stored`` (floats to 1e-9 relative, 1e-12 absolute: the
    same computation, allowing for a platform's last-bit differences)."""
    if isinstance(stored, dict):
        assert isinstance(fresh, dict) and set(fresh) == set(stored), (where, fresh, stored)
        for k in stored:
            _same(fresh[k], stored[k], f"{where}.{k}")
    elif isinstance(stored, list):
        assert isinstance(fresh, list) and len(fresh) == len(stored), (where, fresh, stored)
        for i, (a, b) in enumerate(zip(fresh, stored)):
            _same(a, b, f"{where}[{i}]")
    elif isinstance(stored, float) and isinstance(fresh, float):
        assert fresh == pytest.approx(stored, rel=1e-9, abs=1e-12), (where, fresh, stored)
    else:
        assert fresh == stored, (where, fresh, stored)


def test_the_committed_tables_hold_every_row_the_documents_render() -> None:
    assert [(r["controller"], r["speed_kmh"]) for r in TABLES["replay"]] == list(fs.REPLAY_CASES)
    assert [(c["law"], c["speed_kmh"]) for c in TABLES["closed_loop"]] == [(law, v) for law in fs.SUMO_MODELS for v in fs.CLOSED_LOOP_SPEEDS_KMH]
    assert TABLES["platoon_outage"]["arguments"] == fs.PLATOON_OUTAGE
    assert TABLES["platoon_join"]["arguments"] == fs.PLATOON_JOIN


@pytest.mark.parametrize("controller,speed_kmh", [("flc", 50.0), ("flc", 90.0), ("flc-robust", 70.0), ("idm", 50.0)])
def test_flc_driving_a_sumo_vehicle_matches_flcs_own_ideal_run(tmp_path: Path, controller: str, speed_kmh: float) -> None:
    # Tolerance: the two worlds do the same arithmetic on positions that agree to rounding; what
    # differs is SUMO's clock, one step ahead of the motion (the insertion step), so that every
    # measurement after the first sees the state one step earlier (docs/sumo.md, "The SUMO
    # differences"); the laws' branch points (the stop hold at standstill, the FLC's brake
    # regions) amplify that to a few cm/s at most. The measured figures are the committed table's
    # (docs/figures/sumo-tables.json), compared below.
    rep = fs.replay_ideal_run(controller, speed_kmh, directory=tmp_path)
    sc, r, speeds, gaps, drv = rep.vehicle.scenario, rep.run, rep.speed, rep.gap, rep.vehicle
    dv = rep.speed_difference
    dg = rep.gap_difference
    assert math.sqrt(float(np.mean(dv**2))) < 0.01
    assert float(np.abs(dv).max()) < 0.1
    assert float(np.abs(dg).max()) < 0.05
    # The same outcome: a stop behind the lead at flc's standstill gap.
    assert r.metrics["collision"] is False and gaps.min() > 0.0
    assert abs(gaps[-1] - r.gap[-1]) < 0.05
    # SUMO's gap (the trace's input column) is the bumper gap of the SUMO positions ...
    tr = drv.trace
    assert np.allclose(tr.array("gap")[1:], gaps[:-1], atol=1e-9)
    # ... and what the controller saw (`distance`, ideal perception) is exactly that gap on each
    # measurement (20 Hz: every 5th step), held in between.
    gap_in, seen = tr.array("gap"), tr.array("distance")
    assert seen[0] == gap_in[0]
    fresh = seen[1:] == gap_in[1:]
    held = seen[1:] == seen[:-1]
    assert np.all(fresh | held)
    updates = int(np.sum(fresh & ~held))
    every = round(1.0 / (float(sc["lidar.rate_hz"]) * float(sc["physics_dt"])))
    # Every measurement of a moving scene is an update (at standstill the gap repeats itself).
    assert updates > 0.9 * len(seen) / every * float(np.mean(speeds > 0.01)), updates
    # The documents' row of this case is this run's.
    (stored,) = [row for row in TABLES["replay"] if (row["controller"], row["speed_kmh"]) == (controller, speed_kmh)]
    _same(fs.replay_record(controller, speed_kmh, rep), stored, f"replay {controller} {speed_kmh}")


def test_the_gap_sensor_delays_blurs_and_drops(tmp_path: Path) -> None:
    sc = flc.Scenario.paper(speed_kmh=50.0, controller="flc", lidar_range_noise_std=0.1, lidar_latency_frames=2, lidar_scan_drop_prob=0.2,
                            lidar_jitter=0.0)
    r = flc.run(flc.Scenario.paper(speed_kmh=50.0, controller="flc", **fs.VALIDATION))
    tr = fs.replay_run(sc, r, step=0.01, directory=tmp_path).vehicle.trace
    t, gap, seen = tr.array("t"), tr.array("gap"), tr.array("distance")
    # Measurements every 5 steps (20 Hz), delivered two scans (10 steps) late; 20 % dropped.
    ticks = [k for k in range(10, len(t)) if k % 5 == 0]
    fresh = [k for k in ticks if k + 1 < len(t)]
    # At a delivered tick k the controller's distance is the gap at k - 10 plus noise; NaN for a
    # dropped scan.
    errs = np.array([seen[k] - gap[k - 10] for k in fresh if np.isfinite(seen[k])])
    dropped = sum(1 for k in fresh if not np.isfinite(seen[k])) / len(fresh)
    assert abs(dropped - 0.2) < 0.05
    assert abs(float(errs.mean())) < 0.02 and abs(float(errs.std()) - 0.1) < 0.02


def test_bad_configuration_and_input_name_the_field() -> None:
    with pytest.raises(flc.ScenarioError, match="lidar.rate_hz"):
        fs.FlcVehicle("x", controller="flc", lidar_rate_hz=-1.0)
    with pytest.raises(flc.ScenarioError, match="controller"):
        fs.FlcVehicle("x", controller="nope")
    inner = flc._flc.ExternalFollower(flc.Scenario.paper().to_json(), 1)
    with pytest.raises(flc.ParameterError, match="own_speed"):
        inner.step(0.0, 0.01, 10.0, 5.0, float("nan"))


def test_a_v2v_outage_hands_every_platoon_follower_to_the_flc(tmp_path: Path) -> None:
    o = fs.cacc_platoon(5, directory=tmp_path, outage_at=40.0, brake_at=45.0)
    assert o.controller == "pipeline"
    assert o.switched_to_flc == 5
    for f in o.followers:
        # The PID drove before the outage (one hand-over at the start, one at the outage) ...
        assert f["switches"] == 2
        # ... and the FLC took over within the supervisor's freshness limit (5 ticks at 20 Hz).
        assert 0.0 < f["switch_to_flc_after"] <= 0.25 + 1e-9
        # The lead's 6 m/s² stop during the outage: no contact, SUMO's SSM device saw each one.
        assert f["min_gap"] > 2.0
        assert math.isfinite(f["ssm"]["min_ttc"]) and f["ssm"]["min_ttc"] > 1.0
    assert o.collisions == []
    # SUMO's own CACC on the same script, for reference (perfect information).
    ref = fs.cacc_platoon(5, controller="sumo-cacc", directory=tmp_path / "ref")
    assert ref.switched_to_flc == 0 and ref.collisions == []
    # The documents' platoon table is these two runs.
    stored = TABLES["platoon_outage"]
    assert stored["arguments"] == {"followers": 5, "cruise_kmh": 100.0, "outage_at": 40.0, "brake_at": 45.0}
    _same(fs.platoon_record(o), stored["flc"], "platoon_outage.flc")
    _same(fs.platoon_record(ref), stored["sumo_cacc"], "platoon_outage.sumo_cacc")


@pytest.mark.parametrize("law,speed_kmh", [("idm", 50.0), ("idm", 130.0), ("acc", 50.0), ("acc", 130.0)])
def test_flc_baselines_in_sumo_reproduce_sumos_models_in_closed_loop(tmp_path: Path, law: str, speed_kmh: float) -> None:
    # The same law on the same inputs, so the only differences are floating-point order (IDM:
    # measured 0 m/s) and, for the ACC, the residual of SUMO's ACC internals the step-by-step check
    # bounds at 0.005 m/s per step (tests/sumo.rs); closed loop they stay below 0.01 m/s.
    d = fs.closed_loop_difference(law, speed_kmh, directory=tmp_path)
    ref, ours = d.sumo, d.flc
    assert abs(len(ref) - len(ours)) <= 1
    err = d.difference
    tol = 1e-6 if law == "idm" else 0.01
    assert d.max_difference == float(err.max())
    assert float(err.max()) < tol, f"{law} {speed_kmh}: max {err.max():.3e} m/s at step {err.argmax()}"
    # The documents' cell is this pair of runs.
    (stored,) = [c for c in TABLES["closed_loop"] if (c["law"], c["speed_kmh"]) == (law, speed_kmh)]
    _same(fs.closed_loop_record(d), stored, f"closed_loop {law} {speed_kmh}")


def test_a_car_without_v2v_joining_the_platoon_hands_only_the_follower_behind_it_to_the_flc(tmp_path: Path) -> None:
    # Issue 25 in SUMO: a SUMO car (no flc, no V2V) changes into the platoon's lane between
    # followers 2 and 3 at 30 s; every link stays up and each follower keeps listening to its
    # predecessor. Follower 3 measures the joining car, finds it is not its V2V sender and hands
    # over to the FLC at once; the others keep the PID. Then the lead stops at 6 m/s².
    o = fs.cacc_platoon(5, directory=tmp_path, cruise_kmh=100.0, outage_at=None, join_at=30.0, join_after=2, brake_at=45.0)
    assert o.on_flc_after_join == ["f3"]
    f3 = o.followers[2]
    # The first step after the lane change begins (SUMO step 0.05 s = one scan at 20 Hz).
    assert 0.0 <= f3["switch_to_flc_after_join"] <= 0.05 + 1e-9
    # Not associated from then on (the joining car stays in front), about 35 s of the run.
    assert f3["time_not_associated"] > 30.0
    for f in o.followers[:2] + o.followers[3:]:
        assert f["time_not_associated"] == 0.0 and f["switches"] == 1, f
    assert o.collisions == []
    assert all(f["min_gap"] > 2.0 for f in o.followers)
    assert all(f["ssm"]["min_ttc"] > 1.0 for f in o.followers)
    # The documents' join table is this run.
    stored = TABLES["platoon_join"]
    assert stored["arguments"] == {"followers": 5, "cruise_kmh": 100.0, "outage_at": None, "join_at": 30.0, "join_after": 2, "brake_at": 45.0}
    _same(fs.platoon_record(o), stored["flc"], "platoon_join.flc")
