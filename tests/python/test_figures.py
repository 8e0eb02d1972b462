"""Figures: the data behind them (not pixels) and the command that writes them."""
import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from flc import figures  # noqa: E402

B = 11.0  # bound_t


def law(ds, shift):
    return ds * (shift - np.cos(np.pi * ds / B))


def test_truncated_cosine_data_equals_eq5():
    d = figures.truncated_cosine_data(41)
    ds = d["dist_s"]
    assert ds[0] == -B and ds[-1] == B
    normal = law(ds, 1.0)
    np.testing.assert_allclose(d["normal_law"], normal, rtol=0, atol=1e-12)
    np.testing.assert_allclose(d["normal"], np.where(normal < 0, 2 * normal, normal), rtol=0, atol=1e-12)
    np.testing.assert_allclose(d["braking_no_override"], law(ds, 1.5), rtol=0, atol=1e-12)
    braking = law(np.minimum(ds, -3.0), 1.5)
    np.testing.assert_allclose(d["braking_law"], braking, rtol=0, atol=1e-12)
    np.testing.assert_allclose(d["braking"], 2 * braking, rtol=0, atol=1e-12)
    # Override point: a(-3) = -3 (1.5 - cos(3 pi / 11)) ~ -2.54, flat for dist_s >= -3.
    assert d["braking_law"][-1] == pytest.approx(-3 * (1.5 - math.cos(3 * math.pi / 11)), abs=1e-12)
    assert d["braking_law"][-1] == pytest.approx(-2.535, abs=1e-3)


def test_truncated_cosine_plotted_lines_equal_closed_form():
    fig = figures.fig_truncated_cosine()
    lines = {ln.get_gid(): ln for ln in fig.axes[0].lines if ln.get_gid()}
    assert set(lines) == {"normal_law", "normal", "braking_law", "braking", "braking_no_override"}
    x = np.asarray(lines["normal_law"].get_xdata())
    np.testing.assert_allclose(lines["normal_law"].get_ydata(), law(x, 1.0), atol=1e-12)
    np.testing.assert_allclose(lines["braking_no_override"].get_ydata(), law(x, 1.5), atol=1e-12)
    np.testing.assert_allclose(lines["braking_law"].get_ydata(), law(np.minimum(x, -3.0), 1.5), atol=1e-12)


def test_lyapunov_near_origin_sign_is_minus_x1_x2():
    # Eq. (9): dV/dt ~ -x1 x2 + O(x^3). On the figure's own grid, within |x1| in [0.2, 1] and
    # 0 < |x2| <= 1, the sign of dV/dt equals the sign of -x1 x2 at every point.
    g = figures.lyapunov_data()
    x1, x2, dv = g["x1"], g["x2"], g["dv"]
    near = (np.abs(x1) >= 0.2) & (np.abs(x1) <= 1.0) & (np.abs(x2) > 1e-9) & (np.abs(x2) <= 1.0)
    assert near.sum() > 100
    assert np.array_equal(np.sign(dv[near]), np.sign(-x1 * x2)[near])
    # The quadrants: stable (dV/dt < 0) where x1, x2 share a sign, unstable otherwise.
    _, _, v = figures.lyapunov_field(np.array([0.5, -0.5, 0.5, -0.5]), np.array([0.5, -0.5, -0.5, 0.5]))
    assert v[0] < 0 and v[1] < 0
    assert v[2] > 0 and v[3] > 0
    # Far from the origin the O(x^3) terms win: dV/dt < 0 even at x1 < 0, x2 > 0.
    assert float(figures.lyapunov_field(np.array(-1.0), np.array(5.0))[2]) < 0


def test_lyapunov_field_by_hand():
    # x1 = 1, x2 = 2, S_L = 10, Z = 0.1 / (5/3.6) = 0.072, T_G = 1.
    g = 2 * (1 - math.cos(math.pi * 2 / 11))
    dx1, dx2, v = figures.lyapunov_field(np.array(1.0), np.array(2.0), 10.0)
    assert float(dx1) == pytest.approx(g, abs=1e-15)
    assert float(dx2) == pytest.approx(-1 - g - 2 * 0.072 * g * 11, abs=1e-12)
    assert float(v) == pytest.approx(1 * g + 2 * float(dx2), abs=1e-12)


def test_lyapunov_trajectory_approaches_origin():
    tr = figures.lyapunov_trajectory((4.0, -8.0))
    assert np.hypot(*tr[-1]) < 0.5 * np.hypot(4.0, -8.0)


def test_robust_lyapunov_derivative_on_the_unclamped_band():
    # docs/robust-flc.md, "Stability": V = x1^2/2 + k x2^2/(2h) gives dV/dt = -(k^2/h) x2^2 where
    # the law is not clamped (-h b_max / k_b < x2 < h a_max / k_a, i.e. -3.75 < x2 < 3).
    g = figures.robust_lyapunov_data()
    x2, dv = g["x2"], g["dv"]
    k = np.where(x2 >= 0, 1.0, 4.0)
    band = (x2 > -3.75) & (x2 < 3.0)
    assert band.sum() > 1000
    np.testing.assert_allclose(dv[band], -(k[band] ** 2 / 1.5) * x2[band] ** 2, rtol=1e-12, atol=1e-12)
    assert np.all(dv[band] <= 0.0)
    # Clamped: dV/dt > 0 exists only where the follower is far behind and much slower (a = a_max).
    pos = dv > 1e-9
    assert pos.any() and np.all(x2[pos] > 3.0) and np.all(g["x1"][pos] < 0.0)


