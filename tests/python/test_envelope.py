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
    assert all(w.stat().st_size > 1000 for w in written)
