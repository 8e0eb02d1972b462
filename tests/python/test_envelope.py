"""Safety-envelope summaries and maps from sweep CSVs (data, not pixels)."""
import numpy as np

from flc import envelope

HEADER = "run_id,controller,speed_kmh,lead_decel,seed,collision,impact_speed,min_gap,min_ttc,max_drac,max_decel,max_jerk,time_hard_braking,gap_error_rms\n"


def _csv(tmp_path):
    rows = []
    rid = 0
    # flc: safe up to 70 at decel 6, collides from 90; pid: collides from 70.
    for c, first_crash in (("flc", 90), ("pid", 70)):
        for v in (30, 50, 70, 90):
            crash = v >= first_crash
            rows.append(f"{rid},{c},{v},6.0,1,{str(crash).lower()},{3.0 if crash else 0.0},{0.0 if crash else 10.0 - v / 10},{1.0},{2.0},{6.5},{12.0},{0.5},{0.2}\n")
            rid += 1
    p = tmp_path / "s.csv"
    # Rows in finishing order, not id order: the loader sorts them.
    p.write_text(HEADER + "".join(reversed(rows)))
    return p


def test_summary_highest_safe_speed(tmp_path):
    rows = envelope.summary(envelope.load_sweep(_csv(tmp_path)))
    by = {r["controller"]: r for r in rows}
    assert by["flc"]["highest_safe_speed_kmh"] == 70
    assert by["pid"]["highest_safe_speed_kmh"] == 50
    assert by["flc"]["collisions"] == 1 and by["pid"]["collisions"] == 2
    assert "| controller |" in envelope.write_table(rows)


def test_highest_safe_stops_at_the_first_collision():
    assert envelope.highest_safe(np.array([50.0, 30.0, 70.0]), np.array([True, False, False])) == 30.0
    assert np.isnan(envelope.highest_safe(np.array([30.0]), np.array([True])))


def test_maps_grid_data(tmp_path):
    p = _csv(tmp_path)
    cols = envelope.load_sweep(p)
    xs, ys, z, col = envelope._grid(cols, cols["controller"] == "pid", "speed_kmh", "lead_decel", "min_gap")
    assert list(xs) == [30, 50, 70, 90] and list(ys) == [6.0]
    assert list(col[0]) == [0, 0, 1, 1]
    assert z[0, 0] == 7.0
    written = envelope.make_maps(p, tmp_path / "maps", "speed_kmh", "lead_decel", "t")
    assert [w.name for w in written] == ["t-min_gap.png", "t-impact_speed.png", "t-highest-speed.png", "t-summary.md"]
    assert all(w.stat().st_size > 1000 for w in written if w.suffix == ".png")
    table = written[-1].read_text().splitlines()
    assert table[0].startswith("| controller | lead_decel | runs | collisions | highest_safe_speed_kmh |")
    assert table[2].startswith("| flc | 6 | 4 | 1 | 70 |") and table[3].startswith("| pid | 6 | 4 | 2 | 50 |")


def test_run_grid_rows_equal_individual_runs():
    import flc

    cols = envelope.run_grid("lead_decel", (4.0, 8.0), controllers=("idm", "flc"), speeds_kmh=(50.0,), preset="paper")
    assert cols["controller"].tolist() == ["idm", "idm", "flc", "flc"]
    assert cols["lead_decel"].tolist() == [4.0, 8.0, 4.0, 8.0]
    from flc import _flc

    for i in range(4):
        sc = flc.Scenario.paper(speed_kmh=50, controller=str(cols["controller"][i]), preset="paper", seed=_flc.sweep_run_seed(1, i))
        d = sc.to_dict()
        d["lead"]["phases"][2]["decel"] = cols["lead_decel"][i]
        m = flc.run(flc.Scenario.from_dict(d)).metrics
        assert cols["collision"][i] == float(m["collision"])
        assert cols["min_gap"][i] == m["min_gap"]
        assert cols["max_decel"][i] == m["max_decel"]
    # A dotted key as the second axis reaches the scenario.
    lat = envelope.run_grid("lidar.latency_frames", (0.0, 6.0), controllers=("flc",), speeds_kmh=(90.0,))
    assert lat["lidar.latency_frames"].tolist() == [0.0, 6.0]
    assert lat["min_gap"][1] != lat["min_gap"][0]
    from flc import _flc as _f

    one = flc.run(flc.Scenario.paper(speed_kmh=90, controller="flc", seed=_f.sweep_run_seed(1, 1), **{"lidar.latency_frames": 6})).metrics
    assert lat["min_gap"][1] == one["min_gap"]


def test_cli_writes_envelope_maps_and_tables(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "maps"
    args = ["figures", "--out", str(out), "--speeds", "30", "--envelope-speeds", "30,150", "--envelope-controllers", "flc,idm"]
    r = subprocess.run([sys.executable, "-m", "flc", *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for stem in ("envelope-decel", "envelope-latency"):
        for suffix in ("-min_gap.png", "-impact_speed.png", "-highest-speed.png"):
            assert (out / f"{stem}{suffix}").read_bytes()[:4] == b"\x89PNG"
        table = (out / f"{stem}-summary.md").read_text()
        lines = table.splitlines()
        # Header, rule, and one row per controller x second-axis value (8 decelerations, 7 latencies).
        assert len(lines) == 2 + 2 * (8 if stem == "envelope-decel" else 7)
        assert lines[2].startswith("| flc |") and lines[-1].startswith("| idm |")
