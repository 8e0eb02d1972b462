"""Errors in Python's terms and results shaped as a Python user expects them: wrong types raise
``TypeError`` naming the parameter, messages name a key once, a typo lists every valid key, suite
reports have ``.to_pandas()``, series are in ``dir()``, OpenSCENARIO parameters keep their types,
sweep CSVs end in ``run_id`` order, and the long commands report progress."""
from __future__ import annotations

import concurrent.futures as cf
import io
from pathlib import Path

import numpy as np
import pytest

import flc
from flc import _flc

DATA = Path(__file__).resolve().parents[1] / "data" / "openscenario"

SMALL_SWEEP = """
family = "paper"
calibration = "realistic"
seed = 3
[[axes]]
key = "controller"
values = ["flc", "pid"]
[[axes]]
key = "{axis}"
values = [4.0, 8.0, 6.0]
[[axes]]
key = "duration"
values = [12.0]
"""


# ------------------------------------------------------------------ errors in Python's terms


def test_run_suite_takes_one_controller_name_as_a_string():
    (report,) = flc.run_suite("r157", controllers="flc")
    assert report["controllers"] == ["careful-driver", "flc"]
    assert {r["controller"] for r in report["results"]} == {"careful-driver", "flc"}
    # As on the command line, a comma-separated string is a list.
    (both,) = flc.run_suite("r157", controllers="flc,pid")
    assert both["controllers"] == ["careful-driver", "flc", "pid"]


@pytest.mark.parametrize("controllers", [3, [1, 2], {"flc": 1}, b"flc"])
def test_run_suite_controllers_of_another_type_raise_type_error_naming_it(controllers):
    with pytest.raises(TypeError, match="`controllers`"):
        flc.run_suite("r157", controllers=controllers)


def test_run_of_a_name_raises_type_error_naming_the_parameter_and_what_to_pass():
    with pytest.raises(TypeError, match=r"run\(\): `scenario`.*got str 'paper'.*Scenario\.paper"):
        flc.run("paper")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"`scenarios\[1\]`"):
        flc.sweep([flc.Scenario.paper(30), 7])  # type: ignore[list-item]
    with pytest.raises(TypeError, match="`data`"):
        flc.Scenario.from_dict("paper")  # type: ignore[arg-type]


def test_paper_with_an_unknown_keyword_raises_type_error_naming_it_and_the_parameters():
    with pytest.raises(TypeError, match=r"Scenario\.paper\(\) got an unexpected keyword argument `speed`") as e:
        flc.Scenario.paper(speed=70)
    assert "speed_kmh" in str(e.value) and "`lead_decel`" in str(e.value)
    with pytest.raises(TypeError, match=r"Scenario\.replace\(\) got an unexpected keyword argument `sped_kmh`"):
        flc.Scenario.paper(50).replace(sped_kmh=70)
    # A key inside a section stays a ScenarioError naming the key (the keyword is a scenario key).
    with pytest.raises(flc.ScenarioError, match="rate_hzz"):
        flc.Scenario.paper(50, lidar_rate_hzz=5)


@pytest.mark.parametrize("kwargs, name", [({"speed_kmh": "70"}, "speed_kmh"), ({"controller": 3}, "controller"), ({"preset": None}, "preset")])
def test_paper_arguments_of_the_wrong_type_raise_type_error_naming_them(kwargs, name):
    with pytest.raises(TypeError, match=rf"Scenario\.paper\(\): `{name}`"):
        flc.Scenario.paper(**kwargs)


def test_an_error_names_its_key_once():
    with pytest.raises(flc.ScenarioError) as e:
        flc.Scenario.paper(50, controller="magic")
    assert str(e.value).count("`controller`") == 1, str(e.value)
    assert str(e.value).startswith("`controller`: must be one of flc, pid")


def test_a_sweep_axis_typo_lists_every_valid_axis(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SMALL_SWEEP.format(axis="lead_decl"))
    with pytest.raises(flc.ScenarioError) as e:
        flc.sweep_file(path, out=tmp_path / "s.csv", progress=False)
    msg = str(e.value)
    assert "unknown field `lead_decl`" in msg
    for axis in ("`lead_decel`", "`speed_kmh`", "`controller`", "`lidar`", "`follower`", "`duration`"):
        assert axis in msg, f"{axis} missing from: {msg}"


