"""The generators of the documents' generated blocks (:mod:`flc.docs`): one function per block
kind, registered under the NAME of ``python -m flc docs show NAME [ARG ...]``.

A generator returns Markdown text. It runs the simulator (the same Rust functions the CLI and
the tests use; seconds at most) or reads a committed data file (named in its docstring, with the
command that regenerates that file). Runs are cached within one ``python -m flc docs`` call.
"""
from __future__ import annotations

import functools
import json
import os
import re
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from ._run import RunResult, sweep
from ._scenario import Scenario
from .reproduction import PAPER, ROOT, read_csv

GENERATORS: dict[str, Callable[..., str]] = {}


def generator(name: str) -> Callable[[Callable[..., str]], Callable[..., str]]:
    def reg(f: Callable[..., str]) -> Callable[..., str]:
        GENERATORS[name] = f
        return f

    return reg


# ---------------------------------------------------------------------------------------------
# Shared helpers


@functools.lru_cache(maxsize=None)
def _runs(key: tuple[str, ...]) -> list[RunResult]:
    return sweep([Scenario.from_dict(json.loads(k)) for k in key])


def run_all(scenarios: Sequence[Scenario]) -> list[RunResult]:
    """Runs (in parallel, in Rust) and caches by scenario: equal scenarios run once per call."""
    return _runs(tuple(s.to_json() for s in scenarios))


def outcome(r: RunResult) -> str:
    """``stop, 4.54 m`` / ``collision, 4.36 m/s`` (with what was hit unless the vehicle ahead) /
    ``no stop, min 3.00 m``, as the CLI's outcome column says it."""
    m = r.metrics
    if m["collision"]:
        hit = (r.collision or {}).get("object") or {}
        if hit.get("kind") in ("vehicle", "pedestrian"):
            label = "" if hit.get("name") == "lead" else f", {hit.get('name')}"
        else:
            label = f", {hit.get('kind')} #{hit.get('index')}" if hit else ""
        return f"collision, {m['impact_speed']:.2f} m/s{label}"
    if m.get("final_clearance") is not None:
        return f"stop, {m['final_clearance']:.2f} m"
    return f"no stop, min {m['min_gap']:.2f} m"


def table(header: Sequence[str], rows: Sequence[Sequence[Any]], align: Optional[str] = None) -> str:
    """A Markdown table; ``align`` is one letter per column (``l`` / ``r``), left by default."""
    al = align or "l" * len(header)
    sep = ["---:" if a == "r" else "---" for a in al]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(sep) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _paper_text(c: Optional[float]) -> str:
    return "collision" if c is None else f"{c} m"


# ---------------------------------------------------------------------------------------------
# Committed data files written by Rust (the detector study, the suites' report, the esmini table)

_LINK_RE = re.compile(r"\]\((?P<target>[^)\s]+)\)")


@generator("include")
def include(path: str) -> str:
    """The committed file PATH (relative to the repository) as it is, for results that a Rust
    command or test writes into a data file (``docs/README.md`` lists each file's command). Its
    relative Markdown links are made relative to ``docs/``, where the including documents live."""
    file = ROOT / path
    if not file.is_file():
        raise FileNotFoundError(f"include: {path} is not a file of the repository")
    text = file.read_text(encoding="utf-8")
    base = os.path.relpath(file.parent, ROOT / "docs")

    def relink(m: "re.Match[str]") -> str:
        t = m.group("target")
        if base == "." or re.match(r"^([a-z]+:|/|#)", t):
            return m.group(0)
        return f"]({Path(base, t).as_posix()})"

    return _LINK_RE.sub(relink, text)


@generator("ncap-calculator")
def ncap_calculator(path: str = "docs/standard-suites/ncap-ccr-2026-calculator.json",
                    report: str = "docs/standard-suites/ncap-ccr-2026.json") -> str:
    """Euro NCAP's 2026 rating calculator's points per controller on the ncap-ccr-2026 grid, from
    the committed PATH, written by ``python -m flc.ncap docs/standard-suites/ncap-ccr-2026.json
    --all --out docs/standard-suites/ncap-ccr-2026-calculator.json`` (a minute: the calculator
    runs once per controller). Refused when the suite's committed REPORT no longer gives the
    cells the points were computed from (each controller's fingerprint)."""
    from . import ncap

    data = json.loads((ROOT / path).read_text(encoding="utf-8"))
    rep = json.loads((ROOT / report).read_text(encoding="utf-8"))
    scored = [s["controller"] for s in data["scores"]]
    if scored != rep["controllers"]:
        raise ValueError(f"{path}: scores {scored}, but {report} has {rep['controllers']}: rerun python -m flc.ncap ... --all")
    for s in data["scores"]:
        if s.get("report_fingerprint") != ncap.report_fingerprint(rep, s["controller"]):
            raise ValueError(f"{path}: {s['controller']}'s points are stale ({report} changed): rerun python -m flc.ncap ... --all")
    return ncap.table(data["scores"])


# ---------------------------------------------------------------------------------------------
# docs/paper-reproduction.md


def _paper_runs(preset: str, controllers: Sequence[str] = ("flc", "pid")) -> dict[tuple[str, float], RunResult]:
    cells = [(c, v) for c in controllers for v in (30.0, 50.0, 70.0, 90.0)]
    res = run_all([Scenario.paper(v, c, preset) for (c, v) in cells])
    return dict(zip(cells, res))


@generator("paper-cells")
def paper_cells(preset: str = "paper") -> str:
    """The paper experiment's eight cells at ``preset`` (seed 1) beside the paper's (Sec. IV)."""
    runs = _paper_runs(preset)
    rows = []
    for (c, v), r in runs.items():
        paper = PAPER[(c, v)]
        rows.append((f"{c.upper()} {v:.0f} km/h", outcome(r), "collision" if paper is None else f"stop, {paper} m"))
    return table(("cell", "flc-sim", "paper"), rows)


@generator("paper-impact-90")
def paper_impact_90(preset: str = "paper") -> str:
    """The sentence on the 90 km/h crashes (the paper: the FLC's is the less severe)."""
    runs = _paper_runs(preset)
    f, p = runs[("flc", 90.0)].metrics, runs[("pid", 90.0)].metrics
    if not (f["collision"] and p["collision"]):
        return f"**At 90 km/h at the preset, not both collide** (FLC: {outcome(runs[('flc', 90.0)])}; PID: {outcome(runs[('pid', 90.0)])}).\n"
    verdict = "less severe" if f["impact_speed"] < p["impact_speed"] else "not less severe"
    return (
        f"**At 90 km/h the FLC's crash is {verdict} than the PID's:** {f['impact_speed']:.2f} vs "
        f"{p['impact_speed']:.2f} m/s impact speed at the preset (seed 1; `crates/flc-sim/tests/paper.rs` "
        "asserts the order for seeds 1–5).\n"
    )


