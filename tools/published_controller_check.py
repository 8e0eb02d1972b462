#!/usr/bin/env python3
"""Plays published OpenSCENARIO files in flc's controller mode and with esmini's own ALKS controller.

The outside check of the in-path definition (docs/careful-driver.md): for every scenario or
ParameterValueDistribution that tools/published_check.py checks (the same files, the same
permutations 0, N/3, 2N/3 and N-1), and that flc imports, runs

* flc with the ego driven by each controller of ``--controllers`` (``scenario --config F
  --ego-mode controller [--permutation i] --set controller=NAME --out DIR --json --threads 1``);
* esmini 3.6.0 headless (10 ms step, ``--collision``) with its own ``ALKS_R157SM_Controller`` on
  the ego for each model of ``--esmini-models`` (ReferenceDriver: UN R157's careful and competent
  driver; Regulation: R157's ALKS performance). The file is copied into a scratch folder with that
  controller on the ego (an ``ObjectController`` already there is replaced; the ALKS collection's
  own ``ALKSController`` names no esmini controller) and, unless the file activates the ego's
  controller itself, activated longitudinally in the Init (lateral control stays with the
  storyboard, as in esmini's own ALKS files); catalog folders are made absolute and the file's
  own folder is given to esmini with ``--path``. The copy is never kept.

and records per run the ego's contacts (the pair, the time, both speeds), the closest approach
to an object in the ego's path, the in-path objects the ego passed and the far stops
(:func:`analyse`). Writes the committed data file (default docs/openscenario/controller.json)
that ``python -m flc docs`` renders into docs/careful-driver.md. Only the Python standard library.

    python3 tools/published_controller_check.py --pub /work/scratch/pub -j 2     # the published set
    python3 tools/published_controller_check.py FILE... --no-esmini --data x.json  # flc only

Resumable as tools/published_check.py: each run is cached in ``--work`` (default
target/published-controller-check/) under a key of the file's bytes, the distribution's scenario
file, the collection's commit, the permutation, the controller or model and the binaries' and this
script's hashes.
"""
from __future__ import annotations

import argparse
import bisect
import concurrent.futures
import csv
import datetime
import gzip
import inspect
import json
import math
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import published_check as pc  # noqa: E402

er = pc.er
ROOT = pc.ROOT
STEP = pc.STEP

#: flc's registry names: the careful driver (UN R157's reference), the robust FLC, the paper's FLC,
#: the detector-fed pipeline.
CONTROLLERS = ["careful-driver", "flc-robust", "flc", "pipeline"]
#: The careful driver: the controller whose contacts are held against esmini's ALKS controller's.
REFERENCE = "careful-driver"
ESMINI_MODELS = ["ReferenceDriver", "Regulation"]
#: esmini's model the reference's contacts are held against (R157's careful and competent driver).
ESMINI_REFERENCE = "ReferenceDriver"

#: Margin of the swept-path corridor on each side of the ego's body, m (crates/flc-sim/src/sim/
#: path.rs, ``CORRIDOR_MARGIN``): an object whose body comes within it of the band the ego's body
#: sweeps is in the ego's path.
CORRIDOR_MARGIN = 0.5
#: Half the width of the ego's lane band, m: a 3.5 m lane (every lane of the ALKS roads and of
#: esmini's straight road), centred on the ego's path. An object whose body reaches into the band
#: or into the corridor is *in the ego's path* for this check.
LANE_HALF = 1.75
#: A far stop: the ego standing (below STAND_SPEED) for at least STAND_TIME with nothing in its
#: path within FAR_STOP of its front.
FAR_STOP = 50.0
STAND_SPEED = 0.1
#: 3 s: longer than a driver takes to set off again once the way is clear.
STAND_TIME = 3.0


# ---------------------------------------------------------------------------------------------
# Geometry: the ego's swept path from its own trajectory


