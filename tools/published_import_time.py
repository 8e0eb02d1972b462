#!/usr/bin/env python3
"""Times the import of the published OpenSCENARIO files (the set of tools/published_check.py).

For every file: `scenario convert FILE [--permutation 0] -q` (a distribution: its first run
only), repeated `--repeat` times; the median CPU time (user + system) of the whole process is an
upper bound of the import (it also starts the process, reads the road and catalogs, and writes
the TOML twin). CPU time, not wall time: the figure holds on a loaded machine too.
Prints a Markdown table: the count, the median over files, the slowest files, the goal.

    python3 tools/published_import_time.py --pub /work/scratch/pub
"""
from __future__ import annotations

import argparse
import platform
import resource
import statistics
import subprocess
import sys
from datetime import date
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import published_check as pc  # noqa: E402

GOAL_MS = 50.0


def cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def once(cmd: list[str]) -> float:
    t0 = cpu_children()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    dt = cpu_children() - t0
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {done.returncode}: {done.stderr.strip()[:300]}")
    return dt * 1000.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pub", required=True, help="folder holding OSC-NCAP-scenarios, OSC-ALKS-scenarios and esmini")
    ap.add_argument("--flc", default=str(pc.ROOT / "target" / "release" / "scenario"))
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    paths = []
    for coll, sub, names in pc.STANDARD_SET:
        base = Path(args.pub) / coll / sub
        paths += [base] if names is None else [base / n for n in names]
    files = pc.discover(paths)
    rows = []
    for f in files:
        cmd = [args.flc, "convert", str(f), "-q"] + (["--permutation", "0"] if pc.kind(f) == "distribution" else [])
        once(cmd)  # warm the page cache
        rows.append((statistics.median(once(cmd) for _ in range(args.repeat)), f.name))
    rows.sort(reverse=True)
    med = statistics.median(r[0] for r in rows)
    print(f"{len(rows)} files, {date.today()}, {platform.machine()} {platform.processor() or ''}, "
          f"median CPU time of {args.repeat} runs per file; command: python3 tools/published_import_time.py --pub DIR\n")
    print("| what | figure | goal |\n|---|---|---|")
    print(f"| import a published file, the slowest (`{rows[0][1]}`) | **{rows[0][0]:.1f} ms** | < {GOAL_MS:.0f} ms |")
    for ms, name in rows[1:4]:
        print(f"| next: `{name}` | {ms:.1f} ms | < {GOAL_MS:.0f} ms |")
    print(f"| median over the {len(rows)} files | {med:.1f} ms | < {GOAL_MS:.0f} ms |")
    return 0 if rows[0][0] < GOAL_MS else 1


if __name__ == "__main__":
    sys.exit(main())
