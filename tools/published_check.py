#!/usr/bin/env python3
"""Plays published OpenSCENARIO files in flc (`--ego-mode scripted`) and in esmini, compares them.

For every `.xosc` scenario or ParameterValueDistribution under the given folders (or given files;
catalogs are passed over), and for a distribution its permutations 0, N/3, 2N/3 and N-1 (0-based,
esmini's `--param_permutation`): runs esmini 3.6.0 headless (10 ms step, `--disable_controllers`,
`--collision`, as tools/esmini_reference.py) and `scenario --config F --ego-mode scripted
[--permutation i] --out DIR --json --threads 1`, reads flc's per-entity trajectory CSV
(`t,entity,x,y,heading,speed`) and contacts, and compares each entity by name: position and speed
at every common step, collisions (same pair, start within one step), end time (same step). Writes
the committed data file (default docs/openscenario/published.json) that `python -m flc docs`
renders into docs/openscenario.md. Only the Python standard library.

    python3 tools/published_check.py --pub /work/scratch/pub -j 2          # the 53 published files
    python3 tools/published_check.py DIR_OR_FILE... --data out.json        # any files
    python3 tools/published_check.py --pub /work/scratch/pub --only 4_6_2 --out /tmp/check   # some, into a scratch folder

Resumable: each run's result is cached in `--work` (default target/published-check/) under a key
of the file's bytes, the distribution's scenario file, the collection's commit, the permutation and
the flc / esmini binaries' hashes; a changed input recomputes the run, never serves the old one.
"""
from __future__ import annotations

import argparse
import concurrent.futures
import csv
import datetime
import hashlib
import json
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
sys.path.insert(0, str(Path(__file__).resolve().parent))
import esmini_reference as er  # noqa: E402

STEP = 0.01
POS_TOL, SPEED_TOL = 0.05, 0.05
TIMEOUT_S = 900
#: The published set (docs/openscenario.md, "Published files against esmini"): (collection folder, subfolder, files or None for all below).
STANDARD_SET = [
    ("OSC-NCAP-scenarios", "OpenSCENARIO/NCAP/AEB_C2C_2023", None),
    ("OSC-ALKS-scenarios", "logical_scenarios", None),
    ("esmini", "resources/xosc", ["acc-test.xosc", "alks_cut-in.xosc", "alks_cut-out.xosc", "alks_decelerate.xosc",
                                  "alks_r157_cut_in_quick_brake.xosc", "cut-in_simple.xosc"]),
]
COLLISION = re.compile(r"^\[(-?\d+\.\d+)\] \[warn\] Collision between (.+?) and (.+?)\s*$")
TRAJ_HEAD = ["t", "entity", "x", "y", "heading", "speed"]


def sha(*parts: bytes) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(hashlib.sha256(p).digest())
    return h.hexdigest()


def file_hash(p: Path) -> bytes:
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.digest()


def git(d: Path, *args: str) -> str:
    p = subprocess.run(["git", "-C", str(d), *args], capture_output=True, text=True)
    return p.stdout.strip() if p.returncode == 0 else ""


def collection(path: Path) -> tuple[str, str, str, bool]:
    """(collection name, path inside it, commit, clean) of a file in a git checkout."""
    top = git(path.parent, "rev-parse", "--show-toplevel")
    if not top:
        return path.parent.name, path.name, "", False
    dirty = bool(git(Path(top), "status", "--porcelain"))
    return Path(top).name, str(path.resolve().relative_to(Path(top).resolve())), git(Path(top), "rev-parse", "HEAD"), not dirty


def kind(path: Path) -> str:
    try:
        return er.kind(path)
    except ET.ParseError:
        return "unreadable"


def discover(paths: list[Path]) -> list[Path]:
    out = []
    for p in paths:
        files = sorted(p.rglob("*.xosc")) if p.is_dir() else [p]
        out += [f for f in files if kind(f) in ("scenario", "distribution", "unreadable")]
    return sorted(set(f.resolve() for f in out))


def run(cmd: list[str], cwd: Path, timeout: float) -> tuple[int, str, str]:
    try:
        p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
        return p.returncode, p.stdout, p.stderr
    except subprocess.TimeoutExpired:
        return 124, "", f"timed out after {timeout:g} s"


