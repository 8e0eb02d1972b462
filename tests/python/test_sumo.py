"""flc's controllers driving SUMO vehicles (``flc.sumo``, issue 16; docs/sumo.md).

Needs ``eclipse-sumo`` and ``libsumo`` (the ``flc[sumo]`` extra, installed by tests/run_all.sh).
"""
from __future__ import annotations

import math
from pathlib import Path

import libsumo as traci
import numpy as np
import pytest

import flc
from flc import sumo as fs

#: Ideal perception, no actuator dynamics, a clean sensor schedule: the validation setting.
IDEAL = {
    "follower_perception": "ideal",
    "follower.vehicle.dead_time": 0.0,
    "follower.vehicle.lag": 0.0,
    "lidar_jitter": 0.0,
    "lidar_scan_drop_prob": 0.0,
    "lidar_latency_frames": 0,
}


def _replay_in_sumo(tmp_path: Path, sc: flc.Scenario, r: flc.RunResult, step: float) -> tuple[np.ndarray, np.ndarray, fs.FlcVehicle]:
    """A scripted SUMO lead replaying flc's lead speed, the follower driven by flc; returns the
    follower's speed and gap after each step, and its driver."""
    L = float(sc["lead"]["vehicle"]["length"])
    Lf = float(sc["follower"]["vehicle"]["length"])
    gap0 = float(sc["follower"]["initial_gap"])
    net = fs.straight_road(tmp_path, 3000.0)
    rou = tmp_path / "r.rou.xml"
    common = 'minGap="2.5" accel="10" decel="10" emergencyDecel="10" maxSpeed="60" speedFactor="1" speedDev="0" sigma="0"'
    rou.write_text(
        "<routes>\n"
        f'<vType id="leadT" length="{L}" {common}/>\n<vType id="follT" length="{Lf}" {common}/>\n<route id="r" edges="e"/>\n'
        f'<vehicle id="lead" type="leadT" route="r" depart="0" departPos="{100.0 + gap0 + L}" departSpeed="0" insertionChecks="none"/>\n'
        '<vehicle id="foll" type="follT" route="r" depart="0" departPos="100" departSpeed="0" insertionChecks="none"/>\n</routes>\n'
    )
    traci.start([fs.sumo_binary(), "-n", str(net), "-r", str(rou), "--step-length", str(step), "--step-method.ballistic", "true",
                 "--no-step-log", "--no-warnings", "--collision.action", "warn"])
    try:
        traci.simulationStep()
        traci.vehicle.setSpeedMode("lead", 0)
        drv = fs.FlcVehicle("foll", sc)
        speeds, gaps = [], []
        for k in range(len(r.t)):
            traci.vehicle.setSpeed("lead", float(r.lead_speed[k]))
            drv.step(traci)
            traci.simulationStep()
            speeds.append(traci.vehicle.getSpeed("foll"))
            gaps.append(traci.vehicle.getLanePosition("lead") - L - traci.vehicle.getLanePosition("foll"))
    finally:
        traci.close()
    return np.array(speeds), np.array(gaps), drv


@pytest.mark.parametrize("controller,speed_kmh", [("flc", 50.0), ("flc", 90.0), ("flc-robust", 70.0), ("idm", 50.0)])
def test_flc_driving_a_sumo_vehicle_matches_flcs_own_ideal_run(tmp_path: Path, controller: str, speed_kmh: float) -> None:
    # Tolerance: the two worlds do the same arithmetic except SUMO's own position bookkeeping
    # (lane positions, insertion), which differs from flc's at the 1e-8 m level; the laws' branch
    # points (the stop hold at standstill, the FLC's brake regions) amplify that to a few cm/s at
    # most. Measured: speed RMS 0.003 m/s, max 0.036 m/s, gap max 0.016 m (FLC, 50 km/h).
    sc = flc.Scenario.paper(speed_kmh=speed_kmh, controller=controller, **IDEAL)
    r = flc.run(sc)
    speeds, gaps, drv = _replay_in_sumo(tmp_path, sc, r, float(sc["physics_dt"]))
    dv = speeds - r.follower_speed
    dg = gaps - r.gap
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


def test_the_gap_sensor_delays_blurs_and_drops(tmp_path: Path) -> None:
    sc = flc.Scenario.paper(speed_kmh=50.0, controller="flc", lidar_range_noise_std=0.1, lidar_latency_frames=2, lidar_scan_drop_prob=0.2,
                            lidar_jitter=0.0)
    r = flc.run(flc.Scenario.paper(speed_kmh=50.0, controller="flc", **IDEAL))
    _, _, drv = _replay_in_sumo(tmp_path, sc, r, 0.01)
    tr = drv.trace
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


