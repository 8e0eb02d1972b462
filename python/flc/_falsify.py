"""Falsification: a CMA-ES search for the run of least STL robustness (``docs/safety-evidence.md``).

``python -m flc falsify SPEC.toml [--out DIR]`` and :func:`falsify` read a search specification:

.. code-block:: toml

    [base]                      # the scenario every candidate starts from
    paper = { speed_kmh = 90, controller = "pid", preset = "paper" }   # or: file = "x.toml"
    set = { "lidar.rate_hz" = 20 }                                       # fixed overrides

    [search]
    requirement = "no_contact"  # flc.stl.REQUIREMENTS; params = { tau = 0.9 } its parameters
    budget = 200                # evaluations (simulated runs)
    population = 8              # CMA-ES population (default 4 + 3 ln n)
    sigma0 = 0.3                # initial step, in the box normalised to [0, 1]
    seed = 1                    # the search's seed (the runs' own seed is the scenario's)
    stop_below = -1e9           # stop once a robustness below this is found (default: run the budget)

    [[search.keys]]             # one continuous dimension over scenario keys (the one patch mechanism)
    keys = ["lead.initial_speed", "follower.initial_speed"]   # or key = "..."; all get the value
    min = 10.0
    max = 36.0
    integer = false             # true: rounded (e.g. lidar.latency_frames)

    [search.start]              # steady following at the start: both at `speed`, the gap
    speed = [8.3, 36.1]         # m/s (lead.initial_speed = follower.initial_speed)
    time_gap = [1.5, 1.5]       # s: follower.initial_gap = standstill_gap + time_gap * speed
    standstill_gap = 3.0        # m

    [search.lead_profile]       # replaces the lead's phases by a piecewise, jerk-limited profile
    segments = 4                # each: an acceleration held for a duration
    accel = [-10.0, 3.0]        # m/s², bounds of a segment's acceleration
    duration = [0.5, 6.0]       # s, bounds of a segment's duration
    start = [2.0, 10.0]         # s, the lead holds its initial speed this long first
    jerk = 20.0                 # m/s³: a change of acceleration is ramped in 0.1 s steps at most this fast
    max_speed = 36.2            # m/s, the profile's speed is capped here (and floored at 0)

    [search.lidar_faults]       # scripted LiDAR faults ([[lidar.faults]], docs/sim-model.md)
    blind = 1                   # windows without returns
    ghost = 1                   # windows with a spurious face ahead
    start = [0.0, 30.0]         # s
    duration = [0.0, 1.5]       # s; a window shorter than 0.05 s is left out
    ghost_range = [2.0, 40.0]   # m

The lead's profile is its *commanded* acceleration: the simulator's lead phases
(``brake``/``accelerate`` to a speed, ``hold`` for a duration) realised through the lead's vehicle
model (dead time, lag), so its true acceleration is smoother still. Each segment's acceleration
``a`` is rounded to 0 within 0.05 m/s² (a hold).

Candidates run in batches (one CMA-ES generation) through :func:`flc.sweep`, the parallel Rust
runner; each run's robustness is :func:`flc.stl.robustness` of the requirement. The search is
deterministic for a seed (CMA-ES draws from its own seeded generator; the runs are deterministic
per scenario on any thread count). The result's worst scenario is written as a TOML scenario file
(:func:`write_scenario`) that ``scenario --config FILE`` and :meth:`flc.Scenario.load` replay bit
for bit.
"""
from __future__ import annotations

import json
import math
import os
import re
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

from . import stl
from ._run import sweep
from ._scenario import Scenario

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

PathLike = Union[str, "os.PathLike[str]"]


class SpecError(ValueError):
    """A bad falsification spec: the message names the key."""


@dataclass
class Dim:
    """One dimension of the search box: ``name`` (what it sets), bounds, integer or not."""

    name: str
    lo: float
    hi: float
    integer: bool = False


@dataclass
class Evaluation:
    """One simulated candidate: its point (by dimension name), robustness, collision, the
    scenario that ran."""

    index: int
    generation: int
    point: dict[str, float]
    robustness: float
    collision: bool
    scenario: Scenario


