"""Every example in examples/ runs (issue 26): the notebooks are executed with nbclient, the
scripts as programs; every example a doc or docstring names exists."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
NOTEBOOKS = sorted(EXAMPLES.glob("*.ipynb"))
SCRIPTS = sorted(EXAMPLES.glob("*.py"))


def test_there_are_notebooks_and_scripts() -> None:
    assert len(NOTEBOOKS) >= 3 and SCRIPTS


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_executes(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(path, as_version=4)
    # The kernel is this interpreter's (ipykernel from the test extra), run in examples/.
    client = nbclient.NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(EXAMPLES)}})
    client.execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: p.name)
def test_script_runs(path: Path) -> None:
    if path.name.startswith("sumo"):
        pytest.importorskip("libsumo")
    r = subprocess.run([sys.executable, str(path)], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr


def test_every_example_a_doc_names_exists() -> None:
    docs = list((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"] + list((ROOT / "python" / "flc").glob("*.py"))
    named = set()
    for p in docs:
        # `examples/...` not inside another path (crates/<crate>/examples/... are named with their crate).
        named |= set(re.findall(r"(?<![\w/.-])examples/[\w./-]*\w", p.read_text(encoding="utf-8")))
    assert "examples/sumo_platoon.py" in named
    missing = [n for n in sorted(named) if not (ROOT / n).exists() and not any((c / n).exists() for c in (ROOT / "crates").iterdir())]
    assert not missing, missing


def test_the_readme_gym_example_runs() -> None:
    pytest.importorskip("gymnasium")
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, re.S) if "flc/Following-v0" in b)
    assert len(block.strip().splitlines()) == 3
    ns: dict = {}
    exec(block, ns)
    env = ns["env"]
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs) and set(info["reward_terms"]) == {"collision", "headway", "comfort", "progress"}
