"""Smoke check of an flc installed from its sdist into a fresh venv (tests/run_all.sh): the package
imports from site-packages (not the source tree), runs the paper experiment and steps a simulation;
and, started in a temporary folder outside any checkout, finds what it ships (the standard suites,
the paper reproduction data: `run_suite`, `figures`), while the commands that need the source tree
(`docs`, `reproduction`) say so and exit 2 unless given it (`docs --check --root REPO`)."""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import flc

REPO = Path(__file__).resolve().parents[1]

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


def flc_cli(*args: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "FLC_SOURCE_TREE"}
    return subprocess.run([sys.executable, "-m", "flc", *args], capture_output=True, text=True, env=env)


with tempfile.TemporaryDirectory() as tmp:
    os.chdir(tmp)
    # The suites ship with the package: every suite, one controller (next to the careful driver).
    reports = flc.run_suite("all", controllers=["flc"])
    assert sorted(rep["name"] for rep in reports) == ["ncap-ccr", "ncap-ccr-2026", "r157"], [rep["name"] for rep in reports]
    for rep in reports:
        runs = {s["controller"]: s["runs"] for s in rep["summary"]}
        assert runs["flc"] > 0 and runs["flc"] == len([x for x in rep["results"] if x["controller"] == "flc"]), runs
    # The figures, the paper reproduction map included (drawn from the shipped data).
    p = flc_cli("figures", "--out", "figs", "--no-envelope", "--speeds", "50", "--platoon-frequencies", "0.1")
    assert p.returncode == 0, p.stderr
    for name in ("following.png", "paper_reproduction.png", "paper_reproduction_clearances.png"):
        assert (Path(tmp) / "figs" / name).stat().st_size > 0, name
    # The documents are the source tree's: without it, one line and exit 2; given it, the check runs.
    for args in (["docs", "--check"], ["docs", "list"], ["reproduction", "--out", "rep"]):
        p = flc_cli(*args)
        assert p.returncode == 2 and "source tree" in p.stderr and len(p.stderr.strip().splitlines()) == 1, (args, p.returncode, p.stderr)
    p = flc_cli("docs", "--check", "--root", str(REPO))
    assert p.returncode == 0 and "match the code's output" in p.stderr, p.stderr
    os.chdir(REPO)
print(f"sdist install ok: {here.parent} ({sys.version.split()[0]}); suites, figures and the docs check from a temporary folder")