@dataclass
class FalsifyResult:
    """The search's outcome: every evaluation in order, the worst (least robust) one, the
    first evaluation (1-based count) whose robustness was negative (``None``: never)."""

    spec: dict[str, Any]
    evaluations: list[Evaluation] = field(default_factory=list)

    @property
    def worst(self) -> Evaluation:
        # The first of the least robust (a tie keeps the earlier evaluation): deterministic.
        return min(self.evaluations, key=lambda e: (e.robustness, e.index))

    @property
    def min_robustness(self) -> float:
        return self.worst.robustness

    @property
    def first_violation(self) -> Optional[int]:
        for e in self.evaluations:
            if e.robustness < 0:
                return e.index + 1
        return None

    def history(self) -> list[float]:
        """The lowest robustness found after each evaluation."""
        return list(np.minimum.accumulate([e.robustness for e in self.evaluations]))

    def summary(self) -> dict[str, Any]:
        w = self.worst
        return {
            "requirement": self.spec["search"].get("requirement", "no_contact"),
            "evaluations": len(self.evaluations),
            "min_robustness": w.robustness,
            "worst_collision": w.collision,
            "worst_index": w.index + 1,
            "first_violation": self.first_violation,
            "collisions": sum(e.collision for e in self.evaluations),
            "worst_point": w.point,
        }


