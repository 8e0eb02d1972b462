"""Smoke check of an flc installed from its sdist into a fresh venv (tests/run_all.sh): the package
imports from site-packages (not the source tree), runs the paper experiment and steps a simulation."""
import sys
from pathlib import Path

import flc

here = Path(flc.__file__).resolve()
assert "site-packages" in here.parts, f"flc imported from {here}, not from the installed sdist"
r = flc.run(flc.Scenario.paper(50, "flc"))
assert not r.metrics["collision"] and r.metrics["min_gap"] > 0.5, r.metrics
sim = flc.Simulation(flc.Scenario.paper(50, "flc"))
obs = sim.reset()
while not obs.done:
    obs = sim.step(None, hold_until=obs.t + 0.1)
assert (sim.result().gap == r.gap).all()
assert (Path(flc.__file__).parent / "py.typed").exists()
print(f"sdist install ok: {here.parent} ({sys.version.split()[0]})")
