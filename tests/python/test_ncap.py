"""Euro NCAP's own 2026 rating calculator on the ncap-ccr-2026 suite (flc.ncap): every cell of
its Car-to-Car Rear grid predicted from a run, the drawn verification points filled, and a
result changed by hand moving the calculator's points as its rules say."""
import copy

import pytest

import flc

pytest.importorskip("euroncap_rating_2026", reason="the calculator: pip install 'flc[ncap]'")
openpyxl = pytest.importorskip("openpyxl")

from flc import ncap  # noqa: E402

CONTROLLER = "flc-robust"
STANDARD = (100.0, 75.0, 50.0, 25.0, 0.0)  # the standard-range impact locations (125 and -25: extended)


@pytest.fixture(scope="module")
def report():
    (rep,) = flc.run_suite("ncap-ccr-2026", controllers=CONTROLLER)
    return dict(rep)


@pytest.fixture(scope="module")
def baseline(report):
    return ncap.score(report, CONTROLLER)


def _set(report, scenario, vut, il, band, v_kmh):
    """A copy of the report with one of the controller's cells changed by hand."""
    rep = copy.deepcopy(report)
    hit = [r for r in rep["results"] if r["controller"] == CONTROLLER and r["case"] == scenario
           and r["ncap"]["vut_speed_kmh"] == vut and r["ncap"]["impact_location"] == il]
    assert len(hit) == 1
    hit[0]["ncap"].update(band=band, impact_speed_kmh=v_kmh)
    return rep


def test_every_cell_of_the_grid_is_run_and_predicted(report, tmp_path):
    grid = ncap.cells(report, CONTROLLER)
    assert len(grid) == 8 * 7 + 11 * 7 + 11 * 7
    info = ncap.fill_workbook(report, CONTROLLER, tmp_path / "wb.xlsx", seed=3)
    assert info["cells"] == len(grid)
    wb = openpyxl.load_workbook(tmp_path / "wb.xlsx")
    ws = wb[ncap.PRED_SHEET]
    # The calculator's `preprocess` re-encodes each typed prediction as the cell's fill colour
    # (leaving only its "X" marks as text): every cell must carry its run's band as that fill.
    fill = {"green": "009933", "yellow": "FFDD33", "orange": "FF9933", "brown": "964B00", "red": "FF3333"}
    block, locations, checked, wrong = None, [], 0, []
    for row in ws.iter_rows(min_row=1):
        a = row[0].value
        if isinstance(a, str) and "km/h" not in a:
            block, locations = a.strip(), []
        elif block in ncap.SCENARIOS and a is None and isinstance(row[3].value, (int, float)):
            locations = [(c.column, 100.0 * float(c.value)) for c in row[3:10] if c.value is not None]
        elif block in ncap.SCENARIOS and isinstance(a, str):
            vut, target = float(a.replace("km/h", "")), float(str(row[1].value).replace("km/h", ""))
            for col, il in locations:
                got = str(ws.cell(row[0].row, col).fill.fgColor.rgb)[-6:].upper()
                want = fill[grid[(block, vut, target, il)]["band"].lower()]
                checked += 1
                if got != want:
                    wrong.append((block, a, il, got, want))
    assert checked == len(grid) and wrong == [], f"{checked} cells checked; wrong fills: {wrong[:5]}"
    # Each drawn verification point carries the run's relative impact speed.
    assert info["drawn"] and all(d["value"] == grid[(d["scenario"], d["vut_speed_kmh"], d["target_speed_kmh"], d["impact_location"])]
                                 ["impact_speed_kmh"] for d in info["drawn"])
    # A report without a cell is refused, naming it.
    rep = copy.deepcopy(report)
    rep["results"] = [r for r in rep["results"] if not (r["case"] == "CCRb" and r["ncap"]["vut_speed_kmh"] == 130.0
                                                       and r["ncap"]["impact_location"] == -25.0)]
    with pytest.raises(ncap.NcapError, match="CCRb 130/130 km/h at impact location -25 %: not run"):
        ncap.fill_workbook(rep, CONTROLLER, tmp_path / "x.xlsx")


def test_a_cell_changed_by_hand_moves_the_points_as_the_rules_say(report, baseline):
    base = baseline["scenarios"]
    # The maxima: 15 Longitudinal, 40 Car & PTW; flc claims no robustness layer (0 points there).
    assert baseline["longitudinal"][1] == 15 and baseline["car_ptw"][1] == 40
    assert all(base[s]["Robustness"][0] == 0 for s in ncap.SCENARIOS)
    grid = ncap.cells(report, CONTROLLER)
    # CCRs at 10 and 20 km/h must be green in every standard cell or every frontal point is lost.
    gate = all(grid[("CCRs", v, 0.0, il)]["band"] == "green" for v in (10.0, 20.0) for il in STANDARD)
    assert gate == (baseline["longitudinal"][0] > 0)
    if not gate:
        pytest.skip(f"{CONTROLLER} fails the CCRs 10/20 km/h gate: nothing to move")
    # A green standard CCRm cell made red: CCRm's standard points fall by its share, 2.4 / 55.
    green = [k for k, v in grid.items() if k[0] == "CCRm" and k[3] in STANDARD and v["band"] == "green"]
    assert green
    _, vut, _, il = green[0]
    changed = ncap.score(_set(report, "CCRm", vut, il, "red", 35.0), CONTROLLER)
    drop = base["CCRm"]["Standard"][0] - changed["scenarios"]["CCRm"]["Standard"][0]
    assert drop == pytest.approx(2.4 / 55, abs=2e-3)
    assert changed["scenarios"]["CCRs"] == base["CCRs"] and changed["scenarios"]["CCRb"] == base["CCRb"]
    assert changed["longitudinal"][0] == pytest.approx(baseline["longitudinal"][0] - 2.4 / 55, abs=2e-3)
    # The gate: one CCRs 10 km/h standard cell hit at 5 km/h zeroes every frontal point.
    gated = ncap.score(_set(report, "CCRs", 10.0, 50.0, "red", 5.0), CONTROLLER)
    assert gated["longitudinal"][0] == 0 and gated["car_ptw"][0] == 0
    assert all(gated["scenarios"][s]["Total"][0] == 0 for s in ncap.SCENARIOS)


def test_the_points_do_not_depend_on_the_draw(report, baseline):
    # The predictions are the runs themselves, so whichever points the calculator verifies agree.
    other = ncap.score(report, CONTROLLER, seed=11)
    assert other["scenarios"] == baseline["scenarios"] and other["longitudinal"] == baseline["longitudinal"]


def test_bad_input_names_the_problem(report, tmp_path):
    with pytest.raises(ncap.NcapError, match="controller 'nobody': not in the report"):
        ncap.cells(report, "nobody")
    (r157,) = flc.run_suite("r157", controllers="flc")
    with pytest.raises(ncap.NcapError, match="no 2026 Car-to-Car Rear runs"):
        ncap.cells(dict(r157), "flc")