def _pair(spec: Mapping[str, Any], key: str, where: str, default: Optional[Sequence[float]] = None) -> tuple[float, float]:
    v = spec.get(key, default)
    if v is None:
        raise SpecError(f"{where}.{key}: required ([min, max])")
    if not (isinstance(v, (list, tuple)) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)):
        raise SpecError(f"{where}.{key}: must be [min, max] (two numbers), got {v!r}")
    lo, hi = float(v[0]), float(v[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise SpecError(f"{where}.{key}: must be finite with min <= max, got {v!r}")
    return lo, hi


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    bad = sorted(set(table) - set(allowed))
    if bad:
        raise SpecError(f"{where}: unknown key(s) {', '.join(bad)} (allowed: {', '.join(allowed)})")


class _Plan:
    """A validated spec: the base scenario, the dimensions and how a point becomes a scenario."""

    def __init__(self, spec: Mapping[str, Any], root: str = ".") -> None:
        _check_keys(spec, ("base", "search"), "spec")
        base = spec.get("base", {})
        _check_keys(base, ("paper", "file", "set"), "base")
        if ("paper" in base) == ("file" in base):
            raise SpecError("base: give exactly one of `paper` (a table: speed_kmh, controller, preset) or `file`")
        overrides = dict(base.get("set", {}))
        if "paper" in base:
            p = dict(base["paper"])
            _check_keys(p, ("speed_kmh", "controller", "preset"), "base.paper")
            self.base = Scenario.paper(**p, **overrides)
        else:
            self.base = Scenario.load(os.path.join(root, str(base["file"])), **overrides)
        search = dict(spec.get("search", {}))
        _check_keys(
            search,
            ("requirement", "params", "budget", "population", "sigma0", "seed", "stop_below", "threads", "keys", "start", "lead_profile", "lidar_faults"),
            "search",
        )
        self.requirement = str(search.get("requirement", "no_contact"))
        if self.requirement not in stl.REQUIREMENTS:
            raise SpecError(f"search.requirement: unknown {self.requirement!r} (known: {', '.join(stl.REQUIREMENTS)})")
        self.params = dict(search.get("params", {}))
        try:
            stl.formula(self.requirement, **self.params)
        except ValueError as e:
            raise SpecError(f"search.params: {e}") from None
        self.budget = int(search.get("budget", 200))
        self.seed = int(search.get("seed", 1))
        self.sigma0 = float(search.get("sigma0", 0.3))
        self.stop_below = float(search.get("stop_below", -math.inf))
        self.threads = search.get("threads")
        if self.budget < 1:
            raise SpecError(f"search.budget: must be >= 1, got {self.budget}")
        if not 0 < self.sigma0 <= 1:
            raise SpecError(f"search.sigma0: must be in (0, 1], got {self.sigma0}")
        self.dims: list[Dim] = []
        self.key_dims: list[tuple[Dim, list[str]]] = []
        for i, k in enumerate(search.get("keys", [])):
            where = f"search.keys[{i}]"
            _check_keys(k, ("key", "keys", "min", "max", "integer"), where)
            keys = [k["key"]] if "key" in k else list(k.get("keys", []))
            if not keys or ("key" in k and "keys" in k):
                raise SpecError(f"{where}: give `key` or `keys` (a list)")
            lo, hi = k.get("min"), k.get("max")
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in (lo, hi)) or lo > hi:
                raise SpecError(f"{where}: `min` and `max` must be finite numbers with min <= max, got {lo!r}, {hi!r}")
            lo, hi = float(lo), float(hi)
            d = Dim(keys[0], lo, hi, bool(k.get("integer", False)))
            self.dims.append(d)
            self.key_dims.append((d, [str(x) for x in keys]))
        self.start = search.get("start")
        if self.start is not None:
            st = dict(self.start)
            _check_keys(st, ("speed", "time_gap", "standstill_gap"), "search.start")
            self.dims.append(Dim("start.speed", *_pair(st, "speed", "search.start")))
            self.dims.append(Dim("start.time_gap", *_pair(st, "time_gap", "search.start")))
            self.s_standstill = float(st.get("standstill_gap", 3.0))
        self.profile = search.get("lead_profile")
        if self.profile is not None:
            pr = dict(self.profile)
            _check_keys(pr, ("segments", "accel", "duration", "start", "jerk", "max_speed"), "search.lead_profile")
            n = int(pr.get("segments", 3))
            if not 1 <= n <= 20:
                raise SpecError(f"search.lead_profile.segments: must be in [1, 20], got {n}")
            self.p_accel = _pair(pr, "accel", "search.lead_profile")
            self.p_duration = _pair(pr, "duration", "search.lead_profile")
            self.p_start = _pair(pr, "start", "search.lead_profile", (0.0, 0.0))
            self.p_jerk = float(pr.get("jerk", 20.0))
            self.p_max_speed = float(pr.get("max_speed", 70.0))
            if self.p_jerk <= 0:
                raise SpecError(f"search.lead_profile.jerk: must be > 0, got {self.p_jerk}")
            self.p_segments = n
            self.dims.append(Dim("lead_profile.start", *self.p_start))
            for j in range(n):
                self.dims.append(Dim(f"lead_profile.accel[{j}]", *self.p_accel))
                self.dims.append(Dim(f"lead_profile.duration[{j}]", *self.p_duration))
        self.faults = search.get("lidar_faults")
        if self.faults is not None:
            fa = dict(self.faults)
            _check_keys(fa, ("blind", "ghost", "start", "duration", "ghost_range"), "search.lidar_faults")
            self.f_blind, self.f_ghost = int(fa.get("blind", 0)), int(fa.get("ghost", 0))
            self.f_start = _pair(fa, "start", "search.lidar_faults")
            self.f_duration = _pair(fa, "duration", "search.lidar_faults")
            self.f_range = _pair(fa, "ghost_range", "search.lidar_faults", (2.0, 40.0))
            for j in range(self.f_blind):
                self.dims += [Dim(f"blind[{j}].start", *self.f_start), Dim(f"blind[{j}].duration", *self.f_duration)]
            for j in range(self.f_ghost):
                self.dims += [
                    Dim(f"ghost[{j}].start", *self.f_start),
                    Dim(f"ghost[{j}].duration", *self.f_duration),
                    Dim(f"ghost[{j}].range", *self.f_range),
                ]
        if not self.dims:
            raise SpecError("search: no dimension (give [[search.keys]], [search.start], [search.lead_profile] or [search.lidar_faults])")
        self.population = int(search.get("population", 4 + int(3 * math.log(len(self.dims)))))
        if self.population < 2:
            raise SpecError(f"search.population: must be >= 2, got {self.population}")
        # Every point must build: the box's corners are checked now, so a bad bound is an error
        # naming the key before any run.
        for corner in (0.0, 1.0):
            try:
                self.scenario(self.point(np.full(len(self.dims), corner)))
            except Exception as e:  # ScenarioError / TypeError from the patch mechanism
                raise SpecError(f"search: the box's {'lower' if corner == 0 else 'upper'} corner is not a valid scenario: {e}") from None

    def point(self, u: np.ndarray) -> dict[str, float]:
        """The point of the normalised vector ``u`` in [0, 1]^n, by dimension name."""
        out: dict[str, float] = {}
        for d, x in zip(self.dims, np.clip(u, 0.0, 1.0)):
            v = d.lo + float(x) * (d.hi - d.lo)
            out[d.name] = float(round(v)) if d.integer else v
        return out

    def _profile_phases(self, p: Mapping[str, float], v0: float) -> list[dict[str, Any]]:
        dt = 0.1
        phases: list[dict[str, Any]] = [{"kind": "hold", "duration": max(p["lead_profile.start"], 0.01)}]
        v, a_prev = v0, 0.0

        def add(a: float, dur: float) -> None:
            nonlocal v
            if dur <= 0:
                return
            if abs(a) < 0.05:
                phases.append({"kind": "hold", "duration": dur})
                return
            target = min(max(v + a * dur, 0.0), self.p_max_speed)
            if abs(target - v) < 1e-6:
                phases.append({"kind": "hold", "duration": dur})
                return
            if a > 0:
                phases.append({"kind": "accelerate", "accel": a, "speed": target})
            else:
                phases.append({"kind": "brake", "decel": -a, "speed": target})
            v = target

        for j in range(self.p_segments):
            a = p[f"lead_profile.accel[{j}]"]
            a = 0.0 if abs(a) < 0.05 else a
            dur = p[f"lead_profile.duration[{j}]"]
            # Ramp from the previous acceleration in 0.1 s steps of at most jerk * 0.1.
            steps = int(math.ceil(abs(a - a_prev) / (self.p_jerk * dt) - 1e-9))
            for s in range(1, steps):
                add(a_prev + (a - a_prev) * s / steps, dt)
            add(a, dur)
            a_prev = a
        return phases

    def scenario(self, p: Mapping[str, float]) -> Scenario:
        """The scenario of a point: the base with the point's values set through the one
        patch mechanism (:meth:`flc.Scenario.replace`)."""
        overrides: dict[str, Any] = {}
        for d, keys in self.key_dims:
            v: Any = int(p[d.name]) if d.integer else p[d.name]
            for k in keys:
                overrides[k] = v
        if self.start is not None:
            v = p["start.speed"]
            overrides["lead.initial_speed"] = v
            overrides["follower.initial_speed"] = v
            overrides["follower.initial_gap"] = self.s_standstill + p["start.time_gap"] * v
        sc = self.base.replace(**overrides) if overrides else self.base
        extra: dict[str, Any] = {}
        if self.profile is not None:
            extra["lead.phases"] = self._profile_phases(p, float(sc["lead.initial_speed"]))
            extra["lead.vehicle.max_brake"] = max(float(sc["lead.vehicle.max_brake"]), -self.p_accel[0])
        if self.faults is not None:
            faults = list(sc.to_dict()["lidar"].get("faults", []))
            for j in range(self.f_blind):
                dur = p[f"blind[{j}].duration"]
                if dur >= 0.05:
                    faults.append({"kind": "blind", "start": p[f"blind[{j}].start"], "duration": dur})
            for j in range(self.f_ghost):
                dur = p[f"ghost[{j}].duration"]
                if dur >= 0.05:
                    faults.append({"kind": "ghost", "start": p[f"ghost[{j}].start"], "duration": dur, "range": p[f"ghost[{j}].range"], "width": 1.0})
            extra["lidar.faults"] = faults
        return sc.replace(**extra) if extra else sc


def load_spec(path: PathLike) -> dict[str, Any]:
    """A spec file as a dict (TOML)."""
    with open(path, "rb") as f:
        try:
            return tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            raise SpecError(f"{os.fspath(path)}: {e}") from None


def falsify(
    spec: Union[PathLike, Mapping[str, Any]],
    *,
    budget: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    progress: Optional[Callable[[int, int, float], None]] = None,
) -> FalsifyResult:
    """Search ``spec`` (a TOML file or its dict, see the module doc) with CMA-ES for the run of
    least robustness. ``budget`` / ``seed`` / ``threads`` override the spec's. ``progress`` is
    called after each generation with (evaluations done, budget, lowest robustness so far)."""
    try:
        from cmaes import CMA
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("flc.falsify() needs cmaes: pip install 'flc[safety]'") from e
    root = "."
    if isinstance(spec, Mapping):
        raw: Mapping[str, Any] = spec
    else:
        root = os.path.dirname(os.fspath(spec)) or "."
        raw = load_spec(spec)
    data: dict[str, Any] = json.loads(json.dumps(raw))  # a plain copy
    if budget is not None:
        data.setdefault("search", {})["budget"] = int(budget)
    if seed is not None:
        data.setdefault("search", {})["seed"] = int(seed)
    plan = _Plan(data, root)
    n = len(plan.dims)
    bounds = np.tile([0.0, 1.0], (n, 1))
    opt = CMA(mean=np.full(n, 0.5), sigma=plan.sigma0, bounds=bounds, seed=plan.seed, population_size=plan.population)
    result = FalsifyResult(data)
    th = threads if threads is not None else plan.threads
    gen = 0
    while len(result.evaluations) < plan.budget:
        xs = [opt.ask() for _ in range(opt.population_size)]
        take = min(len(xs), plan.budget - len(result.evaluations))
        points = [plan.point(x) for x in xs[:take]]
        scenarios = [plan.scenario(p) for p in points]
        runs = sweep(scenarios, threads=None if th is None else int(th))
        rob = [stl.robustness(r, plan.requirement, **plan.params) for r in runs]
        for p, sc, r, rho in zip(points, scenarios, runs, rob):
            result.evaluations.append(Evaluation(len(result.evaluations), gen, p, rho, bool(r.metrics.get("collision")), sc))
        if progress is not None:
            progress(len(result.evaluations), plan.budget, result.min_robustness)
        if take < len(xs) or result.min_robustness < plan.stop_below:
            break
        opt.tell([(x, rho) for x, rho in zip(xs, rob)])
        gen += 1
    return result


_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)  # the shortest text that reads back to the same double
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        items = [f"{_toml_key(str(k))} = {_toml_value(x)}" for k, x in v.items() if x is not None]
        return "{" + ", ".join(items) + "}"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _is_table_list(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, Mapping) for x in v)