@generator("paper-tracking")
def paper_tracking() -> str:
    """The tracking errors on the curved route, as ``cargo run --release --bin scenario`` prints
    them (``Scenario::paper_tracking``, paper preset), with how each run ends."""
    paper = {"flc": "0.0176 deg / 0.2258 m", "pid": "0.0199 deg / 0.2876 m"}
    rows = []
    for c, r in zip(("flc", "pid"), run_all([Scenario.paper_tracking(c, "paper") for c in ("flc", "pid")])):
        m = r.metrics
        rows.append((c.upper(), f"{m['rot_error_deg']:.4f}", f"{m['trans_error_m']:.4f}", f"{outcome(r)} after {m['duration']:.2f} s", paper[c]))
    return table(("", "rotational (deg)", "translational (m)", "the run ends", "paper"), rows, "lrrll")


def _share(rows: Sequence[dict[str, str]], at_least: int) -> tuple[int, int]:
    return sum(1 for r in rows if int(r["matches"]) >= at_least), len(rows)


@generator("reproduction-verdict")
def reproduction_verdict() -> str:
    """The region sizes, from the committed ``sweeps/paper-reproduction-{map,random}.csv``
    (regenerated by ``python -m flc reproduction --out docs/figures``)."""
    m8, mn = _share(read_csv(ROOT / "sweeps" / "paper-reproduction-map.csv"), 8)
    rnd = read_csv(ROOT / "sweeps" / "paper-reproduction-random.csv")
    r8, rn = _share(rnd, 8)
    r7, _ = _share(rnd, 7)
    return (
        f"All 8 cells match on **{100 * m8 / mn:.1f} %** ({m8} of {mn} grid points) of the brake authority × "
        f"actuator response map, and on **{100 * r8 / rn:.1f} %** ({r8} of {rn}) of a random sample over "
        f"all seven constants; {100 * r7 / rn:.1f} % of that sample matches at least 7.\n"
    )


# ---------------------------------------------------------------------------------------------
# docs/baselines.md and the scenario files


@generator("paper-matrix")
def paper_matrix(preset: str, controllers: str) -> str:
    """The paper experiment's outcome per speed (rows) and controller (columns, comma separated),
    as ``scenario --controllers ... --preset PRESET`` prints them (seed 1)."""
    names = [c for c in controllers.split(",") if c]
    speeds = (30.0, 50.0, 70.0, 90.0)
    res = run_all([Scenario.paper(v, c, preset) for v in speeds for c in names])
    rows = [[f"{v:.0f}", *(outcome(r) for r in res[i * len(names):(i + 1) * len(names)])] for i, v in enumerate(speeds)]
    return table(("km/h", *names), rows, "r" + "l" * len(names))


@generator("scenario-outcome")
def scenario_outcome(path: str, *overrides: str) -> str:
    """One line: how the scenario file ends (``KEY=VALUE`` overrides, values as TOML/JSON), e.g.
    ``scenarios/robust-cut-out.toml controller=flc``."""
    ov = {}
    for o in overrides:
        k, _, v = o.partition("=")
        try:
            ov[k] = json.loads(v)
        except ValueError:
            ov[k] = v
    sc = Scenario.load(ROOT / path, **ov)
    (r,) = run_all([sc])
    what = " ".join(f"`{o}`" for o in overrides)
    return f"`{path}`{' with ' + what if what else ''}: {outcome(r)} (after {r.metrics['duration']:.2f} s)\n"


# ---------------------------------------------------------------------------------------------
# docs/platoon.md


def _brakedemo() -> list[tuple[str, RunResult]]:
    vs = Scenario.brakedemo().variants()
    return list(zip([v.variant or "" for v in vs], run_all(vs)))


@generator("platoon-brakedemo")
def platoon_brakedemo() -> str:
    """The brake demo's variants (``scenarios/platoon-brakedemo.toml``, seed 1): collisions,
    clearances, the largest counted error ratio and the time-domain verdict."""
    rows = []
    for name, r in _brakedemo():
        assert r.platoon is not None
        per = r.platoon.metrics
        hits = [str(k + 1) for k, m in enumerate(per) if m["collision"]]
        cl = [m["final_clearance"] for m in per if m.get("final_clearance") is not None]
        ss = r.string_stability or {}
        rows.append((
            f"`{name}`",
            "none" if not hits else "followers " + ", ".join(hits),
            f"{min(cl):.2f}–{max(cl):.2f} m" if cl else "–",
            f"{ss.get('max_ratio', float('nan')):.3f}",
            "string stable" if ss.get("time_domain_stable") else "not string stable",
        ))
    return table(("variant", "collisions", "clearances (followers 1–7)", "max counted ratio", "verdict (time domain)"), rows)


@generator("platoon-gamma")
def platoon_gamma() -> str:
    """|Gamma(jw)| per frequency of the brake demo's variants (max over the counted followers;
    ``flc.frequency_response``)."""
    from ._run import frequency_response

    cols = []
    names = []
    for v in Scenario.brakedemo().variants():
        names.append(f"`{v.variant}`")
        pts = frequency_response(v)
        cols.append({p["freq_hz"]: p for p in pts})
    freqs = sorted({f for c in cols for f in c})
    rows = []
    for f in freqs:
        cells = []
        for c in cols:
            p = c.get(f)
            g = None if p is None else p.get("max_gamma")
            cells.append("–" if g is None else f"{g:.3f}")
        rows.append((f"{f:g}", *cells))
    return table(("Hz", *names), rows, "r" * (1 + len(names)))


# ---------------------------------------------------------------------------------------------
# docs/robust-flc.md


def steady_following(controller: str, kmh: float, decel: float) -> Scenario:
    """Steady following at the controller's own gap on a straight road, no V2V; the lead holds
    for 2 s and brakes at ``decel`` to a stop (its brakes raised to 15 m/s²)."""
    v = kmh / 3.6
    gap = 3 + 1.5 * v if controller in ("flc-robust", "flc-robust-odo", "flc-robust-v1") else 1.4 * v + 6  # the own gap (above 20 km/h)
    return Scenario.from_dict({
        "controller": controller, "duration": 90.0, "v2v": {"enabled": False},
        "track": {"kind": "straight", "length": 5000.0},
        "lead": {"initial_speed": v, "vehicle": {"max_brake": 15.0},
                 "phases": [{"kind": "hold", "duration": 2.0}, {"kind": "brake", "decel": float(decel)}]},
        "follower": {"initial_speed": v, "initial_gap": gap},
    })