def test_robust_lyapunov_field_by_hand():
    # x1 = 1, x2 = -2: a = 4 * -2 / 1.5 = -5.333; x2' = -1 + 1.5 * 5.333 = 7; V = 0.5 + 4 * 4 / 3.
    dx1, dx2, v, dv = figures.robust_lyapunov_field(np.array(1.0), np.array(-2.0))
    assert float(dx1) == pytest.approx(-16 / 3, abs=1e-12)
    assert float(dx2) == pytest.approx(7.0, abs=1e-12)
    assert float(v) == pytest.approx(0.5 + 16 / 3, abs=1e-12)
    assert float(dv) == pytest.approx(-(16 / 1.5) * 4, abs=1e-12)
    # Clamped at a_max = 2 for x2 = 6 (k_a x2 / h = 4): x1' = 2, x2' = -x1 - 3.
    dx1, dx2, _, _ = figures.robust_lyapunov_field(np.array(-1.0), np.array(6.0))
    assert float(dx1) == pytest.approx(2.0) and float(dx2) == pytest.approx(-2.0)


def test_robust_lyapunov_trajectories_reach_the_equilibrium():
    for start in [(-8.0, 10.0), (8.0, -10.0), (9.0, 0.0)]:
        tr = figures.robust_lyapunov_trajectory(start)
        assert np.hypot(*tr[-1]) < 0.05


def test_following_runs_match_paper_pattern():
    runs = figures.following_runs((70,), "paper")
    assert runs[(70.0, "flc")].metrics["collision"] is False
    assert runs[(70.0, "pid")].metrics["collision"] is True
    assert figures.outcome(runs[(70.0, "pid")]).startswith("collision at")


@pytest.mark.parametrize("save", [True, False])
def test_missing_matplotlib_message(monkeypatch, tmp_path, save):
    for mod in ("matplotlib", "matplotlib.pyplot", "matplotlib.figure", "matplotlib.backends.backend_agg"):
        monkeypatch.setitem(sys.modules, mod, None)
    with pytest.raises(ImportError, match=r"pip install 'flc\[plot\]'"):
        figures.fig_truncated_cosine(tmp_path / "t.png" if save else None)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flc", *args], capture_output=True, text=True)


def test_cli_writes_all_pngs(tmp_path):
    out = tmp_path / "figs"
    r = _cli("figures", "--out", str(out), "--speeds", "30", "--no-envelope", "--platoon-frequencies", "0.2")
    assert r.returncode == 0, r.stderr
    names = (
        "following.png",
        "truncated_cosine.png",
        "lyapunov.png",
        "platoon_space_time.png",
        "platoon_gap_errors.png",
        "platoon_gamma.png",
        "paper_reproduction.png",
        "paper_reproduction_clearances.png",
    )
    assert r.stdout.split() == [str(out / n) for n in names]
    for name in names:
        data = (out / name).read_bytes()
        assert len(data) > 10_000
        assert data[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args",
    [
        ("figures", "--out", "x", "--speeds", "x"),
        ("figures", "--out", "x", "--speeds", ""),
        ("figures", "--out", "x", "--speeds", "-30"),
        ("figures", "--out", "x", "--preset", "carla"),
        ("figures", "--out", "x", "--envelope-controllers", "flc,lqr"),
        ("figures", "--out", "x", "--envelope-speeds", "0"),
        ("figures", "--out", "x", "--threads", "0"),
        ("figures", "--out", "x", "--platoon-frequencies", "9"),
        ("figures", "--out", "x", "--platoon-frequencies", "a"),
        ("figures",),
        ("plots", "--out", "x"),
        (),
    ],
)
def test_cli_bad_args_exit_2(args, tmp_path):
    r = subprocess.run([sys.executable, "-m", "flc", *args], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "usage:" in r.stderr
    assert not (tmp_path / "x").exists()


def test_the_reproduction_figures_come_from_the_package_data_or_fail(tmp_path, monkeypatch):
    """Issue 48: ``figures`` draws the paper reproduction map from the data that ships with the
    package, from any working directory; without the data it raises instead of leaving the
    figures out."""
    from pathlib import Path

    import flc
    from flc import reproduction as rp

    assert rp.DATA_DIR == Path(flc.__file__).resolve().parent / "data" / "reproduction"
    assert (rp.DATA_DIR / "paper-reproduction-map.csv").is_file() and rp.SPEC_PATH.is_file()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(rp, "DATA_DIR", tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match="paper-reproduction-map.csv"):
        figures.make_all(tmp_path / "figs", speeds_kmh=[30.0])
    assert not (tmp_path / "figs" / "following.png").exists()  # refused before drawing anything
