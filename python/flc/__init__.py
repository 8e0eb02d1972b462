"""flc: fallback longitudinal control for vehicle following without V2V.

Implements Sabry et al., "A LiDAR-Driven Fallback Longitudinal Controller for Safer Following in
Sudden Braking Scenarios": the FLC, the V2V PID, pure pursuit, the supervisor and the LiDAR lead
detector (Rust, ``flc-core``), a closed-loop simulator (``flc-sim``), and analysis / figures.

Units are SI (m, m/s, m/s², s, rad); only arguments named ``*_kmh`` are in km/h.
"""
from __future__ import annotations

from ._controllers import (
    Command,
    FallbackController,
    LeadDetector,
    PidController,
    PurePursuit,
    RobustFallbackController,
    RobustFallbackController2,
    Steering,
    Supervisor,
)
from ._flc import FlcError, ParameterError, ScenarioError, SimulationError
from ._falsify import falsify
from ._mcap import read_mcap
from ._run import PlatoonResult, RunResult, frequency_response, metrics_from_series, run, run_suite, sweep
from ._scenario import Scenario
from ._suite import SuiteReport, SuiteResults
from ._sweep import SweepSummary, sweep_file
from ._simulation import AccelCommand, GroundTruth, Observation, Simulation, SpeedCommand

__all__ = [
    "AccelCommand",
    "Command",
    "FallbackController",
    "FlcError",
    "GroundTruth",
    "LeadDetector",
    "Observation",
    "ParameterError",
    "PlatoonResult",
    "PidController",
    "PurePursuit",
    "RobustFallbackController",
    "RobustFallbackController2",
    "RunResult",
    "Scenario",
    "ScenarioError",
    "Simulation",
    "SimulationError",
    "SpeedCommand",
    "SweepSummary",
    "Steering",
    "SuiteReport",
    "SuiteResults",
    "Supervisor",
    "falsify",
    "frequency_response",
    "metrics_from_series",
    "run_suite",
    "read_mcap",
    "run",
    "sweep",
    "sweep_file",
]
