"""Euro NCAP's 2026 rating calculator on the ``ncap-ccr-2026`` suite (docs/standard-suites.md).

The calculator is Euro NCAP's own open-source package ``euroncap-rating-2026`` (Apache-2.0, on
the Python index; ``pip install 'flc[ncap]'``). For one controller this module

1. has the calculator write its Crash Avoidance template (``generate-template``; the template is
   never copied into flc),
2. fills the Car-to-Car Rear prediction grid (CCRs, CCRm, CCRb: every VUT speed at the seven
   impact locations) with the colour bands of the controller's runs, self-claimed
   ("Self claimed" prediction, standard and extended range), and the Car & PTW robustness sheet
   with ``NO`` for every layer of the three scenarios (flc runs no robustness layer; an empty
   column would make the calculator divide by zero),
3. lets the calculator draw its verification points (``preprocess``, its random draw seeded
   with ``seed``) and writes, for each point drawn, the relative impact speed of that run,
4. with :func:`score_workbook`, runs ``compute-score`` and reads its points per scenario and
   layer, the Longitudinal category and the Car & PTW stage element, each with its maximum.

Every other scenario of the template is declared ``N/A`` (not claimed: zero points). Command line::

    python -m flc.ncap REPORT.json --controller NAME --workbook FILE.xlsx [--score] [--seed N]
    python -m flc.ncap REPORT.json --all --out SCORES.json     # every controller (docs data)

``scenario suite ncap-ccr-2026 --controllers NAME --ncap-workbook FILE.xlsx`` runs the suite and
then this module.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence

#: The scenarios of the suite, as the calculator's sheets name them.
SCENARIOS = ("CCRs", "CCRm", "CCRb")
#: The calculator's prediction sheet and verification sheet for Car & PTW frontal collisions.
PRED_SHEET = "FC - Car & PTW pred."
VERIF_SHEET = "FC - Car & PTW verif."
ROBUST_SHEET = "FC - Car & PTW robust. pred."
#: The calculator's band names, best first (flc's JSON writes them in lower case).
BANDS = ("Green", "Yellow", "Orange", "Brown", "Red")
INSTALL = "pip install 'flc[ncap]'"


class NcapError(ValueError):
    """A report that cannot fill the workbook (a cell not run, a controller not in it) or a
    calculator that fails; the message names what."""


def _require_calculator() -> None:
    try:
        import euroncap_rating_2026  # noqa: F401
        import openpyxl  # noqa: F401
    except ImportError as e:
        raise ImportError(f"the Euro NCAP calculator is not installed ({e}): {INSTALL}") from e


def _calculator(args: Sequence[str], cwd: Path, seed: Optional[int] = None) -> None:
    """Runs the calculator's command line (``euroncap_rating_2026 crash_avoidance ...``) in
    ``cwd`` (it writes its files and log there), its random draw seeded when ``seed`` is given."""
    code = "import random, sys\n"
    if seed is not None:
        code += f"random.seed({int(seed)})\n"
    code += "from euroncap_rating_2026.cli import cli\nsys.argv = ['euroncap_rating_2026'] + sys.argv[1:]\ncli()\n"
    p = subprocess.run([sys.executable, "-c", code, "crash_avoidance", *args], cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        tail = (p.stderr or p.stdout).strip().splitlines()[-1:] or ["no output"]
        raise NcapError(f"the calculator's `{' '.join(args[:1])}` failed (exit {p.returncode}): {tail[0]}")


def _kmh(text: Any) -> float:
    return float(str(text).replace("km/h", "").strip())


def cells(report: Mapping[str, Any], controller: str) -> dict[tuple[str, float, float, float], dict[str, Any]]:
    """The controller's 2026 runs by cell ``(scenario, VUT km/h, target km/h, impact location
    %)``: each run's ``ncap`` record (``band``, ``impact_speed_kmh``, ...)."""
    if controller not in report.get("controllers", []):
        raise NcapError(f"controller {controller!r}: not in the report (it has {', '.join(report.get('controllers', []))})")
    out: dict[tuple[str, float, float, float], dict[str, Any]] = {}
    for r in report.get("results", []):
        n = r.get("ncap")
        if r.get("controller") != controller or r.get("case") not in SCENARIOS or not n or n.get("band") is None:
            continue
        out[(r["case"], n["vut_speed_kmh"], n["target_speed_kmh"], n["impact_location"])] = n
    if not out:
        raise NcapError(f"the report {report.get('name')!r} has no 2026 Car-to-Car Rear runs (`band`): run the suite ncap-ccr-2026")
    return out


