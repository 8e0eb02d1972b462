"""The standard suites from Python (``flc.run_suite``): the same reports as ``scenario suite``."""
import pytest

import flc


def test_r157_suite_for_two_controllers_next_to_the_careful_driver():
    (report,) = flc.run_suite("r157", controllers=["flc-robust", "acc"])
    assert report["name"] == "r157"
    # The reference runs first, in every case.
    assert report["controllers"] == ["careful-driver", "flc-robust", "acc"]
    runs = {s["controller"]: s for s in report["summary"]}
    assert all(s["runs"] == 21 for s in runs.values())
    assert len(report["results"]) == 3 * 21
    # Behaviour, not a pinned number: every collision of a controller in a run the careful driver
    # passes is counted against it, and the reference is never counted against itself.
    ref_pass = {(r["case"], r["run"]) for r in report["results"] if r["controller"] == "careful-driver" and r["outcome"] == "pass"}
    for c in ("flc-robust", "acc"):
        below = [r for r in report["results"] if r["controller"] == c and r["outcome"] != "pass" and (r["case"], r["run"]) in ref_pass]
        assert runs[c]["below_reference"] == len(below)
        assert all(r["below_reference"] for r in below)
    assert runs["careful-driver"]["below_reference"] == 0
    # Each run carries the SSM metrics under their names.
    m = report["results"][0]["metrics"]
    for k in ("min_ttc", "tet", "tit", "max_drac", "min_time_headway", "pet"):
        assert k in m


def test_unknown_suite_and_controller_raise_naming_them():
    with pytest.raises(flc.ScenarioError, match="no-such-suite"):
        flc.run_suite("no-such-suite")
    with pytest.raises(flc.ScenarioError, match="frobnicate"):
        flc.run_suite("r157", controllers=["frobnicate"])


def test_the_suites_ship_with_the_package_and_do_not_depend_on_the_working_directory(tmp_path, monkeypatch):
    """Issue 48: the suites are package data (``flc/data/suites``), found from the package, not
    from the working directory; ``scenarios/suites`` in the repository is a link to them."""
    from pathlib import Path

    from flc import _paths

    package = Path(flc.__file__).resolve().parent
    assert _paths.SUITES == package / "data" / "suites"
    assert (_paths.SUITES / "r157" / "suite.toml").is_file() and (_paths.SUITES / "ncap-ccr" / "suite.toml").is_file()
    here = flc.run_suite("r157", controllers=["flc"])
    # Elsewhere, next to a folder that looks like a suite of the same name: the package's suite.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenarios" / "suites" / "r157").mkdir(parents=True)
    (tmp_path / "scenarios" / "suites" / "r157" / "suite.toml").write_text('title = "not this one"\n')
    assert flc.run_suite("r157", controllers=["flc"]) == here
    # `root=` names another folder.
    with pytest.raises(flc.ScenarioError, match="suite.toml"):
        flc.run_suite("r157", controllers=["flc"], root=tmp_path / "scenarios" / "suites")