@generator("steady-following-grid")
def steady_following_grid(controller: str) -> str:
    """Minimum gap (m) per lead deceleration (rows) and speed (columns), ``X`` + impact speed for
    a collision, ``no stop`` when the follower does not stop behind the lead within 90 s."""
    speeds = (30, 50, 70, 90, 110, 130, 140, 150, 160, 170)
    decels = (2, 6, 8, 9, 10, 12, 15)
    res = run_all([steady_following(controller, k, b) for b in decels for k in speeds])
    rows = []
    for i, b in enumerate(decels):
        cells = []
        for r in res[i * len(speeds):(i + 1) * len(speeds)]:
            m = r.metrics
            if m["collision"]:
                cells.append(f"X{m['impact_speed']:.1f}")
            elif m.get("final_clearance") is None:
                cells.append("no stop")
            else:
                cells.append(f"{m['min_gap']:.2f}")
        rows.append((f"−{b}", *cells))
    return table((controller, *(str(k) for k in speeds)), rows, "l" + "r" * len(speeds))


# ---------------------------------------------------------------------------------------------
# docs/safety-envelope.md


@generator("envelope-highest")
def envelope_highest(stem: str) -> str:
    """The highest collision-free speed (km/h) per controller and second-axis value, read from the
    committed ``docs/figures/<stem>-summary.md`` (``python -m flc figures --out docs/figures``
    writes it; "none": already the lowest speed collided)."""
    path = ROOT / "docs" / "figures" / f"{stem}-summary.md"
    if not path.is_file():
        raise FileNotFoundError(f"envelope-highest: {path.relative_to(ROOT)} is missing (python -m flc figures writes it)")
    rows = [[c.strip() for c in ln.strip().strip("|").split("|")] for ln in path.read_text(encoding="utf-8").splitlines() if ln.startswith("|")]
    head, body = rows[0], [r for r in rows[2:]]
    group, value = head[1], head.index("highest_safe_speed_kmh")
    ctrls: list[str] = []
    groups: list[str] = []
    cell: dict[tuple[str, str], str] = {}
    for r in body:
        ctrls += [r[0]] if r[0] not in ctrls else []
        groups += [r[1]] if r[1] not in groups else []
        cell[(r[0], r[1])] = "none" if r[value] == "nan" else r[value]
    del group
    return table(["controller", *groups], [[c, *(cell.get((c, g), "-") for g in groups)] for c in ctrls])


# ---------------------------------------------------------------------------------------------
# docs/paper-reproduction.md: the constants around the preset


def _lost(cells: Sequence[tuple[tuple[str, float], bool]]) -> str:
    """``FLC 70 collides, PID 90 stops``: the cells whose outcome differs from the paper's."""
    from .reproduction import PAPER

    out = [f"{c.upper()} {v:g} {'collides' if hit else 'stops'}" for (c, v), hit in cells if hit != (PAPER[(c, v)] is None)]
    return ", ".join(out) or "none"


def _lines_rows() -> list[dict[str, str]]:
    return read_csv(ROOT / "sweeps" / "paper-reproduction-lines.csv")


def _center(rows: Sequence[dict[str, str]]) -> dict[str, float]:
    """The point the lines run through (the preset): the constants of the ``seed`` rows."""
    from .reproduction import base_point, load_spec

    seed_row = next(r for r in rows if r["varied"] == "seed")
    return {k: float(seed_row[k]) for k in base_point(load_spec())}


def _row_cells(r: dict[str, str]) -> list[tuple[tuple[str, float], bool]]:
    from .reproduction import CELLS

    return [((c, v), r[f"{c}{int(v)}_collision"] == "1") for (c, v) in CELLS]


@generator("reproduction-lines")
def reproduction_lines() -> str:
    """One constant at a time through the preset, from the committed
    ``sweeps/paper-reproduction-lines.csv`` (``python -m flc reproduction --out docs/figures``):
    the sampled values where all 8 cells match, and what the nearest sampled value outside loses."""
    from .reproduction import constants, load_spec

    rows, cs = _lines_rows(), constants(load_spec())
    out = []
    for name in [*cs, "seed"]:
        line = sorted((r for r in rows if r["varied"] == name), key=lambda r: float(r[name]))
        if not line:
            continue
        vals = [float(r[name]) for r in line]
        ok = [i for i, r in enumerate(line) if r["matches"] == "8"]
        label = cs[name]["label"] if name in cs else "seed"
        if not ok:
            out.append([label, "none", "-", "-"])
            continue
        lo, hi = ok[0], ok[-1]
        gaps = [i for i in range(lo, hi + 1) if i not in ok]
        match = f"{vals[lo]:g}–{vals[hi]:g}" if lo != hi else f"{vals[lo]:g}"
        if gaps:
            match += " (not at " + ", ".join(f"{vals[i]:g}" for i in gaps) + ")"
        below = f"{vals[lo - 1]:g}: {_lost(_row_cells(line[lo - 1]))}" if lo > 0 else "(lowest sampled)"
        above = f"{vals[hi + 1]:g}: {_lost(_row_cells(line[hi + 1]))}" if hi + 1 < len(line) else "(highest sampled)"
        out.append([label, match, below, above])
    return table(["constant", "all 8 match at", "next value below: lost", "next value above: lost"], out)


@generator("reproduction-neighbours")
def reproduction_neighbours() -> str:
    """The preset with brake authority or actuator response moved by ±10 % (8 cells each, run
    now): the cells lost. The preset is the point the committed lines CSV runs through."""
    from .reproduction import CELLS, evaluate, load_spec

    spec = load_spec()
    center = _center(_lines_rows())
    moves = [("brake authority", "brake_authority", f, "m/s²") for f in (0.9, 1.1)]
    moves += [("actuator response", "actuator_response", f, "s") for f in (0.9, 1.1)]
    points = [dict(center, **{k: center[k] * f}) for (_, k, f, _) in moves]
    res = evaluate(spec, points)
    out = []
    for (label, k, f, unit), cells in zip(moves, res):
        lost = _lost([(cell, c["collision"]) for cell, c in zip(CELLS, cells)])
        out.append([f"{label} {'−' if f < 1 else '+'}10 % ({center[k] * f:.3g} {unit})", lost])
    return table(["change", "cells lost"], out)