class SweptPath:
    """The path the ego's box centre drove, as a polyline with arc length, extended 50 m beyond
    both ends along its first and last heading: road coordinates that need no road (``s`` along
    the ego's own path, ``t`` across it, + left). An ego that keeps its lane drives its lane; the
    band its body sweeps is this path widened by half its width."""

    def __init__(self, pts: list[tuple[float, float, float]]):
        xy: list[tuple[float, float]] = []
        for x, y, _ in pts:
            # One vertex a metre: a chord of 1 m on R = 250 m is 0.5 mm off the arc.
            if not xy or math.hypot(x - xy[-1][0], y - xy[-1][1]) > 1.0:
                xy.append((x, y))
        if len(xy) >= 1 and (pts[-1][0], pts[-1][1]) != xy[-1]:
            xy.append((pts[-1][0], pts[-1][1]))
        h0, h1 = pts[0][2], pts[-1][2]
        if len(xy) >= 2:
            h0 = math.atan2(xy[1][1] - xy[0][1], xy[1][0] - xy[0][0])
            h1 = math.atan2(xy[-1][1] - xy[-2][1], xy[-1][0] - xy[-2][0])
        # Beyond its last point the path goes on 200 m with the curvature of its last 20 m (or of all of it, 5 m at least) (the
        # road of a stopped ego curves on as before); before its first, 50 m straight back.
        k1 = 0.0
        back = next((i for i in range(len(xy) - 2, -1, -1) if math.hypot(xy[-1][0] - xy[i][0], xy[-1][1] - xy[i][1]) >= 20.0), 0)
        if len(xy) >= 3 and math.hypot(xy[-1][0] - xy[back][0], xy[-1][1] - xy[back][1]) >= 5.0:
            hb = math.atan2(xy[back + 1][1] - xy[back][1], xy[back + 1][0] - xy[back][0])
            d = math.hypot(xy[-1][0] - xy[back][0], xy[-1][1] - xy[back][1])
            k1 = math.remainder(h1 - hb, math.tau) / d
        tail, (x, y), h = [], xy[-1], h1
        for _ in range(200):
            x, y, h = x + math.cos(h + 0.5 * k1), y + math.sin(h + 0.5 * k1), h + k1
            tail.append((x, y))
        xy = [(xy[0][0] - 50.0 * math.cos(h0), xy[0][1] - 50.0 * math.sin(h0))] + xy + tail
        self.xy = xy
        self.s = [0.0]
        for (x0, y0), (x1, y1) in zip(xy, xy[1:]):
            self.s.append(self.s[-1] + math.hypot(x1 - x0, y1 - y0))
        # A coarse grid of segment indices for the nearest-segment search.
        self.cell = 10.0
        self.grid: dict[tuple[int, int], list[int]] = {}
        for i, ((x0, y0), (x1, y1)) in enumerate(zip(xy, xy[1:])):
            n = max(1, int(math.hypot(x1 - x0, y1 - y0) / self.cell) + 1)
            for k in range(n + 1):
                x, y = x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n
                self.grid.setdefault((int(x // self.cell), int(y // self.cell)), []).append(i)

    def project(self, x: float, y: float) -> tuple[float, float, float]:
        """``(s, t, heading)`` of the point nearest to (x, y) on the path."""
        cx, cy = int(x // self.cell), int(y // self.cell)
        cands: set[int] = set()
        r = 1
        while not cands and r < 64:
            for i in range(cx - r, cx + r + 1):
                for j in range(cy - r, cy + r + 1):
                    cands.update(self.grid.get((i, j), ()))
            r *= 2
        if not cands:
            cands = set(range(len(self.xy) - 1))
        best = (math.inf, 0.0, 0.0, 0.0)
        for i in cands:
            (x0, y0), (x1, y1) = self.xy[i], self.xy[i + 1]
            dx, dy = x1 - x0, y1 - y0
            ll = dx * dx + dy * dy
            u = 0.0 if ll == 0 else max(0.0, min(1.0, ((x - x0) * dx + (y - y0) * dy) / ll))
            px, py = x0 + u * dx, y0 + u * dy
            d = math.hypot(x - px, y - py)
            if d < best[0]:
                h = math.atan2(dy, dx)
                t = -(x - px) * math.sin(h) + (y - py) * math.cos(h)
                best = (d, self.s[i] + u * math.sqrt(ll), t, h)
        return best[1], best[2], best[3]


def centre(x: float, y: float, h: float, dim: tuple[float, float, float]) -> tuple[float, float]:
    """The bounding box's centre of an entity at reference point (x, y), heading h; ``dim`` is
    ``(centre ahead of the reference point, length, width)``."""
    return x + dim[0] * math.cos(h), y + dim[0] * math.sin(h)


def analyse(traj: list[tuple], dims: dict[str, tuple[float, float, float]], ego: str, contacts: list[list], step: float = STEP) -> dict:
    """What the ego did to the objects in its path, from every entity's trajectory.

    ``traj``: ``(t, name, x, y, heading, speed)`` rows (the reference point, as esmini and flc
    write it); ``dims``: name -> (box centre ahead of the reference point, length, width), m;
    ``contacts``: ``[t, a, b]`` of the run. Road coordinates are the ego's own swept path
    (:class:`SweptPath`): an object is *in the ego's path* when its body reaches into the ego's
    lane band (:data:`LANE_HALF` each side of the path) or comes within :data:`CORRIDOR_MARGIN`
    of the band the ego's body sweeps (the in-path module's corridor,
    crates/flc-sim/src/sim/path.rs; with a 2 m wide ego inside the lane band).

    Returns ``closest_m``: the least bumper gap to an object in path ahead (``None``: never one);
    ``passed``: objects that were wholly ahead in path and that the ego's front then went beyond
    the rear of while they were still in path, without a contact with them (object, time, ego
    speed, least lateral clearance between the bodies); ``far_stops``: the ego standing (speed
    below :data:`STAND_SPEED` for :data:`STAND_TIME`) with nothing in path within
    :data:`FAR_STOP` of its front (start time, duration, the gap then or ``None``: nothing);
    ``contacts``: each contact of the ego with both speeds then."""
    by_t: dict[int, dict[str, tuple]] = {}
    for t, n, x, y, h, v in traj:
        by_t.setdefault(round(t / step), {})[n] = (x, y, h, v)
    steps = sorted(by_t)
    ego_steps = [k for k in steps if ego in by_t[k]]
    if not ego_steps:
        return {"closest_m": None, "passed": [], "far_stops": [], "contacts": []}
    de = dims.get(ego, (0.0, 0.0, 0.0))
    path = SweptPath([(*centre(x, y, h, de), h) for x, y, h, _ in (by_t[k][ego] for k in ego_steps)])
    half_le, half_we = de[1] / 2.0, de[2] / 2.0
    band = max(LANE_HALF, half_we + CORRIDOR_MARGIN)  # from the path's centre
    hit_with = {c[2] if c[1] == ego else c[1] for c in contacts if ego in (c[1], c[2])}

    def look(k: int) -> tuple[float, list[tuple[str, float, float]]]:
        """At step k: the gap to the nearest object in path ahead (inf: none) and every object in
        the corridor as (name, bumper gap along the path, lateral clearance between the bodies)."""
        x, y, h, _ = by_t[k][ego]
        se, _, _ = path.project(*centre(x, y, h, de))
        nearest, near = math.inf, []
        for n, (ox, oy, oh, _ov) in by_t[k].items():
            if n == ego or n not in dims:
                continue
            do = dims[n]
            so, to, hp = path.project(*centre(ox, oy, oh, do))
            rel = oh - hp
            along = 0.5 * (do[1] * abs(math.cos(rel)) + do[2] * abs(math.sin(rel)))
            across = 0.5 * (do[1] * abs(math.sin(rel)) + do[2] * abs(math.cos(rel)))
            clearance = abs(to) - across - half_we
            if abs(to) - across >= band:
                continue
            gap = so - along - (se + half_le)  # bumper gap along the path
            if gap > 0:
                nearest = min(nearest, gap)
            if so + along > se - half_le:  # its front ahead of the ego's rear
                near.append((n, gap, clearance))
        return nearest, near

    # Every 0.1 s, and every step where something in the corridor is within 15 m.
    stride = max(1, round(0.1 / step))
    seen: dict[int, tuple[float, list]] = {k: look(k) for k in ego_steps[::stride] + ego_steps[-1:]}
    close = sorted(k for k, (g, near) in seen.items() if any(gap < 15.0 for _, gap, _ in near))
    for k in close:
        i = bisect.bisect_left(ego_steps, k)
        for j in ego_steps[max(0, i - stride):i + stride + 1]:
            if j not in seen:
                seen[j] = look(j)
    closest = math.inf
    ahead_seen: set[str] = set()
    passes: dict[str, dict] = {}
    gaps: list[tuple[int, float, float]] = []  # (step, ego speed, gap to the nearest in path or inf)
    for k in sorted(seen):
        nearest, near = seen[k]
        v = by_t[k][ego][3]
        for n, gap, clearance in near:
            if gap > 0:
                ahead_seen.add(n)
            elif n in ahead_seen and n not in hit_with:
                # Its rear behind the ego's front, its front ahead of the ego's rear: alongside.
                p = passes.setdefault(n, {"object": n, "time": round(k * step, 2), "ego_speed": round(v, 3), "clearance_m": clearance})
                p["clearance_m"] = min(p["clearance_m"], clearance)
        closest = min(closest, nearest)
        gaps.append((k, v, nearest))
    far: list[dict] = []
    run_start = None
    for i, (k, v, g) in enumerate(gaps + [(None, math.inf, 0.0)]):
        standing = v < STAND_SPEED and g > FAR_STOP
        if standing and run_start is None:
            run_start = i
        elif not standing and run_start is not None:
            k0, k1 = gaps[run_start][0], gaps[i - 1][0]
            if (k1 - k0) * step >= STAND_TIME - 1e-9:
                g0 = gaps[run_start][2]
                far.append({"time": round(k0 * step, 2), "duration": round((k1 - k0) * step, 2), "gap_m": None if math.isinf(g0) else round(g0, 2)})
            run_start = None
    cont = []
    for c in contacts:
        t, a, b = c[0], c[1], c[2]
        k = round(t / step)
        row = by_t.get(k) or by_t[steps[min(bisect.bisect_left(steps, k), len(steps) - 1)]]
        sp = {n: round(row[n][3], 3) for n in (a, b) if n in row}
        cont.append({"time": t, "pair": sorted([a, b]), "speeds": sp})
    for p in passes.values():
        p["clearance_m"] = round(p["clearance_m"], 3)
    return {"closest_m": None if math.isinf(closest) else round(closest, 3), "passed": sorted(passes.values(), key=lambda p: p["time"]),
            "far_stops": far, "contacts": cont}


# ---------------------------------------------------------------------------------------------
# esmini with its ALKS controller on the ego


def ego_name(root: ET.Element) -> str | None:
    """The ego as flc chooses it (crates/flc-sim/src/openscenario/entities.rs, ``choose_ego``):
    the entity named ``Ego``, else ``ego``, else the first."""
    names = [o.get("name") for o in root.iter("ScenarioObject")]
    return "Ego" if "Ego" in names else "ego" if "ego" in names else (names[0] if names else None)


def with_alks_controller(src: Path, dst: Path, model: str) -> str:
    """Writes ``src`` to ``dst`` with esmini's ALKS_R157SM_Controller (``model``) on the ego;
    returns what was done to the file's own controller."""
    tree = ET.parse(src)
    root = tree.getroot()
    ego_n = ego_name(root)
    ego = next(o for o in root.iter("ScenarioObject") if o.get("name") == ego_n)
    had = ego.find("ObjectController")
    own = had is not None and any(c.get("name") == "ALKS_R157SM_Controller" for c in had.iter("Controller"))
    if own:
        # esmini's own ALKS files: their settings, the model of this run.
        ctrl = next(c for c in had.iter("Controller") if c.get("name") == "ALKS_R157SM_Controller")
        props = ctrl.find("Properties")
        for p in props.findall("Property"):
            if p.get("name") == "model":
                props.remove(p)
        ET.SubElement(props, "Property", name="model", value=model)
        done = "its own ALKS_R157SM_Controller, model set"
    else:
        if had is not None:
            ego.remove(had)
        oc = ET.SubElement(ego, "ObjectController")
        ctrl = ET.SubElement(oc, "Controller", name="ALKS_R157SM_Controller")
        props = ET.SubElement(ctrl, "Properties")
        for k, v in (("mode", "override"), ("model", model), ("cruise", "true"), ("logLevel", "0")):
            ET.SubElement(props, "Property", name=k, value=v)
        done = "replaced its controller" if had is not None else "added"
    activates = any(a.find("ActivateControllerAction") is not None or a.tag == "ActivateControllerAction"
                    for a in root.iter() if a.tag in ("ControllerAction", "PrivateAction"))
    if not activates:
        init = root.find("Storyboard/Init/Actions")
        priv = next((p for p in init.findall("Private") if p.get("entityRef") == ego_n), None)
        if priv is None:
            priv = ET.SubElement(init, "Private", entityRef=ego_n)
        pa = ET.SubElement(priv, "PrivateAction")
        ca = ET.SubElement(pa, "ControllerAction")
        ET.SubElement(ca, "ActivateControllerAction", longitudinal="true", lateral="false")
        done += ", activated in the Init"
    for d in root.iter("Directory"):
        p = d.get("path", "")
        if p and not p.startswith("$") and not os.path.isabs(p):
            d.set("path", os.path.normpath(os.path.join(src.resolve().parent, p)))
    tree.write(dst, encoding="utf-8", xml_declaration=True)
    return done


def read_esmini_csv(path: Path) -> tuple[list[tuple], dict[str, tuple[float, float, float]]]:
    """esmini's ``--csv_logger`` file: the trajectory rows and each entity's box (centre ahead
    of the reference point, length, width)."""
    traj, dims = [], {}
    with open(path, newline="") as f:
        lines = f.read().splitlines()
    head_i = next(i for i, ln in enumerate(lines) if ln.startswith("Index"))
    head = [c.strip() for c in lines[head_i].split(",")]
    cols: dict[str, int] = {}
    for i, c in enumerate(head):
        if c.startswith("#"):
            k, _, name = c.partition(" ")
            cols[f"{k}|{name.split(' [')[0].split('[')[0]}"] = i
    n_ent = max(int(k.split("|")[0][1:]) for k in cols)
    for ln in lines[head_i + 1:]:
        r = [c.strip() for c in ln.split(",")]
        if len(r) < 3:
            continue
        t = float(r[1])
        for k in range(1, n_ent + 1):
            g = lambda n: r[cols[f"#{k}|{n}"]]  # noqa: E731
            try:
                name = g("Entity_Name")
                x, y, h, v = float(g("World_Position_X")), float(g("World_Position_Y")), float(g("World_Heading_Angle")), float(g("Current_Speed"))
            except (KeyError, IndexError, ValueError):
                continue
            if not name:
                continue
            traj.append((t, name, x, y, h, v))
            if name not in dims:
                dims[name] = (float(g("bb_x")), float(g("bb_length")), float(g("bb_width")))
    return traj, dims


def esmini_alks_run(esmini: Path, file: Path, perm: int | None, model: str, timeout: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="pubctl-esmini-") as tmp:
        work = Path(tmp)
        if perm is None:
            scen, extra = file, []
        else:
            scen, _ = er.dist_parameters(file)
            extra = ["--param_dist", str(file), "--param_permutation", str(perm)]
        copy = work / scen.name
        try:
            done = with_alks_controller(scen, copy, model)
        except (ET.ParseError, StopIteration, AttributeError) as ex:
            return {"status": "failed", "message": f"cannot set the ego's controller: {ex!r}"[:300]}
        cmd = [str(esmini), "--headless", "--fixed_timestep", f"{STEP}", "--seed", "1", "--collision", "--osc", str(copy),
               "--path", str(scen.resolve().parent), *extra, "--csv_logger", str(work / "run.csv"), "--logfile_path", str(work / "run.log"),
               "--disable_stdout"]
        code, out, err = pc.run(cmd, work, timeout)
        logs, csvs = sorted(work.glob("run*.log")), sorted(work.glob("run*.csv"))
        log = logs[0].read_text(errors="replace") if logs else ""
        if code != 0 or not csvs:
            return {"status": "timeout" if code == 124 else "failed", "message": (err.strip() or log.strip())[-300:]}
        traj, dims = read_esmini_csv(csvs[0])
    cols = []
    for line in log.splitlines():
        m = pc.COLLISION.match(line)
        if m and not line.rstrip().endswith("dissolved"):
            cols.append([float(m.group(1)), *sorted([m.group(2), m.group(3)])])
    ego = ego_name(ET.parse(scen).getroot())
    return {"status": "ok", "controller": done, "traj": traj, "dims": dims, "ego": ego, "collisions": cols,
            "end_time": max((t[0] for t in traj), default=0.0), "params": er.logged_parameters(log) if perm is not None else {}}


# ---------------------------------------------------------------------------------------------
# flc in controller mode


def flc_controller_run(flc: Path, file: Path, perm: int | None, controller: str, timeout: float, extra: tuple[str, ...] = ()) -> dict:
    with tempfile.TemporaryDirectory(prefix="pubctl-flc-") as tmp:
        cmd = [str(flc), "--config", str(file), "--ego-mode", "controller", "--set", f"controller={controller}", *extra, "--out", tmp, "--json",
               "--threads", "1"]
        if perm is not None:
            cmd += ["--permutation", str(perm)]
        code, out, err = pc.run(cmd, ROOT, timeout)
        if code != 0:
            errors = [ln for ln in err.splitlines() if ln.startswith("error")]
            msg = errors[-1] if errors else (err.strip().splitlines()[-1] if err.strip() else f"exit {code}")
            return {"status": {2: "refused", 124: "timeout"}.get(code, "failed"), "message": msg.replace(str(file.parent) + "/", "")[:300]}
        records = [json.loads(ln) for ln in out.splitlines() if ln.startswith("{")]
        traj, series = None, None
        for f in sorted(Path(tmp).rglob("*.csv")):
            with open(f, newline="") as fh:
                rows = list(csv.reader(fh))
            head = [c.strip() for c in rows[0]] if rows else []
            if head[:6] == pc.TRAJ_HEAD:
                traj = [(float(x[0]), x[1], float(x[2]), float(x[3]), float(x[4]), float(x[5])) for x in rows[1:] if x]
            elif "gap" in head and "follower_speed" in head:
                ix = {n: head.index(n) for n in ("t", "gap", "follower_speed")}
                series = [(float(r[ix["t"]]), float(r[ix["gap"]] or "nan"), float(r[ix["follower_speed"]])) for r in rows[1:] if r]
    rec = records[0] if records else {}
    cols = []
    for c in rec.get("contacts") or []:
        cols.append([float(c.get("time", math.nan)), *sorted(str((c.get(k) or {}).get("name")) for k in ("a", "b"))])
    return {"status": "ok", "traj": traj, "series": series, "collisions": cols, "min_gap": (rec.get("metrics") or rec).get("min_gap"),
            "end_time": max((t[0] for t in traj), default=0.0) if traj else rec.get("duration")}


def series_far_stops(series: list[tuple[float, float, float]]) -> list[dict]:
    """Far stops from flc's own series: the ego standing (``follower_speed`` below STAND_SPEED
    for STAND_TIME) while the gap to the vehicle in its path (``gap``: the in-path module's ground
    truth, NaN when nothing is in path) is NaN or above FAR_STOP."""
    out, start = [], None
    rows = series + [(math.inf, 0.0, math.inf)]
    for i, (t, g, v) in enumerate(rows):
        standing = v < STAND_SPEED and (math.isnan(g) or g > FAR_STOP) and not math.isinf(t)
        if standing and start is None:
            start = i
        elif not standing and start is not None:
            t0, t1 = rows[start][0], rows[i - 1][0]
            if t1 - t0 >= STAND_TIME - 1e-9:
                g0 = rows[start][1]
                out.append({"time": round(t0, 2), "duration": round(t1 - t0, 2), "gap_m": None if math.isnan(g0) else round(g0, 2)})
            start = None
    return out


def flc_dims(flc: Path, file: Path, perm: int | None, names: set[str], timeout: float) -> dict[str, tuple[float, float, float]]:
    """Each entity's box as flc imports it (``scenario convert``: the TOML twin's vehicle
    length and width and ``[story] references``), by the names of flc's trajectory file: the
    ego, the ``[[vehicles]]`` (pedestrians, objects) by their names, and the lead as the one name
    left. Used when no esmini run of the same file gives the boxes."""
    import tomllib

    with tempfile.TemporaryDirectory(prefix="pubctl-convert-") as tmp:
        # Only the run asked for: converting a whole distribution imports every permutation.
        one = [] if perm is None else ["--permutation", str(perm)]
        code, out, err = pc.run([str(flc), "convert", str(file), *one, "--out", tmp, "-q"], ROOT, timeout)
        if code != 0:
            return {}
        tomls = sorted(Path(tmp).glob("*.toml"))
        if perm is not None:
            tomls = [p for p in tomls if f"-p{perm}_" in p.name or p.name.endswith(f"-p{perm}.toml")]
        if not tomls:
            return {}
        twin = tomllib.loads(tomls[0].read_text())
    refs = (twin.get("story") or {}).get("references") or {}
    dims: dict[str, tuple[float, float, float]] = {}

    def box(sim: str, v: dict) -> tuple[float, float, float]:
        veh = v.get("vehicle") or v
        return (float((refs.get(sim) or [0.0])[0]), float(veh.get("length", 0.0)), float(veh.get("width", 0.0)))

    root = ET.parse(file if perm is None else er.dist_parameters(file)[0]).getroot()
    ego = ego_name(root)
    if ego and "follower" in twin:
        dims[ego] = box("ego", twin["follower"])
    for group in ("vehicles", "pedestrians", "objects"):
        for v in twin.get(group) or []:
            if v.get("name") in names:
                dims[v["name"]] = box(v["name"], v)
    left = sorted(names - set(dims))
    if "lead" in twin and len(left) == 1:
        dims[left[0]] = box("lead", twin["lead"])
    return dims


# ---------------------------------------------------------------------------------------------
# One run, the data file


def one_run(task: dict, tools: dict, work: Path) -> dict:
    """One player's run of one (file, permutation): ``task["who"]`` is ``esmini:<model>`` or a
    flc controller name; flc runs take the entities' boxes from ``task["dims"]`` if given."""
    cache = work / "runs" / f"{task['key']}.json"
    if cache.is_file():
        return json.loads(cache.read_text())
    if tools.get("cached_only"):
        return {"status": "not run", "message": "not in the cache (--cached-only)"}
    file, perm, who = Path(task["file"]), task["perm"], task["who"]
    if who.startswith("esmini:"):
        # esmini's own run is cached apart (gzipped, with its trajectory) under a key of its inputs and
        # of the code that prepares and reads it, so that a change of the analysis re-reads, not re-runs.
        raw = work / "esmini" / f"{task['raw_key']}.json.gz"
        if raw.is_file():
            with gzip.open(raw, "rt") as f:
                r = json.load(f)
            r["traj"] = [tuple(t) for t in r["traj"]] if r.get("traj") else r.get("traj")
            r["dims"] = {k: tuple(v) for k, v in (r.get("dims") or {}).items()}
        else:
            r = esmini_alks_run(tools["esmini"], file, perm, who.split(":", 1)[1], tools["timeout"])
            raw.parent.mkdir(parents=True, exist_ok=True)
            with gzip.open(raw, "wt") as f:
                json.dump(r, f)
        if r["status"] == "ok":
            r.update(analyse(r["traj"], r["dims"], r["ego"], r["collisions"]))
    else:
        # The probe: whether flc imports the file (a run of 0.05 s).
        r = flc_controller_run(tools["flc"], file, perm, who, tools["timeout"], ("--set", "duration=0.05") if task.get("probe") else ())
        if task.get("probe"):
            r = {k: v for k, v in r.items() if k in ("status", "message")}
        elif r["status"] == "ok" and r.get("traj"):
            root = ET.parse(file if perm is None else er.dist_parameters(file)[0]).getroot()
            r["ego"] = ego_name(root)
            names = {t[1] for t in r["traj"]}
            dims = task.get("dims") or flc_dims(tools["flc"], file, perm, names, tools["timeout"])
            r["dims"] = dims
            r.update(analyse(r["traj"], dims, r["ego"], r["collisions"]))
            # Also as flc's own in-path module sees them (the series' `gap`: the corridor only).
            if r.get("series"):
                r["far_stops_corridor"] = series_far_stops(r["series"])
        elif r["status"] == "ok":
            r = {"status": "failed", "message": "flc wrote no per-entity trajectory CSV with --out"}
    out = {k: v for k, v in r.items() if k not in ("traj", "series")}
    if "dims" in out:
        out["dims"] = {k: list(v) for k, v in out["dims"].items()}
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(out) + "\n")
    return out


def check_run(file: Path, p: int | None, base: str, raw_base: str, controllers: list[str], models: list[str], tools: dict, work: Path) -> dict:
    """Every player's run of one (file, permutation): ``{"players": {...}}``, or ``{"flc": {status,
    message}}`` when flc does not import it (esmini is then not run)."""
    out: dict = {"players": {}}
    dims = None
    # Only what flc imports is checked.
    probe = pc.sha(base.encode(), b"imports")
    r = one_run({"file": str(file), "perm": p, "who": controllers[0], "key": probe, "probe": True}, tools, work)
    if r["status"] != "ok":
        out["flc"] = {"status": r["status"], "message": r.get("message", "")}
        return out
    for m in models:
        raw_key = pc.sha(raw_base.encode(), m.encode())
        r = one_run({"file": str(file), "perm": p, "who": f"esmini:{m}", "key": pc.sha(base.encode(), m.encode()), "raw_key": raw_key}, tools, work)
        out["players"][f"esmini:{m}"] = r
        if r["status"] == "ok" and dims is None:
            dims = {k: tuple(v) for k, v in r["dims"].items()}
    for c in controllers:
        # The boxes from esmini's run of the same file (both read the same BoundingBox), else flc's own import.
        key = pc.sha(base.encode(), c.encode(), json.dumps(sorted((dims or {}).items())).encode())
        out["players"][c] = one_run({"file": str(file), "perm": p, "who": c, "key": key, "dims": dims}, tools, work)
    return out


def ego_contacts(r: dict) -> list[dict]:
    ego = r.get("ego")
    return [c for c in r.get("contacts") or [] if ego in c["pair"]]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("paths", nargs="*", help="folders (every scenario / distribution .xosc below) or files")
    ap.add_argument("--pub", help="folder holding OSC-NCAP-scenarios, OSC-ALKS-scenarios and esmini: the files of tools/published_check.py")
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--flc", default=str(ROOT / "target" / "release" / "scenario"), help="the scenario binary (cargo build --release)")
    ap.add_argument("--controllers", default=",".join(CONTROLLERS), help="flc controllers, comma separated")
    ap.add_argument("--esmini", help="folder of the headless esmini build (default ../shared/tools/esmini)")
    ap.add_argument("--esmini-models", default=",".join(ESMINI_MODELS), help="ALKS_R157SM_Controller models, comma separated")
    ap.add_argument("--no-esmini", action="store_true", help="flc only (the boxes from `scenario convert`)")
    ap.add_argument("--work", default=str(ROOT / "target" / "published-controller-check"), help="cache of finished runs (resumable)")
    ap.add_argument("--data", default=str(ROOT / "docs" / "openscenario" / "controller.json"))
    ap.add_argument("--timeout", type=float, default=pc.TIMEOUT_S, help="seconds per esmini or flc run")
    ap.add_argument("--flc-commit", help="the commit the --flc binary was built from, when it is not this checkout's (`git describe` of it by default)")
    ap.add_argument("--cached-only", action="store_true", help="run nothing: write the data file from the finished runs of the cache "
                    "(the others are `not run`)")
    args = ap.parse_args(argv)
    paths = [Path(p) for p in args.paths]
    if args.pub:
        for coll, sub, names in pc.STANDARD_SET:
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
    controllers = [c for c in args.controllers.split(",") if c]
    models = [] if args.no_esmini else [m for m in args.esmini_models.split(",") if m]
    esmini, version = None, ("", "")
    if models:
        try:
            esmini, _, version = er.find_esmini(args.esmini or str(er.DEFAULT_ESMINI if er.DEFAULT_ESMINI.exists() else Path("/work/shared/tools/esmini")))
        except er.EsminiError as ex:
            print(f"error: {ex}", file=sys.stderr)
            return 2
    tools = {"flc": flc, "esmini": esmini, "timeout": args.timeout, "cached_only": args.cached_only}
    esmini_code = "".join(inspect.getsource(f) for f in (ego_name, with_alks_controller, read_esmini_csv, esmini_alks_run, pc.run, er.dist_parameters))
    esmini_bins = (pc.file_hash(esmini.resolve()) if esmini else b"") + esmini_code.encode()
    bins = pc.file_hash(flc) + (pc.file_hash(esmini.resolve()) if esmini else b"") + Path(__file__).read_bytes() + pc.Path(pc.__file__).read_bytes()
    files = pc.discover(paths)
    colls: dict[str, dict] = {}
    entries, jobs = [], []
    for file in files:
        name, inside, commit, clean = pc.collection(file)
        colls.setdefault(name, {"commit": commit})
        k = pc.kind(file)
        entry = {"collection": name, "path": inside, "kind": k, "runs": []}
        entries.append(entry)
        if k == "unreadable":
            continue
        if k == "distribution":
            scen, _ = er.dist_parameters(file)
            if esmini:
                entry["permutations"] = pc.esmini_count(esmini, file)
            else:
                code, out, _ = pc.run([str(flc), "--config", str(file), "--permutations"], ROOT, 120)
                entry["permutations"] = int(out.split()[-1]) if code == 0 and out.split() and out.split()[-1].isdigit() else 0
            perms = pc.permutations(entry["permutations"])
            extra = scen.read_bytes() if scen.is_file() else b""
        else:
            perms, extra = [None], b""
        for p in perms:
            inputs = [file.read_bytes(), extra, commit.encode() if clean else os.urandom(8), str(p).encode(), str(args.timeout).encode()]
            base = pc.sha(*inputs, bins)
            raw_base = pc.sha(*inputs, esmini_bins)
            run = {"permutation": p, "players": {}}
            entry["runs"].append(run)
            jobs.append((run, file, p, base, raw_base))
    work = Path(args.work)
    print(f"{len(files)} files, {len(jobs)} runs x ({len(models)} esmini models + {len(controllers)} flc controllers); -j {args.jobs}; cache {work}",
          file=sys.stderr)

    done = 0
    # Processes, not threads: the reading of long runs is Python work.
    with concurrent.futures.ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futs = {pool.submit(check_run, j[1], j[2], j[3], j[4], controllers, models, tools, work): j for j in jobs}
        for fut in concurrent.futures.as_completed(futs):
            run, file, p, _, _ = futs[fut]
            run.update(fut.result())
            done += 1
            said = [f"flc {run['flc']['status']}: {run['flc']['message']}"] if "flc" in run else []
            for who, r in run["players"].items():
                if r["status"] != "ok":
                    said.append(f"{who} {r['status']}")
                    continue
                bits = [f"{len(ego_contacts(r))} contacts" if ego_contacts(r) else "", f"{len(r['passed'])} passed" if r["passed"] else "",
                        f"{len(r['far_stops'])} far stops" if r["far_stops"] else ""]
                said.append(f"{who}: {', '.join(b for b in bits if b) or 'clean'}")
            print(f"[{done}/{len(jobs)}] {file.name} p{p}: " + "; ".join(said), file=sys.stderr)
    for e in entries:
        e["runs"].sort(key=lambda r: -1 if r["permutation"] is None else r["permutation"])
    data = {
        "generated": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d"),
        "command": "python3 tools/published_controller_check.py " + " ".join(a for a in (argv if argv is not None else sys.argv[1:])),
        "esmini": {"version": version[0], "commit": version[1], "step_s": STEP, "controller": "ALKS_R157SM_Controller", "models": models,
                   "flags": "--headless --fixed_timestep 0.01 --seed 1 --collision"} if models else None,
        "flc": {"commit": args.flc_commit or pc.git(ROOT, "describe", "--always", "--dirty"), "flags": "--ego-mode controller", "controllers": controllers},
        "definitions": {"corridor_margin_m": CORRIDOR_MARGIN, "far_stop_m": FAR_STOP, "stand_speed_mps": STAND_SPEED, "stand_time_s": STAND_TIME,
                        "reference": REFERENCE, "esmini_reference": ESMINI_REFERENCE},
        "collections": colls,
        "files": sorted(entries, key=lambda e: (e["collection"], e["path"])),
    }
    Path(args.data).parent.mkdir(parents=True, exist_ok=True)
    Path(args.data).write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {args.data}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
