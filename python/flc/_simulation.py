"""Stepping the simulator from Python: ``flc.Simulation`` (typed facade over ``flc._flc.Simulation``).

The loop is the simulator's own (the one ``flc.run`` runs); for each follower driven from Python
it pauses at every scan the follower's LiDAR delivers, after the detector and the lateral control
ran, and waits for the longitudinal command. Everything else (lateral control, the lead, traffic,
V2V, sensors, actuators, contacts) stays in Rust.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _flc
from ._flc import ParameterError
from ._run import RunResult, _result
from ._scenario import Scenario


@dataclass(frozen=True)
class SpeedCommand:
    """A speed command, m/s, held until the next one (the low-level speed controller and the
    vehicle model turn it into motion, as they do the scenario's law's)."""

    speed: float


@dataclass(frozen=True)
class AccelCommand:
    """An acceleration demand, m/s², held until the next command; it bypasses the low-level
    speed controller (the vehicle model's dead time, lag and limits still apply)."""

    accel: float


#: What :meth:`Simulation.step` takes per driven follower: ``None`` (the scenario's own
#: controller decides this period), a number (a speed or acceleration command as the
#: simulation's ``command`` says), :class:`SpeedCommand` or :class:`AccelCommand`.
Command = Union[None, float, int, SpeedCommand, AccelCommand]


@dataclass(frozen=True)
class GroundTruth:
    """The truth about a follower at :attr:`t` (for evaluation and rewards; no controller sees it).

    ``gap``: bumper-to-bumper gap to the vehicle in front, m (the ``gap`` column of
    :attr:`RunResult.series`); ``front_speed`` / ``front_accel``: that vehicle's, m/s and m/s²;
    ``speed`` / ``accel``: the follower's own; ``x``, ``y`` (m), ``yaw`` (rad) its pose;
    ``lateral_offset`` from the centreline, m (+ left); ``collision``: its first contact with
    anything (the ``collision_info`` of :attr:`RunResult.collision`), ``None`` without one.
    """

    t: float
    gap: float
    front_speed: float
    front_accel: float
    speed: float
    accel: float
    x: float
    y: float
    yaw: float
    lateral_offset: float
    collision: Optional[dict[str, Any]]


@dataclass(frozen=True)
class Observation:
    """What a driven follower's pipeline got at its last scan, and the ground truth now.

    Measured (what a controller may use): ``t`` (time of the scan, s), ``distance`` (the gap the
    longitudinal law gets, ``LF_dist``: the detector's distance minus the follower's
    ``distance_offset``, m; ``None``: no lead detected), ``own_speed`` (m/s), ``dt`` (s since the
    previous scan), ``v2v_speed`` / ``v2v_seq`` (the latest V2V message received: the speed it
    carries, m/s, and its sequence number; ``None`` before any), ``v2v_age`` (s since it arrived),
    ``v2v_new`` (a message arrived since the previous scan: what the PID family gets),
    ``detection`` (the detector's lead in the sensor frame: ``x``, ``y``, ``distance``, ``width``,
    ``depth``, ``points``, ``confidence``; ``None``), ``detector_status``, ``clusters``,
    ``ranges`` (the scan as ``beams`` range beams over the LiDAR's field of view, m; with
    ``beams``), ``points`` (the raw scan, ``(N, 2)`` sensor frame, m; with ``lidar_points``),
    ``lead_speed`` (the front vehicle's true speed: ideal perception only).

    ``fresh``: this scan is the one the simulation paused at (its command is due); ``done``:
    the run is over. ``truth``: :class:`GroundTruth` (evaluation only).
    """

    follower: int
    t: float
    distance: Optional[float]
    own_speed: float
    dt: float
    v2v_speed: Optional[float]
    v2v_seq: Optional[int]
    v2v_age: Optional[float]
    v2v_new: bool
    detection: Optional[dict[str, Any]]
    detector_status: Optional[str]
    clusters: int
    ranges: Optional[np.ndarray]
    points: Optional[np.ndarray]
    lead_speed: Optional[float]
    fresh: bool
    done: bool
    truth: GroundTruth


def _observation(k: int, m: Mapping[str, Any], g: Mapping[str, Any], done: bool) -> Observation:
    v2v = m["v2v"]
    collision = g["collision"]
    truth = GroundTruth(
        t=g["t"],
        gap=g["gap"],
        front_speed=g["front_speed"],
        front_accel=g["front_accel"],
        speed=g["speed"],
        accel=g["accel"],
        x=g["x"],
        y=g["y"],
        yaw=g["yaw"],
        lateral_offset=g["lateral_offset"],
        collision=None if collision is None else json.loads(collision),
    )
    return Observation(
        follower=k,
        t=m["t"],
        distance=m["distance"],
        own_speed=m["own_speed"],
        dt=m["dt"],
        v2v_speed=None if v2v is None else v2v[0],
        v2v_seq=None if v2v is None else v2v[1],
        v2v_age=m["v2v_age"],
        v2v_new=m["v2v_new"] is not None,
        detection=m["detection"],
        detector_status=m["status"],
        clusters=m["clusters"],
        ranges=m.get("ranges"),
        points=m.get("points"),
        lead_speed=m["lead_speed"],
        fresh=bool(m["fresh"]) and not done,
        done=done,
        truth=truth,
    )


class Simulation:
    """A scenario's closed loop stepped from Python, one control period (a LiDAR scan of a driven
    follower) per :meth:`step`.

    ``scenario``: a :class:`Scenario` (presets, files, overrides: whatever :func:`flc.run`
    takes) or a dict. ``drive``: the follower(s) Python commands, 1-based (``1``, the ego, by
    default; a sequence, or ``"all"`` for every follower of a platoon). ``command``: how a plain
    number given to :meth:`step` is read, ``"speed"`` (m/s) or ``"accel"`` (m/s²).
    ``lidar_points``: put each scan's raw points into the observation; ``beams``: reduce each
    scan to that many range beams (:attr:`Observation.ranges`). ``record``: a folder; each run
    (each :meth:`reset`) is written there as MCAP, named as :func:`flc.run` names it (Foxglove;
    ``flc.read_mcap`` reads it back; the metrics are written when the run reaches its end).

    With one driven follower :meth:`reset` and :meth:`step` return its :class:`Observation`;
    with several, a dict ``{k: Observation}`` and :meth:`step` takes a dict ``{k: command}``
    (followers left out: ``None``). ``step(None)`` all along is :func:`flc.run`; :meth:`result`
    is the :class:`RunResult` ``flc.run`` returns (so far, until :attr:`done`).
    """

    def __init__(
        self,
        scenario: Union[Scenario, Mapping[str, Any]],
        *,
        drive: Union[int, Sequence[int], str] = 1,
        command: str = "speed",
        lidar_points: bool = False,
        beams: int = 0,
        record: Optional[Union[str, "os.PathLike[str]"]] = None,
    ) -> None:
        self._scenario = scenario if isinstance(scenario, Scenario) else Scenario.from_dict(scenario)
        if command not in ("speed", "accel"):
            raise ParameterError(f"`command`: must be speed or accel, got {command!r}")
        self._mode = command
        if isinstance(drive, str):
            if drive != "all":
                raise ParameterError(f"`drive`: a follower index, a sequence of them or 'all', got {drive!r}")
            drive = self._followers_of(self._scenario)
        self._single = isinstance(drive, int)
        self._drive: list[int] = [int(drive)] if isinstance(drive, int) else [int(k) for k in drive]
        if not self._drive:
            raise ParameterError("`drive`: at least one follower")
        if isinstance(beams, bool) or not isinstance(beams, int) or beams < 0:
            raise ParameterError(f"`beams`: a number of beams >= 0, got {beams!r}")
        self._inner = _flc.Simulation(self._scenario.to_json(), self._drive, bool(lidar_points), beams, None if record is None else os.fspath(record))
        self._done = True
        self._started = False

    @staticmethod
    def _followers_of(scenario: Scenario) -> list[int]:
        platoon = scenario.to_dict().get("platoon")
        n = int(platoon.get("followers", 1)) if isinstance(platoon, dict) else 1
        return list(range(1, n + 1))

    @property
    def scenario(self) -> Scenario:
        """The scenario of the current episode."""
        return self._scenario

    @property
    def driven(self) -> list[int]:
        """The followers driven from Python (1-based)."""
        return list(self._drive)

    @property
    def done(self) -> bool:
        """The run is over (or has not been reset)."""
        return self._done

    @property
    def time(self) -> float:
        """Simulation time, s."""
        return self._inner.time() if self._started else 0.0

    def reset(self, seed: Optional[int] = None, scenario: Optional[Union[Scenario, Mapping[str, Any]]] = None) -> Any:
        """Start the run anew (with ``seed`` instead of the scenario's, and on ``scenario`` if
        given) and run to the first scan of a driven follower; returns its observation."""
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
            raise ParameterError(f"`seed`: a non-negative integer, got {seed!r}")
        js = None
        if scenario is not None:
            self._scenario = scenario if isinstance(scenario, Scenario) else Scenario.from_dict(scenario)
            js = self._scenario.to_json()
        self._inner.reset(seed, js)
        self._started = True
        self._done = not self._inner.advance()
        return self._observe()

    def step(self, command: Union[Command, Mapping[int, Command]] = None, *, hold_until: Optional[float] = None) -> Any:
        """Apply ``command`` for the period paused at and run to the next scan of a driven
        follower (or the end: :attr:`Observation.done`). Returns the observation(s). With
        ``hold_until`` (s), the same command is applied again at every scan before that time (one
        decision held over several scans, in Rust): the observation is that of the first scan at
        or after ``hold_until``."""
        if not self._started:
            raise _flc.SimulationError("Simulation.step: call reset() first")
        if self._done:
            raise _flc.SimulationError("Simulation.step: the run is over (reset() starts a new one)")
        if isinstance(command, Mapping):
            unknown = [k for k in command if k not in self._drive]
            if unknown:
                raise ParameterError(f"`command`: followers {unknown} are not driven (driven: {self._drive})")
            cmds = [self._command(int(k), c) for k, c in command.items()]
        else:
            if len(self._drive) > 1 and command is not None:
                raise ParameterError("`command`: several followers are driven: give a dict {follower: command}")
            cmds = [self._command(self._drive[0], command)]
        if hold_until is None:
            for c in cmds:
                self._inner.command(*c)
            self._done = not self._inner.advance()
        else:
            self._done = not self._inner.hold(cmds, float(hold_until))
        return self._observe()

    def _command(self, k: int, c: Command) -> tuple[int, str, float]:
        if c is None:
            return (k, "law", 0.0)
        if isinstance(c, SpeedCommand):
            return (k, "speed", float(c.speed))
        if isinstance(c, AccelCommand):
            return (k, "accel", float(c.accel))
        if isinstance(c, (int, float, np.floating, np.integer)) and not isinstance(c, bool):
            return (k, self._mode, float(c))
        raise ParameterError(f"`command`: None, a number, SpeedCommand or AccelCommand, got {type(c).__name__}")

    def _observe(self) -> Any:
        obs = {k: _observation(k, self._inner.measurement(k), self._inner.ground_truth(k), self._done) for k in self._drive}
        return obs[self._drive[0]] if self._single else obs

    def result(self) -> RunResult:
        """The run's :class:`RunResult` (so far; at the end, the one :func:`flc.run` returns)."""
        if not self._started:
            raise _flc.SimulationError("Simulation.result: call reset() first")
        # The scenario as run (with the seed reset() gave).
        return _result(Scenario(json.loads(self._inner.scenario_json())), self._inner.result())