#: SUMO's vType parameters of each model and the flc law's keyword overrides that mean the same
#: (docs/baselines.md, "Checking the baselines against SUMO"); the SUMO step is the law's
#: `command_gain`.
SUMO_MODELS = {
    "idm": ('carFollowModel="IDM" accel="2.6" decel="4.5" emergencyDecel="9" tau="1.0" minGap="2.5" delta="4" stepping="0.25"',
            {"idm_desired_speed": 50.0, "idm_time_headway": 1.0, "idm_min_gap": 2.5, "idm_max_accel": 2.6, "idm_comfort_decel": 4.5,
             "idm_delta": 4.0, "idm_max_decel": 9.0}),
    "acc": ('carFollowModel="ACC" accel="2.6" decel="8" emergencyDecel="9" tau="1.0" minGap="2.5"',
            {"acc_desired_speed": 50.0, "acc_headway_time": 1.0, "acc_min_gap": 2.5, "acc_decel": 8.0, "acc_lead_decel": 10.0,
             "acc_max_accel": 2.6}),
}


def _paper_lead(t: float, x: float, v: float, step: float, v_max: float, state: dict[str, bool]) -> float:
    if state.get("braking") or x >= 650.0:
        state["braking"] = True
        return max(0.0, v - 6.0 * step)
    return min(v_max, v + 2.5 * step)


def _closed_loop(tmp_path: Path, law: str, speed_kmh: float, flc_drives: bool, step: float = 0.1) -> np.ndarray:
    """The paper experiment in SUMO (Euler steps, SUMO's default), the follower either SUMO's own
    model or flc's law of the same name with ideal perception and direct actuation."""
    vtype, params = SUMO_MODELS[law]
    net = fs.straight_road(tmp_path, 5000.0)
    rou = tmp_path / f"{law}-{flc_drives}.rou.xml"
    common = 'length="5.0" maxSpeed="50" speedFactor="1" speedDev="0"'
    rou.write_text(
        "<routes>\n"
        f'<vType id="leadT" {common} carFollowModel="Krauss" accel="10" decel="10" emergencyDecel="10" sigma="0" minGap="2.5"/>\n'
        f'<vType id="follT" {common} {vtype}/>\n<route id="r" edges="e"/>\n'
        '<vehicle id="lead" type="leadT" route="r" depart="0" departPos="112" departSpeed="0" insertionChecks="none"/>\n'
        '<vehicle id="foll" type="follT" route="r" depart="0" departPos="100" departSpeed="0" insertionChecks="none"/>\n</routes>\n'
    )
    traci.start([fs.sumo_binary(), "-n", str(net), "-r", str(rou), "--step-length", str(step), "--no-step-log", "--no-warnings",
                 "--collision.action", "warn"])
    speeds = []
    try:
        traci.simulationStep()
        traci.vehicle.setSpeedMode("lead", 0)
        drv = None
        if flc_drives:
            sc = flc.Scenario.paper(controller=law, follower_perception="ideal", lidar_rate_hz=1.0 / step, lidar_jitter=0.0,
                                    lidar_scan_drop_prob=0.0, lidar_latency_frames=0, **{f"{law}_command_gain": step}, **params)
            drv = fs.FlcVehicle("foll", sc, actuation="direct")
        state: dict[str, bool] = {}
        t = 0.0
        while t < 160.0:
            v, x = traci.vehicle.getSpeed("lead"), traci.vehicle.getLanePosition("lead")
            traci.vehicle.setSpeed("lead", _paper_lead(t, x - 112.0, v, step, speed_kmh / 3.6, state))
            if drv is not None:
                drv.step(traci)
            traci.simulationStep()
            t = traci.simulation.getTime()
            speeds.append(traci.vehicle.getSpeed("foll"))
            if v == 0.0 and speeds[-1] == 0.0 and t > 10.0:
                break
    finally:
        traci.close()
    return np.array(speeds)


@pytest.mark.parametrize("law,speed_kmh", [("idm", 50.0), ("idm", 130.0), ("acc", 50.0), ("acc", 130.0)])
def test_flc_baselines_in_sumo_reproduce_sumos_models_in_closed_loop(tmp_path: Path, law: str, speed_kmh: float) -> None:
    # The same law on the same inputs, so the only differences are floating-point order (IDM:
    # measured 0 m/s) and, for the ACC, the residual of SUMO's ACC internals the step-by-step check
    # bounds at 0.005 m/s per step (tests/sumo.rs); closed loop they stay below 0.01 m/s.
    ref = _closed_loop(tmp_path, law, speed_kmh, flc_drives=False)
    ours = _closed_loop(tmp_path, law, speed_kmh, flc_drives=True)
    n = min(len(ref), len(ours))
    assert abs(len(ref) - len(ours)) <= 1
    err = np.abs(ours[:n] - ref[:n])
    tol = 1e-6 if law == "idm" else 0.01
    assert float(err.max()) < tol, f"{law} {speed_kmh}: max {err.max():.3e} m/s at step {err.argmax()}"


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
