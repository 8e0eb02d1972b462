"""Closed-loop speed of the installed flc wheel (docs/benchmarks.md, "Wheels"): the best of
``REPEATS`` runs of the 70 km/h paper scenario (FLC, default LiDAR) in Rust alone
(``_flc.bench_rust_run``), as the real-time factor, plus the size of the extension module.

Run: python benches/wheel_speed.py   (in a venv with the wheel to measure installed)
"""
import os
import sys

import flc
from flc import _flc

REPEATS = 30


def main() -> None:
    sc = flc.Scenario.paper(speed_kmh=70, controller="flc")
    sim = flc.run(sc).metrics["duration"]
    best = _flc.bench_rust_run(sc.to_json(), REPEATS)
    so = _flc.__file__
    print(f"{so}: {os.path.getsize(so) / 1e6:.1f} MB; simulated {sim:.2f} s in {best * 1e3:.2f} ms: real-time factor {sim / best:.0f}")


if __name__ == "__main__":
    sys.exit(main())
