"""Reference trajectories from esmini for this project's own OpenSCENARIO fixtures (issue 21).

Plays every scenario in ``tests/data/openscenario/*.xosc`` with esmini 3.6.0 headless (fixed
time step 0.01 s, ``--seed 1``, ``--disable_controllers`` so that every entity, the ego included,
follows its storyboard with esmini's default controller), and every combination of every
``ParameterValueDistribution`` file there, one process per run under ``timeout 60``. Each run is
recorded (``--record``), converted with ``dat2csv --extended --precision 6`` and written to
``tests/data/esmini/``:

* ``<fixture>.csv`` (``<fixture>_<i>.csv`` for run i of a distribution, i from 0): a few ``# ``
  header lines (esmini version, the exact commands, the date), then
  ``time,entity,x,y,heading,speed,road_id,lane_id,lane_offset,s,t``, one row per entity per step
  from t = 0, numbers with 6 decimals. x, y are the entity's reference point (for vehicles the
  rear axle, not the bounding-box centre), heading in (-pi, pi] (esmini writes [0, 2 pi)),
  lane_offset from the lane centre and t from the reference line;
* ``<fixture>.events.csv`` (``<fixture>_<i>.events.csv``): ``time,element,from,to``, every
  storyboard state transition esmini's log reports (``[t] [info] NAME fromState -> xTransition
  -> toState``; init actions are named ``Init <entity> <action type>``);
* ``<fixture>.params.csv`` for a distribution: ``run`` and each distributed parameter's value as
  esmini's log of that run lists it.

Usage (needs the headless esmini build of ``../shared/tools/esmini``, see its README.md)::

    python3 tools/esmini_reference.py [--esmini DIR] [--out tests/data/esmini] [FIXTURE ...]

Written for this project; the fixtures are this project's own files (no esmini resource is read
or copied). Only the Python standard library is used.
"""
from __future__ import annotations

import argparse
import csv
import datetime
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "tests" / "data" / "openscenario"
DEFAULT_ESMINI = ROOT.parent / "shared" / "tools" / "esmini"
#: esmini's --version prints "N/A" for this build; the README of the build names the release.
FALLBACK_VERSION = ("3.6.0", "77028d83")
STEP = "0.01"
SEED = "1"
TIMEOUT_S = 60
COLUMNS = ["time", "entity", "x", "y", "heading", "speed", "road_id", "lane_id", "lane_offset", "s", "t"]
TRANSITION = re.compile(r"^\[(-?\d+\.\d+)\] \[info\] (.+?) (\w+State) -> (\w+Transition) -> (\w+State)\s*$")
PERMUTATION = re.compile(r"Parameter permutation (\d+)/(\d+)")


class EsminiError(RuntimeError):
    pass


def rel(p: Path | str) -> str:
    """A path relative to the repository root (as the header lines show it)."""
    return os.path.relpath(Path(p).resolve(), ROOT)


def find_esmini(arg: str | None) -> tuple[Path, Path, tuple[str, str]]:
    base = Path(arg) if arg else Path(os.environ.get("ESMINI_DIR", DEFAULT_ESMINI))
    esmini, dat2csv = base / "bin" / "esmini", base / "bin" / "dat2csv"
    for exe in (esmini, dat2csv):
        if not (exe.is_file() and os.access(exe, os.X_OK)):
            raise EsminiError(
                f"esmini not found: {exe} is missing or not executable. This script needs the headless esmini 3.6.0 "
                f"build described in {rel(DEFAULT_ESMINI / 'README.md')} (pass --esmini DIR or set ESMINI_DIR to its folder)."
            )
    version = FALLBACK_VERSION
    readme = base / "README.md"
    if readme.is_file():
        m = re.search(r"release\s+(\d+\.\d+\.\d+)\s*\(commit\s+([0-9a-f]+)\)", readme.read_text(errors="replace"))
        if m:
            version = (m.group(1), m.group(2))
    return esmini, dat2csv, version


def kind(path: Path) -> str:
    root = ET.parse(path).getroot()
    if root.find("ParameterValueDistribution") is not None:
        return "distribution"
    if root.find("Storyboard") is not None:
        return "scenario"
    return "other"


