"""Cost of `flc.run` from Python relative to the same run in Rust alone (target: <= 1.2x).

Run: target/ci-venv/bin/python benches/python_run_overhead.py  (results in docs/benchmarks.md)
"""
import time

import flc
from flc import _flc

REPEATS = 20


def main() -> None:
    sc = flc.Scenario.paper(speed_kmh=70, controller="flc")
    rust = _flc.bench_rust_run(sc.to_json(), REPEATS)
    best = float("inf")
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        r = flc.run(sc)
        best = min(best, time.perf_counter() - t0)
    sim = r.metrics["duration"]
    print(f"simulated {sim:.1f} s; Rust alone {rust * 1e3:.2f} ms (RTF {sim / rust:.0f}); "
          f"flc.run {best * 1e3:.2f} ms (RTF {sim / best:.0f}); ratio {best / rust:.3f}")


if __name__ == "__main__":
    main()
