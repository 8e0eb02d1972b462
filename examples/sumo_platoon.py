"""flc's controllers driving a SUMO platoon whose V2V drops (``flc.sumo.cacc_platoon``, docs/sumo.md).

Five SUMO vehicles behind a scripted SUMO lead on a straight lane, each driven by an flc follower
pipeline (the supervisor: the V2V PID while its predecessor's messages are fresh, the FLC from
the LiDAR-like gap sensor otherwise). Every V2V link goes down at ``outage_at``; the lead brakes
at 6 m/s² to a stop 5 s later. For comparison SUMO's own CACC model (perfect information).

Run: ``python examples/sumo_platoon.py`` (needs ``flc[sumo]``; executed in CI by
``tests/python/test_examples.py``).
"""
from __future__ import annotations

import sys

from flc import sumo


def main(followers: int = 5) -> int:
    rows = []
    for controller in ("pipeline", "pid", "sumo-cacc"):
        out = sumo.cacc_platoon(followers, controller=controller, cruise_kmh=80.0, outage_at=25.0, brake_at=30.0)
        min_gap = min(f["min_gap"] for f in out.followers)
        rows.append((controller, min_gap, len(out.collisions), out.switched_to_flc if controller != "sumo-cacc" else "-"))
    print(f"{'controller':<10} {'min gap (m)':>12} {'collisions':>11} {'on FLC after outage':>20}")
    for c, g, n, s in rows:
        print(f"{c:<10} {g:>12.2f} {n:>11} {s!s:>20}")
    # The pipeline hands every follower to the FLC after the outage and the platoon stops safely.
    pipeline = rows[0]
    return 0 if pipeline[2] == 0 and pipeline[3] == followers else 1


if __name__ == "__main__":
    sys.exit(main())