# ---------------------------------------------------------------------------------------------
# esmini


def esmini_count(esmini: Path, dist: Path) -> int:
    scen, _ = er.dist_parameters(dist)
    code, out, _ = run([str(esmini), "--headless", "--osc", str(scen), "--param_dist", str(dist), "--return_nr_permutations"],
                       dist.parent, 120)
    m = re.search(r"Nr permutations: (\d+)", out)
    return int(m.group(1)) if m else code


def esmini_run(esmini: Path, dat2csv: Path, file: Path, perm: int | None, timeout: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="pubcheck-esmini-") as tmp:
        work = Path(tmp)
        if perm is None:
            extra, scen = [], file
        else:
            scen, _ = er.dist_parameters(file)
            extra = ["--param_dist", str(file), "--param_permutation", str(perm)]
        cmd = [str(esmini), "--headless", "--fixed_timestep", f"{STEP}", "--seed", "1", "--disable_controllers", "--collision",
               "--osc", str(scen), *extra, "--record", str(work / "run.dat"), "--logfile_path", str(work / "run.log"), "--disable_stdout"]
        code, out, err = run(cmd, work, timeout)
        logs, dats = sorted(work.glob("run*.log")), sorted(work.glob("run*.dat"))
        log = logs[0].read_text(errors="replace") if logs else ""
        # A run whose StopTrigger never fires goes on until esmini is killed (it has no duration
        # flag): what it recorded until then is compared, marked `cut`.
        cut = code == 124
        if (code != 0 and not cut) or not dats:
            return {"status": "timeout" if cut else "failed", "message": (err.strip() or log.strip())[-300:]}
        c2, _, e2 = run([str(dat2csv), "--file", str(dats[0]), "--csv", str(work / "run.csv"), "--precision", "6"], work, 120)
        if c2 != 0:
            return {"status": "failed", "message": f"dat2csv: {e2.strip()[-300:]}"}
        with open(work / "run.csv", newline="") as f:
            rows = [[c.strip() for c in r] for r in csv.reader(f)]
    head = rows[0]
    ix = {n: head.index(n) for n in ("time", "name", "x", "y", "h", "speed")}
    traj = [(float(r[ix["time"]]), r[ix["name"]], float(r[ix["x"]]), float(r[ix["y"]]), float(r[ix["h"]]), float(r[ix["speed"]]))
            for r in rows[1:] if r and r[0]]
    cols = []
    for line in log.splitlines():
        m = COLLISION.match(line)
        if m and not line.rstrip().endswith("dissolved"):
            cols.append([float(m.group(1)), *sorted([m.group(2), m.group(3)])])
    params = er.logged_parameters(log) if perm is not None else {}
    if cut and not traj:
        return {"status": "timeout", "message": f"timed out after {timeout:g} s, nothing recorded"}
    return {"status": "ok", "traj": traj, "collisions": cols, "end_time": max((t[0] for t in traj), default=0.0), "params": params,
            "cut": cut}


# ---------------------------------------------------------------------------------------------
# flc


def flc_features(flc: Path) -> dict:
    code, out, err = run([str(flc), "--help"], ROOT, 60)
    text = out + err
    return {"permutation": "--permutation " in text or "--permutation <" in text, "max_duration": "--max-duration" in text}


