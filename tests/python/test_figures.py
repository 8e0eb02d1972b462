"""Figures: the data behind them (not pixels) and the command that writes them."""
import math
import subprocess
import sys

import numpy as np

from flc import figures


def test_truncated_cosine_data_equals_eq5():
    d = figures.truncated_cosine_data(41)
    ds = d["dist_s"]
    normal = ds * (1 - np.cos(np.pi * ds / 11))
    np.testing.assert_allclose(d["normal_law"], normal, atol=1e-9)
    np.testing.assert_allclose(d["normal"], np.where(normal < 0, 2 * normal, normal), atol=1e-9)
    over = np.minimum(ds, -3.0)
    braking = over * (1.5 - np.cos(np.pi * over / 11))
    np.testing.assert_allclose(d["braking_law"], braking, atol=1e-9)
    assert np.all(d["braking"] <= 0)


def test_lyapunov_field_signs():
    # Near the origin dV/dt ~ -x1 x2 (Eq. (9)): stable where x1, x2 have the same sign.
    _, _, dv = figures.lyapunov_field(np.array([0.5, 0.5, -0.5, -0.5]), np.array([0.5, -0.5, 0.5, -0.5]))
    assert dv[0] < 0 and dv[3] < 0 and dv[1] > 0 and dv[2] > 0
    # Exact equation at one point by hand: x1 = 1, x2 = 2, S_L = 10, Z = 0.1 / (5/3.6) = 0.072.
    g = 2 * (1 - math.cos(math.pi * 2 / 11))
    dx1, dx2, v = figures.lyapunov_field(np.array(1.0), np.array(2.0), 10.0)
    assert float(dx1) == g
    assert abs(float(dx2) - (-1 - g - 2 * 0.072 * g * 11)) < 1e-12
    assert abs(float(v) - (1 * g + 2 * float(dx2))) < 1e-12


def test_following_runs_match_paper_pattern():
    runs = figures.following_runs((70,), "paper")
    assert runs[(70.0, "flc")].metrics["collision"] is False
    assert runs[(70.0, "pid")].metrics["collision"] is True


def test_cli_writes_three_pngs(tmp_path):
    out = tmp_path / "figs"
    r = subprocess.run([sys.executable, "-m", "flc", "figures", "--out", str(out), "--speeds", "30"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for name in ("following.png", "truncated_cosine.png", "lyapunov.png"):
        p = out / name
        assert p.stat().st_size > 10_000
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = subprocess.run([sys.executable, "-m", "flc", "figures", "--out", str(out), "--speeds", "x"], capture_output=True, text=True)
    assert bad.returncode == 2