def dist_parameters(path: Path) -> tuple[Path, list[str]]:
    pvd = ET.parse(path).getroot().find("ParameterValueDistribution")
    scenario = (path.parent / pvd.find("ScenarioFile").get("filepath")).resolve()
    names: list[str] = []
    for el in pvd.iter():
        n = el.get("parameterName") if el.tag == "DeterministicSingleParameterDistribution" else (
            el.get("parameterRef") if el.tag == "ParameterAssignment" else None)
        if n and n not in names:
            names.append(n)
    return scenario, names


def num(v: str) -> str:
    x = float(v)
    s = f"{x:.6f}"
    return "0.000000" if s == "-0.000000" else s


def heading(v: str) -> str:
    h = math.remainder(float(v), 2 * math.pi)  # (-pi, pi]
    if h <= -math.pi:
        h += 2 * math.pi
    return num(repr(h))


def run(cmd: list[str], what: str) -> subprocess.CompletedProcess:
    try:
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=TIMEOUT_S + 30)
    except subprocess.TimeoutExpired:
        raise EsminiError(f"{what}: timed out") from None
    if p.returncode == 124:
        raise EsminiError(f"{what}: esmini ran past {TIMEOUT_S} s (does the file's StopTrigger fire?)")
    if p.returncode != 0:
        raise EsminiError(f"{what}: exit code {p.returncode}\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")
    return p


def play(esmini: Path, dat2csv: Path, tmp: Path, scenario: Path, extra: list[str], tag: str) -> tuple[list[list[str]], str, list[str]]:
    """Run one scenario (or one permutation), return (trajectory rows, log text, command lines)."""
    work = tmp / tag
    work.mkdir()
    cmd = ["timeout", str(TIMEOUT_S)] if shutil.which("timeout") else []
    cmd += [rel(esmini), "--headless", "--fixed_timestep", STEP, "--seed", SEED, "--disable_controllers",
            "--osc", rel(scenario), *extra, "--record", str(work / "run.dat"), "--logfile_path", str(work / "run.log"),
            "--disable_stdout"]
    run(cmd, f"esmini on {rel(scenario)} {' '.join(extra)}")
    # With --param_dist esmini appends _<i+1>_of_<N> to the record and log names.
    dats, logs = sorted(work.glob("run*.dat")), sorted(work.glob("run*.log"))
    if len(dats) != 1 or len(logs) != 1:
        raise EsminiError(f"esmini on {rel(scenario)}: expected one record and one log in {work}, got {dats} {logs}")
    csv_path = work / "run.csv"
    conv = [rel(dat2csv), "--file", str(dats[0]), "--csv", str(csv_path), "--extended", "--precision", "6"]
    run(conv, f"dat2csv on {dats[0]}")
    with open(csv_path, newline="") as f:
        rows = [[c.strip() for c in r] for r in csv.reader(f)]
    head = rows[0]
    want = ["time", "id", "name", "x", "y", "z", "h", "p", "r", "roadId", "laneId", "offset", "t", "s", "speed"]
    if head[: len(want)] != want:
        raise EsminiError(f"dat2csv: unexpected columns {head}")
    out = []
    for r in rows[1:]:
        if not r or not r[0]:
            continue
        out.append([num(r[0]), r[2], num(r[3]), num(r[4]), heading(r[6]), num(r[14]), r[9], r[10], num(r[11]), num(r[13]), num(r[12])])
    shown = lambda c: " ".join(a if not a.startswith(str(work)) else "<tmp>/" + os.path.relpath(a, work) for a in c)
    return out, logs[0].read_text(errors="replace"), [shown(cmd), shown(conv)]


def transitions(log: str) -> list[list[str]]:
    out = []
    for line in log.splitlines():
        m = TRANSITION.match(line)
        if m:
            out.append([num(m.group(1)), m.group(2), m.group(3), m.group(5)])
    return out


def logged_parameters(log: str) -> dict[str, str]:
    """The `N parameters:` block esmini logs after loading (values as esmini resolved them)."""
    vals: dict[str, str] = {}
    lines = log.splitlines()
    for i, line in enumerate(lines):
        if re.search(r"\[info\] \d+ parameters:\s*$", line):
            for nxt in lines[i + 1:]:
                m = re.match(r"^\[[^\]]*\] \[info\]\s{3,}(\S+) = (.*?)\s*$", nxt)
                if not m:
                    break
                vals[m.group(1)] = m.group(2)
            break
    return vals


