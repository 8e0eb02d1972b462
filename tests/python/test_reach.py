"""Reachability of the paper FLC's closed loop (flc.reach, docs/safety-evidence.md section 4):
soundness against the simulator, hand-checkable cases, refinement, the affine arithmetic."""
import numpy as np
import pytest

import flc
from flc import reach
from flc.reach import AF, Box

MODEL = reach.paper_model()


def test_standing_behind_a_standing_lead_is_certified_with_the_gap_kept():
    # Hand-checkable: both stand, 5 m apart. Eq. (5): dist_s = 5 - D_d(0) - F_shift(0) = 5 - 6 = -1 < 0,
    # so a < 0 and the command clamp(0 + a, 0, 70) = 0: the speed controller holds the brake, nothing
    # moves. The gap stays 5 m (the bound: 5 - bias - contact margin - rounding).
    out = reach.certify(MODEL, [Box(v=(0.0, 0.0), gap=(5.0, 5.0), decel=(6.0, 6.0))], horizon=3.0, max_depth=0)
    assert len(out) == 1 and out[0].certified
    assert out[0].least == pytest.approx(5.0 - reach.CONTACT_MARGIN, abs=1e-3)


def test_a_contact_no_controller_can_avoid_is_never_certified():
    # Hand-checkable: 20 m/s, 1 m behind a lead that stands still (its speed 0). The actuator's dead
    # time alone (0.1 s, nothing brakes before it) covers 2 m > 1 m: contact is certain.
    out = reach.certify(MODEL, [Box(v=(20.0, 20.0), vl=(0.0, 0.0), gap=(1.0, 1.0), decel=(6.0, 6.0))], horizon=2.0, max_depth=2)
    assert not any(o.certified for o in out)
    assert min(o.least for o in out) <= 0


def test_the_point_trajectory_is_the_simulators():
    # One start (a zero-width box, no range error): the reachable set is one trajectory; its least gap
    # is the simulator's within the noise-free LiDAR's f32 error and the model's rounding.
    m = reach.paper_model(bias=0.0, noise=0.0)
    out = reach.certify(m, [Box(v=(25.0, 25.0), gap=(40.0, 40.0), decel=(6.0, 6.0))], horizon=15.0, max_depth=0)
    run = flc.run(reach.start_scenario(25.0, 40.0, 6.0, horizon=15.0))
    assert out[0].certified
    assert out[0].least + reach.CONTACT_MARGIN == pytest.approx(run.metrics["min_gap"], abs=5e-3)


def test_refinement_certifies_a_box_of_positive_width_and_simulated_starts_in_it_agree():
    box = Box(v=(13.8, 13.81), gap=(25.0, 25.1), decel=(5.99, 6.0))
    out = reach.certify(MODEL, [box], horizon=12.0, max_depth=2)
    assert all(o.certified for o in out), [(o.box, o.reason, o.least) for o in out]
    leaves = [{**o.box.to_json(), "least": o.least} for o in out]
    check = reach.crosscheck(leaves, n=3, horizon=12.0)
    # Soundness: no simulated start inside collides, none goes below its box's lower bound, and the
    # detector's range error stays within the model's (else the certificate would not apply).
    assert check["collisions"] == []
    assert check["least_margin"] >= 0, check
    assert check["max_range_error"] <= reach.NOISE, check


def test_arch_initial_set_is_certified_below_the_sampled_robustness():
    cert = reach.arch_certificate(reach.paper_model(rate_hz=10.0))
    assert cert["certified"]
    assert cert["least"] > 0
    from flc import arch_acc

    sampled = next(r for r in arch_acc.evaluate(("flc",)) if r["controller"] == "flc")
    # A lower bound over the whole set is at most the least value on its samples (section 3 runs
    # them with the default LiDAR; the document states this comparison).
    assert cert["least"] <= sampled["min_robustness"]


def test_the_law_chord_contains_eq5_on_its_range():
    rng = np.random.default_rng(3)
    flc_params = MODEL.flc
    for _ in range(200):
        lo = rng.uniform(-11, 11)
        hi = min(11.0, lo + rng.uniform(0, 6))
        x = AF.interval(np.array([lo]), np.array([hi]))
        for shift in (1.0, 1.5):
            a = reach.law(flc_params, x, shift)
            ts = np.linspace(lo, hi, 41)
            vals = reach._law_at(flc_params, ts, shift)
            # The form's value at the point: eps chosen so that x = t (x's only symbol is its radius).
            assert np.all(vals >= a.lo()[0] - 1e-12) and np.all(vals <= a.hi()[0] + 1e-12)


def test_a_refined_branch_keeps_only_its_members():
    # _contract on dgap <= t: members with dgap > t are cut, the others kept.
    rows = reach._start(MODEL, [Box(v=(10.0, 12.0), gap=(20.0, 20.0), decel=(6.0, 6.0))])
    dg = rows.s["v"].scale(-1.0) + 10.0  # dgap = 10 - v in [-2, 0]
    rows.s["dgap"] = dg
    reach._contract(rows, np.array([0]), rows.s["dgap"], -1.5, upper=True)
    v = rows.s["v"]
    assert v.lo()[0] == pytest.approx(11.5, abs=1e-9) and v.hi()[0] == pytest.approx(12.0, abs=1e-9)