def flc_run(flc: Path, file: Path, perm: int | None, features: dict, timeout: float) -> dict:
    if perm is not None and not features["permutation"]:
        return {"status": "skipped", "message": "this flc has no --permutation flag (one permutation of a distribution cannot be run)"}
    with tempfile.TemporaryDirectory(prefix="pubcheck-flc-") as tmp:
        cmd = [str(flc), "--config", str(file), "--ego-mode", "scripted", "--out", tmp, "--json", "--threads", "1"]
        if perm is not None:
            cmd += ["--permutation", str(perm)]
        code, out, err = run(cmd, ROOT, timeout)
        errors = [ln for ln in err.splitlines() if ln.startswith("error")]
        if code != 0:
            status = {2: "refused", 124: "timeout"}.get(code, "failed")
            msg = (errors[-1] if errors else err.strip().splitlines()[-1] if err.strip() else f"exit {code}")
            top = git(file.parent, "rev-parse", "--show-toplevel") or str(file.parent)
            msg = msg.replace(str(file.parent) + "/", "").replace(top + "/", "")  # paths as in the collection
            return {"status": status, "message": msg[:300]}
        records = [json.loads(ln) for ln in out.splitlines() if ln.startswith("{")]
        traj = None
        for f in sorted(Path(tmp).rglob("*.csv")):
            with open(f, newline="") as fh:
                r = csv.reader(fh)
                head = [c.strip() for c in next(r, [])]
                if head[:6] == TRAJ_HEAD:
                    traj = [(float(x[0]), x[1], float(x[2]), float(x[3]), float(x[4]), float(x[5])) for x in r if x]
                    break
    rec = records[0] if records else {}
    cols = []
    for c in rec.get("contacts") or []:
        names = sorted(str((c.get(k) or {}).get("name")) for k in ("a", "b"))
        cols.append([float(c.get("time", math.nan)), *names])
    if not rec.get("contacts") and rec.get("collision_info"):
        ci = rec["collision_info"]
        cols.append([float(ci["time"]), *sorted(["<ego>", str((ci.get("object") or {}).get("name"))])])
    warnings = sum(1 for ln in err.splitlines() if ln.startswith("warning"))
    # flc's guard cut the run: its StopTrigger had not fired by --max-duration.
    cut = any(ln.startswith("warning") and "cut at --max-duration" in ln for ln in err.splitlines())
    return {"status": "ok", "traj": traj, "collisions": cols, "warnings": warnings, "cut": cut,
            "end_time": max((t[0] for t in traj), default=0.0) if traj else rec.get("duration")}


# ---------------------------------------------------------------------------------------------
# comparison


def compare(f: dict, e: dict) -> dict:
    """Largest differences per entity over the common steps, and the verdicts."""
    by = lambda traj: {(round(t / STEP), n): (x, y, h, v) for t, n, x, y, h, v in traj}  # noqa: E731
    a, b = by(f["traj"]), by(e["traj"])
    names_f, names_e = {k[1] for k in a}, {k[1] for k in b}
    worst: dict[str, list] = {}
    for key in sorted(a.keys() & b.keys()):  # in time order: the first step of a maximum, reproducibly
        (x1, y1, _, v1), (x2, y2, _, v2) = a[key], b[key]
        dp, dv = math.hypot(x1 - x2, y1 - y2), abs(v1 - v2)
        w = worst.setdefault(key[1], [0.0, 0.0, 0.0, 0.0])
        if dp > w[0]:
            w[0], w[2] = dp, key[0] * STEP
        if dv > w[1]:
            w[1], w[3] = dv, key[0] * STEP
    only_f, only_e = sorted(names_f - names_e), sorted(names_e - names_f)
    max_dp = max((w[0] for w in worst.values()), default=math.nan)
    max_dv = max((w[1] for w in worst.values()), default=math.nan)
    within = bool(worst) and not only_f and not only_e and max_dp <= POS_TOL and max_dv <= SPEED_TOL

    def match(c1, c2):
        used = set()
        for t, p, q in c1:
            hit = [i for i, (t2, p2, q2) in enumerate(c2) if i not in used and (p, q) == (p2, q2) and abs(t - t2) <= STEP + 1e-9]
            if not hit:
                return False
            used.add(hit[0])
        return len(used) == len(c2)

    # Neither run ended (the file's StopTrigger never fires: esmini killed at the timeout, flc cut
    # by its --max-duration guard): the same outcome, compared over the steps both recorded.
    never = bool(f.get("cut")) and bool(e.get("cut"))
    horizon = min(f["end_time"] or 0.0, e["end_time"]) + STEP if never else math.inf
    cols_ok = match([c for c in f["collisions"] if c[0] <= horizon], [c for c in e["collisions"] if c[0] <= horizon])
    end_ok = never or (f["end_time"] is not None and round(f["end_time"] / STEP) == round(e["end_time"] / STEP))
    reasons = []
    if only_e:
        reasons.append(f"only esmini has {', '.join(only_e)}")
    if only_f:
        reasons.append(f"only flc has {', '.join(only_f)}")
    if worst and max_dp > POS_TOL:
        n, w = max(worst.items(), key=lambda kv: kv[1][0])
        reasons.append(f"position {w[0]:.3f} m ({n}, t {w[2]:.2f} s)")
    if worst and max_dv > SPEED_TOL:
        n, w = max(worst.items(), key=lambda kv: kv[1][1])
        reasons.append(f"speed {w[1]:.3f} m/s ({n}, t {w[3]:.2f} s)")
    if not cols_ok:
        show = lambda cs: "; ".join(f"{p}-{q} {t:.2f} s" for t, p, q in cs) or "none"  # noqa: E731
        reasons.append(f"collisions: flc {show(f['collisions'])}, esmini {show(e['collisions'])}")
    if not end_ok:
        reasons.append(f"end time: flc {f['end_time']} s, esmini {e['end_time']:.2f} s")
    return {"entities": len(worst), "max_position_m": None if math.isnan(max_dp) else round(max_dp, 4),
            "max_speed_mps": None if math.isnan(max_dv) else round(max_dv, 4), "within": within, "collisions_match": cols_ok,
            "end_equal": end_ok, "never_ends": never, "reason": "; ".join(reasons)}