def test_env_step_says_what_an_action_must_be():
    gym = pytest.importorskip("gymnasium")
    from flc.gym import FollowingEnv

    env = FollowingEnv()
    env.reset(seed=1)
    with pytest.raises(TypeError, match=r"`action` must be one number or an array of shape \(1,\).*\[-8, 3\.5\] m/s²") as e:
        env.step(None)
    assert "NoneType" in str(e.value)
    with pytest.raises(TypeError, match="`action`"):
        env.step("brake")
    with pytest.raises(ValueError, match=r"`action`.*shape \(2,\)"):
        env.step(np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match=r"`action`.*nan"):
        env.step(float("nan"))
    # A valid action still steps.
    obs, *_ = env.step(np.array([0.5], dtype=np.float32))
    assert env.observation_space.contains(obs)
    assert isinstance(env.action_space, gym.spaces.Box)


def test_one_speed_limit_for_every_entry_point(tmp_path):
    from flc.__main__ import _speeds

    lo, hi = _flc.paper_speed_range_kmh()
    assert (lo, hi) == (1.0, 250.0)
    for v in (lo, hi):
        assert flc.Scenario.paper(v).speed_kmh == v
        assert flc.Scenario.from_dict({"speed_kmh": v}).speed_kmh == v
        assert _speeds(str(v)) == [v]
    for v in (0.5, 251.0):
        with pytest.raises(flc.ScenarioError, match=r"`speed_kmh`: must be in \[1, 250\] km/h"):
            flc.Scenario.paper(v)
        with pytest.raises(flc.ScenarioError, match=r"`speed_kmh`: must be in \[1, 250\] km/h"):
            flc.Scenario.from_dict({"speed_kmh": v})
        with pytest.raises(Exception, match=r"\[1, 250\] km/h"):
            _speeds(str(v))


# ------------------------------------------------------------------ results shaped for Python


def test_run_suite_returns_reports_with_to_pandas_and_keeps_dict_access():
    pd = pytest.importorskip("pandas")
    results = flc.run_suite("r157", controllers=["flc", "pipeline"])
    assert isinstance(results, list) and results.names == ["r157"]
    (report,) = results
    assert report is results["r157"]
    # The report is still the JSON dict; its keys are attributes too.
    assert report["name"] == report.name == "r157"
    assert report.summary == report["summary"] and "summary" in dir(report)
    df = results.to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) == len(report["results"]) == 3 * 21
    for col in ("suite", "case", "run", "controller", "outcome", "below_reference", "min_gap", "collision", "max_decel"):
        assert col in df.columns, col
    # The table holds what the dicts hold.
    first = report["results"][0]
    assert df.loc[0, "case"] == first["case"] and df.loc[0, "min_gap"] == first["metrics"]["min_gap"]
    passed = df[df.outcome == "pass"].groupby("controller").size().to_dict()
    assert passed == {s["controller"]: s["passed"] for s in report["summary"] if s["passed"]}
    summary = results.summary_to_pandas()
    assert list(summary["controller"]) == ["careful-driver", "flc", "pipeline"]
    assert report.to_pandas().equals(df)
    with pytest.raises(KeyError, match="ncap-ccr"):
        results["ncap-ccr"]


def test_series_are_in_dir_and_declared_for_type_checkers():
    r = flc.run(flc.Scenario.paper(30, duration=5.0))
    names = dir(r)
    columns = {c for c, _, _ in _flc.series_columns()}
    assert columns <= set(names)
    assert {"metrics", "series", "to_pandas", "collision"} <= set(names)
    # The class declares every column (static completion, mypy), and nothing else.
    assert set(flc.RunResult.__annotations__) == columns
    with pytest.raises(AttributeError, match="no attribute or series column 'gapp'"):
        r.gapp  # noqa: B018


def test_platoon_series_are_in_dir():
    r = flc.run(flc.Scenario.brakedemo(platoon_followers=2, duration=3.0).variants()[0])
    assert r.platoon is not None
    assert {"gap", "gap_error", "follower_speed"} <= set(dir(r.platoon))


