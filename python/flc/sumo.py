"""flc's controllers driving SUMO vehicles (extra ``flc[sumo]``: ``eclipse-sumo`` and ``libsumo``).

A :class:`FlcVehicle` hands one SUMO vehicle's longitudinal control to an flc follower pipeline
(``flc_sim::ExternalFollower``): any controller flc has (``flc``, ``flc-robust``, ``flc-robust-v1``, ``pid``,
``pipeline``, the baselines), configured by an :class:`flc.Scenario` and keyword overrides exactly
as in flc's own simulator. Every SUMO step it

1. reads SUMO's leader and gap (``vehicle.getLeader`` + the vehicle's ``minGap``: the bumper gap),
   the leader's speed and its own speed;
2. sends the leader's speed through flc's V2V channel model (``[v2v]``: rate, latency, jitter, loss,
   Gilbert-Elliott bursts, scripted ``outages``, or :meth:`FlcVehicle.start_outage` at run time);
3. turns the gap into what a LiDAR detector would report with the **gap sensor** (``[lidar]``'s
   schedule ``rate_hz``, ``max_range``, ``range_noise_std`` on the distance, ``scan_drop_prob`` /
   ``dropout_prob`` dropouts, ``latency_frames``; ``follower_perception="ideal"`` gives the true gap
   and the leader's true speed instead, for validation);
4. runs the controller on each measurement and flc's low-level speed controller and longitudinal
   vehicle model (``[follower.vehicle]``: dead time, lag, limits, resistance) every step;
5. sets the vehicle's speed for the next step (``vehicle.setSpeed``; speed mode 0 and lane-change
   mode 0 so that SUMO neither overrides nor moves it: collisions are possible and reported).

The loop reads SUMO's clock only to hand it on (``t``, ``dt``); the FLC family takes neither.
Use SUMO's ``--step-method.ballistic true`` for the same position update as flc's vehicles.
``docs/sumo.md`` documents the sensor model and the example; ``examples/sumo_platoon.py`` is a CACC
platoon whose V2V drops.

The comparisons the documents state are computed here, once: :func:`replay_ideal_run` (flc in SUMO
against flc's own run), :func:`closed_loop_difference` (flc's baselines against SUMO's models),
:func:`cacc_platoon` (the platoon with a V2V outage or a joining car) and :func:`ssm_comparison`
(flc's metrics against SUMO's SSM device). :func:`write_tables` (``python -m flc sumo-tables
--out docs/figures``) writes them all into ``docs/figures/sumo-tables.json``, which the documents'
generated blocks render and the tests compare with fresh runs.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Optional, Sequence, Union

import numpy as np

from . import _flc
from ._run import RunResult, metrics_from_series, run
from ._scenario import Scenario

if TYPE_CHECKING:
    import xml.etree.ElementTree as ET

__all__ = [
    "ClosedLoopDifference",
    "FlcVehicle",
    "PlatoonOutcome",
    "Replay",
    "SsmComparison",
    "Trace",
    "cacc_platoon",
    "closed_loop",
    "closed_loop_difference",
    "replay_ideal_run",
    "replay_run",
    "ssm_comparison",
    "ssm_trajectory",
    "straight_road",
    "sumo_binary",
]

#: The columns of a :class:`Trace` (SI units).
TRACE_COLUMNS = (
    "t",
    "gap",
    "front_speed",
    "speed",
    "set_speed",
    "speed_command",
    "accel_command",
    "distance",
    "active_flc",
    "switches",
    "not_associated",
)


@dataclass
class Trace:
    """What one driven vehicle saw and did, one row per SUMO step (before the step's motion).

    ``gap``/``front_speed`` are SUMO's (NaN without a leader), ``distance`` what the controller saw
    at its last measurement (NaN: nothing), ``active_flc`` 1 while the FLC drives, ``switches`` the
    hand-overs so far, ``not_associated`` 1 while the supervisor finds that the vehicle it measures
    is not the V2V sender (reason ``not_associated``), ``leader`` the SUMO id of the leader at each step ("" if none).
    """

    vehicle: str
    columns: dict[str, list[float]] = field(default_factory=lambda: {c: [] for c in TRACE_COLUMNS})
    leader: list[str] = field(default_factory=list)

    def append(self, leader: str, **row: float) -> None:
        """Adds one step: a value for every column of :data:`TRACE_COLUMNS` and the leader's id."""
        for k in TRACE_COLUMNS:
            self.columns[k].append(float(row[k]))
        self.leader.append(leader)

    def array(self, name: str) -> np.ndarray:
        """One column as a NumPy array."""
        return np.asarray(self.columns[name], dtype=float)

    @property
    def switches(self) -> int:
        """Hand-overs between the PID and the FLC so far."""
        s = self.columns["switches"]
        return int(s[-1]) if s else 0

    def summary(self) -> dict[str, Any]:
        """flc's metrics of this vehicle against its leader: minimum gap, maximum deceleration,
        hand-overs, time with the FLC driving."""
        gap = self.array("gap")
        speed = self.array("speed")
        t = self.array("t")
        accel = np.diff(speed) / np.diff(t) if len(t) > 1 else np.zeros(0)
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        finite = gap[np.isfinite(gap)]
        return {
            "vehicle": self.vehicle,
            "min_gap": float(finite.min()) if finite.size else float("nan"),
            "max_decel": float(max(0.0, -accel.min())) if accel.size else 0.0,
            "switches": self.switches,
            "time_flc": float(np.sum(self.array("active_flc")) * dt),
        }


class FlcVehicle:
    """One SUMO vehicle driven by an flc follower pipeline (see the module docs).

    ``scenario`` (default: the paper experiment with ``controller``) gives the pipeline: its
    ``controller``, ``[lidar]`` (the gap sensor), ``[v2v]``, ``[follower]`` (vehicle, low-level
    controller, ``perception``) and the controllers' sections; ``overrides`` patch it like
    :meth:`flc.Scenario.replace` (``v2v_outages=[...]``, ``lidar_range_noise_std=0.05``, ...).
    Bad values raise :class:`flc.ScenarioError` naming the key. ``seed`` (default the scenario's)
    seeds the sensor and the V2V link; give each vehicle its own. ``actuation="direct"`` sets the
    law's speed command itself instead of going through flc's low-level controller and vehicle
    model (how SUMO's own models act; for checking a baseline against SUMO's model in closed loop).
    ``v2v_sender`` (a SUMO vehicle id) is the vehicle whose messages this one receives, whatever is
    in front of it (mixed traffic: a car without V2V may come between); by default the V2V speed is
    that of SUMO's leader, the vehicle measured.
    """

    def __init__(
        self,
        vehicle_id: str,
        scenario: Optional[Scenario] = None,
        *,
        controller: Optional[str] = None,
        seed: Optional[int] = None,
        leader_range: float = 250.0,
        actuation: str = "vehicle",
        v2v_sender: Optional[str] = None,
        **overrides: Any,
    ) -> None:
        base = scenario if scenario is not None else Scenario.paper(controller=controller or "flc")
        if controller is not None:
            overrides = {"controller": controller, **overrides}
        self.scenario = base.replace(**overrides) if overrides else base
        self.vehicle_id = vehicle_id
        self.v2v_sender = v2v_sender
        self.leader_range = float(leader_range)
        self._inner = _flc.ExternalFollower(self.scenario.to_json(), self.scenario.seed if seed is None else int(seed), actuation)
        self._attached = False
        self.trace = Trace(vehicle_id)
        self.last: dict[str, Any] = {}

    @property
    def controller(self) -> str:
        """The flc controller driving this vehicle."""
        return self.scenario.controller

    def start_outage(self, t: float) -> None:
        """Takes the vehicle's incoming V2V link down from ``t`` (SUMO time, s)."""
        self._inner.start_outage(t)

    def end_outage(self, t: float) -> None:
        """Brings the link back from ``t``."""
        self._inner.end_outage(t)

    def v2v_stats(self) -> dict[str, int]:
        """The link's counters (sent, delivered, lost by cause, ...)."""
        stats: dict[str, int] = json.loads(self._inner.v2v_stats())
        return stats

    def step(self, traci: Any) -> dict[str, Any]:
        """One SUMO step: read, control, set the speed. Call it before ``simulationStep()``.
        Returns the controller's output (``speed``, ``active``, ``reason``, ``distance``, ...)."""
        vid = self.vehicle_id
        if not self._attached:
            traci.vehicle.setSpeedMode(vid, 0)
            traci.vehicle.setLaneChangeMode(vid, 0)
            self._attached = True
        t = float(traci.simulation.getTime())
        dt = float(traci.simulation.getDeltaT())
        own = float(traci.vehicle.getSpeed(vid))
        leader_id, gap, front = _leader(traci, vid, self.leader_range)
        if self.v2v_sender is not None:
            # The speed broadcast is the sender's, measured or not (None once it has left).
            sender = self.v2v_sender
            front = float(traci.vehicle.getSpeed(sender)) if sender in traci.vehicle.getIDList() else None
        out: dict[str, Any] = json.loads(self._inner.step(t, dt, gap, front, own))
        traci.vehicle.setSpeed(vid, out["speed"])
        nan = float("nan")
        self.trace.append(
            leader_id,
            t=t,
            gap=nan if gap is None else gap,
            front_speed=nan if front is None else front,
            speed=own,
            set_speed=out["speed"],
            speed_command=out["speed_command"],
            accel_command=out["accel_command"],
            distance=nan if out["distance"] is None else out["distance"],
            active_flc=1.0 if out["active"] == "flc" else 0.0,
            switches=out["switches"],
            not_associated=1.0 if out["reason"] == "not_associated" else 0.0,
        )
        self.last = out
        return out


def sumo_binary(name: str = "sumo") -> str:
    """Path of a SUMO program (``sumo``, ``netconvert``) from the ``eclipse-sumo`` package, or the
    name itself if it is not installed beside this Python."""
    here = Path(sys.executable).parent / name
    if here.exists():
        return str(here)
    try:
        import sumo  # the eclipse-sumo package

        cand = Path(sumo.SUMO_HOME) / "bin" / name
        if cand.exists():
            return str(cand)
    except ImportError:
        pass
    return name


def straight_road(directory: Union[str, "os.PathLike[str]"], length: float = 5000.0, lanes: int = 1, speed: float = 50.0) -> Path:
    """Writes a straight road of ``length`` m with ``lanes`` lanes (edge ``e``) with ``netconvert``
    into ``directory`` and returns the ``.net.xml`` path."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    nod, edg, net = d / "road.nod.xml", d / "road.edg.xml", d / "road.net.xml"
    nod.write_text(f'<nodes><node id="a" x="0" y="0"/><node id="b" x="{length}" y="0"/></nodes>\n')
    edg.write_text(f'<edges><edge id="e" from="a" to="b" numLanes="{lanes}" speed="{speed}"/></edges>\n')
    subprocess.run([sumo_binary("netconvert"), "-n", str(nod), "-e", str(edg), "-o", str(net), "--no-warnings"], check=True, stdout=subprocess.DEVNULL)
    return net


#: Lead speed profile of the platoon example: accelerate at 2 m/s² to the cruise speed, hold,
#: brake at ``brake_decel`` to a stop at ``brake_at``.
def _lead_speed(t: float, v: float, dt: float, cruise: float, brake_at: float, brake_decel: float) -> float:
    if t >= brake_at:
        return max(0.0, v - brake_decel * dt)
    return min(cruise, v + 2.0 * dt)


@dataclass
class PlatoonOutcome:
    """The platoon example's results, per follower (front to back): flc's metrics
    (:meth:`Trace.summary`, plus ``active_after_outage`` = the law driving 1 s after the outage
    starts and ``switch_to_flc_after`` = seconds from the outage to the hand-over), SUMO's SSM
    device (``ssm``: ``min_ttc`` s and ``max_drac`` m/s² over the vehicle's conflicts as ego), and
    SUMO's collisions."""

    controller: str
    followers: list[dict[str, Any]]
    collisions: list[str]
    outage_at: Optional[float]
    brake_at: float
    join_at: Optional[float] = None

    @property
    def switched_to_flc(self) -> int:
        """How many followers were driven by the FLC 1 s after the outage began."""
        return sum(1 for f in self.followers if f.get("active_after_outage") == "flc")

    @property
    def on_flc_after_join(self) -> list[str]:
        """The followers driven by the FLC 1 s after the joining car began its lane change."""
        return [f["vehicle"] for f in self.followers if f.get("active_after_join") == "flc"]


def _ssm(path: Path) -> dict[str, dict[str, float]]:
    import xml.etree.ElementTree as ET

    out: dict[str, dict[str, float]] = {}
    if not path.exists():
        return out
    for c in ET.parse(path).getroot().iter("conflict"):
        ego = c.get("ego", "")
        rec = out.setdefault(ego, {"min_ttc": float("inf"), "max_drac": 0.0})
        for tag, key, better in (("minTTC", "min_ttc", min), ("maxDRAC", "max_drac", max)):
            el = c.find(tag)
            val = el.get("value") if el is not None else None
            if val not in (None, "NA"):
                rec[key] = better(rec[key], float(val))
    return out


def cacc_platoon(
    followers: int = 5,
    *,
    controller: str = "pipeline",
    cruise_kmh: float = 100.0,
    outage_at: float = 40.0,
    brake_at: float = 45.0,
    brake_decel: float = 6.0,
    step: float = 0.05,
    directory: Optional[Union[str, "os.PathLike[str]"]] = None,
    seed: int = 1,
    join_at: Optional[float] = None,
    join_after: int = 2,
    **overrides: Any,
) -> PlatoonOutcome:
    """The example: a SUMO platoon on a straight 3 km highway lane behind a scripted SUMO lead
    (standstill, 7 m gaps, to ``cruise_kmh``, brakes at ``brake_decel`` to a stop at ``brake_at``).
    Each follower is driven by flc's ``controller`` (default the supervisor pipeline: the V2V PID
    while its predecessor's messages are fresh, the FLC otherwise), listening to its predecessor
    over flc's V2V model; every link goes down at ``outage_at`` for the rest of the run.
    ``controller="sumo-cacc"`` runs SUMO's own CACC model instead (perfect information, no flc):
    the reference. Returns flc's and SUMO's SSM measures per follower.

    Mixed traffic: with ``join_at`` the road has two lanes and a SUMO car without flc
    or V2V (``joiner``, SUMO's Krauss model) drives in the left lane beside the gap behind follower
    ``join_after``, and at ``join_at`` changes into the platoon's lane in 3 s. Each follower listens
    to its predecessor's V2V whatever it measures, so follower ``join_after + 1`` must find that
    the car in front is not its V2V sender and hand over to the FLC (reason ``not_associated``);
    ``outage_at=None`` keeps every link up."""
    import tempfile

    import libsumo as traci

    tmp = None
    if directory is None:
        tmp = tempfile.TemporaryDirectory()
        directory = tmp.name
    d = Path(directory)
    try:
        lanes = 1 if join_at is None else 2
        if join_at is not None and not 1 <= join_after < followers:
            raise ValueError(f"join_after: must be in [1, {followers - 1}], got {join_after}")
        net = straight_road(d, 3000.0, lanes=lanes, speed=40.0)
        sc = Scenario.paper(speed_kmh=cruise_kmh, controller="pipeline" if controller == "sumo-cacc" else controller, **overrides)
        length = float(sc["follower"]["vehicle"]["length"])
        model = 'carFollowModel="CACC"' if controller == "sumo-cacc" else 'carFollowModel="Krauss" sigma="0"'
        vehicles = [f'<vehicle id="lead" type="lead" route="r" depart="0" departPos="{30.0 + followers * (7.0 + length) + length}" departSpeed="0" departLane="0" insertionChecks="none"/>']
        ids = [f"f{k}" for k in range(1, followers + 1)]
        for k, vid in enumerate(ids):
            pos = 30.0 + (followers - 1 - k) * (7.0 + length) + length
            vehicles.append(f'<vehicle id="{vid}" type="follower" route="r" depart="0" departPos="{pos}" departSpeed="0" departLane="0" insertionChecks="none"/>')
        if join_at is not None:
            pos = 30.0 + (followers - join_after - 0.5) * (7.0 + length) + length
            vehicles.append(f'<vehicle id="joiner" type="joiner" route="r" depart="0" departPos="{pos}" departSpeed="0" departLane="1" insertionChecks="none"/>')
        common = f'length="{length}" minGap="2.5" maxSpeed="40" speedFactor="1" speedDev="0"'
        (d / "platoon.rou.xml").write_text(
            "<routes>\n"
            f'<vType id="lead" {common} accel="10" decel="10" emergencyDecel="10" sigma="0"/>\n'
            f'<vType id="follower" {common} accel="2.6" decel="8" emergencyDecel="9" {model}/>\n'
            f'<vType id="joiner" {common} accel="2.6" decel="4.5" emergencyDecel="9" carFollowModel="Krauss" sigma="0"/>\n'
            '<route id="r" edges="e"/>\n' + "\n".join(vehicles) + "\n</routes>\n"
        )
        ssm = d / "ssm.xml"
        traci.start(
            [sumo_binary(), "-n", str(net), "-r", str(d / "platoon.rou.xml"), "--step-length", str(step), "--step-method.ballistic", "true",
             "--no-step-log", "--no-warnings", "--collision.action", "warn", "--collision.check-junctions", "true",
             "--device.ssm.probability", "1", "--device.ssm.measures", "TTC DRAC", "--device.ssm.file", str(ssm),
             "--device.ssm.range", "100", "--seed", str(seed)]
        )
        collisions: list[str] = []
        drivers: list[FlcVehicle] = []
        try:
            traci.simulationStep()
            traci.vehicle.setSpeedMode("lead", 0)
            if join_at is not None:
                traci.vehicle.setLaneChangeMode("joiner", 0)  # no lane change of its own; the scripted one at join_at
            if controller != "sumo-cacc":
                # JSON has no inf: "for the rest of the run"
                outage = [] if outage_at is None else [{"start": outage_at, "end": 1e9}]
                senders = ["lead"] + ids[:-1] if join_at is not None else [None] * len(ids)
                drivers = [FlcVehicle(vid, sc, seed=seed + k, v2v_outages=outage, v2v_sender=senders[k]) for k, vid in enumerate(ids)]
            traces = {vid: Trace(vid) for vid in ids}
            t = float(traci.simulation.getTime())
            while t < brake_at + 20.0:
                v = float(traci.vehicle.getSpeed("lead"))
                traci.vehicle.setSpeed("lead", _lead_speed(t, v, step, cruise_kmh / 3.6, brake_at, brake_decel))
                if join_at is not None:
                    _joiner(traci, ids[join_after - 1], ids[join_after], length, t, join_at)
                for drv in drivers:
                    drv.step(traci)
                if not drivers:
                    for vid in ids:
                        _observe(traci, traces[vid], vid, t)
                traci.simulationStep()
                t = float(traci.simulation.getTime())
                collisions += [f"{c.collider}->{c.victim}" for c in traci.simulation.getCollisions()]
        finally:
            traci.close()
        result = []
        for k, vid in enumerate(ids):
            tr = drivers[k].trace if drivers else traces[vid]
            s = tr.summary()
            tt = tr.array("t")
            if drivers:
                for name, at in (("outage", outage_at), ("join", join_at)):
                    if at is None:
                        continue
                    after = np.nonzero(tt >= at + 1.0)[0]
                    s[f"active_after_{name}"] = "flc" if after.size and tr.columns["active_flc"][after[0]] == 1.0 else "pid"
                    flc_on = np.nonzero((tt >= at) & (tr.array("active_flc") == 1.0))[0]
                    key = "switch_to_flc_after" if name == "outage" else "switch_to_flc_after_join"
                    s[key] = float(tt[flc_on[0]] - at) if flc_on.size else float("nan")
                s["time_not_associated"] = float(np.sum(tr.array("not_associated")) * step)
            s["ssm"] = _ssm(ssm).get(vid, {"min_ttc": float("inf"), "max_drac": 0.0})
            result.append(s)
        return PlatoonOutcome(controller, result, collisions, outage_at, brake_at, join_at)
    finally:
        if tmp is not None:
            tmp.cleanup()


def _joiner(traci: Any, front: str, back: str, length: float, t: float, join_at: float) -> None:
    """The joining car of :func:`cacc_platoon`: until its lane change is done it keeps beside the
    middle of the gap between followers ``front`` and ``back`` (speed set each step), at
    ``join_at`` it changes into lane 0 in 3 s; then SUMO's car-following model drives it."""
    if traci.vehicle.getLaneIndex("joiner") == 0:
        traci.vehicle.setSpeed("joiner", -1.0)  # in the platoon's lane: SUMO's model drives
        return
    x_front = float(traci.vehicle.getLanePosition(front)) - length
    x_back = float(traci.vehicle.getLanePosition(back))
    x = float(traci.vehicle.getLanePosition("joiner")) - length / 2.0
    v = float(traci.vehicle.getSpeed(front))
    traci.vehicle.setSpeed("joiner", max(0.0, v + 0.5 * (0.5 * (x_front + x_back) - x)))
    if t >= join_at:
        traci.vehicle.changeLane("joiner", 0, 3.0)


def _leader(traci: Any, vid: str, leader_range: float) -> tuple[str, Optional[float], Optional[float]]:
    """SUMO's leader of `vid`: its id ("" if none), the bumper gap (``getLeader``'s distance is
    the gap minus the follower's ``minGap``) and its speed."""
    leader = traci.vehicle.getLeader(vid, leader_range)
    if not (leader and leader[0]):
        return "", None, None
    return leader[0], float(leader[1]) + float(traci.vehicle.getMinGap(vid)), float(traci.vehicle.getSpeed(leader[0]))


def _observe(traci: Any, tr: Trace, vid: str, t: float) -> None:
    """Records a SUMO-driven vehicle in a :class:`Trace` (for the reference run)."""
    leader_id, gap, front = _leader(traci, vid, 250.0)
    g = float("nan") if gap is None else gap
    own = float(traci.vehicle.getSpeed(vid))
    tr.append(leader_id, t=t, gap=g, front_speed=float("nan") if front is None else front, speed=own, set_speed=own,
              speed_command=own, accel_command=float(traci.vehicle.getAcceleration(vid)), distance=g, active_flc=0.0, switches=0.0,
              not_associated=0.0)


def _workdir(directory: Optional[Union[str, "os.PathLike[str]"]]) -> tuple[Path, Any]:
    """``directory`` as a path, or a fresh temporary directory (and the handle that removes it)."""
    import tempfile

    if directory is not None:
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        return d, None
    tmp = tempfile.TemporaryDirectory()
    return Path(tmp.name), tmp


# ---------------------------------------------------------------------------------------------
# flc in SUMO against flc's own run (docs/sumo.md, "In SUMO, against flc's own ideal run")

#: The validation setting of :func:`replay_ideal_run`: ideal perception (the true gap and the
#: leader's true speed), no actuator dead time or lag, a clean sensor schedule.
VALIDATION: dict[str, Any] = {
    "follower_perception": "ideal",
    "follower.vehicle.dead_time": 0.0,
    "follower.vehicle.lag": 0.0,
    "lidar_jitter": 0.0,
    "lidar_scan_drop_prob": 0.0,
    "lidar_latency_frames": 0,
}


@dataclass
class Replay:
    """A SUMO run replaying flc's own run (:func:`replay_run`): ``speed`` and ``gap`` are the SUMO
    follower's speed (m/s) and bumper gap (m, from the lane positions) after each step, one per
    sample of ``run``; ``vehicle`` the :class:`FlcVehicle` that drove it (its ``trace``)."""

    run: RunResult
    speed: np.ndarray
    gap: np.ndarray
    vehicle: FlcVehicle

    @property
    def speed_difference(self) -> np.ndarray:
        """SUMO's follower speed minus flc's, per sample, m/s."""
        return self.speed - np.asarray(self.run.follower_speed, dtype=float)

    @property
    def gap_difference(self) -> np.ndarray:
        """SUMO's gap minus flc's, per sample, m."""
        return self.gap - np.asarray(self.run.gap, dtype=float)

    def summary(self) -> dict[str, float]:
        """The figures of docs/sumo.md's table: ``speed_rms``, ``speed_max`` (m/s) and ``gap_max``
        (m) of the differences, the final gaps ``final_gap_flc`` / ``final_gap_sumo`` and SUMO's
        smallest gap ``min_gap_sumo`` (m)."""
        dv, dg = self.speed_difference, self.gap_difference
        return {
            "speed_rms": float(np.sqrt(np.mean(dv**2))),
            "speed_max": float(np.abs(dv).max()),
            "gap_max": float(np.abs(dg).max()),
            "final_gap_flc": float(np.asarray(self.run.gap)[-1]),
            "final_gap_sumo": float(self.gap[-1]),
            "min_gap_sumo": float(self.gap.min()),
        }


def replay_run(
    scenario: Scenario,
    flc_run: RunResult,
    *,
    step: Optional[float] = None,
    directory: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> Replay:
    """A SUMO lead replaying ``flc_run``'s lead speed step by step (``setSpeed``, speed mode 0),
    the SUMO follower driven by an :class:`FlcVehicle` configured by ``scenario``, both starting at
    standstill ``scenario``'s initial gap apart on a straight 3 km road; SUMO step ``step``
    (default ``scenario``'s ``physics_dt``), ballistic positions. One SUMO step per sample of
    ``flc_run``. The network and routes are written into ``directory`` (default: a temporary
    one)."""
    import libsumo as traci

    dt = float(scenario["physics_dt"]) if step is None else float(step)
    d, tmp = _workdir(directory)
    try:
        L = float(scenario["lead"]["vehicle"]["length"])
        Lf = float(scenario["follower"]["vehicle"]["length"])
        gap0 = float(scenario["follower"]["initial_gap"])
        net = straight_road(d, 3000.0)
        rou = d / "replay.rou.xml"
        common = 'minGap="2.5" accel="10" decel="10" emergencyDecel="10" maxSpeed="60" speedFactor="1" speedDev="0" sigma="0"'
        rou.write_text(
            "<routes>\n"
            f'<vType id="leadT" length="{L}" {common}/>\n<vType id="follT" length="{Lf}" {common}/>\n<route id="r" edges="e"/>\n'
            f'<vehicle id="lead" type="leadT" route="r" depart="0" departPos="{100.0 + gap0 + L}" departSpeed="0" insertionChecks="none"/>\n'
            '<vehicle id="foll" type="follT" route="r" depart="0" departPos="100" departSpeed="0" insertionChecks="none"/>\n</routes>\n'
        )
        traci.start([sumo_binary(), "-n", str(net), "-r", str(rou), "--step-length", str(dt), "--step-method.ballistic", "true",
                     "--no-step-log", "--no-warnings", "--collision.action", "warn"])
        try:
            traci.simulationStep()
            traci.vehicle.setSpeedMode("lead", 0)
            drv = FlcVehicle("foll", scenario)
            speeds, gaps = [], []
            lead_speed = np.asarray(flc_run.lead_speed, dtype=float)
            for k in range(len(flc_run.t)):
                traci.vehicle.setSpeed("lead", float(lead_speed[k]))
                drv.step(traci)
                traci.simulationStep()
                speeds.append(float(traci.vehicle.getSpeed("foll")))
                gaps.append(float(traci.vehicle.getLanePosition("lead")) - L - float(traci.vehicle.getLanePosition("foll")))
        finally:
            traci.close()
        return Replay(flc_run, np.array(speeds), np.array(gaps), drv)
    finally:
        if tmp is not None:
            tmp.cleanup()


def replay_ideal_run(
    controller: str, speed_kmh: float, *, directory: Optional[Union[str, "os.PathLike[str]"]] = None
) -> Replay:
    """The paper experiment at ``speed_kmh`` with ``controller`` in :data:`VALIDATION`'s setting,
    run by flc and replayed in SUMO at the same step (:func:`replay_run`): what the two worlds'
    bookkeeping alone makes different (docs/sumo.md)."""
    sc = Scenario.paper(speed_kmh=speed_kmh, controller=controller, **VALIDATION)
    return replay_run(sc, run(sc), directory=directory)


# ---------------------------------------------------------------------------------------------
# flc's baselines against SUMO's own models in closed loop (docs/sumo.md, docs/baselines.md)

#: SUMO's vType parameters of each model and the flc law's keyword overrides that mean the same
#: (docs/baselines.md, "Checking the baselines against SUMO"); the SUMO step is the law's
#: ``command_gain``.
SUMO_MODELS: dict[str, tuple[str, dict[str, float]]] = {
    "idm": ('carFollowModel="IDM" accel="2.6" decel="4.5" emergencyDecel="9" tau="1.0" minGap="2.5" delta="4" stepping="0.25"',
            {"idm_desired_speed": 50.0, "idm_time_headway": 1.0, "idm_min_gap": 2.5, "idm_max_accel": 2.6, "idm_comfort_decel": 4.5,
             "idm_delta": 4.0, "idm_max_decel": 9.0}),
    "acc": ('carFollowModel="ACC" accel="2.6" decel="8" emergencyDecel="9" tau="1.0" minGap="2.5"',
            {"acc_desired_speed": 50.0, "acc_headway_time": 1.0, "acc_min_gap": 2.5, "acc_decel": 8.0, "acc_lead_decel": 10.0,
             "acc_max_accel": 2.6}),
}


def _paper_lead(x: float, v: float, step: float, v_max: float, state: dict[str, bool]) -> float:
    """The paper experiment's lead in SUMO: 2.5 m/s² up to ``v_max``, 6 m/s² to a stop from 650 m."""
    if state.get("braking") or x >= 650.0:
        state["braking"] = True
        return max(0.0, v - 6.0 * step)
    return min(v_max, v + 2.5 * step)


def closed_loop(
    law: str,
    speed_kmh: float,
    *,
    flc_drives: bool,
    step: float = 0.1,
    directory: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> np.ndarray:
    """The paper experiment in SUMO (Euler steps, SUMO's default; a scripted lead to
    ``speed_kmh``, braking at 6 m/s² from 650 m), the follower either SUMO's own model ``law``
    (``"idm"``, ``"acc"``: :data:`SUMO_MODELS`) or, with ``flc_drives``, flc's law of the same
    name with SUMO's parameters, ideal perception and direct actuation. Returns the follower's
    speed after each step (m/s) until both stand (at most 160 s)."""
    import libsumo as traci

    if law not in SUMO_MODELS:
        raise ValueError(f"law: expected one of {', '.join(SUMO_MODELS)}, got {law!r}")
    vtype, params = SUMO_MODELS[law]
    d, tmp = _workdir(directory)
    try:
        net = straight_road(d, 5000.0)
        rou = d / f"{law}-{flc_drives}.rou.xml"
        common = 'length="5.0" maxSpeed="50" speedFactor="1" speedDev="0"'
        rou.write_text(
            "<routes>\n"
            f'<vType id="leadT" {common} carFollowModel="Krauss" accel="10" decel="10" emergencyDecel="10" sigma="0" minGap="2.5"/>\n'
            f'<vType id="follT" {common} {vtype}/>\n<route id="r" edges="e"/>\n'
            '<vehicle id="lead" type="leadT" route="r" depart="0" departPos="112" departSpeed="0" insertionChecks="none"/>\n'
            '<vehicle id="foll" type="follT" route="r" depart="0" departPos="100" departSpeed="0" insertionChecks="none"/>\n</routes>\n'
        )
        traci.start([sumo_binary(), "-n", str(net), "-r", str(rou), "--step-length", str(step), "--no-step-log", "--no-warnings",
                     "--collision.action", "warn"])
        speeds: list[float] = []
        try:
            traci.simulationStep()
            traci.vehicle.setSpeedMode("lead", 0)
            drv = None
            if flc_drives:
                kw: dict[str, Any] = {f"{law}_command_gain": step, **params}
                sc = Scenario.paper(controller=law, follower_perception="ideal", lidar_rate_hz=1.0 / step, lidar_jitter=0.0,
                                    lidar_scan_drop_prob=0.0, lidar_latency_frames=0, **kw)
                drv = FlcVehicle("foll", sc, actuation="direct")
            state: dict[str, bool] = {}
            t = 0.0
            while t < 160.0:
                v, x = float(traci.vehicle.getSpeed("lead")), float(traci.vehicle.getLanePosition("lead"))
                traci.vehicle.setSpeed("lead", _paper_lead(x - 112.0, v, step, speed_kmh / 3.6, state))
                if drv is not None:
                    drv.step(traci)
                traci.simulationStep()
                t = float(traci.simulation.getTime())
                speeds.append(float(traci.vehicle.getSpeed("foll")))
                if v == 0.0 and speeds[-1] == 0.0 and t > 10.0:
                    break
        finally:
            traci.close()
        return np.array(speeds)
    finally:
        if tmp is not None:
            tmp.cleanup()


@dataclass
class ClosedLoopDifference:
    """:func:`closed_loop` twice: the follower's speeds with SUMO's model (``sumo``) and with flc's
    law (``flc``), m/s, one per step."""

    law: str
    speed_kmh: float
    sumo: np.ndarray
    flc: np.ndarray

    @property
    def difference(self) -> np.ndarray:
        """``|flc - sumo|`` over the steps both runs have, m/s."""
        n = min(len(self.sumo), len(self.flc))
        return np.abs(self.flc[:n] - self.sumo[:n])

    @property
    def max_difference(self) -> float:
        """The largest speed difference over the whole run, m/s."""
        err = self.difference
        return float(err.max()) if err.size else 0.0


def closed_loop_difference(
    law: str, speed_kmh: float, *, step: float = 0.1, directory: Optional[Union[str, "os.PathLike[str]"]] = None
) -> ClosedLoopDifference:
    """SUMO's model ``law`` and flc's law of the same name on the same scripted lead
    (:func:`closed_loop`), each in its own SUMO run."""
    ref = closed_loop(law, speed_kmh, flc_drives=False, step=step, directory=directory)
    ours = closed_loop(law, speed_kmh, flc_drives=True, step=step, directory=directory)
    return ClosedLoopDifference(law, float(speed_kmh), ref, ours)


# ---------------------------------------------------------------------------------------------
# flc's surrogate safety measures against SUMO's SSM device (docs/v2v-and-metrics.md §3.1)

#: The SSM trajectory's SUMO step (s) and vehicle length (m).
SSM_STEP = 0.1
SSM_LENGTH = 5.0


def _ssm_follower_speed(t: float, v: float) -> float:
    """A late-braking follower: 20 m/s until 4 s, then 4 m/s² down to the lead's 10 m/s."""
    return 20.0 if t < 4.0 else max(10.0, v - 4.0 * SSM_STEP)


def ssm_trajectory(directory: Optional[Union[str, "os.PathLike[str]"]] = None) -> tuple[dict[str, np.ndarray], "ET.Element"]:
    """A follower at 20 m/s 60 m (bumper to bumper) behind a lead at 10 m/s, both scripted in SUMO
    (speed mode 0, step :data:`SSM_STEP`, ballistic): the follower brakes at 4 m/s² from 4 s down
    to 10 m/s. SUMO's SSM device logs TTC, DRAC, PET, SGAP and TGAP (``--precision 6``,
    trajectories on). Returns flc's series columns (one row per SUMO state: the gap from the lane
    positions, bumper to bumper without ``minGap``) and the root of SUMO's SSM log."""
    import xml.etree.ElementTree as ET

    import libsumo as traci

    d, tmp = _workdir(directory)
    try:
        net = straight_road(d, 3000.0, speed=40.0)
        rou = d / "ssm.rou.xml"
        rou.write_text(
            "<routes>\n"
            f'<vType id="v" length="{SSM_LENGTH}" minGap="2.5" maxSpeed="40" accel="10" decel="10" emergencyDecel="10" sigma="0" speedFactor="1" speedDev="0"/>\n'
            '<route id="r" edges="e"/>\n'
            f'<vehicle id="lead" type="v" route="r" depart="0" departPos="{100.0 + 60.0 + SSM_LENGTH}" departSpeed="10" insertionChecks="none"/>\n'
            '<vehicle id="foll" type="v" route="r" depart="0" departPos="100" departSpeed="20" insertionChecks="none"/>\n'
            "</routes>\n"
        )
        ssm = d / "ssm.xml"
        traci.start(
            [sumo_binary(), "-n", str(net), "-r", str(rou), "--step-length", str(SSM_STEP), "--step-method.ballistic", "true",
             "--no-step-log", "--no-warnings", "--precision", "6", "--collision.action", "warn",
             "--device.ssm.probability", "1", "--device.ssm.measures", "TTC DRAC PET SGAP TGAP",
             "--device.ssm.thresholds", "3.0 3.0 2.0 0.2 0.5", "--device.ssm.range", "100", "--device.ssm.trajectories", "true",
             "--device.ssm.file", str(ssm)]
        )
        rows: dict[str, list[float]] = {k: [] for k in ("t", "gap", "lead_speed", "follower_speed", "follower_accel", "lead_accel")}

        def record() -> None:
            rows["t"].append(float(traci.simulation.getTime()))
            rows["gap"].append(float(traci.vehicle.getLanePosition("lead")) - SSM_LENGTH - float(traci.vehicle.getLanePosition("foll")))
            rows["lead_speed"].append(float(traci.vehicle.getSpeed("lead")))
            rows["follower_speed"].append(float(traci.vehicle.getSpeed("foll")))
            rows["follower_accel"].append(float(traci.vehicle.getAcceleration("foll")))
            rows["lead_accel"].append(float(traci.vehicle.getAcceleration("lead")))

        try:
            traci.simulationStep()
            for v in ("lead", "foll"):
                traci.vehicle.setSpeedMode(v, 0)
            record()
            while traci.simulation.getTime() < 20.0:
                t = float(traci.simulation.getTime())
                traci.vehicle.setSpeed("lead", 10.0)
                traci.vehicle.setSpeed("foll", _ssm_follower_speed(t, float(traci.vehicle.getSpeed("foll"))))
                traci.simulationStep()
                record()
        finally:
            traci.close()
        return {k: np.asarray(v) for k, v in rows.items()}, ET.parse(ssm).getroot()
    finally:
        if tmp is not None:
            tmp.cleanup()


def ssm_value(root: "ET.Element", path: str) -> float:
    """The ``value`` attribute of the SSM log element at ``path`` (ElementTree syntax), as a
    float (NaN for ``NA``). Raises ``KeyError`` if there is no such element."""
    el = root.find(path)
    if el is None:
        raise KeyError(f"no `{path}` in SUMO's SSM output")
    v = el.get("value", "NA")
    return float("nan") if v == "NA" else float(v)


def ssm_span(root: "ET.Element", tag: str, ego: str = "foll") -> list[float]:
    """The per-step values of ``ego``'s conflict span ``tag`` (e.g. ``TTCSpan``), NaN for ``NA``."""
    el = root.find(f"conflict[@ego='{ego}']/{tag}")
    if el is None:
        raise KeyError(f"no `{tag}` of ego `{ego}` in SUMO's SSM output")
    return [float("nan") if v == "NA" else float(v) for v in el.get("values", "").split()]


def tet_tit_from_ttc_span(ttc: Sequence[float], step: float, threshold: float = 3.0) -> tuple[float, float]:
    """TET (s) and TIT (s²) rebuilt from a per-step TTC span (SUMO outputs neither): each finite
    value covers one step; TET = step × the number of values ≤ ``threshold``, TIT = step ×
    Σ (``threshold`` − value) over them."""
    exposed = [x for x in ttc if math.isfinite(x) and x <= threshold]
    return step * len(exposed), step * sum(threshold - x for x in exposed)


@dataclass
class SsmComparison:
    """flc's metrics of :func:`ssm_trajectory` (``flc``: :func:`flc.metrics_from_series`) beside
    SUMO's SSM outputs of the same run (``sumo``: ``min_ttc`` = ``minTTC``, ``max_drac`` =
    ``maxDRAC``, ``min_gap`` = ``minSGAP``, ``min_time_headway`` = ``minTGAP``, ``tet`` / ``tit``
    rebuilt from ``TTCSpan``), SUMO's PET element's value (``sumo_pet``, ``"NA"`` for following),
    and the min TTC ``getLeader``'s distance (the gap minus ``minGap`` 2.5 m) would give."""

    flc: dict[str, Any]
    sumo: dict[str, float]
    sumo_pet: Optional[str]
    min_ttc_leader_distance: float
    series: dict[str, np.ndarray]

    def difference(self, key: str) -> float:
        """flc's value minus SUMO's."""
        return float(self.flc[key]) - float(self.sumo[key])


def ssm_comparison(directory: Optional[Union[str, "os.PathLike[str]"]] = None) -> SsmComparison:
    """Runs :func:`ssm_trajectory` and compares flc's metrics with SUMO's SSM outputs."""
    cols, root = ssm_trajectory(directory)
    m = metrics_from_series(cols)
    tet, tit = tet_tit_from_ttc_span(ssm_span(root, "TTCSpan"), SSM_STEP)
    sumo = {
        "min_ttc": ssm_value(root, "conflict[@ego='foll']/minTTC"),
        "max_drac": ssm_value(root, "conflict[@ego='foll']/maxDRAC"),
        "min_gap": ssm_value(root, "globalMeasures[@ego='foll']/minSGAP"),
        "min_time_headway": ssm_value(root, "globalMeasures[@ego='foll']/minTGAP"),
        "tet": tet,
        "tit": tit,
    }
    pet = root.find("conflict[@ego='foll']/PET")
    closing = cols["follower_speed"] - cols["lead_speed"]
    ok = closing > 1e-6
    leader_ttc = float(np.min((cols["gap"][ok] - 2.5) / closing[ok])) if ok.any() else float("inf")
    return SsmComparison(m, sumo, None if pet is None else pet.get("value"), leader_ttc, cols)


# ---------------------------------------------------------------------------------------------
# The committed SUMO tables (docs/figures/sumo-tables.json; `python -m flc sumo-tables --out docs/figures`)

#: The data file the SUMO blocks of docs/sumo.md, docs/v2v-and-metrics.md and docs/baselines.md render.
TABLES_FILE = "sumo-tables.json"
#: The rows of docs/sumo.md's replay table: (controller, km/h) of :func:`replay_ideal_run`.
REPLAY_CASES: tuple[tuple[str, float], ...] = (("flc", 50.0), ("flc", 90.0), ("flc", 130.0), ("flc-robust", 70.0), ("idm", 50.0))
#: The speeds (km/h) of docs/sumo.md's closed-loop table, for each law of :data:`SUMO_MODELS`.
CLOSED_LOOP_SPEEDS_KMH: tuple[float, ...] = (30.0, 50.0, 70.0, 90.0, 110.0, 130.0)
#: :func:`cacc_platoon`'s arguments of docs/sumo.md's platoon table (the V2V outage) ...
PLATOON_OUTAGE: dict[str, Any] = {"followers": 5, "cruise_kmh": 100.0, "outage_at": 40.0, "brake_at": 45.0}
#: ... and of its join table (a car without V2V joins behind follower 2; every link up).
PLATOON_JOIN: dict[str, Any] = {"followers": 5, "cruise_kmh": 100.0, "outage_at": None, "join_at": 30.0, "join_after": 2, "brake_at": 45.0}
#: The join run's association switched off (the overrides of :func:`cacc_platoon`).
NO_ASSOCIATION: dict[str, Any] = {"supervisor.association.enabled": False}


def _json_safe(x: Any) -> Any:
    """Floats as JSON can hold them (NaN and ±inf as ``null``), NumPy scalars as Python ones."""
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else None
    return x


def replay_record(controller: str, speed_kmh: float, replay: Replay) -> dict[str, Any]:
    """One row of the replay table: :meth:`Replay.summary`, the time of the largest speed
    difference (``speed_max_t``, s), the first speed difference above 1e-12 m/s
    (``first_difference`` m/s at ``first_difference_t`` s; ``null`` if none) and the largest gap
    difference before it (``gap_before_first``, m)."""
    dv, dg = replay.speed_difference, replay.gap_difference
    t = np.asarray(replay.run.t, dtype=float)
    k = np.nonzero(np.abs(dv) > 1e-12)[0]
    first: dict[str, Any] = {"first_difference": None, "first_difference_t": None, "gap_before_first": float(np.abs(dg).max())}
    if k.size:
        first = {"first_difference": float(dv[k[0]]), "first_difference_t": float(t[k[0]]),
                 "gap_before_first": float(np.abs(dg[:k[0]]).max()) if k[0] > 0 else 0.0}
    out: dict[str, Any] = _json_safe({"controller": controller, "speed_kmh": float(speed_kmh), **replay.summary(),
                                      "speed_max_t": float(t[int(np.abs(dv).argmax())]), **first})
    return out


def closed_loop_record(d: ClosedLoopDifference) -> dict[str, Any]:
    """One cell of the closed-loop table: the law, the speed, the largest speed difference (m/s)
    and the number of steps of each run."""
    out: dict[str, Any] = _json_safe({"law": d.law, "speed_kmh": d.speed_kmh, "max_difference": d.max_difference,
                                      "steps_sumo": len(d.sumo), "steps_flc": len(d.flc)})
    return out


def platoon_record(o: PlatoonOutcome) -> dict[str, Any]:
    """A :class:`PlatoonOutcome` as JSON data (per follower its metrics and SUMO's SSM measures;
    an SSM entry without a conflict is ``min_ttc`` ``null``)."""
    out: dict[str, Any] = _json_safe({"controller": o.controller, "followers": o.followers, "collisions": o.collisions,
                                      "outage_at": o.outage_at, "brake_at": o.brake_at, "join_at": o.join_at})
    return out


def ssm_record(c: SsmComparison) -> dict[str, Any]:
    """An :class:`SsmComparison` as JSON data: flc's and SUMO's values of the compared metrics,
    flc's and SUMO's PET, and the min TTC of ``getLeader``'s distance."""
    out: dict[str, Any] = _json_safe({"flc": {k: c.flc[k] for k in c.sumo}, "sumo": c.sumo, "flc_pet": c.flc.get("pet"),
                                      "sumo_pet": c.sumo_pet, "min_ttc_leader_distance": c.min_ttc_leader_distance})
    return out


def compute_tables(progress: Optional[Any] = None) -> dict[str, Any]:
    """Every SUMO figure the documents state (about 25 SUMO runs; tens of seconds): the replay
    table, the closed-loop table, the platoon's outage and join runs (with SUMO's CACC and with
    the association off) and the SSM comparison. ``progress(text)`` is called after each part."""
    from importlib.metadata import PackageNotFoundError, version

    say = progress or (lambda _text: None)
    try:
        sumo_version = version("eclipse-sumo")
    except PackageNotFoundError:  # SUMO from elsewhere
        sumo_version = "unknown"
    out: dict[str, Any] = {"command": "python -m flc sumo-tables --out docs/figures", "sumo": sumo_version}
    out["replay"] = [replay_record(c, v, replay_ideal_run(c, v)) for c, v in REPLAY_CASES]
    say("replay table")
    out["closed_loop"] = [closed_loop_record(closed_loop_difference(law, v)) for law in SUMO_MODELS for v in CLOSED_LOOP_SPEEDS_KMH]
    say("closed-loop table")
    out["platoon_outage"] = {"arguments": PLATOON_OUTAGE, "flc": platoon_record(cacc_platoon(**PLATOON_OUTAGE)),
                             "sumo_cacc": platoon_record(cacc_platoon(**PLATOON_OUTAGE, controller="sumo-cacc"))}
    say("platoon outage table")
    out["platoon_join"] = {"arguments": PLATOON_JOIN, "flc": platoon_record(cacc_platoon(**PLATOON_JOIN)),
                           "no_association": platoon_record(cacc_platoon(**PLATOON_JOIN, **NO_ASSOCIATION))}
    say("platoon join table")
    out["ssm"] = ssm_record(ssm_comparison())
    say("SSM comparison")
    return out


def write_tables(out_dir: Union[str, "os.PathLike[str]"], progress: Optional[Any] = None) -> Path:
    """Computes :func:`compute_tables` and writes it as ``out_dir/sumo-tables.json``."""
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    path = d / TABLES_FILE
    path.write_text(json.dumps(compute_tables(progress), indent=1) + "\n", encoding="utf-8")
    return path


def read_tables(path: Optional[Union[str, "os.PathLike[str]"]] = None) -> dict[str, Any]:
    """The committed SUMO tables (default: the repository's ``docs/figures/sumo-tables.json``)."""
    from .reproduction import ROOT

    p = Path(path) if path is not None else ROOT / "docs" / "figures" / TABLES_FILE
    data: dict[str, Any] = json.loads(p.read_text(encoding="utf-8"))
    return data