def _toml_table(path: list[str], d: Mapping[str, Any], out: list[str]) -> None:
    for k, v in d.items():
        if v is None or isinstance(v, Mapping) or _is_table_list(v):
            continue
        out.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for k, v in d.items():
        if isinstance(v, Mapping):
            out.append("")
            out.append("[" + ".".join(_toml_key(x) for x in path + [k]) + "]")
            _toml_table(path + [k], v, out)
    for k, v in d.items():
        if _is_table_list(v):
            for item in v:
                out.append("")
                out.append("[[" + ".".join(_toml_key(x) for x in path + [k]) + "]]")
                _toml_table(path + [k], item, out)


def to_toml(scenario: Scenario, header: str = "") -> str:
    """The full scenario (every key; ``None`` keys left out, which is their default) as a TOML
    scenario file: floats written as their shortest round-trip text, so the file loads back to
    the same scenario bit for bit."""
    out = [f"# {line}" for line in header.splitlines()]
    _toml_table([], scenario.to_dict(), out)
    return "\n".join(out).strip("\n") + "\n"


def write_scenario(path: PathLike, scenario: Scenario, header: str = "") -> str:
    """Writes :func:`to_toml` to ``path`` and checks that it loads back to the same scenario
    (else ``RuntimeError``: never a file that replays something else). Returns the path."""
    text = to_toml(scenario, header)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    back = Scenario.load(path)
    if back != scenario:
        raise RuntimeError(f"{os.fspath(path)}: the written scenario does not load back to the same scenario")
    return os.fspath(path)