# docs/sumo.md, docs/v2v-and-metrics.md (§3.1) and docs/baselines.md: the SUMO results
#
# They read the committed docs/figures/sumo-tables.json (`python -m flc sumo-tables --out
# docs/figures`, ~30 s of SUMO runs; flc.sumo.compute_tables), so the check needs no SUMO;
# tests/python/test_sumo.py and test_ssm.py recompute the rows against the file.


def _sumo_tables() -> dict[str, Any]:
    from .sumo import read_tables

    return read_tables()


def _sci(x: Optional[float]) -> str:
    """``1.8e-15``, ``3.7e-3``, ``0``: one decimal, the exponent without padding."""
    if x is None:
        return "–"
    if x == 0:
        return "0"
    mant, exp = f"{x:.1e}".split("e")
    return f"{mant}e{int(exp)}"


def _sig(x: float) -> str:
    """Two significant digits, no exponent."""
    return f"{x:.2g}" if abs(x) >= 1e-4 else f"{x:.1e}"


@generator("sumo-replay")
def sumo_replay() -> str:
    """docs/sumo.md: flc in SUMO against flc's own ideal run (``flc.sumo.replay_ideal_run``;
    docs/figures/sumo-tables.json)."""
    rows = []
    reps = _sumo_tables()["replay"]
    for r in reps:
        first = "none" if r["first_difference"] is None else f"{_sci(r['first_difference'])} m/s at {r['first_difference_t']:.2f} s"
        rows.append((r["controller"], f"{r['speed_kmh']:.0f}", _sig(r["speed_rms"]), f"{_sig(r['speed_max'])} ({r['speed_max_t']:.2f} s)",
                     _sig(r["gap_max"]), f"{r['final_gap_flc']:.2f} / {r['final_gap_sumo']:.2f}", first))
    before = max(r["gap_before_first"] for r in reps)
    return (table(("controller", "v (km/h)", "speed RMS (m/s)", "speed max (m/s, at)", "gap max (m)", "final gap flc / SUMO (m)",
                   "first speed difference > 1e-12 m/s"), rows, "lrrrrrl")
            + f"\nBefore each row's first speed difference the two worlds' gaps differ by at most {_sci(before)} m.\n")


def _closed_loop_max(law: str) -> float:
    return max(c["max_difference"] for c in _sumo_tables()["closed_loop"] if c["law"] == law)


@generator("sumo-closed-loop")
def sumo_closed_loop() -> str:
    """docs/sumo.md: the largest speed difference (m/s) between flc's law and SUMO's model of the
    same name in closed loop, per speed (``flc.sumo.closed_loop_difference``)."""
    cells = _sumo_tables()["closed_loop"]
    speeds = sorted({c["speed_kmh"] for c in cells})
    laws = list(dict.fromkeys(c["law"] for c in cells))
    by = {(c["law"], c["speed_kmh"]): c for c in cells}
    rows = [(law.upper(), *(_sci(by[(law, v)]["max_difference"]) for v in speeds)) for law in laws]
    steps = "the same number of steps" if all(c["steps_sumo"] == c["steps_flc"] for c in cells) else "different numbers of steps"
    return (table(("law (m/s)", *(f"{v:.0f} km/h" for v in speeds)), rows, "l" + "r" * len(speeds))
            + f"\nEvery pair of runs took {steps} to the stop.\n")


@generator("sumo-closed-loop-max")
def sumo_closed_loop_max() -> str:
    """docs/baselines.md: the closed-loop table's largest difference per law."""
    cells = _sumo_tables()["closed_loop"]
    lo, hi = min(c["speed_kmh"] for c in cells), max(c["speed_kmh"] for c in cells)
    return (f"- IDM: at most {_sci(_closed_loop_max('idm'))} m/s at any speed from {lo:.0f} to {hi:.0f} km/h;\n"
            f"- ACC: at most {_sci(_closed_loop_max('acc'))} m/s.\n")


def _ssm_cells(s: dict[str, Any]) -> tuple[str, str]:
    """SSM min TTC and max DRAC of a follower; ``-`` for both without a conflict."""
    ttc, drac = s.get("min_ttc"), s.get("max_drac")
    if ttc is None and not drac:
        return "-", "-"
    return ("-" if ttc is None else f"{ttc:.2f}"), f"{drac:.2f}"


def _collisions(p: dict[str, Any]) -> str:
    return "none" if not p["collisions"] else ", ".join(p["collisions"])


@generator("sumo-platoon-outage")
def sumo_platoon_outage() -> str:
    """docs/sumo.md: the CACC platoon whose V2V drops, beside SUMO's CACC on the same script
    (``flc.sumo.cacc_platoon(**flc.sumo.PLATOON_OUTAGE)``)."""
    data = _sumo_tables()["platoon_outage"]
    ours, ref = data["flc"], data["sumo_cacc"]
    rows = []
    for f, g in zip(ours["followers"], ref["followers"]):
        ttc, drac = _ssm_cells(f["ssm"])
        rttc, _ = _ssm_cells(g["ssm"])
        after = "-" if f.get("switch_to_flc_after") is None else f"{f['switch_to_flc_after']:.2f} s"
        rows.append((f["vehicle"], f["switches"], after, f"{f['min_gap']:.2f}", f"{f['max_decel']:.1f}", ttc, drac,
                     f"{g['min_gap']:.2f} m / {rttc} s"))
    n = sum(1 for f in ours["followers"] if f.get("active_after_outage") == "flc")
    return (table(("follower", "hand-overs", "to FLC after the outage", "min gap (m)", "max decel (m/s²)", "SSM min TTC (s)",
                   "SSM max DRAC (m/s²)", "SUMO CACC min gap / min TTC"), rows, "lrrrrrrl")
            + f"\nOn the FLC 1 s after the outage: {n} of {len(ours['followers'])} followers. SUMO's collisions: "
            f"{_collisions(ours)} (SUMO's CACC: {_collisions(ref)}).\n")