def test_openscenario_parameters_keep_their_declared_types():
    (s,) = flc.Scenario.load_all(DATA / "parameters.xosc", {"EgoSpeed_kmh": 40, "Gap": 50, "Lane": "-2"})
    assert s.params == {"EgoSpeed_kmh": 40.0, "Gap": 50, "Lane": "-2"}
    assert type(s.params["EgoSpeed_kmh"]) is float and type(s.params["Gap"]) is int and type(s.params["Lane"]) is str
    runs = flc.Scenario.load_all(DATA / "distribution_2x2.xosc", ego_mode="scripted")
    assert [(r.params["EgoSpeed_kmh"], r.params["TargetSpeed_kmh"]) for r in runs] == [(40.0, 10.0), (40.0, 20.0), (60.0, 10.0), (60.0, 20.0)]
    assert all(type(v) is float for r in runs for v in r.params.values())
    # A replaced copy keeps them; a scenario that was not imported has none.
    assert runs[1].replace(duration=5.0).params == runs[1].params
    assert flc.Scenario.paper(50).params == {}


def _ids(csv: Path) -> list[int]:
    return [int(line.split(",", 1)[0]) for line in csv.read_text().splitlines()[1:]]


@pytest.mark.parametrize("engine", ["local", "executor"])
def test_a_resumed_sweep_csv_ends_in_run_id_order(tmp_path, engine):
    path = tmp_path / "s.toml"
    path.write_text(SMALL_SWEEP.format(axis="lead_decel"))
    out = tmp_path / "s.csv"

    def go() -> flc.SweepSummary:
        if engine == "local":
            return flc.sweep_file(path, out=out, progress=False)
        with cf.ThreadPoolExecutor(max_workers=2) as ex:
            return flc.sweep_file(path, executor=ex, out=out, chunk_size=1, progress=False)

    assert go().done == 6
    full = out.read_text()
    assert _ids(out) == list(range(6))
    # Drop the first two rows: a resume appends them after the others, and the file ends sorted.
    lines = full.splitlines(keepends=True)
    out.write_text(lines[0] + "".join(lines[3:]))
    s = go()
    assert (s.done, s.skipped) == (2, 4)
    assert _ids(out) == list(range(6))
    assert out.read_text() == full


def test_sweep_progress_goes_to_stderr_only_when_asked_or_on_a_terminal(tmp_path, capfd):
    path = tmp_path / "s.toml"
    path.write_text(SMALL_SWEEP.format(axis="lead_decel"))
    flc.sweep_file(path, out=tmp_path / "a.csv")  # stderr is not a terminal here: quiet
    assert capfd.readouterr().err == ""
    flc.sweep_file(path, out=tmp_path / "b.csv", progress=True)
    err = capfd.readouterr().err
    assert "6/6 runs" in err
    seen: list[tuple[int, int]] = []
    flc.sweep_file(path, out=tmp_path / "c.csv", progress=lambda d, n: seen.append((d, n)))
    assert seen and seen[-1] == (6, 6) and [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert (tmp_path / "c.csv").read_text() == (tmp_path / "a.csv").read_text()


def test_progress_bar_draws_done_total_and_label():
    from flc._progress import Bar

    buf = io.StringIO()
    bar = Bar(4, "runs", stream=buf)
    bar(4, None, "envelope-decel")
    bar.close()
    assert "4/4 runs" in buf.getvalue() and "envelope-decel" in buf.getvalue() and buf.getvalue().endswith("\n")


def test_envelope_grid_reports_progress_without_changing_results():
    from flc import envelope

    kw = dict(y="lead_decel", y_values=[4.0, 8.0], controllers=["flc"], speeds_kmh=[30.0, 50.0])
    seen: list[tuple[int, int]] = []
    envelope.PROGRESS_BATCH, old = 3, envelope.PROGRESS_BATCH
    try:
        with_progress = envelope.run_grid(**kw, progress=lambda d, n: seen.append((d, n)))  # type: ignore[arg-type]
    finally:
        envelope.PROGRESS_BATCH = old
    plain = envelope.run_grid(**kw)  # type: ignore[arg-type]
    assert seen == [(3, 4), (4, 4)]
    assert set(plain) == set(with_progress)
    for k in plain:
        assert np.array_equal(plain[k], with_progress[k], equal_nan=plain[k].dtype.kind == "f"), k
