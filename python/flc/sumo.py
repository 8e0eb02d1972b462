"""flc's controllers driving SUMO vehicles (extra ``flc[sumo]``: ``eclipse-sumo`` and ``libsumo``).

A :class:`FlcVehicle` hands one SUMO vehicle's longitudinal control to an flc follower pipeline
(``flc_sim::ExternalFollower``): any controller flc has (``flc``, ``flc-robust``, ``pid``,
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
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from . import _flc
from ._scenario import Scenario

__all__ = ["FlcVehicle", "Trace", "straight_road", "sumo_binary"]

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
    subprocess.run([sumo_binary("netconvert"), "-n", str(nod), "-e", str(edg), "-o", str(net), "--no-warnings"], check=True)
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

    Mixed traffic (issue 25): with ``join_at`` the road has two lanes and a SUMO car without flc
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