@generator("sumo-platoon-join")
def sumo_platoon_join() -> str:
    """docs/sumo.md: a car without V2V joins the platoon (``flc.sumo.cacc_platoon(**flc.sumo.PLATOON_JOIN)``),
    and the same run with the association off (``flc.sumo.NO_ASSOCIATION``)."""
    data = _sumo_tables()["platoon_join"]
    ours, off = data["flc"], data["no_association"]
    rows = []
    for f in ours["followers"]:
        ttc, drac = _ssm_cells(f["ssm"])
        on = f.get("active_after_join") == "flc"
        after = "-" if f.get("switch_to_flc_after_join") is None else f"{f['switch_to_flc_after_join']:.2f} s"
        rows.append((f["vehicle"], f["switches"], "**yes**" if on else "no", after, f"{f['time_not_associated']:.2f} s",
                     f"{f['min_gap']:.2f}", f"{f['max_decel']:.1f}", ttc, drac))
    k = data["arguments"]["join_after"]  # the follower behind the joining car is follower k + 1
    f3 = off["followers"][k]
    return (table(("follower", "hand-overs", "on the FLC 1 s after the join", "to FLC after the join", "not associated", "min gap (m)",
                   "max decel (m/s²)", "SSM min TTC (s)", "SSM max DRAC (m/s²)"), rows, "lrlrrrrrr")
            + f"\nSUMO's collisions: {_collisions(ours)}. With the association off: collisions {_collisions(off)}, "
            f"{f3['vehicle']}'s min gap {f3['min_gap']:.2f} m, on the FLC 1 s after the join: "
            f"{'yes' if f3.get('active_after_join') == 'flc' else 'no'}.\n")


#: docs/v2v-and-metrics.md §3.1: flc metric, SUMO output, same definition?, unit.
_SSM_ROWS = (
    ("min_ttc", "s", "`<conflict>` → `minTTC` (measure `TTC`)", "yes, for following: `g / (v_f − v_l)` at the current speeds, bumper gap"),
    ("max_drac", "m/s²", "`<conflict>` → `maxDRAC` (measure `DRAC`)", "yes, for following: `(v_f − v_l)² / (2 g)`"),
    ("min_gap", "m", "`<globalMeasures>` → `minSGAP` (measure `SGAP`, spacing)", "yes: bumper to bumper, without `minGap`"),
    ("min_time_headway", "s", "`<globalMeasures>` → `minTGAP` (measure `TGAP`, time headway)", "yes: `g / v_f`; flc skips `v_f <= 0.5 m/s`"),
    ("pet", "s", "`<conflict>` → `PET` (measure `PET`)",
     "no: SUMO's PET is for crossing and merging conflicts at junctions only; flc's is the cut-in PET above. Neither computes one for plain following"),
    ("tet", "s", "not output (rebuilt here from `TTCSpan` with `--device.ssm.trajectories true`: step length × number of values ≤ 3 s)", "—"),
    ("tit", "s²", "not output (rebuilt from `TTCSpan`: step length × Σ (3 s − value) over values ≤ 3 s)", "—"),
)


def _six(x: float) -> str:
    """SUMO's ``--precision 6`` value without trailing zeros."""
    return f"{x:.6f}".rstrip("0").rstrip(".")


@generator("sumo-ssm")
def sumo_ssm() -> str:
    """docs/v2v-and-metrics.md §3.1: flc's metrics against SUMO's SSM device on one trajectory
    (``flc.sumo.ssm_comparison``; docs/figures/sumo-tables.json)."""
    s = _sumo_tables()["ssm"]
    rows = []
    for key, unit, out, same in _SSM_ROWS:
        if key == "pet":
            diff = f"flc `{'null' if s['flc_pet'] is None else s['flc_pet']}`, SUMO `value=\"{s['sumo_pet']}\"` on this trajectory"
        else:
            fv, sv = s["flc"][key], s["sumo"][key]
            diff = f"{fv - sv:.1e} ({_six(sv)} {unit})"
        rows.append((f"`{key}` ({unit})", out, same, diff))
    return (table(("flc metric", "SUMO SSM output", "same definition?", "flc − SUMO on the trajectory below (SUMO's value)"), rows)
            + f"\nWith `vehicle.getLeader`'s distance (the gap minus the follower's `minGap`, 2.5 m) the min TTC would read "
            f"{s['min_ttc_leader_distance']:.2f} s instead of SUMO's {s['sumo']['min_ttc']:.2f} s.\n")


@generator("scenario-pet")
def scenario_pet(*paths: str) -> str:
    """docs/v2v-and-metrics.md: the cut-in PET of scenario files (``flc.run(flc.Scenario.load(path))``,
    what ``scenario --json --config FILE`` reports)."""
    res = run_all([Scenario.load(ROOT / p) for p in paths])
    parts = []
    for p, r in zip(paths, res):
        pet = r.metrics.get("pet")
        parts.append(f"`{Path(p).name}` {'`null`' if pet is None else f'{pet:.3f} s'}")
    return "PET of the scenario files: " + "; ".join(parts) + ".\n"


# ---------------------------------------------------------------------------------------------
# docs/baselines.md: the paper experiment, SUMO's models against flc's baselines


def _sumo_final(law: str, v: int) -> str:
    """The outcome of SUMO's own model in ``tests/data/sumo/<law>-paper-<v>.csv`` (written by
    ``tools/sumo_reference.py``): the gap at the last sample, or the first contact."""
    rows = [ln.split(",") for ln in (ROOT / "tests" / "data" / "sumo" / f"{law}-paper-{v}.csv").read_text().splitlines()[2:]]
    gaps = [(float(r[0]), float(r[5]), float(r[4]) - float(r[2])) for r in rows]
    hit = next((g for g in gaps if g[1] <= 0.0), None)
    if hit is not None:
        return f"contact {hit[2]:.1f} m/s"
    return f"stop {gaps[-1][1]:.1f} m"


#: The follower without its vehicle model's delays and resistances, with the true gap and lead
#: speed: the closest flc's closed loop comes to SUMO's (which moves the car as the law says).
IDEAL_FOLLOWER: dict[str, Any] = {
    "follower.perception": "ideal",
    "follower.vehicle.dead_time": 0.0,
    "follower.vehicle.lag": 0.0,
    "follower.vehicle.drag_cd": 0.0,
    "follower.vehicle.rolling_resistance": 0.0,
}