def header(version: tuple[str, str], commands: list[str], source: str) -> list[str]:
    return [
        f"# esmini {version[0]} (commit {version[1]}; its --version prints N/A), headless, fixed time step {STEP} s, seed {SEED}, "
        f"--disable_controllers (default controller: every entity follows its storyboard)",
        *[f"# command: {c}" for c in commands],
        f"# source: {source} (this project's own fixture); generated {datetime.date.today().isoformat()} by tools/esmini_reference.py",
    ]


def write_csv(path: Path, head: list[str], columns: list[str], rows: list[list[str]]) -> None:
    with open(path, "w", newline="") as f:
        for h in head:
            f.write(h + "\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(columns)
        w.writerows(rows)


def check_stopped(log: str, what: str) -> None:
    if not re.search(r"storyBoard runningState -> stopTransition -> completeState", log):
        print(f"warning: {what}: the storyboard's StopTrigger did not fire", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--esmini", help=f"folder of the esmini build (default {rel(DEFAULT_ESMINI)} or $ESMINI_DIR)")
    ap.add_argument("--out", default=str(ROOT / "tests" / "data" / "esmini"))
    ap.add_argument("fixtures", nargs="*", help="fixture names (default: every tests/data/openscenario/*.xosc)")
    args = ap.parse_args(argv)
    try:
        esmini, dat2csv, version = find_esmini(args.esmini)
    except EsminiError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    files = sorted(FIXTURES.glob("*.xosc"))
    if args.fixtures:
        wanted = {Path(f).stem for f in args.fixtures}
        files = [f for f in files if f.stem in wanted]
        missing = wanted - {f.stem for f in files}
        if missing:
            print(f"error: no fixture {', '.join(sorted(missing))} in {rel(FIXTURES)}", file=sys.stderr)
            return 2
    try:
        with tempfile.TemporaryDirectory(prefix="esmini-ref-") as tmpd:
            tmp = Path(tmpd)
            for path in files:
                k = kind(path)
                name = path.stem
                if k == "scenario":
                    rows, log, cmds = play(esmini, dat2csv, tmp, path, [], name)
                    check_stopped(log, name)
                    head = header(version, cmds, rel(path))
                    write_csv(out / f"{name}.csv", head, COLUMNS, rows)
                    ev = transitions(log)
                    write_csv(out / f"{name}.events.csv", head, ["time", "element", "from", "to"], ev)
                    print(f"{rel(out / (name + '.csv'))}: {len(rows)} rows, {len({r[1] for r in rows})} entities, "
                          f"t_end {rows[-1][0]}; {len(ev)} transitions")
                elif k == "distribution":
                    scenario, pnames = dist_parameters(path)
                    n_runs, params_rows, params_cmds = None, [], []
                    i = 0
                    while n_runs is None or i < n_runs:
                        extra = ["--param_dist", rel(path), "--param_permutation", str(i)]
                        rows, log, cmds = play(esmini, dat2csv, tmp, scenario, extra, f"{name}_{i}")
                        m = PERMUTATION.search(log)
                        if not m or int(m.group(1)) != i + 1:
                            raise EsminiError(f"{name}: esmini's log does not report permutation {i + 1}")
                        n_runs = int(m.group(2))
                        check_stopped(log, f"{name} run {i}")
                        vals = logged_parameters(log)
                        missing = [p for p in pnames if p not in vals]
                        if missing:
                            raise EsminiError(f"{name} run {i}: parameters {missing} not in esmini's log")
                        params_rows.append([str(i)] + [vals[p] for p in pnames])
                        params_cmds.append(cmds[0])
                        head = header(version, cmds, f"{rel(path)} run {i} of {n_runs} over {rel(scenario)}")
                        write_csv(out / f"{name}_{i}.csv", head, COLUMNS, rows)
                        write_csv(out / f"{name}_{i}.events.csv", head, ["time", "element", "from", "to"], transitions(log))
                        print(f"{rel(out / f'{name}_{i}.csv')}: {len(rows)} rows, " + ", ".join(f"{p}={v}" for p, v in zip(pnames, params_rows[-1][1:])))
                        i += 1
                    head = header(version, [params_cmds[0], f"(and the same with --param_permutation 1 to {n_runs - 1}, one process per run)"],
                                  f"{rel(path)} over {rel(scenario)}, {n_runs} runs in esmini's order (the last distribution varies fastest)")
                    head.insert(1, "# values as esmini's log of each run lists them (its 'N parameters:' block after loading)")
                    write_csv(out / f"{name}.params.csv", head, ["run"] + pnames, params_rows)
    except EsminiError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