def report_fingerprint(report: Mapping[str, Any], controller: str) -> str:
    """A hash of what the workbook takes from the report for a controller (each cell's band and
    impact speed): the docs data is refused when it no longer matches the report."""
    grid = sorted((list(k), v["band"], v["impact_speed_kmh"]) for k, v in cells(report, controller).items())
    return hashlib.sha256(json.dumps(grid).encode()).hexdigest()[:16]


def _fill_template(path: Path, grid: Mapping[tuple[str, float, float, float], Mapping[str, Any]]) -> int:
    import openpyxl

    wb = openpyxl.load_workbook(path)
    ws = wb["Input parameters"]
    scenario = None
    for r in range(2, ws.max_row + 1):
        scenario = ws.cell(r, 5).value or scenario
        parameter = ws.cell(r, 6).value
        if not parameter:
            continue
        claimed = scenario in SCENARIOS and str(parameter).startswith("Prediction")
        ws.cell(r, 7).value = "Self claimed" if claimed else "N/A"
    ws = wb[ROBUST_SHEET]
    cols = {ws.cell(1, c).value: c for c in range(1, ws.max_column + 1)}
    for s in SCENARIOS:
        for r in range(2, ws.max_row + 1):
            if ws.cell(r, 2).value:
                ws.cell(r, cols[s]).value = "NO"
    ws = wb[PRED_SHEET]
    block: Optional[str] = None
    locations: list[Any] = []
    filled = 0
    for r in range(1, ws.max_row + 1):
        a = ws.cell(r, 1).value
        if isinstance(a, str) and "km/h" not in a:
            block, locations = a.strip(), []
            continue
        if block in SCENARIOS and a is None and isinstance(ws.cell(r, 4).value, (int, float)):
            locations = [(c, 100.0 * float(ws.cell(r, c).value)) for c in range(4, 11) if ws.cell(r, c).value is not None]
            continue
        if block in SCENARIOS and isinstance(a, str) and "km/h" in a:
            vut, target = _kmh(a), _kmh(ws.cell(r, 2).value)
            for c, il in locations:
                key = (block, vut, target, il)
                if key not in grid:
                    raise NcapError(f"{block} {vut:g}/{target:g} km/h at impact location {il:g} %: not run (the workbook would be left untested)")
                ws.cell(r, c).value = grid[key]["band"].capitalize()
                filled += 1
    wb.save(path)
    return filled


def _fill_verification(path: Path, grid: Mapping[tuple[str, float, float, float], Mapping[str, Any]]) -> list[dict[str, Any]]:
    import openpyxl

    wb = openpyxl.load_workbook(path)
    ws = wb[VERIF_SHEET]
    head, cols = None, {}
    drawn = []
    for r in range(1, ws.max_row + 1):
        if ws.cell(r, 1).value == "Scenario" and ws.cell(r, 3).value == "VUT speed":
            head, cols = r, {ws.cell(r, c).value: c for c in range(1, ws.max_column + 1)}
            continue
        s = ws.cell(r, 1).value
        if head is None or s not in SCENARIOS:
            continue
        vut, target = _kmh(ws.cell(r, cols["VUT speed"]).value), _kmh(ws.cell(r, cols["Target speed"]).value)
        il = float(str(ws.cell(r, cols["Impact location"]).value).replace("%", ""))
        key = (s, vut, target, il)
        if key not in grid:
            raise NcapError(f"the calculator drew {s} {vut:g}/{target:g} km/h at {il:g} %, which the report does not hold")
        ws.cell(r, cols["Value"]).value = grid[key]["impact_speed_kmh"]
        drawn.append({"scenario": s, "vut_speed_kmh": vut, "target_speed_kmh": target, "impact_location": il,
                      "range": ws.cell(r, cols["Range"]).value, "value": grid[key]["impact_speed_kmh"]})
    wb.save(path)
    return drawn