@generator("sumo-paper-baselines")
def sumo_paper_baselines() -> str:
    """SUMO's ACC and IDM (committed reference data) beside flc's ``acc`` and ``idm`` on the paper
    experiment (realistic preset, seed 1), with the LiDAR and with :data:`IDEAL_FOLLOWER`."""
    speeds = (30, 50, 70, 90, 110, 130)
    scs = [Scenario.paper(speed_kmh=float(v), controller=law, preset="realistic", **ov) for law in ("acc", "idm") for ov in ({}, IDEAL_FOLLOWER) for v in speeds]
    res = iter(run_all(scs))

    def short(r: RunResult) -> str:
        m = r.metrics
        if m["collision"]:
            return f"contact {m['impact_speed']:.1f} m/s"
        return f"stop {m['final_clearance']:.1f} m" if m.get("final_clearance") is not None else f"no stop, min {m['min_gap']:.1f} m"

    rows = []
    for law, name in (("acc", "ACC"), ("idm", "IDM")):
        rows.append([f"SUMO `{name}`", *(_sumo_final(law, v) for v in speeds)])
        rows.append([f"flc `{law}`, realistic vehicle + LiDAR", *(short(next(res)) for _ in speeds)])
        rows.append([f"flc `{law}`, ideal perception, no actuator dynamics or resistance", *(short(next(res)) for _ in speeds)])
    return table(["v (km/h)", *(str(v) for v in speeds)], rows)


# ---------------------------------------------------------------------------------------------
# Published OpenSCENARIO files against esmini (docs/openscenario/published.json, written by
# `python3 tools/published_check.py --pub DIR`; CI has no published files, so the block renders
# the committed file).


def _published() -> dict[str, Any]:
    path = ROOT / "docs" / "openscenario" / "published.json"
    if not path.is_file():
        raise FileNotFoundError("published: docs/openscenario/published.json is missing (tools/published_check.py writes it)")
    data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return data


def _ran(r: dict[str, Any]) -> bool:
    return bool(r["flc"]["status"] == "ok")


@generator("published-summary")
def published_summary() -> str:
    """docs/openscenario.md: the summary figures of the published files against esmini."""
    d = _published()
    files = d["files"]
    runs = [r for f in files for r in f["runs"]]
    imported = [f for f in files if f["runs"] and all(_ran(r) for r in f["runs"])]
    cmp_ = [r["compare"] for r in runs if "compare" in r]
    colls = ", ".join(f"{n} `{c['commit'][:12]}`" for n, c in sorted(d["collections"].items()))
    tol = d["tolerance"]
    rows = [
        ["files imported and run (every run of the file)", f"{len(imported)} of {len(files)}"],
        ["runs imported and run", f"{sum(_ran(r) for r in runs)} of {len(runs)}"],
        ["runs compared (flc wrote its per-entity trajectory)", f"{len(cmp_)} of {len(runs)}"],
        [f"runs with every entity within {tol['position_m']} m and {tol['speed_mps']} m/s", f"{sum(c['within'] for c in cmp_)} of {len(cmp_)}"],
        ["runs whose collisions match (same pair, within one step)", f"{sum(c['collisions_match'] for c in cmp_)} of {len(cmp_)}"],
        ["runs whose end times are equal (same step)", f"{sum(c['end_equal'] for c in cmp_)} of {len(cmp_)}"],
    ]
    head = (f"esmini {d['esmini']['version']} (commit {d['esmini']['commit']}), step {d['esmini']['step_s']} s; flc "
            f"`{d['flc']['commit']}` (`--permutation`: {'yes' if d['flc'].get('permutation') else 'no'}); collections: {colls}; "
            f"checked {d['generated']}.\n\n")
    return head + table(["", "count"], rows, "lr")


@generator("published-files")
def published_files() -> str:
    """docs/openscenario.md: one row per published file with the first reason of a difference."""
    d = _published()
    rows = []
    for f in d["files"]:
        runs = f["runs"]
        cmp_ = [r["compare"] for r in runs if "compare" in r]
        reasons = sorted({r["reason"] for r in runs if r.get("reason")})
        qc = ", ".join(f"{k.split(':')[-1]} {v}" for k, v in sorted((f.get("asam_qc") or {}).items())) or "0"
        rows.append([
            f"{f['collection']}/{f['path'].split('/')[-1]}",
            f"{f.get('permutations', 1)}",
            f"{sum(_ran(r) for r in runs)}/{len(runs)}",
            f"{sum(c['within'] for c in cmp_)}/{len(cmp_)}",
            (reasons[0][:160] + (f" (+{len(reasons) - 1} more)" if len(reasons) > 1 else "")) if reasons else "equal",
            qc,
        ])
    return table(["file", "runs in file", "run by flc", "within tolerance", "difference (first reason)", "ASAM checker issues"], rows, "lrrrll")


# ---------------------------------------------------------------------------------------------
# The published files in controller mode against esmini's ALKS controller
# (docs/openscenario/controller.json, written by `python3 tools/published_controller_check.py
# --pub DIR`; CI has no published files, so the blocks render the committed file).


def _controller_check() -> dict[str, Any]:
    path = ROOT / "docs" / "openscenario" / "controller.json"
    if not path.is_file():
        raise FileNotFoundError("controller-check: docs/openscenario/controller.json is missing (tools/published_controller_check.py writes it)")
    data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return data


def _ego_contacts(r: dict[str, Any]) -> list[dict[str, Any]]:
    return [c for c in r.get("contacts") or [] if r.get("ego") in c["pair"]]


def _controller_runs(d: dict[str, Any]) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """(file, run) of every run flc imported."""
    return [(f, r) for f in d["files"] for r in f["runs"] if "flc" not in r and r["players"]]


@generator("controller-check-summary")
def controller_check_summary() -> str:
    """docs/careful-driver.md: per player, the published runs flc imports in controller mode
    and esmini with its ALKS controller: runs, contacts of the ego, contacts where esmini's
    ALKS controller (the reference model) had none, far stops, in-path objects passed."""
    d = _controller_check()
    runs = _controller_runs(d)
    ref = "esmini:" + d["definitions"]["esmini_reference"]
    players = [f"esmini:{m}" for m in (d["esmini"] or {}).get("models", [])] + d["flc"]["controllers"]
    rows = []
    for who in players:
        ok = [(f, r) for f, r in runs if r["players"].get(who, {}).get("status") == "ok"]
        hit = [(f, r) for f, r in ok if _ego_contacts(r["players"][who])]
        if who.startswith("esmini:") or not any(ref in r["players"] for _, r in runs):
            beyond = "-"
        else:
            beyond = str(sum(1 for f, r in hit if r["players"].get(ref, {}).get("status") == "ok" and not _ego_contacts(r["players"][ref])))
        rows.append([
            who.replace("esmini:", "esmini ALKS_R157SM ") if who.startswith("esmini:") else f"flc `{who}`",
            f"{len(ok)} of {len(runs)}",
            str(len(hit)),
            beyond,
            str(sum(1 for f, r in ok if r["players"][who]["far_stops"])),
            str(sum(1 for f, r in ok if r["players"][who]["passed"])),
        ])
    colls = ", ".join(f"{n} `{c['commit'][:12]}`" for n, c in sorted(d["collections"].items()))
    e = d["esmini"] or {}
    unfinished = sum(1 for f in d["files"] for r in f["runs"] if (r.get("flc") or {}).get("status") == "not run")
    refused = sum(1 for f in d["files"] for r in f["runs"] if (r.get("flc") or {}).get("status") not in (None, "not run"))
    head = (f"{len(runs)} runs of {len({f['path'] for f, _ in runs})} published files that flc imports ({refused} runs flc refuses"
            f"{f', {unfinished} not run yet' if unfinished else ''}); esmini {e.get('version', '-')} "
            f"(commit {e.get('commit', '-')}); flc `{d['flc']['commit']}`; collections: {colls}; checked {d['generated']}.\n\n")
    return head + table(["driver", "runs", "runs with a contact", "of them where esmini's ReferenceDriver had none", "runs with a far stop",
                         "runs passing an in-path object"], rows, "lrrrrr")