def main(argv: Sequence[str]) -> int:
    """``python -m flc falsify SPEC.toml [--out DIR] [--budget N] [--seed N] [--threads N] [--quiet]``."""
    import argparse

    ap = argparse.ArgumentParser(prog="python -m flc falsify", description="CMA-ES falsification of an STL requirement (docs/safety-evidence.md)")
    ap.add_argument("spec", help="the search specification (TOML)")
    ap.add_argument("--out", default=None, help="folder for the worst case (worst.toml) and the search log (falsify.json)")
    ap.add_argument("--budget", type=int, default=None, help="evaluations (overrides the spec's)")
    ap.add_argument("--seed", type=int, default=None, help="the search's seed (overrides the spec's)")
    ap.add_argument("--threads", type=int, default=None, help="worker threads of the batch runner")
    ap.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    args = ap.parse_args(list(argv))
    t0 = time.monotonic()
    from ._progress import stderr_is_terminal

    # Progress as the other long commands show it: redrawn on stderr when it is a terminal.
    shown = [False]

    def show(done: int, total: int, best: float) -> None:
        el = int(time.monotonic() - t0)
        sys.stderr.write(f"\r{done}/{total} evaluations, lowest robustness {best:+.4f} {el // 60:02d}:{el % 60:02d}\x1b[K")
        sys.stderr.flush()
        shown[0] = True

    from ._flc import FlcError

    try:
        res = falsify(args.spec, budget=args.budget, seed=args.seed, threads=args.threads, progress=None if args.quiet or not stderr_is_terminal() else show)
    except (SpecError, FlcError, TypeError, OSError) as e:
        if shown[0]:
            sys.stderr.write("\n")
        print(f"error: {args.spec}: {e}", file=sys.stderr)
        return 2
    if shown[0]:
        sys.stderr.write("\n")
    s = res.summary()
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        w = res.worst
        head = (
            f"Worst case of `python -m flc falsify {os.fspath(args.spec)}` (seed {res.spec['search'].get('seed', 1)}, "
            f"{s['evaluations']} evaluations): {s['requirement']} robustness {w.robustness!r}, collision {str(w.collision).lower()}.\n"
            f"Replay: cargo run --release --bin scenario -- --config FILE"
        )
        s["worst_file"] = write_scenario(os.path.join(args.out, "worst.toml"), w.scenario, head)
        with open(os.path.join(args.out, "falsify.json"), "w", encoding="utf-8") as f:
            json.dump({**s, "history": res.history()}, f)
            f.write("\n")
    print(json.dumps(s))
    return 0