def fill_workbook(report: Mapping[str, Any], controller: str, path: "str | os.PathLike[str]", seed: int = 0) -> dict[str, Any]:
    """Writes the calculator's workbook for ``controller`` to ``path``, ready for
    ``compute-score``: predictions from its runs, verification values for the points the
    calculator drew (seeded with ``seed``). Returns ``{"cells": N, "drawn": [...]}``."""
    _require_calculator()
    grid = cells(report, controller)
    with tempfile.TemporaryDirectory(prefix="flc-ncap-") as tmp:
        d = Path(tmp)
        _calculator(["generate-template"], d)
        template = d / "ca_template.xlsx"
        filled = _fill_template(template, grid)
        if filled != len(grid):
            raise NcapError(f"{controller}: {len(grid)} runs but the calculator's grid has {filled} cells")
        _calculator(["preprocess", "-i", str(template), "-o", str(d)], d, seed=seed)
        pre = d / "ca_preprocessed_template.xlsx"
        drawn = _fill_verification(pre, grid)
        Path(path).write_bytes(pre.read_bytes())
    return {"cells": filled, "drawn": drawn}


def score_workbook(path: "str | os.PathLike[str]") -> dict[str, Any]:
    """Runs the calculator's ``compute-score`` on a filled workbook and returns its points:
    ``scenarios`` (``{"CCRs": {"Standard": [score, max], "Extended": ..., "Robustness": ...,
    "Total": ...}, ...}``), ``longitudinal`` and ``car_ptw`` (``[score, max]``)."""
    _require_calculator()
    import openpyxl

    with tempfile.TemporaryDirectory(prefix="flc-ncap-score-") as tmp:
        d = Path(tmp)
        _calculator(["compute-score", "-i", str(Path(path).resolve()), "-o", str(d)], d)
        reports = sorted(d.glob("ca_*_report.xlsx"))
        if not reports:
            raise NcapError("the calculator's compute-score wrote no report")
        wb = openpyxl.load_workbook(reports[-1], data_only=True)
    scenarios: dict[str, dict[str, list[float]]] = {}
    ws, scenario = wb["Scenario Scores"], None
    for row in ws.iter_rows(min_row=2, values_only=True):
        scenario = row[4] or scenario
        if scenario in SCENARIOS and row[5]:
            scenarios.setdefault(scenario, {})[row[5]] = [float(row[6]), float(row[7])]
    for s in scenarios.values():
        s["Total"] = [round(sum(v[0] for v in s.values()), 6), round(sum(v[1] for v in s.values()), 6)]
    longitudinal = car_ptw = None
    for row in wb["Category Scores"].iter_rows(min_row=2, values_only=True):
        if row[2] == "Car & PTW" and row[3] == "Longitudinal":
            longitudinal = [float(row[4]), float(row[5])]
    for row in wb["Test Scores"].iter_rows(min_row=2, values_only=True):
        if row[1] == "Frontal Collisions" and row[2] == "Car & PTW":
            car_ptw = [float(row[3]), float(row[4])]
    if longitudinal is None or car_ptw is None or set(scenarios) != set(SCENARIOS):
        raise NcapError("the calculator's report lacks the Car & PTW Longitudinal scores")
    return {"scenarios": scenarios, "longitudinal": longitudinal, "car_ptw": car_ptw}


def score(report: Mapping[str, Any], controller: str, seed: int = 0, workbook: "str | os.PathLike[str] | None" = None) -> dict[str, Any]:
    """:func:`fill_workbook` then :func:`score_workbook` for one controller (the workbook kept at
    ``workbook`` when given)."""
    with tempfile.TemporaryDirectory(prefix="flc-ncap-wb-") as tmp:
        path = Path(workbook) if workbook is not None else Path(tmp) / "workbook.xlsx"
        info = fill_workbook(report, controller, path, seed=seed)
        points = score_workbook(path)
    return {"controller": controller, "cells": info["cells"], "drawn": len(info["drawn"]), **points}