@generator("controller-check-findings")
def controller_check_findings() -> str:
    """docs/careful-driver.md: every run of the controller check with a contact, a far stop or
    a passed in-path object, and what esmini's ALKS controller did there."""
    d = _controller_check()
    ref = "esmini:" + d["definitions"]["esmini_reference"]
    rows = []
    for f, r in _controller_runs(d):
        for who, p in r["players"].items():
            if who.startswith("esmini:") or p.get("status") != "ok":
                continue
            bits = []
            for c in _ego_contacts(p):
                other = [n for n in c["pair"] if n != p["ego"]][0]
                bits.append(f"contact with {other} at {c['time']:.2f} s, {c['speeds'].get(p['ego'], 0.0):.1f} m/s")
            for s in p["far_stops"]:
                short = "nothing in path" if s["gap_m"] is None else f"{s['gap_m']:.0f} m short"
                bits.append(f"far stop at {s['time']:.2f} s ({short})")
            for q in p["passed"]:
                bits.append(f"passed {q['object']} at {q['time']:.2f} s, {q['ego_speed']:.1f} m/s, {q['clearance_m']:.2f} m clear")
            if not bits:
                continue
            e = r["players"].get(ref, {})
            es = "not run" if e.get("status") != "ok" else "; ".join(
                f"contact with {[n for n in c['pair'] if n != e['ego']][0]}, {c['speeds'].get(e['ego'], 0.0):.1f} m/s" for c in _ego_contacts(e)) or "no contact"
            perm = "" if r["permutation"] is None else f" p{r['permutation']}"
            rows.append([f"{f['path'].split('/')[-1].replace('.xosc', '')}{perm}", f"`{who}`", "; ".join(bits), es])
    if not rows:
        return "No run has a contact, a far stop or a passed in-path object.\n"
    return table(["run", "controller", "what happened", "esmini ReferenceDriver"], rows)


# ---------------------------------------------------------------------------------------------
# Safety evidence (docs/safety-evidence.md)


@generator("falsify-benchmarks")
def falsify_benchmarks(seeds: str = "1,2,3,4,5") -> str:
    """docs/safety-evidence.md: evaluations the CMA-ES falsifier needs to find the paper PID's and
    the paper FLC's collision at 90 km/h (scenarios/falsify/paper-{pid,flc}-90.toml), per seed,
    stopping at the first generation with a negative robustness."""
    from ._falsify import falsify, load_spec

    rows = []
    for name in ("paper-pid-90", "paper-flc-90"):
        spec = load_spec(ROOT / "scenarios" / "falsify" / f"{name}.toml")
        spec["search"]["stop_below"] = 0.0
        found = []
        for seed in [int(s) for s in seeds.split(",")]:
            r = falsify(spec, seed=seed)
            found.append(r.first_violation)
            w = r.worst
            rows.append([
                f"`{name}.toml`",
                str(seed),
                "not found" if r.first_violation is None else str(r.first_violation),
                f"{w.robustness:.3f}",
                f"{w.point['lead.phases[2].decel']:.2f}",
            ])
        ok = sorted(f for f in found if f is not None)
        med = "-" if len(ok) < len(found) else f"{ok[len(ok) // 2]}"
        rows.append([f"`{name}.toml`", "median", med, "", ""])
    budget = spec["search"]["budget"]
    head = f"Budget {budget} evaluations per search; population {spec['search']['population']}.\n\n"
    return head + table(["spec", "seed", "evaluations to the first collision", "least robustness (m)", "its lead braking (m/s²)"], rows, "lrrrr")


@generator("falsify-summary")
def falsify_summary(path: str) -> str:
    """docs/safety-evidence.md: the committed result of a long search (``falsify.json`` written by
    ``python -m flc falsify SPEC --out DIR``; the command is in the document)."""
    d = json.loads((ROOT / path).read_text(encoding="utf-8"))
    rows = [
        ["requirement", f"`{d['requirement']}`"],
        ["evaluations", str(d["evaluations"])],
        ["least robustness (m)", f"{d['min_robustness']:.4f}"],
        ["runs with contact", str(d["collisions"])],
        ["first negative robustness at evaluation", "-" if d["first_violation"] is None else str(d["first_violation"])],
        ["the worst case (evaluation)", str(d["worst_index"])],
    ]
    pts = [[f"`{k}`", f"{v:.4g}"] for k, v in d["worst_point"].items()]
    return table(["", ""], rows, "lr") + "\n\nThe worst case's point:\n\n" + table(["dimension", "value"], pts, "lr")


@generator("arch-acc")
def arch_acc_table() -> str:
    """docs/safety-evidence.md: the ARCH-COMP ACC benchmark's property on 27 samples per
    controller (:mod:`flc.arch_acc`)."""
    from . import arch_acc

    rows = [
        [
            f"`{r['controller']}`",
            str(r["samples"]),
            str(r["violations"]),
            str(r["collisions"]),
            f"{r['min_robustness']:.2f}",
            "gap {:.1f} m, lead {:.1f} m/s, ego {:.1f} m/s".format(*r["worst"]),
        ]
        for r in arch_acc.evaluate()
    ]
    return table(["controller", "samples", "violations", "contacts", "least robustness (m)", "at"], rows, "lrrrrl")