def one_run(task: dict, tools: dict, work: Path) -> dict:
    key = task["key"]
    cache = work / "runs" / f"{key}.json"
    if cache.is_file():
        return json.loads(cache.read_text())
    file, perm = Path(task["file"]), task["perm"]
    f = flc_run(tools["flc"], file, perm, tools["features"], tools["timeout"])
    # esmini only when there is an flc run to compare with (a refused or skipped run needs none).
    e = esmini_run(tools["esmini"], tools["dat2csv"], file, perm, tools["timeout"]) if f["status"] == "ok" else {"status": "not run"}
    out = {"permutation": perm, "params": e.get("params", {}),
           "esmini": {k: v for k, v in e.items() if k not in ("traj", "params")},
           "flc": {k: v for k, v in f.items() if k != "traj"}}
    if f["status"] != "ok":
        out["reason"] = f"flc {f['status']}: {f.get('message', '')}"
    elif e["status"] != "ok":
        out["reason"] = f"esmini {e['status']}: {e.get('message', '')}"
    elif not f.get("traj"):
        out["reason"] = "flc ran but wrote no per-entity trajectory CSV (t,entity,x,y,heading,speed) with --out"
    else:
        out["compare"] = compare(f, e)
        out["reason"] = out["compare"]["reason"]
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(out) + "\n")
    return out