def table(scores: Sequence[Mapping[str, Any]]) -> str:
    """The points as Markdown, one line per controller: each scenario's total, Longitudinal,
    Car & PTW, with the maxima in the header."""
    if not scores:
        return ""
    first = scores[0]
    heads = [f"{s} (of {first['scenarios'][s]['Total'][1]:g})" for s in SCENARIOS]
    heads += [f"Longitudinal (of {first['longitudinal'][1]:g})", f"Car & PTW (of {first['car_ptw'][1]:g})"]
    out = ["| controller | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
    for sc in scores:
        vals = [f"{sc['scenarios'][s]['Total'][0]:.3f}" for s in SCENARIOS]
        vals += [f"{sc['longitudinal'][0]:.3f}", f"{sc['car_ptw'][0]:.3f}"]
        out.append(f"| {sc['controller']} | " + " | ".join(vals) + " |")
    return "\n".join(out) + "\n"


def describe(sc: Mapping[str, Any]) -> str:
    """One controller's points, scenario by scenario and layer by layer, as text."""
    lines = [f"Euro NCAP 2026 calculator, {sc['controller']} ({sc['cells']} cells predicted, {sc['drawn']} verification points drawn):"]
    for s in SCENARIOS:
        layers = sc["scenarios"][s]
        parts = ", ".join(f"{k} {v[0]:.3f} / {v[1]:g}" for k, v in layers.items() if k != "Total")
        lines.append(f"  {s}: {layers['Total'][0]:.3f} / {layers['Total'][1]:g} ({parts})")
    lines.append(f"  Longitudinal: {sc['longitudinal'][0]:.3f} / {sc['longitudinal'][1]:g}")
    lines.append(f"  Car & PTW: {sc['car_ptw'][0]:.3f} / {sc['car_ptw'][1]:g}")
    return "\n".join(lines) + "\n"


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m flc.ncap", description="Euro NCAP's 2026 calculator on an ncap-ccr-2026 report")
    ap.add_argument("report", help="the suite's JSON report (scenario suite ncap-ccr-2026 --out DIR: DIR/ncap-ccr-2026.json)")
    ap.add_argument("--controller", help="the controller whose workbook to fill")
    ap.add_argument("--workbook", help="write the filled workbook here (.xlsx)")
    ap.add_argument("--score", action="store_true", help="run the calculator on it and print its points")
    ap.add_argument("--all", action="store_true", help="score every controller of the report")
    ap.add_argument("--out", help="with --all: write the points as JSON here")
    ap.add_argument("--seed", type=int, default=0, help="seed of the calculator's draw of verification points (default 0)")
    a = ap.parse_args(argv)
    try:
        report = json.loads(Path(a.report).read_text())
        if a.all:
            scores = []
            for c in report["controllers"]:
                sc = score(report, c, seed=a.seed)
                sc["report_fingerprint"] = report_fingerprint(report, c)
                scores.append(sc)
            text = json.dumps({"suite": report.get("name"), "seed": a.seed, "scores": scores}, indent=1) + "\n"
            if a.out:
                Path(a.out).write_text(text)
            print(table(scores), end="")
            return 0
        if not a.controller or not a.workbook:
            ap.error("give --controller and --workbook (or --all)")
        info = fill_workbook(report, a.controller, a.workbook, seed=a.seed)
        print(f"{a.workbook}: {a.controller}, {info['cells']} cells predicted, {len(info['drawn'])} verification points filled")
        if a.score:
            sc = score_workbook(a.workbook)
            print(describe({"controller": a.controller, "cells": info["cells"], "drawn": len(info["drawn"]), **sc}), end="")
        return 0
    except ImportError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except (NcapError, OSError, KeyError, json.JSONDecodeError) as e:
        print(f"error: {a.report}: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