@generator("reach-map")
def reach_map(path: str) -> str:
    """docs/safety-evidence.md: the certified (speed, gap) map of the paper FLC next to the
    simulated outcome at the same starts (``path``: the JSON of ``python -m flc.reach map --out
    PATH``, cross-checked by ``python -m flc.reach check --out PATH``; both commands are in the
    document). The simulated column runs now (one run per node)."""
    from . import reach

    d = json.loads((ROOT / path).read_text(encoding="utf-8"))
    nodes = d["nodes"]
    speeds = sorted({n["speed"] for n in nodes})
    gaps = sorted({n["gap"] for n in nodes})
    at = {(n["speed"], n["gap"]): n for n in nodes}
    a_lo, a_hi = d["decel"]
    runs = run_all([reach.start_scenario(v, g, a_hi, horizon=d["horizon"]) for v in speeds for g in gaps])
    sim = {(v, g): r for (v, g), r in zip([(v, g) for v in speeds for g in gaps], runs)}

    def cell(v: float, g: float) -> str:
        n = at[(v, g)]
        mark = "**B**" if n["box_certified"] else ("P" if n["point_certified"] else "·")
        r = sim[(v, g)]
        return mark + (" ✗" if r.metrics["collision"] else " ✓")

    rows = [[f"{v:g}"] + [cell(v, g) for g in gaps] for v in speeds]
    head = table(["speed (m/s) \\ gap (m)"] + [f"{g:g}" for g in gaps], rows, "l" + "c" * len(gaps))
    nb = sum(n["box_certified"] for n in nodes)
    npt = sum(n["point_certified"] for n in nodes)
    nsafe = sum(not r.metrics["collision"] for r in runs)
    bad = [(v, g) for (v, g), n in at.items() if (n["box_certified"] or n["point_certified"]) and sim[(v, g)].metrics["collision"]]
    cw, gw = d["cell"]
    lines = [
        head,
        f"\n**B**: the start box `[v, v + {cw:g}] x [gap, gap + {gw:g}]` with the lead braking at "
        f"{a_lo:g}-{a_hi:g} m/s² is certified ({nb} of {len(nodes)} nodes); P: only the start itself "
        f"(with every range error of the model) is ({npt - sum(n['box_certified'] and n['point_certified'] for n in nodes)} more); "
        f"·: neither. ✓ / ✗: the simulator's run from the node (lead at {a_hi:g} m/s²) stops without "
        f"contact / collides ({nsafe} of {len(runs)} without contact). "
        f"Certified nodes whose simulation collides: {len(bad)}.",
    ]
    cc = d.get("crosscheck")
    if cc:
        lines.append(
            f"\n\nCross-check (`python -m flc.reach check`): {cc['runs']} simulated starts inside the certified "
            f"boxes (their corners and random points), {len(cc['collisions'])} collisions; least simulated gap "
            f"{cc['least_gap']:.2f} m; least margin over the certified lower bound {cc['least_margin']:.4f} m "
            f"(must be >= 0); largest range error of the detector {cc['max_range_error']:.1e} m "
            f"(the model allows {d['model']['noise']:.0e} m per frame); largest lateral offset {cc['max_lateral_offset']:.1e} m; "
            f"frames whose detection differs from the model's (none at t = 0, one at every later frame): {cc['frames_not_as_modelled']}."
        )
    return "".join(lines) + "\n"


@generator("reach-arch")
def reach_arch(path: str) -> str:
    """docs/safety-evidence.md: the ARCH-COMP ACC initial set verified for the paper FLC (``path``:
    the JSON of ``python -m flc.reach arch --out PATH``, then ``check``)."""
    d = json.loads((ROOT / path).read_text(encoding="utf-8"))
    b = d["box"]
    rows = [
        ["initial set", f"gap {b['gap'][0]:g}-{b['gap'][1]:g} m, lead {b['vl'][0]:g}-{b['vl'][1]:g} m/s, ego {b['v'][0]:g}-{b['v'][1]:g} m/s, lead -{b['decel'][0]:g} m/s², {d['horizon']:g} s"],
        ["verdict", "**certified**" if d["certified"] else "not certified"],
        ["boxes after refinement", str(len(d["leaves"]))],
        ["most branch paths in a box", str(max(l["paths"] for l in d["leaves"]))],
        ["least lower bound of `D_rel - 10 - 1.4 v_ego` (m)", f"{d['least']:.2f}"],
    ]
    cc = d.get("crosscheck")
    if cc:
        rows.append(["simulated starts in the set (corners + random)", f"{cc['runs']}, {len(cc['collisions'])} collisions, least margin over the bound {cc['least_margin']:.3f} m"])
        rows.append(["their largest range error / lateral offset (m)", f"{cc['max_range_error']:.1e} / {cc['max_lateral_offset']:.1e}"])
        rows.append(["their frames detecting otherwise than the model", str(cc["frames_not_as_modelled"])])
    return table(["", ""], rows, "ll")


@generator("reach-model")
def reach_model() -> str:
    """docs/safety-evidence.md: the constants of :mod:`flc.reach` (its model, its refinement, the
    map and the ARCH-COMP check)."""
    from . import reach

    sig = __import__("inspect").signature
    paths = sig(reach.certify).parameters["max_paths"].default
    syms = sig(reach._run_batch).parameters["max_symbols"].default
    sp, gp = reach.MAP_SPEEDS, reach.MAP_GAPS
    rows = [
        ["range error: constant bias, per frame (m)", f"±{reach.BIAS:g}, ±{reach.NOISE:g}"],
        ["contact margin: the gap's lower bound must stay above (m)", f"{reach.CONTACT_MARGIN:g}"],
        ["widening of every bound per physics step (relative, absolute m)", f"{reach.WIDEN[0]:g}, {reach.WIDEN[1]:g}"],
        ["branch paths per box before they are merged", str(paths)],
        ["symbols kept at each frame (the start box's among them)", f"{syms} ({reach.K0})"],
        ["map nodes: speed (m/s), gap (m)", f"{sp[0]:g}-{sp[-1]:g} every {sp[1] - sp[0]:g}; {gp[0]:g}-{gp[-1]:g} every {gp[1] - gp[0]:g}"],
        ["map start box at a node: speed, gap widths", f"{reach.MAP_CELL[0]:g} m/s, {reach.MAP_CELL[1]:g} m"],
        ["map lead deceleration (m/s²), horizon (s)", f"{reach.MAP_DECEL[0]:g}-{reach.MAP_DECEL[1]:g}, {reach.MAP_HORIZON:g}"],
        ["map: bisections of a start box at most", str(reach.MAP_DEPTH)],
        ["ARCH-COMP horizon (s)", f"{reach.ARCH_HORIZON:g}"],
    ]
    return table(["", ""], rows, "ll")
