"""Mutated shipped scenarios through Python (issue 29): `flc.Scenario.from_dict` and `flc.run`
raise `flc.ScenarioError` with a one-line message naming a key, or run to finite metrics; never
hang, never another exception. The same mutations as `crates/flc-sim/tests/mutation.rs`, fewer
of them (seeded)."""
import math
import pathlib
import random
import time
import tomllib

import pytest

import flc

ROOT = pathlib.Path(__file__).resolve().parents[2]
FILES = sorted((ROOT / "scenarios").glob("*.toml"))
HOSTILE = [0, -1, 1e-6, 1e12, float("nan"), float("inf"), -float("inf"), 2**63 - 1, -(2**63)]
MUTANTS_PER_FILE = 50
MAX_DURATION = 2.0


def numeric_leaves(node, path=()):
    """Paths of every int/float leaf (not bool) of a parsed TOML document."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from numeric_leaves(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from numeric_leaves(v, path + (i,))
    elif isinstance(node, (int, float)) and not isinstance(node, bool):
        yield path


def mutate(doc, path, value):
    node = doc
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


@pytest.mark.parametrize("file", FILES, ids=lambda f: f.name)
def test_mutants_raise_scenario_error_or_run_finite(file):
    rng = random.Random(f"issue-29:{file.name}")
    text = file.read_text()
    leaves = list(numeric_leaves(tomllib.loads(text)))
    assert leaves, file
    outcomes = {"rejected": 0, "ran": 0}
    for _ in range(MUTANTS_PER_FILE):
        doc = tomllib.loads(text)
        path = rng.choice(leaves)
        mutate(doc, path, rng.choice(HOSTILE))
        if path != ("duration",):
            doc["duration"] = min(float(doc.get("duration", MAX_DURATION)), MAX_DURATION)
        t = time.perf_counter()
        try:
            result = flc.run(flc.Scenario.from_dict(doc))
        except flc.ScenarioError as e:
            msg = str(e)
            assert "\n" not in msg and "`" in msg, f"{file.name} {path}: {msg!r}"
            outcomes["rejected"] += 1
        else:
            m = result.metrics
            values = [v for v in m.values() if isinstance(v, float)]
            assert all(math.isfinite(v) for v in values), f"{file.name} {path}: {m}"
            outcomes["ran"] += 1
        assert time.perf_counter() - t < 20.0, f"{file.name} {path}: too slow"
    print(file.name, outcomes)
    assert sum(outcomes.values()) == MUTANTS_PER_FILE