def permutations(n: int) -> list[int]:
    return sorted({0, n // 3, 2 * n // 3, n - 1}) if n > 0 else []


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("paths", nargs="*", help="folders (every scenario / distribution .xosc below) or files")
    ap.add_argument("--pub", help="folder holding OSC-NCAP-scenarios, OSC-ALKS-scenarios and esmini: adds the 53 published files (docs/openscenario.md)")
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--flc", default=str(ROOT / "target" / "release" / "scenario"), help="the scenario binary (cargo build --release)")
    ap.add_argument("--esmini", help="folder of the headless esmini build (default ../shared/tools/esmini or $ESMINI_DIR)")
    ap.add_argument("--work", default=str(ROOT / "target" / "published-check"), help="cache of finished runs (resumable)")
    ap.add_argument("--data", default=str(ROOT / "docs" / "openscenario" / "published.json"))
    ap.add_argument("--timeout", type=float, default=TIMEOUT_S, help="seconds per esmini or flc run (a cut run is reported as a timeout)")
    ap.add_argument("--only", metavar="SUBSTRING", action="append", help="run only the files whose path contains SUBSTRING (repeatable)")
    ap.add_argument("--out", metavar="DIR", help="write the data file and the run cache into DIR (instead of --data / --work; a scratch measurement)")
    ap.add_argument("--asam-qc", metavar="PYTHON", help="also record ASAM's checker findings (a python with tools/asam_qc-requirements.txt)")
    args = ap.parse_args(argv)
    paths = [Path(p) for p in args.paths]
    if args.pub:
        for coll, sub, names in STANDARD_SET:
            base = Path(args.pub) / coll / sub
            paths += [base] if names is None else [base / n for n in names]
    missing = [str(p) for p in paths if not p.exists()]
    if not paths or missing:
        print(f"error: nothing to check{': missing ' + ', '.join(missing) if missing else ' (give folders, files or --pub)'}", file=sys.stderr)
        return 2
    flc = Path(args.flc)
    if not (flc.is_file() and os.access(flc, os.X_OK)):
        print(f"error: {flc}: no flc binary (cargo build --release --bin scenario, or --flc PATH)", file=sys.stderr)
        return 2
    try:
        esmini, dat2csv, version = er.find_esmini(args.esmini or str(er.DEFAULT_ESMINI if er.DEFAULT_ESMINI.exists() else Path("/work/shared/tools/esmini")))
    except er.EsminiError as ex:
        print(f"error: {ex}", file=sys.stderr)
        return 2
    tools = {"flc": flc, "esmini": esmini, "dat2csv": dat2csv, "features": flc_features(flc), "timeout": args.timeout}
    bins = file_hash(flc) + file_hash(esmini.resolve()) + Path(__file__).read_bytes() + str(args.timeout).encode()
    files = discover(paths)
    if args.only:
        files = [f for f in files if any(o in str(f) for o in args.only)]
    if args.out:
        args.work, args.data = str(Path(args.out) / "work"), str(Path(args.out) / "published.json")
    colls: dict[str, dict] = {}
    entries, tasks = [], []
    for file in files:
        name, inside, commit, clean = collection(file)
        colls.setdefault(name, {"commit": commit})
        k = kind(file)
        entry = {"collection": name, "path": inside, "kind": k, "runs": []}
        entries.append(entry)
        if k == "unreadable":
            entry["reason"] = "not well-formed XML"
            continue
        if k == "distribution":
            scen, _ = er.dist_parameters(file)
            entry["permutations"] = esmini_count(esmini, file)
            perms = permutations(entry["permutations"])
            extra = scen.read_bytes() if scen.is_file() else b""
        else:
            perms, extra = [None], b""
        for p in perms:
            key = sha(file.read_bytes(), extra, commit.encode() if clean else os.urandom(8), str(p).encode(), bins)
            tasks.append((entry, {"file": str(file), "perm": p, "key": key}))
    work = Path(args.work)
    print(f"{len(files)} files, {len(tasks)} runs; flc {flc} (--permutation: {'yes' if tools['features']['permutation'] else 'no'}); "
          f"-j {args.jobs}; cache {work}", file=sys.stderr)
    done = 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futs = {pool.submit(one_run, t, tools, work): (entry, t) for entry, t in tasks}
        for fut in concurrent.futures.as_completed(futs):
            entry, t = futs[fut]
            r = fut.result()
            entry["runs"].append(r)
            done += 1
            print(f"[{done}/{len(tasks)}] {entry['collection']}/{entry['path']} p{t['perm']}: {r['reason'] or 'equal'}", file=sys.stderr)
    for e in entries:
        e["runs"].sort(key=lambda r: -1 if r["permutation"] is None else r["permutation"])
    if args.asam_qc:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "qc.json"
            subprocess.run([args.asam_qc, str(ROOT / "tools" / "asam_qc.py"), "--no-fail", "--json", str(out), *map(str, files)],
                           capture_output=True, text=True)
            if out.is_file():
                qc = {str(Path(r["file"]).resolve()): r["issues"] for r in json.loads(out.read_text())["files"]}
                for file, entry in zip(files, entries):
                    rules: dict[str, int] = {}
                    for i in qc.get(str(file), []):
                        rules[i["rule"]] = rules.get(i["rule"], 0) + 1
                    entry["asam_qc"] = rules
    data = {
        "generated": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d"),
        "command": "python3 tools/published_check.py " + " ".join(a for a in (argv if argv is not None else sys.argv[1:])),
        "esmini": {"version": version[0], "commit": version[1], "step_s": STEP, "flags": "--headless --fixed_timestep 0.01 --seed 1 --disable_controllers --collision"},
        "flc": {"commit": git(ROOT, "describe", "--always", "--dirty"), "flags": "--ego-mode scripted", **tools["features"]},
        "tolerance": {"position_m": POS_TOL, "speed_mps": SPEED_TOL, "collision_steps": 1},
        "collections": colls,
        "files": sorted(entries, key=lambda e: (e["collection"], e["path"])),
    }
    Path(args.data).parent.mkdir(parents=True, exist_ok=True)
    Path(args.data).write_text(json.dumps(data, indent=1, sort_keys=False) + "\n")
    print(f"wrote {args.data}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
