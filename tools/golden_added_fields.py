"""Proves that regenerated goldens only *added* fields: every value of the old files is unchanged.

Usage (from the repository root, after ``FLC_BLESS=1 cargo test --release -p flc-sim --test golden``)::

    python tools/golden_added_fields.py REV tet,tit,min_time_headway,pet [FILE.json ...]

``REV`` is the git revision holding the old goldens (e.g. ``main``), the second argument the
fields that may be new, further arguments JSON documents checked like one line of a ``.jsonl``
(e.g. the committed suite reports ``docs/standard-suites/*.json``). For ``tests/golden/*.jsonl`` every JSON object of every line is compared
with the old one: each old key must be present with the identical value *text* (numbers are kept
as the text the simulator wrote), and the keys the new object has beyond the old are exactly the
given fields (nested objects, e.g. a platoon's ``per_follower`` records, are checked the same
way). For ``tests/golden/sweep-200.csv`` the old columns must be byte-identical in every row and
the new columns exactly the given fields. Exits 1 with the first difference otherwise.
"""
from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

GOLDEN = Path("tests/golden")


def old_text(rev: str, path: Path) -> str:
    return subprocess.run(["git", "show", f"{rev}:{path.as_posix()}"], check=True, capture_output=True, text=True).stdout


def load(line: str) -> Any:
    # Numbers stay text: equal text is what the goldens compare.
    return json.loads(line, parse_float=lambda s: ("num", s), parse_int=lambda s: ("num", s))


def compare(old: Any, new: Any, added: set[str], where: str, seen: set[str]) -> None:
    if isinstance(old, dict):
        if not isinstance(new, dict):
            raise SystemExit(f"{where}: an object became {type(new).__name__}")
        extra = set(new) - set(old)
        if extra and extra != added:
            raise SystemExit(f"{where}: new keys {sorted(extra)}, expected exactly {sorted(added)}")
        seen |= extra
        for k, v in old.items():
            if k not in new:
                raise SystemExit(f"{where}: key {k!r} removed")
            compare(v, new[k], added, f"{where}.{k}", seen)
    elif isinstance(old, list):
        if not isinstance(new, list) or len(new) != len(old):
            raise SystemExit(f"{where}: list changed length or type")
        for i, (a, b) in enumerate(zip(old, new)):
            compare(a, b, added, f"{where}[{i}]", seen)
    elif old != new:
        raise SystemExit(f"{where}: {old!r} -> {new!r}")


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    rev, added = argv[0], set(argv[1].split(","))
    for doc in argv[2:]:
        path = Path(doc)
        found: set[str] = set()
        compare(load(old_text(rev, path)), load(path.read_text()), added, str(path), found)
        print(f"{path}: every old value identical; added {sorted(found)}")
    for path in sorted(GOLDEN.glob("*.jsonl")):
        old_lines, new_lines = old_text(rev, path).splitlines(), path.read_text().splitlines()
        if len(old_lines) != len(new_lines):
            raise SystemExit(f"{path}: {len(old_lines)} lines -> {len(new_lines)}")
        seen: set[str] = set()
        for n, (a, b) in enumerate(zip(old_lines, new_lines), 1):
            compare(load(a), load(b), added, f"{path}:{n}", seen)
        print(f"{path}: {len(old_lines)} lines, every old value identical; added {sorted(seen)}")
    for path in sorted(GOLDEN.glob("sweep-*.csv")):
        old_rows = list(csv.reader(io.StringIO(old_text(rev, path))))
        new_rows = list(csv.reader(io.StringIO(path.read_text())))
        oh, nh = old_rows[0], new_rows[0]
        extra = [c for c in nh if c not in oh]
        if set(extra) != added or [c for c in nh if c in oh] != oh or len(old_rows) != len(new_rows):
            raise SystemExit(f"{path}: header {oh} -> {nh}")
        idx = [nh.index(c) for c in oh]
        for n, (old_row, new_row) in enumerate(zip(old_rows, new_rows), 1):
            if [new_row[i] for i in idx] != old_row:
                raise SystemExit(f"{path}:{n}: an old column changed")
        print(f"{path}: {len(old_rows) - 1} rows, the {len(oh)} old columns byte-identical; added {extra}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
